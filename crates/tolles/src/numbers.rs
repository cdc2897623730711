//! How numbers are written in messages (errors and warnings alike), kept apart so that both
//! can use it without needing each other.

/// A rate (Hz) for a message: as written when of ordinary size, else in scientific notation,
/// so that 1e-300 is not three hundred zeros.
pub fn hz(v: f64) -> String {
    match v == 0.0 || (1e-3..1e7).contains(&v.abs()) {
        true => format!("{v}"),
        false => format!("{v:e}"),
    }
}
