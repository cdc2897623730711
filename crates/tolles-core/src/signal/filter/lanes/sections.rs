//! The second-order sections run over interleaved samples: loading, gathering and scattering
//! lanes, and the recursions compiled for each section count and numerator form.

use super::*;

/// [`run`] of the two sections of a filter with [`JUMP_DELAYS`] delays: [`Jumps`]'s three
/// recursions each compile two forms instead of all of [`run`]'s.
#[inline(always)]
pub(super) fn run_two<const L: usize>(
    sections: &mut [Section<L>],
    data: &mut [[f64; L]],
    backward: bool,
) {
    match sections {
        [a, b] => match b.form {
            Numerator::Band => run_fixed::<L, 2, BAND>(&mut [a, b], data, backward),
            Numerator::General => run_fixed::<L, 2, GENERAL>(&mut [a, b], data, backward),
        },
        _ => unreachable!("a filter with {JUMP_DELAYS} delays has two sections"),
    }
}

/// Delays of the filters whose kept samples [`Jumps`] reach: a fourth-order low-pass's.
pub(super) const JUMP_DELAYS: usize = 4;

/// Lane `l`'s delays of every section, `z0` then `z1` of each in turn.
#[inline(always)]
pub(super) fn delays_of<const L: usize, const D: usize>(
    sections: &[Section<L>],
    l: usize,
) -> [f64; D] {
    std::array::from_fn(|i| {
        let s = &sections[i / 2];
        match i % 2 {
            0 => s.z0[l],
            _ => s.z1[l],
        }
    })
}

/// Sets lane `l`'s delays of every section, the inverse of [`delays_of`].
#[inline(always)]
pub(super) fn set_delays_of<const L: usize, const D: usize>(
    sections: &mut [Section<L>],
    l: usize,
    delays: &[f64; D],
) {
    for (s, pair) in sections.iter_mut().zip(delays.chunks_exact(2)) {
        s.z0[l] = pair[0];
        s.z1[l] = pair[1];
    }
}

/// Loads the samples `range` of `signals` into `buffer`, and the forward pass's delays at its
/// start, `saved`, into `forward`.
///
/// A function rather than a closure of [`filtfilt_sampled_block`]: the closure was compiled
/// on its own (5 % of a 10⁶-sample fit's `perf` samples under its own name), outside the
/// `#[inline(always)]` chain that puts every helper into the kernels' instruction sets.
#[inline(always)]
pub(super) fn load<const L: usize>(
    transpose: impl Transpose,
    signals: &[&[f64]],
    range: std::ops::Range<usize>,
    saved: &[[[f64; L]; 2]],
    buffer: &mut [[f64; L]],
    forward: &mut [Section<L>],
) {
    for (s, d) in forward.iter_mut().zip(saved) {
        s.set_delays(d);
    }
    gather(transpose, signals, range.start, &mut buffer[..range.len()]);
}

/// Interleaves samples `start..start + tile.len()` of `signals` (at most `L`) into `tile`,
/// one signal per lane; lanes without a signal are set to 0.
///
/// Eight samples of every signal are read at once and transposed (`transpose`). Writing each
/// signal's samples down its lane instead is a strided store, which the compiler turns into
/// AVX-512 scatter instructions: they took half the time of a low-pass of 19 signals.
#[inline(always)]
pub(super) fn gather<const L: usize, S: AsRef<[f64]>>(
    transpose: impl Transpose,
    signals: &[S],
    start: usize,
    tile: &mut [[f64; L]],
) {
    const { assert!(L <= GROUP, "a tile's lanes fit a transposed block") };
    let len = tile.len();
    let columns: [&[f64]; L] = std::array::from_fn(|l| match signals.get(l) {
        Some(x) => &x.as_ref()[start..start + len],
        None => &[],
    });
    let mut groups = tile.chunks_exact_mut(GROUP);
    let mut t = 0;
    for rows in &mut groups {
        let mut block = [[0.0; GROUP]; GROUP];
        for (b, x) in block.iter_mut().zip(&columns) {
            if let Some(x) = x.get(t..t + GROUP) {
                b.copy_from_slice(x);
            }
        }
        let block = transpose.transpose8(&block);
        for (row, b) in rows.iter_mut().zip(&block) {
            *row = std::array::from_fn(|l| b[l]);
        }
        t += GROUP;
    }
    for (i, row) in groups.into_remainder().iter_mut().enumerate() {
        *row = std::array::from_fn(|l| columns[l].get(t + i).copied().unwrap_or(0.0));
    }
}

/// The inverse of [`gather`], by the same transposes of eight samples.
#[inline(always)]
pub(super) fn scatter<const L: usize, S: AsMut<[f64]>>(
    transpose: impl Transpose,
    tile: &[[f64; L]],
    start: usize,
    signals: &mut [S],
) {
    const { assert!(L <= GROUP, "a tile's lanes fit a transposed block") };
    let mut groups = tile.chunks_exact(GROUP);
    let mut t = start;
    for rows in &mut groups {
        let mut block = [[0.0; GROUP]; GROUP];
        for (b, row) in block.iter_mut().zip(rows) {
            b[..L].copy_from_slice(row);
        }
        let block = transpose.transpose8(&block);
        for (x, b) in signals.iter_mut().zip(&block) {
            x.as_mut()[t..t + GROUP].copy_from_slice(b);
        }
        t += GROUP;
    }
    for (i, row) in groups.remainder().iter().enumerate() {
        for (x, v) in signals.iter_mut().zip(row) {
            x.as_mut()[t + i] = *v;
        }
    }
}

/// A hint to bring the cache line holding `values` into the L1 cache; it reads nothing.
#[inline(always)]
pub(super) fn prefetch_line(values: &[f64]) {
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::x86_64::{_mm_prefetch, _MM_HINT_T0};
        // SAFETY: a prefetch only hints at an address (here of live data) and never faults.
        unsafe { _mm_prefetch::<_MM_HINT_T0>(values.as_ptr().cast()) };
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = values;
}

/// Samples transposed at once between signals and a tile.
pub(super) const GROUP: usize = 8;

/// Runs `data` (time-major, oldest sample first) through all sections in place, forward
/// in time or, if `backward`, from the last sample to the first, carrying the delays on.
#[inline(always)]
pub(super) fn run<const L: usize>(
    sections: &mut [Section<L>],
    data: &mut [[f64; L]],
    backward: bool,
) {
    // A fixed number of sections copied into locals keeps the delays in registers for
    // the tile; through the slice they go to memory and back every sample, which lengthens
    // each section's chain of dependent operations by the store-to-load latency.
    // A band-pass's gain sits in its first section; the others' multiplications by 1, −1
    // and 0 are left out ([`Numerator`]).
    let tail = tail_form(sections);
    match (sections, tail) {
        ([a, b], Numerator::Band) => run_fixed::<L, 2, BAND>(&mut [a, b], data, backward),
        ([a, b, c], Numerator::Band) => run_fixed::<L, 3, BAND>(&mut [a, b, c], data, backward),
        ([a, b, c, d], Numerator::Band) => {
            run_fixed::<L, 4, BAND>(&mut [a, b, c, d], data, backward)
        }
        ([a], _) => run_fixed::<L, 1, GENERAL>(&mut [a], data, backward),
        ([a, b], _) => run_fixed::<L, 2, GENERAL>(&mut [a, b], data, backward),
        ([a, b, c], _) => run_fixed::<L, 3, GENERAL>(&mut [a, b, c], data, backward),
        ([a, b, c, d], _) => run_fixed::<L, 4, GENERAL>(&mut [a, b, c, d], data, backward),
        // Filters of more sections are computed in the general form (see
        // `Numerator::MOST_BAND_SECTIONS`).
        (sections, _) => {
            if backward {
                for v in data.iter_mut().rev() {
                    step::<L, GENERAL>(sections.iter_mut(), v);
                }
            } else {
                for v in data.iter_mut() {
                    step::<L, GENERAL>(sections.iter_mut(), v);
                }
            }
        }
    }
}

/// The form of the sections after the first ([`Butterworth::forms`] gives them all one).
#[inline(always)]
pub(super) fn tail_form<const L: usize>(sections: &[Section<L>]) -> Numerator {
    sections.get(1).map_or(Numerator::General, |s| s.form)
}

/// [`run`] backward over `back` with `back_sections` and forward over `ahead` (at least as
/// long) with `ahead_sections`, the two recursions a sample of each per step, so the processor
/// overlaps their chains; each gets exactly the operations [`run`] gives it.
#[inline(always)]
pub(super) fn run_pair<const L: usize>(
    back_sections: &mut [Section<L>],
    back: &mut [[f64; L]],
    ahead_sections: &mut [Section<L>],
    ahead: &mut [[f64; L]],
) {
    let tail = tail_form(back_sections);
    let (together, rest) = ahead.split_at_mut(back.len());
    match (&mut *back_sections, &mut *ahead_sections, tail) {
        ([a, b], [c, d], Numerator::Band) => {
            run_pair_fixed::<L, 2, BAND>([a, b], back, [c, d], together)
        }
        ([a, b], [c, d], Numerator::General) => {
            run_pair_fixed::<L, 2, GENERAL>([a, b], back, [c, d], together)
        }
        ([a], [c], _) => run_pair_fixed::<L, 1, GENERAL>([a], back, [c], together),
        _ => {
            // More sections fill the arithmetic units on their own.
            run(back_sections, back, true);
            run(ahead_sections, together, false);
        }
    }
    run(ahead_sections, rest, false);
}

/// [`run_pair`] with `S` sections in locals, as [`run_fixed`].
#[inline(always)]
pub(super) fn run_pair_fixed<const L: usize, const S: usize, const TAIL: u8>(
    back_sections: [&mut Section<L>; S],
    back: &mut [[f64; L]],
    ahead_sections: [&mut Section<L>; S],
    ahead: &mut [[f64; L]],
) {
    let mut b: [Section<L>; S] = std::array::from_fn(|k| *back_sections[k]);
    let mut f: [Section<L>; S] = std::array::from_fn(|k| *ahead_sections[k]);
    for (u, v) in back.iter_mut().rev().zip(ahead.iter_mut()) {
        step::<L, TAIL>(b.iter_mut(), u);
        step::<L, TAIL>(f.iter_mut(), v);
    }
    for (s, l) in back_sections.into_iter().zip(b) {
        *s = l;
    }
    for (s, l) in ahead_sections.into_iter().zip(f) {
        *s = l;
    }
}

/// [`run`] with `S` sections, copied in and back out; every section but the first has the
/// numerator form `TAIL`.
#[inline(always)]
pub(super) fn run_fixed<const L: usize, const S: usize, const TAIL: u8>(
    sections: &mut [&mut Section<L>; S],
    data: &mut [[f64; L]],
    backward: bool,
) {
    let mut local: [Section<L>; S] = std::array::from_fn(|k| *sections[k]);
    if backward {
        for v in data.iter_mut().rev() {
            step::<L, TAIL>(local.iter_mut(), v);
        }
    } else {
        for v in data.iter_mut() {
            step::<L, TAIL>(local.iter_mut(), v);
        }
    }
    for (s, l) in sections.iter_mut().zip(local) {
        **s = l;
    }
}

/// One sample of every lane through all sections: [`super::SosState::step`]'s arithmetic
/// per lane, operation for operation (transposed direct form II, no fused multiply-add,
/// which Rust never introduces on its own). The sections after the first take the form
/// `TAIL` ([`Numerator`]): with `BAND`, only their multiplications by `a1` and `−a2` are
/// left, as in the scalar recursion.
///
/// All sections per sample rather than one section over many samples: consecutive
/// sections are further independent chains the processor overlaps (measured about 2×
/// faster than section by section).
#[inline(always)]
// Indexing every array by lane keeps the line-for-line match with the scalar recursion
// visible; the compiler turns the fixed-length loop into vector instructions either way.
#[allow(clippy::needless_range_loop)]
pub(super) fn step<'a, const L: usize, const TAIL: u8>(
    sections: impl Iterator<Item = &'a mut Section<L>>,
    v: &mut [f64; L],
) {
    for (k, s) in sections.enumerate() {
        match if k > 0 { TAIL } else { GENERAL } {
            BAND => {
                // Whole arrays per formula: as one loop over the lanes, the compiler cut it
                // into partial vectors and shuffles (1.4× slower than the general form).
                let x = *v;
                let y: [f64; L] = std::array::from_fn(|l| x[l] + s.z0[l]);
                s.z0 = std::array::from_fn(|l| s.z1[l] - s.a1[l] * y[l]);
                s.z1 = std::array::from_fn(|l| s.minus_a2[l] * y[l] - x[l]);
                *v = y;
            }
            _ => {
                for l in 0..L {
                    let x = v[l];
                    let y = s.b0[l] * x + s.z0[l];
                    s.z0[l] = s.b1[l] * x - s.a1[l] * y + s.z1[l];
                    s.z1[l] = s.b2[l] * x - s.a2[l] * y;
                    v[l] = y;
                }
            }
        }
    }
}

/// [`Numerator`]s as `step`'s constant parameter.
pub(super) const GENERAL: u8 = Numerator::General as u8;
pub(super) const BAND: u8 = Numerator::Band as u8;

/// A section's coefficients (dimensionless) repeated in every lane, so the vector loop
/// loads them rather than broadcasting a scalar every sample, next to its two delays per
/// lane (in the units of the signal).
#[derive(Debug, Clone, Copy)]
pub(super) struct Section<const L: usize> {
    pub(super) b0: [f64; L],
    pub(super) b1: [f64; L],
    pub(super) b2: [f64; L],
    pub(super) a1: [f64; L],
    pub(super) a2: [f64; L],
    /// `−a2`, for [`Numerator::Band`].
    pub(super) minus_a2: [f64; L],
    pub(super) z0: [f64; L],
    pub(super) z1: [f64; L],
    /// How [`step`] computes it.
    pub(super) form: Numerator,
}

impl<const L: usize> Section<L> {
    /// The delays `[z0, z1]`, per lane.
    #[inline(always)]
    pub(super) fn delays(&self) -> [[f64; L]; 2] {
        [self.z0, self.z1]
    }

    #[inline(always)]
    pub(super) fn set_delays(&mut self, &[z0, z1]: &[[f64; L]; 2]) {
        self.z0 = z0;
        self.z1 = z1;
    }

    /// From `[b0, b1, b2, a0, a1, a2]` with `a0 = 1`, computed in `form`, delays at rest.
    pub(super) fn new(&[b0, b1, b2, _, a1, a2]: &[f64; 6], form: Numerator) -> Self {
        Self {
            b0: [b0; L],
            b1: [b1; L],
            b2: [b2; L],
            a1: [a1; L],
            a2: [a2; L],
            minus_a2: [-a2; L],
            z0: [0.0; L],
            z1: [0.0; L],
            form,
        }
    }
}
