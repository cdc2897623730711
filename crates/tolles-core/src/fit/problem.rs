//! One calibration flight cut into runs, and the rows a fit solves: band-passed design rows,
//! interleaved level rows, and the Gauss-Newton rows of the exact magnitude.

use super::choice::{choose_design, Chosen};
use super::levels::{self, LevelDiagnostics, LevelRows, LowFrequency, Reference};
use super::qr::{stacked_factor, triangular_factor, RowFactor};
use super::{
    FitError, FitSettings, Lambda, MagnitudeChoice, Samples, Target, EXACT_CLEAR_LOSS,
    EXACT_ITERATIONS, EXACT_SETTLED, EXACT_TOLERANCE,
};
use crate::model::design::{Design, Term};
use crate::model::magnitude::exact_jacobian_into;
use crate::model::vector::Fluxgates;
use crate::parallel::{blocks, split_rows};
use crate::signal::filter::{
    filtfilt_many_unless_constant, filtfilt_window_handed, filtfilt_window_sampled, surely_varying,
    Butterworth, Ends, Fed, Jumps, PREFIX,
};
use multiversion::multiversion;
use nalgebra::DMatrix;
use std::ops::Range;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::Mutex;

/// Writes the rows `rows` (counted from the run's start) of a run's unfiltered columns and,
/// after them, of its target into the slices given (one per column, `rows.len()` values
/// each), every value of them: they hold whatever a [`Spare`] buffer last held. A row's values
/// are those of the whole run's (its changes taken over the run), however the rows are cut.
pub(super) type FillRun<'m> = dyn Fn(Range<usize>, Range<usize>, &mut [&mut [f64]]) + Sync + 'm;

/// Samples per window of a long run, which is filtered and factored window by window, each
/// window taken whole by the next core free: the rows of a whole run need not be held at once (at 10⁷
/// samples and 19 columns they are 1.5 GB, which on a virtual machine take seconds to fault in).
/// Runs shorter than two windows are done whole. 2¹⁶ to 2¹⁹ timed the same at 10⁷ samples;
/// 2¹⁸ keeps the overlap a thirtieth of a window and two windows' buffers near 85 MB. Tests
/// run with it too; those about windows ask for shorter ones ([`with_window_samples`]).
const WINDOW_SAMPLES: usize = 1 << 18;

thread_local! {
    /// Samples per window of the fits started on this thread when not [`WINDOW_SAMPLES`]: set
    /// only by [`with_window_samples`], so a test can have a run of tens of thousands of
    /// samples done in windows.
    static WINDOW_SAMPLES_HERE: std::cell::Cell<Option<usize>> = const { std::cell::Cell::new(None) };
}

/// Samples per window of a fit started on this thread.
pub(super) fn window_samples() -> usize {
    WINDOW_SAMPLES_HERE.get().unwrap_or(WINDOW_SAMPLES)
}

/// Runs `f` with the fits it starts on this thread cutting long runs into windows of
/// `samples` (at least 2¹⁰).
#[cfg(test)]
pub(super) fn with_window_samples<T>(samples: usize, f: impl FnOnce() -> T) -> T {
    let before = WINDOW_SAMPLES_HERE.replace(Some(samples.max(1 << 10)));
    let out = f();
    WINDOW_SAMPLES_HERE.set(before);
    out
}

/// Samples of each window's own part (its core) of a run of `n` samples done in windows of
/// `window` samples: the run cut into equal parts of at most `window`, as many as a multiple
/// of [`WINDOW_MULTIPLE`].
fn window_core(n: usize, window: usize) -> usize {
    n.div_ceil(n.div_ceil(window).next_multiple_of(WINDOW_MULTIPLE))
}

/// The windows of a run come in a multiple of this many. They are taken whole by the cores:
/// with one window more than a multiple of the cores (39 at 10⁷ samples on two), one core
/// worked through it alone while the other waited, 0.14 s per pass over the rows. The layout
/// does not depend on the cores, so neither do the values; four balances one, two and four.
const WINDOW_MULTIPLE: usize = 4;

/// Samples of the longest window of a run of `n` samples done in windows of `window` samples
/// overlapping by `margin`: a core and a margin on each side.
fn window_len(n: usize, window: usize, margin: usize) -> usize {
    window_core(n, window) + 2 * margin
}

/// Windows of a run of `n` samples done in windows of `window` samples that are worked on at
/// once: one per core, at most one per window. A window's buffer is taken for each.
fn windows_dealt(n: usize, window: usize) -> usize {
    crate::parallel::cores().min(n.div_ceil(window_core(n, window)))
}

/// In tests, how many runs were done in windows.
#[cfg(test)]
pub(super) mod windows_in_tests {
    use std::cell::Cell;
    thread_local! {
        pub(in crate::fit) static DONE: Cell<usize> = const { Cell::new(0) };
    }
}

/// Buffers a fit has finished with, for its next step to reuse. On a long flight, touching
/// fresh memory costs more than the arithmetic done in it (on a virtual machine, gigabytes take
/// seconds to fault in), so every large buffer of a fit comes from here and goes back.
#[derive(Default)]
pub(super) struct Spare(Mutex<Vec<Vec<f64>>>);

impl Spare {
    /// A buffer of at least `len` values, of which the taker uses the first `len`: the
    /// smallest spare one that is long enough, as its last user left it (so every taker writes
    /// all it uses before reading it: zeroing a gigabyte that is about to be overwritten costs
    /// a tenth of a second), or a new one of `len` zeros.
    ///
    /// A new one is zeroed by the system as its pages are first written, by whichever thread
    /// writes them, so the fills that write on all cores also fault its pages in on all cores.
    pub(super) fn take(&self, len: usize) -> Vec<f64> {
        let mut spare = self.0.lock().unwrap_or_else(|e| e.into_inner());
        let fits = (0..spare.len())
            .filter(|&i| spare[i].len() >= len)
            .min_by_key(|&i| spare[i].len());
        match fits {
            Some(i) => spare.swap_remove(i),
            None => vec![0.0; len],
        }
    }

    /// [`Spare::take`] of each of `lens`, the longest first, so that the longest need gets the
    /// longest buffer rather than one a shorter need took first. Empty for a length of 0.
    pub(super) fn take_each(&self, lens: &[usize]) -> Vec<Vec<f64>> {
        let mut order: Vec<usize> = (0..lens.len()).collect();
        order.sort_by_key(|&i| std::cmp::Reverse(lens[i]));
        let mut out = vec![Vec::new(); lens.len()];
        for i in order.into_iter().filter(|&i| lens[i] > 0) {
            out[i] = self.take(lens[i]);
        }
        out
    }

    /// Makes sure a spare buffer of at least `len` values is there, for a fit that will need
    /// one that long after smaller ones: the smaller needs are then met by its first part,
    /// and its pages are faulted in once, as far as each use reaches, rather than those of
    /// every size in turn (on a virtual machine each new gigabyte costs about a second).
    pub(super) fn reserve(&self, len: usize) {
        let mut spare = self.0.lock().unwrap_or_else(|e| e.into_inner());
        if spare.iter().all(|b| b.len() < len) {
            spare.push(vec![0.0; len]);
        }
    }

    /// Returns `buffers` for a later [`Spare::take`].
    pub(super) fn give(&self, buffers: impl IntoIterator<Item = Vec<f64>>) {
        let mut spare = self.0.lock().unwrap_or_else(|e| e.into_inner());
        spare.extend(buffers.into_iter().filter(|b| !b.is_empty()));
    }
}

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
    /// Samples per window of a long run ([`window_samples`]).
    pub(super) window_samples: usize,
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
    /// The same rows for a design of the columns `terms`: only its extra channels' columns
    /// kept (a design without them has its rows zeroed, so they stay part of the score, as they
    /// were for the linear fit it is compared with, but explain nothing).
    fn for_terms(&self, terms: &[Term]) -> AboveBand {
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
    fn rows(&self, data: &[f64], n: usize, trim: usize) -> Result<DMatrix<f64>, FitError> {
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
struct RunRows {
    /// The columns and the target, column-major, `len` samples each, filtered but not trimmed,
    /// at the start of a buffer that may be longer; empty for a run done in windows.
    data: Vec<f64>,
    len: usize,
    /// Rows above the band (trimmed), the target last; with extra channels only.
    above: Option<DMatrix<f64>>,
    /// For a run done in windows, its band rows already factored.
    factored: Option<Factored>,
}

/// Consecutive ranges of a run's band rows and their factors.
type Pieces = Vec<(Range<usize>, DMatrix<f64>)>;

/// The band rows of a run done window by window, factored as they were filtered.
struct Factored {
    /// Consecutive ranges of band rows, cut where windows and the folds of the plans given
    /// to [`Problem::prepare`] start, and their factors.
    pieces: Pieces,
    /// The scatter of its filtered target over its band rows.
    target: super::RunningStd,
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
    width: usize,
    /// Signals after the target (see [`Problem::prepare`]).
    extra: usize,
    trim: usize,
    runs: Vec<RunRows>,
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

/// One fold's rows reduced to triangular factors of all the columns and the target.
#[derive(Clone)]
pub(super) struct FoldFactor {
    /// Factor of every row of the fold.
    pub(super) r: DMatrix<f64>,
    pub(super) rows: usize,
    /// Factor of its (weighted) level rows alone.
    pub(super) level_r: DMatrix<f64>,
    pub(super) level_rows: usize,
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
fn cuts_of(plans: &[&Plan], run: usize, band: usize) -> Vec<usize> {
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
        let mut before = super::RunningStd::default();
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

/// A long run done window by window: each window is the run's samples of its core (about
/// [`WINDOW_SAMPLES`]) widened by `margin` on each side within the run, filled, filtered with
/// open ends where the run goes on, and its core's band rows factored; the margins' values are
/// thrown away once their filters have settled.
struct Windows {
    run: Range<usize>,
    margin: usize,
    /// Columns, the target not included.
    width: usize,
    /// Signals after the target.
    extra: usize,
    trim: usize,
}

/// What one window of a run done in windows gives: its band rows' factors, its filtered
/// target's scatter (block by block, merged in order afterwards), and with levels the samples of
/// its level rows, per signal.
struct WindowPart {
    pieces: Pieces,
    target: Vec<super::RunningStd>,
    sampled: Vec<Vec<f64>>,
}

/// What every window of a run shares.
struct WindowInputs<'w, 'p, 'a> {
    problem: &'w Problem<'p, 'a>,
    fill: &'w FillRun<'w>,
    levels: Option<&'w LevelSetup>,
    cuts: &'w [usize],
    /// The samples of the run its level rows are taken at.
    kept: Option<Vec<usize>>,
    /// What the level rows' target is the scalar less, with levels.
    reference: Option<LevelReference<'w>>,
}

/// What the level rows' target is the scalar less, over a run.
#[derive(Clone, Copy)]
enum LevelReference<'w> {
    /// The calibrated reference's values (nT).
    Values(&'w [f64]),
    /// The fluxgate's magnitude, the signal after the target, while the fluxgate is calibrated
    /// from the same rows ([`levels::InPass`]): the calibration's correction joins the level
    /// rows' target afterwards. The magnitude rather than nothing, so that the low-pass sees
    /// the small difference of two fields of 50 000 nT rather than each (its rounding is
    /// relative to what it filters).
    Magnitude,
}

impl<'w> LevelReference<'w> {
    /// The reference of `setup` over `run`.
    fn of(setup: &'w LevelSetup, run: Range<usize>) -> Self {
        match &setup.reference {
            Some(r) => LevelReference::Values(levels::reference_over(r, run)),
            None => LevelReference::Magnitude,
        }
    }

    /// The reference over `rows` (of the run), its `signals` over them at hand: the columns,
    /// the target, the magnitude.
    fn over<'s, S: AsRef<[f64]>>(&'s self, rows: Range<usize>, signals: &'s [S]) -> &'s [f64] {
        match self {
            LevelReference::Values(values) => &values[rows],
            LevelReference::Magnitude => signals[signals.len() - 1].as_ref(),
        }
    }
}

impl Windows {
    /// The run's band rows factored (cut at the band rows `cuts` and where windows start), the
    /// scatter of its filtered target and, with `levels`, its level rows (not centred), in
    /// windows taken whole by the cores, each core with its share of `buffer` (see
    /// [`Problem::buffer_len`]); `None` if a column or a target is constant or nearly so over
    /// the run (the filters leave a constant signal alone, which only the whole run can tell).
    ///
    /// Whole windows rather than each step of one spread over the cores: a window's fill,
    /// filters and factor stay on one core with no thread started per step, and a fit of few
    /// columns (the fluxgate's calibration: 10 signals, an 8-lane block on one core and a
    /// 2-lane one on the other when its filters were shared) keeps both cores busy.
    fn factor(
        &self,
        problem: &Problem,
        fill: &FillRun<'_>,
        levels: Option<&LevelSetup>,
        cuts: &[usize],
        buffer: &mut [f64],
    ) -> Option<(Factored, Option<LevelRows>)> {
        let n = self.run.len();
        let window = problem.window_samples;
        let core = window_core(n, window);
        let inputs = WindowInputs {
            problem,
            fill,
            levels,
            cuts,
            kept: levels.and_then(|l| l.low.kept(n)),
            reference: levels.map(|l| LevelReference::of(l, self.run.clone())),
        };
        let starts: Vec<usize> = (0..n).step_by(core).collect();
        let longest = window_len(n, window, self.margin);
        // The buffer may be longer than this run asked for (a spare one of a wider fit's), so
        // its shares are counted as they were sized, not by how many it holds.
        let shares: Vec<&mut [f64]> = buffer
            .chunks_exact_mut(longest * (self.width + 1 + self.extra))
            .take(windows_dealt(n, window))
            .collect();
        let dealt = shares.len();
        let mut targets = problem.spare.take_each(&vec![longest; dealt]);
        let given_up = AtomicBool::new(false);
        // Each core takes the next window when it is done with its last, rather than every
        // `dealt`-th: on this virtual machine a core's speed varies, and with a fixed deal one
        // core finished each pass alone for 0.06–0.14 s. Windows are put back in order
        // afterwards, so the values do not depend on who did which.
        let next = AtomicUsize::new(0);
        let deal = |(share, target): (&mut [f64], &mut Vec<f64>)| {
            let mut parts = Vec::new();
            while !given_up.load(Ordering::Relaxed) {
                let index = next.fetch_add(1, Ordering::Relaxed);
                let Some(&start) = starts.get(index) else {
                    break;
                };
                match self.window(&inputs, start..(start + core).min(n), share, target) {
                    Some(part) => parts.push((index, part)),
                    None => given_up.store(true, Ordering::Relaxed),
                }
            }
            parts
        };
        let work = shares.into_iter().zip(targets.iter_mut());
        let mut parts: Vec<(usize, WindowPart)> = match dealt {
            1 => work.flat_map(deal).collect(),
            _ => std::thread::scope(|scope| {
                let handles: Vec<_> = work
                    .map(|w| scope.spawn(|| crate::parallel::on_one_core(|| deal(w))))
                    .collect();
                handles
                    .into_iter()
                    .flat_map(|h| h.join().expect("a window's thread does not panic"))
                    .collect()
            }),
        };
        problem.spare.give(targets);
        if given_up.into_inner() {
            return None;
        }
        parts.sort_by_key(|(index, _)| *index);
        let parts = parts.into_iter().map(|(_, p)| p);
        Some(self.gathered(parts, levels.map(|_| inputs.kept)))
    }

    /// The windows' parts, in order, as one run's; with `levels` (the samples the level rows
    /// are taken at, if any), its level rows.
    fn gathered(
        &self,
        parts: impl Iterator<Item = WindowPart>,
        levels: Option<Option<Vec<usize>>>,
    ) -> (Factored, Option<LevelRows>) {
        let mut factored = Factored {
            pieces: Vec::new(),
            target: super::RunningStd::default(),
        };
        let mut sampled = Vec::new();
        for part in parts {
            factored.pieces.extend(part.pieces);
            for block in part.target {
                factored.target.merge(block);
            }
            sampled.push(part.sampled);
        }
        let rows = levels.map(|kept| match kept {
            Some(at) => LevelRows::from_parts(self.width, sampled, at),
            None => LevelRows::none(self.width),
        });
        (factored, rows)
    }

    /// One window: its samples `core` of the run and the margins either side filled into
    /// `buffer`, filtered and factored; `None` if it is the run's first and a column or the
    /// target is not surely varying there.
    ///
    /// The window is filled a stretch at a time as the band-pass's forward pass asks for it
    /// ([`Fed`]), and the level rows' low-pass takes each stretch as it is filled: the
    /// unfiltered window (40 MB at 19 columns, more than this machine's last-level cache) is
    /// never written whole and read again from memory by each filter in turn. A low-pass that
    /// cannot jump ([`Jumps`]) needs the whole window first, and gets it.
    fn window(
        &self,
        inputs: &WindowInputs,
        core: Range<usize>,
        buffer: &mut [f64],
        target: &mut [f64],
    ) -> Option<WindowPart> {
        let n = self.run.len();
        let band = inputs
            .problem
            .filter
            .as_ref()
            .expect("windows are band-passed");
        let signals = self.width + 1 + self.extra;
        let window = core.start.saturating_sub(self.margin)..(core.end + self.margin).min(n);
        let m = window.len();
        let mut columns: Vec<&mut [f64]> = buffer[..m * signals].chunks_mut(m).collect();
        let mut source = Source {
            inputs,
            width: self.width,
            run: self.run.clone(),
            window: window.clone(),
            filled: 0,
            low_target: &mut target[..m],
        };
        if core.start == 0 {
            source.fill(&mut columns, PREFIX.min(m));
            if !source.varying(&columns, n) {
                return None;
            }
        }
        let ends = Ends::of_window(&window, n);
        let (mut jumps, mut sampled) = (None, Vec::new());
        if let (Some(setup), Some(kept)) = (inputs.levels, &inputs.kept) {
            let at: Vec<usize> = kept
                .iter()
                .filter(|k| core.contains(k))
                .map(|k| k - window.start)
                .collect();
            let low = setup.low.filter();
            // The low-pass reads the columns and the target, not the signals after it.
            jumps = Jumps::new(low, &at, ends, self.width + 1, m);
            if jumps.is_none() {
                source.fill(&mut columns, m);
                sampled = filtfilt_window_sampled(low, &source.low_signals(&columns), &at, ends);
            }
        }
        let lookback = jumps.as_ref().map_or(0, Jumps::lookback);
        let mut feed = |rows: Range<usize>, columns: &mut [&mut [f64]]| {
            source.fill(columns, rows.end);
            if let Some(j) = jumps.as_mut() {
                let low = source.low_signals(columns);
                j.advance(&low, rows.end);
                if rows.end == m {
                    sampled = jumps.take().expect("jumps until the end").finish(&low);
                }
            }
        };
        let mut fed = Fed {
            feed: &mut feed,
            lookback,
        };
        let core = Core {
            window: &window,
            core: &core,
            ends,
        };
        let (pieces, target) = self.factor_core(band, &mut columns, &core, inputs.cuts, &mut fed);
        Some(WindowPart {
            pieces,
            target,
            sampled,
        })
    }

    /// The band-pass `band` of the `columns` of `core.window`, and the factors of the band rows
    /// among its samples `core.core`, cut at `cuts`, with their target's scatter stretch by
    /// stretch.
    ///
    /// The rows are factored as the backward pass hands them over, while they are in the
    /// cache: the filtered window is not written back, nor read again from memory (at 19
    /// columns a window is 40 MB, more than this machine's last-level cache).
    fn factor_core(
        &self,
        band: &Butterworth,
        columns: &mut [&mut [f64]],
        core: &Core,
        cuts: &[usize],
        fed: &mut Fed,
    ) -> (Pieces, Vec<super::RunningStd>) {
        let n = self.run.len();
        let window_start = core.window.start;
        let samples = core.core.start.max(self.trim)..core.core.end.min(n - self.trim);
        if samples.is_empty() {
            return (Vec::new(), Vec::new());
        }
        let rows = samples.start - self.trim..samples.end - self.trim;
        let mut pieces: Vec<(Range<usize>, RowFactor)> = cuts
            .windows(2)
            .map(|w| w[0].max(rows.start)..w[1].min(rows.end))
            .filter(|piece| !piece.is_empty())
            .map(|piece| (piece, RowFactor::new(columns.len())))
            .collect();
        let mut target = Vec::new();
        // Sample `w` of the window is band row `w + window_start − trim`.
        let (first, end) = (samples.start - window_start, samples.end - window_start);
        let mut take = |start: usize, handed: &[&[f64]]| {
            let span = start..(start + handed[0].len()).min(end);
            if span.is_empty() {
                return;
            }
            let row = |w: usize| w + window_start - self.trim;
            let index = |r: usize| r + self.trim - window_start - start;
            let stretch = row(span.start)..row(span.end);
            for (piece, factor) in &mut pieces {
                let both = piece.start.max(stretch.start)..piece.end.min(stretch.end);
                if !both.is_empty() {
                    let part: Vec<&[f64]> = handed
                        .iter()
                        .map(|c| &c[index(both.start)..index(both.end)])
                        .collect();
                    factor.push(&part);
                }
            }
            let values = &handed[self.width][index(stretch.start)..index(stretch.end)];
            target.push(super::RunningStd::of_block(values));
        };
        filtfilt_window_handed(band, columns, core.ends, first, fed, &mut take);
        // The stretches came from the last.
        target.reverse();
        let pieces = pieces
            .into_iter()
            .map(|(piece, factor)| (piece, factor.factor()))
            .collect();
        (pieces, target)
    }
}

/// Where a window's unfiltered values come from, filled row by row in order.
struct Source<'s, 'w, 'p, 'a> {
    inputs: &'s WindowInputs<'w, 'p, 'a>,
    run: Range<usize>,
    /// The window's samples of the run.
    window: Range<usize>,
    /// Rows of the window filled so far.
    filled: usize,
    /// Columns before the target.
    width: usize,
    /// The target less the heading levels' reference (nT), as far as filled, with levels.
    low_target: &'s mut [f64],
}

impl Source<'_, '_, '_, '_> {
    /// Fills the window's `columns` (its columns, its target, the signals after it) up to row
    /// `upto`.
    fn fill(&mut self, columns: &mut [&mut [f64]], upto: usize) {
        let rows = self.filled..upto.max(self.filled);
        if rows.is_empty() {
            return;
        }
        let mut part: Vec<&mut [f64]> = columns.iter_mut().map(|c| &mut c[rows.clone()]).collect();
        let start = self.window.start;
        (self.inputs.fill)(
            self.run.clone(),
            start + rows.start..start + rows.end,
            &mut part,
        );
        if let Some(reference) = &self.inputs.reference {
            let y = &part[self.width];
            let r = reference.over(start + rows.start..start + rows.end, &part);
            for ((t, y), r) in self.low_target[rows.clone()]
                .iter_mut()
                .zip(y.iter())
                .zip(r)
            {
                *t = y - r;
            }
        }
        self.filled = rows.end;
    }

    /// Whether the columns and the target less the reference, filled as far as the test
    /// needs ([`PREFIX`]), are surely varying over the run's `n` samples.
    fn varying(&self, columns: &[&mut [f64]], n: usize) -> bool {
        columns.iter().all(|c| surely_varying(c, n))
            && (self.inputs.reference.is_none() || surely_varying(self.low_target, n))
    }

    /// What the level rows' low-pass reads: the unfiltered columns, and the target less the
    /// reference in the target's place.
    fn low_signals<'c>(&'c self, columns: &'c [&mut [f64]]) -> Vec<&'c [f64]> {
        columns[..self.width]
            .iter()
            .map(|c| &**c)
            .chain([&*self.low_target])
            .collect()
    }
}

/// A window of a run and its core, and which of the window's ends are the run's.
struct Core<'w> {
    window: &'w Range<usize>,
    core: &'w Range<usize>,
    ends: Ends,
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

/// What the heading levels need: the reference, the low-pass, and the weight of their rows.
pub(super) struct LevelSetup {
    /// The reference; `None` while the linear rows are made, when the fluxgate is calibrated
    /// from them ([`levels::InPass`]): their level rows' target is then the scalar less the
    /// fluxgate's magnitude.
    pub(super) reference: Option<Reference>,
    pub(super) low: LowFrequency,
    /// Expected scatter of a level row (nT).
    pub(super) sigma_nt: f64,
    /// Scatter of a band row (nT).
    pub(super) band_sigma_nt: f64,
    /// Level rows of the fit kept (centred, unweighted), to measure the misfit.
    pub(super) rows: Vec<LevelRows>,
    /// The terms of the columns of `rows`: every candidate's for the linear rows, the chosen
    /// design's for the Gauss-Newton ones.
    pub(super) row_terms: Vec<Term>,
}

impl LevelSetup {
    /// The setup with its `reference`, and the level rows' expected scatter from the
    /// calibration's.
    fn with_reference(self, reference: Reference, s: &FitSettings, fs_hz: f64) -> Self {
        // White noise of the reference, seen through the low-pass instead of the band.
        let low = &self.low;
        let width = (s.band.pass2_hz.min(fs_hz / 2.0) - s.band.pass1_hz).max(low.cutoff_hz);
        let sigma_nt =
            (reference.calibration.residual_std_nt * (low.cutoff_hz / width).sqrt()).max(1e-3);
        Self {
            reference: Some(reference),
            sigma_nt,
            ..self
        }
    }

    pub(super) fn weight(&self) -> f64 {
        self.band_sigma_nt / self.sigma_nt
    }

    pub(super) fn row_count(&self) -> usize {
        self.rows.iter().map(|r| r.y.len()).sum()
    }

    /// RMS misfit of the level rows (nT) for the coefficients `beta` of `terms`.
    pub(super) fn misfit(&self, terms: &[Term], beta: &[f64]) -> f64 {
        levels::rms_misfit(&self.rows, &on_columns(&self.row_terms, terms, beta))
    }

    /// The level rows' residual sum of squares as the solve saw it, weighted (nT²), for the
    /// coefficients `beta` of `terms`.
    pub(super) fn weighted_rss(&self, terms: &[Term], beta: &[f64]) -> f64 {
        let misfit = self.misfit(terms, beta);
        let count = self.row_count();
        if count == 0 {
            return 0.0;
        }
        (self.weight() * misfit).powi(2) * count as f64
    }

    /// The level rows' long-run score covariance as the solve weighted them (columns of
    /// `row_terms`), for the coefficients `beta` of `terms`: see
    /// [`Prepared::score_covariance`]. A level row is a low-passed sample, correlated with its
    /// neighbours over about two periods of the cutoff, `fs_hz` samples a second.
    pub(super) fn score_covariance(
        &self,
        terms: &[Term],
        beta: &[f64],
        fs_hz: f64,
    ) -> DMatrix<f64> {
        let b = on_columns(&self.row_terms, terms, beta);
        let p = self.row_terms.len();
        let w2 = self.weight().powi(2);
        let mut total = DMatrix::zeros(p, p);
        for rows in self.rows.iter().filter(|r| !r.y.is_empty()) {
            let n = rows.y.len();
            let fitted = &rows.a * nalgebra::DVector::from_column_slice(&b);
            let residual: Vec<f64> = (0..n).map(|i| w2 * (rows.y[i] - fitted[i])).collect();
            let span = (rows.at[n - 1] - rows.at[0] + 1) as f64;
            let per_second = n as f64 / span * fs_hz;
            let block = (per_second * 2.0 / self.low.cutoff_hz).ceil();
            let block = if block.is_finite() { block as usize } else { n };
            let data = rows.a.as_slice();
            let columns: Vec<&[f64]> = data.chunks_exact(n).take(p).collect();
            total += run_score_covariance(&columns, &residual, block.clamp(1, n));
        }
        total
    }

    pub(super) fn diagnostics(&self, terms: &[Term], beta: &[f64]) -> LevelDiagnostics {
        let count = self.row_count();
        let misfit = self.misfit(terms, beta);
        LevelDiagnostics {
            fluxgate: self
                .reference
                .as_ref()
                .expect("the levels' diagnostics come after the calibration")
                .calibration
                .clone(),
            rows: count,
            cutoff_hz: self.low.cutoff_hz,
            residual_rms_nt: misfit,
            level_std_error_nt: misfit / (count as f64 / 4.0).max(1.0).sqrt(),
            weight: self.weight(),
        }
    }
}

impl Problem<'_, '_> {
    /// Filters a run's `signals` (its columns, then its target, then `extra` signals after it)
    /// in place and, with `levels`, gives its level rows of the columns and the target,
    /// low-passed from the unfiltered signals: with a band-pass, the two filters share the
    /// cores as one job.
    fn filter_run(
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
    fn trim_and_needed(&self, above_band: Option<&AboveBand>) -> (usize, usize) {
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

    /// The folds of the fluxgate's calibration from the linear rows ([`levels::InPass`]),
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
    fn window_margin(
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

    /// Band rows (and, with `levels`, level rows; with `above_band`, rows above the band) of
    /// every run long enough, from the `width` columns, the target and the `extra` signals after
    /// it that `fill` writes. The signals after the target are filtered and factored with the
    /// others (after the target: the leading columns of a factor are those of the columns
    /// before, whatever follows) and have no level rows: the fluxgate's magnitude, whose
    /// calibration [`levels::InPass`] takes from these rows.
    ///
    /// Runs of two windows or more are filtered and factored window by window, their band
    /// rows cut where the folds of `plans` start (see [`Problem::plans_ahead`]).
    pub(super) fn prepare(
        &self,
        width: usize,
        extra: usize,
        fill: &FillRun<'_>,
        levels: Option<&LevelSetup>,
        above_band: Option<&AboveBand>,
        plans: &[&Plan],
    ) -> Result<Prepared, FitError> {
        let (trim, needed) = self.trim_and_needed(above_band);
        let signals = width + 1 + extra;
        let low = levels.map(|l| &l.low);
        let sizes: Vec<usize> = self
            .samples
            .runs
            .iter()
            .map(|r| match r.len() < needed {
                true => 0,
                false => self.buffer_len(r.len(), width + extra, low, above_band),
            })
            .collect();
        let mut buffers = self.spare.take_each(&sizes).into_iter();
        let mut runs = Vec::new();
        let mut level_rows = Vec::new();
        let mut short = 0;
        for (run, used) in self.samples.runs.iter().zip(sizes) {
            let n = run.len();
            let mut buffer = buffers.next().expect("one buffer per run");
            if used == 0 {
                short += n;
                continue;
            }
            if let Some(margin) = self.window_margin(n, low, above_band) {
                let windows = Windows {
                    run: run.clone(),
                    margin,
                    width,
                    extra,
                    trim,
                };
                let cuts = cuts_of(plans, runs.len(), n - 2 * trim);
                if let Some((factored, rows)) =
                    windows.factor(self, fill, levels, &cuts, &mut buffer)
                {
                    #[cfg(test)]
                    windows_in_tests::DONE.set(windows_in_tests::DONE.get() + 1);
                    self.spare.give([buffer]);
                    level_rows.extend(rows);
                    runs.push(RunRows {
                        data: Vec::new(),
                        len: n,
                        above: None,
                        factored: Some(factored),
                    });
                    continue;
                }
                // A constant column: the whole run decides what its filters do.
                buffer.resize(n * signals, 0.0);
            }
            let data = &mut buffer[..n * signals];
            fill(
                run.clone(),
                0..n,
                &mut data.chunks_mut(n).collect::<Vec<_>>(),
            );
            let above = match above_band {
                Some(above) => Some(above.rows(data, n, trim)?),
                None => None,
            };
            let mut signals: Vec<&mut [f64]> = data.chunks_mut(n).collect();
            if let Some(rows) = self.filter_run(run.clone(), &mut signals, extra, levels)? {
                level_rows.push(rows);
            }
            runs.push(RunRows {
                data: buffer,
                len: n,
                above,
                factored: None,
            });
        }
        levels::centre(&mut level_rows);
        Ok(Prepared {
            width: signals,
            extra,
            trim,
            runs,
            levels: level_rows,
            short,
        })
    }

    /// The low-pass of the heading levels' rows, when the settings ask for levels and they can
    /// have them (the fluxgate's calibration, which [`Problem::level_setup`] then needs, may
    /// still fail).
    pub(super) fn level_low_pass(&self, fs_hz: f64) -> Result<Option<LowFrequency>, FitError> {
        let s = self.settings;
        if !s.levels || s.target == Target::Interference || self.flux.count() != 1 {
            return Ok(None);
        }
        Ok(LowFrequency::new(s.band, s.order, s.trim, fs_hz)?)
    }

    /// The reference and low-pass for heading levels, when the settings ask for them and the
    /// fluxgate can be calibrated.
    pub(super) fn level_setup(&self, fs_hz: f64) -> Result<Option<LevelSetup>, FitError> {
        let s = self.settings;
        let Some(setup) = self.level_setup_pending(fs_hz)? else {
            return Ok(None);
        };
        let flux = self.flux.series()[0];
        let reference = levels::reference_reusing(flux, self.samples, fs_hz, s, self.spare);
        Ok(reference.map(|r| setup.with_reference(r, s, fs_hz)))
    }

    /// The low-pass for heading levels, when the settings ask for them, without a reference
    /// yet: for a fit that calibrates the fluxgate from its own rows ([`levels::InPass`]).
    pub(super) fn level_setup_pending(&self, fs_hz: f64) -> Result<Option<LevelSetup>, FitError> {
        Ok(self.level_low_pass(fs_hz)?.map(|low| LevelSetup {
            reference: None,
            low,
            sigma_nt: f64::NAN,
            band_sigma_nt: f64::NAN,
            rows: Vec::new(),
            row_terms: Vec::new(),
        }))
    }

    /// `setup` with the reference calibrated from the fold factors `folds` of the linear rows
    /// ([`levels::InPass`]), and the target of their level rows `rows` made `y − R`; `None`
    /// if the fluxgate cannot be calibrated (the fit then has no levels).
    pub(super) fn calibrated_in_pass(
        &self,
        setup: LevelSetup,
        in_pass: &levels::InPass,
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
    ) -> Result<Chosen, FitError> {
        let s = &band_only.solution;
        let band_rows = s.rows.saturating_sub(above.1).max(1);
        let band_rss = (s.rss - above.0).max(0.0);
        setup.band_sigma_nt = (band_rss / band_rows as f64).sqrt().max(1e-6);
        let mut chosen = solve(setup)?;
        setup.rows = rows;
        setup.row_terms = union.to_vec();
        let terms = designs[chosen.index].design_terms();
        let misfit = setup.misfit(&terms, &chosen.solution.coefficients);
        if misfit > 1.5 * setup.sigma_nt {
            setup.sigma_nt = misfit;
            chosen = solve(setup)?;
        }
        Ok(chosen)
    }

    /// The exact-magnitude fit of `design` by Gauss-Newton from the linear solution, when the
    /// settings ask for it and the design has one fluxgate.
    pub(super) fn exact(
        &self,
        design: &Design,
        linear: &Chosen,
        levels: Option<&LevelSetup>,
    ) -> Result<Option<Exact>, FitError> {
        // Several fluxgates stay linear, and so do extra channels: on simulated strobe currents
        // an exact fit predicted the box's held-out rows better, yet its survey error above the
        // band was 3–10 times the linear fit's (the second-order coupling of the current's
        // field with the aircraft's, through a field the 16 terms describe only in projection,
        // does not carry over to other headings).
        if self.settings.magnitude == MagnitudeChoice::Linear
            || design.fluxgates != 1
            || !design.extras.is_empty()
        {
            return Ok(None);
        }
        let terms = design.design_terms();
        let above = self.above.as_ref().map(|a| a.for_terms(&terms));
        let designs = [design.clone()];
        let series = self.flux.series()[0];
        let count = fold_count(self.settings.lambda);
        let mut beta = linear.solution.coefficients.clone();
        let mut best: Option<Exact> = None;
        let mut last_step = f64::INFINITY;
        let plan = self
            .plans_ahead(levels, above.as_ref(), &[levels.is_some()], count)
            .pop()
            .expect("one plan asked for");
        for iteration in 1..=EXACT_ITERATIONS {
            let current = beta.clone();
            let fill = |run: Range<usize>, rows: Range<usize>, columns: &mut [&mut [f64]]| {
                let series = [&series.x, &series.y, &series.z].map(|c| &c[run.clone()]);
                let extras: Vec<&[f64]> =
                    self.flux.extras().iter().map(|e| &e[run.clone()]).collect();
                let scalar = &self.scalar[run];
                split_rows(rows.len(), columns, |part, parts| {
                    // Block by block, so the target is formed while the block's Jacobian is
                    // still in the cache.
                    let start = rows.start + part.start;
                    let mut sum = vec![0.0; TARGET_BLOCK_ROWS];
                    for block in blocks(0..part.len(), TARGET_BLOCK_ROWS) {
                        let mut j: Vec<&mut [f64]> =
                            parts.iter_mut().map(|c| &mut c[block.clone()]).collect();
                        let (j, y) = j.split_at_mut(terms.len());
                        let y = &mut *y[0];
                        let block = start + block.start..start + block.end;
                        let rows = block.clone();
                        exact_jacobian_into(design, series, &extras, &current, &terms, rows, j, y);
                        let sum = &mut sum[..block.len()];
                        linearised_target(j, &current, &scalar[block], y, sum);
                    }
                });
            };
            let mut prepared =
                self.prepare(terms.len(), 0, &fill, levels, above.as_ref(), &[&plan])?;
            let weight = levels.map_or(0.0, LevelSetup::weight);
            debug_assert!(prepared.plan(levels.is_some(), count) == plan);
            let band = prepared.band_factors(&[&plan]);
            let folds = prepared.fold_factors(&plan, weight, &band);
            let prior = self.settings.prior_weights(&terms, self.fs_hz);
            let lambda = self.settings.lambda;
            let prior = prior.as_ref();
            let chosen =
                match choose_design(&folds, &designs, &terms, lambda, weight, prior, self.fs_hz) {
                    // An exact fit that wanders off to an implausible field is not kept.
                    Err(FitError::Implausible(_)) => return Ok(None),
                    other => other?,
                };
            let level_rows = std::mem::take(&mut prepared.levels);
            self.spare.give(prepared.into_buffers());
            let step = relative_change(&beta, &chosen.solution.coefficients);
            if diverges(iteration, step, last_step) {
                return Ok(None);
            }
            beta = damped(&beta, &chosen.solution.coefficients, step);
            let settled_loser = self.settles_losing(&chosen, linear, step, last_step);
            best = Some(Exact {
                chosen,
                iterations: iteration,
                level_rows,
            });
            if step < EXACT_TOLERANCE || settled_loser {
                break;
            }
            last_step = step;
        }
        Ok(best)
    }
}

/// Rows of a Gauss-Newton fill formed at once: the block's Jacobian (16 columns, 128 KiB)
/// stays in the second-level cache until its target is formed.
const TARGET_BLOCK_ROWS: usize = 1024;

/// The Gauss-Newton target `scalar − Δ + J·β` over a block, into `y`, which holds the exact
/// correction Δ (nT); `jacobian` has one slice per coefficient of `beta`; `sum` (as long as
/// `y`) is room for `J·β`.
///
/// `J·β` is summed column after column, from the empty sum, as an iterator's `sum` over a
/// row would: the same values, from loops over the block rather than across the columns of
/// each row. Compiled also for AVX2 and AVX-512, as the Jacobian is.
#[multiversion(targets("x86_64+avx512f", "x86_64+avx2"))]
fn linearised_target(
    jacobian: &[&mut [f64]],
    beta: &[f64],
    scalar: &[f64],
    y: &mut [f64],
    sum: &mut [f64],
) {
    let empty: f64 = std::iter::empty::<f64>().sum();
    let mut columns = jacobian.iter().zip(beta);
    match columns.next() {
        // The first column's terms added to the empty sum as they are written.
        Some((column, b)) => sum
            .iter_mut()
            .zip(column.iter())
            .for_each(|(s, v)| *s = empty + v * b),
        None => sum.fill(empty),
    }
    for (column, b) in columns {
        sum.iter_mut()
            .zip(column.iter())
            .for_each(|(s, v)| *s += v * b);
    }
    for ((v, s), x) in y.iter_mut().zip(&*sum).zip(scalar) {
        *v = x - *v + s;
    }
}

/// The exact-magnitude fit: its solution, the Gauss-Newton iterations it took, and its last
/// level rows (the columns of its design's terms), which describe it rather than the linear
/// fit.
pub(super) struct Exact {
    pub(super) chosen: Chosen,
    pub(super) iterations: usize,
    pub(super) level_rows: Vec<LevelRows>,
}

/// `beta`, the coefficients of `terms`, as coefficients of `columns`: 0 for a column that is
/// none of `terms`.
pub(super) fn on_columns(columns: &[Term], terms: &[Term], beta: &[f64]) -> Vec<f64> {
    columns
        .iter()
        .map(|c| terms.iter().position(|t| t == c).map_or(0.0, |k| beta[k]))
        .collect()
}

/// The entries of `s`, whose rows and columns are `columns`, for the rows and columns
/// `terms` (zero for a term not among `columns`).
pub(super) fn on_column_pairs(columns: &[Term], terms: &[Term], s: &DMatrix<f64>) -> DMatrix<f64> {
    let at: Vec<Option<usize>> = terms
        .iter()
        .map(|t| columns.iter().position(|c| c == t))
        .collect();
    DMatrix::from_fn(terms.len(), terms.len(), |i, j| match (at[i], at[j]) {
        (Some(a), Some(b)) => s[(a, b)],
        _ => 0.0,
    })
}

impl Problem<'_, '_> {
    /// Whether the exact fit `exact`, after a Gauss-Newton step of `step` that followed one of
    /// `last_step` (relative changes of the coefficients), may stop: with the magnitude chosen
    /// by score, when the next step is expected below [`EXACT_SETTLED`] and the exact fit loses
    /// to `linear` by more than [`EXACT_CLEAR_LOSS`], no further iteration could change the
    /// choice, and the score it reports is already as good as final.
    fn settles_losing(&self, exact: &Chosen, linear: &Chosen, step: f64, last_step: f64) -> bool {
        // The first step, from the linear fit, says nothing of the rate.
        let expected = step * (step / last_step);
        self.settings.magnitude == MagnitudeChoice::Auto
            && last_step.is_finite()
            && expected < EXACT_SETTLED
            && exact.score() > linear.score() * (1.0 + EXACT_CLEAR_LOSS)
    }
}

/// One run's long-run score covariance (see [`Prepared::score_covariance`]): with `Bₖ` the
/// centred scores summed over rows `k..k+block`, `n/(block·positions)·Σₖ BₖBₖᵀ`. Block starts
/// step by an eighth of a block, which costs nothing in accuracy next to the block's own.
fn run_score_covariance(columns: &[&[f64]], residual: &[f64], block: usize) -> DMatrix<f64> {
    let (p, n) = (columns.len(), residual.len());
    let score = |c: usize, t: usize| columns[c][t] * residual[t];
    let mean: Vec<f64> = (0..p)
        .map(|c| (0..n).map(|t| score(c, t)).sum::<f64>() / n as f64)
        .collect();
    // Prefix sums of the centred scores, one row per sample.
    let mut prefix = DMatrix::zeros(n + 1, p);
    for t in 0..n {
        for c in 0..p {
            prefix[(t + 1, c)] = prefix[(t, c)] + score(c, t) - mean[c];
        }
    }
    let step = (block / 8).max(1);
    let mut sum = DMatrix::zeros(p, p);
    let mut positions = 0usize;
    for k in (0..=n - block).step_by(step) {
        let b = (prefix.row(k + block) - prefix.row(k)).transpose();
        sum.ger(1.0, &b, &b, 1.0);
        positions += 1;
    }
    sum * (n as f64 / (block as f64 * positions as f64))
}

/// Subtracts the mean: a run's intercept, for a target that has no filter to remove it.
fn remove_mean(x: &mut [f64]) {
    let mean = x.iter().sum::<f64>() / x.len().max(1) as f64;
    x.iter_mut().for_each(|v| *v -= mean);
}

/// `‖a − b‖ / ‖b‖`.
/// Largest relative change of the coefficients one Gauss-Newton step may make: the magnitude
/// is nearly linear in them, so a good step moves them by about |H|/|B|, a percent or less; a
/// larger one is a linearisation that does not hold, and is taken only this far (a trust
/// region).
const EXACT_MAX_STEP: f64 = 0.5;

/// Step size above which a step that fails to shrink is divergence rather than rounding.
const EXACT_DIVERGING_STEP: f64 = 1e-6;

/// Whether Gauss-Newton diverges: from its second step on, each step must shrink (the
/// iterations converge linearly), and none may be infinite or NaN. A diverging exact fit falls
/// back to the linear one.
fn diverges(iteration: usize, step: f64, last_step: f64) -> bool {
    !step.is_finite() || (iteration > 1 && step > last_step && step > EXACT_DIVERGING_STEP)
}

/// The next linearisation point: `proposed`, or the way towards it from `current` cut to
/// [`EXACT_MAX_STEP`] when the step (`step`, relative) is longer.
fn damped(current: &[f64], proposed: &[f64], step: f64) -> Vec<f64> {
    if step <= EXACT_MAX_STEP {
        return proposed.to_vec();
    }
    let t = EXACT_MAX_STEP / step;
    current
        .iter()
        .zip(proposed)
        .map(|(c, p)| c + t * (p - c))
        .collect()
}

fn relative_change(a: &[f64], b: &[f64]) -> f64 {
    let diff: f64 = a.iter().zip(b).map(|(x, y)| (x - y).powi(2)).sum();
    let size: f64 = b.iter().map(|y| y * y).sum();
    (diff / size.max(f64::MIN_POSITIVE)).sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gauss_newton_steps_are_cut_to_the_trust_region_and_divergence_is_caught() {
        let current = [1.0, 0.0];
        assert_eq!(damped(&current, &[1.01, 0.0], 0.01), vec![1.01, 0.0]);
        let far = damped(&current, &[3.0, 0.0], 2.0);
        assert!((far[0] - 1.5).abs() < 1e-12, "{far:?}");
        assert!(!diverges(1, 0.3, f64::INFINITY));
        assert!(!diverges(3, 1e-3, 1e-2));
        assert!(diverges(3, 1e-2, 1e-3));
        assert!(!diverges(3, 2e-9, 1e-9), "rounding is not divergence");
        assert!(diverges(1, f64::NAN, f64::INFINITY));
    }
    use crate::fit::ridge::Ridge;

    #[test]
    fn coefficients_go_to_the_columns_of_their_terms() {
        use crate::model::terms::{Axis, Column};
        let term = |column| Term {
            fluxgate: 0,
            column,
        };
        let (x, y, z) = (
            term(Column::Permanent(Axis::X)),
            term(Column::Permanent(Axis::Y)),
            term(Column::Permanent(Axis::Z)),
        );
        assert_eq!(
            on_columns(&[x, y, z], &[z, x], &[3.0, 1.0]),
            [1.0, 0.0, 3.0]
        );
    }

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
