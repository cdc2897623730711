//! What a flight file holds: its columns (with units where the file states them), rows,
//! sample rate, lines, time span and missing values, without fitting anything.
//!
//! ```
//! use tolles::{info, simulate, Silent};
//! # let dir = tempfile::tempdir().unwrap();
//! # let path = dir.path().join("box.csv");
//! let flight = simulate::simulate(&simulate::SimulateRequest::default(), &Silent).unwrap();
//! simulate::write(&flight, &path).unwrap();
//! let about = info::info(&path, &Default::default(), &[], &Silent, &mut Vec::new()).unwrap();
//! assert!(about.columns.iter().any(|c| c.name == "mag_1_uc"));
//! assert!(about.sample_rate_hz.unwrap() > 0.0);
//! ```

use crate::error::Result;
use crate::progress::Progress;
use crate::warning::Warning;
use serde_json::{json, Value};
use std::path::{Path, PathBuf};
use tolles_core::signal::segment::sampling_step;
use tolles_io::format::Format;
use tolles_io::schema::{LINE_COLUMN, TIME_COLUMN};
use tolles_io::table::{Column, Table};

/// One column of a flight file.
#[derive(Debug, Clone, PartialEq)]
pub struct ColumnInfo {
    /// The name as the file (after renames) has it.
    pub name: String,
    /// Units as the file states them (a GDF `.dfn`'s `UNITS=`/`UNIT=`, an HDF5 dataset's
    /// `units` attribute), if it does; CSV, XYZ, Parquet and MATLAB v5 files state none.
    pub unit: Option<String>,
    /// tolles' names the column also answers to (SGL raw channels, e.g. `ins_yaw` for AZIMUTH).
    pub aliases: Vec<String>,
    /// Missing cells (empty, NaN, the format's dummy).
    pub missing: usize,
    /// Cells that are not numbers (text such as a line id `L7`).
    pub non_numeric: usize,
}

/// One flight line: its id as written and how many rows are on it.
#[derive(Debug, Clone, PartialEq)]
pub struct LineInfo {
    /// The line id as written.
    pub id: String,
    /// Rows on the line (rows).
    pub rows: usize,
}

/// What [`info`] found.
#[derive(Debug, Clone, PartialEq)]
pub struct FlightInfo {
    /// The file read.
    pub path: PathBuf,
    /// The format: the one the extension names (`csv`, `xyz`, `gdf`, `hdf5`, `parquet`), `mat`
    /// for a MAT-file, and the one its content shows for standard input.
    pub format: String,
    /// Data rows read, after any selection (rows).
    pub rows: usize,
    /// Each column, in file order.
    pub columns: Vec<ColumnInfo>,
    /// 1 / the median step of `tt`, else 1 / the file's `dt`; `None` when neither gives one.
    pub sample_rate_hz: Option<f64>,
    /// The earliest and latest finite time (s) of `tt`.
    pub time_span_s: Option<(f64, f64)>,
    /// Whether `tt` increases from row to row (a file sorted by line often steps back).
    pub time_in_order: bool,
    /// The flight lines in the order they first appear (when there is a `line` column).
    pub lines: Option<Vec<LineInfo>>,
    /// Scalars the file carries besides its columns (HDF5's `dt`, `N`; MATLAB's `fs`), and a
    /// `dt` (s) worked out from `fs`.
    pub metadata: Vec<(String, f64)>,
    /// 1-D arrays of other lengths than the rows (MATLAB, HDF5), as `(name, length)`: not used
    /// by fit or compensate; `tolles convert` writes them.
    pub side_columns: Vec<(String, usize)>,
    /// What the reader left out (matrices, text, cells, groups), one sentence each.
    pub left_out: Vec<String>,
}

impl FlightInfo {
    /// As JSON: `{"path", "format", "rows", "sample_rate_hz", "time_span_s": [earliest,
    /// latest], "time_in_order",
    /// "lines": [{"id", "rows"}], "columns": [{"name", "unit", "aliases", "missing",
    /// "non_numeric"}], "metadata": {name: value}, "side_columns": [{"name", "length"}],
    /// "left_out": [sentence]}`; absent values are `null`.
    pub fn to_json(&self) -> Value {
        let columns: Vec<Value> = self
            .columns
            .iter()
            .map(|c| {
                json!({"name": c.name, "unit": c.unit, "aliases": c.aliases,
                       "missing": c.missing, "non_numeric": c.non_numeric})
            })
            .collect();
        let lines = self.lines.as_ref().map(|lines| {
            lines
                .iter()
                .map(|l| json!({"id": l.id, "rows": l.rows}))
                .collect::<Vec<_>>()
        });
        let metadata: serde_json::Map<String, Value> = self
            .metadata
            .iter()
            .map(|(n, v)| (n.clone(), json!(v)))
            .collect();
        json!({
            "path": self.path.display().to_string(),
            "format": self.format,
            "rows": self.rows,
            "sample_rate_hz": self.sample_rate_hz,
            "time_span_s": self.time_span_s.map(|(a, b)| [a, b]),
            "time_in_order": self.time_in_order,
            "lines": lines,
            "columns": columns,
            "metadata": metadata,
            "side_columns": self
                .side_columns
                .iter()
                .map(|(name, length)| json!({"name": name, "length": length}))
                .collect::<Vec<_>>(),
            "left_out": self.left_out,
        })
    }
}

/// Reads the flight at `path` (any format, columns renamed `(old, new)` first, only the rows
/// `selection` keeps) and says what it holds. Nothing about its values is an error: a time column that does not increase simply
/// gives no sample rate.
pub fn info(
    path: &Path,
    selection: &tolles_io::select::RowSelection,
    renames: &[(String, String)],
    progress: &dyn Progress,
    warnings: &mut Vec<Warning>,
) -> Result<FlightInfo> {
    let mut read_warnings = Vec::new();
    let table = crate::read::read_renamed(path, selection, renames, progress, &mut read_warnings);
    // What was left out and the side columns are part of the answer, not warnings.
    read_warnings
        .retain(|w| !matches!(w, Warning::ReaderNote { .. } | Warning::SideColumns { .. }));
    warnings.append(&mut read_warnings);
    let table = table?.table;
    let format = Format::from_path(path);
    let units = match format {
        Format::Gdf => gdf_units(path),
        Format::Hdf5 => tolles_io::hdf5::units(path),
        _ => Vec::new(),
    };
    let columns = table
        .headers()
        .iter()
        .zip(table.columns())
        .enumerate()
        .map(|(k, (name, column))| {
            let (missing, non_numeric) = counts(column);
            ColumnInfo {
                name: name.clone(),
                unit: units
                    .iter()
                    .find(|(n, _)| n.eq_ignore_ascii_case(name))
                    .map(|(_, u)| u.clone()),
                aliases: table
                    .aliases()
                    .iter()
                    .filter(|(_, j)| *j == k)
                    .map(|(a, _)| a.clone())
                    .collect(),
                missing,
                non_numeric,
            }
        })
        .collect();
    let tt = table.numeric(TIME_COLUMN).ok();
    let step = tt.as_deref().and_then(sampling_step);
    let sample_rate_hz = step
        .map(|s| 1.0 / s)
        .or_else(|| {
            table
                .metadata(tolles_io::schema::SAMPLE_INTERVAL)
                .map(|dt| 1.0 / dt)
        })
        .filter(|fs| fs.is_finite() && *fs > 0.0);
    let time_span_s = tt.as_deref().and_then(|tt| {
        let finite = || tt.iter().copied().filter(|t| t.is_finite());
        let earliest = finite().reduce(f64::min)?;
        Some((earliest, finite().fold(earliest, f64::max)))
    });
    let time_in_order = tt
        .as_deref()
        .is_none_or(|tt| tolles_core::signal::segment::first_non_increasing(tt).is_none());
    Ok(FlightInfo {
        path: table.path().to_path_buf(),
        format: (table.format_name())
            .unwrap_or(format.names()[0])
            .to_string(),
        rows: table.len(),
        columns,
        sample_rate_hz,
        time_span_s,
        time_in_order,
        lines: lines(&table),
        metadata: table.all_metadata().to_vec(),
        side_columns: table
            .side_columns()
            .iter()
            .map(|c| (c.name.clone(), c.values.len()))
            .collect(),
        left_out: table.notes().to_vec(),
    })
}

/// Missing and non-numeric cells of `column`.
fn counts(column: &Column) -> (usize, usize) {
    match column {
        Column::Numbers(v) => (v.iter().filter(|x| x.is_nan()).count(), 0),
        Column::Text(text) => (0..text.len()).fold((0, 0), |(m, n), k| match text.value(k) {
            Some(v) if v.is_nan() => (m + 1, n),
            Some(_) => (m, n),
            None => (m, n + 1),
        }),
    }
}

/// The lines of `table` in order of first appearance, with their row counts; missing ids are
/// left out.
fn lines(table: &Table) -> Option<Vec<LineInfo>> {
    let k = table.index_of(LINE_COLUMN).ok()?;
    let mut out: Vec<LineInfo> = Vec::new();
    // Survey files can hold 10⁵ line ids: find each by hash, not by search.
    let mut found: std::collections::HashMap<String, usize> = std::collections::HashMap::new();
    let column = &table.columns()[k];
    for row in 0..table.len() {
        let id = match column {
            Column::Text(text) => match text.value(row) {
                Some(v) if v.is_nan() => continue,
                _ => text.get(row).trim().to_string(),
            },
            Column::Numbers(v) if v[row].is_nan() => continue,
            Column::Numbers(v) => format!("{}", v[row]),
        };
        match found.get(&id) {
            Some(&j) => out[j].rows += 1,
            None => {
                found.insert(id.clone(), out.len());
                out.push(LineInfo { id, rows: 1 });
            }
        }
    }
    Some(out)
}

/// `(field, units)` from the `.dfn` beside a GDF file; empty when it cannot be read (the
/// table itself was read, so this only loses the units).
fn gdf_units(path: &Path) -> Vec<(String, String)> {
    let dfn = ["dfn", "DFN"]
        .into_iter()
        .map(|e| path.with_extension(e))
        .find(|p| p.exists());
    let Some(text) = dfn.and_then(|p| std::fs::read_to_string(p).ok()) else {
        return Vec::new();
    };
    match tolles_io::gdf::parse_dfn(&text, path, text.len() + 1) {
        Ok(definition) => definition
            .fields
            .into_iter()
            .filter_map(|f| Some((f.name, f.units?)))
            .collect(),
        Err(_) => Vec::new(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Silent;

    #[test]
    fn a_csv_flight_is_described() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("f.csv");
        std::fs::write(
            &path,
            "TIME,LINE,UNCOMPMAG1,x\n0,1,5,a\n0.1,1,,b\n0.2,2,7,\n",
        )
        .unwrap();
        let mut warnings = Vec::new();
        let about = info(&path, &Default::default(), &[], &Silent, &mut warnings).unwrap();
        assert_eq!(about.rows, 3);
        assert!((about.sample_rate_hz.unwrap() - 10.0).abs() < 1e-9);
        assert_eq!(about.time_span_s, Some((0.0, 0.2)));
        let lines = about.lines.unwrap();
        assert_eq!(lines.len(), 2);
        assert_eq!((lines[0].id.as_str(), lines[0].rows), ("1", 2));
        let mag = &about.columns[2];
        assert_eq!((mag.missing, mag.non_numeric), (1, 0));
        assert_eq!(mag.aliases, ["mag_1_uc"]);
        assert_eq!(
            (about.columns[3].missing, about.columns[3].non_numeric),
            (1, 2)
        );
        assert!(matches!(warnings[0], Warning::ColumnsAliased { .. }));
        assert!(about.side_columns.is_empty() && about.left_out.is_empty());
    }

    #[test]
    fn side_columns_and_left_out_arrays_are_described_not_warned() {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../tolles-io/tests/fixtures/magnav_test_data_TL.mat");
        let mut warnings = Vec::new();
        let about = info(&path, &Default::default(), &[], &Silent, &mut warnings).unwrap();
        assert_eq!(
            about.side_columns,
            [
                ("TL_a_1".to_string(), 18),
                ("mag_1_uc_f_t".to_string(), 960)
            ]
        );
        assert_eq!(about.left_out.len(), 2, "{:?}", about.left_out);
        assert!(
            about.left_out[0].contains("1000×18"),
            "{:?}",
            about.left_out
        );
        assert!(warnings.is_empty(), "{warnings:?}");
        assert!((about.sample_rate_hz.unwrap() - 10.0).abs() < 1e-6);
        let json = about.to_json();
        assert_eq!(json["side_columns"][1]["length"], 960);
    }
}
