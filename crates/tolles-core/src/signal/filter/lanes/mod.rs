//! Forward-backward filtering of several equally long signals at once, one signal per
//! vector lane.
//!
//! Filtering one signal leaves most of the floating-point units idle: each section's
//! recursion is a chain of dependent multiplies and adds along time. Independent signals
//! side by side in fixed-size arrays let the compiler put them in SIMD registers (two per
//! SSE2 register, the x86-64 baseline) and fill the pipeline. Each lane performs exactly
//! the operations of [`Butterworth::filtfilt`] in the same order, so the results are
//! bit-for-bit the same; but for kept samples at an even stride, where the delays jump from
//! one to the next ([`Jump`]) and the values agree to rounding.
//!
//! The kernels are compiled three times: for the baseline, for AVX2 (four lanes per
//! register) and for AVX-512 (eight), and [`best`] picks the widest the processor has.
//! Neither extension enables fused multiply-add (Rust never contracts `a * b + c` on its
//! own anyway), so every path gives the same bits. The AVX-512 copy also moves samples
//! between the signals and its tiles by shuffles ([`super::transpose`]).
//!
//! [`filtfilt_all_handed`] is fed its input a stretch at a time as the forward pass goes
//! ([`Fed`]) and hands its output to a consumer of whole rows (a fit's factor) as the backward
//! pass makes it, all blocks of lanes in step, instead of writing it back; [`Jumps`] take a
//! low-pass's kept samples from the same stretches as they come.

mod jumps;
mod sections;

use super::jump::{Forward, Jump};
#[cfg(target_arch = "x86_64")]
use super::transpose::Avx512;
use super::transpose::{Plain, Transpose};
use super::{Butterworth, End, Ends, Numerator};
use jumps::*;
use multiversion::{inherit_target, multiversion, target::match_target};
use sections::*;
use std::ops::Range;
use std::sync::OnceLock;

/// The lane kernels compiled for one instruction set.
#[derive(Clone, Copy)]
pub(super) struct Kernels {
    /// The instruction set, for people: "portable", "AVX2" or "AVX-512".
    pub name: &'static str,
    /// [`filtfilt_all`].
    pub filtfilt_all: fn(&Butterworth, &mut [&mut [f64]], Ends),
    /// [`filtfilt_sampled_all`].
    pub filtfilt_sampled_all: SampledKernel,
    /// [`constant`].
    pub constant: fn(&[&[f64]]) -> Vec<bool>,
    /// [`filtfilt_all_handed`].
    pub filtfilt_all_handed: HandedKernel,
    /// [`Jumps::advance`].
    pub jumps_advance: fn(&mut Jumps, &[&[f64]], usize),
    /// [`Jumps::finish`].
    pub jumps_finish: JumpsFinish,
}

/// Gives the kept samples of a low-pass whose every sample is taken.
type JumpsFinish = fn(Jumps, &[&[f64]]) -> Vec<Vec<f64>>;

/// Filters signals (equally long) and returns each one's samples at the given positions.
type SampledKernel = fn(&Butterworth, &[&[f64]], &[usize], Ends) -> Vec<Vec<f64>>;

/// Filters signals (equally long), fed as it goes, and hands their output from a sample on
/// to a consumer.
type HandedKernel = fn(&Butterworth, &mut [&mut [f64]], Ends, usize, &mut Fed, &mut Take);

/// What [`filtfilt_all_handed`] hands its output to: `take(start, columns)`, one slice per
/// signal of its samples from `start` on.
pub(super) type Take<'t> = dyn FnMut(usize, &[&[f64]]) + 't;

/// What writes [`filtfilt_all_handed`]'s signals as its forward pass goes: see [`Fed`].
pub(crate) type Feed<'f> = dyn FnMut(Range<usize>, &mut [&mut [f64]]) + 'f;

/// The source of [`filtfilt_all_handed`]'s signals: `feed(rows, signals)` is called for
/// consecutive stretches of rows from the first, each before the forward pass reads it, and
/// writes or reads the signals there. Once a call returns, the pass may overwrite the rows
/// before that stretch, so a call may still read the stretch fed before it, which is at least
/// `lookback` rows long.
///
/// The signals of a fit's window need not be written whole before they are filtered: each
/// stretch is written, read by whatever else needs the unfiltered values and filtered while
/// it is in the cache.
pub(crate) struct Fed<'f> {
    pub feed: &'f mut Feed<'f>,
    /// Rows (samples) a call reads before its stretch.
    pub lookback: usize,
}

/// The kernels for the target the crate is compiled for (SSE2 on plain x86-64).
const PORTABLE: Kernels = Kernels {
    name: "portable",
    filtfilt_all: |filter, signals, ends| filtfilt_all(Plain, filter, signals, ends),
    filtfilt_sampled_all: |filter, signals, at, ends| {
        filtfilt_sampled_all(Plain, filter, signals, at, ends)
    },
    constant: |signals| constant(Plain, signals),
    filtfilt_all_handed: |filter, signals, ends, from, fed, take| {
        filtfilt_all_handed(Plain, filter, signals, ends, from, fed, take)
    },
    jumps_advance: |jumps, signals, upto| jumps.advance_with(Plain, signals, upto),
    jumps_finish: |jumps, signals| jumps.finish_inline(signals),
};

/// Defines `$name() -> Option<Kernels>`: the kernels compiled for `$target` (a
/// `multiversion` target string) if the running processor has it, else `None`.
///
/// The kernels' helpers are all `#[inline(always)]`, so they are compiled into these
/// copies with the target's instructions rather than called at the baseline. `$transpose`
/// is the copy's [`Transpose`].
macro_rules! compiled_for {
    ($name:ident, $target:tt, $label:literal, $transpose:expr) => {
        #[multiversion(targets($target))]
        fn $name() -> Option<Kernels> {
            match_target! {
                $target => {
                    #[inherit_target]
                    fn filtfilt_all_here(
                        filter: &Butterworth,
                        signals: &mut [&mut [f64]],
                        ends: Ends,
                    ) {
                        filtfilt_all($transpose, filter, signals, ends)
                    }
                    #[inherit_target]
                    fn filtfilt_sampled_all_here(
                        filter: &Butterworth,
                        signals: &[&[f64]],
                        at: &[usize],
                        ends: Ends,
                    ) -> Vec<Vec<f64>> {
                        filtfilt_sampled_all($transpose, filter, signals, at, ends)
                    }
                    #[inherit_target]
                    fn constant_here(signals: &[&[f64]]) -> Vec<bool> {
                        constant($transpose, signals)
                    }
                    #[inherit_target]
                    fn filtfilt_all_handed_here(
                        filter: &Butterworth,
                        signals: &mut [&mut [f64]],
                        ends: Ends,
                        from: usize,
                        fed: &mut Fed,
                        take: &mut Take,
                    ) {
                        filtfilt_all_handed($transpose, filter, signals, ends, from, fed, take)
                    }
                    #[inherit_target]
                    fn jumps_advance_here(jumps: &mut Jumps, signals: &[&[f64]], upto: usize) {
                        jumps.advance_with($transpose, signals, upto)
                    }
                    #[inherit_target]
                    fn jumps_finish_here(jumps: Jumps, signals: &[&[f64]]) -> Vec<Vec<f64>> {
                        jumps.finish_inline(signals)
                    }
                    Some(Kernels {
                        name: $label,
                        filtfilt_all: filtfilt_all_here,
                        filtfilt_sampled_all: filtfilt_sampled_all_here,
                        constant: constant_here,
                        filtfilt_all_handed: filtfilt_all_handed_here,
                        jumps_advance: jumps_advance_here,
                        jumps_finish: jumps_finish_here,
                    })
                }
                _ => None,
            }
        }
    };
}

compiled_for!(avx2, "x86_64+avx2", "AVX2", Plain);
// `multiversion` requires Ice Lake's AVX-512 extensions on top, so that processors which
// slow their clock down for AVX-512 (Skylake-SP and its kin) run the AVX2 copy instead.
compiled_for!(
    avx512,
    "x86_64+avx512f",
    "AVX-512",
    // SAFETY: this copy runs only where the processor has AVX-512 (chosen at run time).
    unsafe { Avx512::assumed() }
);

/// Every copy of the kernels the running processor can execute, portable first.
pub(super) fn available() -> Vec<Kernels> {
    [Some(PORTABLE), avx2(), avx512()]
        .into_iter()
        .flatten()
        .collect()
}

/// The widest copy of the kernels the running processor can execute, chosen on the
/// first call.
pub(super) fn best() -> Kernels {
    static BEST: OnceLock<Kernels> = OnceLock::new();
    *BEST.get_or_init(|| avx512().or_else(avx2).unwrap_or(PORTABLE))
}

/// Signals per block. Fewer lanes leave the recursion latency-bound on filters with one
/// or two sections; more only add register pressure once the arithmetic units are busy
/// (measured at 10⁶ samples: 8 lanes about 4× faster than one signal at a time with one
/// section, 2× with four or eight). The AVX-512 copy too: 16 lanes (two registers) were
/// about 10 % slower than 8 with MagNav's band-pass, and again 3 % slower on an AMD Zen 4
/// (whose AVX-512 units are 256 bits wide) with the signals in the second-level cache (the
/// filter bench's `filtfilt_20x4096`), though the recursion alone ran 20 % faster there: the
/// transposes of two registers' lanes took it back.
pub(super) const LANES: usize = 8;

/// Samples per tile that the signals are interleaved into and out of. Short tiles
/// measured fastest: the tile and the signals' current stretches stay in the L1 cache.
const TILE: usize = 32;

/// [`Butterworth::filtfilt`] of every one of `signals` (equally long, longer than
/// `filter.padlen()` samples), written back in place, in blocks of up to [`LANES`]; with an
/// open end of `ends`, of a window of longer signals (see [`Ends`]).
///
/// The last, partial block uses a narrower kernel, since idle lanes cost as much as busy
/// ones once the arithmetic units are saturated.
#[inline(always)]
pub(super) fn filtfilt_all(
    transpose: impl Transpose,
    filter: &Butterworth,
    signals: &mut [&mut [f64]],
    ends: Ends,
) {
    for mut block in blocks_of(filter, signals.len()) {
        block.filtfilt(transpose, signals, ends);
    }
}

/// [`Butterworth::filtfilt`] of every one of `signals` (equally long, longer than
/// `filter.padlen()` samples), but only its samples at `at` (ascending, each below the
/// signals' length): one vector of `at.len()` values per signal. The signals are not written.
///
/// Blocks of signals as in [`filtfilt_all`].
#[inline(always)]
pub(super) fn filtfilt_sampled_all(
    transpose: impl Transpose,
    filter: &Butterworth,
    signals: &[&[f64]],
    at: &[usize],
    ends: Ends,
) -> Vec<Vec<f64>> {
    let n = signals.first().map_or(0, |s| s.len());
    if let Some(mut jumps) = Jumps::new(filter, at, ends, signals.len(), n) {
        jumps.advance_with(transpose, signals, n);
        return jumps.finish_inline(signals);
    }
    let mut out = Vec::with_capacity(signals.len());
    let mut blocks = signals.chunks_exact(LANES);
    if blocks.len() > 0 {
        let mut ws = Workspace::<LANES>::new(filter);
        for block in &mut blocks {
            out.extend(filtfilt_sampled_block(transpose, block, at, &mut ws, ends));
        }
    }
    let rest = blocks.remainder();
    out.extend(match rest.len() {
        0 => Vec::new(),
        1..=2 => {
            filtfilt_sampled_block(transpose, rest, at, &mut Workspace::<2>::new(filter), ends)
        }
        3..=4 => {
            filtfilt_sampled_block(transpose, rest, at, &mut Workspace::<4>::new(filter), ends)
        }
        _ => filtfilt_sampled_block(
            transpose,
            rest,
            at,
            &mut Workspace::<LANES>::new(filter),
            ends,
        ),
    });
    out
}

/// Whether each of `signals` (equally long) counts as constant by
/// [`super::sample_std`]'s rule: at least 2 samples and a sample standard deviation of at
/// most `f64::EPSILON` (in the units of the signal).
///
/// The two sums of `sample_std` are sequential chains of additions, which the processor
/// waits on for one signal; eight signals side by side overlap them. Per lane the
/// operations and their order are `sample_std`'s, so the decision is the same.
#[inline(always)]
pub(super) fn constant(transpose: impl Transpose, signals: &[&[f64]]) -> Vec<bool> {
    let n = signals.first().map_or(0, |x| x.len());
    if n < 2 {
        return vec![false; signals.len()];
    }
    let mut tile = vec![[0.0; LANES]; TILE];
    // A plain loop rather than iterator adapters: their closures would be compiled
    // separately, at the baseline, instead of into the AVX copies of this function.
    let mut out = Vec::with_capacity(signals.len());
    for block in signals.chunks(LANES) {
        if clearly_varying(block) {
            out.extend(std::iter::repeat_n(false, block.len()));
            continue;
        }
        let std = sample_std_block(transpose, block, &mut tile);
        for &s in &std[..block.len()] {
            out.push(s <= f64::EPSILON);
        }
    }
    out
}

/// True when every one of `signals` (equally long, at least 2 samples) is
/// [`super::surely_varying`] over its own length, so the two passes of [`sample_std_block`]
/// can be skipped.
#[inline(always)]
fn clearly_varying(signals: &[&[f64]]) -> bool {
    let n = signals[0].len();
    let mut all = true;
    for x in signals {
        all &= super::surely_varying(x, n);
    }
    all
}

/// [`super::sample_std`] of each of `signals` (at most `L`, equally long, at least 2
/// samples) in its lane; unused lanes hold 0.
#[allow(clippy::needless_range_loop)] // as in `step`: the per-lane formula stays visible
#[inline(always)]
fn sample_std_block<const L: usize>(
    transpose: impl Transpose,
    signals: &[&[f64]],
    tile: &mut [[f64; L]],
) -> [f64; L] {
    let n = signals[0].len();
    if signals.len() < L {
        tile.fill([0.0; L]);
    }
    let mut x0 = [0.0; L];
    for (l, x) in signals.iter().enumerate() {
        x0[l] = x[0];
    }
    // Starting where `Iterator::sum` of f64 starts (-0.0) keeps even a zero sum identical.
    let mut sum = [-0.0; L];
    for start in (0..n).step_by(TILE) {
        let tile = &mut tile[..TILE.min(n - start)];
        gather(transpose, signals, start, tile);
        for v in tile.iter() {
            for l in 0..L {
                sum[l] += v[l] - x0[l];
            }
        }
    }
    let mean = sum.map(|s| s / n as f64);
    let mut ss = [-0.0; L];
    for start in (0..n).step_by(TILE) {
        let tile = &mut tile[..TILE.min(n - start)];
        gather(transpose, signals, start, tile);
        for v in tile.iter() {
            for l in 0..L {
                // `powi(2)` is this one multiplication.
                let d = v[l] - x0[l] - mean[l];
                ss[l] += d * d;
            }
        }
    }
    ss.map(|s| (s / (n as f64 - 1.0)).sqrt())
}

/// Scratch space of one thread for blocks of `L` signals, reused from block to block so
/// that filtering allocates nothing per signal and nothing of the signals' length.
struct Workspace<const L: usize> {
    /// Coefficients and delays of each section, per lane.
    sections: Vec<Section<L>>,
    /// Steady-state delays `[z0, z1]` per section for a unit step (scipy's `sosfilt_zi`).
    zi: Vec<[f64; 2]>,
    /// One tile of the signals, time-major: `tile[t][l]` is sample `t` of signal `l`.
    tile: Vec<[f64; L]>,
    /// The `padlen` samples of odd extension at one end, time-major like `tile`.
    pad: Vec<[f64; L]>,
    /// The forward pass's output at the last sample it has taken.
    last: [f64; L],
}

impl<const L: usize> Workspace<L> {
    #[inline(always)]
    fn new(filter: &Butterworth) -> Self {
        Self {
            sections: filter
                .sections
                .iter()
                .zip(filter.forms())
                .map(|(s, form)| Section::new(s, form))
                .collect(),
            zi: filter.sosfilt_zi(),
            tile: vec![[0.0; L]; TILE],
            pad: vec![[0.0; L]; filter.padlen()],
            last: [0.0; L],
        }
    }

    /// Delays as if each lane's input had always been its sample in `x0`, as
    /// [`super::SosState::steady`] does for one signal.
    #[inline(always)]
    fn steady(&mut self, x0: [f64; L]) {
        for (s, [zi0, zi1]) in self.sections.iter_mut().zip(&self.zi) {
            for (l, &x) in x0.iter().enumerate() {
                s.z0[l] = zi0 * x;
                s.z1[l] = zi1 * x;
            }
        }
    }

    /// The forward pass over the leading odd extension of `signals` (scipy's `odd_ext`:
    /// `2 x[0] − x[padlen − i]` at sample `i`), from its steady state: only the delays it
    /// leaves matter.
    #[inline(always)]
    fn start_forward<S: AsRef<[f64]>>(&mut self, signals: &[S]) {
        let padlen = self.pad.len();
        for (l, x) in signals.iter().enumerate() {
            let x = x.as_ref();
            let first = x[0];
            for (p, v) in self.pad.iter_mut().zip(x[1..=padlen].iter().rev()) {
                p[l] = 2.0 * first - v;
            }
        }
        self.steady(self.pad[0]);
        run(&mut self.sections, &mut self.pad, false);
    }

    /// The trailing odd extension of `signals` into `pad`: `2 x[n−1] − x[n−2−j]` at sample
    /// `n + padlen + j`.
    #[inline(always)]
    fn trailing_extension<S: AsRef<[f64]>>(&mut self, signals: &[S]) {
        let padlen = self.pad.len();
        for (l, x) in signals.iter().enumerate() {
            let x = x.as_ref();
            let n = x.len();
            let last = x[n - 1];
            for (p, v) in self
                .pad
                .iter_mut()
                .zip(x[n - 1 - padlen..n - 1].iter().rev())
            {
                p[l] = 2.0 * last - v;
            }
        }
    }

    /// The backward pass over the trailing extension's forward output in `pad`, from the
    /// steady state of its last sample: the delays the signals' backward pass starts from.
    #[inline(always)]
    fn start_backward(&mut self) {
        let padlen = self.pad.len();
        self.steady(self.pad[padlen - 1]);
        run(&mut self.sections, &mut self.pad, true);
    }

    /// The delays the forward pass starts the signals from: after the leading extension at a
    /// padded start, the steady state of their first samples at an open one.
    #[inline(always)]
    fn start_forward_at<S: AsRef<[f64]>>(&mut self, signals: &[S], start: End) {
        match start {
            End::Padded => self.start_forward(signals),
            End::Open => {
                let mut x0 = [0.0; L];
                for (l, x) in signals.iter().enumerate() {
                    x0[l] = x.as_ref()[0];
                }
                self.steady(x0);
            }
        }
    }

    /// The delays the backward pass starts from once the forward pass has left its delays
    /// after the signals' last sample, whose output is `last`: from the trailing extension
    /// (taken into `pad` beforehand) at a padded end, the steady state of `last` at an open one.
    #[inline(always)]
    fn start_backward_at(&mut self, end: End, last: [f64; L]) {
        match end {
            End::Padded => {
                run(&mut self.sections, &mut self.pad, false);
                self.start_backward();
            }
            End::Open => self.steady(last),
        }
    }
}

/// [`Butterworth::filtfilt`] of each of `signals` (at most `L`, equally long, longer than
/// the filter's `padlen` samples), written back in place.
///
/// Only what reaches the kept samples is computed. The forward pass over the leading
/// extension matters only through the delays it leaves, and the backward pass over it
/// not at all. Only the trailing extension's forward output is stored (in `pad`), as the
/// backward pass starts from it. The signals themselves hold the forward output in
/// between, so there is no buffer of the signals' length.
#[inline(always)]
fn filtfilt_block<const L: usize>(
    transpose: impl Transpose,
    signals: &mut [&mut [f64]],
    ws: &mut Workspace<L>,
    ends: Ends,
) {
    let Some(n) = signals.first().map(|s| s.len()) else {
        return;
    };
    forward_block(transpose, signals, ws, ends);
    for start in (0..n).step_by(TILE).rev() {
        let len = TILE.min(n - start);
        backward_tile(transpose, signals, ws, start, len);
        scatter(transpose, &ws.tile[..len], start, signals);
    }
}

/// The forward pass of [`filtfilt_block`] over `signals` (at least one), its output left in
/// them, and `ws` made ready for the backward pass ([`backward_tile`]).
#[inline(always)]
fn forward_block<const L: usize>(
    transpose: impl Transpose,
    signals: &mut [&mut [f64]],
    ws: &mut Workspace<L>,
    ends: Ends,
) {
    forward_begin(signals, ws, ends);
    // The trailing extension is taken before the forward pass overwrites the signals.
    if ends.end == End::Padded {
        ws.trailing_extension(signals);
    }
    forward_tiles(transpose, signals, ws, 0..signals[0].len());
    ws.start_backward_at(ends.end, ws.last);
}

/// The delays [`forward_block`] starts `signals` from, from their first `padlen + 1`
/// samples.
#[inline(always)]
fn forward_begin<const L: usize>(signals: &[&mut [f64]], ws: &mut Workspace<L>, ends: Ends) {
    assert!(signals.len() <= L, "at most {L} signals per block");
    let n = signals[0].len();
    assert!(n > ws.pad.len(), "signals must be longer than padlen");
    if signals.len() < L {
        // Unused lanes stay exactly 0 (zero input, zero delays): no subnormal slow paths,
        // and lanes never mix anyway.
        ws.pad.fill([0.0; L]);
        ws.tile.fill([0.0; L]);
    }
    ws.start_forward_at(signals, ends.start);
}

/// [`forward_block`]'s pass over the samples `rows` (starting where a tile does), after those
/// before them.
#[inline(always)]
fn forward_tiles<const L: usize>(
    transpose: impl Transpose,
    signals: &mut [&mut [f64]],
    ws: &mut Workspace<L>,
    rows: Range<usize>,
) {
    // A full block parks the forward output interleaved, as it comes, where the tile's
    // samples were; a partial one has too few signals to hold all lanes, and writes them back.
    let parked = signals.len() == L;
    for start in rows.clone().step_by(TILE) {
        let tile = &mut ws.tile[..TILE.min(rows.end - start)];
        gather(transpose, signals, start, tile);
        run(&mut ws.sections, tile, false);
        ws.last = tile[tile.len() - 1];
        match parked {
            true => park(tile, start, signals),
            false => scatter(transpose, tile, start, signals),
        }
    }
}

/// The backward pass of [`filtfilt_block`] over the tile of samples `start..start + len`
/// (one of the forward pass's tiles, the last one not yet done), its output left in
/// `ws.tile[..len]`.
#[inline(always)]
fn backward_tile<const L: usize>(
    transpose: impl Transpose,
    signals: &[&mut [f64]],
    ws: &mut Workspace<L>,
    start: usize,
    len: usize,
) {
    let tile = &mut ws.tile[..len];
    match signals.len() == L {
        true => unpark(signals, start, tile),
        false => gather(transpose, signals, start, tile),
    }
    run(&mut ws.sections, tile, true);
}

/// Samples per stretch that [`filtfilt_all_handed`] hands over at once: 256 samples of 19
/// signals are 38 KiB, about a core's L1 data cache.
pub(super) const HANDED: usize = 256;

/// [`filtfilt_all`] of `signals` (at least one), written by `fed` as the forward pass goes
/// (see [`Fed`]), whose output from sample `from` on is handed to `take` instead of written
/// back: stretch by stretch, from the last, as `take(start, columns)` with one slice per signal
/// of its samples `start..` up to the next stretch's start. Stretches start at multiples of
/// [`HANDED`] (or at `from`). The backward pass stops at `from`, and `signals` are left
/// holding the forward pass's output.
///
/// The blocks of lanes go forward and backward in step, so a stretch of every signal is
/// ready at once, while it is in the cache: the feed writes rows that the forward pass reads
/// from there, and a consumer of whole rows (a fit's factor) reads the backward pass's there
/// instead of from memory, and nothing is written back.
#[inline(always)]
pub(super) fn filtfilt_all_handed(
    transpose: impl Transpose,
    filter: &Butterworth,
    signals: &mut [&mut [f64]],
    ends: Ends,
    from: usize,
    fed: &mut Fed,
    take: &mut Take,
) {
    let count = signals.len();
    let Some(n) = signals.first().map(|s| s.len()) else {
        return;
    };
    let mut blocks = blocks_of(filter, count);
    forward_fed(transpose, &mut blocks, signals, ends, fed);
    let mut stretch = vec![vec![0.0; HANDED]; count];
    let mut end = n;
    while end > from {
        let start = (end - 1) / HANDED * HANDED;
        let first_tile = start.max(from / TILE * TILE);
        for tile in (first_tile..end).step_by(TILE).rev() {
            let len = TILE.min(n - tile);
            for (block, out) in blocks.iter_mut().zip(stretch.chunks_mut(LANES)) {
                block.prefetch(signals, tile.saturating_sub(AHEAD * TILE));
                block.backward(transpose, signals, tile, len, out, tile - start);
            }
        }
        let handed = start.max(from);
        let columns: Vec<&[f64]> = stretch
            .iter()
            .map(|c| &c[handed - start..end - start])
            .collect();
        take(handed, &columns);
        end = start;
    }
}

/// Tiles ahead of the backward pass that [`filtfilt_all_handed`] asks the cache for: all
/// blocks in step read as many streams backward as there are signals, more than the
/// processor's prefetcher follows.
const AHEAD: usize = 2;

/// Rows [`forward_fed`] asks its feed for at a time (but for the last, and more if the filters
/// or the feed look back further): two such stretches of a fit's 19 columns are 300 KB, in a
/// core's second-level cache.
const FED: usize = 1024;

/// The forward pass of every block of `signals` in step, stretch by stretch as `fed` writes
/// them (see [`Fed`]), `blocks` made ready for the backward pass. The pass over a stretch
/// waits until the stretch after it is fed, so a feed may read the stretch before its own.
#[inline(always)]
fn forward_fed(
    transpose: impl Transpose,
    blocks: &mut [Block],
    signals: &mut [&mut [f64]],
    ends: Ends,
    fed: &mut Fed,
) {
    let n = signals[0].len();
    let padlen = blocks.first().map_or(0, Block::padlen);
    // A stretch at least `padlen + 1` long holds the samples each end's extension is taken
    // from, the last's in the last two stretches, which are fed before either is overwritten.
    let length = FED.max(padlen + 1).max(fed.lookback).next_multiple_of(TILE);
    let stretches: Vec<Range<usize>> = (0..n)
        .step_by(length)
        .map(|s| s..(s + length).min(n))
        .collect();
    let trailing = |blocks: &mut [Block], signals: &mut [&mut [f64]]| {
        if ends.end == End::Padded {
            blocks
                .iter_mut()
                .for_each(|b| b.trailing_extension(signals));
        }
    };
    (fed.feed)(stretches[0].clone(), signals);
    blocks.iter_mut().for_each(|b| b.begin(signals, ends));
    if stretches.len() == 1 {
        trailing(blocks, signals);
    }
    for (index, rows) in stretches.iter().enumerate() {
        if let Some(next) = stretches.get(index + 1) {
            (fed.feed)(next.clone(), signals);
            if index + 2 == stretches.len() {
                trailing(blocks, signals);
            }
        }
        for block in blocks.iter_mut() {
            block.forward_tiles(transpose, signals, rows.clone());
        }
    }
    blocks.iter_mut().for_each(|b| b.end(ends));
}

/// Blocks of [`LANES`] signals of `count`, the last as narrow as it can be.
#[inline(always)]
fn blocks_of(filter: &Butterworth, count: usize) -> Vec<Block> {
    lane_blocks(count)
        .map(|signals| Block::new(filter, signals))
        .collect()
}

/// The signals (indices) of each block of up to [`LANES`] of `count` signals, in order.
#[inline(always)]
fn lane_blocks(count: usize) -> impl Iterator<Item = Range<usize>> {
    (0..count)
        .step_by(LANES)
        .map(move |start| start..(start + LANES).min(count))
}

/// One block of signals (their indices) and its workspace, as wide as it needs.
enum Block {
    Two(Range<usize>, Workspace<2>),
    Four(Range<usize>, Workspace<4>),
    Eight(Range<usize>, Workspace<LANES>),
}

/// `$body` with `$signals`, the block's of `$all`, and `$ws`, its workspace, whatever its
/// width.
macro_rules! on_block {
    ($block:expr, $all:expr, |$signals:ident, $ws:ident| $body:expr) => {
        match $block {
            Block::Two(range, $ws) => {
                let $signals = &mut $all[range.clone()];
                $body
            }
            Block::Four(range, $ws) => {
                let $signals = &mut $all[range.clone()];
                $body
            }
            Block::Eight(range, $ws) => {
                let $signals = &mut $all[range.clone()];
                $body
            }
        }
    };
}

impl Block {
    /// The narrowest width for the signals `range` (at most [`LANES`]): idle lanes cost as
    /// much as busy ones once the arithmetic units are saturated.
    #[inline(always)]
    fn new(filter: &Butterworth, range: Range<usize>) -> Self {
        match range.len() {
            1..=2 => Self::Two(range, Workspace::new(filter)),
            3..=4 => Self::Four(range, Workspace::new(filter)),
            _ => Self::Eight(range, Workspace::new(filter)),
        }
    }

    /// The filter's `padlen`.
    #[inline(always)]
    fn padlen(&self) -> usize {
        match self {
            Block::Two(_, ws) => ws.pad.len(),
            Block::Four(_, ws) => ws.pad.len(),
            Block::Eight(_, ws) => ws.pad.len(),
        }
    }

    /// [`filtfilt_block`].
    #[inline(always)]
    fn filtfilt(&mut self, transpose: impl Transpose, all: &mut [&mut [f64]], ends: Ends) {
        on_block!(self, all, |s, ws| filtfilt_block(transpose, s, ws, ends))
    }

    /// [`forward_begin`].
    #[inline(always)]
    fn begin(&mut self, all: &mut [&mut [f64]], ends: Ends) {
        on_block!(self, all, |s, ws| forward_begin(s, ws, ends))
    }

    /// [`Workspace::trailing_extension`].
    #[inline(always)]
    fn trailing_extension(&mut self, all: &mut [&mut [f64]]) {
        on_block!(self, all, |s, ws| ws.trailing_extension(s))
    }

    /// [`forward_tiles`].
    #[inline(always)]
    fn forward_tiles(
        &mut self,
        transpose: impl Transpose,
        all: &mut [&mut [f64]],
        rows: Range<usize>,
    ) {
        on_block!(self, all, |s, ws| forward_tiles(transpose, s, ws, rows))
    }

    /// The end of the forward pass: [`Workspace::start_backward_at`].
    #[inline(always)]
    fn end(&mut self, ends: Ends) {
        match self {
            Block::Two(_, ws) => ws.start_backward_at(ends.end, ws.last),
            Block::Four(_, ws) => ws.start_backward_at(ends.end, ws.last),
            Block::Eight(_, ws) => ws.start_backward_at(ends.end, ws.last),
        }
    }

    /// Asks the cache for the tile of samples from `start` on of every signal.
    #[inline(always)]
    fn prefetch(&mut self, all: &mut [&mut [f64]], start: usize) {
        on_block!(self, all, |s, _ws| {
            for x in s.iter() {
                if let Some(tile) = x.get(start..start + TILE) {
                    for line in tile.chunks(8) {
                        prefetch_line(line);
                    }
                }
            }
        })
    }

    /// [`backward_tile`], its output written into `out` (one per signal) from `at` on.
    #[inline(always)]
    fn backward(
        &mut self,
        transpose: impl Transpose,
        all: &mut [&mut [f64]],
        start: usize,
        len: usize,
        out: &mut [Vec<f64>],
        at: usize,
    ) {
        on_block!(self, all, |s, ws| {
            backward_tile(transpose, s, ws, start, len);
            scatter(transpose, &ws.tile[..len], at, out);
        })
    }
}

/// Stores `tile` (samples `start..start + tile.len()` of `L` signals, interleaved) as it is
/// in the signals' own samples there: the tile's values in order, `tile.len()` per signal.
///
/// The forward pass's output is only read back by [`unpark`], so it need not be in signal
/// order: plain copies instead of a transpose each way.
#[inline(always)]
fn park<const L: usize>(tile: &[[f64; L]], start: usize, signals: &mut [&mut [f64]]) {
    let len = tile.len();
    for (x, values) in signals
        .iter_mut()
        .zip(tile.as_flattened().chunks_exact(len))
    {
        copy_tile(&mut x[start..start + len], values);
    }
}

/// `dst.copy_from_slice(src)`, inline for a whole tile: a copy of unknown length is a call to
/// the C library's `memmove`, whose start-up cost per 256 bytes was 4 % of a fit.
#[inline(always)]
fn copy_tile(dst: &mut [f64], src: &[f64]) {
    match (
        <&mut [f64; TILE]>::try_from(&mut *dst),
        <&[f64; TILE]>::try_from(src),
    ) {
        (Ok(dst), Ok(src)) => *dst = *src,
        _ => dst.copy_from_slice(src),
    }
}

/// The inverse of [`park`].
#[inline(always)]
fn unpark<const L: usize>(signals: &[&mut [f64]], start: usize, tile: &mut [[f64; L]]) {
    let len = tile.len();
    for (x, values) in signals
        .iter()
        .zip(tile.as_flattened_mut().chunks_exact_mut(len))
    {
        copy_tile(values, &x[start..start + len]);
    }
}

/// Samples per stretch of [`filtfilt_sampled_block`]: its stretch of the signals, interleaved,
/// stays in the L2 cache between the two passes over it.
const STRETCH: usize = 2048;

/// [`filtfilt_block`] of `signals` (at most `L`), keeping only the samples at `at`, through
/// every sample ([`Jumps`] reach evenly spaced ones faster).
///
/// The forward pass runs twice instead of being stored: once over the whole signals for the
/// delays at the start of every stretch of [`STRETCH`] samples, then again stretch by stretch,
/// from the last, one stretch ahead of the backward pass. The same operations on the same
/// delays give the same bits, and nothing of the signals' length is held.
///
/// The backward pass over one stretch and the second forward pass over the one before it
/// are independent recursions, run sample for sample in one loop ([`run_pair`]): one
/// recursion alone leaves a low-pass of few sections waiting on its chain of dependent
/// operations, two side by side fill those waits.
#[inline(always)]
fn filtfilt_sampled_block<const L: usize>(
    transpose: impl Transpose,
    signals: &[&[f64]],
    at: &[usize],
    ws: &mut Workspace<L>,
    ends: Ends,
) -> Vec<Vec<f64>> {
    assert!(signals.len() <= L, "at most {L} signals per block");
    let Some(n) = signals.first().map(|s| s.len()) else {
        return Vec::new();
    };
    assert!(n > ws.pad.len(), "signals must be longer than padlen");
    let mut current = vec![[0.0; L]; STRETCH.min(n)];
    let mut ahead = current.clone();
    if signals.len() < L {
        ws.pad.fill([0.0; L]);
    }
    ws.start_forward_at(signals, ends.start);
    let starts: Vec<usize> = (0..n).step_by(STRETCH).collect();
    let mut delays = Vec::with_capacity(starts.len() * ws.sections.len());
    let mut last = [0.0; L];
    for &start in &starts {
        delays.extend(ws.sections.iter().map(Section::delays));
        let stretch = &mut current[..STRETCH.min(n - start)];
        gather(transpose, signals, start, stretch);
        run(&mut ws.sections, stretch, false);
        last = stretch[stretch.len() - 1];
    }
    if ends.end == End::Padded {
        ws.trailing_extension(signals);
    }
    let mut forward = ws.sections.clone();
    ws.start_backward_at(ends.end, last);

    let stretch_of = |index: usize| starts[index]..(starts[index] + STRETCH).min(n);
    let sections = forward.len();
    let saved = |index: usize| &delays[index * sections..(index + 1) * sections];
    let last = starts.len() - 1;
    load(
        transpose,
        signals,
        stretch_of(last),
        saved(last),
        &mut current,
        &mut forward,
    );
    run(&mut forward, &mut current[..stretch_of(last).len()], false);

    let mut out = vec![vec![0.0; at.len()]; signals.len()];
    let mut next = at.len();
    for index in (0..=last).rev() {
        let range = stretch_of(index);
        let stretch = &mut current[..range.len()];
        if index > 0 {
            let before = stretch_of(index - 1);
            load(
                transpose,
                signals,
                before,
                saved(index - 1),
                &mut ahead,
                &mut forward,
            );
            run_pair(&mut ws.sections, stretch, &mut forward, &mut ahead);
        } else {
            run(&mut ws.sections, stretch, true);
        }
        while next > 0 && at[next - 1] >= range.start {
            next -= 1;
            let sample = stretch[at[next] - range.start];
            for (o, v) in out.iter_mut().zip(sample) {
                o[next] = v;
            }
        }
        std::mem::swap(&mut current, &mut ahead);
    }
    out
}

/// [`filtfilt_sampled_all`] at evenly spaced samples, by [`Jump`], taken as the signals come:
/// [`Jumps::advance_with`] takes each stretch of samples once, from the first, and
/// [`Jumps::finish_inline`] gives the kept samples. The recursion runs only up to the first kept
/// sample (forward) and from the last one to the end and back, and the delays jump from kept
/// sample to kept sample in between, signal by signal.
///
/// Only the fourth-order low-pass of a fit's level rows (4 delays) jumps, and always with all
/// lanes: each compiled copy adds to the crate's build, and the jumps go signal by signal, so
/// a partial block's idle lanes cost little and a signal's values do not depend on its block.
pub(crate) struct Jumps {
    jump: Jump,
    /// [`Jump::weights`].
    weights: Vec<[f64; 2 * JUMP_DELAYS]>,
    at: Vec<usize>,
    ends: Ends,
    /// Samples per signal.
    n: usize,
    /// Samples taken so far.
    taken: usize,
    blocks: Vec<JumpBlock>,
}

#[cfg(test)]
mod tests {
    use super::super::End;
    use super::super::{
        filtfilt_many_unless_constant, filtfilt_sampled_unless_constant, filtfilt_unless_constant,
        sample_std, Butterworth, Ends, Response,
    };
    use super::{
        available, best, filtfilt_sampled_block, Jump, Jumps, Plain, Workspace, JUMP_DELAYS, LANES,
    };
    use proptest::prelude::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// Low-, high- or band-pass of order 1–8, edges as fractions of the sample rate (Hz)
    /// scaled to one of three sample rates, as `tests/filter_props.rs` designs them.
    /// Either kind of each end.
    fn ends_strategy() -> impl Strategy<Value = Ends> {
        let end = || prop_oneof![Just(End::Padded), Just(End::Open)];
        (end(), end()).prop_map(|(start, end)| Ends { start, end })
    }

    fn filter_strategy() -> impl Strategy<Value = Butterworth> {
        let response = prop_oneof![
            (0.05..0.45f64, 0.05..0.45f64)
                .prop_filter("distinct edges", |(a, b)| (a - b).abs() > 0.02)
                .prop_map(|(a, b)| Response::BandPass {
                    low_hz: a.min(b),
                    high_hz: a.max(b),
                }),
            (0.02..0.48f64).prop_map(|f| Response::LowPass { cutoff_hz: f }),
            (0.02..0.48f64).prop_map(|f| Response::HighPass { cutoff_hz: f }),
        ];
        (
            1usize..=8,
            response,
            prop_oneof![Just(1.0), Just(10.0), Just(160.0)],
        )
            .prop_map(|(order, response, fs)| {
                let scaled = match response {
                    Response::BandPass { low_hz, high_hz } => Response::BandPass {
                        low_hz: low_hz * fs,
                        high_hz: high_hz * fs,
                    },
                    Response::LowPass { cutoff_hz } => Response::LowPass {
                        cutoff_hz: cutoff_hz * fs,
                    },
                    Response::HighPass { cutoff_hz } => Response::HighPass {
                        cutoff_hz: cutoff_hz * fs,
                    },
                };
                Butterworth::design(order, scaled, fs).unwrap()
            })
    }

    /// A column of `n` samples of one of several shapes: noise or a sine on an offset,
    /// exactly constant, constant but for one sample, or noise too small to count as
    /// varying (sample std below `f64::EPSILON`) or right at that threshold.
    fn column(kind: u8, n: usize, rng: &mut ChaCha8Rng) -> Vec<f64> {
        let offset = [0.0, 50_000.0, -3.25][rng.random_range(0..3)];
        let scale = [1e-6, 1.0, 1e4][rng.random_range(0..3)];
        match kind {
            0 => (0..n)
                .map(|_| offset + scale * rng.random_range(-1.0..1.0))
                .collect(),
            1 => vec![offset; n],
            2 => {
                let mut x = vec![offset; n];
                x[rng.random_range(0..n)] += scale;
                x
            }
            3 => (0..n)
                .map(|_| rng.random_range(-1.0..1.0) * 1e-18)
                .collect(),
            // Uniform noise of half-width √3·a has standard deviation a: right at the
            // threshold, where a different rounding would flip the decision.
            5 => {
                let a = 3f64.sqrt() * f64::EPSILON * rng.random_range(0.9..1.1);
                (0..n).map(|_| rng.random_range(-a..a)).collect()
            }
            _ => {
                let w = rng.random_range(0.01..3.0);
                (0..n)
                    .map(|i| offset + scale * (w * i as f64).sin())
                    .collect()
            }
        }
    }

    fn columns(kinds: &[u8], n: usize, seed: u64) -> Vec<Vec<f64>> {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        kinds.iter().map(|&k| column(k, n, &mut rng)).collect()
    }

    fn read_only(columns: &[Vec<f64>]) -> Vec<&[f64]> {
        columns.iter().map(Vec::as_slice).collect()
    }

    /// Ascending samples of `0..n`: the first and last, and others at a stride drawn from
    /// `seed` (sometimes 1, so every sample, sometimes longer than a stretch of the sampled
    /// kernel, so whole stretches hold none).
    fn some_samples(n: usize, seed: u64) -> Vec<usize> {
        let stride = [1, 3, 50, 2500][(seed % 4) as usize];
        let mut at: Vec<usize> = (0..n).step_by(stride).collect();
        if at.last() != Some(&(n - 1)) {
            at.push(n - 1);
        }
        at
    }

    fn same_bits(a: &[f64], b: &[f64]) -> bool {
        a.len() == b.len() && a.iter().zip(b).all(|(x, y)| x.to_bits() == y.to_bits())
    }

    /// The same bits, or with `scale` (the largest magnitude of the signal filtered) within
    /// 1e-12 of it: the rounding of samples reached by [`Jump`]s.
    fn same_values(a: &[f64], b: &[f64], scale: Option<f64>) -> bool {
        match scale {
            None => same_bits(a, b),
            Some(scale) => {
                a.len() == b.len() && a.iter().zip(b).all(|(x, y)| (x - y).abs() <= 1e-12 * scale)
            }
        }
    }

    fn scale_of(x: &[f64]) -> f64 {
        x.iter().fold(0.0f64, |m, v| m.max(v.abs()))
    }

    proptest! {
        /// Every block width and partial blocks: 1–23 signals, from `padlen + 1` samples
        /// up, bit for bit as one signal at a time, constant signals untouched and judged
        /// constant exactly as one at a time, with the kernels this processor is given.
        #[test]
        fn blocks_equal_one_signal_at_a_time(
            f in filter_strategy(),
            kinds in prop::collection::vec(0u8..6, 1..=23),
            extra in prop_oneof![0usize..4, 0usize..200, 0usize..3000],
            seed in any::<u64>(),
        ) {
            let n = f.padlen() + 1 + extra;
            let original = columns(&kinds, n, seed);

            let mut all = original.clone();
            let mut views: Vec<&mut [f64]> = all.iter_mut().map(|c| c.as_mut_slice()).collect();
            let by_rule: Vec<bool> = original
                .iter()
                .map(|x| x.len() >= 2 && sample_std(x) <= f64::EPSILON)
                .collect();
            let kernels = best();
            prop_assert_eq!((kernels.constant)(&read_only(&original)), by_rule);
            (kernels.filtfilt_all)(&f, &mut views, Ends::WHOLE);
            for (x, y) in original.iter().zip(&all) {
                prop_assert!(same_bits(&f.filtfilt(x).unwrap(), y));
            }
            let at = some_samples(n, seed);
            let sampled = (kernels.filtfilt_sampled_all)(&f, &read_only(&original), &at, Ends::WHOLE);
            prop_assert_eq!(sampled.len(), original.len());
            let jumped = Jump::between(&f, &at).is_some();
            for ((x, whole), some) in original.iter().zip(&all).zip(&sampled) {
                let wanted: Vec<f64> = at.iter().map(|&k| whole[k]).collect();
                prop_assert!(same_values(&wanted, some, jumped.then(|| scale_of(x))));
            }

            let mut many = original.clone();
            let mut views: Vec<&mut [f64]> = many.iter_mut().map(|c| c.as_mut_slice()).collect();
            filtfilt_many_unless_constant(&f, &mut views).unwrap();
            for (x, y) in original.iter().zip(&many) {
                prop_assert!(same_bits(&filtfilt_unless_constant(&f, x).unwrap(), y));
            }
        }

        /// Every copy of the kernels this processor can run (portable, AVX2, AVX-512)
        /// gives the same bits and the same constancy decisions as the portable one.
        #[test]
        fn every_instruction_set_gives_the_same_bits(
            f in filter_strategy(),
            kinds in prop::collection::vec(0u8..6, 1..=23),
            extra in prop_oneof![0usize..4, 0usize..200, 0usize..3000],
            seed in any::<u64>(),
        ) {
            let n = f.padlen() + 1 + extra;
            let original = columns(&kinds, n, seed);
            let [portable, others @ ..] = &available()[..] else {
                unreachable!("the portable kernels are always available");
            };
            let mut expected = original.clone();
            let mut views: Vec<&mut [f64]> =
                expected.iter_mut().map(|c| c.as_mut_slice()).collect();
            let expected_constant = (portable.constant)(&read_only(&original));
            (portable.filtfilt_all)(&f, &mut views, Ends::WHOLE);
            let at = some_samples(n, seed);
            let expected_sampled = (portable.filtfilt_sampled_all)(&f, &read_only(&original), &at, Ends::WHOLE);
            for kernels in others {
                let mut got = original.clone();
                let mut views: Vec<&mut [f64]> =
                    got.iter_mut().map(|c| c.as_mut_slice()).collect();
                prop_assert_eq!(
                    &(kernels.constant)(&read_only(&original)),
                    &expected_constant,
                    "{}",
                    kernels.name
                );
                (kernels.filtfilt_all)(&f, &mut views, Ends::WHOLE);
                for (x, y) in expected.iter().zip(&got) {
                    prop_assert!(same_bits(x, y), "{}", kernels.name);
                }
                let sampled = (kernels.filtfilt_sampled_all)(&f, &read_only(&original), &at, Ends::WHOLE);
                for (x, y) in expected_sampled.iter().zip(&sampled) {
                    prop_assert!(same_bits(x, y), "{}", kernels.name);
                }
            }
        }
    }

    /// A feed for [`super::filtfilt_all_handed`] that copies `original` into signals which
    /// start as NaN, checking that it is asked for consecutive stretches from the first, at
    /// least `lookback` long but for the last, and that the stretch before is still its own.
    fn copying_feed<'o>(
        original: &'o [Vec<f64>],
        lookback: usize,
    ) -> impl FnMut(std::ops::Range<usize>, &mut [&mut [f64]]) + 'o {
        let mut before = 0..0;
        move |rows, signals| {
            assert_eq!(rows.start, before.end, "consecutive stretches");
            assert!(rows.len() >= lookback || rows.end == original[0].len());
            for (x, o) in signals.iter_mut().zip(original) {
                assert!(
                    same_bits(&x[before.clone()], &o[before.clone()]),
                    "kept unfiltered"
                );
                x[rows.clone()].copy_from_slice(&o[rows.clone()]);
            }
            before = rows;
        }
    }

    proptest! {
        /// Every copy of the kernels hands over, from any sample on and at any kind of end,
        /// exactly the bits the portable `filtfilt_all` writes back, each sample once, whether
        /// the signals are written beforehand or fed as the forward pass goes (from NaN, so a
        /// sample read before it is fed shows).
        #[test]
        fn handed_output_is_the_written_one(
            f in filter_strategy(),
            kinds in prop::collection::vec(0u8..6, 1..=23),
            extra in prop_oneof![0usize..4, 0usize..200, 0usize..3000],
            from_share in 0.0f64..1.0,
            ends in ends_strategy(),
            lookback in prop_oneof![Just(0usize), 1usize..2000],
            seed in any::<u64>(),
        ) {
            let n = f.padlen() + 1 + extra;
            let from = (from_share * n as f64) as usize;
            let original = columns(&kinds, n, seed);
            let mut expected = original.clone();
            let mut views: Vec<&mut [f64]> =
                expected.iter_mut().map(|c| c.as_mut_slice()).collect();
            (available()[0].filtfilt_all)(&f, &mut views, ends);
            for (kernels, fed) in available().into_iter().flat_map(|k| [(k, false), (k, true)]) {
                let mut scratch = match fed {
                    true => vec![vec![f64::NAN; n]; kinds.len()],
                    false => original.clone(),
                };
                let mut views: Vec<&mut [f64]> =
                    scratch.iter_mut().map(|c| c.as_mut_slice()).collect();
                let mut got = vec![vec![f64::NAN; n - from]; kinds.len()];
                let mut next = n;
                let mut nothing = |_: std::ops::Range<usize>, _: &mut [&mut [f64]]| {};
                let mut copying = copying_feed(&original, lookback);
                let mut fed = match fed {
                    true => super::Fed { feed: &mut copying, lookback },
                    false => super::Fed { feed: &mut nothing, lookback: 0 },
                };
                (kernels.filtfilt_all_handed)(&f, &mut views, ends, from, &mut fed, &mut |start, columns| {
                    // From the last stretch back to `from`, each ending where the one after starts.
                    assert_eq!(start + columns[0].len(), next);
                    assert!(start == from || start % super::HANDED == 0);
                    next = start;
                    for (g, c) in got.iter_mut().zip(columns) {
                        g[start - from..start - from + c.len()].copy_from_slice(c);
                    }
                });
                prop_assert_eq!(next, from.min(n));
                for (x, y) in expected.iter().zip(&got) {
                    prop_assert!(same_bits(&x[from..], y), "{}", kernels.name);
                }
            }
        }
    }

    proptest! {
        /// Evenly spaced kept samples, reached by [`Jump`]s, match the recursion through
        /// every sample to rounding, at every kind of end, for every block width; and the
        /// kernels of every instruction set give the same bits.
        #[test]
        fn jumps_match_the_recursion(
            f in filter_strategy().prop_filter("jumping delays", |f| 2 * f.sections().len() == JUMP_DELAYS),
            kinds in prop::collection::vec(0u8..6, 1..=11),
            extra in 0usize..3000,
            stride in prop_oneof![8usize..=64, 65usize..=700],
            first in 0usize..100,
            ends in ends_strategy(),
            seed in any::<u64>(),
            cuts_seed in any::<u64>(),
        ) {
            let n = f.padlen() + 1 + extra;
            let original = columns(&kinds, n, seed);
            let read = read_only(&original);
            let at: Vec<usize> = (first.min(n - 1)..n).step_by(stride).collect();
            prop_assume!(Jump::between(&f, &at).is_some());
            let jumps = || Jumps::new(&f, &at, ends, kinds.len(), n).expect("jumps");
            let got = taken_in_pieces(jumps, &original, cuts_seed);
            let mut ws = Workspace::<LANES>::new(&f);
            let blocks: Vec<&[&[f64]]> = read.chunks(LANES).collect();
            let mut got = got.iter();
            for block in blocks {
                let expected = filtfilt_sampled_block(Plain, block, &at, &mut ws, ends);
                for (x, e) in block.iter().zip(&expected) {
                    prop_assert!(same_values(e, got.next().expect("a signal"), Some(scale_of(x))));
                }
            }
            let [portable, others @ ..] = &available()[..] else {
                unreachable!("the portable kernels are always available");
            };
            let expected = (portable.filtfilt_sampled_all)(&f, &read, &at, ends);
            for kernels in others {
                let got = (kernels.filtfilt_sampled_all)(&f, &read, &at, ends);
                for (x, y) in expected.iter().zip(&got) {
                    prop_assert!(same_bits(x, y), "{}", kernels.name);
                }
            }
        }
    }

    /// Jumps (from `jumps`) taken through `original` in pieces cut at random (from `seed`),
    /// each at least [`Jumps::lookback`] long but for the last, every sample before the piece
    /// before the newest overwritten by NaN as a fit's band-pass would: their values, checked
    /// to be the bits of the jumps taken whole.
    fn taken_in_pieces(
        jumps: impl Fn() -> Jumps,
        original: &[Vec<f64>],
        seed: u64,
    ) -> Vec<Vec<f64>> {
        let n = original[0].len();
        let read = read_only(original);
        let mut whole = jumps();
        whole.advance(&read, n);
        let whole = whole.finish(&read);
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let mut jumps = jumps();
        let (lookback, kept) = (jumps.lookback(), jumps.at.len());
        let mut signals = original.to_vec();
        let (mut start, mut before) = (0, 0);
        while start < n {
            let end = (start + lookback + rng.random_range(0..3 * lookback)).min(n);
            for x in &mut signals {
                x[..before].fill(f64::NAN);
            }
            jumps.advance(&read_only(&signals), end);
            (before, start) = (start, end);
        }
        // The last piece's call finishes, so the piece before it is still whole.
        let got = jumps.finish(&read_only(&signals));
        assert_eq!(got.len(), original.len());
        for (w, g) in whole.iter().zip(&got) {
            assert_eq!(g.len(), kept);
            assert!(same_bits(w, g), "pieces give the whole's bits");
        }
        got
    }

    /// The processor this runs on picks the widest kernels it has, so that the tests above
    /// check what `filtfilt_many_unless_constant` runs.
    #[test]
    fn best_is_the_widest_available() {
        assert_eq!(best().name, available().last().unwrap().name);
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx2") {
            assert!(available().iter().any(|k| k.name == "AVX2"));
        }
    }

    /// Enough samples for the work to be shared among threads, with a constant signal
    /// that shifts the others between blocks.
    #[test]
    fn threads_equal_one_signal_at_a_time() {
        let f = super::super::magnav_bandpass(0.1, 0.9, 4, 10.0)
            .unwrap()
            .unwrap();
        let kinds: Vec<u8> = (0..21).map(|j| if j == 5 { 1 } else { j % 5 }).collect();
        let original = columns(&kinds, 100_003, 15);
        let mut many = original.clone();
        let mut views: Vec<&mut [f64]> = many.iter_mut().map(|c| c.as_mut_slice()).collect();
        filtfilt_many_unless_constant(&f, &mut views).unwrap();
        for (x, y) in original.iter().zip(&many) {
            assert!(same_bits(&filtfilt_unless_constant(&f, x).unwrap(), y));
        }
        assert!(same_bits(&original[5], &many[5]));

        // Evenly spaced, so jumped to; then once more unevenly, through every sample.
        let even: Vec<usize> = (7..100_003).step_by(50).collect();
        let uneven: Vec<usize> = even.iter().copied().chain([100_002]).collect();
        for at in [even, uneven] {
            let jumped = Jump::between(&f, &at).is_some();
            let sampled = filtfilt_sampled_unless_constant(&f, &read_only(&original), &at).unwrap();
            for ((x, whole), some) in original.iter().zip(&many).zip(&sampled) {
                let wanted: Vec<f64> = at.iter().map(|&k| whole[k]).collect();
                assert!(same_values(&wanted, some, jumped.then(|| scale_of(x))));
            }
        }
    }

    /// NaN and infinities propagate to the same bits too (including the sign of the NaN
    /// that `inf - inf` creates), as long as each lane keeps the scalar operand order.
    #[test]
    fn non_finite_samples_spread_alike() {
        // A low-pass's sections after the first have the numerator (1, 2, 1), whose
        // recursion is shortened; a band-pass's (1, 0, −1) are not.
        let low = Butterworth::design(3, Response::LowPass { cutoff_hz: 1.0 }, 10.0).unwrap();
        let band = super::super::magnav_bandpass(0.1, 0.9, 4, 10.0)
            .unwrap()
            .unwrap();
        for f in [low, band] {
            non_finite_samples_spread_alike_through(&f);
        }
    }

    fn non_finite_samples_spread_alike_through(f: &Butterworth) {
        let mut original = columns(&[0, 4, 0, 4, 0], 300, 7);
        original[0][100] = f64::NAN;
        original[1][0] = f64::INFINITY;
        original[2][299] = f64::NEG_INFINITY;
        original[3][150] = f64::INFINITY;
        original[3][151] = f64::NEG_INFINITY;
        for kernels in available() {
            let mut all = original.clone();
            let mut views: Vec<&mut [f64]> = all.iter_mut().map(|c| c.as_mut_slice()).collect();
            (kernels.filtfilt_all)(f, &mut views, Ends::WHOLE);
            for (x, y) in original.iter().zip(&all) {
                let alone = f.filtfilt(x).unwrap();
                let bits = |v: &[f64]| v.iter().map(|s| s.to_bits()).collect::<Vec<_>>();
                assert_eq!(bits(&alone), bits(y), "{}", kernels.name);
            }
        }
    }
}
