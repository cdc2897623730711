//! Applying a model to survey data: `compensated = uncompensated − (A·β − level)`, one column
//! per fit, on all cores; for a file, whole in memory or a chunk of rows at a time.

mod chunked;

pub use chunked::{needs_bounded_memory, reads_in_chunks};

use crate::error::{Error, Result};
// Checking a model is the model's; `tolles::compensate::check_model` stays the public path.
pub use crate::model::check_model;
use crate::model::{ModelFile, ScalarModel};
use crate::read::Flight;
use crate::selection::Selection;
use crate::warning::Warning;
use rayon::prelude::*;
use std::io::Write;
use std::path::PathBuf;
use std::str::FromStr;
use tolles_core::compensate::chunk::{ChunkCompensator, ChunkField, Setup};
use tolles_core::compensate::{with_level, Compensation, Level};
use tolles_core::fit::check_flux_magnitude;
use tolles_core::signal::segment::median_step;
use tolles_io::format::{write_table, Format};
use tolles_io::schema::output_names;
use tolles_io::select::RowSelection;
use tolles_io::table::{write_padded, Table};

/// Which constant level of the aircraft's field is subtracted.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum LevelChoice {
    /// The mean of `A·β` over the data compensated, which stays in the data (MagNav's choice).
    /// The result depends on which rows are compensated together.
    #[default]
    FileMean,
    /// The calibration flight's mean `A·β` stored in the model (`level_nt`), as a real-time
    /// compensator must: a row's result does not depend on how the data was split.
    Model,
}

impl FromStr for LevelChoice {
    type Err = String;

    /// `mean` or `model`.
    fn from_str(text: &str) -> Result<Self, String> {
        match text.trim().to_ascii_lowercase().as_str() {
            "mean" => Ok(LevelChoice::FileMean),
            "model" => Ok(LevelChoice::Model),
            _ => Err(format!("expected `mean` or `model`, got {text:?}")),
        }
    }
}

/// How to compensate.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct CompensateRequest {
    /// The survey's sample rate (Hz); default: from its time column, else the model's.
    pub fs_hz: Option<f64>,
    /// Which level is subtracted.
    pub level: LevelChoice,
    /// Also give each row's standard error and extrapolation flag (see [`RowTrust`]).
    pub uncertainty: bool,
}

/// How far to trust each compensated row.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct RowTrust {
    /// The correction's standard error (nT), relative to the calibration's mean level; NaN
    /// where nothing is compensated or the model has no uncertainty (a file before version 3).
    /// Only when asked for.
    pub sigma: Option<Vec<f64>>,
    /// Per row, whether it lies outside what the calibration flew. Only when asked for.
    pub extrapolated: Option<Vec<bool>>,
    /// Rows outside what the calibration flew (counted whether asked for or not).
    pub outside: usize,
}

/// One compensated scalar.
#[derive(Debug, Clone, PartialEq)]
pub struct CompensatedColumn {
    /// The column's name in the output (the model's output column, renamed if the input
    /// already has one by that name).
    pub name: String,
    /// The uncompensated scalar it comes from.
    pub scalar: String,
    /// Compensated values (nT); NaN where a value they need is missing.
    pub values: Vec<f64>,
    /// Rows that could not be compensated.
    pub uncomputable: usize,
    /// How far to trust each row.
    pub trust: RowTrust,
}

/// One fit's compensation, how far to trust it, its warnings, and where time steps back.
type FitOutcome = (Compensation, RowTrust, Vec<Warning>, Option<Warning>);

/// Compensates every fit of `model` on `table`, on all cores, in the model's order. Rows that
/// cannot be compensated are NaN and counted in `warnings`; so is a renamed output column.
pub fn compensate(
    table: &Table,
    model: &ModelFile,
    request: &CompensateRequest,
    warnings: &mut Vec<Warning>,
) -> Result<Vec<CompensatedColumn>> {
    let results: Vec<Result<FitOutcome>> = model
        .fits
        .par_iter()
        .map(|fit| {
            let flight = Flight::from_table(table, &fit.scalar, &fit.vectors)?
                .with_extras(&fit.fit.settings.design.extras)?;
            let mut noticed = Vec::new();
            let mut computed = flight_field(&flight, fit, request, &mut noticed)?;
            let field = std::mem::take(&mut computed.field);
            let result = with_level(&flight.scalar, field, level(fit, request.level));
            let trust = row_trust(computed, &result.compensated, request);
            Ok((result, trust, noticed, flight.time_steps_back))
        })
        .collect();
    let mut columns = Vec::new();
    let wanted: Vec<&str> = model
        .fits
        .iter()
        .map(|f| f.output_column.as_str())
        .collect();
    let names = output_names(table.headers(), &wanted);
    for (k, ((fit, result), (name, renamed))) in
        model.fits.iter().zip(results).zip(names).enumerate()
    {
        let (result, trust, noticed, steps_back) = result?;
        // Every fit reads the same time column: where it steps back is told once.
        if k == 0 {
            warnings.extend(steps_back);
        }
        warnings.extend(noticed);
        warnings.extend(crate::warning::verdict_warning(&fit.scalar, &fit.fit));
        let (path, of, column) = (table.path(), table.len(), &fit.output_column);
        warnings.extend(Warning::extrapolated(path, trust.outside, of, column));
        warnings.extend(Warning::uncomputable(path, result.uncomputable, of, column));
        if renamed {
            warnings.push(Warning::OutputRenamed {
                path: table.path().to_path_buf(),
                wanted: fit.output_column.clone(),
                renamed: name.clone(),
            });
        }
        columns.push(CompensatedColumn {
            name,
            scalar: fit.scalar.clone(),
            values: result.compensated,
            uncomputable: result.uncomputable,
            trust,
        });
    }
    Ok(columns)
}

/// `fit` applied to `flight`: eddy terms rescaled to the flight's sample rate (the request's if
/// given, else from its time column, else the model's), the level as the request says. The
/// rows where the model extrapolates are warned of as `compensate` warns of them (the
/// flight's path and `fit`'s output column named).
pub fn compensate_flight(
    flight: &Flight,
    fit: &ScalarModel,
    request: &CompensateRequest,
    warnings: &mut Vec<Warning>,
) -> Result<Compensation> {
    let mut computed = flight_field(flight, fit, request, warnings)?;
    let field = std::mem::take(&mut computed.field);
    let of = field.len();
    let compensation = with_level(&flight.scalar, field, level(fit, request.level));
    let outside = row_trust(computed, &compensation.compensated, request).outside;
    warnings.extend(Warning::extrapolated(
        flight.table.path(),
        outside,
        of,
        &fit.output_column,
    ));
    Ok(compensation)
}

/// The two parts of a correction with a learned network, row by row (nT).
#[derive(Debug, Clone, PartialEq)]
pub struct CorrectionParts {
    /// The linear model's correction `A·β` (nT, the level not subtracted); NaN where it cannot
    /// be computed.
    pub linear_nt: Vec<f64>,
    /// What the network adds to it (nT); their sum is what `compensate` subtracts before the
    /// level.
    pub network_nt: Vec<f64>,
}

/// [`flight_field`]'s correction split into the linear model's part and its network's, when
/// `fit` has a network (`None` otherwise), as `compensate` computes them.
pub fn correction_parts(
    flight: &Flight,
    fit: &ScalarModel,
    request: &CompensateRequest,
    warnings: &mut Vec<Warning>,
) -> Result<Option<CorrectionParts>> {
    if fit.network.is_none() {
        return Ok(None);
    }
    let computed = flight_field(flight, fit, request, warnings)?;
    Ok(computed.learned.map(|network_nt| CorrectionParts {
        linear_nt: (computed.field.iter().zip(&network_nt))
            .map(|(f, n)| f - n)
            .collect(),
        network_nt,
    }))
}

/// `fit`'s correction `A·β` (nT) of every row of `flight`, by the one compensator given the
/// flight as one chunk (`tolles_core::compensate::chunk`): the fluxgate read as late as the
/// fit found it lags, the extra channels conditioned as the model says, the eddy terms
/// rescaled to the flight's sample rate. With `request.uncertainty`, each row's standard error
/// too (NaN for a model file without an uncertainty).
pub fn flight_field(
    flight: &Flight,
    fit: &ScalarModel,
    request: &CompensateRequest,
    warnings: &mut Vec<Warning>,
) -> Result<ChunkField> {
    check_flux_magnitude(&flight.flux).map_err(|e| flight.explain(e, &fit.scalar))?;
    let fs_hz = survey_rate(flight, fit, request, warnings)?;
    let tt = flight.tt.as_deref();
    let setup = Setup {
        lag_s: fit.fit.lag_s,
        flux_offset_nt: fit.fit.flux_offset_nt,
        median_step_s: tt.and_then(median_step),
        coverage: fit.fit.coverage.as_ref(),
        uncertainty: fit.fit.uncertainty.as_ref().filter(|_| request.uncertainty),
        network: fit.network.as_ref().map(|learned| &learned.network),
        network_channels: network_channels(fit).len(),
        ..Setup::new(fit.applied(), fs_hz, fs_hz / fit.fit.fs_hz)
    };
    let extras: Vec<&[f64]> = flight.extras.iter().map(Vec::as_slice).collect();
    let channels = flight.columns(network_channels(fit).iter().map(String::as_str))?;
    let channels: Vec<&[f64]> = channels.iter().map(Vec::as_slice).collect();
    let engine = ChunkCompensator::new(setup);
    let mut computed = engine.whole_series(&flight.flux, &extras, &channels, tt);
    if request.uncertainty && computed.sigma.is_none() {
        computed.sigma = Some(vec![f64::NAN; computed.field.len()]);
    }
    warnings.extend(no_uncertainty(fit, request.uncertainty));
    Ok(computed)
}

/// [`Warning::NoUncertainty`] when σ is asked (`uncertainty`) of a model of `fit` without the
/// coefficients' covariance (a file written before version 3): its σ column stays empty.
pub(crate) fn no_uncertainty(fit: &ScalarModel, uncertainty: bool) -> Option<Warning> {
    (uncertainty && fit.fit.uncertainty.is_none()).then(|| Warning::NoUncertainty {
        scalar: fit.scalar.clone(),
    })
}

/// The survey's sample rate (Hz): the request's if given, else from its time column, else the
/// model's.
fn survey_rate(
    flight: &Flight,
    fit: &ScalarModel,
    request: &CompensateRequest,
    warnings: &mut Vec<Warning>,
) -> Result<f64> {
    Ok(match (request.fs_hz, &flight.tt) {
        (None, None) => fit.fit.fs_hz,
        (fs, _) => {
            let (fs_hz, warning) = flight.sample_rate(fs)?;
            warnings.extend(warning);
            fs_hz
        }
    })
}

/// How far to trust each row of `values` (nT), from its computed `field`: the count of rows
/// outside what the calibration flew, and with `request.uncertainty` each row's standard error
/// and flag (see `tolles_core::compensate::trust`). A row without a value has neither: the
/// field may be known where the scalar is missing, but there is no value to trust. A model
/// file before version 3 has neither coverage nor uncertainty: nothing is counted and the
/// standard errors are NaN.
fn row_trust(field: ChunkField, values: &[f64], request: &CompensateRequest) -> RowTrust {
    let mut outside = field.outside;
    let mut sigma = field.sigma;
    for (r, _) in values.iter().enumerate().filter(|(_, v)| !v.is_finite()) {
        outside[r] = false;
        if let Some(s) = sigma.as_mut() {
            s[r] = f64::NAN;
        }
    }
    RowTrust {
        outside: outside.iter().filter(|f| **f).count(),
        extrapolated: request.uncertainty.then_some(outside),
        sigma,
    }
}

/// The core's level for a choice.
pub fn level(fit: &ScalarModel, choice: LevelChoice) -> Level {
    match choice {
        LevelChoice::FileMean => Level::FileMean,
        LevelChoice::Model => Level::Fixed(fit.fit.level_nt),
    }
}

/// Where compensated data goes.
pub enum Destination<'w> {
    /// A file, in the format its extension names (CSV, HDF5 or Parquet).
    File(PathBuf),
    /// CSV text to a writer (e.g. standard output).
    Csv(&'w mut dyn Write),
}

/// Writes `table` with the compensated `columns` after its own; returns the time column and
/// the unit of time the input declared for it when the output cannot say it (see
/// [`tolles_io::format::Written::time_unit_dropped`]).
pub fn write_compensated(
    table: &Table,
    columns: &[CompensatedColumn],
    destination: Destination<'_>,
) -> Result<Option<(String, String)>> {
    let trust = trust_columns(table.headers(), columns);
    let mut extra: Vec<(&str, &[f64])> = Vec::new();
    for (c, t) in columns.iter().zip(&trust) {
        extra.push((c.name.as_str(), c.values.as_slice()));
        extra.extend(
            t.iter()
                .map(|(name, values)| (name.as_str(), values.as_slice())),
        );
    }
    match destination {
        Destination::File(path) => {
            let written = write_table(table, &extra, &path, Format::for_output(&path)?)?;
            Ok(written.time_unit_dropped)
        }
        Destination::Csv(out) => write_padded(table, &extra, table.len(), &mut *out)
            .and_then(|_| out.flush())
            .map(|_| table.time_unit())
            .map_err(|source| Error::Write {
                what: "writing the compensated data".to_string(),
                source,
            }),
    }
}

/// Per compensated column, the columns of its [`RowTrust`] when it has them:
/// `NAME_sigma` (nT) and `NAME_extrapolated` (1 outside what the calibration flew, 0 inside,
/// empty where nothing is compensated), each renamed like the compensated column if the input
/// already has one by that name.
pub fn trust_columns(
    headers: &[String],
    columns: &[CompensatedColumn],
) -> Vec<Vec<(String, Vec<f64>)>> {
    columns
        .iter()
        .map(|c| {
            let (Some(sigma), Some(flags)) = (&c.trust.sigma, &c.trust.extrapolated) else {
                return Vec::new();
            };
            let flag_values = c
                .values
                .iter()
                .zip(flags)
                .map(|(v, f)| match v.is_finite() {
                    true => f64::from(u8::from(*f)),
                    false => f64::NAN,
                })
                .collect();
            let names = tolles_io::schema::trust_columns(&c.name);
            let wanted: Vec<&str> = names.iter().map(String::as_str).collect();
            let unique = output_names(headers, &wanted);
            vec![
                (unique[0].0.clone(), sigma.clone()),
                (unique[1].0.clone(), flag_values),
            ]
        })
        .collect()
}

/// Whether a survey file may be read a chunk of rows at a time.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Memory {
    /// In chunks when reading the file whole could take more than half the available memory.
    #[default]
    Auto,
    /// In chunks wherever the formats and the model allow it.
    Bounded,
    /// Always whole.
    Whole,
}

impl FromStr for Memory {
    type Err = String;

    /// `auto`, `bounded` or `whole`.
    fn from_str(text: &str) -> Result<Self, String> {
        match text.trim().to_ascii_lowercase().as_str() {
            "auto" | "" => Ok(Memory::Auto),
            "bounded" => Ok(Memory::Bounded),
            "whole" => Ok(Memory::Whole),
            _ => Err(format!("expected auto, bounded or whole, got {text:?}")),
        }
    }
}

/// A survey file to compensate into an output.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct FileRequest {
    /// The survey (CSV, XYZ, GDF, HDF5 or Parquet by extension).
    pub survey: PathBuf,
    /// The output file (CSV, HDF5 or Parquet by extension); `None` writes CSV to the writer
    /// given to [`compensate_file`].
    pub out: Option<PathBuf>,
    /// Sample rate and level.
    pub compensate: CompensateRequest,
    /// Rows to compensate and write (all when empty).
    pub selection: RowSelection,
    /// Columns renamed `(old, new)` right after reading (see [`crate::read::rename`]); the
    /// output is written under the new names.
    pub renames: Vec<(String, String)>,
    /// Whether the survey may be read in chunks.
    pub memory: Memory,
    /// Rows per chunk; giving it asks for chunks (as [`Memory::Bounded`], unless `Whole`).
    /// Zero is an error ([`Error::NoChunkRows`]), but only where the survey is read in chunks.
    pub chunk_rows: Option<usize>,
}

/// What [`compensate_file`] did.
#[derive(Debug, Clone, PartialEq)]
pub struct FileOutcome {
    /// What the selection kept, if one was asked for.
    pub selected: Option<Selection>,
    /// Rows written.
    pub rows: usize,
}

/// Compensates the survey file of `request` with `model` and writes it with one compensated
/// column per fit after its own: to `request.out`, or as CSV to `writer`. Every input row is
/// written (with a selection, every selected row); rows that cannot be compensated get an empty
/// cell and are counted in `warnings`. The survey is read whole, or a chunk of rows at a time
/// where [`reads_in_chunks`] says so; either way the output and the warnings are the same.
pub fn compensate_file(
    model: &ModelFile,
    request: &FileRequest,
    writer: &mut dyn Write,
    progress: &dyn crate::progress::Progress,
    warnings: &mut Vec<Warning>,
) -> Result<FileOutcome> {
    if let Some(out) = &request.out {
        // Before any work: an output named in no format tolles writes is a mistake.
        Format::for_output(out)?;
    }
    if reads_in_chunks(model, request) {
        return chunked::compensate_file(model, request, writer, progress, warnings);
    }
    let data = crate::read::read_parsing(
        &request.survey,
        &request.selection,
        &request.renames,
        &columns_read(model),
        progress,
        warnings,
    )?;
    let columns = compensate(&data.table, model, &request.compensate, warnings)?;
    let destination = match &request.out {
        Some(path) => Destination::File(path.clone()),
        None => Destination::Csv(writer),
    };
    let dropped = write_compensated(&data.table, &columns, destination)?;
    let output = request.out.clone().unwrap_or_else(|| "-".into());
    warnings.extend(dropped.map(|(column, unit)| Warning::TimeUnitNotWritten {
        path: output,
        column,
        unit,
    }));
    Ok(FileOutcome {
        selected: data.selected,
        rows: data.table.len(),
    })
}

/// The columns compensating with `model` reads.
pub fn columns_read(model: &ModelFile) -> Vec<String> {
    model.fits.iter().flat_map(fit_columns).collect()
}

/// The columns applying `fit` reads: its scalar, time, fluxgates, extra channels and its
/// network's channels.
pub fn fit_columns(fit: &ScalarModel) -> Vec<String> {
    let extras = &fit.fit.settings.design.extras;
    let mut names = crate::read::flight_columns(&fit.scalar, &fit.vectors, extras);
    names.extend(network_channels(fit).iter().cloned());
    names
}

/// The columns `fit`'s network reads besides the fluxgate and the extra channels (none
/// without a network).
pub fn network_channels(fit: &ScalarModel) -> &[String] {
    fit.network
        .as_ref()
        .map_or(&[], |learned| &learned.channels)
}

#[cfg(test)]
mod whole_tests {
    use super::*;
    use crate::fit::{fit, FitRequest};
    use crate::simulate::PlanKind;
    use crate::testing::flight;
    use tolles_io::table::Column;

    fn model() -> ModelFile {
        let request = FitRequest::new(vec!["mag_1_uc".into()], vec!["flux_a".into()]);
        fit(
            &flight(PlanKind::Box, 3),
            &request,
            &crate::Silent,
            &mut Vec::new(),
        )
        .unwrap()
    }

    fn rows(table: &Table, range: std::ops::Range<usize>) -> Table {
        let keep: Vec<bool> = (0..table.len()).map(|k| range.contains(&k)).collect();
        table.select_rows(&keep)
    }

    fn compensated(table: &Table, model: &ModelFile, level: LevelChoice) -> Vec<f64> {
        let request = CompensateRequest {
            fs_hz: None,
            level,
            uncertainty: false,
        };
        let columns = compensate(table, model, &request, &mut Vec::new()).unwrap();
        columns.into_iter().next().unwrap().values
    }

    #[test]
    fn the_model_level_makes_rows_independent_of_the_split() {
        let (survey, model) = (flight(PlanKind::Survey, 4), model());
        let whole = compensated(&survey, &model, LevelChoice::Model);
        let half = survey.len() / 2;
        let first = compensated(&rows(&survey, 0..half), &model, LevelChoice::Model);
        // Away from the cut, where the eddy terms' derivative is one-sided.
        for k in 0..half - 1 {
            assert!((first[k] - whole[k]).abs() < 1e-9, "row {k}");
        }
        let mean_level = compensated(&rows(&survey, 0..half), &model, LevelChoice::FileMean);
        assert!(
            (mean_level[0] - first[0]).abs() > 1e-6,
            "the file mean is another level"
        );
    }

    #[test]
    fn missing_values_are_counted_and_a_taken_name_is_renamed() {
        let survey = flight(PlanKind::Survey, 5);
        let mut headers = survey.headers().to_vec();
        let mut columns = survey.columns().to_vec();
        let x = headers.iter().position(|h| h == "flux_a_x").unwrap();
        if let Column::Numbers(values) = &mut columns[x] {
            values[10] = f64::NAN;
        }
        headers.push("mag_1_c".into());
        columns.push(Column::Numbers(vec![0.0; survey.len()]));
        let survey = Table::from_columns("s.csv", headers, columns, None).unwrap();
        let mut warnings = Vec::new();
        let out = compensate(
            &survey,
            &model(),
            &CompensateRequest::default(),
            &mut warnings,
        )
        .unwrap();
        assert_eq!(out[0].name, "mag_1_c_tolles");
        assert_eq!(out[0].uncomputable, 1);
        assert!(out[0].values[10].is_nan());
        assert!(
            matches!(warnings[0], Warning::Uncomputable { rows: 1, .. }),
            "{warnings:?}"
        );
        assert!(
            matches!(warnings[1], Warning::OutputRenamed { .. }),
            "{warnings:?}"
        );
    }

    #[test]
    fn a_row_without_a_scalar_has_no_sigma_and_no_flag() {
        let survey = flight(PlanKind::Survey, 5);
        let mut columns = survey.columns().to_vec();
        let scalar = survey
            .headers()
            .iter()
            .position(|h| h == "mag_1_uc")
            .unwrap();
        if let Column::Numbers(values) = &mut columns[scalar] {
            values[20] = f64::NAN;
        }
        let survey =
            Table::from_columns("s.csv", survey.headers().to_vec(), columns, None).unwrap();
        let request = CompensateRequest {
            uncertainty: true,
            ..CompensateRequest::default()
        };
        let out = compensate(&survey, &model(), &request, &mut Vec::new()).unwrap();
        let sigma = out[0].trust.sigma.as_ref().unwrap();
        assert!(out[0].values[20].is_nan() && sigma[20].is_nan());
        assert!(sigma[19].is_finite() && sigma[21].is_finite());
        assert!(!out[0].trust.extrapolated.as_ref().unwrap()[20]);
    }

    #[test]
    fn level_and_memory_policies_parse() {
        assert_eq!("model".parse::<LevelChoice>().unwrap(), LevelChoice::Model);
        assert_eq!(
            "Mean".parse::<LevelChoice>().unwrap(),
            LevelChoice::FileMean
        );
        assert!("median".parse::<LevelChoice>().is_err());
        assert_eq!("bounded".parse::<Memory>().unwrap(), Memory::Bounded);
        assert!("garbage".parse::<Memory>().is_err());
    }
}
