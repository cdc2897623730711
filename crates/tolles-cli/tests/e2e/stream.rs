//! `tolles stream` end to end: the stream equals `tolles compensate` up to one constant, on
//! standard input and over TCP, with one output line for every input line.

use crate::common::tolles;

use std::io::{BufRead, BufReader, Read, Write};
use std::net::{Shutdown, TcpStream};
use std::path::Path;
use std::process::Stdio;
use tempfile::TempDir;

fn run(dir: &Path, args: &[&str]) -> String {
    let out = tolles().current_dir(dir).args(args).output().unwrap();
    assert!(
        out.status.success(),
        "{args:?}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8(out.stdout).unwrap()
}

/// Rows of the survey (0-based, after the header) that `survey` damages, and their statuses.
const DAMAGE: [(usize, &str); 3] = [
    (100, "missing flux_a_y"),
    (300, "time gap 1.100 s"),
    (500, "nan in mag_1_uc"),
];

/// A model fitted to a simulated box, and a survey made from the same flight with a missing
/// fluxgate value, a time gap (rows removed) and a NaN scalar.
fn model_and_survey(dir: &Path) -> String {
    model_and_survey_with(dir, &["--lambda", "0.001"], "cabin")
}

/// [`model_and_survey`] with more `fit` flags and another installation preset.
fn model_and_survey_with(dir: &Path, fit_flags: &[&str], preset: &str) -> String {
    run(
        dir,
        &[
            "simulate", "--plan", "box", "--seed", "3", "--preset", preset, "--out", "cal.csv",
        ],
    );
    let mut fit = vec![
        "fit", "cal.csv", "--scalar", "mag_1_uc", "--vector", "flux_a", "--out", "m.json",
    ];
    fit.extend(fit_flags);
    run(dir, &fit);
    let text = std::fs::read_to_string(dir.join("cal.csv")).unwrap();
    let mut lines: Vec<String> = text.lines().map(str::to_string).collect();
    let header: Vec<&str> = lines[0].split(',').collect();
    let col = |name: &str| header.iter().position(|h| *h == name).unwrap();
    let (fy, mag) = (col("flux_a_y"), col("mag_1_uc"));
    let set = |line: &mut String, k: usize, v: &str| {
        let mut f: Vec<&str> = line.split(',').collect();
        f[k] = v;
        *line = f.join(",");
    };
    set(&mut lines[1 + 100], fy, "");
    lines.drain(1 + 300..1 + 310);
    set(&mut lines[1 + 500], mag, "nan");
    let survey = lines.join("\n") + "\n";
    std::fs::write(dir.join("survey.csv"), &survey).unwrap();
    survey
}

fn last_fields(line: &str, n: usize) -> Vec<String> {
    // The status may be quoted and hold commas; ours here never do.
    line.rsplitn(n + 1, ',')
        .take(n)
        .map(str::to_string)
        .collect::<Vec<_>>()
        .into_iter()
        .rev()
        .collect()
}

/// Checks `stream` output against the batch output and the survey it came from.
fn check_equivalent(survey: &str, batch: &str, stream: &str) {
    let (survey, batch, stream): (Vec<&str>, Vec<&str>, Vec<&str>) = (
        survey.lines().collect(),
        batch.lines().collect(),
        stream.lines().collect(),
    );
    assert_eq!(stream.len(), survey.len(), "one output line per input line");
    assert_eq!(stream[0], format!("{},mag_1_c,status", survey[0]));
    let mut offset = None;
    for k in 1..survey.len() {
        let row = k - 1;
        assert!(
            stream[k].starts_with(&format!("{},", survey[k])),
            "row {row}: input passed through"
        );
        let [value, status]: [String; 2] = last_fields(stream[k], 2).try_into().unwrap();
        let expected = DAMAGE
            .iter()
            .find(|(r, _)| *r == row)
            .map_or("ok", |(_, s)| s);
        assert_eq!(status, expected, "row {row}");
        let batch_value = last_fields(batch[k], 1)[0].parse::<f64>().ok();
        match (value.parse::<f64>().ok(), batch_value) {
            (Some(s), Some(b)) => {
                let d = *offset.get_or_insert(b - s);
                assert!(
                    (b - s - d).abs() < 1e-9,
                    "row {row}: batch {b}, stream {s}, offset {d}"
                );
            }
            (None, None) => assert_ne!(expected, "ok", "row {row}"),
            other => panic!("row {row}: {other:?}"),
        }
    }
}

#[test]
fn stream_on_stdin_equals_batch_up_to_a_constant() {
    let dir = TempDir::new().unwrap();
    let survey = model_and_survey(dir.path());
    let batch = run(
        dir.path(),
        &["compensate", "survey.csv", "--model", "m.json"],
    );
    let out = tolles()
        .current_dir(dir.path())
        .args(["stream", "--model", "m.json"])
        .write_stdin(survey.clone())
        .output()
        .unwrap();
    assert!(out.status.success());
    let stderr = String::from_utf8_lossy(&out.stderr);
    let n = survey.lines().count() - 1;
    assert!(
        stderr.contains(&format!("stream: {n} in, {n} out, 3 flagged")),
        "{stderr}"
    );
    check_equivalent(&survey, &batch, &String::from_utf8(out.stdout).unwrap());
}

/// `stream` on standard input against `compensate` of the same survey with m.json in `dir`.
fn streams_as_batch_compensates(dir: &Path, survey: &str) {
    let batch = run(dir, &["compensate", "survey.csv", "--model", "m.json"]);
    let out = tolles()
        .current_dir(dir)
        .args(["stream", "--model", "m.json"])
        .write_stdin(survey.to_string())
        .output()
        .unwrap();
    assert!(out.status.success());
    check_equivalent(survey, &batch, &String::from_utf8(out.stdout).unwrap());
}

#[test]
fn an_exact_magnitude_model_streams_as_batch_compensates() {
    let dir = TempDir::new().unwrap();
    let survey = model_and_survey_with(dir.path(), &["--magnitude", "exact"], "cabin");
    let model = std::fs::read_to_string(dir.path().join("m.json")).unwrap();
    assert!(model.contains(r#""magnitude": "exact""#));
    streams_as_batch_compensates(dir.path(), &survey);
}

/// The realistic preset's fluxgate reads thousands of nT of the aircraft: the model takes its
/// offset out, and the stream does as batch does.
#[test]
fn a_model_without_the_fluxgate_offset_streams_as_batch_compensates() {
    let dir = TempDir::new().unwrap();
    let survey = model_and_survey_with(dir.path(), &[], "realistic");
    let model: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.path().join("m.json")).unwrap()).unwrap();
    let offset = &model["fits"][0]["flux_offset_nt"];
    assert!(offset[1].as_f64().unwrap().abs() > 1_000.0, "{offset}");
    streams_as_batch_compensates(dir.path(), &survey);
}

#[test]
fn stream_over_tcp_equals_batch_up_to_a_constant_for_each_client() {
    let dir = TempDir::new().unwrap();
    let survey = model_and_survey(dir.path());
    let batch = run(
        dir.path(),
        &["compensate", "survey.csv", "--model", "m.json"],
    );
    let (mut server, address) = listen(dir.path(), &["stream", "--model", "m.json", "--quiet"]);
    let clients: Vec<_> = (0..2)
        .map(|_| {
            let (address, survey) = (address.clone(), survey.clone());
            std::thread::spawn(move || {
                let mut connection = TcpStream::connect(&address).unwrap();
                let mut writer = connection.try_clone().unwrap();
                let sender = std::thread::spawn(move || {
                    writer.write_all(survey.as_bytes()).unwrap();
                    writer.shutdown(Shutdown::Write).unwrap();
                });
                let mut out = String::new();
                connection.read_to_string(&mut out).unwrap();
                sender.join().unwrap();
                out
            })
        })
        .collect();
    let outputs: Vec<String> = clients.into_iter().map(|c| c.join().unwrap()).collect();
    server.kill().unwrap();
    server.wait().unwrap();
    for out in outputs {
        check_equivalent(&survey, &batch, &out);
    }
}

/// A TCP client on `address` that sends `input` (then ends its side) and reads the reply,
/// within 20 s.
fn client(address: &str, input: Vec<u8>) -> std::thread::JoinHandle<String> {
    let connection = TcpStream::connect(address).unwrap();
    connection
        .set_read_timeout(Some(std::time::Duration::from_secs(20)))
        .unwrap();
    std::thread::spawn(move || {
        let mut writer = connection.try_clone().unwrap();
        let sender = std::thread::spawn(move || {
            // The server may close first: what it answered is what counts.
            let _ = writer.write_all(&input);
            let _ = writer.shutdown(Shutdown::Write);
        });
        let mut out = Vec::new();
        let _ = (&connection).read_to_end(&mut out);
        sender.join().unwrap();
        String::from_utf8_lossy(&out).into_owned()
    })
}

/// Issue 11 item 5: a client sending a line over 1 MiB gets an `error:` line and is closed, an
/// idle client is closed after `--idle-timeout`, and another client's stream goes on.
#[test]
fn a_hostile_tcp_client_ends_only_its_own_stream() {
    let dir = TempDir::new().unwrap();
    let survey = model_and_survey(dir.path());
    let header = survey.lines().next().unwrap().to_string();
    let args = [
        "stream",
        "--model",
        "m.json",
        "--quiet",
        "--idle-timeout",
        "1",
    ];
    let (mut server, address) = listen(dir.path(), &args);
    let mut long = format!("{header}\n").into_bytes();
    long.extend(std::iter::repeat_n(b'7', 3 << 20));
    let long = client(&address, long);
    let idle = TcpStream::connect(&address).unwrap();
    idle.set_read_timeout(Some(std::time::Duration::from_secs(20)))
        .unwrap();
    let mut idle_reply = String::new();
    let _ = (&idle).read_to_string(&mut idle_reply);
    let good = client(&address, survey.clone().into_bytes())
        .join()
        .unwrap();
    let long = long.join().unwrap();
    server.kill().unwrap();
    server.wait().unwrap();
    let lines: Vec<&str> = long.lines().collect();
    assert_eq!(lines.len(), 2, "{long:.300}");
    assert_eq!(
        lines[1],
        "error: a line over 1048576 bytes; the stream is closed"
    );
    assert_eq!(
        idle_reply,
        "error: no input for 1 s; the connection is closed\n"
    );
    assert_eq!(good.lines().count(), survey.lines().count(), "{good:.300}");
}

#[test]
fn a_reader_that_goes_away_ends_the_stream_without_a_panic() {
    let dir = TempDir::new().unwrap();
    let survey = model_and_survey(dir.path());
    let mut child = spawned_stream(dir.path(), &["--derivative", "causal"]);
    let mut stdout = BufReader::new(child.stdout.take().unwrap());
    let mut stdin = child.stdin.take().unwrap();
    let mut lines = survey.lines();
    writeln!(stdin, "{}", lines.next().unwrap()).unwrap();
    let mut header = String::new();
    stdout.read_line(&mut header).unwrap();
    assert!(header.trim_end().ends_with(",mag_1_c,status"));
    drop(stdout);
    // The reader is gone; the writer keeps sending until the stream notices.
    for line in lines.cycle().take(200_000) {
        if writeln!(stdin, "{line}").is_err() {
            break;
        }
    }
    drop(stdin);
    let out = child.wait_with_output().unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    assert!(!stderr.contains("panicked"), "{stderr}");
}

#[test]
fn a_model_column_missing_from_the_header_is_a_one_line_error() {
    let dir = TempDir::new().unwrap();
    model_and_survey(dir.path());
    let out = tolles()
        .current_dir(dir.path())
        .args(["stream", "--model", "m.json", "--quiet"])
        .write_stdin("tt,mag_1_uc,flux_a_x,flux_a_z\n1,2,3,4\n")
        .output()
        .unwrap();
    assert!(!out.status.success());
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(
        stderr.trim(),
        "error: stream on standard input: header has no column \"flux_a_y\"; did you mean \
         flux_a_x, flux_a_z?"
    );
}

/// Starts `tolles stream --model m.json --quiet ARGS` in `dir` with its stdin, stdout and
/// stderr piped to the test.
fn spawned_stream(dir: &std::path::Path, args: &[&str]) -> std::process::Child {
    std::process::Command::new(assert_cmd::cargo::cargo_bin("tolles"))
        .current_dir(dir)
        .args(["stream", "--model", "m.json", "--quiet"])
        .args(args)
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap()
}

/// Starts `tolles ARGS --listen 127.0.0.1:0` in `dir`; returns the server and the address it
/// says it listens on (the first line of its stderr).
fn listen(dir: &std::path::Path, args: &[&str]) -> (std::process::Child, String) {
    let mut server = std::process::Command::new(assert_cmd::cargo::cargo_bin("tolles"))
        .current_dir(dir)
        .args(args)
        .args(["--listen", "127.0.0.1:0"])
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut stderr = BufReader::new(server.stderr.take().unwrap());
    let mut first = String::new();
    stderr.read_line(&mut first).unwrap();
    let address = first
        .trim()
        .strip_prefix("listening on ")
        .unwrap_or_else(|| panic!("{first}"))
        .to_string();
    (server, address)
}

/// Runs `tolles stream ARGS` on `input`; returns stdout.
/// Hostile round 4: a row whose extra channel is missing has no value, and the status says
/// which channel; no row with a value says a column is missing.
#[test]
fn a_row_missing_an_extra_channel_has_no_value_and_says_which() {
    let dir = TempDir::new().unwrap();
    let d = dir.path();
    let sim = [
        "simulate",
        "--plan",
        "box",
        "--seed",
        "3",
        "--effects",
        "all",
        "--out",
        "cal.csv",
    ];
    run(d, &sim);
    let fit = [
        "fit", "cal.csv", "--scalar", "mag_1_uc", "--vector", "flux_a", "--extra", "cur_load",
        "-o", "m.json",
    ];
    run(d, &fit);
    let text = std::fs::read_to_string(d.join("cal.csv")).unwrap();
    let mut lines: Vec<String> = text.lines().map(str::to_string).collect();
    let k = lines[0].split(',').position(|h| h == "cur_load").unwrap();
    for line in &mut lines[2000..2003] {
        let mut cells: Vec<&str> = line.split(',').collect();
        cells[k] = "";
        *line = cells.join(",");
    }
    let out = stream_out(d, &["--model", "m.json"], &(lines.join("\n") + "\n"));
    let rows: Vec<Vec<String>> = out.lines().skip(1).map(|l| last_fields(l, 2)).collect();
    assert_eq!(rows.len(), lines.len() - 1);
    for row in 2000..2003 {
        assert_eq!(rows[row - 1], ["", "missing cur_load"], "row {row}");
    }
    let valued_but_missing = rows
        .iter()
        .filter(|r| !r[0].is_empty() && r[1].contains("missing"))
        .count();
    assert_eq!(valued_but_missing, 0, "{:?}", &rows[1990..2010]);
    // Read 0.2 s late (two samples), the first two missing cells do not stop their own rows'
    // values: their status says the cell was not read there, not that it was missing for it.
    let lagged = [&fit[..6], &["--extra", "cur_load:lag=0.2", "-o", "m.json"]].concat();
    run(d, &lagged);
    let out = stream_out(d, &["--model", "m.json"], &(lines.join("\n") + "\n"));
    let rows: Vec<Vec<String>> = out.lines().skip(1).map(|l| last_fields(l, 2)).collect();
    for row in 2000..2002 {
        let [value, status] = &rows[row - 1][..] else {
            unreachable!()
        };
        assert!(!value.is_empty(), "row {row}: {status}");
        assert!(
            status.contains("which this row's value does not read"),
            "row {row}: {status}"
        );
    }
    let plainly_missing = (rows.iter()).filter(|r| !r[0].is_empty() && r[1] == "missing cur_load");
    assert_eq!(plainly_missing.count(), 0, "{:?}", &rows[1995..2010]);
}

fn stream_out(dir: &Path, args: &[&str], input: &str) -> String {
    let out = tolles()
        .current_dir(dir)
        .arg("stream")
        .args(args)
        .arg("--quiet")
        .write_stdin(input.to_string())
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{args:?}: {stderr}");
    String::from_utf8(out.stdout).unwrap()
}

#[test]
fn a_stream_takes_raw_channel_names_and_renames_as_a_file_does() {
    let dir = TempDir::new().unwrap();
    let survey = model_and_survey(dir.path());
    let plain = stream_out(dir.path(), &["--model", "m.json"], &survey);
    let (header, body) = survey.split_once('\n').unwrap();
    let with_header = |names: &[(&str, &str)]| {
        let fields: Vec<&str> = header
            .split(',')
            .map(|h| names.iter().find(|(from, _)| *from == h).map_or(h, |n| n.1))
            .collect();
        (fields.join(","), format!("{}\n{body}", fields.join(",")))
    };
    let (sgl_header, sgl) = with_header(&[
        ("tt", "TIME"),
        ("mag_1_uc", "UNCOMPMAG1"),
        ("flux_a_x", "FLUXA_X"),
        ("flux_a_y", "FLUXA_Y"),
        ("flux_a_z", "FLUXA_Z"),
    ]);
    let out = stream_out(dir.path(), &["--model", "m.json"], &sgl);
    let (first, rest) = out.split_once('\n').unwrap();
    assert_eq!(first, format!("{sgl_header},mag_1_c,status"));
    assert_eq!(rest, plain.split_once('\n').unwrap().1);
    // Renamed back, the output is the stream of the original names, header included.
    let (_, own) = with_header(&[("mag_1_uc", "MAGUC")]);
    let args = ["--model", "m.json", "--rename", "MAGUC=mag_1_uc"];
    assert_eq!(stream_out(dir.path(), &args, &own), plain);
}

#[test]
fn live_keeps_stdout_as_it_is_and_serves_the_state() {
    let dir = TempDir::new().unwrap();
    let survey = model_and_survey(dir.path());
    let live = ["--live", "127.0.0.1:0", "--live-linger", "30"];
    let mut child = spawned_stream(dir.path(), &live);
    let mut stderr = BufReader::new(child.stderr.take().unwrap());
    let mut said = String::new();
    stderr.read_line(&mut said).unwrap();
    let address = said
        .trim()
        .strip_prefix("live page at http://")
        .unwrap()
        .trim_end_matches('/');
    let address = address.to_string();
    // Written from a thread of its own: the stream answers as it reads.
    let mut stdin = child.stdin.take().unwrap();
    let input = survey.clone();
    let writer = std::thread::spawn(move || stdin.write_all(input.as_bytes()).unwrap());
    // Standard output ends with the input, while the page lingers (30 s) to be read.
    let mut out = String::new();
    let mut stdout = BufReader::new(child.stdout.take().unwrap());
    stdout.read_to_string(&mut out).unwrap();
    assert_eq!(out.lines().count(), survey.lines().count());
    writer.join().unwrap();
    let batch = run(
        dir.path(),
        &["compensate", "survey.csv", "--model", "m.json"],
    );
    check_equivalent(&survey, &batch, &out);
    // The page, after the input and the output ended: every line, the last value.
    std::thread::sleep(std::time::Duration::from_millis(600));
    let mut connection = TcpStream::connect(&address).unwrap();
    connection
        .write_all(b"GET /state.json HTTP/1.1\r\n\r\n")
        .unwrap();
    let mut response = String::new();
    connection.read_to_string(&mut response).unwrap();
    let state: serde_json::Value =
        serde_json::from_str(response.split_once("\r\n\r\n").unwrap().1).unwrap();
    assert_eq!(state["samples"], survey.lines().count() - 1);
    let last = out
        .lines()
        .rev()
        .find_map(|l| last_fields(l, 2)[0].parse::<f64>().ok());
    assert_eq!(state["last_nt"].as_f64(), last);
    assert_eq!(state["status"], "ended");
    // The same address again: a one-line error.
    let taken = tolles()
        .current_dir(dir.path())
        .args(["stream", "--model", "m.json", "--live", &address])
        .write_stdin("")
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&taken.stderr);
    assert!(!taken.status.success() && err.lines().count() == 1, "{err}");
    assert!(
        err.contains(&format!("--live {address}: cannot serve the page there")),
        "{err}"
    );
    child.kill().unwrap();
    child.wait().unwrap();
}
