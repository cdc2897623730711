//! Sensor models: what a fluxgate and a scalar magnetometer read of a true field.
//!
//! ```
//! use tolles_core::flight::sensor::Fluxgate;
//! let ideal = Fluxgate::default();
//! assert_eq!(ideal.read([1.0, 2.0, 3.0], [0.0; 3]), [1.0, 2.0, 3.0]);
//! let biased = Fluxgate { bias_nt: [10.0, 0.0, 0.0], ..Fluxgate::default() };
//! assert_eq!(biased.read([1.0, 2.0, 3.0], [0.0; 3])[0], 11.0);
//! ```

use serde::{Deserialize, Serialize};

/// A three-axis fluxgate's errors. Its reading of a true body-frame field `b` (nT) is
/// `(I + diag(scale_error))·N·b + bias + noise`, where `N` tilts the sensor's y axis toward x by
/// `nonorthogonality_deg[0]`, and its z axis toward x and y by `[1]` and `[2]`.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct Fluxgate {
    /// Standard deviation of each axis's white noise (nT).
    pub noise_nt: f64,
    /// Constant offset of each axis (nT).
    pub bias_nt: [f64; 3],
    /// Relative gain error of each axis (dimensionless, 0.001 = 0.1 %).
    pub scale_error: [f64; 3],
    /// Small angles between the sensor axes and true orthogonal axes (degrees).
    pub nonorthogonality_deg: [f64; 3],
    /// How late the fluxgate samples relative to the scalar magnetometer (s).
    pub lag_s: f64,
    /// Amplitude of each axis's slow offset drift (nT), as temperature and the aircraft's
    /// own slowly changing fields move a real fluxgate's zero; none by default.
    #[serde(default, skip_serializing_if = "is_zero3")]
    pub drift_nt: [f64; 3],
    /// Period of that drift (s); each axis a third of a period after the previous.
    #[serde(default, skip_serializing_if = "is_zero")]
    pub drift_period_s: f64,
}

// Skipped when zero: flights without a drift keep the sidecar they had.
fn is_zero3(v: &[f64; 3]) -> bool {
    v.iter().all(|x| *x == 0.0)
}

fn is_zero(v: &f64) -> bool {
    *v == 0.0
}

impl Fluxgate {
    /// The offset drift (nT) of each axis at time `t` (s): zero without a drift.
    pub fn drift_at(&self, t: f64) -> [f64; 3] {
        if self.drift_period_s <= 0.0 || !self.drift_period_s.is_finite() {
            return [0.0; 3];
        }
        let phase = std::f64::consts::TAU * t / self.drift_period_s;
        [0, 1, 2].map(|i| self.drift_nt[i] * (phase + std::f64::consts::TAU * i as f64 / 3.0).sin())
    }

    /// The reading (nT) of true field `b` (nT) with the noise sample `noise` (nT) added.
    pub fn read(&self, b: [f64; 3], noise: [f64; 3]) -> [f64; 3] {
        let [a, c, d] = self.nonorthogonality_deg.map(f64::to_radians);
        let tilted = [
            b[0],
            a.sin() * b[0] + a.cos() * b[1],
            c.sin() * b[0]
                + d.sin() * b[1]
                + (1.0 - c.sin().powi(2) - d.sin().powi(2)).max(0.0).sqrt() * b[2],
        ];
        [0, 1, 2].map(|i| (1.0 + self.scale_error[i]) * tilted[i] + self.bias_nt[i] + noise[i])
    }
}

/// Sensor errors of a simulated flight.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Sensors {
    /// Standard deviation of the scalar magnetometer's white noise (nT).
    pub scalar_noise_nt: f64,
    /// Standard deviation of each fluxgate component's white noise (nT).
    pub flux_noise_nt: f64,
    /// The fluxgate's other errors (its `noise_nt` is ignored in favour of `flux_noise_nt`).
    pub fluxgate: Fluxgate,
    /// Standard deviation of the white noise (nT) of a reference magnetometer that reads the
    /// earth's field without the aircraft's, as a tail stinger far from the airframe does;
    /// `None`: the flight has no reference magnetometer.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub reference_noise_nt: Option<f64>,
}

impl Default for Sensors {
    /// A caesium magnetometer (0.01 nT) and a survey fluxgate (0.5 nT), otherwise ideal; no
    /// reference magnetometer.
    fn default() -> Self {
        Self {
            scalar_noise_nt: 0.01,
            flux_noise_nt: 0.5,
            fluxgate: Fluxgate::default(),
            reference_noise_nt: None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_offset_drifts_by_its_amplitude_over_its_period_and_not_without_one() {
        let f = Fluxgate {
            drift_nt: [100.0, 50.0, 0.0],
            drift_period_s: 400.0,
            ..Fluxgate::default()
        };
        assert_eq!(f.drift_at(0.0)[0], 0.0);
        assert!((f.drift_at(100.0)[0] - 100.0).abs() < 1e-9); // a quarter period
        let peak = (0..400)
            .map(|t| f.drift_at(t as f64)[1])
            .fold(0.0, f64::max);
        assert!((peak - 50.0).abs() < 0.1, "{peak}");
        assert_eq!(Fluxgate::default().drift_at(123.0), [0.0; 3]);
    }

    #[test]
    fn scale_error_and_nonorthogonality_distort_as_documented() {
        let f = Fluxgate {
            scale_error: [0.01, 0.0, 0.0],
            nonorthogonality_deg: [90.0, 0.0, 0.0],
            ..Fluxgate::default()
        };
        let r = f.read([100.0, 50.0, 10.0], [0.0; 3]);
        assert!((r[0] - 101.0).abs() < 1e-12);
        assert!((r[1] - 100.0).abs() < 1e-9); // y axis tilted all the way onto x
        assert!((r[2] - 10.0).abs() < 1e-12);
    }
}
