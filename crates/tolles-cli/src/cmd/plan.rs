//! `tolles plan`: how well a calibration flight determines each term, before or after flying it.

use crate::progress::Terminal;
use crate::render::{self, OrRender, Use};
use anyhow::{anyhow, bail, Result};
use clap::ValueEnum;
use std::io::Write;
use tolles::plan::{BuiltinPlan, Maneuvers, PlanOutcome, PlanRequest, BAND_HZ};
use tolles_core::flight::plan::Axis;
use tolles_core::flight::sim::EarthField;
use tolles_core::patent::Term;

const EXAMPLES: &str = "\
Examples:
  # The standard box, and the same box without its yaw maneuvers:
  tolles plan --plan box
  tolles plan --plan box --without yaw
  # Any list of maneuvers (kind@heading; kinds roll, pitch, yaw, wingup):
  tolles plan --maneuvers roll@0,roll@90,pitch@0,pitch@90,wingup@90 --inclination 60 --json
  # A flight already flown: maneuvers found in ins_roll/ins_pitch/ins_yaw, fluxgate flux_a:
  tolles plan cal.csv --vector flux_a";

/// A built-in plan to evaluate.
#[derive(Clone, Copy, Debug, ValueEnum)]
pub enum PlanName {
    /// The compensation box (roll ±10°, pitch ±5°, yaw ±5° on N, E, S, W)
    Box,
    /// The Tolles patent's maneuvers
    Patent,
}

/// A maneuver kind to leave out.
#[derive(Clone, Copy, Debug, ValueEnum, PartialEq)]
pub enum Kind {
    Roll,
    Pitch,
    Yaw,
}

/// Evaluate how well a planned (or flown) set of maneuvers determines each of the 16 Tolles terms.
///
/// For every term (perm T, L, V; induced VV-TT, VV-LL, TL+LT, TV+VT, LV+VL; eddy vv-tt, vv-ll,
/// tl, tv, lt, lv, vl, vt) it reports the standard error the flight would give, its variance
/// inflation (how much other terms can mimic it), the maneuvers that carry its information, the
/// terms it is confounded with, and for poorly determined terms the standard maneuver that would
/// help most. A plan is simulated without noise; the noise level sets the error scale. Given a
/// flight file instead, its harmonic maneuvers are found in the attitude columns and its own
/// fluxgate gives the information each carries (the dip for candidate maneuvers is taken from
/// the fluxgate during level flight).
#[derive(clap::Args)]
#[command(after_help = EXAMPLES)]
pub struct Args {
    #[arg(help = flight_help!("A flown calibration flight with tt, ins_roll, ins_pitch, ins_yaw and the fluxgate"))]
    pub flight: Option<std::path::PathBuf>,
    /// Fluxgate prefix of the flight (flux_a reads flux_a_x, flux_a_y, flux_a_z)
    #[arg(long, requires = "flight")]
    pub vector: Option<String>,
    /// A built-in plan
    #[arg(long, value_enum, default_value = "box", conflicts_with = "maneuvers")]
    pub plan: PlanName,
    /// Leave these maneuver kinds out of the built-in plan (repeatable)
    #[arg(long, value_enum)]
    pub without: Vec<Kind>,
    /// Instead of a built-in plan: maneuvers as KIND@HEADING, comma-separated
    #[arg(long)]
    pub maneuvers: Option<String>,
    /// Scalar noise level the standard errors assume (nT)
    #[arg(long, default_value_t = 0.01, allow_negative_numbers = true)]
    pub noise: f64,
    /// Inclination (dip) of the earth field (degrees, positive down)
    #[arg(
        long,
        visible_alias = "dip",
        default_value_t = 68.0,
        allow_negative_numbers = true
    )]
    pub inclination: f64,
    /// Field declination (degrees)
    #[arg(long, default_value_t = 0.0, allow_negative_numbers = true)]
    pub declination: f64,
    /// Field intensity (nT)
    #[arg(long, default_value_t = 52_000.0, allow_negative_numbers = true)]
    pub intensity: f64,
    /// Terms of the model
    #[arg(long, default_value = "permanent,i5,e8")]
    pub terms: tolles_core::model::terms::TermSet,
    /// Print JSON instead of a table
    #[arg(long)]
    pub json: bool,
    /// Sample rate (Hz) of a flight without a tt column (or to override it)
    #[arg(long, requires = "flight", allow_negative_numbers = true)]
    pub fs: Option<f64>,
    /// Rows and names of the flight (only with a flight)
    #[command(flatten)]
    pub select: crate::select::Selection,
}

pub fn run(args: Args) -> Result<()> {
    let request = PlanRequest {
        maneuvers: maneuvers(&args)?,
        terms: args.terms,
        noise_nt: args.noise,
        field: EarthField {
            intensity_nt: args.intensity,
            inclination_deg: args.inclination,
            declination_deg: args.declination,
        },
    };
    let mut warnings = Vec::new();
    let outcome = tolles::plan::plan(&request, &Terminal::default(), &mut warnings);
    render::warnings(&mut warnings, Use::Other);
    let outcome = outcome.or_render()?;
    let mut out = std::io::stdout().lock();
    if args.json {
        writeln!(out, "{}", serde_json::to_string_pretty(&outcome.to_json())?)?;
    } else {
        print_table(&mut out, &outcome)?;
    }
    Ok(())
}

/// The maneuvers the flags name: a flight, a list or a built-in plan.
fn maneuvers(args: &Args) -> Result<Maneuvers> {
    if let Some(path) = &args.flight {
        let vector = args.vector.clone();
        let vector = vector
            .ok_or_else(|| anyhow!("a flight needs --vector PREFIX (its fluxgate columns)"))?;
        return Ok(Maneuvers::Flown {
            path: path.clone(),
            vector,
            selection: args.select.rows(),
            renames: args.select.renames.clone(),
            fs_hz: args.fs,
        });
    }
    if !args.select.rows().is_empty() || !args.select.renames.is_empty() {
        bail!(
            "--line, --time and --rename choose rows and names of a flight; give the flight file"
        );
    }
    if let Some(list) = &args.maneuvers {
        return Ok(Maneuvers::List(list.clone()));
    }
    let plan = match args.plan {
        PlanName::Box => BuiltinPlan::Box,
        PlanName::Patent => BuiltinPlan::Patent,
    };
    let axis = |kind: &Kind| match kind {
        Kind::Roll => Axis::Roll,
        Kind::Pitch => Axis::Pitch,
        Kind::Yaw => Axis::Yaw,
    };
    let without = args.without.iter().map(axis).collect();
    Ok(Maneuvers::Builtin { plan, without })
}

fn print_table(out: &mut impl Write, outcome: &PlanOutcome) -> Result<()> {
    let analysis = &outcome.identifiability;
    writeln!(
        out,
        "Identifiability of the 16 Tolles terms (noise {} nT, band-pass {}–{} Hz):",
        analysis.noise_nt, BAND_HZ.0, BAND_HZ.1
    )?;
    writeln!(
        out,
        "  {:<6} {:>14} {:>9}  {:<9}  {:<44}  confounded with",
        "term", "std error", "VIF", "status", "carried mostly by (variance ×, without it)"
    )?;
    for t in &analysis.terms {
        let carriers: Vec<String> = t
            .carried_by
            .iter()
            .take(2)
            .map(|(l, r)| format!("{l} ×{}", ratio(*r)))
            .collect();
        let partners: Vec<String> = t
            .partners
            .iter()
            .take(2)
            .map(|(p, r)| format!("{p} (r={r:+.2})"))
            .collect();
        writeln!(
            out,
            "  {:<6} {:>11.3e} {:<2} {:>9} {:<9}  {:<44}  {}",
            t.name,
            t.std_error,
            Term::from_name(&t.name).map_or("", Term::unit),
            ratio(t.vif),
            if t.collinear { "collinear" } else { "ok" },
            carriers.join(", "),
            partners.join(", ")
        )?;
    }
    if !outcome.suggestions.is_empty() {
        writeln!(
            out,
            "\nPoorly determined terms and the maneuvers that would help most:"
        )?;
    }
    for s in &outcome.suggestions {
        let text: Vec<String> = s
            .maneuvers
            .iter()
            .map(|(l, r)| format!("{l} (std error ×{r:.2})"))
            .collect();
        writeln!(out, "  {:<6} add {}", s.term, text.join(", or "))?;
    }
    Ok(())
}

fn ratio(r: f64) -> String {
    if r.is_finite() {
        format!("{r:.1}")
    } else {
        "∞".to_string()
    }
}
