//! Ridge least squares by blocked Householder QR, never forming `AᵀA`.
//!
//! ```
//! use nalgebra::DMatrix;
//! use tolles_core::fit::ridge::ridge;
//! let a = DMatrix::from_row_slice(3, 1, &[1.0, 2.0, 3.0]);
//! let beta = ridge(&a, &[2.0, 4.0, 6.0], 0.0).unwrap().coefficients;
//! assert!((beta[0] - 2.0).abs() < 1e-12);
//! ```
//!
//! `(AᵀA + Λ)·β = Aᵀy` with a diagonal penalty `Λ` is the least-squares problem
//! `[A; √Λ]·β ≈ [y; 0]`. We keep only the `(p+1)×(p+1)` triangular factor `R0` of `[A | y]`,
//! updated block by block (TSQR), so rows can come from any number of runs, folds or files, and
//! the condition number is that of `A`, not its square: on MagNav's test flight
//! `cond(AᵀA) ≈ 4·10⁷`, which normal equations would turn into a loss of about eight digits.
//! Since `[A | y] = Q·R0`, the residual of any β on these rows is `‖R0·[β; −1]‖`, which is what
//! makes cross-validation over folds cheap (see [`crate::fit::crossval`]).

use crate::fit::qr::{stacked_factor, triangular_factor, upper_factor};
use nalgebra::{DMatrix, DVector};
use thiserror::Error;

/// Rows gathered before the triangular factor is updated (bounds memory).
const BLOCK_ROWS: usize = 4096;

/// A least-squares problem that cannot be solved.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum RidgeError {
    /// The design matrix is singular: one column is a combination of others.
    #[error("the design matrix is singular (column {column} is a combination of others); use a ridge strength λ > 0 or fewer terms")]
    Singular {
        /// Name of the design column that is a combination of others.
        column: String,
    },
}

/// Incremental least squares: the triangular factor of `[A | y]` for the rows pushed so far.
#[derive(Debug, Clone)]
pub struct Ridge {
    p: usize,
    r: DMatrix<f64>,
    pending: Vec<f64>,
    pending_rows: usize,
    rows: usize,
}

impl Ridge {
    /// An empty problem with `p` unknowns.
    pub fn new(p: usize) -> Self {
        Self {
            p,
            r: DMatrix::zeros(0, p + 1),
            pending: Vec::new(),
            pending_rows: 0,
            rows: 0,
        }
    }

    /// Rows pushed so far.
    pub fn rows(&self) -> usize {
        self.rows
    }

    /// Adds one row `a` (p values) with target `y`.
    pub fn push_row(&mut self, a: impl IntoIterator<Item = f64>, y: f64) {
        let before = self.pending.len();
        self.pending.extend(a);
        assert_eq!(self.pending.len() - before, self.p, "design width");
        self.pending.push(y);
        self.pending_rows += 1;
        self.rows += 1;
        if self.pending_rows == BLOCK_ROWS {
            self.flush();
        }
    }

    /// Adds the rows of `a` (n×p) with targets `y` (n).
    pub fn push(&mut self, a: &DMatrix<f64>, y: &[f64]) {
        assert_eq!(a.nrows(), y.len(), "one target per row");
        for (k, target) in y.iter().enumerate() {
            self.push_row(a.row(k).iter().copied(), *target);
        }
    }

    /// Adds rows given column by column: `columns[j][k]` is column j of row k (p columns, equally
    /// long), `y[k]` its target. Faster than row by row for column-major data.
    pub fn push_columns(&mut self, columns: &[&[f64]], y: &[f64]) {
        assert_eq!(columns.len(), self.p, "design width");
        assert!(
            columns.iter().all(|c| c.len() == y.len()),
            "one target per row"
        );
        let mut all = columns.to_vec();
        all.push(y);
        self.push_factor(&triangular_factor(&all), y.len());
    }

    /// A problem of `p` unknowns holding `rows` rows whose `[A | y]` has the triangular factor
    /// `r` (`(p+1)` columns, at most `p+1` rows).
    pub(crate) fn from_factor(p: usize, r: DMatrix<f64>, rows: usize) -> Self {
        assert_eq!(r.ncols(), p + 1, "design width");
        Self {
            p,
            r,
            pending: Vec::new(),
            pending_rows: 0,
            rows,
        }
    }

    /// Adds `rows` rows given by the triangular factor `r` of their `[A | y]`.
    pub(crate) fn push_factor(&mut self, r: &DMatrix<f64>, rows: usize) {
        assert_eq!(r.ncols(), self.p + 1, "design width");
        self.flush();
        self.r = stacked_factor(&[
            std::mem::replace(&mut self.r, DMatrix::zeros(0, 0)),
            r.clone(),
        ]);
        self.rows += rows;
    }

    /// Adds all rows of another problem of the same width.
    pub fn merge(&mut self, other: &Ridge) {
        assert_eq!(self.p, other.p, "design width");
        let mut other = other.clone();
        other.flush();
        self.flush();
        self.r = upper_factor(stack(&self.r, &other.r));
        self.rows += other.rows;
    }

    fn flush(&mut self) {
        if self.pending_rows == 0 {
            return;
        }
        // Column-major, the block's factor comes from the vectorised kernel.
        let block = DMatrix::from_row_slice(self.pending_rows, self.p + 1, &self.pending);
        let columns: Vec<&[f64]> = block.as_slice().chunks_exact(self.pending_rows).collect();
        self.r = upper_factor(stack(&self.r, &triangular_factor(&columns)));
        self.pending.clear();
        self.pending_rows = 0;
    }

    /// The diagonal of `AᵀA`: each column's sum of squares.
    pub fn column_sums_of_squares(&self) -> Vec<f64> {
        let mut me = self.clone();
        me.flush();
        (0..self.p).map(|j| me.r.column(j).norm_squared()).collect()
    }

    /// `‖y − A·β‖²` over the rows pushed so far.
    pub fn residual_sum_of_squares(&self, beta: &[f64]) -> f64 {
        let mut me = self.clone();
        me.flush();
        if me.r.nrows() == 0 {
            return 0.0;
        }
        let mut extended = DVector::from_element(self.p + 1, -1.0);
        extended.rows_mut(0, self.p).copy_from_slice(beta);
        (&me.r * extended).norm_squared()
    }

    /// Solves `(AᵀA + λI)·β = Aᵀy`; `columns` name the unknowns in errors.
    pub fn solve(&self, lambda: f64, columns: &[String]) -> Result<RidgeSolution, RidgeError> {
        self.solve_penalised(&vec![lambda; self.p], columns)
    }

    /// Solves `(AᵀA + diag(penalty))·β = Aᵀy`.
    pub fn solve_penalised(
        &self,
        penalty: &[f64],
        columns: &[String],
    ) -> Result<RidgeSolution, RidgeError> {
        let p = self.p;
        let mut me = self.clone();
        me.flush();
        let mut rows = DMatrix::zeros(p, p + 1);
        for (j, lambda) in penalty.iter().enumerate() {
            rows[(j, j)] = lambda.sqrt();
        }
        let r = upper_factor(stack(&me.r, &rows));
        let r_a = r.view((0, 0), (p, p)).into_owned();
        let qty = r.view((0, p), (p, 1)).column(0).into_owned();
        check_rank(&r_a, columns)?;
        let beta = r_a
            .solve_upper_triangular(&qty)
            .expect("nonsingular after the rank check");
        let coefficients: Vec<f64> = beta.iter().copied().collect();
        Ok(RidgeSolution {
            rss: me.residual_sum_of_squares(&coefficients),
            coefficients,
            r_a,
            penalty: penalty.to_vec(),
            rows: self.rows,
        })
    }
}

fn stack(top: &DMatrix<f64>, bottom: &DMatrix<f64>) -> DMatrix<f64> {
    let mut m = DMatrix::zeros(top.nrows() + bottom.nrows(), top.ncols());
    m.rows_mut(0, top.nrows()).copy_from(top);
    m.rows_mut(top.nrows(), bottom.nrows()).copy_from(bottom);
    m
}

fn check_rank(r_a: &DMatrix<f64>, columns: &[String]) -> Result<(), RidgeError> {
    let largest = r_a.diagonal().iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let tolerance = largest * f64::EPSILON * r_a.nrows() as f64 * 10.0;
    match r_a.diagonal().iter().position(|v| v.abs() <= tolerance) {
        Some(j) => Err(RidgeError::Singular {
            column: columns.get(j).cloned().unwrap_or_else(|| format!("#{j}")),
        }),
        None => Ok(()),
    }
}

/// A solved ridge problem.
#[derive(Debug, Clone)]
pub struct RidgeSolution {
    /// β, one per column.
    pub coefficients: Vec<f64>,
    /// Triangular factor of `AᵀA + Λ = RᵀR`.
    r_a: DMatrix<f64>,
    penalty: Vec<f64>,
    /// Residual sum of squares `‖y − Aβ‖²` (units of y squared).
    pub rss: f64,
    /// Rows in the problem.
    pub rows: usize,
}

impl RidgeSolution {
    /// The diagonal penalty Λ that was added to `AᵀA`.
    pub fn penalty(&self) -> &[f64] {
        &self.penalty
    }

    /// Condition number (2-norm) of `AᵀA + Λ`, estimated as `(max|Rⱼⱼ| / min|Rⱼⱼ|)²` from the
    /// triangular factor: a lower bound that is usually within a small factor of the true value.
    /// An SVD would be exact but iterates, and on extreme data (entries near 1e150) it can
    /// spin for minutes; this is a fixed p steps.
    pub fn condition_number(&self) -> f64 {
        let (max, min) = self
            .r_a
            .diagonal()
            .iter()
            .fold((0.0f64, f64::INFINITY), |(a, b), v| {
                (a.max(v.abs()), b.min(v.abs()))
            });
        (max / min).powi(2)
    }

    /// The posterior covariance of β, `nu·(AᵀA + Λ)⁻¹` (coefficient units squared), for the
    /// variance `nu` of one independent residual: the penalty read as a Gaussian prior of
    /// precision `Λ/nu` (see [`crate::fit::prior`]), so coefficients the rows hardly determine
    /// keep the prior's uncertainty. NaN where the factor cannot be inverted.
    pub fn covariance(&self, nu: f64) -> DMatrix<f64> {
        self.g_inverse() * nu
    }

    /// `G⁻¹ = (AᵀA + Λ)⁻¹ = R⁻¹R⁻ᵀ` from the triangular factor; NaN where it cannot be
    /// inverted.
    fn g_inverse(&self) -> DMatrix<f64> {
        let p = self.r_a.nrows();
        let r_inv = self
            .r_a
            .clone()
            .try_inverse()
            .unwrap_or_else(|| DMatrix::from_element(p, p, f64::NAN));
        &r_inv * r_inv.transpose()
    }

    /// The sandwich covariance `G⁻¹·S·G⁻¹` of β, `G = AᵀA + Λ`, for the scores' covariance
    /// `middle` (`S`; `ν·AᵀA` for white residuals of variance ν).
    pub fn sandwich(&self, middle: &DMatrix<f64>) -> DMatrix<f64> {
        let g_inv = self.g_inverse();
        &g_inv * middle * &g_inv
    }

    /// Standard errors of β for residual variance `sigma2`, from the ridge sandwich covariance
    /// `σ²·G⁻¹·AᵀA·G⁻¹ = σ²·(G⁻¹ − G⁻¹ΛG⁻¹)`, `G = AᵀA + Λ`.
    pub fn std_errors(&self, sigma2: f64) -> Vec<f64> {
        let p = self.r_a.nrows();
        let g_inv = self.g_inverse();
        let lambda = DMatrix::from_diagonal(&DVector::from_column_slice(&self.penalty));
        let covariance = &g_inv - &g_inv * lambda * &g_inv;
        (0..p)
            .map(|j| (sigma2 * covariance[(j, j)].max(0.0)).sqrt())
            .collect()
    }
}

/// Solves `(AᵀA + λI)·β = Aᵀy` for a ready-made design matrix (MagNav's `linreg`).
pub fn ridge(a: &DMatrix<f64>, y: &[f64], lambda: f64) -> Result<RidgeSolution, RidgeError> {
    let mut solver = Ridge::new(a.ncols());
    solver.push(a, y);
    solver.solve(lambda, &[])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ridge_matches_normal_equations_on_a_small_problem() {
        let a = DMatrix::from_row_slice(4, 2, &[1.0, 0.0, 1.0, 1.0, 1.0, 2.0, 1.0, 3.0]);
        let y = [1.0, 3.0, 5.2, 6.9];
        let lambda = 0.5;
        let got = ridge(&a, &y, lambda).unwrap().coefficients;
        let g = a.transpose() * &a + DMatrix::identity(2, 2) * lambda;
        let want = g
            .lu()
            .solve(&(a.transpose() * DVector::from_column_slice(&y)))
            .unwrap();
        for (u, v) in got.iter().zip(want.iter()) {
            assert!((u - v).abs() < 1e-12, "{u} vs {v}");
        }
    }

    fn problem(n: usize) -> (DMatrix<f64>, Vec<f64>) {
        let a = DMatrix::from_fn(n, 3, |i, j| ((i * (j + 3)) as f64 * 0.37).sin());
        let y = (0..n).map(|i| (i as f64 * 0.11).cos()).collect();
        (a, y)
    }

    #[test]
    fn blocks_and_merges_give_the_same_answer_as_one_solve() {
        let n = 3 * BLOCK_ROWS + 17;
        let (a, y) = problem(n);
        let whole = ridge(&a, &y, 0.0).unwrap();
        let mut first = Ridge::new(3);
        first.push(&a.rows(0, 100).into_owned(), &y[..100]);
        let mut second = Ridge::new(3);
        second.push(&a.rows(100, n - 100).into_owned(), &y[100..]);
        first.merge(&second);
        let merged = first.solve(0.0, &[]).unwrap();
        for (u, v) in whole.coefficients.iter().zip(&merged.coefficients) {
            assert!((u - v).abs() < 1e-10);
        }
        assert_eq!(merged.rows, n);
    }

    #[test]
    fn residual_and_column_sums_match_direct_computation() {
        let (a, y) = problem(500);
        let solution = ridge(&a, &y, 0.1).unwrap();
        let fitted = &a * DVector::from_column_slice(&solution.coefficients);
        let direct: f64 = fitted.iter().zip(&y).map(|(f, t)| (t - f).powi(2)).sum();
        assert!((direct - solution.rss).abs() < 1e-9 * direct);
        let mut solver = Ridge::new(3);
        solver.push(&a, &y);
        let sums = solver.column_sums_of_squares();
        assert!((sums[1] - a.column(1).norm_squared()).abs() < 1e-9);
    }

    #[test]
    fn exactly_collinear_columns_without_ridge_are_singular() {
        let a = DMatrix::from_fn(50, 2, |i, _| i as f64);
        let y: Vec<f64> = (0..50).map(|i| i as f64).collect();
        assert!(matches!(
            ridge(&a, &y, 0.0),
            Err(RidgeError::Singular { .. })
        ));
        assert!(ridge(&a, &y, 1e-3).is_ok());
    }
}
