//! `tolles compensate` read in chunks (bounded memory) writes exactly what reading the survey
//! whole writes — the same CSV bytes, the same Parquet values, the same warnings and errors — on
//! simulated flights with time gaps, missing and non-finite values and several scalars, however
//! small the chunks.

use crate::common::tolles;

use std::path::{Path, PathBuf};
use tempfile::TempDir;
use tolles_io::table::Table;

fn run_ok(dir: &Path, args: &[&str]) {
    let out = tolles().current_dir(dir).args(args).output().unwrap();
    assert!(
        out.status.success(),
        "{args:?}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
}

/// Runs `tolles ARGS` in `dir` reading whole (`None`) or in chunks of `rows` rows; returns
/// (success, stdout, stderr).
fn compensate(dir: &Path, args: &[&str], rows: Option<usize>) -> (bool, String, String) {
    let mut cmd = tolles();
    cmd.current_dir(dir).arg("compensate").args(args);
    match rows {
        None => cmd.env("TOLLES_MEMORY", "whole"),
        Some(n) => cmd.env("TOLLES_CHUNK_ROWS", n.to_string()),
    };
    let out = cmd.output().unwrap();
    (
        out.status.success(),
        String::from_utf8(out.stdout).unwrap(),
        String::from_utf8(out.stderr).unwrap(),
    )
}

/// Both ways give the same result; returns it.
fn same_both_ways(dir: &Path, args: &[&str]) -> (bool, String, String) {
    let whole = compensate(dir, args, None);
    for rows in [7, 1000, 65536] {
        let chunked = compensate(dir, args, Some(rows));
        assert_eq!(
            chunked.0, whole.0,
            "{args:?} in chunks of {rows}: {}",
            chunked.2
        );
        assert!(
            chunked.1 == whole.1,
            "{args:?} in chunks of {rows}: stdout differs"
        );
        assert_eq!(chunked.2, whole.2, "{args:?} in chunks of {rows}: stderr");
    }
    whole
}

/// The chunked path is the one taken: an invalid chunk size is an error only there.
fn is_chunked(dir: &Path, args: &[&str]) -> bool {
    let out = tolles()
        .current_dir(dir)
        .arg("compensate")
        .args(args)
        .env("TOLLES_CHUNK_ROWS", "0")
        .output()
        .unwrap();
    String::from_utf8_lossy(&out.stderr).contains("TOLLES_CHUNK_ROWS must be")
}

fn set(line: &str, k: usize, value: &str) -> String {
    let mut f: Vec<&str> = line.split(',').collect();
    f[k] = value;
    f.join(",")
}

/// A simulated box flight with a second fluxgate `flux_b` (the first, rotated and scaled), and a
/// model of three fits: mag_1_uc on flux_a, truth_earth on flux_a, mag_1_uc on flux_b (as
/// `mag_b`). Returns the survey's lines: the flight damaged with missing and non-finite values,
/// a time gap, a row without time, a cell with blanks around it and a quoted cell.
fn flight_and_model(dir: &Path) -> Vec<String> {
    run_ok(
        dir,
        &[
            "simulate", "--plan", "box", "--seed", "5", "--out", "cal.csv",
        ],
    );
    let text = std::fs::read_to_string(dir.join("cal.csv")).unwrap();
    let mut lines: Vec<String> = text.lines().map(str::to_string).collect();
    let header: Vec<String> = lines[0].split(',').map(str::to_string).collect();
    let col = |name: &str| header.iter().position(|h| h == name).unwrap();
    let (fx, fy, fz) = (col("flux_a_x"), col("flux_a_y"), col("flux_a_z"));
    lines[0] += ",flux_b_x,flux_b_y,flux_b_z,mag_b";
    for line in lines.iter_mut().skip(1) {
        let f: Vec<f64> = line.split(',').map(|v| v.parse().unwrap()).collect();
        let (x, y, z) = (f[fx], f[fy], f[fz]);
        *line += &format!(
            ",{},{},{},{}",
            1.01 * (0.8 * x - 0.6 * y),
            1.01 * (0.6 * x + 0.8 * y),
            1.01 * z,
            f[col("mag_1_uc")]
        );
    }
    std::fs::write(dir.join("cal2.csv"), lines.join("\n") + "\n").unwrap();
    run_ok(
        dir,
        &[
            "fit",
            "cal2.csv",
            "--scalar",
            "mag_1_uc,truth_earth",
            "--vector",
            "flux_a",
            "--magnitude",
            "exact",
            "--out",
            "a.json",
        ],
    );
    run_ok(
        dir,
        &[
            "fit", "cal2.csv", "--scalar", "mag_b", "--vector", "flux_b", "--out", "b.json",
        ],
    );
    let read = |name: &str| -> serde_json::Value {
        serde_json::from_str(&std::fs::read_to_string(dir.join(name)).unwrap()).unwrap()
    };
    let (mut a, b) = (read("a.json"), read("b.json"));
    // The chunked path must apply exact-magnitude models as the whole-file path does.
    assert_eq!(a["fits"][0]["magnitude"], "exact");
    let more = b["fits"].as_array().unwrap().clone();
    a["fits"].as_array_mut().unwrap().extend(more);
    std::fs::write(dir.join("m.json"), a.to_string()).unwrap();

    let header: Vec<String> = lines[0].split(',').map(str::to_string).collect();
    let col = |name: &str| header.iter().position(|h| h == name).unwrap();
    lines[1 + 100] = set(&lines[1 + 100], col("flux_a_y"), "");
    lines[1 + 150] = set(&lines[1 + 150], col("flux_b_z"), "NaN");
    lines.drain(1 + 300..1 + 310); // a time gap
    lines[1 + 500] = set(&lines[1 + 500], col("mag_1_uc"), "nan");
    lines[1 + 600] = set(&lines[1 + 600], col("mag_b"), "inf");
    lines[1 + 700] = set(&lines[1 + 700], col("tt"), ""); // no time: no gap on either side
    let cell = lines[1 + 800]
        .split(',')
        .nth(col("mag_1_uc"))
        .unwrap()
        .to_string();
    lines[1 + 800] = set(&lines[1 + 800], col("mag_1_uc"), &format!("  {cell} "));
    lines[1 + 900] = set(&lines[1 + 900], col("line"), "\"1\"");
    lines.drain(1 + 2000..1 + 2003); // another gap
    lines[1 + 2000] = set(&lines[1 + 2000], col("flux_a_x"), "");
    lines
}

fn write(dir: &Path, name: &str, lines: &[String]) -> PathBuf {
    let path = dir.join(name);
    std::fs::write(&path, lines.join("\n") + "\n").unwrap();
    path
}

#[test]
fn csv_in_chunks_writes_the_bytes_reading_whole_writes() {
    let dir = TempDir::new().unwrap();
    let lines = flight_and_model(dir.path());
    write(dir.path(), "survey.csv", &lines);
    let args = ["survey.csv", "--model", "m.json"];
    assert!(is_chunked(dir.path(), &args));
    let (ok, csv, stderr) = same_both_ways(dir.path(), &args);
    assert!(ok, "{stderr}");
    let header = csv.lines().next().unwrap();
    assert!(
        header.ends_with(",mag_1_c,truth_earth_c,mag_b_c"),
        "{header}"
    );
    assert_eq!(csv.lines().count(), lines.len());
    // Rows without a result are counted, per fit.
    for (n, column) in [(3, "mag_1_c"), (2, "truth_earth_c"), (2, "mag_b_c")] {
        let text = format!("{n} of {} rows have no {column}", lines.len() - 1);
        assert!(stderr.contains(&text), "{text}: {stderr}");
    }

    // To a CSV file too; and --fs that differs from the time column gives the same warning.
    let to_file = [
        "survey.csv",
        "--model",
        "m.json",
        "--out",
        "out.csv",
        "--fs",
        "10.5",
    ];
    let whole = compensate(dir.path(), &to_file, None);
    let whole_file = std::fs::read(dir.path().join("out.csv")).unwrap();
    let chunked = compensate(dir.path(), &to_file, Some(7));
    assert!(whole.0 && chunked.0, "{}", chunked.2);
    assert_eq!(
        std::fs::read(dir.path().join("out.csv")).unwrap(),
        whole_file
    );
    assert!(chunked.2.contains("--fs 10.5 Hz differs"), "{}", chunked.2);
}

#[test]
fn parquet_in_chunks_gives_the_values_reading_whole_gives() {
    let dir = TempDir::new().unwrap();
    let mut lines = flight_and_model(dir.path());
    let line = lines[1 + 900].replace('"', "");
    lines[1 + 900] = line;
    let survey = write(dir.path(), "survey.csv", &lines);
    let table = Table::read(&survey, None).unwrap();
    let columns: Vec<(String, Vec<f64>)> = table
        .headers()
        .iter()
        .map(|h| (h.clone(), table.numeric(h).unwrap()))
        .collect();
    tolles_io::parquet::write(&dir.path().join("survey.parquet"), &columns).unwrap();

    let to_csv = ["survey.parquet", "--model", "m.json"];
    assert!(is_chunked(dir.path(), &to_csv));
    assert!(same_both_ways(dir.path(), &to_csv).0);

    for (input, out) in [
        ("survey.parquet", "out.parquet"),
        ("survey.csv", "o2.parquet"),
    ] {
        let args = [input, "--model", "m.json", "--out", out];
        assert!(is_chunked(dir.path(), &args));
        assert!(compensate(dir.path(), &args, None).0);
        let whole = Table::read(&dir.path().join(out), None).unwrap();
        assert!(compensate(dir.path(), &args, Some(7)).0);
        let chunked = Table::read(&dir.path().join(out), None).unwrap();
        assert_eq!(chunked.headers(), whole.headers());
        for name in whole.headers() {
            let bits = |t: &Table| -> Vec<u64> {
                t.numeric(name)
                    .unwrap()
                    .iter()
                    .map(|v| v.to_bits())
                    .collect()
            };
            assert_eq!(bits(&chunked), bits(&whole), "{input} → {out}: {name}");
        }
        assert!(whole.numeric("mag_b_c").unwrap()[150].is_nan());
    }
}

#[test]
fn xyz_in_chunks_writes_the_bytes_reading_whole_writes() {
    let dir = TempDir::new().unwrap();
    let lines = flight_and_model(dir.path());
    let header = lines[0].replace(',', " ");
    let mut xyz = vec!["/ simulated".to_string(), format!("/ {header}")];
    for (k, line) in lines[1..].iter().enumerate() {
        if k % 1000 == 0 {
            xyz.push(format!("Line {}", 10 + k / 1000));
        }
        let cells: Vec<&str> = line
            .split(',')
            .map(|c| match c.trim().trim_matches('"') {
                "" => "*",
                c => c,
            })
            .collect();
        xyz.push(cells.join(" "));
    }
    write(dir.path(), "survey.xyz", &xyz);
    let args = ["survey.xyz", "--model", "m.json"];
    assert!(is_chunked(dir.path(), &args));
    let (ok, csv, stderr) = same_both_ways(dir.path(), &args);
    assert!(ok, "{stderr}");
    assert_eq!(csv.lines().count(), lines.len());
}

#[test]
fn bad_input_gives_the_message_reading_whole_gives() {
    let dir = TempDir::new().unwrap();
    let lines = flight_and_model(dir.path());
    let header: Vec<String> = lines[0].split(',').map(str::to_string).collect();
    let col = |name: &str| header.iter().position(|h| h == name).unwrap();
    let damaged = |changes: &[(usize, &str, &str)]| -> Vec<String> {
        let mut l = lines.clone();
        for (row, column, value) in changes {
            l[1 + row] = set(&l[1 + row], col(column), value);
        }
        l
    };
    let mut ragged = lines.clone();
    ragged[1 + 1200] += ",7";
    let cases: Vec<(&str, Vec<String>, &str)> = vec![
        // The scalar's bad cell is reported before the fluxgate's, though it comes later.
        (
            "cell",
            damaged(&[(1100, "mag_1_uc", "x1"), (1000, "flux_a_z", "3e")]),
            "line 1102, column \"mag_1_uc\": \"x1\" is not a number",
        ),
        (
            "second-fit",
            damaged(&[(40, "mag_b", "?"), (1300, "truth_earth", "-")]),
            "column \"truth_earth\"",
        ),
        ("ragged", ragged, "fields, but the header has"),
        (
            "magnitude",
            damaged(&[(1700, "flux_b_x", "1e9"), (1800, "flux_a_x", "1e9")]),
            "fluxgate flux_a magnitude",
        ),
        ("empty", lines[..1].to_vec(), "no data rows"),
    ];
    for (name, lines, expected) in cases {
        let file = format!("{name}.csv");
        write(dir.path(), &file, &lines);
        let (ok, _, stderr) = same_both_ways(dir.path(), &[&file, "--model", "m.json"]);
        let last = stderr.lines().last().unwrap_or("");
        assert!(
            !ok && last.starts_with("error: ") && last.contains(expected),
            "{name}: {stderr}"
        );
        assert_eq!(stderr.matches("error").count(), 1, "{name}: {stderr}");
    }
    // A text column cannot go to Parquet; the first bad cell in file order is named.
    let text = damaged(&[(1000, "lat", "N45"), (10, "lon", "W75")]);
    write(dir.path(), "text.csv", &text);
    let args = ["text.csv", "--model", "m.json", "--out", "t.parquet"];
    let (ok, _, stderr) = same_both_ways(dir.path(), &args);
    assert!(!ok && stderr.contains("column \"lat\""), "{stderr}");
}

/// A file sorted by line: time steps back between stretches, and repeats once inside one.
/// Both ways split the runs there and warn once, naming the first place.
#[test]
fn time_that_steps_back_splits_the_runs_both_ways() {
    let dir = TempDir::new().unwrap();
    let lines = flight_and_model(dir.path());
    let n = lines.len() - 1;
    let mut sorted = vec![lines[0].clone()];
    sorted.extend_from_slice(&lines[1 + n / 2..]);
    sorted.extend_from_slice(&lines[1..1 + n / 2]);
    sorted.insert(1 + n / 4, sorted[n / 4].clone());
    write(dir.path(), "sorted.csv", &sorted);
    let (ok, csv, stderr) = same_both_ways(dir.path(), &["sorted.csv", "--model", "m.json"]);
    assert!(ok, "{stderr}");
    assert_eq!(csv.lines().count(), sorted.len());
    let first = format!("line {}", 2 + n / 4);
    assert!(
        stderr
            .matches("time steps back or repeats at 2 place(s)")
            .count()
            == 1
            && stderr.contains(&first),
        "{stderr}"
    );
    // Each stretch is compensated as its own flight would be.
    write(dir.path(), "first.csv", &lines[..1 + n / 2]);
    let model_level = ["--model", "m.json", "--level", "model"];
    let (_, alone, _) = compensate(
        dir.path(),
        &[&["first.csv"], &model_level[..]].concat(),
        None,
    );
    let (_, all, _) = compensate(
        dir.path(),
        &[&["sorted.csv"], &model_level[..]].concat(),
        None,
    );
    let row = |text: &str, k: usize| text.lines().nth(k).unwrap().to_string();
    // The first half of the flight starts after the second half and one repeated row.
    let moved = 1 + (n - n / 2) + 1;
    for k in [1, 2, 10, n / 2] {
        assert_eq!(row(&all, moved + k - 1), row(&alone, k));
    }
}

/// Time written too coarsely for the rate (10 Hz to 0.036 s, as hours with five decimals
/// give it): both ways take 10 Hz from the mean usual step, not 9.26 Hz from the median.
#[test]
fn a_quantised_clock_gives_its_true_rate_both_ways() {
    let dir = TempDir::new().unwrap();
    let mut lines = flight_and_model(dir.path());
    let header: Vec<String> = lines[0].split(',').map(str::to_string).collect();
    let tt = header.iter().position(|h| h == "tt").unwrap();
    for line in lines.iter_mut().skip(1) {
        if let Ok(t) = line.split(',').nth(tt).unwrap().parse::<f64>() {
            *line = set(line, tt, &format!("{:.3}", (t / 0.036).round() * 0.036));
        }
    }
    write(dir.path(), "coarse.csv", &lines);
    let args = ["coarse.csv", "--model", "m.json", "--fs", "9.26"];
    let (ok, _, stderr) = same_both_ways(dir.path(), &args);
    assert!(ok && stderr.contains("differs from the 10.0"), "{stderr}");
}

#[test]
fn a_survey_written_over_itself_is_read_whole_first() {
    let dir = TempDir::new().unwrap();
    let lines = flight_and_model(dir.path());
    write(dir.path(), "survey.csv", &lines);
    let (_, expected, _) = compensate(dir.path(), &["survey.csv", "--model", "m.json"], None);
    let args = ["survey.csv", "--model", "m.json", "--out", "survey.csv"];
    assert!(compensate(dir.path(), &args, Some(7)).0);
    assert_eq!(
        std::fs::read_to_string(dir.path().join("survey.csv")).unwrap(),
        expected
    );
    assert!(!is_chunked(dir.path(), &args));
}

#[test]
fn a_jittered_clock_takes_more_median_passes_and_still_matches() {
    // 80 000 rows whose time steps are nearly all distinct: the exact median step (sample rate,
    // gap threshold) needs more than one pass in chunks.
    let dir = TempDir::new().unwrap();
    let mut text = String::from("tt,mag,flux_x,flux_y,flux_z\n");
    let mut t = 0.0;
    for k in 0..80_000u64 {
        let jitter = (k.wrapping_mul(2_654_435_761) % 1_000_003) as f64 * 1e-9;
        t += if k % 9_000 == 8_999 {
            0.35
        } else {
            0.1 + jitter
        };
        let a = 0.05 * k as f64;
        let (x, y, z) = (
            20_000.0 + 3_000.0 * a.sin(),
            5_000.0 + 2_000.0 * (0.7 * a).cos(),
            45_000.0 + 1_000.0 * (0.3 * a).sin(),
        );
        let mag = 50_000.0 + 0.001 * x - 0.002 * y + 1e-3 * (0.01 * a).sin();
        text += &format!("{t},{mag},{x},{y},{z}\n");
    }
    std::fs::write(dir.path().join("jitter.csv"), text).unwrap();
    run_ok(
        dir.path(),
        &[
            "fit",
            "jitter.csv",
            "--scalar",
            "mag",
            "--vector",
            "flux",
            "--terms",
            "p,i5,e8",
            "--lambda",
            "0.001",
            "--out",
            "m.json",
        ],
    );
    let args = ["jitter.csv", "--model", "m.json"];
    assert!(is_chunked(dir.path(), &args));
    let (ok, csv, stderr) = same_both_ways(dir.path(), &args);
    assert!(ok, "{stderr}");
    assert_eq!(csv.lines().count(), 80_001);
}

#[test]
fn the_model_level_in_chunks_writes_what_reading_whole_writes() {
    let dir = TempDir::new().unwrap();
    let lines = flight_and_model(dir.path());
    write(dir.path(), "survey.csv", &lines);
    let args = ["survey.csv", "--model", "m.json", "--level", "model"];
    assert!(is_chunked(dir.path(), &args));
    let (ok, csv, stderr) = same_both_ways(dir.path(), &args);
    assert!(ok, "{stderr}");
    let (_, mean, _) = compensate(dir.path(), &args[..3], None);
    assert!(csv != mean, "the model's level is not the file's mean");
    // An error after the checks warns the same way too: a text column cannot go to Parquet.
    let lat = lines[0].split(',').position(|h| h == "lat").unwrap();
    let mut text = lines.clone();
    text[1 + 1000] = set(&text[1 + 1000], lat, "N45");
    write(dir.path(), "text.csv", &text);
    let args = [
        "text.csv",
        "--model",
        "m.json",
        "--level",
        "model",
        "--out",
        "t.parquet",
    ];
    let (ok, _, stderr) = same_both_ways(dir.path(), &args);
    assert!(!ok && stderr.contains("rows have no mag_1_c"), "{stderr}");
}

#[test]
fn an_unknown_memory_policy_is_an_error() {
    let dir = TempDir::new().unwrap();
    let out = tolles()
        .current_dir(dir.path())
        .args(["compensate", "survey.csv", "--model", "m.json"])
        .env("TOLLES_MEMORY", "sometimes")
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success());
    assert!(
        stderr.contains("TOLLES_MEMORY must be auto, bounded or whole, got \"sometimes\""),
        "{stderr}"
    );
}

/// Issue 11 item 14: a survey without any of the model's columns is reported by the column it
/// lacks, in chunks as reading whole does, not as an empty file.
#[test]
fn a_survey_without_the_models_columns_names_the_missing_column() {
    let dir = TempDir::new().unwrap();
    flight_and_model(dir.path());
    std::fs::write(dir.path().join("s.csv"), "a,b\n1,2\n3,4\n").unwrap();
    let args = ["s.csv", "--model", "m.json"];
    assert!(is_chunked(dir.path(), &args));
    let (ok, _, stderr) = same_both_ways(dir.path(), &args);
    assert!(!ok && stderr.contains("no column \"mag_1_uc\""), "{stderr}");
}

/// A survey whose columns answer to the model's names only through SGL's raw channel names or
/// `--rename` is read in chunks, and gives what reading it whole gives.
#[test]
fn raw_channel_names_and_renames_are_read_in_chunks_too() {
    let dir = TempDir::new().unwrap();
    let d = dir.path();
    run_ok(
        d,
        &[
            "simulate", "--plan", "box", "--seed", "3", "--out", "cal.csv",
        ],
    );
    let fit = [
        "fit", "cal.csv", "--scalar", "mag_1_uc", "--vector", "flux_a",
    ];
    run_ok(d, &[&fit[..], &["--out", "m.json"]].concat());
    let text = std::fs::read_to_string(d.join("cal.csv")).unwrap();
    let (header, body) = text.split_once('\n').unwrap();
    let renamed = |names: &[(&str, &str)]| {
        let fields: Vec<&str> = header
            .split(',')
            .map(|h| names.iter().find(|(from, _)| *from == h).map_or(h, |n| n.1))
            .collect();
        format!("{}\n{body}", fields.join(","))
    };
    let sgl = [
        ("tt", "TIME"),
        ("mag_1_uc", "UNCOMPMAG1"),
        ("flux_a_x", "FLUXA_X"),
        ("flux_a_y", "FLUXA_Y"),
        ("flux_a_z", "FLUXA_Z"),
    ];
    std::fs::write(d.join("sgl.csv"), renamed(&sgl)).unwrap();
    std::fs::write(d.join("own.csv"), renamed(&[("mag_1_uc", "MAGUC")])).unwrap();
    let cases: [&[&str]; 2] = [
        &["sgl.csv", "--model", "m.json"],
        &["own.csv", "--model", "m.json", "--rename", "MAGUC=mag_1_uc"],
    ];
    for args in cases {
        assert!(is_chunked(d, args), "{args:?} is read whole");
        let (ok, out, err) = same_both_ways(d, args);
        assert!(ok, "{args:?}: {err}");
        let header = out.lines().next().unwrap();
        assert!(header.ends_with(",mag_1_c"), "{header}");
    }
    let (_, _, err) = same_both_ways(d, &["sgl.csv", "--model", "m.json"]);
    assert!(err.contains("UNCOMPMAG1"), "the aliases are said: {err}");
    let (ok, _, err) = same_both_ways(d, &["own.csv", "--model", "m.json", "--rename", "NOPE=x"]);
    assert!(!ok && err.contains("--rename NOPE=x"), "{err}");
}
