//! Reading a flight table from a file, or from standard input (`-`), in the format named or
//! else the one its extension (or, for standard input, its content) shows. Kept apart from
//! [`crate::format`] so that standard input, which needs [`Format`], is not needed by it.

use crate::error::IoError;
use crate::format::Format;
use crate::stdin;
use crate::table::Table;
use std::path::Path;

impl Table {
    /// Reads `path` in `format`, or in the format its extension names when `format` is `None`.
    /// `-` is standard input, in the format its content shows ([`crate::stdin`]).
    pub fn read(path: &Path, format: Option<Format>) -> Result<Table, IoError> {
        if stdin::is_stdin(path) {
            return stdin::read(format);
        }
        match format.unwrap_or_else(|| Format::from_path(path)) {
            Format::Csv => Table::csv().path(path),
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
        return Ok(crate::mat::from_bytes(&bytes, path)?.with_format_name("mat"));
    }
    let is_mat = path
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("mat"));
    // A MAT-file that is neither v5 nor HDF5 is named as what it claims to be, not as HDF5.
    let v5_text = bytes.starts_with(b"MATLAB 5.0 MAT-file");
    let (is_v73, size) = (bytes.starts_with(b"MATLAB 7.3 MAT-file"), bytes.len());
    match crate::hdf5::from_bytes(bytes, path) {
        Err(IoError::Invalid { path, .. }) if is_mat && v5_text => Err(IoError::Invalid {
            path,
            message: format!(
                "a MATLAB v5 MAT-file cut short ({size} bytes; its header alone is 128)"
            ),
        }),
        Err(IoError::Invalid { path, message }) if is_mat => Err(IoError::Invalid {
            path,
            message: match is_v73 {
                true => format!(
                    "not a readable MATLAB v7.3 MAT-file (HDF5): {}",
                    message
                        .trim_start_matches("not a readable HDF5 file")
                        .trim_start_matches([':', ' '])
                ),
                false => "not a MATLAB MAT-file (neither a v5 nor a v7.3 header)".to_string(),
            },
        }),
        Ok(table) if is_mat => Ok(table.with_format_name("mat")),
        read => read,
    }
}
