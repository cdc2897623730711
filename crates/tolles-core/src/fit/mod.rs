//! Fitting a Tolles-Lawson model: filter, trim, ridge least squares.
//!
//! ```
//! use tolles_core::model::design::Design;
//! use tolles_core::fit::{fit, FitSettings, Lambda};
//! use tolles_core::model::vector::VectorSeries;
//!
//! // A fluxgate swinging through ±20° at 0.2 Hz, and a scalar that sees a 40 nT permanent field
//! // along the aircraft's x axis.
//! let fs = 10.0;
//! let n = 2000;
//! let angle = |k: usize| 0.35 * (2.0 * std::f64::consts::PI * 0.2 * k as f64 / fs).sin();
//! let flux = VectorSeries::new(
//!     (0..n).map(|k| 20_000.0 * angle(k).cos()).collect(),
//!     (0..n).map(|k| 20_000.0 * angle(k).sin()).collect(),
//!     vec![45_000.0; n],
//! );
//! let scalar: Vec<f64> = (0..n).map(|k| 50_000.0 + 40.0 * flux.x[k] / flux.magnitude(k)).collect();
//! let settings = FitSettings {
//!     design: Design::new("p".parse().unwrap()),
//!     lambda: Lambda::Fixed(0.0),
//!     ..FitSettings::magnav()
//! };
//! let model = fit(&scalar, &flux, fs, None, &settings).unwrap();
//! assert!((model.coefficients[0] - 40.0).abs() < 1e-6);
//! ```
//!
//! The procedure is MagNav.jl's `create_TL_coef`: build the design matrix `A` from the fluxgate,
//! band-pass every column of `A` and the scalar with the same zero-phase filter (constant columns
//! are left alone), drop `trim` samples at each end, and solve
//! `(AᵀA + λI)·β = Aᵀy` with unscaled columns (MagNav's `linreg`).
//!
//! We solve the ridge problem as the least-squares problem `[A; √λ·I]·β ≈ [y; 0]` by a
//! blocked Householder QR ("TSQR"), never forming `AᵀA`: on the MagNav test flight
//! `cond(AᵀA) ≈ 4·10⁷`, so normal equations would lose about eight digits.
//!
//! Samples where the scalar or fluxgate is not finite are skipped; the remaining samples are cut
//! into contiguous runs (also at time gaps, see [`crate::signal::segment`]) and each run is designed,
//! filtered and trimmed on its own, so no derivative or filter reaches across a hole.
//!
//! [`FitSettings::recommended`] goes further, in three steps that share the folds:
//! 1. the candidate term sets (the patent's traceless 16, `i5,e8`, and over several fluxgates
//!    MagNav's 18) are fitted and scored on held-out folds, each with a physical prior
//!    ([`prior`]) whose strength the folds choose too, and none beyond the bounds of
//!    [`plausible`];
//! 2. with `levels`, low-frequency rows against the calibrated fluxgate's magnitude join the
//!    band rows, and the score adds their held-out error ([`levels`]);
//! 3. with `magnitude`, the chosen terms are refitted for the exact magnitude `|B + H| − |B|`
//!    by Gauss-Newton from the linear solution: each iteration rebuilds the rows from the
//!    Jacobian (see [`crate::model::magnitude`]) and the target `y − Δ(β) + J·β`, filters them
//!    like the linear rows and solves the same ridge problem; the exact fit is kept if its score
//!    is no worse. Steps are cut to a trust region, and a fit that diverges or leaves the
//!    plausible bounds falls back to the linear one.
//!
//! Every fit then judges itself ([`verdict`]) and keeps its coefficients' covariance and the
//! span of attitudes it flew ([`trust`]), from which compensation gives each row a standard
//! error and says whether the model extrapolates there.

mod basis;
mod choice;
pub mod crossval;
mod diagnostics;
mod error;
mod exact;
mod factor;
mod inputs;
pub mod lag;
mod level_rows;
mod level_setup;
pub mod levels;
pub mod network;
mod outcome;
pub mod plausible;
mod prepare;
pub mod prior;
mod problem;
mod qr;
pub mod ridge;
mod run;
mod samples;
mod settings;
mod spare;
pub mod trust;
pub mod verdict;
mod window_size;
mod windows;

pub use crate::model::limits::{scalar_usable, show_nt, FLUX_MAGNITUDE_RANGE_NT, SCALAR_LIMIT_NT};
// The pass band lives with the filters; re-exported because a fit's settings name it.
pub use crate::signal::filter::Band;
pub use error::FitError;
pub use inputs::check_flux_magnitude;
pub use outcome::{Diagnostics, Fit, TermScore};
pub use settings::{
    FitSettings, Lambda, MagnitudeChoice, Target, LAMBDA_MAX_RATIO, TERM_CHOICE_MARGIN,
};

use crate::fit::inputs::check_inputs;
use crate::fit::run::{fit_reusing, Wanted};
use crate::fit::samples::Samples;
use crate::fit::spare::Spare;
use crate::model::vector::Fluxgates;

/// Fits a model to a calibration flight.
///
/// - `scalar`: the uncompensated scalar magnetometer (nT); non-finite samples are skipped;
/// - `flux`: the fluxgate (nT, body frame FRD), or several, one per block of
///   `settings.design` (see [`crate::model::design::Design`]); a sample is skipped if any of them is not finite;
/// - `fs_hz`: sample rate (Hz);
/// - `tt`: optional time (seconds) used only to split runs at gaps.
pub fn fit<'a>(
    scalar: &[f64],
    flux: impl Into<Fluxgates<'a>>,
    fs_hz: f64,
    tt: Option<&[f64]>,
    settings: &FitSettings,
) -> Result<Fit, FitError> {
    let flux = flux.into();
    check_inputs(scalar, &flux, fs_hz, settings)?;
    let samples = Samples::of(scalar, &flux, tt);
    let spare = Spare::default();
    fit_reusing(
        scalar,
        flux,
        fs_hz,
        &samples,
        settings,
        &spare,
        Wanted::Everything,
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fit::basis::Basis;
    use crate::fit::choice::union_of_terms;
    use crate::fit::diagnostics::RunningStd;
    use crate::fit::run::check_finite;
    use crate::fit::settings::passband_fraction;
    use crate::fit::window_size::with_window_samples;
    use crate::model::design::Design;
    use crate::model::magnitude::Magnitude;
    use crate::model::vector::VectorSeries;
    use proptest::prelude::*;

    proptest! {
        #[test]
        fn flux_magnitude_check_finds_the_first_sample_out_of_range(
            // Magnitudes at, just inside and just outside both limits, NaN, and (mostly)
            // ordinary ones, so the first sample out of range is often a few blocks in.
            picks in prop::collection::vec((0usize..4000, 0.0f64..1.0), 1..5000),
        ) {
            let (lo, hi) = FLUX_MAGNITUDE_RANGE_NT;
            let magnitudes = [lo, hi, lo * (1.0 - 1e-16), hi * (1.0 + 2e-16), 0.0, f64::NAN, 50_000.0];
            let flux = VectorSeries::new(
                picks.iter().map(|(m, f)| magnitudes[(*m).min(6)] * f.sqrt()).collect(),
                picks.iter().map(|(m, f)| magnitudes[(*m).min(6)] * (1.0 - f).sqrt()).collect(),
                vec![0.0; picks.len()],
            );
            let expected = (0..flux.len()).find(|&k| {
                let m = flux.magnitude(k);
                !m.is_nan() && !(lo..=hi).contains(&m)
            });
            match check_flux_magnitude(&flux) {
                Ok(()) => prop_assert_eq!(expected, None),
                Err(FitError::FluxMagnitude { index, .. }) => prop_assert_eq!(Some(index), expected),
                Err(e) => prop_assert!(false, "{e}"),
            }
        }
    }

    /// A long flight is checked in a part per core: the sample reported is the first out of
    /// range, whichever part holds it.
    #[test]
    fn flux_magnitude_check_of_a_long_flight_finds_the_first_sample_out_of_range() {
        let n = 3 * crate::parallel::PARALLEL_ROWS;
        let series = |bad: &[usize]| {
            let mut x = vec![50_000.0; n];
            bad.iter().for_each(|&k| x[k] = 1e7);
            VectorSeries::new(x, vec![0.0; n], vec![0.0; n])
        };
        let late = 2 * n / 3 + 5;
        for (bad, first) in [
            (vec![late], late),
            (vec![late, 7], 7),
            (vec![n / 2, n - 1], n / 2),
        ] {
            match check_flux_magnitude(&series(&bad)) {
                Err(FitError::FluxMagnitude { index, .. }) => assert_eq!(index, first, "{bad:?}"),
                other => panic!("{other:?}"),
            }
        }
        assert!(check_flux_magnitude(&series(&[])).is_ok());
    }

    proptest! {
        /// Blocks of every length, merged across blocks and calls, and an offset far larger
        /// than the scatter (a band-passed target is centred, a level is not).
        #[test]
        fn running_std_by_blocks_is_the_two_pass_std(
            lengths in proptest::collection::vec(0usize..5000, 1..4),
            offset in -1e4f64..1e4,
            seed in 0.0f64..10.0,
        ) {
            let parts: Vec<Vec<f64>> = lengths
                .iter()
                .enumerate()
                .map(|(p, &n)| {
                    (0..n)
                        .map(|k| offset + (k as f64 * 0.37 + seed + p as f64).sin() * (1.0 + p as f64))
                        .collect()
                })
                .collect();
            let mut running = RunningStd::default();
            parts.iter().for_each(|p| running.push_all(p));
            // Two plain passes over all the values.
            let want = crate::signal::metrics::std_dev(&parts.concat());
            if lengths.iter().sum::<usize>() == 0 {
                prop_assert!(running.std().is_nan());
            } else {
                prop_assert!(
                    (running.std() - want).abs() <= 1e-9 * want.max(1e-3),
                    "{} vs {}", running.std(), want
                );
            }
        }
    }

    #[test]
    fn passband_fraction_follows_the_fallbacks() {
        let band = |a, b| Band {
            pass1_hz: a,
            pass2_hz: b,
        };
        assert!((passband_fraction(band(0.1, 0.9), 10.0) - 0.16).abs() < 1e-12);
        assert!((passband_fraction(band(0.0, 1.0), 10.0) - 0.2).abs() < 1e-12);
        assert_eq!(passband_fraction(band(0.0, 99.0), 10.0), 1.0);
    }

    #[test]
    fn settings_are_validated() {
        let flux = VectorSeries::new(vec![30_000.0; 3], vec![0.0; 3], vec![40_000.0; 3]);
        let mut s = FitSettings::magnav();
        s.lambda = Lambda::Fixed(-1.0);
        assert_eq!(
            fit(&[1.0; 3], &flux, 10.0, None, &s).unwrap_err(),
            FitError::Lambda(-1.0)
        );
        s.lambda = Lambda::CrossValidated { folds: 1 };
        assert_eq!(
            fit(&[1.0; 3], &flux, 10.0, None, &s).unwrap_err(),
            FitError::Folds(1)
        );
        assert_eq!(
            fit(&[1.0; 3], &flux, 0.0, None, &s).unwrap_err(),
            FitError::SampleRate(0.0)
        );
    }

    /// The module example's flight: a permanent term of 40 nT along x.
    fn turning_flight() -> (Vec<f64>, VectorSeries, FitSettings) {
        let (fs, n) = (10.0, 2000);
        let angle = |k: usize| 0.35 * (2.0 * std::f64::consts::PI * 0.2 * k as f64 / fs).sin();
        let flux = VectorSeries::new(
            (0..n).map(|k| 20_000.0 * angle(k).cos()).collect(),
            (0..n).map(|k| 20_000.0 * angle(k).sin()).collect(),
            vec![45_000.0; n],
        );
        let scalar = (0..n)
            .map(|k| 50_000.0 + 40.0 * flux.x[k] / flux.magnitude(k))
            .collect();
        let settings = FitSettings {
            design: Design::new("p".parse().unwrap()),
            lambda: Lambda::Fixed(0.0),
            ..FitSettings::magnav()
        };
        (scalar, flux, settings)
    }

    #[test]
    fn a_scalar_spike_is_skipped_not_fitted() {
        let (mut scalar, flux, settings) = turning_flight();
        scalar[700] = 1e300;
        let model = fit(&scalar, &flux, 10.0, None, &settings).unwrap();
        assert!((model.coefficients[0] - 40.0).abs() < 1e-6);
        assert!(model.diagnostics.residual_std_nt.is_finite());
        assert_eq!(model.diagnostics.samples_nonfinite, 1);
    }

    #[test]
    fn an_overflowing_or_infinite_fluxgate_is_out_of_range() {
        for bad in [1e155, 1e200, f64::INFINITY] {
            let (scalar, mut flux, settings) = turning_flight();
            flux.y[101] = bad;
            match fit(&scalar, &flux, 10.0, None, &settings).unwrap_err() {
                FitError::FluxMagnitude { index, .. } => assert_eq!(index, 101),
                e => panic!("{e}"),
            }
        }
    }

    #[test]
    fn an_absurd_fixed_lambda_is_refused_quickly() {
        let (scalar, flux, mut settings) = turning_flight();
        settings.lambda = Lambda::Fixed(1e308);
        assert!(matches!(
            fit(&scalar, &flux, 10.0, None, &settings).unwrap_err(),
            FitError::LambdaTooLarge { .. }
        ));
    }

    #[test]
    fn a_fit_that_overflows_is_an_error() {
        let diagnostics = |residual| Diagnostics {
            residual_std_nt: residual,
            ..turning_fit().diagnostics
        };
        let all = Wanted::Everything;
        assert_eq!(
            check_finite(&[f64::NAN], &diagnostics(1.0), all),
            Err(FitError::NotFinite {
                what: "coefficients"
            })
        );
        assert_eq!(
            check_finite(&[1.0], &diagnostics(f64::NAN), all),
            Err(FitError::NotFinite { what: "residual" })
        );
        // A calibration leaves the scatter before the fit out (NaN); its residual still counts.
        let mut unmeasured = diagnostics(1.0);
        unmeasured.filtered_std_before_nt = f64::NAN;
        assert!(check_finite(&[1.0], &unmeasured, all).is_err());
        assert_eq!(
            check_finite(&[1.0], &unmeasured, Wanted::Coefficients),
            Ok(())
        );
        let coefficients_only = Wanted::Coefficients;
        assert!(check_finite(&[1.0], &diagnostics(f64::NAN), coefficients_only).is_err());
    }

    #[test]
    fn an_exact_fit_that_loses_stops_once_settled_and_the_linear_fit_keeps_its_level_rows() {
        use crate::flight::plan::BoxPlan;
        use crate::flight::sim::{simulate, Installation};
        let mut scenario = Installation::Cabin.scenario(2);
        scenario.extras.current = None;
        let cal = simulate(&BoxPlan::default().build(), &scenario).unwrap();
        let fit_with = |magnitude| {
            let settings = FitSettings {
                magnitude,
                levels: true,
                ..FitSettings::recommended()
            };
            fit(&cal.scalar, &cal.flux, 10.0, Some(&cal.tt), &settings).unwrap()
        };
        let exact_score = |f: &Fit| {
            let mut s = f.diagnostics.term_choice.iter();
            let exact = s.rfind(|t| t.magnitude == Magnitude::Exact);
            exact.and_then(|t| t.heldout_rms_nt).unwrap()
        };
        let auto = fit_with(MagnitudeChoice::Auto);
        let converged = fit_with(MagnitudeChoice::Exact);
        // The exact fit loses, and takes three iterations to converge when it is wanted ...
        assert_eq!(auto.magnitude, Magnitude::Linear);
        assert_eq!(converged.diagnostics.exact_iterations, 3);
        // ... yet the score it reports after two, settled, is the converged fit's.
        let (early, last) = (exact_score(&auto), exact_score(&converged));
        assert!((early - last).abs() <= 1e-9 * last, "{early} {last}");
        // The linear fit kept is described by its own level rows, not the exact fit's.
        let linear = fit_with(MagnitudeChoice::Linear);
        let levels = |f: &Fit| f.diagnostics.levels.clone().unwrap();
        assert_eq!(levels(&auto), levels(&linear));
        assert_eq!(
            auto.diagnostics.residual_std_nt,
            linear.diagnostics.residual_std_nt
        );
    }

    /// The fluxgate calibrated from the linear fit's own rows (with levels) is the one its own
    /// fit finds ([`levels::reference`]), in runs done whole and in windows; and so is the one
    /// calibrated in a pass of its own, for a `Bt_scale` unlike the calibration's.
    #[test]
    fn the_fluxgate_calibrated_in_the_fit_pass_is_the_one_its_own_fit_finds() {
        use crate::flight::plan::BoxPlan;
        use crate::flight::sim::{simulate, Installation};
        let recommended = FitSettings {
            levels: true,
            ..FitSettings::recommended()
        };
        let union = union_of_terms(&recommended.candidate_designs());
        let stored = Basis::of(&union).stored;
        assert!(levels::InPass::of(&recommended, &stored, false, 10.0).is_some());
        let mut other_scale = recommended.clone();
        other_scale.design.bt_scale = 20_000.0;
        assert!(levels::InPass::of(&other_scale, &stored, false, 10.0).is_none());
        let scenario = Installation::TailStinger.scenario(3);
        let short = simulate(&BoxPlan::default().build(), &scenario).unwrap();
        // Three boxes of long manoeuvres: one run of about 80 000 samples, done in windows.
        let long_plan = BoxPlan {
            headings_deg: [0.0, 90.0, 180.0, 270.0].repeat(3),
            cycles: 30,
            ..BoxPlan::default()
        };
        let long = simulate(&long_plan.build(), &scenario).unwrap();
        for (flight, windowed) in [(&short, false), (&long, true)] {
            let (scalar, flux, tt) = (&flight.scalar, &flight.flux, Some(&flight.tt[..]));
            let usable = vec![true; scalar.len()];
            let own = levels::reference(flux, &usable, 10.0, tt, &recommended).unwrap();
            let own = own.calibration;
            let mut seen = Vec::new();
            for settings in [&recommended, &other_scale] {
                crate::fit::window_size::windows_in_tests::DONE.set(0);
                let fitted = in_windows(|| fit(scalar, flux, 10.0, tt, settings)).unwrap();
                assert_eq!(
                    crate::fit::window_size::windows_in_tests::DONE.get() > 0,
                    windowed
                );
                let levels = fitted.diagnostics.levels.unwrap();
                // Another Bt_scale only rescales columns: the same fit, whose level rows'
                // target was made from the reference in the pass or before it.
                seen.push([
                    levels.residual_rms_nt,
                    levels.weight,
                    fitted.diagnostics.residual_std_nt,
                ]);
                let got = levels.fluxgate;
                let values = |c: &levels::FluxgateCalibration| {
                    let mut v = c.offset_nt.to_vec();
                    v.extend(c.distortion.map(|d| d * 50_000.0));
                    v.push(c.residual_std_nt);
                    v
                };
                for (a, b) in values(&got).iter().zip(values(&own)) {
                    // Offsets and distortions near 0 move by the rounding of the others.
                    let close = (a - b).abs() <= 1e-9 * a.abs().max(b.abs()).max(1e-3);
                    assert!(close, "{a} vs {b}: {got:?} vs {own:?}");
                }
            }
            // The level rows' misfit and weight agree to rounding; the band residual to the
            // rounding of a solve whose confounded columns (the patent's pairs) leave it
            // conditioned near 10¹⁰ (a few parts in 10⁶).
            for ((a, b), tolerance) in seen[0].iter().zip(seen[1]).zip([1e-9, 1e-9, 1e-5]) {
                assert!(
                    (a - b).abs() <= tolerance * a.abs().max(b.abs()),
                    "{seen:?}"
                );
            }
        }
    }

    /// Runs `f` with the fits it starts cutting runs of more than 2¹⁶ samples into windows.
    fn in_windows<T>(f: impl FnOnce() -> T) -> T {
        with_window_samples(1 << 15, f)
    }

    /// A run of 100 000 samples at 10 Hz, done whole or (with [`in_windows`]) in windows: its
    /// scalar and fluxgate.
    fn long_run() -> (Vec<f64>, VectorSeries) {
        let (fs, n) = (10.0, 100_000);
        let t = |k: usize| k as f64 / fs;
        let roll = |k: usize| 0.3 * (0.9 * t(k)).sin() + 0.1 * (0.013 * t(k)).sin();
        let pitch = |k: usize| 0.2 * (1.3 * t(k) + 1.0).sin();
        let yaw = |k: usize| 0.002 * t(k) + 0.2 * (0.4 * t(k)).sin();
        let flux = VectorSeries::new(
            (0..n)
                .map(|k| 20_000.0 * yaw(k).cos() * pitch(k).cos())
                .collect(),
            (0..n)
                .map(|k| 20_000.0 * yaw(k).sin() + 900.0 * roll(k))
                .collect(),
            (0..n)
                .map(|k| 45_000.0 + 8_000.0 * pitch(k) * roll(k).cos())
                .collect(),
        );
        let scalar: Vec<f64> = (0..n)
            .map(|k| {
                let u = [flux.x[k], flux.y[k], flux.z[k]].map(|c| c / flux.magnitude(k));
                50_000.0 + 40.0 * u[0] - 25.0 * u[2]
                    + 3e-3 * flux.y[k] * u[1]
                    + 0.01 * (7.1 * t(k)).sin()
            })
            .collect();
        (scalar, flux)
    }

    #[test]
    fn a_long_run_done_in_windows_fits_as_when_done_whole() {
        use crate::fit::window_size::windows_in_tests::DONE;
        let (scalar, flux) = long_run();
        let fs = 10.0;
        let settings = FitSettings::recommended();
        DONE.set(0);
        let windowed = in_windows(|| fit(&scalar, &flux, fs, None, &settings)).unwrap();
        assert!(DONE.get() > 0, "the run was done in windows");
        DONE.set(0);
        let whole = fit(&scalar, &flux, fs, None, &settings).unwrap();
        assert_eq!(DONE.get(), 0, "the production window takes the run whole");
        let d = (&windowed.diagnostics, &whole.diagnostics);
        assert_eq!(d.0.exact_iterations, d.1.exact_iterations);
        assert_eq!(windowed.columns, whole.columns);
        let close = |a: f64, b: f64| (a - b).abs() <= 1e-9 * a.abs().max(b.abs()).max(1e-3);
        for (a, b) in windowed.coefficients.iter().zip(&whole.coefficients) {
            assert!(close(*a, *b), "{a} vs {b}");
        }
        assert!(close(d.0.residual_std_nt, d.1.residual_std_nt));
        assert!(close(
            d.0.filtered_std_before_nt,
            d.1.filtered_std_before_nt
        ));
        assert!(close(windowed.level_nt, whole.level_nt));
    }

    /// A run whose first window is not surely varying (here: level and steady for its first
    /// 5 000 samples) is done whole, on however many cores, the other windows' work dropped.
    #[test]
    fn a_run_steady_at_its_start_is_done_whole() {
        use crate::fit::window_size::windows_in_tests::DONE;
        let (mut scalar, mut flux) = long_run();
        for k in 0..5_000 {
            (flux.x[k], flux.y[k], flux.z[k], scalar[k]) =
                (flux.x[0], flux.y[0], flux.z[0], scalar[0]);
        }
        let settings = FitSettings::recommended();
        DONE.set(0);
        let fitted = || fit(&scalar, &flux, 10.0, None, &settings);
        let dealt = crate::parallel::on_cores(3, || in_windows(fitted));
        assert_eq!(DONE.get(), 0, "no run was done in windows");
        let whole = crate::parallel::on_cores(3, fitted);
        let bits = |f: &Fit| {
            f.coefficients
                .iter()
                .map(|c| c.to_bits())
                .collect::<Vec<_>>()
        };
        assert_eq!(bits(&dealt.unwrap()), bits(&whole.unwrap()));
    }

    /// Each window is worked on one core and the windows' parts are put together in order, so
    /// how many cores share them changes no bit.
    #[test]
    fn windows_dealt_to_any_number_of_cores_give_the_same_bits() {
        use crate::fit::window_size::windows_in_tests::DONE;
        let (scalar, flux) = long_run();
        let settings = FitSettings::recommended();
        let on = |cores| {
            crate::parallel::on_cores(cores, || {
                in_windows(|| fit(&scalar, &flux, 10.0, None, &settings)).unwrap()
            })
        };
        DONE.set(0);
        let (one, three) = (on(1), on(3));
        assert!(DONE.get() >= 2, "both fits were done in windows");
        let bits = |f: &Fit| {
            let d = &f.diagnostics;
            let mut v: Vec<u64> = f.coefficients.iter().map(|c| c.to_bits()).collect();
            v.extend([d.residual_std_nt, d.filtered_std_before_nt, f.level_nt].map(f64::to_bits));
            v
        };
        assert_eq!(bits(&one), bits(&three));
    }

    fn turning_fit() -> Fit {
        let (scalar, flux, settings) = turning_flight();
        fit(&scalar, &flux, 10.0, None, &settings).unwrap()
    }
}
