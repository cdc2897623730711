//! Choosing the ridge strength by blocked cross-validation over time.
//!
//! ```
//! use nalgebra::DMatrix;
//! use tolles_core::fit::crossval::{cross_validate, LAMBDA_GRID};
//! use tolles_core::fit::ridge::Ridge;
//!
//! // Five contiguous folds of a noiseless problem y = 2·a: no ridge is best.
//! let folds: Vec<Ridge> = (0..5)
//!     .map(|f| {
//!         let mut r = Ridge::new(1);
//!         for k in 0..50 {
//!             let a = ((f * 50 + k) as f64 * 0.3).sin();
//!             r.push_row([a], 2.0 * a);
//!         }
//!         r
//!     })
//!     .collect();
//! let cv = cross_validate(&folds, &LAMBDA_GRID, &[], &[]).unwrap();
//! assert_eq!(cv.chosen_lambda_rel, 0.0);
//! ```
//!
//! The filtered calibration rows are cut into `folds` contiguous blocks in time (never random
//! samples: neighbouring samples of a band-passed signal are strongly correlated, and a random
//! split would let the fit see its own test data). For each candidate relative strength
//! `λ_rel`, each fold is predicted by a fit on the other folds with the penalty
//! `λ_rel·diag(AᵀA)`, i.e. a ridge on standardised columns, so one grid suits every term set,
//! sample rate and flight length. The candidate with the smallest held-out RMS wins; that RMS is
//! what a user should expect of the model on data it has not seen.

use crate::fit::ridge::Ridge;
use serde::{Deserialize, Serialize};

/// Candidate relative ridge strengths.
pub const LAMBDA_GRID: [f64; 9] = [0.0, 1e-8, 1e-7, 1e-6, 1e-5, 1e-4, 1e-3, 1e-2, 1e-1];

/// Default number of contiguous folds.
pub const DEFAULT_FOLDS: usize = 5;

/// Multiples of a prior's penalty (see [`crate::fit::prior`]) that cross-validation chooses
/// between when a fit has a prior: from a tenth of the prior's own strength, for flights that
/// determine every term, to a millionfold, for flights whose residual is mostly not noise.
pub const PRIOR_GRID: [f64; 8] = [1.0, 10.0, 1e2, 1e3, 1e4, 1e5, 1e6, 1e7];

/// The held-out error of one candidate.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct CvPoint {
    /// Relative ridge strength (dimensionless; penalty `λ_rel·diag(AᵀA)`).
    pub lambda_rel: f64,
    /// With a prior: the multiple of the prior's penalty (dimensionless).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub prior_multiplier: Option<f64>,
    /// RMS of the held-out filtered residuals (nT); `None` when a fold could not be solved.
    pub heldout_rms_nt: Option<f64>,
}

/// The outcome of cross-validation.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CrossValidation {
    /// Number of contiguous folds.
    pub folds: usize,
    /// Every candidate and its held-out error.
    pub grid: Vec<CvPoint>,
    /// The chosen relative strength.
    pub chosen_lambda_rel: f64,
    /// With a prior: the chosen multiple of its penalty common to every term.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub chosen_prior_multiplier: Option<f64>,
    /// With a prior: the multiple of its penalty each column ended with, its group's (see
    /// [`crate::fit::prior::Group`]); empty when every column has the common one.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub prior_multipliers: Vec<f64>,
    /// Held-out RMS of the chosen strength (nT): the filtered residual to expect on new data.
    pub expected_heldout_rms_nt: f64,
}

impl CrossValidation {
    /// The chosen candidate's penalty, given the columns' sums of squares and the prior's
    /// penalty at a multiple of one (empty without a prior).
    pub fn chosen_penalty(&self, sums_of_squares: &[f64], prior: &[f64]) -> Vec<f64> {
        penalty(
            self.chosen_lambda_rel,
            sums_of_squares,
            &self.chosen_prior(prior),
        )
    }

    /// The prior's part of the chosen penalty.
    pub fn chosen_prior(&self, prior: &[f64]) -> Vec<f64> {
        if self.prior_multipliers.len() == prior.len() {
            return prior
                .iter()
                .zip(&self.prior_multipliers)
                .map(|(p, m)| p * m)
                .collect();
        }
        scaled(prior, self.chosen_prior_multiplier)
    }
}

fn scaled(prior: &[f64], multiplier: Option<f64>) -> Vec<f64> {
    let m = multiplier.unwrap_or(1.0);
    prior.iter().map(|p| p * m).collect()
}

/// The ridge on standardised columns kept under a prior: far too weak to shrink anything the
/// data determine, it bounds the condition number where neither the data nor the prior hold a
/// direction, so that rounding does not decide it.
pub const CONDITIONING_LAMBDA_REL: f64 = 1e-9;

/// Smallest column scale, relative to the largest, used in the penalty: a column with no signal
/// at all on a flight (say, a fluxgate axis that never changes) then gets a coefficient of zero
/// instead of making the problem singular.
const SCALE_FLOOR: f64 = 1e-12;

/// The diagonal penalty for relative strength `lambda_rel` given the columns' sums of squares,
/// plus `prior` (one value per column, or empty for none; see [`crate::fit::prior`]).
pub fn penalty(lambda_rel: f64, sums_of_squares: &[f64], prior: &[f64]) -> Vec<f64> {
    let largest = sums_of_squares.iter().fold(0.0f64, |m, s| m.max(*s));
    sums_of_squares
        .iter()
        .enumerate()
        .map(|(j, s)| lambda_rel * s.max(SCALE_FLOOR * largest) + prior.get(j).unwrap_or(&0.0))
        .collect()
}

/// Cross-validates `grid` over `folds` (each a problem holding one block of rows), every
/// penalty with `prior` added (see [`penalty`]). `None` when no candidate could be solved on
/// every fold.
pub fn cross_validate(
    folds: &[Ridge],
    grid: &[f64],
    columns: &[String],
    prior: &[f64],
) -> Option<CrossValidation> {
    let points = grid.iter().map(|&lambda_rel| CvPoint {
        lambda_rel,
        prior_multiplier: None,
        heldout_rms_nt: None,
    });
    validate(folds, points.collect(), columns, prior, false)
}

/// Cross-validates multiples `grid` of the prior's penalty `prior`, over `folds`, with only
/// [`CONDITIONING_LAMBDA_REL`] of a ridge on standardised columns. `None` when no candidate
/// could be solved on every fold.
///
/// `parsimonious` (for a calibration whose maneuvers do not separate the terms): the strongest
/// multiple the folds cannot tell from the best (the "one standard error" rule).
pub fn cross_validate_prior(
    folds: &[Ridge],
    grid: &[f64],
    columns: &[String],
    prior: &[f64],
    parsimonious: bool,
) -> Option<CrossValidation> {
    let points = grid.iter().map(|&m| CvPoint {
        lambda_rel: CONDITIONING_LAMBDA_REL,
        prior_multiplier: Some(m),
        heldout_rms_nt: None,
    });
    validate(folds, points.collect(), columns, prior, parsimonious)
}

/// Scores every point and keeps the best or, `parsimonious`, the most regularised one the
/// folds cannot tell from the best (see [`indistinguishable`]); `points` go from the weakest
/// penalty to the strongest.
fn validate(
    folds: &[Ridge],
    mut points: Vec<CvPoint>,
    columns: &[String],
    prior: &[f64],
    parsimonious: bool,
) -> Option<CrossValidation> {
    let sizes: Vec<usize> = folds.iter().map(Ridge::rows).collect();
    let rows: usize = sizes.iter().sum();
    let mut per_fold = Vec::with_capacity(points.len());
    for p in points.iter_mut() {
        let prior = scaled(prior, p.prior_multiplier);
        let sums = heldout_fold_sums(folds, folds, p.lambda_rel, columns, &prior);
        p.heldout_rms_nt = sums
            .as_ref()
            .map(|s| (s.iter().sum::<f64>() / rows as f64).sqrt());
        per_fold.push(sums);
    }
    let (best_at, _) = points
        .iter()
        .enumerate()
        .filter_map(|(k, p)| p.heldout_rms_nt.map(|rms| (k, rms)))
        .min_by(|a, b| a.1.total_cmp(&b.1))?;
    let chosen = match parsimonious {
        false => best_at,
        true => (best_at..points.len())
            .rev()
            .find(|&k| match (&per_fold[k], &per_fold[best_at]) {
                (Some(a), Some(b)) => indistinguishable(a, b, &sizes),
                _ => false,
            })
            .unwrap_or(best_at),
    };
    let best = (&points[chosen], points[chosen].heldout_rms_nt?);
    Some(CrossValidation {
        folds: folds.len(),
        chosen_lambda_rel: best.0.lambda_rel,
        chosen_prior_multiplier: best.0.prior_multiplier,
        prior_multipliers: Vec::new(),
        expected_heldout_rms_nt: best.1,
        grid: points.clone(),
    })
}

/// Factors by which one group's multiple of the prior is moved from the common one, in turn.
const GROUP_FACTORS: [f64; 6] = [1e-3, 1e-2, 0.1, 10.0, 1e2, 1e3];

/// [`cross_validate_prior`], then each group's multiple moved on its own (`groups` gives each
/// column's group, `None` for a column without a prior): a move is kept when it predicts the
/// held-out rows better, one group after another; `parsimonious`, a move to a weaker multiple
/// must predict better by more than the folds can tell.
pub fn cross_validate_prior_groups<G: PartialEq + Copy>(
    folds: &[Ridge],
    grid: &[f64],
    columns: &[String],
    prior: &[f64],
    groups: &[Option<G>],
    parsimonious: bool,
) -> Option<CrossValidation> {
    let mut cv = cross_validate_prior(folds, grid, columns, prior, parsimonious)?;
    let common = cv.chosen_prior_multiplier.unwrap_or(1.0);
    let mut distinct: Vec<G> = Vec::new();
    groups.iter().flatten().for_each(|g| {
        if !distinct.contains(g) {
            distinct.push(*g);
        }
    });
    if distinct.len() < 2 {
        return Some(cv);
    }
    let sizes: Vec<usize> = folds.iter().map(Ridge::rows).collect();
    let rows: usize = sizes.iter().sum();
    let lambda_rel = cv.chosen_lambda_rel;
    let score = |multipliers: &[f64]| {
        let penalty: Vec<f64> = prior.iter().zip(multipliers).map(|(p, m)| p * m).collect();
        heldout_fold_sums(folds, folds, lambda_rel, columns, &penalty)
    };
    let mut multipliers = vec![common; prior.len()];
    let mut best = score(&multipliers)?;
    for group in distinct {
        let start = multipliers.clone();
        for factor in GROUP_FACTORS {
            let mut trial = start.clone();
            groups
                .iter()
                .zip(trial.iter_mut())
                .filter(|(g, _)| **g == Some(group))
                .for_each(|(_, m)| *m = (common * factor).max(1.0));
            let Some(sums) = score(&trial) else { continue };
            let lower = sums.iter().sum::<f64>() < best.iter().sum::<f64>();
            let better = match parsimonious && factor < 1.0 {
                true => lower && !indistinguishable(&best, &sums, &sizes),
                false => lower,
            };
            if better {
                best = sums;
                multipliers = trial;
            }
        }
    }
    cv.expected_heldout_rms_nt = (best.iter().sum::<f64>() / rows as f64).sqrt();
    cv.prior_multipliers = multipliers;
    Some(cv)
}

/// Whether a candidate whose folds' held-out sums of squares are `candidate` predicts no worse
/// than the best one's, `best`, by what the folds can tell: the mean over folds of the
/// difference of their mean squares (nT²) is within one standard error of that mean. Folds of
/// one flight differ in difficulty, so the difference is taken fold by fold (a paired test).
/// A more strongly regularised candidate that passes is the "one standard error" choice: the
/// calibration cannot show it worse, and on other attitudes it extrapolates less (MagNav's
/// real snippet, 46 s without maneuvers: the weakest prior the folds liked left 0.205 nT on the
/// flight's other half, where the raw band held 0.136 nT).
fn indistinguishable(candidate: &[f64], best: &[f64], sizes: &[usize]) -> bool {
    let k = candidate.len();
    if k < 2 || best.len() != k {
        return candidate == best;
    }
    let d: Vec<f64> = (0..k)
        .map(|f| (candidate[f] - best[f]) / sizes[f].max(1) as f64)
        .collect();
    let mean = d.iter().sum::<f64>() / k as f64;
    let var = d.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (k - 1) as f64;
    mean <= (var / k as f64).sqrt()
}

/// Sum over k of the squared residuals on `tests[k]` of a fit on every fold but `folds[k]`
/// with the relative penalty `lambda_rel` and `prior`; `tests` holds one problem per fold (for
/// example a subset of each fold's rows). `None` when a training set cannot be solved.
pub fn heldout_sum_of_squares_on(
    folds: &[Ridge],
    tests: &[Ridge],
    lambda_rel: f64,
    columns: &[String],
    prior: &[f64],
) -> Option<f64> {
    heldout_fold_sums(folds, tests, lambda_rel, columns, prior).map(|s| s.iter().sum())
}

/// The terms of [`heldout_sum_of_squares_on`], fold by fold.
fn heldout_fold_sums(
    folds: &[Ridge],
    tests: &[Ridge],
    lambda_rel: f64,
    columns: &[String],
    prior: &[f64],
) -> Option<Vec<f64>> {
    let mut sums = Vec::with_capacity(tests.len());
    for (k, test) in tests.iter().enumerate() {
        let mut train: Option<Ridge> = None;
        for (_, fold) in folds.iter().enumerate().filter(|(j, _)| *j != k) {
            match train.as_mut() {
                Some(t) => t.merge(fold),
                None => train = Some(fold.clone()),
            }
        }
        let train = train?;
        let weights = penalty(lambda_rel, &train.column_sums_of_squares(), prior);
        let beta = train.solve_penalised(&weights, columns).ok()?.coefficients;
        sums.push(test.residual_sum_of_squares(&beta));
    }
    sums.iter().all(|s| s.is_finite()).then_some(sums)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_difference_within_one_standard_error_of_the_folds_is_no_difference() {
        let sizes = [100; 5];
        let best = [10.0, 20.0, 30.0, 40.0, 50.0];
        // Worse on every fold by the same amount: a clear difference.
        let worse: Vec<f64> = best.iter().map(|b| b + 1.0).collect();
        assert!(!indistinguishable(&worse, &best, &sizes));
        // Worse on average by less than the folds' scatter of the difference.
        let noisy = [11.0, 19.0, 31.0, 39.5, 51.0];
        assert!(indistinguishable(&noisy, &best, &sizes));
        assert!(indistinguishable(&best, &best, &sizes));
    }

    #[test]
    fn parsimony_takes_the_strongest_prior_the_folds_cannot_refuse() {
        // y = a + noise: a prior on the one coefficient only shrinks it, so the weakest is
        // best; the strongest that the folds cannot tell from it is kept when parsimonious.
        let folds: Vec<Ridge> = (0..5)
            .map(|f| {
                let mut r = Ridge::new(1);
                for k in 0..40 {
                    let t = (f * 40 + k) as f64;
                    let a = (t * 0.37).sin();
                    r.push_row([a], 0.15 * a + (t * 1.7).cos());
                }
                r
            })
            .collect();
        let prior = [1.0];
        let grid = [1e-3, 1.0, 3.0, 10.0, 30.0, 100.0, 1e3];
        let best = cross_validate_prior(&folds, &grid, &[], &prior, false).unwrap();
        let simple = cross_validate_prior(&folds, &grid, &[], &prior, true).unwrap();
        let m = |cv: &CrossValidation| cv.chosen_prior_multiplier.unwrap();
        eprintln!("best ×{}, parsimonious ×{}", m(&best), m(&simple));
        assert!(m(&simple) > m(&best));
        assert!(simple.expected_heldout_rms_nt >= best.expected_heldout_rms_nt);
    }
}
