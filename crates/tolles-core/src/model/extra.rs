//! Extra channels (currents, switch states) as regressors, each with optional conditioning: a
//! low-pass for a field smoothed by the source's inductance or the structure's eddy currents,
//! and a lag for a field timed differently from the recorded channel.
//!
//! ```
//! use tolles_core::model::extra::ExtraChannel;
//! let spec: ExtraChannel = "cur_strb:lowpass=0.5:lag=0.2".parse().unwrap();
//! assert_eq!((spec.name.as_str(), spec.lowpass_hz, spec.lag_s), ("cur_strb", Some(0.5), 0.2));
//! assert_eq!(spec.to_string(), "cur_strb:lowpass=0.5:lag=0.2");
//! assert!("cur_1".parse::<ExtraChannel>().unwrap().is_plain());
//! assert!("cur_1:lowpass=-1".parse::<ExtraChannel>().is_err());
//! ```
//!
//! **Conditioning** ([`ExtraChannel::condition`]): the channel `c` is first low-passed, then
//! delayed, and the design's columns are `B̂·(conditioned c)`.
//! - The low-pass is the causal first-order one, `τ·dy/dt + y = c` with `τ = 1/(2π·f_c)`: the
//!   response of an RL circuit or of eddy currents, which delay a field as well as smooth it
//!   (a zero-phase filter would not model that delay). It is solved exactly for `c` linear
//!   between samples, starts at the first sample's value, and restarts after a non-finite sample
//!   (which stays non-finite).
//! - A lag `L` (s) makes the field follow the channel late: `y(t − L)`, by cubic interpolation
//!   ([`crate::signal::shift`]); the first `L·fs` samples (the last, for a negative lag) have no
//!   value and are left out of a fit and of compensation.
//!
//! Both work on sample indices: they run across time gaps as they run across the file.

use crate::signal::shift::{shift, Shift};
use serde::{Deserialize, Serialize};
use std::fmt;
use std::str::FromStr;

/// Largest lag (s) accepted either way.
pub const MAX_LAG_S: f64 = 60.0;

/// Largest low-pass corner (Hz) a channel may be given: far above any sample rate, where the
/// low-pass no longer acts; a larger number is a typing slip.
pub const MAX_LOWPASS_HZ: f64 = 1e6;

/// Smallest low-pass corner (Hz): a time constant of about two days, longer than any flight.
/// Below it the channel would be a constant, indistinguishable from the permanent field.
pub const MIN_LOWPASS_HZ: f64 = 1e-6;

/// One extra channel of a design: its column name and how it is conditioned.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(from = "Stored", into = "Stored")]
pub struct ExtraChannel {
    /// Column name (e.g. `cur_strb`).
    pub name: String,
    /// Corner frequency (Hz) of the first-order low-pass the field sees; `None`: unfiltered.
    pub lowpass_hz: Option<f64>,
    /// Lag (s) of the field behind the channel; positive: the field follows the channel late.
    pub lag_s: f64,
}

impl ExtraChannel {
    /// The channel `name`, unconditioned.
    pub fn plain(name: &str) -> Self {
        Self {
            name: name.to_string(),
            lowpass_hz: None,
            lag_s: 0.0,
        }
    }

    /// True when the channel is used as recorded (no low-pass, no lag).
    pub fn is_plain(&self) -> bool {
        self.lowpass_hz.is_none() && self.lag_s == 0.0
    }

    /// The channel `raw` (its own unit) as its field sees it, at sample rate `fs_hz` (Hz): the
    /// low-pass, then the lag (see the module documentation).
    pub fn condition(&self, raw: &[f64], fs_hz: f64) -> Vec<f64> {
        let smoothed = match self.lowpass_hz {
            Some(corner_hz) => {
                let mut filter = LowPass::new(corner_hz, fs_hz);
                raw.iter().map(|x| filter.next(*x)).collect()
            }
            None => raw.to_vec(),
        };
        if self.lag_s == 0.0 {
            return smoothed;
        }
        shift(&smoothed, self.shift_samples(fs_hz))
    }

    /// The lag as a [`Shift`] of the low-passed channel (`y[k] = x(k − L·fs)`).
    pub fn shift(&self, fs_hz: f64) -> Shift {
        Shift::new(self.shift_samples(fs_hz))
    }

    fn shift_samples(&self, fs_hz: f64) -> f64 {
        -self.lag_s * fs_hz
    }
}

impl From<&str> for ExtraChannel {
    fn from(name: &str) -> Self {
        Self::plain(name)
    }
}

impl fmt::Display for ExtraChannel {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", self.name)?;
        if let Some(hz) = self.lowpass_hz {
            write!(f, ":lowpass={hz}")?;
        }
        if self.lag_s != 0.0 {
            write!(f, ":lag={}", self.lag_s)?;
        }
        Ok(())
    }
}

impl FromStr for ExtraChannel {
    type Err = String;

    /// `NAME[:lowpass=HZ][:lag=S]`, options in any order.
    fn from_str(text: &str) -> Result<Self, String> {
        let mut parts = text.split(':');
        let name = parts.next().unwrap_or_default().trim();
        if name.is_empty() {
            return Err(format!("{text:?}: no channel name before the options"));
        }
        let mut spec = Self::plain(name);
        for option in parts {
            let (key, value) = option.split_once('=').unwrap_or((option, ""));
            let number = value.trim().parse::<f64>().ok().filter(|v| v.is_finite());
            match (key.trim().to_ascii_lowercase().as_str(), number) {
                ("lowpass", Some(hz)) if (MIN_LOWPASS_HZ..=MAX_LOWPASS_HZ).contains(&hz) => {
                    spec.lowpass_hz = Some(hz)
                }
                ("lowpass", _) => {
                    return Err(format!(
                        "{text:?}: lowpass wants a frequency in [{MIN_LOWPASS_HZ:e}, {MAX_LOWPASS_HZ:e}] Hz, got {value:?}"
                    ))
                }
                ("lag", Some(s)) if s.abs() <= MAX_LAG_S => spec.lag_s = s,
                ("lag", _) => {
                    return Err(format!(
                        "{text:?}: lag wants seconds (|lag| ≤ {MAX_LAG_S} s), got {value:?}"
                    ))
                }
                (other, _) => {
                    return Err(format!(
                        "{text:?}: unknown option {other:?} (expected lowpass=HZ or lag=S)"
                    ))
                }
            }
        }
        Ok(spec)
    }
}

/// How a channel is stored in a model file: its name alone when plain (as files before the
/// options have it), else an object.
#[derive(Serialize, Deserialize)]
#[serde(untagged)]
enum Stored {
    Name(String),
    Spec {
        name: String,
        #[serde(default, skip_serializing_if = "Option::is_none")]
        lowpass_hz: Option<f64>,
        #[serde(default, skip_serializing_if = "is_zero")]
        lag_s: f64,
    },
}

fn is_zero(v: &f64) -> bool {
    *v == 0.0
}

impl From<Stored> for ExtraChannel {
    fn from(stored: Stored) -> Self {
        match stored {
            Stored::Name(name) => Self::plain(&name),
            Stored::Spec {
                name,
                lowpass_hz,
                lag_s,
            } => Self {
                name,
                lowpass_hz,
                lag_s,
            },
        }
    }
}

impl From<ExtraChannel> for Stored {
    fn from(spec: ExtraChannel) -> Self {
        if spec.is_plain() {
            return Stored::Name(spec.name);
        }
        Stored::Spec {
            name: spec.name,
            lowpass_hz: spec.lowpass_hz,
            lag_s: spec.lag_s,
        }
    }
}

/// The causal first-order low-pass `τ·dy/dt + y = x`, solved exactly for `x` linear between
/// samples; one sample at a time, so a stream and a file give the same numbers.
#[derive(Debug, Clone, PartialEq)]
pub struct LowPass {
    /// `exp(−h/τ)`, h the sample step.
    decay: f64,
    /// `τ/h`.
    tau_steps: f64,
    /// The previous input and output, when they were finite.
    last: Option<(f64, f64)>,
}

impl LowPass {
    /// A low-pass with corner `corner_hz` (Hz) for samples at `fs_hz` (Hz).
    pub fn new(corner_hz: f64, fs_hz: f64) -> Self {
        let tau_steps = fs_hz / (2.0 * std::f64::consts::PI * corner_hz);
        Self {
            decay: (-1.0 / tau_steps).exp(),
            tau_steps,
            last: None,
        }
    }

    /// The output for the next input `x`; a non-finite `x` gives itself and restarts the filter.
    pub fn next(&mut self, x: f64) -> f64 {
        if !x.is_finite() {
            self.last = None;
            return x;
        }
        let y = match self.last {
            None => x,
            Some((x0, y0)) => {
                let a = self.decay;
                x + a * (y0 - x0) - self.tau_steps * (1.0 - a) * (x - x0)
            }
        };
        self.last = Some((x, y));
        y
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn specs_round_trip_through_text_and_json() {
        for text in [
            "cur_1",
            "cur_1:lowpass=0.3",
            "cur_1:lag=-0.25",
            "a:lowpass=2:lag=1",
        ] {
            let spec: ExtraChannel = text.parse().unwrap();
            assert_eq!(spec.to_string(), text);
            let json = serde_json::to_string(&spec).unwrap();
            assert_eq!(serde_json::from_str::<ExtraChannel>(&json).unwrap(), spec);
        }
        // Plain names are stored as older model files have them.
        assert_eq!(
            serde_json::to_string(&ExtraChannel::plain("cur_1")).unwrap(),
            "\"cur_1\""
        );
        let options: ExtraChannel = "x:LAG=0.5:lowpass=1".parse().unwrap();
        assert_eq!((options.lowpass_hz, options.lag_s), (Some(1.0), 0.5));
    }

    #[test]
    fn bad_options_are_one_line_errors_naming_the_option() {
        for (text, word) in [
            (":lag=1", "name"),
            ("c:lowpass=0", "lowpass"),
            ("c:lowpass", "lowpass"),
            ("c:lag=abc", "lag"),
            ("c:lag=100", "lag"),
            ("c:gain=2", "gain"),
        ] {
            let e = text.parse::<ExtraChannel>().unwrap_err();
            assert!(e.contains(word) && !e.contains('\n'), "{text}: {e}");
        }
    }

    #[test]
    fn the_low_pass_passes_dc_and_follows_a_slow_sine_with_its_phase_lag() {
        let (fs, corner, f) = (100.0, 0.3, 0.2);
        let w = 2.0 * std::f64::consts::PI * f;
        let x: Vec<f64> = (0..4000).map(|k| (w * k as f64 / fs).sin()).collect();
        let mut filter = LowPass::new(corner, fs);
        let y: Vec<f64> = x.iter().map(|v| filter.next(*v)).collect();
        let ratio = f / corner;
        let (gain, phase) = (1.0 / (1.0 + ratio * ratio).sqrt(), ratio.atan());
        for (k, v) in y.iter().enumerate().skip(1000) {
            let expected = gain * (w * k as f64 / fs - phase).sin();
            assert!((v - expected).abs() < 1e-4, "{k}: {v} vs {expected}");
        }
        let mut filter = LowPass::new(corner, fs);
        assert!([4.0; 20].iter().all(|v| filter.next(*v) == 4.0));
    }

    #[test]
    fn a_non_finite_sample_restarts_the_low_pass() {
        let mut filter = LowPass::new(1.0, 10.0);
        let out: Vec<f64> = [0.0, 1.0, f64::NAN, 5.0, 5.0]
            .iter()
            .map(|v| filter.next(*v))
            .collect();
        assert!(out[1] > 0.0 && out[1] < 1.0 && out[2].is_nan());
        assert_eq!(out[3..], [5.0, 5.0]);
    }

    #[test]
    fn a_lag_delays_the_channel() {
        let spec: ExtraChannel = "c:lag=0.2".parse().unwrap();
        let raw: Vec<f64> = (0..10).map(|k| k as f64).collect();
        let y = spec.condition(&raw, 10.0);
        assert!(y[..2].iter().all(|v| v.is_nan()));
        assert_eq!(y[2..], raw[..8]);
    }
}
