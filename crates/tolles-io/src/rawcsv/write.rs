//! Rows of a CSV file held as its bytes written back: a tidy row copied, an untidy one trimmed
//! cell by cell, and new cells of numbers formatted on all cores.

use super::{RawRows, BLOCK_ROWS};
use std::io::Write;
use std::ops::Range;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};

/// Writes every row of `rows` followed by one cell per `extra` column (empty for NaN), as the
/// general CSV writer would: tidy rows copied, untidy ones trimmed cell by cell. Rows are
/// formatted on all cores and written in order as they are ready.
pub fn write_rows(rows: &RawRows, extra: &[&[f64]], out: &mut dyn Write) -> std::io::Result<()> {
    let n = rows.len();
    let blocks = n.div_ceil(BLOCK_ROWS);
    // Rayon's count, as for the pieces read: asked once, where the standard library reads the
    // control group's files at every call.
    let threads = rayon::current_num_threads();
    if blocks <= 1 || threads <= 1 {
        let mut text = Vec::new();
        return (0..blocks).try_for_each(|b| {
            format_block(rows, extra, block(b, n), &mut text);
            out.write_all(&text)
        });
    }
    // Formatting threads take blocks in order and the caller's thread writes them in order, so
    // the output is written while the rest is formatted; written buffers go back to the
    // formatters, so memory stays a few blocks and their pages are touched once.
    let next = AtomicUsize::new(0);
    let stop = AtomicBool::new(false);
    let (sender, receiver) = std::sync::mpsc::channel::<(usize, Vec<u8>)>();
    let (give_back, spare) = std::sync::mpsc::channel::<Vec<u8>>();
    let spare = std::sync::Mutex::new(spare);
    std::thread::scope(|scope| {
        for _ in 0..threads {
            let (sender, next, stop, spare) = (sender.clone(), &next, &stop, &spare);
            scope.spawn(move || loop {
                let b = next.fetch_add(1, Ordering::Relaxed);
                if b >= blocks || stop.load(Ordering::Relaxed) {
                    break;
                }
                let reused = spare.lock().ok().and_then(|s| s.try_recv().ok());
                let mut text = reused.unwrap_or_default();
                format_block(rows, extra, block(b, n), &mut text);
                if sender.send((b, text)).is_err() {
                    break;
                }
            });
        }
        drop(sender);
        let mut waiting = std::collections::BTreeMap::new();
        let mut written = 0;
        for (b, text) in receiver {
            waiting.insert(b, text);
            while let Some(text) = waiting.remove(&written) {
                if let Err(e) = out.write_all(&text) {
                    stop.store(true, Ordering::Relaxed);
                    return Err(e);
                }
                let _ = give_back.send(text);
                written += 1;
            }
        }
        Ok(())
    })
}

/// The rows of block `b` of a table of `n` rows.
fn block(b: usize, n: usize) -> Range<usize> {
    b * BLOCK_ROWS..((b + 1) * BLOCK_ROWS).min(n)
}

/// The text of rows `range` with their extra cells.
fn format_block(rows: &RawRows, extra: &[&[f64]], range: Range<usize>, text: &mut Vec<u8>) {
    let width: usize = range.clone().map(|k| rows.lens[k] as usize).sum();
    text.clear();
    text.reserve(width + range.len() * (1 + 25 * extra.len()));
    let first_untidy = rows.untidy.partition_point(|&u| (u as usize) < range.start);
    let mut untidy = rows.untidy[first_untidy..].iter().peekable();
    let mut number = zmij::Buffer::new();
    for k in range {
        if untidy.next_if(|&&u| u as usize == k).is_some() {
            let start = text.len();
            for (j, cell) in rows.line(k).split(|&b| b == b',').enumerate() {
                if j > 0 {
                    text.push(b',');
                }
                let cell = std::str::from_utf8(cell).unwrap_or_default();
                text.extend_from_slice(cell.trim().as_bytes());
            }
            // A row of one empty cell must not become a blank line, which readers skip; the
            // csv crate quotes it so too.
            if text.len() == start && extra.is_empty() {
                text.extend_from_slice(b"\"\"");
            }
        } else {
            text.extend_from_slice(rows.line(k));
        }
        for column in extra {
            text.push(b',');
            format_number(column[k], &mut number, text);
        }
        text.push(b'\n');
    }
}

/// Appends `v` as [`crate::table::format_value`] writes it — the shortest text that reads back
/// as the same f64, with an exponent below 1e-5 and from 1e17 on; `inf`/`-inf` for an infinite
/// value and nothing for a missing one — three times faster: the shortest digits come from
/// `zmij` and are laid out here.
pub fn format_number(v: f64, buffer: &mut zmij::Buffer, out: &mut Vec<u8>) {
    if !v.is_finite() {
        out.extend_from_slice(crate::table::non_finite_text(v).as_bytes());
        return;
    }
    let magnitude = v.abs();
    if magnitude >= 1e16 {
        return general_format(v, out);
    }
    let shortest = buffer.format_finite(v).as_bytes();
    if (1e-5..1e16).contains(&magnitude) && !shortest.contains(&b'e') {
        // Already laid out as `Display` lays it out, but for a trailing `.0`.
        let text = shortest.strip_suffix(b".0").unwrap_or(shortest);
        let decimals = text.iter().position(|&b| b == b'.');
        let decimals = decimals.map_or(0, |point| (text.len() - point - 1) as i32);
        if fraction_bits(v) != decimals + 1 {
            out.extend_from_slice(text);
            return;
        }
    }
    let (negative, digits, exponent) = decompose(shortest);
    let decimals = (digits.len() as i32 - exponent).max(0);
    if fraction_bits(v) == decimals + 1 {
        // Exactly halfway between two shortest candidates: `zmij` rounds the tie to even,
        // the standard library away from zero; its text is the reference.
        return general_format(v, out);
    }
    if negative {
        out.push(b'-');
    }
    if magnitude != 0.0 && !(1e-5..1e17).contains(&magnitude) {
        // d.ddde±x
        out.push(digits[0]);
        if digits.len() > 1 {
            out.push(b'.');
            out.extend_from_slice(&digits[1..]);
        }
        out.push(b'e');
        let _ = write!(out, "{}", exponent - 1);
        return;
    }
    // `exponent` is where the point goes: value = 0.digits × 10^exponent.
    let len = digits.len() as i32;
    if exponent <= 0 {
        out.extend_from_slice(b"0.");
        out.extend(std::iter::repeat_n(b'0', (-exponent) as usize));
        out.extend_from_slice(&digits);
    } else if exponent >= len {
        out.extend_from_slice(&digits);
        out.extend(std::iter::repeat_n(b'0', (exponent - len) as usize));
    } else {
        let point = exponent as usize;
        out.extend_from_slice(&digits[..point]);
        out.push(b'.');
        out.extend_from_slice(&digits[point..]);
    }
}

/// [`crate::table::format_value`]'s text of `v`, appended.
fn general_format(v: f64, out: &mut Vec<u8>) {
    let mut text = String::new();
    crate::table::format_value(v, &mut text);
    out.extend_from_slice(text.as_bytes());
}

/// How many binary digits `v` has after its point: its exact decimal expansion has as many
/// decimals.
fn fraction_bits(v: f64) -> i32 {
    let bits = v.to_bits();
    let biased = ((bits >> 52) & 0x7ff) as i32;
    let fraction = bits & ((1 << 52) - 1);
    let (significand, exponent) = match biased {
        0 => (fraction, -1074),
        _ => (fraction | 1 << 52, biased - 1075),
    };
    if significand == 0 {
        return 0;
    }
    (-exponent - significand.trailing_zeros() as i32).max(0)
}

/// The sign, significant digits (no leading or trailing zeros; `0` for zero) and point
/// position (value = 0.digits × 10^position) of a number zmij wrote (`-1.25e-7`, `1e+16`,
/// `50000.0`).
fn decompose(text: &[u8]) -> (bool, smallvec_digits::Digits, i32) {
    let (negative, text) = match text.split_first() {
        Some((b'-', rest)) => (true, rest),
        _ => (false, text),
    };
    let (mantissa, exponent) = match text.iter().position(|&b| b == b'e' || b == b'E') {
        Some(e) => (
            &text[..e],
            std::str::from_utf8(&text[e + 1..])
                .ok()
                .and_then(|s| s.parse::<i32>().ok())
                .unwrap_or(0),
        ),
        None => (text, 0),
    };
    let mut digits = smallvec_digits::Digits::default();
    let mut before_point = 0i32;
    let mut seen_point = false;
    for &b in mantissa {
        if b == b'.' {
            seen_point = true;
        } else {
            if digits.is_empty() && b == b'0' {
                // A leading zero moves the point, it is no digit.
                if seen_point {
                    before_point -= 1;
                }
                continue;
            }
            digits.push(b);
            if !seen_point {
                before_point += 1;
            }
        }
    }
    while digits.len() > 1 && digits.last() == Some(b'0') {
        digits.pop();
    }
    if digits.is_empty() {
        digits.push(b'0');
        return (negative, digits, 1);
    }
    (negative, digits, before_point + exponent)
}

/// A short digit string on the stack (an f64 has at most 17 significant digits).
mod smallvec_digits {
    #[derive(Default)]
    pub struct Digits {
        bytes: [u8; 24],
        len: usize,
    }

    impl Digits {
        pub fn push(&mut self, b: u8) {
            if self.len < self.bytes.len() {
                self.bytes[self.len] = b;
                self.len += 1;
            }
        }

        pub fn pop(&mut self) {
            self.len = self.len.saturating_sub(1);
        }

        pub fn last(&self) -> Option<u8> {
            self.len.checked_sub(1).map(|k| self.bytes[k])
        }

        pub fn is_empty(&self) -> bool {
            self.len == 0
        }

        pub fn len(&self) -> usize {
            self.len
        }
    }

    impl std::ops::Deref for Digits {
        type Target = [u8];

        fn deref(&self) -> &[u8] {
            &self.bytes[..self.len]
        }
    }
}
