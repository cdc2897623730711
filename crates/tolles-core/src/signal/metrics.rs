//! Noise metrics of a magnetometer signal.
//!
//! ```
//! use tolles_core::signal::metrics::{fourth_difference, improvement_ratio};
//! // A cubic has no fourth difference.
//! let cubic: Vec<f64> = (0..8).map(|k| (k as f64).powi(3)).collect();
//! let d4 = fourth_difference(&cubic);
//! assert!(d4[2..6].iter().all(|v| v.abs() < 1e-12));
//! assert!(d4[0].is_nan() && d4[7].is_nan());
//! assert_eq!(improvement_ratio(4.0, 0.5), 8.0);
//! ```

use crate::signal::filter::{Butterworth, FilterError};

/// Noise level (nT): standard deviation of `x` after zero-phase filtering with `filter`
/// (or of `x` itself when `filter` is `None`). Non-finite samples are ignored by the standard
/// deviation; `x` must be free of them to be filtered.
pub fn noise_level(x: &[f64], filter: Option<&Butterworth>) -> Result<f64, FilterError> {
    let filtered = match filter {
        Some(f) => f.filtfilt(x)?,
        None => x.to_vec(),
    };
    Ok(std_dev(&filtered))
}

/// Improvement ratio: noise level before compensation divided by after (dimensionless).
pub fn improvement_ratio(before_nt: f64, after_nt: f64) -> f64 {
    before_nt / after_nt
}

/// Fourth difference `(x₋₂ − 4x₋₁ + 6x₀ − 4x₊₁ + x₊₂)/16` (units of `x`), the standard
/// measure of high-frequency magnetometer noise.
///
/// Output has the length of `x`; the first two and last two values are NaN.
pub fn fourth_difference(x: &[f64]) -> Vec<f64> {
    let mut d = vec![f64::NAN; x.len()];
    for k in 2..x.len().saturating_sub(2) {
        d[k] = (x[k - 2] - 4.0 * x[k - 1] + 6.0 * x[k] - 4.0 * x[k + 1] + x[k + 2]) / 16.0;
    }
    d
}

/// High-pass noise (units of `x`): the standard deviation of the [`fourth_difference`] of `x`,
/// over its finite values (NaN with fewer than 5 samples). `tolles fom` prints it.
pub fn fourth_difference_noise(x: &[f64]) -> f64 {
    std_dev(&fourth_difference(x))
}

/// [`fourth_difference_noise`] over the `runs` of `x` (contiguous stretches: lines, or the
/// parts between time gaps): no difference reaches across two runs, where it would measure the
/// jump between them, not the noise.
pub fn fourth_difference_noise_over(x: &[f64], runs: &[std::ops::Range<usize>]) -> f64 {
    let differences: Vec<f64> = runs
        .iter()
        .flat_map(|r| fourth_difference(&x[r.clone()]))
        .collect();
    std_dev(&differences)
}

/// Population standard deviation of the finite values (NaN if there are none).
pub fn std_dev(x: &[f64]) -> f64 {
    let finite = || x.iter().copied().filter(|v| v.is_finite());
    let n = finite().count();
    if n == 0 {
        return f64::NAN;
    }
    let mean = finite().sum::<f64>() / n as f64;
    (finite().map(|v| (v - mean).powi(2)).sum::<f64>() / n as f64).sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fourth_difference_noise_does_not_reach_across_runs() {
        let quiet = |k: usize| 0.01 * ((k * 7919) % 13) as f64;
        let mut x: Vec<f64> = (0..200).map(quiet).collect();
        x[100..].iter_mut().for_each(|v| *v += 50.0);
        let runs = [0..100, 100..200];
        let (first, second) = (&x[..100], &x[100..]);
        let over = fourth_difference_noise_over(&x, &runs);
        let each = fourth_difference_noise(first).max(fourth_difference_noise(second));
        assert!(over <= each * 1.01, "{over} vs {each}");
        assert!(
            fourth_difference_noise(&x) > 10.0 * over,
            "the jump counts when not split"
        );
    }

    #[test]
    fn fourth_difference_of_white_noise_has_known_scale() {
        // Var of the weights (1,−4,6,−4,1)/16 is 70/256 for unit white noise.
        let mut state = 12345u64;
        let x: Vec<f64> = (0..200_000)
            .map(|_| {
                state = state
                    .wrapping_mul(6364136223846793005)
                    .wrapping_add(1442695040888963407);
                ((state >> 11) as f64 / (1u64 << 53) as f64 - 0.5) * 12f64.sqrt()
            })
            .collect();
        let s = std_dev(&fourth_difference(&x));
        assert!((s - (70.0f64 / 256.0).sqrt()).abs() < 0.01, "{s}");
    }

    #[test]
    fn std_dev_ignores_nan() {
        assert_eq!(std_dev(&[1.0, f64::NAN, 3.0]), 1.0);
        assert!(std_dev(&[f64::NAN]).is_nan());
    }

    #[test]
    fn noise_level_without_filter_is_std() {
        assert_eq!(noise_level(&[1.0, 3.0], None).unwrap(), 1.0);
    }
}
