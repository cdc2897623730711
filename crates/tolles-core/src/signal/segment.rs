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
/// [`GAP_FACTOR`] times the median step, or where time steps back or repeats (a survey file
/// sorted by line): each stretch is then filtered and differenced on its own.
pub fn contiguous_runs(usable: &[bool], tt: Option<&[f64]>) -> Vec<Range<usize>> {
    let step = tt.and_then(median_step);
    contiguous_runs_with_step(usable, tt, step)
}

/// [`contiguous_runs`] with the median time step (s) given: a part of a longer flight is split
/// where the whole flight is, not by its own median.
pub fn contiguous_runs_with_step(
    usable: &[bool],
    tt: Option<&[f64]>,
    median_step_s: Option<f64>,
) -> Vec<Range<usize>> {
    let gaps = match (tt, median_step_s) {
        (Some(tt), Some(step)) => gaps(tt, usable.len(), step),
        _ => Vec::new(),
    };
    let mut gaps = gaps.iter().copied().peekable();
    let mut runs = Vec::new();
    let mut k = 0;
    while let Some(first) = usable[k..].iter().position(|&u| u) {
        let start = k + first;
        let end = usable[start..]
            .iter()
            .position(|&u| !u)
            .map_or(usable.len(), |e| start + e);
        // A gap after sample g of the run ends it at g + 1; one after its last sample changes
        // nothing.
        let mut from = start;
        while let Some(g) = gaps.next_if(|&g| g + 1 < end) {
            if g >= from {
                runs.push(from..g + 1);
                from = g + 1;
            }
        }
        runs.push(from..end);
        k = end;
    }
    runs
}

/// The samples k whose step to sample k + 1 is a gap (more than [`GAP_FACTOR`] median
/// `step`s, s, or none at all: time stepping back), ascending.
fn gaps(tt: &[f64], n: usize, step: f64) -> Vec<usize> {
    let limit = GAP_FACTOR * step;
    let tt = &tt[..n.min(tt.len())];
    // Steps k → k + 1 for k in a part per core, in order.
    let steps = tt.len().saturating_sub(1);
    let found = crate::parallel::map_parts(steps, 1, |part| {
        part.filter(|&k| {
            let dt = tt[k + 1] - tt[k];
            dt.is_finite() && (dt > limit || dt <= 0.0)
        })
        .collect::<Vec<usize>>()
    });
    found.concat()
}

/// Median of the finite positive time steps (seconds), if any.
pub fn median_step(tt: &[f64]) -> Option<f64> {
    median_from(few_step_counts(tt).as_deref(), tt)
}

/// [`median_step`] from the clock's few distinct steps when it has them (`counts`, see
/// [`few_step_counts`]), else by selection over `tt`.
fn median_from(counts: Option<&[(f64, usize)]>, tt: &[f64]) -> Option<f64> {
    match counts {
        Some(counts) => median_of_counts(counts),
        None => median_by_selection(tt),
    }
}

/// Distinct step values counted when a clock has only a few of them.
pub(crate) const FEW_STEPS: usize = 32;

/// The value at sorted position ⌊n/2⌋ of distinct `counts` (ascending), as the selection
/// below takes it.
fn median_of_counts(counts: &[(f64, usize)]) -> Option<f64> {
    let mid = counts.iter().map(|(_, n)| n).sum::<usize>() / 2;
    let mut seen = 0;
    counts.iter().find_map(|&(v, n)| {
        seen += n;
        (seen > mid).then_some(v)
    })
}

/// Each distinct finite positive step of `tt` (s) and how often it occurs, ascending; `None`
/// when there are more than [`FEW_STEPS`] distinct steps.
fn few_step_counts(tt: &[f64]) -> Option<Vec<(f64, usize)>> {
    let mut counts: Vec<(f64, usize)> = Vec::with_capacity(2 * FEW_STEPS);
    for part in step_counts_on_all_cores(tt) {
        for (v, n) in part? {
            match counts.iter_mut().find(|(c, _)| c.to_bits() == v.to_bits()) {
                Some(c) => c.1 += n,
                None => counts.push((v, n)),
            }
        }
    }
    if counts.len() > FEW_STEPS {
        return None;
    }
    counts.sort_by(|a, b| a.0.total_cmp(&b.0));
    Some(counts)
}

/// The sampling interval (s) of the clock `tt`: its [`median_step`], unless the clock is
/// written too coarsely for its rate (time in hours with five decimals reads 0.1 s steps as
/// 0.072 or 0.108 s), when it is the mean of its usual steps (see [`sampling_step_of`]).
pub fn sampling_step(tt: &[f64]) -> Option<f64> {
    // One count of the steps serves both the median and the mean.
    let counts = few_step_counts(tt);
    let median = median_from(counts.as_deref(), tt)?;
    Some(sampling_step_of(counts.as_deref(), median))
}

/// Usual steps lie within this factor of the median step; the rest are gaps or glitches.
const USUAL_STEP: std::ops::RangeInclusive<f64> = 0.5..=1.5;

/// Usual steps further apart than this (relative) mark a quantised clock, not rounding.
const QUANTISED: f64 = 0.01;

/// [`sampling_step`] from the clock's distinct steps and their counts (`None` when there are
/// many: a jittered clock, whose median is its interval) and its median step (s).
pub fn sampling_step_of(counts: Option<&[(f64, usize)]>, median_s: f64) -> f64 {
    let Some(counts) = counts else {
        return median_s;
    };
    let usual: Vec<(f64, usize)> = (counts.iter().copied())
        .filter(|(v, _)| USUAL_STEP.contains(&(v / median_s)))
        .collect();
    let (low, high) = usual
        .iter()
        .fold((f64::INFINITY, 0.0f64), |(lo, hi), (v, _)| {
            (lo.min(*v), hi.max(*v))
        });
    if usual.is_empty() || high <= low * (1.0 + QUANTISED) {
        return median_s;
    }
    let (sum, n) = (usual.iter()).fold((0.0, 0usize), |(s, c), (v, n)| (s + v * *n as f64, c + n));
    sum / n as f64
}

/// Samples of time below which [`step_counts`] runs on one core.
const STEPS_ON_ONE_CORE: usize = 1 << 18;

/// [`step_counts`] of consecutive parts of `tt` (overlapping by a sample, so every step is in
/// exactly one), on all cores.
fn step_counts_on_all_cores(tt: &[f64]) -> Vec<Option<Vec<(f64, usize)>>> {
    let threads = crate::parallel::cores();
    if threads == 1 || tt.len() < STEPS_ON_ONE_CORE {
        return vec![step_counts(tt)];
    }
    let part = tt.len().div_ceil(threads);
    std::thread::scope(|scope| {
        let handles: Vec<_> = (0..threads)
            .map(|t| {
                let samples = &tt[(t * part).min(tt.len())..((t + 1) * part + 1).min(tt.len())];
                scope.spawn(move || step_counts(samples))
            })
            .collect();
        handles
            .into_iter()
            .map(|h| h.join().unwrap_or(None))
            .collect()
    })
}

/// Each distinct finite positive step of `tt` and how often it occurs; `None` when there are
/// more than [`FEW_STEPS`] distinct steps.
fn step_counts(tt: &[f64]) -> Option<Vec<(f64, usize)>> {
    // Counted in a small open-addressing table keyed by the step's bits (0 marks an empty
    // slot: a zero step is never counted), so a sample costs a hash and a probe or two.
    const SLOTS: usize = 2 * FEW_STEPS;
    let mut keys = [0u64; SLOTS];
    let mut counts = [0usize; SLOTS];
    let mut distinct = 0;
    for w in tt.windows(2) {
        let d = w[1] - w[0];
        if !(d.is_finite() && d > 0.0) {
            continue;
        }
        let bits = d.to_bits();
        let mut slot = (bits.wrapping_mul(0x9E37_79B9_7F4A_7C15) >> 58) as usize % SLOTS;
        loop {
            if keys[slot] == bits {
                counts[slot] += 1;
                break;
            }
            if keys[slot] == 0 {
                if distinct == FEW_STEPS {
                    return None;
                }
                (keys[slot], counts[slot], distinct) = (bits, 1, distinct + 1);
                break;
            }
            slot = (slot + 1) % SLOTS;
        }
    }
    Some(
        keys.iter()
            .zip(counts)
            .filter(|(key, _)| **key != 0)
            .map(|(key, n)| (f64::from_bits(*key), n))
            .collect(),
    )
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
    // A part per core, each scanned on its own: within a part, the running last time is the
    // true one from the part's first finite time on, which only the last finite time of the
    // parts before decides.
    let scans = crate::parallel::map_parts(tt.len(), 1, |part| scan_times(tt, part));
    let mut last = f64::NEG_INFINITY;
    for scan in scans {
        if let Some((k, first)) = scan.first {
            if first <= last {
                return Some(k);
            }
        }
        if scan.non_increasing.is_some() {
            return scan.non_increasing;
        }
        last = scan.last.unwrap_or(last);
    }
    None
}

/// What [`first_non_increasing`] needs of a part of the times.
struct TimesScan {
    /// The first finite time and its sample.
    first: Option<(usize, f64)>,
    /// The last finite time.
    last: Option<f64>,
    /// The first sample whose time is not after the part's previous finite one.
    non_increasing: Option<usize>,
}

fn scan_times(tt: &[f64], part: Range<usize>) -> TimesScan {
    let first = part
        .clone()
        .find(|&k| tt[k].is_finite())
        .map(|k| (k, tt[k]));
    let mut last = f64::NEG_INFINITY;
    for k in part {
        let t = tt[k];
        if !t.is_finite() {
            continue;
        }
        if t <= last {
            return TimesScan {
                first,
                last: None,
                non_increasing: Some(k),
            };
        }
        last = t;
    }
    TimesScan {
        first,
        last: first.map(|_| last),
        non_increasing: None,
    }
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

    /// [`median_step`] of a clock whose steps take at most [`FEW_STEPS`] distinct values (a
    /// regular clock written with a few decimals: 0.1 s give a handful of values a few ulp apart)
    /// by counting them: one pass, no copy. `None` for any other clock (or no step at all).
    fn median_of_few(tt: &[f64]) -> Option<f64> {
        median_of_counts(&few_step_counts(tt)?)
    }

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

    /// The definition: a run goes on while samples are usable and no gap follows the last one.
    fn runs_one_by_one(usable: &[bool], tt: Option<&[f64]>) -> Vec<Range<usize>> {
        let gap_after = |k: usize| {
            let (Some(tt), Some(step)) = (tt, tt.and_then(median_step)) else {
                return false;
            };
            let dt = tt[k + 1] - tt[k];
            k + 1 < usable.len() && dt.is_finite() && (dt > GAP_FACTOR * step || dt <= 0.0)
        };
        let mut runs = Vec::new();
        let mut start = None;
        for (k, &ok) in usable.iter().enumerate() {
            match (ok, start) {
                (true, None) => start = Some(k),
                (false, Some(s)) => {
                    runs.push(s..k);
                    start = None;
                }
                _ => {}
            }
            if let (Some(s), true) = (start, k + 1 < usable.len() && gap_after(k)) {
                runs.push(s..k + 1);
                start = None;
            }
        }
        runs.extend(start.map(|s| s..usable.len()));
        runs
    }

    proptest! {
        #[test]
        fn runs_split_at_unusable_samples_and_gaps(
            samples in prop::collection::vec((any::<bool>(), prop::sample::select(vec![0.1, 0.1, 0.1, 0.5, 2.0, -3.0, 0.0, f64::NAN])), 0..80),
        ) {
            let usable: Vec<bool> = samples.iter().map(|s| s.0).collect();
            // Steps of 0.1 s with longer ones, steps back and repeats among them; a NaN step
            // leaves that time missing.
            let mut t = 0.0f64;
            let tt: Vec<f64> = samples
                .iter()
                .map(|s| {
                    t += if s.1.is_nan() { 0.1 } else { s.1 };
                    if s.1.is_nan() { f64::NAN } else { t }
                })
                .collect();
            prop_assert_eq!(contiguous_runs(&usable, None), runs_one_by_one(&usable, None));
            prop_assert_eq!(contiguous_runs(&usable, Some(&tt)), runs_one_by_one(&usable, Some(&tt)));
        }
    }

    #[test]
    fn long_clocks_are_counted_in_parts_as_one() {
        let n = 3 * STEPS_ON_ONE_CORE;
        // A 0.1 s clock written with 4 decimals: a few distinct steps a few ulp apart.
        let regular: Vec<f64> = (0..n)
            .map(|k| (k as f64 * 0.1 * 1e4).round() / 1e4)
            .collect();
        assert!(median_of_few(&regular).is_some());
        assert_eq!(median_of_few(&regular), median_by_selection(&regular));
        // Twenty distinct steps in each half, forty in all: too many to count.
        let step = |k: usize| 0.1 + (k % 20 + 20 * (k >= n / 2) as usize) as f64 * 1e-3;
        let mut t = 0.0;
        let uneven: Vec<f64> = (0..n)
            .map(|k| {
                t += step(k);
                t
            })
            .collect();
        assert_eq!(median_of_few(&uneven), None);
        assert_eq!(median_step(&uneven), median_by_selection(&uneven));
    }

    #[test]
    fn empty_and_all_unusable() {
        assert!(contiguous_runs(&[], None).is_empty());
        assert!(contiguous_runs(&[false, false], None).is_empty());
    }

    #[test]
    fn a_file_sorted_by_line_splits_where_time_steps_back_or_repeats() {
        // Line 2 flown first, then line 1; a repeated time inside line 1.
        let tt = [20.0, 20.1, 20.2, 10.0, 10.1, 10.1, 10.2];
        let runs = contiguous_runs(&[true; 7], Some(&tt));
        assert_eq!(runs, [0..3, 3..5, 5..7]);
    }

    #[test]
    fn a_clock_written_too_coarsely_gives_its_mean_usual_step() {
        // 10 Hz written in hours with five decimals: steps of 0.072 and 0.108 s.
        let tt: Vec<f64> = (0..1000)
            .map(|k| ((16.8 + k as f64 * 0.1 / 3600.0) * 1e5).round() / 1e5 * 3600.0)
            .collect();
        let median = median_step(&tt).unwrap();
        let step = sampling_step(&tt).unwrap();
        assert!((median - 0.108).abs() < 1e-6, "{median}");
        assert!((step - 0.1).abs() < 1e-4, "{step}");
        // A clean clock keeps its median to the bit, gaps and all.
        let clean = [0.0, 0.1, 0.2, 0.30000000000000004, 0.4, 9.0, 9.1];
        assert_eq!(sampling_step(&clean), median_step(&clean));
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

    /// The reference: one pass over every sample.
    fn first_non_increasing_one_by_one(tt: &[f64]) -> Option<usize> {
        let mut last = f64::NEG_INFINITY;
        for (k, &t) in tt.iter().enumerate() {
            if t.is_finite() {
                if t <= last {
                    return Some(k);
                }
                last = t;
            }
        }
        None
    }

    /// Long clocks, scanned in a part per core: a step back inside either part, one right after
    /// the parts meet, one whose earlier time lies in the other part across missing times, and
    /// parts with no finite time at all.
    #[test]
    fn long_clocks_are_checked_in_parts_as_one() {
        let n: usize = 300_001;
        let clock: Vec<f64> = (0..n).map(|k| k as f64 * 0.1).collect();
        let half = n.div_ceil(2);
        let mut cases = vec![clock.clone()];
        for at in [17, half - 1, half, half + 1, n - 1] {
            let mut tt = clock.clone();
            tt[at] = tt[at - 1];
            cases.push(tt);
        }
        let mut across = clock.clone();
        across[half - 3..half + 2].fill(f64::NAN);
        across[half + 2] = across[half - 4] - 1.0;
        cases.push(across);
        let mut unknown = vec![f64::NAN; n];
        cases.push(unknown.clone());
        unknown[3] = 1.0;
        unknown[n - 2] = 0.5;
        cases.push(unknown);
        for tt in &cases {
            assert!(tt.len() > 2 * crate::parallel::PARALLEL_ROWS);
            assert_eq!(
                first_non_increasing(tt),
                first_non_increasing_one_by_one(tt)
            );
        }
        assert_eq!(first_non_increasing(&cases[6]), Some(half + 2));
        assert_eq!(first_non_increasing(&cases[8]), Some(n - 2));
        // The gaps of a long clock, found in parts, are those of one pass.
        let mut tt = clock;
        for at in [5, half - 1, half, n - 2] {
            tt[at + 1..].iter_mut().for_each(|t| *t += 7.0);
        }
        let usable = vec![true; n];
        assert_eq!(
            contiguous_runs(&usable, Some(&tt)),
            [0..6, 6..half, half..half + 1, half + 1..n - 1, n - 1..n]
        );
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
