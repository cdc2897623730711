//! Flight data as a table of named columns, read from CSV, Geosoft XYZ, ASEG-GDF2, HDF5 or Parquet.
//!
//! ```
//! use tolles_io::table::Table;
//! let csv = "tt,mag_1_uc,flux_a_x,flux_a_y,flux_a_z\n0.0,50000,30000,0,40000\n0.1,,30001,1,40000\n";
//! let table = Table::csv().reader(csv.as_bytes(), "example.csv").unwrap();
//! let mag = table.numeric("mag_1_uc").unwrap();
//! assert_eq!(mag[0], 50_000.0);
//! assert!(mag[1].is_nan()); // an empty cell is a missing value, not an error
//! assert_eq!(table.vector("flux_a").unwrap()[0][1], 30_001.0);
//! ```
//!
//! Columns from text files (CSV, XYZ, GDF) keep their cells as text so that a file can be written
//! back with every column unchanged; columns from binary files (HDF5, Parquet) hold numbers.
//! An empty cell, `NaN` or `nan` is a missing value, and so is a format's own dummy (`*` in XYZ,
//! the NULL value of a GDF field); anything else that does not parse as a number is an error
//! naming the line (or, for binary files, the row) and column.

pub use crate::csv_reader::CsvReader;
pub(crate) use crate::csv_reader::{bounded_header, csv_error, read_located, Bounded};
pub use crate::csv_writer::{
    format_value, write_columns, write_columns_to, write_padded, write_with_column,
};
pub(crate) use crate::csv_writer::{non_finite_text, write_header, write_rows};
use crate::error::IoError;
use crate::header::{check_header, rename_header, suggest_vector};
// Part of this module's API since before they moved to `header`, which the readers share.
pub use crate::header::{find_column, parse_cell, MAX_HEADER_BYTES};
use crate::rawcsv::RawRows;
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// How a text column marks a missing value besides an empty cell or `NaN`.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Missing {
    /// A cell written exactly so is missing (Geosoft's `*`).
    pub token: Option<String>,
    /// A cell whose number equals this is missing (a GDF field's NULL, e.g. -99999).
    pub null: Option<f64>,
}

/// One column's cells as written in a text file: stored in one buffer, or left in the file's
/// own bytes ([`crate::rawcsv`]) until asked for.
#[derive(Debug, Clone, Default)]
pub struct TextColumn {
    cells: Cells,
    missing: Missing,
}

#[derive(Debug, Clone)]
enum Cells {
    /// Cells copied into one buffer; `ends[k]` is where cell k ends.
    Owned { text: String, ends: Vec<usize> },
    /// Cell `field` of each row of a CSV file read by [`crate::rawcsv`].
    Raw { rows: Arc<RawRows>, field: usize },
}

impl Default for Cells {
    fn default() -> Self {
        Cells::Owned {
            text: String::new(),
            ends: Vec::new(),
        }
    }
}

impl TextColumn {
    /// An empty column whose missing cells are marked as `missing` says.
    pub fn new(missing: Missing) -> Self {
        Self {
            missing,
            ..Self::default()
        }
    }

    /// Cell `field` of every row of `rows`.
    pub(crate) fn raw(rows: Arc<RawRows>, field: usize) -> Self {
        Self {
            cells: Cells::Raw { rows, field },
            missing: Missing::default(),
        }
    }

    /// Appends a cell.
    pub fn push(&mut self, cell: &str) {
        if let Cells::Raw { .. } = self.cells {
            self.cells = self.owned();
        }
        if let Cells::Owned { text, ends } = &mut self.cells {
            text.push_str(cell);
            ends.push(text.len());
        }
    }

    /// The cells copied into one buffer.
    fn owned(&self) -> Cells {
        let mut text = String::new();
        let mut ends = Vec::with_capacity(self.len());
        for k in 0..self.len() {
            text.push_str(self.get(k));
            ends.push(text.len());
        }
        Cells::Owned { text, ends }
    }

    /// Number of cells.
    pub fn len(&self) -> usize {
        match &self.cells {
            Cells::Owned { ends, .. } => ends.len(),
            Cells::Raw { rows, .. } => rows.len(),
        }
    }

    /// True when the column has no cells.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Cell `k` as written.
    pub fn get(&self, k: usize) -> &str {
        match &self.cells {
            Cells::Owned { text, ends } => {
                let start = if k == 0 { 0 } else { ends[k - 1] };
                &text[start..ends[k]]
            }
            Cells::Raw { rows, field } => rows.cell(k, *field),
        }
    }

    /// The file rows and cell this column reads, when it is left in a CSV file's bytes.
    fn raw_source(&self) -> Option<(&Arc<RawRows>, usize)> {
        match &self.cells {
            Cells::Raw { rows, field } => Some((rows, *field)),
            Cells::Owned { .. } => None,
        }
    }

    /// Cell `k` as a number (NaN when missing), or `None` when it is not a number.
    pub fn value(&self, k: usize) -> Option<f64> {
        let cell = self.get(k).trim();
        if self.missing.token.as_deref() == Some(cell) {
            return Some(f64::NAN);
        }
        let v = parse_cell(cell)?;
        Some(if Some(v) == self.missing.null {
            f64::NAN
        } else {
            v
        })
    }

    /// True when cell `k` is the format's own dummy (XYZ's `*`, a GDF field's NULL).
    pub(crate) fn is_dummy(&self, k: usize) -> bool {
        self.missing.token.is_some() && self.missing.token.as_deref() == Some(self.get(k).trim())
            || self.missing.null.is_some() && parse_cell(self.get(k)) == self.missing.null
    }
}

/// The cells of one column.
#[derive(Debug, Clone)]
pub enum Column {
    /// Cells as written in a text file.
    Text(TextColumn),
    /// Numbers from a binary file; NaN is missing.
    Numbers(Vec<f64>),
}

impl Column {
    /// Number of cells.
    pub fn len(&self) -> usize {
        match self {
            Column::Text(t) => t.len(),
            Column::Numbers(v) => v.len(),
        }
    }

    /// True when the column has no cells.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The file rows and field behind a text column left in a file's bytes.
    fn raw_source(&self) -> Option<(&Arc<RawRows>, usize)> {
        match self {
            Column::Text(text) => text.raw_source(),
            Column::Numbers(_) => None,
        }
    }
}

/// A 1-D numeric array a file holds beside the table's columns but of another length (in
/// MagNav's `test_data_TL.mat`, the 960-value `mag_1_uc_f_t` and the 18-value `TL_a_1` beside
/// 1000-row columns). Fit and compensate do not use it; `tolles convert` writes it.
#[derive(Debug, Clone, PartialEq)]
pub struct SideColumn {
    /// The name, as a column of the file would be named.
    pub name: String,
    /// The values, in the file's units; NaN is missing.
    pub values: Vec<f64>,
}

/// The `parts` one after another, with a NaN between two.
fn joined(parts: Vec<Vec<f64>>) -> Vec<f64> {
    let mut column = Vec::with_capacity(parts.iter().map(|p| p.len() + 1).sum());
    for (k, part) in parts.into_iter().enumerate() {
        if k > 0 {
            column.push(f64::NAN);
        }
        column.extend(part);
    }
    column
}

/// The most common of `lengths` (the longer on a tie): how many rows a table read from a file of
/// 1-D arrays of several lengths has. `None` when there are none.
pub(crate) fn most_common_length(lengths: impl IntoIterator<Item = usize>) -> Option<usize> {
    let mut counts: Vec<(usize, usize)> = Vec::new();
    for n in lengths {
        match counts.iter_mut().find(|(len, _)| *len == n) {
            Some((_, count)) => *count += 1,
            None => counts.push((n, 1)),
        }
    }
    counts
        .into_iter()
        .max_by_key(|&(len, count)| (count, len))
        .map(|(len, _)| len)
}

/// Where each row of a table is in the file it was read from, so messages about a table whose
/// rows were selected still name the file's own lines.
#[derive(Debug, Clone)]
enum Origin {
    /// The file line of each row (text files).
    Lines(Vec<u64>),
    /// The 1-based row number in the file of each row (binary files, after a selection).
    Rows(Vec<u64>),
    /// Row `k` is the file's row `k + 1` (binary files as read).
    InOrder,
    /// Row `k` is the file's line `k + first` (a text file without blank lines, as read).
    LinesFrom(u64),
}

/// A table of named, equally long columns held in memory.
#[derive(Debug, Clone)]
pub struct Table {
    path: PathBuf,
    headers: Vec<String>,
    columns: Vec<Column>,
    len: usize,
    origin: Origin,
    metadata: Vec<(String, f64)>,
    /// Metadata the reader worked out rather than read (`dt` from MATLAB's `fs`).
    derived: Vec<String>,
    side: Vec<SideColumn>,
    notes: Vec<String>,
    aliases: Vec<(String, usize)>,
    /// Units the file declares for its columns: `(column index, unit)`.
    units: Vec<(usize, String)>,
    /// What the reader found the file to be, where its name does not say (a MAT-file read as
    /// HDF5, standard input).
    format_name: Option<&'static str>,
}

impl Table {
    /// A table of `columns` named `headers`. `lines` gives each row's file line (text files);
    /// without it, messages name rows by number. Errors if there are no columns or rows, a
    /// name repeats, or the columns differ in length.
    pub fn from_columns(
        path: impl AsRef<Path>,
        headers: Vec<String>,
        columns: Vec<Column>,
        lines: Option<Vec<u64>>,
    ) -> Result<Self, IoError> {
        let path = path.as_ref().to_path_buf();
        check_header(&path, &headers)?;
        let len = columns.first().map_or(0, Column::len);
        for (name, column) in headers.iter().zip(&columns) {
            if column.len() != len {
                return Err(IoError::UnequalColumns {
                    path,
                    first: headers[0].clone(),
                    expected: len,
                    column: name.clone(),
                    found: column.len(),
                });
            }
        }
        if len == 0 {
            return Err(IoError::NoRows { path });
        }
        Ok(Self {
            path,
            headers,
            columns,
            len,
            origin: lines.map_or(Origin::InOrder, Origin::Lines),
            metadata: Vec::new(),
            derived: Vec::new(),
            side: Vec::new(),
            notes: Vec::new(),
            aliases: Vec::new(),
            units: Vec::new(),
            format_name: None,
        })
    }

    /// Adds a scalar the reader worked out from the file rather than read from it (MATLAB's
    /// `dt = 1 / fs`): [`Table::metadata`] finds it, [`Table::file_metadata`] does not, so a
    /// converted file holds only what the input held.
    pub fn with_derived_metadata(mut self, name: &str, value: f64) -> Self {
        self.metadata.push((name.to_string(), value));
        self.derived.push(name.to_string());
        self
    }

    /// The table with the sample interval `dt` (s) in its metadata when the file states it
    /// otherwise: as 1 / a scalar `fs` (Hz; MagNav's `TL_data.fs`), or, in a one-row table of
    /// a file's scalars, as its `dt` or `fs` column. Unchanged when `dt` is there already.
    pub fn with_dt_from_fs(self) -> Self {
        let dt = crate::schema::SAMPLE_INTERVAL;
        if self.metadata(dt).is_some() {
            return self;
        }
        let scalar = |name: &str| {
            self.metadata(name).or_else(|| {
                (self.len == 1)
                    .then(|| self.numeric(name).ok().map(|v| v[0]))
                    .flatten()
            })
        };
        let interval = scalar(dt).or_else(|| scalar("fs").map(|fs| 1.0 / fs));
        match interval.filter(|dt| dt.is_finite() && *dt > 0.0) {
            Some(value) => self.with_derived_metadata(dt, value),
            None => self,
        }
    }

    /// The scalars the file itself holds (all of [`Table::all_metadata`] but those the reader
    /// worked out).
    pub fn file_metadata(&self) -> impl Iterator<Item = &(String, f64)> {
        self.metadata
            .iter()
            .filter(|(name, _)| !self.derived.contains(name))
    }

    /// Adds 1-D arrays the file holds beside the columns, of other lengths ([`SideColumn`]).
    pub fn with_side_columns(mut self, side: Vec<SideColumn>) -> Self {
        self.side = side;
        self
    }

    /// The 1-D arrays the file holds beside the columns, of other lengths; not rows of the table.
    pub fn side_columns(&self) -> &[SideColumn] {
        &self.side
    }

    /// Adds scalar values the file carries besides its columns (HDF5's `N`, `dt`).
    pub fn with_metadata(mut self, metadata: Vec<(String, f64)>) -> Self {
        self.metadata = metadata;
        self
    }

    /// The table, its format named (`"mat"`, `"xyz"`, …) where the file's name does not say.
    pub fn with_format_name(mut self, name: &'static str) -> Self {
        self.format_name = Some(name);
        self
    }

    /// What the reader found the file to be, where its name does not say it.
    pub fn format_name(&self) -> Option<&'static str> {
        self.format_name
    }

    /// The table, with notes about what the reader left out of it (e.g. a 2-D dataset), so the
    /// caller can tell the user.
    pub fn with_notes(mut self, notes: Vec<String>) -> Self {
        self.notes = notes;
        self
    }

    /// Adds other names for columns: `(name, index)` makes [`Table::index_of`] find column
    /// `index` also as `name` (case-insensitively) when no column is called so. The headers,
    /// and so every file written from the table, are unchanged. See
    /// [`crate::schema::aliases`].
    pub fn with_aliases(mut self, aliases: Vec<(String, usize)>) -> Self {
        self.aliases = aliases;
        self
    }

    /// Adds the units the file declares for its columns, `(column name, unit)`; names that are
    /// no column are ignored. A time column in a unit of time other than seconds is read in
    /// seconds from then on (see [`Table::numeric`]); one in a unit that is not time gets a
    /// note, and is read as it is.
    pub fn with_units(mut self, units: Vec<(String, String)>) -> Self {
        self.units = units
            .into_iter()
            .filter(|(_, unit)| !unit.trim().is_empty())
            .filter_map(|(name, unit)| Some((self.headers.iter().position(|h| *h == name)?, unit)))
            .collect();
        self
    }

    /// The unit the file declares for column `name`, if any.
    pub fn unit(&self, name: &str) -> Option<&str> {
        let index = self.index_of(name).ok()?;
        self.units
            .iter()
            .find(|(k, _)| *k == index)
            .map(|(_, u)| u.as_str())
    }

    /// The time column's name and the unit of time its file declares, when that is not seconds.
    pub fn time_unit(&self) -> Option<(String, String)> {
        let (index, _) = self.time_scale()?;
        let unit = self.units.iter().find(|(k, _)| *k == index)?;
        Some((self.headers[index].clone(), unit.1.clone()))
    }

    /// The time column's index and the seconds in one of its declared units, when that is not
    /// one second.
    pub(crate) fn time_scale(&self) -> Option<(usize, f64)> {
        if self.units.is_empty() {
            return None;
        }
        let index = self.index_of(crate::schema::TIME_COLUMN).ok()?;
        let (_, unit) = self.units.iter().find(|(k, _)| *k == index)?;
        crate::schema::seconds_per(unit)
            .filter(|s| *s != 1.0)
            .map(|s| (index, s))
    }

    /// A note on a time column whose declared unit is not a unit of time, if there is one.
    pub fn time_unit_note(&self) -> Option<String> {
        let index = self.index_of(crate::schema::TIME_COLUMN).ok()?;
        let (_, unit) = self.units.iter().find(|(k, _)| *k == index)?;
        crate::schema::seconds_per(unit).is_none().then(|| {
            format!(
                "time column {:?} is declared in {unit:?}, which is no unit of time tolles knows; \
                 read as seconds",
                self.headers[index]
            )
        })
    }

    /// The other names columns are also found by: `(name, column index)`.
    pub fn aliases(&self) -> &[(String, usize)] {
        &self.aliases
    }

    /// Renames column `old` (found as [`Table::index_of`] finds it) to `new`; where no column is
    /// called `old`, the side column or file scalar of that exact name is renamed instead. An
    /// error if there is none of these, or a column, side column or scalar is already called
    /// `new` (the file could not be written back). Aliases of the table are dropped (they were
    /// chosen for the old names).
    pub fn rename(&mut self, old: &str, new: &str) -> Result<(), IoError> {
        let new = new.trim();
        if new.is_empty() {
            return Err(IoError::Empty {
                path: self.path.clone(),
            });
        }
        let taken = self.beside_names().any(|name| name == new && name != old);
        let beside = find_column(&self.path, &self.headers, old).is_err()
            && self.beside_names().any(|name| name == old);
        if taken || (beside && self.headers.iter().any(|h| h == new)) {
            return Err(IoError::DuplicateColumn {
                path: self.path.clone(),
                column: new.to_string(),
            });
        }
        if beside {
            self.rename_beside(old, new);
        } else {
            rename_header(&self.path, &mut self.headers, old, new)?;
        }
        self.aliases.clear();
        Ok(())
    }

    /// The names of the side columns and of the scalars the file holds.
    fn beside_names(&self) -> impl Iterator<Item = &str> {
        let side = self.side.iter().map(|s| s.name.as_str());
        side.chain(self.file_metadata().map(|(name, _)| name.as_str()))
    }

    /// Renames the side column or file scalar called exactly `old` to `new`.
    fn rename_beside(&mut self, old: &str, new: &str) {
        if let Some(side) = self.side.iter_mut().find(|s| s.name == old) {
            side.name = new.to_string();
        } else if let Some((name, _)) = self
            .metadata
            .iter_mut()
            .find(|(n, _)| n == old && !self.derived.contains(n))
        {
            *name = new.to_string();
        }
    }

    /// Replaces the cells of column `name` with `values` (as numbers; NaN is missing); an error
    /// if there is no such column or `values` has another length than the table.
    pub fn set_numeric(&mut self, name: &str, values: Vec<f64>) -> Result<(), IoError> {
        let index = self.index_of(name)?;
        if values.len() != self.len {
            return Err(IoError::UnequalColumns {
                path: self.path.clone(),
                first: self.headers[0].clone(),
                expected: self.len,
                column: self.headers[index].clone(),
                found: values.len(),
            });
        }
        // The column keeps its declared unit: values come in seconds, as they went out.
        let values = match self.time_scale() {
            Some((time, seconds)) if time == index => values.iter().map(|t| t / seconds).collect(),
            _ => values,
        };
        self.columns[index] = Column::Numbers(values);
        Ok(())
    }

    /// The same columns under `names` (one per column), for a reader that renamed its header.
    pub(crate) fn set_headers(&mut self, names: Vec<String>) {
        debug_assert_eq!(names.len(), self.headers.len());
        self.headers = names;
    }

    /// A reader of CSV text with a header row into a table (see [`CsvReader`]): from a file,
    /// bytes in memory or any reader, left in its bytes where it can be.
    pub fn csv() -> CsvReader<'static> {
        CsvReader::new()
    }

    /// Row `k` is the file's line `k + first`: a text file without blank lines, as read.
    pub(crate) fn with_lines_from(mut self, first: u64) -> Self {
        self.origin = Origin::LinesFrom(first);
        self
    }

    /// The file this table came from.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Column names in file order.
    pub fn headers(&self) -> &[String] {
        &self.headers
    }

    /// The columns, in the order of [`Table::headers`].
    pub fn columns(&self) -> &[Column] {
        &self.columns
    }

    /// Number of data rows.
    pub fn len(&self) -> usize {
        self.len
    }

    /// True when there are no data rows (never, for a table that was read successfully).
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// Scalar `name` the file carries besides its columns (e.g. HDF5 `dt`, s), if any.
    pub fn metadata(&self, name: &str) -> Option<f64> {
        self.metadata
            .iter()
            .find(|(n, _)| n == name)
            .map(|(_, v)| *v)
    }

    /// All scalars the file carries besides its columns.
    pub fn all_metadata(&self) -> &[(String, f64)] {
        &self.metadata
    }

    /// What the reader left out of the table, one sentence each.
    pub fn notes(&self) -> &[String] {
        &self.notes
    }

    /// The file line of data row `k` (0-based), for messages; for binary files, the 1-based row
    /// number in the file. Both stay those of the file after [`Table::select_rows`].
    pub fn line_of(&self, k: usize) -> u64 {
        let listed = match &self.origin {
            Origin::Lines(numbers) | Origin::Rows(numbers) => numbers.get(k).copied(),
            Origin::InOrder => None,
            Origin::LinesFrom(first) => Some(k as u64 + first),
        };
        listed.unwrap_or(k as u64 + 1)
    }

    /// Where data row `k` (0-based) is, for messages: "line N" for text files, "row N"
    /// (1-based) for binary ones; the file's own line or row, also after a selection.
    pub fn place_of(&self, k: usize) -> String {
        match &self.origin {
            Origin::Lines(_) | Origin::LinesFrom(_) => format!("line {}", self.line_of(k)),
            Origin::Rows(_) | Origin::InOrder => format!("row {}", self.line_of(k)),
        }
    }

    /// A table of the rows `k` with `keep[k]` true, in order, each keeping its cells as written
    /// and its place in the file (see [`Table::place_of`]); metadata, side columns (which are
    /// not rows) and notes carry over.
    /// The result has no rows when nothing is kept.
    ///
    /// # Panics
    /// If `keep` is not one flag per row.
    pub fn select_rows(&self, keep: &[bool]) -> Table {
        assert_eq!(keep.len(), self.len, "select_rows needs one flag per row");
        let kept: Vec<usize> = (0..self.len).filter(|&k| keep[k]).collect();
        // The columns left in a file's bytes share their rows, so those are selected once.
        let mut selected: Vec<(&Arc<RawRows>, Arc<RawRows>)> = Vec::new();
        let columns = self
            .columns
            .iter()
            .map(|column| match (column, column.raw_source()) {
                (_, Some((rows, field))) => {
                    let subset = match selected.iter().find(|(r, _)| Arc::ptr_eq(r, rows)) {
                        Some((_, subset)) => Arc::clone(subset),
                        None => {
                            let subset = Arc::new(rows.select(&kept));
                            selected.push((rows, Arc::clone(&subset)));
                            subset
                        }
                    };
                    Column::Text(TextColumn::raw(subset, field))
                }
                (Column::Text(text), None) => {
                    let mut chosen = TextColumn::new(text.missing.clone());
                    for &k in &kept {
                        chosen.push(text.get(k));
                    }
                    Column::Text(chosen)
                }
                (Column::Numbers(values), None) => {
                    Column::Numbers(kept.iter().map(|&k| values[k]).collect())
                }
            })
            .collect();
        let places = kept.iter().map(|&k| self.line_of(k)).collect();
        Table {
            path: self.path.clone(),
            headers: self.headers.clone(),
            columns,
            len: kept.len(),
            origin: match self.origin {
                Origin::Lines(_) | Origin::LinesFrom(_) => Origin::Lines(places),
                Origin::Rows(_) | Origin::InOrder => Origin::Rows(places),
            },
            metadata: self.metadata.clone(),
            derived: self.derived.clone(),
            side: self.side.clone(),
            notes: self.notes.clone(),
            aliases: self.aliases.clone(),
            units: self.units.clone(),
            format_name: self.format_name,
        }
    }

    /// The columns `needed` (as numbers; missing values NaN) of every table in `parts`, one
    /// table's rows after another's, with one row of NaN between two tables: a missing sample
    /// ends every run, so no filter or difference reaches from one flight into the next, and
    /// time may start again in the next. A needed name that some part lacks is an error naming
    /// that part's file; an `optional` one is kept when every part has it as numbers. The
    /// result is named `path`; messages name its rows by number.
    pub fn stacked(
        path: &Path,
        parts: &[Table],
        needed: &[String],
        optional: &[&str],
    ) -> Result<Table, IoError> {
        let mut per_part: Vec<Vec<Vec<f64>>> = vec![Vec::new(); needed.len()];
        for part in parts {
            let indices =
                (needed.iter().map(|name| part.index_of(name))).collect::<Result<Vec<_>, _>>()?;
            for (column, values) in per_part.iter_mut().zip(part.numeric_many(&indices)) {
                column.push(values?);
            }
        }
        let mut headers = needed.to_vec();
        for name in optional {
            let values = parts.iter().map(|part| part.numeric(name).ok());
            if let Some(values) = values.collect::<Option<Vec<_>>>() {
                headers.push(name.to_string());
                per_part.push(values);
            }
        }
        let columns = per_part
            .into_iter()
            .map(|parts| Column::Numbers(joined(parts)));
        Table::from_columns(path, headers, columns.collect(), None)
    }

    /// True when the table has a column named `name` (see [`Table::index_of`] on case).
    pub fn has(&self, name: &str) -> bool {
        self.index_of(name).is_ok()
    }

    /// The index of column `name`, or an error that suggests near names. When no column has
    /// exactly that name, one column whose name differs only in case is taken (GDF and XYZ
    /// files often name their channels in capitals).
    pub fn index_of(&self, name: &str) -> Result<usize, IoError> {
        find_column(&self.path, &self.headers, name).or_else(|e| {
            self.aliases
                .iter()
                .find(|(alias, _)| alias.eq_ignore_ascii_case(name))
                .map(|(_, k)| *k)
                .ok_or(e)
        })
    }

    /// Column `name` as numbers; missing values are NaN.
    pub fn numeric(&self, name: &str) -> Result<Vec<f64>, IoError> {
        self.numeric_at(self.index_of(name)?)
    }

    /// Column number `index` as numbers; missing values are NaN.
    pub fn numeric_at(&self, index: usize) -> Result<Vec<f64>, IoError> {
        self.numeric_many(&[index]).remove(0)
    }

    /// Columns number `indices` as numbers (missing values NaN), each with the error
    /// [`Table::numeric_at`] gives; columns left in a file's bytes are parsed in one pass on all
    /// cores.
    pub fn numeric_many(&self, indices: &[usize]) -> Vec<Result<Vec<f64>, IoError>> {
        let mut out: Vec<Option<Result<Vec<f64>, IoError>>> =
            indices.iter().map(|_| None).collect();
        // Per file behind some of the columns, which of `indices` (j) are which of its fields.
        let mut groups: Vec<(&Arc<RawRows>, Vec<usize>, Vec<usize>)> = Vec::new();
        for (j, &index) in indices.iter().enumerate() {
            match self.columns[index].raw_source() {
                Some((rows, field)) => match groups.iter_mut().find(|(r, ..)| Arc::ptr_eq(r, rows))
                {
                    Some((_, members, fields)) => {
                        members.push(j);
                        fields.push(field);
                    }
                    None => groups.push((rows, vec![j], vec![field])),
                },
                None => out[j] = Some(self.numeric_cells(indices[j])),
            }
        }
        for (rows, members, fields) in groups {
            for (&j, (values, bad)) in members.iter().zip(rows.parse(&fields)) {
                out[j] = Some(match bad {
                    Some(k) => Err(self.not_a_number(indices[j], k)),
                    None => Ok(values),
                });
            }
        }
        let scale = self.time_scale();
        out.into_iter()
            .zip(indices)
            .map(|(r, &index)| {
                let values = r.expect("every column parsed");
                match scale {
                    Some((time, seconds)) if time == index => {
                        values.map(|v| v.into_iter().map(|t| t * seconds).collect())
                    }
                    _ => values,
                }
            })
            .collect()
    }

    /// The error for cell `k` of column `index`, which is not a number.
    fn not_a_number(&self, index: usize, k: usize) -> IoError {
        let value = match &self.columns[index] {
            Column::Text(text) => text.get(k).to_string(),
            Column::Numbers(v) => v[k].to_string(),
        };
        IoError::NotANumber {
            path: self.path.clone(),
            place: self.place_of(k),
            column: self.headers[index].clone(),
            value,
        }
    }

    /// Column number `index` as numbers, cell by cell.
    fn numeric_cells(&self, index: usize) -> Result<Vec<f64>, IoError> {
        match &self.columns[index] {
            Column::Numbers(v) => Ok(v.clone()),
            Column::Text(text) => (0..text.len())
                .map(|k| {
                    text.value(k).ok_or_else(|| IoError::NotANumber {
                        path: self.path.clone(),
                        place: self.place_of(k),
                        column: self.headers[index].clone(),
                        value: text.get(k).to_string(),
                    })
                })
                .collect(),
        }
    }

    /// Columns `PREFIX_x`, `PREFIX_y`, `PREFIX_z` as numbers, `[x, y, z]` (the suffixes in any
    /// case), or the three columns of a triple `X:Y:Z`; see [`crate::schema::vector_columns`].
    /// A missing column's error suggests the fluxgate prefixes the file has.
    pub fn vector(&self, spec: &str) -> Result<[Vec<f64>; 3], IoError> {
        self.parse_together(&[]).vector(spec)
    }

    /// The columns `names` (those the table has) parsed in one pass, to be taken one by one
    /// with [`Parsed::numeric`] and [`Parsed::vector`], which give what [`Table::numeric`] and
    /// [`Table::vector`] give, errors included.
    pub fn parse_together(&self, names: &[&str]) -> Parsed<'_> {
        let mut indices: Vec<usize> = names.iter().filter_map(|n| self.index_of(n).ok()).collect();
        indices.sort_unstable();
        indices.dedup();
        let values = indices
            .iter()
            .copied()
            .zip(self.numeric_many(&indices))
            .collect();
        Parsed {
            table: self,
            values,
        }
    }

    /// The file rows behind this table when every column is, in order, the cells of a CSV file
    /// left in its bytes ([`crate::rawcsv`]): a row can then be written by copying it.
    pub(crate) fn raw_rows(&self) -> Option<&RawRows> {
        let (rows, _) = self.columns.first()?.raw_source()?;
        let same = self.columns.iter().enumerate().all(|(j, c)| {
            c.raw_source()
                .is_some_and(|(r, field)| Arc::ptr_eq(r, rows) && field == j)
        });
        (same && rows.fields() == self.columns.len()).then_some(&**rows)
    }

    /// Appends cell (`column`, `row`) as CSV text: text cells as written (a format's dummy
    /// becomes empty so the CSV reads back as missing), numbers as [`format_value`] writes them.
    pub(crate) fn cell_text(&self, column: usize, row: usize, out: &mut String) {
        match &self.columns[column] {
            Column::Text(text) if text.is_dummy(row) => {}
            Column::Text(text) => out.push_str(text.get(row)),
            Column::Numbers(v) => format_value(v[row], out),
        }
    }
}

/// Columns of a table parsed together ([`Table::parse_together`]).
pub struct Parsed<'t> {
    table: &'t Table,
    values: Vec<(usize, Result<Vec<f64>, IoError>)>,
}

impl Parsed<'_> {
    /// Column `name` as numbers, as [`Table::numeric`] gives it; a column not parsed together
    /// (or taken before) is parsed now.
    pub fn numeric(&mut self, name: &str) -> Result<Vec<f64>, IoError> {
        let index = self.table.index_of(name)?;
        match self.values.iter().position(|(k, _)| *k == index) {
            Some(at) => self.values.swap_remove(at).1,
            None => self.table.numeric_at(index),
        }
    }

    /// The vector `spec` as numbers, as [`Table::vector`] gives it.
    pub fn vector(&mut self, spec: &str) -> Result<[Vec<f64>; 3], IoError> {
        let [x, y, z] = crate::schema::vector_columns(spec);
        let headers = self.table.headers();
        let mut column = |name: &str| {
            self.numeric(name).map_err(|e| match e {
                IoError::MissingColumn { path, column, near } if !spec.contains(':') => {
                    let near = suggest_vector(headers, spec).unwrap_or(near);
                    IoError::MissingColumn { path, column, near }
                }
                other => other,
            })
        };
        Ok([column(&x)?, column(&y)?, column(&z)?])
    }
}

/// The indices among `headers` of the columns `names` would find ([`Table::index_of`]) once
/// the table is renamed `(old, new)` by `renames` and given the raw-channel aliases
/// ([`crate::schema::aliases`]): what a workflow will ask for, known before the rows are read.
/// Names that would find nothing are left out (asking for them later gives the error).
pub fn indices_after_renames(
    headers: &[String],
    renames: &[(String, String)],
    names: &[String],
) -> Vec<usize> {
    let path = Path::new("");
    let mut renamed = headers.to_vec();
    for (old, new) in renames {
        if rename_header(path, &mut renamed, old, new).is_err() {
            return Vec::new();
        }
    }
    let aliases = crate::schema::aliases(&renamed);
    names
        .iter()
        .filter_map(|name| {
            find_column(path, &renamed, name).ok().or_else(|| {
                let alias = aliases.iter().find(|(a, _)| a.eq_ignore_ascii_case(name));
                alias.map(|(_, k)| *k)
            })
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn read(text: &str) -> Result<Table, IoError> {
        Table::csv().reader(text.as_bytes(), "t.csv")
    }

    #[test]
    fn stacked_tables_keep_every_row_apart_by_one_missing_row_and_name_a_lacking_file() {
        let first = read("tt,a,b\n0,1,x\n1,2,y\n").unwrap();
        let second = Table::csv()
            .reader("b,a,tt\n,3,0\n".as_bytes(), "second.csv")
            .unwrap();
        let names = ["tt".to_string(), "a".to_string()];
        let stacked = Table::stacked(Path::new("both"), &[first, second], &names, &["b", "c"]);
        let stacked = stacked.unwrap();
        assert_eq!(stacked.headers(), names);
        assert_eq!(stacked.numeric("a").unwrap()[..2], [1.0, 2.0]);
        let tt = stacked.numeric("tt").unwrap();
        assert!(tt[2].is_nan() && tt.len() == 4 && tt[3] == 0.0, "{tt:?}");
        // An optional column every part has as numbers is kept; "b" (text) and "c" were not.
        let parts = [read("tt,a\n0,1\n").unwrap(), read("a,tt\n2,0\n").unwrap()];
        let kept = Table::stacked(Path::new("k"), &parts, &names[..1], &["a"]).unwrap();
        assert_eq!(kept.headers(), ["tt", "a"]);
        assert_eq!(kept.numeric("a").unwrap()[2], 2.0);
        let lacking = Table::csv()
            .reader("a\n1\n".as_bytes(), "third.csv")
            .unwrap();
        let error = Table::stacked(
            Path::new("x"),
            &[read("tt,a\n0,1\n").unwrap(), lacking],
            &names,
            &[],
        )
        .unwrap_err()
        .to_string();
        assert!(
            error.contains("third.csv") && error.contains("tt"),
            "{error}"
        );
    }

    #[test]
    fn bytes_parsed_while_read_give_the_values_and_errors_of_bytes_parsed_later() {
        let text = "a,b,c\n1,2.5,x\n\n-3,4e1,5\n";
        let wanted = |_: &[String]| vec![0, 2];
        let early = Table::csv()
            .parsing(&wanted)
            .bytes(text.as_bytes().to_vec(), "t.csv");
        let (early, later) = (early.unwrap(), read(text).unwrap());
        for _ in 0..2 {
            assert_eq!(early.numeric("a").unwrap(), [1.0, -3.0]);
            assert_eq!(early.numeric("b").unwrap(), later.numeric("b").unwrap());
            let error = |t: &Table| t.numeric("c").unwrap_err().to_string();
            assert_eq!(error(&early), error(&later));
        }
    }

    #[test]
    fn a_last_row_without_a_newline_after_blank_lines_is_named_by_its_own_line() {
        for (text, line) in [
            ("a\n\nx", 3),
            ("a\n\nx\n", 3),
            ("a\n1\n\n\nx", 5),
            ("a\nx", 2),
            ("a\n\n\"\nx\"", 3),
        ] {
            let error = read(text).unwrap().numeric("a").unwrap_err().to_string();
            assert!(
                error.contains(&format!("line {line},")),
                "{text:?}: {error}"
            );
            let raw = Table::csv()
                .bytes(text.as_bytes().to_vec(), "t.csv")
                .unwrap();
            assert_eq!(raw.numeric("a").unwrap_err().to_string(), error, "{text:?}");
        }
        let error = read("a,b\n1,2\n\n3").unwrap_err().to_string();
        assert_eq!(error, "t.csv: line 4: 1 fields, but the header has 2");
    }

    #[test]
    fn ragged_row_names_its_line() {
        let err = read("a,b\n1,2\n3\n").unwrap_err().to_string();
        assert_eq!(err, "t.csv: line 3: 1 fields, but the header has 2");
    }

    #[test]
    fn blank_lines_and_quoted_newlines_do_not_shift_line_numbers() {
        let t = read("a,b\n1,2\n\n\n3,x7\n\"4\n5\",6\n7,y\n").unwrap();
        let err = t.numeric("b").unwrap_err().to_string();
        assert_eq!(err, "t.csv: line 5, column \"b\": \"x7\" is not a number");
        assert_eq!((t.line_of(2), t.line_of(3)), (6, 8));
        let t = read("a,b\n1,2\n3,4").unwrap();
        assert_eq!(t.line_of(1), 3, "a last row without a newline");
        let err = read("a,b\n1,2\n\n3\n").unwrap_err().to_string();
        assert_eq!(err, "t.csv: line 4: 1 fields, but the header has 2");
    }

    #[test]
    fn non_numeric_cell_names_line_and_column() {
        let t = read("a,b\n1,2\n3,x7\n").unwrap();
        let err = t.numeric("b").unwrap_err().to_string();
        assert_eq!(err, "t.csv: line 3, column \"b\": \"x7\" is not a number");
    }

    #[test]
    fn missing_column_suggests_near_names() {
        let t = read("tt,flux_b_x,flux_b_y,flux_b_z\n1,2,3,4\n").unwrap();
        let err = t.vector("flux_a").unwrap_err().to_string();
        assert!(err.contains("no column \"flux_a_x\""), "{err}");
        let err = t.numeric("mag").unwrap_err().to_string();
        assert!(err.contains("the header has: tt, flux_b_x"), "{err}");
    }

    #[test]
    fn vector_suggestions_are_caseless_prefixes() {
        let t = read("tt,FLUXA_X,FLUXA_Y,FLUXA_Z\n1,2,3,4\n").unwrap();
        let err = t.vector("FLUX").unwrap_err().to_string();
        assert!(err.contains("did you mean FLUXA?"), "{err}");
        let err = t.vector("flux").unwrap_err().to_string();
        assert!(err.contains("did you mean FLUXA?"), "{err}");
        assert_eq!(t.vector("fluxa").unwrap()[2][0], 4.0);
        assert_eq!(t.vector("FLUXA_Z:FLUXA_Y:FLUXA_X").unwrap()[0][0], 4.0);
        // Names without a separator are read as three columns, which is what is suggested.
        let bare = read("tt,FLUXX,FLUXY,FLUXZ\n1,2,3,4\n").unwrap();
        let err = bare.vector("FLUX").unwrap_err().to_string();
        assert!(err.contains("did you mean FLUXX:FLUXY:FLUXZ?"), "{err}");
        assert_eq!(bare.vector("FLUXX:FLUXY:FLUXZ").unwrap()[2][0], 4.0);
        let err = t.numeric("fluxa").unwrap_err().to_string();
        assert!(
            err.contains("did you mean FLUXA_X, FLUXA_Y, FLUXA_Z?"),
            "{err}"
        );
    }

    #[test]
    fn aliases_find_columns_and_renames_change_headers() {
        let t = read("AZIMUTH,b\n1,2\n").unwrap();
        let aliases = crate::schema::aliases(t.headers());
        let mut t = t.with_aliases(aliases);
        assert_eq!(t.numeric("ins_yaw").unwrap(), [1.0]);
        assert_eq!(t.numeric("azimuth").unwrap(), [1.0]);
        t.rename("b", "c").unwrap();
        assert_eq!(t.headers(), ["AZIMUTH", "c"]);
        assert!(t
            .rename("nope", "d")
            .unwrap_err()
            .to_string()
            .contains("\"nope\""));
        assert!(matches!(
            t.rename("c", "AZIMUTH"),
            Err(IoError::DuplicateColumn { .. })
        ));
    }

    #[test]
    fn headers_and_cells_are_trimmed() {
        let t = read(" a ,b\t\n 1.5 ,\t2\n").unwrap();
        assert_eq!(t.headers(), ["a", "b"]);
        let mut out = Vec::new();
        write_with_column(&t, &[], &mut out).unwrap();
        assert_eq!(String::from_utf8(out).unwrap(), "a,b\n1.5,2\n");
    }

    #[test]
    fn empty_and_header_only_files_are_errors() {
        assert!(matches!(read(""), Err(IoError::Empty { .. })));
        assert!(matches!(read("a,b\n"), Err(IoError::NoRows { .. })));
        assert!(matches!(
            read("a,a\n1,2\n"),
            Err(IoError::DuplicateColumn { .. })
        ));
    }

    #[test]
    fn written_table_keeps_every_cell_and_row() {
        let t = read("a,b\n1.50,x\n,2\n").unwrap();
        let mut out = Vec::new();
        write_with_column(&t, &[("c".into(), vec![0.1, f64::NAN])], &mut out).unwrap();
        assert_eq!(String::from_utf8(out).unwrap(), "a,b,c\n1.50,x,0.1\n,2,\n");
    }

    #[test]
    fn written_columns_read_back_identically() {
        let a = [0.1, -2.5e-7, 50_000.123_456_789];
        let b = [1.0, f64::NAN, 3.0];
        let mut out = Vec::new();
        write_columns(&[("a", &a), ("b", &b)], &mut out).unwrap();
        let t = Table::csv().reader(out.as_slice(), "w.csv").unwrap();
        assert_eq!(t.numeric("a").unwrap(), a);
        let back = t.numeric("b").unwrap();
        assert!(back[1].is_nan() && back[2] == 3.0);
    }

    #[test]
    fn selected_rows_keep_their_cells_and_file_lines() {
        let t = read("a,b\n1.50,x\n2,y\n7,w\n3.0,z\n")
            .unwrap()
            .with_metadata(vec![("dt".into(), 0.1)])
            .with_notes(vec!["left out c".into()]);
        let s = t.select_rows(&[true, false, false, true]);
        assert_eq!(s.len(), 2);
        assert_eq!(s.headers(), t.headers());
        assert_eq!((s.line_of(0), s.line_of(1)), (2, 5));
        assert_eq!(s.place_of(1), "line 5");
        assert_eq!(s.metadata("dt"), Some(0.1));
        assert_eq!(s.notes(), ["left out c"]);
        let mut out = Vec::new();
        write_with_column(&s, &[], &mut out).unwrap();
        assert_eq!(String::from_utf8(out).unwrap(), "a,b\n1.50,x\n3.0,z\n");
        let err = s.numeric("b").unwrap_err().to_string();
        assert_eq!(err, "t.csv: line 2, column \"b\": \"x\" is not a number");
    }

    #[test]
    fn a_selection_of_a_selection_still_names_the_file_line() {
        let t = read("a\n1\n2\n3\nq\n").unwrap();
        let s = t.select_rows(&[false, true, true, true]);
        let s = s.select_rows(&[false, true, true]);
        let err = s.numeric("a").unwrap_err().to_string();
        assert_eq!(err, "t.csv: line 5, column \"a\": \"q\" is not a number");
    }

    #[test]
    fn selected_rows_of_a_binary_table_name_the_file_row() {
        let column = Column::Numbers(vec![10.0, 11.0, 12.0, 13.0]);
        let t = Table::from_columns("t.h5", vec!["a".into()], vec![column], None).unwrap();
        assert_eq!(t.place_of(2), "row 3");
        let s = t.select_rows(&[false, false, true, true]);
        assert_eq!(s.numeric("a").unwrap(), [12.0, 13.0]);
        assert_eq!((s.place_of(0), s.line_of(1)), ("row 3".into(), 4));
        let s = s.select_rows(&[false, true]);
        assert_eq!(s.place_of(0), "row 4");
    }

    #[test]
    fn selecting_nothing_gives_an_empty_table() {
        let t = read("a\n1\n").unwrap();
        assert!(t.select_rows(&[false]).is_empty());
    }

    #[test]
    fn format_value_round_trips() {
        for v in [
            0.1,
            1e-300,
            50_123.456_789_012_34,
            -3.0,
            3.334_722e-11,
            -2e300,
            5e-324,
        ] {
            let mut s = String::new();
            format_value(v, &mut s);
            assert_eq!(s.parse::<f64>().unwrap(), v, "{s}");
            assert!(s.len() < 25, "{s}");
        }
        let mut s = String::new();
        format_value(50_000.0, &mut s);
        assert_eq!(s, "50000");
    }
}
