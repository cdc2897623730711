//! File formats for tolles.
//!
//! - [`atomic`]: every file written whole or not at all (a temporary file renamed over it);
//! - [`table`]: flight data as a table of named columns;
//! - [`csv_reader`]: CSV text with a header row read into a table, from a file, bytes or a reader;
//! - [`csv_writer`]: tables written as CSV, cells as read and added numbers round-tripping;
//! - [`format`](mod@format): which format a flight file is in; [`table::Table::read`] reads any of
//!   them;
//! - [`xyz`], [`gdf`], [`hdf5`], [`mat`], [`parquet`]: Geosoft XYZ, ASEG-GDF2, HDF5, MATLAB v5
//!   MAT-file and Parquet tables;
//! - [`chunks`]: flight tables read and written a chunk of rows at a time (bounded memory);
//! - [`schema`]: every column name tolles gives a meaning to, and how added columns are named;
//! - [`select`]: choosing rows by flight line and time (`--line`, `--time`);
//! - [`simulation`]: the columns of a simulated flight, and named columns written in any format;
//! - [`stream_line`]: the CSV lines of a live stream, read and written one at a time.
//!
//! Formats know nothing of the numerics: this crate depends on no other tolles crate. The model
//! file, whose contents are the numerics' types, is the facade's (`tolles::model`).
//!
//! Every error names the file, and where it can the line and column, so a user can fix the input.

pub mod atomic;
mod bytemask;
pub mod chunks;
pub mod csv_reader;
pub mod csv_writer;
mod decimal;
pub mod error;
pub mod format;
pub mod gdf;
mod guard;
pub mod hdf5;
mod header;
pub mod mat;
mod open;
pub mod parquet;
pub mod rawcsv;
pub mod schema;
pub mod select;
pub mod simulation;
pub mod stdin;
pub mod stream_line;
pub mod table;
pub mod xyz;

pub use error::IoError;
