//! `--line` and `--time` through the binary: `fit`, `compensate` and `fom` on selected rows give
//! what they give on a file holding only those rows, and messages still name the file's lines.

use crate::common::tolles;

use serde_json::Value;
use std::path::{Path, PathBuf};
use tempfile::TempDir;

/// Runs `tolles ARGS`, expecting success; returns (stdout, stderr).
fn run(args: &[&str]) -> (String, String) {
    let out = tolles().args(args).output().unwrap();
    let stderr = String::from_utf8(out.stderr).unwrap();
    assert!(out.status.success(), "{args:?}: {stderr}");
    (String::from_utf8(out.stdout).unwrap(), stderr)
}

/// Runs `tolles ARGS`, expecting failure; returns its one error line (after what was selected,
/// if the error came later).
fn fails(args: &[&str]) -> String {
    let out = tolles().args(args).output().unwrap();
    let stderr = String::from_utf8(out.stderr).unwrap();
    assert!(!out.status.success(), "expected failure for {args:?}");
    assert!(!stderr.contains("panicked"), "{stderr}");
    let errors: Vec<&str> = stderr
        .lines()
        .filter(|l| l.starts_with("error: "))
        .collect();
    assert_eq!(errors.len(), 1, "{stderr}");
    errors[0].to_string()
}

fn text(path: &Path) -> &str {
    path.to_str().unwrap()
}

/// A simulated compensation box (columns tt, line, attitude, mag_1_uc, flux_a_*), 10 Hz.
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

/// The file's data lines (no header) whose row `keep` accepts, given the row's `line` and `tt`.
fn rows_where(csv: &str, keep: impl Fn(&str, f64) -> bool) -> Vec<String> {
    let mut lines = csv.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let at = |name: &str| header.iter().position(|h| *h == name).unwrap();
    let (line, tt) = (at("line"), at("tt"));
    lines
        .filter(|row| {
            let cells: Vec<&str> = row.split(',').collect();
            keep(cells[line], cells[tt].parse().unwrap())
        })
        .map(str::to_string)
        .collect()
}

/// Writes the header of `csv` and `rows` to `name` in `dir`.
fn write_rows(dir: &Path, name: &str, csv: &str, rows: &[String]) -> PathBuf {
    let header = csv.lines().next().unwrap();
    let path = dir.join(name);
    std::fs::write(&path, format!("{header}\n{}\n", rows.join("\n"))).unwrap();
    path
}

fn fit_model(flight: &Path, model: &Path, select: &[&str]) -> String {
    let args = [
        "fit",
        text(flight),
        "--scalar",
        "mag_1_uc",
        "--vector",
        "flux_a",
    ];
    let (_, stderr) = run(&[&args[..], &["--out", text(model)], select].concat());
    stderr
}

#[test]
fn fit_on_a_line_equals_fit_on_a_file_of_that_line() {
    let dir = TempDir::new().unwrap();
    let flight = box_flight(dir.path());
    let csv = std::fs::read_to_string(&flight).unwrap();
    let total = csv.lines().count() - 1;

    let line_2 = rows_where(&csv, |line, _| line == "2");
    let only = write_rows(dir.path(), "line2.csv", &csv, &line_2);
    let (selected, alone) = (dir.path().join("sel.json"), dir.path().join("alone.json"));
    let stderr = fit_model(&flight, &selected, &["--line", "2"]);
    fit_model(&only, &alone, &[]);
    assert!(
        stderr.contains(&format!(
            "selected {} of {total} rows (line 2); the fit uses only these",
            line_2.len()
        )),
        "{stderr}"
    );
    // The same model, but for the calibration flight each names.
    let model = |path: &Path| {
        let text = std::fs::read_to_string(path).unwrap();
        let mut json: serde_json::Value = serde_json::from_str(&text).unwrap();
        json["fits"][0]["calibration_flight"] = serde_json::Value::Null;
        json
    };
    assert_eq!(model(&selected), model(&alone));
    let whole = dir.path().join("whole.json");
    fit_model(&flight, &whole, &[]);
    assert_ne!(
        model(&selected),
        model(&whole),
        "the selection made no difference"
    );

    // Lines apart in time, as a file of only them: runs are cut at the gap in both.
    let some = rows_where(&csv, |line, _| ["2", "4", "6"].contains(&line));
    let only = write_rows(dir.path(), "lines.csv", &csv, &some);
    fit_model(&flight, &selected, &["--line", "2,4", "--line", "6"]);
    fit_model(&only, &alone, &[]);
    assert_eq!(model(&selected), model(&alone));
}

#[test]
fn compensate_writes_only_the_selected_rows_levelled_over_them() {
    let dir = TempDir::new().unwrap();
    let flight = box_flight(dir.path());
    let model = dir.path().join("model.json");
    fit_model(&flight, &model, &[]);
    let csv = std::fs::read_to_string(&flight).unwrap();
    let total = csv.lines().count() - 1;

    let (written, stderr) = run(&[
        "compensate",
        text(&flight),
        "--model",
        text(&model),
        "--line",
        "3.0",
    ]);
    let line_3 = rows_where(&csv, |line, _| line == "3");
    let rows: Vec<&str> = written.lines().skip(1).collect();
    assert_eq!(rows.len(), line_3.len());
    for (out, input) in rows.iter().zip(&line_3) {
        assert!(out.starts_with(&format!("{input},")), "{out} vs {input}");
    }
    assert!(
        stderr.contains(&format!(
            "selected {} of {total} rows (line 3.0); only these are compensated and written (the other {} rows are left out)",
            line_3.len(),
            total - line_3.len()
        )),
        "{stderr}"
    );
    let only = write_rows(dir.path(), "line3.csv", &csv, &line_3);
    let (alone, _) = run(&["compensate", text(&only), "--model", text(&model)]);
    assert_eq!(
        written, alone,
        "the file-mean level is not over the selected rows"
    );
}

#[test]
fn fom_uses_only_the_selected_time() {
    let dir = TempDir::new().unwrap();
    let flight = box_flight(dir.path());
    let csv = std::fs::read_to_string(&flight).unwrap();
    let fom = |path: &Path, select: &[&str]| -> (Value, String) {
        let args = ["fom", text(path), "--scalar", "mag_1_uc", "--json"];
        let (out, stderr) = run(&[&args[..], select].concat());
        (serde_json::from_str(&out).unwrap(), stderr)
    };
    let (whole, _) = fom(&flight, &[]);
    let (first_half, stderr) = fom(&flight, &["--time", "..200"]);
    assert!(
        stderr.contains("(tt ..200 s); the FOM uses only these"),
        "{stderr}"
    );
    let counted = |v: &Value| v["maneuvers"].as_array().unwrap().clone();
    assert!(!counted(&first_half).is_empty());
    assert!(counted(&first_half).len() < counted(&whole).len());
    for maneuver in counted(&first_half) {
        assert!(maneuver["end_tt"].as_f64().unwrap() <= 200.0, "{maneuver}");
    }
    let early = rows_where(&csv, |_, tt| tt <= 200.0);
    let only = write_rows(dir.path(), "early.csv", &csv, &early);
    assert_eq!(first_half, fom(&only, &[]).0);
}

#[test]
fn selection_errors_name_the_file_and_what_is_wrong() {
    let dir = TempDir::new().unwrap();
    let flight = box_flight(dir.path());
    let f = text(&flight);
    let fit = ["fit", f, "--scalar", "mag_1_uc", "--vector", "flux_a"];

    let e = fails(&[&fit[..], &["--line", "3,77"]].concat());
    assert!(
        e.contains("box.csv: --line 77: no row is on that line; the file's lines are 1, 2, 3"),
        "{e}"
    );
    let e = fails(&["fom", f, "--scalar", "mag_1_uc", "--time", "1e6.."]);
    assert!(
        e.contains("box.csv: no row is within tt 1000000.. s; the file's rows span tt 0.."),
        "{e}"
    );
    let e = fails(&[&fit[..], &["--time", "300..100"]].concat());
    assert!(
        e.contains("--time") && e.contains("START is after END"),
        "{e}"
    );

    let csv = std::fs::read_to_string(&flight).unwrap();
    let no_line = dir.path().join("noline.csv");
    std::fs::write(&no_line, csv.replacen(",line,", ",flight_line,", 1)).unwrap();
    let e = fails(&["fom", text(&no_line), "--scalar", "mag_1_uc", "--line", "1"]);
    assert!(
        e.contains("noline.csv: --line needs a column \"line\""),
        "{e}"
    );
}

#[test]
fn an_error_in_a_selected_row_names_its_line_in_the_file() {
    let dir = TempDir::new().unwrap();
    let flight = box_flight(dir.path());
    let csv = std::fs::read_to_string(&flight).unwrap();
    let header: Vec<&str> = csv.lines().next().unwrap().split(',').collect();
    let mag = header.iter().position(|h| *h == "mag_1_uc").unwrap();
    let line = header.iter().position(|h| *h == "line").unwrap();
    // The 11th row of line 4, at a file line far from the 11th of the selection.
    let (index, row) = csv
        .lines()
        .enumerate()
        .filter(|(_, row)| row.split(',').nth(line) == Some("4"))
        .nth(10)
        .unwrap();
    let mut cells: Vec<&str> = row.split(',').collect();
    cells[mag] = "oops";
    let broken: Vec<String> = csv
        .lines()
        .enumerate()
        .map(|(k, l)| {
            if k == index {
                cells.join(",")
            } else {
                l.to_string()
            }
        })
        .collect();
    let path = dir.path().join("broken.csv");
    std::fs::write(&path, broken.join("\n") + "\n").unwrap();
    let e = fails(&[
        "fit",
        text(&path),
        "--scalar",
        "mag_1_uc",
        "--vector",
        "flux_a",
        "--line",
        "4",
    ]);
    let file_line = index + 1;
    assert!(
        e.contains(&format!(
            "broken.csv: line {file_line}, column \"mag_1_uc\": \"oops\" is not a number"
        )),
        "{e}"
    );
}
