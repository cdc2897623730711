//! Which file format a flight table is in, chosen by extension or named explicitly.
//!
//! ```
//! use std::path::Path;
//! use tolles_io::format::Format;
//! assert_eq!(Format::from_path(Path::new("flight_1002.h5")), Format::Hdf5);
//! assert_eq!(Format::from_path(Path::new("survey.DAT")), Format::Gdf);
//! assert_eq!("parquet".parse::<Format>().unwrap(), Format::Parquet);
//! assert_eq!(Format::from_path(Path::new("notes.txt")), Format::Csv); // unknown: CSV
//! ```

use crate::error::IoError;
use crate::table::{write_with_column, Table};
use std::path::Path;
use std::str::FromStr;

/// A flight-table file format.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Format {
    /// Comma-separated values with a header row (`.csv`).
    Csv,
    /// Geosoft XYZ text (`.xyz`).
    Xyz,
    /// ASEG-GDF2: a `.dfn` definition file and a `.dat` data file.
    Gdf,
    /// HDF5 with one 1-D dataset per column at the root (`.h5`, `.hdf5`, MATLAB v7.3 `.mat`);
    /// a MATLAB v5 `.mat` file, told apart by its content, is read by [`crate::mat`].
    Hdf5,
    /// Apache Parquet (`.parquet`, `.pq`).
    Parquet,
}

impl Format {
    /// The format a file's extension names; CSV for any other extension.
    pub fn from_path(path: &Path) -> Format {
        let ext = path
            .extension()
            .and_then(|e| e.to_str())
            .unwrap_or("")
            .to_ascii_lowercase();
        ext.parse().unwrap_or(Format::Csv)
    }

    /// The names this format is given by, the first being its canonical one.
    pub fn names(self) -> &'static [&'static str] {
        match self {
            Format::Csv => &["csv"],
            Format::Xyz => &["xyz"],
            Format::Gdf => &["gdf", "dfn", "dat"],
            Format::Hdf5 => &["hdf5", "h5", "mat"],
            Format::Parquet => &["parquet", "pq"],
        }
    }

    const ALL: [Format; 5] = [
        Format::Csv,
        Format::Xyz,
        Format::Gdf,
        Format::Hdf5,
        Format::Parquet,
    ];
}

impl std::fmt::Display for Format {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.names()[0])
    }
}

impl FromStr for Format {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let s = s.trim().trim_start_matches('.').to_ascii_lowercase();
        Format::ALL
            .into_iter()
            .find(|f| f.names().contains(&s.as_str()))
            .ok_or_else(|| format!("unknown format {s:?}; expected csv, xyz, gdf, hdf5 or parquet"))
    }
}

impl Table {
    /// Reads `path` in `format`, or in the format its extension names when `format` is `None`.
    /// `-` is standard input, in the format its content shows ([`crate::stdin`]).
    pub fn read(path: &Path, format: Option<Format>) -> Result<Table, IoError> {
        if crate::stdin::is_stdin(path) {
            return crate::stdin::read(format);
        }
        match format.unwrap_or_else(|| Format::from_path(path)) {
            Format::Csv => Table::read_csv(path),
            Format::Xyz => crate::xyz::read(path),
            Format::Gdf => crate::gdf::read(path),
            Format::Hdf5 => read_hdf5_or_mat(path),
            Format::Parquet => crate::parquet::read(path),
        }
    }
}

/// An HDF5 file, or a MATLAB v5 MAT-file (which `.mat` files written before v7.3 are), told
/// apart by the file's first bytes rather than its extension.
fn read_hdf5_or_mat(path: &Path) -> Result<Table, IoError> {
    let bytes = std::fs::read(path).map_err(|source| IoError::Open {
        path: path.to_path_buf(),
        source,
    })?;
    if crate::mat::is_v5(&bytes) {
        crate::mat::from_bytes(&bytes, path)
    } else {
        crate::hdf5::from_bytes(bytes, path)
    }
}

/// Writes `table` plus the `extra` columns to `path` in `format` (see [`write_with_column`] for
/// CSV). HDF5 and Parquet hold numbers only, so every input column must be numeric there.
/// The file is written whole or not at all ([`crate::atomic`]), so `path` may be the input.
pub fn write_table(
    table: &Table,
    extra: &[(String, Vec<f64>)],
    path: &Path,
    format: Format,
) -> Result<(), IoError> {
    match format {
        Format::Csv => crate::atomic::write_with(path, |out| write_with_column(table, extra, out)),
        Format::Hdf5 => crate::hdf5::write(path, &numeric_columns(table, extra)?),
        Format::Parquet => crate::parquet::write(path, &numeric_columns(table, extra)?),
        Format::Xyz | Format::Gdf => Err(IoError::Invalid {
            path: path.to_path_buf(),
            message: format!(
                "writing {format} is not supported; write CSV, HDF5 or Parquet (.csv, .h5, .parquet)"
            ),
        }),
    }
}

/// Every column of `table` as numbers, then `extra`.
fn numeric_columns(
    table: &Table,
    extra: &[(String, Vec<f64>)],
) -> Result<Vec<(String, Vec<f64>)>, IoError> {
    let mut columns = Vec::with_capacity(table.headers().len() + extra.len());
    for (k, name) in table.headers().iter().enumerate() {
        columns.push((name.clone(), table.numeric_at(k)?));
    }
    columns.extend(extra.iter().cloned());
    Ok(columns)
}
