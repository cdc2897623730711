//! Butterworth filters in second-order sections, applied causally or forward-backward.
//!
//! ```
//! use tolles_core::signal::filter::{magnav_bandpass, Butterworth, Response};
//!
//! // MagNav's default: 4th-order band-pass 0.1–0.9 Hz on 10 Hz data.
//! let fs_hz = 10.0;
//! let bpf = magnav_bandpass(0.1, 0.9, 4, fs_hz).unwrap().expect("both edges valid");
//! assert_eq!(bpf.sections().len(), 4); // band-pass doubles the order: 8 poles
//!
//! // A constant offset is removed, a 0.4 Hz sine passes.
//! let x: Vec<f64> = (0..500)
//!     .map(|i| 50_000.0 + (2.0 * std::f64::consts::PI * 0.4 * i as f64 / fs_hz).sin())
//!     .collect();
//! let y = bpf.filtfilt(&x).unwrap();
//! assert!(y[250].abs() < 1.1);
//!
//! // A low-pass keeps DC exactly (up to rounding).
//! let lpf = Butterworth::design(3, Response::LowPass { cutoff_hz: 1.0 }, fs_hz).unwrap();
//! let flat = lpf.filtfilt(&[7.0; 100]).unwrap();
//! assert!(flat.iter().all(|v| (v - 7.0).abs() < 1e-9));
//! ```
//!
//! Conventions, chosen so results can be checked against the Python/Julia tools:
//! - [`Butterworth::design`] gives the transfer function of
//!   `scipy.signal.butter(order, Wn, btype, fs=fs_hz, output='sos')` (a band-pass of
//!   order `N` has `2N` poles, as in scipy and DSP.jl). The pairing of poles and zeros
//!   into sections may differ from scipy's, but odd low/high-pass orders keep scipy's
//!   layout of exactly one section with `b2 == 0` and `a2 == 0`, so
//!   [`Butterworth::padlen`] equals scipy's default.
//! - [`Butterworth::filtfilt`] follows `scipy.signal.sosfiltfilt(sos, x)` with its
//!   defaults: odd extension by `padlen` samples at both ends and steady-state initial
//!   conditions ([`Butterworth::sosfilt_zi`]) scaled by the edge sample.
//! - [`magnav_bandpass`] and [`filtfilt_unless_constant`] reproduce MagNav.jl's
//!   `get_bpf` fallbacks and `bpf_data`'s handling of constant signals.
//!
//! All frequencies are in Hz, lengths in samples.

use design::{bandpass, bilinear, highpass, lowpass, prewarp};

use serde::{Deserialize, Serialize};
use thiserror::Error;

mod design;
mod jump;
mod lanes;
mod together;
mod transpose;

pub(crate) use lanes::{Fed, Jumps};
pub use together::filtfilt_sampled_then_in_place;

/// Which ends of the signals a forward-backward filter is given are the signals' own.
///
/// A long signal can be filtered window by window: a window whose end is not the signal's
/// (an [`End::Open`] one) starts that end's pass from the steady state of its sample there
/// instead of an odd extension, and its values are right only beyond
/// [`Butterworth::settling_samples`] from that end, where the start's error has died away.
/// Windows overlapping by that much on each side give the whole signal's values to rounding.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Ends {
    /// The start of the samples given.
    pub start: End,
    /// The end of the samples given.
    pub end: End,
}

/// One end of the samples given to a filter: see [`Ends`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum End {
    /// The signal's own end, padded with its odd extension as [`Butterworth::filtfilt`] does.
    Padded,
    /// The signal goes on beyond it.
    Open,
}

impl Ends {
    /// A whole signal.
    pub const WHOLE: Ends = Ends {
        start: End::Padded,
        end: End::Padded,
    };

    /// A window of samples `window` of a signal of `n` samples.
    pub fn of_window(window: &std::ops::Range<usize>, n: usize) -> Self {
        let end = |own: bool| if own { End::Padded } else { End::Open };
        Ends {
            start: end(window.start == 0),
            end: end(window.end == n),
        }
    }
}

/// Pass band (Hz) of a zero-phase Butterworth filter, MagNav's `pass1`/`pass2`.
///
/// An edge ≤ 0 or ≥ fs/2 is switched off (see [`magnav_bandpass`]): band-pass becomes low-pass
/// (`pass1` off) or high-pass (`pass2` off); both off means no filtering (and, in a fit, no
/// trimming).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Band {
    /// Lower edge (Hz).
    pub pass1_hz: f64,
    /// Upper edge (Hz).
    pub pass2_hz: f64,
}

impl Band {
    /// MagNav's fitting band, 0.1–0.9 Hz.
    pub const MAGNAV: Band = Band {
        pass1_hz: 0.1,
        pass2_hz: 0.9,
    };

    /// The edges `(pass1_hz, pass2_hz)` (Hz), the form reports serialise.
    pub fn edges_hz(self) -> (f64, f64) {
        (self.pass1_hz, self.pass2_hz)
    }

    /// This band's Butterworth filter of `order` at `fs_hz` (Hz), with MagNav's fallbacks:
    /// `None` means "do not filter" (see [`magnav_bandpass`]).
    pub fn butterworth(self, order: usize, fs_hz: f64) -> Result<Option<Butterworth>, FilterError> {
        magnav_bandpass(self.pass1_hz, self.pass2_hz, order, fs_hz)
    }
}

/// Which frequencies a filter keeps. Frequencies in Hz.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Response {
    /// Keep frequencies below `cutoff_hz`.
    LowPass {
        /// Cutoff frequency (Hz).
        cutoff_hz: f64,
    },
    /// Keep frequencies above `cutoff_hz`.
    HighPass {
        /// Cutoff frequency (Hz).
        cutoff_hz: f64,
    },
    /// Keep frequencies between `low_hz` and `high_hz`.
    BandPass {
        /// Lower band edge (Hz).
        low_hz: f64,
        /// Upper band edge (Hz).
        high_hz: f64,
    },
}

/// Errors from filter design or application.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum FilterError {
    /// The Butterworth order (number of poles per edge) was 0.
    #[error("filter order must be at least 1, got {0}")]
    InvalidOrder(usize),
    /// The sample rate (Hz) was not positive and finite.
    #[error("sample rate must be positive and finite, got {0} Hz")]
    InvalidSampleRate(f64),
    /// A cutoff or band edge (Hz) was not strictly inside (0, Nyquist).
    #[error("cutoff {cutoff_hz} Hz must lie strictly between 0 and the Nyquist frequency {nyquist_hz} Hz")]
    InvalidCutoff {
        /// The cutoff or band edge given (Hz).
        cutoff_hz: f64,
        /// The Nyquist frequency, half the sample rate (Hz).
        nyquist_hz: f64,
    },
    /// Band edges (Hz) were not ordered low < high.
    #[error("band edges must satisfy low < high, got {low_hz} Hz and {high_hz} Hz")]
    InvalidBand {
        /// The lower band edge given (Hz).
        low_hz: f64,
        /// The upper band edge given (Hz).
        high_hz: f64,
    },
    /// The signal had `len <= padlen` samples, too few for edge padding.
    #[error("signal of {len} samples is too short for this filter: forward-backward filtering needs more than {padlen} samples")]
    TooShort {
        /// Length of the signal (samples).
        len: usize,
        /// Edge padding the filter needs (samples); the signal must be longer.
        padlen: usize,
    },
}

/// A digital Butterworth filter as cascaded second-order sections.
#[derive(Debug, Clone, PartialEq)]
pub struct Butterworth {
    sections: Vec<[f64; 6]>,
}

impl Butterworth {
    /// Designs a Butterworth filter of `order` (band-pass: `order` per edge, as scipy's
    /// `butter(order, [lo, hi], 'bandpass')`) at sample rate `fs_hz`.
    ///
    /// Cutoffs are in Hz and must lie strictly inside `(0, fs_hz / 2)`.
    pub fn design(order: usize, response: Response, fs_hz: f64) -> Result<Self, FilterError> {
        if order == 0 {
            return Err(FilterError::InvalidOrder(order));
        }
        if !(fs_hz.is_finite() && fs_hz > 0.0) {
            return Err(FilterError::InvalidSampleRate(fs_hz));
        }
        let analog = match response {
            Response::LowPass { cutoff_hz } => {
                lowpass(order, prewarp(normalized(cutoff_hz, fs_hz)?))
            }
            Response::HighPass { cutoff_hz } => {
                highpass(order, prewarp(normalized(cutoff_hz, fs_hz)?))
            }
            Response::BandPass { low_hz, high_hz } => {
                let lo = prewarp(normalized(low_hz, fs_hz)?);
                let hi = prewarp(normalized(high_hz, fs_hz)?);
                if low_hz >= high_hz {
                    return Err(FilterError::InvalidBand { low_hz, high_hz });
                }
                bandpass(order, lo, hi)
            }
        };
        Ok(Self {
            sections: bilinear(analog).into_sections(),
        })
    }

    /// Second-order sections `[b0, b1, b2, a0, a1, a2]` with `a0 = 1`: dimensionless
    /// coefficients of `z^0, z^-1, z^-2`, one delay being one sample. Applied in order.
    pub fn sections(&self) -> &[[f64; 6]] {
        &self.sections
    }

    /// How each section's recursion is computed ([`Numerator`]): the first by the general
    /// formula (it carries the gain), the others by their shared form if the filter has at
    /// most [`Numerator::MOST_BAND_SECTIONS`] sections.
    pub(crate) fn forms(&self) -> Vec<Numerator> {
        let tail = self.sections.get(1..).unwrap_or_default();
        let shared = match tail.first().map(Numerator::of) {
            Some(form)
                if self.sections.len() <= Numerator::MOST_BAND_SECTIONS
                    && tail.iter().all(|s| Numerator::of(s) == form) =>
            {
                form
            }
            _ => Numerator::General,
        };
        (0..self.sections.len())
            .map(|k| if k == 0 { Numerator::General } else { shared })
            .collect()
    }

    /// Edge padding in samples used by [`Butterworth::filtfilt`], identical to scipy's
    /// `sosfiltfilt` default `3 * (2 * n_sections + 1 - min(#{b2 == 0}, #{a2 == 0}))`.
    pub fn padlen(&self) -> usize {
        // Sections padded with a root at the origin are really first order; scipy
        // discounts them, and matching that keeps the edge effects identical.
        let b2_zero = self.sections.iter().filter(|s| s[2] == 0.0).count();
        let a2_zero = self.sections.iter().filter(|s| s[5] == 0.0).count();
        3 * (2 * self.sections.len() + 1 - b2_zero.min(a2_zero))
    }

    /// Samples after which the response to any starting state has fallen below 10⁻²⁰ of its
    /// size: the overlap an [`End::Open`] window needs at that end (see [`Ends`]).
    ///
    /// From the largest pole radius `r`: a transient decays as `rᵏ` (the poles of a Butterworth
    /// filter are simple), and twice the samples that take to reach 10⁻²⁰ leave room for the
    /// factor in front, which grows as poles crowd towards 1.
    pub fn settling_samples(&self) -> usize {
        let radius = self
            .sections
            .iter()
            .map(|s| pole_radius(s[4], s[5]))
            .fold(0.0, f64::max);
        if radius <= 0.0 {
            return 1;
        }
        if radius >= 1.0 {
            return usize::MAX;
        }
        (2.0 * (1e-20f64).ln() / radius.ln()).ceil() as usize
    }

    /// Steady-state section states (transposed direct form II) for a unit step input,
    /// as scipy's `sosfilt_zi`: scaled by a constant `c`, filtering `c, c, ...` from this
    /// state outputs the DC response with no transient.
    pub fn sosfilt_zi(&self) -> Vec<[f64; 2]> {
        let mut scale = 1.0;
        self.sections
            .iter()
            .map(|s| {
                let [b0, b1, b2, a0, a1, a2] = *s;
                let gain = (b0 + b1 + b2) / (a0 + a1 + a2);
                let zi = [scale * (gain - b0), scale * (b2 - a2 * gain)];
                // Each later section sees the DC output of those before it.
                scale *= gain;
                zi
            })
            .collect()
    }

    /// Causal filtering from a zero initial state, as `scipy.signal.sosfilt(sos, x)`.
    /// Output has one sample per input sample.
    pub fn filter(&self, x: &[f64]) -> Vec<f64> {
        let mut state = SosState::new(self);
        x.iter().map(|&v| state.step(v)).collect()
    }

    /// Zero-phase forward-backward filtering, matching `scipy.signal.sosfiltfilt(sos, x)`.
    ///
    /// Needs `x.len() > self.padlen()` samples, else [`FilterError::TooShort`].
    /// Runs in O(n) time with a single buffer of `n + 2 * padlen` samples.
    pub fn filtfilt(&self, x: &[f64]) -> Result<Vec<f64>, FilterError> {
        let padlen = self.padlen();
        if x.len() <= padlen {
            return Err(FilterError::TooShort {
                len: x.len(),
                padlen,
            });
        }
        let mut buf = odd_extension(x, padlen);
        let mut forward = SosState::steady(self, buf[0]);
        buf.iter_mut().for_each(|v| *v = forward.step(*v));
        let last = buf[buf.len() - 1];
        let mut backward = SosState::steady(self, last);
        buf.iter_mut().rev().for_each(|v| *v = backward.step(*v));
        buf.copy_within(padlen..padlen + x.len(), 0);
        buf.truncate(x.len());
        Ok(buf)
    }
}

/// The numerator `(b0, b1, b2)` of a section, as far as its recursion leaves multiplications
/// out.
///
/// A band-pass's sections after the first have numerator (1, 0, −1): its recursion needs the
/// multiplications by `a1` and `a2` only. Multiplications by 1 and −1 are exact, so leaving
/// them out changes no bits; leaving out `0·x` changes at most the sign of an exact zero (and
/// gives ±∞ rather than NaN after an infinite sample, whose output is lost either way). The
/// scalar recursion ([`SosState::step`]) and the vector lanes use the same forms, so they
/// agree to the bit. (A low- or high-pass's (1, ±2, 1) would save two multiplications of five,
/// but every form is compiled into every lane kernel for every width and instruction set, and
/// the build time is what limits them.)
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[repr(u8)]
pub(crate) enum Numerator {
    /// Any numerator: `y = b0·x + z0`, `z0 = b1·x − a1·y + z1`, `z1 = b2·x − a2·y`.
    General,
    /// (1, 0, −1): `y = x + z0`, `z0 = z1 − a1·y`, `z1 = (−a2)·y − x`; two multiplications
    /// and three additions instead of five and four.
    Band,
}

impl Numerator {
    /// The most sections a filter computed in [`Numerator::Band`] form has: the default
    /// fourth-order band-pass's four. Each count is compiled apart in the lane kernels.
    pub(crate) const MOST_BAND_SECTIONS: usize = 4;

    /// The form of `[b0, b1, b2, a0, a1, a2]`.
    pub(crate) fn of(section: &[f64; 6]) -> Self {
        match section[..3] {
            [1.0, 0.0, -1.0] => Self::Band,
            _ => Self::General,
        }
    }
}

/// Streaming state of a [`Butterworth`] filter, one sample (same units as the input)
/// in and one out per [`SosState::step`]; for causal, real-time use.
#[derive(Debug, Clone, PartialEq)]
pub struct SosState {
    sections: Vec<[f64; 6]>,
    forms: Vec<Numerator>,
    state: Vec<[f64; 2]>,
}

impl SosState {
    /// Starts from rest (all delays zero), like `sosfilt` without `zi`.
    pub fn new(filter: &Butterworth) -> Self {
        Self {
            sections: filter.sections.clone(),
            forms: filter.forms(),
            state: vec![[0.0; 2]; filter.sections.len()],
        }
    }

    /// Starts as if the input had always been `x0`, avoiding a start-up transient.
    pub fn steady(filter: &Butterworth, x0: f64) -> Self {
        let state = filter
            .sosfilt_zi()
            .into_iter()
            .map(|[z0, z1]| [z0 * x0, z1 * x0])
            .collect();
        Self {
            sections: filter.sections.clone(),
            forms: filter.forms(),
            state,
        }
    }

    /// Feeds one sample through all sections and returns the filtered sample.
    #[inline]
    pub fn step(&mut self, x: f64) -> f64 {
        let mut v = x;
        let sections = self.sections.iter().zip(&self.forms);
        for ((s, form), z) in sections.zip(self.state.iter_mut()) {
            // Transposed direct form II: two delays per section, good rounding behaviour.
            let y = s[0] * v + z[0];
            match form {
                Numerator::Band => {
                    z[0] = z[1] - s[4] * y;
                    z[1] = (-s[5]) * y - v;
                }
                _ => {
                    z[0] = s[1] * v - s[4] * y + z[1];
                    z[1] = s[2] * v - s[5] * y;
                }
            }
            v = y;
        }
        v
    }
}

/// MagNav's band-pass with its fallbacks: `None` means "do not filter".
///
/// Edges `pass1_hz < pass2_hz` in Hz, sample rate `fs_hz` in Hz, Butterworth `order`
/// (MagNav's `pole`; a band-pass has `2 * order` poles). An edge is valid when it lies
/// strictly inside `(0, fs_hz / 2)`: both valid gives a band-pass, only `pass2_hz` valid
/// a low-pass at `pass2_hz`, only `pass1_hz` valid a high-pass at `pass1_hz`, neither
/// valid `Ok(None)`.
pub fn magnav_bandpass(
    pass1_hz: f64,
    pass2_hz: f64,
    order: usize,
    fs_hz: f64,
) -> Result<Option<Butterworth>, FilterError> {
    if !(fs_hz.is_finite() && fs_hz > 0.0) {
        return Err(FilterError::InvalidSampleRate(fs_hz));
    }
    if order == 0 {
        return Err(FilterError::InvalidOrder(order));
    }
    // An edge may be off (≤ 0 or ≥ Nyquist, infinite included), but is never NaN.
    if pass1_hz.is_nan() || pass2_hz.is_nan() {
        return Err(FilterError::InvalidBand {
            low_hz: pass1_hz,
            high_hz: pass2_hz,
        });
    }
    let valid = |f: f64| f > 0.0 && f < fs_hz / 2.0;
    let response = match (valid(pass1_hz), valid(pass2_hz)) {
        (true, true) => Response::BandPass {
            low_hz: pass1_hz,
            high_hz: pass2_hz,
        },
        (false, true) => Response::LowPass {
            cutoff_hz: pass2_hz,
        },
        (true, false) => Response::HighPass {
            cutoff_hz: pass1_hz,
        },
        (false, false) => return Ok(None),
    };
    Butterworth::design(order, response, fs_hz).map(Some)
}

/// Filters `x` unless it is constant (std ≤ f64::EPSILON), which MagNav leaves alone.
///
/// The standard deviation is the sample one (divisor `n - 1`), in the units of `x`.
/// Signals of fewer than two samples are passed to [`Butterworth::filtfilt`], which
/// rejects them as too short.
pub fn filtfilt_unless_constant(filter: &Butterworth, x: &[f64]) -> Result<Vec<f64>, FilterError> {
    if x.len() >= 2 && sample_std(x) <= f64::EPSILON {
        return Ok(x.to_vec());
    }
    filter.filtfilt(x)
}

/// [`filtfilt_unless_constant`] on several equally long signals, in place, shared among the
/// available cores; the result is bit-for-bit the same as filtering each on its own.
///
/// The signals are tested for constancy and filtered side by side, up to eight per pass,
/// in the lanes of SIMD registers: one signal's sums and recursions are latency-bound, so
/// this runs about twice as fast with MagNav's band-pass (four sections) and up to four
/// times with a single section, and it needs no buffer of the signals' length.
///
/// The kernels are compiled for AVX2 and AVX-512 as well as for the baseline, and the widest
/// the processor has is used ([`Simd::best`]); all give the same bits.
///
/// # Panics
/// If the signals differ in length: that is a programming error, not bad input.
pub fn filtfilt_many_unless_constant(
    filter: &Butterworth,
    signals: &mut [&mut [f64]],
) -> Result<(), FilterError> {
    filtfilt_many_unless_constant_with(Simd::best(), filter, signals)
}

/// [`filtfilt_many_unless_constant`] with the kernels compiled for `simd` rather than the
/// best ones, to compare their speed; the result is the same.
///
/// # Panics
/// If the signals differ in length.
pub fn filtfilt_many_unless_constant_with(
    simd: Simd,
    filter: &Butterworth,
    signals: &mut [&mut [f64]],
) -> Result<(), FilterError> {
    let kernels = simd.0;
    let read: Vec<&[f64]> = signals.iter().map(|x| &**x).collect();
    let (n, constant) = constancy(kernels, filter, &read)?;
    let mut varying: Vec<&mut [f64]> = signals
        .iter_mut()
        .zip(constant)
        .filter(|(_, constant)| !constant)
        .map(|(x, _)| &mut **x)
        .collect();
    in_shares(&mut varying, n, |share| {
        (kernels.filtfilt_all)(filter, share, Ends::WHOLE)
    });
    Ok(())
}

/// The samples at `at` (ascending, each below the signals' length) of
/// [`filtfilt_unless_constant`] of each of `signals` (equally long): one vector of `at.len()`
/// values per signal, those of the whole result: bit for bit, except for a filter of two
/// sections (a fourth-order low-pass) keeping one sample in 8 to 1024 at an even stride, whose
/// delays then jump from kept sample to kept sample (`jump.rs`: a dot product per stretch
/// instead of three recursions through every sample), and whose values agree to rounding
/// (1e-13 of the signal's size at worst in the tests, which allow 1e-12).
///
/// For a long signal of which a few samples are wanted (the low-passed level rows of a fit
/// take one sample in fifty): nothing of the signals' length is allocated or written, and the
/// signals are only read. The work is shared among the cores and runs in SIMD lanes as in
/// [`filtfilt_many_unless_constant`], at the price of a second forward pass where the samples
/// are not evenly spaced. Every instruction set gives the same bits either way.
///
/// # Panics
/// If the signals differ in length or a sample of `at` is out of range or out of order.
pub fn filtfilt_sampled_unless_constant(
    filter: &Butterworth,
    signals: &[&[f64]],
    at: &[usize],
) -> Result<Vec<Vec<f64>>, FilterError> {
    let kernels = Simd::best().0;
    let (n, constant) = constancy(kernels, filter, signals)?;
    assert_samples_within(at, n);
    let mut varying: Vec<&[f64]> = signals
        .iter()
        .zip(&constant)
        .filter(|(_, constant)| !**constant)
        .map(|(x, _)| *x)
        .collect();
    let mut filtered = in_shares(&mut varying, n, |share| {
        (kernels.filtfilt_sampled_all)(filter, share, at, Ends::WHOLE)
    })
    .into_iter()
    .flatten();
    Ok(signals
        .iter()
        .zip(constant)
        .map(|(x, constant)| match constant {
            true => samples_at(x, at),
            false => filtered.next().expect("one result per varying signal"),
        })
        .collect())
}

/// The signals' common length and, tested on all cores, which of them are constant by
/// [`filtfilt_unless_constant`]'s rule; an error if any other is too short for `filter`.
///
/// # Panics
/// If the signals differ in length.
fn constancy(
    kernels: lanes::Kernels,
    filter: &Butterworth,
    signals: &[&[f64]],
) -> Result<(usize, Vec<bool>), FilterError> {
    let n = equal_length(signals);
    let mut shared = signals.to_vec();
    let constant: Vec<bool> = in_shares(&mut shared, n, |share| (kernels.constant)(share))
        .into_iter()
        .flatten()
        .collect();
    let padlen = filter.padlen();
    if constant.iter().any(|c| !c) && n <= padlen {
        return Err(FilterError::TooShort { len: n, padlen });
    }
    Ok((n, constant))
}

/// An instruction set that [`filtfilt_many_unless_constant`]'s kernels are compiled for and
/// the running processor has: the baseline of the target ("portable"), "AVX2" or "AVX-512".
#[derive(Clone, Copy)]
pub struct Simd(lanes::Kernels);

impl Simd {
    /// The widest the processor has, the one [`filtfilt_many_unless_constant`] uses (chosen
    /// once per process).
    pub fn best() -> Self {
        Self(lanes::best())
    }

    /// Every one the processor has, portable first.
    pub fn available() -> Vec<Self> {
        lanes::available().into_iter().map(Self).collect()
    }

    /// "portable", "AVX2" or "AVX-512".
    pub fn name(self) -> &'static str {
        self.0.name
    }
}

impl std::fmt::Debug for Simd {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// `work` on `signals` (each of `n` samples) in near-equal shares on the available cores,
/// the shares' results in order; on the calling thread alone if the work is small.
///
/// Equal shares of signals, rather than of whole blocks of them, keep the threads finishing
/// together: 20 signals on two cores as 10 + 10 (8 + 2 each), not 16 + 4.
fn in_shares<S: Send, R: Send>(
    signals: &mut [S],
    n: usize,
    work: impl Fn(&mut [S]) -> R + Sync,
) -> Vec<R> {
    let threads = threads_for(signals.len(), n * signals.len());
    if threads <= 1 {
        return vec![work(signals)];
    }
    let per_thread = signals.len().div_ceil(threads);
    let work = &work;
    std::thread::scope(|scope| {
        let shares: Vec<_> = signals
            .chunks_mut(per_thread)
            .map(|share| scope.spawn(move || work(share)))
            .collect();
        shares
            .into_iter()
            .map(|share| {
                share
                    .join()
                    .unwrap_or_else(|e| std::panic::resume_unwind(e))
            })
            .collect()
    })
}

/// Samples (signals × length) below which [`filtfilt_many_unless_constant`] uses one thread
/// for a pass over its signals.
const PARALLEL_SAMPLES: usize = 2_000_000;

/// Threads worth starting for `pieces` independent pieces of work over `samples` samples in
/// all: one per core, at most one per piece, and only when each has a sizeable share.
fn threads_for(pieces: usize, samples: usize) -> usize {
    crate::parallel::cores()
        .min(pieces)
        .min(1 + samples / PARALLEL_SAMPLES)
}

/// The larger modulus of the roots of `z² + a1·z + a2`, a section's poles.
fn pole_radius(a1: f64, a2: f64) -> f64 {
    let discriminant = a1 * a1 - 4.0 * a2;
    if discriminant < 0.0 {
        a2.sqrt()
    } else {
        (a1.abs() + discriminant.sqrt()) / 2.0
    }
}

/// [`filtfilt_many_unless_constant`] of a window of longer signals, written by `fed` as the
/// forward pass goes (see [`Fed`]), `ends` saying which of its ends are theirs (see [`Ends`]),
/// every signal filtered (whether one is constant is a question about the whole signals, which
/// their caller answers), and its output from sample `from` on handed to `take(start,
/// columns)` stretch by stretch, from the last, instead of written back
/// (one slice per signal of the samples from `start` on; the stretches start where multiples
/// of 256 samples do, or at `from`): a consumer of whole rows reads them while they are in the
/// cache. The signals are left holding the forward pass's output. One core does it all.
///
/// # Panics
/// If the signals differ in length or are not longer than the filter's `padlen` samples.
pub(crate) fn filtfilt_window_handed(
    filter: &Butterworth,
    signals: &mut [&mut [f64]],
    ends: Ends,
    from: usize,
    fed: &mut Fed,
    take: &mut lanes::Take,
) {
    equal_length(signals);
    (Simd::best().0.filtfilt_all_handed)(filter, signals, ends, from, fed, take);
}

/// [`filtfilt_sampled_unless_constant`] of a window of longer signals, `ends` saying which of
/// its ends are theirs, every signal filtered (see [`filtfilt_window_handed`]). One core does
/// it all.
///
/// # Panics
/// If the signals differ in length or a sample of `at` is out of range or out of order.
pub(crate) fn filtfilt_window_sampled(
    filter: &Butterworth,
    signals: &[&[f64]],
    at: &[usize],
    ends: Ends,
) -> Vec<Vec<f64>> {
    assert_samples_within(at, equal_length(signals));
    (Simd::best().0.filtfilt_sampled_all)(filter, signals, at, ends)
}

/// The length of `signals`, all as long (0 for none).
///
/// # Panics
/// If they differ in length: a programming error of the caller.
fn equal_length<S: AsRef<[f64]>>(signals: &[S]) -> usize {
    let n = signals.first().map_or(0, |s| s.as_ref().len());
    assert!(
        signals.iter().all(|s| s.as_ref().len() == n),
        "signals must have equal lengths"
    );
    n
}

/// Samples at the start of a signal in which [`surely_varying`] looks.
pub(crate) const PREFIX: usize = 4096;

/// True when the first [`PREFIX`] samples of `x` hold two so far apart that any signal of `n`
/// samples holding them has a sample standard deviation surely above `f64::EPSILON`, the test
/// for a constant signal ([`filtfilt_unless_constant`]), so it is not constant.
///
/// Two samples `a`, `b` of `n` bound the sample standard deviation below by
/// `|a − b| / √(2(n − 1))`; a range above twice `f64::EPSILON·√(2(n − 1))` leaves a margin far
/// larger than the sums' rounding (a relative `n·2⁻⁵³`, under 10⁻⁶ for a billion samples),
/// so the decision is `sample_std`'s. `min` and `max` pass over NaN: a signal holding one is
/// not constant by `sample_std` either (its deviation is NaN).
#[inline(always)]
pub(crate) fn surely_varying(x: &[f64], n: usize) -> bool {
    let needed = 2.0 * f64::EPSILON * (2.0 * (n as f64 - 1.0)).sqrt();
    let prefix = &x[..x.len().min(PREFIX)];
    let (mut lo, mut hi) = (prefix[0], prefix[0]);
    for &v in prefix {
        lo = lo.min(v);
        hi = hi.max(v);
    }
    hi - lo > needed
}

/// Panics unless the sample positions `at` are ascending and below `n`: a programming error.
fn assert_samples_within(at: &[usize], n: usize) {
    assert!(
        at.windows(2).all(|w| w[0] < w[1]) && at.last().is_none_or(|&k| k < n),
        "samples must be ascending and within the signals"
    );
}

/// The values of `x` at the positions `at`: what a constant signal gives for its filtered
/// samples, as it is left alone.
fn samples_at(x: &[f64], at: &[usize]) -> Vec<f64> {
    at.iter().map(|&k| x[k]).collect()
}

/// Two-pass standard deviation of the data shifted by its first sample: the shift keeps
/// a large offset (e.g. 50 000 nT) from swamping the variance, and makes an exactly
/// constant signal give exactly 0 (its rounded mean would not equal the value).
fn sample_std(x: &[f64]) -> f64 {
    let n = x.len() as f64;
    let x0 = x[0];
    let mean = x.iter().map(|v| v - x0).sum::<f64>() / n;
    let ss: f64 = x.iter().map(|v| (v - x0 - mean).powi(2)).sum();
    (ss / (n - 1.0)).sqrt()
}

/// `x` extended at both ends by point reflection about its end samples (scipy's
/// `odd_ext`), which continues the local trend and so keeps the edge transient small.
fn odd_extension(x: &[f64], padlen: usize) -> Vec<f64> {
    let n = x.len();
    let (first, last) = (x[0], x[n - 1]);
    let mut ext = Vec::with_capacity(n + 2 * padlen);
    ext.extend(x[1..=padlen].iter().rev().map(|v| 2.0 * first - v));
    ext.extend_from_slice(x);
    ext.extend(
        x[n - 1 - padlen..n - 1]
            .iter()
            .rev()
            .map(|v| 2.0 * last - v),
    );
    ext
}

/// Cutoff as a fraction of the Nyquist frequency, after checking it is inside (0, 1).
fn normalized(cutoff_hz: f64, fs_hz: f64) -> Result<f64, FilterError> {
    let nyquist_hz = fs_hz / 2.0;
    if cutoff_hz > 0.0 && cutoff_hz < nyquist_hz {
        Ok(2.0 * cutoff_hz / fs_hz)
    } else {
        Err(FilterError::InvalidCutoff {
            cutoff_hz,
            nyquist_hz,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::design::C;
    use super::*;
    use std::f64::consts::PI;
    use std::ops::Range;

    fn bp(lo: f64, hi: f64) -> Response {
        Response::BandPass {
            low_hz: lo,
            high_hz: hi,
        }
    }

    /// |H| at `f_hz` for a filter sampled at `fs_hz`.
    fn gain_at(filter: &Butterworth, f_hz: f64, fs_hz: f64) -> f64 {
        let w = 2.0 * PI * f_hz / fs_hz;
        let e1 = C::new(w.cos(), -w.sin());
        let e2 = e1 * e1;
        filter.sections().iter().fold(1.0, |acc, s| {
            let num = C::real(s[0]) + C::real(s[1]) * e1 + C::real(s[2]) * e2;
            let den = C::real(s[3]) + C::real(s[4]) * e1 + C::real(s[5]) * e2;
            acc * (num / den).abs()
        })
    }

    #[test]
    fn invalid_inputs_give_matching_errors() {
        let low = |f| Response::LowPass { cutoff_hz: f };
        assert_eq!(
            Butterworth::design(0, low(1.0), 10.0),
            Err(FilterError::InvalidOrder(0))
        );
        for fs in [0.0, -10.0, f64::NAN, f64::INFINITY] {
            assert!(matches!(
                Butterworth::design(2, low(1.0), fs),
                Err(FilterError::InvalidSampleRate(_))
            ));
        }
        for f in [0.0, -1.0, 5.0, 6.0, f64::NAN] {
            assert!(matches!(
                Butterworth::design(2, low(f), 10.0),
                Err(FilterError::InvalidCutoff { .. })
            ));
            let high = Response::HighPass { cutoff_hz: f };
            assert!(matches!(
                Butterworth::design(2, high, 10.0),
                Err(FilterError::InvalidCutoff { .. })
            ));
        }
        assert_eq!(
            Butterworth::design(2, bp(0.9, 0.1), 10.0),
            Err(FilterError::InvalidBand {
                low_hz: 0.9,
                high_hz: 0.1
            })
        );
        assert!(matches!(
            Butterworth::design(2, bp(0.5, 0.5), 10.0),
            Err(FilterError::InvalidBand { .. })
        ));
        assert!(matches!(
            Butterworth::design(2, bp(0.1, 5.0), 10.0),
            Err(FilterError::InvalidCutoff { cutoff_hz, .. }) if cutoff_hz == 5.0
        ));
    }

    #[test]
    fn magnav_fallbacks() {
        let fs = 10.0;
        let both = magnav_bandpass(0.1, 0.9, 4, fs).unwrap().unwrap();
        assert_eq!(both, Butterworth::design(4, bp(0.1, 0.9), fs).unwrap());
        for pass1 in [0.0, -1.0, 5.0, 7.0] {
            let lp = magnav_bandpass(pass1, 0.9, 4, fs).unwrap().unwrap();
            let expected = Response::LowPass { cutoff_hz: 0.9 };
            assert_eq!(lp, Butterworth::design(4, expected, fs).unwrap());
        }
        for pass2 in [0.0, 5.0, 10.0] {
            let hp = magnav_bandpass(0.1, pass2, 4, fs).unwrap().unwrap();
            let expected = Response::HighPass { cutoff_hz: 0.1 };
            assert_eq!(hp, Butterworth::design(4, expected, fs).unwrap());
        }
        assert_eq!(magnav_bandpass(0.0, 5.0, 4, fs), Ok(None));
        assert_eq!(magnav_bandpass(-1.0, 20.0, 4, fs), Ok(None));
        assert!(matches!(
            magnav_bandpass(0.9, 0.1, 4, fs),
            Err(FilterError::InvalidBand { .. })
        ));
        assert_eq!(
            magnav_bandpass(0.1, 0.9, 0, fs),
            Err(FilterError::InvalidOrder(0))
        );
    }

    #[test]
    fn band_pass_doubles_order() {
        for order in 1..=8 {
            let f = Butterworth::design(order, bp(0.1, 0.9), 10.0).unwrap();
            assert_eq!(f.sections().len(), order);
            assert_eq!(f.padlen(), 3 * (2 * order + 1));
        }
    }

    #[test]
    fn odd_low_pass_has_one_first_order_section() {
        let f = Butterworth::design(5, Response::LowPass { cutoff_hz: 1.0 }, 10.0).unwrap();
        assert_eq!(f.sections().len(), 3);
        assert_eq!(f.padlen(), 3 * (2 * 3 + 1 - 1));
    }

    #[test]
    fn constant_signal_is_left_alone() {
        let f = magnav_bandpass(0.1, 0.9, 4, 10.0).unwrap().unwrap();
        let x = vec![50_000.123; 200];
        assert_eq!(filtfilt_unless_constant(&f, &x).unwrap(), x);
        let mut y = x.clone();
        y[100] += 1e-3;
        assert_ne!(filtfilt_unless_constant(&f, &y).unwrap(), y);
        assert!(matches!(
            filtfilt_unless_constant(&f, &[1.0]),
            Err(FilterError::TooShort { len: 1, .. })
        ));
    }

    #[test]
    fn dc_gain_of_low_pass_is_one_and_high_pass_kills_dc() {
        for order in 1..=8 {
            let lp = Butterworth::design(order, Response::LowPass { cutoff_hz: 0.9 }, 10.0);
            let lp = lp.unwrap();
            assert!((gain_at(&lp, 0.0, 10.0) - 1.0).abs() < 1e-12);
            assert!((gain_at(&lp, 0.9, 10.0) - 0.5f64.sqrt()).abs() < 1e-12);
            let hp = Butterworth::design(order, Response::HighPass { cutoff_hz: 0.1 }, 10.0);
            let hp = hp.unwrap();
            assert!(gain_at(&hp, 0.0, 10.0) < 1e-12);
            assert!((gain_at(&hp, 5.0, 10.0) - 1.0).abs() < 1e-12);
            let y = hp.filtfilt(&[3.0; 200]).unwrap();
            assert!(y.iter().all(|v| v.abs() < 1e-9));
        }
    }

    #[test]
    fn sections_after_the_first_take_their_shared_form() {
        use Numerator::{Band, General};
        let forms = |order, response| Butterworth::design(order, response, 10.0).unwrap().forms();
        assert_eq!(forms(4, bp(0.1, 0.9)), [General, Band, Band, Band]);
        assert_eq!(forms(1, bp(0.1, 0.9)), [General]);
        let low = Response::LowPass { cutoff_hz: 1.0 };
        let high = Response::HighPass { cutoff_hz: 1.0 };
        assert_eq!(forms(4, low), [General, General]);
        assert_eq!(forms(5, high), [General, General, General]);
        assert_eq!(forms(5, bp(0.1, 0.9)), [General; 5]);
        assert_eq!(Numerator::of(&[1.0, 0.5, -1.0, 1.0, 0.1, 0.2]), General);
    }

    /// The general transposed direct form II over `sections`, from rest.
    fn by_general_formula(sections: &[[f64; 6]], x: &[f64]) -> Vec<f64> {
        let mut z = vec![[0.0; 2]; sections.len()];
        let step = |mut v: f64, z: &mut [[f64; 2]]| {
            for (s, z) in sections.iter().zip(z.iter_mut()) {
                let y = s[0] * v + z[0];
                z[0] = s[1] * v - s[4] * y + z[1];
                z[1] = s[2] * v - s[5] * y;
                v = y;
            }
            v
        };
        x.iter().map(|&v| step(v, &mut z)).collect()
    }

    #[test]
    fn band_form_gives_the_general_formulas_bits() {
        // Leaving out 0·x and (−1)·x can only change the sign of an exact zero: on samples
        // that give none, every output bit is the general formula's.
        let f = Butterworth::design(4, bp(0.1, 0.9), 10.0).unwrap();
        let x: Vec<f64> = (0..5000)
            .map(|i| (i as f64 * 0.37).sin() * 300.0 + (i as f64 * 0.011).cos() * 4e4 + 0.3)
            .collect();
        let expected = by_general_formula(f.sections(), &x);
        let got = f.filter(&x);
        assert!(got.iter().all(|v| *v != 0.0));
        assert_eq!(
            got.iter().map(|v| v.to_bits()).collect::<Vec<_>>(),
            expected.iter().map(|v| v.to_bits()).collect::<Vec<_>>()
        );
    }

    #[test]
    fn band_pass_peaks_at_one() {
        let f = Butterworth::design(4, bp(0.1, 0.9), 10.0).unwrap();
        // The bilinear transform maps the analog centre sqrt(lo·hi) to this frequency.
        let warp = |f: f64| (PI * f / 10.0).tan();
        let centre = (warp(0.1) * warp(0.9)).sqrt().atan() * 10.0 / PI;
        assert!((gain_at(&f, centre, 10.0) - 1.0).abs() < 1e-12);
        assert!((gain_at(&f, 0.1, 10.0) - 0.5f64.sqrt()).abs() < 1e-12);
        assert!((gain_at(&f, 0.9, 10.0) - 0.5f64.sqrt()).abs() < 1e-12);
    }

    #[test]
    fn too_short_is_rejected() {
        let f = Butterworth::design(4, bp(0.1, 0.9), 10.0).unwrap();
        let padlen = f.padlen();
        assert_eq!(padlen, 27);
        let x: Vec<f64> = (0..=padlen).map(|i| i as f64).collect();
        assert_eq!(
            f.filtfilt(&x[..padlen]),
            Err(FilterError::TooShort {
                len: padlen,
                padlen
            })
        );
        assert_eq!(f.filtfilt(&x).unwrap().len(), padlen + 1);
        assert!(matches!(
            f.filtfilt(&[]),
            Err(FilterError::TooShort { len: 0, .. })
        ));
    }

    #[test]
    fn streaming_state_matches_batch_filter() {
        let f = Butterworth::design(3, bp(0.5, 5.0), 160.0).unwrap();
        let x: Vec<f64> = (0..300).map(|i| ((i * 37) % 11) as f64).collect();
        let batch = f.filter(&x);
        let mut state = SosState::new(&f);
        for (&xi, &yi) in x.iter().zip(&batch) {
            assert_eq!(state.step(xi), yi);
        }
    }

    /// Nine signals of `n` samples that wander slowly and wiggle fast, as a fit's columns do.
    fn wandering(n: usize) -> Vec<Vec<f64>> {
        (0..9)
            .map(|j| {
                (0..n)
                    .map(|i| {
                        let t = i as f64 * 0.1;
                        5e4 * (1e-3 * t * (j + 1) as f64).cos() + 3e2 * (0.7 * t + j as f64).sin()
                    })
                    .collect()
            })
            .collect()
    }

    /// The windows `core` long of `n` samples, each widened by `margin` on both sides.
    fn windows(n: usize, core: usize, margin: usize) -> Vec<(Range<usize>, Range<usize>)> {
        (0..n)
            .step_by(core)
            .map(|c0| {
                let c1 = (c0 + core).min(n);
                (c0..c1, c0.saturating_sub(margin)..(c1 + margin).min(n))
            })
            .collect()
    }

    #[test]
    fn windows_overlapping_by_the_settling_length_filter_as_the_whole_signal() {
        let band = magnav_bandpass(0.1, 0.9, 4, 10.0).unwrap().unwrap();
        let low = Butterworth::design(4, Response::LowPass { cutoff_hz: 0.1 }, 10.0).unwrap();
        let margin = band.settling_samples().max(low.settling_samples());
        assert!((2_000..10_000).contains(&margin), "{margin}");
        let n = 5 * margin + 123;
        let signals = wandering(n);
        let at: Vec<usize> = (7..n).step_by(50).collect();
        let mut whole = signals.clone();
        let mut views: Vec<&mut [f64]> = whole.iter_mut().map(|s| s.as_mut_slice()).collect();
        let (last_low, rest) = views.split_last_mut().unwrap();
        let whole_low = filtfilt_sampled_then_in_place(&low, &at, last_low, &band, rest).unwrap();
        let mut windowed = vec![Vec::new(); 8];
        let mut low_parts = vec![Vec::new(); 8];
        for (core, window) in windows(n, 2 * margin, margin) {
            let mut part: Vec<Vec<f64>> =
                signals.iter().map(|s| s[window.clone()].to_vec()).collect();
            let (last_low, rest) = part.split_last_mut().unwrap();
            let mut rest: Vec<&mut [f64]> = rest.iter_mut().map(|s| s.as_mut_slice()).collect();
            let kept: Vec<usize> = at
                .iter()
                .filter(|k| core.contains(k))
                .map(|k| k - window.start)
                .collect();
            let ends = Ends::of_window(&window, n);
            // The low-pass takes `last_low` in place of the band-pass's last signal.
            let mut read: Vec<&[f64]> = rest[..7].iter().map(|s| &**s).collect();
            read.push(last_low);
            let low_part = filtfilt_window_sampled(&low, &read, &kept, ends);
            for (all, p) in low_parts.iter_mut().zip(low_part) {
                all.extend(p);
            }
            let inner = core.start - window.start..core.end - window.start;
            for (all, s) in windowed
                .iter_mut()
                .zip(handed(&band, &mut rest, ends, &inner))
            {
                all.extend_from_slice(&s);
            }
        }
        let close = |a: &[f64], b: &[f64]| {
            let scale = a.iter().fold(1.0f64, |m, v| m.max(v.abs()));
            a.iter().zip(b).all(|(x, y)| (x - y).abs() <= 1e-13 * scale)
        };
        for (w, s) in windowed.iter().zip(&whole) {
            assert!(close(s, w));
        }
        for (w, s) in low_parts.iter().zip(&whole_low) {
            assert!(close(s, w));
        }
        // Too short an overlap is seen.
        let mut part = signals[0][..3 * margin].to_vec();
        let short = handed(
            &band,
            &mut [part.as_mut_slice()],
            Ends::of_window(&(0..3 * margin), n),
            &(2 * margin..3 * margin),
        );
        assert!(!close(&whole[0][2 * margin..3 * margin], &short[0]));
    }

    /// [`filtfilt_window_handed`]'s output over the samples `keep`, gathered per signal.
    fn handed(
        band: &Butterworth,
        signals: &mut [&mut [f64]],
        ends: Ends,
        keep: &Range<usize>,
    ) -> Vec<Vec<f64>> {
        let mut out = vec![vec![f64::NAN; keep.len()]; signals.len()];
        let mut written = |_: std::ops::Range<usize>, _: &mut [&mut [f64]]| {};
        let mut fed = Fed {
            feed: &mut written,
            lookback: 0,
        };
        filtfilt_window_handed(
            band,
            signals,
            ends,
            keep.start,
            &mut fed,
            &mut |start, columns| {
                for (o, c) in out.iter_mut().zip(columns) {
                    for (k, v) in c.iter().enumerate() {
                        if let Some(slot) = (start + k)
                            .checked_sub(keep.start)
                            .and_then(|i| o.get_mut(i))
                        {
                            *slot = *v;
                        }
                    }
                }
            },
        );
        assert!(
            out.iter().flatten().all(|v| !v.is_nan()),
            "every sample handed"
        );
        out
    }

    #[test]
    fn many_signals_filter_exactly_as_one_at_a_time() {
        let f = magnav_bandpass(0.1, 0.9, 4, 10.0).unwrap().unwrap();
        let n = 400;
        let signals: Vec<Vec<f64>> = (0..7)
            .map(|j| {
                if j == 2 {
                    vec![3.5; n] // constant: left alone
                } else {
                    (0..n)
                        .map(|i| (i as f64 * 0.1 * (j + 1) as f64).sin() * 1e3 + j as f64)
                        .collect()
                }
            })
            .collect();
        let mut together = signals.clone();
        let mut views: Vec<&mut [f64]> = together.iter_mut().map(|s| s.as_mut_slice()).collect();
        filtfilt_many_unless_constant(&f, &mut views).unwrap();
        for (alone, both) in signals.iter().zip(&together) {
            let alone = filtfilt_unless_constant(&f, alone).unwrap();
            assert!(alone
                .iter()
                .zip(both)
                .all(|(a, b)| a.to_bits() == b.to_bits()));
        }
        let mut short = vec![1.0, 2.0, 3.0];
        assert!(matches!(
            filtfilt_many_unless_constant(&f, &mut [short.as_mut_slice()]),
            Err(FilterError::TooShort { .. })
        ));
    }

    #[test]
    fn steady_state_has_no_transient() {
        let f = Butterworth::design(6, Response::LowPass { cutoff_hz: 5.0 }, 160.0).unwrap();
        let mut state = SosState::steady(&f, -2.5);
        for _ in 0..50 {
            assert!((state.step(-2.5) + 2.5).abs() < 1e-12);
        }
    }
}
