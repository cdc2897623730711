//! What a fit's heading-level rows need: the reference, the low-pass, the weight of the rows,
//! and their misfit and diagnostics for a solution.

use super::basis::on_columns;
use super::diagnostics::run_score_covariance;
use super::level_rows::{rms_misfit, LevelRows};
use super::levels::{self, LowFrequency, Reference};
use super::outcome::LevelDiagnostics;
use super::settings::FitSettings;
use crate::model::design::Term;
use nalgebra::DMatrix;
use std::ops::Range;

/// What the heading levels need: the reference, the low-pass, and the weight of their rows.
pub(super) struct LevelSetup {
    /// The reference; `None` while the linear rows are made, when the fluxgate is calibrated
    /// from them ([`levels::InPass`]): their level rows' target is then the scalar less the
    /// fluxgate's magnitude.
    pub(super) reference: Option<Reference>,
    pub(super) low: LowFrequency,
    /// Expected scatter of a level row (nT): at first the reference's noise through the
    /// low-pass, then the rows' measured misfit if that is larger.
    pub(super) sigma_nt: f64,
    /// The reference's noise through the low-pass (nT): what a model that describes the low
    /// frequencies leaves of the level rows.
    pub(super) expected_nt: f64,
    /// Scatter of a band row (nT).
    pub(super) band_sigma_nt: f64,
    /// Level rows of the fit kept (centred, unweighted), to measure the misfit.
    pub(super) rows: Vec<LevelRows>,
    /// The terms of the columns of `rows`: every candidate's for the linear rows, the chosen
    /// design's for the Gauss-Newton ones.
    pub(super) row_terms: Vec<Term>,
}

impl LevelSetup {
    /// The setup with its `reference`, and the level rows' expected scatter from the
    /// calibration's.
    pub(super) fn with_reference(self, reference: Reference, s: &FitSettings, fs_hz: f64) -> Self {
        // White noise of the reference, seen through the low-pass instead of the band.
        let low = &self.low;
        let width = (s.band.pass2_hz.min(fs_hz / 2.0) - s.band.pass1_hz).max(low.cutoff_hz);
        let sigma_nt =
            (reference.calibration.residual_std_nt * (low.cutoff_hz / width).sqrt()).max(1e-3);
        Self {
            reference: Some(reference),
            sigma_nt,
            expected_nt: sigma_nt,
            ..self
        }
    }

    pub(super) fn weight(&self) -> f64 {
        self.band_sigma_nt / self.sigma_nt
    }

    pub(super) fn row_count(&self) -> usize {
        self.rows.iter().map(|r| r.y.len()).sum()
    }

    /// RMS misfit of the level rows (nT) for the coefficients `beta` of `terms`.
    pub(super) fn misfit(&self, terms: &[Term], beta: &[f64]) -> f64 {
        rms_misfit(&self.rows, &on_columns(&self.row_terms, terms, beta))
    }

    /// The level rows' residual sum of squares as the solve saw it, weighted (nT²), for the
    /// coefficients `beta` of `terms`.
    pub(super) fn weighted_rss(&self, terms: &[Term], beta: &[f64]) -> f64 {
        let misfit = self.misfit(terms, beta);
        let count = self.row_count();
        if count == 0 {
            return 0.0;
        }
        (self.weight() * misfit).powi(2) * count as f64
    }

    /// The level rows' long-run score covariance as the solve weighted them (columns of
    /// `row_terms`), for the coefficients `beta` of `terms`: see
    /// [`super::problem::Prepared::score_covariance`]. A level row is a low-passed sample,
    /// correlated with its neighbours over about two periods of the cutoff, `fs_hz` samples a
    /// second.
    pub(super) fn score_covariance(
        &self,
        terms: &[Term],
        beta: &[f64],
        fs_hz: f64,
    ) -> DMatrix<f64> {
        let b = on_columns(&self.row_terms, terms, beta);
        let p = self.row_terms.len();
        let w2 = self.weight().powi(2);
        let mut total = DMatrix::zeros(p, p);
        for rows in self.rows.iter().filter(|r| !r.y.is_empty()) {
            let n = rows.y.len();
            let fitted = &rows.a * nalgebra::DVector::from_column_slice(&b);
            let residual: Vec<f64> = (0..n).map(|i| w2 * (rows.y[i] - fitted[i])).collect();
            let span = (rows.at[n - 1] - rows.at[0] + 1) as f64;
            let per_second = n as f64 / span * fs_hz;
            let block = (per_second * 2.0 / self.low.cutoff_hz).ceil();
            let block = if block.is_finite() { block as usize } else { n };
            let data = rows.a.as_slice();
            let columns: Vec<&[f64]> = data.chunks_exact(n).take(p).collect();
            total += run_score_covariance(&columns, &residual, block.clamp(1, n));
        }
        total
    }

    pub(super) fn diagnostics(&self, terms: &[Term], beta: &[f64]) -> LevelDiagnostics {
        let count = self.row_count();
        let misfit = self.misfit(terms, beta);
        LevelDiagnostics {
            fluxgate: self
                .reference
                .as_ref()
                .expect("the levels' diagnostics come after the calibration")
                .calibration
                .clone(),
            rows: count,
            cutoff_hz: self.low.cutoff_hz,
            residual_rms_nt: misfit,
            expected_rms_nt: Some(self.expected_nt).filter(|e| e.is_finite()),
            level_std_error_nt: misfit / (count as f64 / 4.0).max(1.0).sqrt(),
            weight: self.weight(),
        }
    }
}

/// What the level rows' target is the scalar less, over a run.
#[derive(Clone, Copy)]
pub(super) enum LevelReference<'w> {
    /// The calibrated reference's values (nT).
    Values(&'w [f64]),
    /// The fluxgate's magnitude, the signal after the target, while the fluxgate is calibrated
    /// from the same rows ([`levels::InPass`]): the calibration's correction joins the level
    /// rows' target afterwards. The magnitude rather than nothing, so that the low-pass sees
    /// the small difference of two fields of 50 000 nT rather than each (its rounding is
    /// relative to what it filters).
    Magnitude,
}

impl<'w> LevelReference<'w> {
    /// The reference of `setup` over `run`.
    pub(super) fn of(setup: &'w LevelSetup, run: Range<usize>) -> Self {
        match &setup.reference {
            Some(r) => LevelReference::Values(levels::reference_over(r, run)),
            None => LevelReference::Magnitude,
        }
    }

    /// The reference over `rows` (of the run), its `signals` over them at hand: the columns,
    /// the target, the magnitude.
    pub(super) fn over<'s, S: AsRef<[f64]>>(
        &'s self,
        rows: Range<usize>,
        signals: &'s [S],
    ) -> &'s [f64] {
        match self {
            LevelReference::Values(values) => &values[rows],
            LevelReference::Magnitude => signals[signals.len() - 1].as_ref(),
        }
    }
}
