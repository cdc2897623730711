//! # tolles
//!
//! Removes an aircraft's own magnetic field from airborne magnetometer data: learn the
//! aircraft's permanent, induced and eddy-current fields from a calibration flight (a scalar
//! magnetometer and a vector fluxgate) with the Tolles-Lawson model, then subtract them from
//! survey data. This crate is the library every interface stands on: the `tolles` command and
//! the Python package call exactly these functions.
//!
//! ## A tour: read, fit, compensate, measure
//!
//! ```
//! use std::path::Path;
//! use tolles::{compensate, fit, fom, read, simulate, Silent};
//!
//! # let dir = tempfile::tempdir().unwrap();
//! # let path = dir.path().join("box.csv");
//! // A calibration box whose truth is known (a real flight is read the same way).
//! let flight = simulate::simulate(&simulate::SimulateRequest::default(), &Silent).unwrap();
//! simulate::write(&flight, &path).unwrap();
//!
//! // Read it: CSV, Geosoft XYZ, ASEG-GDF2, HDF5 (also MATLAB v7.3) or Parquet.
//! let mut warnings = Vec::new();
//! let data = read::read(&path, &Default::default(), &Silent, &mut warnings).unwrap();
//!
//! // Fit the scalar `mag_1_uc` against the fluxgate `flux_a_x/_y/_z` with tolles' defaults.
//! let request = fit::FitRequest::new(vec!["mag_1_uc".into()], vec!["flux_a".into()]);
//! let model = fit::fit(&data.table, &request, &Silent, &mut warnings).unwrap();
//!
//! // Compensate: one new column, `mag_1_c` (nT).
//! let columns = compensate::compensate(&data.table, &model, &Default::default(), &mut warnings).unwrap();
//! assert_eq!(columns[0].name, "mag_1_c");
//!
//! // The figure of merit of the box (nT) before and after.
//! let fit = fom::fit_for(&model, Path::new("model"), "mag_1_uc").unwrap();
//! let measured = fom::fom(&data.table, &fom::FomRequest::new("mag_1_uc"), Some(fit), &mut warnings).unwrap();
//! assert!(measured.after.unwrap().fom_nt < measured.before.fom_nt / 20.0);
//! assert!(warnings.is_empty());
//! ```
//!
//! ## What is where
//! - [`read`]: flights from any format, row selection by line and time, sample rate;
//! - [`fit`]: one or several scalars, in parallel, to a [`model::ModelFile`];
//! - [`convert`]: any format tolles reads to CSV, HDF5 or Parquet, losing nothing;
//! - [`info`]: what a flight file holds (columns, units, rows, sample rate, lines, missing values);
//! - [`model`]: saving and loading models;
//! - [`compensate`]: applying a model, whole in memory or in bounded memory ([`compensate::Memory`]);
//! - [`fom`]: the figure of merit of a compensation box, before and after;
//! - [`procedure`]: the Tolles patent's step-by-step procedure on a flight, beside least squares;
//! - [`plan`]: how well a planned or flown calibration flight determines each term;
//! - [`stream`]: real-time compensation of CSV lines from any reader (standard input, TCP
//!   clients) to any writer, with health counters and a latency histogram;
//! - [`simulate`]: flights with known truth;
//! - [`report`]: what a flight's compensation report shows (signals, spectra, FOM by maneuver),
//!   computed; the `tolles-report` crate lays it out as HTML;
//! - [`demo`]: the built-in example's flights and how its compensated survey compares with the
//!   truth.
//!
//! Every workflow takes typed requests and returns typed results; errors are [`Error`], one line
//! naming the file, row or column; warnings are values ([`Warning`]) added to a vector the
//! caller owns, so they survive a later error; progress goes to a [`Progress`] of the caller's
//! choosing. Nothing here prints, reads environment variables or parses command lines.
//!
//! Units: nT for fields, s for time, Hz for rates, degrees for attitude (yaw clockwise from
//! north, pitch nose up, roll right wing down), body frame FRD (x forward, y right, z down).
//! The numerics live in [`tolles_core`], the formats in [`tolles_io`].

pub mod compensate;
pub mod convert;
pub mod demo;
pub mod error;
pub mod fit;
pub mod fom;
pub mod info;
pub mod lines;
pub mod live;
pub mod model;
mod numbers;
pub mod plan;
pub mod procedure;
pub mod progress;
pub mod read;
pub mod report;
mod selection;
pub mod simulate;
pub mod stream;
#[cfg(test)]
mod testing;
pub mod warning;

pub use error::{Error, Result};
pub use progress::{Progress, Silent, Stage};
pub use warning::Warning;

pub use tolles_core;
pub use tolles_io;
