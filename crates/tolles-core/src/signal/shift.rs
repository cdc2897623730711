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
    let n = x.len();
    (0..n)
        .map(|k| {
            let t = k as f64 + by;
            if !(t >= 0.0 && t <= (n - 1) as f64) {
                return f64::NAN;
            }
            let i = (t.floor() as usize).min(n.saturating_sub(2));
            let u = t - i as f64;
            if n < 2 {
                return x[0];
            }
            if i == 0 || i + 2 >= n {
                return x[i] + u * (x[i + 1] - x[i]);
            }
            catmull_rom([x[i - 1], x[i], x[i + 1], x[i + 2]], u)
        })
        .collect()
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
}
