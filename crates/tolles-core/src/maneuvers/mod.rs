//! Maneuvers: finding them in the attitude, scoring a compensation box by them, and judging how
//! well they determine each term.
//!
//! # Which maneuver type means what
//!
//! Several types name maneuvers; each means something different, except where noted:
//! - [`ManeuverKind`] (here): the axis a harmonic maneuver oscillates about, roll, pitch or yaw.
//!   It is what [`detect`] finds, what a [`fom::Slot`] is made of, and what a flight plan flies:
//!   [`flight::plan::Axis`](crate::flight::plan::Axis) is the same type under the plan's name.
//!   JSON: `"roll"`, `"pitch"`, `"yaw"`.
//! - [`heading`] is not a maneuver type: it measures the scalar's level on the straight legs
//!   between maneuvers, the surveyors' heading error.
//! - [`detect::Maneuver`]: one maneuver found in a flight (kind, heading, samples, amplitude,
//!   period).
//! - [`patent::Maneuver`](crate::patent::Maneuver): the two maneuvers the patent's tables cover,
//!   roll and pitch (no yaw: the patent's tables have none). Converts into [`ManeuverKind`].
//! - [`patent::procedure::ManeuverKind`](crate::patent::procedure::ManeuverKind): what the
//!   aircraft does in a window of the patent's procedure; the three axes plus a held wing-up and
//!   the cloverleaf check. A [`ManeuverKind`] converts into it. JSON: `"roll"`, `"pitch"`,
//!   `"yaw"`, `"wing-up"`, `"cloverleaf"`.
//! - [`flight::plan::Motion`](crate::flight::plan::Motion): what a planned segment flies
//!   (straight, turn, harmonic, hold, turbulence).
//! - [`model::terms::Axis`](crate::model::terms::Axis) is not a maneuver: it is a body axis
//!   x, y, z of the design matrix's columns.

pub mod detect;
pub mod fom;
pub mod heading;
pub mod identifiability;
pub mod live;

use serde::{Deserialize, Serialize};
use std::fmt;

/// The axis about which a harmonic maneuver oscillates; a flight plan calls it
/// [`Axis`](crate::flight::plan::Axis).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum ManeuverKind {
    /// About the longitudinal (x, forward) axis: right wing down positive.
    Roll,
    /// About the lateral (y, right) axis: nose up positive.
    Pitch,
    /// About the vertical (z, down) axis: nose right (clockwise) positive.
    Yaw,
}

impl ManeuverKind {
    /// All kinds, in the order a compensation box flies them.
    pub const ALL: [ManeuverKind; 3] = [ManeuverKind::Roll, ManeuverKind::Pitch, ManeuverKind::Yaw];

    /// Lower-case name: `roll`, `pitch`, `yaw`.
    pub fn name(self) -> &'static str {
        match self {
            ManeuverKind::Roll => "roll",
            ManeuverKind::Pitch => "pitch",
            ManeuverKind::Yaw => "yaw",
        }
    }
}

impl fmt::Display for ManeuverKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}
