//! The triangular factor of a tall, skinny matrix given column by column.
//!
//! A fit reduces millions of rows of a few dozen columns to the `k×k` factor `R` of
//! `[A | y] = Q·R` (see [`crate::fit::ridge`]). The rows are taken in chunks small enough to
//! stay in a core's L1 cache, and each chunk is absorbed into the factor so far by Householder
//! reflections of `[R; chunk]`: reflection j touches only row j of `R` and the chunk, so a chunk
//! costs `2·rows·k²` flops and `R` never grows. The reflections are found a panel of four
//! columns at a time and applied to the later columns together (LAPACK's compact WY form), so
//! each later column is read and written once per panel. The dot products and updates run over the
//! chunk's rows with the processor's vector instructions, chosen at run time (`pulp`); a
//! generic build would only use SSE2. Large matrices are split between the available cores and
//! their factors stacked and factored once more at the end.
//!
//! Any `R` with `RᵀR = AᵀA` serves: the rows' signs and the order the rows come in do not matter
//! to anything computed from it.

use nalgebra::DMatrix;
use pulp::{Arch, Simd, WithSimd};
use std::ops::Range;

/// Rows of one chunk: 256 rows of 24 columns are 48 KiB, about a core's L1 data cache.
const CHUNK_ROWS: usize = 256;

/// Matrix entries (rows × columns) below which one core factors the whole matrix: below it,
/// starting a thread costs more than it saves.
const PARALLEL_ENTRIES: usize = 1 << 20;

/// The upper triangular factor R (`min(m, k) × k`) of the `m×k` matrix whose column j is
/// `columns[j]` (all `m` long).
///
/// # Panics
/// If the columns differ in length: a programming error.
pub(crate) fn triangular_factor(columns: &[&[f64]]) -> DMatrix<f64> {
    let k = columns.len();
    let m = columns.first().map_or(0, |c| c.len());
    assert!(
        columns.iter().all(|c| c.len() == m),
        "columns of equal length"
    );
    let threads = if m * k < PARALLEL_ENTRIES {
        1
    } else {
        crate::parallel::cores().min(m / CHUNK_ROWS).max(1)
    };
    if threads == 1 {
        return trimmed(factor_rows(columns, 0..m), m);
    }
    let share = m.div_ceil(threads);
    let parts: Vec<DMatrix<f64>> = std::thread::scope(|scope| {
        let handles: Vec<_> = (0..threads)
            .map(|t| {
                let rows = (t * share).min(m)..((t + 1) * share).min(m);
                scope.spawn(move || factor_rows(columns, rows))
            })
            .collect();
        handles
            .into_iter()
            .map(|h| h.join().expect("a factor thread does not panic"))
            .collect()
    });
    stacked_factor(&parts)
}

/// The factor of several factors (or any blocks of rows) stacked on one another,
/// `min(rows, k) × k`.
pub(crate) fn stacked_factor(blocks: &[DMatrix<f64>]) -> DMatrix<f64> {
    let k = blocks.first().map_or(0, |b| b.ncols());
    let rows: usize = blocks.iter().map(|b| b.nrows()).sum();
    let mut m = DMatrix::zeros(rows, k);
    let mut at = 0;
    for b in blocks {
        m.rows_mut(at, b.nrows()).copy_from(b);
        at += b.nrows();
    }
    upper_factor(m)
}

/// The triangular factor R of a small matrix, `min(rows, cols) × cols`.
pub(crate) fn upper_factor(m: DMatrix<f64>) -> DMatrix<f64> {
    m.qr().r()
}

/// The first `min(m, k)` rows of a `k×k` factor of `m` rows (the others are zero).
fn trimmed(r: DMatrix<f64>, m: usize) -> DMatrix<f64> {
    let keep = m.min(r.nrows());
    r.rows(0, keep).into_owned()
}

/// The `k×k` factor of `rows` of the columns, absorbed chunk by chunk.
fn factor_rows(columns: &[&[f64]], rows: Range<usize>) -> DMatrix<f64> {
    let mut factor = RowFactor::new(columns.len());
    let part: Vec<&[f64]> = columns.iter().map(|c| &c[rows.clone()]).collect();
    factor.push(&part);
    factor.square()
}

/// The triangular factor of rows of `k` columns given a few at a time, in any order: each
/// [`CHUNK_ROWS`] rows as they fill a chunk are absorbed into the factor so far.
pub(crate) struct RowFactor {
    k: usize,
    /// Rows taken so far.
    rows: usize,
    /// Column-major, [`CHUNK_ROWS`] per column, `filled` of them taken.
    chunk: Vec<f64>,
    filled: usize,
    /// The factor of the current group, row-major `k×k`, and the chunks it has absorbed.
    r: Vec<f64>,
    absorbed: usize,
    /// Factors of the groups before.
    groups: Vec<DMatrix<f64>>,
    arch: Arch,
}

impl RowFactor {
    /// No rows yet, of `k` columns.
    pub(crate) fn new(k: usize) -> Self {
        Self {
            k,
            rows: 0,
            chunk: vec![0.0; CHUNK_ROWS * k],
            filled: 0,
            r: vec![0.0; k * k],
            absorbed: 0,
            groups: Vec::new(),
            arch: Arch::new(),
        }
    }

    /// Takes the rows of `columns` (one slice per column, all as long).
    pub(crate) fn push(&mut self, columns: &[&[f64]]) {
        debug_assert_eq!(columns.len(), self.k, "one slice per column");
        let n = columns.first().map_or(0, |c| c.len());
        let mut at = 0;
        while at < n {
            let take = (CHUNK_ROWS - self.filled).min(n - at);
            for (j, c) in columns.iter().enumerate() {
                let to = j * CHUNK_ROWS + self.filled;
                self.chunk[to..to + take].copy_from_slice(&c[at..at + take]);
            }
            self.filled += take;
            at += take;
            if self.filled == CHUNK_ROWS {
                self.absorb_chunk();
            }
        }
        self.rows += n;
    }

    /// Absorbs the rows in the chunk into the current group's factor.
    fn absorb_chunk(&mut self) {
        let (k, rows) = (self.k, self.filled);
        if rows < CHUNK_ROWS {
            // `Absorb` takes the columns one after the other.
            for j in 1..k {
                self.chunk
                    .copy_within(j * CHUNK_ROWS..j * CHUNK_ROWS + rows, j * rows);
            }
        }
        self.arch.dispatch(Absorb {
            r: &mut self.r,
            chunk: &mut self.chunk[..rows * k],
            rows,
            k,
        });
        self.filled = 0;
        self.absorbed += 1;
        if self.absorbed == GROUP_CHUNKS {
            self.close_group();
        }
    }

    /// Ends the current group: its factor joins the groups', which are stacked into one once
    /// there are [`GROUP_CHUNKS`] of them.
    fn close_group(&mut self) {
        let k = self.k;
        self.groups.push(DMatrix::from_row_slice(k, k, &self.r));
        self.r.fill(0.0);
        self.absorbed = 0;
        if self.groups.len() == GROUP_CHUNKS {
            let merged = stacked_factor(&self.groups);
            self.groups = vec![merged];
        }
    }

    /// The `k×k` factor of every row taken (zero if none).
    fn square(mut self) -> DMatrix<f64> {
        if self.filled > 0 {
            self.absorb_chunk();
        }
        if self.absorbed > 0 {
            self.close_group();
        }
        match self.groups.len() {
            0 => DMatrix::zeros(self.k, self.k),
            1 => self.groups.pop().expect("one group"),
            _ => stacked_factor(&self.groups),
        }
    }

    /// The factor of every row taken, `min(rows, k) × k`, as [`triangular_factor`] gives it.
    pub(crate) fn factor(self) -> DMatrix<f64> {
        let rows = self.rows;
        trimmed(self.square(), rows)
    }
}

/// Chunks one factor absorbs, and factors stacked at once, at most: a long chain of updates
/// would accumulate rounding like a long sum does.
const GROUP_CHUNKS: usize = 64;

/// Absorbs a column-major chunk of `rows × k` into the row-major `k×k` upper triangular `r`.
struct Absorb<'a> {
    r: &'a mut [f64],
    chunk: &'a mut [f64],
    rows: usize,
    k: usize,
}

impl WithSimd for Absorb<'_> {
    type Output = ();

    #[inline(always)]
    fn with_simd<S: Simd>(mut self, simd: S) {
        let mut first = 0;
        while first < self.k {
            let panel = PANEL.min(self.k - first);
            let tau = self.reflect_panel(simd, first..first + panel);
            if first + panel < self.k {
                self.apply_panel(simd, first, tau);
            }
            first += panel;
        }
    }
}

/// Reflections found and applied together: each column after a panel of this many is read and
/// written once for all of them rather than once per reflection (one at a time, writing the
/// columns back after every reflection bound the chunk's update by the stores). Measured on
/// one core, 5 folds of 200 000 rows × 20 columns: 45 ms against 51 ms one at a time; a
/// panel of 8 took 38 ms on two cores against 23 ms for 4 (its sums no longer fit the
/// registers).
const PANEL: usize = 4;

impl Absorb<'_> {
    /// Finds the reflections of the columns `panel` (each applied to the panel's later columns
    /// only, one at a time) and returns their `τ`, 0 for the identity. Reflection j leaves its
    /// vector `[x0 − β; x]/(x0 − β)` below the diagonal: `v = [1; x]` on rows j of `r` and the
    /// chunk's.
    #[inline(always)]
    fn reflect_panel<S: Simd>(&mut self, simd: S, panel: Range<usize>) -> [f64; PANEL] {
        let Absorb { r, chunk, rows, k } = self;
        let (rows, k) = (*rows, *k);
        let mut tau = [0.0; PANEL];
        for j in panel.clone() {
            let (done, rest) = chunk.split_at_mut((j + 1) * rows);
            let x = &mut done[j * rows..];
            let sigma = dot(simd, x, x);
            if sigma == 0.0 {
                // The chunk has nothing in this column: the reflection is the identity.
                continue;
            }
            // LAPACK's reflection: v = [1; x/(x0 − β)], H = I − τ·v·vᵀ maps [x0; x] to [β; 0].
            let x0 = r[j * k + j];
            let norm = (x0 * x0 + sigma).sqrt();
            let beta = if x0 >= 0.0 { -norm } else { norm };
            let t = (beta - x0) / beta;
            tau[j - panel.start] = t;
            scale(simd, x, 1.0 / (x0 - beta));
            r[j * k + j] = beta;
            let later = &mut rest[..(panel.end - j - 1) * rows];
            for (c, column) in (j + 1..).zip(later.chunks_exact_mut(rows)) {
                let w = r[j * k + c] + dot(simd, x, column);
                r[j * k + c] -= t * w;
                axpy(simd, x, -t * w, column);
            }
        }
        tau
    }

    /// Applies the [`PANEL`] reflections of the columns from `first` (found by
    /// [`Absorb::reflect_panel`], `τ` given) to every later column: `C ← C − V·Tᵀ·(Vᵀ·C)`, with
    /// `T` the upper triangular factor of their product `H₁⋯H_b = I − V·T·Vᵀ` (LAPACK's compact
    /// WY form).
    #[inline(always)]
    fn apply_panel<S: Simd>(&mut self, simd: S, first: usize, tau: [f64; PANEL]) {
        let Absorb { r, chunk, rows, k } = self;
        let (rows, k) = (*rows, *k);
        let (panel, later) = chunk.split_at_mut((first + PANEL) * rows);
        let x: [&[f64]; PANEL] = std::array::from_fn(|i| &panel[(first + i) * rows..][..rows]);
        let t = compact_wy(simd, x, tau);
        let mut c = first + PANEL;
        let mut groups = later.chunks_exact_mut(TOGETHER * rows);
        for group in groups.by_ref() {
            let mut columns = group.chunks_exact_mut(rows);
            let columns: [&mut [f64]; TOGETHER] =
                std::array::from_fn(|_| columns.next().expect("TOGETHER columns"));
            apply_to(simd, r, k, first, &t, x, columns, c);
            c += TOGETHER;
        }
        for column in groups.into_remainder().chunks_exact_mut(rows) {
            apply_to(simd, r, k, first, &t, x, [column], c);
            c += 1;
        }
    }
}

/// Later columns [`Absorb::apply_panel`] reads at once: `PANEL × TOGETHER` sums in registers.
const TOGETHER: usize = 2;

/// The upper triangular `T` of [`Absorb::apply_panel`]: `T[i][i] = τᵢ`, and column q above the
/// diagonal `−τ_q·T[..q][..q]·(Xᵀ·x_q)`, the rows of `r` adding nothing (each vector has its 1
/// on its own row).
#[inline(always)]
fn compact_wy<S: Simd>(simd: S, x: [&[f64]; PANEL], tau: [f64; PANEL]) -> [[f64; PANEL]; PANEL] {
    // Loops rather than closures throughout these kernels: a closure is compiled without the
    // instruction set `pulp` chose, and each vector operation in it became a call.
    let mut t = [[0.0; PANEL]; PANEL];
    for q in 0..PANEL {
        t[q][q] = tau[q];
        let mut g = [0.0; PANEL];
        for m in 0..q {
            g[m] = dot(simd, x[m], x[q]);
        }
        for (p, row) in t.iter_mut().enumerate().take(q) {
            let mut s = 0.0;
            for m in p..q {
                s += row[m] * g[m];
            }
            row[q] = -tau[q] * s;
        }
    }
    t
}

/// [`Absorb::apply_panel`] for the columns `columns` of the chunk, the first of them column `c`.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn apply_to<S: Simd, const C: usize>(
    simd: S,
    r: &mut [f64],
    k: usize,
    first: usize,
    t: &[[f64; PANEL]; PANEL],
    x: [&[f64]; PANEL],
    columns: [&mut [f64]; C],
    c: usize,
) {
    let mut w = dots_of(simd, x, &columns);
    for (i, w) in w.iter_mut().enumerate() {
        for (j, w) in w.iter_mut().enumerate() {
            *w += r[(first + i) * k + c + j];
        }
    }
    // Tᵀ·W, T being upper triangular.
    let mut f = [[0.0; C]; PANEL];
    for i in 0..PANEL {
        for j in 0..C {
            let mut s = 0.0;
            for p in 0..=i {
                s += t[p][i] * w[p][j];
            }
            f[i][j] = s;
            r[(first + i) * k + c + j] -= s;
        }
    }
    subtract_combinations(simd, x, f, columns);
}

/// `xᵢ·cⱼ` for every `i` and `j`, reading each once.
#[inline(always)]
fn dots_of<S: Simd, const C: usize>(
    simd: S,
    x: [&[f64]; PANEL],
    c: &[&mut [f64]; C],
) -> [[f64; C]; PANEL] {
    let n = S::as_simd_f64s(c[0]).0.len();
    let xh = heads::<S, PANEL>(x, n);
    let ch = heads::<S, C>(c.each_ref().map(|c| &**c), n);
    let zero = simd.splat_f64s(0.0);
    let mut acc = [[zero; C]; PANEL];
    for k in 0..n {
        for j in 0..C {
            let v = ch[j][k];
            for i in 0..PANEL {
                acc[i][j] = simd.mul_add_f64s(xh[i][k], v, acc[i][j]);
            }
        }
    }
    let done = n * S::F64_LANES;
    let mut out = [[0.0; C]; PANEL];
    for i in 0..PANEL {
        for j in 0..C {
            let mut tail = 0.0;
            for (u, v) in x[i][done..].iter().zip(&c[j][done..]) {
                tail += u * v;
            }
            out[i][j] = simd.reduce_sum_f64s(acc[i][j]) + tail;
        }
    }
    out
}

/// The first `n` vectors of each of `slices` (each holding at least `n`): one length for all,
/// so a loop over them indexes without bounds checks.
#[inline(always)]
fn heads<S: Simd, const N: usize>(slices: [&[f64]; N], n: usize) -> [&[S::f64s]; N] {
    let mut out = [&[][..]; N];
    for (o, s) in out.iter_mut().zip(slices) {
        *o = &S::as_simd_f64s(s).0[..n];
    }
    out
}

/// `cⱼ ← cⱼ − Σᵢ f[i][j]·xᵢ`, each column read and written once.
#[inline(always)]
fn subtract_combinations<S: Simd, const C: usize>(
    simd: S,
    x: [&[f64]; PANEL],
    f: [[f64; C]; PANEL],
    c: [&mut [f64]; C],
) {
    let n = S::as_simd_f64s(x[0]).0.len();
    let xh = heads::<S, PANEL>(x, n);
    let done = n * S::F64_LANES;
    for (j, column) in c.into_iter().enumerate() {
        let mut fv = [simd.splat_f64s(0.0); PANEL];
        for i in 0..PANEL {
            fv[i] = simd.splat_f64s(-f[i][j]);
        }
        let (head, tail) = S::as_mut_simd_f64s(column);
        let head = &mut head[..n];
        for (k, v) in head.iter_mut().enumerate() {
            let mut s = *v;
            for i in 0..PANEL {
                s = simd.mul_add_f64s(fv[i], xh[i][k], s);
            }
            *v = s;
        }
        for (l, v) in tail.iter_mut().enumerate() {
            for i in 0..PANEL {
                *v -= f[i][j] * x[i][done + l];
            }
        }
    }
}

/// `Σ a·b`.
#[inline(always)]
fn dot<S: Simd>(simd: S, a: &[f64], b: &[f64]) -> f64 {
    let (a_head, a_tail) = S::as_simd_f64s(a);
    let (b_head, b_tail) = S::as_simd_f64s(b);
    let mut acc = [simd.splat_f64s(0.0); 4];
    let mut pairs = a_head.chunks_exact(4).zip(b_head.chunks_exact(4));
    for (u, v) in pairs.by_ref() {
        for i in 0..4 {
            acc[i] = simd.mul_add_f64s(u[i], v[i], acc[i]);
        }
    }
    let done = a_head.len() / 4 * 4;
    for (u, v) in a_head[done..].iter().zip(&b_head[done..]) {
        acc[0] = simd.mul_add_f64s(*u, *v, acc[0]);
    }
    let sum = simd.add_f64s(simd.add_f64s(acc[0], acc[1]), simd.add_f64s(acc[2], acc[3]));
    let tail: f64 = a_tail.iter().zip(b_tail).map(|(u, v)| u * v).sum();
    simd.reduce_sum_f64s(sum) + tail
}

/// `x ← x·s`.
#[inline(always)]
fn scale<S: Simd>(simd: S, x: &mut [f64], s: f64) {
    let (head, tail) = S::as_mut_simd_f64s(x);
    let sv = simd.splat_f64s(s);
    for v in head {
        *v = simd.mul_f64s(*v, sv);
    }
    tail.iter_mut().for_each(|v| *v *= s);
}

/// `c ← c + f·x`.
#[inline(always)]
fn axpy<S: Simd>(simd: S, x: &[f64], f: f64, c: &mut [f64]) {
    let (x_head, x_tail) = S::as_simd_f64s(x);
    let (c_head, c_tail) = S::as_mut_simd_f64s(c);
    let fv = simd.splat_f64s(f);
    for (u, v) in x_head.iter().zip(c_head) {
        *v = simd.mul_add_f64s(fv, *u, *v);
    }
    for (u, v) in x_tail.iter().zip(c_tail) {
        *v += f * u;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn columns(m: usize, k: usize, seed: f64) -> Vec<Vec<f64>> {
        (0..k)
            .map(|j| {
                (0..m)
                    .map(|i| ((i * (j + 2)) as f64 * 0.37 + seed).sin() * (j + 1) as f64)
                    .collect()
            })
            .collect()
    }

    fn gram(r: &DMatrix<f64>) -> DMatrix<f64> {
        r.transpose() * r
    }

    fn assert_same_gram(got: &DMatrix<f64>, want: &DMatrix<f64>) {
        let (g, w) = (gram(got), gram(want));
        let scale = w.diagonal().iter().fold(0.0f64, |m, v| m.max(v.abs()));
        for (u, v) in g.iter().zip(w.iter()) {
            assert!((u - v).abs() <= 1e-12 * scale, "{u} vs {v}");
        }
        for i in 0..got.nrows() {
            for j in 0..i {
                assert_eq!(got[(i, j)], 0.0, "upper triangular");
            }
        }
    }

    fn direct(cols: &[Vec<f64>]) -> DMatrix<f64> {
        let m = cols[0].len();
        DMatrix::from_fn(m, cols.len(), |i, j| cols[j][i]).qr().r()
    }

    #[test]
    fn chunked_and_parallel_factors_equal_one_householder_qr() {
        for m in [
            3,
            50,
            CHUNK_ROWS + 7,
            (PARALLEL_ENTRIES / 8) + 3 * CHUNK_ROWS + 5,
        ] {
            let cols = columns(m, 9, 0.2);
            let refs: Vec<&[f64]> = cols.iter().map(Vec::as_slice).collect();
            let r = triangular_factor(&refs);
            assert_eq!(r.shape(), (m.min(9), 9));
            assert_same_gram(&r, &direct(&cols));
        }
    }

    #[test]
    fn a_dependent_column_gives_a_zero_on_the_diagonal() {
        let mut cols = columns(5000, 4, 1.0);
        cols[2] = cols[0].iter().map(|v| 2.0 * v).collect();
        let refs: Vec<&[f64]> = cols.iter().map(Vec::as_slice).collect();
        let r = triangular_factor(&refs);
        assert!(r[(2, 2)].abs() < 1e-9 * r[(0, 0)].abs());
        assert_same_gram(&r, &direct(&cols));
    }

    #[test]
    fn a_zero_column_inside_a_panel_leaves_the_later_columns_right() {
        // Its reflection is the identity (τ = 0), which the panel's product must leave out.
        for zero in [0, 2, 3, 5] {
            let mut cols = columns(3 * CHUNK_ROWS + 11, 11, 0.4);
            cols[zero].fill(0.0);
            let refs: Vec<&[f64]> = cols.iter().map(Vec::as_slice).collect();
            assert_same_gram(&triangular_factor(&refs), &direct(&cols));
        }
    }

    /// [`RowFactor`] of `cols` given in pieces cut at `cuts` (fractions of the rows).
    fn in_pieces(cols: &[Vec<f64>], cuts: &[f64]) -> DMatrix<f64> {
        let m = cols[0].len();
        let mut at: Vec<usize> = cuts.iter().map(|c| (c * m as f64) as usize).collect();
        at.extend([0, m]);
        at.sort_unstable();
        let mut factor = RowFactor::new(cols.len());
        for w in at.windows(2) {
            let piece: Vec<&[f64]> = cols.iter().map(|c| &c[w[0]..w[1]]).collect();
            factor.push(&piece);
        }
        factor.factor()
    }

    #[test]
    fn rows_in_pieces_across_groups_give_one_factor_s_bits() {
        let cols = columns((GROUP_CHUNKS + 1) * CHUNK_ROWS + 17, 3, 0.7);
        let refs: Vec<&[f64]> = cols.iter().map(Vec::as_slice).collect();
        let whole = triangular_factor(&refs);
        assert_eq!(in_pieces(&cols, &[0.3, 0.31, 0.9]), whole);
        assert_same_gram(&whole, &direct(&cols));
    }

    proptest! {
        /// However the rows are cut into pieces, the chunks are the same, and so are the bits.
        #[test]
        fn rows_in_pieces_give_one_factor_s_bits(
            m in 1usize..2000,
            k in 1usize..11,
            cuts in prop::collection::vec(0.0f64..1.0, 0..6),
            seed in -3.0f64..3.0,
        ) {
            let cols = columns(m, k, seed);
            let refs: Vec<&[f64]> = cols.iter().map(Vec::as_slice).collect();
            prop_assert_eq!(in_pieces(&cols, &cuts), triangular_factor(&refs));
        }

        #[test]
        fn the_factor_reproduces_the_gram_matrix(m in 1usize..700, k in 1usize..26, seed in -3.0f64..3.0) {
            let cols = columns(m, k, seed);
            let refs: Vec<&[f64]> = cols.iter().map(Vec::as_slice).collect();
            assert_same_gram(&triangular_factor(&refs), &direct(&cols));
        }
    }
}
