//! The procedure's measurements: the maneuvers of a flight, the field's direction cosines and
//! their rates over each, the harmonic components of the scalar, and the wing-up and static
//! changes the patent reads off by hand.

use super::procedure::ManeuverKind;
use crate::flight::attitude::Attitude;
use crate::flight::plan::{Motion, Plan};
use crate::model::vector::VectorSeries;
use crate::patent::{field_direction, Term};
use crate::signal::demodulate::{fit_sinusoid, Basis, DemodulateError, Harmonics};
use serde::{Deserialize, Serialize};
use std::ops::Range;

/// A maneuver found in a flight: its kind, magnetic heading and samples.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ManeuverWindow {
    /// Roll, pitch, …
    pub kind: ManeuverKind,
    /// Heading (degrees, clockwise from magnetic north: true heading minus declination).
    pub heading_deg: f64,
    /// Sample indices.
    pub range: Range<usize>,
}

/// `roll on 045°`: a maneuver on a heading (degrees, rounded).
pub fn maneuver_name(kind: ManeuverKind, heading_deg: f64) -> String {
    let heading = heading_deg.rem_euclid(360.0).round() as i64 % 360;
    format!("{} on {heading:03}°", kind.name())
}

impl ManeuverWindow {
    /// `roll on 045°`.
    pub fn label(&self) -> String {
        maneuver_name(self.kind, self.heading_deg)
    }
}

/// The windows of a plan's maneuvers at sample rate `fs_hz` (Hz), headings made magnetic with
/// `declination_deg` (degrees east). Turns of 180° or more are cloverleaf turns; other turns
/// and straight legs are not maneuvers.
pub fn windows_from_plan(plan: &Plan, fs_hz: f64, declination_deg: f64) -> Vec<ManeuverWindow> {
    let samples = (plan.duration_s() * fs_hz).floor() as usize + 1;
    plan.segments()
        .iter()
        .zip(plan.starts())
        .filter_map(|(segment, start)| {
            let kind = match &segment.motion {
                Motion::Harmonic { axis, .. } => ManeuverKind::from(*axis),
                Motion::Hold { .. } => ManeuverKind::WingUp,
                Motion::Turn { change_deg, .. } if change_deg.abs() >= 180.0 => {
                    ManeuverKind::Cloverleaf
                }
                _ => return None,
            };
            let first = (start * fs_hz).ceil() as usize;
            let end = (((start + segment.duration_s) * fs_hz).floor() as usize + 1).min(samples);
            Some(ManeuverWindow {
                kind,
                heading_deg: segment.heading_deg - declination_deg,
                range: first..end,
            })
        })
        .collect()
}

/// The earth field's direction in the body frame and its magnitude, sample by sample.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Geometry {
    /// Unit direction `(l, t, v)` (body x, y, z); NaN where unknown.
    pub direction: Vec<[f64; 3]>,
    /// Its rate of change (1/s), by central differences in time.
    pub rate: Vec<[f64; 3]>,
    /// Field magnitude H (nT).
    pub h_nt: Vec<f64>,
}

impl Geometry {
    /// From the attitude (degrees: roll right wing down, pitch nose up, yaw clockwise from true
    /// north), the dip and declination (degrees) and a field magnitude `h_nt` (nT).
    pub fn from_attitude(
        tt: &[f64],
        roll_deg: &[f64],
        pitch_deg: &[f64],
        yaw_deg: &[f64],
        dip_deg: f64,
        declination_deg: f64,
        h_nt: f64,
    ) -> Self {
        let direction: Vec<[f64; 3]> = (0..tt.len())
            .map(|k| {
                let attitude =
                    Attitude::from_degrees(yaw_deg[k] - declination_deg, pitch_deg[k], roll_deg[k]);
                field_direction(&attitude, dip_deg.to_radians())
            })
            .collect();
        Self {
            rate: rate_of_change(tt, &direction),
            direction,
            h_nt: vec![h_nt; tt.len()],
        }
    }

    /// From a fluxgate (nT, body frame): `l, t, v = B̂x, B̂y, B̂z`, `H = |B|`.
    pub fn from_fluxgate(tt: &[f64], flux: &VectorSeries) -> Self {
        let h_nt: Vec<f64> = (0..flux.len()).map(|k| flux.magnitude(k)).collect();
        let direction: Vec<[f64; 3]> = (0..flux.len())
            .map(|k| flux.at(k).map(|b| b / h_nt[k]))
            .collect();
        Self {
            rate: rate_of_change(tt, &direction),
            direction,
            h_nt,
        }
    }

    /// Samples.
    pub fn len(&self) -> usize {
        self.direction.len()
    }

    /// No samples.
    pub fn is_empty(&self) -> bool {
        self.direction.is_empty()
    }

    /// `scale × g` of a term at every sample: nT per unit of the term (nT/nT for perm, nT for
    /// induced, nT/s for eddy).
    pub fn term_series(&self, term: Term) -> Vec<f64> {
        self.term_series_within(term, 0..self.len())
    }

    /// [`Geometry::term_series`] over the samples of `span` only, NaN elsewhere (full length).
    pub fn term_series_within(&self, term: Term, span: Range<usize>) -> Vec<f64> {
        let inside = span.start.min(self.len())..span.end.min(self.len());
        (0..self.len())
            .map(|k| match inside.contains(&k) {
                true => term.scale(self.h_nt[k]) * term.generating(self.direction[k], self.rate[k]),
                false => f64::NAN,
            })
            .collect()
    }

    /// The aircraft's signal (nT) predicted from term values in [`Term::OBSERVABLE`] order;
    /// undetermined terms (`None`) contribute nothing.
    pub fn aircraft_signal(&self, values: &[Option<f64>; 16]) -> Vec<f64> {
        let mut out = vec![0.0; self.len()];
        for (term, value) in Term::OBSERVABLE.iter().zip(values) {
            if let Some(v) = value {
                for (o, g) in out.iter_mut().zip(self.term_series(*term)) {
                    *o += v * g;
                }
            }
        }
        out
    }

    /// The fluxgate this geometry implies, `H·(l, t, v)` (nT).
    pub fn as_fluxgate(&self) -> VectorSeries {
        let axis = |i: usize| -> Vec<f64> {
            (0..self.len())
                .map(|k| self.h_nt[k] * self.direction[k][i])
                .collect()
        };
        VectorSeries::new(axis(0), axis(1), axis(2))
    }
}

fn rate_of_change(tt: &[f64], c: &[[f64; 3]]) -> Vec<[f64; 3]> {
    let n = c.len();
    (0..n)
        .map(|k| {
            let (a, b) = (k.saturating_sub(1), (k + 1).min(n.saturating_sub(1)));
            let dt = tt[b] - tt[a];
            [0, 1, 2].map(|i| {
                if dt > 0.0 {
                    (c[b][i] - c[a][i]) / dt
                } else {
                    f64::NAN
                }
            })
        })
        .collect()
}

/// A part of the magnetometer signal on one maneuver.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum Component {
    /// `sin ωτ`: perm and induced fundamental.
    #[serde(rename = "sin wt")]
    Sin1,
    /// `cos ωτ`: eddy fundamental.
    #[serde(rename = "cos wt")]
    Cos1,
    /// `sin 2ωτ`: eddy second harmonic.
    #[serde(rename = "sin 2wt")]
    Sin2,
    /// `cos 2ωτ`: perm and induced second harmonic.
    #[serde(rename = "cos 2wt")]
    Cos2,
    /// A wing-up's steady change from the level flight around it.
    #[serde(rename = "static")]
    Static,
}

impl Component {
    /// Its name.
    pub fn name(self) -> &'static str {
        match self {
            Component::Sin1 => "sin ωt",
            Component::Cos1 => "cos ωt",
            Component::Sin2 => "sin 2ωt",
            Component::Cos2 => "cos 2ωt",
            Component::Static => "static",
        }
    }

    fn of(self, h: &Harmonics) -> f64 {
        match self {
            Component::Sin1 => h.sin1,
            Component::Cos1 => h.cos1,
            Component::Sin2 => h.sin2,
            Component::Cos2 => h.cos2,
            Component::Static => f64::NAN,
        }
    }

    /// RMS of a component of unit amplitude: 1/√2 for a sinusoid, 1 for a static change.
    pub(super) fn rms_factor(self) -> f64 {
        match self {
            Component::Static => 1.0,
            _ => std::f64::consts::FRAC_1_SQRT_2,
        }
    }
}

/// One component of one maneuver: the magnetometer's and every term's.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ComponentData {
    /// Which component.
    pub component: Component,
    /// The magnetometer's (nT).
    pub measured_nt: f64,
    /// Its standard error (nT).
    pub std_error_nt: f64,
    /// Each term's `scale × g` projected the same way (nT per unit term), [`Term::OBSERVABLE`]
    /// order.
    #[serde(skip)]
    pub per_term: [f64; 16],
}

/// A maneuver, analysed.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ManeuverAnalysis {
    /// The window.
    pub window: ManeuverWindow,
    /// `roll on 045°`.
    pub label: String,
    /// Start and end time (s).
    pub time_s: (f64, f64),
    /// Period (s) of a roll or pitch.
    pub period_s: Option<f64>,
    /// Amplitude (degrees) of a roll or pitch, or the held bank of a wing-up.
    pub amplitude_deg: Option<f64>,
    /// The components.
    pub components: Vec<ComponentData>,
}

/// The flight the procedure reads.
#[derive(Debug, Clone, Copy)]
pub struct ProcedureInput<'a> {
    /// Time (s).
    pub tt: &'a [f64],
    /// Uncompensated scalar magnetometer (nT).
    pub scalar: &'a [f64],
    /// Roll, right wing down (degrees): the channel a roll is demodulated on.
    pub roll_deg: &'a [f64],
    /// Pitch, nose up (degrees).
    pub pitch_deg: &'a [f64],
    /// Direction cosines and field magnitude.
    pub geometry: &'a Geometry,
    /// The maneuvers.
    pub windows: &'a [ManeuverWindow],
}

/// Analyses one window: harmonic components for rolls and pitches, the static change for a
/// wing-up; `None` for other kinds.
pub fn analyse(
    input: &ProcedureInput,
    window: &ManeuverWindow,
) -> Option<Result<ManeuverAnalysis, DemodulateError>> {
    let r = window.range.start.min(input.tt.len())..window.range.end.min(input.tt.len());
    let tt = &input.tt[r.clone()];
    let time_s = (
        tt.first().copied().unwrap_or(f64::NAN),
        tt.last().copied().unwrap_or(f64::NAN),
    );
    // A wing-up also reads the level flight around it.
    let reach = match window.kind {
        ManeuverKind::WingUp => reference_samples(input.tt),
        _ => 0,
    };
    let span = r.start.saturating_sub(reach)..r.end + reach;
    let series: Vec<Vec<f64>> = Term::OBSERVABLE
        .iter()
        .map(|t| input.geometry.term_series_within(*t, span.clone()))
        .collect();
    let analysis = |period_s, amplitude_deg, components| ManeuverAnalysis {
        window: window.clone(),
        label: window.label(),
        time_s,
        period_s,
        amplitude_deg,
        components,
    };
    match window.kind {
        ManeuverKind::Roll | ManeuverKind::Pitch => {
            let angle = match window.kind {
                ManeuverKind::Roll => &input.roll_deg[r.clone()],
                _ => &input.pitch_deg[r.clone()],
            };
            let result = (|| {
                let wave = fit_sinusoid(tt, angle)?;
                let basis = Basis {
                    omega: wave.omega,
                    t0: wave.t0,
                };
                let measured = basis.demodulate(tt, &input.scalar[r.clone()])?;
                let projected = series
                    .iter()
                    .map(|s| basis.project(tt, &s[r.clone()]))
                    .collect::<Result<Vec<_>, _>>()?;
                let components = [
                    Component::Sin1,
                    Component::Cos1,
                    Component::Sin2,
                    Component::Cos2,
                ]
                .map(|c| ComponentData {
                    component: c,
                    measured_nt: c.of(&measured.value),
                    std_error_nt: c.of(&measured.std_error),
                    per_term: std::array::from_fn(|k| c.of(&projected[k])),
                })
                .to_vec();
                Ok(analysis(
                    Some(wave.period_s()),
                    Some(wave.amplitude),
                    components,
                ))
            })();
            Some(result)
        }
        ManeuverKind::WingUp => Some(
            wing_up(input, window, &series)
                .map(|(bank, component)| analysis(None, Some(bank), vec![component])),
        ),
        ManeuverKind::Yaw | ManeuverKind::Cloverleaf => None,
    }
}

/// Level flight this long (s) before and after a wing-up is its reference.
pub const WING_UP_REFERENCE_S: f64 = 10.0;

/// Samples in [`WING_UP_REFERENCE_S`].
fn reference_samples(tt: &[f64]) -> usize {
    let fs = crate::signal::segment::median_step(tt).map_or(1.0, |dt| 1.0 / dt);
    (WING_UP_REFERENCE_S * fs).round() as usize
}

/// Attitude within this many degrees of level counts as level flight.
const LEVEL_DEG: f64 = 2.0;

/// The static change of a wing-up: the mean over the held bank (|roll| within 5 % of its peak)
/// minus the level flight around it (within [`WING_UP_REFERENCE_S`] of the window, |roll| and
/// |pitch| under 2°), detrended by a straight line when there is level flight on both sides.
fn wing_up(
    input: &ProcedureInput,
    window: &ManeuverWindow,
    series: &[Vec<f64>],
) -> Result<(f64, ComponentData), DemodulateError> {
    let n = input.tt.len();
    let r = window.range.start.min(n)..window.range.end.min(n);
    let roll = input.roll_deg;
    let peak = r
        .clone()
        .map(|k| roll[k])
        .filter(|v| v.is_finite())
        .fold(0.0f64, |m, v| if v.abs() > m.abs() { v } else { m });
    let held: Vec<usize> = r
        .clone()
        .filter(|&k| roll[k] * peak.signum() >= 0.95 * peak.abs())
        .collect();
    let reach = reference_samples(input.tt);
    let level = |k: &usize| roll[*k].abs() < LEVEL_DEG && input.pitch_deg[*k].abs() < LEVEL_DEG;
    let before: Vec<usize> = (r.start.saturating_sub(reach)..r.start)
        .filter(level)
        .collect();
    let after: Vec<usize> = (r.end..(r.end + reach).min(n)).filter(level).collect();
    const MIN: usize = 5;
    if held.len() < MIN || before.len() + after.len() < MIN {
        return Err(DemodulateError::TooShort {
            needed: MIN,
            got: held.len().min(before.len() + after.len()),
        });
    }
    let line = before.len() >= MIN && after.len() >= MIN;
    let reference: Vec<usize> = before.into_iter().chain(after).collect();
    let change = |y: &[f64]| static_change(input.tt, y, &held, &reference, line);
    let (measured, sigma) = change(input.scalar);
    let se = sigma * (1.0 / held.len() as f64 + 1.0 / reference.len() as f64).sqrt();
    let per_term = std::array::from_fn(|k| change(&series[k]).0);
    Ok((
        peak,
        ComponentData {
            component: Component::Static,
            measured_nt: measured,
            std_error_nt: se,
            per_term,
        },
    ))
}

/// Mean of `y` over `held` minus the reference level there (mean, or straight line in time
/// through the `reference` samples), and the reference's residual standard deviation.
fn static_change(
    tt: &[f64],
    y: &[f64],
    held: &[usize],
    reference: &[usize],
    line: bool,
) -> (f64, f64) {
    let m = reference.len() as f64;
    let t_mean = reference.iter().map(|&k| tt[k]).sum::<f64>() / m;
    let y_mean = reference.iter().map(|&k| y[k]).sum::<f64>() / m;
    let slope = if line {
        let (sxy, sxx) = reference.iter().fold((0.0, 0.0), |(sxy, sxx), &k| {
            let dt = tt[k] - t_mean;
            (sxy + dt * (y[k] - y_mean), sxx + dt * dt)
        });
        if sxx > 0.0 {
            sxy / sxx
        } else {
            0.0
        }
    } else {
        0.0
    };
    let level = |k: usize| y_mean + slope * (tt[k] - t_mean);
    let change = held.iter().map(|&k| y[k] - level(k)).sum::<f64>() / held.len() as f64;
    let dof = (m - if line { 2.0 } else { 1.0 }).max(1.0);
    let sigma = (reference
        .iter()
        .map(|&k| (y[k] - level(k)).powi(2))
        .sum::<f64>()
        / dof)
        .sqrt();
    (change, sigma)
}
