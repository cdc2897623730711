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
