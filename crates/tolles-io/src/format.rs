//! Which file format a flight table is in, chosen by extension or named explicitly.
//!
//! ```
//! use std::path::Path;
//! use tolles_io::format::Format;
//! assert_eq!(Format::from_path(Path::new("flight_1002.h5")), Format::Hdf5);
//! assert_eq!(Format::from_path(Path::new("survey.DAT")), Format::Gdf);
//! assert_eq!("parquet".parse::<Format>().unwrap(), Format::Parquet);
//! assert_eq!(Format::from_path(Path::new("notes.txt")), Format::Csv); // unknown: CSV
//! // Writing is strict: an unknown extension is an error rather than a CSV file misnamed.
//! assert_eq!(Format::for_output(Path::new("out.pq")).unwrap(), Format::Parquet);
//! assert!(Format::for_output(Path::new("out.xlsx")).is_err());
//! ```

use crate::error::IoError;
use crate::table::{write_padded, Column, Table, TextColumn};
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

    /// The format a table written to `path` is written in, by its extension: `.csv`,
    /// `.h5`/`.hdf5` or `.parquet`/`.pq`. Any other extension (none, `.xlsx`, `.xyz`, `.dfn`,
    /// `.mat`, whose MATLAB header tolles does not write) is an error naming the allowed ones,
    /// so a file is never written in a format its name does not say.
    pub fn for_output(path: &Path) -> Result<Format, IoError> {
        let ext = path
            .extension()
            .and_then(|e| e.to_str())
            .unwrap_or("")
            .to_ascii_lowercase();
        match ext.as_str() {
            "csv" => Ok(Format::Csv),
            "h5" | "hdf5" => Ok(Format::Hdf5),
            "parquet" | "pq" => Ok(Format::Parquet),
            _ => Err(IoError::Invalid {
                path: path.to_path_buf(),
                message: format!(
                    "cannot write {}: the output's extension names its format; use {OUTPUT_EXTENSIONS}",
                    if ext.is_empty() {
                        "a file without an extension".to_string()
                    } else {
                        format!(".{ext} files")
                    }
                ),
            }),
        }
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

/// The extensions a table may be written to, for messages.
pub const OUTPUT_EXTENSIONS: &str = ".csv, .h5/.hdf5 or .parquet/.pq";

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

/// Writes `table` plus the `extra` columns (as long as the table) to `path` in `format` (see
/// [`crate::table::write_with_column`] for CSV). HDF5 and Parquet get numbers only here, so
/// every column must be numeric there (the first cell that is not is an error naming its line
/// and column, as the chunked writer of `compensate` says it too); [`write_everything`] writes
/// text as text. The file is written whole or not at all ([`crate::atomic`]), so `path` may be
/// the input.
pub fn write_table(
    table: &Table,
    extra: &[(&str, &[f64])],
    path: &Path,
    format: Format,
) -> Result<Written, IoError> {
    write_parts(table, extra, &[], path, format, Text::Refuse)
}

/// What a table was written as.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Written {
    /// Rows of the file written (for HDF5, the table's rows; side columns keep their lengths).
    pub rows: usize,
    /// Columns (datasets) written, scalars and side columns included.
    pub columns: usize,
    /// Columns written as text because not every cell is a number (HDF5 and Parquet; CSV
    /// writes every cell as text).
    pub text_columns: Vec<String>,
    /// Columns shorter than [`Written::rows`], padded with missing cells (CSV and Parquet), as
    /// `(name, own length)`.
    pub padded: Vec<(String, usize)>,
    /// The time column and the unit of time its file declared, when that is not seconds and
    /// the column is written as read into CSV, which cannot declare it: read back, its times are
    /// taken as seconds. HDF5 and Parquet write such a time column in seconds (HDF5 with a
    /// `units` attribute `s`; every other declared unit is kept as its `units` attribute).
    pub time_unit_dropped: Option<(String, String)>,
}

/// Writes everything `table` holds to `path` in `format`, for `tolles convert`: its columns
/// (text columns as their cells were written, or in HDF5 and Parquet as numbers when they all
/// are), its side columns ([`Table::side_columns`]) and the scalars the file held
/// ([`Table::file_metadata`]).
///
/// - HDF5: every column and side column a 1-D dataset of its own length, every scalar a
///   scalar dataset (as the DAF-MIT/SGL files hold `dt`).
/// - CSV and Parquet: every scalar a column of length 1, and the rows as many as the longest
///   column: a shorter one (a side column, a scalar, or the table's columns when a side column
///   is longer) is padded with missing cells (empty in CSV, null in Parquet), named in
///   [`Written::padded`].
///
/// A side column or scalar with the name of another column is an error (nothing is written).
pub fn write_everything(table: &Table, path: &Path, format: Format) -> Result<Written, IoError> {
    let side: Vec<(&str, &[f64])> = table
        .side_columns()
        .iter()
        .map(|c| (c.name.as_str(), c.values.as_slice()))
        .collect();
    let scalars: Vec<(&str, f64)> = table
        .file_metadata()
        .map(|(name, value)| (name.as_str(), *value))
        .collect();
    write_parts(table, &side, &scalars, path, format, Text::Keep)
}

/// What [`write_parts`] does with a text column that is not all numbers in HDF5 or Parquet.
#[derive(Clone, Copy, PartialEq)]
enum Text {
    Keep,
    Refuse,
}

/// Writes `table`, then `extra` columns of any length, then `scalars`; see [`write_everything`].
fn write_parts(
    table: &Table,
    extra: &[(&str, &[f64])],
    scalars: &[(&str, f64)],
    path: &Path,
    format: Format,
    text: Text,
) -> Result<Written, IoError> {
    let names = extra.iter().map(|(n, _)| *n);
    check_unique(table, names.chain(scalars.iter().map(|(n, _)| *n)), path)?;
    let singles: Vec<[f64; 1]> = scalars.iter().map(|(_, v)| [*v]).collect();
    // CSV and Parquet hold scalars as columns of length 1.
    let mut all_extra = extra.to_vec();
    if format != Format::Hdf5 {
        let as_columns = scalars.iter().zip(&singles);
        all_extra.extend(as_columns.map(|((n, _), v)| (*n, v.as_slice())));
    }
    let longest = all_extra.iter().map(|(_, v)| v.len()).max().unwrap_or(0);
    let rows = match format {
        Format::Hdf5 => table.len(),
        _ => table.len().max(longest),
    };
    let kinds = column_kinds(table, format, text)?;
    match format {
        Format::Csv => {
            crate::atomic::write_with(path, |out| write_padded(table, &all_extra, rows, out))?
        }
        Format::Hdf5 => write_hdf5(table, &kinds, extra, scalars, path)?,
        Format::Parquet => {
            let mut outputs: Vec<crate::parquet::Output<'_>> = kinds
                .iter()
                .zip(table.headers())
                .map(|(kind, name)| match kind {
                    Kind::Numbers(values) => crate::parquet::Output::Numbers(name, values),
                    Kind::Text(text) => crate::parquet::Output::Text(name, text),
                })
                .collect();
            let more = all_extra.iter();
            outputs.extend(more.map(|(n, v)| crate::parquet::Output::Numbers(n, v)));
            crate::parquet::write_padded(path, &outputs, rows)?;
        }
        Format::Xyz | Format::Gdf => {
            return Err(IoError::Invalid {
                path: path.to_path_buf(),
                message: format!("writing {format} is not supported; use {OUTPUT_EXTENSIONS}"),
            })
        }
    }
    let mut padded = Vec::new();
    if rows > table.len() {
        padded.extend(table.headers().iter().map(|h| (h.clone(), table.len())));
    }
    if format != Format::Hdf5 {
        let short = all_extra.iter().filter(|(_, v)| v.len() < rows);
        padded.extend(short.map(|(n, v)| (n.to_string(), v.len())));
    }
    Ok(Written {
        rows,
        columns: table.headers().len() + extra.len() + scalars.len(),
        text_columns: kinds
            .iter()
            .zip(table.headers())
            .filter(|(kind, _)| matches!(kind, Kind::Text(_)))
            .map(|(_, name)| name.clone())
            .collect(),
        padded,
        time_unit_dropped: (format == Format::Csv).then(|| table.time_unit()).flatten(),
    })
}

/// Writes the table's columns as `kinds` says, then `extra` at their own lengths and `scalars`
/// as scalar datasets, to the HDF5 file `path`.
fn write_hdf5(
    table: &Table,
    kinds: &[Kind<'_>],
    extra: &[(&str, &[f64])],
    scalars: &[(&str, f64)],
    path: &Path,
) -> Result<(), IoError> {
    use crate::hdf5::Output;
    let mut outputs: Vec<Output<'_>> = kinds
        .iter()
        .zip(table.headers())
        .map(|(kind, name)| match kind {
            Kind::Numbers(values) => Output::Numbers(name, values),
            Kind::Text(text) => Output::Text(name, text),
        })
        .collect();
    outputs.extend(extra.iter().map(|(n, v)| Output::Numbers(n, v)));
    outputs.extend(scalars.iter().map(|(n, v)| Output::Scalar(n, *v)));
    // The time column is written in seconds (see `column_kinds`).
    let time = table.time_scale().map(|(index, _)| index);
    let units: Vec<(&str, &str)> = (table.headers().iter().enumerate())
        .filter_map(|(k, name)| {
            let unit = if Some(k) == time {
                "s"
            } else {
                table.unit(name)?
            };
            Some((name.as_str(), unit))
        })
        .collect();
    crate::hdf5::write_datasets(path, &outputs, &units)
}

/// How a column of the table is written in HDF5 or Parquet.
enum Kind<'t> {
    Numbers(std::borrow::Cow<'t, [f64]>),
    Text(&'t TextColumn),
}

/// Every column of `table` as numbers where it can be, else as its text (or, refusing text,
/// the error naming its first cell that is not a number); none for CSV, which writes cells as
/// they are.
fn column_kinds(table: &Table, format: Format, text: Text) -> Result<Vec<Kind<'_>>, IoError> {
    if format == Format::Csv {
        return Ok(Vec::new());
    }
    // A time column declared in another unit is written in seconds, as it is read.
    let time = table.time_scale().map(|(index, _)| index);
    let mut kinds = Vec::with_capacity(table.columns().len());
    for (k, column) in table.columns().iter().enumerate() {
        kinds.push(match column {
            _ if Some(k) == time => Kind::Numbers(table.numeric_at(k)?.into()),
            Column::Numbers(values) => Kind::Numbers(values.as_slice().into()),
            Column::Text(cells) => match table.numeric_at(k) {
                Ok(values) => Kind::Numbers(values.into()),
                Err(_) if text == Text::Keep => Kind::Text(cells),
                Err(e) => return Err(e),
            },
        });
    }
    Ok(kinds)
}

/// An error when one of `names` is already a column of `table` or repeats.
fn check_unique<'n>(
    table: &Table,
    names: impl Iterator<Item = &'n str>,
    path: &Path,
) -> Result<(), IoError> {
    let mut seen: std::collections::HashSet<&str> =
        table.headers().iter().map(String::as_str).collect();
    for name in names {
        if !seen.insert(name) {
            return Err(IoError::DuplicateColumn {
                path: path.to_path_buf(),
                column: name.to_string(),
            });
        }
    }
    Ok(())
}
