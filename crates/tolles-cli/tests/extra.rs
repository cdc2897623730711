//! `fit --extra`: a UAV's motor current as a regressor, end to end.

mod common;

use common::{column, std, tolles};
use std::path::Path;
use tempfile::TempDir;

fn simulate(dir: &Path, plan: &str, seed: &str) {
    tolles()
        .current_dir(dir)
        .args([
            "simulate", "--preset", "uav", "--plan", plan, "--seed", seed, "--out",
        ])
        .arg(format!("{plan}.csv"))
        .assert()
        .success();
}

/// Fits the box with `flags`, compensates the survey; returns the error against the truth
/// (nT) and `fit`'s standard error.
fn survey_error(dir: &Path, flags: &[&str]) -> (f64, String) {
    let out = tolles()
        .current_dir(dir)
        .args([
            "fit", "box.csv", "--scalar", "mag_1_uc", "--vector", "flux_a", "--out", "m.json",
        ])
        .args(flags)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    tolles()
        .current_dir(dir)
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
    let csv = std::fs::read_to_string(dir.join("c.csv")).unwrap();
    let error: Vec<f64> = column(&csv, "mag_1_c")
        .iter()
        .zip(column(&csv, "truth_earth"))
        .map(|(c, t)| c.unwrap() - t.unwrap())
        .collect();
    (std(&error), String::from_utf8(out.stderr).unwrap())
}

#[test]
fn a_motor_current_as_an_extra_channel_is_compensated() {
    let dir = TempDir::new().unwrap();
    simulate(dir.path(), "box", "1");
    simulate(dir.path(), "survey", "2");
    let (without, warned) = survey_error(dir.path(), &[]);
    let (with, summary) = survey_error(dir.path(), &["--extra", "cur_1"]);
    eprintln!("UAV survey against the truth: {without:.4} nT without --extra, {with:.4} nT with --extra cur_1");
    assert!(warned.contains("try --extra"), "{warned}");
    assert!(!summary.contains("try --extra"), "{summary}");
    assert!(summary.contains("+cur_1"), "{summary}");
    assert!(with < 0.05 && without > 100.0 * with, "{without} -> {with}");
    let model = std::fs::read_to_string(dir.path().join("m.json")).unwrap();
    assert!(
        model.contains(r#""extras": ["#) && model.contains("cur_1_x"),
        "{model}"
    );
    // A live stream cannot take the channel yet, and says so in one line.
    let out = tolles()
        .current_dir(dir.path())
        .args(["stream", "--model", "m.json"])
        .write_stdin(std::fs::read_to_string(dir.path().join("survey.csv")).unwrap())
        .output()
        .unwrap();
    assert!(!out.status.success());
    let stderr = String::from_utf8(out.stderr).unwrap();
    assert!(
        stderr.contains("extra channels (cur_1)") && stderr.lines().count() == 1,
        "{stderr}"
    );
}

#[test]
fn a_fluxgate_lag_is_estimated_stored_and_applied() {
    let dir = TempDir::new().unwrap();
    tolles()
        .current_dir(dir.path())
        .args(["simulate", "--flux-lag", "0.05", "--out", "box.csv"])
        .assert()
        .success();
    let fit = |lag: &str, out: &str| {
        let o = tolles()
            .current_dir(dir.path())
            .args([
                "fit", "box.csv", "--scalar", "mag_1_uc", "--vector", "flux_a", "--lag", lag,
                "--out", out,
            ])
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let model: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(dir.path().join(out)).unwrap()).unwrap();
        model["fits"][0]["lag_s"].as_f64().unwrap_or(0.0)
    };
    let found = fit("auto", "auto.json");
    eprintln!("simulated lag 0.05 s, found {found:.4} s");
    assert!((found - 0.05).abs() * 10.0 < 0.1, "{found}");
    assert_eq!(fit("-0.02", "given.json"), -0.02);
    // Compensation reads the fluxgate that much later: better than ignoring the lag.
    let error = |model: &str| {
        tolles()
            .current_dir(dir.path())
            .args(["compensate", "box.csv", "--model", model, "--out", "c.csv"])
            .assert()
            .success();
        let csv = std::fs::read_to_string(dir.path().join("c.csv")).unwrap();
        let e: Vec<f64> = column(&csv, "mag_1_c")
            .iter()
            .zip(column(&csv, "truth_earth"))
            .filter_map(|(c, t)| Some(c.as_ref()? - t?))
            .collect();
        std(&e)
    };
    fit("none", "none.json");
    let (with, without) = (error("auto.json"), error("none.json"));
    eprintln!("box against the truth: {without:.4} nT ignoring the lag, {with:.4} nT with it");
    assert!(with < without, "{with} vs {without}");
}
