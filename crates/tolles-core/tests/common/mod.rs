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
