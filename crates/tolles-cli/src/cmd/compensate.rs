//! `tolles compensate`: apply a model to survey data.

use crate::progress::Terminal;
use crate::render::{self, OrRender, Use};
use anyhow::{anyhow, bail, Result};
use std::path::PathBuf;
use tolles::compensate::{CompensateRequest, FileRequest, Memory};
use tolles::Error;

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
/// empty cell and are counted on stderr; so are rows outside what the calibration flew, and a
/// model whose verdict is not good says so.
#[derive(clap::Args)]
#[command(after_help = EXAMPLES)]
pub struct Args {
    #[arg(help = flight_help!("Survey data with the model's scalar and fluxgate columns"))]
    pub survey: PathBuf,
    /// Model file written by `tolles fit`
    #[arg(long)]
    pub model: PathBuf,
    /// Output file, in the format its extension names (.csv, .h5/.hdf5, .parquet/.pq; any
    /// other extension is an error); `-` for CSV on standard output, also where it goes when
    /// this is left out, unless that is a terminal
    #[arg(short, long)]
    pub out: Option<PathBuf>,
    /// Sample rate of the survey in Hz, if it has no `tt` column (default: the model's)
    #[arg(long, allow_negative_numbers = true)]
    pub fs: Option<f64>,
    /// The level of the aircraft's field subtracted: `mean`, its mean over the rows written,
    /// which stays in the data (MagNav's choice); `model`, the calibration flight's mean stored
    /// in the model, so a row's result does not depend on how the data was split
    #[arg(long, default_value = "mean", value_parser = parse_level)]
    pub level: tolles::compensate::LevelChoice,
    /// Also write, per compensated column NAME, NAME_sigma: the compensated value's standard
    /// error up to a constant level (nT): the correction's, from the coefficients' covariance,
    /// and what the model leaves of the calibration's scalar, in quadrature; and
    /// NAME_extrapolated: 1 where the row's field direction, its rate of change or an extra
    /// channel lies outside what the calibration flew, else 0. The survey is then read whole
    #[arg(long)]
    pub uncertainty: bool,
    #[command(flatten)]
    pub select: crate::select::Selection,
}

/// Environment variable: `bounded` always reads the survey in chunks where it can, `whole` never
/// does, `auto` (the default) does when reading it whole could take more than half of the memory
/// available.
const MEMORY_VAR: &str = "TOLLES_MEMORY";
/// Environment variable: rows per chunk; giving it asks for chunks.
const CHUNK_ROWS_VAR: &str = "TOLLES_CHUNK_ROWS";

pub fn run(args: Args) -> Result<()> {
    let memory = memory()?;
    let chunk_rows = chunk_rows();
    let model = tolles::model::load_model(&args.model).or_render()?;
    let request = FileRequest {
        survey: args.survey,
        out: crate::input::out_for_programs(
            args.out,
            "the compensated flight (CSV)",
            "compensated.csv",
        )?,
        compensate: CompensateRequest {
            fs_hz: args.fs,
            level: args.level,
            uncertainty: args.uncertainty,
        },
        selection: args.select.rows(),
        renames: args.select.renames.clone(),
        memory,
        chunk_rows: chunk_rows.as_ref().map(|(_, rows)| *rows),
    };
    let mut warnings = Vec::new();
    let stdout = std::io::stdout();
    let mut out = std::io::BufWriter::new(stdout.lock());
    let done = tolles::compensate::compensate_file(
        &model,
        &request,
        &mut out,
        &Terminal::default(),
        &mut warnings,
    );
    render::warnings(&mut warnings, Use::Compensate);
    match done {
        Err(Error::NoChunkRows) => {
            let text = chunk_rows.map(|(text, _)| text).unwrap_or_default();
            bail!("{CHUNK_ROWS_VAR} must be a positive number of rows, got {text:?}")
        }
        done => done.or_render().map(drop),
    }
}

/// The memory policy `TOLLES_MEMORY` names (auto when unset).
fn memory() -> Result<Memory> {
    let Some(text) = std::env::var_os(MEMORY_VAR) else {
        return Ok(Memory::Auto);
    };
    let text = text.to_string_lossy();
    text.parse()
        .map_err(|_| anyhow!("{MEMORY_VAR} must be auto, bounded or whole, got {text:?}"))
}

/// `TOLLES_CHUNK_ROWS` as written, and as rows. Text that is not a number of rows becomes 0,
/// which the library refuses only where it reads in chunks: a setting the whole-file path
/// ignores stays harmless.
fn chunk_rows() -> Option<(String, usize)> {
    let text = std::env::var(CHUNK_ROWS_VAR).ok()?;
    let rows = text.trim().parse().unwrap_or(0);
    Some((text, rows))
}

fn parse_level(text: &str) -> Result<tolles::compensate::LevelChoice, String> {
    text.parse()
}
