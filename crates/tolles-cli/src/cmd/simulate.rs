//! `tolles simulate`: flights whose truth is known.

use anyhow::{bail, Context, Result};
use clap::ValueEnum;
use std::path::{Path, PathBuf};
use tolles_core::environment::{Diurnal, Environment, Geology, Location};
use tolles_core::igrf::decimal_year;
use tolles_core::plan::{BoxPlan, PatentPlan, Plan, SurveyPlan};
use tolles_core::sim::{simulate_with_progress, EarthField, Installation, Scenario};
use tolles_io::simulation::{write_flight, Sidecar};

const EXAMPLES: &str = "\
Examples:
  tolles simulate --plan box --seed 1 --out box.csv
  tolles simulate --plan survey --preset tail-stinger --lines 6 --geology 50 --out survey.csv
  tolles simulate --plan patent --inclination 60 --declination 0 --intensity 50000 --out patent.csv
  tolles simulate --plan box --period 4 --cycles 4 --fs 160 --flux-lag 0.05 --out fast.csv";

/// A flight plan.
#[derive(Clone, Copy, Debug, ValueEnum)]
pub enum PlanName {
    /// The compensation box: roll, pitch and yaw maneuvers on N, E, S, W
    Box,
    /// The Tolles patent's maneuvers: rolls on 8 headings, pitches on 4, wing-ups, cloverleaf
    Patent,
    /// Straight survey lines with turbulence, joined by 180° turns
    Survey,
}

impl PlanName {
    fn name(self) -> &'static str {
        match self {
            PlanName::Box => "box",
            PlanName::Patent => "patent",
            PlanName::Survey => "survey",
        }
    }
}

/// A typical installation.
#[derive(Clone, Copy, Debug, ValueEnum)]
pub enum Preset {
    /// Tail stinger: a few nT of aircraft field
    TailStinger,
    /// Cabin: hundreds of nT, with a second-order induced field
    Cabin,
    /// UAV: moderate airframe field and strong motor currents (column cur_1)
    Uav,
}

/// Simulate a flight of a scalar magnetometer and a fluxgate whose truth is known.
///
/// Writes the flight as CSV in the layout `tolles fit` reads (tt, line, lat, lon, ins_roll,
/// ins_pitch, ins_yaw, mag_1_uc, flux_a_x/y/z, truth columns) and a JSON sidecar (OUT with
/// `.json`) with every parameter and the true terms in physical and patent nomenclature.
/// Deterministic: the same arguments give the same file.
#[derive(clap::Args)]
#[command(after_help = EXAMPLES)]
pub struct Args {
    /// Flight plan
    #[arg(long, value_enum, default_value = "box")]
    pub plan: PlanName,
    /// Seed of noise, turbulence and geology
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Output CSV (the sidecar goes next to it, with extension .json)
    #[arg(long)]
    pub out: PathBuf,
    /// Installation: sets the aircraft field and its extras
    #[arg(long, value_enum, default_value = "cabin")]
    pub preset: Preset,
    /// Sample rate (Hz)
    #[arg(long, default_value_t = 10.0)]
    pub fs: f64,
    /// Ground speed (m/s)
    #[arg(long, default_value_t = 60.0)]
    pub speed: f64,
    /// Start latitude (degrees) for IGRF-14
    #[arg(long, default_value_t = 45.4)]
    pub lat: f64,
    /// Start longitude (degrees east) for IGRF-14
    #[arg(long, default_value_t = -75.7, allow_hyphen_values = true)]
    pub lon: f64,
    /// Altitude above the WGS84 ellipsoid (m)
    #[arg(long, default_value_t = 3000.0)]
    pub alt: f64,
    /// Date YYYY-MM-DD for IGRF-14
    #[arg(long, default_value = "2025-07-01")]
    pub date: String,
    /// Instead of IGRF: a uniform field of this inclination (degrees, down positive)…
    #[arg(long, requires_all = ["declination", "intensity"], allow_hyphen_values = true)]
    pub inclination: Option<f64>,
    /// …declination (degrees east of true north)…
    #[arg(long, requires_all = ["inclination", "intensity"], allow_hyphen_values = true)]
    pub declination: Option<f64>,
    /// …and intensity (nT)
    #[arg(long, requires_all = ["inclination", "declination"])]
    pub intensity: Option<f64>,
    /// Maneuver period (s), box and patent plans
    #[arg(long, default_value_t = 6.0)]
    pub period: f64,
    /// Cycles of each maneuver, box and patent plans
    #[arg(long, default_value_t = 3)]
    pub cycles: u32,
    /// Roll amplitude (degrees); default 10 for the box, 15 for the patent plan
    #[arg(long)]
    pub roll: Option<f64>,
    /// Pitch amplitude (degrees); default 5 for the box, 10 for the patent plan
    #[arg(long)]
    pub pitch: Option<f64>,
    /// Yaw amplitude (degrees), box plan
    #[arg(long, default_value_t = 5.0)]
    pub yaw: f64,
    /// Number of survey lines
    #[arg(long, default_value_t = 4)]
    pub lines: u32,
    /// Duration of each survey line (s)
    #[arg(long, default_value_t = 120.0)]
    pub line_duration: f64,
    /// Turbulence on survey lines (degrees)
    #[arg(long, default_value_t = 0.5)]
    pub turbulence: f64,
    /// Largest geology anomaly (nT); 0 for none
    #[arg(long, default_value_t = 20.0)]
    pub geology: f64,
    /// Diurnal variation amplitude (nT, 1 h period); 0 for none
    #[arg(long, default_value_t = 3.0)]
    pub diurnal: f64,
    /// Scalar magnetometer white noise (nT)
    #[arg(long, default_value_t = 0.01)]
    pub scalar_noise: f64,
    /// Fluxgate white noise per axis (nT)
    #[arg(long, default_value_t = 0.5)]
    pub flux_noise: f64,
    /// How late the fluxgate samples relative to the scalar (s)
    #[arg(long, default_value_t = 0.0)]
    pub flux_lag: f64,
}

pub fn run(args: Args) -> Result<()> {
    let plan = plan(&args);
    let scenario = scenario(&args)?;
    let bar = crate::progress::bar(0, "simulating");
    let flight = simulate_with_progress(&plan, &scenario, &mut |done, total| {
        bar.set_length(total as u64);
        bar.set_position(done as u64);
    })
    .context("simulating the flight")?;
    bar.finish_and_clear();
    write_flight(&args.out, &flight)?;
    let sidecar = sidecar_path(&args.out);
    Sidecar::new(args.plan.name(), &plan, &scenario).write(&sidecar)?;
    eprintln!(
        "simulated {} plan: {} samples at {} Hz ({:.0} s) -> {} and {}",
        args.plan.name(),
        flight.tt.len(),
        args.fs,
        plan.duration_s(),
        args.out.display(),
        sidecar.display()
    );
    Ok(())
}

/// `flight.csv` → `flight.json`.
pub fn sidecar_path(csv: &Path) -> PathBuf {
    csv.with_extension("json")
}

fn plan(args: &Args) -> Plan {
    match args.plan {
        PlanName::Box => BoxPlan {
            roll_deg: args.roll.unwrap_or(10.0),
            pitch_deg: args.pitch.unwrap_or(5.0),
            yaw_deg: args.yaw,
            period_s: args.period,
            cycles: args.cycles,
            ..BoxPlan::default()
        }
        .build(),
        PlanName::Patent => PatentPlan {
            roll_deg: args.roll.unwrap_or(15.0),
            pitch_deg: args.pitch.unwrap_or(10.0),
            period_s: args.period,
            cycles: args.cycles,
            ..PatentPlan::default()
        }
        .build(),
        PlanName::Survey => SurveyPlan {
            lines: args.lines,
            line_s: args.line_duration,
            turbulence_deg: args.turbulence,
            seed: args.seed,
            ..SurveyPlan::default()
        }
        .build(),
    }
}

fn scenario(args: &Args) -> Result<Scenario> {
    let installation = match args.preset {
        Preset::TailStinger => Installation::TailStinger,
        Preset::Cabin => Installation::Cabin,
        Preset::Uav => Installation::Uav,
    };
    check_positive("--fs", args.fs)?;
    check_positive("--period", args.period)?;
    let mut scenario = installation.scenario(args.seed);
    scenario.fs_hz = args.fs;
    scenario.speed_mps = args.speed;
    scenario.environment = environment(args)?;
    scenario.sensors.scalar_noise_nt = args.scalar_noise;
    scenario.sensors.flux_noise_nt = args.flux_noise;
    scenario.sensors.fluxgate.lag_s = args.flux_lag;
    Ok(scenario)
}

fn environment(args: &Args) -> Result<Environment> {
    let mut env = match (args.inclination, args.declination, args.intensity) {
        (Some(inclination_deg), Some(declination_deg), Some(intensity_nt)) => {
            Environment::uniform(EarthField {
                intensity_nt,
                inclination_deg,
                declination_deg,
            })
        }
        _ => Environment::at(Location {
            lat_deg: args.lat,
            lon_deg: args.lon,
            alt_m: args.alt,
            year: parse_date(&args.date)?,
        }),
    };
    if args.geology > 0.0 {
        env.geology = Some(Geology::random(40, args.geology, 15_000.0, args.seed));
    }
    if args.diurnal > 0.0 {
        env.diurnal = Some(Diurnal {
            amplitude_nt: args.diurnal,
            period_s: 3_600.0,
            phase_rad: 0.4,
        });
    }
    Ok(env)
}

fn parse_date(text: &str) -> Result<f64> {
    let parts: Vec<&str> = text.split('-').collect();
    let [y, m, d] = parts[..] else {
        bail!("--date must be YYYY-MM-DD, got {text:?}")
    };
    let (Ok(y), Ok(m), Ok(d)) = (y.parse(), m.parse(), d.parse()) else {
        bail!("--date must be YYYY-MM-DD, got {text:?}")
    };
    decimal_year(y, m, d).with_context(|| format!("--date {text}"))
}

fn check_positive(name: &str, value: f64) -> Result<()> {
    if !(value.is_finite() && value > 0.0) {
        bail!("{name} must be a positive number, got {value}");
    }
    Ok(())
}
