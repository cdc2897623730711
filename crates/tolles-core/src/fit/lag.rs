//! The time offset between the scalar magnetometer and the fluxgate.
//!
//! Sensors sampled a little apart make the design columns late or early against the scalar;
//! the fit then trades eddy terms for the offset. The lag is estimated as the shift of the
//! fluxgate that lets a fit predict held-out data best: whole samples first, then a
//! golden-section search within a sample of the best, the fluxgate shifted by cubic
//! interpolation ([`crate::signal::shift`]).

use crate::fit::{fit, FitError, FitSettings, MagnitudeChoice};
use crate::model::vector::VectorSeries;
use crate::signal::shift::shift;

/// Sub-sample precision of the search (samples).
const TOLERANCE_SAMPLES: f64 = 0.01;

/// The fluxgate as it would read `lag_s` seconds later: undoes a fluxgate that samples `lag_s`
/// late (a negative lag, early). Samples shifted past either end are NaN.
pub fn shifted(flux: &VectorSeries, lag_s: f64, fs_hz: f64) -> VectorSeries {
    if lag_s == 0.0 {
        return flux.clone();
    }
    let by = lag_s * fs_hz;
    VectorSeries::new(shift(&flux.x, by), shift(&flux.y, by), shift(&flux.z, by))
}

/// Estimates the fluxgate's lag behind the scalar (s), searched within `±max_s`, with a linear
/// band-passed fit of `settings`' first term set.
pub fn estimate(
    scalar: &[f64],
    flux: &VectorSeries,
    fs_hz: f64,
    tt: Option<&[f64]>,
    settings: &FitSettings,
    max_s: f64,
) -> Result<f64, FitError> {
    let search = FitSettings {
        design: crate::model::design::Design {
            fluxgates: 1,
            extras: Vec::new(),
            ..settings.design.clone()
        },
        alternative_terms: Vec::new(),
        magnitude: MagnitudeChoice::Linear,
        levels: false,
        ..settings.clone()
    };
    let score = |samples: f64| -> Result<f64, FitError> {
        let moved = shifted(flux, samples / fs_hz, fs_hz);
        let found = fit(scalar, &moved, fs_hz, tt, &search)?;
        Ok(match &found.diagnostics.cross_validation {
            Some(cv) => cv.expected_heldout_rms_nt,
            None => found.diagnostics.residual_std_nt,
        })
    };
    let reach = (max_s * fs_hz).round().clamp(0.0, 50.0) as i64;
    let mut best = (0.0, score(0.0)?);
    for k in (-reach..=reach).filter(|k| *k != 0) {
        let s = score(k as f64)?;
        if s < best.1 {
            best = (k as f64, s);
        }
    }
    let refined = golden_section(best.0 - 1.0, best.0 + 1.0, &score)?;
    Ok(refined / fs_hz)
}

/// The minimum of `f` on `[a, b]` by golden-section search, to [`TOLERANCE_SAMPLES`].
fn golden_section(
    mut a: f64,
    mut b: f64,
    f: &dyn Fn(f64) -> Result<f64, FitError>,
) -> Result<f64, FitError> {
    let ratio = (5f64.sqrt() - 1.0) / 2.0;
    let (mut c, mut d) = (b - ratio * (b - a), a + ratio * (b - a));
    let (mut fc, mut fd) = (f(c)?, f(d)?);
    while b - a > TOLERANCE_SAMPLES {
        if fc < fd {
            (b, d, fd) = (d, c, fc);
            c = b - ratio * (b - a);
            fc = f(c)?;
        } else {
            (a, c, fc) = (c, d, fd);
            d = a + ratio * (b - a);
            fd = f(d)?;
        }
    }
    Ok((a + b) / 2.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn golden_section_finds_a_parabola_s_minimum() {
        let m = golden_section(-1.0, 2.0, &|x| Ok((x - 0.37).powi(2))).unwrap();
        assert!((m - 0.37).abs() < TOLERANCE_SAMPLES);
    }

    #[test]
    fn shifting_by_zero_changes_nothing() {
        let f = VectorSeries::new(vec![1.0, 2.0], vec![3.0, 4.0], vec![5.0, 6.0]);
        assert_eq!(shifted(&f, 0.0, 10.0), f);
    }
}
