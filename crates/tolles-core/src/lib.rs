//! Numerics of aircraft magnetic compensation.
//!
//! ```
//! use tolles_core::design::{Design, TermSet};
//! use tolles_core::vector::VectorSeries;
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
//! Crate layout, one concept per module:
//! - [`conventions`]: frames, axes, units (read this first);
//! - [`terms`]: which Tolles-Lawson terms a model uses;
//! - [`design`]: the Tolles-Lawson design matrix (permanent, induced and eddy-current columns);
//! - [`filter`]: Butterworth second-order sections and zero-phase filtering;
//! - [`ridge`]: numerically stable ridge least squares (blocked QR);
//! - [`crossval`]: choosing the ridge strength by blocked cross-validation over time;
//! - [`fit`]: the whole fit: filter, trim, solve, diagnose;
//! - [`compensate`]: applying a fitted model;
//! - [`adapt`]: online adaptation of the coefficients while streaming;
//! - [`maneuver`]: finding roll, pitch and yaw maneuvers in the attitude;
//! - [`patent_maneuvers`]: finding the patent's rolls, pitches, wing-ups and cloverleaf turns;
//! - [`fom`]: the figure of merit of a compensation box;
//! - [`metrics`]: noise level, improvement ratio, fourth difference;
//! - [`interpret`]: coefficients as physical fields and in the patent's nomenclature;
//! - [`patent`]: the Tolles patent's maneuver model: direction cosines, generating functions, printed tables;
//! - [`harmonics`]: the patent's roll and pitch tables computed by Fourier analysis;
//! - [`segment`]: contiguous runs of usable samples;
//! - [`median`]: the exact median of a sequence too long to hold, over repeated passes;
//! - [`attitude`]: rotations between the navigation and body frames;
//! - [`plan`]: flight plans (compensation box, survey lines);
//! - [`maneuver_list`]: a plan from a list of maneuvers (`roll@0,wingup@90`);
//! - [`environment`]: the earth's field along a flight (IGRF, geology, diurnal);
//! - [`field_estimate`]: the earth field's dip and intensity from a flight's own sensors;
//! - [`sensor`]: fluxgate and magnetometer error models;
//! - [`sim`]: simulated flights with known truth;
//! - [`igrf`]: IGRF-14 reference field of the earth;
//! - [`identifiability`]: how well a flight's maneuvers determine each term;
//! - [`spectrum`]: power spectral density by Welch's method;
//! - [`demodulate`]: a maneuver's frequency and phase, and any series demodulated on them;
//! - [`procedure`]: the patent's step-by-step compensation procedure, digitised;
//! - [`stream`]: real-time compensation, one sample in and one out.
//!
//! No module here reads files or writes to a terminal.

pub mod adapt;
pub mod attitude;
pub mod compensate;
pub mod conventions;
pub mod crossval;
pub mod demodulate;
pub mod design;
pub mod environment;
pub mod field_estimate;
pub mod filter;
pub mod fit;
pub mod fom;
pub mod harmonics;
pub mod identifiability;
pub mod igrf;
pub mod interpret;
pub mod maneuver;
pub mod maneuver_list;
pub mod median;
pub mod metrics;
pub mod patent;
pub mod patent_maneuvers;
pub mod plan;
pub mod procedure;
pub mod ridge;
pub mod segment;
pub mod sensor;
pub mod sim;
pub mod spectrum;
pub mod stream;
pub mod terms;
pub mod vector;
