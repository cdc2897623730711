//! What a fit gives: the fitted model ([`Fit`]) and what it found out about itself — scatters
//! (nT), counts of samples and runs, the term sets it compared, and the heading levels with the
//! fluxgate calibration behind them.

use super::crossval::CrossValidation;
use super::settings::FitSettings;
use super::{plausible, verdict};
use crate::model::magnitude::Magnitude;
use crate::model::terms::TermSet;
use crate::model::uncertainty::Uncertainty;
use serde::{Deserialize, Serialize};

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
    /// The diagonal penalty added to `AᵀA`, one value per column (squared column units).
    pub penalty: Vec<f64>,
    /// How λ was chosen, when it was cross-validated.
    pub cross_validation: Option<CrossValidation>,
    /// Every term set cross-validation compared, with its held-out error (empty when only one
    /// was tried).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub term_choice: Vec<TermScore>,
    /// Standard error of each coefficient (coefficient units): the square root of the
    /// diagonal of the covariance each row's σ and the verdict use ([`Fit::uncertainty`]), the
    /// sandwich with the rows' long-run score covariance; without one (a fit in windows of a
    /// long flight), the ridge sandwich `σ²·G⁻¹AᵀAG⁻¹`, `G = AᵀA + λI`, with the residual's
    /// variance inflated for the band's width.
    pub std_errors: Vec<f64>,
    /// How the heading levels were fitted, when they were.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub levels: Option<LevelDiagnostics>,
    /// With levels asked for, the RMS misfit (nT) by which the band-only model missed them when
    /// that was too large to trust them (see `problem::UNTRUSTED_LEVELS_NT`, 10 nT): the fit
    /// then left them out.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub untrusted_levels_nt: Option<f64>,
    /// Gauss-Newton iterations of the exact fit (0 for a linear model).
    #[serde(default)]
    pub exact_iterations: usize,
    /// RMS change of the (first) fluxgate's direction inside the fitting band (degrees): how
    /// much the calibration maneuvered.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub excitation_deg: Option<f64>,
    /// The field the fit found before its prior was strengthened to make it believable, when
    /// it was (see [`plausible`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub restrained: Option<plausible::Fault>,
}

/// How well one candidate term set predicted held-out data.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TermScore {
    /// The term set.
    pub terms: TermSet,
    /// The extra channels it used.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub extras: Vec<crate::model::extra::ExtraChannel>,
    /// The magnitude model.
    #[serde(default)]
    pub magnitude: Magnitude,
    /// Its cross-validated relative ridge strength, `None` if it could not be fitted.
    pub lambda_rel: Option<f64>,
    /// Its held-out RMS (nT), `None` if it could not be fitted.
    pub heldout_rms_nt: Option<f64>,
    /// Its held-out RMS of the low-frequency (heading-level) rows (nT), with levels. The choice
    /// compares `hypot(heldout_rms_nt, heldout_low_rms_nt)`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub heldout_low_rms_nt: Option<f64>,
    /// True for the set the model uses.
    pub chosen: bool,
}

/// A fitted model and its diagnostics.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Fit {
    /// The settings used; `design.terms` is the term set chosen.
    pub settings: FitSettings,
    /// Sample rate (Hz) of the calibration data; eddy coefficients are per sample at this rate.
    pub fs_hz: f64,
    /// How the model's field enters the scalar (absent in files before version 2: linear).
    #[serde(default)]
    pub magnitude: Magnitude,
    /// How late the fluxgate samples behind the scalar (s); compensation reads the fluxgate
    /// this much later (see [`crate::fit::lag::shifted`]). Zero unless a lag was given or estimated.
    #[serde(default, skip_serializing_if = "is_zero")]
    pub lag_s: f64,
    /// The lone fluxgate's offset (nT; x, y, z) taken out of its readings before the design
    /// is built, in the fit and in every compensation (see [`FitSettings::fluxgate_offset`]).
    /// A cabin fluxgate sees the aircraft's own field, thousands of nT that bend every
    /// direction cosine by a few percent; `None`: the readings as they are.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub flux_offset_nt: Option<[f64; 3]>,
    /// Names of the columns, in order (see [`crate::model::design::Design::column_names`]).
    pub columns: Vec<String>,
    /// One coefficient per column (nT per unit of the column).
    pub coefficients: Vec<f64>,
    /// Mean of the unfiltered `A·β` over the calibration samples (nT): the level a streaming
    /// compensator subtracts, since it cannot know a whole file's mean.
    pub level_nt: f64,
    /// Fit quality.
    pub diagnostics: Diagnostics,
    /// Whether to trust the model (absent in files before version 3).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub verdict: Option<verdict::Verdict>,
    /// The coefficients' uncertainty, for each compensated row's (absent before version 3).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub uncertainty: Option<Uncertainty>,
    /// The directions, rates and channel values the calibration spanned, to tell which rows a
    /// compensation extrapolates to (absent before version 3).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub coverage: Option<crate::model::coverage::Coverage>,
}

/// The fluxgate's own errors as seen in its magnitude.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FluxgateCalibration {
    /// Offset of each axis, x, y, z (nT).
    pub offset_nt: [f64; 3],
    /// Traceless distortion `K` (dimensionless) as `[zz−xx, zz−yy, xy+yx, xz+zx, yz+zy]`.
    pub distortion: [f64; 5],
    /// Standard deviation of the band-passed magnitude after calibration (nT): fluxgate noise
    /// and geology inside the band.
    pub residual_std_nt: f64,
}

/// How the low-frequency rows were used, for the fit's diagnostics.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct LevelDiagnostics {
    /// The fluxgate calibration behind the reference.
    pub fluxgate: FluxgateCalibration,
    /// Low-frequency rows that entered the fit.
    pub rows: usize,
    /// Their cut-off (Hz).
    pub cutoff_hz: f64,
    /// RMS misfit of the low-passed `y − R` after the fit (nT): how well one constant and the
    /// model explain the levels the calibration flight flew.
    pub residual_rms_nt: f64,
    /// What a model that describes the low frequencies would leave of them (nT RMS): the
    /// reference's own noise through the low-pass (absent in files before it).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub expected_rms_nt: Option<f64>,
    /// Standard error of a heading level (nT): the misfit over the square root of the rows per
    /// heading of a four-heading box.
    pub level_std_error_nt: f64,
    /// Weight of each low-frequency row relative to a band-passed one.
    pub weight: f64,
}

fn is_zero(v: &f64) -> bool {
    *v == 0.0
}
