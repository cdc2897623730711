//! `tolles fit`: learn a model from a calibration flight.

use crate::input::{name_list, parse_band};
use crate::progress::Terminal;
use crate::render::{self, OrRender, Use};
use anyhow::{Context, Result};
use std::io::Write;
use std::path::{Path, PathBuf};
use tolles::fit::{FitRequest, Terms};
use tolles_core::fit::{Band, Lambda};
use tolles_io::model::ScalarModel;
use tolles_io::table::Table;

/// Default terms: the 16 a scalar magnetometer can identify, or MagNav's 18 when
/// cross-validation finds them clearly better (see `--terms`).
pub const DEFAULT_TERMS: &str = "auto";

fn parse_terms(text: &str) -> Result<Terms, String> {
    text.parse()
}

const EXAMPLES: &str = "\
Examples:
  tolles fit cal.csv --scalar mag_1_uc --vector flux_a --out model.json
  # MagNav.jl's exact procedure:
  tolles fit cal.csv --scalar mag_1_uc --vector flux_a --out model.json \\
      --terms permanent,induced,eddy --lambda 0.001 --band 0.1,0.9 --order 4 --trim 20";

/// Learn the aircraft's field from a calibration flight (CSV, XYZ, GDF, HDF5 or Parquet).
///
/// The fluxgate gives the earth field's direction in the aircraft; every design column and the
/// scalar are band-passed with a zero-phase Butterworth filter, trimmed, and fitted by ridge
/// least squares. Prints a summary to stderr; writes the model to --out (or stdout).
#[derive(clap::Args)]
#[command(after_help = EXAMPLES)]
pub struct Args {
    /// Calibration flight: CSV, XYZ, GDF (.dfn/.dat), HDF5 (.h5/.mat) or Parquet, by extension;
    /// time column `tt` (s) if present
    pub cal: PathBuf,
    /// Uncompensated scalar magnetometer column (nT), e.g. mag_1_uc; several separated by
    /// commas (mag_3_uc,mag_4_uc,mag_5_uc) give one model holding a fit per scalar
    #[arg(long)]
    pub scalar: String,
    /// Fluxgate column prefix: `flux_a` reads flux_a_x, flux_a_y, flux_a_z (nT, body frame FRD);
    /// several separated by commas (flux_a,flux_b,flux_c) build one design in which each
    /// fluxgate adds its own block of terms, for every scalar
    #[arg(long)]
    pub vector: String,
    /// Where to write the model (JSON); standard output if omitted
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Terms: `auto`, or a list of permanent|p, induced|i, i5, i3, eddy|e, e8, e3, bias|b.
    /// `auto` fits the 16 terms a scalar magnetometer can identify (permanent,i5,e8) and
    /// MagNav.jl's 18 (permanent,induced,eddy) and keeps the 18 only if cross-validation finds
    /// them at least 2 % better on held-out data
    #[arg(long, default_value = DEFAULT_TERMS, value_parser = parse_terms)]
    pub terms: Terms,
    /// Ridge strength: `auto` chooses λ·diag(AᵀA) by 5-fold blocked cross-validation over time;
    /// a number X adds X·I to AᵀA with unscaled columns, exactly as MagNav's linreg
    #[arg(long, default_value = "auto", value_parser = parse_lambda)]
    pub lambda: Lambda,
    /// Pass band LO,HI in Hz; an edge ≤ 0 or ≥ fs/2 turns band-pass into low- or high-pass,
    /// both invalid means no filtering
    #[arg(long, default_value = "0.1,0.9")]
    pub band: String,
    /// Butterworth order (per band edge)
    #[arg(long, default_value_t = 4)]
    pub order: usize,
    /// Samples dropped at each end after filtering
    #[arg(long, default_value_t = 20)]
    pub trim: usize,
    /// Sample rate in Hz (required when the file has no `tt` column)
    #[arg(long)]
    pub fs: Option<f64>,
    #[command(flatten)]
    pub select: crate::select::Selection,
}

fn parse_lambda(text: &str) -> Result<Lambda, String> {
    if text.eq_ignore_ascii_case("auto") {
        return Ok(Lambda::auto());
    }
    match text.parse::<f64>() {
        Ok(x) if x.is_finite() && x >= 0.0 => Ok(Lambda::Fixed(x)),
        _ => Err(format!("expected `auto` or a number ≥ 0, got {text:?}")),
    }
}

pub fn run(args: Args) -> Result<()> {
    let request = request(&args)?;
    let table = args.select.read(&args.cal, Use::Fit)?;
    fit_and_save(&table, &request, args.out.as_deref())
}

/// Fits the whole flight at `cal` as `request` says and writes the model to `out` (or stdout).
pub fn run_request(cal: &Path, request: &FitRequest, out: Option<&Path>) -> Result<()> {
    let table = crate::select::Selection::default().read(cal, Use::Fit)?;
    fit_and_save(&table, request, out)
}

fn fit_and_save(table: &Table, request: &FitRequest, out: Option<&Path>) -> Result<()> {
    let mut warnings = Vec::new();
    let fitted = tolles::fit::fit(table, request, &Terminal::default(), &mut warnings);
    render::warnings(&mut warnings, Use::Fit);
    let model = fitted.or_render()?;
    for fit in &model.fits {
        print_summary(fit, table.path())?;
    }
    match out {
        Some(path) => tolles::model::save_model(&model, path).or_render()?,
        None => writeln!(std::io::stdout(), "{}", model.to_json()).context("writing the model")?,
    }
    Ok(())
}

/// The library request the flags ask for.
fn request(args: &Args) -> Result<FitRequest> {
    let (pass1_hz, pass2_hz) = parse_band(&args.band)?;
    Ok(FitRequest {
        terms: args.terms,
        lambda: args.lambda,
        band: Band { pass1_hz, pass2_hz },
        order: args.order,
        trim: args.trim,
        fs_hz: args.fs,
        ..FitRequest::new(
            name_list(&args.scalar, "--scalar")?,
            name_list(&args.vector, "--vector")?,
        )
    })
}

fn print_summary(model: &ScalarModel, cal: &Path) -> Result<()> {
    let d = &model.fit.diagnostics;
    let mut err = std::io::stderr().lock();
    writeln!(
        err,
        "fit {} ~ {} ({}) on {}: {} of {} samples used",
        model.scalar,
        model.vectors.join(","),
        model.fit.settings.design.terms,
        cal.display(),
        d.samples_used,
        d.samples_total
    )?;
    if d.samples_nonfinite > 0 {
        writeln!(
            err,
            "  skipped {} samples with missing or non-finite values",
            d.samples_nonfinite
        )?;
    }
    if d.samples_in_short_runs > 0 {
        writeln!(
            err,
            "  skipped {} samples in runs too short to filter",
            d.samples_in_short_runs
        )?;
    }
    writeln!(
        err,
        "  filtered scalar {:.4} nT -> residual {:.4} nT (improvement ×{:.2}), cond(AᵀA+Λ) = {:.3e}",
        d.filtered_std_before_nt, d.residual_std_nt, d.improvement_ratio, d.condition_number
    )?;
    for score in &d.term_choice {
        writeln!(
            err,
            "  terms {:<28} held-out residual {}{}",
            score.terms.to_string(),
            score
                .heldout_rms_nt
                .map_or("(could not be fitted)".to_string(), |r| format!(
                    "{r:.4} nT"
                )),
            if score.chosen { "  <- chosen" } else { "" }
        )?;
    }
    if let Some(cv) = &d.cross_validation {
        writeln!(
            err,
            "  ridge: λ = {}·diag(AᵀA) chosen by {}-fold blocked cross-validation; expected residual on new data {:.4} nT",
            short_number(cv.chosen_lambda_rel),
            cv.folds,
            cv.expected_heldout_rms_nt
        )?;
    }
    writeln!(
        err,
        "  {:<12} {:>14} {:>12}",
        "term", "coefficient", "std error"
    )?;
    for ((name, beta), se) in model
        .fit
        .columns
        .iter()
        .zip(&model.fit.coefficients)
        .zip(&d.std_errors)
    {
        writeln!(err, "  {name:<12} {beta:>14.6} {se:>12.4}")?;
    }
    let p = &model.patent;
    writeln!(
        err,
        "  patent terms: perm T {:.3} L {:.3} V {:.3} nT; induced VV-TT {:.5} VV-LL {:.5} TL+LT {:.5} TV+VT {:.5} LV+VL {:.5}",
        p.perm_nt.t, p.perm_nt.l, p.perm_nt.v, p.induced.vv_tt, p.induced.vv_ll, p.induced.tl_lt, p.induced.tv_vt, p.induced.lv_vl
    )?;
    Ok(())
}

/// `0`, `1e-8`, `0.001`: the shortest honest text for a ridge strength.
fn short_number(x: f64) -> String {
    if x == 0.0 || (1e-3..1e3).contains(&x.abs()) {
        format!("{x}")
    } else {
        format!("{x:e}")
    }
}
