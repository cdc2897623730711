//! `tolles compensate`: apply a model to survey data.

use crate::progress::Terminal;
use crate::render::{self, OrRender, Use};
use anyhow::Result;
use std::path::PathBuf;
use tolles::compensate::{CompensateRequest, FileRequest};

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
    /// The level of the aircraft's field subtracted: `mean`, its mean over the rows written,
    /// which stays in the data (MagNav's choice); `model`, the calibration flight's mean stored
    /// in the model, so a row's result does not depend on how the data was split
    #[arg(long, default_value = "mean", value_parser = parse_level)]
    pub level: tolles::compensate::LevelChoice,
    #[command(flatten)]
    pub select: crate::select::Selection,
}

pub fn run(args: Args) -> Result<()> {
    let model = tolles::model::load_model(&args.model).or_render()?;
    if super::compensate_stream::applies(&args, &model) {
        return super::compensate_stream::run(&args, &model);
    }
    let request = FileRequest {
        survey: args.survey.clone(),
        out: args.out.clone(),
        compensate: CompensateRequest {
            fs_hz: args.fs,
            level: args.level,
        },
        selection: args.select.rows(),
        ..FileRequest::default()
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
    done.or_render()?;
    Ok(())
}

fn parse_level(text: &str) -> Result<tolles::compensate::LevelChoice, String> {
    text.parse()
}
