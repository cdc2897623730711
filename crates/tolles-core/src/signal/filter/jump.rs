//! The kept samples of a zero-phase filter, reached a stretch at a time instead of sample by
//! sample.
//!
//! A fit's level rows keep one sample in `M` (50 at 10 Hz) of a low-pass of every column.
//! Run sample by sample, that low-pass costs three recursions over every sample (the forward
//! pass twice, so that nothing of the signal's length is stored, and the backward pass), each
//! a chain of dependent operations, and its share of a fit was as large as the band-pass's.
//!
//! The filter's sections are one linear system: with `s` the sections' delays (two each, `d`
//! in all), a sample `x` gives `y = c·s + δ·x` and leaves `s' = A·s + b·x`. From a kept
//! sample `k` to the next, `k + M`, the forward pass's delays move to
//!
//! `s(k+M) = A^M·s(k) + Σ_{l<M} A^{M−1−l}·b·x(k+l)`,
//!
//! and the backward pass's delays before it takes sample `k` are, from those before `k + M`,
//!
//! `u(k) = A^M·u(k+M) + Σ_{i=1..M} A^{i−1}·b·y(k+i) = A^M·u(k+M) + P·s(k) + Σ_{l≤M} W_l·x(k+l)`,
//!
//! the forward output `y(k+i) = c·A^i·s(k) + Σ_{l<i} c·A^{i−1−l}·b·x(k+l) + δ·x(k+i)` written
//! out, so that `P = Σ_{i=1..M} A^{i−1}·b·c·A^i` and
//! `W_l = Σ_{j≤M−1−l} A^{j+l}·b·h_j + [l ≥ 1]·A^{l−1}·b·δ` with `h_j = c·A^j·b`.
//! The filtered value at `k` is `c·u(k) + δ·(c·s(k) + δ·x(k))`. Both sums are dot products of
//! the stretch's `M + 1` samples with fixed vectors: `2d` multiply-adds per sample, with no
//! chain from one sample to the next, and the delays move once per stretch.
//!
//! The values are those of the recursion up to rounding (1e-13 of the signal's size at worst
//! in the tests), the same bits on every instruction set: the sums run in a fixed order and
//! nothing is fused.

use super::{Butterworth, SosState};
use nalgebra::{DMatrix, DVector, RowDVector};

/// Samples between kept samples below which the recursion is run instead: a stretch's
/// fixed work (three `d×d` products) is then no longer small beside its samples'.
const MIN_STRIDE: usize = 8;

/// Samples between kept samples above which the recursion is run instead, so that the
/// weights (`2d` values per sample of a stretch, built in `M²·d` operations) stay small.
const MAX_STRIDE: usize = 1024;

/// Accumulators per dot product: independent chains of additions the processor overlaps.
const CHAINS: usize = 4;

/// The matrices that move a filter's delays from one kept sample to the next, `stride`
/// samples on.
#[derive(Debug, Clone)]
pub(super) struct Jump {
    /// Samples from one kept sample to the next (`M`).
    stride: usize,
    /// Delays of the filter (`d`, two per section).
    delays: usize,
    /// `A^M`, `d×d`, row-major.
    power: Vec<f64>,
    /// `P`, `d×d`, row-major.
    p: Vec<f64>,
    /// `c`, the output's weights on the delays.
    c: Vec<f64>,
    /// `δ`, the output's weight on the sample.
    direct: f64,
    /// Per sample `l` of a stretch (`M + 1` of them): `A^{M−1−l}·b` (0 at `l = M`), then
    /// `W_l`; `2d` values each.
    weights: Vec<f64>,
}

impl Jump {
    /// The jumps of `filter` between the samples `at`, if they are evenly spaced, at least two,
    /// and at a stride worth jumping.
    pub(super) fn between(filter: &Butterworth, at: &[usize]) -> Option<Self> {
        let stride = match at {
            [first, second, ..] => second.checked_sub(*first)?,
            _ => return None,
        };
        let even = at
            .windows(2)
            .all(|w| w[1].checked_sub(w[0]) == Some(stride));
        (even && (MIN_STRIDE..=MAX_STRIDE).contains(&stride)).then(|| Self::new(filter, stride))
    }

    fn new(filter: &Butterworth, stride: usize) -> Self {
        let System { a, b, c, direct } = System::of(filter);
        let (d, m) = (b.len(), stride);
        // A^j·b for j < M, and c·A^i for i ≤ M.
        let ab: Vec<DVector<f64>> = std::iter::successors(Some(b.clone()), |v| Some(&a * v))
            .take(m)
            .collect();
        let ca: Vec<RowDVector<f64>> = std::iter::successors(Some(c.clone()), |r| Some(r * &a))
            .take(m + 1)
            .collect();
        let p = (1..=m).fold(DMatrix::zeros(d, d), |p, i| p + &ab[i - 1] * &ca[i]);
        // h_j = c·A^j·b, the impulse response after the first sample.
        let h: Vec<f64> = ca[..m].iter().map(|row| row.dot(&b.transpose())).collect();
        let mut weights = Vec::with_capacity((m + 1) * 2 * d);
        for l in 0..=m {
            match l < m {
                true => weights.extend(ab[m - 1 - l].iter()),
                false => weights.extend(std::iter::repeat_n(0.0, d)),
            }
            // W_l = Σ_{j ≤ M−1−l} A^{j+l}·b·h_j + [l ≥ 1]·A^{l−1}·b·δ.
            let through = (0..m - l).fold(DVector::zeros(d), |w, j| w + &ab[j + l] * h[j]);
            let w = match l {
                0 => through,
                _ => through + &ab[l - 1] * direct,
            };
            weights.extend(w.iter());
        }
        Self {
            stride,
            delays: d,
            power: row_major(&a.pow(m as u32)),
            p: row_major(&p),
            c: c.iter().copied().collect(),
            direct,
            weights,
        }
    }

    /// The per-sample weights as arrays of `R = 2d` values.
    #[inline(always)]
    pub(super) fn weights<const R: usize>(&self) -> Vec<[f64; R]> {
        assert_eq!(R, 2 * self.delays, "two weights per delay");
        self.weights
            .chunks_exact(R)
            .map(|w| w.try_into().expect("R values"))
            .collect()
    }

    /// The filter's output for the sample `y` taken with the delays `delays`.
    #[inline(always)]
    pub(super) fn output(&self, delays: &[f64], y: f64) -> f64 {
        weigh(&self.c, delays) + self.direct * y
    }

    /// Samples from one kept sample to the next.
    pub(super) fn stride(&self) -> usize {
        self.stride
    }

    /// `forward` taken on over `x` across every stretch from its current kept sample of `at`
    /// (evenly spaced by the stride) to the next that ends before sample `upto`, as far as
    /// the last kept sample: see [`Forward`]. Reads `x` from the current kept sample on.
    #[inline(always)]
    pub(super) fn forward_until<const D: usize, const R: usize>(
        &self,
        weights: &[[f64; R]],
        forward: &mut Forward<D>,
        x: &[f64],
        at: &[usize],
        upto: usize,
    ) {
        let mut s = forward.current;
        for &k in &at[forward.sums.len()..at.len() - 1] {
            if k + self.stride >= upto {
                break;
            }
            let both = dot_stretch(weights, &x[k..=k + self.stride]);
            forward.states.push(s);
            forward.outputs.push(self.output(&s, x[k]));
            let moved: [f64; D] = apply(&self.power, &s);
            s = std::array::from_fn(|i| moved[i] + both[i]);
            forward.sums.push(std::array::from_fn(|i| both[D + i]));
        }
        forward.current = s;
    }

    /// The filtered values at every kept sample but the last, from the forward pass's
    /// [`Forward`] and the backward pass's delays `last` before it takes the last kept sample;
    /// written into `out`.
    #[inline(always)]
    pub(super) fn backward<const D: usize>(
        &self,
        forward: &Forward<D>,
        last: [f64; D],
        out: &mut [f64],
    ) {
        let mut u = last;
        for i in (0..forward.sums.len()).rev() {
            let moved: [f64; D] = apply(&self.power, &u);
            let through: [f64; D] = apply(&self.p, &forward.states[i]);
            u = std::array::from_fn(|j| (moved[j] + through[j]) + forward.sums[i][j]);
            out[i] = self.output(&u, forward.outputs[i]);
        }
    }
}

/// What the forward pass of one signal leaves at its kept samples.
pub(super) struct Forward<const D: usize> {
    /// The delays before each kept sample whose stretch is done.
    states: Vec<[f64; D]>,
    /// The delays before the next kept sample (once all stretches are done, the last's).
    pub current: [f64; D],
    /// The output at each kept sample but the last: stored while the stretch is in the cache,
    /// since the backward pass, reading its sample again, waited on memory there.
    outputs: Vec<f64>,
    /// The backward sums `Σ W_l·x(k+l)` of the stretch from each kept sample but the last.
    sums: Vec<[f64; D]>,
}

impl<const D: usize> Forward<D> {
    /// A forward pass from the delays `start` at the first of `kept` kept samples, to be
    /// taken on by [`Jump::forward_until`].
    #[inline(always)]
    pub(super) fn new(kept: usize, start: [f64; D]) -> Self {
        Self {
            states: Vec::with_capacity(kept),
            outputs: Vec::with_capacity(kept),
            sums: Vec::with_capacity(kept.saturating_sub(1)),
            current: start,
        }
    }
}

/// `Σ_l weights[l]·x[l]` over a stretch, in [`CHAINS`] interleaved partial sums.
#[inline(always)]
#[allow(clippy::needless_range_loop)]
fn dot_stretch<const R: usize>(weights: &[[f64; R]], x: &[f64]) -> [f64; R] {
    let mut acc = [[0.0; R]; CHAINS];
    let whole = x.len() / CHAINS * CHAINS;
    for (w, v) in weights[..whole]
        .chunks_exact(CHAINS)
        .zip(x[..whole].chunks_exact(CHAINS))
    {
        for q in 0..CHAINS {
            for r in 0..R {
                acc[q][r] += w[q][r] * v[q];
            }
        }
    }
    for (q, (w, v)) in weights[whole..x.len()].iter().zip(&x[whole..]).enumerate() {
        for r in 0..R {
            acc[q][r] += w[r] * v;
        }
    }
    std::array::from_fn(|r| (acc[0][r] + acc[1][r]) + (acc[2][r] + acc[3][r]))
}

/// `m·v` for a `D×D` row-major `m`.
#[inline(always)]
fn apply<const D: usize>(m: &[f64], v: &[f64; D]) -> [f64; D] {
    std::array::from_fn(|i| weigh(&m[i * D..(i + 1) * D], v))
}

/// `Σ w_i·v_i`, in order.
#[inline(always)]
fn weigh(w: &[f64], v: &[f64]) -> f64 {
    let mut sum = 0.0;
    for (a, b) in w.iter().zip(v) {
        sum += a * b;
    }
    sum
}

/// A filter's sections as one linear system: delays `s` (each section's `z0`, `z1` in
/// turn), `y = c·s + direct·x`, `s' = a·s + b·x`.
struct System {
    a: DMatrix<f64>,
    b: DVector<f64>,
    c: RowDVector<f64>,
    direct: f64,
}

impl System {
    /// Read off the sections' recursion ([`SosState::step`]) applied to unit delays and a
    /// unit sample.
    fn of(filter: &Butterworth) -> Self {
        let d = 2 * filter.sections().len();
        let delays =
            |state: &SosState| DVector::from_iterator(d, state.state.iter().flatten().copied());
        let mut a = DMatrix::zeros(d, d);
        let mut c = RowDVector::zeros(d);
        for j in 0..d {
            let mut state = SosState::new(filter);
            state.state[j / 2][j % 2] = 1.0;
            c[j] = state.step(0.0);
            a.set_column(j, &delays(&state));
        }
        let mut state = SosState::new(filter);
        let direct = state.step(1.0);
        Self {
            a,
            b: delays(&state),
            c,
            direct,
        }
    }
}

/// The entries of `m` row by row, as [`apply`] reads them.
fn row_major(m: &DMatrix<f64>) -> Vec<f64> {
    m.transpose().as_slice().to_vec()
}
