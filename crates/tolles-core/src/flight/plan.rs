//! Flight plans: attitude as a continuous function of time, built from segments.
//!
//! ```
//! use tolles_core::flight::plan::{BoxPlan, Plan};
//! let plan: Plan = BoxPlan::default().build();
//! let a = plan.attitude(12.0); // 2 s into the roll maneuver on north
//! assert!(a.roll.to_degrees() > 5.0 && a.yaw.abs() < 1e-12);
//! assert_eq!(plan.segments()[1].line, 2.0);
//! ```
//!
//! Angles in a plan's parameters are degrees; [`Plan::attitude`] returns radians. Conventions are
//! those of [`crate::model::conventions`].

use crate::flight::attitude::Attitude;
use serde::{Deserialize, Serialize};
use std::f64::consts::PI;

/// The axis of a harmonic maneuver: the same type as a detected maneuver's kind, so a plan and
/// what is found in its flight compare directly.
pub use crate::maneuvers::ManeuverKind as Axis;

/// A sinusoid `amplitude·sin(2π·frequency·t + phase)` (degrees, Hz, radians).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Wave {
    /// Amplitude (degrees).
    pub amplitude_deg: f64,
    /// Frequency (Hz).
    pub frequency_hz: f64,
    /// Phase at `t = 0` (rad).
    pub phase_rad: f64,
}

impl Wave {
    fn at(&self, t: f64) -> f64 {
        self.amplitude_deg * (2.0 * PI * self.frequency_hz * t + self.phase_rad).sin()
    }
}

/// What the aircraft does during a segment.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum Motion {
    /// Straight and level.
    Straight,
    /// A coordinated turn by `change_deg` (positive clockwise) banked at most `bank_deg`.
    Turn {
        /// Heading change (degrees, positive clockwise).
        change_deg: f64,
        /// Largest bank angle (degrees).
        bank_deg: f64,
    },
    /// `amplitude·sin(2π t / period)` about one axis, whole cycles.
    Harmonic {
        /// The axis turned about.
        axis: Axis,
        /// Amplitude (degrees).
        amplitude_deg: f64,
        /// Period (s).
        period_s: f64,
    },
    /// A constant roll (positive right wing down) entered and left smoothly: the patent's
    /// wing-up (a left wing-up is a positive roll).
    Hold {
        /// The roll held (degrees, positive right wing down).
        roll_deg: f64,
    },
    /// Straight flight disturbed by turbulence: a sum of waves on each axis.
    Turbulent {
        /// Waves summed on the roll (degrees).
        roll: Vec<Wave>,
        /// Waves summed on the pitch (degrees).
        pitch: Vec<Wave>,
        /// Waves summed on the yaw (degrees).
        yaw: Vec<Wave>,
    },
}

/// A piece of a flight.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Segment {
    /// Line id written to the `line` column.
    pub line: f64,
    /// Heading at the start (degrees clockwise from north).
    pub heading_deg: f64,
    /// Duration (s).
    pub duration_s: f64,
    /// What the aircraft does.
    pub motion: Motion,
}

impl Segment {
    /// Heading at the end (degrees).
    pub fn end_heading_deg(&self) -> f64 {
        match self.motion {
            Motion::Turn { change_deg, .. } => self.heading_deg + change_deg,
            _ => self.heading_deg,
        }
    }

    /// Attitude `t` seconds into the segment.
    pub fn attitude(&self, t: f64) -> Attitude {
        let u = (t / self.duration_s).clamp(0.0, 1.0);
        let (mut yaw, mut pitch, mut roll) = (self.heading_deg, 0.0, 0.0);
        match &self.motion {
            Motion::Straight => {}
            Motion::Turn {
                change_deg,
                bank_deg,
            } => {
                yaw += change_deg * (1.0 - (PI * u).cos()) / 2.0;
                roll = bank_deg * change_deg.signum() * (PI * u).sin();
            }
            Motion::Harmonic {
                axis,
                amplitude_deg,
                period_s,
            } => {
                let angle = amplitude_deg * (2.0 * PI * t / period_s).sin();
                match axis {
                    Axis::Roll => roll = angle,
                    Axis::Pitch => pitch = angle,
                    Axis::Yaw => yaw += angle,
                }
            }
            Motion::Hold { roll_deg } => {
                // Quarter of the time to roll in, half held, quarter to roll out.
                let ramp = ((4.0 * u).min(1.0).min(4.0 * (1.0 - u)) * PI / 2.0)
                    .sin()
                    .powi(2);
                roll = roll_deg * ramp;
            }
            Motion::Turbulent {
                roll: r,
                pitch: p,
                yaw: y,
            } => {
                // Fade in and out so the attitude joins its neighbours without a jump.
                let fade = taper(t, self.duration_s, TURBULENCE_FADE_S);
                roll = fade * r.iter().map(|w| w.at(t)).sum::<f64>();
                pitch = fade * p.iter().map(|w| w.at(t)).sum::<f64>();
                yaw += fade * y.iter().map(|w| w.at(t)).sum::<f64>();
            }
        }
        Attitude::from_degrees(yaw, pitch, roll)
    }
}

/// Time (s) over which turbulence fades in at the start of a segment and out at its end.
const TURBULENCE_FADE_S: f64 = 5.0;

/// A smooth window: 0 at both ends of `[0, duration]`, rising as sin² over `fade` seconds.
fn taper(t: f64, duration: f64, fade: f64) -> f64 {
    let fade = fade.min(duration / 2.0);
    let edge = t.min(duration - t).clamp(0.0, fade) / fade;
    (edge * PI / 2.0).sin().powi(2)
}

/// A sequence of segments flown back to back.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct Plan {
    segments: Vec<Segment>,
    starts: Vec<f64>,
}

impl Plan {
    /// A plan from segments in flight order.
    pub fn new(segments: Vec<Segment>) -> Self {
        let mut starts = Vec::with_capacity(segments.len());
        let mut t = 0.0;
        for s in &segments {
            starts.push(t);
            t += s.duration_s;
        }
        Self { segments, starts }
    }

    /// The segments.
    pub fn segments(&self) -> &[Segment] {
        &self.segments
    }

    /// Start time of each segment (s).
    pub fn starts(&self) -> &[f64] {
        &self.starts
    }

    /// Total duration (s).
    pub fn duration_s(&self) -> f64 {
        self.segments.iter().map(|s| s.duration_s).sum()
    }

    /// Index of the segment flown at time `t` (s); the last one after the end.
    pub fn segment_at(&self, t: f64) -> usize {
        self.starts
            .partition_point(|start| *start <= t)
            .saturating_sub(1)
            .min(self.segments.len().saturating_sub(1))
    }

    /// Attitude at time `t` (s from the start of the plan).
    pub fn attitude(&self, t: f64) -> Attitude {
        let k = self.segment_at(t);
        self.segments[k].attitude(t - self.starts[k])
    }
}

/// The standard compensation box: on each heading, rolls, pitches and yaws of a few cycles,
/// joined by straight legs and turns. A maneuver whose amplitude is zero is left out.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct BoxPlan {
    /// Headings flown, in order (degrees clockwise from north).
    pub headings_deg: Vec<f64>,
    /// Roll amplitude (degrees).
    pub roll_deg: f64,
    /// Pitch amplitude (degrees).
    pub pitch_deg: f64,
    /// Yaw amplitude (degrees).
    pub yaw_deg: f64,
    /// Period of every maneuver (s).
    pub period_s: f64,
    /// Cycles of each maneuver.
    pub cycles: u32,
    /// Straight flight before, between and after the maneuvers of a heading (s).
    pub straight_s: f64,
    /// Duration of each turn to the next heading (s).
    pub turn_s: f64,
}

impl Default for BoxPlan {
    /// Headings N, E, S, W; roll ±10°, pitch ±5°, yaw ±5°; 6 s period, 3 cycles.
    fn default() -> Self {
        Self {
            headings_deg: vec![0.0, 90.0, 180.0, 270.0],
            roll_deg: 10.0,
            pitch_deg: 5.0,
            yaw_deg: 5.0,
            period_s: 6.0,
            cycles: 3,
            straight_s: 10.0,
            turn_s: 30.0,
        }
    }
}

impl BoxPlan {
    /// The plan; each segment gets its own line id 1, 2, 3, …
    pub fn build(&self) -> Plan {
        let mut b = Builder::default();
        for (k, &heading) in self.headings_deg.iter().enumerate() {
            b.heading = heading;
            b.push(self.straight_s, Motion::Straight);
            for (axis, amplitude) in [
                (Axis::Roll, self.roll_deg),
                (Axis::Pitch, self.pitch_deg),
                (Axis::Yaw, self.yaw_deg),
            ] {
                // An amplitude of zero leaves the maneuver out of the box.
                if amplitude == 0.0 {
                    continue;
                }
                b.push(
                    self.period_s * self.cycles as f64,
                    Motion::Harmonic {
                        axis,
                        amplitude_deg: amplitude,
                        period_s: self.period_s,
                    },
                );
                b.push(self.straight_s, Motion::Straight);
            }
            if let Some(next) = self.headings_deg.get(k + 1) {
                b.turn_to(*next, self.turn_s);
            }
        }
        b.plan()
    }
}

/// The patent's harmonic maneuvers (US 2,692,970): rolls on the cardinal and intercardinal
/// headings, pitches on the cardinal headings, large wing-ups on east and west, and a cloverleaf
/// to verify the compensation.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PatentPlan {
    /// Roll amplitude (degrees); the patent uses 15°.
    pub roll_deg: f64,
    /// Pitch amplitude (degrees).
    pub pitch_deg: f64,
    /// Period of the harmonic maneuvers (s).
    pub period_s: f64,
    /// Cycles of each harmonic maneuver.
    pub cycles: u32,
    /// Wing-up bank (degrees); the patent asks for 35–45°.
    pub wingup_deg: f64,
    /// Duration of each wing-up, entry and exit included (s).
    pub wingup_s: f64,
    /// Straight flight between maneuvers (s).
    pub straight_s: f64,
    /// Duration of each 45° turn between headings (s).
    pub turn_s: f64,
    /// Fly the cloverleaf at the end.
    pub cloverleaf: bool,
}

impl Default for PatentPlan {
    /// 15° rolls, 10° pitches, 6 s period, 3 cycles, 40° wing-ups, with a cloverleaf.
    fn default() -> Self {
        Self {
            roll_deg: 15.0,
            pitch_deg: 10.0,
            period_s: 6.0,
            cycles: 3,
            wingup_deg: 40.0,
            wingup_s: 20.0,
            straight_s: 8.0,
            turn_s: 15.0,
            cloverleaf: true,
        }
    }
}

impl PatentPlan {
    /// The plan, heading N, NE, E, … NW in turn; each segment gets its own line id.
    ///
    /// On east a right wing-up (negative roll), on west a left wing-up (positive roll), as in
    /// the patent. The cloverleaf is four 270° right turns banked 30°, each after a straight leg.
    pub fn build(&self) -> Plan {
        let mut b = Builder::default();
        for k in 0..8 {
            let heading = 45.0 * k as f64;
            if k > 0 {
                b.turn_to(heading, self.turn_s);
            }
            b.push(self.straight_s, Motion::Straight);
            b.push(self.maneuver_s(), self.harmonic(Axis::Roll, self.roll_deg));
            if k % 2 == 0 {
                b.push(self.straight_s, Motion::Straight);
                b.push(
                    self.maneuver_s(),
                    self.harmonic(Axis::Pitch, self.pitch_deg),
                );
            }
            let wingup = match k {
                2 => Some(-self.wingup_deg),
                6 => Some(self.wingup_deg),
                _ => None,
            };
            if let Some(roll_deg) = wingup {
                b.push(self.straight_s, Motion::Straight);
                b.push(self.wingup_s, Motion::Hold { roll_deg });
            }
        }
        b.push(self.straight_s, Motion::Straight);
        if self.cloverleaf {
            b.turn_to(0.0, self.turn_s);
            for _ in 0..4 {
                b.push(self.straight_s, Motion::Straight);
                b.push(
                    4.0 * self.turn_s,
                    Motion::Turn {
                        change_deg: 270.0,
                        bank_deg: 30.0,
                    },
                );
            }
            b.push(self.straight_s, Motion::Straight);
        }
        b.plan()
    }

    fn maneuver_s(&self) -> f64 {
        self.period_s * self.cycles as f64
    }

    fn harmonic(&self, axis: Axis, amplitude_deg: f64) -> Motion {
        Motion::Harmonic {
            axis,
            amplitude_deg,
            period_s: self.period_s,
        }
    }
}

/// Straight survey lines flown back and forth through light turbulence.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SurveyPlan {
    /// Number of lines.
    pub lines: u32,
    /// Duration of each line (s).
    pub line_s: f64,
    /// Heading of the first line (degrees); lines alternate with the reciprocal.
    pub heading_deg: f64,
    /// RMS-like amplitude of the turbulence on each axis (degrees).
    pub turbulence_deg: f64,
    /// Duration of each 180° turn (s).
    pub turn_s: f64,
    /// Seed of the turbulence.
    pub seed: u64,
}

impl Default for SurveyPlan {
    /// Four 2-minute lines north and south, 0.5° turbulence.
    fn default() -> Self {
        Self {
            lines: 4,
            line_s: 120.0,
            heading_deg: 0.0,
            turbulence_deg: 0.5,
            turn_s: 60.0,
            seed: 1,
        }
    }
}

impl SurveyPlan {
    /// The plan; survey lines get ids 1001, 1002, …, turns their own ids.
    pub fn build(&self) -> Plan {
        let mut b = Builder {
            heading: self.heading_deg,
            ..Builder::default()
        };
        let mut waves = WaveSource::new(self.seed);
        for k in 0..self.lines {
            let mut axis = || waves.turbulence(self.turbulence_deg);
            let motion = Motion::Turbulent {
                roll: axis(),
                pitch: axis(),
                yaw: axis(),
            };
            b.push_line(1001.0 + k as f64, self.line_s, motion);
            if k + 1 < self.lines {
                let next = b.heading + 180.0;
                b.turn_to(next, self.turn_s);
            }
        }
        b.plan()
    }
}

/// Appends segments, tracking heading and line ids.
#[derive(Default)]
struct Builder {
    segments: Vec<Segment>,
    heading: f64,
}

impl Builder {
    fn next_line(&self) -> f64 {
        self.segments.len() as f64 + 1.0
    }

    fn push(&mut self, duration_s: f64, motion: Motion) {
        let line = self.next_line();
        self.push_line(line, duration_s, motion);
    }

    fn push_line(&mut self, line: f64, duration_s: f64, motion: Motion) {
        let segment = Segment {
            line,
            heading_deg: self.heading,
            duration_s,
            motion,
        };
        self.heading = segment.end_heading_deg();
        self.segments.push(segment);
    }

    /// A right turn to `heading` (degrees), banked 20°.
    fn turn_to(&mut self, heading: f64, duration_s: f64) {
        let change = (heading - self.heading).rem_euclid(360.0);
        self.push(
            duration_s,
            Motion::Turn {
                change_deg: change,
                bank_deg: 20.0,
            },
        );
    }

    fn plan(self) -> Plan {
        Plan::new(self.segments)
    }
}

/// A small deterministic generator (SplitMix64): plans and geology are pure functions of a seed.
pub(crate) struct SplitMix(u64);

impl SplitMix {
    pub(crate) fn new(seed: u64) -> Self {
        Self(seed ^ 0x9E37_79B9_7F4A_7C15)
    }

    /// Uniform in [0, 1].
    pub(crate) fn uniform(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        (z ^ (z >> 31)) as f64 / u64::MAX as f64
    }
}

/// Turbulence waves from a seed.
struct WaveSource(SplitMix);

impl WaveSource {
    fn new(seed: u64) -> Self {
        Self(SplitMix::new(seed))
    }

    fn uniform(&mut self) -> f64 {
        self.0.uniform()
    }

    /// Five waves between 0.05 and 0.5 Hz whose amplitudes add to about `amplitude_deg` RMS.
    fn turbulence(&mut self, amplitude_deg: f64) -> Vec<Wave> {
        (0..5)
            .map(|_| Wave {
                amplitude_deg: amplitude_deg * (2.0 / 5.0f64).sqrt() * (0.5 + self.uniform()),
                frequency_hz: 0.05 + 0.45 * self.uniform(),
                phase_rad: 2.0 * PI * self.uniform(),
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn box_flies_every_heading_and_ends_on_the_last() {
        let plan = BoxPlan::default().build();
        let end = plan.attitude(plan.duration_s());
        assert!((end.yaw.to_degrees() - 270.0).abs() < 1e-9);
        // 4 headings × (straight + 3 × (maneuver + straight)) + 3 turns
        assert_eq!(plan.segments().len(), 4 * 7 + 3);
    }

    #[test]
    fn attitude_is_continuous_across_segments() {
        let plan = BoxPlan::default().build();
        for &start in &plan.starts()[1..] {
            let (a, b) = (plan.attitude(start - 1e-9), plan.attitude(start + 1e-9));
            assert!((a.yaw - b.yaw).abs() < 1e-6 && (a.roll - b.roll).abs() < 1e-6);
        }
    }

    #[test]
    fn survey_attitude_is_continuous_across_segments() {
        let plan = SurveyPlan::default().build();
        for &start in &plan.starts()[1..] {
            let (a, b) = (plan.attitude(start - 1e-9), plan.attitude(start + 1e-9));
            assert!((a.yaw - b.yaw).abs() < 1e-6 && (a.roll - b.roll).abs() < 1e-6);
            assert!((a.pitch - b.pitch).abs() < 1e-6);
        }
    }

    #[test]
    fn turns_bank_into_the_turn() {
        let plan = Plan::new(vec![Segment {
            line: 1.0,
            heading_deg: 0.0,
            duration_s: 10.0,
            motion: Motion::Turn {
                change_deg: 90.0,
                bank_deg: 20.0,
            },
        }]);
        let mid = plan.attitude(5.0);
        assert!((mid.roll.to_degrees() - 20.0).abs() < 1e-9);
        assert!((mid.yaw.to_degrees() - 45.0).abs() < 1e-9);
    }

    #[test]
    fn patent_plan_flies_its_maneuvers() {
        let plan = PatentPlan::default().build();
        let count = |axis: Axis| {
            plan.segments()
                .iter()
                .filter(|s| matches!(s.motion, Motion::Harmonic { axis: a, .. } if a == axis))
                .count()
        };
        assert_eq!(count(Axis::Roll), 8);
        assert_eq!(count(Axis::Pitch), 4);
        let holds: Vec<(f64, f64)> = plan
            .segments()
            .iter()
            .filter_map(|s| match s.motion {
                Motion::Hold { roll_deg } => Some((s.heading_deg, roll_deg)),
                _ => None,
            })
            .collect();
        assert_eq!(holds, [(90.0, -40.0), (270.0, 40.0)]);
        for &start in &plan.starts()[1..] {
            let (a, b) = (plan.attitude(start - 1e-9), plan.attitude(start + 1e-9));
            let dyaw = (a.yaw - b.yaw).rem_euclid(2.0 * PI);
            assert!(dyaw.min(2.0 * PI - dyaw) < 1e-6 && (a.roll - b.roll).abs() < 1e-6);
        }
    }

    #[test]
    fn survey_is_deterministic_per_seed() {
        let a = SurveyPlan::default().build();
        let b = SurveyPlan::default().build();
        let c = SurveyPlan {
            seed: 2,
            ..SurveyPlan::default()
        }
        .build();
        assert_eq!(a, b);
        assert_ne!(a, c);
        assert_eq!(a.segments()[0].line, 1001.0);
    }
}
