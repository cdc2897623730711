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

/// Conditions channels a chunk of samples at a time: each chunk's source values go in, and out
/// come the channel values of every sample now complete, in order. One row at a time this is
/// the stream's [`Aligner`]; one chunk holding every sample, the whole series; in between,
/// bounded-memory compensation. The numbers are the same in all three.
#[derive(Debug, Clone)]
pub struct Conditioner {
    channels: Vec<Channel>,
    /// Low-passed source values of each channel, for samples `first..received`.
    window: Vec<Vec<f64>>,
    first: usize,
    received: usize,
    /// The first sample not yet given out.
    next: usize,
    ahead: i64,
    behind: i64,
}

/// Channel values of consecutive samples, one column per channel.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Conditioned {
    /// Index of the first sample (counted from the start of the stream).
    pub start: usize,
    /// One column per channel, all of the same length.
    pub columns: Vec<Vec<f64>>,
}

impl Conditioned {
    /// Number of samples.
    pub fn len(&self) -> usize {
        self.columns.first().map_or(0, Vec::len)
    }

    /// True when it holds no sample.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
}

impl Conditioner {
    /// A conditioner producing `channels`, in order.
    pub fn new(channels: Vec<Channel>) -> Self {
        let ahead = channels.iter().map(|c| c.shift.ahead()).max().unwrap_or(0);
        let behind = channels.iter().map(|c| c.shift.behind()).max().unwrap_or(0);
        Self {
            window: vec![Vec::new(); channels.len()],
            channels,
            first: 0,
            received: 0,
            next: 0,
            ahead,
            behind,
        }
    }

    /// How many samples a sample is held back at most.
    pub fn delay(&self) -> usize {
        self.ahead.max(0) as usize
    }

    /// True when every channel is its source as it is (no low-pass, no shift): the output is
    /// the input, given out at once.
    pub fn is_identity(&self) -> bool {
        let plain = |c: &Channel| c.lowpass.is_none() && c.shift == Shift::new(0.0);
        self.channels.iter().all(plain)
    }

    /// Takes the next `rows` samples' source columns (`sources[j]` the source `j` of every
    /// sample; a source missing or shorter is NaN); gives the samples now complete.
    pub fn push(&mut self, sources: &[&[f64]], rows: usize) -> Conditioned {
        for (channel, window) in self.channels.iter_mut().zip(&mut self.window) {
            let source = sources.get(channel.source).copied().unwrap_or(&[]);
            let value = |k: usize| source.get(k).copied().unwrap_or(f64::NAN);
            match channel.lowpass.as_mut() {
                Some(filter) => window.extend((0..rows).map(|k| filter.next(value(k)))),
                None => window.extend((0..rows).map(value)),
            }
        }
        self.received += rows;
        let complete = (self.received as i64 - self.ahead.max(0)).max(0) as usize;
        self.give_out(complete)
    }

    /// Ends the stream: gives every sample still held, finished as the end of a series is.
    pub fn finish(&mut self) -> Conditioned {
        self.give_out(self.received)
    }

    /// The samples `next..until`, then forgets the values no later sample reads.
    fn give_out(&mut self, until: usize) -> Conditioned {
        let rows = self.next..until.max(self.next);
        let (first, received) = (self.first, self.received);
        let columns = self.channels.iter().zip(&self.window);
        let columns = columns.map(|(channel, window)| {
            let at = |i: usize| window[i - first];
            let shift = channel.shift;
            rows.clone().map(|k| shift.value(at, received, k)).collect()
        });
        let out = Conditioned {
            start: rows.start,
            columns: columns.collect(),
        };
        self.next = rows.end;
        let keep_from = ((self.next as i64 - self.behind).max(0) as usize).min(self.received);
        if keep_from > self.first {
            for window in &mut self.window {
                window.drain(..keep_from - self.first);
            }
            self.first = keep_from;
        }
        out
    }
}

/// Holds samples until every channel's value is known; `T` is carried with each sample. The
/// [`Conditioner`] fed one sample at a time.
pub struct Aligner<T> {
    conditioner: Conditioner,
    /// Payloads of the samples not yet emitted.
    pending: VecDeque<T>,
    values: Vec<f64>,
}

impl<T> Aligner<T> {
    /// An aligner producing `channels`, in order.
    pub fn new(channels: Vec<Channel>) -> Self {
        Self {
            values: vec![f64::NAN; channels.len()],
            conditioner: Conditioner::new(channels),
            pending: VecDeque::new(),
        }
    }

    /// How many samples a sample is held back at most.
    pub fn delay(&self) -> usize {
        self.conditioner.delay()
    }

    /// Takes one sample's source values (NaN where unknown) and `payload`; calls `emit` with
    /// the payload and channel values of every sample now complete, in order.
    pub fn push(&mut self, payload: T, sources: &[f64], emit: impl FnMut(T, &[f64])) {
        self.pending.push_back(payload);
        let columns: Vec<&[f64]> = sources.iter().map(std::slice::from_ref).collect();
        let out = self.conditioner.push(&columns, 1);
        self.emit(out, emit);
    }

    /// Ends the stream: emits every held sample, as the end of a series.
    pub fn finish(&mut self, emit: impl FnMut(T, &[f64])) {
        let out = self.conditioner.finish();
        self.emit(out, emit);
    }

    fn emit(&mut self, out: Conditioned, mut emit: impl FnMut(T, &[f64])) {
        for k in 0..out.len() {
            for (value, column) in self.values.iter_mut().zip(&out.columns) {
                *value = column[k];
            }
            let payload = self.pending.pop_front().expect("a sample is pending");
            emit(payload, &self.values);
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
            let kept = &aligner.conditioner;
            assert!(
                kept.window[0].len() <= kept.behind.max(0) as usize + 1,
                "{text}"
            );
        }
    }
}
