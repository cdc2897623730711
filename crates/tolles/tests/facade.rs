//! The facade's key invariant at its own level: one model applied three ways (the whole file,
//! the file in bounded chunks, the stream line by line) gives the same compensated values, on
//! a simulated survey with a gap and missing cells. The CLI's tests check the same through the
//! binary; these check the library a Python binding or another program calls.

use std::path::{Path, PathBuf};
use tolles::compensate::{compensate_file, FileRequest, Memory};
use tolles::fit::{fit, FitRequest};
use tolles::model::ModelFile;
use tolles::simulate::{simulate, write, PlanKind, SimulateRequest};
use tolles::stream::{serve, Setup, Stats, StreamRequest};
use tolles::Silent;

/// A box fitted into a model, and a four-line survey with a cell missing, as files in `dir`.
fn model_and_survey(dir: &Path) -> (ModelFile, PathBuf) {
    let flight = |plan, name: &str| {
        let request = SimulateRequest {
            plan,
            lines: 4,
            ..SimulateRequest::default()
        };
        let path = dir.join(name);
        write(&simulate(&request, &Silent).unwrap(), &path).unwrap();
        path
    };
    let calibration = flight(PlanKind::Box, "box.csv");
    let survey = flight(PlanKind::Survey, "survey.csv");
    let mut warnings = Vec::new();
    let table = tolles::read::read(&calibration, &Default::default(), &Silent, &mut warnings)
        .unwrap()
        .table;
    let request = FitRequest::new(vec!["mag_1_uc".into()], vec!["flux_a".into()]);
    let model = fit(&table, &request, &Silent, &mut warnings).unwrap();
    // A missing scalar cell in the middle of the survey: one uncomputable row.
    let text = std::fs::read_to_string(&survey).unwrap();
    let column = text
        .lines()
        .next()
        .unwrap()
        .split(',')
        .position(|h| h == "mag_1_uc");
    let damaged: Vec<String> = (text.lines().enumerate())
        .map(|(k, line)| match k {
            2000 => {
                let mut cells: Vec<&str> = line.split(',').collect();
                cells[column.unwrap()] = "";
                cells.join(",")
            }
            _ => line.to_string(),
        })
        .collect();
    std::fs::write(&survey, damaged.join("\n") + "\n").unwrap();
    (model, survey)
}

/// The survey compensated as CSV text, read as `memory` says (in chunks of `rows`).
fn compensated(model: &ModelFile, survey: &Path, memory: Memory, rows: Option<usize>) -> String {
    let request = FileRequest {
        survey: survey.to_path_buf(),
        memory,
        chunk_rows: rows,
        ..FileRequest::default()
    };
    let mut out = Vec::new();
    compensate_file(model, &request, &mut out, &Silent, &mut Vec::new()).unwrap();
    String::from_utf8(out).unwrap()
}

/// The last cell of each line after the header, as a number (`None` when empty or not one).
fn last_values(text: &str, skip_last: usize) -> Vec<Option<f64>> {
    (text.lines().skip(1))
        .map(|line| {
            let cells: Vec<&str> = line.rsplit(',').collect();
            cells[skip_last].parse().ok()
        })
        .collect()
}

#[test]
fn whole_chunked_and_streamed_compensation_agree() {
    let dir = tempfile::tempdir().unwrap();
    let (model, survey) = model_and_survey(dir.path());
    let whole = compensated(&model, &survey, Memory::Whole, None);
    // Chunks that split lines and the missing cell's neighbourhood: the same bytes.
    for rows in [997, 4096] {
        let chunked = compensated(&model, &survey, Memory::Bounded, Some(rows));
        assert!(
            chunked == whole,
            "{rows}-row chunks differ from the whole file"
        );
    }
    let setup = Setup::new(&model, Path::new("m.json"), &StreamRequest::default()).unwrap();
    let input = std::fs::read(&survey).unwrap();
    let mut output = Vec::new();
    serve(&setup, &Stats::default(), &input[..], &mut output).unwrap();
    let streamed = String::from_utf8(output).unwrap();
    let (batch, stream) = (last_values(&whole, 0), last_values(&streamed, 1));
    assert_eq!(batch.len(), stream.len(), "one output line per input line");
    // The stream keeps the model's level, the file its own mean: one constant apart.
    let mut offset = None;
    let mut missing = 0;
    for (row, pair) in batch.iter().zip(&stream).enumerate() {
        match pair {
            (Some(b), Some(s)) => {
                let d = *offset.get_or_insert(b - s);
                assert!((b - s - d).abs() < 1e-9, "row {row}: {b} against {s}");
            }
            (None, None) => missing += 1,
            other => panic!("row {row}: {other:?}"),
        }
    }
    assert_eq!(missing, 1);
}

/// A page's files for the tests: the state element alone.
fn bare_page() -> tolles::live::LivePage {
    tolles::live::LivePage {
        html: tolles::live::LIVE_ELEMENT.to_string(),
        uplot_js: "",
        uplot_css: "",
    }
}

/// `GET path` from the live page at `address`: the body.
fn get(address: std::net::SocketAddr, path: &str) -> String {
    use std::io::{Read, Write};
    let mut connection = std::net::TcpStream::connect(address).unwrap();
    write!(connection, "GET {path} HTTP/1.1\r\nHost: x\r\n\r\n").unwrap();
    let mut text = String::new();
    connection.read_to_string(&mut text).unwrap();
    text.split_once("\r\n\r\n").unwrap().1.to_string()
}

#[test]
fn the_live_page_shows_what_the_stream_answered_and_never_holds_it_up() {
    use tolles::live::{Live, LiveRequest};
    let dir = tempfile::tempdir().unwrap();
    let (model, _) = model_and_survey(dir.path());
    let flight = dir.path().join("box.csv");
    let request = LiveRequest {
        address: "127.0.0.1:0".into(),
        noise_spec_nt: 0.1,
        fom_spec_nt: 1.5,
        fs_hz: 10.0,
        verdict: "good".into(),
    };
    let live = Live::start(request.clone(), bare_page()).unwrap();
    // A second page on the same port is refused, naming the address.
    let taken = LiveRequest {
        address: live.address().to_string(),
        ..request
    };
    let zero = LiveRequest {
        noise_spec_nt: 0.0,
        ..taken.clone()
    };
    let bad = Live::start(zero, bare_page()).err().unwrap();
    assert!(
        bad.to_string()
            .contains("--noise-spec must be a positive number"),
        "{bad}"
    );
    let refused = Live::start(taken, bare_page()).err().unwrap();
    assert!(
        refused.to_string().contains(&live.address().to_string()),
        "{refused}"
    );
    // A browser that asks for the events and never reads them.
    let mut stalled = std::net::TcpStream::connect(live.address()).unwrap();
    std::io::Write::write_all(&mut stalled, b"GET /events HTTP/1.1\r\n\r\n").unwrap();
    let setup = Setup::new(&model, Path::new("m.json"), &StreamRequest::default()).unwrap();
    let setup = setup.with_live(live.feed());
    let input = std::fs::read(&flight).unwrap();
    let mut output = Vec::new();
    serve(&setup, &Stats::default(), &input[..], &mut output).unwrap();
    live.feed().end();
    let answered = String::from_utf8(output).unwrap();
    let lines = answered.lines().count() - 1;
    let last: f64 = last_values(&answered, 1).last().unwrap().unwrap();
    // The worker publishes within a quarter of a second of the end.
    std::thread::sleep(std::time::Duration::from_millis(600));
    let state: serde_json::Value =
        serde_json::from_str(&get(live.address(), "/state.json")).unwrap();
    assert_eq!(state["samples"].as_u64().unwrap() as usize, lines);
    assert_eq!(state["last_nt"].as_f64().unwrap(), last);
    assert_eq!(state["status"], "ended");
    // The live box's figure of merit against the batch one, on the same compensated values.
    let mut warnings = Vec::new();
    let table = tolles::read::read(&flight, &Default::default(), &Silent, &mut warnings)
        .unwrap()
        .table;
    let batch = tolles::fom::fom(
        &table,
        &tolles::fom::FomRequest::new("mag_1_uc"),
        Some(&model.fits[0]),
        &mut warnings,
    )
    .unwrap();
    let batch_after = batch.after.unwrap().fom_nt;
    let live_after = state["fom"]["after_nt"].as_f64().unwrap();
    println!("FOM after: live {live_after:.4} nT, batch {batch_after:.4} nT");
    assert!((live_after / batch_after - 1.0).abs() < 0.10);
    assert_eq!(state["fom"]["slots"], 12);
    let page = get(live.address(), "/");
    assert!(
        page.contains(&format!("data-samples=\"{lines}\"")),
        "{page}"
    );
    assert!(page.contains(&format!("data-last-nt=\"{last}\"")), "{page}");
    assert!(
        page.contains(&format!("data-fom-nt=\"{live_after}\"")),
        "{page}"
    );
    drop(stalled);
}
