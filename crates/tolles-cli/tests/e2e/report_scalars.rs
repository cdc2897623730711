//! `tolles report` of several scalars on one page: `--scalar` repeated, or every fit of the model.

use crate::common::tolles;
use std::collections::HashSet;
use std::path::{Path, PathBuf};

/// A simulated box with a second scalar `mag_2_uc` (`mag_1_uc` plus a 0.5 nT wobble) and a
/// model fitted to both; returns (flight, model).
fn box_with_two_scalars(dir: &Path) -> (PathBuf, PathBuf) {
    let one = dir.join("one.csv");
    tolles()
        .arg("simulate")
        .arg("--out")
        .arg(&one)
        .assert()
        .success();
    let text = std::fs::read_to_string(&one).unwrap();
    let mut lines = text.lines();
    let header = lines.next().unwrap();
    let column = header.split(',').position(|h| h == "mag_1_uc").unwrap();
    let mut csv = format!("{header},mag_2_uc\n");
    for (row, line) in lines.enumerate() {
        let value: f64 = line.split(',').nth(column).unwrap().parse().unwrap();
        csv += &format!("{line},{}\n", value + 0.5 * (row as f64 * 0.7).sin());
    }
    let flight = dir.join("two.csv");
    std::fs::write(&flight, csv).unwrap();
    let model = dir.join("m.json");
    tolles()
        .arg("fit")
        .arg(&flight)
        .args([
            "--scalar",
            "mag_1_uc,mag_2_uc",
            "--vector",
            "flux_a",
            "--out",
        ])
        .arg(&model)
        .assert()
        .success();
    (flight, model)
}

/// Runs `tolles report FLIGHT --model MODEL --out OUT ARGS…`; returns the page and the plot
/// files' names.
fn report(flight: &Path, model: &Path, out: &Path, args: &[&str]) -> (String, Vec<String>) {
    tolles()
        .arg("report")
        .arg(flight)
        .arg("--model")
        .arg(model)
        .arg("--out")
        .arg(out)
        .args(args)
        .assert()
        .success();
    let page = std::fs::read_to_string(out.join("index.html")).unwrap();
    let plots = std::fs::read_dir(out.join("plots"))
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().to_string())
        .collect();
    (page, plots)
}

/// The ids of the page's section headings, in order.
fn section_ids(page: &str) -> Vec<&str> {
    page.split("<h2 id=\"")
        .skip(1)
        .map(|rest| &rest[..rest.find('"').unwrap()])
        .collect()
}

/// The part of `page` from the section `id` to the next section.
fn section<'a>(page: &'a str, id: &str) -> &'a str {
    let start = page.find(&format!("<h2 id=\"{id}\"")).unwrap();
    let rest = &page[start + 4..];
    &rest[..rest.find("<h2 ").unwrap_or(rest.len())]
}

fn assert_no_nan_or_inf(page: &str, plots: &[String], out: &Path) {
    let svgs = plots
        .iter()
        .map(|p| std::fs::read_to_string(out.join("plots").join(p)).unwrap());
    for text in std::iter::once(page.to_string()).chain(svgs) {
        for bad in ["NaN", "inf", "∞"] {
            assert!(!text.contains(bad), "{bad} in the report");
        }
    }
}

#[test]
fn two_scalars_share_a_page_with_a_comparison_and_their_own_sections() {
    let dir = tempfile::tempdir().unwrap();
    let (flight, model) = box_with_two_scalars(dir.path());
    let out = dir.path().join("rep");
    let args = ["--scalar", "mag_1_uc", "--scalar", "mag_2_uc"];
    let (page, plots) = report(&flight, &model, &out, &args);

    let compared = section(&page, "scalars-compared");
    let rows: Vec<&str> = compared.split("<tr>").skip(2).collect();
    assert_eq!(rows.len(), 2, "{compared}");
    assert!(rows[0].contains(">mag_1_uc<") && rows[1].contains(">mag_2_uc<"));
    // Both compensated against the truth: the wobble mag_2_uc carries stays in its error.
    assert!(!compared.contains('—'), "{compared}");

    let ids = section_ids(&page);
    let unique: HashSet<&str> = ids.iter().copied().collect();
    assert_eq!(unique.len(), ids.len(), "{ids:?}");
    for scalar in ["mag-1-uc", "mag-2-uc"] {
        for part in ["summary", "signals", "figure-of-merit", "model"] {
            let id = format!("{scalar}-{part}");
            assert!(unique.contains(id.as_str()), "{id} not in {ids:?}");
        }
    }
    let maps: Vec<&String> = plots.iter().filter(|p| p.starts_with("map-")).collect();
    assert_eq!(maps.len(), 4, "{plots:?}");
    for map in maps {
        assert!(
            page.contains(&format!("plots/{map}")),
            "{map} not on the page"
        );
    }
    assert_no_nan_or_inf(&page, &plots, &out);
}

#[test]
fn without_scalar_every_fit_of_the_model_is_reported() {
    let dir = tempfile::tempdir().unwrap();
    let (flight, model) = box_with_two_scalars(dir.path());
    let out = dir.path().join("rep");
    let (page, _) = report(&flight, &model, &out, &[]);
    let ids = section_ids(&page);
    assert_eq!(ids[0], "scalars-compared");
    assert!(ids.contains(&"mag-1-uc-signals") && ids.contains(&"mag-2-uc-signals"));
}

#[test]
fn one_scalar_of_the_model_is_the_page_of_one() {
    let dir = tempfile::tempdir().unwrap();
    let (flight, model) = box_with_two_scalars(dir.path());
    let out = dir.path().join("rep");
    let (page, _) = report(&flight, &model, &out, &["--scalar", "mag_2_uc"]);
    let ids = section_ids(&page);
    assert!(!ids.contains(&"scalars-compared"), "{ids:?}");
    assert!(ids.contains(&"signals"), "{ids:?}");
    assert!(page.contains("Scalar mag_2_uc at"));
}

#[test]
fn an_unknown_scalar_is_a_one_line_error_naming_it() {
    let dir = tempfile::tempdir().unwrap();
    let (flight, model) = box_with_two_scalars(dir.path());
    for with_model in [true, false] {
        let mut command = tolles();
        command.arg("report").arg(&flight);
        if with_model {
            command.arg("--model").arg(&model);
        }
        let done = command
            .args(["--scalar", "mag_1_uc", "--scalar", "mag_9_uc", "--out"])
            .arg(dir.path().join("rep"))
            .output()
            .unwrap();
        assert!(!done.status.success());
        let stderr = String::from_utf8_lossy(&done.stderr);
        assert_eq!(stderr.trim().lines().count(), 1, "{stderr}");
        assert!(stderr.contains("mag_9_uc"), "{stderr}");
        assert!(!dir.path().join("rep/index.html").exists());
    }
}

/// Issue 58: a warning about the file, not a scalar (time stepping back), is printed once for
/// a page of two scalars, not once per scalar.
#[test]
fn a_file_s_warning_is_printed_once_for_two_scalars() {
    let dir = tempfile::tempdir().unwrap();
    let (flight, model) = box_with_two_scalars(dir.path());
    let text = std::fs::read_to_string(&flight).unwrap();
    let mut lines: Vec<String> = text.lines().map(str::to_string).collect();
    let (a, b) = (lines[51].clone(), lines[101].clone());
    let time = |line: &str| line.split(',').next().unwrap().to_string();
    lines[101] = b.replacen(&time(&b), &time(&a), 1);
    let back = dir.path().join("back.csv");
    std::fs::write(&back, lines.join("\n") + "\n").unwrap();
    let done = tolles()
        .arg("report")
        .arg(&back)
        .arg("--model")
        .arg(&model)
        .args(["--scalar", "mag_1_uc,mag_2_uc", "-o"])
        .arg(dir.path().join("rep"))
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&done.stderr);
    assert!(done.status.success(), "{stderr}");
    assert_eq!(stderr.matches("time steps back").count(), 1, "{stderr}");
}
