//! Channel names through the binary: SGL's raw names answer to tolles' own, `--rename`,
//! fluxgates named as three columns `X:Y:Z`, suggestions, and `tolles info`.

use assert_cmd::Command;
use serde_json::Value;
use std::path::{Path, PathBuf};

/// tolles' names → SGL's raw export names (MagNav.jl's `Flt1003_sample.xyz`).
const SGL: [(&str, &str); 11] = [
    ("tt", "TIME"),
    ("line", "LINE"),
    ("ins_roll", "ROLL"),
    ("ins_pitch", "PITCH"),
    ("ins_yaw", "AZIMUTH"),
    ("mag_1_uc", "UNCOMPMAG1"),
    ("flux_a_x", "FLUXA_X"),
    ("flux_a_y", "FLUXA_Y"),
    ("flux_a_z", "FLUXA_Z"),
    ("lat", "LAT"),
    ("lon", "LONG"),
];

fn tolles(args: &[&str]) -> std::process::Output {
    Command::cargo_bin("tolles")
        .unwrap()
        .args(args)
        .output()
        .unwrap()
}

fn ok(args: &[&str]) -> (String, String) {
    let out = tolles(args);
    let stderr = String::from_utf8_lossy(&out.stderr).to_string();
    assert!(out.status.success(), "{args:?}: {stderr}");
    (String::from_utf8_lossy(&out.stdout).to_string(), stderr)
}

fn fails(args: &[&str]) -> String {
    let out = tolles(args);
    assert!(!out.status.success(), "{args:?} should fail");
    String::from_utf8_lossy(&out.stderr).to_string()
}

/// A simulated box whose header carries SGL's raw names.
fn sgl_box(dir: &Path) -> PathBuf {
    let plain = dir.join("box.csv");
    ok(&[
        "simulate",
        "--plan",
        "box",
        "--seed",
        "1",
        "--out",
        plain.to_str().unwrap(),
    ]);
    let text = std::fs::read_to_string(&plain).unwrap();
    let (header, rest) = text.split_once('\n').unwrap();
    let header: Vec<String> = header
        .split(',')
        .map(|h| {
            SGL.iter()
                .find(|(ours, _)| *ours == h)
                .map_or(h.to_string(), |(_, raw)| raw.to_string())
        })
        .collect();
    let path = dir.join("sgl.csv");
    std::fs::write(&path, format!("{}\n{rest}", header.join(","))).unwrap();
    path
}

#[test]
fn a_box_with_sgl_raw_names_fits_and_measures_without_renaming() {
    let dir = tempfile::tempdir().unwrap();
    let sgl = sgl_box(dir.path());
    let f = sgl.to_str().unwrap();
    let model = dir.path().join("m.json");
    let m = model.to_str().unwrap();
    let (_, stderr) = ok(&[
        "fit",
        f,
        "--scalar",
        "UNCOMPMAG1",
        "--vector",
        "FLUXA",
        "--out",
        m,
    ]);
    assert!(stderr.contains("AZIMUTH as ins_yaw"), "{stderr}");
    ok(&["fom", f, "--scalar", "UNCOMPMAG1"]);
    ok(&["fom", f, "--scalar", "UNCOMPMAG1", "--model", m]);
    // tolles' own names find the raw channels.
    ok(&[
        "fit", f, "--scalar", "mag_1_uc", "--vector", "flux_a", "--out", m,
    ]);
    ok(&[
        "fom", f, "--scalar", "mag_1_uc", "--model", m, "--line", "2",
    ]);
}

#[test]
fn a_fluxgate_named_by_three_columns_round_trips_through_the_model() {
    let dir = tempfile::tempdir().unwrap();
    let sgl = sgl_box(dir.path());
    let f = sgl.to_str().unwrap();
    let model = dir.path().join("m.json");
    let m = model.to_str().unwrap();
    let triple = "FLUXA_X:FLUXA_Y:FLUXA_Z";
    ok(&[
        "fit",
        f,
        "--scalar",
        "UNCOMPMAG1",
        "--vector",
        triple,
        "--out",
        m,
    ]);
    let saved: Value = serde_json::from_str(&std::fs::read_to_string(&model).unwrap()).unwrap();
    assert!(saved.to_string().contains(triple), "{saved}");
    let out = dir.path().join("c.csv");
    ok(&[
        "compensate",
        f,
        "--model",
        m,
        "--out",
        out.to_str().unwrap(),
    ]);
    let written = std::fs::read_to_string(&out).unwrap();
    assert!(
        written.starts_with("TIME,"),
        "headers are written as the file has them"
    );
    assert!(written.lines().next().unwrap().ends_with("UNCOMPMAG1_c"));
    let e = fails(&[
        "fit",
        f,
        "--scalar",
        "UNCOMPMAG1",
        "--vector",
        "FLUXA_X:FLUXA_Y",
    ]);
    assert!(
        e.contains("X:Y:Z") && e.lines().last().unwrap().starts_with("error: --vector"),
        "{e}"
    );
}

#[test]
fn rename_applies_before_everything_and_names_an_unknown_column() {
    let dir = tempfile::tempdir().unwrap();
    let sgl = sgl_box(dir.path());
    let f = sgl.to_str().unwrap();
    let model = dir.path().join("m.json");
    let m = model.to_str().unwrap();
    let renames = "UNCOMPMAG1=mag,FLUXA_X=bx,FLUXA_Y=by,FLUXA_Z=bz";
    ok(&[
        "fit", f, "--rename", renames, "--scalar", "mag", "--vector", "bx:by:bz", "--out", m,
    ]);
    ok(&["fom", f, "--rename", "UNCOMPMAG1=mag", "--scalar", "mag"]);
    let e = fails(&["fom", f, "--rename", "NOPE=mag", "--scalar", "mag"]);
    assert!(
        e.contains("--rename NOPE=mag") && e.contains("\"NOPE\""),
        "{e}"
    );
}

#[test]
fn a_missing_fluxgate_suggests_prefixes_whatever_the_case() {
    let dir = tempfile::tempdir().unwrap();
    let sgl = sgl_box(dir.path());
    let e = fails(&[
        "fit",
        sgl.to_str().unwrap(),
        "--scalar",
        "UNCOMPMAG1",
        "--vector",
        "FLUX",
    ]);
    assert!(e.contains("did you mean FLUXA?"), "{e}");
}

#[test]
fn info_describes_columns_rows_rate_lines_and_missing_values() {
    let dir = tempfile::tempdir().unwrap();
    let sgl = sgl_box(dir.path());
    let f = sgl.to_str().unwrap();
    let (text, _) = ok(&["info", f]);
    assert!(
        text.contains("rows: 4661") && text.contains("sample rate: 10"),
        "{text}"
    );
    let (json, _) = ok(&["info", f, "--json"]);
    let about: Value = serde_json::from_str(&json).unwrap();
    assert_eq!(about["rows"], 4661);
    assert!((about["sample_rate_hz"].as_f64().unwrap() - 10.0).abs() < 1e-9);
    assert_eq!(about["time_span_s"][0], 0.0);
    assert!(!about["lines"].as_array().unwrap().is_empty());
    let azimuth = about["columns"]
        .as_array()
        .unwrap()
        .iter()
        .find(|c| c["name"] == "AZIMUTH")
        .unwrap();
    assert_eq!(azimuth["aliases"][0], "ins_yaw");
    assert_eq!(azimuth["missing"], 0);
    // GDF units come from the .dfn.
    let dfn = dir.path().join("g.dfn");
    std::fs::write(
        &dfn,
        "DEFN   ST=RECD,RT=COMM;RT:A4;COMMENTS:A76\nDEFN 1 ST=RECD,RT=;TT:F10.1:UNITS=s\nDEFN 2 ST=RECD,RT=;MAG_1_UC:F12.3:NULL=-99999.000,UNITS=nT\nDEFN 3 ST=RECD,RT=;END DEFN\n",
    )
    .unwrap();
    std::fs::write(
        dir.path().join("g.dat"),
        "       0.0   50000.000\n       0.1  -99999.000\n",
    )
    .unwrap();
    let (json, _) = ok(&["info", dfn.to_str().unwrap(), "--json"]);
    let about: Value = serde_json::from_str(&json).unwrap();
    assert_eq!(about["columns"][1]["unit"], "nT", "{about}");
    assert_eq!(about["columns"][1]["missing"], 1, "{about}");
}
