//! Shifting a sampled signal by a fraction of a sample, to line up sensors sampled at
//! different moments.
//!
//! ```
//! use tolles_core::signal::shift::shift;
//! let x: Vec<f64> = (0..10).map(|k| (k * k) as f64).collect();
//! let y = shift(&x, 0.5);
//! // Cubic interpolation is exact for a quadratic: x(2.5) = 6.25.
//! assert!((y[2] - 6.25).abs() < 1e-12);
//! assert!(y[9].is_nan()); // past the end
//! ```

/// `y[k] = x(k + by)` by cubic (Catmull-Rom) interpolation, `by` in samples (any sign); NaN
/// where `k + by` falls outside the samples or a neighbour needed is NaN. Near the ends, where a
/// cubic lacks a neighbour, the interpolation is linear.
pub fn shift(x: &[f64], by: f64) -> Vec<f64> {
    let shift = Shift::new(by);
    (0..x.len())
        .map(|k| shift.value(|i| x[i], x.len(), k))
        .collect()
}

/// A shift by `by` samples, split into whole samples and a fraction, so that every sample is
/// interpolated with the same weights whether the series is held whole or a window at a time
/// (a stream, a file read in chunks).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Shift {
    /// Whole samples (`floor(by)`).
    whole: i64,
    /// The fraction of a sample, in `[0, 1)`.
    fraction: f64,
}

impl Shift {
    /// A shift by `by` samples (`y[k] = x(k + by)`); within 1e-9 of a whole number, by that
    /// number (0.3 s at 10 Hz is 3.0000000000000004 samples: three, not four and a fraction).
    pub fn new(by: f64) -> Self {
        let by = if (by - by.round()).abs() < 1e-9 {
            by.round()
        } else {
            by
        };
        let whole = by.floor();
        Self {
            whole: whole as i64,
            fraction: by - whole,
        }
    }

    /// How many samples past `k` sample `k` of the shifted series needs (negative: it needs
    /// none, and that many before `k` are the last it reads), unless it falls past the end.
    pub fn ahead(&self) -> i64 {
        if self.fraction == 0.0 {
            self.whole
        } else {
            self.whole + 2
        }
    }

    /// How many samples before `k` sample `k` of the shifted series may read.
    pub fn behind(&self) -> i64 {
        1 - self.whole
    }

    /// Sample `k` of the shifted series of `n` samples, `x(i)` giving sample `i` (only those
    /// within [`Shift::behind`] and [`Shift::ahead`] of `k` are asked for).
    pub fn value(&self, x: impl Fn(usize) -> f64, n: usize, k: usize) -> f64 {
        let i = k as i64 + self.whole;
        let u = self.fraction;
        let last = n as i64 - 1;
        if i < 0 || i > last || (i == last && u > 0.0) {
            return f64::NAN;
        }
        let i = i as usize;
        if u == 0.0 {
            return x(i);
        }
        if i == 0 || i + 2 >= n {
            return x(i) + u * (x(i + 1) - x(i));
        }
        catmull_rom([x(i - 1), x(i), x(i + 1), x(i + 2)], u)
    }
}

fn catmull_rom(p: [f64; 4], u: f64) -> f64 {
    let [p0, p1, p2, p3] = p;
    p1 + 0.5
        * u
        * (p2 - p0 + u * (2.0 * p0 - 5.0 * p1 + 4.0 * p2 - p3 + u * (3.0 * (p1 - p2) + p3 - p0)))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn whole_sample_shifts_move_samples() {
        let x: Vec<f64> = (0..6).map(|k| k as f64 * 1.5).collect();
        assert_eq!(shift(&x, 2.0)[..4], x[2..]);
        assert!(shift(&x, -1.0)[0].is_nan());
        assert_eq!(shift(&x, -1.0)[1..], x[..5]);
        assert_eq!(shift(&x, 0.0), x);
    }

    #[test]
    fn a_slow_sine_is_shifted_accurately() {
        let x: Vec<f64> = (0..400).map(|k| (0.05 * k as f64).sin()).collect();
        let y = shift(&x, 0.3);
        for (k, v) in y.iter().enumerate().take(397).skip(2) {
            assert!((v - (0.05 * (k as f64 + 0.3)).sin()).abs() < 1e-5, "{k}");
        }
    }

    #[test]
    fn a_shift_a_rounding_error_off_a_whole_number_is_that_number() {
        assert_eq!(Shift::new(-0.3 * 10.0), Shift::new(-3.0));
        assert_eq!(Shift::new(2.9999999999999996).ahead(), 3);
    }

    #[test]
    fn a_sample_reads_only_within_behind_and_ahead() {
        for by in [-3.7, -1.0, -0.2, 0.0, 0.4, 2.0, 2.5] {
            let shift = Shift::new(by);
            let x: Vec<f64> = (0..30).map(|k| (k * k) as f64).collect();
            for k in 0..30 {
                let reads = |i: usize| {
                    let d = i as i64 - k as i64;
                    assert!(-shift.behind() <= d && d <= shift.ahead(), "{by} {k} {i}");
                    x[i]
                };
                shift.value(reads, x.len(), k);
            }
        }
    }
}
