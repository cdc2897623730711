//! Low-frequency (heading-level) rows of a fit: per run, the low-passed design columns and
//! target (nT) at the kept samples, their centring, and the RMS misfit (nT) of coefficients.

use nalgebra::DMatrix;
use std::ops::Range;

/// Low-frequency rows of one run, before centring and weighting.
#[derive(Debug, Clone)]
pub struct LevelRows {
    /// Rows (one per kept sample), columns as the band rows.
    pub a: DMatrix<f64>,
    /// Targets (nT).
    pub y: Vec<f64>,
    /// Sample index of each row within its run, to interleave them with the band rows in time.
    pub at: Vec<usize>,
}

impl LevelRows {
    /// No rows, for `columns` columns.
    pub(super) fn none(columns: usize) -> Self {
        LevelRows {
            a: DMatrix::zeros(0, columns),
            y: Vec::new(),
            at: Vec::new(),
        }
    }

    /// The rows at `at` from the low-passed samples of each column, then of the target.
    pub(super) fn from_sampled(sampled: Vec<Vec<f64>>, at: Vec<usize>) -> Self {
        let width = sampled.len().checked_sub(1);
        Self::from_parts(width.expect("the target is filtered last"), [sampled], at)
    }

    /// [`LevelRows::from_sampled`] of the kept samples given in parts that follow each other
    /// in time (a run's windows), each with `width` columns and then the target (or empty).
    ///
    /// Each part goes straight to its place in the matrix, column by column, copied whole: an
    /// iterator over every value took 12 ms of 10⁷ samples' level rows, and columns grown part
    /// by part and then copied took fresh memory twice, with the other core idle.
    pub(super) fn from_parts(
        width: usize,
        parts: impl IntoIterator<Item = Vec<Vec<f64>>>,
        at: Vec<usize>,
    ) -> Self {
        let count = at.len();
        let mut a = vec![0.0; count * width];
        let mut y = Vec::with_capacity(count);
        for part in parts {
            if let Some((target, columns)) = part.split_last() {
                for (c, values) in columns.iter().enumerate() {
                    a[c * count + y.len()..][..values.len()].copy_from_slice(values);
                }
                y.extend_from_slice(target);
            }
        }
        LevelRows {
            a: DMatrix::from_vec(count, width, a),
            y,
            at,
        }
    }
}

/// Subtracts, from every level row's columns and target, their mean over all runs: the unknown
/// constant between the scalar and the reference is eliminated rather than fitted.
pub fn centre(rows: &mut [LevelRows]) {
    let count: usize = rows.iter().map(|r| r.y.len()).sum();
    if count == 0 {
        return;
    }
    // Column by column, the columns dealt to the cores (200 k rows of 18 columns at 10⁷
    // samples, fresh from the filters: memory-bound).
    let p = rows[0].a.ncols();
    let columns: Vec<usize> = (0..=p).collect();
    let sum_of = |c: usize| {
        rows.iter().fold(0.0, |sum, r| match c < p {
            true => sum + r.a.column(c).sum(),
            false => sum + r.y.iter().sum::<f64>(),
        })
    };
    let means =
        crate::parallel::map_items(&columns, count * (p + 1), |&c| sum_of(c) / count as f64);
    let mut parts: Vec<(&mut [f64], f64)> = Vec::with_capacity(rows.len() * (p + 1));
    for r in rows.iter_mut() {
        let n = r.y.len();
        let a = r.a.as_mut_slice().chunks_exact_mut(n.max(1));
        parts.extend(a.zip(means.iter().copied()));
        parts.push((r.y.as_mut_slice(), means[p]));
    }
    crate::parallel::for_each_item(&mut parts, count * (p + 1), |(values, mean)| {
        values.iter_mut().for_each(|v| *v -= *mean);
    });
}

/// `A·w` over the rows `rows` of the level rows' columns `a` (as many columns as `w` has):
/// each row's sum taken column after column from the empty sum, as a sum across the row would
/// be, but a column at a time (contiguous, so it vectorises): the same values.
pub(super) fn combination(a: &DMatrix<f64>, w: &[f64], rows: Range<usize>) -> Vec<f64> {
    let empty: f64 = std::iter::empty::<f64>().sum();
    let mut out = vec![empty; rows.len()];
    for (column, w) in a.as_slice().chunks_exact(a.nrows().max(1)).zip(w) {
        out.iter_mut()
            .zip(&column[rows.clone()])
            .for_each(|(o, a)| *o += a * w);
    }
    out
}

/// RMS of `y − A·β` over all level rows (nT), NaN without rows.
///
/// The fit is formed by parts of the rows on all cores ([`combination`]); the squares are then
/// added in row order: the same values as row after row.
pub fn rms_misfit(rows: &[LevelRows], beta: &[f64]) -> f64 {
    let mut sum = 0.0;
    let mut count = 0usize;
    for r in rows {
        let n = r.y.len();
        let mut squares = vec![0.0; n];
        crate::parallel::split_items(&mut squares, |part, squares| {
            let fitted = combination(&r.a, beta, part.clone());
            for ((q, y), f) in squares.iter_mut().zip(&r.y[part]).zip(&fitted) {
                *q = (y - f).powi(2);
            }
        });
        squares.iter().for_each(|q| sum += q);
        count += n;
    }
    (sum / count as f64).sqrt()
}
