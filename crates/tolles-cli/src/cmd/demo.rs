//! `tolles demo`: the built-in example, end to end through the same library calls as the
//! `simulate`, `fit`, `compensate`, `fom` and `report` commands.

use crate::progress::Terminal;
use crate::render::{self, OrRender, Use};
use anyhow::{Context, Result};
use std::io::Write;
use std::path::{Path, PathBuf};
use tolles::compensate::FileRequest;
use tolles::demo::DemoOutcome;
use tolles::fit::FitRequest;
use tolles::fom::FomRequest;
use tolles::model::ModelFile;
use tolles_io::simulation::{SCALAR, VECTOR};

/// Simulate a calibration box and a survey, fit, compensate and compare with the truth.
///
/// Example: `tolles demo --out /tmp/tolles-demo`
///
/// The aircraft is a cabin installation (a strong field of hundreds of nT); everything is written
/// to --out so each step can be repeated by hand with `tolles fit` and `tolles compensate`,
/// with two reports: --out/report (the calibration box) and --out/survey-report (the survey
/// compensated with the box's model, against the simulator's truth).
#[derive(clap::Args)]
#[command(
    after_help = "Example:\n  tolles demo --out /tmp/tolles-demo\n  tolles fit /tmp/tolles-demo/calibration.csv --scalar mag_1_uc --vector flux_a"
)]
pub struct Args {
    /// Directory for the simulated flights, the model, the compensated survey and the reports
    #[arg(short, long, default_value = "tolles-demo")]
    pub out: PathBuf,
    /// Seed of the simulation
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
}

pub fn run(args: Args) -> Result<()> {
    let out = &args.out;
    std::fs::create_dir_all(out)
        .with_context(|| format!("{}: cannot create directory", out.display()))?;
    let (cal, survey) = (out.join("calibration.csv"), out.join("survey.csv"));
    let (model_path, compensated) = (out.join("model.json"), out.join("survey_compensated.csv"));
    let flights = tolles::demo::flights(args.seed, &Terminal::default()).or_render()?;
    tolles::simulate::write(&flights.calibration, &cal).or_render()?;
    tolles::simulate::write(&flights.survey, &survey).or_render()?;
    println!(
        "Simulated a cabin installation at 10 Hz over IGRF-14 with geology and diurnal variation: a calibration box (N, E, S, W; roll ±10°, pitch ±5°, yaw ±5°) of {} samples and a survey of 4 lines, {} samples.",
        flights.calibration.flight.tt.len(),
        flights.survey.flight.tt.len()
    );
    std::io::stdout().flush()?;
    println!(
        "\n$ tolles fit {} --scalar {SCALAR} --vector {VECTOR} --out {}",
        cal.display(),
        model_path.display()
    );
    fit(&cal, &model_path)?;
    std::io::stdout().flush()?;
    println!(
        "\n$ tolles compensate {} --model {} --out {}",
        survey.display(),
        model_path.display(),
        compensated.display()
    );
    // Read back, as a user repeating the steps by hand would.
    let model = tolles::model::load_model(&model_path).or_render()?;
    compensate(&model, survey.clone(), &compensated)?;
    std::io::stdout().flush()?;
    let fit = &model.fits[0];
    let outcome = tolles::demo::compare(&flights.survey, &compensated, fit).or_render()?;
    print_outcome(&outcome)?;
    figure_of_merit(&cal, &model)?;
    for report in tolles::demo::reports(&cal, &survey, &model_path) {
        let dir = out.join(report.dir);
        println!(
            "\n$ tolles report {} --scalar {SCALAR} --model {} --out {}",
            report.request.flight.display(),
            model_path.display(),
            dir.display()
        );
        let index = render::report(&report.request, &[], &dir)?;
        println!(
            "Report on {}: open {} in a browser (it needs no network).",
            report.what,
            index.display()
        );
    }
    Ok(())
}

/// `tolles fit CAL --scalar mag_1_uc --vector flux_a --out MODEL` with the defaults.
fn fit(cal: &Path, model: &Path) -> Result<()> {
    let table = crate::select::Selection::default().read(cal, Use::Fit)?;
    let request = FitRequest::new(vec![SCALAR.into()], vec![VECTOR.into()]);
    let mut warnings = Vec::new();
    let fitted = tolles::fit::fit(&table, &request, &Terminal::default(), &mut warnings);
    render::warnings(&mut warnings, Use::Fit);
    let fitted = fitted.or_render()?;
    render::fit_summary(&fitted.fits[0], table.path())?;
    tolles::model::save_model(&fitted, model).or_render()
}

/// `tolles compensate SURVEY --model MODEL --out OUT`.
fn compensate(model: &ModelFile, survey: PathBuf, out: &Path) -> Result<()> {
    let request = FileRequest {
        survey,
        out: Some(out.to_path_buf()),
        ..FileRequest::default()
    };
    let mut warnings = Vec::new();
    let progress = Terminal::default();
    let sink = &mut std::io::sink();
    let done = tolles::compensate::compensate_file(model, &request, sink, &progress, &mut warnings);
    render::warnings(&mut warnings, Use::Compensate);
    done.or_render()?;
    Ok(())
}

/// Prints the FOM of the calibration box before and after compensation.
fn figure_of_merit(cal: &Path, model: &ModelFile) -> Result<()> {
    let table = crate::select::Selection::default().read(cal, Use::Other)?;
    let mut warnings = Vec::new();
    let outcome = tolles::fom::fom(
        &table,
        &FomRequest::new(SCALAR),
        Some(&model.fits[0]),
        &mut warnings,
    );
    render::warnings(&mut warnings, Use::Other);
    let outcome = outcome.or_render()?;
    let after = outcome.after.as_ref().expect("a model was given");
    let (lo, hi) = outcome.before.band_hz;
    println!(
        "\nFigure of merit of the calibration box ({} of 12 maneuvers found, band {lo}–{hi} Hz):",
        12 - outcome.before.missing.len()
    );
    println!(
        "  FOM before {:8.3} nT   after {:7.3} nT   improvement ×{:.0}",
        outcome.before.fom_nt,
        after.fom_nt,
        outcome.improvement_ratio().unwrap_or(f64::NAN)
    );
    Ok(())
}

/// The survey against the simulator's truth, and the aircraft's field true and fitted.
fn print_outcome(outcome: &DemoOutcome) -> Result<()> {
    let mut out = std::io::stdout().lock();
    let (lo, hi) = outcome.band_hz;
    writeln!(out, "\nSurvey result against the simulator's truth:")?;
    writeln!(
        out,
        "  error (scalar − earth field), std:   before {:8.3} nT   after {:8.4} nT",
        outcome.error_before_nt, outcome.error_after_nt
    )?;
    writeln!(
        out,
        "  band-passed {lo}–{hi} Hz noise level:  before {:8.3} nT   after {:8.4} nT   improvement ×{:.0}",
        outcome.noise_before_nt, outcome.noise_after_nt, outcome.improvement
    )?;
    writeln!(
        out,
        "\nThe aircraft's field in the Tolles patent's terms (L = forward, T = right, V = down):"
    )?;
    writeln!(out, "  {:<7} {:>12} {:>12}", "term", "true", "fitted")?;
    for term in &outcome.terms {
        let (name, t, f) = (term.name, term.truth, term.fitted);
        writeln!(out, "  {name:<7} {t:>12.4e} {f:>12.4e}")?;
    }
    writeln!(
        out,
        "  (perm in nT, induced dimensionless, eddy in seconds)"
    )?;
    Ok(())
}
