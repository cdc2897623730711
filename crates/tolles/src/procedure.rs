//! The Tolles patent's compensation procedure (US 2,692,970) on a flight: its maneuvers found
//! in the attitude, the 16 terms identified step by step in the patent's order, and the same
//! terms fitted by least squares for comparison.
//!
//! ```
//! use tolles::procedure::{procedure, Direction, ProcedureRequest};
//! use tolles::{read, simulate, Silent};
//!
//! # let dir = tempfile::tempdir().unwrap();
//! # let path = dir.path().join("patent.csv");
//! let request = simulate::SimulateRequest { plan: simulate::PlanKind::Patent, ..Default::default() };
//! simulate::write(&simulate::simulate(&request, &Silent).unwrap(), &path).unwrap();
//! let mut warnings = Vec::new();
//! let table = read::read_table(&path, &Silent, &mut warnings).unwrap();
//!
//! let request = ProcedureRequest::new("mag_1_uc", Direction::Fluxgate { vector: "flux_a".into() });
//! let outcome = procedure(&table, &request, &mut warnings).unwrap();
//! assert!(outcome.report.undetermined.is_empty());
//! assert!(outcome.to_json()["perm_nT"]["T"].is_number());
//! ```

use crate::error::{Error, Result};
use crate::read::time_column;
use crate::warning::Warning;
use serde_json::{json, Value};
use tolles_core::flight::field_estimate::scalar_intensity;
use tolles_core::patent::detect::detect_patent_maneuvers;
use tolles_core::patent::procedure::{
    least_squares_terms, run, Geometry, ManeuverWindow, ProcedureInput, ProcedureReport, TermValues,
};
use tolles_core::patent::Term;
use tolles_core::signal::segment::median_step;
use tolles_io::schema::{PITCH, ROLL, YAW};
use tolles_io::table::Table;

/// Where the direction of the earth field in the body frame comes from.
#[derive(Debug, Clone, PartialEq)]
pub enum Direction {
    /// A fluxgate: columns `vector_x/_y/_z` (nT, body frame); it also gives the magnitude H.
    Fluxgate {
        /// Prefix of the fluxgate columns `<vector>_x/_y/_z` (nT, body frame).
        vector: String,
    },
    /// The attitude and the field's dip (degrees, down positive); H is the scalar's median.
    Attitude {
        /// The field's dip (degrees, down positive).
        dip_deg: f64,
    },
}

/// What to run the procedure on.
#[derive(Debug, Clone, PartialEq)]
pub struct ProcedureRequest {
    /// The scalar magnetometer column (nT).
    pub scalar: String,
    /// Where the field's direction comes from.
    pub direction: Direction,
    /// Declination (degrees east): magnetic heading = yaw − declination. With a fluxgate it
    /// only names the headings (a maneuver matches a step's heading within 20°).
    pub declination_deg: f64,
    /// Maneuvers found in the flight to leave out, by label (`roll on 045`; the degree sign
    /// and case do not matter).
    pub ignore: Vec<String>,
}

impl ProcedureRequest {
    /// The procedure on `scalar` with declination 0 and every maneuver found.
    pub fn new(scalar: &str, direction: Direction) -> Self {
        Self {
            scalar: scalar.to_string(),
            direction,
            declination_deg: 0.0,
            ignore: Vec::new(),
        }
    }
}

/// What [`procedure`] found.
#[derive(Debug, Clone, PartialEq)]
pub struct ProcedureOutcome {
    /// The procedure step by step, its terms and what it lacked.
    pub report: ProcedureReport,
    /// The same 16 terms by least squares on the whole flight, unless that fit failed.
    pub least_squares: Option<TermValues>,
}

/// One term by both methods.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Comparison {
    /// The patent term compared.
    pub term: Term,
    /// By the procedure (nT perm, dimensionless induced, s eddy); `None` undetermined.
    pub procedure: Option<f64>,
    /// By least squares, same unit.
    pub least_squares: Option<f64>,
    /// Procedure − least squares, when both exist.
    pub difference: Option<f64>,
}

/// Runs the patent's procedure on the flight `table`: finds its maneuvers in the attitude
/// columns (degrees) and the time column (s), leaves out those the request names, identifies
/// the 16 terms, and fits them by least squares for comparison (a failed fit is a warning).
pub fn procedure(
    table: &Table,
    request: &ProcedureRequest,
    warnings: &mut Vec<Warning>,
) -> Result<ProcedureOutcome> {
    let path = table.path().to_path_buf();
    let scalar = table.numeric(&request.scalar)?;
    let (tt, steps_back) = time_column(table)?;
    warnings.extend(steps_back);
    let tt = tt.ok_or_else(|| Error::NoTimeColumn {
        path: path.clone(),
        what: "the procedure",
    })?;
    let (roll, pitch, yaw) = (
        table.numeric(ROLL)?,
        table.numeric(PITCH)?,
        table.numeric(YAW)?,
    );
    let dt = median_step(&tt).ok_or_else(|| Error::NoTimeStep { path: path.clone() })?;
    let geometry = match &request.direction {
        Direction::Fluxgate { vector } => {
            Geometry::from_fluxgate(&tt, &table.vector(vector)?.into())
        }
        Direction::Attitude { dip_deg } => {
            let h_nt = scalar_intensity(&scalar).ok_or_else(|| Error::NoFiniteValue {
                path: path.clone(),
                column: request.scalar.clone(),
            })?;
            let declination = request.declination_deg;
            Geometry::from_attitude(&tt, &roll, &pitch, &yaw, *dip_deg, declination, h_nt)
        }
    };
    let found = detect_patent_maneuvers(&tt, &roll, &pitch, &yaw, request.declination_deg);
    let windows = without_ignored(found, &request.ignore, table)?;
    let input = ProcedureInput {
        tt: &tt,
        scalar: &scalar,
        roll_deg: &roll,
        pitch_deg: &pitch,
        geometry: &geometry,
        windows: &windows,
    };
    let report = run(&input).map_err(|reason| Error::Procedure {
        path: path.clone(),
        reason,
    })?;
    let least_squares = least_squares_terms(&scalar, &geometry, 1.0 / dt, Some(&tt))
        .map_err(|e| {
            warnings.push(Warning::NoLeastSquares {
                path,
                reason: e.to_string(),
            })
        })
        .ok();
    Ok(ProcedureOutcome {
        report,
        least_squares,
    })
}

/// `windows` without those labelled as an `ignore` entry (`roll on 045`, `°` and case
/// optional); an entry that labels none is an error naming what was found.
fn without_ignored(
    windows: Vec<ManeuverWindow>,
    ignore: &[String],
    table: &Table,
) -> Result<Vec<ManeuverWindow>> {
    let plain = |s: &str| s.replace('°', "").trim().to_lowercase();
    let ignored = |w: &ManeuverWindow| ignore.iter().any(|name| plain(&w.label()) == plain(name));
    if let Some(name) = ignore
        .iter()
        .find(|name| !windows.iter().any(|w| plain(&w.label()) == plain(name)))
    {
        return Err(Error::NoSuchManeuver {
            path: table.path().to_path_buf(),
            name: name.clone(),
            found: windows.iter().map(|w| w.label()).collect(),
        });
    }
    Ok(windows.into_iter().filter(|w| !ignored(w)).collect())
}

impl ProcedureOutcome {
    /// The 16 terms by the procedure and by least squares, in the patent's order.
    pub fn comparison(&self) -> Vec<Comparison> {
        Term::OBSERVABLE
            .iter()
            .enumerate()
            .map(|(k, &term)| {
                let procedure = self.report.terms.0[k];
                let least_squares = self.least_squares.and_then(|l| l.0[k]);
                Comparison {
                    term,
                    procedure,
                    least_squares,
                    difference: procedure.zip(least_squares).map(|(a, b)| a - b),
                }
            })
            .collect()
    }

    /// The outcome as `tolles procedure --json` writes it: the terms in the patent's three
    /// groups (`perm_nT`, `induced`, `eddy_s`), their standard errors, the steps, passes,
    /// missing maneuvers and undetermined terms, the least-squares terms and the comparison,
    /// the cloverleaf check, skipped windows and every maneuver analysed.
    pub fn to_json(&self) -> Value {
        let report = &self.report;
        let mut doc = serde_json::to_value(report.terms).expect("terms serialise");
        let comparison: Vec<Value> = self
            .comparison()
            .iter()
            .map(|c| {
                json!({
                    "term": c.term.name(),
                    "procedure": c.procedure,
                    "least_squares": c.least_squares,
                    "difference": c.difference,
                })
            })
            .collect();
        let maneuvers: Vec<Value> = report
            .maneuvers
            .iter()
            .map(|m| {
                json!({
                    "label": m.label,
                    "time_s": m.time_s,
                    "period_s": m.period_s,
                    "amplitude_deg": m.amplitude_deg,
                })
            })
            .collect();
        let fields = [
            ("std_errors", serde_json::to_value(report.std_errors)),
            ("steps", serde_json::to_value(&report.steps)),
            ("passes", serde_json::to_value(report.passes)),
            ("missing", serde_json::to_value(&report.missing)),
            ("undetermined", serde_json::to_value(&report.undetermined)),
            ("least_squares", serde_json::to_value(self.least_squares)),
            ("comparison", Ok(Value::Array(comparison))),
            ("cloverleaf", serde_json::to_value(&report.cloverleaf)),
            ("skipped", serde_json::to_value(&report.skipped)),
            ("maneuvers", Ok(Value::Array(maneuvers))),
        ];
        let object = doc.as_object_mut().expect("an object");
        for (key, value) in fields {
            object.insert(key.into(), value.expect("the report serialises"));
        }
        doc
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::read::read_table;
    use crate::simulate::{simulate, write, PlanKind, SimulateRequest, UniformField};
    use crate::Silent;
    use tolles_core::patent::procedure::ManeuverKind;

    /// A patent flight in a uniform field (dip 68°, declination −3°), no geology or diurnal
    /// variation, written to `dir`; its table and true terms.
    fn patent_flight(dir: &std::path::Path) -> (Table, [f64; 16]) {
        let request = SimulateRequest {
            plan: PlanKind::Patent,
            uniform: Some(UniformField {
                inclination_deg: 68.0,
                declination_deg: -3.0,
                intensity_nt: 52_000.0,
            }),
            geology_nt: 0.0,
            diurnal_nt: 0.0,
            ..SimulateRequest::default()
        };
        let simulated = simulate(&request, &Silent).unwrap();
        let path = dir.join("patent.csv");
        write(&simulated, &path).unwrap();
        let truth = Term::OBSERVABLE.map(|t| t.value(&simulated.scenario.aircraft));
        (read_table(&path, &Silent, &mut Vec::new()).unwrap(), truth)
    }

    fn term(name: &str) -> usize {
        Term::OBSERVABLE
            .iter()
            .position(|t| t.name() == name)
            .unwrap()
    }

    #[test]
    fn the_procedure_recovers_the_simulated_terms_with_either_direction() {
        let dir = tempfile::tempdir().unwrap();
        let (table, truth) = patent_flight(dir.path());
        let fluxgate = Direction::Fluxgate {
            vector: "flux_a".into(),
        };
        let attitude = Direction::Attitude { dip_deg: 68.0 };
        for direction in [fluxgate, attitude] {
            let request = ProcedureRequest {
                declination_deg: -3.0,
                ..ProcedureRequest::new("mag_1_uc", direction)
            };
            let mut warnings = Vec::new();
            let outcome = procedure(&table, &request, &mut warnings).unwrap();
            assert!(warnings.is_empty(), "{warnings:?}");
            // Perm T (nT) within 5 % of the largest perm term, as the CLI's tests ask.
            let largest = truth[..3].iter().fold(0.0f64, |m, v| m.max(v.abs()));
            let t = outcome.report.terms.0[term("T")].unwrap();
            assert!((t - truth[term("T")]).abs() <= 0.05 * largest, "{t}");
            let json = outcome.to_json();
            assert_eq!(json["perm_nT"]["T"], json!(t));
            assert_eq!(json["comparison"].as_array().unwrap().len(), 16);
            assert!(json["least_squares"]["eddy_s"]["tl"].is_number());
        }
    }

    #[test]
    fn ignored_maneuvers_are_missing_and_unknown_ones_an_error() {
        let dir = tempfile::tempdir().unwrap();
        let (table, _) = patent_flight(dir.path());
        let request = ProcedureRequest {
            ignore: vec!["Roll on 045°".into()],
            ..ProcedureRequest::new("mag_1_uc", Direction::Attitude { dip_deg: 68.0 })
        };
        let outcome = procedure(&table, &request, &mut Vec::new()).unwrap();
        assert_eq!(outcome.report.missing, ["roll on 045°"]);
        let request = ProcedureRequest {
            ignore: vec!["roll on 046".into()],
            ..request
        };
        let e = procedure(&table, &request, &mut Vec::new()).unwrap_err();
        assert!(matches!(&e, Error::NoSuchManeuver { name, .. } if name == "roll on 046"));
        assert!(!e.to_string().contains("--"), "{e}");
    }

    #[test]
    fn ignoring_matches_labels_with_or_without_the_degree_sign() {
        let table = Table::csv().reader("tt\n0\n".as_bytes(), "f.csv").unwrap();
        let window = |heading: f64| ManeuverWindow {
            kind: ManeuverKind::Roll,
            heading_deg: heading,
            range: 0..10,
        };
        let names = ["Roll on 045".to_string(), "roll on 315°".to_string()];
        let kept = without_ignored(vec![window(45.0), window(315.0)], &names, &table).unwrap();
        assert!(kept.is_empty());
        let pitch = ["pitch on 045".to_string()];
        assert!(without_ignored(vec![window(45.0)], &pitch, &table).is_err());
    }

    #[test]
    fn a_flight_without_time_says_so() {
        let table = Table::csv().reader("mag\n1\n".as_bytes(), "f.csv").unwrap();
        let request = ProcedureRequest::new("mag", Direction::Attitude { dip_deg: 60.0 });
        let e = procedure(&table, &request, &mut Vec::new()).unwrap_err();
        assert_eq!(
            e.to_string(),
            "f.csv: the procedure needs the time column \"tt\" (s)"
        );
    }
}
