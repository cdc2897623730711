//! Plain decimals (`[+-]digits[.digits]`) read straight from a file's bytes, to the same f64
//! as `str::parse` gives.
//!
//! The digits without their point form an integer of at most 2⁵³ and the decimals a power of
//! ten of at most 10²²; both are exact f64s, so their quotient is correctly rounded. The digits
//! before and after the point are read by two tight loops, with no test per digit of which side
//! of the point it is on. (A 128-bit word version, the point found and the digits combined
//! eight at a time with multiplications, measured 1.8× slower here: its variable shifts of a
//! 128-bit word cost more than the ten digits of a survey's number.)

/// Exact powers of ten as f64 (10²² is the largest that is exact).
const POW10: [f64; 23] = [
    1e0, 1e1, 1e2, 1e3, 1e4, 1e5, 1e6, 1e7, 1e8, 1e9, 1e10, 1e11, 1e12, 1e13, 1e14, 1e15, 1e16,
    1e17, 1e18, 1e19, 1e20, 1e21, 1e22,
];

/// Most digits a u64 takes, whatever they are.
const MAX_DIGITS: usize = 19;

/// A cell written as a plain decimal (at most 19 digits, at most 2⁵³ without its point, at
/// most 22 decimals), else `None`.
pub(crate) fn plain_decimal(cell: &[u8]) -> Option<f64> {
    let (negative, text) = match cell.first()? {
        b'-' => (true, &cell[1..]),
        b'+' => (false, &cell[1..]),
        _ => (false, cell),
    };
    let (mantissa, whole) = leading_digits(text, 0, MAX_DIGITS);
    let (mantissa, decimals) = match text.get(whole) {
        None => (mantissa, 0),
        Some(b'.') => {
            let fraction = &text[whole + 1..];
            let (mantissa, decimals) = leading_digits(fraction, mantissa, MAX_DIGITS - whole);
            if decimals != fraction.len() {
                return None;
            }
            (mantissa, decimals)
        }
        Some(_) => return None,
    };
    if whole + decimals == 0 || mantissa > 1 << 53 || decimals >= POW10.len() {
        return None;
    }
    let value = mantissa as f64 / POW10[decimals];
    Some(if negative { -value } else { value })
}

/// `mantissa` followed by the digits that start `text` (at most `room` of them), and how many
/// digits those were.
fn leading_digits(text: &[u8], mut mantissa: u64, room: usize) -> (u64, usize) {
    let mut count = 0;
    for &b in text.iter().take(room) {
        let d = b.wrapping_sub(b'0');
        if d >= 10 {
            break;
        }
        mantissa = mantissa * 10 + u64::from(d);
        count += 1;
    }
    (mantissa, count)
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// The reference: every byte in turn.
    fn byte_by_byte(cell: &[u8]) -> Option<f64> {
        let (negative, digits) = match cell.first()? {
            b'-' => (true, &cell[1..]),
            b'+' => (false, &cell[1..]),
            _ => (false, cell),
        };
        let (mut mantissa, mut count, mut decimals, mut point) = (0u64, 0u32, 0usize, false);
        for &b in digits {
            let d = b.wrapping_sub(b'0');
            if d < 10 {
                if count == 19 {
                    return None;
                }
                mantissa = mantissa * 10 + u64::from(d);
                count += 1;
                decimals += usize::from(point);
            } else if b == b'.' && !point {
                point = true;
            } else {
                return None;
            }
        }
        if count == 0 || mantissa > 1 << 53 || decimals >= POW10.len() {
            return None;
        }
        let value = mantissa as f64 / POW10[decimals];
        Some(if negative { -value } else { value })
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(3000))]
        #[test]
        fn plain_decimals_parse_as_str_parse_does(
            int in 0u64..100_000_000_000, frac in 0u64..100_000_000, width in 0usize..9,
            negative in any::<bool>(),
        ) {
            let frac = frac % 10u64.pow(width as u32);
            let text = if width == 0 {
                format!("{}{int}", if negative { "-" } else { "" })
            } else {
                format!("{}{int}.{frac:0width$}", if negative { "-" } else { "" })
            };
            let want: f64 = text.parse().unwrap();
            let got = plain_decimal(text.as_bytes());
            // Digits beyond 2⁵³ go the general way; every other cell takes the fast one.
            let fast = text.len() - usize::from(negative) - usize::from(width > 0) <= 15;
            prop_assert!(got.is_some() || !fast, "{text}");
            prop_assert!(got.is_none_or(|v| v.to_bits() == want.to_bits()), "{text}");
        }

        #[test]
        fn cells_read_as_byte_by_byte_reads_them(
            cell in "[-+]?[0-9.]{0,22}|[-+ 0-9.eE,\u{0}\u{ff}]{0,24}",
        ) {
            let got = plain_decimal(cell.as_bytes());
            let want = byte_by_byte(cell.as_bytes());
            prop_assert_eq!(got.map(f64::to_bits), want.map(f64::to_bits), "{:?}", cell);
            if let Some(v) = got {
                prop_assert_eq!(v.to_bits(), cell.parse::<f64>().unwrap().to_bits());
            }
        }
    }

    #[test]
    fn only_plain_decimals_take_the_fast_path() {
        for cell in [
            "", "-", ".", "1e5", " 1", "1 ", "1.2.3", "nan", "inf", "0x10", "--1", "+", "-.", "..",
            "1..", "1/2", "1:2",
        ] {
            assert_eq!(plain_decimal(cell.as_bytes()), None, "{cell:?}");
        }
        assert_eq!(plain_decimal(b"1."), Some(1.0));
        assert_eq!(plain_decimal(b".5"), Some(0.5));
        assert_eq!(plain_decimal(b"+2.50"), Some(2.5));
        assert_eq!(plain_decimal(b"0000000000000007"), Some(7.0));
        assert_eq!(plain_decimal(b"123456789.1234567"), Some(123456789.1234567));
        assert_eq!(
            plain_decimal(b"-0").map(f64::to_bits),
            Some((-0.0f64).to_bits())
        );
        assert_eq!(plain_decimal(b"12345678901234567890"), None);
        assert_eq!(plain_decimal(b"9007199254740993"), None);
        assert_eq!(plain_decimal(b"9007199254740992"), Some(9007199254740992.0));
    }
}
