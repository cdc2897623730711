//! Errors of the file formats. Each message is one line that names the file.

use std::path::PathBuf;
use thiserror::Error;

/// Why a file could not be read or written.
#[derive(Debug, Error)]
pub enum IoError {
    #[error("{path}: cannot open: {source}")]
    Open {
        path: PathBuf,
        source: std::io::Error,
    },
    #[error("{path}: cannot write: {source}")]
    Write {
        path: PathBuf,
        source: std::io::Error,
    },
    #[error("{path}: the file is empty; expected a header row and data rows")]
    Empty { path: PathBuf },
    #[error("{path}: the file has a header but no data rows")]
    NoRows { path: PathBuf },
    #[error("{path}: no column {column:?}{hint}")]
    MissingColumn {
        path: PathBuf,
        column: String,
        hint: String,
    },
    #[error("{path}: column {column:?} appears more than once in the header")]
    DuplicateColumn { path: PathBuf, column: String },
    #[error("{path}: line {line}: {found} fields, but the header has {expected}")]
    Ragged {
        path: PathBuf,
        line: u64,
        expected: usize,
        found: usize,
    },
    /// `place` is "line N" for text files, "row N" (1-based) for binary ones.
    #[error("{path}: {place}, column {column:?}: {value:?} is not a number")]
    NotANumber {
        path: PathBuf,
        place: String,
        column: String,
        value: String,
    },
    #[error("{path}: line {line}: {message}")]
    Malformed {
        path: PathBuf,
        line: u64,
        message: String,
    },
    #[error("{path}: {message}")]
    Invalid { path: PathBuf, message: String },
    #[error(
        "{path}: column {column:?} holds {found} values, but column {first:?} holds {expected}"
    )]
    UnequalColumns {
        path: PathBuf,
        first: String,
        expected: usize,
        column: String,
        found: usize,
    },
    #[error("{path}: not a tolles model file: {message}")]
    Model { path: PathBuf, message: String },
}
