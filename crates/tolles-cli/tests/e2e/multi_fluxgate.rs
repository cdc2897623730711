//! `--vector flux_a,flux_b` end to end: a UAV whose motor current disturbs the scalar, with a
//! second fluxgate beside the motor cable.

use crate::common::{error_vs_truth, tolles};

use std::path::{Path, PathBuf};
use tempfile::TempDir;

/// Field of the motor cable at fluxgate B per ampere (nT/A, body frame).
const AT_FLUXGATE_B: [f64; 3] = [25.0, -12.0, 18.0];

/// Simulates a UAV flight and adds fluxgate B: fluxgate A's reading plus the cable's field.
fn uav_flight(dir: &Path, plan: &str, seed: &str) -> PathBuf {
    let path = dir.join(format!("{plan}.csv"));
    tolles()
        .args([
            "simulate", "--preset", "uav", "--plan", plan, "--seed", seed, "--out",
        ])
        .arg(&path)
        .assert()
        .success();
    let text = std::fs::read_to_string(&path).unwrap();
    let mut lines = text.lines();
    let header = lines.next().unwrap();
    let names: Vec<&str> = header.split(',').collect();
    let at = |name: &str| names.iter().position(|n| *n == name).unwrap();
    let (x, current) = (at("flux_a_x"), at("cur_1"));
    let mut out = format!("{header},flux_b_x,flux_b_y,flux_b_z\n");
    for line in lines {
        let cells: Vec<f64> = line.split(',').map(|c| c.parse().unwrap()).collect();
        let b: Vec<String> = (0..3)
            .map(|j| (cells[x + j] + cells[current] * AT_FLUXGATE_B[j]).to_string())
            .collect();
        out += &format!("{line},{}\n", b.join(","));
    }
    std::fs::write(&path, out).unwrap();
    path
}

/// Fits with `vectors`, compensates the survey and returns the survey's error against the
/// true earth field (nT) and the model file's text.
fn survey_error(dir: &Path, cal: &Path, survey: &Path, vectors: &str) -> (f64, String) {
    let model = dir.join(format!("{vectors}.json"));
    tolles()
        .arg("fit")
        .arg(cal)
        .args(["--scalar", "mag_1_uc", "--vector", vectors, "--out"])
        .arg(&model)
        .assert()
        .success();
    let out = tolles()
        .arg("compensate")
        .arg(survey)
        .arg("--model")
        .arg(&model)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let csv = String::from_utf8(out.stdout).unwrap();
    (
        error_vs_truth(&csv, "mag_1_c"),
        std::fs::read_to_string(model).unwrap(),
    )
}

#[test]
fn a_fluxgate_beside_the_motor_cable_removes_the_motor_field() {
    let dir = TempDir::new().unwrap();
    let cal = uav_flight(dir.path(), "box", "3");
    let survey = uav_flight(dir.path(), "survey", "4");
    let (single, _) = survey_error(dir.path(), &cal, &survey, "flux_a");
    let (both, model) = survey_error(dir.path(), &cal, &survey, "flux_a,flux_b");
    eprintln!("survey error: flux_a {single:.3} nT, flux_a,flux_b {both:.3} nT");
    assert!(both < 0.2 * single, "{both} vs {single}");
    let model: serde_json::Value = serde_json::from_str(&model).unwrap();
    let fit = &model["fits"][0];
    assert_eq!(fit["vectors"], serde_json::json!(["flux_a", "flux_b"]));
    let columns = fit["columns"].as_array().unwrap();
    assert!(columns.contains(&serde_json::json!("flux_b.perm_x")));
    assert_eq!(fit["coefficients"].as_array().unwrap().len(), columns.len());
}

#[test]
fn a_missing_fluxgate_or_a_repeated_one_is_a_one_line_error() {
    let dir = TempDir::new().unwrap();
    let cal = uav_flight(dir.path(), "box", "3");
    for (vectors, expected) in [
        ("flux_a,flux_c", "flux_c_x"),
        ("flux_a,flux_a", "--vector names \"flux_a\" twice"),
    ] {
        let out = tolles()
            .arg("fit")
            .arg(&cal)
            .args(["--scalar", "mag_1_uc", "--vector", vectors])
            .output()
            .unwrap();
        let err = String::from_utf8(out.stderr).unwrap();
        assert!(!out.status.success());
        assert_eq!(err.trim().lines().count(), 1, "{err}");
        assert!(err.contains(expected), "{err}");
    }
}
