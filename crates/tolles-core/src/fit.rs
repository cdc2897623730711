//! Fitting a Tolles-Lawson model: filter, trim, ridge least squares.
//!
//! ```
//! use tolles_core::design::Design;
//! use tolles_core::fit::{fit, FitSettings};
//! use tolles_core::vector::VectorSeries;
//!
//! // A fluxgate swinging through ±20° at 0.2 Hz, and a scalar that sees a 40 nT permanent field
//! // along the aircraft's x axis.
//! let fs = 10.0;
//! let n = 2000;
//! let angle = |k: usize| 0.35 * (2.0 * std::f64::consts::PI * 0.2 * k as f64 / fs).sin();
//! let flux = VectorSeries::new(
//!     (0..n).map(|k| 20_000.0 * angle(k).cos()).collect(),
//!     (0..n).map(|k| 20_000.0 * angle(k).sin()).collect(),
//!     vec![45_000.0; n],
//! );
//! let scalar: Vec<f64> = (0..n).map(|k| 50_000.0 + 40.0 * flux.x[k] / flux.magnitude(k)).collect();
//! let settings = FitSettings { design: Design::new("p".parse().unwrap()), lambda: 0.0, ..FitSettings::magnav() };
//! let model = fit(&scalar, &flux, fs, None, &settings).unwrap();
//! assert!((model.coefficients[0] - 40.0).abs() < 1e-6);
//! ```
//!
//! The procedure is MagNav.jl's `create_TL_coef`: build the design matrix `A` from the fluxgate,
//! band-pass every column of `A` and the scalar with the same zero-phase filter (constant columns
//! are left alone), drop `trim` samples at each end, and solve
//! `(AᵀA + λI)·β = Aᵀy` with unscaled columns (MagNav's `linreg`).
//!
//! We solve the ridge problem as the least-squares problem `[A; √λ·I]·β ≈ [y; 0]` by a
//! blocked Householder QR ("TSQR"), never forming `AᵀA`: on the MagNav test flight
//! `cond(AᵀA) ≈ 4·10⁷`, so normal equations would lose about eight digits.
//!
//! Samples where the scalar or fluxgate is not finite are skipped; the remaining samples are cut
//! into contiguous runs (also at time gaps, see [`crate::segment`]) and each run is designed,
//! filtered and trimmed on its own, so no derivative or filter reaches across a hole.

use crate::design::Design;
use crate::filter::{magnav_bandpass, Butterworth, FilterError};
use crate::segment::contiguous_runs;
use crate::terms::Column;
use crate::vector::VectorSeries;
use nalgebra::{DMatrix, DVector};
use serde::{Deserialize, Serialize};
use std::ops::Range;
use thiserror::Error;

/// Fluxgate magnitudes outside this range (nT) mean the data is not in nT or not a fluxgate.
pub const FLUX_MAGNITUDE_RANGE_NT: (f64, f64) = (1_000.0, 100_000.0);

/// Pass band (Hz) of the zero-phase Butterworth filter, MagNav's `pass1`/`pass2`.
///
/// An edge ≤ 0 or ≥ fs/2 is switched off: band-pass becomes low-pass (`pass1` off) or
/// high-pass (`pass2` off); both off means no filtering and no trimming.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Band {
    /// Lower edge (Hz).
    pub pass1_hz: f64,
    /// Upper edge (Hz).
    pub pass2_hz: f64,
}

/// How to fit.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FitSettings {
    /// Terms and `Bt_scale`.
    pub design: Design,
    /// Ridge strength λ added to `AᵀA` (units of the squared design columns).
    pub lambda: f64,
    /// Pass band of the filter applied to every column and the scalar.
    pub band: Band,
    /// Butterworth order (per edge for band-pass, as scipy and DSP.jl count).
    pub order: usize,
    /// Samples dropped at each end of each run after filtering.
    pub trim: usize,
}

impl FitSettings {
    /// MagNav.jl's procedure as its tests run it: 18 terms, λ = 0.001, 0.1–0.9 Hz, order 4,
    /// trim 20, `Bt_scale` 50 000.
    pub fn magnav() -> Self {
        Self {
            design: Design::new(crate::terms::TermSet::magnav_default()),
            lambda: 0.001,
            band: Band {
                pass1_hz: 0.1,
                pass2_hz: 0.9,
            },
            order: 4,
            trim: 20,
        }
    }
}

/// Why a fit could not be made.
#[derive(Debug, Error, PartialEq)]
pub enum FitError {
    #[error("scalar has {scalar} samples but the fluxgate has {flux}")]
    LengthMismatch { scalar: usize, flux: usize },
    #[error("sample rate must be positive and finite, got {0} Hz")]
    SampleRate(f64),
    #[error("ridge strength λ must be finite and ≥ 0, got {0}")]
    Lambda(f64),
    #[error("fluxgate magnitude {magnitude:.1} nT at sample {index} is outside 1,000–100,000 nT: is the fluxgate in nT?")]
    FluxMagnitude { index: usize, magnitude: f64 },
    #[error("the scalar magnetometer is constant: there is nothing to fit")]
    ConstantScalar,
    #[error("the fluxgate is constant: the aircraft did not maneuver, so no term can be fitted")]
    ConstantFlux,
    #[error("only {usable} usable samples after filtering and trimming, fewer than the {terms} terms; use a longer flight, fewer terms or a smaller --trim")]
    TooFewSamples { usable: usize, terms: usize },
    #[error("the design matrix is singular (column {column} is a combination of others); add --lambda or use fewer terms")]
    Singular { column: String },
    #[error(transparent)]
    Filter(#[from] FilterError),
}

/// Everything a fit found out about how well it went.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Diagnostics {
    /// Samples in the input.
    pub samples_total: usize,
    /// Samples skipped because the scalar or fluxgate was not finite.
    pub samples_nonfinite: usize,
    /// Samples in runs too short to filter and trim (skipped).
    pub samples_in_short_runs: usize,
    /// Samples that entered the least-squares solve (after trimming).
    pub samples_used: usize,
    /// Contiguous runs used.
    pub runs_used: usize,
    /// Standard deviation of the filtered scalar before fitting (nT).
    pub filtered_std_before_nt: f64,
    /// Standard deviation of the filtered residual `y − A·β` (nT).
    pub residual_std_nt: f64,
    /// `filtered_std_before_nt / residual_std_nt`.
    pub improvement_ratio: f64,
    /// Condition number of `AᵀA + λI` (2-norm).
    pub condition_number: f64,
    /// Fraction of the Nyquist band the filter passes; residuals are correlated over about
    /// `1/fraction` samples, so the standard errors are inflated by `1/√fraction`.
    pub effective_sample_fraction: f64,
    /// Standard error of each coefficient (coefficient units), from the ridge sandwich
    /// covariance `σ²·G⁻¹AᵀAG⁻¹`, `G = AᵀA + λI`.
    pub std_errors: Vec<f64>,
}

/// A fitted model and its diagnostics.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Fit {
    /// The settings used.
    pub settings: FitSettings,
    /// Sample rate (Hz) of the calibration data; eddy coefficients are per sample at this rate.
    pub fs_hz: f64,
    /// Names of the columns, in order.
    pub columns: Vec<String>,
    /// One coefficient per column (nT per unit of the column).
    pub coefficients: Vec<f64>,
    /// Mean of the unfiltered `A·β` over the calibration samples (nT): the level a streaming
    /// compensator subtracts, since it cannot know a whole file's mean.
    pub level_nt: f64,
    /// Fit quality.
    pub diagnostics: Diagnostics,
}

/// Fits a model to a calibration flight.
///
/// - `scalar`: the uncompensated scalar magnetometer (nT); non-finite samples are skipped;
/// - `flux`: the fluxgate (nT, body frame FRD);
/// - `fs_hz`: sample rate (Hz);
/// - `tt`: optional time (seconds) used only to split runs at gaps.
pub fn fit(
    scalar: &[f64],
    flux: &VectorSeries,
    fs_hz: f64,
    tt: Option<&[f64]>,
    settings: &FitSettings,
) -> Result<Fit, FitError> {
    check_inputs(scalar, flux, fs_hz, settings)?;
    let usable: Vec<bool> = (0..scalar.len())
        .map(|k| scalar[k].is_finite() && flux.is_finite(k))
        .collect();
    check_not_constant(scalar, flux, &usable)?;
    let filter = magnav_bandpass(
        settings.band.pass1_hz,
        settings.band.pass2_hz,
        settings.order,
        fs_hz,
    )?;
    let columns = settings.design.columns();
    let mut solver = Ridge::new(columns.len());
    let mut short = 0;
    let mut runs_used = 0;
    let mut before = RunningStd::default();
    for run in contiguous_runs(&usable, tt) {
        match prepare_run(scalar, flux, run.clone(), filter.as_ref(), settings)? {
            Some((a, y)) => {
                y.iter().for_each(|v| before.push(*v));
                solver.push(&a, &y);
                runs_used += 1;
            }
            None => short += run.len(),
        }
    }
    if solver.rows < columns.len() {
        return Err(FitError::TooFewSamples {
            usable: solver.rows,
            terms: columns.len(),
        });
    }
    let solution = solver.solve(settings.lambda, &columns)?;
    let level_nt = mean_correction(flux, &usable, tt, &settings.design, &solution.coefficients);
    let fraction = passband_fraction(settings.band, fs_hz);
    let samples_nonfinite = usable.iter().filter(|u| !**u).count();
    let diagnostics = solution.diagnostics(DiagnosticCounts {
        total: scalar.len(),
        nonfinite: samples_nonfinite,
        short,
        runs_used,
        before_std: before.std(),
        fraction,
    });
    Ok(Fit {
        settings: settings.clone(),
        fs_hz,
        columns: columns.iter().map(Column::to_string).collect(),
        coefficients: solution.coefficients.clone(),
        level_nt,
        diagnostics,
    })
}

fn check_inputs(
    scalar: &[f64],
    flux: &VectorSeries,
    fs_hz: f64,
    settings: &FitSettings,
) -> Result<(), FitError> {
    if scalar.len() != flux.len() {
        return Err(FitError::LengthMismatch {
            scalar: scalar.len(),
            flux: flux.len(),
        });
    }
    if !(fs_hz.is_finite() && fs_hz > 0.0) {
        return Err(FitError::SampleRate(fs_hz));
    }
    if !(settings.lambda.is_finite() && settings.lambda >= 0.0) {
        return Err(FitError::Lambda(settings.lambda));
    }
    check_flux_magnitude(flux)
}

/// Rejects a fluxgate whose finite samples have a magnitude outside
/// [`FLUX_MAGNITUDE_RANGE_NT`]; reports the first such sample.
pub fn check_flux_magnitude(flux: &VectorSeries) -> Result<(), FitError> {
    let (lo, hi) = FLUX_MAGNITUDE_RANGE_NT;
    for k in 0..flux.len() {
        let magnitude = flux.magnitude(k);
        if magnitude.is_finite() && !(lo..=hi).contains(&magnitude) {
            return Err(FitError::FluxMagnitude {
                index: k,
                magnitude,
            });
        }
    }
    Ok(())
}

fn check_not_constant(scalar: &[f64], flux: &VectorSeries, usable: &[bool]) -> Result<(), FitError> {
    let varies = |x: &[f64]| {
        let mut values = x.iter().zip(usable).filter(|(_, u)| **u).map(|(v, _)| *v);
        let first = values.next();
        first.is_some_and(|f| values.any(|v| v != f))
    };
    if !varies(scalar) {
        return Err(FitError::ConstantScalar);
    }
    if !(varies(&flux.x) || varies(&flux.y) || varies(&flux.z)) {
        return Err(FitError::ConstantFlux);
    }
    Ok(())
}

/// Design, filter and trim one run; `None` if it is too short.
fn prepare_run(
    scalar: &[f64],
    flux: &VectorSeries,
    run: Range<usize>,
    filter: Option<&Butterworth>,
    settings: &FitSettings,
) -> Result<Option<(DMatrix<f64>, Vec<f64>)>, FitError> {
    let trim = if filter.is_some() { settings.trim } else { 0 };
    let needed = filter.map_or(0, |f| f.padlen() + 1).max(2 * trim + 1);
    if run.len() < needed {
        return Ok(None);
    }
    let mut a = settings.design.matrix(&flux.slice(run.clone()));
    let mut y = scalar[run].to_vec();
    if let Some(f) = filter {
        for mut col in a.column_iter_mut() {
            let filtered = crate::filter::filtfilt_unless_constant(f, col.as_slice())?;
            col.copy_from_slice(&filtered);
        }
        y = crate::filter::filtfilt_unless_constant(f, &y)?;
    }
    let n = y.len();
    let a = a.rows(trim, n - 2 * trim).into_owned();
    let y = y[trim..n - trim].to_vec();
    Ok(Some((a, y)))
}

/// Mean of the unfiltered correction `A·β` over the usable samples (nT).
fn mean_correction(
    flux: &VectorSeries,
    usable: &[bool],
    tt: Option<&[f64]>,
    design: &Design,
    coefficients: &[f64],
) -> f64 {
    let mut sum = 0.0;
    let mut count = 0usize;
    for run in contiguous_runs(usable, tt) {
        let correction = design.apply(&flux.slice(run), coefficients);
        sum += correction.iter().sum::<f64>();
        count += correction.len();
    }
    if count == 0 {
        0.0
    } else {
        sum / count as f64
    }
}

/// Fraction of the band 0…fs/2 that the filter passes (1 when it does not filter).
fn passband_fraction(band: Band, fs_hz: f64) -> f64 {
    let nyquist = fs_hz / 2.0;
    let valid = |f: f64| f > 0.0 && f < nyquist;
    let lo = if valid(band.pass1_hz) { band.pass1_hz } else { 0.0 };
    let hi = if valid(band.pass2_hz) { band.pass2_hz } else { nyquist };
    ((hi - lo) / nyquist).clamp(f64::EPSILON, 1.0)
}

/// Rows added to a ridge problem before the QR is updated (keeps memory bounded).
const BLOCK_ROWS: usize = 4096;

/// Incremental least squares by blocked Householder QR of `[A | y]`.
///
/// Holds only the `(p+1)×(p+1)` triangular factor, so rows can be pushed from any number of runs
/// or files.
#[derive(Debug, Clone)]
pub struct Ridge {
    p: usize,
    r: DMatrix<f64>,
    pending: Vec<f64>,
    pending_rows: usize,
    rows: usize,
    yy: f64,
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
            yy: 0.0,
        }
    }

    /// Rows pushed so far.
    pub fn rows(&self) -> usize {
        self.rows
    }

    /// Adds the rows of `a` (n×p) with right-hand side `y` (n).
    pub fn push(&mut self, a: &DMatrix<f64>, y: &[f64]) {
        assert_eq!(a.ncols(), self.p, "design width");
        assert_eq!(a.nrows(), y.len(), "one target per row");
        for (k, target) in y.iter().enumerate() {
            self.pending.extend(a.row(k).iter());
            self.pending.push(*target);
            self.yy += target * target;
            self.pending_rows += 1;
            if self.pending_rows == BLOCK_ROWS {
                self.flush();
            }
        }
        self.rows += y.len();
    }

    fn flush(&mut self) {
        if self.pending_rows == 0 {
            return;
        }
        let width = self.p + 1;
        let block = DMatrix::from_row_slice(self.pending_rows, width, &self.pending);
        let stacked = stack(&self.r, &block);
        self.r = upper_factor(stacked);
        self.pending.clear();
        self.pending_rows = 0;
    }

    /// Solves `(AᵀA + λI)·β = Aᵀy`; `columns` name the unknowns in errors.
    pub fn solve(mut self, lambda: f64, columns: &[Column]) -> Result<RidgeSolution, FitError> {
        self.flush();
        let p = self.p;
        let mut penalty = DMatrix::zeros(p, p + 1);
        for j in 0..p {
            penalty[(j, j)] = lambda.sqrt();
        }
        let r = upper_factor(stack(&self.r, &penalty));
        let r_a = r.view((0, 0), (p, p)).into_owned();
        let qty = r.view((0, p), (p, 1)).column(0).into_owned();
        check_rank(&r_a, columns)?;
        let beta = r_a
            .solve_upper_triangular(&qty)
            .expect("nonsingular after rank check");
        // [A | y] = Q·R0, so ‖y − Aβ‖ = ‖R0·[β; −1]‖ without touching the data again.
        let mut beta_ext = DVector::from_element(p + 1, -1.0);
        beta_ext.rows_mut(0, p).copy_from(&beta);
        let rss = if self.r.nrows() == 0 { 0.0 } else { (&self.r * beta_ext).norm_squared() };
        Ok(RidgeSolution {
            coefficients: beta.iter().copied().collect(),
            r_a,
            lambda,
            rss,
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

/// The upper-triangular factor R of a QR decomposition, `min(rows, cols) × cols`.
fn upper_factor(m: DMatrix<f64>) -> DMatrix<f64> {
    m.qr().r()
}

fn check_rank(r_a: &DMatrix<f64>, columns: &[Column]) -> Result<(), FitError> {
    let largest = r_a.diagonal().iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let tolerance = largest * f64::EPSILON * r_a.nrows() as f64 * 10.0;
    match r_a.diagonal().iter().position(|v| v.abs() <= tolerance) {
        Some(j) => Err(FitError::Singular {
            column: columns.get(j).map_or(format!("#{j}"), Column::to_string),
        }),
        None => Ok(()),
    }
}

/// The solution of a ridge problem and what is needed for its diagnostics.
#[derive(Debug, Clone)]
pub struct RidgeSolution {
    /// β.
    pub coefficients: Vec<f64>,
    /// Triangular factor of `AᵀA + λI = RᵀR`.
    r_a: DMatrix<f64>,
    lambda: f64,
    /// Residual sum of squares `‖y − Aβ‖²`.
    pub rss: f64,
    /// Rows in the problem.
    pub rows: usize,
}

struct DiagnosticCounts {
    total: usize,
    nonfinite: usize,
    short: usize,
    runs_used: usize,
    before_std: f64,
    fraction: f64,
}

impl RidgeSolution {
    /// Condition number (2-norm) of `AᵀA + λI`.
    pub fn condition_number(&self) -> f64 {
        let s = self.r_a.clone().singular_values();
        let (max, min) = s
            .iter()
            .fold((0.0f64, f64::INFINITY), |(a, b), v| (a.max(*v), b.min(*v)));
        (max / min).powi(2)
    }

    /// Standard errors of β for residual variance `sigma2` (nT²).
    pub fn std_errors(&self, sigma2: f64) -> Vec<f64> {
        let p = self.r_a.nrows();
        let r_inv = self
            .r_a
            .clone()
            .try_inverse()
            .unwrap_or_else(|| DMatrix::from_element(p, p, f64::NAN));
        let g_inv = &r_inv * r_inv.transpose();
        let covariance = &g_inv - (&g_inv * &g_inv) * self.lambda;
        (0..p)
            .map(|j| (sigma2 * covariance[(j, j)].max(0.0)).sqrt())
            .collect()
    }

    fn diagnostics(&self, c: DiagnosticCounts) -> Diagnostics {
        let p = self.coefficients.len();
        let dof = self.rows.saturating_sub(p).max(1) as f64;
        let residual_std = (self.rss / self.rows as f64).sqrt();
        let sigma2 = self.rss / dof / c.fraction;
        Diagnostics {
            samples_total: c.total,
            samples_nonfinite: c.nonfinite,
            samples_in_short_runs: c.short,
            samples_used: self.rows,
            runs_used: c.runs_used,
            filtered_std_before_nt: c.before_std,
            residual_std_nt: residual_std,
            improvement_ratio: c.before_std / residual_std,
            condition_number: self.condition_number(),
            effective_sample_fraction: c.fraction,
            std_errors: self.std_errors(sigma2),
        }
    }
}

/// Solves `(AᵀA + λI)·β = Aᵀy` for a ready-made (already filtered) design matrix.
pub fn ridge(a: &DMatrix<f64>, y: &[f64], lambda: f64) -> Result<RidgeSolution, FitError> {
    let mut solver = Ridge::new(a.ncols());
    solver.push(a, y);
    let names: Vec<Column> = Vec::new();
    solver.solve(lambda, &names)
}

/// Population standard deviation accumulated one value at a time (Welford).
#[derive(Debug, Default, Clone, Copy)]
struct RunningStd {
    n: usize,
    mean: f64,
    m2: f64,
}

impl RunningStd {
    fn push(&mut self, x: f64) {
        self.n += 1;
        let delta = x - self.mean;
        self.mean += delta / self.n as f64;
        self.m2 += delta * (x - self.mean);
    }

    fn std(&self) -> f64 {
        if self.n == 0 {
            return f64::NAN;
        }
        (self.m2 / self.n as f64).sqrt()
    }
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
        let want = g.lu().solve(&(a.transpose() * DVector::from_column_slice(&y))).unwrap();
        for (u, v) in got.iter().zip(want.iter()) {
            assert!((u - v).abs() < 1e-12, "{u} vs {v}");
        }
    }

    #[test]
    fn blocks_give_the_same_answer_as_one_solve() {
        let n = 3 * BLOCK_ROWS + 17;
        let a = DMatrix::from_fn(n, 3, |i, j| ((i * (j + 3)) as f64 * 0.37).sin());
        let y: Vec<f64> = (0..n).map(|i| (i as f64 * 0.11).cos()).collect();
        let whole = ridge(&a, &y, 0.0).unwrap();
        let mut split = Ridge::new(3);
        split.push(&a.rows(0, 100).into_owned(), &y[..100]);
        split.push(&a.rows(100, n - 100).into_owned(), &y[100..]);
        let split = split.solve(0.0, &[]).unwrap();
        for (u, v) in whole.coefficients.iter().zip(&split.coefficients) {
            assert!((u - v).abs() < 1e-10);
        }
        let resid: f64 = (0..n)
            .map(|i| {
                let fit: f64 = (0..3).map(|j| a[(i, j)] * whole.coefficients[j]).sum();
                (y[i] - fit).powi(2)
            })
            .sum();
        assert!((resid - whole.rss).abs() < 1e-8 * resid.max(1.0));
    }

    #[test]
    fn exactly_collinear_columns_without_ridge_are_singular() {
        let a = DMatrix::from_fn(50, 2, |i, _| i as f64);
        let y: Vec<f64> = (0..50).map(|i| i as f64).collect();
        assert!(matches!(ridge(&a, &y, 0.0), Err(FitError::Singular { .. })));
        assert!(ridge(&a, &y, 1e-3).is_ok());
    }

    #[test]
    fn passband_fraction_follows_the_fallbacks() {
        let band = |a, b| Band { pass1_hz: a, pass2_hz: b };
        assert!((passband_fraction(band(0.1, 0.9), 10.0) - 0.16).abs() < 1e-12);
        assert!((passband_fraction(band(0.0, 1.0), 10.0) - 0.2).abs() < 1e-12);
        assert_eq!(passband_fraction(band(0.0, 99.0), 10.0), 1.0);
    }
}
