//! Power spectral density by Welch's method.
//!
//! ```
//! use tolles_core::signal::spectrum::welch;
//! // A 1 nT sine at 0.5 Hz, sampled at 10 Hz for 400 s.
//! let fs = 10.0;
//! let x: Vec<f64> = (0..4000)
//!     .map(|k| (2.0 * std::f64::consts::PI * 0.5 * k as f64 / fs).sin())
//!     .collect();
//! let psd = welch(&x, fs).unwrap();
//! let peak = psd.peak_frequency_hz().unwrap();
//! assert!((peak - 0.5).abs() <= psd.resolution_hz());
//! // Parseval: the sine's power A²/2 = 0.5 nT² is the area under the density.
//! assert!((psd.band_power(0.4, 0.6) - 0.5).abs() < 1e-3);
//! ```
//!
//! The estimate is the same as `scipy.signal.welch(x, fs, window="hann", nperseg=L,
//! noverlap=L/2, detrend="constant", scaling="density")`: periodic Hann window, 50 % overlap,
//! the mean removed from every segment, one-sided density (every bin but DC and Nyquist
//! doubled), averaged over segments. Samples past the last whole segment are not used.
//!
//! Non-finite samples are never fed to the FFT: the data is cut into contiguous runs of finite
//! samples, the segment length is chosen from the longest run, and every run at least one
//! segment long contributes its segments to the average. How many samples that leaves unused
//! (non-finite ones, runs shorter than a segment, tails) is reported in
//! [`Spectrum::samples_unused`].

use std::ops::Range;

use realfft::RealFftPlanner;

use crate::signal::segment::contiguous_runs;

/// Shortest segment (samples) Welch's method is run with.
pub const MIN_SEGMENT_LEN: usize = 16;
/// Longest segment (samples) chosen automatically.
pub const MAX_AUTO_SEGMENT_LEN: usize = 1 << 16;

/// Why a spectrum cannot be estimated.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SpectrumError {
    /// The sample rate must be finite and positive (Hz).
    #[error("sample rate must be finite and positive, got {0} Hz")]
    InvalidSampleRate(f64),
    /// An explicit segment length must be at least 2 samples.
    #[error("segment length must be at least 2 samples, got {0}")]
    InvalidSegmentLen(usize),
    /// No contiguous run of finite samples is long enough for one segment.
    #[error("longest run of finite samples is {longest_run}, need at least {needed}")]
    TooShort {
        /// Length (samples) of the longest run of finite samples.
        longest_run: usize,
        /// Samples one segment needs.
        needed: usize,
    },
}

/// A one-sided power spectral density.
#[derive(Debug, Clone, PartialEq)]
pub struct Spectrum {
    /// Frequency of every bin (Hz), from 0 to fs/2 in steps of fs / `segment_len`.
    pub frequency_hz: Vec<f64>,
    /// Power spectral density per bin (units of the input squared per Hz; nT²/Hz for nT).
    pub density: Vec<f64>,
    /// Samples per segment (the FFT length).
    pub segment_len: usize,
    /// Segments averaged.
    pub segments: usize,
    /// Input samples that fall inside at least one segment.
    pub samples_used: usize,
    /// Input samples in no segment: non-finite ones, runs shorter than a segment, and the tail
    /// of each run past its last whole segment.
    pub samples_unused: usize,
}

impl Spectrum {
    /// Spacing of the frequency bins (Hz).
    pub fn resolution_hz(&self) -> f64 {
        self.frequency_hz.get(1).copied().unwrap_or(f64::NAN)
    }

    /// Power (units²; nT² for nT input) in the bins whose frequency lies in `[lo_hz, hi_hz]`:
    /// the density summed over them times the bin spacing.
    pub fn band_power(&self, lo_hz: f64, hi_hz: f64) -> f64 {
        let in_band = self
            .frequency_hz
            .iter()
            .zip(&self.density)
            .filter(|(f, _)| (lo_hz..=hi_hz).contains(*f))
            .map(|(_, p)| p)
            .sum::<f64>();
        in_band * self.resolution_hz()
    }

    /// Frequency (Hz) of the largest density above DC, if there is a bin above DC.
    pub fn peak_frequency_hz(&self) -> Option<f64> {
        self.density
            .iter()
            .enumerate()
            .skip(1)
            .max_by(|a, b| a.1.total_cmp(b.1))
            .map(|(k, _)| self.frequency_hz[k])
    }
}

/// Welch estimate of the power spectral density of `x` sampled at `fs_hz` (Hz), with the
/// segment length chosen by [`auto_segment_len`] from the longest run of finite samples.
pub fn welch(x: &[f64], fs_hz: f64) -> Result<Spectrum, SpectrumError> {
    let longest = finite_runs(x).iter().map(|r| r.len()).max().unwrap_or(0);
    if longest < MIN_SEGMENT_LEN {
        return Err(SpectrumError::TooShort {
            longest_run: longest,
            needed: MIN_SEGMENT_LEN,
        });
    }
    welch_with_segment_len(x, fs_hz, auto_segment_len(longest))
}

/// Segment length for a run of `n` samples: the largest power of two not above n / 8 (so
/// about 15 half-overlapping segments are averaged), kept within [`MIN_SEGMENT_LEN`] ..=
/// [`MAX_AUTO_SEGMENT_LEN`] and never above `n` rounded down to a power of two.
pub fn auto_segment_len(n: usize) -> usize {
    let power_of_two_at_most = |m: usize| if m == 0 { 1 } else { 1 << m.ilog2() };
    power_of_two_at_most(n / 8)
        .clamp(MIN_SEGMENT_LEN, MAX_AUTO_SEGMENT_LEN)
        .min(power_of_two_at_most(n))
}

/// Welch estimate of the power spectral density of `x` sampled at `fs_hz` (Hz) with segments
/// of `segment_len` samples overlapping by `segment_len / 2` (any length ≥ 2; powers of two
/// are fastest).
pub fn welch_with_segment_len(
    x: &[f64],
    fs_hz: f64,
    segment_len: usize,
) -> Result<Spectrum, SpectrumError> {
    if !(fs_hz.is_finite() && fs_hz > 0.0) {
        return Err(SpectrumError::InvalidSampleRate(fs_hz));
    }
    if segment_len < 2 {
        return Err(SpectrumError::InvalidSegmentLen(segment_len));
    }
    let runs = finite_runs(x);
    let longest = runs.iter().map(|r| r.len()).max().unwrap_or(0);
    if longest < segment_len {
        return Err(SpectrumError::TooShort {
            longest_run: longest,
            needed: segment_len,
        });
    }

    let mut estimator = Welch::new(segment_len, fs_hz);
    let step = segment_len - segment_len / 2;
    let mut samples_used = 0;
    for run in runs.iter().filter(|r| r.len() >= segment_len) {
        let count = (run.len() - segment_len) / step + 1;
        for s in 0..count {
            let start = run.start + s * step;
            estimator.add_segment(&x[start..start + segment_len]);
        }
        samples_used += (count - 1) * step + segment_len;
    }
    Ok(estimator.finish(samples_used, x.len() - samples_used))
}

fn finite_runs(x: &[f64]) -> Vec<Range<usize>> {
    let finite: Vec<bool> = x.iter().map(|v| v.is_finite()).collect();
    contiguous_runs(&finite, None)
}

/// Accumulates windowed periodograms of equal-length segments.
struct Welch {
    fs_hz: f64,
    window: Vec<f64>,
    fft: std::sync::Arc<dyn realfft::RealToComplex<f64>>,
    buffer: Vec<f64>,
    spectrum: Vec<realfft::num_complex::Complex<f64>>,
    sum: Vec<f64>,
    segments: usize,
}

impl Welch {
    fn new(segment_len: usize, fs_hz: f64) -> Self {
        let fft = RealFftPlanner::<f64>::new().plan_fft_forward(segment_len);
        let spectrum = fft.make_output_vec();
        Welch {
            fs_hz,
            window: periodic_hann(segment_len),
            buffer: fft.make_input_vec(),
            sum: vec![0.0; spectrum.len()],
            spectrum,
            fft,
            segments: 0,
        }
    }

    fn add_segment(&mut self, segment: &[f64]) {
        let mean = segment.iter().sum::<f64>() / segment.len() as f64;
        for ((b, &v), &w) in self.buffer.iter_mut().zip(segment).zip(&self.window) {
            *b = (v - mean) * w;
        }
        self.fft
            .process(&mut self.buffer, &mut self.spectrum)
            .expect("buffer lengths come from the plan");
        for (s, c) in self.sum.iter_mut().zip(&self.spectrum) {
            *s += c.norm_sqr();
        }
        self.segments += 1;
    }

    fn finish(self, samples_used: usize, samples_unused: usize) -> Spectrum {
        let n = self.window.len();
        let window_power = self.window.iter().map(|w| w * w).sum::<f64>();
        let scale = 1.0 / (self.fs_hz * window_power * self.segments as f64);
        let has_nyquist_bin = n.is_multiple_of(2);
        let last = self.sum.len() - 1;
        let density = self
            .sum
            .iter()
            .enumerate()
            .map(|(k, s)| {
                // One-sided: fold the negative frequencies onto the positive ones; DC and
                // Nyquist have no mirror image.
                let unpaired = k == 0 || (has_nyquist_bin && k == last);
                s * scale * if unpaired { 1.0 } else { 2.0 }
            })
            .collect();
        Spectrum {
            frequency_hz: (0..self.sum.len())
                .map(|k| k as f64 * self.fs_hz / n as f64)
                .collect(),
            density,
            segment_len: n,
            segments: self.segments,
            samples_used,
            samples_unused,
        }
    }
}

/// Periodic Hann window of length `n` (as `scipy.signal.get_window("hann", n)`): the
/// symmetric window of length n + 1 without its last point, so segments tile smoothly.
fn periodic_hann(n: usize) -> Vec<f64> {
    (0..n)
        .map(|k| 0.5 - 0.5 * (2.0 * std::f64::consts::PI * k as f64 / n as f64).cos())
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;
    use rand_distr::{Distribution, Normal};
    use std::f64::consts::PI;

    fn sine(amplitude: f64, f0_hz: f64, fs_hz: f64, n: usize) -> Vec<f64> {
        (0..n)
            .map(|k| amplitude * (2.0 * PI * f0_hz * k as f64 / fs_hz + 0.3).sin())
            .collect()
    }

    fn white_noise(sigma: f64, n: usize, seed: u64) -> Vec<f64> {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let normal = Normal::new(0.0, sigma).unwrap();
        (0..n).map(|_| normal.sample(&mut rng)).collect()
    }

    #[test]
    fn sine_power_is_amplitude_squared_over_two_at_its_frequency() {
        let (a, f0, fs) = (3.0, 1.7, 20.0);
        let psd = welch(&sine(a, f0, fs, 20_000), fs).unwrap();
        assert!((psd.peak_frequency_hz().unwrap() - f0).abs() <= psd.resolution_hz());
        // Off-bin frequency: the Hann window spreads the line over a few bins.
        let df = psd.resolution_hz();
        let power = psd.band_power(f0 - 4.0 * df, f0 + 4.0 * df);
        assert!((power - a * a / 2.0).abs() < 1e-3 * a * a, "power {power}");
    }

    #[test]
    fn white_noise_density_is_flat_at_two_sigma_squared_over_fs() {
        let (sigma, fs) = (0.5, 10.0);
        let psd = welch(&white_noise(sigma, 200_000, 7), fs).unwrap();
        let expected = 2.0 * sigma * sigma / fs;
        let inner = &psd.density[1..psd.density.len() - 1];
        let mean = inner.iter().sum::<f64>() / inner.len() as f64;
        assert!(
            (mean / expected - 1.0).abs() < 0.02,
            "mean {mean} vs {expected}"
        );
        // Flat: the lower and upper halves of the band agree.
        let (lo, hi) = inner.split_at(inner.len() / 2);
        let avg = |v: &[f64]| v.iter().sum::<f64>() / v.len() as f64;
        assert!((avg(lo) / avg(hi) - 1.0).abs() < 0.05);
    }

    #[test]
    fn non_finite_samples_split_the_data_into_runs() {
        let fs = 10.0;
        let mut x = sine(1.0, 2.0, fs, 3000);
        x[1000] = f64::NAN;
        x[2000] = f64::INFINITY;
        let psd = welch_with_segment_len(&x, fs, 256).unwrap();
        // Runs 0..1000, 1001..2000, 2001..3000: 6, 6 and 6 segments of 256 with step 128.
        assert_eq!(psd.segments, 18);
        assert_eq!(psd.samples_used + psd.samples_unused, x.len());
        assert_eq!(psd.samples_used, 3 * (5 * 128 + 256));
        assert!(psd.density.iter().all(|p| p.is_finite()));
        assert!((psd.band_power(1.5, 2.5) - 0.5).abs() < 1e-2);
    }

    #[test]
    fn short_runs_are_reported_unused() {
        let mut x = white_noise(1.0, 600, 1);
        x[100] = f64::NAN;
        let psd = welch_with_segment_len(&x, 1.0, 128).unwrap();
        // The first run (100 samples) is shorter than a segment.
        assert_eq!(psd.segments, (499 - 128) / 64 + 1);
        assert_eq!(psd.samples_unused, 600 - psd.samples_used);
        assert!(psd.samples_unused >= 101);
    }

    #[test]
    fn automatic_segment_length_is_a_power_of_two_giving_many_segments() {
        assert_eq!(auto_segment_len(16), 16);
        assert_eq!(auto_segment_len(100), 16);
        assert_eq!(auto_segment_len(1000), 64);
        assert_eq!(auto_segment_len(100_000), 8192);
        assert_eq!(auto_segment_len(10_000_000), MAX_AUTO_SEGMENT_LEN);
        for n in [16, 17, 31, 1000, 12345, 1 << 20] {
            let len = auto_segment_len(n);
            assert!(len.is_power_of_two() && len <= n, "n {n} len {len}");
        }
    }

    #[test]
    fn bad_input_is_an_error() {
        let x = vec![1.0; 100];
        assert_eq!(
            welch(&x, 0.0).unwrap_err(),
            SpectrumError::InvalidSampleRate(0.0)
        );
        assert_eq!(
            welch_with_segment_len(&x, 1.0, 1).unwrap_err(),
            SpectrumError::InvalidSegmentLen(1)
        );
        assert_eq!(
            welch_with_segment_len(&x, 1.0, 128).unwrap_err(),
            SpectrumError::TooShort {
                longest_run: 100,
                needed: 128
            }
        );
        assert_eq!(
            welch(&[f64::NAN; 40], 1.0).unwrap_err(),
            SpectrumError::TooShort {
                longest_run: 0,
                needed: MIN_SEGMENT_LEN
            }
        );
    }

    #[test]
    fn window_is_periodic_hann() {
        let w = periodic_hann(4);
        let expected = [0.0, 0.5, 1.0, 0.5];
        for (a, b) in w.iter().zip(expected) {
            assert!((a - b).abs() < 1e-15);
        }
    }
}
