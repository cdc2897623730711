//! Contiguous runs of usable samples.
//!
//! ```
//! use tolles_core::signal::segment::contiguous_runs;
//! let usable = [true, true, false, true, true, true];
//! assert_eq!(contiguous_runs(&usable, None), vec![0..2, 3..6]);
//! // A time gap also ends a run: derivatives and filters must not reach across it.
//! let tt = [0.0, 0.1, 0.2, 5.0, 5.1, 5.2];
//! assert_eq!(contiguous_runs(&[true; 6], Some(&tt)), vec![0..3, 3..6]);
//! ```

use std::ops::Range;

/// A time step longer than this many median steps is a gap.
pub const GAP_FACTOR: f64 = 1.5;

/// Maximal runs of `usable` samples, also split where the time step (`tt`, seconds) exceeds
/// [`GAP_FACTOR`] times the median step.
pub fn contiguous_runs(usable: &[bool], tt: Option<&[f64]>) -> Vec<Range<usize>> {
    let gap_after = gaps(tt, usable.len());
    let mut runs = Vec::new();
    let mut start: Option<usize> = None;
    for (k, &ok) in usable.iter().enumerate() {
        match (ok, start) {
            (true, None) => start = Some(k),
            (false, Some(s)) => {
                runs.push(s..k);
                start = None;
            }
            _ => {}
        }
        if let (Some(s), true) = (start, gap_after[k]) {
            runs.push(s..k + 1);
            start = None;
        }
    }
    if let Some(s) = start {
        runs.push(s..usable.len());
    }
    runs
}

/// `gap[k]` is true when the step from sample k to k+1 is a gap.
fn gaps(tt: Option<&[f64]>, n: usize) -> Vec<bool> {
    let mut gap = vec![false; n];
    let Some(tt) = tt else { return gap };
    let Some(step) = median_step(tt) else {
        return gap;
    };
    for k in 0..n.saturating_sub(1) {
        let dt = tt[k + 1] - tt[k];
        gap[k] = dt.is_finite() && dt > GAP_FACTOR * step;
    }
    gap
}

/// Median of the finite positive time steps (seconds), if any.
pub fn median_step(tt: &[f64]) -> Option<f64> {
    median_of_few(tt).or_else(|| median_by_selection(tt))
}

/// Distinct step values counted when a clock has only a few of them.
const FEW_STEPS: usize = 32;

/// [`median_step`] of a clock whose steps take at most [`FEW_STEPS`] distinct values (a
/// regular clock written with a few decimals: 0.1 s give a handful of values a few ulp apart)
/// by counting them: one pass, no copy. `None` for any other clock (or no step at all).
fn median_of_few(tt: &[f64]) -> Option<f64> {
    let mut counts: Vec<(f64, usize)> = Vec::with_capacity(FEW_STEPS);
    for w in tt.windows(2) {
        let d = w[1] - w[0];
        if !(d.is_finite() && d > 0.0) {
            continue;
        }
        match counts.iter().position(|(v, _)| v.to_bits() == d.to_bits()) {
            Some(k) => counts[k].1 += 1,
            None if counts.len() < FEW_STEPS => counts.push((d, 1)),
            None => return None,
        }
    }
    counts.sort_by(|a, b| a.0.total_cmp(&b.0));
    // The value at sorted position ⌊n/2⌋, as the selection below takes it.
    let mid = counts.iter().map(|(_, n)| n).sum::<usize>() / 2;
    let mut seen = 0;
    counts.into_iter().find_map(|(v, n)| {
        seen += n;
        (seen > mid).then_some(v)
    })
}

fn median_by_selection(tt: &[f64]) -> Option<f64> {
    let mut steps: Vec<f64> = tt
        .windows(2)
        .map(|w| w[1] - w[0])
        .filter(|d| d.is_finite() && *d > 0.0)
        .collect();
    if steps.is_empty() {
        return None;
    }
    let mid = steps.len() / 2;
    let (_, m, _) = steps.select_nth_unstable_by(mid, f64::total_cmp);
    Some(*m)
}

/// Index of the first sample whose time (seconds) is not after the previous finite one.
pub fn first_non_increasing(tt: &[f64]) -> Option<usize> {
    let mut last = f64::NEG_INFINITY;
    for (k, &t) in tt.iter().enumerate() {
        if !t.is_finite() {
            continue;
        }
        if t <= last {
            return Some(k);
        }
        last = t;
    }
    None
}

/// Median steps (see [`median_step`]) between two stretches that [`run_on`] joins: far more than
/// a gap, so filters restart there.
pub const RUN_ON_GAP_STEPS: f64 = 100.0;

/// `tt` (s) made increasing: from each sample whose time is not after the previous finite one
/// (a survey file sorted by line, a second day of flying), the rest is moved on to start
/// [`RUN_ON_GAP_STEPS`] median steps after that previous time. Returns the new times and the
/// samples where a stretch was moved on (empty when `tt` already increases).
pub fn run_on(tt: &[f64]) -> (Vec<f64>, Vec<usize>) {
    let gap = RUN_ON_GAP_STEPS * median_step(tt).unwrap_or(1.0);
    let mut out = Vec::with_capacity(tt.len());
    let mut moved = Vec::new();
    let (mut shift, mut last) = (0.0, f64::NEG_INFINITY);
    for (k, &t) in tt.iter().enumerate() {
        if t.is_finite() {
            if t + shift <= last {
                shift = last + gap - t;
                moved.push(k);
            }
            last = t + shift;
        }
        out.push(t + shift);
    }
    (out, moved)
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    proptest! {
        #[test]
        fn counting_a_few_steps_gives_the_selected_median(
            steps in prop::collection::vec(prop::sample::select(vec![0.1, 0.1 + 1e-15, 0.1 - 2e-15, 0.2, -0.1, f64::NAN, 0.0]), 0..60),
            many in prop::collection::vec(0.05f64..0.15, 0..80),
        ) {
            for steps in [steps.clone(), [steps, many].concat()] {
                let mut tt = vec![0.0];
                for d in &steps {
                    tt.push(tt[tt.len() - 1] + d);
                }
                let counted = median_of_few(&tt);
                let selected = median_by_selection(&tt);
                prop_assert!(counted.is_none() || counted.map(f64::to_bits) == selected.map(f64::to_bits));
                prop_assert_eq!(median_step(&tt).map(f64::to_bits), selected.map(f64::to_bits));
            }
        }
    }

    #[test]
    fn empty_and_all_unusable() {
        assert!(contiguous_runs(&[], None).is_empty());
        assert!(contiguous_runs(&[false, false], None).is_empty());
    }

    #[test]
    fn median_step_ignores_gaps() {
        let m = median_step(&[0.0, 0.1, 0.2, 9.0, 9.1]).unwrap();
        assert!((m - 0.1).abs() < 1e-12);
        assert_eq!(median_step(&[1.0]), None);
    }

    #[test]
    fn non_increasing_time_is_found() {
        assert_eq!(first_non_increasing(&[0.0, 1.0, 1.0]), Some(2));
        assert_eq!(first_non_increasing(&[0.0, f64::NAN, 2.0, 1.5]), Some(3));
        assert_eq!(first_non_increasing(&[0.0, 1.0, 2.0]), None);
    }

    #[test]
    fn run_on_joins_stretches_that_step_back_with_a_gap_between() {
        let tt = [10.0, 10.1, 10.2, 5.0, 5.1, f64::NAN, 5.3, 5.3, 5.4];
        let (run, moved) = run_on(&tt);
        assert_eq!(moved, [3, 7]);
        assert_eq!(first_non_increasing(&run), None);
        let step = median_step(&tt).unwrap();
        let gap = RUN_ON_GAP_STEPS * step;
        assert!((run[3] - (10.2 + gap)).abs() < 1e-9, "{run:?}");
        assert!((run[4] - run[3] - 0.1).abs() < 1e-9);
        assert!(run[5].is_nan());
        assert!((run[7] - (run[6] + gap)).abs() < 1e-9, "{run:?}");
        let usable = vec![true; tt.len()];
        assert_eq!(contiguous_runs(&usable, Some(&run)).len(), 3);
        let increasing = [1.0, 2.0, 3.0];
        assert_eq!(run_on(&increasing), (increasing.to_vec(), vec![]));
    }
}
