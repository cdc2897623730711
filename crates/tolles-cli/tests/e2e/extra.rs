//! `fit --extra`: a UAV's motor current as a regressor, end to end.

use crate::common::{column, error_vs_truth_where_computed, run_in, survey_error, tolles};
use std::path::Path;
use tempfile::TempDir;

fn simulate(dir: &Path, plan: &str, seed: &str) {
    tolles()
        .current_dir(dir)
        .args([
            "simulate", "--preset", "uav", "--plan", plan, "--seed", seed, "--out",
        ])
        .arg(format!("{plan}.csv"))
        .assert()
        .success();
}

#[test]
fn a_motor_current_as_an_extra_channel_is_compensated() {
    let dir = TempDir::new().unwrap();
    simulate(dir.path(), "box", "1");
    simulate(dir.path(), "survey", "2");
    let (without, warned) = survey_error(dir.path(), &[]);
    let (with, summary) = survey_error(dir.path(), &["--extra", "cur_1"]);
    eprintln!("UAV survey against the truth: {without:.4} nT without --extra, {with:.4} nT with --extra cur_1");
    assert!(warned.contains("try --extra"), "{warned}");
    assert!(!summary.contains("try --extra"), "{summary}");
    assert!(summary.contains("+cur_1"), "{summary}");
    // A current's coefficients are in nT per ampere, as the channel's name says.
    let row = summary
        .lines()
        .find(|l| l.trim_start().starts_with("cur_1_x"));
    assert!(
        row.is_some_and(|r| r.trim_end().ends_with("nT/A")),
        "{summary}"
    );
    assert!(with < 0.05 && without > 100.0 * with, "{without} -> {with}");
    // The report's coefficient table says the same unit, and the compared models name the
    // extra channel.
    run_in(
        dir.path(),
        &["report", "box.csv", "--model", "m.json", "-o", "rep"],
    );
    let page = std::fs::read_to_string(dir.path().join("rep/index.html")).unwrap();
    assert!(page.contains("<td>cur_1_x</td>"), "no cur_1_x row");
    let row = page.split("<td>cur_1_x</td>").nth(1).unwrap();
    assert!(
        row[..row.find("</tr>").unwrap()].ends_with("<td>nT/A</td>"),
        "{row:.200}"
    );
    assert!(page.contains("+cur_1</td>"));
    let model = std::fs::read_to_string(dir.path().join("m.json")).unwrap();
    assert!(
        model.contains(r#""extras": ["#) && model.contains("cur_1_x"),
        "{model}"
    );
}

#[test]
fn a_fluxgate_lag_is_estimated_stored_and_applied() {
    let dir = TempDir::new().unwrap();
    tolles()
        .current_dir(dir.path())
        .args(["simulate", "--flux-lag", "0.05", "--out", "box.csv"])
        .assert()
        .success();
    let fit = |lag: &str, out: &str| {
        let o = tolles()
            .current_dir(dir.path())
            .args([
                "fit", "box.csv", "--scalar", "mag_1_uc", "--vector", "flux_a", "--lag", lag,
                "--out", out,
            ])
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let model: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(dir.path().join(out)).unwrap()).unwrap();
        model["fits"][0]["lag_s"].as_f64().unwrap_or(0.0)
    };
    let found = fit("auto", "auto.json");
    eprintln!("simulated lag 0.05 s, found {found:.4} s");
    assert!((found - 0.05).abs() * 10.0 < 0.1, "{found}");
    assert_eq!(fit("-0.02", "given.json"), -0.02);
    // Compensation reads the fluxgate that much later: better than ignoring the lag.
    let error = |model: &str| {
        tolles()
            .current_dir(dir.path())
            .args(["compensate", "box.csv", "--model", model, "--out", "c.csv"])
            .assert()
            .success();
        let csv = std::fs::read_to_string(dir.path().join("c.csv")).unwrap();
        error_vs_truth_where_computed(&csv, "mag_1_c")
    };
    fit("none", "none.json");
    let (with, without) = (error("auto.json"), error("none.json"));
    eprintln!("box against the truth: {without:.4} nT ignoring the lag, {with:.4} nT with it");
    assert!(with < without, "{with} vs {without}");
}

/// `stream` of `survey` with the model `m.json` equals `compensate` up to a constant (the
/// level) to 1e-9 nT on every row both compute, and both compute the same rows, but for a few
/// at the ends (the stream's level restarts nothing, but a lag leaves the ends without value).
fn stream_equals_batch(dir: &Path, survey: &str) {
    let batch = tolles()
        .current_dir(dir)
        .args(["compensate", survey, "--model", "m.json"])
        .output()
        .unwrap();
    assert!(
        batch.status.success(),
        "{}",
        String::from_utf8_lossy(&batch.stderr)
    );
    let input = std::fs::read_to_string(dir.join(survey)).unwrap();
    let out = tolles()
        .current_dir(dir)
        .args(["stream", "--model", "m.json"])
        .write_stdin(input.clone())
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let (batch, stream) = (
        String::from_utf8(batch.stdout).unwrap(),
        String::from_utf8(out.stdout).unwrap(),
    );
    assert_eq!(
        stream.lines().count(),
        input.lines().count(),
        "one line out per line in"
    );
    let b = column(&batch, "mag_1_c");
    let s: Vec<Option<f64>> = stream
        .lines()
        .skip(1)
        .map(|l| l.rsplit(',').nth(1).unwrap().parse().ok())
        .collect();
    assert_eq!(b.len(), s.len());
    let n = b.len();
    let offset = b[n / 2].unwrap() - s[n / 2].unwrap();
    let mut compared = 0;
    // At the ends a run starts or ends: a one-sided derivative, a lag without samples.
    for k in 5..n - 5 {
        match (b[k], s[k]) {
            (Some(b), Some(s)) => {
                assert!(
                    (b - s - offset).abs() < 1e-9,
                    "row {k}: batch {b}, stream {s}"
                );
                compared += 1;
            }
            other => panic!("row {k} of {n}: {other:?}"),
        }
    }
    assert!(compared + 20 > n, "{compared} of {n} rows compared");
}

#[test]
fn conditioned_extra_channels_are_stored_and_streamed_as_compensated() {
    let dir = TempDir::new().unwrap();
    simulate(dir.path(), "box", "1");
    simulate(dir.path(), "survey", "2");
    let spec = "cur_1:lowpass=0.5:lag=-0.15";
    survey_error(dir.path(), &["--extra", spec, "--lambda", "0.001"]);
    let model = std::fs::read_to_string(dir.path().join("m.json")).unwrap();
    assert!(
        model.contains(r#""lowpass_hz": 0.5"#) && model.contains(r#""lag_s": -0.15"#),
        "{model}"
    );
    stream_equals_batch(dir.path(), "survey.csv");
    // A bad option is a one-line error naming it.
    let out = tolles()
        .current_dir(dir.path())
        .args([
            "fit",
            "box.csv",
            "--scalar",
            "mag_1_uc",
            "--vector",
            "flux_a",
            "--extra",
            "cur_1:lowpas=1",
        ])
        .output()
        .unwrap();
    let stderr = String::from_utf8(out.stderr).unwrap();
    assert!(
        !out.status.success() && stderr.contains("lowpas") && stderr.trim().lines().count() == 1,
        "{stderr}"
    );
}

#[test]
fn a_model_with_a_fluxgate_lag_streams_as_compensated() {
    let dir = TempDir::new().unwrap();
    simulate(dir.path(), "box", "1");
    simulate(dir.path(), "survey", "2");
    survey_error(dir.path(), &["--lag", "0.13", "--extra", "cur_1:lag=0.3"]);
    let model = std::fs::read_to_string(dir.path().join("m.json")).unwrap();
    assert!(model.contains(r#""lag_s": 0.13"#), "{model}");
    stream_equals_batch(dir.path(), "survey.csv");
    // The first lines wait on cur_1's lag: said so, not "nan in cur_1" (issue 46, item 29).
    let input = std::fs::read_to_string(dir.path().join("survey.csv")).unwrap();
    let out = tolles()
        .current_dir(dir.path())
        .args(["stream", "--model", "m.json"])
        .write_stdin(input)
        .output()
        .unwrap();
    let text = String::from_utf8(out.stdout).unwrap();
    let first = text.lines().nth(1).unwrap();
    assert!(
        first.contains("cur_1 not yet conditioned") && !first.contains("nan in cur_1"),
        "{first}"
    );
}

/// A hostile channel's cell at row `k` of `n`.
type Cell = fn(usize, usize) -> String;

/// A box with the effects' channels (`cur_load`, `pos_flap`, `temp`) but not their field, and
/// hostile extra channels appended: `(name, value at row k of n)`.
fn useless_extras_box(dir: &Path) -> usize {
    tolles()
        .current_dir(dir)
        .args([
            "simulate",
            "--preset",
            "cabin",
            "--plan",
            "box",
            "--seed",
            "1",
            "--effects",
            "all",
            "--out",
            "effects.csv",
        ])
        .assert()
        .success();
    let csv = std::fs::read_to_string(dir.join("effects.csv")).unwrap();
    let mut lines = csv.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let at = |name: &str| header.iter().position(|h| *h == name).unwrap();
    let (scalar, effects) = (at("mag_1_uc"), at("truth_effects"));
    let rows: Vec<Vec<String>> = lines
        .map(|l| l.split(',').map(str::to_string).collect())
        .collect();
    let n = rows.len();
    let hostile: [(&str, Cell); 7] = [
        ("x_noise", |k, _| {
            format!("{}", ((k * 7919) % 1000) as f64 / 1000.0 - 0.5)
        }),
        ("x_spike", |k, _| {
            if k % 1000 == 0 {
                "1".into()
            } else {
                "0".into()
            }
        }),
        (
            "x_step",
            |k, n| if k > n / 2 { "5".into() } else { "0".into() },
        ),
        ("x_huge", |k, _| {
            format!("{}", ((k * 104_729) % 997) as f64 * 1e12)
        }),
        ("x_tiny", |k, _| {
            format!("{}", ((k * 104_729) % 997) as f64 * 1e-12)
        }),
        ("x_drift", |k, _| format!("{}", k as f64 * 1e-3)),
        ("x_sparse", |k, _| {
            if k % 7 == 0 {
                format!("{}", k % 5)
            } else {
                String::new()
            }
        }),
    ];
    let mut out = header.join(",");
    for (name, _) in &hostile {
        out += &format!(",{name}");
    }
    out.push('\n');
    for (k, row) in rows.iter().enumerate() {
        let mut row = row.clone();
        // The scalar without the effects' field: the channels then carry nothing of it.
        let value: f64 = row[scalar].parse::<f64>().unwrap() - row[effects].parse::<f64>().unwrap();
        row[scalar] = format!("{value}");
        out += &row.join(",");
        for (_, value) in &hostile {
            out += &format!(",{}", value(k, n));
        }
        out.push('\n');
    }
    std::fs::write(dir.join("box.csv"), out).unwrap();
    n
}

/// Fits `box.csv` with `flags`; the exit status and standard error.
fn fit_box(dir: &Path, flags: &[&str]) -> (bool, String) {
    let out = tolles()
        .current_dir(dir)
        .args([
            "fit", "box.csv", "--scalar", "mag_1_uc", "--vector", "flux_a", "--out", "m.json",
        ])
        .args(flags)
        .output()
        .unwrap();
    (out.status.success(), String::from_utf8(out.stderr).unwrap())
}

#[test]
fn extra_channels_that_carry_nothing_are_dropped_by_name_and_the_model_is_written() {
    let dir = TempDir::new().unwrap();
    let d = dir.path();
    useless_extras_box(d);
    let compensate = |out: &str| {
        let args = ["compensate", "box.csv", "--model", "m.json", "--out", out];
        run_in(d, &args);
    };
    let (ok, stderr) = fit_box(d, &["--extra", "cur_load,pos_flap,temp"]);
    assert!(ok, "{stderr}");
    assert!(
        stderr.contains("dropped --extra cur_load,pos_flap,temp"),
        "{stderr}"
    );
    let model: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(d.join("m.json")).unwrap()).unwrap();
    let fit = &model["fits"][0];
    assert!(fit["settings"]["design"].get("extras").is_none(), "{fit}");
    assert!(
        fit["coverage"].get("extras").is_none(),
        "no range of a dropped channel"
    );
    compensate("c.csv");

    // The network still trains: the dropped channels become its plain inputs.
    let (ok, stderr) = fit_box(
        d,
        &[
            "--extra",
            "cur_load,pos_flap,temp",
            "--reference",
            "mag_ref",
            "--network",
        ],
    );
    assert!(ok, "{stderr}");
    assert!(!stderr.contains("NaN"), "{stderr}");
    compensate("n.csv");
    let linear = error_vs_truth_where_computed(
        &std::fs::read_to_string(d.join("c.csv")).unwrap(),
        "mag_1_c",
    );
    let network = error_vs_truth_where_computed(
        &std::fs::read_to_string(d.join("n.csv")).unwrap(),
        "mag_1_c",
    );
    eprintln!("without the effects: linear {linear:.4} nT, with --network {network:.4} nT");
    assert!(network <= 1.05 * linear, "{network} against {linear}");
}

#[test]
fn each_hostile_extra_channel_fits_or_is_refused_by_name() {
    let dir = TempDir::new().unwrap();
    let d = dir.path();
    useless_extras_box(d);
    for name in [
        "x_noise", "x_spike", "x_step", "x_huge", "x_tiny", "x_drift", "x_sparse",
    ] {
        let (ok, stderr) = fit_box(d, &["--extra", name]);
        let named = stderr.contains(name);
        eprintln!("--extra {name}: {} ", if ok { "fitted" } else { "refused" });
        assert!(ok || named, "{name}: {stderr}");
        assert!(!stderr.contains("cannot be written"), "{name}: {stderr}");
        if ok && stderr.contains("dropped") {
            assert!(named, "{name}: {stderr}");
        }
    }
    // A channel missing on most rows leaves too few: refused, the channel and the fix named.
    let (ok, stderr) = fit_box(d, &["--extra", "x_sparse"]);
    assert!(
        !ok && stderr.contains("--extra x_sparse has a value in only"),
        "{stderr}"
    );
}
