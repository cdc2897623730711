//! `fit --reference`: a cabin magnetometer fitted against a compensated reference, end to end.

use crate::common::{error_vs_truth, tolles};
use std::path::Path;
use tempfile::TempDir;

fn simulate(dir: &Path, plan: &str, seed: &str) {
    tolles()
        .current_dir(dir)
        .args([
            "simulate", "--preset", "cabin", "--plan", plan, "--seed", seed, "--out",
        ])
        .arg(format!("{plan}.csv"))
        .assert()
        .success();
}

#[test]
fn a_cabin_sensor_fitted_against_the_truth_compensates_a_survey() {
    let dir = TempDir::new().unwrap();
    simulate(dir.path(), "box", "1");
    simulate(dir.path(), "survey", "2");
    let fitted = tolles()
        .current_dir(dir.path())
        .args([
            "fit",
            "box.csv",
            "--scalar",
            "mag_1_uc",
            "--vector",
            "flux_a",
            "--reference",
            "truth_earth",
            "--out",
            "m.json",
        ])
        .output()
        .unwrap();
    let summary = String::from_utf8_lossy(&fitted.stderr);
    assert!(fitted.status.success(), "{summary}");
    assert!(
        summary.contains("mag_1_uc − truth_earth (full band)"),
        "{summary}"
    );
    let model = std::fs::read_to_string(dir.path().join("m.json")).unwrap();
    assert!(model.contains(r#""reference": "truth_earth""#), "{model}");
    assert!(model.contains(r#""target": "interference""#), "{model}");
    // Compensation needs only the cabin sensor and the fluxgate.
    tolles()
        .current_dir(dir.path())
        .args([
            "compensate",
            "survey.csv",
            "--model",
            "m.json",
            "--out",
            "c.csv",
        ])
        .assert()
        .success();
    let csv = std::fs::read_to_string(dir.path().join("c.csv")).unwrap();
    let (before, after) = (
        error_vs_truth(&csv, "mag_1_uc"),
        error_vs_truth(&csv, "mag_1_c"),
    );
    eprintln!("cabin survey against the truth: {before:.3} nT uncompensated, {after:.4} nT after");
    assert!(
        after < 0.05 && before > 100.0 * after,
        "{before} -> {after}"
    );
}

#[test]
fn the_reference_cannot_be_a_scalar_being_fitted() {
    let dir = TempDir::new().unwrap();
    simulate(dir.path(), "box", "3");
    let out = tolles()
        .current_dir(dir.path())
        .args([
            "fit",
            "box.csv",
            "--scalar",
            "mag_1_uc",
            "--vector",
            "flux_a",
            "--reference",
            "mag_1_uc",
        ])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success());
    assert!(err.contains("is also a scalar to fit"), "{err}");
    let out = tolles()
        .current_dir(dir.path())
        .args([
            "fit",
            "box.csv",
            "--scalar",
            "mag_1_uc",
            "--vector",
            "flux_a",
            "--reference",
            "mag_9_c",
        ])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success() && err.contains("mag_9_c"), "{err}");
    assert_eq!(err.trim().lines().count(), 1, "{err}");
}
