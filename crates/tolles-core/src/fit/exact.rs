//! The exact magnitude's fit: Gauss-Newton from the linear solution, each step's rows the
//! Jacobian of `|B + H|` and the linearised target, cut to a trust region and stopped when it
//! settles or diverges.

use super::choice::{choose_design, Chosen};
use super::error::FitError;
use super::level_rows::LevelRows;
use super::level_setup::LevelSetup;
use super::problem::*;
use super::settings::MagnitudeChoice;
use crate::model::design::Design;
use crate::model::magnitude::exact_jacobian_into;
use crate::parallel::{blocks, split_rows};
use multiversion::multiversion;
use std::ops::Range;

/// Gauss-Newton iterations of the exact fit at most.
const EXACT_ITERATIONS: usize = 8;

/// Relative change of the coefficients below which the exact fit has converged.
const EXACT_TOLERANCE: f64 = 1e-7;

/// Relative change of the coefficients the next Gauss-Newton iteration is expected to make
/// (the last step times the last ratio of steps: the iterations converge linearly) below which
/// an exact fit that clearly loses to the linear one is not refined further: what it reports,
/// its score, would move by about as little.
const EXACT_SETTLED: f64 = 1e-9;

/// Relative margin by which the exact fit's score must exceed the linear fit's to lose
/// clearly: far more than a settled fit's score can still move.
const EXACT_CLEAR_LOSS: f64 = 1e-3;

impl Problem<'_, '_> {
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
        // does not carry over to other headings). Where a current switches every few seconds
        // the exact fit would be the better one (bench/verdict's 420 nT cabin with 5 nT/A:
        // 0.357 → 0.013 nT; the realistic preset 1.21 → 1.06 nT), but tests/strobe.rs's
        // toggles every 0.25–0.5 s then leave 5× the current-off error: the choice between
        // them is not yet one cross-validation can make, so `auto` keeps them linear and the
        // verdict says what that leaves out; `--magnitude exact` fits them exactly.
        let extras_linear =
            !design.extras.is_empty() && self.settings.magnitude == MagnitudeChoice::Auto;
        if self.settings.magnitude == MagnitudeChoice::Linear
            || design.fluxgates != 1
            || extras_linear
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
            let prior = self.prior_weights(&terms);
            let lambda = self.settings.lambda;
            let prior = prior.as_ref();
            let chosen =
                match choose_design(&folds, &designs, &terms, lambda, weight, prior, self.fs_hz) {
                    // An exact fit that wanders off to an implausible field is not kept.
                    Err(FitError::Implausible(_)) => return Ok(None),
                    other => other?,
                };
            let level_rows = std::mem::take(&mut prepared.levels);
            let step = relative_change(&beta, &chosen.solution.coefficients);
            let settled_loser = self.settles_losing(&chosen, linear, step, last_step);
            let last = step < EXACT_TOLERANCE || settled_loser || iteration == EXACT_ITERATIONS;
            // The scores of the exact fit's own residual, of the iteration kept: the linear
            // fit's, 13× larger on a heavy cabin, made each row's σ 25× its error
            // (bench/installations 11 and 12).
            let (band_scores, above_rss) = match last {
                true => {
                    let beta = &chosen.solution.coefficients;
                    let block = super::diagnostics::score_block(self.settings, self.fs_hz);
                    let scores = prepared.score_covariance(beta, block);
                    (scores, prepared.above_residual(beta).0)
                }
                false => (None, 0.0),
            };
            self.spare.give(prepared.into_buffers());
            if diverges(iteration, step, last_step) {
                return Ok(None);
            }
            beta = damped(&beta, &chosen.solution.coefficients, step);
            best = Some(Exact {
                chosen,
                iterations: iteration,
                level_rows,
                band_scores,
                above_rss,
            });
            if last {
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
    /// The long-run covariance of its band rows' scores (its design's terms), `None` when a
    /// run was done in windows (see [`Prepared::score_covariance`]).
    pub(super) band_scores: Option<nalgebra::DMatrix<f64>>,
    /// Its residual sum of squares over the rows above the band (nT²; extra channels).
    pub(super) above_rss: f64,
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
}
