//! `tolles report` of survey files as delivered: no attitude, positions under survey names, lines
//! sorted by number so that time steps back between them.

use crate::common::{self, tolles};
use std::path::{Path, PathBuf};

fn gondwana() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../tolles-io/tests/fixtures/aseg_gdf2/Example_Mag_Gondwana_200Ma.dfn")
}

/// The page, the plot files and what the command said on stderr.
fn report(flight: &Path, scalar: &str, out: &Path) -> (String, Vec<String>, String) {
    let done = tolles()
        .arg("report")
        .arg(flight)
        .args(["--scalar", scalar, "--out"])
        .arg(out)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&done.stderr).to_string();
    assert!(done.status.success(), "{stderr}");
    let page = std::fs::read_to_string(out.join("index.html")).unwrap();
    let plots = std::fs::read_dir(out.join("plots"))
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().to_string())
        .collect();
    (page, plots, stderr)
}

fn assert_no_nan_or_inf(page: &str, plots: &[String], dir: &Path) {
    for text in std::iter::once(page.to_string()).chain(
        plots
            .iter()
            .map(|p| std::fs::read_to_string(dir.join("plots").join(p)).unwrap()),
    ) {
        for bad in ["NaN", "inf", "∞"] {
            assert!(!text.contains(bad), "{bad} in the report");
        }
    }
}

#[test]
fn a_gdf_survey_sorted_by_line_without_attitude_reports_every_line_and_a_map() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("report");
    let (page, plots, stderr) = report(&gondwana(), "CompMag", &out);
    assert!(stderr.contains("time steps back"), "{stderr}");
    assert!(stderr.contains("no attitude column"), "{stderr}");
    for line in ["43012", "47020"] {
        assert!(
            page.contains(&format!("<td class=\"num\">{line}</td>")),
            "{line}"
        );
    }
    // Latitude/Longitude are the survey's names for lat/lon.
    assert!(plots.iter().any(|p| p.starts_with("map-")), "{plots:?}");
    assert!(!page.contains("FOM before"));
    assert_no_nan_or_inf(&page, &plots, &out);
}

#[test]
fn a_simulated_survey_stripped_of_attitude_still_reports() {
    let dir = tempfile::tempdir().unwrap();
    let full = dir.path().join("survey.csv");
    tolles()
        .args(["simulate", "--plan", "survey", "--lines", "3", "--out"])
        .arg(&full)
        .assert()
        .success();
    let text = std::fs::read_to_string(&full).unwrap();
    let header: Vec<&str> = text.lines().next().unwrap().split(',').collect();
    let keep: Vec<usize> = ["tt", "line", "lat", "lon", "mag_1_uc"]
        .iter()
        .map(|c| header.iter().position(|h| h == c).unwrap())
        .collect();
    let stripped: String = text
        .lines()
        .map(|l| {
            let cells: Vec<&str> = l.split(',').collect();
            let kept: Vec<&str> = keep.iter().map(|&k| cells[k]).collect();
            kept.join(",") + "\n"
        })
        .collect();
    let flight = dir.path().join("stripped.csv");
    std::fs::write(&flight, stripped).unwrap();
    let out = dir.path().join("report");
    let (page, plots, stderr) = report(&flight, "mag_1_uc", &out);
    assert!(stderr.contains("no attitude column"), "{stderr}");
    for line in ["1001", "1002", "1003"] {
        assert!(
            page.contains(&format!("<td class=\"num\">{line}</td>")),
            "line {line}"
        );
    }
    assert!(plots.iter().any(|p| p.starts_with("map-")), "{plots:?}");
    // Each straight line's profile, and none of the turns'.
    assert!(page.contains("Line profiles"));
    for line in ["1001", "1002", "1003"] {
        assert!(page.contains(&format!("Line {line}")), "profile of {line}");
    }
    assert!(!page.contains("Line 2<"), "a turn drawn as a line");
    assert_no_nan_or_inf(&page, &plots, &out);
}

/// `--reference COLUMN` judges the compensated scalar against a column of the flight, as
/// MagNav users compare with SGL's `mag_1_c`: here a reference magnetometer, which reads the
/// earth field as the truth does, so the two errors agree to its noise.
#[test]
fn a_reference_column_takes_the_place_of_the_truth() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let run = |args: &[&str]| common::run_in(d, args);
    run(&[
        "simulate",
        "--preset",
        "tail-stinger",
        "--reference",
        "--out",
        "box.csv",
    ]);
    run(&[
        "fit", "box.csv", "--scalar", "mag_1_uc", "--vector", "flux_a", "--out", "m.json",
    ]);
    let report = ["report", "box.csv", "--model", "m.json", "--out"];
    run(&[&report[..], &["truth"]].concat());
    run(&[&report[..], &["ref", "--reference", "mag_ref"]].concat());
    let page = |dir: &str| std::fs::read_to_string(d.join(dir).join("index.html")).unwrap();
    let (truth, reference) = (page("truth"), page("ref"));
    let after = |page: &str, label: &str| -> f64 {
        let at = page.find(label).unwrap_or_else(|| panic!("no {label:?}"));
        let value = page[at..].split("<dd>").nth(1).unwrap();
        value.split(' ').next().unwrap().parse().unwrap()
    };
    assert!(!reference.contains("error vs truth after"));
    let (t, r) = (
        after(&truth, "error vs truth after"),
        after(&reference, "error vs mag_ref after"),
    );
    println!("error after: vs truth {t} nT, vs mag_ref {r} nT");
    assert!((r - t).abs() < 0.02, "{t} {r}");
    let missing = tolles()
        .current_dir(d)
        .args([&report[..], &["x", "--reference", "mag_1_c"]].concat())
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&missing.stderr);
    assert!(
        !missing.status.success() && stderr.contains("mag_1_c"),
        "{stderr}"
    );
}

/// Issue 58: the specification is the user's (`--fom-spec`, `--heading-error-spec`), each test
/// passed or failed on the first screen, and a limit that is no positive number is refused
/// naming its flag.
#[test]
fn the_specification_is_the_users_and_passes_or_fails_on_the_first_screen() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let run = |args: &[&str]| common::run_in(d, args);
    run(&["simulate", "--reference", "--out", "box.csv"]);
    run(&[
        "fit", "box.csv", "--scalar", "mag_1_uc", "--vector", "flux_a", "-o", "m.json",
    ]);
    let report = [
        "report",
        "box.csv",
        "--model",
        "m.json",
        "--reference",
        "mag_ref",
        "-o",
    ];
    let first_screen = |dir: &str, flags: &[&str]| {
        run(&[&report[..], &[dir], flags].concat());
        let page = std::fs::read_to_string(d.join(dir).join("index.html")).unwrap();
        page[..page.find("<h2").unwrap()].to_string()
    };
    let row = |page: &str, test: &str| {
        let at = page
            .find(&format!("<td>{test}</td>"))
            .unwrap_or_else(|| panic!("{test}"));
        page[at..at + page[at..].find("</tr>").unwrap()].to_string()
    };
    let lenient = first_screen("lenient", &[]);
    assert!(row(&lenient, "figure of merit (box)").ends_with("<td>pass</td>"));
    assert!(row(&lenient, "heading error, compensated").contains("vs mag_ref"));
    let strict = first_screen(
        "strict",
        &["--fom-spec", "0.001", "--heading-error-spec", "1e-6"],
    );
    for test in ["figure of merit (box)", "heading error, compensated"] {
        let row = row(&strict, test);
        assert!(row.ends_with("<td>FAIL</td>"), "{row}");
    }
    assert!(row(&strict, "figure of merit (box)").contains("at most 0.001 nT"));
    let refused = tolles()
        .current_dir(d)
        .args([&report[..], &["x", "--fom-spec", "0"]].concat())
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&refused.stderr);
    assert!(
        !refused.status.success() && stderr.contains("--fom-spec"),
        "{stderr}"
    );
    assert_eq!(stderr.trim().lines().count(), 1, "{stderr}");
}

/// Issue 58 (item 5): a survey flight that starts with its calibration box keeps its Lines
/// table on the page: every survey line listed with its verdict, the box's legs and the turns
/// named under it.
#[test]
fn a_box_then_lines_flight_lists_every_line_on_the_page() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let run = |args: &[&str]| common::run_in(d, args);
    run(&["simulate", "--plan", "box", "--out", "box.csv"]);
    run(&[
        "simulate",
        "--plan",
        "survey",
        "--lines",
        "3",
        "--out",
        "lines.csv",
    ]);
    let flight_box = std::fs::read_to_string(d.join("box.csv")).unwrap();
    let survey = std::fs::read_to_string(d.join("lines.csv")).unwrap();
    let header: Vec<&str> = survey.lines().next().unwrap().split(',').collect();
    let at = |name: &str| header.iter().position(|h| *h == name).unwrap();
    let (tt, line) = (at("tt"), at("line"));
    let last = flight_box
        .lines()
        .last()
        .unwrap()
        .split(',')
        .nth(tt)
        .unwrap();
    let offset: f64 = last.parse::<f64>().unwrap() + 0.1;
    let mut joined = flight_box.clone();
    for row in survey.lines().skip(1) {
        let cells: Vec<String> = (row.split(',').enumerate())
            .map(|(k, c)| match k {
                k if k == tt => (c.parse::<f64>().unwrap() + offset).to_string(),
                k if k == line => (c.parse::<f64>().unwrap() + 100.0).to_string(),
                _ => c.to_string(),
            })
            .collect();
        joined += &(cells.join(",") + "\n");
    }
    std::fs::write(d.join("flight.csv"), joined).unwrap();
    run(&[
        "fit", "box.csv", "--scalar", "mag_1_uc", "--vector", "flux_a", "-o", "m.json",
    ]);
    run(&["report", "flight.csv", "--model", "m.json", "-o", "rep"]);
    let page = std::fs::read_to_string(d.join("rep/index.html")).unwrap();
    let lines = &page[page.find(">Lines</h2>").expect("a Lines section")..];
    let lines = &lines[..lines[5..].find("<h2").unwrap() + 5];
    for id in ["1101", "1102", "1103"] {
        let row = lines
            .split("<tr>")
            .find(|r| r.contains(&format!(">{id}</td>")))
            .unwrap_or_else(|| panic!("line {id} is not listed"));
        assert!(
            row.contains("<td>pass</td>") || row.contains("<td>FAIL</td>"),
            "{row}"
        );
    }
    assert!(lines.contains("Not in the table"), "{lines}");
    // The box keeps its own sections.
    assert!(page.contains(">Maneuvers</h2>") && page.contains(">Figure of merit</h2>"));
}
