//! Helpers shared by the end-to-end tests.
#![allow(dead_code)]

use assert_cmd::Command;
use std::path::Path;

/// The `tolles` binary under test.
pub fn tolles() -> Command {
    Command::cargo_bin("tolles").unwrap()
}

/// Runs `tolles ARGS` in `dir`, expecting success; returns its stdout and stderr.
pub fn run_in(dir: &Path, args: &[&str]) -> (String, String) {
    let out = tolles().current_dir(dir).args(args).output().unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr).to_string();
    assert!(out.status.success(), "{args:?}: {stderr}");
    (String::from_utf8(out.stdout).unwrap(), stderr)
}

/// Fits `box.csv` in `dir` with `flags` (`--scalar mag_1_uc --vector flux_a`), compensates
/// `survey.csv` with the model; the survey's error against the truth where it was computed
/// (nT) and `fit`'s standard error.
pub fn survey_error(dir: &Path, flags: &[&str]) -> (f64, String) {
    let fit = [
        "fit", "box.csv", "--scalar", "mag_1_uc", "--vector", "flux_a", "--out", "m.json",
    ];
    let (_, stderr) = run_in(dir, &[&fit[..], flags].concat());
    run_in(
        dir,
        &[
            "compensate",
            "survey.csv",
            "--model",
            "m.json",
            "--out",
            "c.csv",
        ],
    );
    let csv = std::fs::read_to_string(dir.join("c.csv")).unwrap();
    (error_vs_truth_where_computed(&csv, "mag_1_c"), stderr)
}

/// A column of MagNav's golden Tolles-Lawson test data, one value per line.
pub fn magnav(name: &str) -> Vec<f64> {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../tolles-core/tests/fixtures/magnav")
        .join(format!("TL_data.{name}.csv"));
    std::fs::read_to_string(path)
        .unwrap()
        .lines()
        .map(|l| l.trim().parse().unwrap())
        .collect()
}

/// Column `name` of CSV text; `None` for an empty or non-numeric cell.
pub fn column(csv: &str, name: &str) -> Vec<Option<f64>> {
    let mut lines = csv.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let k = header
        .iter()
        .position(|h| *h == name)
        .unwrap_or_else(|| panic!("no {name} in {header:?}"));
    lines
        .map(|l| l.split(',').nth(k).unwrap().parse().ok())
        .collect()
}

/// Std (nT) of column `name` minus `truth_earth` in CSV text; every cell must be a number.
pub fn error_vs_truth(csv: &str, name: &str) -> f64 {
    let error: Vec<f64> = column(csv, name)
        .iter()
        .zip(column(csv, "truth_earth"))
        .map(|(c, t)| c.unwrap() - t.unwrap())
        .collect();
    std(&error)
}

/// As [`error_vs_truth`] over the rows where `name` has a value (a lag leaves a few rows at
/// the ends without one).
pub fn error_vs_truth_where_computed(csv: &str, name: &str) -> f64 {
    let error: Vec<f64> = column(csv, name)
        .iter()
        .zip(column(csv, "truth_earth"))
        .filter_map(|(c, t)| Some(c.as_ref()? - t?))
        .collect();
    std(&error)
}

/// Population standard deviation.
pub fn std(x: &[f64]) -> f64 {
    let mean = x.iter().sum::<f64>() / x.len() as f64;
    (x.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / x.len() as f64).sqrt()
}
