//! Hostile input (issue 11): absurd cells and parameters give a clear error or an
//! uncomputable row, never a silently corrupt output, a hang or an unusable model.

use crate::common;

use crate::common::tolles;

use std::path::Path;
use tempfile::TempDir;

fn run(dir: &Path, args: &[&str]) -> (bool, String, String) {
    let out = tolles().current_dir(dir).args(args).output().unwrap();
    (
        out.status.success(),
        String::from_utf8(out.stdout).unwrap(),
        String::from_utf8(out.stderr).unwrap(),
    )
}

/// A simulated box flight `box.csv`, its model `m.json`, and `name` = the flight with `column`
/// of data row `row` (1-based after the header) set to `value`.
fn damaged(dir: &Path, name: &str, column: &str, row: usize, value: &str) {
    if !dir.join("m.json").exists() {
        let sim = [
            "simulate", "--plan", "box", "--seed", "1", "--out", "box.csv",
        ];
        assert!(run(dir, &sim).0);
        let fit = [
            "fit", "box.csv", "--scalar", "mag_1_uc", "--vector", "flux_a", "--out", "m.json",
        ];
        assert!(run(dir, &fit).0);
    }
    let text = std::fs::read_to_string(dir.join("box.csv")).unwrap();
    let mut lines: Vec<String> = text.lines().map(str::to_string).collect();
    let k = lines[0].split(',').position(|h| h == column).unwrap();
    let mut cells: Vec<&str> = lines[row].split(',').collect();
    cells[k] = value;
    lines[row] = cells.join(",");
    std::fs::write(dir.join(name), lines.join("\n") + "\n").unwrap();
}

fn fit(dir: &Path, file: &str, extra: &[&str]) -> (bool, String, String) {
    let args = [
        &[
            "fit", file, "--scalar", "mag_1_uc", "--vector", "flux_a", "--out", "out.json",
        ][..],
        extra,
    ]
    .concat();
    run(dir, &args)
}

#[test]
fn an_overflowing_fluxgate_cell_is_an_error_in_compensate_and_fit() {
    let dir = TempDir::new().unwrap();
    damaged(dir.path(), "f.csv", "flux_a_x", 101, "1e155");
    let args = ["compensate", "f.csv", "--model", "m.json", "--out", "o.csv"];
    let (ok, _, err) = run(dir.path(), &args);
    assert!(!ok);
    assert!(err.contains("magnitude 1.000e155 nT is outside"), "{err}");
    assert!(err.contains("line 102"), "{err}");
    let (ok, _, err) = fit(dir.path(), "f.csv", &[]);
    assert!(!ok);
    assert!(err.contains("is outside 1,000–100,000 nT"), "{err}");
    assert_eq!(err.trim().lines().count(), 1, "{err}");
}

#[test]
fn a_scalar_spike_is_skipped_by_fit_and_uncomputable_in_compensate() {
    let dir = TempDir::new().unwrap();
    damaged(dir.path(), "s.csv", "mag_1_uc", 101, "1e300");
    let (ok, _, err) = fit(dir.path(), "s.csv", &["--lambda", "0.001"]);
    assert!(ok, "{err}");
    let model = std::fs::read_to_string(dir.path().join("out.json")).unwrap();
    let model: serde_json::Value = serde_json::from_str(&model).unwrap();
    let coefficients = model["fits"][0]["coefficients"].as_array().unwrap();
    assert!(coefficients.iter().all(|b| b.is_f64()), "{coefficients:?}");
    let args = ["compensate", "s.csv", "--model", "m.json", "--out", "o.csv"];
    let (ok, _, err) = run(dir.path(), &args);
    assert!(ok, "{err}");
    let out = std::fs::read_to_string(dir.path().join("o.csv")).unwrap();
    let compensated = common::column(&out, "mag_1_c");
    assert_eq!(compensated[100], None);
    assert!(compensated.iter().flatten().all(|v| v.abs() < 1e6));
    assert!(err.contains("1 of 4661 rows have no mag_1_c"), "{err}");
}

#[test]
fn an_absurd_lambda_is_refused_at_once() {
    let dir = TempDir::new().unwrap();
    damaged(dir.path(), "f.csv", "flux_a_x", 101, "1e200");
    let (ok, _, err) = fit(dir.path(), "f.csv", &["--lambda", "0.001"]);
    assert!(!ok && err.contains("is outside"), "{err}");
    let (ok, _, err) = fit(dir.path(), "box.csv", &["--lambda", "1e308"]);
    assert!(!ok);
    assert!(err.contains("ridge strength λ = 1e308"), "{err}");
    assert_eq!(err.trim().lines().count(), 1, "{err}");
}

#[test]
fn an_empty_fluxgate_column_or_time_column_is_named_for_what_it_is() {
    let dir = TempDir::new().unwrap();
    damaged(dir.path(), "f.csv", "flux_a_x", 101, "");
    let text = std::fs::read_to_string(dir.path().join("box.csv")).unwrap();
    let blank = |column: usize| -> String {
        let mut lines = text.lines();
        let header = lines.next().unwrap().to_string();
        let rows = lines.map(|l| {
            let mut cells: Vec<&str> = l.split(',').collect();
            cells[column] = "";
            cells.join(",")
        });
        std::iter::once(header)
            .chain(rows)
            .collect::<Vec<_>>()
            .join("\n")
            + "\n"
    };
    std::fs::write(dir.path().join("nox.csv"), blank(10)).unwrap();
    let (ok, _, err) = fit(dir.path(), "nox.csv", &[]);
    assert!(!ok);
    assert!(
        err.contains("column \"flux_a_x\" has no usable value"),
        "{err}"
    );
    std::fs::write(dir.path().join("nott.csv"), blank(0)).unwrap();
    let (ok, _, err) = fit(dir.path(), "nott.csv", &[]);
    assert!(!ok);
    assert!(
        err.contains("time column \"tt\" has no two successive usable times"),
        "{err}"
    );
}

/// `fit` never writes a model the other commands refuse (issue 46, item 23): a NaN or
/// unordered band, and a sample rate no model can be kept at, are one-line errors and leave
/// no model behind.
#[test]
fn fit_refuses_what_would_make_a_model_others_reject() {
    let dir = TempDir::new().unwrap();
    damaged(dir.path(), "f.csv", "flux_a_x", 101, "1e4");
    let cases: [(&[&str], &str); 5] = [
        (
            &["--band", "nan,0.9"],
            "the band's edges must be finite frequencies in Hz",
        ),
        (
            &["--band", "0.1,inf"],
            "the band's edges must be finite frequencies in Hz",
        ),
        (&["--fs", "1e-300"], "a model cannot be fitted at 1e-300 Hz"),
        (&["--fs", "1e7"], "a model cannot be fitted at 1e7 Hz"),
        (&["--fs", "0.0001"], "a model cannot be fitted at 1e-4 Hz"),
    ];
    for (flags, expected) in cases {
        let (ok, _, err) = fit(dir.path(), "box.csv", flags);
        assert!(!ok && err.contains(expected), "{flags:?}: {err}");
        let lines: Vec<&str> = err.lines().filter(|l| l.starts_with("error")).collect();
        assert_eq!(lines.len(), 1, "{flags:?}: {err}");
        assert!(!dir.path().join("out.json").exists(), "{flags:?}");
    }
    // A high-pass (upper edge off) is still a band.
    let (ok, _, err) = fit(dir.path(), "box.csv", &["--band", "0.1,0"]);
    assert!(ok, "{err}");
    let (ok, _, err) = run(
        dir.path(),
        &["compensate", "box.csv", "--model", "out.json"],
    );
    assert!(ok, "{err}");
}

/// Column names HDF5 would read as something else (issue 46, item 26): a '/' (a group path),
/// "." (the group itself), a NUL (the name's end) are one-line errors naming the column, and
/// nothing is written; renamed, the column converts.
#[test]
fn convert_to_hdf5_refuses_names_other_readers_cannot_open() {
    let dir = TempDir::new().unwrap();
    for (header, shown) in [("speed m/s", "speed m/s"), (".", "."), ("a\u{0}b", "a\\0b")] {
        let csv = format!("tt,{header}\n0,1\n0.1,2\n");
        std::fs::write(dir.path().join("n.csv"), csv).unwrap();
        let (ok, _, err) = run(dir.path(), &["convert", "n.csv", "n.h5"]);
        assert!(
            !ok && err.contains(&format!("cannot write column \"{shown}\"")),
            "{err}"
        );
        assert_eq!(err.trim().lines().count(), 1, "{err}");
        assert!(!dir.path().join("n.h5").exists());
    }
    std::fs::write(dir.path().join("s.csv"), "tt,speed m/s\n0,1\n0.1,2\n").unwrap();
    let args = [
        "convert",
        "s.csv",
        "s.h5",
        "--rename",
        "speed m/s=speed_mps",
    ];
    let (ok, _, err) = run(dir.path(), &args);
    assert!(ok, "{err}");
    let (ok, info, err) = run(dir.path(), &["info", "s.h5"]);
    assert!(ok && info.contains("speed_mps"), "{err}");
}

/// An infinite value read from a binary file stays infinite in CSV, signed, as pandas writes
/// it; a missing one stays an empty cell (issue 46, item 27).
#[test]
fn infinities_survive_conversion_to_csv() {
    let dir = TempDir::new().unwrap();
    std::fs::write(
        dir.path().join("i.csv"),
        "tt,v\n0,inf\n1,-inf\n2,\n3,1e400\n",
    )
    .unwrap();
    assert!(run(dir.path(), &["convert", "i.csv", "i.h5"]).0);
    let (ok, _, err) = run(dir.path(), &["convert", "i.h5", "back.csv"]);
    assert!(ok, "{err}");
    let back = std::fs::read_to_string(dir.path().join("back.csv")).unwrap();
    assert_eq!(back, "tt,v\n0,inf\n1,-inf\n2,\n3,inf\n");
}

/// Degenerate references and extras are named for what they are (issue 46, item 29): an
/// all-missing or absurd `--reference` is the reference's fault, not the scalar's; a low-pass
/// corner of 1e-320 Hz is refused at once; a fit with an extra channel counts samples, not
/// rows (it said "9242 of 4661 samples used").
#[test]
fn degenerate_references_and_extras_are_named_for_what_they_are() {
    let dir = TempDir::new().unwrap();
    let sim = [
        "simulate", "--plan", "box", "--preset", "uav", "--out", "uav.csv",
    ];
    assert!(run(dir.path(), &sim).0);
    let text = std::fs::read_to_string(dir.path().join("uav.csv")).unwrap();
    let mut lines = text.lines();
    let mut out = format!("{},ref_nan,ref_big\n", lines.next().unwrap());
    for line in lines {
        out += &format!("{line},,1e300\n");
    }
    std::fs::write(dir.path().join("f.csv"), out).unwrap();
    for column in ["ref_nan", "ref_big"] {
        let (ok, _, err) = fit(dir.path(), "f.csv", &["--reference", column]);
        assert!(
            !ok && err.contains(&format!("column \"{column}\" has no usable value")),
            "{err}"
        );
    }
    let (ok, _, err) = fit(dir.path(), "f.csv", &["--extra", "cur_1:lowpass=1e-320"]);
    assert!(
        !ok && err.contains("lowpass wants a frequency in [1e-6, 1e6] Hz"),
        "{err}"
    );
    let (ok, _, err) = fit(dir.path(), "f.csv", &["--extra", "cur_1"]);
    assert!(ok, "{err}");
    let summary = err.lines().find(|l| l.contains("samples used")).unwrap();
    let numbers: Vec<usize> = summary
        .split_whitespace()
        .filter_map(|w| w.parse().ok())
        .collect();
    assert!(numbers.len() == 2 && numbers[0] <= numbers[1], "{summary}");
}

/// `box.csv` in `dir` with its header's names replaced (`(old, new)`), as `name`.
fn renamed(dir: &Path, name: &str, renames: &[(&str, &str)]) {
    let text = std::fs::read_to_string(dir.join("box.csv")).unwrap();
    let (header, rest) = text.split_once('\n').unwrap();
    let header: Vec<String> = (header.split(','))
        .map(|h| {
            let new = renames
                .iter()
                .find(|(old, _)| *old == h)
                .map(|(_, new)| *new);
            new.unwrap_or(h).to_string()
        })
        .collect();
    std::fs::write(dir.join(name), header.join(",") + "\n" + rest).unwrap();
}

/// Hostile round 4: `-o` is `--out`, and a model or compensated flight is never dumped on a
/// terminal (a pseudo-terminal from util-linux's `script`): the command stops before its work
/// and names `-o`. Piped, it goes to standard output as before.
#[test]
fn the_model_goes_to_o_and_never_to_a_terminal() {
    let dir = TempDir::new().unwrap();
    let d = dir.path();
    damaged(d, "same.csv", "mag_1_uc", 1, "0");
    let base = [
        "fit", "box.csv", "--scalar", "mag_1_uc", "--vector", "flux_a",
    ];
    let (ok, _, err) = run(d, &[&base[..], &["-o", "short.json"]].concat());
    assert!(ok && d.join("short.json").exists(), "{err}");
    let (ok, piped, _) = run(d, &base);
    assert!(
        ok && piped.starts_with('{'),
        "{}",
        &piped[..piped.len().min(80)]
    );
    let binary = assert_cmd::cargo::cargo_bin("tolles");
    for (command, fix) in [
        (
            format!("{} {}", binary.display(), base.join(" ")),
            "-o model.json",
        ),
        (
            format!("{} compensate box.csv --model m.json", binary.display()),
            "-o compensated.csv",
        ),
    ] {
        let out = std::process::Command::new("script")
            .current_dir(d)
            .args(["-qec", &command, "/dev/null"])
            .output()
            .expect("util-linux's script, for a pseudo-terminal");
        let said = String::from_utf8_lossy(&out.stdout);
        assert!(!out.status.success(), "{command}: {said}");
        assert!(
            said.contains("not written to a terminal") && said.contains(fix),
            "{said}"
        );
        assert!(said.lines().count() <= 2, "{said}");
    }
}

#[test]
fn hostile_round_4_messages_say_the_fix() {
    let dir = TempDir::new().unwrap();
    let d = dir.path();
    damaged(d, "same.csv", "mag_1_uc", 1, "0");
    // A model's scalar under another name: the error names the flag that maps it.
    renamed(d, "named.csv", &[("mag_1_uc", "MAG")]);
    let args = [
        "compensate",
        "named.csv",
        "--model",
        "m.json",
        "--out",
        "o.csv",
    ];
    let (ok, _, err) = run(d, &args);
    assert!(!ok && err.lines().count() == 1, "{err}");
    assert!(
        err.contains("did you mean MAG? (if it is, --rename MAG=mag_1_uc)"),
        "{err}"
    );
    // Fluxgate columns without a separator: the spelling that reads them.
    let axes = [
        ("flux_a_x", "FLUXX"),
        ("flux_a_y", "FLUXY"),
        ("flux_a_z", "FLUXZ"),
    ];
    renamed(d, "bare.csv", &axes);
    let (ok, _, err) = fit(d, "bare.csv", &["--vector", "FLUX"]);
    assert!(!ok, "{err}");
    assert!(err.contains("did you mean FLUXX:FLUXY:FLUXZ?"), "{err}");
    let fit_bare = [
        "fit",
        "bare.csv",
        "--scalar",
        "mag_1_uc",
        "--vector",
        "FLUXX:FLUXY:FLUXZ",
        "--out",
        "bare.json",
    ];
    assert!(run(d, &fit_bare).0);
}

#[test]
fn a_band_beyond_nyquist_is_said_and_stored_as_used() {
    let dir = TempDir::new().unwrap();
    let d = dir.path();
    let sim = [
        "simulate", "--plan", "box", "--fs", "1", "--period", "20", "--out", "slow.csv",
    ];
    assert!(run(d, &sim).0);
    let (ok, _, err) = fit(d, "slow.csv", &["--lambda", "auto"]);
    assert!(ok, "{err}");
    assert!(
        err.contains("upper edge 0.9 Hz is at or above the Nyquist frequency 0.5 Hz"),
        "{err}"
    );
    let model: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(d.join("out.json")).unwrap()).unwrap();
    assert_eq!(model["fits"][0]["settings"]["band"]["pass2_hz"], 0.5);
    let (ok, out, err) = run(d, &["fom", "slow.csv", "--scalar", "mag_1_uc"]);
    assert!(ok, "{err}");
    assert!(out.contains("Band-pass 0.05–0.5 Hz"), "{out}");
    assert!(err.contains("upper edge 1 Hz"), "{err}");
}

#[test]
fn tiny_files_and_untimed_plans_say_what_is_missing() {
    let dir = TempDir::new().unwrap();
    let d = dir.path();
    damaged(d, "same.csv", "mag_1_uc", 1, "0");
    let text = std::fs::read_to_string(d.join("box.csv")).unwrap();
    let nine: Vec<&str> = text.lines().take(10).collect();
    std::fs::write(d.join("nine.csv"), nine.join("\n") + "\n").unwrap();
    let (_, out, err) = run(
        d,
        &["fom", "nine.csv", "--scalar", "mag_1_uc", "--fs", "10"],
    );
    assert!(!out.contains("NaN") && !err.contains("NaN"), "{out}{err}");
    // A report of nine rows is a page without spectra, and says why.
    let report = [
        "report", "nine.csv", "--scalar", "mag_1_uc", "--model", "m.json", "--out", "nine",
    ];
    let (ok, _, err) = run(d, &report);
    assert!(ok && d.join("nine/index.html").exists(), "{err}");
    let page = std::fs::read_to_string(d.join("nine/index.html")).unwrap();
    assert!(
        err.contains("no spectrum of the uncompensated scalar"),
        "{err}"
    );
    assert!(page.contains("no spectrum of the uncompensated scalar"));
    // plan reads a flight without tt at --fs, as every other command does.
    std::fs::write(d.join("untimed.csv"), text.replacen("tt,", "t_gps,", 1)).unwrap();
    let plan = ["plan", "untimed.csv", "--vector", "flux_a"];
    let (ok, _, err) = run(d, &plan);
    assert!(!ok && err.contains("give it with --fs"), "{err}");
    let (ok, out, err) = run(d, &[&plan[..], &["--fs", "10"]].concat());
    assert!(ok && out.contains("roll"), "{err}");
}
