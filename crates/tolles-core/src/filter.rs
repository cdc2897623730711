//! Butterworth filters in second-order sections, applied causally or forward-backward.
//!
//! STUB: the implementation is being written; the public API below is fixed.

use thiserror::Error;

/// Which frequencies a filter keeps. Frequencies in Hz.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Response {
    /// Keep frequencies below `cutoff_hz`.
    LowPass { cutoff_hz: f64 },
    /// Keep frequencies above `cutoff_hz`.
    HighPass { cutoff_hz: f64 },
    /// Keep frequencies between `low_hz` and `high_hz`.
    BandPass { low_hz: f64, high_hz: f64 },
}

/// Errors from filter design or application.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum FilterError {
    #[error("filter order must be at least 1, got {0}")]
    InvalidOrder(usize),
    #[error("sample rate must be positive and finite, got {0} Hz")]
    InvalidSampleRate(f64),
    #[error("cutoff {cutoff_hz} Hz must lie strictly between 0 and the Nyquist frequency {nyquist_hz} Hz")]
    InvalidCutoff { cutoff_hz: f64, nyquist_hz: f64 },
    #[error("band edges must satisfy low < high, got {low_hz} Hz and {high_hz} Hz")]
    InvalidBand { low_hz: f64, high_hz: f64 },
    #[error("signal of {len} samples is too short for this filter: forward-backward filtering needs more than {padlen} samples")]
    TooShort { len: usize, padlen: usize },
}

/// A digital Butterworth filter as cascaded second-order sections.
#[derive(Debug, Clone, PartialEq)]
pub struct Butterworth {
    sections: Vec<[f64; 6]>,
}

impl Butterworth {
    /// Designs a Butterworth filter of `order` (band-pass: `order` per edge, as scipy's
    /// `butter(order, [lo, hi], 'bandpass')`) at sample rate `fs_hz`.
    pub fn design(_order: usize, _response: Response, _fs_hz: f64) -> Result<Self, FilterError> {
        unimplemented!("stub")
    }

    /// Second-order sections `[b0, b1, b2, a0, a1, a2]` with `a0 = 1`.
    pub fn sections(&self) -> &[[f64; 6]] {
        &self.sections
    }

    /// Edge padding used by [`Butterworth::filtfilt`], identical to scipy's `sosfiltfilt` default.
    pub fn padlen(&self) -> usize {
        unimplemented!("stub")
    }

    /// Zero-phase forward-backward filtering, matching `scipy.signal.sosfiltfilt(sos, x)`.
    pub fn filtfilt(&self, _x: &[f64]) -> Result<Vec<f64>, FilterError> {
        unimplemented!("stub")
    }
}

/// MagNav's band-pass with its fallbacks: `None` means "do not filter".
pub fn magnav_bandpass(
    _pass1_hz: f64,
    _pass2_hz: f64,
    _order: usize,
    _fs_hz: f64,
) -> Result<Option<Butterworth>, FilterError> {
    unimplemented!("stub")
}

/// Filters `x` unless it is constant (std ≤ f64::EPSILON), which MagNav leaves alone.
pub fn filtfilt_unless_constant(filter: &Butterworth, x: &[f64]) -> Result<Vec<f64>, FilterError> {
    let _ = (filter, x);
    unimplemented!("stub")
}
