//! One calibration flight cut into runs, and the rows a fit solves: band-passed design rows,
//! interleaved level rows, and the Gauss-Newton rows of the exact magnitude.

use super::choice::Chosen;
use super::diagnostics::{run_score_covariance, RunningStd};
use super::error::FitError;
pub(super) use super::factor::FoldFactor;
use super::level_rows::LevelRows;
use super::level_setup::{LevelReference, LevelSetup};
use super::levels::{InPass, LowFrequency};
use super::qr::{stacked_factor, triangular_factor};
use super::samples::Samples;
use super::settings::{FitSettings, Lambda, Target};
pub(super) use super::spare::Spare;
use super::window_size::{window_len, windows_dealt};
use crate::model::design::{Design, Term};
use crate::model::terms::Column;
use crate::model::vector::Fluxgates;
use crate::signal::filter::{filtfilt_many_unless_constant, magnav_bandpass, Butterworth};
use nalgebra::DMatrix;
use std::ops::Range;

/// Writes the rows `rows` (counted from the run's start) of a run's unfiltered columns and,
/// after them, of its target into the slices given (one per column, `rows.len()` values
/// each), every value of them: they hold whatever a [`Spare`] buffer last held. A row's values
/// are those of the whole run's (its changes taken over the run), however the rows are cut.
pub(super) type FillRun<'m> = dyn Fn(Range<usize>, Range<usize>, &mut [&mut [f64]]) + Sync + 'm;

/// One calibration flight, cut into runs, and how to fit it.
pub(super) struct Problem<'p, 'a> {
    pub(super) scalar: &'p [f64],
    pub(super) flux: &'p Fluxgates<'a>,
    /// The samples it uses and their runs.
    pub(super) samples: &'p Samples,
    pub(super) filter: Option<Butterworth>,
    pub(super) above: Option<AboveBand>,
    pub(super) settings: &'p FitSettings,
    /// Where the fit's large buffers come from and go back to.
    pub(super) spare: &'p Spare,
    /// Sample rate (Hz).
    pub(super) fs_hz: f64,
    /// Samples per window of a long run ([`super::window_size::window_samples`]).
    pub(super) window_samples: usize,
    /// Whether the calibration maneuvered too little for the folds to separate the terms
    /// ([`super::prior::PriorWeights::parsimonious`]); known once the band rows are.
    pub(super) parsimonious: std::sync::atomic::AtomicBool,
}

/// Rows above the fitting band for extra channels. A current may switch or flash faster than
/// the band's upper edge (a strobe at 1–2 Hz lies wholly above 0.9 Hz), so the band alone
/// hardly sees it. Above the band the target and the columns are high-passed and every column
/// but the extra channels' is zeroed: the Tolles-Lawson columns are left out there because
/// their eddy terms differentiate the fluxgate's noise, which the upper edge exists to keep
/// out, and the aircraft's own field has little power that high. What the zeroed columns
/// would explain is then noise to these rows, uncorrelated with a current.
pub(crate) struct AboveBand {
    /// High-pass at the band's upper edge.
    pub(crate) filter: Butterworth,
    /// Which columns of the rows are extra channels.
    pub(crate) extra: Vec<bool>,
}

impl AboveBand {
    /// With extra channels and a band whose upper edge is on (in `settings`): rows above the
    /// band that only the extra channels' columns explain, for the columns `union`.
    pub(super) fn of(
        settings: &FitSettings,
        fs_hz: f64,
        union: &[Term],
    ) -> Result<Option<AboveBand>, FitError> {
        if settings.design.extras.is_empty() || settings.target != Target::Band {
            return Ok(None);
        }
        let high_pass = magnav_bandpass(settings.band.pass2_hz, 0.0, settings.order, fs_hz)?;
        Ok(high_pass.map(|filter| AboveBand {
            filter,
            extra: union
                .iter()
                .map(|t| matches!(t.column, Column::Extra { .. }))
                .collect(),
        }))
    }

    /// The same rows for a design of the columns `terms`: only its extra channels' columns
    /// kept (a design without them has its rows zeroed, so they stay part of the score, as they
    /// were for the linear fit it is compared with, but explain nothing).
    pub(super) fn for_terms(&self, terms: &[Term]) -> AboveBand {
        AboveBand {
            filter: self.filter.clone(),
            extra: terms
                .iter()
                .map(|t| matches!(t.column, crate::model::terms::Column::Extra { .. }))
                .collect(),
        }
    }

    /// A run's rows above the band from its unfiltered columns and target (`data`, as
    /// [`FillRun`] writes them), trimmed; the target is the last column.
    pub(super) fn rows(
        &self,
        data: &[f64],
        n: usize,
        trim: usize,
    ) -> Result<DMatrix<f64>, FitError> {
        let width = data.len() / n;
        let mut a = DMatrix::from_column_slice(n, width, data);
        for (c, keep) in self.extra.iter().enumerate() {
            if !keep {
                a.column_mut(c).fill(0.0);
            }
        }
        let mut signals: Vec<&mut [f64]> = a.as_mut_slice().chunks_mut(n).collect();
        filtfilt_many_unless_constant(&self.filter, &mut signals)?;
        Ok(a.rows(trim, n - 2 * trim).into_owned())
    }
}

/// The filtered rows of one run.
pub(super) struct RunRows {
    /// The columns and the target, column-major, `len` samples each, filtered but not trimmed,
    /// at the start of a buffer that may be longer; empty for a run done in windows.
    pub(super) data: Vec<f64>,
    pub(super) len: usize,
    /// Rows above the band (trimmed), the target last; with extra channels only.
    pub(super) above: Option<DMatrix<f64>>,
    /// For a run done in windows, its band rows already factored.
    pub(super) factored: Option<Factored>,
}

/// Consecutive ranges of a run's band rows and their factors.
pub(super) type Pieces = Vec<(Range<usize>, DMatrix<f64>)>;

/// The band rows of a run done window by window, factored as they were filtered.
pub(super) struct Factored {
    /// Consecutive ranges of band rows, cut where windows and the folds of the plans given
    /// to [`Problem::prepare`] start, and their factors.
    pub(super) pieces: Pieces,
    /// The scatter of its filtered target over its band rows.
    pub(super) target: RunningStd,
}

/// A used run's rows as the folds count them.
struct RowCounts<'l> {
    band: usize,
    level_at: &'l [usize],
    above: usize,
}

/// Rows of every run ready for the folds: band rows (the filtered runs, read from `trim` on),
/// level rows and rows above the band.
pub(super) struct Prepared {
    /// Columns, the target and the signals after it included.
    pub(super) width: usize,
    /// Signals after the target (see [`Problem::prepare`]).
    pub(super) extra: usize,
    pub(super) trim: usize,
    pub(super) runs: Vec<RunRows>,
    /// Per run, the centred, unweighted level rows; empty without levels.
    pub(super) levels: Vec<LevelRows>,
    pub(super) short: usize,
}

/// Which rows of a run a fold holds: contiguous ranges of its band, level and above-band rows.
#[derive(Debug, Clone, PartialEq)]
pub(super) struct Piece {
    run: usize,
    band: Range<usize>,
    level: Range<usize>,
    above: Range<usize>,
}

/// Per fold, the pieces of runs it holds.
pub(super) type Plan = Vec<Vec<Piece>>;

/// The factors of the band rows of each run, cut where any fold of any plan starts.
pub(super) struct BandFactors {
    /// Per run, consecutive ranges of band rows and their factors.
    runs: Vec<Pieces>,
}

/// [`Prepared::plan`] of runs with the rows `runs`.
fn plan_of(runs: &[RowCounts], trim: usize, count: usize) -> Plan {
    let kinds: Vec<Vec<Stretch>> = runs
        .iter()
        .map(|r| merged_kinds(r.band, trim, r.level_at, r.above))
        .collect();
    let length = |kinds: &[Stretch]| kinds.iter().map(|s| s.rows).sum::<usize>();
    let total: usize = kinds.iter().map(|k| length(k)).sum();
    let mut plan: Plan = vec![Vec::new(); count];
    let mut r = 0;
    for (run, kind) in kinds.iter().enumerate() {
        let n = length(kind);
        let mut rows = Counter::new(kind);
        let mut start = 0;
        while start < n {
            let fold = (r + start) * count / total;
            let fold_end = ((fold + 1) * total).div_ceil(count);
            let end = (fold_end - r).min(n);
            let before = rows.counts;
            rows.take(end - start, |_, _| {});
            let after = rows.counts;
            plan[fold].push(Piece {
                run,
                band: before[0]..after[0],
                level: before[1]..after[1],
                above: before[2]..after[2],
            });
            start = end;
        }
        r += n;
    }
    plan
}

/// Consecutive rows of one kind ([`BAND`], [`LEVEL`] or [`ABOVE`]).
#[derive(Debug, Clone, Copy, PartialEq)]
struct Stretch {
    kind: u8,
    rows: usize,
}

/// Rows of each kind taken so far from stretches, in order.
struct Counter<'k> {
    kinds: &'k [Stretch],
    /// The stretch taken from next, and its rows already taken.
    next: usize,
    used: usize,
    counts: [usize; 3],
}

impl<'k> Counter<'k> {
    fn new(kinds: &'k [Stretch]) -> Self {
        Self {
            kinds,
            next: 0,
            used: 0,
            counts: [0; 3],
        }
    }

    /// Takes the next `rows` rows, handing each part of a stretch taken to `each(kind, rows)`.
    fn take(&mut self, mut rows: usize, mut each: impl FnMut(u8, usize)) {
        while rows > 0 {
            let stretch = self.kinds[self.next];
            let taken = (stretch.rows - self.used).min(rows);
            each(stretch.kind, taken);
            self.counts[stretch.kind as usize] += taken;
            self.used += taken;
            rows -= taken;
            if self.used == stretch.rows {
                self.next += 1;
                self.used = 0;
            }
        }
    }
}

/// Appends `rows` rows of `kind`, joining the last stretch if it is of that kind.
fn extend(stretches: &mut Vec<Stretch>, kind: u8, rows: usize) {
    match stretches.last_mut() {
        _ if rows == 0 => {}
        Some(last) if last.kind == kind => last.rows += rows,
        _ => stretches.push(Stretch { kind, rows }),
    }
}

/// Where the plans cut the band rows `0..band` of run `run`, its ends included, in order.
pub(super) fn cuts_of(plans: &[&Plan], run: usize, band: usize) -> Vec<usize> {
    let mut cuts = vec![0, band];
    for piece in plans.iter().flat_map(|p| p.iter().flatten()) {
        if piece.run == run {
            cuts.extend([piece.band.start, piece.band.end]);
        }
    }
    cuts.sort_unstable();
    cuts.dedup();
    cuts
}

/// Kinds of rows, in the order the folds take them.
const BAND: u8 = 0;
const LEVEL: u8 = 1;
const ABOVE: u8 = 2;

/// A run's rows in time order, as stretches of one kind: `band` band rows (sample `trim + r`
/// for row r) interleaved with the level rows at samples `level_at` (ascending; a band row
/// first at the same sample), then merged with `above` rows above the band by their relative
/// position in the run (the others first at the same position).
///
/// Stretches rather than a kind per row: at 10⁷ samples, a byte per row took 35 ms that no
/// other core shared, three times per fit.
fn merged_kinds(band: usize, trim: usize, level_at: &[usize], above: usize) -> Vec<Stretch> {
    let mut first = Vec::with_capacity(2 * level_at.len() + 1);
    let mut b = 0;
    for &at in level_at {
        // Band rows at samples up to `at` come first.
        let upto = (at + 1).saturating_sub(trim).clamp(b, band);
        extend(&mut first, BAND, upto - b);
        b = upto;
        extend(&mut first, LEVEL, 1);
    }
    extend(&mut first, BAND, band - b);
    if above == 0 {
        return first;
    }
    let position = |k: usize, n: usize| (2 * k + 1) as f64 / (2 * n) as f64;
    let n1 = band + level_at.len();
    let mut out = Vec::with_capacity(first.len() + 2 * above);
    let mut rows = Counter::new(&first);
    let mut taken = 0;
    for a in 0..above {
        // The rows at positions up to the above row's come first (positions rise with k).
        let (mut lo, mut hi) = (taken, n1);
        while lo < hi {
            let mid = lo + (hi - lo) / 2;
            match position(mid, n1) <= position(a, above) {
                true => lo = mid + 1,
                false => hi = mid,
            }
        }
        rows.take(lo - taken, |kind, n| extend(&mut out, kind, n));
        taken = lo;
        extend(&mut out, ABOVE, 1);
    }
    rows.take(n1 - taken, |kind, n| extend(&mut out, kind, n));
    out
}

impl Prepared {
    /// The buffers of the runs, for another preparation to reuse.
    pub(super) fn into_buffers(self) -> Vec<Vec<f64>> {
        // A run done in windows holds none (an empty one is not kept).
        self.runs.into_iter().map(|r| r.data).collect()
    }

    /// Band rows of run `run`.
    fn band_rows(&self, run: usize) -> usize {
        self.runs[run].len - 2 * self.trim
    }

    /// Column `c` of run `run`'s band rows `rows`.
    fn band_column(&self, run: usize, c: usize, rows: &Range<usize>) -> &[f64] {
        let r = &self.runs[run];
        let start = c * r.len + self.trim;
        &r.data[start + rows.start..start + rows.end]
    }

    /// The rows above the band (one per sample used, with extra channels; else none).
    pub(super) fn above_rows(&self) -> usize {
        self.runs
            .iter()
            .filter_map(|r| r.above.as_ref())
            .map(|a| a.nrows())
            .sum()
    }

    /// The residual sum of squares (nT²) and count of the rows above the band, for the
    /// coefficients `beta` of the stored columns.
    pub(super) fn above_residual(&self, beta: &[f64]) -> (f64, usize) {
        let target = self.width - 1 - self.extra;
        let mut sum = 0.0;
        let mut count = 0;
        for above in self.runs.iter().filter_map(|r| r.above.as_ref()) {
            let fitted = above.columns(0, target) * nalgebra::DVector::from_column_slice(beta);
            sum += (above.column(target) - fitted).norm_squared();
            count += above.nrows();
        }
        (sum, count)
    }

    /// The long-run covariance of the band rows' scores `xₜ·rₜ` (stored columns; `rₜ` the
    /// residual of `beta`, nT), summed over the rows: the middle of the sandwich
    /// `G⁻¹·S·G⁻¹` that gives the coefficients' covariance when the residual is not white.
    ///
    /// A band-passed residual is correlated over about a period of the band's low edge and
    /// its spectrum is rarely flat (the fluxgate's noise rises with frequency through the eddy
    /// columns, geology falls), so `σ²·(AᵀA)⁻¹` misjudges it by the overlap of the residual's
    /// and the columns' spectra. Overlapping batch means of `block` rows measure that overlap.
    /// `None` when a run was done in windows (its rows are no longer held).
    pub(super) fn score_covariance(&self, beta: &[f64], block: usize) -> Option<DMatrix<f64>> {
        let p = self.width - 1 - self.extra;
        let mut total = DMatrix::zeros(p, p);
        for run in 0..self.runs.len() {
            if self.runs[run].factored.is_some() {
                return None;
            }
            let n = self.band_rows(run);
            if n == 0 {
                continue;
            }
            let all = 0..n;
            let mut residual = self.band_column(run, p, &all).to_vec();
            for (c, b) in beta.iter().enumerate() {
                let x = self.band_column(run, c, &all);
                residual.iter_mut().zip(x).for_each(|(r, x)| *r -= b * x);
            }
            let scores: Vec<&[f64]> = (0..p).map(|c| self.band_column(run, c, &all)).collect();
            total += run_score_covariance(&scores, &residual, block.clamp(1, n));
        }
        Some(total)
    }

    /// Band rows of every run.
    pub(super) fn band_row_count(&self) -> usize {
        (0..self.runs.len()).map(|run| self.band_rows(run)).sum()
    }

    /// Runs that gave rows.
    pub(super) fn runs_used(&self) -> usize {
        self.runs.len()
    }

    /// Standard deviation of the filtered targets of the band rows and the rows above it (nT).
    pub(super) fn band_std(&self) -> f64 {
        let mut before = RunningStd::default();
        let target = self.width - 1 - self.extra;
        for run in 0..self.runs.len() {
            if let Some(factored) = &self.runs[run].factored {
                before.merge(factored.target);
                continue;
            }
            let all = 0..self.band_rows(run);
            before.push_all(self.band_column(run, target, &all));
            if let Some(above) = &self.runs[run].above {
                before.push_all(above.column(target).as_slice());
            }
        }
        before.std()
    }

    /// Cuts the rows, in time order over all runs, into `count` contiguous folds: row r of
    /// `total` goes to fold ⌊r·count/total⌋. Level rows count only `with_levels`.
    pub(super) fn plan(&self, with_levels: bool, count: usize) -> Plan {
        let runs: Vec<RowCounts> = (0..self.runs.len())
            .map(|run| RowCounts {
                band: self.band_rows(run),
                level_at: match self.levels.get(run) {
                    Some(l) if with_levels => l.at.as_slice(),
                    _ => &[],
                },
                above: self.runs[run].above.as_ref().map_or(0, |a| a.nrows()),
            })
            .collect();
        plan_of(&runs, self.trim, count)
    }

    /// Factors the band rows of every run, cut where a fold of any of `plans` starts.
    ///
    /// A run done in windows was factored as it was filtered, cut where the plans given to
    /// [`Problem::prepare`] cut it; `plans` must cut it nowhere else.
    pub(super) fn band_factors(&self, plans: &[&Plan]) -> BandFactors {
        let runs = (0..self.runs.len())
            .map(|run| {
                let cuts = cuts_of(plans, run, self.band_rows(run));
                cuts.windows(2)
                    .map(|w| {
                        let rows = w[0]..w[1];
                        let factor = match &self.runs[run].factored {
                            Some(factored) => factored.within(&rows),
                            None => {
                                let columns: Vec<&[f64]> = (0..self.width)
                                    .map(|c| self.band_column(run, c, &rows))
                                    .collect();
                                triangular_factor(&columns)
                            }
                        };
                        (rows, factor)
                    })
                    .collect()
            })
            .collect();
        BandFactors { runs }
    }

    /// Each fold's factor for the plan `plan` (made with level rows when `weight > 0`), its band
    /// rows taken from `band`, its level rows weighted by `weight`.
    pub(super) fn fold_factors(
        &self,
        plan: &Plan,
        weight: f64,
        band: &BandFactors,
    ) -> Vec<FoldFactor> {
        // The folds' level rows are factored one fold on each core (200 k level rows at 10⁷
        // samples: 40 ms on one core, between passes that keep both busy).
        let level_rows: usize = self.levels.iter().map(|l| l.y.len()).sum();
        crate::parallel::map_items(plan, level_rows, |pieces| {
            let mut blocks = Vec::new();
            let mut level_blocks = Vec::new();
            let (mut rows, mut level_rows) = (0, 0);
            for piece in pieces {
                for (range, factor) in &band.runs[piece.run] {
                    if range.start >= piece.band.start && range.end <= piece.band.end {
                        blocks.push(factor.clone());
                    }
                }
                rows += piece.band.len() + piece.level.len() + piece.above.len();
                if !piece.level.is_empty() {
                    let level = &self.levels[piece.run];
                    // Level rows have the columns and the target; the signals after it
                    // have none (0).
                    let target = self.width - 1 - self.extra;
                    let weighted: Vec<Vec<f64>> = (0..self.width)
                        .map(|c| {
                            let values = match c.cmp(&target) {
                                std::cmp::Ordering::Less => {
                                    let n = level.a.nrows();
                                    &level.a.as_slice()[c * n..][piece.level.clone()]
                                }
                                std::cmp::Ordering::Equal => &level.y[piece.level.clone()],
                                std::cmp::Ordering::Greater => {
                                    return vec![weight * 0.0; piece.level.len()]
                                }
                            };
                            values.iter().map(|v| weight * v).collect()
                        })
                        .collect();
                    let columns: Vec<&[f64]> = weighted.iter().map(Vec::as_slice).collect();
                    level_blocks.push(triangular_factor(&columns));
                    level_rows += piece.level.len();
                }
                if let Some(above) = &self.runs[piece.run].above {
                    if !piece.above.is_empty() {
                        let rows = above.nrows();
                        let columns: Vec<&[f64]> = above
                            .as_slice()
                            .chunks_exact(rows)
                            .map(|c| &c[piece.above.clone()])
                            .collect();
                        blocks.push(triangular_factor(&columns));
                    }
                }
            }
            let empty = || DMatrix::zeros(0, self.width);
            let level_r = if level_blocks.is_empty() {
                empty()
            } else {
                stacked_factor(&level_blocks)
            };
            blocks.push(level_r.clone());
            FoldFactor {
                r: stacked_factor(&blocks),
                rows,
                level_r,
                level_rows,
            }
        })
    }
}

impl Factored {
    /// The factor of the band rows `rows`, which start and end where pieces do.
    fn within(&self, rows: &Range<usize>) -> DMatrix<f64> {
        let (mut inside, mut covered) = (Vec::new(), 0);
        for (r, factor) in &self.pieces {
            if r.start >= rows.start && r.end <= rows.end {
                inside.push(factor.clone());
                covered += r.len();
            }
        }
        assert_eq!(
            covered,
            rows.len(),
            "a run done in windows is cut where it was planned"
        );
        match inside.len() {
            1 => inside.into_iter().next().expect("one piece"),
            _ => stacked_factor(&inside),
        }
    }
}

/// The number of folds `lambda` asks for: one for a fixed λ.
pub(super) fn fold_count(lambda: Lambda) -> usize {
    match lambda {
        Lambda::Fixed(_) => 1,
        Lambda::CrossValidated { folds } => folds,
    }
}

impl Problem<'_, '_> {
    /// The settings' prior weights for the columns `terms`, parsimonious when the calibration
    /// maneuvered too little ([`Problem::parsimonious`]).
    pub(super) fn prior_weights(&self, terms: &[Term]) -> Option<super::prior::PriorWeights> {
        let parsimonious = self.parsimonious.load(std::sync::atomic::Ordering::Relaxed);
        (self.settings.prior_weights(terms, self.fs_hz))
            .map(|p| super::prior::PriorWeights { parsimonious, ..p })
    }

    /// Filters a run's `signals` (its columns, then its target, then `extra` signals after it)
    /// in place and, with `levels`, gives its level rows of the columns and the target,
    /// low-passed from the unfiltered signals: with a band-pass, the two filters share the
    /// cores as one job.
    pub(super) fn filter_run(
        &self,
        run: Range<usize>,
        signals: &mut [&mut [f64]],
        extra: usize,
        levels: Option<&LevelSetup>,
    ) -> Result<Option<LevelRows>, FitError> {
        let Some(setup) = levels else {
            self.filter_alone(signals)?;
            return Ok(None);
        };
        // The magnitude is filtered in place below: its values are copied first.
        let magnitude;
        let reference = match LevelReference::of(setup, run.clone()) {
            LevelReference::Values(values) => values,
            LevelReference::Magnitude => {
                magnitude = signals[signals.len() - 1].to_vec();
                &magnitude
            }
        };
        let (signals, after) = signals.split_at_mut(signals.len() - extra);
        let mut target = self.spare.take(run.len());
        let target_part = &mut target[..run.len()];
        let rows = match &self.filter {
            Some(band) => setup
                .low
                .rows_against_then_band(signals, reference, target_part, band),
            None => {
                let (columns, y) = signals.split_at(signals.len() - 1);
                let columns: Vec<&[f64]> = columns.iter().map(|c| &**c).collect();
                let rows = setup
                    .low
                    .rows_against(&columns, y[0], Some(reference), target_part);
                self.unfiltered(signals);
                rows
            }
        };
        self.spare.give([target]);
        self.filter_alone(after)?;
        Ok(Some(rows?))
    }

    /// The band-pass of `signals` in place, or without one what [`Problem::unfiltered`] does.
    fn filter_alone(&self, signals: &mut [&mut [f64]]) -> Result<(), FitError> {
        if signals.is_empty() {
            return Ok(());
        }
        match &self.filter {
            Some(band) => filtfilt_many_unless_constant(band, signals)?,
            None => self.unfiltered(signals),
        }
        Ok(())
    }

    /// Without a filter, a reference target's run loses its mean (its intercept).
    fn unfiltered(&self, signals: &mut [&mut [f64]]) {
        if self.settings.target == Target::Interference {
            signals.iter_mut().for_each(|s| remove_mean(s));
        }
    }

    /// Samples trimmed at each end of a run, and the fewest a run needs to give rows.
    pub(super) fn trim_and_needed(&self, above_band: Option<&AboveBand>) -> (usize, usize) {
        let trim = if self.filter.is_some() {
            self.settings.trim
        } else {
            0
        };
        let needed = self
            .filter
            .iter()
            .chain(above_band.map(|a| &a.filter))
            .map(|f| f.padlen() + 1)
            .max()
            .unwrap_or(0)
            .max(2 * trim + 1);
        (trim, needed)
    }

    /// The plans [`Prepared::plan`] will give, for each of `with_levels`, for the rows
    /// [`Problem::prepare`] will make with `levels` and `above_band`: known before, so that long
    /// runs can be factored as they are filtered, cut where the folds start.
    pub(super) fn plans_ahead(
        &self,
        levels: Option<&LevelSetup>,
        above_band: Option<&AboveBand>,
        with_levels: &[bool],
        count: usize,
    ) -> Vec<Plan> {
        let (trim, needed) = self.trim_and_needed(above_band);
        let used: Vec<usize> = self
            .samples
            .runs
            .iter()
            .map(|r| r.len())
            .filter(|&n| n >= needed)
            .collect();
        let kept: Vec<Vec<usize>> = used
            .iter()
            .map(|&n| levels.and_then(|l| l.low.kept(n)).unwrap_or_default())
            .collect();
        with_levels
            .iter()
            .map(|&with| {
                let runs: Vec<RowCounts> = used
                    .iter()
                    .zip(&kept)
                    .map(|(&n, at)| RowCounts {
                        band: n - 2 * trim,
                        level_at: if with { at } else { &[] },
                        above: if above_band.is_some() {
                            n - 2 * trim
                        } else {
                            0
                        },
                    })
                    .collect();
                plan_of(&runs, trim, count)
            })
            .collect()
    }

    /// The folds of the fluxgate's calibration from the linear rows ([`InPass`]),
    /// cross-validated as its own fit would be, when they are not those of `band_plan`.
    pub(super) fn calibration_plan(
        &self,
        levels: Option<&LevelSetup>,
        above_band: Option<&AboveBand>,
        band_plan: &Plan,
    ) -> Option<Plan> {
        let count = fold_count(Lambda::auto());
        let plan = self.plans_ahead(levels, above_band, &[false], count);
        plan.into_iter().next().filter(|p| p != band_plan)
    }

    /// Overlap (samples) of the windows of a run of `n` samples done in windows: the longer
    /// settling length of the band-pass and the level rows' low-pass `low`. `None` when the run
    /// is done whole: shorter than two windows, without a band-pass, with rows above the band,
    /// or with filters that take too long to settle for the overlap to stay small beside a
    /// window.
    pub(super) fn window_margin(
        &self,
        n: usize,
        low: Option<&LowFrequency>,
        above_band: Option<&AboveBand>,
    ) -> Option<usize> {
        let band = self.filter.as_ref()?;
        let window = self.window_samples;
        if above_band.is_some() || n < window.saturating_mul(2) {
            return None;
        }
        let margin = low
            .map_or(0, |l| l.filter().settling_samples())
            .max(band.settling_samples());
        (margin <= window / 4).then_some(margin)
    }

    /// Values a run of `n` samples needs in its buffer, `width` columns and the target: all of
    /// them, or a window's when it is done in windows (see [`Problem::window_margin`]).
    pub(super) fn buffer_len(
        &self,
        n: usize,
        width: usize,
        low: Option<&LowFrequency>,
        above_band: Option<&AboveBand>,
    ) -> usize {
        match self.window_margin(n, low, above_band) {
            Some(margin) => {
                let window = self.window_samples;
                windows_dealt(n, window) * window_len(n, window, margin) * (width + 1)
            }
            None => n * (width + 1),
        }
    }

    /// The low-pass of the heading levels' rows, when the settings ask for levels and they can
    /// have them (the fluxgate's calibration, which [`super::run`]`::level_setup` then needs, may
    /// still fail).
    pub(super) fn level_low_pass(&self, fs_hz: f64) -> Result<Option<LowFrequency>, FitError> {
        let s = self.settings;
        if !s.levels || s.target == Target::Interference || self.flux.count() != 1 {
            return Ok(None);
        }
        Ok(LowFrequency::new(s.band, s.order, s.trim, fs_hz)?)
    }

    /// The low-pass for heading levels, when the settings ask for them, without a reference
    /// yet: for a fit that calibrates the fluxgate from its own rows ([`InPass`]).
    pub(super) fn level_setup_pending(&self, fs_hz: f64) -> Result<Option<LevelSetup>, FitError> {
        Ok(self.level_low_pass(fs_hz)?.map(|low| LevelSetup {
            reference: None,
            low,
            sigma_nt: f64::NAN,
            expected_nt: f64::NAN,
            band_sigma_nt: f64::NAN,
            rows: Vec::new(),
            row_terms: Vec::new(),
        }))
    }

    /// `setup` with the reference calibrated from the fold factors `folds` of the linear rows
    /// ([`InPass`]), and the target of their level rows `rows` made `y − R`; `None`
    /// if the fluxgate cannot be calibrated (the fit then has no levels).
    pub(super) fn calibrated_in_pass(
        &self,
        setup: LevelSetup,
        in_pass: &InPass,
        folds: &[FoldFactor],
        rows: &mut [LevelRows],
        fs_hz: f64,
    ) -> Option<LevelSetup> {
        let flux = self.flux.series()[0];
        let (reference, coefficients) = in_pass.reference(flux, self.samples, folds, self.spare)?;
        in_pass.subtract_reference(rows, &coefficients);
        Some(setup.with_reference(reference, self.settings, fs_hz))
    }

    /// Refits with the level rows: first weighted by the reference's expected noise, then, if
    /// the rows scatter more than that about the fit, once more with their measured scatter.
    ///
    /// `rows` are the level rows on the columns of `union`, the same for every weight (formed
    /// once: at 10⁷ samples they are 35 MB of fresh memory, 0.1–0.2 s here); `designs` are the
    /// candidates, whose chosen one's coefficients are placed on the union's columns to measure
    /// the misfit.
    ///
    /// The band rows' scatter, which sets the level rows' weight, leaves out the rows above the
    /// band (`above`: their residual sum of squares for `band_only` and their count): with
    /// extra channels, what the aircraft's field does above the band is left to them, and
    /// would pass for scatter of the band rows.
    pub(super) fn choose_with_levels(
        &self,
        setup: &mut LevelSetup,
        (band_only, above): (&Chosen, (f64, usize)),
        (union, designs): (&[Term], &[Design]),
        rows: Vec<LevelRows>,
        solve: impl Fn(&LevelSetup) -> Result<Chosen, FitError>,
    ) -> Result<LevelChoice, FitError> {
        setup.rows = rows;
        setup.row_terms = union.to_vec();
        let band_terms = designs[band_only.index].design_terms();
        let untrusted = setup.misfit(&band_terms, &band_only.solution.coefficients);
        // No misfit to measure (no level row) is no level to trust either.
        if untrusted.is_nan() || untrusted > UNTRUSTED_LEVELS_NT {
            return Ok(LevelChoice::Untrusted {
                misfit_nt: untrusted,
            });
        }
        let s = &band_only.solution;
        let band_rows = s.rows.saturating_sub(above.1).max(1);
        let band_rss = (s.rss - above.0).max(0.0);
        setup.band_sigma_nt = (band_rss / band_rows as f64).sqrt().max(1e-6);
        let mut chosen = solve(setup)?;
        let terms = designs[chosen.index].design_terms();
        let misfit = setup.misfit(&terms, &chosen.solution.coefficients);
        if misfit > 1.5 * setup.sigma_nt {
            setup.sigma_nt = misfit;
            chosen = solve(setup)?;
        }
        Ok(LevelChoice::Used(Box::new(chosen)))
    }
}

/// The heading levels' RMS misfit (nT) to the band-only model beyond which the calibration's
/// low frequencies are not trusted to steer the fit. A box whose model fits its band to tenths
/// of a nT but misses its levels by tens (real boxes: 38–115 nT) holds below the band what no
/// term models: geology under legs kilometres apart, diurnal variation, a fluxgate whose
/// calibration drifts. Simulated boxes, whose low frequencies the model describes, miss by
/// about 0.1 nT.
pub(super) const UNTRUSTED_LEVELS_NT: f64 = 10.0;

/// What the heading levels did to a fit's choice.
pub(super) enum LevelChoice {
    /// The choice made with the level rows.
    Used(Box<Chosen>),
    /// The band-only model misses the level rows by `misfit_nt` (nT RMS), more than
    /// [`UNTRUSTED_LEVELS_NT`], or there is no misfit to measure (NaN): the fit keeps the
    /// band-only choice.
    Untrusted { misfit_nt: f64 },
}

/// Subtracts the mean: a run's intercept, for a target that has no filter to remove it.
fn remove_mean(x: &mut [f64]) {
    let mean = x.iter().sum::<f64>() / x.len().max(1) as f64;
    x.iter_mut().for_each(|v| *v -= mean);
}

#[cfg(test)]
mod tests {
    use super::*;

    use crate::fit::ridge::Ridge;

    /// [`merged_kinds`] a row at a time, as the rows were once merged.
    fn kinds_row_by_row(band: usize, trim: usize, level_at: &[usize], above: usize) -> Vec<u8> {
        let mut first = Vec::new();
        let (mut b, mut l) = (0, 0);
        while b < band || l < level_at.len() {
            if l == level_at.len() || (b < band && b + trim <= level_at[l]) {
                first.push(BAND);
                b += 1;
            } else {
                first.push(LEVEL);
                l += 1;
            }
        }
        let position = |k: usize, n: usize| (2 * k + 1) as f64 / (2 * n) as f64;
        let n1 = first.len();
        let mut out = Vec::new();
        let (mut i, mut a) = (0, 0);
        while i < n1 || a < above {
            if a == above || (i < n1 && position(i, n1) <= position(a, above)) {
                out.push(first[i]);
                i += 1;
            } else {
                out.push(ABOVE);
                a += 1;
            }
        }
        out
    }

    /// The kind of every row of `stretches`.
    fn expanded(stretches: &[Stretch]) -> Vec<u8> {
        stretches
            .iter()
            .flat_map(|s| std::iter::repeat_n(s.kind, s.rows))
            .collect()
    }

    #[test]
    fn level_rows_follow_the_band_row_of_their_sample() {
        // Band rows are samples 2, 3, 4 (trim 2); the level row at sample 3 follows band row 3.
        assert_eq!(
            expanded(&merged_kinds(3, 2, &[3], 0)),
            [BAND, BAND, LEVEL, BAND]
        );
        assert_eq!(
            expanded(&merged_kinds(2, 0, &[0, 5], 0)),
            [BAND, LEVEL, BAND, LEVEL]
        );
    }

    proptest::proptest! {
        /// Stretches hold the rows one at a time would, each stretch longest.
        #[test]
        fn stretches_are_the_rows_one_at_a_time(
            band in 0usize..300,
            trim in 0usize..20,
            mut level_at in proptest::collection::vec(0usize..340, 0..40),
            above in proptest::prop_oneof![proptest::strategy::Just(0usize), 0usize..400],
        ) {
            level_at.sort_unstable();
            let stretches = merged_kinds(band, trim, &level_at, above);
            proptest::prop_assert_eq!(
                expanded(&stretches),
                kinds_row_by_row(band, trim, &level_at, above)
            );
            proptest::prop_assert!(stretches.windows(2).all(|w| w[0].kind != w[1].kind));
            proptest::prop_assert!(stretches.iter().all(|s| s.rows > 0));
        }
    }

    #[test]
    fn rows_above_the_band_are_merged_by_position() {
        // Four rows (the second a level row) and two above: positions 1/8, 3/8, 5/8, 7/8 and
        // 1/4, 3/4.
        assert_eq!(
            expanded(&merged_kinds(3, 0, &[0], 2)),
            [BAND, ABOVE, LEVEL, BAND, ABOVE, BAND]
        );
    }

    /// Runs of `lengths` samples, two columns and a target of made-up values, trim 2, with a
    /// level row every 3 samples and, if `above`, rows above the band.
    fn prepared(lengths: &[usize], above: bool) -> Prepared {
        let (width, trim) = (3, 2);
        let value =
            |run: usize, k: usize, c: usize| ((run * 31 + k * 7 + c * 3) as f64 * 0.41).sin();
        let runs = lengths
            .iter()
            .enumerate()
            .map(|(run, &n)| RunRows {
                data: (0..width)
                    .flat_map(|c| (0..n).map(move |k| value(run, k, c)))
                    .collect(),
                len: n,
                above: above
                    .then(|| DMatrix::from_fn(n - 2 * trim, width, |k, c| value(run + 9, k, c))),
                factored: None,
            })
            .collect();
        let levels = lengths
            .iter()
            .enumerate()
            .map(|(run, &n)| {
                let at: Vec<usize> = (trim..n - trim).step_by(3).collect();
                LevelRows {
                    a: DMatrix::from_fn(at.len(), width - 1, |k, c| value(run + 5, k, c)),
                    y: (0..at.len()).map(|k| value(run + 5, k, 2)).collect(),
                    at,
                }
            })
            .collect();
        Prepared {
            width,
            extra: 0,
            trim,
            runs,
            levels,
            short: 0,
        }
    }

    /// The rows of every fold the slow way: each run's rows materialised in time order and
    /// dealt out row by row, as the folds were made before they were factored in place.
    fn folds_row_by_row(p: &Prepared, with_levels: bool, count: usize, weight: f64) -> Vec<Ridge> {
        let mut rows: Vec<(Vec<f64>, f64)> = Vec::new();
        for run in 0..p.runs.len() {
            let level = &p.levels[run];
            let at: &[usize] = if with_levels { &level.at } else { &[] };
            let above = p.runs[run].above.as_ref();
            let kinds =
                kinds_row_by_row(p.band_rows(run), p.trim, at, above.map_or(0, |a| a.nrows()));
            let mut next = [0usize; 3];
            for kind in kinds {
                let k = next[kind as usize];
                next[kind as usize] += 1;
                let all = 0..p.band_rows(run);
                rows.push(match kind {
                    BAND => (
                        (0..2).map(|c| p.band_column(run, c, &all)[k]).collect(),
                        p.band_column(run, 2, &all)[k],
                    ),
                    LEVEL => (
                        (0..2).map(|c| weight * level.a[(k, c)]).collect(),
                        weight * level.y[k],
                    ),
                    _ => {
                        let a = above.unwrap();
                        ((0..2).map(|c| a[(k, c)]).collect(), a[(k, 2)])
                    }
                });
            }
        }
        let total = rows.len();
        let mut folds = vec![Ridge::new(2); count];
        for (g, (a, y)) in rows.into_iter().enumerate() {
            folds[g * count / total].push_row(a, y);
        }
        folds
    }

    #[test]
    fn fold_factors_from_the_filtered_runs_equal_the_folds_dealt_row_by_row() {
        for (lengths, above) in [(vec![40, 23, 61], false), (vec![30, 57], true)] {
            let p = prepared(&lengths, above);
            let band_plan = p.plan(false, 5);
            let level_plan = p.plan(true, 5);
            let band = p.band_factors(&[&band_plan, &level_plan]);
            for (plan, with_levels, weight) in [(&band_plan, false, 0.0), (&level_plan, true, 0.7)]
            {
                let factors = p.fold_factors(plan, weight, &band);
                let (fast, _) = super::super::choice::fold_problems(&factors, &[0, 1]);
                let slow = folds_row_by_row(&p, with_levels, 5, weight);
                for (f, s) in fast.iter().zip(&slow) {
                    assert_eq!(f.rows(), s.rows());
                    let beta = [0.3, -1.2];
                    let (u, v) = (
                        f.residual_sum_of_squares(&beta),
                        s.residual_sum_of_squares(&beta),
                    );
                    assert!((u - v).abs() <= 1e-12 * v.max(1.0), "{u} vs {v}");
                    let (u, v) = (f.column_sums_of_squares(), s.column_sums_of_squares());
                    for (x, y) in u.iter().zip(&v) {
                        assert!((x - y).abs() <= 1e-12 * y.max(1.0), "{x} vs {y}");
                    }
                }
            }
        }
    }

    #[test]
    fn the_longest_need_gets_the_longest_spare_buffer() {
        let spare = Spare::default();
        spare.reserve(100);
        spare.reserve(60); // one long enough is there already
        spare.give([vec![1.0; 30]]);
        let taken = spare.take_each(&[20, 0, 90]);
        let lens: Vec<usize> = taken.iter().map(Vec::len).collect();
        // The 90 gets the reserved 100 although the 20, first in order, would fit it too.
        assert_eq!(lens, [30, 0, 100]);
        // A spare buffer comes as its last user left it; a new one is zeros.
        assert_eq!(taken[0][0], 1.0);
        assert_eq!(spare.take(5), vec![0.0; 5]);
    }

    #[test]
    fn a_run_mean_is_removed_for_an_interference_target() {
        let mut x = [1.0, 2.0, 6.0];
        remove_mean(&mut x);
        assert_eq!(x, [-2.0, -1.0, 3.0]);
    }
}
