//! Aircraft attitude and the rotation from the navigation frame (NED) to the body frame (FRD).
//!
//! ```
//! use tolles_core::flight::attitude::Attitude;
//! // Heading east, level: north is to the aircraft's left (−y), down stays down.
//! let east = Attitude::from_degrees(90.0, 0.0, 0.0);
//! let b = east.to_body([1.0, 0.0, 0.0]);
//! assert!((b[0]).abs() < 1e-12 && (b[1] + 1.0).abs() < 1e-12);
//! // Nose up 30°: the forward axis points above the horizon, so "down" is partly backward.
//! let up = Attitude::from_degrees(0.0, 30.0, 0.0).to_body([0.0, 0.0, 1.0]);
//! assert!((up[0] + 0.5).abs() < 1e-12);
//! ```
//!
//! Conventions ([`crate::model::conventions`]): yaw clockwise from north, pitch nose-up positive, roll
//! right-wing-down positive, applied in the order yaw, pitch, roll (ZYX).

use serde::{Deserialize, Serialize};

/// Yaw, pitch and roll (radians).
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct Attitude {
    /// Heading, clockwise from north (rad).
    pub yaw: f64,
    /// Nose-up positive (rad).
    pub pitch: f64,
    /// Right wing down positive (rad).
    pub roll: f64,
}

impl Attitude {
    /// From degrees: yaw (clockwise from north), pitch (nose up), roll (right wing down).
    pub fn from_degrees(yaw_deg: f64, pitch_deg: f64, roll_deg: f64) -> Self {
        Self {
            yaw: yaw_deg.to_radians(),
            pitch: pitch_deg.to_radians(),
            roll: roll_deg.to_radians(),
        }
    }

    /// Body components (FRD) of a vector given in NED.
    pub fn to_body(&self, ned: [f64; 3]) -> [f64; 3] {
        let (sy, cy) = self.yaw.sin_cos();
        let (sp, cp) = self.pitch.sin_cos();
        let (sr, cr) = self.roll.sin_cos();
        // Undo yaw: the heading frame (forward-level, right-level, down).
        let h = [
            cy * ned[0] + sy * ned[1],
            -sy * ned[0] + cy * ned[1],
            ned[2],
        ];
        // Undo pitch about the right axis.
        let p = [cp * h[0] - sp * h[2], h[1], sp * h[0] + cp * h[2]];
        // Undo roll about the forward axis.
        [p[0], cr * p[1] + sr * p[2], -sr * p[1] + cr * p[2]]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: [f64; 3], b: [f64; 3]) -> bool {
        a.iter().zip(&b).all(|(u, v)| (u - v).abs() < 1e-12)
    }

    #[test]
    fn right_wing_down_tilts_the_down_vector_toward_the_right_wing() {
        // Rolled 90° right, the right wing points down: NED down is body +y.
        let body = Attitude::from_degrees(0.0, 0.0, 90.0).to_body([0.0, 0.0, 1.0]);
        assert!(close(body, [0.0, 1.0, 0.0]));
    }

    #[test]
    fn heading_north_level_is_identity() {
        assert!(close(
            Attitude::default().to_body([1.0, 2.0, 3.0]),
            [1.0, 2.0, 3.0]
        ));
    }

    #[test]
    fn rotation_keeps_length() {
        let v = Attitude::from_degrees(123.0, -7.0, 33.0).to_body([3.0, -4.0, 12.0]);
        let n = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
        assert!((n - 13.0).abs() < 1e-12);
    }
}
