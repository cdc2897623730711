//! Lining up a stream's channels before compensation: each channel low-passed (causally, as it
//! arrives) and shifted in time ([`Shift`]) with exactly the numbers a whole series gives
//! ([`crate::fit::lag::shifted`], [`ExtraChannel::condition`](crate::model::extra::ExtraChannel::condition)).
//!
//! A shift that reads later samples holds each sample back until they have arrived: the delay is
//! the largest [`Shift::ahead`] (samples). At the end of the stream the held samples are
//! finished as the end of a series is (linear interpolation, then no value).
//!
//! ```
//! use tolles_core::compensate::align::{Aligner, Channel};
//! use tolles_core::signal::shift::Shift;
//! // One channel read 1.5 samples later (a fluxgate lag), one as it is.
//! let mut aligner = Aligner::new(vec![Channel::shifted(0, Shift::new(1.5)), Channel::shifted(1, Shift::new(0.0))]);
//! assert_eq!(aligner.delay(), 3);
//! let mut out = Vec::new();
//! for k in 0..6 {
//!     aligner.push(k, &[k as f64 * 2.0, k as f64], |k, values| out.push((k, values.to_vec())));
//! }
//! assert_eq!(out.len(), 3);
//! aligner.finish(|k, values| out.push((k, values.to_vec())));
//! assert_eq!(out[0], (0, vec![3.0, 0.0])); // a straight line interpolates exactly
//! assert!(out[5].1[0].is_nan()); // past the end
//! ```

use crate::model::extra::LowPass;
use crate::signal::shift::Shift;
use std::collections::VecDeque;

/// One output channel: a source value of each sample, low-passed or not, then shifted.
#[derive(Debug, Clone, PartialEq)]
pub struct Channel {
    /// Index of the source value in each pushed sample.
    pub source: usize,
    /// The low-pass the source goes through first, if any.
    pub lowpass: Option<LowPass>,
    /// The shift of the (low-passed) source.
    pub shift: Shift,
}

impl Channel {
    /// Source `source` shifted by `shift`, not low-passed.
    pub fn shifted(source: usize, shift: Shift) -> Self {
        Self {
            source,
            lowpass: None,
            shift,
        }
    }
}

/// Holds samples until every channel's value is known; `T` is carried with each sample.
pub struct Aligner<T> {
    channels: Vec<Channel>,
    /// Low-passed source values of each channel, for samples `first..received`.
    window: VecDeque<Vec<f64>>,
    first: usize,
    received: usize,
    /// Payloads of samples `next..received`, not yet emitted.
    pending: VecDeque<T>,
    next: usize,
    ahead: i64,
    behind: i64,
    values: Vec<f64>,
}

impl<T> Aligner<T> {
    /// An aligner producing `channels`, in order.
    pub fn new(channels: Vec<Channel>) -> Self {
        let ahead = channels.iter().map(|c| c.shift.ahead()).max().unwrap_or(0);
        let behind = channels.iter().map(|c| c.shift.behind()).max().unwrap_or(0);
        Self {
            values: vec![f64::NAN; channels.len()],
            channels,
            window: VecDeque::new(),
            first: 0,
            received: 0,
            pending: VecDeque::new(),
            next: 0,
            ahead,
            behind,
        }
    }

    /// How many samples a sample is held back at most.
    pub fn delay(&self) -> usize {
        self.ahead.max(0) as usize
    }

    /// Takes one sample's source values (NaN where unknown) and `payload`; calls `emit` with
    /// the payload and channel values of every sample now complete, in order.
    pub fn push(&mut self, payload: T, sources: &[f64], mut emit: impl FnMut(T, &[f64])) {
        let row = self
            .channels
            .iter_mut()
            .map(|c| {
                let v = sources.get(c.source).copied().unwrap_or(f64::NAN);
                c.lowpass.as_mut().map_or(v, |filter| filter.next(v))
            })
            .collect();
        self.window.push_back(row);
        self.received += 1;
        self.pending.push_back(payload);
        while self.next < self.received && self.next as i64 + self.ahead < self.received as i64 {
            self.emit_next(&mut emit);
        }
    }

    /// Ends the stream: emits every held sample, as the end of a series.
    pub fn finish(&mut self, mut emit: impl FnMut(T, &[f64])) {
        while self.next < self.received {
            self.emit_next(&mut emit);
        }
    }

    fn emit_next(&mut self, emit: &mut impl FnMut(T, &[f64])) {
        let k = self.next;
        for (c, channel) in self.channels.iter().enumerate() {
            let (window, first) = (&self.window, self.first);
            self.values[c] = channel
                .shift
                .value(|i| window[i - first][c], self.received, k);
        }
        let payload = self.pending.pop_front().expect("a sample is pending");
        self.next += 1;
        emit(payload, &self.values);
        let keep_from = (self.next as i64 - self.behind).max(0) as usize;
        while self.first < keep_from.min(self.received) {
            self.window.pop_front();
            self.first += 1;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::extra::ExtraChannel;

    /// The aligner's output equals the whole-series conditioning, bit for bit.
    #[test]
    fn a_stream_conditions_as_the_whole_series_does() {
        let fs = 10.0;
        let raw: Vec<f64> = (0..200)
            .map(|k| (0.3 * k as f64).sin() + if k == 77 { f64::NAN } else { 0.0 })
            .collect();
        for text in [
            "c:lag=0.23",
            "c:lag=-0.37:lowpass=0.4",
            "c:lowpass=1",
            "c",
            "c:lag=-2",
        ] {
            let spec: ExtraChannel = text.parse().unwrap();
            let whole = spec.condition(&raw, fs);
            let channel = Channel {
                source: 0,
                lowpass: spec.lowpass_hz.map(|hz| LowPass::new(hz, fs)),
                shift: spec.shift(fs),
            };
            let mut aligner = Aligner::new(vec![channel]);
            let mut streamed = Vec::new();
            for (k, v) in raw.iter().enumerate() {
                aligner.push(k, &[*v], |k, out| streamed.push((k, out[0])));
            }
            aligner.finish(|k, out| streamed.push((k, out[0])));
            assert!(streamed.iter().enumerate().all(|(k, (j, _))| k == *j));
            let streamed: Vec<f64> = streamed.iter().map(|(_, v)| *v).collect();
            assert_eq!(
                streamed.iter().map(|v| v.to_bits()).collect::<Vec<_>>(),
                whole.iter().map(|v| v.to_bits()).collect::<Vec<_>>(),
                "{text}"
            );
            assert!(
                aligner.window.len() <= aligner.behind.max(0) as usize + 1,
                "{text}"
            );
        }
    }
}
