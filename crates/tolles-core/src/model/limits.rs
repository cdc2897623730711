//! What a reading must be to be believed: a fluxgate's magnitude and a scalar's size (nT), and
//! how a value beyond belief is shown in a message.

/// Fluxgate magnitudes outside this range (nT) mean the data is not in nT or not a fluxgate.
pub const FLUX_MAGNITUDE_RANGE_NT: (f64, f64) = (1_000.0, 100_000.0);

/// Largest believable |scalar| (nT), twenty times the strongest geomagnetic field: a larger
/// reading is a corrupt cell, and its sample is treated as missing rather than let its square
/// overflow every sum it enters.
pub const SCALAR_LIMIT_NT: f64 = 2_000_000.0;

/// A field value (nT) for a message: one decimal when it is of a believable size, else in
/// scientific notation, so a corrupt 1e155 does not print as 156 digits.
pub fn show_nt(v: f64) -> String {
    if v.abs() < 1e9 {
        format!("{v:.1}")
    } else {
        format!("{v:.3e}")
    }
}

/// True when a scalar reading (nT) is finite and within [`SCALAR_LIMIT_NT`].
pub fn scalar_usable(v: f64) -> bool {
    v.abs() <= SCALAR_LIMIT_NT
}
