//! `fit --network` through the binary (issue 48): a network kept for a field no linear term
//! holds, applied by `compensate` whole and in bounded memory with the same bytes, refused by
//! `stream` (which cannot apply it yet), and a hand-damaged network a one-line error.

use crate::common;

use crate::common::{run_in, tolles};
use std::path::Path;
use tempfile::TempDir;

/// `name.csv` simulated as `args`, with `3 nT · tanh(4 B̂x)` added to `mag_1_uc` (a saturating
/// field no Tolles-Lawson term holds) and a reference `mag_ref`: the field without the
/// aircraft.
fn flight_with_effect(dir: &Path, name: &str, args: &[&str]) {
    let out = format!("{name}.csv");
    run_in(dir, &[&["simulate"][..], args, &["--out", &out]].concat());
    let text = std::fs::read_to_string(dir.join(&out)).unwrap();
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let at = |name: &str| header.iter().position(|h| *h == name).unwrap();
    let (scalar, x, y, z) = (
        at("mag_1_uc"),
        at("flux_a_x"),
        at("flux_a_y"),
        at("flux_a_z"),
    );
    let truth = [at("truth_earth"), at("truth_anomaly"), at("truth_diurnal")];
    let mut written = format!("{},mag_ref\n", header.join(","));
    for line in lines {
        let mut cells: Vec<String> = line.split(',').map(str::to_string).collect();
        let value = |k: usize| cells[k].parse::<f64>().unwrap();
        let b = [value(x), value(y), value(z)];
        let cos_x = b[0] / (b[0] * b[0] + b[1] * b[1] + b[2] * b[2]).sqrt();
        let reference: f64 = truth.iter().map(|&k| value(k)).sum();
        cells[scalar] = format!("{}", value(scalar) + 3.0 * (4.0 * cos_x).tanh());
        written += &format!("{},{reference}\n", cells.join(","));
    }
    std::fs::write(dir.join(&out), written).unwrap();
}

#[test]
fn a_kept_network_is_applied_whole_and_in_chunks_and_refused_where_it_cannot_be() {
    let dir = TempDir::new().unwrap();
    let d = dir.path();
    flight_with_effect(
        d,
        "cal",
        &["--plan", "box", "--preset", "tail-stinger", "--seed", "3"],
    );
    flight_with_effect(
        d,
        "survey",
        &[
            "--plan",
            "survey",
            "--preset",
            "tail-stinger",
            "--seed",
            "3",
            "--lines",
            "2",
        ],
    );
    let fit = [
        "fit",
        "cal.csv",
        "--scalar",
        "mag_1_uc",
        "--vector",
        "flux_a",
        "--reference",
        "mag_ref",
    ];
    let (_, said) = run_in(
        d,
        &[
            &fit[..],
            &[
                "--network",
                "--inputs",
                "ins_roll",
                "--network-seed",
                "7",
                "--out",
                "net.json",
            ],
        ]
        .concat(),
    );
    assert!(
        said.contains("network (5 inputs, layers 8, swish, seed 7)"),
        "{said}"
    );
    assert!(said.contains("kept"), "{said}");
    let model = std::fs::read_to_string(d.join("net.json")).unwrap();
    assert!(
        model.contains("\"flux_a:cos_x\""),
        "the network's inputs are named"
    );

    let compensate = ["compensate", "survey.csv", "--model", "net.json", "--out"];
    run_in(d, &[&compensate[..], &["whole.csv"]].concat());
    let chunked = tolles()
        .current_dir(d)
        .env("TOLLES_MEMORY", "bounded")
        .env("TOLLES_CHUNK_ROWS", "333")
        .args([&compensate[..], &["chunked.csv"]].concat())
        .output()
        .unwrap();
    assert!(chunked.status.success());
    let (whole, chunked) = (
        std::fs::read(d.join("whole.csv")).unwrap(),
        std::fs::read(d.join("chunked.csv")).unwrap(),
    );
    assert!(whole == chunked, "whole and bounded compensation differ");
    the_report_shows_the_network_s_share(d);

    stream_equals_batch(d, "survey.csv", "net.json");
    let said = one_line_failure(d, &["stream", "--model", "net.json", "--adapt"]);
    assert!(said.contains("holds a network"), "{said}");
    let damaged = model.replacen("\"inputs\": 5", "\"inputs\": 6", 1);
    assert_ne!(damaged, model);
    std::fs::write(d.join("damaged.json"), damaged).unwrap();
    let compensate = [
        "compensate",
        "survey.csv",
        "--model",
        "damaged.json",
        "--out",
        "x.csv",
    ];
    let said = one_line_failure(d, &compensate);
    assert!(said.contains("network"), "{said}");
    assert!(!d.join("x.csv").exists());
}

/// The report of the survey with `net.json` says how much the network corrects, and that is
/// about the `3 nT · tanh(4 B̂x)` the survey holds beyond the linear model.
fn the_report_shows_the_network_s_share(d: &Path) {
    run_in(
        d,
        &[
            "report",
            "survey.csv",
            "--model",
            "net.json",
            "--out",
            "rep",
        ],
    );
    let html = std::fs::read_to_string(d.join("rep/index.html")).unwrap();
    assert!(html.contains("A network (8 hidden units, swish, 5 inputs)"));
    // The fit's diagnostics quote what the model as applied leaves, beside the linear model's.
    assert!(html.contains("expected held-out residual, linear model alone"));
    assert!(html.contains("held-out residual with the network"));
    // On the first screen, among the summary's tiles, before any section.
    let tile = html
        .find("network share of the correction")
        .expect("a network tile");
    assert!(
        tile < html.find("<h2").unwrap_or(usize::MAX),
        "the tile is below a section"
    );
    let said = html
        .split("part varies by ")
        .nth(1)
        .expect("the network's share");
    let network_std: f64 = said.split(' ').next().unwrap().parse().unwrap();
    let csv = std::fs::read_to_string(d.join("survey.csv")).unwrap();
    let flux = ["flux_a_x", "flux_a_y", "flux_a_z"].map(|c| common::column(&csv, c));
    let effect: Vec<f64> = (0..flux[0].len())
        .map(|k| {
            let b = flux.each_ref().map(|c| c[k].unwrap());
            3.0 * (4.0 * b[0] / b.iter().map(|v| v * v).sum::<f64>().sqrt()).tanh()
        })
        .collect();
    let effect_std = common::std(&effect);
    println!("the network's part: {network_std} nT; the effect: {effect_std:.4} nT");
    assert!((network_std / effect_std - 1.0).abs() < 0.3);
}

/// `stream` of `survey` with `model` gives, line by line, what `compensate --level model`
/// gives (to 1e-9 nT): the network included, in both.
fn stream_equals_batch(dir: &Path, survey: &str, model: &str) {
    let batch = [
        "compensate",
        survey,
        "--model",
        model,
        "--level",
        "model",
        "--out",
        "batch.csv",
    ];
    run_in(dir, &batch);
    let batch = std::fs::read_to_string(dir.join("batch.csv")).unwrap();
    let input = std::fs::read_to_string(dir.join(survey)).unwrap();
    let out = tolles()
        .current_dir(dir)
        .args(["stream", "--model", model])
        .write_stdin(input)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let streamed = String::from_utf8(out.stdout).unwrap();
    let (batch, streamed) = (
        common::column(&batch, "mag_1_c"),
        common::column(&streamed, "mag_1_c"),
    );
    assert_eq!(batch.len(), streamed.len());
    let mut compared = 0;
    for (row, (b, s)) in batch.iter().zip(&streamed).enumerate() {
        match (b, s) {
            (Some(b), Some(s)) => {
                assert!((b - s).abs() < 1e-9, "row {row}: batch {b}, stream {s}");
                compared += 1;
            }
            (None, None) => {}
            other => panic!("row {row}: {other:?}"),
        }
    }
    assert!(compared > batch.len() / 2, "{compared} rows compared");
}

/// The one line `tolles ARGS` fails with in `dir` (a header on standard input).
fn one_line_failure(dir: &Path, args: &[&str]) -> String {
    let out = tolles()
        .current_dir(dir)
        .args(args)
        .write_stdin("tt,mag_1_uc,flux_a_x,flux_a_y,flux_a_z\n")
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr).trim().to_string();
    assert!(!out.status.success(), "{args:?} succeeded");
    assert_eq!(err.lines().count(), 1, "{err}");
    err
}

#[test]
fn network_flags_need_a_reference() {
    let dir = TempDir::new().unwrap();
    let fit = [
        "fit",
        "cal.csv",
        "--scalar",
        "mag_1_uc",
        "--vector",
        "flux_a",
        "--network",
    ];
    let out = tolles().current_dir(dir.path()).args(fit).output().unwrap();
    let said = String::from_utf8_lossy(&out.stderr);
    assert!(
        !out.status.success() && said.contains("--reference"),
        "{said}"
    );
}

/// Standard deviation (nT) of `mag_1_c − truth_earth` in the compensated `csv`.
fn error_vs_earth(csv: &str) -> f64 {
    let values = common::column(csv, "mag_1_c").into_iter();
    let pairs = values.zip(common::column(csv, "truth_earth"));
    let e: Vec<f64> = pairs.filter_map(|(c, t)| Some(c? - t?)).collect();
    common::std(&e)
}

/// Issue 48's protocol: fitted on two cabin boxes given as two files, compensating another
/// flight (a survey with another seed), the network's error against the linear model's, with the simulated effects
/// (`cur_load`, `pos_flap`, `temp`) and without them.
#[test]
fn on_a_held_out_flight_the_network_beats_the_linear_model_only_where_there_is_something_to_learn()
{
    for effects in [true, false] {
        let dir = TempDir::new().unwrap();
        let d = dir.path();
        let kind: &[&str] = if effects {
            &["--effects", "all"]
        } else {
            &["--reference"]
        };
        let simulate = |plan: &[&str], seed: &str, out: &str| {
            let args = [
                &["simulate", "--preset", "cabin"][..],
                plan,
                kind,
                &["--seed", seed, "--out", out],
            ];
            run_in(d, &args.concat());
        };
        simulate(&["--plan", "box"], "1", "box.csv");
        simulate(&["--plan", "box", "--roll", "15"], "3", "box_15.csv");
        simulate(&["--plan", "survey", "--lines", "3"], "2", "survey.csv");
        // Two calibration flights, fitted together.
        let mut fit = vec![
            "fit",
            "box.csv",
            "box_15.csv",
            "--scalar",
            "mag_1_uc",
            "--vector",
            "flux_a",
            "--reference",
            "mag_ref",
        ];
        if effects {
            fit.extend(["--extra", "cur_load,pos_flap,temp"]);
        }
        run_in(d, &[&fit[..], &["--out", "linear.json"]].concat());
        run_in(
            d,
            &[&fit[..], &["--network", "--out", "network.json"]].concat(),
        );
        let error = |model: &str| {
            let out = format!("{model}.csv");
            run_in(
                d,
                &[
                    "compensate",
                    "survey.csv",
                    "--model",
                    &format!("{model}.json"),
                    "--out",
                    &out,
                ],
            );
            error_vs_earth(&std::fs::read_to_string(d.join(out)).unwrap())
        };
        run_in(
            d,
            &[
                &fit[..],
                &["--network", "--network-joint", "--out", "joint.json"],
            ]
            .concat(),
        );
        let (linear, learned, joint) = (error("linear"), error("network"), error("joint"));
        println!("effects {effects}: held-out flight error linear {linear:.4} nT, with the network {learned:.4} nT (2b), {joint:.4} nT (2c)");
        match effects {
            true => assert!(joint <= 0.5 * linear, "{joint} vs {linear}"),
            false => assert!(joint <= 1.05 * linear, "{joint} vs {linear}"),
        }
        match effects {
            true => assert!(learned <= 0.5 * linear, "{learned} vs {linear}"),
            false => assert!(learned <= 1.05 * linear, "{learned} vs {linear}"),
        }
    }
}
