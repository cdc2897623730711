//! The Tolles patent's compensation procedure (US 2,692,970), digitised: one maneuver family at
//! a time identifies a few terms, with the terms found before cancelled.
//!
//! ```
//! use tolles_core::flight::plan::PatentPlan;
//! use tolles_core::patent::procedure::{windows_from_plan, Geometry, ProcedureInput, run};
//! use tolles_core::flight::sim::{simulate, Installation, Scenario};
//!
//! let plan = PatentPlan::default().build();
//! let mut scenario = Scenario::new(Installation::Cabin.aircraft(), 1);
//! scenario.sensors.flux_noise_nt = 0.0;
//! let flight = simulate(&plan, &scenario).unwrap();
//! let windows = windows_from_plan(&plan, scenario.fs_hz, -3.0); // declination −3°
//! let geometry = Geometry::from_fluxgate(&flight.tt, &flight.flux);
//! let report = run(&ProcedureInput {
//!     tt: &flight.tt,
//!     scalar: &flight.scalar,
//!     roll_deg: &flight.roll_deg,
//!     pitch_deg: &flight.pitch_deg,
//!     geometry: &geometry,
//!     windows: &windows,
//! })
//! .unwrap();
//! let t = report.value("T").unwrap();
//! assert!((t - scenario.aircraft.permanent_nt[1]).abs() < 2.0); // perm T = P_y (nT)
//! assert!(report.undetermined.is_empty());
//! ```
//!
//! # The sequence
//! Each step uses one maneuver family and some harmonic components of the magnetometer signal
//! on it ([`STEPS`]). For a roll or pitch `angle = A·sin ωτ`, perm and induced terms give only
//! `sin ωτ, cos 2ωτ, sin 3ωτ, …` and eddy terms only `cos ωτ, sin 2ωτ, …` (the generating
//! function of an eddy term is a function of the angle times its rate). So reading `cos ωτ` and
//! `sin 2ωτ` silences perm and induced exactly: the patent's "temporary compensation" of them
//! while the eddy terms are adjusted (steps 1–5). Steps 6–11 then read `sin ωτ` and `cos 2ωτ`
//! (and the wing-ups' static change) for perm and induced terms. Where the patent compensates
//! a term "temporarily" (T and V while adjusting TL+LT, TV+VT and LV+VL) that term is a nuisance
//! unknown of the step, solved for and not reported.
//!
//! Within a step: every component of every used maneuver, minus the contributions of the terms
//! already known, equals `Σ unknown × projection of its generating function`; the small system
//! is solved by least squares weighted by the components' standard errors. The projections are
//! computed from the maneuver as flown (measured attitude and dip, or the fluxgate), from the
//! exact generating functions, not from the tables' small-angle closed forms.
//!
//! The patent repeats adjustments in flight until the indications vanish; we repeat the whole
//! sequence, each pass cancelling every other term at its latest value, until no term moves by
//! more than a thousandth of its standard error (at most [`MAX_PASSES`]). This removes the
//! cross-talk the first-order tables neglect (vt's O(b³) share of a north roll's `cos ωτ`,
//! VV−TT beside V in step 7) and the cross-talk of headings that are not exactly cardinal
//! (a north roll at magnetic 013° also carries V and LV+VL). From the second pass on, a term
//! still undetermined that shows on a step's maneuvers is solved for beside the step's own
//! unknowns, and any of them it cannot be told from is undetermined too.
//!
//! Headings are magnetic, clockwise from magnetic north (true heading minus declination); a
//! window matches a step's heading within [`HEADING_TOLERANCE_DEG`].

pub use super::analysis::*;
use crate::patent::{Section, Term};
use crate::signal::filter::Band;
use crate::signal::metrics::std_dev;
use nalgebra::{DMatrix, DVector};
use serde::ser::SerializeMap;
use serde::{Deserialize, Serialize, Serializer};

/// A window matches a step's heading when they differ by at most this much (degrees).
pub const HEADING_TOLERANCE_DEG: f64 = 20.0;

/// At most this many passes through the sequence (see the module documentation).
pub const MAX_PASSES: usize = 30;

/// The passes stop when no term changes by more than this fraction of its standard error.
const CONVERGED: f64 = 1e-3;

/// What the aircraft does in a window.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum ManeuverKind {
    /// Oscillation in roll (about x, right wing down positive).
    Roll,
    /// Oscillation in pitch (about y, nose up positive).
    Pitch,
    /// Oscillation in yaw (about z, nose right positive).
    Yaw,
    /// A large bank held steady (the patent's wing-up, 35–45°).
    WingUp,
    /// Cloverleaf turns: verification only.
    Cloverleaf,
}

impl From<crate::maneuvers::ManeuverKind> for ManeuverKind {
    /// A harmonic maneuver about `axis`.
    fn from(axis: crate::maneuvers::ManeuverKind) -> Self {
        match axis {
            crate::maneuvers::ManeuverKind::Roll => ManeuverKind::Roll,
            crate::maneuvers::ManeuverKind::Pitch => ManeuverKind::Pitch,
            crate::maneuvers::ManeuverKind::Yaw => ManeuverKind::Yaw,
        }
    }
}

impl ManeuverKind {
    pub(super) fn name(self) -> &'static str {
        match self {
            ManeuverKind::Roll => "roll",
            ManeuverKind::Pitch => "pitch",
            ManeuverKind::Yaw => "yaw",
            ManeuverKind::WingUp => "wing-up",
            ManeuverKind::Cloverleaf => "cloverleaf",
        }
    }
}

/// One step of the sequence.
#[derive(Debug, Clone, Copy)]
pub struct StepSpec {
    /// What the step does, in the patent's words.
    pub purpose: &'static str,
    /// The maneuvers it uses: kind and magnetic heading (degrees).
    pub maneuvers: &'static [(ManeuverKind, f64)],
    /// Harmonic components read on rolls and pitches (wing-ups give their static change).
    pub components: &'static [Component],
    /// Terms it identifies.
    pub identifies: &'static [Term],
    /// Terms compensated temporarily: solved for, not reported.
    pub temporary: &'static [Term],
}

use ManeuverKind::{Pitch as P, Roll as R, WingUp as W};

const EDDY: &[Component] = &[Component::Cos1, Component::Sin2];

/// The patent's sequence. Adjustments to its wording, where the mathematics asks for them:
/// step 3 also uses the SE and SW rolls (vl's sign there is the same information); step 7 reads
/// all eight roll headings with T and V as temporary unknowns, which is what the patent's
/// "temporarily compensate T on north–south rolls and V on east–west rolls, then roll NE and
/// NW" amounts to; step 10 also reads the rolls' `cos 2ωt`, where V and VV−TT differ.
pub const STEPS: [StepSpec; 11] = [
    StepSpec {
        purpose: "eddy tl and tv from north and south rolls",
        maneuvers: &[(R, 0.0), (R, 180.0)],
        components: EDDY,
        identifies: &[Term::EddyTL, Term::EddyTV],
        temporary: &[],
    },
    StepSpec {
        purpose: "eddy vv−tt and vt from east and west rolls",
        maneuvers: &[(R, 90.0), (R, 270.0)],
        components: EDDY,
        identifies: &[Term::EddyVVTT, Term::EddyVT],
        temporary: &[],
    },
    StepSpec {
        purpose: "eddy vl from northeast and northwest (and southeast, southwest) rolls",
        maneuvers: &[(R, 45.0), (R, 315.0), (R, 135.0), (R, 225.0)],
        components: EDDY,
        identifies: &[Term::EddyVL],
        temporary: &[],
    },
    StepSpec {
        purpose: "eddy vv−ll and lv from north and south pitches",
        maneuvers: &[(P, 0.0), (P, 180.0)],
        components: EDDY,
        identifies: &[Term::EddyVVLL, Term::EddyLV],
        temporary: &[],
    },
    StepSpec {
        purpose: "eddy lt from east and west pitches",
        maneuvers: &[(P, 90.0), (P, 270.0)],
        components: EDDY,
        identifies: &[Term::EddyLT],
        temporary: &[],
    },
    StepSpec {
        purpose: "induced TL+LT from north and south rolls (T temporarily)",
        maneuvers: &[(R, 0.0), (R, 180.0)],
        components: &[Component::Sin1],
        identifies: &[Term::InducedTLLT],
        temporary: &[Term::PermT],
    },
    StepSpec {
        purpose: "induced LV+VL and TV+VT from northeast and northwest (and the other) rolls \
                  (T and V temporarily)",
        maneuvers: &[
            (R, 45.0),
            (R, 315.0),
            (R, 135.0),
            (R, 225.0),
            (R, 0.0),
            (R, 180.0),
            (R, 90.0),
            (R, 270.0),
        ],
        components: &[Component::Sin1],
        identifies: &[Term::InducedLVVL, Term::InducedTVVT],
        temporary: &[Term::PermT, Term::PermV],
    },
    StepSpec {
        purpose: "perm T from north and south rolls",
        maneuvers: &[(R, 0.0), (R, 180.0)],
        components: &[Component::Sin1],
        identifies: &[Term::PermT],
        temporary: &[],
    },
    StepSpec {
        purpose: "perm L from east and west pitches",
        maneuvers: &[(P, 90.0), (P, 270.0)],
        components: &[Component::Sin1],
        identifies: &[Term::PermL],
        temporary: &[],
    },
    StepSpec {
        purpose: "perm V and induced VV−TT from east and west rolls and wing-ups",
        maneuvers: &[(R, 90.0), (R, 270.0), (W, 90.0), (W, 270.0)],
        components: &[Component::Sin1, Component::Cos2],
        identifies: &[Term::PermV, Term::InducedVVTT],
        temporary: &[],
    },
    StepSpec {
        purpose: "induced VV−LL from north and south pitches",
        maneuvers: &[(P, 0.0), (P, 180.0)],
        components: &[Component::Sin1, Component::Cos2],
        identifies: &[Term::InducedVVLL],
        temporary: &[],
    },
];

/// A term's value, or why there is none.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct TermEstimate {
    /// Patent name (`T`, `VV-TT`, `tl`, …).
    pub term: &'static str,
    /// nT (perm), dimensionless (induced), s (eddy); `None` when undetermined.
    pub value: Option<f64>,
    /// Standard error, same unit.
    pub std_error: Option<f64>,
}

/// A component as used by a step.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct UsedComponent {
    /// `roll on 000°`.
    pub maneuver: String,
    /// Which component.
    pub component: Component,
    /// As measured (nT).
    pub measured_nt: f64,
    /// Its standard error (nT).
    pub std_error_nt: f64,
    /// What is left after cancelling every term known at the end of the step (nT).
    pub after_nt: f64,
}

/// A maneuver a step used.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct UsedManeuver {
    /// `roll on 000°`.
    pub label: String,
    /// Start and end time (s).
    pub time_s: (f64, f64),
}

/// The compensator adjustment equivalent to a term, as in the patent's Fig. 2.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct CompensatorSetting {
    /// Patent name of the term.
    pub term: &'static str,
    /// Which device and how it is wired.
    pub device: String,
    /// Its gain: nT (perm coil), fraction of the pickup's reading (induced mixer), seconds on
    /// the pickup's rate (eddy mixer).
    pub gain: f64,
    /// Unit of the gain.
    pub unit: &'static str,
}

/// What a step did.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct StepReport {
    /// 1, 2, …
    pub number: usize,
    /// What it does.
    pub purpose: &'static str,
    /// Maneuvers used.
    pub maneuvers: Vec<UsedManeuver>,
    /// Maneuvers it asks for that the flight lacks (`roll on 045°`).
    pub missing: Vec<String>,
    /// Terms identified.
    pub identified: Vec<TermEstimate>,
    /// Terms compensated temporarily (solved for, not kept).
    pub temporary: Vec<TermEstimate>,
    /// The components it read.
    pub components: Vec<UsedComponent>,
    /// Harmonic (or static) RMS of those components before any cancelling (nT).
    pub rms_before_nt: f64,
    /// The same after cancelling every term known at the end of the step (nT).
    pub rms_after_nt: f64,
    /// Equivalent compensator settings of the identified terms.
    pub settings: Vec<CompensatorSetting>,
    /// Why terms are undetermined, if they are.
    pub note: Option<String>,
}

/// Band-passed noise of the cloverleaf before and after compensating with the identified terms.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Verification {
    /// Time span (s).
    pub time_s: (f64, f64),
    /// Pass band (Hz), `(pass1, pass2)`.
    pub band_hz: (f64, f64),
    /// Standard deviation of the band-passed scalar (nT).
    pub before_nt: f64,
    /// After subtracting the identified terms' signal (nT).
    pub after_nt: f64,
    /// before / after.
    pub improvement: f64,
}

/// 16 optional term values serialised as the patent's three groups:
/// `{"perm_nT": {"T": …}, "induced": {"VV-TT": …}, "eddy_s": {"vv-tt": …}}`.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct TermValues(pub [Option<f64>; 16]);

impl TermValues {
    /// The value of the term named `name` (patent name).
    pub fn get(&self, name: &str) -> Option<f64> {
        self.term(Term::from_name(name)?)
    }

    /// The value of `term` (unit [`Term::unit`]), if known; `None` for TT, LL and VV alone.
    pub fn term(&self, term: Term) -> Option<f64> {
        self.0[term.observable_index()?]
    }
}

struct Group<'a>(&'a TermValues, Section);

impl Serialize for Group<'_> {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        let mut map = s.serialize_map(None)?;
        for (term, value) in Term::OBSERVABLE.iter().zip(self.0 .0) {
            if term.section() == self.1 {
                map.serialize_entry(term.name(), &value)?;
            }
        }
        map.end()
    }
}

impl Serialize for TermValues {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        let mut map = s.serialize_map(Some(3))?;
        map.serialize_entry("perm_nT", &Group(self, Section::Perm))?;
        map.serialize_entry("induced", &Group(self, Section::Induced))?;
        map.serialize_entry("eddy_s", &Group(self, Section::Eddy))?;
        map.end()
    }
}

/// The whole procedure's result.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ProcedureReport {
    /// The 16 terms (`None`: undetermined).
    pub terms: TermValues,
    /// Their standard errors.
    pub std_errors: TermValues,
    /// Step by step, as in the last pass.
    pub steps: Vec<StepReport>,
    /// Passes through the sequence until the terms stopped changing.
    pub passes: usize,
    /// Maneuvers the sequence asks for that the flight lacks.
    pub missing: Vec<String>,
    /// Terms that could not be determined.
    pub undetermined: Vec<&'static str>,
    /// The cloverleaf check, if the flight has one.
    pub cloverleaf: Option<Verification>,
    /// Windows that could not be analysed, and why.
    pub skipped: Vec<String>,
    /// Every analysed maneuver.
    pub maneuvers: Vec<ManeuverAnalysis>,
}

impl ProcedureReport {
    /// A term's value by patent name.
    pub fn value(&self, name: &str) -> Option<f64> {
        self.terms.get(name)
    }
}

fn index(term: Term) -> usize {
    term.observable_index().expect("an observable term")
}

fn heading_matches(a: f64, b: f64) -> bool {
    let d = (a - b).rem_euclid(360.0);
    d.min(360.0 - d) <= HEADING_TOLERANCE_DEG
}

/// A row of a step's system: a maneuver's component.
struct Row<'a> {
    maneuver: &'a ManeuverAnalysis,
    data: &'a ComponentData,
}

/// Why the procedure cannot run.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum ProcedureError {
    /// An input channel differs in length from the time column.
    #[error("{what} has {got} samples but the time column has {expected}")]
    LengthMismatch {
        /// The input channel that differs.
        what: &'static str,
        /// Its length (samples).
        got: usize,
        /// Length of the time column (samples).
        expected: usize,
    },
}

fn check_lengths(input: &ProcedureInput) -> Result<(), ProcedureError> {
    let expected = input.tt.len();
    for (what, got) in [
        ("the scalar", input.scalar.len()),
        ("the roll", input.roll_deg.len()),
        ("the pitch", input.pitch_deg.len()),
        ("the geometry", input.geometry.len()),
    ] {
        if got != expected {
            return Err(ProcedureError::LengthMismatch {
                what,
                got,
                expected,
            });
        }
    }
    Ok(())
}

/// Runs the patent's sequence on a flight. Windows reaching past the end are cut there.
pub fn run(input: &ProcedureInput) -> Result<ProcedureReport, ProcedureError> {
    check_lengths(input)?;
    let mut maneuvers = Vec::new();
    let mut skipped = Vec::new();
    for window in input.windows {
        match analyse(input, window) {
            Some(Ok(a)) => maneuvers.push(a),
            Some(Err(e)) => skipped.push(format!("{}: {e}", window.label())),
            None => {}
        }
    }
    let mut values: [Option<f64>; 16] = [None; 16];
    let mut errors: [Option<f64>; 16] = [None; 16];
    let mut steps = Vec::new();
    let mut passes = 0;
    while passes < MAX_PASSES {
        let previous = values;
        steps.clear();
        // From the second pass on, a term still unknown is known to be undetermined.
        let settled = passes > 0;
        for (k, spec) in STEPS.iter().enumerate() {
            let step = run_step(k + 1, spec, &maneuvers, &mut values, &mut errors, settled);
            steps.push(step);
        }
        passes += 1;
        let converged = (0..16).all(|k| match (previous[k], values[k], errors[k]) {
            (None, None, _) => true,
            (Some(a), Some(b), Some(se)) => (a - b).abs() <= CONVERGED * se,
            _ => false,
        });
        if settled && converged {
            break;
        }
    }
    let mut missing: Vec<String> = Vec::new();
    for m in steps.iter().flat_map(|s| &s.missing) {
        if !missing.contains(m) {
            missing.push(m.clone());
        }
    }
    let undetermined = Term::OBSERVABLE
        .iter()
        .zip(values)
        .filter(|(_, v)| v.is_none())
        .map(|(t, _)| t.name())
        .collect();
    let terms = TermValues(values);
    Ok(ProcedureReport {
        cloverleaf: verify(input, &terms),
        terms,
        std_errors: TermValues(errors),
        steps,
        passes,
        missing,
        undetermined,
        skipped,
        maneuvers,
    })
}

/// A column is negligible when its norm is below this fraction of the largest column of the
/// same section (perm, induced or eddy) on all components of the step's maneuvers.
const NEGLIGIBLE: f64 = 1e-3;

fn run_step(
    number: usize,
    spec: &StepSpec,
    maneuvers: &[ManeuverAnalysis],
    values: &mut [Option<f64>; 16],
    errors: &mut [Option<f64>; 16],
    settled: bool,
) -> StepReport {
    let mut used = Vec::new();
    let mut missing = Vec::new();
    let mut rows: Vec<Row> = Vec::new();
    for &(kind, heading) in spec.maneuvers {
        let found: Vec<&ManeuverAnalysis> = maneuvers
            .iter()
            .filter(|m| m.window.kind == kind && heading_matches(m.window.heading_deg, heading))
            .collect();
        if found.is_empty() {
            missing.push(maneuver_name(kind, heading));
        }
        for m in found {
            used.push(UsedManeuver {
                label: m.label.clone(),
                time_s: m.time_s,
            });
            for data in &m.components {
                let wanted = match kind {
                    ManeuverKind::WingUp => data.component == Component::Static,
                    _ => spec.components.contains(&data.component),
                };
                if wanted {
                    rows.push(Row { maneuver: m, data });
                }
            }
        }
    }
    let unknowns: Vec<Term> = spec
        .identifies
        .iter()
        .chain(spec.temporary)
        .copied()
        .collect();
    let is_unknown = |k: usize| unknowns.iter().any(|t| index(*t) == k);
    // Everything else known is cancelled.
    let target: Vec<f64> = rows
        .iter()
        .map(|r| {
            r.data.measured_nt
                - (0..16)
                    .filter(|&k| !is_unknown(k))
                    .map(|k| values[k].unwrap_or(0.0) * r.data.per_term[k])
                    .sum::<f64>()
        })
        .collect();
    // A term not determined elsewhere that shows on these rows is solved for beside the
    // step's unknowns, so that it is not absorbed by them; an unknown it cannot be told from
    // is then undetermined too.
    let blockers: Vec<Term> = if settled {
        Term::OBSERVABLE
            .iter()
            .enumerate()
            .filter(|&(k, t)| !is_unknown(k) && values[k].is_none() && !negligible(*t, &rows))
            .map(|(_, t)| *t)
            .collect()
    } else {
        Vec::new()
    };
    let columns: Vec<Term> = unknowns.iter().chain(&blockers).copied().collect();
    let solution = solve(&rows, &target, &columns, unknowns.len());
    let undetermined = unknowns
        .iter()
        .zip(&solution)
        .filter(|(_, s)| s.is_none())
        .map(|(t, _)| t.name())
        .collect::<Vec<_>>();
    let note = if undetermined.is_empty() {
        None
    } else if rows.is_empty() {
        Some("undetermined: none of its maneuvers was flown".to_string())
    } else if blockers.is_empty() {
        Some(format!(
            "{} undetermined: the maneuvers flown do not separate them",
            undetermined.join(", ")
        ))
    } else {
        Some(format!(
            "{} undetermined: the maneuvers flown do not separate them from {}, which could \
             not be determined",
            undetermined.join(", "),
            blockers
                .iter()
                .map(|t| t.name())
                .collect::<Vec<_>>()
                .join(", ")
        ))
    };
    let mut identified = Vec::new();
    let mut temporary = Vec::new();
    for &term in &unknowns {
        let found = unknowns
            .iter()
            .position(|t| *t == term)
            .and_then(|j| solution[j]);
        let estimate = TermEstimate {
            term: term.name(),
            value: found.map(|f| f.0),
            std_error: found.map(|f| f.1),
        };
        if spec.identifies.contains(&term) {
            values[index(term)] = estimate.value;
            errors[index(term)] = estimate.std_error;
            identified.push(estimate);
        } else {
            temporary.push(estimate);
        }
    }
    let temporary_value = |k: usize| {
        temporary
            .iter()
            .find(|e| e.term == Term::OBSERVABLE[k].name())
            .and_then(|e| e.value)
    };
    let components: Vec<UsedComponent> = rows
        .iter()
        .map(|r| {
            let explained: f64 = (0..16)
                .map(|k| temporary_value(k).or(values[k]).unwrap_or(0.0) * r.data.per_term[k])
                .sum();
            UsedComponent {
                maneuver: r.maneuver.label.clone(),
                component: r.data.component,
                measured_nt: r.data.measured_nt,
                std_error_nt: r.data.std_error_nt,
                after_nt: r.data.measured_nt - explained,
            }
        })
        .collect();
    let rms = |f: &dyn Fn(&UsedComponent) -> f64| {
        if components.is_empty() {
            return f64::NAN;
        }
        (components
            .iter()
            .map(|c| (c.component.rms_factor() * f(c)).powi(2))
            .sum::<f64>()
            / components.len() as f64)
            .sqrt()
    };
    StepReport {
        number,
        purpose: spec.purpose,
        maneuvers: used,
        missing,
        settings: identified
            .iter()
            .filter_map(|e| {
                let term = Term::from_name(e.term)?;
                e.value.map(|v| compensator_setting(term, v))
            })
            .collect(),
        identified,
        temporary,
        rms_before_nt: rms(&|c| c.measured_nt),
        rms_after_nt: rms(&|c| c.after_nt),
        components,
        note,
    }
}

/// Whether `term`'s column on `rows` is negligible beside the largest column of its section on
/// every component of the same maneuvers.
fn negligible(term: Term, rows: &[Row]) -> bool {
    let own = rows
        .iter()
        .map(|r| r.data.per_term[index(term)].powi(2))
        .sum::<f64>()
        .sqrt();
    let mut maneuvers: Vec<&ManeuverAnalysis> = Vec::new();
    for r in rows {
        if !maneuvers.iter().any(|m| std::ptr::eq(*m, r.maneuver)) {
            maneuvers.push(r.maneuver);
        }
    }
    let largest = Term::OBSERVABLE
        .iter()
        .enumerate()
        .filter(|(_, t)| t.section() == term.section())
        .map(|(k, _)| {
            maneuvers
                .iter()
                .flat_map(|m| &m.components)
                .map(|c| c.per_term[k].powi(2))
                .sum::<f64>()
                .sqrt()
        })
        .fold(0.0, f64::max);
    !(own.is_finite() && own > NEGLIGIBLE * largest && largest > 0.0)
}

/// An unknown is undetermined when less than this fraction of its (weighted) column is
/// independent of the other columns.
const COLLINEAR: f64 = 1e-2;

/// Weighted least squares for `terms` (the first `reported` of them are the step's own): value
/// and standard error of each, `None` for a term the rows do not determine (negligible, or not
/// separable from the others).
fn solve(rows: &[Row], target: &[f64], terms: &[Term], reported: usize) -> Vec<Option<(f64, f64)>> {
    let m = rows.len();
    let mut out = vec![None; terms.len()];
    // Weights 1/σ; a floor keeps a noise-free component from swamping the rest.
    let floor = rows
        .iter()
        .map(|r| r.data.std_error_nt)
        .filter(|s| s.is_finite() && *s > 0.0)
        .fold(f64::INFINITY, f64::min)
        .clamp(1e-9, 1.0);
    let weight: Vec<f64> = rows
        .iter()
        .map(|r| 1.0 / r.data.std_error_nt.max(floor))
        .collect();
    let column = |term: Term| -> DVector<f64> {
        DVector::from_fn(m, |i, _| weight[i] * rows[i].data.per_term[index(term)])
    };
    let y = DVector::from_fn(m, |i, _| weight[i] * target[i]);
    let mut active: Vec<usize> = (0..terms.len())
        .filter(|&j| !negligible(terms[j], rows) && column(terms[j]).iter().all(|v| v.is_finite()))
        .collect();
    if m == 0 || !y.iter().all(|v| v.is_finite()) {
        return out;
    }
    // One at a time: drop the step's unknown the others explain best; failing that the
    // blocker; and while there are more columns than rows, the least independent blocker.
    loop {
        let fractions: Vec<(usize, f64)> = active
            .iter()
            .map(|&j| {
                let others: Vec<Term> = active
                    .iter()
                    .filter(|&&i| i != j)
                    .map(|&i| terms[i])
                    .collect();
                (j, independent_fraction(&column(terms[j]), &others, &column))
            })
            .collect();
        let least = |mine: bool, limit: f64| {
            fractions
                .iter()
                .filter(|(j, f)| (*j < reported) == mine && *f < limit)
                .min_by(|a, b| a.1.total_cmp(&b.1))
                .map(|(j, _)| *j)
        };
        let crowded = if active.len() > m {
            f64::INFINITY
        } else {
            COLLINEAR
        };
        let drop = least(true, COLLINEAR)
            .or_else(|| least(false, crowded))
            .or_else(|| least(true, crowded));
        match drop {
            Some(j) => active.retain(|&i| i != j),
            None => break,
        }
    }
    let p = active.len();
    if p == 0 || m < p {
        return out;
    }
    let a = DMatrix::from_fn(m, p, |i, k| column(terms[active[k]])[i]);
    // Solved on unit-norm columns, for conditioning.
    let norms: Vec<f64> = (0..p).map(|k| a.column(k).norm()).collect();
    let scaled = DMatrix::from_fn(m, p, |i, k| a[(i, k)] / norms[k]);
    let Some(gram_inv) = (scaled.transpose() * &scaled).try_inverse() else {
        return out;
    };
    let beta = &gram_inv * (scaled.transpose() * &y);
    let residual = &y - &scaled * &beta;
    let dof = m - p;
    let chi2 = if dof > 0 {
        (residual.norm_squared() / dof as f64).max(1.0)
    } else {
        1.0
    };
    for (k, &j) in active.iter().enumerate() {
        out[j] = Some((
            beta[k] / norms[k],
            (chi2 * gram_inv[(k, k)]).sqrt() / norms[k],
        ));
    }
    out
}

/// The fraction of `v`'s norm not explained by the columns of `others`.
fn independent_fraction(
    v: &DVector<f64>,
    others: &[Term],
    column: &dyn Fn(Term) -> DVector<f64>,
) -> f64 {
    let norm = v.norm();
    if norm.is_nan() || norm <= 0.0 {
        return 0.0;
    }
    if others.is_empty() {
        return 1.0;
    }
    let m = v.len();
    let b = DMatrix::from_fn(m, others.len(), |i, k| column(others[k])[i]);
    match b.svd(true, true).solve(v, 1e-12) {
        Ok(x) => {
            (v - &DMatrix::from_fn(m, others.len(), |i, k| column(others[k])[i]) * x).norm() / norm
        }
        Err(_) => 0.0,
    }
}

/// The patent's Fig. 2 setting equivalent to `term = value`. Perm coils and mixers must add
/// `−value·scale·g` to the magnetometer; the pickups read `H·t` (transverse) and `H·v`
/// (vertical), the eddy pickups the rates `H·ṫ`, `H·l̇`, `H·v̇`.
pub fn compensator_setting(term: Term, value: f64) -> CompensatorSetting {
    let perm = |coil: &str| CompensatorSetting {
        term: term.name(),
        device: format!("perm coil {coil}: field along it"),
        gain: -value,
        unit: "nT",
    };
    let mixer = |pickup: &str, coil: &str, gain: f64| CompensatorSetting {
        term: term.name(),
        device: format!("induced mixer: pickup {pickup} into coil {coil}"),
        gain,
        unit: "fraction of the pickup signal",
    };
    let eddy = |pickup: &str, coil: &str, gain: f64| CompensatorSetting {
        term: term.name(),
        device: format!("eddy mixer: rate of pickup {pickup} into coil {coil}"),
        gain,
        unit: "s",
    };
    match term {
        Term::PermT => perm("T (transverse)"),
        Term::PermL => perm("L (longitudinal)"),
        Term::PermV => perm("V (vertical)"),
        // g = −t²: a field +value·H·t along T adds +value·H·t² = −value·H·g.
        Term::InducedVVTT => mixer("T", "T", value),
        // g = −l² = t² + v² − 1: the two pickups on their own coils, the constant dropped.
        Term::InducedVVLL => mixer("T and V", "T and V respectively", -value),
        Term::InducedTLLT => mixer("T", "L", -value),
        Term::InducedTVVT => mixer("T", "V", -value),
        Term::InducedLVVL => mixer("V", "L", -value),
        Term::InducedTT | Term::InducedLL | Term::InducedVV => mixer("-", "-", -value),
        // Eddy 'ab' = E[b][a]: the rate along a drives a field along b.
        Term::EddyVVTT => eddy("T", "T", value),
        Term::EddyVVLL => eddy("L", "L", value),
        Term::EddyTL => eddy("T", "L", -value),
        Term::EddyTV => eddy("T", "V", -value),
        Term::EddyLT => eddy("L", "T", -value),
        Term::EddyLV => eddy("L", "V", -value),
        Term::EddyVL => eddy("V", "L", -value),
        Term::EddyVT => eddy("V", "T", -value),
    }
}

/// Pass band (Hz) of the cloverleaf check, as MagNav's.
pub const VERIFY_BAND: Band = Band::MAGNAV;

/// The cloverleaf check: band-passed scalar over the span of the cloverleaf windows, before
/// and after subtracting the identified terms' signal.
pub fn verify(input: &ProcedureInput, terms: &TermValues) -> Option<Verification> {
    let clover: Vec<&ManeuverWindow> = input
        .windows
        .iter()
        .filter(|w| w.kind == ManeuverKind::Cloverleaf)
        .collect();
    let n = input.tt.len();
    let start = clover.iter().map(|w| w.range.start).min()?.min(n);
    let end = clover.iter().map(|w| w.range.end).max()?.min(n);
    let span = start..end;
    let predicted = input.geometry.aircraft_signal(&terms.0);
    let fs = crate::signal::segment::median_step(&input.tt[span.clone()]).map(|dt| 1.0 / dt)?;
    let filter = VERIFY_BAND.butterworth(4, fs).ok()??;
    let band_passed = |x: Vec<f64>| -> Option<f64> {
        if !x.iter().all(|v| v.is_finite()) {
            return None;
        }
        let detrended = crate::compensate::detrend(&x);
        Some(std_dev(&filter.filtfilt(&detrended).ok()?))
    };
    let before = band_passed(input.scalar[span.clone()].to_vec())?;
    let after = band_passed(
        span.clone()
            .map(|k| input.scalar[k] - predicted[k])
            .collect(),
    )?;
    Some(Verification {
        time_s: (input.tt[start], input.tt[end.saturating_sub(1)]),
        band_hz: VERIFY_BAND.edges_hz(),
        before_nt: before,
        after_nt: after,
        improvement: before / after,
    })
}

/// The 16 terms from an ordinary least-squares fit on the same flight, for comparison: the
/// design `permanent,i5,e8` with λ by cross-validation, on the fluxgate the geometry implies.
pub fn least_squares_terms(
    scalar: &[f64],
    geometry: &Geometry,
    fs_hz: f64,
    tt: Option<&[f64]>,
) -> Result<TermValues, crate::fit::FitError> {
    // The defaults of `tolles fit` (exact magnitude when it predicts better, heading levels),
    // kept to the patent's 16 terms.
    let settings = crate::fit::FitSettings {
        alternative_terms: Vec::new(),
        ..crate::fit::FitSettings::recommended()
    };
    let flux = geometry.as_fluxgate();
    let fitted = crate::fit::fit(scalar, &flux, fs_hz, tt, &settings)?;
    let field = crate::model::interpret::AircraftField::from_coefficients(
        &fitted.settings.design,
        &fitted.coefficients,
        fs_hz,
    );
    Ok(TermValues(Term::OBSERVABLE.map(|t| Some(t.value(&field)))))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::flight::plan::PatentPlan;
    use crate::flight::plan::Plan;
    use crate::flight::sim::{simulate, Installation, Scenario, SimulatedFlight};
    use crate::model::interpret::AircraftField;

    const DECLINATION: f64 = -3.0;

    fn patent_flight(aircraft: AircraftField, seed: u64) -> (Plan, Scenario, SimulatedFlight) {
        let plan = PatentPlan::default().build();
        let scenario = Scenario::new(aircraft, seed);
        let flight = simulate(&plan, &scenario).unwrap();
        (plan, scenario, flight)
    }

    fn report_of(plan: &Plan, flight: &SimulatedFlight, fs: f64) -> ProcedureReport {
        let windows = windows_from_plan(plan, fs, DECLINATION);
        let geometry = Geometry::from_fluxgate(&flight.tt, &flight.flux);
        run(&ProcedureInput {
            tt: &flight.tt,
            scalar: &flight.scalar,
            roll_deg: &flight.roll_deg,
            pitch_deg: &flight.pitch_deg,
            geometry: &geometry,
            windows: &windows,
        })
        .unwrap()
    }

    /// Largest |truth| of each section.
    fn largest(truth: &[f64; 16], section: Section) -> f64 {
        Term::OBSERVABLE
            .iter()
            .zip(truth)
            .filter(|(t, _)| t.section() == section)
            .fold(0.0, |m, (_, v)| m.max(v.abs()))
    }

    fn truth_of(aircraft: &AircraftField) -> [f64; 16] {
        Term::OBSERVABLE.map(|t| t.value(aircraft))
    }

    #[test]
    fn the_procedure_recovers_every_term_and_quiets_a_held_out_cloverleaf() {
        // Cabin installation: all 16 terms non-zero; a uniform field (no geology, no diurnal:
        // a compensation flight is flown high); scalar noise 0.01 nT, fluxgate noise 0.5 nT.
        let aircraft = Installation::Cabin.aircraft();
        let (plan, scenario, flight) = patent_flight(aircraft, 3);
        assert_eq!(
            (
                scenario.sensors.scalar_noise_nt,
                scenario.sensors.flux_noise_nt
            ),
            (0.01, 0.5)
        );
        let report = report_of(&plan, &flight, scenario.fs_hz);
        assert!(report.missing.is_empty() && report.skipped.is_empty());
        let truth = truth_of(&aircraft);
        assert!(truth.iter().all(|v| *v != 0.0));
        for (k, term) in Term::OBSERVABLE.iter().enumerate() {
            let tolerance = match term.section() {
                Section::Perm => 0.05,
                Section::Induced => 0.08,
                Section::Eddy => 0.15,
            } * largest(&truth, term.section());
            let got = report.terms.0[k].expect("determined");
            assert!(
                (got - truth[k]).abs() <= tolerance,
                "{}: {got:e} vs truth {:e} (tolerance {tolerance:e})",
                term.name(),
                truth[k]
            );
        }
        // A second flight, other noise, never seen by the procedure: its cloverleaf.
        let held_out = simulate(&plan, &Scenario::new(aircraft, 4)).unwrap();
        let windows = windows_from_plan(&plan, scenario.fs_hz, DECLINATION);
        let geometry = Geometry::from_fluxgate(&held_out.tt, &held_out.flux);
        let check = verify(
            &ProcedureInput {
                tt: &held_out.tt,
                scalar: &held_out.scalar,
                roll_deg: &held_out.roll_deg,
                pitch_deg: &held_out.pitch_deg,
                geometry: &geometry,
                windows: &windows,
            },
            &report.terms,
        )
        .unwrap();
        assert!(check.improvement >= 20.0, "{check:?}");
        // Every step explains its maneuvers.
        for step in &report.steps {
            assert!(step.rms_after_nt < step.rms_before_nt, "{step:?}");
        }
    }

    #[test]
    fn projected_generating_functions_agree_with_the_computed_tables() {
        use crate::patent::harmonics::{HarmonicManeuver, HarmonicTable};
        use crate::patent::Maneuver;
        // Noise-free, ideal maneuvers; geometry from the attitude, as without a fluxgate.
        let mut scenario = Scenario::new(AircraftField::default(), 1);
        scenario.sensors.scalar_noise_nt = 0.0;
        scenario.sensors.flux_noise_nt = 0.0;
        // Four cycles; the windows below are the middle two, whole cycles away from the
        // segments' ends, where the rate (a central difference) straddles the start of motion.
        let patent = PatentPlan {
            cycles: 4,
            ..PatentPlan::default()
        };
        let plan = patent.build();
        let flight = simulate(&plan, &scenario).unwrap();
        let earth = crate::flight::sim::EarthField::default();
        let h = earth.intensity_nt;
        let geometry = Geometry::from_attitude(
            &flight.tt,
            &flight.roll_deg,
            &flight.pitch_deg,
            &flight.yaw_deg,
            earth.inclination_deg,
            earth.declination_deg,
            h,
        );
        let fs = scenario.fs_hz;
        let cycle = (patent.period_s * fs).round() as usize;
        let windows: Vec<ManeuverWindow> = windows_from_plan(&plan, fs, earth.declination_deg)
            .into_iter()
            .map(|w| ManeuverWindow {
                range: w.range.start + cycle..w.range.start + 3 * cycle,
                ..w
            })
            .collect();
        let input = ProcedureInput {
            tt: &flight.tt,
            scalar: &flight.scalar,
            roll_deg: &flight.roll_deg,
            pitch_deg: &flight.pitch_deg,
            geometry: &geometry,
            windows: &windows,
        };
        let mut checked = 0;
        for window in &windows {
            let (maneuver, amplitude) = match window.kind {
                ManeuverKind::Roll => (Maneuver::Roll, patent.roll_deg),
                ManeuverKind::Pitch => (Maneuver::Pitch, patent.pitch_deg),
                _ => continue,
            };
            let analysis = analyse(&input, window).unwrap().unwrap();
            let omega = 2.0 * std::f64::consts::PI / analysis.period_s.unwrap();
            assert!((analysis.period_s.unwrap() - patent.period_s).abs() < 1e-6);
            assert!((analysis.amplitude_deg.unwrap() - amplitude).abs() < 1e-6);
            let table = HarmonicTable::compute(&HarmonicManeuver::new(
                maneuver,
                amplitude,
                window.heading_deg,
                earth.inclination_deg,
            ))
            .unwrap();
            let component = |c: Component| {
                analysis
                    .components
                    .iter()
                    .find(|d| d.component == c)
                    .unwrap()
                    .per_term
            };
            let (sin1, cos1, sin2, cos2) = (
                component(Component::Sin1),
                component(Component::Cos1),
                component(Component::Sin2),
                component(Component::Cos2),
            );
            for (k, term) in Term::OBSERVABLE.iter().enumerate() {
                let row = table.row(*term).unwrap();
                let scale = term.scale(h);
                let (fundamental, second, others) = match term.section() {
                    Section::Eddy => (
                        cos1[k] / (scale * omega),
                        sin2[k] / (scale * omega),
                        [sin1[k], cos2[k]],
                    ),
                    _ => (sin1[k] / scale, cos2[k] / scale, [cos1[k], sin2[k]]),
                };
                let tolerance = 2e-3 * amplitude.to_radians();
                assert!(
                    (fundamental - row.fundamental).abs() < tolerance
                        && (second - row.second_harmonic).abs() < tolerance,
                    "{} {}: ({fundamental}, {second}) vs table ({}, {})",
                    window.label(),
                    term.name(),
                    row.fundamental,
                    row.second_harmonic
                );
                // Perm and induced give no cos ωt or sin 2ωt, eddy no sin ωt or cos 2ωt.
                let size = scale
                    * if term.section() == Section::Eddy {
                        omega
                    } else {
                        1.0
                    };
                assert!(others.iter().all(|v| (v / size).abs() < tolerance));
            }
            checked += 1;
        }
        assert_eq!(checked, 12); // 8 rolls and 4 pitches
    }

    fn without(
        windows: &[ManeuverWindow],
        kind: ManeuverKind,
        headings: &[f64],
    ) -> Vec<ManeuverWindow> {
        windows
            .iter()
            .filter(|w| {
                !(w.kind == kind && headings.iter().any(|h| heading_matches(w.heading_deg, *h)))
            })
            .cloned()
            .collect()
    }

    #[test]
    fn missing_maneuvers_are_named_and_the_rest_is_still_determined() {
        // Declination 0: the cardinal headings are exactly magnetic cardinal headings, where
        // LV+VL gives no sin ωt at all.
        let aircraft = Installation::Cabin.aircraft();
        let plan = PatentPlan::default().build();
        let mut scenario = Scenario::new(aircraft, 5);
        scenario.environment =
            crate::flight::environment::Environment::uniform(crate::flight::sim::EarthField {
                declination_deg: 0.0,
                ..crate::flight::sim::EarthField::default()
            });
        let flight = simulate(&plan, &scenario).unwrap();
        let all = windows_from_plan(&plan, scenario.fs_hz, 0.0);
        let geometry = Geometry::from_fluxgate(&flight.tt, &flight.flux);
        let run_with = |windows: &[ManeuverWindow]| {
            run(&ProcedureInput {
                tt: &flight.tt,
                scalar: &flight.scalar,
                roll_deg: &flight.roll_deg,
                pitch_deg: &flight.pitch_deg,
                geometry: &geometry,
                windows,
            })
            .unwrap()
        };
        let truth = truth_of(&aircraft);
        // No NE and NW rolls: named; SE and SW still give vl and LV+VL.
        let report = run_with(&without(&all, ManeuverKind::Roll, &[45.0, 315.0]));
        assert_eq!(report.missing, ["roll on 045°", "roll on 315°"]);
        assert!(report.undetermined.is_empty());
        let step3 = &report.steps[2];
        assert_eq!(step3.missing, ["roll on 045°", "roll on 315°"]);
        assert_eq!(step3.maneuvers.len(), 2);
        // No intercardinal rolls at all: vl and LV+VL cannot be determined; nor can L, which
        // east and west pitches show only in proportion to LV+VL. The rest can: VV−LL changes
        // sign between north and south pitches, L and LV+VL do not.
        let report = run_with(&without(
            &all,
            ManeuverKind::Roll,
            &[45.0, 135.0, 225.0, 315.0],
        ));
        assert_eq!(report.undetermined, ["L", "LV+VL", "vl"]);
        assert!(report.steps[8].note.as_deref().unwrap().contains("LV+VL"));
        assert_eq!(report.value("vl"), None);
        for (k, term) in Term::OBSERVABLE.iter().enumerate() {
            if let Some(v) = report.terms.0[k] {
                let tolerance = 0.15 * largest(&truth, term.section());
                assert!(
                    (v - truth[k]).abs() < tolerance,
                    "{}: {v:e} vs {:e}",
                    term.name(),
                    truth[k]
                );
            }
        }
        // No wing-ups: V and VV−TT rest on the rolls' second harmonic alone, still reported.
        let report = run_with(&without(&all, ManeuverKind::WingUp, &[90.0, 270.0]));
        assert_eq!(report.missing, ["wing-up on 090°", "wing-up on 270°"]);
    }

    #[test]
    fn inputs_of_different_lengths_are_an_error() {
        let tt = [0.0, 0.1, 0.2];
        let geometry =
            Geometry::from_attitude(&tt, &[0.0; 3], &[0.0; 3], &[0.0; 3], 60.0, 0.0, 5e4);
        let input = ProcedureInput {
            tt: &tt,
            scalar: &[5e4; 2],
            roll_deg: &[0.0; 3],
            pitch_deg: &[0.0; 3],
            geometry: &geometry,
            windows: &[],
        };
        assert_eq!(
            run(&input),
            Err(ProcedureError::LengthMismatch {
                what: "the scalar",
                got: 2,
                expected: 3
            })
        );
    }

    #[test]
    fn json_groups_carry_nulls_for_undetermined_terms() {
        let mut values = TermValues([Some(1.0); 16]);
        values.0[index(Term::EddyVL)] = None;
        let json = serde_json::to_value(values).unwrap();
        assert_eq!(json["perm_nT"]["T"], 1.0);
        assert_eq!(json["induced"]["VV-TT"], 1.0);
        assert!(json["eddy_s"]["vl"].is_null());
        assert_eq!(json["eddy_s"].as_object().unwrap().len(), 8);
        assert_eq!(json["induced"].as_object().unwrap().len(), 5);
    }

    #[test]
    fn compensator_settings_cancel_their_term() {
        // A mixer of gain k from pickup a into coil b adds k·H·c_a·c_b (induced) to the scalar;
        // with the stated gain this must be −value·H·g.
        let c = [0.3, -0.4, (1.0f64 - 0.25).sqrt()];
        let value = 2e-3;
        for (term, a, b) in [
            (Term::InducedTLLT, 1, 0),
            (Term::InducedTVVT, 1, 2),
            (Term::InducedLVVL, 2, 0),
            (Term::InducedVVTT, 1, 1),
        ] {
            let gain = compensator_setting(term, value).gain;
            let added = gain * c[a] * c[b];
            assert!(
                (added + value * term.generating(c, [0.0; 3])).abs() < 1e-15,
                "{term:?}"
            );
        }
        let vv_ll = compensator_setting(Term::InducedVVLL, value).gain;
        let added = vv_ll * (c[1] * c[1] + c[2] * c[2]);
        let wanted = -value * Term::InducedVVLL.generating(c, [0.0; 3]);
        // Equal up to the constant −value·1 the compensator drops.
        assert!((added - (wanted - value)).abs() < 1e-15);
        assert_eq!(compensator_setting(Term::PermT, 5.0).gain, -5.0);
    }
}
