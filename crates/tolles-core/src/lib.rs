//! Numerics of aircraft magnetic compensation.
//!
//! ```
//! use tolles_core::model::design::{Design, TermSet};
//! use tolles_core::model::vector::VectorSeries;
//!
//! // Four samples of a fluxgate (nT, body frame FRD).
//! let flux = VectorSeries::new(
//!     vec![20_000.0, 20_010.0, 20_030.0, 20_060.0],
//!     vec![-3_000.0, -2_990.0, -2_970.0, -2_940.0],
//!     vec![45_000.0, 45_005.0, 45_010.0, 45_015.0],
//! );
//! let design = Design::new(TermSet::magnav_default());
//! let a = design.matrix(&flux);
//! assert_eq!(a.ncols(), 18);
//! ```
//!
//! # A guided tour
//!
//! Read [`model::conventions`] first: frames, axes and units used everywhere. Then, in the order
//! data flows through a compensation:
//!
//! [`model`]: what a Tolles-Lawson model is
//! - [`model::conventions`]: frames, axes, units;
//! - [`model::terms`]: which Tolles-Lawson terms a model uses;
//! - [`model::design`]: the design matrix (permanent, induced and eddy-current columns);
//! - [`model::vector`]: time series of 3-component vectors (fluxgates);
//! - [`model::interpret`]: coefficients as physical fields and in the patent's nomenclature.
//! - [`model::magnitude`]: the field applied to first order (`B̂·H`) or exactly (`|B + H| − |B|`).
//!
//! [`signal`]: signal processing that knows nothing of aircraft
//! - [`signal::filter`]: Butterworth second-order sections, zero-phase filtering and the pass
//!   [`Band`](signal::filter::Band) every band-passing step takes;
//! - [`signal::spectrum`]: power spectral density by Welch's method;
//! - [`signal::demodulate`]: a maneuver's frequency and phase, and any series demodulated on them;
//! - [`signal::segment`]: contiguous runs of usable samples;
//! - [`signal::median`]: the exact median of a sequence too long to hold, over repeated passes;
//! - [`signal::metrics`]: noise level, improvement ratio, fourth difference.
//!
//! [`fit`]: the whole fit: filter, trim, solve, diagnose
//! - [`fit::ridge`]: numerically stable ridge least squares (blocked QR);
//! - [`fit::crossval`]: choosing the ridge strength by blocked cross-validation over time.
//!
//! [`compensate`]: applying a fitted model to a whole record
//! - [`compensate::stream`]: real-time compensation, one sample in and one out;
//! - [`compensate::adapt`]: online adaptation of the coefficients while streaming.
//!
//! [`maneuvers`]: the maneuvers of a calibration flight (and which maneuver type means what)
//! - [`maneuvers::detect`]: finding roll, pitch and yaw maneuvers in the attitude;
//! - [`maneuvers::fom`]: the figure of merit of a compensation box;
//! - [`maneuvers::identifiability`]: how well a flight's maneuvers determine each term.
//!
//! [`patent`]: the Tolles patent's maneuver model: direction cosines, generating functions,
//! printed tables
//! - [`patent::detect`]: finding the patent's rolls, pitches, wing-ups and cloverleaf turns;
//! - [`patent::harmonics`]: the patent's roll and pitch tables computed by Fourier analysis;
//! - [`patent::procedure`]: the patent's step-by-step compensation procedure, digitised.
//!
//! [`flight`]: flights and the world they happen in
//! - [`flight::attitude`]: rotations between the navigation and body frames;
//! - [`flight::plan`]: flight plans (compensation box, patent procedure, survey lines);
//! - [`flight::maneuver_list`]: a plan from a list of maneuvers (`roll@0,wingup@90`);
//! - [`flight::field_estimate`]: the earth field's dip and intensity from a flight's own sensors;
//! - [`flight::environment`]: the earth's field along a flight (IGRF, geology, diurnal);
//! - [`flight::igrf`]: IGRF-14 reference field of the earth;
//! - [`flight::sensor`]: fluxgate and magnetometer error models;
//! - [`flight::sim`]: simulated flights with known truth.
//!
//! No module here reads files or writes to a terminal.

pub mod compensate;
pub mod fit;
pub mod flight;
pub mod maneuvers;
pub mod model;
mod parallel;
pub mod patent;
pub mod signal;
pub mod survey;
