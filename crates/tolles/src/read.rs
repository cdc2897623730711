//! Reading flights: any format tolles knows, the rows a selection keeps, and the columns one
//! scalar's model needs, with the checks every workflow makes (time increases, a sample rate).

use crate::error::{Error, Result};
use crate::progress::{CountingReader, Progress, Stage};
// Defined in its own module, which warnings also use; public here as before.
pub use crate::selection::Selection;
use crate::warning::Warning;
use std::path::Path;
use tolles_core::fit::FitError;
use tolles_core::model::extra::ExtraChannel;
use tolles_core::model::vector::VectorSeries;
use tolles_core::signal::segment::{first_non_increasing, run_on, sampling_step};
use tolles_io::format::Format;
use tolles_io::schema::{SAMPLE_INTERVAL, TIME_COLUMN};
use tolles_io::select::RowSelection;
use tolles_io::table::Table;
use tolles_io::IoError;

/// A flight table as read, with the rows a selection kept.
#[derive(Debug, Clone)]
pub struct FlightData {
    /// The kept rows; every row names its own line of the file in messages.
    pub table: Table,
    /// What a selection kept, when one was asked for.
    pub selected: Option<Selection>,
}

/// Reads the flight at `path` in the format its extension names (CSV, XYZ, GDF, HDF5 or
/// Parquet; `-` is standard input, in the format its content shows) and keeps the rows `selection` selects (all when it is empty). Text files report
/// their bytes read to `progress`; what the reader left out, and what the selection kept, are
/// added to `warnings`.
pub fn read(
    path: &Path,
    selection: &RowSelection,
    progress: &dyn Progress,
    warnings: &mut Vec<Warning>,
) -> Result<FlightData> {
    read_renamed(path, selection, &[], progress, warnings)
}

/// [`read`], with columns renamed `(old, new)` right after reading (before the selection and
/// the aliases; see [`rename`]).
pub fn read_renamed(
    path: &Path,
    selection: &RowSelection,
    renames: &[(String, String)],
    progress: &dyn Progress,
    warnings: &mut Vec<Warning>,
) -> Result<FlightData> {
    read_parsing(path, selection, renames, &[], progress, warnings)
}

/// [`read_renamed`], with the columns `needed` (tolles' names, as asked for after the renames
/// and aliases) parsed while the rows of a CSV file are found: the one pass over its text a
/// workflow needs, instead of one to find the rows and another for the numbers.
pub fn read_parsing(
    path: &Path,
    selection: &RowSelection,
    renames: &[(String, String)],
    needed: &[String],
    progress: &dyn Progress,
    warnings: &mut Vec<Warning>,
) -> Result<FlightData> {
    let mut table = read_raw(path, renames, needed, progress, warnings)?;
    rename(&mut table, renames)?;
    let table = with_aliases(table, warnings);
    let (table, selected) = select(table, selection)?;
    warnings.extend(selected.clone().map(|selection| Warning::RowsSelected {
        path: table.path().to_path_buf(),
        selection,
    }));
    Ok(FlightData { table, selected })
}

/// Reads a flight table whole; what the reader left out of it is added to `warnings`. Raw
/// channel names (SGL's `AZIMUTH`, `UNCOMPMAG1`, `FLUXA_X`, …) answer to tolles' names when
/// the table has no such columns ([`tolles_io::schema::aliases`]); which did is added to
/// `warnings`.
pub fn read_table(
    path: &Path,
    progress: &dyn Progress,
    warnings: &mut Vec<Warning>,
) -> Result<Table> {
    read_table_renamed(path, &[], progress, warnings)
}

/// [`read_table`], with columns renamed `(old, new)` right after reading (see [`rename`]).
pub fn read_table_renamed(
    path: &Path,
    renames: &[(String, String)],
    progress: &dyn Progress,
    warnings: &mut Vec<Warning>,
) -> Result<Table> {
    let mut table = read_raw(path, renames, &[], progress, warnings)?;
    rename(&mut table, renames)?;
    Ok(with_aliases(table, warnings))
}

/// Renames columns of `table`, each `(old, new)` in turn: `old` is found as any column is
/// (exactly, or by case when only one matches); an error names an unknown `old` (with near
/// names) or a `new` another column already has.
pub fn rename(table: &mut Table, renames: &[(String, String)]) -> Result<()> {
    for (old, new) in renames {
        table.rename(old, new).map_err(|source| Error::Rename {
            old: old.clone(),
            new: new.clone(),
            source: Box::new(source),
        })?;
    }
    Ok(())
}

/// `table` answering to tolles' names for the raw channels it has
/// ([`tolles_io::schema::aliases`]); a warning lists them, when there are any.
pub fn with_aliases(table: Table, warnings: &mut Vec<Warning>) -> Table {
    let aliases = tolles_io::schema::aliases(table.headers());
    let table = match aliases.is_empty() {
        true => table,
        false => {
            warnings.push(Warning::ColumnsAliased {
                path: table.path().to_path_buf(),
                aliases: aliases
                    .iter()
                    .map(|(name, k)| (table.headers()[*k].clone(), name.clone()))
                    .collect(),
            });
            table.with_aliases(aliases)
        }
    };
    warnings.extend(time_unit_warning(&table));
    table
}

/// What the file's declared time unit does to its time column: converted to seconds, or not
/// understood.
fn time_unit_warning(table: &Table) -> Option<Warning> {
    let note = |note: String| Warning::ReaderNote {
        path: table.path().to_path_buf(),
        note,
    };
    if let Some(text) = table.time_unit_note() {
        return Some(note(text));
    }
    let unit = table.unit(TIME_COLUMN)?;
    let seconds = tolles_io::schema::seconds_per(unit).filter(|s| *s != 1.0)?;
    Some(note(format!(
        "time is declared in {unit:?}: read as seconds ({seconds} s each)"
    )))
}

/// Reads a flight table as the file has it; a CSV file's columns `needed` (see
/// [`read_parsing`]) are parsed while it is read.
fn read_raw(
    path: &Path,
    renames: &[(String, String)],
    needed: &[String],
    progress: &dyn Progress,
    warnings: &mut Vec<Warning>,
) -> Result<Table> {
    let format = Format::from_path(path);
    let table = match format {
        _ if tolles_io::stdin::is_stdin(path) => Table::read(path, None)?,
        Format::Csv => match read_csv_raw(path, renames, needed, progress)? {
            Some(table) => table,
            None => read_text(path, format, progress)?,
        },
        Format::Xyz => read_text(path, format, progress)?,
        other => Table::read(path, Some(other))?,
    };
    warnings.extend(table.notes().iter().map(|note| Warning::ReaderNote {
        path: table.path().to_path_buf(),
        note: note.clone(),
    }));
    if !table.side_columns().is_empty() {
        warnings.push(Warning::SideColumns {
            path: path.to_path_buf(),
            rows: table.len(),
            columns: table
                .side_columns()
                .iter()
                .map(|c| (c.name.clone(), c.values.len()))
                .collect(),
        });
    }
    Ok(table)
}

/// A CSV file left in its bytes and parsed on demand (see [`tolles_io::rawcsv`]), or `None`
/// when the general reader must take it. The whole file counts as read at once: the rows are
/// found on every core together.
fn read_csv_raw(
    path: &Path,
    renames: &[(String, String)],
    needed: &[String],
    progress: &dyn Progress,
) -> Result<Option<Table>> {
    let size = std::fs::metadata(path).map_or(0, |m| m.len());
    progress.begin(Stage::Reading, Some(size));
    let wanted =
        |headers: &[String]| tolles_io::table::indices_after_renames(headers, renames, needed);
    let table = Table::csv().parsing(&wanted).path_in_place(path);
    progress.advance(size);
    progress.finish();
    Ok(table?)
}

/// A CSV or XYZ file read cell by cell, its bytes reported to `progress` as they are read.
fn read_text(path: &Path, format: Format, progress: &dyn Progress) -> Result<Table> {
    let file = std::fs::File::open(path).map_err(|source| IoError::Open {
        path: path.to_path_buf(),
        source,
    })?;
    let size = file.metadata().map_or(0, |m| m.len());
    progress.begin(Stage::Reading, Some(size));
    let counted = CountingReader {
        inner: file,
        progress,
    };
    let reader = std::io::BufReader::new(counted);
    let table = match format {
        Format::Xyz => tolles_io::xyz::from_reader(reader, path),
        _ => Table::csv().reader(reader, path),
    };
    progress.finish();
    Ok(table?)
}

/// The rows of `table` that `selection` keeps (all of it when the selection is empty).
pub fn select(table: Table, selection: &RowSelection) -> Result<(Table, Option<Selection>)> {
    if selection.is_empty() {
        return Ok((table, None));
    }
    let selected = selection.apply(&table)?;
    let summary = Selection {
        summary: selected.to_string(),
        left_out: table.len() - selected.table.len(),
    };
    Ok((selected.table, Some(summary)))
}

/// The names of the columns [`Flight::from_table`] and [`Flight::with_extras`] read for
/// `scalar`, the fluxgates `vectors` and the extra channels `extras`, time included: what a
/// workflow asks [`read_parsing`] to parse as it reads.
pub fn flight_columns(scalar: &str, vectors: &[String], extras: &[ExtraChannel]) -> Vec<String> {
    let mut names = vec![scalar.to_string(), TIME_COLUMN.to_string()];
    names.extend(
        vectors
            .iter()
            .flat_map(|v| tolles_io::schema::vector_columns(v)),
    );
    names.extend(extras.iter().map(|e| e.name.clone()));
    names
}

/// The columns of a flight table that one scalar's model needs.
#[derive(Debug, Clone)]
pub struct Flight<'t> {
    /// The table they come from.
    pub table: &'t Table,
    /// The scalar (nT).
    pub scalar: Vec<f64>,
    /// The fluxgates (nT, body frame FRD), one per name in `vectors`.
    pub flux: Vec<VectorSeries>,
    /// The fluxgates' column prefixes.
    pub vectors: Vec<String>,
    /// Time (s), when the table has a time column; it may step back (see `time_steps_back`).
    pub tt: Option<Vec<f64>>,
    /// Where time steps back or repeats, for the workflow to warn of once.
    pub time_steps_back: Option<Warning>,
    /// Extra channels (e.g. currents) as read, one per spec in `extra_specs`.
    pub extras: Vec<Vec<f64>>,
    /// The extra channels' columns and conditioning.
    pub extra_specs: Vec<ExtraChannel>,
}

impl<'t> Flight<'t> {
    /// The columns `scalar` and `V_x/_y/_z` for every V in `vectors`, and the time column.
    /// A vector is a prefix (`flux_a`) or three columns `X:Y:Z`
    /// ([`tolles_io::schema::vector_columns`]).
    pub fn from_table(table: &'t Table, scalar: &str, vectors: &[String]) -> Result<Self> {
        for spec in vectors {
            if let Some(reason) = tolles_io::schema::vector_spec_error(spec) {
                return Err(Error::VectorSpec {
                    spec: spec.clone(),
                    reason,
                });
            }
        }
        // One pass over the file's text for every column, when it is left in the file's bytes.
        let names = flight_columns(scalar, vectors, &[]);
        let names: Vec<&str> = names.iter().map(String::as_str).collect();
        let mut parsed = table.parse_together(&names);
        let scalar = parsed.numeric(scalar)?;
        let flux = vectors
            .iter()
            .map(|v| parsed.vector(v).map(VectorSeries::from))
            .collect::<std::result::Result<Vec<_>, _>>()?;
        // Time may step back (a file sorted by line): the runs split there, as at a gap.
        let tt = match table.has(TIME_COLUMN) {
            true => Some(parsed.numeric(TIME_COLUMN)?),
            false => None,
        };
        let places = tt.as_deref().map(non_increasing_places).unwrap_or_default();
        Ok(Self {
            table,
            scalar,
            flux,
            vectors: vectors.to_vec(),
            time_steps_back: steps_back(table, &places, false),
            tt,
            extras: Vec::new(),
            extra_specs: Vec::new(),
        })
    }

    /// The same flight with the extra channels `specs` read from its table (conditioned later,
    /// by [`Flight::lagged_inputs`], which knows the sample rate).
    pub fn with_extras(mut self, specs: &[ExtraChannel]) -> Result<Self> {
        self.extras = self.columns(specs.iter().map(|spec| spec.name.as_str()))?;
        self.extra_specs = specs.to_vec();
        Ok(self)
    }

    /// The flight with only the extra channels named in `kept`: what a fit that dropped some of
    /// its `--extra` channels reads, so its design and its inputs agree. The flight itself
    /// when it keeps them all (no copy of its columns).
    pub fn keeping_extras(&self, kept: &[ExtraChannel]) -> std::borrow::Cow<'_, Self> {
        let keep = |spec: &ExtraChannel| kept.iter().any(|k| k.name == spec.name);
        if self.extra_specs.iter().all(keep) {
            return std::borrow::Cow::Borrowed(self);
        }
        let mut view = self.clone();
        view.extras = (self.extras.iter().zip(&self.extra_specs))
            .filter(|(_, spec)| keep(spec))
            .map(|(column, _)| column.clone())
            .collect();
        view.extra_specs.retain(keep);
        std::borrow::Cow::Owned(view)
    }

    /// The columns `names` of the flight's table, as numbers (their units); the first that
    /// is missing or not numeric is the error.
    pub fn columns<'n>(&self, names: impl IntoIterator<Item = &'n str>) -> Result<Vec<Vec<f64>>> {
        let columns = names.into_iter().map(|name| self.table.numeric(name));
        Ok(columns.collect::<std::result::Result<_, _>>()?)
    }

    /// The fluxgates as they read `lag_s` seconds later (see `tolles_core::fit::lag::shifted`),
    /// the first less `offset` (nT, see `Fit::flux_offset_nt`), with the extra channels
    /// low-passed and lagged as their specs say ([`ExtraChannel::condition`]), at sample rate
    /// `fs_hz` (Hz): what fit and compensation use.
    pub fn lagged_inputs(
        &self,
        lag_s: f64,
        offset: Option<[f64; 3]>,
        fs_hz: f64,
    ) -> tolles_core::model::vector::SlicedInputs {
        let mut series: Vec<_> = (self.flux.iter())
            .map(|f| tolles_core::fit::lag::shifted(f, lag_s, fs_hz))
            .collect();
        if let (Some(offset), Some(first)) = (offset, series.first_mut()) {
            first.remove_offset(offset);
        }
        tolles_core::model::vector::SlicedInputs {
            series,
            extras: self
                .extras
                .iter()
                .zip(&self.extra_specs)
                .map(|(raw, spec)| spec.condition(raw, fs_hz))
                .collect(),
        }
    }

    /// `work` given the inputs of [`Flight::lagged_inputs`]; without a lag, an offset or extra
    /// channels to condition, the flight's own columns (no copy: a 10⁷-sample fluxgate is
    /// 240 MB).
    pub fn with_inputs<R>(
        &self,
        lag_s: f64,
        offset: Option<[f64; 3]>,
        fs_hz: f64,
        work: impl FnOnce(tolles_core::model::vector::Fluxgates) -> R,
    ) -> R {
        if lag_s == 0.0 && offset.is_none() && self.extras.is_empty() {
            work(self.flux.as_slice().into())
        } else {
            work((&self.lagged_inputs(lag_s, offset, fs_hz)).into())
        }
    }

    /// The sample rate (Hz): `fs_hz` if given, else from the time column or the file's `dt`.
    pub fn sample_rate(&self, fs_hz: Option<f64>) -> Result<(f64, Option<Warning>)> {
        sample_rate(self.table, self.tt.as_deref(), fs_hz)
    }

    /// A core fit error with the file, line and column names it needs to be fixed.
    pub fn explain(&self, error: FitError, scalar: &str) -> Error {
        let path = self.table.path().to_path_buf();
        match error {
            FitError::FluxMagnitude {
                fluxgate,
                index,
                magnitude,
            } => Error::FluxMagnitude {
                path,
                place: self.table.place_of(index),
                vector: self.vectors[fluxgate].clone(),
                magnitude,
            },
            FitError::NothingUsable(what) => {
                let column = match what.strip_prefix("fluxgate component ") {
                    Some(axis) => {
                        let columns = tolles_io::schema::vector_columns(&self.vectors[0]);
                        let k = ["x", "y", "z"].iter().position(|a| *a == axis);
                        match k {
                            Some(k) => columns[k].clone(),
                            None => format!("{}_{axis}", self.vectors[0]),
                        }
                    }
                    None if what == "the scalar" => scalar.to_string(),
                    None => {
                        return Error::Fit {
                            path,
                            cause: FitError::NothingUsable(what),
                        }
                    }
                };
                Error::NoUsableRow { path, column }
            }
            FitError::ConstantScalar => Error::ConstantScalar {
                path,
                scalar: scalar.to_string(),
            },
            FitError::ConstantFlux => Error::ConstantFlux {
                path,
                vector: self.vectors[0].clone(),
            },
            cause @ FitError::TooFewSamples { .. } => match self.sparsest_extra() {
                Some((name, present)) => Error::Invalid(format!(
                    "{}: --extra {name} has a value in only {present} of {} rows, and a fit uses only rows where every extra channel has one: {cause}; leave {name} out, or fill its gaps",
                    path.display(),
                    self.scalar_len(),
                )),
                None => Error::Fit { path, cause },
            },
            cause => Error::Fit { path, cause },
        }
    }

    /// The extra channel with the fewest finite values and its count of them, when it is
    /// missing on at least half of the rows: the likely reason a fit found too few samples.
    fn sparsest_extra(&self) -> Option<(String, usize)> {
        let rows = self.scalar_len();
        (self.extra_specs.iter().zip(&self.extras))
            .map(|(spec, column)| {
                let present = column.iter().filter(|v| v.is_finite()).count();
                (spec.name.clone(), present)
            })
            .filter(|(_, present)| 2 * present <= rows)
            .min_by_key(|(_, present)| *present)
    }

    /// Rows of the flight (the fluxgate's length: the scalar may have been taken by a fit).
    fn scalar_len(&self) -> usize {
        self.flux.first().map_or(self.scalar.len(), |f| f.x.len())
    }
}

/// Makes the time column of `table` increase where the file's steps back or repeats (a survey
/// file sorted by line, a second day), as [`tolles_core::signal::segment::run_on`] does, so a
/// report can filter and plot the whole file; filters restart at each join. Returns a warning
/// naming the first place moved, or `None` when time already increased (or there is none).
pub fn run_time_on(table: &mut Table) -> Result<Option<Warning>> {
    let (tt, warning) = time_column(table)?;
    if let (Some(tt), Some(_)) = (tt, &warning) {
        table.set_numeric(TIME_COLUMN, tt)?;
    }
    Ok(warning)
}

/// The time column of `table` (s), if it has one, run on where it steps back or repeats
/// ([`tolles_core::signal::segment::run_on`]), with the warning saying where.
pub fn time_column(table: &Table) -> Result<(Option<Vec<f64>>, Option<Warning>)> {
    if !table.has(TIME_COLUMN) {
        return Ok((None, None));
    }
    let (tt, moved) = run_on(&table.numeric(TIME_COLUMN)?);
    let warning = steps_back(table, &moved, true);
    Ok((Some(tt), warning))
}

/// The warning for a time column that steps back or repeats at the samples `places`, if any.
fn steps_back(table: &Table, places: &[usize], run_on: bool) -> Option<Warning> {
    let first = *places.first()?;
    Some(Warning::TimeStepsBack {
        path: table.path().to_path_buf(),
        place: table.place_of(first),
        places: places.len(),
        run_on,
    })
}

/// A warning when `tt` (s), the time column of `table`, steps back or repeats.
pub(crate) fn time_steps_back(table: &Table, tt: &[f64]) -> Option<Warning> {
    steps_back(table, &non_increasing_places(tt), false)
}

/// The samples of `tt` (s) whose time is not after the previous finite one.
fn non_increasing_places(tt: &[f64]) -> Vec<usize> {
    match first_non_increasing(tt) {
        None => Vec::new(),
        Some(_) => run_on(tt).1,
    }
}

/// The sample rate (Hz) of `table`: `fs_hz` if given, else 1 / sampling interval of `tt`, else 1 /
/// the file's `dt` scalar (s; SGL HDF5 files carry one). A given rate more than 1 % away from
/// the time column's is used, with a warning.
pub fn sample_rate(
    table: &Table,
    tt: Option<&[f64]>,
    fs_hz: Option<f64>,
) -> Result<(f64, Option<Warning>)> {
    let step = tt.and_then(sampling_step);
    let dt = table.metadata(SAMPLE_INTERVAL);
    if tt.is_some() && step.is_none() && dt.is_none() && fs_hz.is_none() {
        return Err(Error::TimeUnusable {
            path: table.path().to_path_buf(),
        });
    }
    sample_rate_from(table.path(), table.metadata(SAMPLE_INTERVAL), step, fs_hz)
}

/// [`sample_rate`] from its ingredients: the file's `dt` scalar (s) and the sampling interval of
/// its time column (s; [`sampling_step`]), if any.
pub fn sample_rate_from(
    path: &Path,
    dt: Option<f64>,
    sampling_step_s: Option<f64>,
    fs_hz: Option<f64>,
) -> Result<(f64, Option<Warning>)> {
    let from_dt = dt
        .filter(|dt| dt.is_finite() && *dt > 0.0)
        .map(|dt| 1.0 / dt);
    let from_time = sampling_step_s.map(|dt| 1.0 / dt).or(from_dt);
    match (fs_hz, from_time) {
        (Some(fs), _) if !(fs.is_finite() && fs > 0.0) => Err(Error::BadSampleRate { fs_hz: fs }),
        (Some(fs), Some(t)) if ((fs - t) / t).abs() > 0.01 => Ok((
            fs,
            Some(Warning::SampleRateDiffers {
                given_hz: fs,
                from_time_hz: t,
            }),
        )),
        (Some(fs), _) => Ok((fs, None)),
        (None, Some(t)) => Ok((t, unlikely_rate(path, t))),
        (None, None) => Err(Error::NoSampleRate {
            path: path.to_path_buf(),
        }),
    }
}

/// Sample rates (Hz) airborne magnetometers are read at: from a ground station's one sample a
/// minute to the 2560 Hz of a fast optically pumped counter, with room on either side.
const LIKELY_RATES_HZ: std::ops::RangeInclusive<f64> = 0.01..=10_000.0;

/// A warning when the rate the file's time gives is none a magnetometer samples at: time in
/// hours or milliseconds read as seconds, most likely.
fn unlikely_rate(path: &Path, hz: f64) -> Option<Warning> {
    (!LIKELY_RATES_HZ.contains(&hz)).then(|| Warning::UnlikelySampleRate {
        path: path.to_path_buf(),
        hz,
    })
}

/// `names` checked: at least one, none twice; `what` says what they name in errors.
pub(crate) fn checked_names(names: &[String], what: &'static str) -> Result<()> {
    if names.is_empty() {
        return Err(Error::NoColumnNamed { what });
    }
    match (1..names.len()).find(|&k| names[..k].contains(&names[k])) {
        Some(k) => Err(Error::RepeatedColumn {
            what,
            name: names[k].clone(),
        }),
        None => Ok(()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn table(csv: &str) -> Table {
        Table::csv().reader(csv.as_bytes(), "f.csv").unwrap()
    }

    #[test]
    fn the_sample_rate_comes_from_time_then_dt_then_is_an_error() {
        let p = Path::new("f.csv");
        assert_eq!(sample_rate_from(p, None, Some(0.1), None).unwrap().0, 10.0);
        assert_eq!(sample_rate_from(p, Some(0.5), None, None).unwrap().0, 2.0);
        let e = sample_rate_from(p, None, None, None).unwrap_err();
        assert!(matches!(e, Error::NoSampleRate { .. }), "{e}");
    }

    #[test]
    fn a_given_rate_far_from_the_time_column_is_used_with_a_warning() {
        let (fs, warning) = sample_rate_from(Path::new("f"), None, Some(0.1), Some(12.0)).unwrap();
        assert_eq!(fs, 12.0);
        assert!(matches!(warning, Some(Warning::SampleRateDiffers { .. })));
        let (_, close) = sample_rate_from(Path::new("f"), None, Some(0.1), Some(10.05)).unwrap();
        assert_eq!(close, None);
        assert!(sample_rate_from(Path::new("f"), None, None, Some(-1.0)).is_err());
    }

    #[test]
    fn time_that_steps_back_is_run_on_and_named() {
        let (tt, warning) = time_column(&table("tt\n0\n1\n1\n2\n")).unwrap();
        let tt = tt.unwrap();
        assert!(tt[2] > tt[1] && tt[3] - tt[2] == 1.0, "{tt:?}");
        let text = warning.unwrap().to_string();
        assert!(
            text.contains("f.csv: time steps back or repeats at 1 place(s), the first at line 4"),
            "{text}"
        );
        assert_eq!(time_column(&table("x\n1\n")).unwrap(), (None, None));
        assert_eq!(time_column(&table("tt\n0\n1\n")).unwrap().1, None);
    }

    #[test]
    fn names_must_be_given_once_each() {
        let names = |v: &[&str]| v.iter().map(|s| s.to_string()).collect::<Vec<_>>();
        assert!(checked_names(&names(&["a", "b"]), "scalar").is_ok());
        assert!(checked_names(&names(&[]), "scalar").is_err());
        let e = checked_names(&names(&["a", "b", "a"]), "scalar").unwrap_err();
        assert_eq!(e.to_string(), "scalar column \"a\" is named twice");
    }
}
