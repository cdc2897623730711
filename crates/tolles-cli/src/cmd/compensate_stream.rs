//! `tolles compensate` in bounded memory: the survey is read a chunk of rows at a time, in three
//! passes, and the output is the same text (CSV) or the same values (Parquet) as reading it
//! whole gives.
//!
//! 1. **Scan** the columns the fits use (every column when writing Parquet, which holds numbers
//!    only) for what reading the file whole finds: the first bad cell of each column, time that
//!    does not increase, an implausible fluxgate magnitude, and the exact median time step
//!    (sample rate and gap threshold). They are reported in the order the whole-file path meets
//!    them.
//! 2. **Level**: each fit's correction `A·β` from the streaming compensator with central
//!    differences, its runs split where the batch computation splits them (unusable fluxgate,
//!    time gaps), and its mean over the file: the level the batch computation keeps. For text
//!    files pass 1 keeps the numbers it read in an anonymous temporary file (8 bytes a value),
//!    so the text is parsed twice, not three times.
//! 3. **Write** every row with the compensated columns, `scalar − (A·β − level)`.
//!
//! Memory holds two chunks ([`CHUNK_ROWS_VAR`] rows each, default
//! [`tolles_io::chunks::DEFAULT_CHUNK_ROWS`]) whatever the length of the file.

use super::compensate::Args;
use crate::input::{flux_magnitude_error, sample_rate_from, time_not_increasing, TIME_COLUMN};
use anyhow::{bail, Context, Result};
use indicatif::ProgressBar;
use std::io::Write;
use std::path::Path;
use tolles_core::fit::check_flux_magnitude;
use tolles_core::median::MedianSearch;
use tolles_core::segment::GAP_FACTOR;
use tolles_core::stream::{Derivative, Output, Sample, ScalarSpec, StreamCompensator};
use tolles_core::vector::VectorSeries;
use tolles_io::chunks::{
    ChunkReader, CsvChunkWriter, NumberSpill, ParquetChunkWriter, SpillReader, DEFAULT_CHUNK_ROWS,
};
use tolles_io::format::Format;
use tolles_io::model::ModelFile;
use tolles_io::table::{find_column, Table};
use tolles_io::IoError;

/// Environment variable: rows per chunk (default [`DEFAULT_CHUNK_ROWS`]).
pub const CHUNK_ROWS_VAR: &str = "TOLLES_CHUNK_ROWS";
/// Environment variable: `bounded` always reads the survey in chunks where it can, `whole` never
/// does, `auto` (the default) does when reading it whole could take more than half of the memory
/// available (see [`needs_bounded_memory`]).
pub const MEMORY_VAR: &str = "TOLLES_MEMORY";

/// True when `tolles compensate` reads the survey in chunks: CSV, XYZ or Parquet input that is a
/// regular file (read three times), CSV or Parquet output that is not the input itself, one
/// fluxgate per fit, no row selection, and memory asks for it: `TOLLES_MEMORY=bounded`, a
/// `TOLLES_CHUNK_ROWS` given, or (by default) a file too large to read whole comfortably.
pub fn applies(args: &Args, model: &ModelFile) -> bool {
    let mode = std::env::var(MEMORY_VAR)
        .unwrap_or_default()
        .to_ascii_lowercase();
    let output_streams = args.out.as_deref().is_none_or(|out| {
        matches!(Format::from_path(out), Format::Csv | Format::Parquet)
            && !same_file(&args.survey, out)
    });
    let format = Format::from_path(&args.survey);
    let size = std::fs::metadata(&args.survey)
        .ok()
        .filter(|m| m.is_file())
        .map(|m| m.len());
    let wanted = match mode.as_str() {
        "whole" => false,
        "bounded" => true,
        _ => {
            std::env::var(CHUNK_ROWS_VAR).is_ok()
                || size.is_some_and(|s| needs_bounded_memory(s, format))
        }
    };
    wanted
        && ChunkReader::reads(format)
        && size.is_some()
        && output_streams
        && model.fits.iter().all(|f| f.vectors.len() == 1)
        && args.select.is_everything()
}

/// Whether reading a survey of `bytes` whole could take more than half of the memory available
/// now. Reading whole is faster (the text is parsed once, not twice) but holds every cell:
/// measured, about 3.4 bytes of memory per byte of CSV and 11 per byte of Parquet (compressed).
/// Without `/proc/meminfo` (not Linux) memory is assumed short.
pub fn needs_bounded_memory(bytes: u64, format: Format) -> bool {
    let per_byte = match format {
        Format::Parquet => 12,
        _ => 4,
    };
    match available_memory_bytes() {
        Some(available) => bytes.saturating_mul(per_byte) > available / 2,
        None => true,
    }
}

/// `MemAvailable` of `/proc/meminfo` (bytes).
fn available_memory_bytes() -> Option<u64> {
    let text = std::fs::read_to_string("/proc/meminfo").ok()?;
    let line = text.lines().find(|l| l.starts_with("MemAvailable:"))?;
    let kib: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kib * 1024)
}

/// Whether `out` is the file `survey` (writing it while reading it would destroy it).
fn same_file(survey: &Path, out: &Path) -> bool {
    let (Ok(a), Ok(b)) = (std::fs::metadata(survey), std::fs::metadata(out)) else {
        return false;
    };
    #[cfg(unix)]
    {
        use std::os::unix::fs::MetadataExt;
        a.dev() == b.dev() && a.ino() == b.ino()
    }
    #[cfg(not(unix))]
    {
        let _ = (a, b);
        survey.canonicalize().ok() == out.canonicalize().ok()
    }
}

/// Compensates `args.survey` with `model` in bounded memory (see the module documentation).
pub fn run(args: &Args, model: &ModelFile) -> Result<()> {
    let progress = crate::progress::rows("checking");
    let result = run_with(args, model, &progress);
    progress.finish_and_clear();
    result
}

/// [`run`], counting rows on `progress`: the first pass as they are read, then the two
/// passes that compute and write against the rows the first one found.
fn run_with(args: &Args, model: &ModelFile, progress: &ProgressBar) -> Result<()> {
    let format = Format::from_path(&args.survey);
    let rows = chunk_rows()?;
    let open = || ChunkReader::open(&args.survey, format, rows);
    let reader = open()?;
    for note in reader.notes() {
        eprintln!("warning: {}: {note}", args.survey.display());
    }
    let numeric_output = args
        .out
        .as_deref()
        .is_some_and(|out| Format::from_path(out) == Format::Parquet);
    let plan = Plan::new(&reader, model, numeric_output);
    let mut scan = scan(reader.only(plan.read.clone()), &plan, progress)?;
    crate::progress::restyle_as_bar(progress, 2 * scan.rows as u64, "compensating");
    // The fits before one that fails are computed and reported, as the whole-file path does.
    let (fits, failure) = check_in_order(&plan, &scan, model, args);
    let levels = match fits.is_empty() {
        true => Vec::new(),
        false => {
            let numbers = match scan.spill.take() {
                Some(spill) => Numbers::Spill(spill.into_reader(rows).context("temporary file")?),
                None => Numbers::File(open()?.only(plan.read.clone())),
            };
            level(numbers, &plan, &scan, &fits, progress)?
        }
    };
    let headers = open()?.headers().to_vec();
    let mut names = Vec::new();
    for (fit, level) in model.fits.iter().zip(&levels) {
        if level.uncomputable > 0 {
            warn_uncomputable(
                &args.survey,
                level.uncomputable,
                scan.rows,
                &fit.output_column,
            );
        }
        names.push(output_name(&args.survey, &headers, &fit.output_column));
    }
    if let Some(e) = failure {
        return Err(e);
    }
    if numeric_output {
        if let Some(e) = scan.first_error_in_file_order() {
            return Err(e.into());
        }
    }
    let specs = fits
        .iter()
        .zip(&levels)
        .map(|(f, l)| f.spec(l.level_nt))
        .collect();
    let uncomputable = write(args, open()?, &plan, &scan, specs, &names, progress)?;
    for ((fit, level), n) in model.fits.iter().zip(&levels).zip(uncomputable) {
        // Only a value beyond f64's range makes these differ.
        if n != level.uncomputable {
            warn_uncomputable(&args.survey, n, scan.rows, &fit.output_column);
        }
    }
    Ok(())
}

fn chunk_rows() -> Result<usize> {
    match std::env::var(CHUNK_ROWS_VAR) {
        Err(_) => Ok(DEFAULT_CHUNK_ROWS),
        Ok(text) => match text.trim().parse::<usize>() {
            Ok(n) if n > 0 => Ok(n),
            _ => bail!("{CHUNK_ROWS_VAR} must be a positive number of rows, got {text:?}"),
        },
    }
}

fn warn_uncomputable(survey: &Path, n: usize, rows: usize, column: &str) {
    eprintln!(
        "warning: {}: {n} of {rows} rows have no {column} (missing scalar or fluxgate values); their cells are empty",
        survey.display(),
    );
}

/// The compensated column's name, as the whole-file path chooses it.
fn output_name(survey: &Path, headers: &[String], wanted: &str) -> String {
    if find_column(survey, headers, wanted).is_ok() {
        let renamed = format!("{wanted}_tolles");
        eprintln!(
            "warning: {} already has a column {wanted:?}; writing ours as {renamed:?}",
            survey.display()
        );
        renamed
    } else {
        wanted.to_string()
    }
}

/// Which columns are read, and where each fit's columns are in a chunk.
struct Plan {
    /// Indices into the file's headers of the columns read in passes 1 and 2.
    read: Vec<usize>,
    fits: Vec<FitColumns>,
    /// Position of `tt` in a chunk, if the file has it (or the error looking it up, never shown
    /// when there is no such column).
    tt: Option<usize>,
    /// Distinct fluxgate prefixes, and per fluxgate the chunk positions of x, y, z.
    fluxgates: Vec<(String, [Result<usize, IoError>; 3])>,
}

struct FitColumns {
    scalar: Result<usize, IoError>,
    fluxgate: usize,
}

impl Plan {
    /// Positions (in a chunk of the columns read) of the columns the computation uses: the
    /// scalars, fluxgates and time; the others are read only to be checked.
    fn used(&self) -> Vec<usize> {
        let scalars = self.fits.iter().filter_map(|f| f.scalar.as_ref().ok());
        let axes = self.fluxgates.iter().flat_map(|(_, a)| a.iter().flatten());
        let mut used: Vec<usize> = scalars.chain(axes).chain(&self.tt).copied().collect();
        used.sort_unstable();
        used.dedup();
        used
    }

    fn new(reader: &ChunkReader, model: &ModelFile, every_column: bool) -> Self {
        let headers = reader.headers();
        let mut read: Vec<usize> = if every_column {
            (0..headers.len()).collect()
        } else {
            Vec::new()
        };
        let mut position = |name: &str| -> Result<usize, IoError> {
            let index = find_column(reader.path(), headers, name)?;
            Ok(match read.iter().position(|r| *r == index) {
                Some(p) => p,
                None => {
                    read.push(index);
                    read.len() - 1
                }
            })
        };
        let mut fluxgates: Vec<(String, [Result<usize, IoError>; 3])> = Vec::new();
        let mut fits = Vec::new();
        for fit in &model.fits {
            let scalar = position(&fit.scalar);
            let vector = &fit.vectors[0];
            let fluxgate = match fluxgates.iter().position(|(v, _)| v == vector) {
                Some(j) => j,
                None => {
                    let axes = ["x", "y", "z"].map(|a| position(&format!("{vector}_{a}")));
                    fluxgates.push((vector.clone(), axes));
                    fluxgates.len() - 1
                }
            };
            fits.push(FitColumns { scalar, fluxgate });
        }
        let tt = position(TIME_COLUMN).ok();
        Self {
            read,
            fits,
            tt,
            fluxgates,
        }
    }
}

/// What pass 1 found.
struct Scan {
    rows: usize,
    /// Per column read, the first cell that is not a number.
    bad_cell: Vec<Option<IoError>>,
    /// Where time first fails to increase: (place, time, the time before), seconds.
    not_increasing: Option<(String, f64, f64)>,
    /// Per fluxgate, the first implausible magnitude: (place, nT).
    bad_magnitude: Vec<Option<(String, f64)>>,
    median_step: Option<f64>,
    /// The numbers read, for pass 2, when the file is text.
    spill: Option<NumberSpill>,
}

impl Scan {
    /// The first bad cell in the order reading the whole file as numbers meets it: column by
    /// column in file order.
    fn first_error_in_file_order(&self) -> Option<IoError> {
        self.bad_cell.iter().flatten().next().map(clone_error)
    }
}

/// One chunk's columns as numbers; a column with a bad cell is all NaN here (its error is kept
/// and reported when its turn comes).
fn numbers(chunk: &Table, bad_cell: &mut [Option<IoError>]) -> Vec<Vec<f64>> {
    (0..chunk.headers().len())
        .map(|j| match chunk.numeric_at(j) {
            Ok(v) => v,
            Err(e) => {
                bad_cell[j].get_or_insert(e);
                vec![f64::NAN; chunk.len()]
            }
        })
        .collect()
}

fn fluxgate(values: &[Vec<f64>], axes: &[Result<usize, IoError>; 3], len: usize) -> VectorSeries {
    let axis = |a: usize| match &axes[a] {
        Ok(p) => values[*p].clone(),
        Err(_) => vec![f64::NAN; len],
    };
    VectorSeries::new(axis(0), axis(1), axis(2))
}

fn scan(mut reader: ChunkReader, plan: &Plan, progress: &ProgressBar) -> Result<Scan> {
    let mut bad_cell: Vec<Option<IoError>> = (0..plan.read.len()).map(|_| None).collect();
    let mut bad_magnitude = vec![None; plan.fluxgates.len()];
    let mut not_increasing = None;
    let mut median = MedianSearch::default();
    let mut steps = median.start_pass();
    let mut previous = f64::NAN;
    let mut last_finite = f64::NEG_INFINITY;
    let mut rows = 0;
    let text = Format::from_path(reader.path()) != Format::Parquet;
    let mut spill = match text {
        true => Some(NumberSpill::new(plan.used().len()).context("temporary file")?),
        false => None,
    };
    while let Some(chunk) = reader.next_chunk()? {
        progress.inc(chunk.len() as u64);
        let values = numbers(&chunk, &mut bad_cell);
        if let Some(spill) = &mut spill {
            let used: Vec<&[f64]> = plan.used().iter().map(|&p| values[p].as_slice()).collect();
            spill.push(&used).context("temporary file")?;
        }
        if let Some(p) = plan.tt {
            for (k, &t) in values[p].iter().enumerate() {
                push_step(&mut steps, previous, t);
                previous = t;
                if !t.is_finite() {
                    continue;
                }
                if t <= last_finite && not_increasing.is_none() {
                    not_increasing = Some((reader.place_of(&chunk, k), t, last_finite));
                }
                last_finite = t;
            }
        }
        for (j, (_, axes)) in plan.fluxgates.iter().enumerate() {
            if bad_magnitude[j].is_some() {
                continue;
            }
            if let Err(tolles_core::fit::FitError::FluxMagnitude {
                index, magnitude, ..
            }) = check_flux_magnitude(&fluxgate(&values, axes, chunk.len()))
            {
                bad_magnitude[j] = Some((reader.place_of(&chunk, index), magnitude));
            }
        }
        rows += chunk.len();
    }
    median.finish_pass(steps);
    if let Some(p) = plan.tt {
        while median.needs_pass() {
            median = more_median_passes(median, p, plan, &reader)?;
        }
    }
    Ok(Scan {
        rows,
        bad_cell,
        not_increasing,
        bad_magnitude,
        median_step: median.median(),
        spill,
    })
}

/// Counts the step from time `before` to `t` (s) as the batch median does: finite and positive.
fn push_step(pass: &mut tolles_core::median::MedianPass, before: f64, t: f64) {
    let d = t - before;
    if d.is_finite() && d > 0.0 {
        pass.push(d);
    }
}

/// Another pass over the time column alone, for a median that one pass could not settle.
fn more_median_passes(
    mut median: MedianSearch,
    tt: usize,
    plan: &Plan,
    reader: &ChunkReader,
) -> Result<MedianSearch> {
    let format = Format::from_path(reader.path());
    let mut again =
        ChunkReader::open(reader.path(), format, DEFAULT_CHUNK_ROWS)?.only(vec![plan.read[tt]]);
    let mut steps = median.start_pass();
    let mut previous = f64::NAN;
    // A bad time cell is NaN here, as in pass 1; its error is reported when its turn comes.
    let mut bad = vec![None];
    while let Some(chunk) = again.next_chunk()? {
        for t in numbers(&chunk, &mut bad).remove(0) {
            push_step(&mut steps, previous, t);
            previous = t;
        }
    }
    median.finish_pass(steps);
    Ok(median)
}

/// One fit, checked and ready to compute.
struct ReadyFit {
    name: String,
    fluxgate: usize,
    design: tolles_core::design::Design,
    coefficients: Vec<f64>,
    fs_ratio: f64,
}

impl ReadyFit {
    fn spec(&self, level_nt: f64) -> ScalarSpec {
        ScalarSpec::new(
            &self.name,
            self.fluxgate,
            self.design.clone(),
            &self.coefficients,
            level_nt,
            self.fs_ratio,
        )
    }
}

/// Checks what pass 1 found in the order the whole-file path does: per fit its scalar, its
/// fluxgate's x, y, z, the time column, the fluxgate's magnitude, then the sample rate. Returns
/// the fits before the first that fails, and its error.
fn check_in_order(
    plan: &Plan,
    scan: &Scan,
    model: &ModelFile,
    args: &Args,
) -> (Vec<ReadyFit>, Option<anyhow::Error>) {
    let mut ready = Vec::new();
    for (fit, columns) in model.fits.iter().zip(&plan.fits) {
        match check_fit(plan, scan, fit, columns, args) {
            Ok(f) => ready.push(f),
            Err(e) => return (ready, Some(e)),
        }
    }
    (ready, None)
}

fn check_fit(
    plan: &Plan,
    scan: &Scan,
    fit: &tolles_io::model::ScalarModel,
    columns: &FitColumns,
    args: &Args,
) -> Result<ReadyFit> {
    let column = |position: &Result<usize, IoError>| -> Result<()> {
        match position {
            Err(e) => Err(clone_error(e).into()),
            Ok(p) => match &scan.bad_cell[*p] {
                Some(e) => Err(clone_error(e).into()),
                None => Ok(()),
            },
        }
    };
    column(&columns.scalar)?;
    let (vector, axes) = &plan.fluxgates[columns.fluxgate];
    for axis in axes {
        column(axis)?;
    }
    if let Some(p) = plan.tt {
        column(&Ok(p))?;
        if let Some((place, t, before)) = &scan.not_increasing {
            return Err(time_not_increasing(&args.survey, place, *t, *before));
        }
    }
    if let Some((place, magnitude)) = &scan.bad_magnitude[columns.fluxgate] {
        return Err(flux_magnitude_error(
            &args.survey,
            place,
            vector,
            *magnitude,
        ));
    }
    let fs_hz = match (args.fs, plan.tt) {
        (None, None) => fit.fit.fs_hz,
        (fs, _) => sample_rate_from(&args.survey, None, scan.median_step, fs)?,
    };
    Ok(ReadyFit {
        name: fit.scalar.clone(),
        fluxgate: columns.fluxgate,
        design: fit.fit.settings.design.clone(),
        coefficients: fit.fit.coefficients.clone(),
        fs_ratio: fs_hz / fit.fit.fs_hz,
    })
}

/// The errors pass 1 keeps are shown once, when their turn comes; this copies one to return.
fn clone_error(e: &IoError) -> IoError {
    match e {
        IoError::NotANumber {
            path,
            place,
            column,
            value,
        } => IoError::NotANumber {
            path: path.clone(),
            place: place.clone(),
            column: column.clone(),
            value: value.clone(),
        },
        IoError::MissingColumn { path, column, hint } => IoError::MissingColumn {
            path: path.clone(),
            column: column.clone(),
            hint: hint.clone(),
        },
        other => IoError::Invalid {
            path: std::path::PathBuf::new(),
            message: other.to_string(),
        },
    }
}

/// The numbers one pass feeds the compensator: per chunk row, the time step before it is a gap.
struct Feed<'a> {
    plan: &'a Plan,
    /// Gap threshold (s): [`GAP_FACTOR`] median steps, as the batch runs use.
    gap_s: Option<f64>,
    previous_t: f64,
    scalars: Vec<f64>,
    flux: Vec<[f64; 3]>,
}

impl<'a> Feed<'a> {
    fn new(plan: &'a Plan, scan: &Scan) -> Self {
        Self {
            plan,
            gap_s: scan.median_step.map(|step| GAP_FACTOR * step),
            previous_t: f64::NAN,
            scalars: vec![0.0; plan.fits.len()],
            flux: vec![[f64::NAN; 3]; plan.fluxgates.len()],
        }
    }

    /// Loads row `k` of `values`; true when a time gap comes before it.
    fn load(&mut self, values: &[Vec<f64>], k: usize) -> bool {
        for (j, (_, axes)) in self.plan.fluxgates.iter().enumerate() {
            self.flux[j] = [0, 1, 2].map(|a| match &axes[a] {
                Ok(p) => values[*p][k],
                Err(_) => f64::NAN,
            });
        }
        for (i, fit) in self.plan.fits.iter().enumerate() {
            self.scalars[i] = match &fit.scalar {
                Ok(p) => values[*p][k],
                Err(_) => f64::NAN,
            };
        }
        let Some(p) = self.plan.tt else { return false };
        let t = values[p][k];
        let dt = t - self.previous_t;
        self.previous_t = t;
        self.gap_s.is_some_and(|gap| dt.is_finite() && dt > gap)
    }

    fn sample(&self) -> Sample<'_> {
        Sample {
            time_s: None,
            scalars: &self.scalars,
            fluxgates: &self.flux,
        }
    }
}

/// A fit's level (the mean of `A·β` over the file, nT) and how many rows it cannot compensate.
struct Level {
    level_nt: f64,
    uncomputable: usize,
}

/// Where pass 2 takes its numbers: what pass 1 spilled (text files, so the text is parsed twice,
/// not three times), or the file again (Parquet: only the columns needed are decoded).
enum Numbers {
    Spill(SpillReader),
    File(ChunkReader),
}

impl Numbers {
    fn next_chunk(&mut self, plan: &Plan) -> Result<Option<Vec<Vec<f64>>>> {
        match self {
            Numbers::Spill(spill) => {
                let Some(used) = spill.next_chunk().context("temporary file")? else {
                    return Ok(None);
                };
                let mut values = vec![Vec::new(); plan.read.len()];
                for (p, column) in plan.used().into_iter().zip(used) {
                    values[p] = column;
                }
                Ok(Some(values))
            }
            Numbers::File(reader) => {
                // Bad cells can only be in the columns of fits after one that failed, not
                // computed here.
                let mut bad: Vec<Option<IoError>> = (0..plan.read.len()).map(|_| None).collect();
                Ok(reader.next_chunk()?.map(|c| numbers(&c, &mut bad)))
            }
        }
    }

    fn path(&self) -> std::path::PathBuf {
        match self {
            Numbers::Spill(_) => std::path::PathBuf::from("temporary file"),
            Numbers::File(reader) => reader.path().to_path_buf(),
        }
    }
}

/// Pass 2: the mean of each fit's correction over the file, summed in file order as the batch
/// mean is. The compensator is fed a scalar of 0, which makes its output exactly −A·β; each
/// row carries whether its scalars are finite, for the count of rows without a result.
fn level(
    mut numbers: Numbers,
    plan: &Plan,
    scan: &Scan,
    fits: &[ReadyFit],
    progress: &ProgressBar,
) -> Result<Vec<Level>> {
    let specs = fits.iter().map(|f| f.spec(0.0)).collect();
    let mut stream = compensator::<Vec<bool>>(specs, plan);
    let mut sums = vec![(0.0, 0usize, 0usize); fits.len()];
    let mut emit = |o: Output<'_, Vec<bool>>| {
        let rows = sums.iter_mut().zip(o.compensated).zip(&o.payload);
        for (((sum, n, empty), v), scalar_finite) in rows {
            if v.is_finite() {
                *sum += -v;
                *n += 1;
            }
            if !(v.is_finite() && *scalar_finite) {
                *empty += 1;
            }
        }
    };
    let mut feed = Feed::new(plan, scan);
    let mut rows = 0;
    while let Some(values) = numbers.next_chunk(plan)? {
        let len = values.first().map_or(0, Vec::len);
        progress.inc(len as u64);
        for k in 0..len {
            if feed.load(&values, k) {
                stream.split(&mut emit);
            }
            let scalar_finite = feed.scalars.iter().map(|s| s.is_finite()).collect();
            feed.scalars.iter_mut().for_each(|s| *s = 0.0);
            stream.push(scalar_finite, Some(feed.sample()), Vec::new(), &mut emit);
        }
        rows += len;
    }
    stream.finish(&mut emit);
    same_rows(&numbers.path(), rows, scan.rows)?;
    Ok(sums
        .into_iter()
        .map(|(sum, n, empty)| Level {
            level_nt: if n == 0 { f64::NAN } else { sum / n as f64 },
            uncomputable: empty,
        })
        .collect())
}

fn compensator<T>(specs: Vec<ScalarSpec>, plan: &Plan) -> StreamCompensator<T> {
    let names = plan.fluxgates.iter().map(|(v, _)| v.clone()).collect();
    // No times are fed (runs are split by the caller), so the rate here sets nothing.
    StreamCompensator::new(specs, names, 1.0, Derivative::Central)
}

fn same_rows(path: &Path, rows: usize, expected: usize) -> Result<()> {
    if rows != expected {
        bail!(
            "{}: the file changed while it was read ({expected} rows, then {rows})",
            path.display()
        );
    }
    Ok(())
}

/// Pass 3: every row with the compensated columns, to `args.out` or standard output. Returns
/// per fit the number of empty compensated cells written.
fn write(
    args: &Args,
    mut reader: ChunkReader,
    plan: &Plan,
    scan: &Scan,
    specs: Vec<ScalarSpec>,
    names: &[String],
    progress: &ProgressBar,
) -> Result<Vec<usize>> {
    let headers = reader.headers().to_vec();
    let mut sink: Box<dyn ChunkSink> = match &args.out {
        None => Box::new(CsvSink::stdout(&headers, names)?),
        Some(path) if Format::from_path(path) == Format::Parquet => {
            let all: Vec<String> = headers.iter().chain(names).cloned().collect();
            Box::new(ParquetChunkWriter::create(path, &all)?)
        }
        Some(path) => Box::new(CsvSink::file(path, &headers, names)?),
    };
    let mut stream = compensator::<usize>(specs, plan);
    let mut feed = Feed::new(plan, scan);
    let mut empty = vec![0usize; names.len()];
    // The chunk before the current one waits for its last row, which the compensator holds
    // back until it sees the next row.
    let mut previous: Option<Pending> = None;
    let mut rows = 0;
    while let Some(chunk) = reader.next_chunk()? {
        progress.inc(chunk.len() as u64);
        let all = numbers_of(&chunk, &plan.read)?;
        let mut current = Pending::new(chunk, rows, names.len());
        for k in 0..current.chunk.len() {
            let gap = feed.load(&all, k);
            let mut emit = |o: Output<'_, usize>| place(o, previous.as_mut(), &mut current);
            if gap {
                stream.split(&mut emit);
            }
            stream.push(rows + k, Some(feed.sample()), Vec::new(), &mut emit);
        }
        rows += current.chunk.len();
        if let Some(done) = previous.take() {
            done.write(sink.as_mut(), &mut empty)?;
        }
        previous = Some(current);
    }
    if let Some(mut last) = previous.take() {
        stream.finish(|o| {
            let row = o.payload - last.first;
            for (column, v) in last.extra.iter_mut().zip(o.compensated) {
                column[row] = *v;
            }
        });
        last.write(sink.as_mut(), &mut empty)?;
    }
    same_rows(reader.path(), rows, scan.rows)?;
    sink.finish()?;
    Ok(empty)
}

/// The numbers of the columns at `positions` of `chunk`. Pass 1 found every bad cell, so an
/// error here means the file changed since.
fn numbers_of(chunk: &Table, positions: &[usize]) -> Result<Vec<Vec<f64>>> {
    positions
        .iter()
        .map(|&j| Ok(chunk.numeric_at(j)?))
        .collect()
}

/// A chunk whose compensated values are being filled in.
struct Pending {
    chunk: Table,
    first: usize,
    extra: Vec<Vec<f64>>,
}

impl Pending {
    fn new(chunk: Table, first: usize, fits: usize) -> Self {
        let extra = vec![vec![f64::NAN; chunk.len()]; fits];
        Self {
            chunk,
            first,
            extra,
        }
    }

    fn write(self, sink: &mut dyn ChunkSink, empty: &mut [usize]) -> Result<()> {
        for (n, column) in empty.iter_mut().zip(&self.extra) {
            *n += column.iter().filter(|v| !v.is_finite()).count();
        }
        let extra: Vec<&[f64]> = self.extra.iter().map(Vec::as_slice).collect();
        sink.write(&self.chunk, &extra)
    }
}

/// Puts an emitted result into the chunk its row belongs to.
fn place(o: Output<'_, usize>, previous: Option<&mut Pending>, current: &mut Pending) {
    let target = match previous {
        Some(p) if o.payload < current.first => p,
        _ => current,
    };
    let row = o.payload - target.first;
    for (column, v) in target.extra.iter_mut().zip(o.compensated) {
        column[row] = *v;
    }
}

/// Where pass 3 writes.
trait ChunkSink {
    fn write(&mut self, chunk: &Table, extra: &[&[f64]]) -> Result<()>;
    fn finish(self: Box<Self>) -> Result<()>;
}

struct CsvSink {
    writer: CsvChunkWriter<Box<dyn Write>>,
    /// The file written, or `None` for standard output.
    path: Option<std::path::PathBuf>,
}

impl CsvSink {
    fn stdout(headers: &[String], names: &[String]) -> Result<Self> {
        let out: Box<dyn Write> = Box::new(std::io::BufWriter::new(std::io::stdout().lock()));
        let writer =
            CsvChunkWriter::new(out, headers, names).context("writing to standard output")?;
        Ok(Self { writer, path: None })
    }

    fn file(path: &Path, headers: &[String], names: &[String]) -> Result<Self> {
        let fail = |source| IoError::Write {
            path: path.to_path_buf(),
            source,
        };
        let file = std::fs::File::create(path).map_err(fail)?;
        let out: Box<dyn Write> = Box::new(std::io::BufWriter::new(file));
        let writer = CsvChunkWriter::new(out, headers, names).map_err(fail)?;
        Ok(Self {
            writer,
            path: Some(path.to_path_buf()),
        })
    }

    fn fail(&self, source: std::io::Error) -> anyhow::Error {
        match &self.path {
            Some(path) => IoError::Write {
                path: path.clone(),
                source,
            }
            .into(),
            None => anyhow::Error::new(source).context("writing to standard output"),
        }
    }
}

impl ChunkSink for CsvSink {
    fn write(&mut self, chunk: &Table, extra: &[&[f64]]) -> Result<()> {
        self.writer.write(chunk, extra).map_err(|e| self.fail(e))
    }

    fn finish(self: Box<Self>) -> Result<()> {
        let path = self.path.clone();
        let fail = |source| match &path {
            Some(path) => anyhow::Error::from(IoError::Write {
                path: path.clone(),
                source,
            }),
            None => anyhow::Error::new(source).context("writing to standard output"),
        };
        let mut out = self.writer.finish().map_err(fail)?;
        out.flush().map_err(fail)
    }
}

impl ChunkSink for ParquetChunkWriter {
    fn write(&mut self, chunk: &Table, extra: &[&[f64]]) -> Result<()> {
        Ok(ParquetChunkWriter::write(self, chunk, extra)?)
    }

    fn finish(self: Box<Self>) -> Result<()> {
        Ok(ParquetChunkWriter::finish(*self)?)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn only_files_too_large_for_memory_need_chunks() {
        assert!(needs_bounded_memory(1 << 50, Format::Csv));
        assert!(needs_bounded_memory(1 << 47, Format::Parquet));
        if available_memory_bytes().is_some() {
            assert!(!needs_bounded_memory(1 << 20, Format::Csv));
        }
    }
}
