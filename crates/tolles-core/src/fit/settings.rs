//! How a fit is made: its terms and `Bt_scale` (nT), the ridge strength λ, the pass band (Hz),
//! filter order and trim (samples), which magnitude models and term sets it may choose among,
//! and what its target holds. Of the rest of the fit the settings need only its error, the
//! prior and the default number of folds, so every part of it can read them.

use super::crossval::DEFAULT_FOLDS;
use super::error::FitError;
use super::prior;
use crate::model::design::{Design, Term};
use crate::model::terms::TermSet;
use crate::signal::filter::{Band, Butterworth};
use serde::{Deserialize, Serialize};

/// A fixed λ larger than this times the largest `diag(AᵀA)` shrinks every coefficient at least
/// this many-fold towards zero: the fit would be meaningless, so it is refused.
pub const LAMBDA_MAX_RATIO: f64 = 1e8;

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
    /// What the scalar given to [`crate::fit::fit`] is: a magnetometer's reading (band-passed), or the
    /// interference itself (fitted in the full band).
    #[serde(default, skip_serializing_if = "Target::is_band")]
    pub target: Target,
    /// The physical sizes of the terms, a ridge prior in the coefficients' own units added to
    /// the cross-validated ridge (see [`prior`]); `None` for none. Only with a cross-validated
    /// λ: a fixed λ is MagNav's procedure, exactly.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub prior: Option<prior::Prior>,
    /// Calibrate a lone fluxgate's offset first (see [`crate::fit::levels::reference`]) and fit on its
    /// readings without it ([`crate::fit::Fit::flux_offset_nt`]). Only with a cross-validated λ and one
    /// fluxgate: over several, their differences, offsets included, are what sees sources near
    /// one of them.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub fluxgate_offset: bool,
}

/// What the scalar given to [`crate::fit::fit`] holds, and so which of its frequencies a fit may use.
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
    pub(super) fn is_band(&self) -> bool {
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
    pub(super) fn candidate_designs(&self) -> Vec<Design> {
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

    /// The filter the fit applies to every column and the target; `None` for none.
    pub(super) fn filter(&self, fs_hz: f64) -> Result<Option<Butterworth>, FitError> {
        match self.target {
            Target::Band => Ok(self.band.butterworth(self.order, fs_hz)?),
            Target::Interference => Ok(None),
        }
    }
}

/// Fraction of the band 0…fs/2 that the filter passes (1 when it does not filter).
pub(super) fn passband_fraction(band: Band, fs_hz: f64) -> f64 {
    let nyquist = fs_hz / 2.0;
    let valid = |f: f64| f > 0.0 && f < nyquist;
    let lo = if valid(band.pass1_hz) {
        band.pass1_hz
    } else {
        0.0
    };
    let hi = if valid(band.pass2_hz) {
        band.pass2_hz
    } else {
        nyquist
    };
    ((hi - lo) / nyquist).clamp(f64::EPSILON, 1.0)
}
