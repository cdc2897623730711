//! One calibration flight cut into runs, and the rows a fit solves: band-passed design rows,
//! interleaved level rows, and the Gauss-Newton rows of the exact magnitude.

use super::choice::{choose_design, Chosen};
use super::levels::{self, LevelDiagnostics, LevelRows, LowFrequency, Reference};
use super::{FitError, FitSettings, MagnitudeChoice, Target, EXACT_ITERATIONS, EXACT_TOLERANCE};
use crate::model::design::Design;
use crate::model::magnitude::exact_jacobian;
use crate::model::vector::Fluxgates;
use crate::signal::filter::Butterworth;
use nalgebra::DMatrix;
use std::ops::Range;

/// Filtered, trimmed design rows and their scalar targets.
pub(super) type Rows = (DMatrix<f64>, Vec<f64>);

/// `a − b`, element by element.
pub(super) fn difference(a: &[f64], b: &[f64]) -> Vec<f64> {
    a.iter().zip(b).map(|(x, y)| x - y).collect()
}

/// Unfiltered design columns, band target and level target of one run.
pub(super) type RunInputs = (DMatrix<f64>, Vec<f64>, Vec<f64>);

/// Makes a run's [`RunInputs`] from its sample range and its stretch of the reference.
pub(super) type MakeRun<'m> = dyn Fn(Range<usize>, Option<&[f64]>) -> RunInputs + 'm;

/// One calibration flight, cut into runs, and how to fit it.
pub(super) struct Problem<'p, 'a> {
    pub(super) scalar: &'p [f64],
    pub(super) flux: &'p Fluxgates<'a>,
    pub(super) runs: Vec<Range<usize>>,
    pub(super) filter: Option<Butterworth>,
    pub(super) above: Option<AboveBand>,
    pub(super) settings: &'p FitSettings,
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
    /// The same rows for a design of `width` columns without extra channels: every column
    /// zeroed, so the rows stay part of the score (as they were for the linear fit it is
    /// compared with) but explain nothing.
    fn without_extras(&self, width: usize) -> AboveBand {
        AboveBand {
            filter: self.filter.clone(),
            extra: vec![false; width],
        }
    }

    /// A run's rows above the band from its unfiltered columns and target, trimmed.
    fn rows(&self, a: &DMatrix<f64>, y: &[f64], trim: usize) -> Result<Rows, FitError> {
        let n = y.len();
        let mut a = a.clone();
        let mut y = y.to_vec();
        for (c, keep) in self.extra.iter().enumerate() {
            if !keep {
                a.column_mut(c).fill(0.0);
            }
        }
        let mut signals: Vec<&mut [f64]> = a.as_mut_slice().chunks_mut(n).collect();
        signals.push(&mut y);
        crate::signal::filter::filtfilt_many_unless_constant(&self.filter, &mut signals)?;
        Ok((
            a.rows(trim, n - 2 * trim).into_owned(),
            y[trim..n - trim].to_vec(),
        ))
    }
}

/// Merges a run's rows (with their level mask) and its rows above the band by their
/// position in the run, so contiguous cross-validation folds take both from the same
/// stretch of time. Rows above the band are not level rows.
fn merge_by_position(
    (a, y, mask): (DMatrix<f64>, Vec<f64>, Vec<bool>),
    (above_a, above_y): Rows,
) -> (DMatrix<f64>, Vec<f64>, Vec<bool>) {
    let (n1, n2) = (y.len(), above_y.len());
    let position = |k: usize, n: usize| (2 * k + 1) as f64 / (2 * n) as f64;
    let mut order: Vec<(f64, bool, usize)> = (0..n1).map(|k| (position(k, n1), false, k)).collect();
    order.extend((0..n2).map(|k| (position(k, n2), true, k)));
    order.sort_by(|p, q| p.0.total_cmp(&q.0).then(p.1.cmp(&q.1)));
    let mut out = DMatrix::zeros(n1 + n2, a.ncols());
    let mut target = Vec::with_capacity(n1 + n2);
    let mut merged_mask = Vec::with_capacity(n1 + n2);
    for (row, &(_, is_above, k)) in order.iter().enumerate() {
        let (source, value, level) = if is_above {
            (&above_a, above_y[k], false)
        } else {
            (&a, y[k], mask.get(k).copied().unwrap_or(false))
        };
        out.row_mut(row).copy_from(&source.row(k));
        target.push(value);
        merged_mask.push(level);
    }
    (out, target, merged_mask)
}

/// Rows of every run ready for the folds, and the level rows they hold.
pub(super) struct Prepared {
    pub(super) rows: Vec<Rows>,
    /// Per run, which rows are (weighted) level rows; empty without levels.
    pub(super) masks: Vec<Vec<bool>>,
    /// The level rows' weight (0 without levels).
    pub(super) weight: f64,
    pub(super) levels: Vec<LevelRows>,
    pub(super) short: usize,
}

/// What the heading levels need: the reference, the low-pass, and the weight of their rows.
pub(super) struct LevelSetup {
    pub(super) reference: Reference,
    pub(super) low: LowFrequency,
    /// Expected scatter of a level row (nT).
    pub(super) sigma_nt: f64,
    /// Scatter of a band row (nT).
    pub(super) band_sigma_nt: f64,
    /// Level rows of the last preparation (centred, unweighted), to measure the misfit.
    pub(super) rows: Vec<LevelRows>,
}

impl LevelSetup {
    pub(super) fn weight(&self) -> f64 {
        self.band_sigma_nt / self.sigma_nt
    }

    pub(super) fn row_count(&self) -> usize {
        self.rows.iter().map(|r| r.y.len()).sum()
    }

    /// The level rows' residual sum of squares as the solve saw it, weighted (nT²).
    pub(super) fn weighted_rss(&self, beta: &[f64]) -> f64 {
        let misfit = levels::rms_misfit(&self.rows, beta);
        let count = self.row_count();
        if count == 0 {
            return 0.0;
        }
        (self.weight() * misfit).powi(2) * count as f64
    }

    pub(super) fn diagnostics(&self, beta: &[f64]) -> LevelDiagnostics {
        let count = self.row_count();
        let misfit = levels::rms_misfit(&self.rows, beta);
        LevelDiagnostics {
            fluxgate: self.reference.calibration.clone(),
            rows: count,
            cutoff_hz: self.low.cutoff_hz,
            residual_rms_nt: misfit,
            level_std_error_nt: misfit / (count as f64 / 4.0).max(1.0).sqrt(),
            weight: self.weight(),
        }
    }
}

impl Problem<'_, '_> {
    /// Band rows (and, with `levels`, interleaved level rows; with extra channels, rows
    /// above the band) of every run long enough.
    pub(super) fn rows(
        &self,
        make: &MakeRun<'_>,
        levels: Option<&LevelSetup>,
    ) -> Result<Prepared, FitError> {
        self.rows_with(make, levels, self.above.as_ref())
    }

    fn rows_with(
        &self,
        make: &MakeRun<'_>,
        levels: Option<&LevelSetup>,
        above_band: Option<&AboveBand>,
    ) -> Result<Prepared, FitError> {
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
        let mut band = Vec::new();
        let mut level_rows = Vec::new();
        let mut above_rows = Vec::new();
        let mut short = 0;
        for run in &self.runs {
            if run.len() < needed {
                short += run.len();
                continue;
            }
            let reference = levels.map(|l| levels::reference_over(&l.reference, run.clone()));
            let (mut a, mut y, level_target) = make(run.clone(), reference);
            if let Some(above) = above_band {
                above_rows.push(above.rows(&a, &y, trim)?);
            }
            if let Some(setup) = levels {
                level_rows.push(setup.low.rows(a.clone(), level_target)?);
            }
            let n = y.len();
            let mut signals: Vec<&mut [f64]> = a.as_mut_slice().chunks_mut(n).collect();
            signals.push(&mut y);
            if let Some(f) = &self.filter {
                crate::signal::filter::filtfilt_many_unless_constant(f, &mut signals)?;
            } else if self.settings.target == Target::Interference {
                signals.iter_mut().for_each(|s| remove_mean(s));
            }
            band.push((
                a.rows(trim, n - 2 * trim).into_owned(),
                y[trim..n - trim].to_vec(),
            ));
        }
        let Some(setup) = levels else {
            let (rows, _) = with_above(band_without_levels(band), above_rows);
            return Ok(Prepared {
                rows,
                masks: Vec::new(),
                weight: 0.0,
                levels: Vec::new(),
                short,
            });
        };
        levels::centre(&mut level_rows);
        let weight = setup.weight();
        let interleaved = band
            .into_iter()
            .zip(&level_rows)
            .map(|(b, l)| levels::interleave(b, trim, l, weight))
            .collect();
        let (rows, masks) = with_above(interleaved, above_rows);
        Ok(Prepared {
            rows,
            masks,
            weight,
            levels: level_rows,
            short,
        })
    }

    /// The reference and low-pass for heading levels, when the settings ask for them and the
    /// fluxgate can be calibrated.
    pub(super) fn level_setup(
        &self,
        usable: &[bool],
        fs_hz: f64,
        tt: Option<&[f64]>,
    ) -> Result<Option<LevelSetup>, FitError> {
        let s = self.settings;
        if !s.levels || s.target == Target::Interference || self.flux.count() != 1 {
            return Ok(None);
        }
        let Some(low) = LowFrequency::new(s.band, s.order, s.trim, fs_hz)? else {
            return Ok(None);
        };
        let Some(reference) = levels::reference(self.flux.series()[0], usable, fs_hz, tt, s) else {
            return Ok(None);
        };
        // White noise of the reference, seen through the low-pass instead of the band.
        let width = (s.band.pass2_hz.min(fs_hz / 2.0) - s.band.pass1_hz).max(low.cutoff_hz);
        let sigma_nt =
            (reference.calibration.residual_std_nt * (low.cutoff_hz / width).sqrt()).max(1e-3);
        Ok(Some(LevelSetup {
            reference,
            low,
            sigma_nt,
            band_sigma_nt: f64::NAN,
            rows: Vec::new(),
        }))
    }

    /// Refits with the level rows: first weighted by the reference's expected noise, then, if
    /// the rows scatter more than that about the fit, once more with their measured scatter.
    pub(super) fn choose_with_levels(
        &self,
        setup: &mut LevelSetup,
        band_only: &Chosen,
        solve: impl Fn(&LevelSetup) -> Result<(Chosen, Vec<LevelRows>), FitError>,
    ) -> Result<Chosen, FitError> {
        let s = &band_only.solution;
        setup.band_sigma_nt = (s.rss / s.rows.max(1) as f64).sqrt().max(1e-6);
        let (mut chosen, rows) = solve(setup)?;
        setup.rows = rows;
        let misfit = levels::rms_misfit(&setup.rows, &chosen.solution.coefficients);
        if misfit > 1.5 * setup.sigma_nt {
            setup.sigma_nt = misfit;
            let (again, rows) = solve(setup)?;
            chosen = again;
            setup.rows = rows;
        }
        Ok(chosen)
    }

    /// The exact-magnitude fit of `design` by Gauss-Newton from the linear solution, when the
    /// settings ask for it and the design has one fluxgate.
    pub(super) fn exact(
        &self,
        design: &Design,
        linear: &Chosen,
        mut levels: Option<&mut LevelSetup>,
    ) -> Result<Option<(Chosen, usize)>, FitError> {
        // Extra channels and several fluxgates stay linear.
        if self.settings.magnitude == MagnitudeChoice::Linear
            || design.fluxgates != 1
            || !design.extras.is_empty()
        {
            return Ok(None);
        }
        let terms = design.design_terms();
        let above = self.above.as_ref().map(|a| a.without_extras(terms.len()));
        let designs = [design.clone()];
        let series = self.flux.series()[0];
        let mut beta = linear.solution.coefficients.clone();
        let mut best: Option<Chosen> = None;
        for iteration in 1..=EXACT_ITERATIONS {
            let current = beta.clone();
            let make = |run: Range<usize>, reference: Option<&[f64]>| {
                let (delta, j) =
                    exact_jacobian(design, &series.slice(run.clone()), &current, &terms);
                let linearised = &j * nalgebra::DVector::from_column_slice(&current);
                let y: Vec<f64> = (0..run.len())
                    .map(|k| self.scalar[run.start + k] - delta[k] + linearised[k])
                    .collect();
                let level = reference.map_or_else(Vec::new, |r| difference(&y, r));
                (j, y, level)
            };
            let prepared = self.rows_with(&make, levels.as_deref(), above.as_ref())?;
            let chosen = choose_design(&prepared, &designs, &terms, self.settings.lambda)?;
            if let Some(setup) = levels.as_deref_mut() {
                setup.rows = prepared.levels;
            }
            let step = relative_change(&beta, &chosen.solution.coefficients);
            beta = chosen.solution.coefficients.clone();
            best = Some(chosen);
            if step < EXACT_TOLERANCE {
                return Ok(best.map(|b| (b, iteration)));
            }
        }
        Ok(best.map(|b| (b, EXACT_ITERATIONS)))
    }
}

/// Band rows with an empty level mask.
fn band_without_levels(band: Vec<Rows>) -> Vec<(DMatrix<f64>, Vec<f64>, Vec<bool>)> {
    band.into_iter().map(|(a, y)| (a, y, Vec::new())).collect()
}

/// Each run's rows with its rows above the band merged in (none without extra channels),
/// split into rows and level masks.
fn with_above(
    runs: Vec<(DMatrix<f64>, Vec<f64>, Vec<bool>)>,
    above: Vec<Rows>,
) -> (Vec<Rows>, Vec<Vec<bool>>) {
    let mut above = above.into_iter();
    runs.into_iter()
        .map(|run| match above.next() {
            Some(extra) => merge_by_position(run, extra),
            None => run,
        })
        .map(|(a, y, mask)| ((a, y), mask))
        .unzip()
}

/// Subtracts the mean: a run's intercept, for a target that has no filter to remove it.
fn remove_mean(x: &mut [f64]) {
    let mean = x.iter().sum::<f64>() / x.len().max(1) as f64;
    x.iter_mut().for_each(|v| *v -= mean);
}

/// `‖a − b‖ / ‖b‖`.
fn relative_change(a: &[f64], b: &[f64]) -> f64 {
    let diff: f64 = a.iter().zip(b).map(|(x, y)| (x - y).powi(2)).sum();
    let size: f64 = b.iter().map(|y| y * y).sum();
    (diff / size.max(f64::MIN_POSITIVE)).sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rows_above_the_band_are_merged_in_time_order_and_are_not_level_rows() {
        // Four band rows (the second a level row) and two rows above the band.
        let band = (
            DMatrix::from_column_slice(4, 1, &[1.0, 2.0, 3.0, 4.0]),
            vec![10.0, 20.0, 30.0, 40.0],
            vec![false, true, false, false],
        );
        let above = (
            DMatrix::from_column_slice(2, 1, &[-1.0, -2.0]),
            vec![-10.0, -20.0],
        );
        let (a, y, mask) = merge_by_position(band, above);
        // Positions in the run: band 1/8, 3/8, 5/8, 7/8; above 1/4, 3/4.
        assert_eq!(y, [10.0, -10.0, 20.0, 30.0, -20.0, 40.0]);
        assert_eq!(a.column(0).as_slice(), [1.0, -1.0, 2.0, 3.0, -2.0, 4.0]);
        assert_eq!(mask, [false, false, true, false, false, false]);
    }

    #[test]
    fn a_run_mean_is_removed_for_an_interference_target() {
        let mut x = [1.0, 2.0, 6.0];
        remove_mean(&mut x);
        assert_eq!(x, [-2.0, -1.0, 3.0]);
    }
}
