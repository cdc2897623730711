//! Numbers as a report shows them: tick labels (plain decimals, or powers of ten with
//! superscripts), values with their significant digits, and counts grouped by thousands.

/// A tick label: plain decimals for everyday magnitudes, powers of ten otherwise.
pub fn format_tick(v: f64) -> String {
    if v == 0.0 {
        return "0".to_string();
    }
    let a = v.abs();
    if (1e-3..1e6).contains(&a) {
        let s = format!("{v:.6}");
        let s = s.trim_end_matches('0').trim_end_matches('.');
        return s.to_string();
    }
    let exponent = a.log10().floor() as i32;
    let mantissa = v / 10f64.powi(exponent);
    if (mantissa.abs() - 1.0).abs() < 1e-9 {
        format!(
            "{}10{}",
            if v < 0.0 { "−" } else { "" },
            superscript(exponent)
        )
    } else {
        format!("{}×10{}", format_value(mantissa), superscript(exponent))
    }
}

/// A tick label on a logarithmic axis: decades as powers of ten (`10⁻³`), others as
/// [`format_tick`].
pub fn format_log_tick(v: f64) -> String {
    let exponent = v.abs().log10().round();
    if v > 0.0 && (v / 10f64.powf(exponent) - 1.0).abs() < 1e-9 {
        format!("10{}", superscript(exponent as i32))
    } else {
        format_tick(v)
    }
}

/// A value with three significant digits, without trailing zeros (`0.0123`, `45.6`, `1.23e5`).
pub fn format_value(v: f64) -> String {
    if !v.is_finite() {
        return v.to_string();
    }
    if v == 0.0 {
        return "0".to_string();
    }
    let a = v.abs();
    if !(1e-4..1e6).contains(&a) {
        return format!("{v:.2e}");
    }
    let decimals = (2 - a.log10().floor() as i32).max(0) as usize;
    let s = format!("{v:.decimals$}");
    if s.contains('.') {
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        s
    }
}

fn superscript(n: i32) -> String {
    n.to_string()
        .chars()
        .map(|c| match c {
            '-' => '⁻',
            '0' => '⁰',
            '1' => '¹',
            '2' => '²',
            '3' => '³',
            '4' => '⁴',
            '5' => '⁵',
            '6' => '⁶',
            '7' => '⁷',
            '8' => '⁸',
            _ => '⁹',
        })
        .collect()
}

/// `1234567` → `1 234 567` (thin spaces), for counts in prose.
pub fn group_thousands(n: usize) -> String {
    let digits = n.to_string();
    let mut out = String::new();
    for (k, c) in digits.chars().enumerate() {
        if k > 0 && (digits.len() - k).is_multiple_of(3) {
            out.push('\u{2009}');
        }
        out.push(c);
    }
    out
}

/// 1, 2 or 5 times a power of ten: the nearest at or above `rough` (> 0), a round step
/// between an axis's ticks or a map's grid lines (units of `rough`).
pub fn nice_step(rough: f64) -> f64 {
    let power = 10f64.powf(rough.log10().floor());
    [1.0, 2.0, 5.0, 10.0]
        .into_iter()
        .map(|m| m * power)
        .find(|step| *step >= rough)
        .unwrap_or(10.0 * power)
}

/// `value ± error` to the error's two significant digits (53544.7 ± 6.3, not 53544.701 ±
/// 6.312): digits beyond what the error allows are noise. Three decimals when the error is not
/// a positive finite number.
pub fn with_error(value: f64, error: f64) -> String {
    let (value, error) = to_error(value, error);
    format!("{value} ± {error}")
}

/// `value` and `error` as [`with_error`] writes them, apart (for a table's two columns); a
/// value smaller than the error's last digit keeps two significant digits of its own, so a
/// small coefficient never reads as 0.
pub fn to_error(value: f64, error: f64) -> (String, String) {
    let decimals = match error.is_finite() && error > 0.0 {
        true => (1 - error.log10().floor() as i32).clamp(0, 9) as usize,
        false => 3,
    };
    let shown = format!("{value:.decimals$}");
    let vanishes = value != 0.0
        && shown
            .trim_start_matches('-')
            .trim_matches(['0', '.'])
            .is_empty();
    let shown = match vanishes {
        true => format!("{value:.1e}"),
        false => shown,
    };
    (shown, format!("{error:.decimals$}"))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_value_keeps_the_digits_its_error_allows() {
        assert_eq!(with_error(53544.701, 6.312), "53544.7 ± 6.3");
        assert_eq!(with_error(0.123456, 0.0123), "0.123 ± 0.012");
        assert_eq!(with_error(12.5, 0.0), "12.500 ± 0.000");
        assert_eq!(with_error(12.5, f64::NAN), "12.500 ± NaN");
        // Apart, for a coefficient table; a value below the error's last digit keeps its own.
        assert_eq!(to_error(-512.143684, 68.58), ("-512".into(), "69".into()));
        assert_eq!(to_error(12.856756, 32.3301), ("13".into(), "32".into()));
        assert_eq!(to_error(0.0004, 3.2), ("4.0e-4".into(), "3.2".into()));
    }
}
