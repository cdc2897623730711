//! Maneuvers: finding them in the attitude, scoring a compensation box by them, and judging how
//! well they determine each term.

pub mod detect;
pub mod fom;
pub mod identifiability;
