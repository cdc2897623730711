//! Outputs onto things that are not regular files: a named pipe is written into, not replaced
//! by a regular file (issue 46, item 20).

use crate::common;

use crate::common::run_in;
use tempfile::TempDir;

#[cfg(unix)]
#[test]
fn compensate_writes_into_a_named_pipe_and_leaves_it_a_pipe() {
    use std::os::unix::fs::FileTypeExt;
    let dir = TempDir::new().unwrap();
    let fifo = dir.path().join("out.csv");
    let made = std::process::Command::new("mkfifo").arg(&fifo).status();
    if !made.is_ok_and(|s| s.success()) {
        eprintln!("no mkfifo: skipped");
        return;
    }
    run_in(
        dir.path(),
        &["simulate", "--plan", "box", "--out", "cal.csv"],
    );
    let fit = [
        "fit", "cal.csv", "--scalar", "mag_1_uc", "--vector", "flux_a", "--out", "m.json",
    ];
    run_in(dir.path(), &fit);
    let reader = {
        let fifo = fifo.clone();
        std::thread::spawn(move || std::fs::read_to_string(fifo).unwrap())
    };
    let args = [
        "compensate",
        "cal.csv",
        "--model",
        "m.json",
        "--out",
        "out.csv",
    ];
    run_in(dir.path(), &args);
    let through = reader.join().unwrap();
    assert!(through.lines().next().unwrap().contains("mag_1_c"));
    assert_eq!(through.lines().count(), 1 + 4661);
    assert!(std::fs::metadata(&fifo).unwrap().file_type().is_fifo());
}

/// Runs `tolles ARGS` in `dir` under `sh` with standard error closed; returns the exit code.
#[cfg(unix)]
fn with_stderr_closed(dir: &std::path::Path, args: &[&str]) -> i32 {
    let binary = assert_cmd::cargo::cargo_bin("tolles");
    let status = std::process::Command::new("sh")
        .current_dir(dir)
        .arg("-c")
        .arg("\"$0\" \"$@\" 2>&-")
        .arg(binary)
        .args(args)
        .status()
        .unwrap();
    status.code().unwrap_or(-1)
}

#[cfg(unix)]
#[test]
fn a_closed_standard_error_costs_neither_the_model_nor_the_output() {
    let dir = TempDir::new().unwrap();
    run_in(
        dir.path(),
        &["simulate", "--plan", "box", "--out", "cal.csv"],
    );
    let fit = [
        "fit", "cal.csv", "--scalar", "mag_1_uc", "--vector", "flux_a", "--out", "m.json",
    ];
    assert_eq!(with_stderr_closed(dir.path(), &fit), 0);
    assert!(dir.path().join("m.json").exists());
    let convert = ["convert", "cal.csv", "cal.parquet"];
    assert_eq!(with_stderr_closed(dir.path(), &convert), 0);
    assert!(dir.path().join("cal.parquet").exists());
    let report = ["report", "cal.csv", "--model", "m.json", "--out", "r"];
    assert_eq!(with_stderr_closed(dir.path(), &report), 0);
    assert!(dir.path().join("r/index.html").exists());
}

#[test]
fn an_extra_channel_must_vary_and_be_a_channel_of_its_own() {
    let dir = TempDir::new().unwrap();
    run_in(
        dir.path(),
        &["simulate", "--plan", "box", "--out", "cal.csv"],
    );
    let csv = std::fs::read_to_string(dir.path().join("cal.csv")).unwrap();
    let with_constant: String = csv
        .lines()
        .enumerate()
        .map(|(k, l)| format!("{l},{}\n", if k == 0 { "cur_idle" } else { "1.5" }))
        .collect();
    std::fs::write(dir.path().join("idle.csv"), with_constant).unwrap();
    let fails = |file: &str, extra: &str| {
        let out = common::tolles()
            .current_dir(dir.path())
            .args([
                "fit", file, "--scalar", "mag_1_uc", "--vector", "flux_a", "--extra", extra,
            ])
            .output()
            .unwrap();
        assert!(!out.status.success(), "{extra} was accepted");
        String::from_utf8_lossy(&out.stderr).to_string()
    };
    assert!(fails("idle.csv", "cur_idle").contains("constant"));
    assert!(fails("cal.csv", "mag_1_uc").contains("already uses as a scalar"));
    assert!(fails("cal.csv", "FLUX_A_X").contains("a fluxgate component"));
}

/// Every file a report writes under `dir`, with its bytes, but the temporary ones.
fn report_files(dir: &std::path::Path) -> std::collections::BTreeMap<String, Vec<u8>> {
    let mut files = std::collections::BTreeMap::new();
    for sub in ["", "plots", "data"] {
        let Ok(entries) = std::fs::read_dir(dir.join(sub)) else {
            continue;
        };
        for entry in entries.flatten() {
            if entry.path().is_file() {
                let name = format!("{sub}/{}", entry.file_name().to_string_lossy());
                files.insert(name, std::fs::read(entry.path()).unwrap());
            }
        }
    }
    files
}

/// A report that fails part-way (issue 46, item 27: a full disk; here the assets directory,
/// written after the plots and data, cannot be made) leaves the previous report whole: its
/// page, plots and the data its page loads, and no temporary files.
#[test]
fn a_report_that_fails_part_way_leaves_the_previous_one_whole() {
    let dir = TempDir::new().unwrap();
    for seed in ["1", "2"] {
        let sim = [
            "simulate",
            "--plan",
            "box",
            "--seed",
            seed,
            "--out",
            &format!("b{seed}.csv"),
        ];
        run_in(dir.path(), &sim);
    }
    let report = |flight: &str| {
        let args = ["report", flight, "--scalar", "mag_1_uc", "--out", "r"];
        common::tolles()
            .current_dir(dir.path())
            .args(args)
            .output()
            .unwrap()
    };
    assert!(report("b1.csv").status.success());
    let before = report_files(&dir.path().join("r"));
    assert!(
        before.keys().any(|k| k.starts_with("data/")),
        "{:?}",
        before.keys()
    );
    std::fs::remove_dir_all(dir.path().join("r/assets")).unwrap();
    std::fs::write(dir.path().join("r/assets"), "in the way").unwrap();
    let failed = report("b2.csv");
    let stderr = String::from_utf8_lossy(&failed.stderr);
    assert!(
        !failed.status.success() && stderr.contains("assets"),
        "{stderr}"
    );
    let mut after = report_files(&dir.path().join("r"));
    after.remove("/assets");
    assert_eq!(
        before.keys().collect::<Vec<_>>(),
        after.keys().collect::<Vec<_>>()
    );
    assert!(before == after, "a file of the old report was replaced");
}
