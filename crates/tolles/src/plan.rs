//! How well a calibration flight determines each of the 16 Tolles terms, before flying it (a
//! plan, simulated without noise) or after (the maneuvers found in a flown flight, with its own
//! fluxgate): standard errors, variance inflation, the maneuvers that carry each term, and the
//! standard maneuvers that would help the poorly determined ones most.
//!
//! ```
//! use tolles::plan::{plan, Maneuvers, PlanRequest};
//! use tolles::Silent;
//!
//! // The variance inflation of perm V: how much other terms can mimic it.
//! let vif_of_v = |maneuvers: Maneuvers| {
//!     let request = PlanRequest { maneuvers, ..PlanRequest::default() };
//!     let outcome = plan(&request, &Silent, &mut Vec::new()).unwrap();
//!     outcome.identifiability.terms.iter().find(|t| t.name == "V").unwrap().vif
//! };
//! let the_box = vif_of_v(PlanRequest::default().maneuvers);
//! let list = "roll@0,roll@90,roll@180,roll@270,pitch@0,pitch@90,wingup@90,wingup@270";
//! let with_wing_ups = vif_of_v(Maneuvers::List(list.into()));
//! assert!(with_wing_ups < the_box / 10.0); // wing-ups tell V from the induced terms
//! ```

use crate::error::{Error, Result};
use crate::progress::Progress;
use crate::read::{sample_rate, time_column};
use crate::warning::Warning;
use serde_json::{json, Value};
use std::ops::Range;
use std::path::PathBuf;
use tolles_core::flight::environment::Environment;
use tolles_core::flight::field_estimate::level_field;
use tolles_core::flight::plan::{Axis, BoxPlan, PatentPlan, Plan};
use tolles_core::flight::sim::{EarthField, Scenario};
use tolles_core::maneuvers::detect::{detect_harmonic_maneuvers, ManeuverSettings};
use tolles_core::maneuvers::identifiability::{
    analyse_mapped, candidate_blocks, flight_blocks, patent_map, planned_blocks, suggest, Block,
    Identifiability, PlanningError,
};
use tolles_core::model::design::Design;
use tolles_core::model::interpret::AircraftField;
use tolles_core::model::terms::TermSet;
use tolles_core::model::vector::VectorSeries;
use tolles_core::signal::filter::{magnav_bandpass, Butterworth, FilterError};
use tolles_io::schema::{PITCH, ROLL, YAW};
use tolles_io::select::RowSelection;
use tolles_io::table::Table;

/// The band-pass (Hz) applied to the design rows, as in MagNav's fits.
pub const BAND_HZ: (f64, f64) = (0.1, 0.9);
/// Its Butterworth order per edge.
pub const BAND_ORDER: usize = 4;
/// Maneuvers suggested per poorly determined term.
pub const SUGGESTIONS: usize = 3;

/// A built-in plan.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum BuiltinPlan {
    /// The compensation box: roll ±10°, pitch ±5°, yaw ±5° on N, E, S, W.
    #[default]
    Box,
    /// The Tolles patent's maneuvers: rolls ±15°, pitches ±10°, wing-ups, cloverleaf.
    Patent,
}

/// The maneuvers to evaluate.
#[derive(Debug, Clone, PartialEq)]
pub enum Maneuvers {
    /// A built-in plan, the maneuvers about the `without` axes left out.
    Builtin {
        /// Which built-in plan.
        plan: BuiltinPlan,
        /// Axes whose maneuvers are left out.
        without: Vec<Axis>,
    },
    /// A list `roll@0,pitch@90,wingup@270` ([`Plan::from_maneuver_list`]).
    List(String),
    /// A flown flight: its harmonic maneuvers, found in the attitude columns, weighed with its
    /// fluxgate `vector_x/_y/_z` (nT); the dip and intensity come from that fluxgate too.
    /// Only the rows `selection` keeps are used (all when empty), after the columns are renamed
    /// `(old, new)` (see [`crate::read::rename`]).
    Flown {
        /// The flight file.
        path: PathBuf,
        /// Prefix of the fluxgate columns `<vector>_x/_y/_z` (nT, body frame).
        vector: String,
        /// Which rows to use; all when empty.
        selection: RowSelection,
        /// Column renames `(old, new)` applied when reading.
        renames: Vec<(String, String)>,
        /// The sample rate (Hz) of a flight without a time column (or to override it).
        fs_hz: Option<f64>,
    },
}

/// What to evaluate.
#[derive(Debug, Clone, PartialEq)]
pub struct PlanRequest {
    /// The maneuvers to evaluate.
    pub maneuvers: Maneuvers,
    /// The terms of the model.
    pub terms: TermSet,
    /// Scalar noise (nT) the standard errors assume.
    pub noise_nt: f64,
    /// The earth field of a plan; a flown flight keeps only its declination.
    pub field: EarthField,
}

impl Default for PlanRequest {
    /// The box, model `permanent,i5,e8`, noise 0.01 nT, field 52 000 nT at dip 68°,
    /// declination 0°.
    fn default() -> Self {
        Self {
            maneuvers: Maneuvers::Builtin {
                plan: BuiltinPlan::Box,
                without: Vec::new(),
            },
            terms: "permanent,i5,e8".parse().expect("a valid term list"),
            noise_nt: 0.01,
            field: EarthField {
                intensity_nt: 52_000.0,
                inclination_deg: 68.0,
                declination_deg: 0.0,
            },
        }
    }
}

/// Maneuvers that would determine a poorly determined term better.
#[derive(Debug, Clone, PartialEq)]
pub struct Suggestion {
    /// The term's patent name.
    pub term: String,
    /// Candidate maneuvers, best first, each with the factor its standard error would be
    /// multiplied by (< 1 helps).
    pub maneuvers: Vec<(String, f64)>,
}

/// What [`plan`] found.
#[derive(Debug, Clone, PartialEq)]
pub struct PlanOutcome {
    /// Every term's standard error, variance inflation, carriers and partners.
    pub identifiability: Identifiability,
    /// For each collinear term, the standard maneuvers that would help it most.
    pub suggestions: Vec<Suggestion>,
    /// The earth field the analysis assumed (for a flown flight, from its fluxgate).
    pub field: EarthField,
}

impl PlanOutcome {
    /// The outcome as `tolles plan --json` prints it:
    /// `{"identifiability": {...}, "suggestions": [[term, [[maneuver, ratio], ...]], ...]}`.
    pub fn to_json(&self) -> Value {
        let suggestions: Vec<(&String, &Vec<(String, f64)>)> = self
            .suggestions
            .iter()
            .map(|s| (&s.term, &s.maneuvers))
            .collect();
        json!({ "identifiability": self.identifiability, "suggestions": suggestions })
    }
}

/// Evaluates the request's maneuvers. A flown flight is read with `progress`; what the reader
/// left out is added to `warnings`.
pub fn plan(
    request: &PlanRequest,
    progress: &dyn Progress,
    warnings: &mut Vec<Warning>,
) -> Result<PlanOutcome> {
    let design = Design::new(request.terms);
    let mut scenario = Scenario::new(AircraftField::default(), 0);
    let mut field = request.field;
    let blocks = match &request.maneuvers {
        Maneuvers::Flown {
            path,
            vector,
            selection,
            renames,
            fs_hz,
        } => {
            let read = crate::read::read_renamed(path, selection, renames, progress, warnings)?;
            let flown = flown(&read.table, vector, *fs_hz, &design, warnings)?;
            scenario.fs_hz = flown.fs_hz;
            field.inclination_deg = flown.dip_deg;
            field.intensity_nt = flown.intensity_nt;
            flown.blocks
        }
        Maneuvers::Builtin { plan, without } => {
            planned(&builtin(*plan, without), &mut scenario, field, &design)?
        }
        Maneuvers::List(list) => {
            let plan = Plan::from_maneuver_list(list).map_err(Error::ManeuverList)?;
            planned(&plan, &mut scenario, field, &design)?
        }
    };
    scenario.environment = Environment::uniform(field);
    let filter = band_pass(scenario.fs_hz).map_err(PlanningError::from)?;
    let candidates = candidate_blocks(&scenario, &design, filter.as_ref())?;
    let (identifiability, suggestions) = analyse(&blocks, &candidates, &design, &scenario, request);
    Ok(PlanOutcome {
        identifiability,
        suggestions,
        field,
    })
}

/// The blocks of `plan` flown in `scenario` in the uniform `field`.
fn planned(
    plan: &Plan,
    scenario: &mut Scenario,
    field: EarthField,
    design: &Design,
) -> Result<Vec<Block>> {
    scenario.environment = Environment::uniform(field);
    let filter = band_pass(scenario.fs_hz).map_err(PlanningError::from)?;
    Ok(planned_blocks(plan, scenario, design, filter.as_ref())?)
}

fn band_pass(fs_hz: f64) -> Result<Option<Butterworth>, FilterError> {
    magnav_bandpass(BAND_HZ.0, BAND_HZ.1, BAND_ORDER, fs_hz)
}

/// The identifiability of the patent's 16 terms, and suggestions for the collinear ones.
fn analyse(
    blocks: &[Block],
    candidates: &[Block],
    design: &Design,
    scenario: &Scenario,
    request: &PlanRequest,
) -> (Identifiability, Vec<Suggestion>) {
    let (names, map) = patent_map(design, scenario.fs_hz);
    let analysis = analyse_mapped(blocks, &names, &map, request.noise_nt);
    let suggestions = analysis
        .terms
        .iter()
        .enumerate()
        .filter(|(_, t)| t.collinear)
        .map(|(j, t)| Suggestion {
            term: t.name.clone(),
            maneuvers: suggest(blocks, candidates, &map, j)
                .into_iter()
                .take(SUGGESTIONS)
                .collect(),
        })
        .collect();
    (analysis, suggestions)
}

/// A built-in plan without the maneuvers about the `without` axes (amplitude 0).
fn builtin(plan: BuiltinPlan, without: &[Axis]) -> Plan {
    let keep = |axis: Axis, amplitude_deg: f64| {
        if without.contains(&axis) {
            0.0
        } else {
            amplitude_deg
        }
    };
    match plan {
        BuiltinPlan::Box => BoxPlan {
            roll_deg: keep(Axis::Roll, 10.0),
            pitch_deg: keep(Axis::Pitch, 5.0),
            yaw_deg: keep(Axis::Yaw, 5.0),
            ..BoxPlan::default()
        }
        .build(),
        BuiltinPlan::Patent => PatentPlan {
            roll_deg: keep(Axis::Roll, 15.0),
            pitch_deg: keep(Axis::Pitch, 10.0),
            ..PatentPlan::default()
        }
        .build(),
    }
}

/// What a flown flight contributes: one block per maneuver found, and the field it flew in.
struct Flown {
    blocks: Vec<Block>,
    /// Sample rate (Hz).
    fs_hz: f64,
    /// Dip (degrees) and intensity (nT) from the fluxgate in level flight.
    dip_deg: f64,
    intensity_nt: f64,
}

const WHAT: &str = "identifiability";

fn flown(
    table: &Table,
    vector: &str,
    fs_hz: Option<f64>,
    design: &Design,
    warnings: &mut Vec<Warning>,
) -> Result<Flown> {
    let path = table.path();
    let flux = VectorSeries::from(table.vector(vector)?);
    // Without a time column the rate comes from the file's stated interval or `fs_hz`, as
    // every other command takes it.
    let (tt, steps_back) = time_column(table)?;
    warnings.extend(steps_back);
    let (fs_hz, warning) = sample_rate(table, tt.as_deref(), fs_hz)?;
    warnings.extend(warning);
    let tt = tt.unwrap_or_else(|| (0..table.len()).map(|k| k as f64 / fs_hz).collect());
    let (roll, pitch, yaw) = (
        table.numeric(ROLL)?,
        table.numeric(PITCH)?,
        table.numeric(YAW)?,
    );
    if let Some(k) = (0..flux.len()).find(|&k| !flux.is_finite(k)) {
        return Err(Error::IncompleteFluxgate {
            path: path.to_path_buf(),
            place: table.place_of(k),
            what: WHAT,
        });
    }
    let windows = maneuver_windows(&tt, &roll, &pitch, &yaw);
    if windows.is_empty() {
        return Err(Error::NoManeuversFound {
            path: path.to_path_buf(),
            kind: "harmonic",
            columns: format!("{ROLL}, {PITCH}, {YAW}"),
        });
    }
    let filter = band_pass(fs_hz).map_err(|reason| Error::Filter {
        path: path.to_path_buf(),
        reason,
    })?;
    let blocks = flight_blocks(&flux, design, filter.as_ref(), &windows).map_err(|reason| {
        Error::Filter {
            path: path.to_path_buf(),
            reason,
        }
    })?;
    let level = level_field(&flux, &roll, &pitch);
    Ok(Flown {
        blocks,
        fs_hz,
        dip_deg: level.dip_deg,
        intensity_nt: level.intensity_nt,
    })
}

/// The harmonic maneuvers in the attitude (degrees) and time (s), labelled as blocks:
/// `roll on 090° at 123 s` (measured heading, start time).
fn maneuver_windows(
    tt: &[f64],
    roll: &[f64],
    pitch: &[f64],
    yaw: &[f64],
) -> Vec<(String, Range<usize>)> {
    detect_harmonic_maneuvers(tt, roll, pitch, yaw, &ManeuverSettings::default())
        .iter()
        .map(|m| {
            let label = format!(
                "{} on {:03.0}° at {:.0} s",
                m.kind, m.heading_deg_measured, m.start_tt
            );
            (label, m.range())
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::simulate::{simulate, write, PlanKind, Preset, SimulateRequest, UniformField};
    use crate::Silent;
    use tolles_core::maneuvers::identifiability::TermInformation;

    fn term<'a>(outcome: &'a PlanOutcome, name: &str) -> &'a TermInformation {
        let terms = &outcome.identifiability.terms;
        terms.iter().find(|t| t.name == name).unwrap()
    }

    fn carried_by_yaw(t: &TermInformation) -> bool {
        t.carried_by
            .iter()
            .any(|(label, _)| label.starts_with("yaw"))
    }

    #[test]
    fn a_box_without_yaws_loses_the_yaw_information() {
        let evaluate = |without: Vec<Axis>| {
            let maneuvers = Maneuvers::Builtin {
                plan: BuiltinPlan::Box,
                without,
            };
            let request = PlanRequest {
                maneuvers,
                ..PlanRequest::default()
            };
            plan(&request, &Silent, &mut Vec::new()).unwrap()
        };
        let (full, no_yaw) = (evaluate(vec![]), evaluate(vec![Axis::Yaw]));
        assert!(carried_by_yaw(term(&full, "lt")));
        assert!(!carried_by_yaw(term(&no_yaw, "lt")));
        assert!(term(&no_yaw, "lt").std_error > 1.05 * term(&full, "lt").std_error);
        // Perm V needs a wing-up, and one is suggested.
        let v = full.suggestions.iter().find(|s| s.term == "V").unwrap();
        assert!(v.maneuvers[0].0.contains("wing-up"), "{v:?}");
        assert_eq!(
            full.to_json()["suggestions"].as_array().unwrap().len(),
            full.suggestions.len()
        );
    }

    #[test]
    fn a_flown_box_without_time_takes_its_rate_from_fs() {
        let dir = tempfile::tempdir().unwrap();
        let with_time = dir.path().join("box.csv");
        write(
            &simulate(&SimulateRequest::default(), &Silent).unwrap(),
            &with_time,
        )
        .unwrap();
        let text = std::fs::read_to_string(&with_time).unwrap();
        let path = dir.path().join("untimed.csv");
        std::fs::write(&path, text.replacen("tt,", "t_gps,", 1)).unwrap();
        let request = |fs_hz| PlanRequest {
            maneuvers: Maneuvers::Flown {
                path: path.clone(),
                vector: "flux_a".into(),
                selection: RowSelection::default(),
                renames: Vec::new(),
                fs_hz,
            },
            ..PlanRequest::default()
        };
        let refused = plan(&request(None), &Silent, &mut Vec::new()).unwrap_err();
        assert!(matches!(refused, Error::NoSampleRate { .. }), "{refused}");
        let timed = PlanRequest {
            maneuvers: Maneuvers::Flown {
                path: with_time,
                vector: "flux_a".into(),
                selection: RowSelection::default(),
                renames: Vec::new(),
                fs_hz: None,
            },
            ..PlanRequest::default()
        };
        // The same maneuvers weighed the same, to the rounding of the file's times.
        let errors = |request: &PlanRequest| -> Vec<f64> {
            let json = plan(request, &Silent, &mut Vec::new()).unwrap().to_json();
            let terms = json["identifiability"]["terms"].as_array().unwrap().clone();
            terms
                .iter()
                .map(|t| t["std_error"].as_f64().unwrap())
                .collect()
        };
        let (given, read) = (errors(&request(Some(10.0))), errors(&timed));
        assert_eq!(given.len(), read.len());
        for (g, r) in given.iter().zip(&read) {
            assert!((g / r - 1.0).abs() < 1e-3, "{g} {r}");
        }
    }

    #[test]
    fn a_flown_box_is_weighed_with_its_own_fluxgate_and_field() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("box.csv");
        let flight = SimulateRequest {
            plan: PlanKind::Box,
            preset: Preset::TailStinger,
            uniform: Some(UniformField {
                inclination_deg: 60.0,
                declination_deg: 0.0,
                intensity_nt: 50_000.0,
            }),
            ..SimulateRequest::default()
        };
        write(&simulate(&flight, &Silent).unwrap(), &path).unwrap();
        let request = PlanRequest {
            maneuvers: Maneuvers::Flown {
                path,
                vector: "flux_a".into(),
                selection: RowSelection::default(),
                renames: Vec::new(),
                fs_hz: None,
            },
            ..PlanRequest::default()
        };
        let outcome = plan(&request, &Silent, &mut Vec::new()).unwrap();
        assert!(carried_by_yaw(term(&outcome, "lt")));
        assert!(
            (outcome.field.inclination_deg - 60.0).abs() < 1.0,
            "{:?}",
            outcome.field
        );
        assert!(
            (outcome.field.intensity_nt - 50_000.0).abs() < 500.0,
            "{:?}",
            outcome.field
        );
    }

    #[test]
    fn a_bad_maneuver_list_is_an_error_naming_no_flag() {
        let request = PlanRequest {
            maneuvers: Maneuvers::List("roll@0,loop@90".into()),
            ..PlanRequest::default()
        };
        let e = plan(&request, &Silent, &mut Vec::new()).unwrap_err();
        assert_eq!(
            e.to_string(),
            "maneuver list: unknown kind \"loop\"; use roll, pitch, yaw or wingup"
        );
    }
}
