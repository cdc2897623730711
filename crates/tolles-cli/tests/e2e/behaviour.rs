//! The bytes tolles writes, pinned: models, compensated files (whole and in bounded memory),
//! `--json` outputs and conversions of simulated flights and of the real-layout ASEG-GDF2
//! examples, each reduced to a 64-bit FNV-1a digest and compared with
//! `tests/fixtures/behaviour.txt`. A refactoring must leave every line as it is (issue 47).
//!
//! A change of behaviour that is meant rewrites the file:
//! `TOLLES_UPDATE_BEHAVIOUR=1 cargo test -p tolles-cli --test e2e behaviour::`, and the diff of
//! the file goes into the commit with the reason. `TOLLES_BEHAVIOUR_BIN=PATH` runs another build
//! (an older commit's) to check that it writes the same bytes.

use std::path::Path;
use std::process::Command;
use tempfile::TempDir;

const DIGESTS: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/fixtures/behaviour.txt");

/// The binary under test: this build's, or `TOLLES_BEHAVIOUR_BIN`.
fn tolles() -> Command {
    match std::env::var_os("TOLLES_BEHAVIOUR_BIN") {
        Some(bin) => Command::new(bin),
        None => Command::new(env!("CARGO_BIN_EXE_tolles")),
    }
}

/// Runs `args` in `dir` with `env` set; its standard output.
fn run(dir: &Path, env: &[(&str, &str)], args: &[&str]) -> Vec<u8> {
    let out = tolles()
        .current_dir(dir)
        .envs(env.iter().copied())
        .args(args)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "tolles {}: {err}", args.join(" "));
    out.stdout
}

/// 64-bit FNV-1a: enough to tell one output from another, no dependency.
fn digest(bytes: &[u8]) -> String {
    let hash = bytes.iter().fold(0xcbf2_9ce4_8422_2325_u64, |h, b| {
        (h ^ u64::from(*b)).wrapping_mul(0x0100_0000_01b3)
    });
    format!("{hash:016x}")
}

/// The real-layout example `stem` copied into `dir` (outputs name the file as given); its
/// `.dfn` file name.
fn example(dir: &Path, stem: &str) -> String {
    let examples =
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../tolles-io/tests/fixtures/aseg_gdf2");
    for entry in std::fs::read_dir(&examples).unwrap() {
        let path = entry.unwrap().path();
        if path.file_stem().is_some_and(|s| s == stem) {
            std::fs::copy(&path, dir.join(path.file_name().unwrap())).unwrap();
        }
    }
    format!("{stem}.dfn")
}

/// Every output pinned, as (name, digest).
fn outputs(dir: &Path) -> Vec<(String, String)> {
    let mut pinned = Vec::new();
    let file = |name: &str| {
        let bytes = std::fs::read(dir.join(name)).unwrap();
        (name.to_string(), digest(&bytes))
    };
    let none: &[(&str, &str)] = &[];
    let bounded = [("TOLLES_MEMORY", "bounded"), ("TOLLES_CHUNK_ROWS", "777")];
    let flights = [
        ("box", vec!["--plan", "box", "--preset", "cabin"]),
        (
            "uav",
            vec!["--plan", "box", "--preset", "uav", "--seed", "3"],
        ),
        (
            "survey",
            vec![
                "--plan", "survey", "--preset", "cabin", "--seed", "4", "--lines", "3",
            ],
        ),
        (
            "uav_survey",
            vec![
                "--plan", "survey", "--preset", "uav", "--seed", "5", "--lines", "2",
            ],
        ),
    ];
    for (name, args) in &flights {
        let out = format!("{name}.csv");
        run(
            dir,
            none,
            &[&["simulate"][..], args, &["--out", &out]].concat(),
        );
        pinned.push(file(&out));
    }
    let fits: [(&str, &str, &[&str]); 3] = [
        ("m.json", "box.csv", &[]),
        ("m_lag.json", "box.csv", &["--lag", "0.05"]),
        (
            "m_extra.json",
            "uav.csv",
            &["--extra", "cur_1:lowpass=0.5:lag=0.2"],
        ),
    ];
    for (model, flight, more) in fits {
        let args = [
            "fit", flight, "--scalar", "mag_1_uc", "--vector", "flux_a", "--out", model,
        ];
        run(dir, none, &[&args[..], more].concat());
        pinned.push(file(model));
    }
    let compensations = [
        ("m.json", "survey.csv"),
        ("m_lag.json", "survey.csv"),
        ("m_extra.json", "uav_survey.csv"),
    ];
    for (model, survey) in compensations {
        let stem = model.trim_end_matches(".json");
        for (how, env) in [("whole", none), ("bounded", &bounded[..])] {
            let out = format!("c_{stem}_{how}.csv");
            run(
                dir,
                env,
                &["compensate", survey, "--model", model, "--out", &out],
            );
            pinned.push(file(&out));
        }
    }
    let json = run(
        dir,
        none,
        &["fom", "box.csv", "--model", "m.json", "--json"],
    );
    pinned.push(("fom box --json".into(), digest(&json)));
    for stem in [
        "Example_Mag_HillValley_1985",
        "Example_AeroMag_MuppetTown_2009",
    ] {
        let dfn = example(dir, stem);
        let info = run(dir, none, &["info", &dfn, "--json"]);
        pinned.push((format!("info {stem} --json"), digest(&info)));
        let out = format!("{stem}.csv");
        run(dir, none, &["convert", &dfn, &out]);
        pinned.push(file(&out));
    }
    pinned
}

#[test]
fn outputs_are_the_pinned_bytes() {
    let dir = TempDir::new().unwrap();
    let text: String = outputs(dir.path())
        .iter()
        .map(|(name, digest)| format!("{digest}  {name}\n"))
        .collect();
    if std::env::var_os("TOLLES_UPDATE_BEHAVIOUR").is_some() {
        std::fs::write(DIGESTS, &text).unwrap();
        return;
    }
    let pinned = std::fs::read_to_string(DIGESTS).unwrap();
    let changed: Vec<String> = (text.lines().zip(pinned.lines()))
        .filter(|(now, then)| now != then)
        .map(|(now, then)| format!("now {now}, pinned {then}"))
        .collect();
    assert!(
        changed.is_empty() && text.lines().count() == pinned.lines().count(),
        "outputs changed (see the module documentation):\n{}",
        changed.join("\n")
    );
}
