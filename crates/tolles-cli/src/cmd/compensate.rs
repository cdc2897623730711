//! `tolles compensate`: apply a model to survey data.

use crate::input::Flight;
use anyhow::{bail, Context, Result};
use rayon::prelude::*;
use std::io::Write;
use std::path::PathBuf;
use tolles_core::compensate::{compensate, Compensation, Level};
use tolles_core::fit::check_flux_magnitude;
use tolles_io::format::{write_table, Format};
use tolles_io::model::{ModelFile, ScalarModel};
use tolles_io::table::write_with_column;

const EXAMPLES: &str = "\
Examples:
  tolles compensate survey.csv --model model.json --out survey_c.csv
  tolles compensate survey.csv --model model.json | head";

/// Remove the aircraft's field from survey data with a model from `tolles fit`.
///
/// Writes every input row (with --line/--time, every selected row) and column unchanged plus
/// the compensated scalar, named after the scalar with `_uc` replaced by `_c`
/// (mag_1_uc → mag_1_c). The correction's mean over the rows written is kept in the data, as
/// MagNav.jl does. Rows that cannot be compensated (missing values) get an
/// empty cell and are counted on stderr.
#[derive(clap::Args)]
#[command(after_help = EXAMPLES)]
pub struct Args {
    /// Survey data (CSV, XYZ, GDF .dfn/.dat, HDF5 or Parquet by extension) with the model's
    /// scalar and fluxgate columns
    pub survey: PathBuf,
    /// Model file written by `tolles fit`
    #[arg(long)]
    pub model: PathBuf,
    /// Output file, in the format its extension names (.csv, .h5/.hdf5/.mat, .parquet/.pq);
    /// CSV on standard output if omitted
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Sample rate of the survey in Hz, if it has no `tt` column (default: the model's)
    #[arg(long)]
    pub fs: Option<f64>,
    #[command(flatten)]
    pub select: crate::select::Selection,
}

pub fn run(args: Args) -> Result<()> {
    let model = ModelFile::read(&args.model)?;
    if model.fits.is_empty() {
        bail!("{}: the model holds no fits", args.model.display());
    }
    if super::compensate_stream::applies(&args, &model) {
        return super::compensate_stream::run(&args, &model);
    }
    // The survey is read once; each fit takes its own scalar and fluxgate columns from it, and
    // it is written back whole with one compensated column per fit.
    let table = args
        .select
        .read(&args.survey, crate::select::Use::Compensate)?;
    // Fits are independent: compensate them on all cores, then report in the model's order.
    let results: Vec<Result<(usize, Compensation)>> = model
        .fits
        .par_iter()
        .map(|scalar_model| {
            let flight = Flight::from_table(&table, &scalar_model.scalar, &scalar_model.vectors)?;
            Ok((
                flight.scalar.len(),
                compensate_flight(&flight, scalar_model, args.fs)?,
            ))
        })
        .collect();
    let mut extra = Vec::new();
    for (scalar_model, result) in model.fits.iter().zip(results) {
        let (rows, result) = result?;
        if result.uncomputable > 0 {
            eprintln!(
                "warning: {}: {} of {} rows have no {} (missing scalar or fluxgate values); their cells are empty",
                args.survey.display(),
                result.uncomputable,
                rows,
                scalar_model.output_column
            );
        }
        extra.push((
            output_name(&table, &scalar_model.output_column),
            result.compensated,
        ));
    }
    match &args.out {
        Some(path) => Ok(write_table(&table, &extra, path, Format::from_path(path))?),
        None => {
            let stdout = std::io::stdout();
            let mut out = std::io::BufWriter::new(stdout.lock());
            write_with_column(&table, &extra, &mut out)
                .and_then(|_| out.flush())
                .context("writing to standard output")
        }
    }
}

/// `scalar_model` applied to `flight` as `tolles compensate` does: the correction's mean over the
/// file kept in the data, eddy terms rescaled to the flight's sample rate (`--fs` if given, else
/// from its time column, else the model's).
pub fn compensate_flight(
    flight: &Flight,
    scalar_model: &ScalarModel,
    fs: Option<f64>,
) -> Result<Compensation> {
    check_flux_magnitude(&flight.flux).map_err(|e| flight.explain(e, &scalar_model.scalar))?;
    let fs_hz = match (fs, &flight.tt) {
        (None, None) => scalar_model.fit.fs_hz,
        (fs, _) => flight.sample_rate(fs)?,
    };
    let fit = &scalar_model.fit;
    Ok(compensate(
        &flight.scalar,
        &flight.flux,
        flight.tt.as_deref(),
        &fit.settings.design,
        &fit.coefficients,
        fs_hz / fit.fs_hz,
        Level::FileMean,
    ))
}

/// The compensated column's name; if the input already has that column (SGL files carry their
/// own `mag_1_c`), ours becomes `NAME_tolles` so no input column is overwritten.
fn output_name(table: &tolles_io::table::Table, wanted: &str) -> String {
    if table.has(wanted) {
        let renamed = format!("{wanted}_tolles");
        eprintln!(
            "warning: {} already has a column {wanted:?}; writing ours as {renamed:?}",
            table.path().display()
        );
        renamed
    } else {
        wanted.to_string()
    }
}
