//! The coefficients' uncertainty a fit leaves, as compensation uses it for each row's standard
//! error.

use nalgebra::DMatrix;
use serde::{Deserialize, Serialize};

/// The coefficients' uncertainty, as compensation needs it for the uncertainty of each row.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Uncertainty {
    /// Covariance of the coefficients, row-major, one row per column (coefficient units
    /// squared): the sandwich `G⁻¹·S·G⁻¹`, `G = AᵀA + Λ`, with `S` the long-run covariance of
    /// the rows' scores, which holds when the residual is not white (a band-passed one never
    /// is); `ν·G⁻¹` when the rows are no longer held (runs fitted in windows).
    pub covariance: Vec<f64>,
    /// Mean unfiltered design row over the calibration flight: the correction's uncertainty is
    /// that of its difference from the calibration's mean level, which a level removes.
    pub mean_row: Vec<f64>,
    /// What the model leaves of the scalar at every frequency (nT), taken as white: the band
    /// rows' residual scatter over the square root of the band's share of the spectrum (the
    /// scalar's own noise, and any field the model does not describe). Added to the
    /// correction's error in [`Uncertainty::value_sigma`]; 0 in files before it.
    #[serde(default, skip_serializing_if = "is_zero")]
    pub noise_nt: f64,
}

fn is_zero(v: &f64) -> bool {
    *v == 0.0
}

impl Uncertainty {
    /// The covariance as a matrix.
    pub fn matrix(&self) -> DMatrix<f64> {
        let p = self.mean_row.len();
        DMatrix::from_row_slice(p, p, &self.covariance)
    }

    /// The standard error (nT) of a compensated value whose design row is `row`, up to a
    /// constant level: the correction's ([`Uncertainty::sigma`]) and what the model leaves
    /// ([`Uncertainty::noise_nt`]), independent, in quadrature.
    pub fn value_sigma(&self, row: &[f64]) -> f64 {
        self.sigma(row).hypot(self.noise_nt)
    }

    /// The standard error (nT) of the correction `rowᵀβ` of a design row, less the mean row.
    pub fn sigma(&self, row: &[f64]) -> f64 {
        let p = self.mean_row.len();
        let d: Vec<f64> = row.iter().zip(&self.mean_row).map(|(r, m)| r - m).collect();
        let total: f64 = self
            .covariance
            .chunks_exact(p)
            .zip(&d)
            .map(|(c, di)| di * c.iter().zip(&d).map(|(c, dj)| c * dj).sum::<f64>())
            .sum();
        total.max(0.0).sqrt()
    }
}
