//! File formats for tolles.
//!
//! - [`table`]: flight data as a table of named columns, read from CSV with a header row;
//! - [`model`]: the model file (JSON) that `tolles fit` writes and `tolles compensate` reads;
//! - [`simulation`]: simulated flights (CSV) and their JSON sidecars.
//!
//! Every error names the file, and where it can the line and column, so a user can fix the input.

pub mod error;
pub mod model;
pub mod simulation;
pub mod stream_line;
pub mod table;

pub use error::IoError;
