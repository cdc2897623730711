//! The command line's smaller stumbles: `-` for standard input and output, negative numbers as
//! flag values, one name for the inclination, row selection and renaming on every command that
//! reads a flight, `--scalar` taken from a one-fit model, and help that names every format.

use crate::common::tolles;
use serde_json::Value;
use std::path::{Path, PathBuf};
use tempfile::TempDir;

/// Runs `tolles ARGS` with `stdin`, expecting success; returns (stdout, stderr).
fn run_with(args: &[&str], stdin: &[u8]) -> (String, String) {
    let out = tolles().args(args).write_stdin(stdin).output().unwrap();
    let stderr = String::from_utf8(out.stderr).unwrap();
    assert!(out.status.success(), "{args:?}: {stderr}");
    (String::from_utf8(out.stdout).unwrap(), stderr)
}

fn run(args: &[&str]) -> (String, String) {
    run_with(args, b"")
}

/// [`run`] in the directory `dir`, where a file named `-` would show up.
fn run_in(dir: &Path, args: &[&str]) -> String {
    let out = tolles().current_dir(dir).args(args).output().unwrap();
    let stderr = String::from_utf8(out.stderr).unwrap();
    assert!(out.status.success(), "{args:?}: {stderr}");
    String::from_utf8(out.stdout).unwrap()
}

/// Runs `tolles ARGS`, expecting failure; returns stderr, which must be one error line.
fn fails(args: &[&str]) -> String {
    let out = tolles().args(args).output().unwrap();
    let stderr = String::from_utf8(out.stderr).unwrap();
    assert!(!out.status.success(), "expected failure for {args:?}");
    assert!(!stderr.contains("panicked"), "{stderr}");
    assert_eq!(stderr.trim_end().lines().count(), 1, "{stderr}");
    stderr
}

fn text(path: &Path) -> &str {
    path.to_str().unwrap()
}

/// A simulated compensation box, 10 Hz, with a `line` column.
fn box_flight(dir: &Path) -> PathBuf {
    let path = dir.join("box.csv");
    run(&[
        "simulate",
        "--plan",
        "box",
        "--seed",
        "5",
        "--out",
        text(&path),
    ]);
    path
}

/// A one-fit model of `flight` (mag_1_uc, flux_a).
fn model(dir: &Path, flight: &Path) -> PathBuf {
    let path = dir.join("model.json");
    let args = ["--scalar", "mag_1_uc", "--vector", "flux_a"];
    run(&[&["fit", text(flight)], &args[..], &["--out", text(&path)]].concat());
    path
}

#[test]
fn a_dash_reads_the_flight_from_standard_input_for_every_command() {
    let dir = TempDir::new().unwrap();
    let flight = box_flight(dir.path());
    let csv = std::fs::read(&flight).unwrap();
    let model = model(dir.path(), &flight);
    let m = text(&model);
    let out = dir.path().join("report");
    let commands: [&[&str]; 7] = [
        &["fit", "-", "--scalar", "mag_1_uc", "--vector", "flux_a"],
        &["compensate", "-", "--model", m],
        &["fom", "-", "--scalar", "mag_1_uc"],
        &["info", "-"],
        &["report", "-", "--scalar", "mag_1_uc", "--out", text(&out)],
        &[
            "procedure",
            "-",
            "--scalar",
            "mag_1_uc",
            "--vector",
            "flux_a",
        ],
        &["plan", "-", "--vector", "flux_a"],
    ];
    for args in commands {
        run_with(args, &csv);
    }
    // The same rows as the file gives, the file's name replaced by <stdin>.
    let (from_file, _) = run(&["info", text(&flight), "--json"]);
    let (from_stdin, _) = run_with(&["info", "-", "--json"], &csv);
    let rows = |json: &str| serde_json::from_str::<Value>(json).unwrap()["rows"].clone();
    assert_eq!(rows(&from_stdin), rows(&from_file));
    assert_eq!(rows(&from_file), 4661);
    assert!(from_stdin.contains("<stdin>"), "{from_stdin}");
}

#[test]
fn geosoft_xyz_on_standard_input_is_told_from_csv_by_its_content() {
    let xyz = "/ tt mag_1_uc\nLine 10\n0.0 50000.5\n0.1 *\nLine 11\n0.2 50001.0\n";
    let (json, _) = run_with(&["info", "-", "--json"], xyz.as_bytes());
    let about: Value = serde_json::from_str(&json).unwrap();
    assert_eq!(about["rows"], 3);
    let (listing, _) = run_with(&["info", "-", "--line", "11"], xyz.as_bytes());
    assert!(listing.contains("rows: 1"), "{listing}");
}

#[test]
fn a_dash_as_out_writes_the_table_or_model_to_standard_output() {
    let dir = TempDir::new().unwrap();
    let flight = box_flight(dir.path());
    let model = model(dir.path(), &flight);
    let fit = [
        "fit",
        text(&flight),
        "--scalar",
        "mag_1_uc",
        "--vector",
        "flux_a",
    ];
    let json = run_in(dir.path(), &[&fit[..], &["--out", "-"]].concat());
    let from_stdout: Value = serde_json::from_str(&json).unwrap();
    let from_file: Value = serde_json::from_str(&std::fs::read_to_string(&model).unwrap()).unwrap();
    assert_eq!(from_stdout["fits"], from_file["fits"]);
    let compensate = ["compensate", text(&flight), "--model", text(&model)];
    let to_dash = run_in(dir.path(), &[&compensate[..], &["--out", "-"]].concat());
    let (plain, _) = run(&compensate);
    assert_eq!(to_dash, plain);
    assert!(to_dash.starts_with("tt,line,"));
    let procedure = [
        "procedure",
        text(&flight),
        "--scalar",
        "mag_1_uc",
        "--vector",
        "flux_a",
    ];
    let json = run_in(dir.path(), &[&procedure[..], &["--out", "-"]].concat());
    let (asked, _) = run(&[&procedure[..], &["--json"]].concat());
    assert_eq!(json, asked);
    assert!(!dir.path().join("-").exists(), "no file named -");
}

/// Every flag whose value may be negative, with a negative value; `--help` after it succeeds
/// only if the value was taken as the flag's.
#[test]
fn negative_values_are_values_not_unknown_flags() {
    let cases: &[(&[&str], &str, &str)] = &[
        (&["fit", "f.csv"], "--band", "-1,0.9"),
        (&["fit", "f.csv"], "--lag", "-0.05"),
        (&["fit", "f.csv"], "--fs", "-10"),
        (&["fit", "f.csv"], "--time", "-5..10"),
        (&["compensate", "f.csv"], "--fs", "-10"),
        (&["fom", "f.csv"], "--band", "-1,0.9"),
        (&["fom", "f.csv"], "--fs", "-10"),
        (&["report", "f.csv"], "--band", "-1,0.9"),
        (&["report", "f.csv"], "--fs", "-10"),
        (&["report", "f.csv"], "--time", "-5..10"),
        (&["procedure", "f.csv"], "--inclination", "-33.9"),
        (&["procedure", "f.csv"], "--declination", "-3"),
        (&["procedure", "f.csv"], "--time", "-5..10"),
        (&["plan"], "--inclination", "-33.9"),
        (&["plan"], "--declination", "-3"),
        (&["plan"], "--noise", "-1"),
        (&["plan"], "--intensity", "-5"),
        (&["info", "f.csv"], "--time", "-5..10"),
        (&["tables"], "--inclination", "-33.9"),
        (&["tables"], "--heading", "-45"),
        (&["tables"], "--amplitude", "-5"),
        (&["simulate"], "--lat", "-33.9"),
        (&["simulate"], "--lon", "-75.7"),
        (&["simulate"], "--alt", "-10"),
        (&["simulate"], "--inclination", "-33.9"),
        (&["simulate"], "--declination", "-3"),
        (&["simulate"], "--intensity", "-5"),
        (&["simulate"], "--flux-lag", "-0.05"),
        (&["simulate"], "--roll", "-10"),
        (&["simulate"], "--pitch", "-5"),
        (&["simulate"], "--yaw", "-5"),
        (&["simulate"], "--fs", "-10"),
        (&["simulate"], "--speed", "-60"),
        (&["simulate"], "--period", "-6"),
        (&["simulate"], "--line-duration", "-1"),
        (&["simulate"], "--turbulence", "-1"),
        (&["simulate"], "--geology", "-1"),
        (&["simulate"], "--diurnal", "-1"),
        (&["simulate"], "--scalar-noise", "-1"),
        (&["simulate"], "--flux-noise", "-1"),
        (&["stream"], "--fs", "-10"),
        (&["stream"], "--idle-timeout", "-1"),
    ];
    for (command, flag, value) in cases {
        let args = [command, &[*flag, *value, "--help"][..]].concat();
        let out = tolles().args(&args).output().unwrap();
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(
            out.status.success() && !stderr.contains("unexpected argument"),
            "{args:?}: {stderr}"
        );
    }
}

#[test]
fn negative_values_reach_the_command() {
    let dir = TempDir::new().unwrap();
    let path = dir.path().join("south.csv");
    let sim = ["simulate", "--plan", "box", "--out", text(&path)];
    run(&[
        &sim[..],
        &["--lat", "-33.9", "--lon", "18.4", "--flux-lag", "-0.05"],
    ]
    .concat());
    let sidecar = std::fs::read_to_string(path.with_extension("json")).unwrap();
    assert!(sidecar.contains("-33.9"), "{sidecar}");
    // A band edge ≤ 0 switches it off, as in a fit (a low-pass at 0.9 Hz): the command, not
    // the parser, takes the negative number.
    let fom = [
        "fom",
        text(&path),
        "--scalar",
        "mag_1_uc",
        "--band",
        "-1,0.9",
        "--json",
    ];
    let (json, _) = run(&fom);
    let json: serde_json::Value = serde_json::from_str(&json).unwrap();
    assert_eq!(json["band_hz"][0], -1.0, "{json}");
}

#[test]
fn inclination_is_the_name_everywhere_and_dip_an_alias() {
    let (by_inclination, _) = run(&["tables", "--inclination", "-60", "--json"]);
    let (by_dip, _) = run(&["tables", "--dip", "-60", "--json"]);
    assert_eq!(by_inclination, by_dip);
    assert!(by_inclination.contains("-60"));
    for command in ["tables", "procedure", "plan", "simulate"] {
        let (help, _) = run(&[command, "--help"]);
        assert!(
            help.contains("--inclination <INCLINATION>") && help.contains("[alias: --dip]"),
            "{command}: {help}"
        );
    }
    let err = fails(&["procedure", "f.csv", "--scalar", "mag_1_uc"]);
    assert!(err.contains("--inclination DEG"), "{err}");
}

#[test]
fn every_command_that_reads_a_flight_selects_rows_and_renames_columns() {
    let dir = TempDir::new().unwrap();
    let flight = box_flight(dir.path());
    let f = text(&flight);
    let selected = |stderr: &str| stderr.contains("selected") && stderr.contains("of 4661 rows");
    let (listing, stderr) = run(&["info", f, "--time", "..99.95", "--json"]);
    let about: Value = serde_json::from_str(&listing).unwrap();
    assert_eq!(about["rows"], 1000);
    assert!(selected(&stderr), "{stderr}");
    let (listing, _) = run(&["info", f, "--rename", "mag_1_uc=scalar", "--json"]);
    assert!(listing.contains("\"scalar\""), "{listing}");

    let report = dir.path().join("report");
    let (_, stderr) = run(&[
        "report",
        f,
        "--scalar",
        "m",
        "--rename",
        "mag_1_uc=m",
        "--time",
        "..300",
        "--out",
        text(&report),
    ]);
    assert!(selected(&stderr), "{stderr}");
    let (_, stderr) = run(&[
        "procedure",
        f,
        "--scalar",
        "mag_1_uc",
        "--vector",
        "flux_a",
        "--time",
        "..300",
    ]);
    assert!(selected(&stderr), "{stderr}");
    let (_, stderr) = run(&[
        "plan",
        f,
        "--vector",
        "fx",
        "--rename",
        "flux_a_x=fx_x,flux_a_y=fx_y,flux_a_z=fx_z",
        "--time",
        "..300",
    ]);
    assert!(selected(&stderr), "{stderr}");
    let err = fails(&["plan", "--time", "..300"]);
    assert!(err.contains("give the flight file"), "{err}");
}

#[test]
fn the_scalar_defaults_to_that_of_a_model_with_one_fit() {
    let dir = TempDir::new().unwrap();
    let flight = box_flight(dir.path());
    let model = model(dir.path(), &flight);
    let (f, m) = (text(&flight), text(&model));
    let (named, _) = run(&["fom", f, "--scalar", "mag_1_uc", "--model", m]);
    let (defaulted, _) = run(&["fom", f, "--model", m]);
    assert_eq!(named, defaulted);
    let report = dir.path().join("report");
    run(&["report", f, "--model", m, "--out", text(&report)]);
    let html = std::fs::read_to_string(report.join("index.html")).unwrap();
    assert!(
        html.contains("Scalar mag_1_uc"),
        "the report names the scalar"
    );

    let err = fails(&["fom", f]);
    assert!(err.contains("--scalar"), "{err}");
    // A model with fits for two scalars: which one is the user's to say.
    let mut two: Value = serde_json::from_str(&std::fs::read_to_string(&model).unwrap()).unwrap();
    let mut second = two["fits"][0].clone();
    second["scalar"] = "mag_2_uc".into();
    two["fits"].as_array_mut().unwrap().push(second);
    let two_path = dir.path().join("two.json");
    std::fs::write(&two_path, two.to_string()).unwrap();
    let err = fails(&["fom", f, "--model", text(&two_path)]);
    assert!(
        err.contains("--scalar mag_1_uc|mag_2_uc") && err.contains("two.json"),
        "{err}"
    );
    // A report covers every fit: here the flight lacks the second fit's scalar.
    let err = fails(&[
        "report",
        f,
        "--model",
        text(&two_path),
        "--out",
        text(&report),
    ]);
    assert!(err.contains("no column \"mag_2_uc\""), "{err}");
}

#[test]
fn every_flight_argument_names_every_format_and_standard_input() {
    for command in [
        "fit",
        "compensate",
        "fom",
        "info",
        "report",
        "procedure",
        "plan",
    ] {
        let (help, _) = run(&[command, "--help"]);
        for format in [
            "CSV",
            "XYZ",
            "GDF",
            ".dfn",
            "HDF5",
            ".mat",
            "Parquet",
            "standard input",
        ] {
            assert!(help.contains(format), "{command} --help lacks {format}");
        }
    }
}

#[test]
fn fit_takes_several_scalars_by_repeating_the_flag_as_report_does() {
    let dir = TempDir::new().unwrap();
    let flight = box_flight(dir.path());
    let f = text(&flight);
    // A second scalar: the first plus a constant, so both fit.
    let csv = std::fs::read_to_string(&flight).unwrap();
    let mut lines = csv.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let k = header.iter().position(|h| *h == "mag_1_uc").unwrap();
    let mut two = format!("{},mag_2_uc\n", header.join(","));
    for line in lines {
        let value: f64 = line.split(',').nth(k).unwrap().parse().unwrap();
        two += &format!("{line},{}\n", value + 12.5);
    }
    let two_flight = dir.path().join("two.csv");
    std::fs::write(&two_flight, two).unwrap();
    let f2 = text(&two_flight);
    let (commas, _) = run(&[
        "fit",
        f2,
        "--scalar",
        "mag_1_uc,mag_2_uc",
        "--vector",
        "flux_a",
    ]);
    let (repeated, _) = run(&[
        "fit", f2, "--scalar", "mag_1_uc", "--scalar", "mag_2_uc", "--vector", "flux_a",
    ]);
    assert_eq!(commas, repeated);
    let model: Value = serde_json::from_str(&repeated).unwrap();
    assert_eq!(model["fits"].as_array().unwrap().len(), 2);
    // Still required (clap's own message, with its usage line).
    let out = tolles()
        .args(["fit", f, "--vector", "flux_a"])
        .output()
        .unwrap();
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("--scalar"));
}
