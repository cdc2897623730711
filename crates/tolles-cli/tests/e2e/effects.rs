//! `tolles simulate --effects`: cabin effects Tolles-Lawson cannot represent, fitted as well as
//! a linear model can (against the reference `mag_ref`, with the effects' channels as extras),
//! beside the same installation without them (issue 48, item 3).

use crate::common;

use crate::common::{column, error_vs_truth, run_in, std};
use std::path::Path;
use tempfile::TempDir;

/// Simulates `plan` with `seed` and `more` flags into `out`.
fn simulate(dir: &Path, plan: &str, seed: &str, more: &[&str], out: &str) {
    let args = [
        &[
            "simulate", "--preset", "cabin", "--plan", plan, "--seed", seed,
        ][..],
        more,
        &["--out", out],
    ]
    .concat();
    run_in(dir, &args);
}

/// Fits `train` against `mag_ref` with `extra` channels, compensates `train` and `survey`;
/// their errors against the truth (nT).
fn linear_errors(dir: &Path, train: &str, survey: &str, extra: &[&str], model: &str) -> [f64; 2] {
    let fit = [
        "fit",
        train,
        "--scalar",
        "mag_1_uc",
        "--vector",
        "flux_a",
        "--reference",
        "mag_ref",
        "--out",
        model,
    ];
    run_in(dir, &[&fit[..], extra].concat());
    [train, survey].map(|flight| {
        let out = format!("c_{model}_{flight}");
        run_in(
            dir,
            &["compensate", flight, "--model", model, "--out", &out],
        );
        let csv = std::fs::read_to_string(dir.join(&out)).unwrap();
        error_vs_truth(&csv, "mag_1_c")
    })
}

#[test]
fn the_effects_leave_a_linear_fit_clearly_more_residual_than_without_them() {
    let dir = TempDir::new().unwrap();
    let d = dir.path();
    simulate(d, "box", "1", &["--effects", "all"], "train.csv");
    simulate(d, "survey", "2", &["--effects", "all"], "survey.csv");
    simulate(d, "box", "1", &["--reference"], "plain_train.csv");
    simulate(d, "survey", "2", &["--reference"], "plain_survey.csv");

    let csv = std::fs::read_to_string(d.join("train.csv")).unwrap();
    let header = csv.lines().next().unwrap();
    assert!(
        header.ends_with("truth_diurnal,mag_ref,cur_load,pos_flap,temp,truth_effects"),
        "{header}"
    );
    let effects: Vec<f64> = column(&csv, "truth_effects")
        .into_iter()
        .map(Option::unwrap)
        .collect();
    let extras = ["--extra", "cur_load,pos_flap,temp"];
    let with = linear_errors(d, "train.csv", "survey.csv", &extras, "m_effects.json");
    let without = linear_errors(
        d,
        "plain_train.csv",
        "plain_survey.csv",
        &[],
        "m_plain.json",
    );
    let no_extras = linear_errors(d, "train.csv", "survey.csv", &[], "m_no_extras.json");
    eprintln!(
        "cabin flights with effects (truth_effects std {:.2} nT on the box), linear fit with \
         --reference mag_ref: box / held-out survey {:.3} / {:.3} nT with --extra \
         cur_load,pos_flap,temp, {:.3} / {:.3} nT without; the same flights without effects \
         {:.4} / {:.4} nT",
        std(&effects),
        with[0],
        with[1],
        no_extras[0],
        no_extras[1],
        without[0],
        without[1],
    );
    assert!(std(&effects) > 3.0, "{}", std(&effects));
    for k in 0..2 {
        assert!(
            with[k] > 1.0 && with[k] > 10.0 * without[k],
            "{with:?} {without:?}"
        );
    }
    // The fit with effects did use the extras: its model names them.
    let model = std::fs::read_to_string(d.join("m_effects.json")).unwrap();
    assert!(
        model.contains("pos_flap") && model.contains("cur_load"),
        "{model}"
    );
}

#[test]
fn effects_are_deterministic_and_a_reference_alone_changes_no_other_column() {
    let dir = TempDir::new().unwrap();
    let d = dir.path();
    simulate(d, "box", "4", &["--effects", "flap,load"], "a.csv");
    simulate(d, "box", "4", &["--effects", "load,flap"], "b.csv");
    simulate(d, "box", "4", &[], "plain.csv");
    simulate(d, "box", "4", &["--reference"], "reference.csv");
    let read = |name: &str| std::fs::read_to_string(d.join(name)).unwrap();
    assert_eq!(read("a.csv"), read("b.csv"));
    assert!(read("a.csv")
        .lines()
        .next()
        .unwrap()
        .ends_with("mag_ref,cur_load,pos_flap,truth_effects"));
    // The reference's column is added at the end; every other cell is as without it.
    let (plain, reference) = (read("plain.csv"), read("reference.csv"));
    for (p, r) in plain.lines().zip(reference.lines()) {
        assert_eq!(r.rsplit_once(',').unwrap().0, p);
    }
    let sidecar: serde_json::Value = serde_json::from_str(&read("a.json")).unwrap();
    let effects = &sidecar["scenario"]["effects"];
    assert!(effects["load"]["saturation_a"].is_number(), "{effects}");
    assert!(effects["surface"]["moment_am2"].is_array(), "{effects}");
    assert!(effects["temperature"].is_null());
    assert_eq!(sidecar["scenario"]["sensors"]["reference_noise_nt"], 0.01);
    let described: Vec<&str> = sidecar["columns"]
        .as_array()
        .unwrap()
        .iter()
        .map(|c| c[0].as_str().unwrap())
        .collect();
    assert!(described.ends_with(&["mag_ref", "cur_load", "pos_flap", "truth_effects"]));
    let plain_sidecar = read("plain.json");
    assert!(!plain_sidecar.contains("effects") && !plain_sidecar.contains("mag_ref"));
    let bad = common::tolles()
        .current_dir(d)
        .args(["simulate", "--effects", "wind", "--out", "x.csv"])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&bad.stderr);
    assert!(
        !bad.status.success() && err.contains("load, flap, temp"),
        "{err}"
    );
}
