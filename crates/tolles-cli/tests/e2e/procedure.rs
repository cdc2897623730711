//! `tolles procedure` end to end, on simulated patent flights whose truth is known.

use assert_cmd::Command;
use serde_json::Value;
use std::path::{Path, PathBuf};

fn tolles(args: &[&str]) -> std::process::Output {
    Command::cargo_bin("tolles")
        .unwrap()
        .args(args)
        .output()
        .unwrap()
}

fn ok(out: &std::process::Output) -> String {
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8_lossy(&out.stdout).into_owned()
}

/// The patent flight of the cabin preset, high up (no geology, no diurnal variation).
fn patent_flight(dir: &Path, extra: &[&str]) -> PathBuf {
    let csv = dir.join("f.csv");
    let mut args = vec![
        "simulate",
        "--plan",
        "patent",
        "--preset",
        "cabin",
        "--geology",
        "0",
        "--diurnal",
        "0",
        "--out",
        csv.to_str().unwrap(),
    ];
    args.extend_from_slice(extra);
    ok(&tolles(&args));
    csv
}

fn read_json(path: &Path) -> Value {
    serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap()
}

const GROUPS: [(&str, &[&str], f64); 3] = [
    ("perm_nT", &["T", "L", "V"], 0.05),
    (
        "induced",
        &["VV-TT", "VV-LL", "TL+LT", "TV+VT", "LV+VL"],
        0.08,
    ),
    (
        "eddy_s",
        &["vv-tt", "vv-ll", "tl", "tv", "lt", "lv", "vl", "vt"],
        0.15,
    ),
];

/// Every term within its group's tolerance (a fraction of the group's largest true term).
fn assert_accurate(terms: &Value, truth: &Value) {
    for (group, names, fraction) in GROUPS {
        let largest = names
            .iter()
            .map(|n| truth[group][n].as_f64().unwrap().abs())
            .fold(0.0, f64::max);
        for name in names {
            let got = terms[group][name]
                .as_f64()
                .unwrap_or_else(|| panic!("{group}.{name} is {}", terms[group][name]));
            let want = truth[group][name].as_f64().unwrap();
            assert!(
                (got - want).abs() <= fraction * largest,
                "{group}.{name}: {got:e} vs truth {want:e}"
            );
        }
    }
}

#[test]
fn procedure_on_a_patent_flight_recovers_the_terms_and_writes_the_documented_json() {
    let dir = tempfile::tempdir().unwrap();
    let csv = patent_flight(dir.path(), &[]);
    let out_json = dir.path().join("t.json");
    let stdout = ok(&tolles(&[
        "procedure",
        csv.to_str().unwrap(),
        "--scalar",
        "mag_1_uc",
        "--vector",
        "flux_a",
        "--out",
        out_json.to_str().unwrap(),
    ]));
    // The story, step by step.
    assert!(stdout.contains("Step 1: eddy tl and tv from north and south rolls"));
    assert!(stdout.contains("Step 12: cloverleaf"));
    assert!(stdout.contains("All 16 terms determined."));
    let doc = read_json(&out_json);
    for (group, names, _) in GROUPS {
        let object = doc[group].as_object().unwrap();
        assert_eq!(object.len(), names.len(), "{group}");
        for name in names {
            assert!(object[*name].is_number(), "{group}.{name}");
            assert!(doc["least_squares"][group][name].is_number());
        }
    }
    assert_eq!(doc["steps"].as_array().unwrap().len(), 11);
    assert_eq!(doc["missing"], Value::Array(vec![]));
    assert_eq!(doc["steps"][0]["identified"][0]["term"], "tl");
    let truth = &read_json(&dir.path().join("f.json"))["truth"]["patent"];
    assert_accurate(&doc, truth);
    assert_accurate(&doc["least_squares"], truth);
    let clover = &doc["cloverleaf"];
    assert!(clover["improvement"].as_f64().unwrap() >= 20.0, "{clover}");
}

#[test]
fn a_missing_maneuver_is_named_and_the_other_terms_are_still_reported() {
    let dir = tempfile::tempdir().unwrap();
    let csv = patent_flight(dir.path(), &[]);
    let run = |ignore: &[&str]| {
        let mut args = vec![
            "procedure",
            csv.to_str().unwrap(),
            "--scalar",
            "mag_1_uc",
            "--vector",
            "flux_a",
        ];
        for i in ignore {
            args.extend_from_slice(&["--ignore", i]);
        }
        let text = ok(&tolles(&args));
        args.push("--json");
        let doc: Value = serde_json::from_str(&ok(&tolles(&args))).unwrap();
        (text, doc)
    };
    let (text, doc) = run(&["roll on 045"]);
    assert!(text.contains("missing: roll on 045°"), "{text}");
    assert!(text.contains("Missing maneuvers: roll on 045°"));
    assert_eq!(doc["missing"][0], "roll on 045°");
    assert!(doc["eddy_s"]["vl"].is_number()); // from the other intercardinal rolls
    let (text, doc) = run(&["roll on 045", "roll on 315"]);
    assert!(
        text.contains("missing: roll on 045°, roll on 315°"),
        "{text}"
    );
    assert_eq!(
        doc["missing"],
        serde_json::json!(["roll on 045°", "roll on 315°"])
    );
    let truth = &read_json(&dir.path().join("f.json"))["truth"]["patent"];
    assert_accurate(&doc, truth);
}

#[test]
fn terms_the_flight_cannot_determine_are_null_and_named() {
    // Declination 0, so the cardinal headings are exactly magnetic ones; without any
    // intercardinal roll vl and LV+VL cannot be found, nor L (east and west pitches show it only
    // in proportion to LV+VL); everything else is still reported.
    let dir = tempfile::tempdir().unwrap();
    let uniform = [
        "--inclination",
        "68",
        "--declination",
        "0",
        "--intensity",
        "52000",
    ];
    let csv = patent_flight(dir.path(), &uniform);
    let mut args = vec![
        "procedure",
        csv.to_str().unwrap(),
        "--scalar",
        "mag_1_uc",
        "--vector",
        "flux_a",
    ];
    for roll in ["roll on 045", "roll on 135", "roll on 225", "roll on 315"] {
        args.extend_from_slice(&["--ignore", roll]);
    }
    let text = ok(&tolles(&args));
    assert!(
        text.contains("Could not be determined: L, LV+VL, vl"),
        "{text}"
    );
    args.push("--json");
    let doc: Value = serde_json::from_str(&ok(&tolles(&args))).unwrap();
    assert!(doc["eddy_s"]["vl"].is_null());
    assert!(doc["induced"]["LV+VL"].is_null());
    assert!(doc["perm_nT"]["L"].is_null());
    assert_eq!(doc["undetermined"], serde_json::json!(["L", "LV+VL", "vl"]));
    let truth = &read_json(&dir.path().join("f.json"))["truth"]["patent"];
    for (group, names, fraction) in GROUPS {
        let largest = names
            .iter()
            .map(|n| truth[group][n].as_f64().unwrap().abs())
            .fold(0.0, f64::max);
        for name in names {
            if let Some(v) = doc[group][name].as_f64() {
                let want = truth[group][name].as_f64().unwrap();
                assert!(
                    (v - want).abs() <= fraction * largest,
                    "{name}: {v:e} vs {want:e}"
                );
            }
        }
    }
}

#[test]
fn without_a_fluxgate_the_attitude_and_dip_give_the_direction_cosines() {
    let dir = tempfile::tempdir().unwrap();
    // A uniform field whose dip and declination are known.
    let csv = patent_flight(
        dir.path(),
        &[
            "--inclination",
            "68",
            "--declination",
            "-3",
            "--intensity",
            "52000",
        ],
    );
    let path = csv.to_str().unwrap();
    let out = tolles(&["procedure", path, "--scalar", "mag_1_uc"]);
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.starts_with("error: ") && err.contains("--inclination"),
        "{err}"
    );
    assert_eq!(err.trim_end().lines().count(), 1);
    let doc: Value = serde_json::from_str(&ok(&tolles(&[
        "procedure",
        path,
        "--scalar",
        "mag_1_uc",
        "--dip",
        "68",
        "--declination",
        "-3",
        "--json",
    ])))
    .unwrap();
    let truth = &read_json(&dir.path().join("f.json"))["truth"]["patent"];
    assert_accurate(&doc, truth);
}

#[test]
fn ignoring_a_maneuver_that_is_not_there_is_an_error() {
    let dir = tempfile::tempdir().unwrap();
    let csv = patent_flight(dir.path(), &[]);
    let out = tolles(&[
        "procedure",
        csv.to_str().unwrap(),
        "--scalar",
        "mag_1_uc",
        "--vector",
        "flux_a",
        "--ignore",
        "roll on 046",
    ]);
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("no such maneuver") && err.contains("roll on 045°"),
        "{err}"
    );
}
