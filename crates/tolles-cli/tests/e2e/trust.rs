//! How far to trust a model, end to end: the fit's verdict in its summary, its model file, `fom
//! --json` and `compensate`'s warnings; each row's standard error and extrapolation flag from
//! `compensate --uncertainty`, and the same from `stream --uncertainty`.

use crate::common::{run_in as run, tolles};

use serde_json::Value;
use std::path::Path;
use tempfile::TempDir;

/// A box fitted with the defaults (m.json) where the earth's field dips 70°, and a survey
/// (survey.csv) flown where it dips 20°: on its lines the field meets the aircraft at angles
/// the box never saw, and on its turns too.
fn box_model_and_survey(dir: &Path) -> String {
    let simulate = |plan: &str, seed: &str, out: &str, more: &[&str]| {
        let mut args = vec!["simulate", "--plan", plan, "--seed", seed, "--out", out];
        args.extend(more);
        run(dir, &args);
    };
    let field = |dip: &'static str| {
        [
            "--inclination",
            dip,
            "--declination",
            "0",
            "--intensity",
            "50000",
        ]
    };
    simulate("box", "5", "cal.csv", &field("70"));
    let survey = [&field("20")[..], &["--lines", "2"]].concat();
    simulate("survey", "6", "survey.csv", &survey);
    let fit = [
        "fit", "cal.csv", "--scalar", "mag_1_uc", "--vector", "flux_a", "--out", "m.json",
    ];
    run(dir, &fit).1
}

fn columns(csv: &str) -> (Vec<String>, Vec<Vec<String>>) {
    let mut lines = csv.lines();
    let header = lines
        .next()
        .unwrap()
        .split(',')
        .map(str::to_string)
        .collect();
    let rows = lines
        .map(|l| l.split(',').map(str::to_string).collect())
        .collect();
    (header, rows)
}

fn column(csv: &str, name: &str) -> Vec<f64> {
    let (header, rows) = columns(csv);
    let k = header.iter().position(|h| h == name).unwrap_or_else(|| {
        panic!("no {name} in {header:?}");
    });
    rows.iter()
        .map(|r| r[k].parse::<f64>().unwrap_or(f64::NAN))
        .collect()
}

#[test]
fn a_box_fit_says_its_verdict_and_stores_it() {
    let dir = TempDir::new().unwrap();
    let summary = box_model_and_survey(dir.path());
    assert!(summary.contains("verdict for mag_1_uc: good"), "{summary}");
    let model: Value =
        serde_json::from_str(&std::fs::read_to_string(dir.path().join("m.json")).unwrap()).unwrap();
    let verdict = &model["fits"][0]["verdict"];
    assert_eq!(verdict["grade"], "good", "{verdict}");
    let (fom, _) = run(
        dir.path(),
        &[
            "fom", "cal.csv", "--scalar", "mag_1_uc", "--model", "m.json", "--json",
        ],
    );
    let fom: Value = serde_json::from_str(&fom).unwrap();
    assert_eq!(fom["verdict"]["grade"], "good", "{fom}");
}

#[test]
fn compensate_and_stream_give_each_row_its_standard_error_and_flag() {
    let dir = TempDir::new().unwrap();
    box_model_and_survey(dir.path());
    let args = [
        "compensate",
        "survey.csv",
        "--model",
        "m.json",
        "--uncertainty",
        "--out",
        "out.csv",
    ];
    let (_, warnings) = run(dir.path(), &args);
    let batch = std::fs::read_to_string(dir.path().join("out.csv")).unwrap();
    let sigma = column(&batch, "mag_1_c_sigma");
    let flag = column(&batch, "mag_1_c_extrapolated");
    let computed = column(&batch, "mag_1_c");
    let rows = sigma.len();
    assert!(sigma.iter().all(|s| s.is_finite() && *s >= 0.0));
    assert!(sigma.iter().any(|s| *s > 0.0));
    assert!(flag.iter().all(|f| *f == 0.0 || *f == 1.0), "{flag:?}");
    assert!(computed.iter().all(|c| c.is_finite()));
    let flagged = flag.iter().filter(|f| **f == 1.0).count();
    let sigma_rms = (sigma.iter().map(|s| s * s).sum::<f64>() / rows as f64).sqrt();
    eprintln!("σ RMS {sigma_rms:.4} nT over {rows} rows; {flagged} flagged as extrapolated");
    if flagged > 0 {
        assert!(
            warnings.contains(&format!("{flagged} of {rows}")),
            "{warnings}"
        );
    }
    // The stream gives the same σ and flags, line for line.
    let survey = std::fs::read_to_string(dir.path().join("survey.csv")).unwrap();
    let out = tolles()
        .current_dir(dir.path())
        .args(["stream", "--model", "m.json", "--uncertainty", "--quiet"])
        .write_stdin(survey)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let stream = String::from_utf8(out.stdout).unwrap();
    let stream_sigma = column(&stream, "mag_1_c_sigma");
    let stream_flag = column(&stream, "mag_1_c_extrapolated");
    assert_eq!(stream_sigma.len(), rows);
    for k in 0..rows {
        assert!(
            (stream_sigma[k] - sigma[k]).abs() <= 1e-9 * (1.0 + sigma[k]),
            "row {k}"
        );
    }
    assert_eq!(stream_flag, flag);
}

#[test]
fn compensate_with_a_doubtful_model_repeats_its_verdict() {
    let dir = TempDir::new().unwrap();
    box_model_and_survey(dir.path());
    // Straight lines: the fluxgate's direction hardly moves inside the band.
    let fit = [
        "fit",
        "survey.csv",
        "--scalar",
        "mag_1_uc",
        "--vector",
        "flux_a",
        "--out",
        "lines.json",
    ];
    let (_, summary) = run(dir.path(), &fit);
    assert!(
        summary.contains("verdict for mag_1_uc: doubtful"),
        "{summary}"
    );
    assert!(summary.contains("no maneuvers"), "{summary}");
    let args = [
        "compensate",
        "cal.csv",
        "--model",
        "lines.json",
        "--out",
        "out.csv",
    ];
    let (_, warnings) = run(dir.path(), &args);
    assert!(warnings.contains("doubtful"), "{warnings}");
    assert!(warnings.contains("no maneuvers"), "{warnings}");
}

/// A model without the coefficients' covariance (a file before version 3): σ is empty and
/// `compensate` and `stream` say why.
#[test]
fn sigma_asked_of_a_model_without_a_covariance_is_empty_with_a_warning() {
    let dir = TempDir::new().unwrap();
    box_model_and_survey(dir.path());
    let path = dir.path().join("m.json");
    let mut model: Value = serde_json::from_str(&std::fs::read_to_string(&path).unwrap()).unwrap();
    model["fits"][0]
        .as_object_mut()
        .unwrap()
        .remove("uncertainty");
    std::fs::write(dir.path().join("old.json"), model.to_string()).unwrap();
    let args = [
        "compensate",
        "survey.csv",
        "--model",
        "old.json",
        "--uncertainty",
        "--out",
        "out.csv",
    ];
    let (_, warnings) = run(dir.path(), &args);
    assert!(
        warnings.contains("holds no covariance") && warnings.contains("mag_1_uc"),
        "{warnings}"
    );
    let out = std::fs::read_to_string(dir.path().join("out.csv")).unwrap();
    assert!(column(&out, "mag_1_c_sigma").iter().all(|s| s.is_nan()));
    assert!(column(&out, "mag_1_c").iter().all(|c| c.is_finite()));
    let survey = std::fs::read_to_string(dir.path().join("survey.csv")).unwrap();
    let lines: String = survey.lines().take(20).map(|l| format!("{l}\n")).collect();
    let streamed = tolles()
        .current_dir(dir.path())
        .args(["stream", "--model", "old.json", "--uncertainty", "--quiet"])
        .write_stdin(lines)
        .output()
        .unwrap();
    assert!(streamed.status.success());
    let warnings = String::from_utf8_lossy(&streamed.stderr);
    assert!(
        warnings.contains("holds no covariance") && warnings.contains("mag_1_uc"),
        "{warnings}"
    );
    let out = String::from_utf8_lossy(&streamed.stdout);
    assert_eq!(out.lines().count(), 20, "{out}");
}

/// σ is the compensated value's error up to a level, the scalar's noise included: on simulated
/// tail stingers and cabins it covers about two rows in three of the survey's true error.
#[test]
fn sigma_covers_the_compensated_values_error_at_about_its_stated_rate() {
    for (preset, seed) in [("tail-stinger", "1"), ("cabin", "2")] {
        let dir = TempDir::new().unwrap();
        let simulate = |plan: &str, seed: &str, out: &str| {
            let args = [
                "simulate", "--plan", plan, "--preset", preset, "--seed", seed, "--out", out,
            ];
            run(dir.path(), &args);
        };
        simulate("box", seed, "cal.csv");
        simulate("survey", "11", "survey.csv");
        let fit = [
            "fit", "cal.csv", "--scalar", "mag_1_uc", "--vector", "flux_a", "--out", "m.json",
        ];
        run(dir.path(), &fit);
        let args = [
            "compensate",
            "survey.csv",
            "--model",
            "m.json",
            "--uncertainty",
            "--out",
            "out.csv",
        ];
        run(dir.path(), &args);
        let out = std::fs::read_to_string(dir.path().join("out.csv")).unwrap();
        let error: Vec<f64> = (column(&out, "mag_1_c").iter())
            .zip(column(&out, "truth_earth"))
            .map(|(c, t)| c - t)
            .collect();
        let mean = error.iter().sum::<f64>() / error.len() as f64;
        let sigma = column(&out, "mag_1_c_sigma");
        let inside = (error.iter().zip(&sigma))
            .filter(|(e, s)| (*e - mean).abs() <= **s)
            .count() as f64
            / error.len() as f64;
        eprintln!("{preset}: {:.0} % of survey rows within 1σ", 100.0 * inside);
        assert!((0.4..=0.9).contains(&inside), "{preset}: {inside}");
    }
}
