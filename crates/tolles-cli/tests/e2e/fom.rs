//! `tolles fom` end to end: simulated boxes written as CSV, maneuvers found from the attitude.

use crate::common::tolles;

use serde_json::Value;
use std::path::{Path, PathBuf};
use tempfile::TempDir;
use tolles_core::flight::plan::BoxPlan;
use tolles_core::flight::sim::{simulate, Installation, Scenario};
use tolles_io::table::write_columns_to;

/// Runs `tolles ARGS`, expecting success; returns stdout.
fn run(args: &[&str]) -> String {
    let out = tolles().args(args).output().unwrap();
    assert!(
        out.status.success(),
        "{args:?}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8(out.stdout).unwrap()
}

fn json(args: &[&str]) -> Value {
    serde_json::from_str(&run(args)).unwrap()
}

/// `tolles demo --out DIR`: a calibration box (calibration.csv) and its model (model.json).
fn demo(dir: &Path) -> (String, String) {
    run(&["demo", "--out", dir.to_str().unwrap()]);
    let path = |name: &str| dir.join(name).to_str().unwrap().to_string();
    (path("calibration.csv"), path("model.json"))
}

/// A simulated box written as CSV with the attitude columns, `skip` leaving out one column.
fn box_csv(dir: &Path, plan: &BoxPlan, skip: &str) -> PathBuf {
    let f = simulate(
        &plan.build(),
        &Scenario::new(Installation::Cabin.aircraft(), 9),
    )
    .unwrap();
    let columns: Vec<(&str, &[f64])> = [
        ("tt", &f.tt[..]),
        ("ins_roll", &f.roll_deg[..]),
        ("ins_pitch", &f.pitch_deg[..]),
        ("ins_yaw", &f.yaw_deg[..]),
        ("mag_1_uc", &f.scalar[..]),
    ]
    .into_iter()
    .filter(|(name, _)| *name != skip)
    .collect();
    let path = dir.join("box.csv");
    write_columns_to(&path, &columns).unwrap();
    path
}

fn slots(maneuvers: &Value) -> Vec<(u64, String)> {
    let mut out: Vec<(u64, String)> = maneuvers
        .as_array()
        .unwrap()
        .iter()
        .map(|m| {
            (
                m["heading_deg"].as_u64().unwrap(),
                m["kind"].as_str().unwrap().to_string(),
            )
        })
        .collect();
    out.sort();
    out
}

fn all_slots() -> Vec<(u64, String)> {
    let mut out: Vec<(u64, String)> = [0, 90, 180, 270]
        .into_iter()
        .flat_map(|h| ["roll", "pitch", "yaw"].map(|k| (h, k.to_string())))
        .collect();
    out.sort();
    out
}

fn check_block(block: &Value) {
    let maneuvers = block["maneuvers"].as_array().unwrap();
    let sum: f64 = maneuvers
        .iter()
        .map(|m| m["peak_to_peak_nT"].as_f64().unwrap())
        .sum();
    let fom = block["fom_nT"].as_f64().unwrap();
    assert!((sum - fom).abs() < 1e-9 * fom.max(1.0), "{sum} vs {fom}");
    assert_eq!(block["band_hz"], serde_json::json!([0.05, 1.0]));
    assert!(block["fourth_difference_nT"].as_f64().unwrap() > 0.0);
    for m in maneuvers {
        assert!(m["start_tt"].as_f64().unwrap() < m["end_tt"].as_f64().unwrap());
    }
}

#[test]
fn fom_of_the_demo_box_before_and_after_its_model() {
    let dir = TempDir::new().unwrap();
    let (cal, model) = demo(dir.path());
    let before = json(&["fom", &cal, "--scalar", "mag_1_uc", "--json"]);
    check_block(&before);
    assert_eq!(slots(&before["maneuvers"]), all_slots());
    assert_eq!(before["missing"], serde_json::json!([]));
    assert_eq!(before["extra_maneuvers"], serde_json::json!([]));
    assert!(before["improvement_ratio"].is_null());
    assert!(before.get("compensated").is_none());
    let roll_north = &before["maneuvers"][0];
    assert_eq!(roll_north["kind"], "roll");
    assert_eq!(roll_north["heading_deg"], 0);
    assert!((roll_north["start_tt"].as_f64().unwrap() - 10.0).abs() < 0.2);
    assert!((roll_north["end_tt"].as_f64().unwrap() - 28.0).abs() < 0.2);

    let both = json(&[
        "fom", &cal, "--scalar", "mag_1_uc", "--model", &model, "--json",
    ]);
    check_block(&both);
    check_block(&both["compensated"]);
    let fom_before = both["fom_nT"].as_f64().unwrap();
    let fom_after = both["compensated"]["fom_nT"].as_f64().unwrap();
    assert_eq!(fom_before, before["fom_nT"].as_f64().unwrap());
    assert!(fom_before > 50.0, "a cabin installation: {fom_before}");
    assert!(
        fom_after < 1.0 && fom_after * 50.0 < fom_before,
        "{fom_after}"
    );
    let ratio = both["improvement_ratio"].as_f64().unwrap();
    assert!((ratio - fom_before / fom_after).abs() < 1e-9 * ratio);
    // The same windows are used for both.
    assert_eq!(
        both["maneuvers"][5]["start_tt"],
        both["compensated"]["maneuvers"][5]["start_tt"]
    );

    let table = run(&["fom", &cal, "--scalar", "mag_1_uc", "--model", &model]);
    assert!(table.contains("0.05–1 Hz"), "{table}");
    assert!(table.contains("improvement ratio"), "{table}");
    assert!(table.contains("fourth-difference noise"), "{table}");
    assert_eq!(
        table.lines().filter(|l| l.contains("° ")).count(),
        12,
        "{table}"
    );
    assert!(!table.contains("missing"), "{table}");
    assert!(table.contains("heading error: "), "{table}");
    assert!(table.contains(" nT after"), "{table}");
    assert!(table.contains("compensated (nT)"), "{table}");

    // The demo flies over geology, which stays in the heading error: it drops, not to zero.
    let heading = |block: &Value| block["heading_error"]["heading_error_nT"].as_f64().unwrap();
    let (error_before, error_after) = (heading(&both), heading(&both["compensated"]));
    assert_eq!(error_before, heading(&before));
    assert!(
        error_before > error_after,
        "{error_before} -> {error_after}"
    );
}

/// `tolles simulate` with a uniform earth field, no geology and no diurnal variation, then
/// `tolles fit`: the heading error is the aircraft's alone, and compensation removes it.
#[test]
fn the_heading_error_of_a_uniform_field_box_vanishes_with_its_model() {
    let dir = TempDir::new().unwrap();
    let path = |name: &str| dir.path().join(name).to_str().unwrap().to_string();
    let (csv, model) = (path("box.csv"), path("model.json"));
    run(&[
        "simulate",
        "--out",
        &csv,
        "--inclination",
        "68",
        "--declination",
        "-3",
        "--intensity",
        "52000",
        "--geology",
        "0",
        "--diurnal",
        "0",
    ]);
    run(&[
        "fit", &csv, "--scalar", "mag_1_uc", "--vector", "flux_a", "--out", &model,
    ]);
    let report = json(&[
        "fom", &csv, "--scalar", "mag_1_uc", "--model", &model, "--json",
    ]);
    let (before, after) = (
        &report["heading_error"],
        &report["compensated"]["heading_error"],
    );
    let number = |block: &Value, key: &str| block[key].as_f64().unwrap();
    assert!(number(before, "heading_error_nT") > 30.0, "{before}");
    assert!(number(before, "uncertainty_nT") < 1.0, "{before}");
    assert!(number(after, "heading_error_nT") < 0.5, "{after}");
    let levels = before["levels"].as_array().unwrap();
    let headings: Vec<u64> = levels
        .iter()
        .map(|l| l["heading_deg"].as_u64().unwrap())
        .collect();
    assert_eq!(headings, [0, 90, 180, 270]);
    for (b, a) in levels.iter().zip(after["levels"].as_array().unwrap()) {
        assert_eq!(b["samples"], a["samples"]);
        assert!(b["samples"].as_u64().unwrap() > 30, "{b}");
        assert!(b["std_error_nT"].as_f64().unwrap() >= 0.0, "{b}");
        assert!(b["level_nT"].as_f64().unwrap() > 50_000.0, "{b}");
    }
    assert_eq!(before["skipped"], serde_json::json!([]));

    let table = run(&["fom", &csv, "--scalar", "mag_1_uc", "--model", &model]);
    let line = table
        .lines()
        .find(|l| l.starts_with("heading error: "))
        .unwrap_or_else(|| panic!("{table}"));
    assert!(
        line.contains(" nT before, ") && line.ends_with(" nT after"),
        "{line}"
    );
    let without = run(&["fom", &csv, "--scalar", "mag_1_uc"]);
    assert!(!without.contains(" after"), "{without}");
    assert!(without.contains("heading error: "), "{without}");
}

#[test]
fn a_box_without_pitches_reports_them_missing() {
    let dir = TempDir::new().unwrap();
    let plan = BoxPlan {
        pitch_deg: 0.0,
        ..BoxPlan::default()
    };
    let csv = box_csv(dir.path(), &plan, "");
    let csv = csv.to_str().unwrap();
    let report = json(&["fom", csv, "--scalar", "mag_1_uc", "--json"]);
    check_block(&report);
    let missing = slots(&report["missing"]);
    assert_eq!(
        missing,
        [0, 90, 180, 270].map(|h| (h, "pitch".to_string())).to_vec()
    );
    assert_eq!(report["maneuvers"].as_array().unwrap().len(), 8);
    let table = run(&["fom", csv, "--scalar", "mag_1_uc"]);
    assert!(table.contains("missing: pitch on heading 180°"), "{table}");
    assert!(!table.contains("missing: roll"), "{table}");
}

#[test]
fn band_and_sample_rate_options_are_used() {
    let dir = TempDir::new().unwrap();
    let csv = box_csv(dir.path(), &BoxPlan::default(), "");
    let csv = csv.to_str().unwrap();
    let report = json(&[
        "fom", csv, "--scalar", "mag_1_uc", "--band", "0.1,0.9", "--json",
    ]);
    assert_eq!(report["band_hz"], serde_json::json!([0.1, 0.9]));
    assert_eq!(report["maneuvers"].as_array().unwrap().len(), 12);
    // No time column: --fs gives the time base.
    let no_time = box_csv(dir.path(), &BoxPlan::default(), "tt");
    let no_time = no_time.to_str().unwrap();
    let report = json(&[
        "fom", no_time, "--scalar", "mag_1_uc", "--fs", "10", "--json",
    ]);
    assert_eq!(report["maneuvers"].as_array().unwrap().len(), 12);
}

/// Runs `tolles ARGS` expecting failure with a one-line error; returns it.
fn fails(args: &[&str]) -> String {
    let out = tolles().args(args).output().unwrap();
    assert!(!out.status.success(), "expected failure for {args:?}");
    let stderr = String::from_utf8(out.stderr).unwrap();
    assert!(!stderr.contains("panicked"), "{stderr}");
    assert_eq!(
        stderr.trim_end().lines().count(),
        1,
        "not one line: {stderr}"
    );
    assert!(stderr.starts_with("error: "), "{stderr}");
    stderr
}

#[test]
fn missing_attitude_is_a_survey_and_a_missing_scalar_a_one_line_error() {
    let dir = TempDir::new().unwrap();
    let csv = box_csv(dir.path(), &BoxPlan::default(), "ins_yaw");
    let csv = csv.to_str().unwrap();
    // Without attitude there are no maneuvers, but the noise is still measured.
    let out = tolles()
        .args(["fom", csv, "--scalar", "mag_1_uc"])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{err}");
    assert!(err.contains("box.csv: no attitude column ins_yaw"), "{err}");
    assert!(String::from_utf8_lossy(&out.stdout).contains("FOM  none"));
    let full = TempDir::new().unwrap();
    let full = box_csv(full.path(), &BoxPlan::default(), "");
    let err = fails(&["fom", full.to_str().unwrap(), "--scalar", "mag_9"]);
    assert!(err.contains("mag_9"), "{err}");
    let err = fails(&["fom", csv, "--scalar", "mag_1_uc", "--band", "0.1"]);
    assert!(err.contains("--band"), "{err}");
}

#[test]
fn a_model_for_another_scalar_is_refused() {
    let dir = TempDir::new().unwrap();
    let (_, model) = demo(&dir.path().join("demo"));
    let csv = box_csv(dir.path(), &BoxPlan::default(), "");
    let text = std::fs::read_to_string(&csv)
        .unwrap()
        .replacen("mag_1_uc", "mag_2_uc", 1);
    std::fs::write(&csv, text).unwrap();
    let err = fails(&[
        "fom",
        csv.to_str().unwrap(),
        "--scalar",
        "mag_2_uc",
        "--model",
        &model,
    ]);
    assert!(
        err.contains("mag_2_uc") && err.contains("mag_1_uc"),
        "{err}"
    );
}

/// A box flown 6° east of the cardinal headings: the default tolerances take its legs and
/// maneuvers; tighter ones leave them out; other nominal headings find their own legs.
#[test]
fn heading_tolerances_and_nominal_headings_are_flags() {
    let dir = TempDir::new().unwrap();
    let plan = BoxPlan {
        headings_deg: vec![6.0, 96.0, 186.0, 276.0],
        ..BoxPlan::default()
    };
    let csv = box_csv(dir.path(), &plan, "");
    let csv = csv.to_str().unwrap();
    let fom = |flags: &[&str]| {
        let mut args = vec!["fom", csv, "--scalar", "mag_1_uc", "--json"];
        args.extend(flags);
        json(&args)
    };
    let levels = |v: &Value| -> Vec<(f64, u64)> {
        let levels = v["heading_error"]["levels"].as_array().unwrap();
        levels
            .iter()
            .map(|l| {
                let heading = l["heading_deg"].as_f64().unwrap();
                (heading, l["samples"].as_u64().unwrap())
            })
            .collect()
    };

    let default = fom(&[]);
    assert_eq!(slots(&default["maneuvers"]), all_slots());
    let found = levels(&default);
    assert_eq!(found.len(), 4, "{found:?}");

    let tight = fom(&["--heading-tolerance", "3", "--cardinal-tolerance", "3"]);
    assert!(levels(&tight).is_empty(), "{:?}", levels(&tight));
    assert_eq!(tight["missing"].as_array().unwrap().len(), 12, "{tight}");
    assert!(tight["fom_nT"].as_f64().is_none_or(|f| f == 0.0), "{tight}");

    let own = fom(&["--headings", "6,96,186,276", "--heading-tolerance", "3"]);
    let own_levels = levels(&own);
    assert_eq!(
        own_levels.iter().map(|l| l.0).collect::<Vec<_>>(),
        [6.0, 96.0, 186.0, 276.0]
    );
    // The same legs: nothing of them lies more than 3° off their own heading.
    let samples = |l: &[(f64, u64)]| l.iter().map(|l| l.1).collect::<Vec<_>>();
    assert_eq!(samples(&own_levels), samples(&found));

    let level = fom(&["--level-tolerance", "0.01"]);
    let fewer: u64 = samples(&levels(&level)).iter().sum();
    assert!(fewer < samples(&found).iter().sum(), "{fewer}");

    for (flag, value) in [
        ("--heading-tolerance", "91"),
        ("--heading-tolerance", "-1"),
        ("--cardinal-tolerance", "nan"),
        ("--cardinal-tolerance", "46"),
        ("--level-tolerance", "inf"),
        ("--headings", "0,inf"),
    ] {
        let err = fails(&["fom", csv, "--scalar", "mag_1_uc", flag, value]);
        assert!(err.contains(flag), "{flag} {value}: {err}");
    }
}
