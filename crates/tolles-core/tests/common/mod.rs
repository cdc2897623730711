//! Shared helpers for integration tests.
#![allow(dead_code)]

use std::path::PathBuf;

/// Reads a MagNav golden CSV (one matrix row per line) as rows of numbers.
pub fn magnav(name: &str) -> Vec<Vec<f64>> {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("tests/fixtures/magnav")
        .join(format!("TL_data.{name}.csv"));
    let text = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    text.lines()
        .filter(|l| !l.trim().is_empty())
        .map(|l| {
            l.split(',')
                .map(|v| v.trim().parse::<f64>().unwrap())
                .collect()
        })
        .collect()
}

/// A MagNav golden column vector.
pub fn magnav_vector(name: &str) -> Vec<f64> {
    magnav(name).into_iter().map(|row| row[0]).collect()
}

/// Population standard deviation.
pub fn std(x: &[f64]) -> f64 {
    let mean = x.iter().sum::<f64>() / x.len() as f64;
    (x.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / x.len() as f64).sqrt()
}

/// How far a survey is from the simulator's true earth field: std of `values − earth_nt` (nT).
pub fn error_vs_truth(values: &[f64], earth_nt: &[f64]) -> f64 {
    let error: Vec<f64> = values.iter().zip(earth_nt).map(|(v, e)| v - e).collect();
    tolles_core::signal::metrics::std_dev(&error)
}

/// `scalar` (nT) compensated with `model` as `tolles compensate` does it: the model's chosen
/// design, the correction's file mean kept, the same sample rate as the calibration.
pub fn compensate_with<'a>(
    model: &tolles_core::fit::Fit,
    scalar: &[f64],
    flux: impl Into<tolles_core::model::vector::Fluxgates<'a>>,
    tt: &[f64],
) -> Vec<f64> {
    let applied = tolles_core::compensate::Model {
        design: &model.settings.design,
        coefficients: &model.coefficients,
        magnitude: model.magnitude,
    };
    tolles_core::compensate::compensate_model(
        scalar,
        flux,
        Some(tt),
        applied,
        1.0,
        tolles_core::compensate::Level::FileMean,
    )
    .compensated
}
