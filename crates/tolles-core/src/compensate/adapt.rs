//! Online adaptation of a model's coefficients while streaming: a Kalman filter on the
//! coefficients, fed with band-passed design rows and scalar, updating only during maneuvers.
//!
//! ```
//! use tolles_core::compensate::adapt::{Adapter, AdaptSettings};
//! let mut adapter = Adapter::new(&[10.0, 0.0, 0.0], 10.0, &AdaptSettings::default()).unwrap();
//! // A constant row carries no excitation after the band-pass: nothing is learnt.
//! for _ in 0..500 {
//!     adapter.update(&[1.0, 0.0, 0.0], 50_000.0);
//! }
//! assert_eq!(adapter.coefficients(), [10.0, 0.0, 0.0]);
//! assert_eq!(adapter.updates(), 0);
//! ```
//!
//! The model: the coefficients β (nT per unit of their column) drift as a random walk, and the
//! band-passed scalar is `y = a·β + noise`, where `a` is the band-passed design row. Both are
//! band-passed causally (Butterworth, [`filter::SosState`](crate::signal::filter::SosState)) like the fit
//! does, so the earth's slow variation and the constant level drop out.
//!
//! - Start: β from the model; covariance a scaled identity `initial_std²·I` (nT²), the same for
//!   every column (the model file's diagnostics give no full covariance).
//! - Each update adds the drift `drift_std²·I` (nT² per update) and applies the Kalman update
//!   with measurement noise `noise_nt²`.
//! - Guard against drifting on straight-and-level flight: a sample updates β only when the
//!   band-passed row's norm is at least `min_excitation` (the column values are of order one for
//!   the permanent and induced terms, so a 10° roll gives about 0.1), and not during the band-pass's
//!   settling time after a (re)start. Without excitation the covariance does not grow either.

use crate::signal::filter::{Band, Butterworth, FilterError, SosState};

/// A band-passed misfit beyond this many predicted standard deviations is an outlier (a
/// spike, a corrupt cell) and does not update the coefficients.
pub const OUTLIER_SIGMAS: f64 = 8.0;

/// Tuning of the adaptation.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AdaptSettings {
    /// Band-pass edges (Hz); both must be valid, the adaptation needs a band-pass.
    pub band: Band,
    /// Butterworth order of the band-pass.
    pub order: usize,
    /// Prior standard deviation of every coefficient (nT per unit of its column).
    pub initial_std: f64,
    /// Random-walk standard deviation added per update (nT per unit of the column).
    pub drift_std: f64,
    /// Standard deviation of the band-passed scalar's misfit (nT).
    pub noise_nt: f64,
    /// Smallest band-passed row norm (unit of the columns) that updates the coefficients.
    pub min_excitation: f64,
}

impl Default for AdaptSettings {
    /// 0.1–0.9 Hz order 4, prior 5 nT, drift 0.05 nT per update, noise 0.5 nT, excitation 0.02.
    fn default() -> Self {
        Self {
            band: Band::MAGNAV,
            order: 4,
            initial_std: 5.0,
            drift_std: 0.05,
            noise_nt: 0.5,
            min_excitation: 0.02,
        }
    }
}

/// The adapting coefficients of one scalar.
#[derive(Debug, Clone)]
pub struct Adapter {
    beta: Vec<f64>,
    p: Vec<f64>,
    filter: Butterworth,
    columns: Vec<SosState>,
    scalar: Option<SosState>,
    settle: usize,
    since_start: usize,
    settings: AdaptSettings,
    updates: u64,
    pa: Vec<f64>,
    af: Vec<f64>,
}

impl Adapter {
    /// Starts from `coefficients` at sample rate `fs_hz` (Hz).
    pub fn new(
        coefficients: &[f64],
        fs_hz: f64,
        settings: &AdaptSettings,
    ) -> Result<Self, FilterError> {
        let band = settings.band;
        let filter = band
            .butterworth(settings.order, fs_hz)?
            .ok_or(FilterError::InvalidBand {
                low_hz: band.pass1_hz,
                high_hz: band.pass2_hz,
            })?;
        let n = coefficients.len();
        let mut p = vec![0.0; n * n];
        for k in 0..n {
            p[k * n + k] = settings.initial_std.powi(2);
        }
        Ok(Self {
            beta: coefficients.to_vec(),
            p,
            columns: Vec::new(),
            scalar: None,
            settle: (2.0 * fs_hz / band.pass1_hz).ceil() as usize,
            since_start: 0,
            filter,
            settings: *settings,
            updates: 0,
            pa: vec![0.0; n],
            af: vec![0.0; n],
        })
    }

    /// The current coefficients.
    pub fn coefficients(&self) -> &[f64] {
        &self.beta
    }

    /// How many samples have updated the coefficients.
    pub fn updates(&self) -> u64 {
        self.updates
    }

    /// Forgets the filters' history (at a break in the data); the coefficients are kept.
    pub fn restart(&mut self) {
        self.columns.clear();
        self.scalar = None;
        self.since_start = 0;
    }

    /// Feeds one design row and its scalar (nT); returns true if the coefficients were updated.
    ///
    /// A non-finite input restarts the filters (it would poison their state for good), and a
    /// misfit beyond [`OUTLIER_SIGMAS`] of its predicted spread is not learnt from.
    pub fn update(&mut self, row: &[f64], scalar: f64) -> bool {
        if !(scalar.is_finite() && row.iter().all(|v| v.is_finite())) {
            self.restart();
            return false;
        }
        if self.scalar.is_none() {
            self.columns = row
                .iter()
                .map(|v| SosState::steady(&self.filter, *v))
                .collect();
            self.scalar = Some(SosState::steady(&self.filter, scalar));
        }
        for ((f, state), v) in self.af.iter_mut().zip(&mut self.columns).zip(row) {
            *f = state.step(*v);
        }
        let y = self.scalar.as_mut().map_or(0.0, |s| s.step(scalar));
        self.since_start += 1;
        let excitation = self.af.iter().map(|v| v * v).sum::<f64>().sqrt();
        if self.since_start <= self.settle || excitation < self.settings.min_excitation {
            return false;
        }
        if !self.kalman(y) {
            return false;
        }
        self.updates += 1;
        true
    }

    /// One Kalman step; false (nothing changed) when the misfit is an outlier.
    fn kalman(&mut self, y: f64) -> bool {
        let n = self.beta.len();
        let q = self.settings.drift_std.powi(2);
        for k in 0..n {
            self.p[k * n + k] += q;
        }
        for i in 0..n {
            self.pa[i] = (0..n).map(|j| self.p[i * n + j] * self.af[j]).sum();
        }
        let s: f64 = self.settings.noise_nt.powi(2)
            + self
                .af
                .iter()
                .zip(&self.pa)
                .map(|(a, pa)| a * pa)
                .sum::<f64>();
        let e = y - self
            .af
            .iter()
            .zip(&self.beta)
            .map(|(a, b)| a * b)
            .sum::<f64>();
        let inlier = e * e <= OUTLIER_SIGMAS.powi(2) * s; // false for NaN too
        if !inlier {
            // Undo the drift: an outlier teaches nothing, not even uncertainty.
            for k in 0..n {
                self.p[k * n + k] -= q;
            }
            return false;
        }
        for i in 0..n {
            self.beta[i] += self.pa[i] / s * e;
            for j in 0..n {
                self.p[i * n + j] -= self.pa[i] * self.pa[j] / s;
            }
        }
        true
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_well_excited_linear_model_is_learnt() {
        let truth = [3.0, -2.0];
        let mut adapter = Adapter::new(&[0.0, 0.0], 10.0, &AdaptSettings::default()).unwrap();
        for k in 0..3_000 {
            let t = k as f64 / 10.0;
            let row = [(2.0 * t).sin(), (1.3 * t).cos()];
            adapter.update(&row, 40_000.0 + truth[0] * row[0] + truth[1] * row[1]);
        }
        let b = adapter.coefficients();
        assert!(
            (b[0] - 3.0).abs() < 0.05 && (b[1] + 2.0).abs() < 0.05,
            "{b:?}"
        );
        assert!(adapter.updates() > 2_000);
    }

    #[test]
    fn spikes_and_non_finite_values_do_not_poison_the_coefficients() {
        let truth = [3.0, -2.0];
        let mut adapter = Adapter::new(&[0.0, 0.0], 10.0, &AdaptSettings::default()).unwrap();
        for k in 0..3_000 {
            let t = k as f64 / 10.0;
            let row = [(2.0 * t).sin(), (1.3 * t).cos()];
            let mut y = 40_000.0 + truth[0] * row[0] + truth[1] * row[1];
            if k == 1_500 {
                y = 1e308;
            }
            if k == 2_000 {
                y = f64::NAN;
            }
            adapter.update(&row, y);
        }
        let b = adapter.coefficients();
        assert!(b.iter().all(|v| v.is_finite()), "{b:?}");
        assert!(
            (b[0] - 3.0).abs() < 0.05 && (b[1] + 2.0).abs() < 0.05,
            "{b:?}"
        );
    }
}
