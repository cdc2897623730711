//! `tolles plan`: how well a calibration flight determines each term, before or after flying it.

use anyhow::{bail, Context, Result};
use clap::ValueEnum;
use std::io::Write;
use tolles_core::design::Design;
use tolles_core::environment::Environment;
use tolles_core::filter::magnav_bandpass;
use tolles_core::identifiability::{
    analyse_mapped, candidate_blocks, patent_map, planned_blocks, suggest, Block, Identifiability,
};
use tolles_core::interpret::AircraftField;
use tolles_core::plan::{Axis, BoxPlan, Motion, PatentPlan, Plan, Segment};
use tolles_core::sim::{EarthField, Scenario};

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
    /// A flown calibration flight (CSV with tt, ins_roll, ins_pitch, ins_yaw and the fluxgate)
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
    #[arg(long, default_value_t = 0.01)]
    pub noise: f64,
    /// Field inclination (degrees, down positive)
    #[arg(long, default_value_t = 68.0, allow_hyphen_values = true)]
    pub inclination: f64,
    /// Field declination (degrees)
    #[arg(long, default_value_t = 0.0, allow_hyphen_values = true)]
    pub declination: f64,
    /// Field intensity (nT)
    #[arg(long, default_value_t = 52_000.0)]
    pub intensity: f64,
    /// Terms of the model
    #[arg(long, default_value = "permanent,i5,e8")]
    pub terms: tolles_core::terms::TermSet,
    /// Print JSON instead of a table
    #[arg(long)]
    pub json: bool,
}

pub fn run(args: Args) -> Result<()> {
    let design = Design::new(args.terms);
    let mut scenario = Scenario::new(AircraftField::default(), 0);
    let mut earth = EarthField {
        intensity_nt: args.intensity,
        inclination_deg: args.inclination,
        declination_deg: args.declination,
    };
    let blocks = match &args.flight {
        Some(path) => {
            let vector = args.vector.as_deref().ok_or_else(|| {
                anyhow::anyhow!("a flight needs --vector PREFIX (its fluxgate columns)")
            })?;
            let flown = flown_blocks(path, vector, &design)?;
            scenario.fs_hz = flown.fs_hz;
            earth.inclination_deg = flown.dip_deg;
            earth.intensity_nt = flown.intensity_nt;
            flown.blocks
        }
        None => {
            scenario.environment = Environment::uniform(earth);
            let plan = match &args.maneuvers {
                Some(list) => plan_from_list(list)?,
                None => builtin(&args),
            };
            let filter = magnav_bandpass(0.1, 0.9, 4, scenario.fs_hz)?;
            planned_blocks(&plan, &scenario, &design, filter.as_ref())?
        }
    };
    scenario.environment = Environment::uniform(earth);
    let filter = magnav_bandpass(0.1, 0.9, 4, scenario.fs_hz)?;
    let candidates = candidate_blocks(&scenario, &design, filter.as_ref())?;
    report(
        &blocks,
        &candidates,
        &design,
        scenario.fs_hz,
        args.noise,
        args.json,
    )
}

/// What a flown flight contributes: one block per detected maneuver, and the field it flew in.
struct Flown {
    blocks: Vec<Block>,
    fs_hz: f64,
    dip_deg: f64,
    intensity_nt: f64,
}

fn flown_blocks(path: &std::path::Path, vector: &str, design: &Design) -> Result<Flown> {
    use tolles_core::maneuver::{detect_harmonic_maneuvers, ManeuverSettings};
    let table = crate::input::read_table(path)?;
    let flux = table.vector(vector)?;
    let tt = tolles::read::time_column(&table)
        .map_err(crate::render::error)?
        .ok_or_else(|| anyhow::anyhow!("{}: needs a time column tt", path.display()))?;
    let fs_hz = crate::input::sample_rate(&table, Some(&tt), None)?;
    let (roll, pitch, yaw) = (
        table.numeric("ins_roll")?,
        table.numeric("ins_pitch")?,
        table.numeric("ins_yaw")?,
    );
    if let Some(k) = (0..flux.len()).find(|&k| !flux.is_finite(k)) {
        bail!(
            "{}: line {}: the fluxgate has a missing value; identifiability needs a complete fluxgate record",
            path.display(),
            table.line_of(k)
        );
    }
    let maneuvers =
        detect_harmonic_maneuvers(&tt, &roll, &pitch, &yaw, &ManeuverSettings::default());
    if maneuvers.is_empty() {
        bail!(
            "{}: no harmonic maneuvers found in ins_roll, ins_pitch, ins_yaw",
            path.display()
        );
    }
    let windows: Vec<(String, std::ops::Range<usize>)> = maneuvers
        .iter()
        .map(|m| {
            (
                format!(
                    "{} on {:03.0}° at {:.0} s",
                    m.kind, m.heading_deg_measured, m.start_tt
                ),
                m.range(),
            )
        })
        .collect();
    let filter = magnav_bandpass(0.1, 0.9, 4, fs_hz)?;
    let blocks =
        tolles_core::identifiability::flight_blocks(&flux, design, filter.as_ref(), &windows)?;
    let (dip_deg, intensity_nt) = level_field(&flux, &roll, &pitch);
    Ok(Flown {
        blocks,
        fs_hz,
        dip_deg,
        intensity_nt,
    })
}

/// Dip (degrees) and intensity (nT) of the fluxgate over the samples flown within 2° of level.
fn level_field(
    flux: &tolles_core::vector::VectorSeries,
    roll: &[f64],
    pitch: &[f64],
) -> (f64, f64) {
    let level: Vec<usize> = (0..flux.len())
        .filter(|&k| roll[k].abs() < 2.0 && pitch[k].abs() < 2.0)
        .collect();
    let chosen: Vec<usize> = if level.is_empty() {
        (0..flux.len()).collect()
    } else {
        level
    };
    let n = chosen.len().max(1) as f64;
    let intensity = chosen.iter().map(|&k| flux.magnitude(k)).sum::<f64>() / n;
    let dip = chosen
        .iter()
        .map(|&k| (flux.z[k] / flux.magnitude(k)).asin())
        .sum::<f64>()
        / n;
    (dip.to_degrees(), intensity)
}

fn builtin(args: &Args) -> Plan {
    let keep = |kind: Kind, amplitude: f64| {
        if args.without.contains(&kind) {
            0.0
        } else {
            amplitude
        }
    };
    match args.plan {
        PlanName::Box => BoxPlan {
            roll_deg: keep(Kind::Roll, 10.0),
            pitch_deg: keep(Kind::Pitch, 5.0),
            yaw_deg: keep(Kind::Yaw, 5.0),
            ..BoxPlan::default()
        }
        .build(),
        PlanName::Patent => PatentPlan {
            roll_deg: keep(Kind::Roll, 15.0),
            pitch_deg: keep(Kind::Pitch, 10.0),
            ..PatentPlan::default()
        }
        .build(),
    }
}

/// `roll@0,pitch@90,wingup@270` → a plan with those maneuvers, each between straight legs.
fn plan_from_list(list: &str) -> Result<Plan> {
    let mut segments = Vec::new();
    for item in list.split(',').map(str::trim).filter(|s| !s.is_empty()) {
        let Some((kind, heading)) = item.split_once('@') else {
            bail!("--maneuvers: {item:?} is not KIND@HEADING (e.g. roll@90)")
        };
        let heading: f64 = heading
            .parse()
            .with_context(|| format!("--maneuvers: {heading:?} is not a heading in degrees"))?;
        let (duration_s, motion) = match kind {
            "roll" => (18.0, harmonic(Axis::Roll, 10.0)),
            "pitch" => (18.0, harmonic(Axis::Pitch, 5.0)),
            "yaw" => (18.0, harmonic(Axis::Yaw, 5.0)),
            // A right wing-up on an easterly heading, a left one otherwise, as in the patent.
            "wingup" => (
                20.0,
                Motion::Hold {
                    roll_deg: if heading.rem_euclid(360.0) < 180.0 {
                        -40.0
                    } else {
                        40.0
                    },
                },
            ),
            other => bail!("--maneuvers: unknown kind {other:?}; use roll, pitch, yaw or wingup"),
        };
        let leg = |line: usize, duration_s, motion| Segment {
            line: line as f64 + 1.0,
            heading_deg: heading,
            duration_s,
            motion,
        };
        segments.push(leg(segments.len(), 15.0, Motion::Straight));
        segments.push(leg(segments.len(), duration_s, motion));
    }
    if segments.is_empty() {
        bail!("--maneuvers: the list is empty");
    }
    let heading = segments.last().map_or(0.0, |s: &Segment| s.heading_deg);
    segments.push(Segment {
        line: segments.len() as f64 + 1.0,
        heading_deg: heading,
        duration_s: 15.0,
        motion: Motion::Straight,
    });
    Ok(Plan::new(segments))
}

fn harmonic(axis: Axis, amplitude_deg: f64) -> Motion {
    Motion::Harmonic {
        axis,
        amplitude_deg,
        period_s: 6.0,
    }
}

fn report(
    blocks: &[Block],
    candidates: &[Block],
    design: &Design,
    fs_hz: f64,
    noise: f64,
    json: bool,
) -> Result<()> {
    let (names, map) = patent_map(design, fs_hz);
    let analysis = analyse_mapped(blocks, &names, &map, noise);
    let fixes: Vec<(String, Vec<(String, f64)>)> = analysis
        .terms
        .iter()
        .enumerate()
        .filter(|(_, t)| t.collinear)
        .map(|(j, t)| {
            (
                t.name.clone(),
                suggest(blocks, candidates, &map, j)
                    .into_iter()
                    .take(3)
                    .collect(),
            )
        })
        .collect();
    let mut out = std::io::stdout().lock();
    if json {
        let value = serde_json::json!({ "identifiability": analysis, "suggestions": fixes });
        writeln!(out, "{}", serde_json::to_string_pretty(&value)?)?;
        return Ok(());
    }
    print_table(&mut out, &analysis)?;
    if !fixes.is_empty() {
        writeln!(
            out,
            "\nPoorly determined terms and the maneuvers that would help most:"
        )?;
        for (name, ranked) in &fixes {
            let text: Vec<String> = ranked
                .iter()
                .map(|(l, r)| format!("{l} (std error ×{r:.2})"))
                .collect();
            writeln!(out, "  {name:<6} add {}", text.join(", or "))?;
        }
    }
    Ok(())
}

fn unit(name: &str) -> &'static str {
    match name {
        "T" | "L" | "V" => "nT",
        n if n.chars().next().is_some_and(char::is_uppercase) => "",
        _ => "s",
    }
}

fn print_table(out: &mut impl Write, analysis: &Identifiability) -> Result<()> {
    writeln!(
        out,
        "Identifiability of the 16 Tolles terms (noise {} nT, band-pass 0.1–0.9 Hz):",
        analysis.noise_nt
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
            unit(&t.name),
            ratio(t.vif),
            if t.collinear { "collinear" } else { "ok" },
            carriers.join(", "),
            partners.join(", ")
        )?;
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
