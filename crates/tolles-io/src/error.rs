//! Errors of the file formats. Each message is one line that names the file.

use std::path::PathBuf;
use thiserror::Error;

/// Why a file could not be read or written.
#[derive(Debug, Error)]
pub enum IoError {
    /// The file could not be opened or read.
    #[error("{path}: cannot open: {source}")]
    Open {
        /// The file the error is about.
        path: PathBuf,
        /// The operating system's error.
        source: std::io::Error,
    },
    /// The file could not be written.
    #[error("{path}: cannot write: {source}")]
    Write {
        /// The file the error is about.
        path: PathBuf,
        /// The operating system's error.
        source: std::io::Error,
    },
    /// The file is empty.
    #[error("{path}: the file is empty; expected a header row and data rows")]
    Empty {
        /// The file the error is about.
        path: PathBuf,
    },
    /// The file has a header but no data rows.
    #[error("{path}: the file has a header but no data rows")]
    NoRows {
        /// The file the error is about.
        path: PathBuf,
    },
    /// A column asked for is not in the file.
    #[error("{path}: no column {column:?}{near}")]
    MissingColumn {
        /// The file the error is about.
        path: PathBuf,
        /// The column asked for.
        column: String,
        /// The names near it, or the header's first names.
        near: Near,
    },
    /// A column name appears more than once in the header.
    #[error("{path}: column {column:?} appears more than once in the header")]
    DuplicateColumn {
        /// The file the error is about.
        path: PathBuf,
        /// The repeated column name.
        column: String,
    },
    /// A row has a different number of fields from the header.
    #[error("{path}: line {line}: {found} fields, but the header has {expected}")]
    Ragged {
        /// The file the error is about.
        path: PathBuf,
        /// Line of the file (1-based).
        line: u64,
        /// Fields in the header.
        expected: usize,
        /// Fields on the line.
        found: usize,
    },
    /// `place` is "line N" for text files, "row N" (1-based) for binary ones.
    #[error("{path}: {place}, column {column:?}: {value:?} is not a number")]
    NotANumber {
        /// The file the error is about.
        path: PathBuf,
        /// Where the value is: "line N" or "row N" (1-based).
        place: String,
        /// The column of the value.
        column: String,
        /// The value as written.
        value: String,
    },
    /// A line of a text file cannot be parsed.
    #[error("{path}: line {line}: {message}")]
    Malformed {
        /// The file the error is about.
        path: PathBuf,
        /// Line of the file (1-based).
        line: u64,
        /// What is wrong with the line.
        message: String,
    },
    /// The file's contents are not what the format requires.
    #[error("{path}: {message}")]
    Invalid {
        /// The file the error is about.
        path: PathBuf,
        /// What is wrong.
        message: String,
    },
    /// Two columns of the file hold different numbers of values.
    #[error(
        "{path}: column {column:?} holds {found} values, but column {first:?} holds {expected}"
    )]
    UnequalColumns {
        /// The file the error is about.
        path: PathBuf,
        /// The first column, whose length the others must have.
        first: String,
        /// Values in the first column (rows).
        expected: usize,
        /// The column that differs.
        column: String,
        /// Values in that column (rows).
        found: usize,
    },
    /// The file is not a tolles model file.
    #[error("{path}: not a tolles model file: {message}")]
    Model {
        /// The file the error is about.
        path: PathBuf,
        /// Why the file is not a model file.
        message: String,
    },
}

/// What a name missing from a header is near: names like it, or, none being near, the header's
/// first names. As text it ends an error's sentence: `; did you mean A, B?` or `; the header
/// has: …`.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Near {
    /// Columns like the name asked for, or fluxgate prefixes, or a fluxgate's three columns
    /// spelled `X:Y:Z`.
    Names(Vec<String>),
    /// No name is near: the header's first names, and how many more it has.
    Header {
        /// The first names, in the header's order.
        first: Vec<String>,
        /// How many more names the header has.
        more: usize,
    },
}

impl Near {
    /// The one name near, when there is exactly one: a spelling the user may have meant.
    pub fn only(&self) -> Option<&str> {
        match self {
            Near::Names(names) if names.len() == 1 => Some(&names[0]),
            _ => None,
        }
    }
}

impl std::fmt::Display for Near {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Near::Names(names) => write!(f, "; did you mean {}?", names.join(", ")),
            Near::Header { first, more } => {
                write!(f, "; the header has: {}", first.join(", "))?;
                match more {
                    0 => Ok(()),
                    n => write!(f, " and {n} more (tolles info lists them)"),
                }
            }
        }
    }
}
