//! `tolles simulate` through the binary.

use crate::common::{survey_error, tolles};

use tempfile::TempDir;

fn simulate(dir: &TempDir, name: &str, args: &[&str]) -> (String, serde_json::Value) {
    let out = dir.path().join(name);
    tolles()
        .args(["simulate", "--out"])
        .arg(&out)
        .args(args)
        .assert()
        .success();
    let csv = std::fs::read_to_string(&out).unwrap();
    let sidecar = std::fs::read_to_string(out.with_extension("json")).unwrap();
    (csv, serde_json::from_str(&sidecar).unwrap())
}

#[test]
fn same_seed_same_flight_and_the_sidecar_holds_the_truth() {
    let dir = TempDir::new().unwrap();
    let (a, sidecar) = simulate(&dir, "a.csv", &["--plan", "box", "--seed", "3"]);
    let (b, _) = simulate(&dir, "b.csv", &["--plan", "box", "--seed", "3"]);
    let (c, _) = simulate(&dir, "c.csv", &["--plan", "box", "--seed", "4"]);
    assert_eq!(a, b);
    assert_ne!(a, c);
    let header = a.lines().next().unwrap();
    for column in [
        "tt",
        "line",
        "ins_roll",
        "ins_pitch",
        "ins_yaw",
        "mag_1_uc",
        "flux_a_x",
        "truth_earth",
        "truth_aircraft",
        "lat",
        "lon",
    ] {
        assert!(
            header.split(',').any(|h| h == column),
            "{column} missing from {header}"
        );
    }
    assert_eq!(sidecar["format"], "tolles-simulation");
    assert_eq!(sidecar["plan_name"], "box");
    assert_eq!(sidecar["truth"]["patent"]["perm_nT"]["L"], 100.0);
    assert!(sidecar["scenario"]["environment"]["main"]["igrf"]["lat_deg"].is_number());
}

#[test]
fn every_plan_and_preset_runs() {
    let dir = TempDir::new().unwrap();
    for plan in ["box", "patent", "survey"] {
        for preset in ["tail-stinger", "cabin", "uav", "realistic"] {
            let (csv, _) = simulate(
                &dir,
                "f.csv",
                &[
                    "--plan",
                    plan,
                    "--preset",
                    preset,
                    "--lines",
                    "2",
                    "--line-duration",
                    "30",
                ],
            );
            assert!(csv.lines().count() > 100, "{plan} {preset}");
            assert_eq!(
                csv.lines().next().unwrap().contains("cur_1"),
                preset == "uav" || preset == "realistic"
            );
        }
    }
    let (_, sidecar) = simulate(
        &dir,
        "u.csv",
        &[
            "--inclination",
            "60",
            "--declination",
            "-5",
            "--intensity",
            "50000",
        ],
    );
    assert_eq!(
        sidecar["scenario"]["environment"]["main"]["uniform"]["inclination_deg"],
        60.0
    );
}

#[test]
fn bad_arguments_are_one_line_errors() {
    let dir = TempDir::new().unwrap();
    let out = dir.path().join("x.csv");
    for (args, expected) in [
        (vec!["--date", "2025-02-30"], "not a calendar date"),
        (vec!["--date", "yesterday"], "YYYY-MM-DD"),
        (vec!["--fs", "0"], "--fs (fs= in Python) must lie within"),
        // Hostile round 4: settings that overflowed to infinities, exhausted memory or hung.
        (
            vec!["--reference", "--reference-noise", "1e308"],
            "--reference-noise (reference_noise= in Python) must lie within 0..=10000 nT",
        ),
        (vec!["--geology", "1e308"], "--geology"),
        (vec!["--roll", "1e308"], "--roll"),
        (vec!["--fs", "1e9"], "--fs"),
        (vec!["--plan", "survey", "--lines", "4000000000"], "--lines"),
        (
            vec![
                "--plan",
                "survey",
                "--lines",
                "10000",
                "--line-duration",
                "86400",
            ],
            "more than 1e7: ask for fewer --lines",
        ),
        (
            vec!["--intensity", "1e308", "--dip", "70", "--declination", "0"],
            "--intensity",
        ),
        (vec!["--date", "1800-01-01"], "outside the IGRF-14 validity"),
    ] {
        let result = tolles()
            .args(["simulate", "--out"])
            .arg(&out)
            .args(&args)
            .output()
            .unwrap();
        assert!(!result.status.success());
        let stderr = String::from_utf8(result.stderr).unwrap();
        assert!(
            stderr.contains(expected) && stderr.lines().count() == 1,
            "{args:?}: {stderr}"
        );
    }
}

#[test]
fn a_simulated_box_fits_and_compensates() {
    let dir = TempDir::new().unwrap();
    simulate(
        &dir,
        "cal.csv",
        &["--plan", "box", "--preset", "tail-stinger"],
    );
    let cal = dir.path().join("cal.csv");
    let model = dir.path().join("m.json");
    tolles()
        .args([
            "fit",
            cal.to_str().unwrap(),
            "--scalar",
            "mag_1_uc",
            "--vector",
            "flux_a",
            "--out",
        ])
        .arg(&model)
        .assert()
        .success();
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&model).unwrap()).unwrap();
    let l = json["fits"][0]["patent"]["perm_nT"]["L"].as_f64().unwrap();
    assert!((l - 4.0).abs() < 0.5, "perm L {l} vs 4 nT");
}

#[test]
fn a_report_without_a_model_shows_the_uncompensated_flight() {
    let dir = TempDir::new().unwrap();
    simulate(&dir, "box.csv", &["--plan", "box"]);
    let out = dir.path().join("report");
    tolles()
        .args([
            "report",
            dir.path().join("box.csv").to_str().unwrap(),
            "--scalar",
            "mag_1_uc",
            "--out",
        ])
        .arg(&out)
        .assert()
        .success();
    let html = std::fs::read_to_string(out.join("index.html")).unwrap();
    assert!(html.contains("FOM before") && !html.contains("FOM after"));
    assert!(html.contains("12 of 12"));
    assert!(
        !html.contains("http://") && !html.contains("https://"),
        "the report must not need the network"
    );
}

/// The realistic preset looks like a real cabin box to the fit: its fluxgate's offset is
/// thousands of nT, its levels are missed by tens of nT (so the fit leaves them out, as on real
/// boxes), and an unmodelled current leaves the band far above the scalar's noise. The
/// defaults do as well as MagNav's settings there, and the current as `--extra` removes most
/// of what is left.
#[test]
fn the_realistic_preset_is_fitted_as_a_real_cabin_box() {
    let dir = TempDir::new().unwrap();
    simulate(
        &dir,
        "box.csv",
        &["--plan", "box", "--preset", "realistic", "--seed", "1"],
    );
    let (_, sidecar) = simulate(
        &dir,
        "survey.csv",
        &["--plan", "survey", "--preset", "realistic", "--seed", "2"],
    );
    let bias = &sidecar["scenario"]["sensors"]["fluxgate"]["bias_nt"];
    assert!(bias[1].as_f64().unwrap().abs() > 1_000.0, "{bias}");
    let (defaults, _) = survey_error(dir.path(), &[]);
    // Asked for, the heading levels of a real-like box are left out, with the misfit said.
    let (_, stderr) = survey_error(dir.path(), &["--levels", "on"]);
    assert!(stderr.contains("heading levels: not used"), "{stderr}");
    let (magnav, _) = survey_error(
        dir.path(),
        &["--terms", "permanent,induced,eddy", "--lambda", "0.001"],
    );
    let (extra, stderr) = survey_error(dir.path(), &["--extra", "cur_1"]);
    assert!(stderr.contains("fluxgate offset taken out"), "{stderr}");
    let flags = ["--extra", "cur_1", "--fluxgate-offset", "off"];
    let (raw_fluxgate, _) = survey_error(dir.path(), &flags);
    eprintln!(
        "realistic preset, survey error against the truth: defaults {defaults:.3} nT, MagNav's settings {magnav:.3} nT, defaults with --extra cur_1 {extra:.3} nT, and with the fluxgate's offset left in {raw_fluxgate:.3} nT"
    );
    assert!(defaults <= 1.1 * magnav, "{defaults} against {magnav}");
    assert!(extra < 0.6 * defaults, "{extra} against {defaults}");
    // The fluxgate sees thousands of nT of the aircraft: taking them out helps.
    assert!(
        extra < 0.97 * raw_fluxgate,
        "{extra} against {raw_fluxgate}"
    );
}
