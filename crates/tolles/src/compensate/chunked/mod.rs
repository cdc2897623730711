//! Compensating a survey file in bounded memory: the survey is read a chunk of rows at a time,
//! in up to three passes, and the output is the same text (CSV) or the same values (Parquet),
//! with the same warnings and errors, as reading it whole gives.
//!
//! 1. **Scan** ([`scan`]) the columns the fits use (every column when writing Parquet, which
//!    holds numbers only) for what reading the file whole finds: the first bad cell of each
//!    column, where time steps back, an implausible fluxgate magnitude, and the exact
//!    median time step (sample rate and gap threshold). [`check`] reports them in the order the
//!    whole-file path meets them.
//! 2. **Level** ([`level`]): each fit's correction `A·β`, computed a chunk at a time by the
//!    compensator the whole-file path calls with one chunk
//!    (`tolles_core::compensate::chunk`; [`field`]), and its mean over the file: the level the batch computation keeps.
//!    For text files pass 1 keeps the numbers it read in an anonymous temporary file (8 bytes a
//!    value), so the text is parsed twice, not three times. With the model's level
//!    ([`LevelChoice::Model`]) this pass is skipped, unless an error is coming: the whole-file
//!    path counts the rows without a result before it fails, so this path does too.
//! 3. **Write** ([`write`](mod@write)) every row with the compensated columns, `scalar − (A·β − level)`.
//!
//! Memory holds two chunks (rows per chunk as requested, default
//! [`tolles_io::chunks::DEFAULT_CHUNK_ROWS`]; a CSV chunk at most 1 MiB of lines) and the few
//! rows a fluxgate lag or an extra channel's shift reads ahead, whatever the length of the file.

mod check;
mod field;
mod level;
mod scan;
mod write;

use super::{FileOutcome, FileRequest, LevelChoice, Memory};
use crate::error::{Error, Result};
use crate::model::ModelFile;
use crate::progress::{Progress, Stage};
use crate::warning::Warning;
use check::ReadyFit;
use level::{Level, Numbers};
use std::io::Write;
use std::path::Path;
use tolles_io::chunks::{ChunkReader, DEFAULT_CHUNK_ROWS};
use tolles_io::format::Format;
use tolles_io::schema::output_names;

/// True when [`super::compensate_file`] reads the survey of `request` in chunks: CSV, XYZ or
/// Parquet input that is a regular file (it is read several times), CSV or Parquet output that
/// is not the input itself, one fluxgate per fit (extra channels and a lag included), no row
/// selection, and the memory policy asks
/// for it: [`Memory::Bounded`], rows per chunk given (unless [`Memory::Whole`]), or with
/// [`Memory::Auto`] a file too large to read whole comfortably ([`needs_bounded_memory`]).
pub fn reads_in_chunks(model: &ModelFile, request: &FileRequest) -> bool {
    let format = Format::from_path(&request.survey);
    // Standard input (`-`) is read once, so whole.
    let size = std::fs::metadata(&request.survey)
        .ok()
        .filter(|m| m.is_file() && !tolles_io::stdin::is_stdin(&request.survey))
        .map(|m| m.len());
    let wanted = match (request.memory, request.chunk_rows) {
        (Memory::Whole, _) => false,
        (Memory::Bounded, _) | (Memory::Auto, Some(_)) => true,
        (Memory::Auto, None) => size.is_some_and(|s| needs_bounded_memory(s, format)),
    };
    let output_streams = request.out.as_deref().is_none_or(|out| {
        matches!(Format::from_path(out), Format::Csv | Format::Parquet)
            && !same_file(&request.survey, out)
    });
    wanted
        && ChunkReader::reads(format)
        && size.is_some()
        && output_streams
        // Several fluxgates per fit are read whole.
        && model.fits.iter().all(|f| f.vectors.len() == 1)
        && request.selection.is_empty()
        // Each row's standard error and flag are computed from the whole flight.
        && !request.compensate.uncertainty
}

/// Whether reading a survey of `bytes` in `format` whole could take more than half of the
/// memory available now. Reading whole is faster (the text is parsed once, not twice) but holds
/// every cell: measured, about 3.4 bytes of memory per byte of CSV and 11 per byte of Parquet
/// (compressed). Without `/proc/meminfo` (not Linux) memory is assumed short.
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

/// Compensates the survey of `request` with `model` in bounded memory (see the module
/// documentation), to `request.out` or as CSV to `writer`. Progress: the rows of pass 1 as
/// [`Stage::Checking`], then the rows of the computing passes as [`Stage::Compensating`].
pub(super) fn compensate_file(
    model: &ModelFile,
    request: &FileRequest,
    writer: &mut dyn Write,
    progress: &dyn Progress,
    warnings: &mut Vec<Warning>,
) -> Result<FileOutcome> {
    progress.begin(Stage::Checking, None);
    let result = run(model, request, writer, progress, warnings);
    progress.finish();
    result
}

/// Renames the columns of `reader` `(old, new)` in turn, as [`crate::read::rename`] renames a
/// table read whole (the same errors).
fn rename(reader: &mut ChunkReader, renames: &[(String, String)]) -> Result<()> {
    for (old, new) in renames {
        reader.rename(old, new).map_err(|source| Error::Rename {
            old: old.clone(),
            new: new.clone(),
            source: Box::new(source),
        })?;
    }
    Ok(())
}

/// Rows per chunk: as requested, else the default.
fn chunk_rows(requested: Option<usize>) -> Result<usize> {
    match requested {
        Some(0) => Err(Error::NoChunkRows),
        Some(rows) => Ok(rows),
        None => Ok(DEFAULT_CHUNK_ROWS),
    }
}

fn run(
    model: &ModelFile,
    request: &FileRequest,
    writer: &mut dyn Write,
    progress: &dyn Progress,
    warnings: &mut Vec<Warning>,
) -> Result<FileOutcome> {
    let mut file = Scanned::new(model, request, progress, warnings)?;
    // The fits before one that fails are computed and reported, as the whole-file path does.
    let (fits, failure) = check::check_in_order(
        &request.survey,
        &file.plan,
        &file.scan,
        model,
        request.compensate.fs_hz,
    );
    let failure = failure.or_else(|| file.numeric_error());
    let fixed = request.compensate.level == LevelChoice::Model;
    let level_pass = !fits.is_empty() && (!fixed || failure.is_some());
    let passes = if level_pass { 2 } else { 1 };
    progress.begin(Stage::Compensating, Some(passes * file.scan.rows as u64));
    let levels = match level_pass {
        true => Some(file.levels(&fits, progress)?),
        false => None,
    };
    let report = Report {
        survey: &request.survey,
        rows: file.scan.rows,
        headers: &file.headers,
        steps_back: file.scan.steps_back.as_ref(),
    };
    if let Some(levels) = &levels {
        let counts: Vec<usize> = levels.iter().map(|l| l.uncomputable).collect();
        let outside: Vec<usize> = levels.iter().map(|l| l.outside).collect();
        report.fits(&fits, (&counts, &outside), warnings);
    }
    if let Some(e) = failure {
        return Err(e);
    }
    let levels_nt = levels_nt(&fits, levels.as_deref(), fixed);
    let names: Vec<String> = report.names(&fits).into_iter().map(|n| n.0).collect();
    let target = write::Target {
        out: request.out.as_deref(),
        writer,
    };
    let (plan, scan) = (&file.plan, &file.scan);
    let reader = file.open()?.parsing(plan.read.clone());
    let computing = (fits.as_slice(), levels_nt.as_slice());
    let (empty, outside) = write::write(reader, target, (plan, scan), computing, &names, progress)?;
    match &levels {
        // Only a value beyond f64's range makes these differ from pass 2's counts.
        Some(levels) => report.changed_counts(&fits, levels, &empty, warnings),
        None => report.fits(&fits, (&empty, &outside), warnings),
    }
    Ok(FileOutcome {
        selected: None,
        rows: file.scan.rows,
    })
}

/// The survey after pass 1: what it holds, and how to read it again.
struct Scanned<'r> {
    request: &'r FileRequest,
    rows_per_chunk: usize,
    /// Every column name of the file.
    headers: Vec<String>,
    plan: scan::Plan,
    scan: scan::Scan,
}

impl<'r> Scanned<'r> {
    /// Pass 1 over the survey of `request` for the fits of `model`; what the reader leaves out
    /// goes to `warnings`.
    fn new(
        model: &ModelFile,
        request: &'r FileRequest,
        progress: &dyn Progress,
        warnings: &mut Vec<Warning>,
    ) -> Result<Self> {
        let rows_per_chunk = chunk_rows(request.chunk_rows)?;
        let survey = &request.survey;
        let mut reader = ChunkReader::open(survey, Format::from_path(survey), rows_per_chunk)?;
        warnings.extend(reader.notes().iter().map(|note| Warning::ReaderNote {
            path: survey.clone(),
            note: note.clone(),
        }));
        rename(&mut reader, &request.renames)?;
        let aliases = tolles_io::schema::aliases(reader.headers());
        if !aliases.is_empty() {
            warnings.push(Warning::ColumnsAliased {
                path: survey.clone(),
                aliases: aliases
                    .iter()
                    .map(|(name, k)| (reader.headers()[*k].clone(), name.clone()))
                    .collect(),
            });
        }
        let plan = scan::Plan::new(&reader, model, numeric_output(request));
        if let Some(missing) = plan.nothing_to_read() {
            return Err(missing.into());
        }
        let headers = reader.headers().to_vec();
        let scan = scan::scan(reader.only(plan.read.clone()), &plan, progress)?;
        Ok(Self {
            request,
            rows_per_chunk,
            headers,
            plan,
            scan,
        })
    }

    /// The survey opened again from its first row.
    fn open(&self) -> Result<ChunkReader> {
        let survey = &self.request.survey;
        let mut reader = ChunkReader::open(survey, Format::from_path(survey), self.rows_per_chunk)?;
        rename(&mut reader, &self.request.renames)?;
        Ok(reader)
    }

    /// For Parquet output, which holds numbers only, the first cell of the file that is not one.
    fn numeric_error(&self) -> Option<Error> {
        match numeric_output(self.request) {
            true => self.scan.first_error_in_file_order().map(Error::from),
            false => None,
        }
    }

    /// Pass 2 for `fits`, from the numbers pass 1 kept or else from the file.
    fn levels(&mut self, fits: &[ReadyFit], progress: &dyn Progress) -> Result<Vec<Level>> {
        let numbers = match self.scan.spill.take() {
            Some(spill) => {
                let spilled = spill.into_reader(self.rows_per_chunk);
                Numbers::Spill(spilled.map_err(scan::temporary)?)
            }
            None => Numbers::File(self.open()?.only(self.plan.read.clone())),
        };
        level::level(numbers, &self.plan, &self.scan, fits, progress)
    }
}

/// Whether the output is Parquet, which holds numbers only.
fn numeric_output(request: &FileRequest) -> bool {
    request
        .out
        .as_deref()
        .is_some_and(|out| Format::from_path(out) == Format::Parquet)
}

/// The level each fit subtracts (nT): the model's, or its mean over the file from pass 2.
fn levels_nt(fits: &[ReadyFit], levels: Option<&[Level]>, fixed: bool) -> Vec<f64> {
    match (fixed, levels) {
        (false, Some(levels)) => levels.iter().map(|l| l.level_nt).collect(),
        _ => fits.iter().map(|f| f.model_level_nt).collect(),
    }
}

/// Warnings about the compensated columns, in the whole-file path's order.
struct Report<'a> {
    survey: &'a Path,
    rows: usize,
    headers: &'a [String],
    /// Where time first steps back or repeats, and at how many places.
    steps_back: Option<&'a (String, usize)>,
}

impl Report<'_> {
    /// Where time steps back (before the first fit's warnings); then per fit: a given sample
    /// rate far from the time column's, its verdict when not good,
    /// its rows `outside` what its calibration flew, its `uncomputable` rows, and its column
    /// renamed.
    fn fits(
        &self,
        fits: &[ReadyFit],
        (uncomputable, outside): (&[usize], &[usize]),
        warnings: &mut Vec<Warning>,
    ) {
        let names = self.names(fits);
        if let (Some((place, places)), false) = (self.steps_back, fits.is_empty()) {
            warnings.push(Warning::TimeStepsBack {
                path: self.survey.to_path_buf(),
                place: place.clone(),
                places: *places,
                run_on: false,
            });
        }
        let counts = uncomputable.iter().zip(outside);
        for ((fit, (&rows, &out)), (name, renamed)) in fits.iter().zip(counts).zip(names) {
            warnings.extend(fit.rate_warning.clone());
            warnings.extend(fit.verdict.clone());
            warnings.extend(Warning::extrapolated(
                self.survey,
                out,
                self.rows,
                &fit.output,
            ));
            self.uncomputable(fit, rows, warnings);
            if renamed {
                warnings.push(Warning::OutputRenamed {
                    path: self.survey.to_path_buf(),
                    wanted: fit.output.clone(),
                    renamed: name,
                });
            }
        }
    }

    /// The names the fits' columns are written under, and whether each had to be renamed.
    fn names(&self, fits: &[ReadyFit]) -> Vec<(String, bool)> {
        let wanted: Vec<&str> = fits.iter().map(|f| f.output.as_str()).collect();
        output_names(self.headers, &wanted)
    }

    /// The counts of empty cells written that differ from those pass 2 reported.
    fn changed_counts(
        &self,
        fits: &[ReadyFit],
        levels: &[Level],
        empty: &[usize],
        warnings: &mut Vec<Warning>,
    ) {
        for ((fit, level), &rows) in fits.iter().zip(levels).zip(empty) {
            if rows != level.uncomputable {
                self.uncomputable(fit, rows, warnings);
            }
        }
    }

    fn uncomputable(&self, fit: &ReadyFit, rows: usize, warnings: &mut Vec<Warning>) {
        warnings.extend(Warning::uncomputable(
            self.survey,
            rows,
            self.rows,
            &fit.output,
        ));
    }
}

#[cfg(test)]
mod tests;
