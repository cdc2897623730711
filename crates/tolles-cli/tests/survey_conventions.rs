//! Survey files as they come (issue 46): declared time units, fiducials and projected
//! coordinates, noise that restarts at line gaps, flights without maneuvers, 1 Hz rates, and a
//! fit summary that prints what it chose by.

mod common;

use common::{column, run_in as run};

use serde_json::Value;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use tempfile::TempDir;

fn example(stem: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../tolles-io/tests/fixtures/aseg_gdf2")
        .join(format!("{stem}.dfn"))
}

/// A simulated box written as ASEG-GDF2 with its time in `unit` (`per_second` of them a
/// second), under the channel names survey contractors use.
fn box_as_gdf(dir: &Path, unit: &str, per_second: f64) -> String {
    run(
        dir,
        &[
            "simulate", "--plan", "box", "--seed", "2", "--out", "box.csv",
        ],
    );
    let csv = std::fs::read_to_string(dir.join("box.csv")).unwrap();
    let get =
        |name: &str| -> Vec<f64> { column(&csv, name).into_iter().map(Option::unwrap).collect() };
    let (tt, mag) = (get("tt"), get("mag_1_uc"));
    let flux = [get("flux_a_x"), get("flux_a_y"), get("flux_a_z")];
    let fields = [
        ("TIME", unit),
        ("RAWMAG", "nT"),
        ("FLUXX", "nT"),
        ("FLUXY", "nT"),
        ("FLUXZ", "nT"),
    ];
    let mut dfn = String::from("DEFN   ST=RECD,RT=COMM;RT:A4;COMMENTS:A76\n");
    for (k, (name, unit)) in fields.iter().enumerate() {
        let format = if k == 0 { "F16.9" } else { "F12.3" };
        writeln!(
            dfn,
            "DEFN {} ST=RECD,RT=;{name}:{format}:UNITS={unit}",
            k + 1
        )
        .unwrap();
    }
    dfn.push_str("DEFN 6 ST=RECD,RT=;END DEFN\n");
    let mut dat = String::new();
    for k in 0..tt.len() {
        writeln!(
            dat,
            "{:16.9}{:12.3}{:12.3}{:12.3}{:12.3}",
            (1000.0 + tt[k]) * per_second,
            mag[k],
            flux[0][k],
            flux[1][k],
            flux[2][k]
        )
        .unwrap();
    }
    std::fs::write(dir.join("box.dfn"), dfn).unwrap();
    std::fs::write(dir.join("box.dat"), dat).unwrap();
    "box.dfn".to_string()
}

#[test]
fn a_time_column_declared_in_hours_or_milliseconds_is_read_in_seconds() {
    for (unit, per_second) in [("hours", 1.0 / 3600.0), ("msec", 1000.0)] {
        let dir = TempDir::new().unwrap();
        let gdf = box_as_gdf(dir.path(), unit, per_second);
        let (info, _) = run(dir.path(), &["info", &gdf]);
        let rate: f64 = info
            .split("sample rate: ")
            .nth(1)
            .and_then(|r| r.split(' ').next())
            .and_then(|r| r.parse().ok())
            .unwrap();
        // Nine decimals of an hour are 3.6 µs.
        assert!((rate - 10.0).abs() < 1e-3, "{unit}: {info}");
        let fit = [
            "fit",
            &gdf,
            "--scalar",
            "RAWMAG",
            "--vector",
            "FLUXX:FLUXY:FLUXZ",
        ];
        let (_, summary) = run(dir.path(), &fit);
        assert!(
            summary.contains(&format!("declared in {unit:?}")),
            "{summary}"
        );
        let improvement: f64 = summary
            .split("improvement ×")
            .nth(1)
            .and_then(|r| r.split(')').next())
            .and_then(|r| r.parse().ok())
            .unwrap();
        eprintln!("{unit}: improvement ×{improvement}");
        assert!(improvement > 20.0, "{unit}: {summary}");
    }
}

#[test]
fn a_time_column_in_an_unknown_unit_and_an_unlikely_rate_are_warned_of() {
    let dir = TempDir::new().unwrap();
    let gdf = box_as_gdf(dir.path(), "fortnights", 1e-4);
    let fit = [
        "fit",
        &gdf,
        "--scalar",
        "RAWMAG",
        "--vector",
        "FLUXX:FLUXY:FLUXZ",
    ];
    let (_, warnings) = run(dir.path(), &fit);
    assert!(warnings.contains("no unit of time"), "{warnings}");
    assert!(
        warnings.contains("no magnetometer samples at"),
        "{warnings}"
    );
}

#[test]
fn fiducials_and_projected_coordinates_answer_to_tolles_names() {
    let dir = TempDir::new().unwrap();
    let muppet = example("Example_AeroMag_MuppetTown_2009");
    let (info, notes) = run(dir.path(), &["info", muppet.to_str().unwrap()]);
    assert!(info.contains("sample rate: 1.000000 Hz"), "{info}");
    for pair in [
        "FIDUCIAL as tt",
        "EAST_MGA as east_m",
        "NORTH_MGA as north_m",
        "GDA94LAT as lat",
        "GDA94LON as lon",
    ] {
        assert!(notes.contains(pair), "{pair}: {notes}");
    }
    let bowser = example("Example_Rad_BowsersCastle_2012");
    let (_, notes) = run(dir.path(), &["info", bowser.to_str().unwrap()]);
    assert!(
        notes.contains("EASTMGA56 as east_m") && notes.contains("FID as tt"),
        "{notes}"
    );
    // A file with its own time keeps it: HillValley has FIDUCIAL and TIME (in hours).
    let hill = example("Example_Mag_HillValley_1985");
    let (_, notes) = run(dir.path(), &["info", hill.to_str().unwrap()]);
    assert!(
        notes.contains("TIME as tt") && !notes.contains("FIDUCIAL as tt"),
        "{notes}"
    );
}

/// A simulated box (box.csv) and the model fitted to it with the defaults (m.json).
fn box_model(dir: &Path) {
    run(dir, &["simulate", "--plan", "box", "--out", "box.csv"]);
    let fit = [
        "fit", "box.csv", "--scalar", "mag_1_uc", "--vector", "flux_a", "--out", "m.json",
    ];
    run(dir, &fit);
}

fn survey(dir: &Path, fs: &str) {
    let args = [
        "simulate", "--plan", "survey", "--seed", "4", "--lines", "3", "--fs", fs,
    ];
    run(dir, &[&args[..], &["--out", "survey.csv"]].concat());
}

fn fourth_difference(dir: &Path, lines: &str) -> f64 {
    let args = [
        "fom",
        "survey.csv",
        "--scalar",
        "mag_1_uc",
        "--line",
        lines,
        "--json",
    ];
    let json: Value = serde_json::from_str(&run(dir, &args).0).unwrap();
    json["fourth_difference_nT"].as_f64().unwrap()
}

#[test]
fn the_noise_of_several_lines_is_that_of_each_line() {
    let dir = TempDir::new().unwrap();
    survey(dir.path(), "10");
    let (one, three) = (
        fourth_difference(dir.path(), "1001"),
        fourth_difference(dir.path(), "1003"),
    );
    let both = fourth_difference(dir.path(), "1001,1003");
    eprintln!("fourth-difference noise: 1001 {one:.4} nT, 1003 {three:.4} nT, both {both:.4} nT");
    assert!(both <= 1.05 * one.max(three) && both >= 0.95 * one.min(three));
}

#[test]
fn a_flight_without_maneuvers_has_no_figure_of_merit_rather_than_zero() {
    let dir = TempDir::new().unwrap();
    survey(dir.path(), "10");
    let (text, _) = run(dir.path(), &["fom", "survey.csv", "--scalar", "mag_1_uc"]);
    assert!(text.contains("FOM  none"), "{text}");
    assert!(!text.contains("0.000\n"), "{text}");
    let (json, _) = run(
        dir.path(),
        &["fom", "survey.csv", "--scalar", "mag_1_uc", "--json"],
    );
    let json: Value = serde_json::from_str(&json).unwrap();
    assert!(json["fom_nT"].is_null(), "{json}");
    assert!(json["fourth_difference_nT"].as_f64().unwrap() > 0.0);
}

#[test]
fn a_one_hertz_survey_gets_its_noise_and_report_with_the_default_band() {
    let dir = TempDir::new().unwrap();
    survey(dir.path(), "1");
    run(dir.path(), &["fom", "survey.csv", "--scalar", "mag_1_uc"]);
    box_model(dir.path());
    run(
        dir.path(),
        &[
            "report",
            "survey.csv",
            "--scalar",
            "mag_1_uc",
            "--model",
            "m.json",
            "--out",
            "r",
        ],
    );
    assert!(dir.path().join("r/index.html").exists());
}

#[test]
fn a_report_takes_the_rate_of_its_model_when_the_flight_states_none() {
    let dir = TempDir::new().unwrap();
    box_model(dir.path());
    let csv = std::fs::read_to_string(dir.path().join("box.csv")).unwrap();
    let without_time: String = csv
        .lines()
        .map(|l| l.split_once(',').unwrap().1.to_string() + "\n")
        .collect();
    assert!(!without_time.lines().next().unwrap().contains("tt"));
    std::fs::write(dir.path().join("notime.csv"), without_time).unwrap();
    let args = [
        "report",
        "notime.csv",
        "--scalar",
        "mag_1_uc",
        "--model",
        "m.json",
        "--out",
        "r",
    ];
    run(dir.path(), &args);
}

#[test]
fn the_fit_summary_prints_the_score_it_chose_by_and_small_terms_in_full() {
    let dir = TempDir::new().unwrap();
    run(
        dir.path(),
        &[
            "simulate", "--plan", "box", "--seed", "8", "--out", "box.csv",
        ],
    );
    let fit = [
        "fit", "box.csv", "--scalar", "mag_1_uc", "--vector", "flux_a", "--out", "m.json",
    ];
    let (_, summary) = run(dir.path(), &fit);
    let scores: Vec<(f64, bool)> = summary
        .lines()
        .filter(|l| l.trim_start().starts_with("terms "))
        .map(|l| {
            let score = l.split("score ").nth(1).and_then(|r| r.split(' ').next());
            (score.unwrap().parse().unwrap(), l.contains("<- chosen"))
        })
        .collect();
    let lowest = scores.iter().map(|s| s.0).fold(f64::INFINITY, f64::min);
    assert!(
        scores.iter().any(|&(s, chosen)| chosen && s == lowest),
        "{summary}"
    );
    let patent = summary
        .lines()
        .find(|l| l.contains("patent terms"))
        .unwrap();
    let induced = patent.split("induced ").nth(1).unwrap();
    assert!(
        !induced.contains("0.00000") && induced.contains('e'),
        "{patent}"
    );
}

#[test]
fn a_file_sorted_by_line_shows_its_time_span_earliest_to_latest() {
    let dir = TempDir::new().unwrap();
    let gondwana = example("Example_Mag_Gondwana_200Ma");
    let (info, _) = run(dir.path(), &["info", gondwana.to_str().unwrap()]);
    let span = info.lines().find(|l| l.starts_with("time: ")).unwrap();
    // Earliest to latest (the file starts at 38000.3 s and later steps back to 29932 s).
    assert!(
        span.starts_with("time: 29906.9 .. 38000.4 s (8093.5 s"),
        "{span}"
    );
    assert!(span.contains("not in time order"), "{span}");
}
