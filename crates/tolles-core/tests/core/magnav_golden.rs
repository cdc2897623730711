//! Golden parity with MagNav.jl's Tolles-Lawson test data.

use crate::common::{magnav, magnav_vector, std};
use nalgebra::DMatrix;
use tolles_core::compensate::{compensate, Level};
use tolles_core::fit::ridge::ridge;
use tolles_core::fit::{fit, FitSettings};
use tolles_core::model::design::Design;
use tolles_core::model::terms::TermSet;
use tolles_core::model::vector::VectorSeries;

fn flux() -> VectorSeries {
    VectorSeries::new(
        magnav_vector("flux_a_x"),
        magnav_vector("flux_a_y"),
        magnav_vector("flux_a_z"),
    )
}

fn matrix(rows: Vec<Vec<f64>>) -> DMatrix<f64> {
    let ncols = rows[0].len();
    DMatrix::from_row_iterator(rows.len(), ncols, rows.into_iter().flatten())
}

#[test]
fn a_matrix_matches_create_tl_a_to_1e_12() {
    let want = matrix(magnav("A_a"));
    let got = Design::new(TermSet::magnav_default()).matrix(&flux());
    assert_eq!(got.shape(), (1000, 18));
    let worst = (got - &want).abs().max();
    assert!(worst < 1e-12, "max |ΔA| = {worst:e}");
}

#[test]
fn ridge_on_stored_filtered_arrays_matches_tl_a_1_to_1e_9() {
    let a = matrix(magnav("A_a_f_t"));
    let y = magnav_vector("mag_1_uc_f_t");
    let want = magnav_vector("TL_a_1");
    let got = ridge(&a, &y, 0.001).unwrap().coefficients;
    for (k, (g, w)) in got.iter().zip(&want).enumerate() {
        let rel = (g - w).abs() / w.abs().max(1e-300);
        assert!(rel < 1e-9, "coefficient {k}: {g} vs {w} (rel {rel:e})");
    }
}

#[test]
fn compensation_with_stored_coefficients_matches_mag_1_c_up_to_a_constant() {
    let coefficients = magnav_vector("TL_a_1");
    let uc = magnav_vector("mag_1_uc");
    let design = Design::new(TermSet::magnav_default());
    let ours = compensate(
        &uc,
        &flux(),
        None,
        &design,
        &coefficients,
        1.0,
        Level::FileMean,
    );
    let reference = magnav_vector("mag_1_c");
    let diff: Vec<f64> = ours
        .compensated
        .iter()
        .zip(&reference)
        .map(|(a, b)| a - b)
        .collect();
    assert!(std(&diff) < 1e-9, "std = {:e}", std(&diff));
}

#[test]
fn end_to_end_fit_and_compensation_are_within_magnav_tolerance() {
    let uc = magnav_vector("mag_1_uc");
    let fs = magnav_vector("fs")[0];
    let settings = FitSettings::magnav();
    let model = fit(&uc, &flux(), fs, None, &settings).unwrap();
    assert_eq!(model.diagnostics.samples_used, 960);
    for (name, level) in [
        ("mag_1_c", Level::FileMean),
        ("mag_1_c_d", Level::FileLinearTrend),
    ] {
        let ours = compensate(
            &uc,
            &flux(),
            None,
            &settings.design,
            &model.coefficients,
            1.0,
            level,
        );
        let reference = magnav_vector(name);
        let diff: Vec<f64> = ours
            .compensated
            .iter()
            .zip(&reference)
            .map(|(a, b)| a - b)
            .collect();
        let s = std(&diff);
        assert!(s < 0.1, "std(ours − {name}) = {s} nT");
        eprintln!("std(ours − {name}) = {s:.4} nT");
    }
}

#[test]
fn fit_equals_magnav_procedure_with_scipy_filter() {
    // scripts/fixtures/gen_magnav_pipeline.py: the same procedure in numpy/scipy.
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/fixtures/magnav/scipy_pipeline_beta.csv");
    let want: Vec<f64> = std::fs::read_to_string(path)
        .unwrap()
        .lines()
        .map(|l| l.trim().parse().unwrap())
        .collect();
    let uc = magnav_vector("mag_1_uc");
    let fs = magnav_vector("fs")[0];
    let got = fit(&uc, &flux(), fs, None, &FitSettings::magnav())
        .unwrap()
        .coefficients;
    let scale = want.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    for (k, (g, w)) in got.iter().zip(&want).enumerate() {
        // Normal equations in numpy lose digits at cond ≈ 1e7; 1e-6 of the largest is ample.
        assert!((g - w).abs() < 1e-6 * scale, "coefficient {k}: {g} vs {w}");
    }
}

/// MagNav's real snippet: its low frequencies miss the band's model by tens of nT (the levels
/// of a real flight hold what no term models), so the recommended fit leaves the heading
/// levels (asked for) out and says by how much they missed. A simulated box's, which the model describes
/// to about 0.1 nT, keep steering its fit (the unit tests of `fit` unwrap their diagnostics).
#[test]
fn a_real_flight_whose_levels_the_model_misses_is_fitted_on_its_band_alone() {
    let uc = magnav_vector("mag_1_uc");
    let fs = magnav_vector("fs")[0];
    let settings = FitSettings {
        levels: true,
        ..FitSettings::recommended()
    };
    let model = fit(&uc, &flux(), fs, None, &settings).unwrap();
    let misfit = model.diagnostics.untrusted_levels_nt;
    eprintln!("MagNav's snippet: heading levels miss the band's model by {misfit:?} nT");
    assert!(misfit.is_some_and(|m| m > 10.0), "{misfit:?}");
    assert!(model.diagnostics.levels.is_none());
    let band_only = FitSettings {
        levels: false,
        ..FitSettings::recommended()
    };
    let without = fit(&uc, &flux(), fs, None, &band_only).unwrap();
    // The same model up to rounding (the rows were prepared with the level rows beside them).
    for (a, b) in model.coefficients.iter().zip(&without.coefficients) {
        assert!((a - b).abs() <= 1e-9 * b.abs().max(1.0), "{a} against {b}");
    }
}

/// The band-passed (0.1–0.9 Hz) standard deviation of `x` (nT), 20 samples trimmed each end.
fn band_std(x: &[f64], fs: f64) -> f64 {
    let filter = tolles_core::signal::filter::magnav_bandpass(0.1, 0.9, 4, fs)
        .unwrap()
        .unwrap();
    let y = filter.filtfilt(x).unwrap();
    std(&y[20..y.len() - 20])
}

/// MagNav's real snippet is 100 s without maneuvers (its first half moves the fluxgate's
/// direction 0.72° RMS in the band): its held-out folds cannot separate the terms, so the fit
/// takes the strongest prior they cannot tell from the best. Fitted on the first half, it then
/// leaves the second half's band below raw and below MagNav's settings; taking the prior the
/// folds liked best left 0.205 nT, more than the raw 0.136 nT.
#[test]
fn a_calibration_without_maneuvers_keeps_the_strongest_prior_its_folds_allow() {
    let uc = magnav_vector("mag_1_uc");
    let fs = magnav_vector("fs")[0];
    let (x, y, z) = (
        magnav_vector("flux_a_x"),
        magnav_vector("flux_a_y"),
        magnav_vector("flux_a_z"),
    );
    let half = |v: &[f64], first: bool| match first {
        true => v[..500].to_vec(),
        false => v[500..].to_vec(),
    };
    let flux = |first| VectorSeries::new(half(&x, first), half(&y, first), half(&z, first));
    let residual = |settings: &FitSettings| {
        let model = fit(&half(&uc, true), &flux(true), fs, None, settings).unwrap();
        let out = compensate(
            &half(&uc, false),
            &flux(false),
            None,
            &model.settings.design,
            &model.coefficients,
            1.0,
            Level::FileMean,
        );
        band_std(&out.compensated, fs)
    };
    let raw = band_std(&half(&uc, false), fs);
    let magnav = residual(&FitSettings::magnav());
    let ours = residual(&FitSettings::recommended());
    eprintln!(
        "MagNav's snippet, second half: raw {raw:.4} nT, MagNav's settings {magnav:.4} nT, defaults {ours:.4} nT"
    );
    assert!(
        ours < raw && ours <= magnav,
        "{ours} against {raw}, {magnav}"
    );
}
