//! Why a fit could not be made: one error for every refusal, naming the input or setting at
//! fault in its own units (samples, Hz, nT).

use super::plausible;
use super::ridge::RidgeError;
use crate::model::limits::show_nt;
use crate::signal::filter::FilterError;
use thiserror::Error;

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
