//! The chunked path against the whole-file path on a simulated survey with a time gap, a
//! missing fluxgate value and a column already named like ours.

use super::*;
use crate::compensate::CompensateRequest;
use crate::fit::{fit, FitRequest};
use crate::simulate::{simulate, write as write_flight, SimulateRequest};
use crate::Silent;
use std::path::PathBuf;
use std::sync::Mutex;
use tempfile::TempDir;

/// A damaged simulated survey in `dir` and a model of `mag_1_uc` and `truth_earth` on `flux_a`
/// fitted to it.
fn survey_and_model(dir: &Path) -> (PathBuf, ModelFile) {
    let clean = dir.join("clean.csv");
    write_flight(
        &simulate(&SimulateRequest::default(), &Silent).unwrap(),
        &clean,
    )
    .unwrap();
    let mut warnings = Vec::new();
    let data = crate::read::read(&clean, &Default::default(), &Silent, &mut warnings).unwrap();
    let request = FitRequest::new(
        vec!["mag_1_uc".into(), "truth_earth".into()],
        vec!["flux_a".into()],
    );
    let model = fit(&data.table, &request, &Silent, &mut warnings).unwrap();

    let text = std::fs::read_to_string(&clean).unwrap();
    let mut lines: Vec<String> = text.lines().map(str::to_string).collect();
    let flux_y = lines[0].split(',').position(|h| h == "flux_a_y").unwrap();
    lines[0] += ",mag_1_c";
    for line in lines.iter_mut().skip(1) {
        *line += ",0";
    }
    let mut cells: Vec<&str> = lines[101].split(',').collect();
    cells[flux_y] = "";
    lines[101] = cells.join(",");
    lines.drain(301..311); // a time gap
    let survey = dir.join("survey.csv");
    std::fs::write(&survey, lines.join("\n") + "\n").unwrap();
    (survey, model)
}

/// The CSV written and the warnings given, reading `survey` whole or in chunks of `rows`.
fn run(
    survey: &Path,
    model: &ModelFile,
    compensate: CompensateRequest,
    rows: Option<usize>,
) -> (Vec<u8>, Vec<Warning>) {
    let request = FileRequest {
        survey: survey.to_path_buf(),
        compensate,
        memory: if rows.is_some() {
            Memory::Bounded
        } else {
            Memory::Whole
        },
        chunk_rows: rows,
        ..FileRequest::default()
    };
    assert_eq!(reads_in_chunks(model, &request), rows.is_some());
    let (mut out, mut warnings) = (Vec::new(), Vec::new());
    let progress = Silent;
    super::super::compensate_file(model, &request, &mut out, &progress, &mut warnings).unwrap();
    (out, warnings)
}

#[test]
fn chunks_write_what_reading_whole_writes_with_either_level() {
    let dir = TempDir::new().unwrap();
    let (survey, model) = survey_and_model(dir.path());
    for level in [LevelChoice::FileMean, LevelChoice::Model] {
        // 10.5 Hz is far from the time column's 10 Hz: a warning in the same place both ways.
        for fs_hz in [None, Some(10.5)] {
            let request = CompensateRequest {
                fs_hz,
                level,
                uncertainty: false,
            };
            let whole = run(&survey, &model, request, None);
            // Per fit: the rate, its empty rows, and for `mag_1_c` the renaming; the fit of
            // the earth field alone (`truth_earth`) explains nothing, which its verdict says.
            assert_eq!(
                whole.1.len(),
                4 + 2 * fs_hz.is_some() as usize,
                "{:?}",
                whole.1
            );
            for rows in [7, 1000] {
                let chunked = run(&survey, &model, request, Some(rows));
                assert!(chunked.0 == whole.0, "{level:?}, {fs_hz:?}, {rows} rows");
                assert_eq!(chunked.1, whole.1, "{level:?}, {fs_hz:?}, {rows} rows");
            }
        }
    }
}

#[test]
fn the_levels_differ_by_a_constant() {
    let dir = TempDir::new().unwrap();
    let (survey, model) = survey_and_model(dir.path());
    let column = |level| {
        let request = CompensateRequest {
            fs_hz: None,
            level,
            uncertainty: false,
        };
        let (csv, _) = run(&survey, &model, request, Some(64));
        let text = String::from_utf8(csv).unwrap();
        let last = |line: &str| line.rsplit(',').next().unwrap().parse::<f64>().ok();
        text.lines().skip(1).map(last).collect::<Vec<_>>()
    };
    let (mean, fixed) = (column(LevelChoice::FileMean), column(LevelChoice::Model));
    let offsets: Vec<f64> = mean
        .iter()
        .zip(&fixed)
        .filter_map(|(a, b)| Some(a.as_ref()? - b.as_ref()?))
        .collect();
    assert!(offsets.len() > 1000);
    assert!(offsets.iter().all(|d| (d - offsets[0]).abs() < 1e-6));
}

/// What a workflow reported as progress.
#[derive(Default)]
struct Recorded(Mutex<Vec<(Stage, Option<u64>, u64)>>);

impl Progress for Recorded {
    fn begin(&self, stage: Stage, total: Option<u64>) {
        self.0.lock().unwrap().push((stage, total, 0));
    }

    fn advance(&self, units: u64) {
        self.0.lock().unwrap().last_mut().unwrap().2 += units;
    }
}

#[test]
fn progress_counts_rows_checked_then_rows_computed() {
    let dir = TempDir::new().unwrap();
    let (survey, model) = survey_and_model(dir.path());
    for (level, passes) in [(LevelChoice::FileMean, 2), (LevelChoice::Model, 1)] {
        let request = FileRequest {
            survey: survey.clone(),
            compensate: CompensateRequest {
                fs_hz: None,
                level,
                uncertainty: false,
            },
            memory: Memory::Bounded,
            ..FileRequest::default()
        };
        let progress = Recorded::default();
        let done = super::super::compensate_file(
            &model,
            &request,
            &mut Vec::new(),
            &progress,
            &mut Vec::new(),
        )
        .unwrap();
        let rows = done.rows as u64;
        let expected = [
            (Stage::Checking, None, rows),
            (Stage::Compensating, Some(passes * rows), passes * rows),
        ];
        assert_eq!(*progress.0.lock().unwrap(), expected, "{level:?}");
    }
}

#[test]
fn zero_rows_per_chunk_is_an_error_only_where_chunks_are_read() {
    let dir = TempDir::new().unwrap();
    let (survey, model) = survey_and_model(dir.path());
    let mut request = FileRequest {
        survey,
        chunk_rows: Some(0),
        ..FileRequest::default()
    };
    let compensate = |request: &FileRequest| {
        super::super::compensate_file(&model, request, &mut Vec::new(), &Silent, &mut Vec::new())
    };
    let e = compensate(&request).unwrap_err();
    assert_eq!(e.to_string(), "rows per chunk must be positive");
    request.memory = Memory::Whole;
    assert!(compensate(&request).is_ok());
}

#[test]
fn what_cannot_be_read_in_chunks_is_read_whole() {
    let dir = TempDir::new().unwrap();
    let (survey, model) = survey_and_model(dir.path());
    let bounded = FileRequest {
        survey: survey.clone(),
        memory: Memory::Bounded,
        ..FileRequest::default()
    };
    assert!(reads_in_chunks(&model, &bounded));
    let whole = |change: fn(&mut FileRequest)| {
        let mut request = bounded.clone();
        change(&mut request);
        !reads_in_chunks(&model, &request)
    };
    assert!(whole(|r| r.memory = Memory::Whole));
    assert!(whole(|r| r.out = Some(r.survey.clone())));
    assert!(whole(|r| r.out = Some(r.survey.with_extension("h5"))));
    assert!(whole(|r| r.selection.time = Some("..10".parse().unwrap())));
    assert!(whole(|r| r.survey = r.survey.with_extension("missing.csv")));
    let mut auto = bounded.clone();
    auto.memory = Memory::Auto;
    // A small file fits in memory, unless rows per chunk are asked for.
    assert_eq!(
        reads_in_chunks(&model, &auto),
        available_memory_bytes().is_none()
    );
    auto.chunk_rows = Some(100);
    assert!(reads_in_chunks(&model, &auto));
}

#[test]
fn only_files_too_large_for_memory_need_chunks() {
    assert!(needs_bounded_memory(1 << 50, Format::Csv));
    assert!(needs_bounded_memory(1 << 47, Format::Parquet));
    if available_memory_bytes().is_some() {
        assert!(!needs_bounded_memory(1 << 20, Format::Csv));
    }
}

#[test]
fn runs_end_where_reading_whole_ends_them_at_every_chunk_edge() {
    let dir = TempDir::new().unwrap();
    let (survey, model) = survey_and_model(dir.path());
    let text = std::fs::read_to_string(&survey).unwrap();
    let mut lines: Vec<String> = text.lines().take(1 + 120).map(str::to_string).collect();
    let headers: Vec<&str> = lines[0].split(',').collect();
    let (tt, flux_x) = (headers.iter().position(|h| *h == "tt"), "flux_a_x");
    let (tt, flux_x) = (
        tt.unwrap(),
        headers.iter().position(|h| *h == flux_x).unwrap(),
    );
    // Steps of 0.16 s (a gap: over 1.5 median steps of 0.1 s) and 0.14 s (none), one after
    // another and apart, and fluxgate holes of one and two rows next to them.
    let mut shift = 0.0;
    for (k, line) in lines.iter_mut().enumerate().skip(1) {
        shift += match k {
            20 | 21 | 40 | 61 => 0.06,
            30 | 31 | 50 | 62 => 0.04,
            _ => 0.0,
        };
        let mut cells: Vec<String> = line.split(',').map(str::to_string).collect();
        let t: f64 = cells[tt].parse().unwrap();
        cells[tt] = format!("{}", t + shift);
        if [44, 70, 71, 90].contains(&k) {
            cells[flux_x] = String::new();
        }
        *line = cells.join(",");
    }
    std::fs::write(&survey, lines.join("\n") + "\n").unwrap();
    let request = CompensateRequest {
        fs_hz: None,
        level: LevelChoice::FileMean,
        uncertainty: false,
    };
    let whole = run(&survey, &model, request, None);
    let empty = |csv: &[u8]| String::from_utf8_lossy(csv).matches(",\n").count();
    assert!(
        empty(&whole.0) >= 4,
        "the holes leave rows without a result"
    );
    for rows in 1..=9 {
        let chunked = run(&survey, &model, request, Some(rows));
        assert!(chunked.0 == whole.0, "{rows} rows");
        assert_eq!(chunked.1, whole.1, "{rows} rows");
    }
}

/// The model of [`survey_and_model`] with its fluxgate read 0.37 s late and an extra channel
/// (the roll, low-passed and lagged) whose three coefficients are made up.
fn with_extra_and_lag(mut model: ModelFile, extra: &str) -> ModelFile {
    for fit in &mut model.fits {
        fit.fit.lag_s = 0.37;
        let spec = format!("{extra}:lowpass=0.5:lag=0.23").parse().unwrap();
        fit.fit.settings.design.extras.push(spec);
        fit.fit.coefficients.extend([0.5, -0.3, 0.2]);
    }
    model
}

#[test]
fn extra_channels_and_a_lag_are_read_in_chunks_with_the_same_bytes() {
    let dir = TempDir::new().unwrap();
    let (survey, model) = survey_and_model(dir.path());
    let model = with_extra_and_lag(model, "ins_roll");
    let bounded = FileRequest {
        survey: survey.clone(),
        memory: Memory::Bounded,
        ..FileRequest::default()
    };
    assert!(reads_in_chunks(&model, &bounded));
    for level in [LevelChoice::FileMean, LevelChoice::Model] {
        let request = CompensateRequest {
            fs_hz: None,
            level,
            uncertainty: false,
        };
        let whole = run(&survey, &model, request, None);
        let finite = |csv: &[u8]| {
            let text = String::from_utf8(csv.to_vec()).unwrap();
            let last = |l: &str| l.rsplit(',').next().unwrap().parse::<f64>().is_ok();
            text.lines().skip(1).filter(|l| last(l)).count()
        };
        // The lag and the extra channel's shift leave the last rows without a value.
        assert!(finite(&whole.0) > 1000, "{:?}", whole.1);
        // Chunks shorter than the shifts' reach, and longer.
        for rows in [1, 3, 7, 1000] {
            let chunked = run(&survey, &model, request, Some(rows));
            assert!(chunked.0 == whole.0, "{level:?}, {rows} rows");
            assert_eq!(chunked.1, whole.1, "{level:?}, {rows} rows");
        }
    }
}

#[test]
fn a_missing_extra_channel_is_the_same_error_in_chunks() {
    let dir = TempDir::new().unwrap();
    let (survey, model) = survey_and_model(dir.path());
    let model = with_extra_and_lag(model, "cur_none");
    let message = |rows: Option<usize>| {
        let request = FileRequest {
            survey: survey.clone(),
            memory: rows.map_or(Memory::Whole, |_| Memory::Bounded),
            chunk_rows: rows,
            ..FileRequest::default()
        };
        let mut warnings = Vec::new();
        let result = super::super::compensate_file(
            &model,
            &request,
            &mut Vec::new(),
            &Silent,
            &mut warnings,
        );
        (result.unwrap_err().to_string(), warnings)
    };
    let whole = message(None);
    assert!(whole.0.contains("cur_none"), "{}", whole.0);
    assert_eq!(message(Some(5)), whole);
}
