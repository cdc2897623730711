//! Harmonic analysis of one maneuver: the maneuver's frequency and phase from its attitude
//! channel, then any series (the magnetometer, or a term's generating function) demodulated on
//! the same basis.
//!
//! ```
//! use tolles_core::signal::demodulate::{fit_sinusoid, Basis};
//! use std::f64::consts::PI;
//!
//! // A 15° roll of period 6 s sampled at 10 Hz, starting 0.7 s into its cycle.
//! let t: Vec<f64> = (0..180).map(|k| k as f64 / 10.0).collect();
//! let w = 2.0 * PI / 6.0;
//! let roll: Vec<f64> = t.iter().map(|t| 15.0 * (w * (t + 0.7)).sin()).collect();
//! let wave = fit_sinusoid(&t, &roll).unwrap();
//! assert!((wave.omega - w).abs() < 1e-6 && (wave.amplitude - 15.0).abs() < 1e-6);
//!
//! // A magnetometer signal 3 sin ωτ + 0.5 cos 2ωτ on the same basis (τ = t − t0).
//! let basis = Basis { omega: wave.omega, t0: wave.t0 };
//! let y: Vec<f64> = t.iter().map(|&t| {
//!     let p = basis.phase(t);
//!     40.0 + 3.0 * p.sin() + 0.5 * (2.0 * p).cos()
//! }).collect();
//! let h = basis.demodulate(&t, &y).unwrap().value;
//! assert!((h.sin1 - 3.0).abs() < 1e-9 && (h.cos2 - 0.5).abs() < 1e-9);
//! ```
//!
//! The model on a window is `c0 + c1·τ + s1 sin ωτ + k1 cos ωτ + s2 sin 2ωτ + k2 cos 2ωτ`,
//! τ = t − t0 (s), chosen so the attitude channel is `A·sin ωτ` with A > 0. The straight line
//! absorbs a slowly varying earth field (diurnal, geology) over the window. Standard errors come
//! from the residual variance and assume white residuals; correlated residuals (unmodelled
//! third harmonics, turbulence) make them optimistic.

use nalgebra::{DMatrix, DVector};
use serde::{Deserialize, Serialize};
use std::f64::consts::PI;
use thiserror::Error;

/// Shortest and longest maneuver period searched (s).
pub const PERIOD_RANGE_S: (f64, f64) = (2.0, 20.0);

/// Why a window cannot be analysed.
#[derive(Debug, Error, PartialEq)]
pub enum DemodulateError {
    /// Too few finite samples in the window.
    #[error("a window needs at least {needed} finite samples, got {got}")]
    TooShort {
        /// Finite samples needed (samples).
        needed: usize,
        /// Finite samples in the window (samples).
        got: usize,
    },
    /// The window is shorter than one period of the maneuver.
    #[error("the window spans {span_s:.1} s, less than one period of {period_s:.1} s")]
    ShorterThanAPeriod {
        /// Time the window spans (s).
        span_s: f64,
        /// The maneuver's period (s).
        period_s: f64,
    },
    /// The attitude channel does not oscillate.
    #[error("the attitude channel does not oscillate")]
    NoOscillation,
}

/// `A·sin(ω(t − t0)) + mean` fitted to an attitude channel.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Sinusoid {
    /// Amplitude (units of the channel, e.g. degrees), positive.
    pub amplitude: f64,
    /// Angular frequency (rad/s).
    pub omega: f64,
    /// A time (s) where the oscillation crosses its mean going up.
    pub t0: f64,
    /// Mean of the channel over the window.
    pub mean: f64,
    /// RMS of the channel minus the fit.
    pub residual_rms: f64,
}

impl Sinusoid {
    /// Period (s).
    pub fn period_s(&self) -> f64 {
        2.0 * PI / self.omega
    }
}

/// Sum of squared residuals and the fitted (a, b, c) of `a sin ωt + b cos ωt + c`.
fn sinusoid_fit(t: &[f64], x: &[f64], omega: f64, t_ref: f64) -> (f64, [f64; 3]) {
    let rows = t.len();
    let a = DMatrix::from_fn(rows, 3, |k, j| {
        let p = omega * (t[k] - t_ref);
        match j {
            0 => p.sin(),
            1 => p.cos(),
            _ => 1.0,
        }
    });
    let y = DVector::from_column_slice(x);
    let Ok(beta) = a.clone().svd(true, true).solve(&y, 1e-12) else {
        return (f64::INFINITY, [0.0; 3]);
    };
    let rss = (y - &a * &beta).norm_squared();
    (rss, [beta[0], beta[1], beta[2]])
}

fn finite_pairs(t: &[f64], x: &[f64]) -> (Vec<f64>, Vec<f64>) {
    t.iter()
        .zip(x)
        .filter(|(t, x)| t.is_finite() && x.is_finite())
        .map(|(t, x)| (*t, *x))
        .unzip()
}

/// Fits `A·sin(ω(t − t0)) + mean` to an attitude channel (any unit) sampled at times `t` (s),
/// searching periods in [`PERIOD_RANGE_S`]: a coarse grid in frequency, then golden-section
/// refinement around the best grid point. Non-finite samples are skipped.
pub fn fit_sinusoid(t: &[f64], x: &[f64]) -> Result<Sinusoid, DemodulateError> {
    let (t, x) = finite_pairs(t, x);
    if t.len() < 8 {
        return Err(DemodulateError::TooShort {
            needed: 8,
            got: t.len(),
        });
    }
    let t_ref = t[0];
    let rss = |omega: f64| sinusoid_fit(&t, &x, omega, t_ref).0;
    let span = t[t.len() - 1] - t[0];
    // A harmonic maneuver holds at least one whole cycle.
    let w_lo = (2.0 * PI / PERIOD_RANGE_S.1).max(2.0 * PI / span.max(f64::MIN_POSITIVE));
    let w_hi = 2.0 * PI / PERIOD_RANGE_S.0;
    if w_lo >= w_hi {
        return Err(DemodulateError::ShorterThanAPeriod {
            span_s: span,
            period_s: PERIOD_RANGE_S.0,
        });
    }
    // The grid must resolve the peak: its width in ω is about 2π / span.
    let step = (PI / span.max(1.0) / 4.0).min((w_hi - w_lo) / 50.0);
    let grid: Vec<f64> = (0..)
        .map(|k| w_lo + k as f64 * step)
        .take_while(|w| *w <= w_hi)
        .collect();
    let best = grid
        .iter()
        .copied()
        .min_by(|a, b| rss(*a).total_cmp(&rss(*b)))
        .expect("the grid is not empty");
    let omega = golden_section(rss, (best - step).max(w_lo), (best + step).min(w_hi));
    let (rss_best, [a, b, mean]) = sinusoid_fit(&t, &x, omega, t_ref);
    let amplitude = a.hypot(b);
    let total: f64 = {
        let m = x.iter().sum::<f64>() / x.len() as f64;
        x.iter().map(|v| (v - m).powi(2)).sum()
    };
    if amplitude.is_nan() || amplitude <= 0.0 || rss_best > 0.5 * total {
        return Err(DemodulateError::NoOscillation);
    }
    // a sin p + b cos p = A sin(p + φ), φ = atan2(b, a): zero phase at p = −φ.
    let phi = b.atan2(a);
    let t0 = t_ref - phi / omega;
    Ok(Sinusoid {
        amplitude,
        omega,
        t0,
        mean,
        residual_rms: (rss_best / t.len() as f64).sqrt(),
    })
}

fn golden_section(f: impl Fn(f64) -> f64, mut a: f64, mut b: f64) -> f64 {
    let r = (5f64.sqrt() - 1.0) / 2.0;
    let mut c = b - r * (b - a);
    let mut d = a + r * (b - a);
    let (mut fc, mut fd) = (f(c), f(d));
    for _ in 0..80 {
        if fc < fd {
            b = d;
            d = c;
            fd = fc;
            c = b - r * (b - a);
            fc = f(c);
        } else {
            a = c;
            c = d;
            fc = fd;
            d = a + r * (b - a);
            fd = f(d);
        }
    }
    (a + b) / 2.0
}

/// The demodulation basis of one maneuver: phase `ω(t − t0)`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Basis {
    /// Angular frequency (rad/s).
    pub omega: f64,
    /// Time of zero phase (s).
    pub t0: f64,
}

/// Coefficients of `c0 + c1·τ + s1 sin ωτ + k1 cos ωτ + s2 sin 2ωτ + k2 cos 2ωτ`, in the units
/// of the demodulated series (c1 per second).
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct Harmonics {
    /// Level `c0` (units of the series).
    pub c0: f64,
    /// Slope `c1` (units of the series per s).
    pub c1: f64,
    /// Fundamental sine coefficient `s1` (units of the series).
    pub sin1: f64,
    /// Fundamental cosine coefficient `k1` (units of the series).
    pub cos1: f64,
    /// Second-harmonic sine coefficient `s2` (units of the series).
    pub sin2: f64,
    /// Second-harmonic cosine coefficient `k2` (units of the series).
    pub cos2: f64,
}

impl Harmonics {
    fn from_slice(b: &[f64]) -> Self {
        Self {
            c0: b[0],
            c1: b[1],
            sin1: b[2],
            cos1: b[3],
            sin2: b[4],
            cos2: b[5],
        }
    }
}

/// A demodulated series: coefficients, their standard errors, and the residual RMS.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Demodulated {
    /// The coefficients.
    pub value: Harmonics,
    /// Their standard errors (white residuals assumed).
    pub std_error: Harmonics,
    /// RMS of the series minus the model (units of the series).
    pub residual_rms: f64,
    /// Samples used.
    pub samples: usize,
}

const BASIS_COLUMNS: usize = 6;

impl Basis {
    /// The phase `ω(t − t0)` (rad) at time `t` (s).
    pub fn phase(&self, t: f64) -> f64 {
        self.omega * (t - self.t0)
    }

    fn matrix(&self, t: &[f64]) -> DMatrix<f64> {
        // τ is centred on the window so c0 is the window's level, not an extrapolation.
        let centre = t.iter().sum::<f64>() / t.len() as f64;
        DMatrix::from_fn(t.len(), BASIS_COLUMNS, |k, j| {
            let p = self.phase(t[k]);
            match j {
                0 => 1.0,
                1 => t[k] - centre,
                2 => p.sin(),
                3 => p.cos(),
                4 => (2.0 * p).sin(),
                _ => (2.0 * p).cos(),
            }
        })
    }

    fn check(&self, t: &[f64]) -> Result<(), DemodulateError> {
        if t.len() < 2 * BASIS_COLUMNS {
            return Err(DemodulateError::TooShort {
                needed: 2 * BASIS_COLUMNS,
                got: t.len(),
            });
        }
        let span = t[t.len() - 1] - t[0];
        let period = 2.0 * PI / self.omega;
        if span < period * 0.95 {
            return Err(DemodulateError::ShorterThanAPeriod {
                span_s: span,
                period_s: period,
            });
        }
        Ok(())
    }

    /// Least-squares demodulation of `y` sampled at `t` (s), with standard errors from the
    /// residual variance `RSS/(n − 6)`. Non-finite samples are skipped.
    pub fn demodulate(&self, t: &[f64], y: &[f64]) -> Result<Demodulated, DemodulateError> {
        let (t, y) = finite_pairs(t, y);
        self.check(&t)?;
        let a = self.matrix(&t);
        let y = DVector::from_column_slice(&y);
        let qr = a.clone().qr();
        let r = qr.r();
        let qty = qr.q().transpose() * &y;
        let beta = r
            .solve_upper_triangular(&qty)
            .ok_or(DemodulateError::NoOscillation)?;
        let residual = &y - &a * &beta;
        let n = t.len();
        let sigma2 = residual.norm_squared() / (n - BASIS_COLUMNS) as f64;
        let r_inv = r.try_inverse().ok_or(DemodulateError::NoOscillation)?;
        // (AᵀA)⁻¹ = R⁻¹R⁻ᵀ: its diagonal is the squared row norms of R⁻¹.
        let se: Vec<f64> = (0..BASIS_COLUMNS)
            .map(|i| (sigma2 * r_inv.row(i).norm_squared()).sqrt())
            .collect();
        Ok(Demodulated {
            value: Harmonics::from_slice(beta.as_slice()),
            std_error: Harmonics::from_slice(&se),
            residual_rms: (residual.norm_squared() / n as f64).sqrt(),
            samples: n,
        })
    }

    /// Projects `y` onto the basis without standard errors: the coefficients a series such as a
    /// generating function has on this maneuver as flown.
    pub fn project(&self, t: &[f64], y: &[f64]) -> Result<Harmonics, DemodulateError> {
        Ok(self.demodulate(t, y)?.value)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;
    use rand_distr::{Distribution, Normal};

    fn times(n: usize, fs: f64) -> Vec<f64> {
        (0..n).map(|k| 100.0 + k as f64 / fs).collect()
    }

    #[test]
    fn frequency_and_phase_are_recovered_over_the_period_range() {
        for period in [2.5, 6.0, 9.3, 17.0] {
            let t = times((3.0 * period * 10.0) as usize, 10.0);
            let w = 2.0 * PI / period;
            let x: Vec<f64> = t
                .iter()
                .map(|t| 2.0 + 10.0 * (w * (t - 101.3)).sin())
                .collect();
            let s = fit_sinusoid(&t, &x).unwrap();
            assert!((s.omega - w).abs() < 1e-6 * w, "{period}: {}", s.omega);
            assert!((s.amplitude - 10.0).abs() < 1e-5);
            assert!((s.mean - 2.0).abs() < 1e-5);
            // t0 is 101.3 up to whole periods.
            let shift = (s.t0 - 101.3) / period;
            assert!((shift - shift.round()).abs() < 1e-6, "{period}: {shift}");
        }
    }

    #[test]
    fn a_level_channel_does_not_oscillate() {
        let t = times(100, 10.0);
        // Level flight: a little deterministic jitter around zero.
        let x: Vec<f64> = (0..100).map(|k| 0.05 * ((k * k) as f64).sin()).collect();
        assert_eq!(fit_sinusoid(&t, &x), Err(DemodulateError::NoOscillation));
    }

    fn synthetic(basis: &Basis, t: &[f64], h: &Harmonics, noise: f64, seed: u64) -> Vec<f64> {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let normal = Normal::new(0.0, noise.max(1e-300)).unwrap();
        let centre = t.iter().sum::<f64>() / t.len() as f64;
        t.iter()
            .map(|&t| {
                let p = basis.phase(t);
                h.c0 + h.c1 * (t - centre)
                    + h.sin1 * p.sin()
                    + h.cos1 * p.cos()
                    + h.sin2 * (2.0 * p).sin()
                    + h.cos2 * (2.0 * p).cos()
                    + if noise > 0.0 {
                        normal.sample(&mut rng)
                    } else {
                        0.0
                    }
            })
            .collect()
    }

    const TRUE: Harmonics = Harmonics {
        c0: 52_000.0,
        c1: 0.3,
        sin1: 12.0,
        cos1: -4.0,
        sin2: 0.7,
        cos2: -1.5,
    };

    #[test]
    fn known_amplitudes_are_recovered() {
        let basis = Basis {
            omega: 2.0 * PI / 6.0,
            t0: 101.0,
        };
        let t = times(180, 10.0);
        let d = basis
            .demodulate(&t, &synthetic(&basis, &t, &TRUE, 0.0, 1))
            .unwrap();
        let v = d.value;
        for (got, want) in [
            (v.c0, TRUE.c0),
            (v.c1, TRUE.c1),
            (v.sin1, TRUE.sin1),
            (v.cos1, TRUE.cos1),
            (v.sin2, TRUE.sin2),
            (v.cos2, TRUE.cos2),
        ] {
            assert!((got - want).abs() < 1e-8, "{got} vs {want}");
        }
        assert!(d.std_error.sin1 < 1e-8);
    }

    #[test]
    fn uncertainties_scale_with_noise_and_cover_the_error() {
        let basis = Basis {
            omega: 2.0 * PI / 6.0,
            t0: 101.0,
        };
        let t = times(180, 10.0);
        let se = |noise: f64| {
            let d = basis
                .demodulate(&t, &synthetic(&basis, &t, &TRUE, noise, 7))
                .unwrap();
            (d.std_error.sin1, d.value.sin1 - TRUE.sin1)
        };
        let (small, _) = se(0.01);
        let (large, error) = se(1.0);
        let ratio = large / small;
        assert!((ratio - 100.0).abs() < 10.0, "{ratio}");
        // White noise σ on n samples: the sine coefficient's error is about σ·√(2/n).
        assert!((large - (2.0f64 / 180.0).sqrt()).abs() < 0.03, "{large}");
        assert!(error.abs() < 4.0 * large);
    }

    proptest::proptest! {
        #[test]
        fn any_harmonics_on_any_basis_are_recovered(
            period in 2.5f64..15.0, t0 in -10.0f64..10.0, cycles in 1.0f64..4.0,
            sin1 in -50.0f64..50.0, cos1 in -50.0f64..50.0,
            sin2 in -5.0f64..5.0, cos2 in -5.0f64..5.0, slope in -1.0f64..1.0,
        ) {
            let basis = Basis { omega: 2.0 * PI / period, t0 };
            let t = times((cycles * period * 10.0).ceil() as usize + 1, 10.0);
            let truth = Harmonics { c0: 3.0, c1: slope, sin1, cos1, sin2, cos2 };
            let got = basis.demodulate(&t, &synthetic(&basis, &t, &truth, 0.0, 0)).unwrap().value;
            for (a, b) in [(got.sin1, sin1), (got.cos1, cos1), (got.sin2, sin2), (got.cos2, cos2)] {
                proptest::prop_assert!((a - b).abs() < 1e-6, "{a} vs {b}");
            }
        }
    }

    #[test]
    fn a_window_shorter_than_a_period_is_refused() {
        let basis = Basis {
            omega: 2.0 * PI / 6.0,
            t0: 0.0,
        };
        let t = times(30, 10.0);
        let y = vec![1.0; 30];
        assert!(matches!(
            basis.demodulate(&t, &y),
            Err(DemodulateError::ShorterThanAPeriod { .. })
        ));
    }
}
