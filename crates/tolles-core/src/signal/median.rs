//! The exact median of a sequence too long to hold in memory, found over repeated passes.
//!
//! ```
//! use tolles_core::signal::median::MedianSearch;
//! let steps = [0.1, 0.1, 0.30000000000000004, 0.1, 5.0]; // seconds
//! let mut search = MedianSearch::default();
//! while search.needs_pass() {
//!     let mut pass = search.start_pass();
//!     steps.iter().for_each(|s| pass.push(*s));
//!     search.finish_pass(pass);
//! }
//! assert_eq!(search.median(), Some(0.1));
//! ```
//!
//! The median is the value of rank `n / 2` (0-based) in ascending [`f64::total_cmp`] order, the
//! element `select_nth_unstable_by(n / 2, f64::total_cmp)` returns — the one
//! [`crate::signal::segment::median_step`] uses. A pass counts the distinct values it sees; while there
//! are at most [`DISTINCT_LIMIT`] of them (a regularly sampled time column has a few dozen
//! distinct steps) one pass is enough. Otherwise each further pass fixes 16 more bits of the
//! answer (radix selection), so at most four passes are needed. Memory is bounded by
//! [`DISTINCT_LIMIT`] entries and a 65 536-bin histogram, whatever the length of the sequence.

use std::collections::BTreeMap;

/// Distinct values one pass keeps count of before it falls back to its histogram.
pub const DISTINCT_LIMIT: usize = 1 << 16;

const DIGIT_BITS: u32 = 16;

/// A median search in progress; see the module example.
#[derive(Debug, Clone, Default)]
pub struct MedianSearch {
    /// Rank (0-based) of the median among the values whose key starts with `prefix`.
    rank: Option<usize>,
    prefix: u64,
    fixed_bits: u32,
    answer: Option<Option<f64>>,
    /// The distinct values and their counts, ascending, when the first pass saw only a few.
    few: Option<Vec<(f64, usize)>>,
}

/// One pass over the sequence: push every value, in any order.
#[derive(Debug, Clone)]
pub struct MedianPass {
    prefix: u64,
    fixed_bits: u32,
    count: usize,
    histogram: Vec<usize>,
    distinct: BTreeMap<u64, usize>,
    overflow: bool,
}

impl MedianSearch {
    /// True until the median is known.
    pub fn needs_pass(&self) -> bool {
        self.answer.is_none()
    }

    /// A pass to feed every value of the sequence to.
    pub fn start_pass(&self) -> MedianPass {
        MedianPass {
            prefix: self.prefix,
            fixed_bits: self.fixed_bits,
            count: 0,
            histogram: vec![0; 1 << DIGIT_BITS],
            distinct: BTreeMap::new(),
            overflow: false,
        }
    }

    /// Takes in a finished pass; afterwards [`MedianSearch::needs_pass`] says whether another
    /// pass over the same sequence is needed.
    pub fn finish_pass(&mut self, pass: MedianPass) {
        let first = self.rank.is_none();
        if first && !pass.overflow && pass.distinct.len() <= crate::signal::segment::FEW_STEPS {
            let few = pass.distinct.iter().map(|(key, n)| (from_key(*key), *n));
            self.few = Some(few.collect());
        }
        let rank = *self.rank.get_or_insert(pass.count / 2);
        if pass.count == 0 {
            self.answer = Some(None);
            return;
        }
        if !pass.overflow {
            let mut below = 0;
            for (key, n) in &pass.distinct {
                below += n;
                if below > rank {
                    self.answer = Some(Some(from_key(*key)));
                    return;
                }
            }
        }
        let mut below = 0;
        for (digit, n) in pass.histogram.iter().enumerate() {
            if below + n > rank {
                self.rank = Some(rank - below);
                self.prefix = (self.prefix << DIGIT_BITS) | digit as u64;
                self.fixed_bits += DIGIT_BITS;
                break;
            }
            below += n;
        }
        if self.fixed_bits == 64 {
            self.answer = Some(Some(from_key(self.prefix)));
        }
    }

    /// The median, once known; `None` for an empty sequence (or before the last pass).
    pub fn median(&self) -> Option<f64> {
        self.answer.flatten()
    }

    /// The distinct values and how often each occurs, ascending, when the sequence holds at
    /// most 32 distinct values (a regular or quantised clock's steps); else `None`.
    pub fn few_values(&self) -> Option<&[(f64, usize)]> {
        self.few.as_deref()
    }
}

impl MedianPass {
    /// Counts one value of the sequence.
    pub fn push(&mut self, value: f64) {
        let key = to_key(value);
        if self.fixed_bits > 0 && key >> (64 - self.fixed_bits) != self.prefix {
            return;
        }
        self.count += 1;
        let digit = (key >> (64 - self.fixed_bits - DIGIT_BITS)) as usize & ((1 << DIGIT_BITS) - 1);
        self.histogram[digit] += 1;
        if !self.overflow {
            *self.distinct.entry(key).or_insert(0) += 1;
            if self.distinct.len() > DISTINCT_LIMIT {
                self.overflow = true;
                self.distinct.clear();
            }
        }
    }
}

/// A key whose unsigned order is [`f64::total_cmp`]'s order.
fn to_key(v: f64) -> u64 {
    let bits = v.to_bits();
    if bits >> 63 == 1 {
        !bits
    } else {
        bits | 1 << 63
    }
}

fn from_key(key: u64) -> f64 {
    f64::from_bits(if key >> 63 == 1 {
        key & !(1 << 63)
    } else {
        !key
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn search(values: &[f64]) -> (Option<f64>, usize) {
        let mut search = MedianSearch::default();
        let mut passes = 0;
        while search.needs_pass() {
            let mut pass = search.start_pass();
            values.iter().for_each(|v| pass.push(*v));
            search.finish_pass(pass);
            passes += 1;
        }
        (search.median(), passes)
    }

    fn by_sorting(values: &[f64]) -> Option<f64> {
        let mut v = values.to_vec();
        if v.is_empty() {
            return None;
        }
        let mid = v.len() / 2;
        Some(*v.select_nth_unstable_by(mid, f64::total_cmp).1)
    }

    #[test]
    fn empty_has_no_median() {
        assert_eq!(search(&[]), (None, 1));
    }

    #[test]
    fn many_distinct_values_take_more_passes_and_stay_exact() {
        let values: Vec<f64> = (0..200_000u64)
            .map(|k| 0.1 + (k.wrapping_mul(2_654_435_761) % 1_000_003) as f64 * 1e-12)
            .collect();
        let (median, passes) = search(&values);
        assert!(passes > 1, "{passes}");
        assert_eq!(median, by_sorting(&values));
    }

    proptest! {
        #[test]
        fn equals_the_median_by_sorting(values in prop::collection::vec(
            prop_oneof![any::<f64>(), (0.0..1.0f64), Just(0.1), Just(-0.0)], 0..300)) {
            let (median, _) = search(&values);
            let expected = by_sorting(&values);
            prop_assert_eq!(median.map(f64::to_bits), expected.map(f64::to_bits));
        }
    }
}
