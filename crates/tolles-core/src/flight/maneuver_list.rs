//! A flight plan from a short list of maneuvers, `roll@0,pitch@90,wingup@270`, for asking what
//! a calibration flight would determine before flying it.
//!
//! ```
//! use tolles_core::flight::plan::{Motion, Plan};
//!
//! let plan = Plan::from_maneuver_list("roll@0, wingup@90").unwrap();
//! // Straight, roll, straight, wing-up, straight.
//! assert_eq!(plan.segments().len(), 5);
//! assert_eq!(plan.segments()[3].motion, Motion::Hold { roll_deg: -40.0 });
//! assert!(Plan::from_maneuver_list("loop@90").is_err());
//! ```

use crate::flight::plan::{Axis, Motion, Plan, Segment};

/// Straight flight before each maneuver and after the last (s).
pub const STRAIGHT_S: f64 = 15.0;
/// Duration of a roll, pitch or yaw: three 6 s cycles (s).
pub const HARMONIC_S: f64 = 18.0;
/// Period of a roll, pitch or yaw (s).
pub const PERIOD_S: f64 = 6.0;
/// Amplitudes of a roll, pitch and yaw (degrees), as in the compensation box.
pub const ROLL_DEG: f64 = 10.0;
/// Amplitude of a pitch (degrees).
pub const PITCH_DEG: f64 = 5.0;
/// Amplitude of a yaw (degrees).
pub const YAW_DEG: f64 = 5.0;
/// Duration of a wing-up, entry and exit included (s).
pub const WING_UP_S: f64 = 20.0;
/// Bank of a wing-up (degrees).
pub const WING_UP_BANK_DEG: f64 = 40.0;

/// Why a maneuver list is not a plan.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ManeuverListError {
    /// An item without `@`.
    #[error("{item:?} is not KIND@HEADING (e.g. roll@90)")]
    NotKindAtHeading {
        /// The item as written.
        item: String,
    },
    /// A heading that is not a number.
    #[error("{heading:?} is not a heading in degrees: {reason}")]
    BadHeading {
        /// The heading as written.
        heading: String,
        /// Why it does not parse as a number.
        reason: String,
    },
    /// A kind other than roll, pitch, yaw or wingup.
    #[error("unknown kind {kind:?}; use roll, pitch, yaw or wingup")]
    UnknownKind {
        /// The kind as written.
        kind: String,
    },
    /// No maneuver at all.
    #[error("the list is empty")]
    Empty,
}

impl Plan {
    /// The plan of `list`, comma-separated `KIND@HEADING` items (kinds `roll`, `pitch`, `yaw`,
    /// `wingup`; headings in degrees clockwise from north): each maneuver after
    /// [`STRAIGHT_S`] of straight flight on its heading, and a last straight leg. Rolls, pitches
    /// and yaws are the box's ([`ROLL_DEG`], [`PITCH_DEG`], [`YAW_DEG`] over [`HARMONIC_S`]);
    /// wing-ups bank [`WING_UP_BANK_DEG`] for [`WING_UP_S`]. Each segment has its own line id.
    pub fn from_maneuver_list(list: &str) -> Result<Plan, ManeuverListError> {
        let mut segments = Vec::new();
        for item in list.split(',').map(str::trim).filter(|s| !s.is_empty()) {
            let (heading_deg, duration_s, motion) = maneuver(item)?;
            let mut leg = |duration_s, motion| {
                segments.push(Segment {
                    line: segments.len() as f64 + 1.0,
                    heading_deg,
                    duration_s,
                    motion,
                })
            };
            leg(STRAIGHT_S, Motion::Straight);
            leg(duration_s, motion);
        }
        let Some(last) = segments.last() else {
            return Err(ManeuverListError::Empty);
        };
        segments.push(Segment {
            line: segments.len() as f64 + 1.0,
            heading_deg: last.heading_deg,
            duration_s: STRAIGHT_S,
            motion: Motion::Straight,
        });
        Ok(Plan::new(segments))
    }
}

/// `roll@90` → its heading (degrees), duration (s) and motion.
fn maneuver(item: &str) -> Result<(f64, f64, Motion), ManeuverListError> {
    let Some((kind, heading)) = item.split_once('@') else {
        return Err(ManeuverListError::NotKindAtHeading { item: item.into() });
    };
    let heading_deg: f64 =
        heading.parse().map_err(
            |e: std::num::ParseFloatError| ManeuverListError::BadHeading {
                heading: heading.into(),
                reason: e.to_string(),
            },
        )?;
    let (duration_s, motion) = match kind {
        "roll" => (HARMONIC_S, harmonic(Axis::Roll, ROLL_DEG)),
        "pitch" => (HARMONIC_S, harmonic(Axis::Pitch, PITCH_DEG)),
        "yaw" => (HARMONIC_S, harmonic(Axis::Yaw, YAW_DEG)),
        "wingup" => (WING_UP_S, wing_up(heading_deg)),
        other => return Err(ManeuverListError::UnknownKind { kind: other.into() }),
    };
    Ok((heading_deg, duration_s, motion))
}

fn harmonic(axis: Axis, amplitude_deg: f64) -> Motion {
    Motion::Harmonic {
        axis,
        amplitude_deg,
        period_s: PERIOD_S,
    }
}

/// A right wing-up (right wing down is a positive roll, so up is negative) on an easterly
/// heading, a left one otherwise, as in the patent.
fn wing_up(heading_deg: f64) -> Motion {
    let easterly = heading_deg.rem_euclid(360.0) < 180.0;
    Motion::Hold {
        roll_deg: if easterly {
            -WING_UP_BANK_DEG
        } else {
            WING_UP_BANK_DEG
        },
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn each_maneuver_follows_a_straight_leg_on_its_heading() {
        let plan = Plan::from_maneuver_list("roll@0,pitch@90 , wingup@270,").unwrap();
        let s = plan.segments();
        assert_eq!(s.len(), 7);
        let lines: Vec<f64> = s.iter().map(|s| s.line).collect();
        assert_eq!(lines, [1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0]);
        assert_eq!(s[0].motion, Motion::Straight);
        assert_eq!(
            s[3].motion,
            Motion::Harmonic {
                axis: Axis::Pitch,
                amplitude_deg: 5.0,
                period_s: 6.0
            }
        );
        assert_eq!(s[3].heading_deg, 90.0);
        assert_eq!(s[5].motion, Motion::Hold { roll_deg: 40.0 });
        assert_eq!((s[6].heading_deg, s[6].duration_s), (270.0, 15.0));
        assert_eq!(plan.duration_s(), 15.0 * 4.0 + 18.0 * 2.0 + 20.0);
    }

    #[test]
    fn bad_lists_say_what_is_wrong() {
        let error = |list: &str| Plan::from_maneuver_list(list).unwrap_err().to_string();
        assert_eq!(
            error("roll@0,loop@90"),
            "unknown kind \"loop\"; use roll, pitch, yaw or wingup"
        );
        assert_eq!(
            error("roll90"),
            "\"roll90\" is not KIND@HEADING (e.g. roll@90)"
        );
        assert_eq!(
            error("roll@x"),
            "\"x\" is not a heading in degrees: invalid float literal"
        );
        assert_eq!(error(" , "), "the list is empty");
    }
}
