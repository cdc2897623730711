//! `tolles demo`: the built-in example, end to end through the same code paths as the
//! `fit` and `compensate` commands.

use crate::cmd;
use crate::render::{self, OrRender, Use};
use anyhow::{Context, Result};
use std::io::Write;
use std::path::{Path, PathBuf};
use tolles_core::filter::magnav_bandpass;
use tolles_core::interpret::AircraftField;
use tolles_core::metrics::{improvement_ratio, noise_level, std_dev};
use tolles_core::plan::{BoxPlan, Plan, SurveyPlan};
use tolles_core::sim::{simulate, Installation, Scenario, SimulatedFlight};
use tolles_io::model::ModelFile;
use tolles_io::simulation::{write_flight, Sidecar, SCALAR, VECTOR};
use tolles_io::table::Table;

/// Simulate a calibration box and a survey, fit, compensate and compare with the truth.
///
/// Example: `tolles demo --out /tmp/tolles-demo`
///
/// The aircraft is a cabin installation (a strong field of tens of nT); everything is written
/// to --out so each step can be repeated by hand with `tolles fit` and `tolles compensate`.
#[derive(clap::Args)]
#[command(
    after_help = "Example:\n  tolles demo --out /tmp/tolles-demo\n  tolles fit /tmp/tolles-demo/calibration.csv --scalar mag_1_uc --vector flux_a"
)]
pub struct Args {
    /// Directory for the simulated flights, the model and the compensated survey
    #[arg(long, default_value = "tolles-demo")]
    pub out: PathBuf,
    /// Seed of the simulation
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
}

pub fn run(args: Args) -> Result<()> {
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("{}: cannot create directory", args.out.display()))?;
    let installation = Installation::Cabin;
    let truth = installation.aircraft();
    let cal_path = args.out.join("calibration.csv");
    let survey_path = args.out.join("survey.csv");
    let model_path = args.out.join("model.json");
    let compensated_path = args.out.join("survey_compensated.csv");
    let box_plan = BoxPlan::default().build();
    let cal = fly(
        "box",
        &box_plan,
        &installation.scenario(args.seed),
        &cal_path,
    )?;
    let survey_plan = SurveyPlan::default().build();
    let survey_scenario = installation.scenario(args.seed + 1);
    let survey = fly("survey", &survey_plan, &survey_scenario, &survey_path)?;
    println!(
        "Simulated a cabin installation at 10 Hz over IGRF-14 with geology and diurnal variation: a calibration box (N, E, S, W; roll ±10°, pitch ±5°, yaw ±5°) of {} samples and a survey of 4 lines, {} samples.",
        cal.tt.len(),
        survey.tt.len()
    );
    std::io::stdout().flush()?;
    println!(
        "\n$ tolles fit {} --scalar {SCALAR} --vector {VECTOR} --out {}",
        cal_path.display(),
        model_path.display()
    );
    fit(&cal_path, &model_path)?;
    std::io::stdout().flush()?;
    println!(
        "\n$ tolles compensate {} --model {} --out {}",
        survey_path.display(),
        model_path.display(),
        compensated_path.display()
    );
    cmd::compensate::run(cmd::compensate::Args {
        survey: survey_path,
        model: model_path.clone(),
        out: Some(compensated_path.clone()),
        fs: None,
        level: Default::default(),
        select: Default::default(),
    })?;
    std::io::stdout().flush()?;
    report(&survey, &compensated_path, &model_path, &truth)?;
    figure_of_merit(&cal_path, &model_path)?;
    let report_dir = args.out.join("report");
    println!(
        "\n$ tolles report {} --scalar {SCALAR} --model {} --out {}",
        cal_path.display(),
        model_path.display(),
        report_dir.display()
    );
    let index = cmd::report::write(&cmd::report::Args {
        flight: cal_path,
        scalar: SCALAR.into(),
        model: Some(model_path),
        out: report_dir,
        band: "0.05,1".into(),
        fs: None,
    })?;
    println!(
        "Open {} in a browser (it needs no network).",
        index.display()
    );
    Ok(())
}

/// `tolles fit CAL --scalar mag_1_uc --vector flux_a --out MODEL` with the defaults.
fn fit(cal: &Path, model: &Path) -> Result<()> {
    cmd::fit::run_request(
        cal,
        &tolles::fit::FitRequest::new(vec![SCALAR.into()], vec![VECTOR.into()]),
        Some(model),
    )
}

/// Prints the FOM of the calibration box before and after compensation.
fn figure_of_merit(cal: &Path, model: &Path) -> Result<()> {
    let model_file = ModelFile::read(model)?;
    let table = crate::select::Selection::default().read(cal, Use::Other)?;
    let settings = tolles_core::fom::FomSettings::default();
    let request = tolles::fom::FomRequest {
        band: settings.band,
        order: settings.order,
        ..tolles::fom::FomRequest::new(SCALAR)
    };
    let mut warnings = Vec::new();
    let outcome = tolles::fom::fom(&table, &request, Some(&model_file.fits[0]), &mut warnings);
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
        outcome.before.fom_nt / after.fom_nt
    );
    Ok(())
}

/// Simulates `plan` and writes it as a flight CSV with truth columns, plus its sidecar.
fn fly(name: &str, plan: &Plan, scenario: &Scenario, path: &Path) -> Result<SimulatedFlight> {
    let flight = simulate(plan, scenario)?;
    write_flight(path, &flight)?;
    Sidecar::new(name, plan, scenario).write(&cmd::simulate::sidecar_path(path))?;
    Ok(flight)
}

fn report(
    survey: &SimulatedFlight,
    compensated: &Path,
    model: &Path,
    truth: &AircraftField,
) -> Result<()> {
    let table = Table::read_csv(compensated)?;
    let clean = table.numeric("mag_1_c")?;
    let error =
        |x: &[f64]| -> Vec<f64> { x.iter().zip(&survey.earth_nt).map(|(a, b)| a - b).collect() };
    let filter = magnav_bandpass(0.1, 0.9, 4, 10.0)?;
    let (before, after) = (
        noise_level(&survey.scalar, filter.as_ref())?,
        noise_level(&clean, filter.as_ref())?,
    );
    let mut out = std::io::stdout().lock();
    writeln!(out, "\nSurvey result against the simulator's truth:")?;
    writeln!(
        out,
        "  error (scalar − earth field), std:   before {:8.3} nT   after {:8.4} nT",
        std_dev(&error(&survey.scalar)),
        std_dev(&error(&clean))
    )?;
    writeln!(
        out,
        "  band-passed 0.1–0.9 Hz noise level:  before {before:8.3} nT   after {after:8.4} nT   improvement ×{:.0}",
        improvement_ratio(before, after)
    )?;
    let found = &ModelFile::read(model)?.fits[0].patent;
    writeln!(
        out,
        "\nThe aircraft's field in the Tolles patent's terms (L = forward, T = right, V = down):"
    )?;
    writeln!(out, "  {:<7} {:>12} {:>12}", "term", "true", "fitted")?;
    for ((name, t), (_, f)) in truth.patent_terms().named().iter().zip(found.named()) {
        writeln!(out, "  {name:<7} {t:>12.4e} {f:>12.4e}")?;
    }
    writeln!(
        out,
        "  (perm in nT, induced dimensionless, eddy in seconds)"
    )?;
    Ok(())
}
