//! Writing simulated flights: a CSV in the layout `tolles fit` reads, and a JSON sidecar with
//! every parameter and the true aircraft terms.
//!
//! ```no_run
//! use tolles_core::flight::plan::BoxPlan;
//! use tolles_core::flight::sim::{simulate, Installation};
//! use tolles_io::simulation::{write_flight, Sidecar};
//! let plan = BoxPlan::default().build();
//! let scenario = Installation::Cabin.scenario(1);
//! let flight = simulate(&plan, &scenario).unwrap();
//! write_flight("box.csv".as_ref(), &flight).unwrap();
//! Sidecar::new("box", &plan, &scenario).write("box.json".as_ref()).unwrap();
//! ```

use crate::error::IoError;
use crate::format::Format;
use crate::schema;
use crate::table::write_columns_to;
use serde::Serialize;
use std::path::Path;
use tolles_core::flight::plan::Plan;
use tolles_core::flight::sim::{Scenario, SimulatedFlight};
use tolles_core::model::interpret::{AircraftField, PatentTerms};

/// The scalar column of a simulated flight (SGL's name for an uncompensated magnetometer).
pub const SCALAR: &str = "mag_1_uc";
/// The fluxgate prefix of a simulated flight.
pub const VECTOR: &str = "flux_a";

/// Every column a simulated flight can have, with its meaning.
pub const COLUMNS: [(&str, &str); 18] = [
    (schema::TIME_COLUMN, "time (s)"),
    (schema::LINE_COLUMN, "line id of the flight segment"),
    ("lat", "latitude (degrees), when the main field is IGRF"),
    (
        "lon",
        "longitude (degrees, east positive), when the main field is IGRF",
    ),
    ("north_m", "distance north of the start (m)"),
    ("east_m", "distance east of the start (m)"),
    (schema::ROLL, "roll, right wing down positive (degrees)"),
    (schema::PITCH, "pitch, nose up positive (degrees)"),
    (schema::YAW, "yaw, clockwise from true north (degrees)"),
    ("mag_1_uc", "scalar magnetometer, uncompensated (nT)"),
    ("flux_a_x", "fluxgate, forward (nT)"),
    ("flux_a_y", "fluxgate, right (nT)"),
    ("flux_a_z", "fluxgate, down (nT)"),
    (
        "cur_1",
        "current of the current source (A), when there is one",
    ),
    (
        "truth_earth",
        "truth: earth field magnitude without the aircraft (nT)",
    ),
    (
        "truth_aircraft",
        "truth: the aircraft's contribution to the scalar, |B+H|-|B| (nT)",
    ),
    ("truth_anomaly", "truth: geology's total-field anomaly (nT)"),
    ("truth_diurnal", "truth: diurnal variation (nT)"),
];

/// Writes `flight` with the columns of [`COLUMNS`] that it has, in the format `path`'s
/// extension names (CSV, HDF5 or Parquet; any other extension is an error, see
/// [`Format::for_output`]).
pub fn write_flight(path: &Path, flight: &SimulatedFlight) -> Result<(), IoError> {
    let columns = flight_columns(flight);
    match Format::for_output(path)? {
        Format::Csv => write_columns_to(path, &columns),
        format => {
            let owned: Vec<(String, Vec<f64>)> = columns
                .iter()
                .map(|(name, values)| (name.to_string(), values.to_vec()))
                .collect();
            match format {
                Format::Parquet => crate::parquet::write(path, &owned),
                _ => crate::hdf5::write(path, &owned),
            }
        }
    }
}

/// The columns of [`COLUMNS`] that `flight` has, named, in that order.
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
    COLUMNS
        .iter()
        .zip(all)
        .filter(|(_, values)| values.len() == flight.tt.len())
        .map(|((name, _), values)| (*name, values))
        .collect()
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
    /// What each CSV column means.
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
            columns: COLUMNS.to_vec(),
        }
    }

    /// The sidecar as pretty JSON text.
    pub fn to_json(&self) -> String {
        serde_json::to_string_pretty(self).expect("a sidecar always serialises")
    }

    /// Writes the sidecar as pretty JSON.
    pub fn write(&self, path: &Path) -> Result<(), IoError> {
        crate::atomic::write_bytes(path, (self.to_json() + "\n").as_bytes())
    }
}
