//! Survey files as they come (issue 46): declared time units, fiducials and projected
//! coordinates, noise that restarts at line gaps, flights without maneuvers, 1 Hz rates, and a
//! fit summary that prints what it chose by.

use crate::common;

use crate::common::{column, run_in as run};

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
        let rate = info_rate(dir.path(), &gdf);
        // Nine decimals of an hour are 3.6 µs.
        assert!((rate - 10.0).abs() < 1e-3, "{unit}: {rate} Hz");
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

/// The sample rate `tolles info` reports for `file` in `dir` (Hz).
fn info_rate(dir: &Path, file: &str) -> f64 {
    let (info, _) = run(dir, &["info", file]);
    info.split("sample rate: ")
        .nth(1)
        .and_then(|r| r.split(' ').next())
        .and_then(|r| r.trim().parse().ok())
        .unwrap_or_else(|| panic!("{info}"))
}

/// Times written as read keep their unit in HDF5; CSV cannot say it, and the command says so.
#[test]
fn a_declared_time_unit_is_kept_in_hdf5_and_its_loss_in_csv_is_warned_of() {
    let dir = TempDir::new().unwrap();
    let gdf = box_as_gdf(dir.path(), "hours", 1.0 / 3600.0);
    for out in ["box.h5", "box.parquet"] {
        let (_, quiet) = run(dir.path(), &["convert", &gdf, out]);
        assert!(!quiet.contains("cannot declare"), "{quiet}");
        assert!((info_rate(dir.path(), out) - 10.0).abs() < 1e-3, "{out}");
    }

    let (_, said) = run(dir.path(), &["convert", &gdf, "box_converted.csv"]);
    assert!(
        said.contains("box_converted.csv: time column \"TIME\" is written in \"hours\""),
        "{said}"
    );
    assert!((info_rate(dir.path(), "box_converted.csv") - 36_000.0).abs() < 1.0);

    let fit = [
        "fit",
        &gdf,
        "--scalar",
        "RAWMAG",
        "--vector",
        "FLUXX:FLUXY:FLUXZ",
        "--out",
        "m.json",
    ];
    run(dir.path(), &fit);
    let compensate = ["compensate", &gdf, "--model", "m.json", "--out"];
    let (_, said) = run(dir.path(), &[&compensate[..], &["c.csv"]].concat());
    assert!(said.contains("c.csv: time column \"TIME\""), "{said}");
    let (_, quiet) = run(dir.path(), &[&compensate[..], &["c.h5"]].concat());
    assert!(!quiet.contains("cannot declare"), "{quiet}");
    assert!((info_rate(dir.path(), "c.h5") - 10.0).abs() < 1e-3);
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
    // A heading column is the yaw when the file has no AZIMUTH, so the heading error needs no
    // renaming.
    let csv = dir.path().join("heading.csv");
    std::fs::write(
        &csv,
        "Fiducial,Heading,Roll,Pitch,mag\n1,90,0,0,5\n2,90,0,0,6\n",
    )
    .unwrap();
    let (_, notes) = run(dir.path(), &["info", csv.to_str().unwrap()]);
    assert!(notes.contains("Heading as ins_yaw"), "{notes}");
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
    assert!(
        !text.contains("missing:"),
        "one 'none', not twelve missing: {text}"
    );
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
    // The page says the rate is assumed, and whose it is; given, it says so.
    let page =
        |name: &str| std::fs::read_to_string(dir.path().join(name).join("index.html")).unwrap();
    assert!(page("r").contains("(assumed: the model&#39;s rate; the file states none)"));
    run(
        dir.path(),
        &[&args[..6], &["--out", "given", "--fs", "10"]].concat(),
    );
    assert!(page("given").contains("10.000 Hz (given with --fs)"));
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
            // With heading levels a candidate's score follows "score"; without, it is the
            // band's held-out residual.
            let after = l.split("score ").nth(1);
            let after = after.or_else(|| l.split("held-out residual ").nth(1));
            let score = after.and_then(|r| r.split(' ').next());
            (score.unwrap().parse().unwrap(), l.contains("<- chosen"))
        })
        .collect();
    let lowest = scores.iter().map(|s| s.0).fold(f64::INFINITY, f64::min);
    assert!(
        scores.iter().any(|&(s, chosen)| chosen && s == lowest),
        "{summary}"
    );
    // Every coefficient carries its unit (item 18).
    let header = summary
        .lines()
        .position(|l| l.contains("coefficient"))
        .unwrap();
    assert!(
        summary.lines().nth(header).unwrap().ends_with("unit"),
        "{summary}"
    );
    let first = summary.lines().nth(header + 1).unwrap();
    assert!(
        first.trim_start().starts_with("perm") && first.ends_with(" nT"),
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

/// `lines` (a CSV's header and rows) with its data rows' halves swapped: time steps back once.
fn halves_swapped(text: &str) -> String {
    let lines: Vec<&str> = text.lines().collect();
    let rows = &lines[1..];
    let (first, second) = rows.split_at(rows.len() / 2);
    let swapped = [&lines[..1], second, first].concat();
    swapped.join("\n") + "\n"
}

#[test]
fn a_file_sorted_by_line_is_fitted_compensated_and_measured_without_flags() {
    let dir = TempDir::new().unwrap();
    box_model(dir.path());
    survey(dir.path(), "10");
    let read = |name: &str| std::fs::read_to_string(dir.path().join(name)).unwrap();
    std::fs::write(
        dir.path().join("box_sorted.csv"),
        halves_swapped(&read("box.csv")),
    )
    .unwrap();
    std::fs::write(
        dir.path().join("sorted.csv"),
        halves_swapped(&read("survey.csv")),
    )
    .unwrap();
    let fit = [
        "fit",
        "box_sorted.csv",
        "--scalar",
        "mag_1_uc",
        "--vector",
        "flux_a",
        "--out",
        "s.json",
    ];
    let (_, warned) = run(dir.path(), &fit);
    assert!(
        warned.contains("time steps back or repeats at 1 place(s)"),
        "{warned}"
    );
    let compensated = |survey: &str, model: &str| {
        let args = ["compensate", survey, "--model", model, "--level", "model"];
        let out = run(dir.path(), &args).0;
        let values = column(&out, "mag_1_c");
        let tt = column(&out, "tt");
        let mut rows: Vec<(f64, f64)> = (tt.iter().zip(values))
            .map(|(t, v)| (t.unwrap(), v.unwrap()))
            .collect();
        rows.sort_by(|a, b| a.0.total_cmp(&b.0));
        rows
    };
    // The same rows, compensated as in time order (each half is its own run there too, as
    // the join is a gap), by the model of the box in time order or sorted by leg.
    let truth = compensated("survey.csv", "m.json");
    for model in ["m.json", "s.json"] {
        let sorted = compensated("sorted.csv", model);
        let error = sorted
            .iter()
            .zip(&truth)
            .map(|(a, b)| (a.1 - b.1).abs())
            .fold(0.0, f64::max);
        eprintln!("{model}: largest difference to the time-ordered file {error:.4} nT");
        assert!(error < 0.5, "{model}: {error}");
    }
    let noise = |file: &str| {
        let args = ["fom", file, "--scalar", "mag_1_uc", "--json"];
        let json: Value = serde_json::from_str(&run(dir.path(), &args).0).unwrap();
        json["fourth_difference_nT"].as_f64().unwrap()
    };
    let (ordered, sorted) = (noise("survey.csv"), noise("sorted.csv"));
    assert!(
        (sorted / ordered - 1.0).abs() < 0.05,
        "{ordered} vs {sorted}"
    );
}

/// The example surveys with a fluxgate, as delivered: every command runs on them without
/// flags, at the rate their time gives (HillValley's time is in hours with five decimals:
/// 10 Hz, not the 9.26 Hz of its median step).
#[test]
fn the_example_surveys_run_through_every_command_without_flags() {
    let dir = TempDir::new().unwrap();
    let cases = [
        (
            "Example_Mag_Gondwana_200Ma",
            "CompMag",
            "Fluxx:Fluxy:Fluxz",
            "10.00",
        ),
        (
            "Example_Mag_HillValley_1985",
            "RAWMAG",
            "FLUXX:FLUXY:FLUXZ",
            "10.00",
        ),
    ];
    for (stem, scalar, vector, rate) in cases {
        let file = example(stem);
        let file = file.to_str().unwrap();
        let (info, _) = run(dir.path(), &["info", file]);
        assert!(
            info.contains(&format!("sample rate: {rate}")),
            "{stem}: {info}"
        );
        let model = format!("{stem}.json");
        let fit = [
            "fit", file, "--scalar", scalar, "--vector", vector, "--out", &model,
        ];
        run(dir.path(), &fit);
        let (csv, _) = run(dir.path(), &["compensate", file, "--model", &model]);
        let compensated = column(&csv, &format!("{scalar}_c"));
        assert!(compensated.iter().all(Option::is_some), "{stem}");
        let (fom, warned) = run(dir.path(), &["fom", file, "--scalar", scalar, "--json"]);
        let fom: Value = serde_json::from_str(&fom).unwrap();
        assert!(fom["fom_nT"].is_null() && fom["fourth_difference_nT"].as_f64().unwrap() > 0.0);
        assert!(warned.contains("no attitude column"), "{warned}");
        let report = [
            "report", file, "--scalar", scalar, "--model", &model, "--out", stem,
        ];
        run(dir.path(), &report);
        let html = std::fs::read_to_string(dir.path().join(stem).join("index.html")).unwrap();
        assert!(html.contains("<svg"), "{stem}");
        // No attitude: no heading-error section that would only say "none".
        assert!(!html.contains(">Heading error<"), "{stem}");
    }
}

/// 10⁵ line ids (issue 46, item 25): `info` lists the first 50 and counts the rest, `--json`
/// every one with its rows, and the report has a row per line (found by hash, so both take
/// well under a second where they took 15 s and 23 s).
#[test]
fn a_file_with_a_hundred_thousand_line_ids_is_described_and_reported() {
    let dir = TempDir::new().unwrap();
    let mut csv = String::from("line,tt,mag_1_uc\n");
    for k in 0..200_000 {
        writeln!(csv, "{},{:.1},{}", k / 2, k as f64 * 0.1, 50_000 + k % 7).unwrap();
    }
    std::fs::write(dir.path().join("ids.csv"), csv).unwrap();
    let (text, _) = run(dir.path(), &["info", "ids.csv"]);
    let lines = text.lines().find(|l| l.starts_with("lines: ")).unwrap();
    assert!(
        lines.starts_with("lines: 100000: 0 (2 rows), 1 (2 rows)")
            && lines.ends_with("49 (2 rows), … 99950 more (--json lists every one)"),
        "{}",
        &lines[..200.min(lines.len())]
    );
    let (json, _) = run(dir.path(), &["info", "ids.csv", "--json"]);
    let json: Value = serde_json::from_str(&json).unwrap();
    let ids = json["lines"].as_array().unwrap();
    assert_eq!(ids.len(), 100_000);
    assert_eq!(ids[99_999]["rows"], 2);
    let report = ["report", "ids.csv", "--scalar", "mag_1_uc", "--out", "r"];
    run(dir.path(), &report);
    let html = std::fs::read_to_string(dir.path().join("r/index.html")).unwrap();
    assert!(html.contains("99999"));
}

/// `info` names a MAT-file a MAT-file, and standard input by its content (issue 46, item 18).
#[test]
fn info_names_the_format_it_read() {
    let dir = TempDir::new().unwrap();
    let fixtures = Path::new(env!("CARGO_MANIFEST_DIR")).join("../tolles-io/tests/fixtures");
    for name in ["matlab_v5.mat", "matlab_v73.mat"] {
        let (text, _) = run(dir.path(), &["info", fixtures.join(name).to_str().unwrap()]);
        assert!(text.lines().next().unwrap().ends_with(" (mat)"), "{text}");
    }
    for (name, format) in [("pyarrow.parquet", "parquet"), ("geosoft.xyz", "xyz")] {
        let input = std::fs::read(fixtures.join(name)).unwrap();
        let out = common::tolles()
            .current_dir(dir.path())
            .args(["info", "-"])
            .write_stdin(input)
            .output()
            .unwrap();
        let text = String::from_utf8_lossy(&out.stdout);
        assert!(text.starts_with(&format!("<stdin> ({format})")), "{text}");
    }
}

/// `stream` suggests the column meant, as the file commands do (item 18).
#[test]
fn stream_suggests_the_column_meant() {
    let dir = TempDir::new().unwrap();
    box_model(dir.path());
    let out = common::tolles()
        .current_dir(dir.path())
        .args(["stream", "--model", "m.json"])
        .write_stdin("tt,mag1uc,flux_a_x,flux_a_y,flux_a_z\n0,5e4,1e4,1e4,4e4\n")
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        !out.status.success() && err.contains("no column \"mag_1_uc\"; did you mean mag1uc?"),
        "{err}"
    );
}

/// A mistyped flag's error shows the command's own usage, not the flags given (`--out`) as if
/// they were required (item 18).
#[test]
fn a_usage_line_shows_what_is_required_not_what_was_given() {
    let out = common::tolles()
        .args([
            "fit", "c.csv", "--scalar", "a", "--vector", "b", "--out", "m.json", "--bogus",
        ])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    let usage = err.lines().find(|l| l.starts_with("Usage:")).unwrap();
    assert_eq!(
        usage,
        "Usage: tolles fit [OPTIONS] --scalar <SCALAR> --vector <VECTOR> <CAL>..."
    );
}
