//! Writing simulated flights: a table in the layout `tolles fit` reads
//! ([`tolles_io::simulation::COLUMNS`], then those of
//! [`tolles_io::simulation::EFFECT_COLUMNS`] the flight has), and a JSON sidecar with every
//! parameter and the true aircraft terms.
//!
//! ```no_run
//! use tolles::simulate::output::{write_flight, Sidecar};
//! use tolles_core::flight::plan::BoxPlan;
//! use tolles_core::flight::sim::{simulate, Installation};
//! let plan = BoxPlan::default().build();
//! let scenario = Installation::Cabin.scenario(1);
//! let flight = simulate(&plan, &scenario).unwrap();
//! write_flight("box.csv".as_ref(), &flight).unwrap();
//! Sidecar::new("box", &plan, &scenario).write("box.json".as_ref()).unwrap();
//! ```

use serde::Serialize;
use std::path::Path;
use tolles_core::flight::plan::Plan;
use tolles_core::flight::sim::{Scenario, SimulatedFlight};
use tolles_core::model::interpret::AircraftField;
use tolles_core::patent::PatentTerms;
use tolles_io::simulation::{write_named_columns, COLUMNS, EFFECT_COLUMNS};
use tolles_io::IoError;

/// Writes `flight` with the columns of [`COLUMNS`] and [`EFFECT_COLUMNS`] that it has, in the
/// format `path`'s extension names (CSV, HDF5 or Parquet; any other extension is an error).
pub fn write_flight(path: &Path, flight: &SimulatedFlight) -> Result<(), IoError> {
    write_named_columns(path, &flight_columns(flight))
}

/// The columns of [`COLUMNS`], then of [`EFFECT_COLUMNS`], that `flight` has, named, in that
/// order.
pub fn flight_columns(flight: &SimulatedFlight) -> Vec<(&'static str, &[f64])> {
    let all: [&[f64]; 18] = [
        &flight.tt,
        &flight.line,
        &flight.lat_deg,
        &flight.lon_deg,
        &flight.north_m,
        &flight.east_m,
        &flight.roll_deg,
        &flight.pitch_deg,
        &flight.yaw_deg,
        &flight.scalar,
        &flight.flux.x,
        &flight.flux.y,
        &flight.flux.z,
        &flight.current_a,
        &flight.earth_nt,
        &flight.interference_nt,
        &flight.anomaly_nt,
        &flight.diurnal_nt,
    ];
    let effects: [&[f64]; 5] = [
        &flight.reference_nt,
        &flight.load_a,
        &flight.flap_deg,
        &flight.temperature_c,
        &flight.effects_nt,
    ];
    COLUMNS
        .iter()
        .zip(all)
        .chain(EFFECT_COLUMNS.iter().zip(effects))
        .filter(|(_, values)| values.len() == flight.tt.len())
        .map(|((name, _), values)| (*name, values))
        .collect()
}

/// The entries of [`EFFECT_COLUMNS`] a flight through `scenario` writes.
fn effect_columns(
    scenario: &Scenario,
) -> impl Iterator<Item = &'static (&'static str, &'static str)> {
    let effects = &scenario.effects;
    let has = [
        scenario.sensors.reference_noise_nt.is_some(),
        effects.load.is_some(),
        effects.surface.is_some(),
        effects.temperature.is_some(),
        !effects.is_empty(),
    ];
    EFFECT_COLUMNS
        .iter()
        .zip(has)
        .filter_map(|(column, has)| has.then_some(column))
}

/// The true aircraft terms.
#[derive(Debug, Clone, Serialize)]
pub struct Truth {
    /// Permanent (nT), induced (1) and eddy (s) fields.
    pub physical: AircraftField,
    /// The 16 patent terms.
    pub patent: PatentTerms,
}

/// Everything about a simulated flight that is not in its CSV.
#[derive(Debug, Clone, Serialize)]
pub struct Sidecar<'a> {
    /// Always `tolles-simulation`.
    pub format: &'static str,
    /// Layout version.
    pub version: u32,
    /// The program that wrote it.
    pub created_by: String,
    /// The plan's name (`box`, `patent`, `survey`, …).
    pub plan_name: &'a str,
    /// The plan, segment by segment.
    pub plan: &'a Plan,
    /// Every parameter of the simulation.
    pub scenario: &'a Scenario,
    /// The true aircraft terms.
    pub truth: Truth,
    /// What each CSV column means: every column a flight can have, then those of a reference
    /// magnetometer and cabin effects this flight has.
    pub columns: Vec<(&'static str, &'static str)>,
}

impl<'a> Sidecar<'a> {
    /// The sidecar of a flight of `plan` through `scenario`.
    pub fn new(plan_name: &'a str, plan: &'a Plan, scenario: &'a Scenario) -> Self {
        Self {
            format: "tolles-simulation",
            version: 1,
            created_by: format!("tolles {}", env!("CARGO_PKG_VERSION")),
            plan_name,
            plan,
            scenario,
            truth: Truth {
                physical: scenario.aircraft,
                patent: scenario.aircraft.patent_terms(),
            },
            columns: COLUMNS
                .iter()
                .chain(effect_columns(scenario))
                .copied()
                .collect(),
        }
    }

    /// The sidecar as pretty JSON text.
    pub fn to_json(&self) -> String {
        serde_json::to_string_pretty(self).expect("a sidecar always serialises")
    }

    /// Writes the sidecar as pretty JSON.
    pub fn write(&self, path: &Path) -> Result<(), IoError> {
        tolles_io::atomic::write_bytes(path, (self.to_json() + "\n").as_bytes())
    }
}
