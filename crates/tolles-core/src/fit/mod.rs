//! Fitting a Tolles-Lawson model: filter, trim, ridge least squares.
//!
//! ```
//! use tolles_core::model::design::Design;
//! use tolles_core::fit::{fit, FitSettings, Lambda};
//! use tolles_core::model::vector::VectorSeries;
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
//! let settings = FitSettings {
//!     design: Design::new("p".parse().unwrap()),
//!     lambda: Lambda::Fixed(0.0),
//!     ..FitSettings::magnav()
//! };
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
//! into contiguous runs (also at time gaps, see [`crate::signal::segment`]) and each run is designed,
//! filtered and trimmed on its own, so no derivative or filter reaches across a hole.
//!
//! [`FitSettings::recommended`] goes further, in three steps that share the folds:
//! 1. the candidate term sets (the patent's traceless 16, `i5,e8`, and over several fluxgates
//!    MagNav's 18) are fitted and scored on held-out folds, each with a physical prior
//!    ([`prior`]) whose strength the folds choose too, and none beyond the bounds of
//!    [`plausible`];
//! 2. with `levels`, low-frequency rows against the calibrated fluxgate's magnitude join the
//!    band rows, and the score adds their held-out error ([`levels`]);
//! 3. with `magnitude`, the chosen terms are refitted for the exact magnitude `|B + H| − |B|`
//!    by Gauss-Newton from the linear solution: each iteration rebuilds the rows from the
//!    Jacobian (see [`crate::model::magnitude`]) and the target `y − Δ(β) + J·β`, filters them
//!    like the linear rows and solves the same ridge problem; the exact fit is kept if its score
//!    is no worse. Steps are cut to a trust region, and a fit that diverges or leaves the
//!    plausible bounds falls back to the linear one.
//!
//! Every fit then judges itself ([`verdict`]) and keeps its coefficients' covariance and the
//! span of attitudes it flew ([`trust`]), from which compensation gives each row a standard
//! error and says whether the model extrapolates there.

mod basis;
mod choice;
pub mod crossval;
mod diagnostics;
mod exact;
mod inputs;
pub mod lag;
mod level_setup;
pub mod levels;
pub mod network;
pub mod plausible;
pub mod prior;
mod problem;
mod qr;
pub mod ridge;
mod spare;
pub mod trust;
pub mod verdict;
mod windows;

use crate::compensate::{write_runs, Model};
use crate::fit::basis::Basis;
use crate::fit::choice::{choose_design, pick_magnitude, union_of_terms};
use crate::fit::crossval::{CrossValidation, DEFAULT_FOLDS};
use crate::fit::levels::LevelDiagnostics;
use crate::fit::problem::{fold_count, AboveBand, LevelChoice, Problem, Spare};
use crate::fit::ridge::{RidgeError, RidgeSolution};
use crate::model::design::{Design, Term};
use crate::model::magnitude::Magnitude;
use crate::model::terms::{Column, TermSet};
use crate::model::vector::{Fluxgates, VectorSeries};
use crate::signal::filter::{magnav_bandpass, Butterworth, FilterError};
use crate::signal::segment::contiguous_runs;
pub(crate) use diagnostics::{band_residual_std, RunningStd};
use diagnostics::{diagnostics, passband_fraction, score_block, DiagnosticCounts};
pub use inputs::check_flux_magnitude;
use inputs::check_inputs;
pub(crate) use inputs::check_not_constant;
use serde::{Deserialize, Serialize};
use std::ops::Range;
use std::sync::atomic::Ordering::Relaxed;
use thiserror::Error;

pub use crate::model::limits::{scalar_usable, show_nt, FLUX_MAGNITUDE_RANGE_NT, SCALAR_LIMIT_NT};

/// A fixed λ larger than this times the largest `diag(AᵀA)` shrinks every coefficient at least
/// this many-fold towards zero: the fit would be meaningless, so it is refused.
pub const LAMBDA_MAX_RATIO: f64 = 1e8;

// The pass band lives with the filters; re-exported because a fit's settings name it.
pub use crate::signal::filter::Band;

/// How strongly to regularise the least-squares solve.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Lambda {
    /// Add this λ to every diagonal entry of `AᵀA`, columns unscaled: MagNav's `linreg`.
    Fixed(f64),
    /// Choose `λ_rel` by blocked cross-validation over time in `folds` contiguous folds and add
    /// `λ_rel·diag(AᵀA)` (a ridge on standardised columns); see [`crate::fit::crossval`].
    CrossValidated {
        /// Number of contiguous folds (at least 2).
        folds: usize,
    },
}

impl Lambda {
    /// Cross-validation with the default number of folds.
    pub fn auto() -> Self {
        Lambda::CrossValidated {
            folds: DEFAULT_FOLDS,
        }
    }
}

/// How to fit.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FitSettings {
    /// Terms and `Bt_scale`.
    pub design: Design,
    /// Ridge regularisation.
    pub lambda: Lambda,
    /// Pass band of the filter applied to every column and the scalar.
    pub band: Band,
    /// Butterworth order (per edge for band-pass, as scipy and DSP.jl count).
    pub order: usize,
    /// Samples dropped at each end of each run after filtering.
    pub trim: usize,
    /// Other term sets cross-validation may choose instead of `design.terms` (only when λ is
    /// cross-validated). An alternative must predict the held-out folds at least
    /// [`TERM_CHOICE_MARGIN`] better to be chosen, since a larger set can also fit the earth
    /// field's own variations through the fluxgate's magnitude.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub alternative_terms: Vec<TermSet>,
    /// Which magnitude models to fit (see [`crate::model::magnitude`]).
    #[serde(default)]
    pub magnitude: MagnitudeChoice,
    /// Also fit the heading levels: low-frequency rows against the calibrated fluxgate's
    /// magnitude (see [`crate::fit::levels`]); one fluxgate only.
    #[serde(default)]
    pub levels: bool,
    /// What the scalar given to [`fit`] is: a magnetometer's reading (band-passed), or the
    /// interference itself (fitted in the full band).
    #[serde(default, skip_serializing_if = "Target::is_band")]
    pub target: Target,
    /// The physical sizes of the terms, a ridge prior in the coefficients' own units added to
    /// the cross-validated ridge (see [`prior`]); `None` for none. Only with a cross-validated
    /// λ: a fixed λ is MagNav's procedure, exactly.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub prior: Option<prior::Prior>,
    /// Calibrate a lone fluxgate's offset first (see [`levels::reference`]) and fit on its
    /// readings without it ([`Fit::flux_offset_nt`]). Only with a cross-validated λ and one
    /// fluxgate: over several, their differences, offsets included, are what sees sources near
    /// one of them.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub fluxgate_offset: bool,
}

/// What the scalar given to [`fit`] holds, and so which of its frequencies a fit may use.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Target {
    /// A magnetometer's reading: the earth's field plus the aircraft's. Only `band` is fitted,
    /// where the aircraft's manoeuvres dominate; below it the earth field's own changes
    /// (geology, diurnal, the flight's path) would be taken for interference.
    #[default]
    Band,
    /// The aircraft's field alone (nT): a magnetometer minus a compensated reference
    /// magnetometer on the same flight (MagNav's `y_type = :d` for cabin sensors). The earth
    /// field is gone, so every frequency is fitted: no filter, no trim, no heading levels
    /// (the low frequencies are in the target already). Each run's mean is removed from the
    /// target and the columns, because two sensors a few metres apart differ by a constant
    /// that is not the aircraft's.
    Interference,
}

impl Target {
    fn is_band(&self) -> bool {
        *self == Target::Band
    }
}

/// Which magnitude model a fit makes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum MagnitudeChoice {
    /// Tolles-Lawson's linear `B̂·H` (MagNav).
    #[default]
    Linear,
    /// The exact `|B + H| − |B|`, by Gauss-Newton from the linear fit (one fluxgate).
    Exact,
    /// Both; the one that predicts held-out data better (with a fixed λ, the one with the
    /// smaller residual: both have the same number of coefficients).
    Auto,
}

impl std::str::FromStr for MagnitudeChoice {
    type Err = String;

    /// `linear`, `exact` or `auto`, in any case.
    fn from_str(text: &str) -> Result<Self, String> {
        match text.trim().to_ascii_lowercase().as_str() {
            "linear" => Ok(MagnitudeChoice::Linear),
            "exact" => Ok(MagnitudeChoice::Exact),
            "auto" => Ok(MagnitudeChoice::Auto),
            _ => Err(format!("expected linear, exact or auto, got {text:?}")),
        }
    }
}

/// Gauss-Newton iterations of the exact fit at most.
const EXACT_ITERATIONS: usize = 8;

/// Relative change of the coefficients below which the exact fit has converged.
const EXACT_TOLERANCE: f64 = 1e-7;

/// Relative change of the coefficients the next Gauss-Newton iteration is expected to make
/// (the last step times the last ratio of steps: the iterations converge linearly) below which
/// an exact fit that clearly loses to the linear one is not refined further: what it reports,
/// its score, would move by about as little.
const EXACT_SETTLED: f64 = 1e-9;

/// Relative margin by which the exact fit's score must exceed the linear fit's to lose
/// clearly: far more than a settled fit's score can still move.
const EXACT_CLEAR_LOSS: f64 = 1e-3;

/// Relative improvement of held-out RMS an alternative term set with more columns than
/// `design.terms` needs to be chosen.
pub const TERM_CHOICE_MARGIN: f64 = 0.02;

impl FitSettings {
    /// What `tolles fit` does by default: the patent's 16 traceless terms (or `i5,e8`, the
    /// same span), or over several fluxgates MagNav's 18 if cross-validation finds them
    /// clearly better; a physical prior on the terms' sizes; λ by cross-validation; the exact magnitude
    /// when it predicts held-out data better; otherwise MagNav's filter and trim.
    pub fn recommended() -> Self {
        Self {
            design: Design::new(TermSet::patent()),
            lambda: Lambda::auto(),
            // `i5,e8` spans the same columns as the patent's form but shrinks towards I_zz = 0;
            // on some real flights that predicts a little better, so it competes (without a
            // margin: it is no larger). MagNav's 18 competes with a margin, and only over
            // several fluxgates (see `candidate_designs`). `trace` is left out: on simulated
            // ordinary installations cross-validation took it as often as not and the
            // isotropic term it fitted to the reference's own errors then scaled the survey's
            // anomalies (tests/exact_floor.rs).
            alternative_terms: vec![TermSet::identifiable(), TermSet::magnav_default()],
            magnitude: MagnitudeChoice::Auto,
            // The heading levels are asked for, not a default: against a fluxgate reference
            // whose low frequencies hold tenths of a nT of its own noise, they moved the
            // low-frequency terms more than they pinned them. On `bench/installations`
            // they cost 5 of 15 installations 1.8–7× the band-only fit's survey error and
            // gained at most 1.35× on 3; on our simulator's boxes they changed it by under 5 %
            // but one (1.5× worse); on real boxes they miss by tens of nT and are not used.
            levels: false,
            prior: Some(prior::Prior::AIRCRAFT),
            fluxgate_offset: true,
            ..Self::magnav()
        }
    }

    /// The designs to try: `design` first, then its alternatives when λ is cross-validated.
    /// With extra channels and a cross-validated λ, every term set is tried without them
    /// first and then with them, so the channels must earn their place by the margin a larger
    /// set needs.
    fn candidate_designs(&self) -> Vec<Design> {
        if !matches!(self.lambda, Lambda::CrossValidated { .. }) {
            return vec![self.design.clone()];
        }
        // With one fluxgate, an alternative that spans an isotropic term is its magnitude as a
        // regressor: band-passed, that is the earth's own anomalies inside the band, which it
        // fits (an induced trace of 1.2 on simulated flights over short-wavelength geology, the
        // survey's anomalies then scaled away). Over several fluxgates a second one's magnitude
        // also measures sources near it (a current loop), which only such a set sees. Allowed
        // with one fluxgate too, they won on real cabin pairs only with traces near −1.5 (the
        // survey's anomalies scaled by 1.5) and cost MagNav's real snippet 0.039 → 0.211 nT
        // (`bench/real`).
        let isotropic_allowed = self.design.fluxgates > 1;
        let alternatives = self
            .alternative_terms
            .iter()
            .copied()
            .filter(|t| isotropic_allowed || !t.spans_isotropic());
        let term_sets = std::iter::once(self.design.terms).chain(alternatives);
        let with_extras: Vec<Design> = term_sets
            .map(|terms| Design {
                terms,
                ..self.design.clone()
            })
            .collect();
        if self.design.extras.is_empty() {
            return with_extras;
        }
        let without = with_extras
            .iter()
            .map(|d| d.clone().with_extras(Vec::new()));
        without.chain(with_extras.iter().cloned()).collect()
    }

    /// MagNav.jl's procedure as its tests run it: 18 terms, λ = 0.001, 0.1–0.9 Hz, order 4,
    /// trim 20, `Bt_scale` 50 000.
    pub fn magnav() -> Self {
        Self {
            design: Design::new(TermSet::magnav_default()),
            lambda: Lambda::Fixed(0.001),
            band: Band::MAGNAV,
            order: 4,
            trim: 20,
            alternative_terms: Vec::new(),
            magnitude: MagnitudeChoice::Linear,
            levels: false,
            target: Target::Band,
            prior: None,
            fluxgate_offset: false,
        }
    }

    /// The prior's weights for the columns `terms` of a fit at `fs_hz`, when the settings have
    /// a prior and a cross-validated λ.
    pub(crate) fn prior_weights(&self, terms: &[Term], fs_hz: f64) -> Option<prior::PriorWeights> {
        let prior = self
            .prior
            .filter(|_| !matches!(self.lambda, Lambda::Fixed(_)))?;
        let fraction = match self.target {
            Target::Band => passband_fraction(self.band, fs_hz),
            Target::Interference => 1.0,
        };
        Some(prior::PriorWeights {
            precision: prior.precisions(terms, self.design.bt_scale, fs_hz),
            groups: prior::Prior::groups(terms),
            rows_per_residual: 1.0 / fraction,
            parsimonious: false,
        })
    }

    /// With extra channels and a band whose upper edge is on: rows above the band that only
    /// the extra channels' columns explain (see [`AboveBand`]).
    fn above_band(&self, fs_hz: f64, union: &[Term]) -> Result<Option<AboveBand>, FitError> {
        if self.design.extras.is_empty() || self.target != Target::Band {
            return Ok(None);
        }
        let high_pass = magnav_bandpass(self.band.pass2_hz, 0.0, self.order, fs_hz)?;
        Ok(high_pass.map(|filter| AboveBand {
            filter,
            extra: union
                .iter()
                .map(|t| matches!(t.column, Column::Extra { .. }))
                .collect(),
        }))
    }

    /// The filter the fit applies to every column and the target; `None` for none.
    fn filter(&self, fs_hz: f64) -> Result<Option<Butterworth>, FitError> {
        match self.target {
            Target::Band => Ok(self.band.butterworth(self.order, fs_hz)?),
            Target::Interference => Ok(None),
        }
    }
}

/// Why a fit could not be made.
#[derive(Debug, Error, PartialEq)]
pub enum FitError {
    /// The scalar and the fluxgate differ in length.
    #[error("scalar has {scalar} samples but the fluxgate has {flux}")]
    LengthMismatch {
        /// Length of the scalar series (samples).
        scalar: usize,
        /// Length of the fluxgate series (samples).
        flux: usize,
    },
    /// The sample rate (Hz) is not positive and finite.
    #[error("sample rate must be positive and finite, got {0} Hz")]
    SampleRate(f64),
    /// The ridge strength λ is negative or not finite.
    #[error("ridge strength λ must be finite and ≥ 0, got {0}")]
    Lambda(f64),
    /// The ridge strength λ would shrink every coefficient to nothing.
    #[error("ridge strength λ = {lambda:e} is more than 1e8 times the largest design column's sum of squares ({largest:.3e}): every coefficient would be shrunk to nothing")]
    LambdaTooLarge {
        /// The ridge strength λ given (units of `AᵀA`).
        lambda: f64,
        /// The largest design column's sum of squares (units of `AᵀA`).
        largest: f64,
    },
    /// The fit overflowed: its coefficients or residual are not finite.
    #[error(
        "the fit is unusable: its {what} is not finite (an extreme value in the data overflowed)"
    )]
    NotFinite {
        /// The part of the fit that is not finite (`coefficients` or `residual`).
        what: &'static str,
    },
    /// Cross-validation was asked for with fewer than 2 folds (the number given).
    #[error("cross-validation needs at least 2 folds, got {0}")]
    Folds(usize),
    /// No ridge strength could be fitted on every cross-validation fold.
    #[error("no ridge strength could be fitted on every cross-validation fold (too little data for {terms} terms); fix the ridge strength λ or use fewer terms")]
    CrossValidation {
        /// Number of terms in the design.
        terms: usize,
    },
    /// A fluxgate's field magnitude lies outside 1,000–100,000 nT: probably not in nT.
    #[error("fluxgate {} magnitude {} nT at sample {index} is outside 1,000–100,000 nT: is the fluxgate in nT?", fluxgate + 1, show_nt(*magnitude))]
    FluxMagnitude {
        /// Fluxgate block (0-based).
        fluxgate: usize,
        /// The first sample out of range (0-based sample index).
        index: usize,
        /// Its field magnitude (nT).
        magnitude: f64,
    },
    /// The number of fluxgates differs from the design's.
    #[error("the design is for {design} fluxgates but {given} were given")]
    FluxgateCount {
        /// Number of fluxgates the design is for.
        design: usize,
        /// Number of fluxgates given.
        given: usize,
    },
    /// The number of extra channels differs from the design's.
    #[error("the design names {design} extra channels but {given} were given")]
    ExtraCount {
        /// Number of extra channels the design names.
        design: usize,
        /// Number of extra channels given.
        given: usize,
    },
    /// An extra channel differs in length from the fluxgate.
    #[error("extra channel {} has {samples} samples but the fluxgate has {first}", channel + 1)]
    ExtraLength {
        /// Extra channel (0-based).
        channel: usize,
        /// Its length (samples).
        samples: usize,
        /// The first fluxgate's length (samples).
        first: usize,
    },
    /// A fluxgate differs in length from the first.
    #[error("fluxgate {} has {samples} samples but the first has {first}", fluxgate + 1)]
    FluxgateLength {
        /// Fluxgate block (0-based).
        fluxgate: usize,
        /// Its length (samples).
        samples: usize,
        /// The first fluxgate's length (samples).
        first: usize,
    },
    /// No sample is usable; names the input that is missing, non-finite or out of range throughout.
    #[error("no sample has the scalar and every fluxgate component: {0} is missing, non-finite or out of range throughout")]
    NothingUsable(String),
    /// The scalar magnetometer never changes over the usable samples.
    #[error("the scalar magnetometer is constant: there is nothing to fit")]
    ConstantScalar,
    /// The fluxgate never changes over the usable samples: the aircraft did not maneuver.
    #[error("the fluxgate is constant: the aircraft did not maneuver, so no term can be fitted")]
    ConstantFlux,
    /// Fewer usable samples than terms after filtering and trimming.
    #[error("only {usable} usable samples after filtering and trimming, fewer than the {terms} terms; use a longer flight, fewer terms or a smaller trim")]
    TooFewSamples {
        /// Usable samples left after filtering and trimming.
        usable: usize,
        /// Number of terms in the design.
        terms: usize,
    },
    /// The fitted model is physically implausible even with its terms restrained.
    #[error("refused: the fit found {0}, a field no aircraft has, even with its terms restrained; the flight does not determine the model (fly maneuvers, or use fewer terms)")]
    Implausible(plausible::Fault),
    /// The regularised solve failed.
    #[error(transparent)]
    Ridge(#[from] RidgeError),
    /// The band-pass filter could not be designed or applied.
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
    /// this much later (see [`lag::shifted`]). Zero unless a lag was given or estimated.
    #[serde(default, skip_serializing_if = "is_zero")]
    pub lag_s: f64,
    /// The lone fluxgate's offset (nT; x, y, z) taken out of its readings before the design
    /// is built, in the fit and in every compensation (see [`FitSettings::fluxgate_offset`]).
    /// A cabin fluxgate sees the aircraft's own field, thousands of nT that bend every
    /// direction cosine by a few percent; `None`: the readings as they are.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub flux_offset_nt: Option<[f64; 3]>,
    /// Names of the columns, in order (see [`Design::column_names`]).
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
    pub uncertainty: Option<trust::Uncertainty>,
    /// The directions, rates and channel values the calibration spanned, to tell which rows a
    /// compensation extrapolates to (absent before version 3).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub coverage: Option<crate::model::coverage::Coverage>,
}

/// Fits a model to a calibration flight.
///
/// - `scalar`: the uncompensated scalar magnetometer (nT); non-finite samples are skipped;
/// - `flux`: the fluxgate (nT, body frame FRD), or several, one per block of
///   `settings.design` (see [`Design`]); a sample is skipped if any of them is not finite;
/// - `fs_hz`: sample rate (Hz);
/// - `tt`: optional time (seconds) used only to split runs at gaps.
pub fn fit<'a>(
    scalar: &[f64],
    flux: impl Into<Fluxgates<'a>>,
    fs_hz: f64,
    tt: Option<&[f64]>,
    settings: &FitSettings,
) -> Result<Fit, FitError> {
    let flux = flux.into();
    check_inputs(scalar, &flux, fs_hz, settings)?;
    let samples = Samples::of(scalar, &flux, tt);
    let spare = Spare::default();
    fit_reusing(
        scalar,
        flux,
        fs_hz,
        &samples,
        settings,
        &spare,
        Wanted::Everything,
    )
}

/// The samples a fit uses and their runs, worked out once per flight: a fluxgate calibration
/// within a fit ([`levels`]) takes the fit's, rather than checking and scanning 10⁷ samples
/// again (0.1 s).
#[derive(Debug, Clone)]
pub(super) struct Samples {
    /// Per sample: every fluxgate finite and the scalar believable ([`scalar_usable`]).
    pub(super) usable: Vec<bool>,
    /// Maximal runs of usable samples, split at gaps in time
    /// ([`crate::signal::segment::contiguous_runs`]).
    pub(super) runs: Vec<Range<usize>>,
}

impl Samples {
    /// The usable samples of `scalar` (nT) and `flux` (as long as it, checked) and their runs,
    /// split at gaps in `tt` (s).
    fn of(scalar: &[f64], flux: &Fluxgates, tt: Option<&[f64]>) -> Self {
        let mut usable = flux.finite_mask();
        crate::parallel::split_items(&mut usable, |rows, usable| {
            usable
                .iter_mut()
                .zip(&scalar[rows])
                .for_each(|(u, s)| *u &= scalar_usable(*s));
        });
        Self::within(usable, tt)
    }

    /// The runs of the samples `usable`, split at gaps in `tt` (s).
    pub(super) fn within(usable: Vec<bool>, tt: Option<&[f64]>) -> Self {
        let runs = contiguous_runs(&usable, tt);
        Self { usable, runs }
    }
}

/// What the caller of [`fit_reusing`] reads of the fit.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Wanted {
    /// Every part of the [`Fit`].
    Everything,
    /// The coefficients and the residual's standard deviation only (a fluxgate calibration):
    /// the mean correction and the scatter before the fit, each a pass over every sample,
    /// are left out (`level_nt` 0, `filtered_std_before_nt` NaN).
    Coefficients,
}

/// [`fit`] of the checked inputs on `samples` (those of `scalar`: a sample of it that is not
/// believable is not among them), with its large buffers from `spare`, and given back to it
/// when done.
fn fit_reusing(
    scalar: &[f64],
    flux: Fluxgates,
    fs_hz: f64,
    samples: &Samples,
    settings: &FitSettings,
    spare: &Spare,
    wanted: Wanted,
) -> Result<Fit, FitError> {
    let usable = &samples.usable;
    check_not_constant(scalar, flux.series()[0], usable)?;
    let designs = settings.candidate_designs();
    let union = union_of_terms(&designs);
    // The rows hold the columns of `basis.stored`; factors and level rows are mapped onto
    // `union` before the candidates take theirs.
    let basis = Basis::of(&union);
    let stored = &basis.stored;
    let problem = Problem {
        scalar,
        flux: &flux,
        samples,
        filter: settings.filter(fs_hz)?,
        above: settings.above_band(fs_hz, stored)?,
        settings,
        spare,
        fs_hz,
        window_samples: windows::window_samples(),
        parsimonious: std::sync::atomic::AtomicBool::new(false),
    };
    let above = problem.above.as_ref();
    // The linear rows are the largest buffer; a calibration of the fluxgate in a pass of its own
    // uses its first part.
    let longest = samples.runs.iter().map(|r| r.len()).max().unwrap_or(0);
    let low = problem.level_low_pass(fs_hz)?;
    // With levels, the fluxgate is calibrated in this pass when it can be: its magnitude is
    // one more signal, after the target.
    let in_pass = low
        .as_ref()
        .and_then(|_| levels::InPass::of(settings, stored, above.is_some(), fs_hz));
    let extra = usize::from(in_pass.is_some());
    spare.reserve(problem.buffer_len(longest, stored.len() + extra, low.as_ref(), above));
    let mut levels = match in_pass {
        Some(_) => problem.level_setup_pending(fs_hz)?,
        None => problem.level_setup(fs_hz)?,
    };
    let series = flux.series()[0];
    let linear = |run: Range<usize>, rows: Range<usize>, out: &mut [&mut [f64]]| {
        let (a, after) = out.split_at_mut(stored.len());
        let (y, magnitude) = after.split_at_mut(1);
        settings.design.matrix_rows_into_columns(
            flux.clone(),
            run.clone(),
            rows.clone(),
            stored,
            a,
        );
        let samples = run.start + rows.start..run.start + rows.end;
        if let Some(m) = magnitude.first_mut() {
            let components = [&series.x, &series.y, &series.z].map(|c| &c[samples.clone()]);
            crate::model::vector::norms3_into(components, m);
        }
        y[0].copy_from_slice(&scalar[samples]);
    };
    let count = fold_count(settings.lambda);
    // The band rows are factored once, cut where the folds of any plan start: the folds
    // move when the level rows join, and the calibration's may be more or fewer.
    let mut plans = problem.plans_ahead(levels.as_ref(), above, &[false, true], count);
    let level_plan = plans.pop().filter(|_| levels.is_some());
    let band_plan = plans.pop().expect("the band rows' plan");
    let calibration_plan = in_pass
        .as_ref()
        .and_then(|_| problem.calibration_plan(levels.as_ref(), above, &band_plan));
    let plans: Vec<&problem::Plan> = std::iter::once(&band_plan)
        .chain(&level_plan)
        .chain(&calibration_plan)
        .collect();
    let mut prepared =
        problem.prepare(stored.len(), extra, &linear, levels.as_ref(), above, &plans)?;
    debug_assert!(prepared.plan(false, count) == band_plan);
    let band = prepared.band_factors(&plans);
    let band_folds = prepared.fold_factors(&band_plan, 0.0, &band);
    if let Some(in_pass) = &in_pass {
        let folds = match &calibration_plan {
            Some(plan) => prepared.fold_factors(plan, 0.0, &band),
            None => band_folds.clone(),
        };
        levels = levels.and_then(|setup| {
            problem.calibrated_in_pass(setup, in_pass, &folds, &mut prepared.levels, fs_hz)
        });
    }
    let excitation = excitation_of(&band_folds, stored, prepared.band_row_count());
    // Without maneuvers the folds cannot separate the terms: among priors they cannot tell
    // apart, the strongest (MagNav's real snippet, 0.72° RMS: 0.205 → 0.039 nT on its other half).
    problem
        .parsimonious
        .store(excitation < verdict::MIN_EXCITATION_DEG, Relaxed);
    let prior = problem.prior_weights(&union);
    let band_folds = basis.folds(band_folds);
    let mut chosen = choose_design(
        &band_folds,
        &designs,
        &union,
        settings.lambda,
        0.0,
        prior.as_ref(),
        fs_hz,
    )?;
    let (mut untrusted, mut untrusted_levels_nt) = (false, None);
    if let (Some(setup), Some(plan)) = (levels.as_mut(), &level_plan) {
        let rows = basis.level_rows(&prepared.levels);
        let candidates = (union.as_slice(), designs.as_slice());
        let terms = designs[chosen.index].design_terms();
        let on_union = problem::on_columns(&union, &terms, &chosen.solution.coefficients);
        let above = prepared.above_residual(&basis.on_stored(&on_union));
        let choice =
            problem.choose_with_levels(setup, (&chosen, above), candidates, rows, |setup| {
                let folds = basis.folds(prepared.fold_factors(plan, setup.weight(), &band));
                let weight = setup.weight();
                let prior = prior.as_ref();
                choose_design(
                    &folds,
                    &designs,
                    &union,
                    settings.lambda,
                    weight,
                    prior,
                    fs_hz,
                )
            })?;
        match choice {
            LevelChoice::Used(with_levels) => chosen = *with_levels,
            LevelChoice::Untrusted { misfit_nt } => {
                untrusted = true;
                untrusted_levels_nt = misfit_nt.is_finite().then_some(misfit_nt);
            }
        }
    }
    if untrusted {
        levels = None;
    }
    let design = designs[chosen.index].clone();
    let before = match wanted {
        Wanted::Everything => prepared.band_std(),
        Wanted::Coefficients => f64::NAN,
    };
    let (short, runs_used) = (prepared.short, prepared.runs_used());
    let above_rows = prepared.above_rows();
    let chosen_terms = designs[chosen.index].design_terms();
    let on_stored = basis.on_stored(&problem::on_columns(
        &union,
        &chosen_terms,
        &chosen.solution.coefficients,
    ));
    // The rows above the band hold what only the extra channels explain there: the aircraft's
    // other fields above the band are left in them, so they are no part of the band's residual.
    let mut above_rss = prepared.above_residual(&on_stored).0;
    let mut band_scores = match wanted {
        Wanted::Everything => {
            let block = score_block(settings, fs_hz);
            prepared.score_covariance(&on_stored, block).map(|s| {
                problem::on_column_pairs(&union, &chosen_terms, &basis.square_on_terms(&s))
            })
        }
        Wanted::Coefficients => None,
    };
    spare.give(prepared.into_buffers());
    let terms = design.design_terms();
    let exact = problem.exact(&design, &chosen, levels.as_ref())?;
    let (magnitude, chosen, iterations) = match exact {
        Some(exact) => {
            let picked = pick_magnitude(chosen, exact.chosen, exact.iterations, settings.magnitude);
            // The level rows describe the fit kept: the Gauss-Newton ones only for the exact.
            if picked.0 == Magnitude::Exact {
                if let Some(setup) = levels.as_mut() {
                    setup.rows = exact.level_rows;
                    setup.row_terms = terms.clone();
                }
                band_scores = band_scores.and(exact.band_scores);
                above_rss = exact.above_rss;
            }
            picked
        }
        None => (Magnitude::Linear, chosen, 0),
    };
    let model = Model {
        design: &design,
        coefficients: &chosen.solution.coefficients,
        magnitude,
    };
    let (level_nt, white_noise_nt) = match wanted {
        Wanted::Everything => level_and_noise(scalar, &flux, &samples.runs, model, spare),
        Wanted::Coefficients => (0.0, f64::NAN),
    };
    let mut diagnostics = diagnostics(
        &chosen.solution,
        DiagnosticCounts {
            level_rows: levels.as_ref().map_or(0, |l| l.row_count()),
            above_rows,
            above_rss,
            level_rss: levels.as_ref().map_or(0.0, |l| {
                l.weighted_rss(&terms, &chosen.solution.coefficients)
            }),
            total: scalar.len(),
            nonfinite: usable.iter().filter(|u| !**u).count(),
            short,
            runs_used,
            before_std: before,
            fraction: match settings.target {
                Target::Band => passband_fraction(settings.band, fs_hz),
                Target::Interference => 1.0,
            },
        },
        chosen.cross_validation,
        chosen.scores,
    );
    diagnostics.levels = levels
        .as_ref()
        .map(|l| l.diagnostics(&terms, &chosen.solution.coefficients));
    diagnostics.untrusted_levels_nt = untrusted_levels_nt;
    diagnostics.exact_iterations = iterations;
    diagnostics.excitation_deg = excitation.is_finite().then_some(excitation);
    diagnostics.restrained = chosen.restrained.clone();
    check_finite(&chosen.solution.coefficients, &diagnostics, wanted)?;
    let assessed = (wanted == Wanted::Everything).then(|| {
        let solution = &chosen.solution;
        let dof = solution
            .rows
            .saturating_sub(solution.coefficients.len())
            .max(1);
        let inputs = trust::Inputs {
            design: &design,
            coefficients: &solution.coefficients,
            solution,
            lambda: settings.lambda,
            fs_hz,
            restrained: chosen.restrained.clone(),
            excitation_deg: excitation,
            white_noise_nt,
            covariance: match &band_scores {
                Some(band) => {
                    let level = levels.as_ref().map(|l| {
                        let s = l.score_covariance(&terms, &solution.coefficients, fs_hz);
                        problem::on_column_pairs(&l.row_terms, &terms, &s)
                    });
                    solution.sandwich(&level.map_or_else(|| band.clone(), |l| band + l))
                }
                None => solution
                    .covariance(solution.rss / dof as f64 / diagnostics.effective_sample_fraction),
            },
            interference: !settings.target.is_band(),
        };
        trust::assess(inputs, &diagnostics, &flux, &samples.runs)
    });
    let (uncertainty, coverage, verdict) = match assessed {
        Some((u, c, v)) => (u, Some(c), Some(v)),
        None => (None, None, None),
    };
    // One standard error everywhere: the table, the model file and the report show the
    // covariance the verdict and each row's σ use.
    if let Some(u) = &uncertainty {
        let p = u.mean_row.len();
        diagnostics.std_errors = (0..p)
            .map(|j| u.covariance[j * p + j].max(0.0).sqrt())
            .collect();
    }
    Ok(Fit {
        settings: FitSettings {
            design: design.clone(),
            ..settings.clone()
        },
        fs_hz,
        magnitude,
        lag_s: 0.0,
        flux_offset_nt: None,
        columns: design.column_names(&[]),
        coefficients: chosen.solution.coefficients,
        level_nt,
        diagnostics,
        verdict,
        uncertainty,
        coverage,
    })
}

/// RMS change (degrees) of the first fluxgate's direction inside the band, from the folds'
/// factors of the band rows (`band_rows` of them) over the `stored` columns: their permanent
/// columns are its band-passed direction cosines. NaN without those columns.
fn excitation_of(folds: &[problem::FoldFactor], stored: &[Term], band_rows: usize) -> f64 {
    let cosines: Vec<usize> = crate::model::terms::Axis::ALL
        .iter()
        .filter_map(|a| {
            stored.iter().position(|t| {
                t.fluxgate == 0 && t.column == crate::model::terms::Column::Permanent(*a)
            })
        })
        .collect();
    let sums: Vec<f64> = cosines
        .iter()
        .map(|&j| folds.iter().map(|f| f.r.column(j).norm_squared()).sum())
        .collect();
    trust::excitation_deg(&sums, band_rows)
}

fn is_zero(v: &f64) -> bool {
    *v == 0.0
}

/// Refuses a fit that overflowed: a model with NaN coefficients would be refused only later,
/// by whoever applies it, far from the cause.
fn check_finite(
    coefficients: &[f64],
    diagnostics: &Diagnostics,
    wanted: Wanted,
) -> Result<(), FitError> {
    if !coefficients.iter().all(|b| b.is_finite()) {
        return Err(FitError::NotFinite {
            what: "coefficients",
        });
    }
    let before = diagnostics.filtered_std_before_nt;
    if !(diagnostics.residual_std_nt.is_finite()
        && (before.is_finite() || wanted == Wanted::Coefficients))
    {
        return Err(FitError::NotFinite { what: "residual" });
    }
    Ok(())
}

/// The mean of the model's unfiltered correction over the calibration's `runs` (nT), and the
/// white noise of the scalar less it (nT): the standard deviation of its fourth difference
/// over `√70 / 16`, what that difference keeps of white noise.
fn level_and_noise(
    scalar: &[f64],
    flux: &Fluxgates,
    runs: &[Range<usize>],
    model: Model,
    spare: &Spare,
) -> (f64, f64) {
    let mut field = spare.take(flux.len());
    write_runs(flux.clone(), runs, model, &mut field[..flux.len()]);
    // Run by run, each summed from its first sample: the same additions as ever.
    let mut sum = 0.0;
    let mut count = 0usize;
    for run in runs {
        sum += field[run.clone()].iter().sum::<f64>();
        count += run.len();
    }
    // What the model leaves, in place of the correction (no fresh flight-long vector).
    field[..flux.len()]
        .iter_mut()
        .zip(scalar)
        .for_each(|(f, y)| *f = y - *f);
    let white = crate::signal::metrics::fourth_difference_noise_over(&field[..flux.len()], runs)
        / (70f64.sqrt() / 16.0);
    spare.give([field]);
    let level = if count == 0 { 0.0 } else { sum / count as f64 };
    (level, white)
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    proptest! {
        #[test]
        fn flux_magnitude_check_finds_the_first_sample_out_of_range(
            // Magnitudes at, just inside and just outside both limits, NaN, and (mostly)
            // ordinary ones, so the first sample out of range is often a few blocks in.
            picks in prop::collection::vec((0usize..4000, 0.0f64..1.0), 1..5000),
        ) {
            let (lo, hi) = FLUX_MAGNITUDE_RANGE_NT;
            let magnitudes = [lo, hi, lo * (1.0 - 1e-16), hi * (1.0 + 2e-16), 0.0, f64::NAN, 50_000.0];
            let flux = VectorSeries::new(
                picks.iter().map(|(m, f)| magnitudes[(*m).min(6)] * f.sqrt()).collect(),
                picks.iter().map(|(m, f)| magnitudes[(*m).min(6)] * (1.0 - f).sqrt()).collect(),
                vec![0.0; picks.len()],
            );
            let expected = (0..flux.len()).find(|&k| {
                let m = flux.magnitude(k);
                !m.is_nan() && !(lo..=hi).contains(&m)
            });
            match check_flux_magnitude(&flux) {
                Ok(()) => prop_assert_eq!(expected, None),
                Err(FitError::FluxMagnitude { index, .. }) => prop_assert_eq!(Some(index), expected),
                Err(e) => prop_assert!(false, "{e}"),
            }
        }
    }

    /// A long flight is checked in a part per core: the sample reported is the first out of
    /// range, whichever part holds it.
    #[test]
    fn flux_magnitude_check_of_a_long_flight_finds_the_first_sample_out_of_range() {
        let n = 3 * crate::parallel::PARALLEL_ROWS;
        let series = |bad: &[usize]| {
            let mut x = vec![50_000.0; n];
            bad.iter().for_each(|&k| x[k] = 1e7);
            VectorSeries::new(x, vec![0.0; n], vec![0.0; n])
        };
        let late = 2 * n / 3 + 5;
        for (bad, first) in [
            (vec![late], late),
            (vec![late, 7], 7),
            (vec![n / 2, n - 1], n / 2),
        ] {
            match check_flux_magnitude(&series(&bad)) {
                Err(FitError::FluxMagnitude { index, .. }) => assert_eq!(index, first, "{bad:?}"),
                other => panic!("{other:?}"),
            }
        }
        assert!(check_flux_magnitude(&series(&[])).is_ok());
    }

    proptest! {
        /// Blocks of every length, merged across blocks and calls, and an offset far larger
        /// than the scatter (a band-passed target is centred, a level is not).
        #[test]
        fn running_std_by_blocks_is_the_two_pass_std(
            lengths in proptest::collection::vec(0usize..5000, 1..4),
            offset in -1e4f64..1e4,
            seed in 0.0f64..10.0,
        ) {
            let parts: Vec<Vec<f64>> = lengths
                .iter()
                .enumerate()
                .map(|(p, &n)| {
                    (0..n)
                        .map(|k| offset + (k as f64 * 0.37 + seed + p as f64).sin() * (1.0 + p as f64))
                        .collect()
                })
                .collect();
            let mut running = RunningStd::default();
            parts.iter().for_each(|p| running.push_all(p));
            // Two plain passes over all the values.
            let want = crate::signal::metrics::std_dev(&parts.concat());
            if lengths.iter().sum::<usize>() == 0 {
                prop_assert!(running.std().is_nan());
            } else {
                prop_assert!(
                    (running.std() - want).abs() <= 1e-9 * want.max(1e-3),
                    "{} vs {}", running.std(), want
                );
            }
        }
    }

    #[test]
    fn passband_fraction_follows_the_fallbacks() {
        let band = |a, b| Band {
            pass1_hz: a,
            pass2_hz: b,
        };
        assert!((passband_fraction(band(0.1, 0.9), 10.0) - 0.16).abs() < 1e-12);
        assert!((passband_fraction(band(0.0, 1.0), 10.0) - 0.2).abs() < 1e-12);
        assert_eq!(passband_fraction(band(0.0, 99.0), 10.0), 1.0);
    }

    #[test]
    fn settings_are_validated() {
        let flux = VectorSeries::new(vec![30_000.0; 3], vec![0.0; 3], vec![40_000.0; 3]);
        let mut s = FitSettings::magnav();
        s.lambda = Lambda::Fixed(-1.0);
        assert_eq!(
            fit(&[1.0; 3], &flux, 10.0, None, &s).unwrap_err(),
            FitError::Lambda(-1.0)
        );
        s.lambda = Lambda::CrossValidated { folds: 1 };
        assert_eq!(
            fit(&[1.0; 3], &flux, 10.0, None, &s).unwrap_err(),
            FitError::Folds(1)
        );
        assert_eq!(
            fit(&[1.0; 3], &flux, 0.0, None, &s).unwrap_err(),
            FitError::SampleRate(0.0)
        );
    }

    /// The module example's flight: a permanent term of 40 nT along x.
    fn turning_flight() -> (Vec<f64>, VectorSeries, FitSettings) {
        let (fs, n) = (10.0, 2000);
        let angle = |k: usize| 0.35 * (2.0 * std::f64::consts::PI * 0.2 * k as f64 / fs).sin();
        let flux = VectorSeries::new(
            (0..n).map(|k| 20_000.0 * angle(k).cos()).collect(),
            (0..n).map(|k| 20_000.0 * angle(k).sin()).collect(),
            vec![45_000.0; n],
        );
        let scalar = (0..n)
            .map(|k| 50_000.0 + 40.0 * flux.x[k] / flux.magnitude(k))
            .collect();
        let settings = FitSettings {
            design: Design::new("p".parse().unwrap()),
            lambda: Lambda::Fixed(0.0),
            ..FitSettings::magnav()
        };
        (scalar, flux, settings)
    }

    #[test]
    fn a_scalar_spike_is_skipped_not_fitted() {
        let (mut scalar, flux, settings) = turning_flight();
        scalar[700] = 1e300;
        let model = fit(&scalar, &flux, 10.0, None, &settings).unwrap();
        assert!((model.coefficients[0] - 40.0).abs() < 1e-6);
        assert!(model.diagnostics.residual_std_nt.is_finite());
        assert_eq!(model.diagnostics.samples_nonfinite, 1);
    }

    #[test]
    fn an_overflowing_or_infinite_fluxgate_is_out_of_range() {
        for bad in [1e155, 1e200, f64::INFINITY] {
            let (scalar, mut flux, settings) = turning_flight();
            flux.y[101] = bad;
            match fit(&scalar, &flux, 10.0, None, &settings).unwrap_err() {
                FitError::FluxMagnitude { index, .. } => assert_eq!(index, 101),
                e => panic!("{e}"),
            }
        }
    }

    #[test]
    fn an_absurd_fixed_lambda_is_refused_quickly() {
        let (scalar, flux, mut settings) = turning_flight();
        settings.lambda = Lambda::Fixed(1e308);
        assert!(matches!(
            fit(&scalar, &flux, 10.0, None, &settings).unwrap_err(),
            FitError::LambdaTooLarge { .. }
        ));
    }

    #[test]
    fn a_fit_that_overflows_is_an_error() {
        let diagnostics = |residual| Diagnostics {
            residual_std_nt: residual,
            ..turning_fit().diagnostics
        };
        let all = Wanted::Everything;
        assert_eq!(
            check_finite(&[f64::NAN], &diagnostics(1.0), all),
            Err(FitError::NotFinite {
                what: "coefficients"
            })
        );
        assert_eq!(
            check_finite(&[1.0], &diagnostics(f64::NAN), all),
            Err(FitError::NotFinite { what: "residual" })
        );
        // A calibration leaves the scatter before the fit out (NaN); its residual still counts.
        let mut unmeasured = diagnostics(1.0);
        unmeasured.filtered_std_before_nt = f64::NAN;
        assert!(check_finite(&[1.0], &unmeasured, all).is_err());
        assert_eq!(
            check_finite(&[1.0], &unmeasured, Wanted::Coefficients),
            Ok(())
        );
        let coefficients_only = Wanted::Coefficients;
        assert!(check_finite(&[1.0], &diagnostics(f64::NAN), coefficients_only).is_err());
    }

    #[test]
    fn an_exact_fit_that_loses_stops_once_settled_and_the_linear_fit_keeps_its_level_rows() {
        use crate::flight::plan::BoxPlan;
        use crate::flight::sim::{simulate, Installation};
        let mut scenario = Installation::Cabin.scenario(2);
        scenario.extras.current = None;
        let cal = simulate(&BoxPlan::default().build(), &scenario).unwrap();
        let fit_with = |magnitude| {
            let settings = FitSettings {
                magnitude,
                levels: true,
                ..FitSettings::recommended()
            };
            fit(&cal.scalar, &cal.flux, 10.0, Some(&cal.tt), &settings).unwrap()
        };
        let exact_score = |f: &Fit| {
            let mut s = f.diagnostics.term_choice.iter();
            let exact = s.rfind(|t| t.magnitude == Magnitude::Exact);
            exact.and_then(|t| t.heldout_rms_nt).unwrap()
        };
        let auto = fit_with(MagnitudeChoice::Auto);
        let converged = fit_with(MagnitudeChoice::Exact);
        // The exact fit loses, and takes three iterations to converge when it is wanted ...
        assert_eq!(auto.magnitude, Magnitude::Linear);
        assert_eq!(converged.diagnostics.exact_iterations, 3);
        // ... yet the score it reports after two, settled, is the converged fit's.
        let (early, last) = (exact_score(&auto), exact_score(&converged));
        assert!((early - last).abs() <= 1e-9 * last, "{early} {last}");
        // The linear fit kept is described by its own level rows, not the exact fit's.
        let linear = fit_with(MagnitudeChoice::Linear);
        let levels = |f: &Fit| f.diagnostics.levels.clone().unwrap();
        assert_eq!(levels(&auto), levels(&linear));
        assert_eq!(
            auto.diagnostics.residual_std_nt,
            linear.diagnostics.residual_std_nt
        );
    }

    /// The fluxgate calibrated from the linear fit's own rows (with levels) is the one its own
    /// fit finds ([`levels::reference`]), in runs done whole and in windows; and so is the one
    /// calibrated in a pass of its own, for a `Bt_scale` unlike the calibration's.
    #[test]
    fn the_fluxgate_calibrated_in_the_fit_pass_is_the_one_its_own_fit_finds() {
        use crate::flight::plan::BoxPlan;
        use crate::flight::sim::{simulate, Installation};
        let recommended = FitSettings {
            levels: true,
            ..FitSettings::recommended()
        };
        let union = union_of_terms(&recommended.candidate_designs());
        let stored = Basis::of(&union).stored;
        assert!(levels::InPass::of(&recommended, &stored, false, 10.0).is_some());
        let mut other_scale = recommended.clone();
        other_scale.design.bt_scale = 20_000.0;
        assert!(levels::InPass::of(&other_scale, &stored, false, 10.0).is_none());
        let scenario = Installation::TailStinger.scenario(3);
        let short = simulate(&BoxPlan::default().build(), &scenario).unwrap();
        // Three boxes of long manoeuvres: one run of about 80 000 samples, done in windows.
        let long_plan = BoxPlan {
            headings_deg: [0.0, 90.0, 180.0, 270.0].repeat(3),
            cycles: 30,
            ..BoxPlan::default()
        };
        let long = simulate(&long_plan.build(), &scenario).unwrap();
        for (flight, windowed) in [(&short, false), (&long, true)] {
            let (scalar, flux, tt) = (&flight.scalar, &flight.flux, Some(&flight.tt[..]));
            let usable = vec![true; scalar.len()];
            let own = levels::reference(flux, &usable, 10.0, tt, &recommended).unwrap();
            let own = own.calibration;
            let mut seen = Vec::new();
            for settings in [&recommended, &other_scale] {
                windows::windows_in_tests::DONE.set(0);
                let fitted = in_windows(|| fit(scalar, flux, 10.0, tt, settings)).unwrap();
                assert_eq!(windows::windows_in_tests::DONE.get() > 0, windowed);
                let levels = fitted.diagnostics.levels.unwrap();
                // Another Bt_scale only rescales columns: the same fit, whose level rows'
                // target was made from the reference in the pass or before it.
                seen.push([
                    levels.residual_rms_nt,
                    levels.weight,
                    fitted.diagnostics.residual_std_nt,
                ]);
                let got = levels.fluxgate;
                let values = |c: &levels::FluxgateCalibration| {
                    let mut v = c.offset_nt.to_vec();
                    v.extend(c.distortion.map(|d| d * 50_000.0));
                    v.push(c.residual_std_nt);
                    v
                };
                for (a, b) in values(&got).iter().zip(values(&own)) {
                    // Offsets and distortions near 0 move by the rounding of the others.
                    let close = (a - b).abs() <= 1e-9 * a.abs().max(b.abs()).max(1e-3);
                    assert!(close, "{a} vs {b}: {got:?} vs {own:?}");
                }
            }
            // The level rows' misfit and weight agree to rounding; the band residual to the
            // rounding of a solve whose confounded columns (the patent's pairs) leave it
            // conditioned near 10¹⁰ (a few parts in 10⁶).
            for ((a, b), tolerance) in seen[0].iter().zip(seen[1]).zip([1e-9, 1e-9, 1e-5]) {
                assert!(
                    (a - b).abs() <= tolerance * a.abs().max(b.abs()),
                    "{seen:?}"
                );
            }
        }
    }

    /// Runs `f` with the fits it starts cutting runs of more than 2¹⁶ samples into windows.
    fn in_windows<T>(f: impl FnOnce() -> T) -> T {
        windows::with_window_samples(1 << 15, f)
    }

    /// A run of 100 000 samples at 10 Hz, done whole or (with [`in_windows`]) in windows: its
    /// scalar and fluxgate.
    fn long_run() -> (Vec<f64>, VectorSeries) {
        let (fs, n) = (10.0, 100_000);
        let t = |k: usize| k as f64 / fs;
        let roll = |k: usize| 0.3 * (0.9 * t(k)).sin() + 0.1 * (0.013 * t(k)).sin();
        let pitch = |k: usize| 0.2 * (1.3 * t(k) + 1.0).sin();
        let yaw = |k: usize| 0.002 * t(k) + 0.2 * (0.4 * t(k)).sin();
        let flux = VectorSeries::new(
            (0..n)
                .map(|k| 20_000.0 * yaw(k).cos() * pitch(k).cos())
                .collect(),
            (0..n)
                .map(|k| 20_000.0 * yaw(k).sin() + 900.0 * roll(k))
                .collect(),
            (0..n)
                .map(|k| 45_000.0 + 8_000.0 * pitch(k) * roll(k).cos())
                .collect(),
        );
        let scalar: Vec<f64> = (0..n)
            .map(|k| {
                let u = [flux.x[k], flux.y[k], flux.z[k]].map(|c| c / flux.magnitude(k));
                50_000.0 + 40.0 * u[0] - 25.0 * u[2]
                    + 3e-3 * flux.y[k] * u[1]
                    + 0.01 * (7.1 * t(k)).sin()
            })
            .collect();
        (scalar, flux)
    }

    #[test]
    fn a_long_run_done_in_windows_fits_as_when_done_whole() {
        use windows::windows_in_tests::DONE;
        let (scalar, flux) = long_run();
        let fs = 10.0;
        let settings = FitSettings::recommended();
        DONE.set(0);
        let windowed = in_windows(|| fit(&scalar, &flux, fs, None, &settings)).unwrap();
        assert!(DONE.get() > 0, "the run was done in windows");
        DONE.set(0);
        let whole = fit(&scalar, &flux, fs, None, &settings).unwrap();
        assert_eq!(DONE.get(), 0, "the production window takes the run whole");
        let d = (&windowed.diagnostics, &whole.diagnostics);
        assert_eq!(d.0.exact_iterations, d.1.exact_iterations);
        assert_eq!(windowed.columns, whole.columns);
        let close = |a: f64, b: f64| (a - b).abs() <= 1e-9 * a.abs().max(b.abs()).max(1e-3);
        for (a, b) in windowed.coefficients.iter().zip(&whole.coefficients) {
            assert!(close(*a, *b), "{a} vs {b}");
        }
        assert!(close(d.0.residual_std_nt, d.1.residual_std_nt));
        assert!(close(
            d.0.filtered_std_before_nt,
            d.1.filtered_std_before_nt
        ));
        assert!(close(windowed.level_nt, whole.level_nt));
    }

    /// A run whose first window is not surely varying (here: level and steady for its first
    /// 5 000 samples) is done whole, on however many cores, the other windows' work dropped.
    #[test]
    fn a_run_steady_at_its_start_is_done_whole() {
        use windows::windows_in_tests::DONE;
        let (mut scalar, mut flux) = long_run();
        for k in 0..5_000 {
            (flux.x[k], flux.y[k], flux.z[k], scalar[k]) =
                (flux.x[0], flux.y[0], flux.z[0], scalar[0]);
        }
        let settings = FitSettings::recommended();
        DONE.set(0);
        let fitted = || fit(&scalar, &flux, 10.0, None, &settings);
        let dealt = crate::parallel::on_cores(3, || in_windows(fitted));
        assert_eq!(DONE.get(), 0, "no run was done in windows");
        let whole = crate::parallel::on_cores(3, fitted);
        let bits = |f: &Fit| {
            f.coefficients
                .iter()
                .map(|c| c.to_bits())
                .collect::<Vec<_>>()
        };
        assert_eq!(bits(&dealt.unwrap()), bits(&whole.unwrap()));
    }

    /// Each window is worked on one core and the windows' parts are put together in order, so
    /// how many cores share them changes no bit.
    #[test]
    fn windows_dealt_to_any_number_of_cores_give_the_same_bits() {
        use windows::windows_in_tests::DONE;
        let (scalar, flux) = long_run();
        let settings = FitSettings::recommended();
        let on = |cores| {
            crate::parallel::on_cores(cores, || {
                in_windows(|| fit(&scalar, &flux, 10.0, None, &settings)).unwrap()
            })
        };
        DONE.set(0);
        let (one, three) = (on(1), on(3));
        assert!(DONE.get() >= 2, "both fits were done in windows");
        let bits = |f: &Fit| {
            let d = &f.diagnostics;
            let mut v: Vec<u64> = f.coefficients.iter().map(|c| c.to_bits()).collect();
            v.extend([d.residual_std_nt, d.filtered_std_before_nt, f.level_nt].map(f64::to_bits));
            v
        };
        assert_eq!(bits(&one), bits(&three));
    }

    fn turning_fit() -> Fit {
        let (scalar, flux, settings) = turning_flight();
        fit(&scalar, &flux, 10.0, None, &settings).unwrap()
    }
}
