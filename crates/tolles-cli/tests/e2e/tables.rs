//! `tolles tables` end to end.

use assert_cmd::Command;
use serde_json::Value;

fn tables(args: &[&str]) -> std::process::Output {
    Command::cargo_bin("tolles")
        .unwrap()
        .arg("tables")
        .args(args)
        .output()
        .unwrap()
}

fn json(args: &[&str]) -> Value {
    let mut all = vec!["--json"];
    all.extend_from_slice(args);
    let out = tables(&all);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).unwrap()
}

fn row<'a>(table: &'a Value, name: &str) -> &'a Value {
    table["rows"]
        .as_array()
        .unwrap()
        .iter()
        .find(|r| r["name"] == name)
        .unwrap_or_else(|| panic!("no row {name}"))
}

fn num(v: &Value, key: &str) -> f64 {
    v[key].as_f64().unwrap()
}

#[test]
fn json_roll_table_gives_the_patents_t_row() {
    let doc = json(&[
        "--maneuver",
        "roll",
        "--amplitude",
        "10",
        "--heading",
        "90",
        "--dip",
        "60",
    ]);
    let tables = doc["tables"].as_array().unwrap();
    assert_eq!(tables.len(), 1);
    assert_eq!(tables[0]["maneuver"], "roll");
    let (b, dip) = (10f64.to_radians(), 60f64.to_radians());
    let t = row(&tables[0], "T");
    assert!((num(t, "closed_fundamental") - b * dip.sin()).abs() < 1e-12);
    assert!((num(t, "fundamental") - b * dip.sin()).abs() < b.powi(3));
    // Heading east is the patent's θp = −90°: second harmonic b²/4 cos φ sin θp < 0.
    assert!((num(t, "closed_second_harmonic") + b * b / 4.0 * dip.cos()).abs() < 1e-12);
    assert_eq!(t["printed"]["status"], "printed");
    assert_eq!(row(&tables[0], "L")["printed"]["status"], "not_printed");
}

#[test]
fn json_marks_the_misprinted_rows() {
    let doc = json(&["--heading", "30"]);
    let tables = doc["tables"].as_array().unwrap();
    assert_eq!(tables.len(), 2);
    let misprinted: Vec<(String, String)> = tables
        .iter()
        .flat_map(|t| {
            let rows = t["rows"].as_array().unwrap().iter();
            rows.filter(|r| r["printed"]["status"] == "misprint")
                .map(move |r| {
                    (
                        t["maneuver"].as_str().unwrap().to_string(),
                        format!("{} printed {}", r["name"], r["printed"]["printed_name"]),
                    )
                })
        })
        .collect();
    let expected = [
        ("roll", "\"TL+LT\" printed \"TL+LT\""),
        ("pitch", "\"vv-ll\" printed \"vv-tl\""),
        ("pitch", "\"lt\" printed \"tl\""),
    ]
    .map(|(a, b)| (a.to_string(), b.to_string()));
    assert_eq!(misprinted, expected);
    // The pitch row printed as 'tl' is lt: non-zero, while tl itself is zero in a pitch.
    let pitch = &tables[1];
    assert!(num(row(pitch, "lt"), "fundamental").abs() > 0.01);
    assert!(num(row(pitch, "tl"), "fundamental").abs() < 1e-12);
}

#[test]
fn text_output_shows_computed_and_patent_columns_and_footnotes() {
    let out = tables(&[
        "--maneuver",
        "pitch",
        "--amplitude",
        "5",
        "--heading",
        "-45",
    ]);
    assert!(out.status.success());
    let text = String::from_utf8(out.stdout).unwrap();
    assert!(text.contains("Pitches: pitch (nose up) = a·sin ωt, a = 5°, heading -45°"));
    assert!(text.contains("computed") && text.contains("patent"));
    assert!(text.contains("MISPRINT [2]"));
    assert!(text.contains("lt (printed 'tl')"));
    assert!(!text.contains("Rolls"));
}

#[test]
fn out_of_range_input_is_a_one_line_error() {
    for (flag, value) in [("--dip", "95"), ("--amplitude", "0"), ("--heading", "nan")] {
        let out = tables(&[flag, value]);
        assert!(!out.status.success(), "{flag} {value}");
        let err = String::from_utf8(out.stderr).unwrap();
        assert!(
            err.starts_with("error: ") && err.trim_end().lines().count() == 1,
            "{err}"
        );
    }
}

#[test]
fn help_has_a_worked_example() {
    let out = tables(&["--help"]);
    let text = String::from_utf8(out.stdout).unwrap();
    assert!(text.contains("tolles tables --amplitude 15 --heading 0 --inclination 68"));
}
