//! Converting a flight file to another format, losing nothing tolles can read: any format it
//! reads (CSV, Geosoft XYZ, ASEG-GDF2, HDF5, MATLAB v5 and v7.3, Parquet) to CSV, HDF5 or
//! Parquet, chosen by the output's extension.
//!
//! ```
//! use tolles::{convert, simulate, Silent};
//! # let dir = tempfile::tempdir().unwrap();
//! # let csv = dir.path().join("box.csv");
//! # let h5 = dir.path().join("box.h5");
//! let flight = simulate::simulate(&simulate::SimulateRequest::default(), &Silent).unwrap();
//! simulate::write(&flight, &csv).unwrap();
//! let request = convert::ConvertRequest::new(&csv, &h5);
//! let done = convert::convert(&request, &Silent, &mut Vec::new()).unwrap();
//! assert!(done.rows > 0 && done.columns > 10);
//! ```
//!
//! What is written (see [`tolles_io::format::write_everything`]):
//! - every column; text columns (CSV, XYZ, GDF) cell for cell as the file has them in CSV, and
//!   in HDF5 and Parquet as numbers when every cell is one (or missing), else as text;
//! - the 1-D arrays of other lengths a MATLAB or HDF5 file holds beside its columns (side
//!   columns): in HDF5 each at its own length, in CSV and Parquet padded with missing cells to
//!   the longest column (a warning names them and their lengths);
//! - the scalars the file holds (MATLAB `fs`, HDF5 `dt`, `N`): scalar datasets in HDF5, columns
//!   of length 1 in CSV and Parquet;
//! - not: 2-D and higher arrays, text, cells and groups of MATLAB and HDF5 files, nor a
//!   Parquet file's text columns, which the readers leave out: a warning names each.
//!
//! With a row selection (`--line`, `--time`), only the selected rows of the table's columns are
//! written; side columns and scalars are not rows and are written whole.

use crate::error::Result;
use crate::progress::Progress;
use crate::warning::Warning;
use std::path::{Path, PathBuf};
use tolles_io::format::{write_everything, Format};
use tolles_io::select::RowSelection;

/// What to convert.
#[derive(Debug, Clone, PartialEq)]
pub struct ConvertRequest {
    /// The flight file read, in the format its extension names.
    pub input: PathBuf,
    /// The file written: `.csv`, `.h5`/`.hdf5` or `.parquet`/`.pq` (any other extension is an
    /// error). Written whole or not at all; it may be the input.
    pub output: PathBuf,
    /// The rows written (all when empty).
    pub selection: RowSelection,
    /// Columns renamed `(old, new)` right after reading.
    pub renames: Vec<(String, String)>,
}

impl ConvertRequest {
    /// Every row of `input` to `output`, no renames.
    pub fn new(input: impl AsRef<Path>, output: impl AsRef<Path>) -> Self {
        Self {
            input: input.as_ref().to_path_buf(),
            output: output.as_ref().to_path_buf(),
            selection: RowSelection::default(),
            renames: Vec::new(),
        }
    }
}

/// What [`convert`] wrote.
#[derive(Debug, Clone, PartialEq)]
pub struct ConvertResult {
    /// The file written.
    pub output: PathBuf,
    /// Its format (`csv`, `hdf5`, `parquet`).
    pub format: String,
    /// Rows written: the table's (for HDF5), or the longest column's (CSV, Parquet).
    pub rows: usize,
    /// Columns (HDF5 datasets) written, side columns and scalars included.
    pub columns: usize,
    /// Columns shorter than `rows`, padded with missing cells, as `(name, own length)`.
    pub padded: Vec<(String, usize)>,
    /// What the reader left out of the file, one sentence each (also in the warnings).
    pub left_out: Vec<String>,
    /// Input rows not written because a selection left them out.
    pub rows_left_out: usize,
}

/// Reads `request.input`, keeps the selected rows and writes everything it holds to
/// `request.output`. Warnings name what the reader left out and what was padded.
pub fn convert(
    request: &ConvertRequest,
    progress: &dyn Progress,
    warnings: &mut Vec<Warning>,
) -> Result<ConvertResult> {
    // Before reading: an output named in no format tolles writes is a mistake.
    let format = Format::for_output(&request.output)?;
    let mut read_warnings = Vec::new();
    let data = crate::read::read_renamed(
        &request.input,
        &request.selection,
        &request.renames,
        progress,
        &mut read_warnings,
    );
    // Side columns are written here, so the reader's "not used" does not apply.
    read_warnings.retain(|w| !matches!(w, Warning::SideColumns { .. }));
    warnings.append(&mut read_warnings);
    let data = data?;
    let table = &data.table;
    let written = write_everything(table, &request.output, format)?;
    if let Some((column, unit)) = written.time_unit_dropped {
        warnings.push(Warning::TimeUnitNotWritten {
            path: request.output.clone(),
            column,
            unit,
        });
    }
    if !written.padded.is_empty() {
        warnings.push(Warning::Padded {
            path: request.output.clone(),
            rows: written.rows,
            columns: written.padded.clone(),
        });
    }
    Ok(ConvertResult {
        output: request.output.clone(),
        format: format.to_string(),
        rows: written.rows,
        columns: written.columns,
        padded: written.padded,
        left_out: table.notes().to_vec(),
        rows_left_out: data.selected.map_or(0, |s| s.left_out),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Silent;
    use tolles_io::table::Table;

    #[test]
    fn an_unknown_output_extension_is_refused_before_reading() {
        let dir = tempfile::tempdir().unwrap();
        let request = ConvertRequest::new(dir.path().join("absent.csv"), dir.path().join("o.xlsx"));
        let err = convert(&request, &Silent, &mut Vec::new())
            .unwrap_err()
            .to_string();
        assert!(err.contains("o.xlsx: cannot write .xlsx files"), "{err}");
        assert!(err.contains(".csv, .h5/.hdf5 or .parquet/.pq"), "{err}");
        assert!(!dir.path().join("o.xlsx").exists());
    }

    #[test]
    fn text_cells_survive_a_csv_to_csv_conversion() {
        let dir = tempfile::tempdir().unwrap();
        let input = dir.path().join("in.csv");
        let text = "tt,line,note\n0.10,L7,a b\n0.2,,\"x,y\"\n";
        std::fs::write(&input, text).unwrap();
        let output = dir.path().join("out.csv");
        let done = convert(
            &ConvertRequest::new(&input, &output),
            &Silent,
            &mut Vec::new(),
        )
        .unwrap();
        assert_eq!((done.rows, done.columns), (2, 3));
        assert_eq!(std::fs::read_to_string(&output).unwrap(), text);
        let back = Table::read(&output, None).unwrap();
        assert_eq!(back.numeric("tt").unwrap(), [0.1, 0.2]);
    }
}
