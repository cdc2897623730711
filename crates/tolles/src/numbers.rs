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

/// `value` to four significant digits: a comparison of two small residuals stays readable
/// (0.0001 nT against 0.0001 nT hid which was smaller).
pub fn significant(value: f64) -> String {
    if value == 0.0 || !value.is_finite() {
        return format!("{value}");
    }
    let decimals = (3 - value.abs().log10().floor() as i32).max(0) as usize;
    format!("{value:.decimals$}")
}

#[cfg(test)]
mod tests {
    #[test]
    fn significant_keeps_four_digits_of_small_and_large_values() {
        assert_eq!(super::significant(0.000_123_46), "0.0001235");
        assert_eq!(super::significant(0.000_1), "0.0001000");
        assert_eq!(super::significant(12.345_6), "12.35");
        assert_eq!(super::significant(123_456.0), "123456");
    }
}
