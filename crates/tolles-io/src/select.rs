//! Choosing the rows of a flight table by flight line (`--line`) and by time (`--time`).
//!
//! ```
//! use tolles_io::select::RowSelection;
//! use tolles_io::table::Table;
//! let csv = "tt,line,mag\n0,1001,1\n1,1002.020,2\n2,1002.020,3\n3,1003,4\n";
//! let table = Table::csv().reader(csv.as_bytes(), "flight.csv").unwrap();
//! let selection = RowSelection {
//!     lines: vec!["1002.02".parse().unwrap()],
//!     time: Some("..1.5".parse().unwrap()),
//! };
//! let selected = selection.apply(&table).unwrap();
//! assert_eq!(selected.table.numeric("mag").unwrap(), [2.0]);
//! assert_eq!(selected.table.line_of(0), 3); // still the file's own line
//! assert_eq!(selected.to_string(), "selected 1 of 4 rows (line 1002.02; tt ..1.5 s)");
//! ```
//!
//! A line id matches a cell of the `line` column as a number (`1002.02` matches `1002.020`, and
//! the same number stored as a 32-bit float) or, when either is not a number, as the same text.
//! A time range is inclusive at both ends, in seconds of the `tt` column; rows without a time
//! are outside every range. Lines and a time range together select the rows that satisfy both.

use crate::error::IoError;
use crate::table::{format_value, Column, Table};
use std::collections::HashSet;
use std::fmt;
use std::path::PathBuf;
use std::str::FromStr;
use thiserror::Error;

pub use crate::schema::{LINE_COLUMN, TIME_COLUMN};
/// How many of a file's lines an error about an unknown line lists.
const LINES_SHOWN: usize = 10;

/// Why rows could not be selected. Each message is one line that names the file.
#[derive(Debug, Error)]
pub enum SelectError {
    /// A line id or time range that does not parse; the message is only why, as the caller
    /// names the value (a command line names its flag).
    #[error("{why}")]
    Parse {
        /// `line` or `time`.
        by: &'static str,
        /// The value as given.
        text: String,
        /// Why it does not parse.
        why: String,
    },
    /// Selecting by `line` or `time` needs a column the file lacks.
    #[error("{path}: selecting by {by} needs a column {column:?}{near}")]
    NoColumn {
        /// The file the error is about.
        path: PathBuf,
        /// `line` or `time`.
        by: &'static str,
        /// The column needed.
        column: &'static str,
        /// The names near it, or the header's first names.
        near: crate::error::Near,
    },
    /// A line id no row is on.
    #[error("{path}: line {line}: no row is on that line; the file's lines are {present}")]
    UnknownLine {
        /// The file the error is about.
        path: PathBuf,
        /// The line id asked for, as given.
        line: String,
        /// The file's distinct line ids in file order: the first 10, then how many more.
        present: String,
    },
    /// No row meets the selection.
    #[error("{path}: no row is {criteria}; {span}")]
    NothingSelected {
        /// The file the error is about.
        path: PathBuf,
        /// The selection, in words.
        criteria: String,
        /// What the rows considered span in time (s), or that they have no time.
        span: String,
    },
    /// The file could not be read.
    #[error(transparent)]
    Io(#[from] IoError),
}

/// One flight line id as given on the command line.
#[derive(Debug, Clone, PartialEq)]
pub struct LineId {
    text: String,
    number: Option<f64>,
}

impl LineId {
    /// True when a cell of the line column, as written (`text`) and as a number (`number`,
    /// NaN when missing or not a number), names this line.
    fn matches(&self, text: Option<&str>, number: f64) -> bool {
        text.is_some_and(|t| t.trim() == self.text)
            || self
                .number
                .is_some_and(|id| id == number || f64::from(id as f32) == number)
    }
}

impl fmt::Display for LineId {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.text)
    }
}

impl FromStr for LineId {
    type Err = SelectError;

    fn from_str(text: &str) -> Result<Self, Self::Err> {
        let text = text.trim();
        if text.is_empty() {
            return Err(SelectError::Parse {
                by: "line",
                text: text.into(),
                why: "an empty line id (two commas in a row, or one at an end?)".into(),
            });
        }
        let number = text.parse::<f64>().ok().filter(|x| x.is_finite());
        Ok(Self {
            text: text.into(),
            number,
        })
    }
}

/// An inclusive range of time (s), either end possibly open.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TimeRange {
    /// Earliest time kept (s), if any.
    pub start: Option<f64>,
    /// Latest time kept (s), if any.
    pub end: Option<f64>,
}

impl TimeRange {
    /// True when time `t` (s) is in the range; never for NaN.
    pub fn contains(&self, t: f64) -> bool {
        !t.is_nan() && self.start.is_none_or(|s| t >= s) && self.end.is_none_or(|e| t <= e)
    }
}

impl fmt::Display for TimeRange {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let end = |x: Option<f64>| x.map_or(String::new(), |x| x.to_string());
        write!(f, "{}..{}", end(self.start), end(self.end))
    }
}

impl FromStr for TimeRange {
    type Err = SelectError;

    /// `START..END`, `START..` or `..END`, in seconds.
    fn from_str(text: &str) -> Result<Self, Self::Err> {
        let fail = |why: &str| SelectError::Parse {
            by: "time",
            text: text.into(),
            why: why.into(),
        };
        let Some((start, end)) = text.split_once("..") else {
            return Err(fail(
                "expected START..END in seconds of tt (or START.. or ..END)",
            ));
        };
        let bound = |s: &str, name: &str| -> Result<Option<f64>, SelectError> {
            let s = s.trim();
            if s.is_empty() {
                return Ok(None);
            }
            match s.parse::<f64>() {
                Ok(x) if x.is_finite() => Ok(Some(x)),
                _ => Err(fail(&format!("{name} {s:?} is not a number of seconds"))),
            }
        };
        let range = Self {
            start: bound(start, "START")?,
            end: bound(end, "END")?,
        };
        match (range.start, range.end) {
            (None, None) => Err(fail("give START, END or both (START..END, START.., ..END)")),
            (Some(s), Some(e)) if s > e => Err(fail("START is after END")),
            _ => Ok(range),
        }
    }
}

/// Which rows to keep: those on any of `lines` (all rows when empty) and with `tt` in `time`.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct RowSelection {
    /// Flight lines kept; empty keeps every line.
    pub lines: Vec<LineId>,
    /// Time range kept (s), if any.
    pub time: Option<TimeRange>,
}

/// The rows a [`RowSelection`] kept, and what it was; its `Display` says so in one line.
#[derive(Debug, Clone)]
pub struct Selected {
    /// The kept rows, each naming its own line of the file in messages.
    pub table: Table,
    /// Rows of the table the selection was made from.
    pub rows_before: usize,
    /// Rows on the chosen lines left out because they have no time (with a time range).
    pub rows_without_time: usize,
    criteria: String,
}

impl fmt::Display for Selected {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "selected {} of {} rows ({})",
            self.table.len(),
            self.rows_before,
            self.criteria
        )?;
        match self.rows_without_time {
            0 => {}
            1 => write!(f, "; 1 row with no {TIME_COLUMN} is outside any time range")?,
            n => write!(
                f,
                "; {n} rows with no {TIME_COLUMN} are outside any time range"
            )?,
        }
        Ok(())
    }
}

impl RowSelection {
    /// True when nothing is selected by, so every row is kept.
    pub fn is_empty(&self) -> bool {
        self.lines.is_empty() && self.time.is_none()
    }

    /// The rows of `table` this selection keeps. Errors if a column it needs is missing or not
    /// numeric, a line id is on no row, or no row is kept.
    pub fn apply(&self, table: &Table) -> Result<Selected, SelectError> {
        let mut keep = self.rows_on_lines(table)?;
        let mut rows_without_time = 0;
        if let Some(range) = &self.time {
            let tt = column_for(table, TIME_COLUMN, "time")?;
            let tt = table.numeric_at(tt)?;
            for (keep, t) in keep.iter_mut().zip(&tt) {
                rows_without_time += usize::from(*keep && t.is_nan());
                *keep = *keep && range.contains(*t);
            }
            if !keep.contains(&true) {
                return Err(self.nothing_selected(table, &tt));
            }
        }
        Ok(Selected {
            table: table.select_rows(&keep),
            rows_before: table.len(),
            rows_without_time,
            criteria: self.criteria(),
        })
    }

    /// One flag per row: on one of the chosen lines (every row when no line is chosen).
    fn rows_on_lines(&self, table: &Table) -> Result<Vec<bool>, SelectError> {
        if self.lines.is_empty() {
            return Ok(vec![true; table.len()]);
        }
        let column = &table.columns()[column_for(table, LINE_COLUMN, "line")?];
        let mut found = vec![false; self.lines.len()];
        let keep = (0..table.len())
            .map(|k| {
                let (text, number) = cell(column, k);
                let mut on_line = false;
                for (id, found) in self.lines.iter().zip(&mut found) {
                    if id.matches(text, number) {
                        (*found, on_line) = (true, true);
                    }
                }
                on_line
            })
            .collect();
        if let Some(missing) = found.iter().position(|f| !f) {
            return Err(SelectError::UnknownLine {
                path: table.path().to_path_buf(),
                line: self.lines[missing].to_string(),
                present: lines_present(column),
            });
        }
        Ok(keep)
    }

    fn nothing_selected(&self, table: &Table, tt: &[f64]) -> SelectError {
        let on_lines = self.rows_on_lines(table).unwrap_or_default();
        let times = tt
            .iter()
            .zip(&on_lines)
            .filter(|(t, on)| **on && t.is_finite())
            .map(|(t, _)| *t);
        let span = times.fold(None, |span: Option<(f64, f64)>, t| {
            Some(span.map_or((t, t), |(lo, hi)| (lo.min(t), hi.max(t))))
        });
        let whose = if self.lines.is_empty() {
            "the file's rows".to_string()
        } else {
            format!("the rows on {}", self.lines_text())
        };
        let span = match span {
            Some((lo, hi)) => format!("{whose} span tt {lo}..{hi} s"),
            None => format!("{whose} have no time in column {TIME_COLUMN:?}"),
        };
        SelectError::NothingSelected {
            path: table.path().to_path_buf(),
            criteria: self.where_text(),
            span,
        }
    }

    /// "on line 2 within tt 100..200 s", "within tt 100..200 s".
    fn where_text(&self) -> String {
        let time = self
            .time
            .map(|range| format!("within {TIME_COLUMN} {range} s"));
        match (self.lines.is_empty(), time) {
            (true, time) => time.unwrap_or_default(),
            (false, None) => format!("on {}", self.lines_text()),
            (false, Some(time)) => format!("on {} {time}", self.lines_text()),
        }
    }

    /// "lines 1002.02, 1003.01; tt 100..200 s".
    fn criteria(&self) -> String {
        let mut parts = Vec::new();
        if !self.lines.is_empty() {
            parts.push(self.lines_text());
        }
        if let Some(range) = &self.time {
            parts.push(format!("{TIME_COLUMN} {range} s"));
        }
        if parts.is_empty() {
            parts.push("every row".into());
        }
        parts.join("; ")
    }

    /// "line 1002.02" or "lines 1002.02, 1003.01", each id once.
    fn lines_text(&self) -> String {
        let mut ids: Vec<&str> = Vec::new();
        for id in &self.lines {
            if !ids.contains(&id.text.as_str()) {
                ids.push(&id.text);
            }
        }
        let noun = if ids.len() == 1 { "line" } else { "lines" };
        format!("{noun} {}", ids.join(", "))
    }
}

/// The index of column `name`, or an error saying that selecting `by` needs it.
fn column_for(table: &Table, name: &'static str, by: &'static str) -> Result<usize, SelectError> {
    table.index_of(name).map_err(|_| SelectError::NoColumn {
        path: table.path().to_path_buf(),
        by,
        column: name,
        near: crate::header::suggest(table.headers(), name),
    })
}

/// Cell `k` as written (text columns) and as a number (NaN when missing or not a number).
fn cell(column: &Column, k: usize) -> (Option<&str>, f64) {
    match column {
        Column::Text(text) => (Some(text.get(k)), text.value(k).unwrap_or(f64::NAN)),
        Column::Numbers(values) => (None, values[k]),
    }
}

/// The distinct ids in a line column, in file order: the first [`LINES_SHOWN`], then how many
/// more there are.
fn lines_present(column: &Column) -> String {
    let mut seen = HashSet::new();
    let mut shown = Vec::new();
    for k in 0..column.len() {
        let id = match cell(column, k) {
            (Some(text), _) => text.trim().to_string(),
            (None, number) => {
                let mut text = String::new();
                format_value(number, &mut text);
                text
            }
        };
        if !id.is_empty() && seen.insert(id.clone()) && shown.len() < LINES_SHOWN {
            shown.push(id);
        }
    }
    match seen.len() {
        0 => "all empty".into(),
        n if n > shown.len() => format!("{} and {} more", shown.join(", "), n - shown.len()),
        _ => shown.join(", "),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn table(text: &str) -> Table {
        Table::csv().reader(text.as_bytes(), "f.csv").unwrap()
    }

    fn selection(lines: &[&str], time: Option<&str>) -> RowSelection {
        RowSelection {
            lines: lines.iter().map(|l| l.parse().unwrap()).collect(),
            time: time.map(|t| t.parse().unwrap()),
        }
    }

    const FLIGHT: &str = "tt,line,mag\n\
        0,1001,1\n1,1001,2\n2,1002.020,3\n3,1002.020,4\n4,1003,5\n5,1003,6\n";

    #[test]
    fn time_ranges_parse_with_open_ends() {
        let r: TimeRange = "100..200".parse().unwrap();
        assert_eq!((r.start, r.end), (Some(100.0), Some(200.0)));
        let r: TimeRange = " ..-5.5".parse().unwrap();
        assert_eq!((r.start, r.end), (None, Some(-5.5)));
        let r: TimeRange = "1e3..".parse().unwrap();
        assert_eq!((r.start, r.end), (Some(1000.0), None));
        assert!(r.contains(1000.0) && !r.contains(999.9) && !r.contains(f64::NAN));
        assert_eq!(r.to_string(), "1000..");
        let r: TimeRange = "7..7".parse().unwrap();
        assert!(r.contains(7.0) && !r.contains(7.000_001));
    }

    #[test]
    fn bad_time_ranges_say_why() {
        let why = |t: &str| t.parse::<TimeRange>().unwrap_err().to_string();
        assert_eq!(why("200..100"), "START is after END");
        assert!(why("100").contains("expected START..END"), "{}", why("100"));
        assert!(why("abc..5").contains("START \"abc\" is not a number"));
        assert!(why("5..nan").contains("END \"nan\" is not a number"));
        assert!(why("..").contains("give START, END or both"));
    }

    #[test]
    fn line_ids_parse_and_an_empty_one_is_an_error() {
        let id: LineId = " 1002.02 ".parse().unwrap();
        assert_eq!((id.text.as_str(), id.number), ("1002.02", Some(1002.02)));
        let id: LineId = "L7".parse().unwrap();
        assert_eq!(id.number, None);
        assert!(""
            .parse::<LineId>()
            .unwrap_err()
            .to_string()
            .contains("empty line id"));
    }

    #[test]
    fn lines_match_numerically_and_keep_file_lines() {
        let s = selection(&["1002.02", "1003"], None)
            .apply(&table(FLIGHT))
            .unwrap();
        assert_eq!(s.table.numeric("mag").unwrap(), [3.0, 4.0, 5.0, 6.0]);
        assert_eq!(s.table.line_of(0), 4);
        assert_eq!(s.to_string(), "selected 4 of 6 rows (lines 1002.02, 1003)");
    }

    #[test]
    fn a_line_stored_as_a_32_bit_float_matches() {
        let line = Column::Numbers(vec![f64::from(1002.02_f32), 1003.0]);
        let t = Table::from_columns("f.h5", vec!["line".into()], vec![line], None).unwrap();
        let s = selection(&["1002.02"], None).apply(&t).unwrap();
        assert_eq!((s.table.len(), s.table.place_of(0)), (1, "row 1".into()));
        let s = selection(&["1003"], None).apply(&t).unwrap();
        assert_eq!(s.table.place_of(0), "row 2");
        let near = selection(&["1002.0201"], None)
            .apply(&t)
            .unwrap_err()
            .to_string();
        assert!(near.contains("line 1002.0201: no row"), "{near}");
    }

    #[test]
    fn text_line_ids_match_as_text() {
        let t = table("tt,line\n0,L1\n1,L2\n2,L2\n");
        let s = selection(&["L2"], None).apply(&t).unwrap();
        assert_eq!(s.table.numeric("tt").unwrap(), [1.0, 2.0]);
    }

    #[test]
    fn lines_and_time_together_intersect() {
        let s = selection(&["1001", "1003"], Some("1..4"))
            .apply(&table(FLIGHT))
            .unwrap();
        assert_eq!(s.table.numeric("tt").unwrap(), [1.0, 4.0]);
        assert_eq!(
            s.to_string(),
            "selected 2 of 6 rows (lines 1001, 1003; tt 1..4 s)"
        );
        let s = selection(&[], Some("..2")).apply(&table(FLIGHT)).unwrap();
        assert_eq!(s.table.numeric("tt").unwrap(), [0.0, 1.0, 2.0]);
    }

    #[test]
    fn an_unknown_line_is_named_with_the_lines_there_are() {
        let e = selection(&["1003", "1005"], None)
            .apply(&table(FLIGHT))
            .unwrap_err();
        assert_eq!(
            e.to_string(),
            "f.csv: line 1005: no row is on that line; the file's lines are 1001, 1002.020, 1003"
        );
        let mut many = String::from("line\n");
        for k in 0..25 {
            many += &format!("{k}\n{k}\n");
        }
        let e = selection(&["99"], None)
            .apply(&table(&many))
            .unwrap_err()
            .to_string();
        assert!(
            e.ends_with("are 0, 1, 2, 3, 4, 5, 6, 7, 8, 9 and 15 more"),
            "{e}"
        );
    }

    #[test]
    fn missing_columns_name_the_selection() {
        let t = table("tt,mag\n0,1\n");
        let e = selection(&["1"], None).apply(&t).unwrap_err().to_string();
        assert!(
            e.starts_with("f.csv: selecting by line needs a column \"line\""),
            "{e}"
        );
        let t = table("time,line\n0,1\n");
        let e = selection(&[], Some("0..1"))
            .apply(&t)
            .unwrap_err()
            .to_string();
        assert!(
            e.starts_with("f.csv: selecting by time needs a column \"tt\""),
            "{e}"
        );
    }

    #[test]
    fn an_empty_selection_says_where_the_rows_are() {
        let e = selection(&["1002.02"], Some("4.."))
            .apply(&table(FLIGHT))
            .unwrap_err();
        assert_eq!(
            e.to_string(),
            "f.csv: no row is on line 1002.02 within tt 4.. s; the rows on line 1002.02 span tt 2..3 s"
        );
        let e = selection(&[], Some("10..20"))
            .apply(&table(FLIGHT))
            .unwrap_err();
        assert_eq!(
            e.to_string(),
            "f.csv: no row is within tt 10..20 s; the file's rows span tt 0..5 s"
        );
    }

    #[test]
    fn rows_without_time_are_counted() {
        let t = table("tt,line\n0,1\n,1\n2,1\n");
        let s = selection(&["1"], Some("0..10")).apply(&t).unwrap();
        assert_eq!(s.table.len(), 2);
        assert!(s
            .to_string()
            .ends_with("; 1 row with no tt is outside any time range"));
    }

    #[test]
    fn a_non_numeric_time_in_the_file_names_its_line() {
        let t = table("tt,line\n0,1\nx,1\n");
        let e = selection(&[], Some("0..1"))
            .apply(&t)
            .unwrap_err()
            .to_string();
        assert_eq!(e, "f.csv: line 3, column \"tt\": \"x\" is not a number");
    }
}
