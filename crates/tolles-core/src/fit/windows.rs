//! Long runs done window by window: each window of a run is filled, filtered with open ends
//! where the run goes on, and its core's band rows factored, on whichever core is free, so the
//! rows of a whole run need never be held at once.

use super::diagnostics::RunningStd;
use super::level_rows::LevelRows;
use super::level_setup::{LevelReference, LevelSetup};
use super::problem::*;
use super::qr::RowFactor;
use super::window_size::{window_core, window_len, windows_dealt};
use crate::signal::filter::{
    filtfilt_window_handed, filtfilt_window_sampled, surely_varying, Butterworth, Ends, Fed, Jumps,
    PREFIX,
};
use std::ops::Range;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};

/// A long run done window by window: each window is the run's samples of its core (about
/// [`super::window_size::window_samples`] of them) widened by `margin` on each side within the
/// run, filled, filtered with open ends where the run goes on, and its core's band rows
/// factored; the margins' values are thrown away once their filters have settled.
pub(super) struct Windows {
    pub(super) run: Range<usize>,
    pub(super) margin: usize,
    /// Columns, the target not included.
    pub(super) width: usize,
    /// Signals after the target.
    pub(super) extra: usize,
    pub(super) trim: usize,
}

/// What one window of a run done in windows gives: its band rows' factors, its filtered
/// target's scatter (block by block, merged in order afterwards), and with levels the samples of
/// its level rows, per signal.
struct WindowPart {
    pieces: Pieces,
    target: Vec<RunningStd>,
    sampled: Vec<Vec<f64>>,
}

/// What every window of a run shares.
struct WindowInputs<'w, 'p, 'a> {
    problem: &'w Problem<'p, 'a>,
    fill: &'w FillRun<'w>,
    levels: Option<&'w LevelSetup>,
    cuts: &'w [usize],
    /// The samples of the run its level rows are taken at.
    kept: Option<Vec<usize>>,
    /// What the level rows' target is the scalar less, with levels.
    reference: Option<LevelReference<'w>>,
}

impl Windows {
    /// The run's band rows factored (cut at the band rows `cuts` and where windows start), the
    /// scatter of its filtered target and, with `levels`, its level rows (not centred), in
    /// windows taken whole by the cores, each core with its share of `buffer` (see
    /// [`Problem::buffer_len`]); `None` if a column or a target is constant or nearly so over
    /// the run (the filters leave a constant signal alone, which only the whole run can tell).
    ///
    /// Whole windows rather than each step of one spread over the cores: a window's fill,
    /// filters and factor stay on one core with no thread started per step, and a fit of few
    /// columns (the fluxgate's calibration: 10 signals, an 8-lane block on one core and a
    /// 2-lane one on the other when its filters were shared) keeps both cores busy.
    pub(super) fn factor(
        &self,
        problem: &Problem,
        fill: &FillRun<'_>,
        levels: Option<&LevelSetup>,
        cuts: &[usize],
        buffer: &mut [f64],
    ) -> Option<(Factored, Option<LevelRows>)> {
        let n = self.run.len();
        let window = problem.window_samples;
        let core = window_core(n, window);
        let inputs = WindowInputs {
            problem,
            fill,
            levels,
            cuts,
            kept: levels.and_then(|l| l.low.kept(n)),
            reference: levels.map(|l| LevelReference::of(l, self.run.clone())),
        };
        let starts: Vec<usize> = (0..n).step_by(core).collect();
        let longest = window_len(n, window, self.margin);
        // The buffer may be longer than this run asked for (a spare one of a wider fit's), so
        // its shares are counted as they were sized, not by how many it holds.
        let shares: Vec<&mut [f64]> = buffer
            .chunks_exact_mut(longest * (self.width + 1 + self.extra))
            .take(windows_dealt(n, window))
            .collect();
        let dealt = shares.len();
        let mut targets = problem.spare.take_each(&vec![longest; dealt]);
        let given_up = AtomicBool::new(false);
        // Each core takes the next window when it is done with its last, rather than every
        // `dealt`-th: on this virtual machine a core's speed varies, and with a fixed deal one
        // core finished each pass alone for 0.06–0.14 s. Windows are put back in order
        // afterwards, so the values do not depend on who did which.
        let next = AtomicUsize::new(0);
        let deal = |(share, target): (&mut [f64], &mut Vec<f64>)| {
            let mut parts = Vec::new();
            while !given_up.load(Ordering::Relaxed) {
                let index = next.fetch_add(1, Ordering::Relaxed);
                let Some(&start) = starts.get(index) else {
                    break;
                };
                match self.window(&inputs, start..(start + core).min(n), share, target) {
                    Some(part) => parts.push((index, part)),
                    None => given_up.store(true, Ordering::Relaxed),
                }
            }
            parts
        };
        let work = shares.into_iter().zip(targets.iter_mut());
        let mut parts: Vec<(usize, WindowPart)> = match dealt {
            1 => work.flat_map(deal).collect(),
            _ => std::thread::scope(|scope| {
                let handles: Vec<_> = work
                    .map(|w| scope.spawn(|| crate::parallel::on_one_core(|| deal(w))))
                    .collect();
                handles
                    .into_iter()
                    .flat_map(|h| h.join().expect("a window's thread does not panic"))
                    .collect()
            }),
        };
        problem.spare.give(targets);
        if given_up.into_inner() {
            return None;
        }
        parts.sort_by_key(|(index, _)| *index);
        let parts = parts.into_iter().map(|(_, p)| p);
        Some(self.gathered(parts, levels.map(|_| inputs.kept)))
    }

    /// The windows' parts, in order, as one run's; with `levels` (the samples the level rows
    /// are taken at, if any), its level rows.
    fn gathered(
        &self,
        parts: impl Iterator<Item = WindowPart>,
        levels: Option<Option<Vec<usize>>>,
    ) -> (Factored, Option<LevelRows>) {
        let mut factored = Factored {
            pieces: Vec::new(),
            target: RunningStd::default(),
        };
        let mut sampled = Vec::new();
        for part in parts {
            factored.pieces.extend(part.pieces);
            for block in part.target {
                factored.target.merge(block);
            }
            sampled.push(part.sampled);
        }
        let rows = levels.map(|kept| match kept {
            Some(at) => LevelRows::from_parts(self.width, sampled, at),
            None => LevelRows::none(self.width),
        });
        (factored, rows)
    }

    /// One window: its samples `core` of the run and the margins either side filled into
    /// `buffer`, filtered and factored; `None` if it is the run's first and a column or the
    /// target is not surely varying there.
    ///
    /// The window is filled a stretch at a time as the band-pass's forward pass asks for it
    /// ([`Fed`]), and the level rows' low-pass takes each stretch as it is filled: the
    /// unfiltered window (40 MB at 19 columns, more than this machine's last-level cache) is
    /// never written whole and read again from memory by each filter in turn. A low-pass that
    /// cannot jump ([`Jumps`]) needs the whole window first, and gets it.
    fn window(
        &self,
        inputs: &WindowInputs,
        core: Range<usize>,
        buffer: &mut [f64],
        target: &mut [f64],
    ) -> Option<WindowPart> {
        let n = self.run.len();
        let band = inputs
            .problem
            .filter
            .as_ref()
            .expect("windows are band-passed");
        let signals = self.width + 1 + self.extra;
        let window = core.start.saturating_sub(self.margin)..(core.end + self.margin).min(n);
        let m = window.len();
        let mut columns: Vec<&mut [f64]> = buffer[..m * signals].chunks_mut(m).collect();
        let mut source = Source {
            inputs,
            width: self.width,
            run: self.run.clone(),
            window: window.clone(),
            filled: 0,
            low_target: &mut target[..m],
        };
        if core.start == 0 {
            source.fill(&mut columns, PREFIX.min(m));
            if !source.varying(&columns, n) {
                return None;
            }
        }
        let ends = Ends::of_window(&window, n);
        let (mut jumps, mut sampled) = (None, Vec::new());
        if let (Some(setup), Some(kept)) = (inputs.levels, &inputs.kept) {
            let at: Vec<usize> = kept
                .iter()
                .filter(|k| core.contains(k))
                .map(|k| k - window.start)
                .collect();
            let low = setup.low.filter();
            // The low-pass reads the columns and the target, not the signals after it.
            jumps = Jumps::new(low, &at, ends, self.width + 1, m);
            if jumps.is_none() {
                source.fill(&mut columns, m);
                sampled = filtfilt_window_sampled(low, &source.low_signals(&columns), &at, ends);
            }
        }
        let lookback = jumps.as_ref().map_or(0, Jumps::lookback);
        let mut feed = |rows: Range<usize>, columns: &mut [&mut [f64]]| {
            source.fill(columns, rows.end);
            if let Some(j) = jumps.as_mut() {
                let low = source.low_signals(columns);
                j.advance(&low, rows.end);
                if rows.end == m {
                    sampled = jumps.take().expect("jumps until the end").finish(&low);
                }
            }
        };
        let mut fed = Fed {
            feed: &mut feed,
            lookback,
        };
        let core = Core {
            window: &window,
            core: &core,
            ends,
        };
        let (pieces, target) = self.factor_core(band, &mut columns, &core, inputs.cuts, &mut fed);
        Some(WindowPart {
            pieces,
            target,
            sampled,
        })
    }

    /// The band-pass `band` of the `columns` of `core.window`, and the factors of the band rows
    /// among its samples `core.core`, cut at `cuts`, with their target's scatter stretch by
    /// stretch.
    ///
    /// The rows are factored as the backward pass hands them over, while they are in the
    /// cache: the filtered window is not written back, nor read again from memory (at 19
    /// columns a window is 40 MB, more than this machine's last-level cache).
    fn factor_core(
        &self,
        band: &Butterworth,
        columns: &mut [&mut [f64]],
        core: &Core,
        cuts: &[usize],
        fed: &mut Fed,
    ) -> (Pieces, Vec<RunningStd>) {
        let n = self.run.len();
        let window_start = core.window.start;
        let samples = core.core.start.max(self.trim)..core.core.end.min(n - self.trim);
        if samples.is_empty() {
            return (Vec::new(), Vec::new());
        }
        let rows = samples.start - self.trim..samples.end - self.trim;
        let mut pieces: Vec<(Range<usize>, RowFactor)> = cuts
            .windows(2)
            .map(|w| w[0].max(rows.start)..w[1].min(rows.end))
            .filter(|piece| !piece.is_empty())
            .map(|piece| (piece, RowFactor::new(columns.len())))
            .collect();
        let mut target = Vec::new();
        // Sample `w` of the window is band row `w + window_start − trim`.
        let (first, end) = (samples.start - window_start, samples.end - window_start);
        let mut take = |start: usize, handed: &[&[f64]]| {
            let span = start..(start + handed[0].len()).min(end);
            if span.is_empty() {
                return;
            }
            let row = |w: usize| w + window_start - self.trim;
            let index = |r: usize| r + self.trim - window_start - start;
            let stretch = row(span.start)..row(span.end);
            for (piece, factor) in &mut pieces {
                let both = piece.start.max(stretch.start)..piece.end.min(stretch.end);
                if !both.is_empty() {
                    let part: Vec<&[f64]> = handed
                        .iter()
                        .map(|c| &c[index(both.start)..index(both.end)])
                        .collect();
                    factor.push(&part);
                }
            }
            let values = &handed[self.width][index(stretch.start)..index(stretch.end)];
            target.push(RunningStd::of_block(values));
        };
        filtfilt_window_handed(band, columns, core.ends, first, fed, &mut take);
        // The stretches came from the last.
        target.reverse();
        let pieces = pieces
            .into_iter()
            .map(|(piece, factor)| (piece, factor.factor()))
            .collect();
        (pieces, target)
    }
}

/// Where a window's unfiltered values come from, filled row by row in order.
struct Source<'s, 'w, 'p, 'a> {
    inputs: &'s WindowInputs<'w, 'p, 'a>,
    run: Range<usize>,
    /// The window's samples of the run.
    window: Range<usize>,
    /// Rows of the window filled so far.
    filled: usize,
    /// Columns before the target.
    width: usize,
    /// The target less the heading levels' reference (nT), as far as filled, with levels.
    low_target: &'s mut [f64],
}

impl Source<'_, '_, '_, '_> {
    /// Fills the window's `columns` (its columns, its target, the signals after it) up to row
    /// `upto`.
    fn fill(&mut self, columns: &mut [&mut [f64]], upto: usize) {
        let rows = self.filled..upto.max(self.filled);
        if rows.is_empty() {
            return;
        }
        let mut part: Vec<&mut [f64]> = columns.iter_mut().map(|c| &mut c[rows.clone()]).collect();
        let start = self.window.start;
        (self.inputs.fill)(
            self.run.clone(),
            start + rows.start..start + rows.end,
            &mut part,
        );
        if let Some(reference) = &self.inputs.reference {
            let y = &part[self.width];
            let r = reference.over(start + rows.start..start + rows.end, &part);
            for ((t, y), r) in self.low_target[rows.clone()]
                .iter_mut()
                .zip(y.iter())
                .zip(r)
            {
                *t = y - r;
            }
        }
        self.filled = rows.end;
    }

    /// Whether the columns and the target less the reference, filled as far as the test
    /// needs ([`PREFIX`]), are surely varying over the run's `n` samples.
    fn varying(&self, columns: &[&mut [f64]], n: usize) -> bool {
        columns.iter().all(|c| surely_varying(c, n))
            && (self.inputs.reference.is_none() || surely_varying(self.low_target, n))
    }

    /// What the level rows' low-pass reads: the unfiltered columns, and the target less the
    /// reference in the target's place.
    fn low_signals<'c>(&'c self, columns: &'c [&mut [f64]]) -> Vec<&'c [f64]> {
        columns[..self.width]
            .iter()
            .map(|c| &**c)
            .chain([&*self.low_target])
            .collect()
    }
}

/// A window of a run and its core, and which of the window's ends are the run's.
struct Core<'w> {
    window: &'w Range<usize>,
    core: &'w Range<usize>,
    ends: Ends,
}
