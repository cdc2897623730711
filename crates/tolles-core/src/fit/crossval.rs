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
//! let cv = cross_validate(&folds, &LAMBDA_GRID, &[]).unwrap();
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

/// The held-out error of one candidate.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct CvPoint {
    /// Relative ridge strength (dimensionless; penalty `λ_rel·diag(AᵀA)`).
    pub lambda_rel: f64,
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
    /// Held-out RMS of the chosen strength (nT): the filtered residual to expect on new data.
    pub expected_heldout_rms_nt: f64,
}

/// Smallest column scale, relative to the largest, used in the penalty: a column with no signal
/// at all on a flight (say, a fluxgate axis that never changes) then gets a coefficient of zero
/// instead of making the problem singular.
const SCALE_FLOOR: f64 = 1e-12;

/// The diagonal penalty for relative strength `lambda_rel` given the columns' sums of squares.
pub fn penalty(lambda_rel: f64, sums_of_squares: &[f64]) -> Vec<f64> {
    let largest = sums_of_squares.iter().fold(0.0f64, |m, s| m.max(*s));
    sums_of_squares
        .iter()
        .map(|s| lambda_rel * s.max(SCALE_FLOOR * largest))
        .collect()
}

/// Cross-validates `grid` over `folds` (each a problem holding one block of rows).
/// `None` when no candidate could be solved on every fold.
pub fn cross_validate(
    folds: &[Ridge],
    grid: &[f64],
    columns: &[String],
) -> Option<CrossValidation> {
    let rows: usize = folds.iter().map(Ridge::rows).sum();
    let points: Vec<CvPoint> = grid
        .iter()
        .map(|&lambda_rel| CvPoint {
            lambda_rel,
            heldout_rms_nt: heldout_sum_of_squares(folds, lambda_rel, columns)
                .map(|ss| (ss / rows as f64).sqrt()),
        })
        .collect();
    let best = points
        .iter()
        .filter_map(|p| p.heldout_rms_nt.map(|rms| (p.lambda_rel, rms)))
        .min_by(|a, b| a.1.total_cmp(&b.1))?;
    Some(CrossValidation {
        folds: folds.len(),
        grid: points,
        chosen_lambda_rel: best.0,
        expected_heldout_rms_nt: best.1,
    })
}

fn heldout_sum_of_squares(folds: &[Ridge], lambda_rel: f64, columns: &[String]) -> Option<f64> {
    heldout_sum_of_squares_on(folds, folds, lambda_rel, columns)
}

/// Sum over k of the squared residuals on `tests[k]` of a fit on every fold but `folds[k]`
/// with the relative penalty `lambda_rel`; `tests` holds one problem per fold (for example a
/// subset of each fold's rows). `None` when a training set cannot be solved.
pub fn heldout_sum_of_squares_on(
    folds: &[Ridge],
    tests: &[Ridge],
    lambda_rel: f64,
    columns: &[String],
) -> Option<f64> {
    let mut total = 0.0;
    for (k, test) in tests.iter().enumerate() {
        let mut train: Option<Ridge> = None;
        for (_, fold) in folds.iter().enumerate().filter(|(j, _)| *j != k) {
            match train.as_mut() {
                Some(t) => t.merge(fold),
                None => train = Some(fold.clone()),
            }
        }
        let train = train?;
        let weights = penalty(lambda_rel, &train.column_sums_of_squares());
        let beta = train.solve_penalised(&weights, columns).ok()?.coefficients;
        total += test.residual_sum_of_squares(&beta);
    }
    total.is_finite().then_some(total)
}
