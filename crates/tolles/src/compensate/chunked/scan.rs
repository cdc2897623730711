//! Pass 1: which columns are read, and what reading the file whole would find in them.

use crate::error::{Error, Result};
use crate::model::ModelFile;
use crate::progress::Progress;
use tolles_core::fit::{check_flux_magnitude, FitError};
use tolles_core::model::vector::VectorSeries;
use tolles_core::signal::median::{MedianPass, MedianSearch};
use tolles_core::signal::segment::sampling_step_of;
use tolles_io::chunks::{ChunkReader, NumberSpill, DEFAULT_CHUNK_ROWS};
use tolles_io::format::Format;
use tolles_io::schema::{vector_columns, TIME_COLUMN};
use tolles_io::table::{find_column, Table};
use tolles_io::IoError;

/// Which columns are read, and where each fit's columns are in a chunk.
pub(super) struct Plan {
    /// Indices into the file's headers of the columns read in passes 1 and 2.
    pub read: Vec<usize>,
    pub fits: Vec<FitColumns>,
    /// Position of `tt` in a chunk, if the file has it.
    pub tt: Option<usize>,
    /// Distinct fluxgate prefixes, and per fluxgate the chunk positions of x, y, z (or the
    /// error looking one up, reported when its fit's turn comes).
    pub fluxgates: Vec<(String, [Result<usize, IoError>; 3])>,
}

/// Where one fit's columns are in a chunk.
pub(super) struct FitColumns {
    pub scalar: Result<usize, IoError>,
    /// Index into [`Plan::fluxgates`].
    pub fluxgate: usize,
    /// The design's extra channels, in its order.
    pub extras: Vec<Result<usize, IoError>>,
    /// The network's own channels, in its order.
    pub network: Vec<Result<usize, IoError>>,
}

impl Plan {
    /// The columns `model` uses in the file `reader` reads (every column when `every_column`,
    /// as Parquet output needs them all checked as numbers).
    pub fn new(reader: &ChunkReader, model: &ModelFile, every_column: bool) -> Self {
        let headers = reader.headers();
        // Raw channel names answer to tolles' names, as in a table read whole.
        let aliases = tolles_io::schema::aliases(headers);
        let mut read: Vec<usize> = match every_column {
            true => (0..headers.len()).collect(),
            false => Vec::new(),
        };
        let mut position = |name: &str| -> Result<usize, IoError> {
            let index = find_column(reader.path(), headers, name).or_else(|e| {
                aliases
                    .iter()
                    .find(|(alias, _)| alias.eq_ignore_ascii_case(name))
                    .map(|(_, k)| *k)
                    .ok_or(e)
            })?;
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
                    let axes = vector_columns(vector).map(|name| position(&name));
                    fluxgates.push((vector.clone(), axes));
                    fluxgates.len() - 1
                }
            };
            let extras = fit.fit.settings.design.extras.iter();
            let extras = extras.map(|spec| position(&spec.name)).collect();
            let network = crate::compensate::network_channels(fit).iter();
            let network = network.map(|name| position(name)).collect();
            fits.push(FitColumns {
                scalar,
                fluxgate,
                extras,
                network,
            });
        }
        let tt = position(TIME_COLUMN).ok();
        Self {
            read,
            fits,
            tt,
            fluxgates,
        }
    }

    /// When the file has none of the columns the model uses (nor time), the first fit's missing
    /// scalar, as the whole-file path reports it: reading no column at all would otherwise
    /// find no rows and call the file empty.
    pub fn nothing_to_read(&self) -> Option<IoError> {
        match self.read.is_empty() {
            true => self.fits.first()?.scalar.as_ref().err().map(clone_error),
            false => None,
        }
    }

    /// Positions (in a chunk of the columns read) of the columns the computation uses: the
    /// scalars, fluxgates, extra channels and time; the others are read only to be checked.
    pub fn used(&self) -> Vec<usize> {
        let scalars = self.fits.iter().filter_map(|f| f.scalar.as_ref().ok());
        let extras = self
            .fits
            .iter()
            .flat_map(|f| f.extras.iter().chain(&f.network).flatten());
        let axes = self.fluxgates.iter().flat_map(|(_, a)| a.iter().flatten());
        let mut used: Vec<usize> = (scalars.chain(axes).chain(extras).chain(&self.tt))
            .copied()
            .collect();
        used.sort_unstable();
        used.dedup();
        used
    }
}

/// What pass 1 found.
pub(super) struct Scan {
    pub rows: usize,
    /// Per column read, the first cell that is not a number.
    pub bad_cell: Vec<Option<IoError>>,
    /// Where time first steps back or repeats, and at how many places it does.
    pub steps_back: Option<(String, usize)>,
    /// Per fluxgate, the first implausible magnitude: (place, nT).
    pub bad_magnitude: Vec<Option<(String, f64)>>,
    /// The median step of the time column (s), exact: the gap threshold's unit.
    pub median_step: Option<f64>,
    /// The sampling interval of the time column (s), as
    /// [`tolles_core::signal::segment::sampling_step`] gives it.
    pub sampling_step: Option<f64>,
    /// The numbers used, kept for pass 2 when the file is text.
    pub spill: Option<NumberSpill>,
}

impl Scan {
    /// The first bad cell in the order reading the whole file as numbers meets it: column by
    /// column in file order.
    pub fn first_error_in_file_order(&self) -> Option<IoError> {
        self.bad_cell.iter().flatten().next().map(clone_error)
    }
}

/// Pass 1 over `reader` (the columns of `plan` only), counting rows on `progress`.
pub(super) fn scan(mut reader: ChunkReader, plan: &Plan, progress: &dyn Progress) -> Result<Scan> {
    let mut bad_cell: Vec<Option<IoError>> = (0..plan.read.len()).map(|_| None).collect();
    let mut bad_magnitude = vec![None; plan.fluxgates.len()];
    let mut time = TimeCheck::default();
    let mut median = MedianSearch::default();
    let mut steps = median.start_pass();
    let mut rows = 0;
    // Keeping the numbers spares pass 2 parsing the text again; Parquet decodes cheaply.
    let mut spill = match Format::from_path(reader.path()) {
        Format::Parquet => None,
        _ => Some(NumberSpill::new(plan.used().len()).map_err(temporary)?),
    };
    while let Some(chunk) = reader.next_chunk()? {
        progress.advance(chunk.len() as u64);
        let values = numbers(&chunk, &mut bad_cell);
        if let Some(spill) = &mut spill {
            let used: Vec<&[f64]> = plan.used().iter().map(|&p| values[p].as_slice()).collect();
            spill.push(&used).map_err(temporary)?;
        }
        if let Some(p) = plan.tt {
            time.check(&values[p], &mut steps, |k| reader.place_of(&chunk, k));
        }
        for (j, (_, axes)) in plan.fluxgates.iter().enumerate() {
            if bad_magnitude[j].is_none() {
                let flux = fluxgate(&values, axes, chunk.len());
                if let Err(FitError::FluxMagnitude {
                    index, magnitude, ..
                }) = check_flux_magnitude(&flux)
                {
                    bad_magnitude[j] = Some((reader.place_of(&chunk, index), magnitude));
                }
            }
        }
        rows += chunk.len();
    }
    median.finish_pass(steps);
    if let Some(p) = plan.tt {
        while median.needs_pass() {
            median = more_median_passes(median, plan.read[p], &reader)?;
        }
    }
    Ok(Scan {
        rows,
        bad_cell,
        steps_back: time.first_back.map(|place| (place, time.places_back)),
        bad_magnitude,
        median_step: median.median(),
        sampling_step: (median.median()).map(|m| sampling_step_of(median.few_values(), m)),
        spill,
    })
}

/// The time column followed across chunks: its steps for the median, and where it steps back
/// or repeats (a file sorted by line; its runs split there).
struct TimeCheck {
    previous: f64,
    last_finite: f64,
    first_back: Option<String>,
    places_back: usize,
}

impl Default for TimeCheck {
    fn default() -> Self {
        Self {
            previous: f64::NAN,
            last_finite: f64::NEG_INFINITY,
            first_back: None,
            places_back: 0,
        }
    }
}

impl TimeCheck {
    /// Follows one chunk's times `tt` (s); `place` names row `k` of the chunk.
    fn check(&mut self, tt: &[f64], steps: &mut MedianPass, place: impl Fn(usize) -> String) {
        for (k, &t) in tt.iter().enumerate() {
            push_step(steps, self.previous, t);
            self.previous = t;
            if !t.is_finite() {
                continue;
            }
            if t <= self.last_finite {
                self.places_back += 1;
                self.first_back.get_or_insert_with(|| place(k));
            }
            self.last_finite = t;
        }
    }
}

/// Counts the step from time `before` to `t` (s) as the batch median does: finite and positive.
fn push_step(pass: &mut MedianPass, before: f64, t: f64) {
    let d = t - before;
    if d.is_finite() && d > 0.0 {
        pass.push(d);
    }
}

/// Another pass over the time column alone (`tt`, an index into the file's headers), for a
/// median that one pass could not settle.
fn more_median_passes(
    mut median: MedianSearch,
    tt: usize,
    reader: &ChunkReader,
) -> Result<MedianSearch> {
    let format = Format::from_path(reader.path());
    let mut again = ChunkReader::open(reader.path(), format, DEFAULT_CHUNK_ROWS)?.only(vec![tt]);
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

/// One chunk's columns as numbers; a column with a bad cell is all NaN here (its error is kept
/// in `bad_cell` and reported when its turn comes).
pub(super) fn numbers(chunk: &Table, bad_cell: &mut [Option<IoError>]) -> Vec<Vec<f64>> {
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

/// The fluxgate at chunk positions `axes` of `values` (nT); a missing axis is NaN.
fn fluxgate(values: &[Vec<f64>], axes: &[Result<usize, IoError>; 3], len: usize) -> VectorSeries {
    let axis = |a: usize| match &axes[a] {
        Ok(p) => values[*p].clone(),
        Err(_) => vec![f64::NAN; len],
    };
    VectorSeries::new(axis(0), axis(1), axis(2))
}

/// A failure of the anonymous temporary file pass 1 keeps its numbers in.
pub(super) fn temporary(source: std::io::Error) -> Error {
    Error::TemporaryFile { source }
}

/// The errors pass 1 keeps are returned once, when their turn comes; this copies one to return
/// (an [`IoError`] cannot be cloned, as some variants hold an `std::io::Error`).
pub(super) fn clone_error(e: &IoError) -> IoError {
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
        IoError::MissingColumn { path, column, near } => IoError::MissingColumn {
            path: path.clone(),
            column: column.clone(),
            near: near.clone(),
        },
        other => IoError::Invalid {
            path: std::path::PathBuf::new(),
            message: other.to_string(),
        },
    }
}
