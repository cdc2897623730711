//! Flights whose truth is known: a plan flown by a simulated installation over IGRF-14 (or a
//! uniform field), with geology, diurnal variation and sensor errors.

mod limits;
pub mod output;

use crate::error::{Error, Result};
use crate::progress::{Progress, Stage};
use output::{write_flight, Sidecar};
use std::path::{Path, PathBuf};
use std::str::FromStr;
use tolles_core::flight::effects::{ControlSurface, Effects, SaturatingLoad, Temperature};
use tolles_core::flight::environment::{Diurnal, Environment, Geology, Location};
use tolles_core::flight::igrf::decimal_year;
use tolles_core::flight::plan::{BoxPlan, PatentPlan, Plan, SurveyPlan};
use tolles_core::flight::sim::{
    simulate_with_progress, EarthField, Installation, Scenario, SimulatedFlight,
};

/// Which flight plan.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum PlanKind {
    /// The compensation box: roll, pitch and yaw maneuvers on N, E, S, W.
    #[default]
    Box,
    /// The Tolles patent's maneuvers: rolls on 8 headings, pitches on 4, wing-ups, cloverleaf.
    Patent,
    /// Straight survey lines with turbulence, joined by 180° turns.
    Survey,
}

impl PlanKind {
    /// `box`, `patent` or `survey`.
    pub fn name(self) -> &'static str {
        match self {
            PlanKind::Box => "box",
            PlanKind::Patent => "patent",
            PlanKind::Survey => "survey",
        }
    }
}

impl FromStr for PlanKind {
    type Err = String;
    fn from_str(text: &str) -> Result<Self, String> {
        match text.trim().to_ascii_lowercase().as_str() {
            "box" => Ok(PlanKind::Box),
            "patent" => Ok(PlanKind::Patent),
            "survey" => Ok(PlanKind::Survey),
            _ => Err(format!("expected box, patent or survey, got {text:?}")),
        }
    }
}

/// A typical installation.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Preset {
    /// Tail stinger: a few nT of aircraft field.
    TailStinger,
    /// Cabin: hundreds of nT, with a second-order induced field.
    #[default]
    Cabin,
    /// UAV: moderate airframe field and strong motor currents (column `cur_1`).
    Uav,
    /// A cabin as real boxes measure it: a thousand nT of aircraft field, a fluxgate that sees
    /// the aircraft (thousands of nT of offset, drifting by tens), and an unmodelled current
    /// inside the band (column `cur_1`); see `docs/simulation.md`.
    Realistic,
}

impl FromStr for Preset {
    type Err = String;
    fn from_str(text: &str) -> Result<Self, String> {
        match text.trim().to_ascii_lowercase().replace('_', "-").as_str() {
            "tail-stinger" => Ok(Preset::TailStinger),
            "cabin" => Ok(Preset::Cabin),
            "uav" => Ok(Preset::Uav),
            "realistic" => Ok(Preset::Realistic),
            _ => Err(format!(
                "expected tail-stinger, cabin, uav or realistic, got {text:?}"
            )),
        }
    }
}

/// Which cabin effects the Tolles-Lawson model cannot represent a flight has (see
/// [`tolles_core::flight::effects`]): read from `load,flap,temp`, `all` or `none`.
///
/// ```
/// use tolles::simulate::CabinEffects;
/// let some: CabinEffects = "temp,load".parse().unwrap();
/// assert_eq!(some.to_string(), "load,temp");
/// assert_eq!("all".parse::<CabinEffects>().unwrap(), CabinEffects::ALL);
/// assert!("none".parse::<CabinEffects>().unwrap().is_empty());
/// assert!("wind".parse::<CabinEffects>().is_err());
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct CabinEffects {
    /// A saturating load current, column `cur_load` (A).
    pub load: bool,
    /// A control surface turning a magnetised part, column `pos_flap` (degrees).
    pub flap: bool,
    /// Temperature-dependent magnetisation, column `temp` (°C).
    pub temp: bool,
}

impl CabinEffects {
    /// All three effects.
    pub const ALL: CabinEffects = CabinEffects {
        load: true,
        flap: true,
        temp: true,
    };

    /// True when no effect is asked for.
    pub fn is_empty(self) -> bool {
        !(self.load || self.flap || self.temp)
    }

    /// The core's effects: the typical load, control surface and temperature drift of each
    /// effect asked for.
    pub fn effects(self) -> Effects {
        Effects {
            load: self.load.then(SaturatingLoad::typical),
            surface: self.flap.then(ControlSurface::typical),
            temperature: self.temp.then(Temperature::typical),
        }
    }

    fn names(self) -> impl Iterator<Item = &'static str> {
        [
            (self.load, "load"),
            (self.flap, "flap"),
            (self.temp, "temp"),
        ]
        .into_iter()
        .filter_map(|(on, name)| on.then_some(name))
    }
}

impl std::fmt::Display for CabinEffects {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        if self.is_empty() {
            return f.write_str("none");
        }
        f.write_str(&self.names().collect::<Vec<_>>().join(","))
    }
}

impl FromStr for CabinEffects {
    type Err = String;
    fn from_str(text: &str) -> Result<Self, String> {
        let mut effects = CabinEffects::default();
        for name in text.split(',').map(|n| n.trim().to_ascii_lowercase()) {
            match name.as_str() {
                "load" => effects.load = true,
                "flap" => effects.flap = true,
                "temp" => effects.temp = true,
                "all" => effects = CabinEffects::ALL,
                "none" => {}
                _ => {
                    return Err(format!(
                        "expected load, flap, temp (comma-separated), all or none, got {name:?}"
                    ))
                }
            }
        }
        Ok(effects)
    }
}

/// A uniform earth field instead of IGRF.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct UniformField {
    /// Inclination (deg, down positive).
    pub inclination_deg: f64,
    /// Declination (deg east of true north).
    pub declination_deg: f64,
    /// Intensity (nT).
    pub intensity_nt: f64,
}

/// What to simulate. The default is `tolles simulate`'s: a box flown by a cabin installation.
#[derive(Debug, Clone, PartialEq)]
pub struct SimulateRequest {
    /// Flight plan.
    pub plan: PlanKind,
    /// Seed of noise, turbulence and geology.
    pub seed: u64,
    /// Installation.
    pub preset: Preset,
    /// Sample rate (Hz).
    pub fs_hz: f64,
    /// Ground speed (m/s).
    pub speed_mps: f64,
    /// Start latitude (deg) for IGRF-14.
    pub lat_deg: f64,
    /// Start longitude (deg east) for IGRF-14.
    pub lon_deg: f64,
    /// Altitude above the WGS84 ellipsoid (m).
    pub alt_m: f64,
    /// Date `YYYY-MM-DD` for IGRF-14.
    pub date: String,
    /// A uniform field instead of IGRF.
    pub uniform: Option<UniformField>,
    /// Maneuver period (s), box and patent plans.
    pub period_s: f64,
    /// Cycles of each maneuver, box and patent plans.
    pub cycles: u32,
    /// Roll amplitude (deg); default 10 for the box, 15 for the patent plan.
    pub roll_deg: Option<f64>,
    /// Pitch amplitude (deg); default 5 for the box, 10 for the patent plan.
    pub pitch_deg: Option<f64>,
    /// Yaw amplitude (deg), box plan.
    pub yaw_deg: f64,
    /// Number of survey lines.
    pub lines: u32,
    /// Duration of each survey line (s).
    pub line_duration_s: f64,
    /// Turbulence on survey lines (deg).
    pub turbulence_deg: f64,
    /// Largest geology anomaly (nT); 0 for none.
    pub geology_nt: f64,
    /// Diurnal variation amplitude (nT, 1 h period); 0 for none.
    pub diurnal_nt: f64,
    /// Scalar magnetometer white noise (nT).
    pub scalar_noise_nt: f64,
    /// Fluxgate white noise per axis (nT).
    pub flux_noise_nt: f64,
    /// How late the fluxgate samples relative to the scalar (s).
    pub flux_lag_s: f64,
    /// Cabin effects the Tolles-Lawson model cannot represent, each with its channel; none by
    /// default.
    pub effects: CabinEffects,
    /// Whether to write a reference magnetometer free of the aircraft's field (`mag_ref`, nT);
    /// a flight with any `effects` always has one.
    pub reference: bool,
    /// The reference magnetometer's white noise (nT).
    pub reference_noise_nt: f64,
}

impl Default for SimulateRequest {
    fn default() -> Self {
        Self {
            plan: PlanKind::Box,
            seed: 1,
            preset: Preset::Cabin,
            fs_hz: 10.0,
            speed_mps: 60.0,
            lat_deg: 45.4,
            lon_deg: -75.7,
            alt_m: 3000.0,
            date: "2025-07-01".to_string(),
            uniform: None,
            period_s: 6.0,
            cycles: 3,
            roll_deg: None,
            pitch_deg: None,
            yaw_deg: 5.0,
            lines: 4,
            line_duration_s: 120.0,
            turbulence_deg: 0.5,
            geology_nt: 20.0,
            diurnal_nt: 3.0,
            scalar_noise_nt: 0.01,
            flux_noise_nt: 0.5,
            flux_lag_s: 0.0,
            effects: CabinEffects::default(),
            reference: false,
            reference_noise_nt: 0.01,
        }
    }
}

/// A simulated flight with what made it.
#[derive(Debug, Clone)]
pub struct Simulated {
    /// Which plan.
    pub plan_kind: PlanKind,
    /// The plan flown.
    pub plan: Plan,
    /// Installation, sensors and environment.
    pub scenario: Scenario,
    /// The samples and their truth.
    pub flight: SimulatedFlight,
}

/// Simulates the flight `request` describes; deterministic for a given request.
pub fn simulate(request: &SimulateRequest, progress: &dyn Progress) -> Result<Simulated> {
    limits::check_settings(request)?;
    let plan = plan(request);
    limits::check_length(plan.duration_s(), request.fs_hz)?;
    let scenario = scenario(request)?;
    simulate_plan(request.plan, plan, scenario, progress)
}

/// Flies `plan`, a plan of kind `kind`, with `scenario`: for callers that build plans and
/// scenarios beyond what a [`SimulateRequest`] says (the demo, tests).
pub fn simulate_plan(
    kind: PlanKind,
    plan: Plan,
    scenario: Scenario,
    progress: &dyn Progress,
) -> Result<Simulated> {
    let mut reported: Option<usize> = None;
    let flight = simulate_with_progress(&plan, &scenario, &mut |done, total| {
        let before = *reported.get_or_insert_with(|| {
            progress.begin(Stage::Simulating, Some(total as u64));
            0
        });
        progress.advance(done.saturating_sub(before) as u64);
        reported = Some(done);
    })
    .map_err(|e| Error::Invalid(format!("simulating the flight: {e}")))?;
    progress.finish();
    Ok(Simulated {
        plan_kind: kind,
        plan,
        scenario,
        flight,
    })
}

/// Writes the flight to `path` (CSV, HDF5 or Parquet by its extension; any other is an error)
/// and its JSON sidecar (every parameter and the true terms)
/// beside it; returns the sidecar's path.
pub fn write(simulated: &Simulated, path: &Path) -> Result<PathBuf> {
    write_flight(path, &simulated.flight)?;
    let sidecar = sidecar_path(path);
    Sidecar::new(
        simulated.plan_kind.name(),
        &simulated.plan,
        &simulated.scenario,
    )
    .write(&sidecar)?;
    Ok(sidecar)
}

/// `flight.csv` → `flight.json`.
pub fn sidecar_path(csv: &Path) -> PathBuf {
    csv.with_extension("json")
}

fn plan(r: &SimulateRequest) -> Plan {
    match r.plan {
        PlanKind::Box => BoxPlan {
            roll_deg: r.roll_deg.unwrap_or(10.0),
            pitch_deg: r.pitch_deg.unwrap_or(5.0),
            yaw_deg: r.yaw_deg,
            period_s: r.period_s,
            cycles: r.cycles,
            ..BoxPlan::default()
        }
        .build(),
        PlanKind::Patent => PatentPlan {
            roll_deg: r.roll_deg.unwrap_or(15.0),
            pitch_deg: r.pitch_deg.unwrap_or(10.0),
            period_s: r.period_s,
            cycles: r.cycles,
            ..PatentPlan::default()
        }
        .build(),
        PlanKind::Survey => SurveyPlan {
            lines: r.lines,
            line_s: r.line_duration_s,
            turbulence_deg: r.turbulence_deg,
            seed: r.seed,
            ..SurveyPlan::default()
        }
        .build(),
    }
}

fn scenario(r: &SimulateRequest) -> Result<Scenario> {
    let installation = match r.preset {
        Preset::TailStinger => Installation::TailStinger,
        Preset::Cabin => Installation::Cabin,
        Preset::Uav => Installation::Uav,
        Preset::Realistic => Installation::Realistic,
    };
    let mut scenario = installation.scenario(r.seed);
    scenario.fs_hz = r.fs_hz;
    scenario.speed_mps = r.speed_mps;
    scenario.environment = environment(r)?;
    scenario.sensors.scalar_noise_nt = r.scalar_noise_nt;
    scenario.sensors.flux_noise_nt = r.flux_noise_nt;
    scenario.sensors.fluxgate.lag_s = r.flux_lag_s;
    // The effects are for fits against a reference (`fit --reference mag_ref`), so a flight
    // with them has one.
    if r.reference || !r.effects.is_empty() {
        scenario.sensors.reference_noise_nt = Some(r.reference_noise_nt);
    }
    scenario.effects = r.effects.effects();
    Ok(scenario)
}

fn environment(r: &SimulateRequest) -> Result<Environment> {
    let mut env = match r.uniform {
        Some(u) => Environment::uniform(EarthField {
            intensity_nt: u.intensity_nt,
            inclination_deg: u.inclination_deg,
            declination_deg: u.declination_deg,
        }),
        None => Environment::at(Location {
            lat_deg: r.lat_deg,
            lon_deg: r.lon_deg,
            alt_m: r.alt_m,
            year: parse_date(&r.date)?,
        }),
    };
    if r.geology_nt > 0.0 {
        env.geology = Some(Geology::random(40, r.geology_nt, 15_000.0, r.seed));
    }
    if r.diurnal_nt > 0.0 {
        env.diurnal = Some(Diurnal {
            amplitude_nt: r.diurnal_nt,
            period_s: 3_600.0,
            phase_rad: 0.4,
        });
    }
    Ok(env)
}

/// `YYYY-MM-DD` as a decimal year.
pub fn parse_date(text: &str) -> Result<f64> {
    let bad = || Error::DateFormat {
        text: text.to_string(),
    };
    let parts: Vec<&str> = text.split('-').collect();
    let [y, m, d] = parts[..] else {
        return Err(bad());
    };
    let (Ok(y), Ok(m), Ok(d)) = (y.parse(), m.parse(), d.parse()) else {
        return Err(bad());
    };
    decimal_year(y, m, d).map_err(|reason| Error::Date {
        text: text.to_string(),
        reason,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::progress::Silent;

    #[test]
    fn settings_out_of_range_are_typed_errors() {
        let fs = SimulateRequest {
            fs_hz: 0.0,
            ..SimulateRequest::default()
        };
        assert!(
            matches!(simulate(&fs, &Silent), Err(Error::SimulateSetting { flag: "--fs", value, .. }) if value == 0.0)
        );
        let period = SimulateRequest {
            period_s: -1.0,
            ..SimulateRequest::default()
        };
        assert!(matches!(
            simulate(&period, &Silent),
            Err(Error::SimulateSetting {
                flag: "--period",
                ..
            })
        ));
        assert!(matches!(
            parse_date("yesterday"),
            Err(Error::DateFormat { .. })
        ));
        let long = SimulateRequest {
            plan: PlanKind::Survey,
            lines: 10_000,
            line_duration_s: 86_400.0,
            ..SimulateRequest::default()
        };
        assert!(matches!(
            simulate(&long, &Silent),
            Err(Error::SimulateTooLong { .. })
        ));
        let e = parse_date("2025-02-30").unwrap_err();
        assert_eq!(
            e.to_string(),
            "date 2025-02-30: 2025-02-30 is not a calendar date"
        );
        assert!((parse_date("2025-07-01").unwrap() - 2025.4959).abs() < 1e-4);
    }

    #[test]
    fn effects_bring_their_columns_and_a_reference() {
        let request = SimulateRequest {
            cycles: 1,
            effects: "flap,temp".parse().unwrap(),
            ..SimulateRequest::default()
        };
        let simulated = simulate(&request, &Silent).unwrap();
        let names: Vec<&str> = output::flight_columns(&simulated.flight)
            .iter()
            .map(|(name, _)| *name)
            .collect();
        let added = &names[names.len() - 4..];
        assert_eq!(added, ["mag_ref", "pos_flap", "temp", "truth_effects"]);
        let plain = simulate(
            &SimulateRequest {
                cycles: 1,
                ..SimulateRequest::default()
            },
            &Silent,
        )
        .unwrap();
        assert_eq!(names.len(), output::flight_columns(&plain.flight).len() + 4);
        let reference_only = SimulateRequest {
            cycles: 1,
            reference: true,
            ..SimulateRequest::default()
        };
        let flight = simulate(&reference_only, &Silent).unwrap().flight;
        assert_eq!(flight.reference_nt.len(), flight.tt.len());
        assert_eq!(flight.scalar, plain.flight.scalar);
        assert!(flight.effects_nt.is_empty());
    }

    #[test]
    fn a_request_and_its_plan_and_scenario_fly_the_same_flight() {
        let request = SimulateRequest {
            cycles: 1,
            ..SimulateRequest::default()
        };
        let a = simulate(&request, &Silent).unwrap();
        let b = simulate_plan(
            PlanKind::Box,
            plan(&request),
            scenario(&request).unwrap(),
            &Silent,
        )
        .unwrap();
        assert_eq!(a.flight.scalar, b.flight.scalar);
        assert_eq!(b.plan_kind, PlanKind::Box);
    }
}
