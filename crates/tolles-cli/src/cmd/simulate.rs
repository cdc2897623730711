//! `tolles simulate`: flights whose truth is known.

use crate::progress::Terminal;
use crate::render;
use anyhow::{anyhow, Result};
use clap::ValueEnum;
use std::path::PathBuf;
use tolles::simulate::{self, CabinEffects, PlanKind, SimulateRequest, UniformField};
use tolles::Error;

const EXAMPLES: &str = "\
Examples:
  tolles simulate --plan box --seed 1 --out box.csv
  tolles simulate --plan survey --preset tail-stinger --lines 6 --geology 50 --out survey.csv
  tolles simulate --plan patent --inclination 60 --declination 0 --intensity 50000 --out patent.csv
  tolles simulate --plan box --period 4 --cycles 4 --fs 160 --flux-lag 0.05 --out fast.csv
  tolles simulate --plan box --effects all --out cabin.csv
  tolles fit cabin.csv --scalar mag_1_uc --vector flux_a --reference mag_ref --extra cur_load,pos_flap,temp";

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

/// A typical installation.
#[derive(Clone, Copy, Debug, ValueEnum)]
pub enum Preset {
    /// Tail stinger: a few nT of aircraft field
    TailStinger,
    /// Cabin: hundreds of nT, with a second-order induced field
    Cabin,
    /// UAV: moderate airframe field and strong motor currents (column cur_1)
    Uav,
    /// A cabin as real boxes measure: a thousand nT, a fluxgate that sees the aircraft
    /// (thousands of nT of offset, drifting), an unmodelled current in the band (column cur_1)
    Realistic,
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
    /// Output file: .csv, .h5/.hdf5 or .parquet/.pq by extension (the sidecar goes next to it,
    /// with extension .json)
    #[arg(short, long)]
    pub out: PathBuf,
    /// Installation: sets the aircraft field and its extras
    #[arg(long, value_enum, default_value = "cabin")]
    pub preset: Preset,
    /// Sample rate (Hz)
    #[arg(long, default_value_t = 10.0, allow_negative_numbers = true)]
    pub fs: f64,
    /// Ground speed (m/s)
    #[arg(long, default_value_t = 60.0, allow_negative_numbers = true)]
    pub speed: f64,
    /// Start latitude (degrees) for IGRF-14
    #[arg(long, default_value_t = 45.4, allow_negative_numbers = true)]
    pub lat: f64,
    /// Start longitude (degrees east) for IGRF-14
    #[arg(long, default_value_t = -75.7, allow_negative_numbers = true)]
    pub lon: f64,
    /// Altitude above the WGS84 ellipsoid (m)
    #[arg(long, default_value_t = 3000.0, allow_negative_numbers = true)]
    pub alt: f64,
    /// Date YYYY-MM-DD for IGRF-14
    #[arg(long, default_value = "2025-07-01")]
    pub date: String,
    /// Instead of IGRF: a uniform field of this inclination (dip; degrees, positive down)…
    #[arg(long, visible_alias = "dip", requires_all = ["declination", "intensity"], allow_negative_numbers = true)]
    pub inclination: Option<f64>,
    /// …declination (degrees east of true north)…
    #[arg(long, requires_all = ["inclination", "intensity"], allow_negative_numbers = true)]
    pub declination: Option<f64>,
    /// …and intensity (nT)
    #[arg(long, requires_all = ["inclination", "declination"], allow_negative_numbers = true)]
    pub intensity: Option<f64>,
    /// Maneuver period (s), box and patent plans
    #[arg(long, default_value_t = 6.0, allow_negative_numbers = true)]
    pub period: f64,
    /// Cycles of each maneuver, box and patent plans
    #[arg(long, default_value_t = 3)]
    pub cycles: u32,
    /// Roll amplitude (degrees); default 10 for the box, 15 for the patent plan
    #[arg(long, allow_negative_numbers = true)]
    pub roll: Option<f64>,
    /// Pitch amplitude (degrees); default 5 for the box, 10 for the patent plan
    #[arg(long, allow_negative_numbers = true)]
    pub pitch: Option<f64>,
    /// Yaw amplitude (degrees), box plan
    #[arg(long, default_value_t = 5.0, allow_negative_numbers = true)]
    pub yaw: f64,
    /// Number of survey lines
    #[arg(long, default_value_t = 4)]
    pub lines: u32,
    /// Duration of each survey line (s)
    #[arg(long, default_value_t = 120.0, allow_negative_numbers = true)]
    pub line_duration: f64,
    /// Turbulence on survey lines (degrees)
    #[arg(long, default_value_t = 0.5, allow_negative_numbers = true)]
    pub turbulence: f64,
    /// Largest geology anomaly (nT); 0 for none
    #[arg(long, default_value_t = 20.0, allow_negative_numbers = true)]
    pub geology: f64,
    /// Diurnal variation amplitude (nT, 1 h period); 0 for none
    #[arg(long, default_value_t = 3.0, allow_negative_numbers = true)]
    pub diurnal: f64,
    /// Scalar magnetometer white noise (nT)
    #[arg(long, default_value_t = 0.01, allow_negative_numbers = true)]
    pub scalar_noise: f64,
    /// Fluxgate white noise per axis (nT)
    #[arg(long, default_value_t = 0.5, allow_negative_numbers = true)]
    pub flux_noise: f64,
    /// How late the fluxgate samples relative to the scalar (s; negative: early)
    #[arg(long, default_value_t = 0.0, allow_negative_numbers = true)]
    pub flux_lag: f64,
    /// Cabin effects Tolles-Lawson cannot represent, comma-separated: load (a saturating load
    /// current, column cur_load in A), flap (a control surface turning a magnetised part,
    /// pos_flap in degrees), temp (temperature-dependent magnetisation, temp in °C); or all.
    /// Adds their truth (truth_effects, nT) and a reference magnetometer (mag_ref, nT)
    #[arg(long, value_name = "LIST")]
    pub effects: Option<CabinEffects>,
    /// Also write a reference magnetometer free of the aircraft's field (column mag_ref, nT),
    /// as a tail stinger would read it; implied by --effects
    #[arg(long)]
    pub reference: bool,
    /// The reference magnetometer's white noise (nT)
    #[arg(long, default_value_t = 0.01, allow_negative_numbers = true)]
    pub reference_noise: f64,
}

pub fn run(args: Args) -> Result<()> {
    let request = request(&args);
    let simulated = simulate::simulate(&request, &Terminal::default()).map_err(error)?;
    let sidecar = simulate::write(&simulated, &args.out).map_err(error)?;
    note!(
        "simulated {} plan: {} samples at {} Hz ({:.0} s) -> {} and {}",
        simulated.plan_kind.name(),
        simulated.flight.tt.len(),
        args.fs,
        simulated.plan.duration_s(),
        args.out.display(),
        sidecar.display()
    );
    Ok(())
}

/// The library request the flags ask for.
fn request(args: &Args) -> SimulateRequest {
    let uniform = match (args.inclination, args.declination, args.intensity) {
        (Some(inclination_deg), Some(declination_deg), Some(intensity_nt)) => Some(UniformField {
            inclination_deg,
            declination_deg,
            intensity_nt,
        }),
        _ => None,
    };
    SimulateRequest {
        plan: match args.plan {
            PlanName::Box => PlanKind::Box,
            PlanName::Patent => PlanKind::Patent,
            PlanName::Survey => PlanKind::Survey,
        },
        seed: args.seed,
        preset: match args.preset {
            Preset::TailStinger => simulate::Preset::TailStinger,
            Preset::Cabin => simulate::Preset::Cabin,
            Preset::Uav => simulate::Preset::Uav,
            Preset::Realistic => simulate::Preset::Realistic,
        },
        fs_hz: args.fs,
        speed_mps: args.speed,
        lat_deg: args.lat,
        lon_deg: args.lon,
        alt_m: args.alt,
        date: args.date.clone(),
        uniform,
        period_s: args.period,
        cycles: args.cycles,
        roll_deg: args.roll,
        pitch_deg: args.pitch,
        yaw_deg: args.yaw,
        lines: args.lines,
        line_duration_s: args.line_duration,
        turbulence_deg: args.turbulence,
        geology_nt: args.geology,
        diurnal_nt: args.diurnal,
        scalar_noise_nt: args.scalar_noise,
        flux_noise_nt: args.flux_noise,
        flux_lag_s: args.flux_lag,
        effects: args.effects.unwrap_or_default(),
        reference: args.reference,
        reference_noise_nt: args.reference_noise,
    }
}

/// A library error, naming the flag that sets what it is about.
fn error(e: Error) -> anyhow::Error {
    match e {
        Error::DateFormat { text } => anyhow!("--date must be YYYY-MM-DD, got {text:?}"),
        Error::Date { text, reason } => anyhow!("--date {text}: {reason}"),
        other => render::error(other),
    }
}
