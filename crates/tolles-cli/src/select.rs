//! `--line` and `--time`: which rows of a flight `fit`, `compensate` and `fom` work on.
//!
//! The same flags and help for all three commands (a flattened [`Selection`]); the row logic
//! is [`tolles_io::select`]. What was selected is said on stderr, with what becomes of the rest.

use crate::input::read_table;
use anyhow::Result;
use std::path::Path;
use tolles_io::select::{LineId, RowSelection, TimeRange};
use tolles_io::table::Table;

/// The selection flags, shared by `fit`, `compensate` and `fom`.
#[derive(clap::Args, Clone, Debug, Default)]
#[command(next_help_heading = "Selecting rows")]
pub struct Selection {
    /// Only rows on these flight lines (column `line`), e.g. 1002.02,1003.01; the flag may
    /// repeat. Ids match as numbers (1002.02 matches 1002.020) or else as text. fit and fom use
    /// only the selected rows; compensate writes only them (the rest are left out, as stderr
    /// says) and takes the correction's mean over them
    #[arg(long = "line", value_name = "LIST", value_delimiter = ',')]
    pub lines: Vec<LineId>,
    /// Only rows with time tt (s) in START..END, both ends included; START.. or ..END leaves an
    /// end open. With --line, only rows on those lines and in that time. Lines far apart in
    /// time are never filtered or differentiated across: runs are cut at time gaps
    #[arg(long, value_name = "START..END", allow_hyphen_values = true)]
    pub time: Option<TimeRange>,
}

/// What a command does with the selected rows, for the message that says what was selected.
#[derive(Clone, Copy)]
pub enum Use {
    Fit,
    Compensate,
    Fom,
}

impl Selection {
    /// True when no --line or --time was given: every row is used.
    pub fn is_everything(&self) -> bool {
        self.lines.is_empty() && self.time.is_none()
    }

    /// Reads `path` (see [`read_table`]) and keeps the selected rows (all without flags).
    pub fn read(&self, path: &Path, purpose: Use) -> Result<Table> {
        self.apply(read_table(path)?, purpose)
    }

    /// The selected rows of `table` (all of it without flags), saying on stderr which were
    /// selected and what becomes of the others.
    pub fn apply(&self, table: Table, purpose: Use) -> Result<Table> {
        let selection = RowSelection {
            lines: self.lines.clone(),
            time: self.time,
        };
        if selection.is_empty() {
            return Ok(table);
        }
        let selected = selection.apply(&table)?;
        let left_out = table.len() - selected.table.len();
        let consequence = match purpose {
            Use::Fit => "the fit uses only these".to_string(),
            Use::Fom => "the FOM uses only these".to_string(),
            Use::Compensate => format!(
                "only these are compensated and written (the other {left_out} rows are left out), and the correction's mean is taken over them"
            ),
        };
        eprintln!("{}: {selected}; {consequence}", table.path().display());
        Ok(selected.table)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::Parser;

    #[derive(Parser)]
    struct Wrapper {
        #[command(flatten)]
        select: Selection,
    }

    fn parse(args: &[&str]) -> Result<Selection, clap::Error> {
        Wrapper::try_parse_from([&["tolles"], args].concat()).map(|w| w.select)
    }

    fn ids(s: &Selection) -> Vec<String> {
        s.lines.iter().map(ToString::to_string).collect()
    }

    #[test]
    fn lines_are_comma_separated_and_the_flag_repeats() {
        let s = parse(&["--line", "1002.02,1003.01", "--line", "L7"]).unwrap();
        assert_eq!(ids(&s), ["1002.02", "1003.01", "L7"]);
        assert!(s.time.is_none());
    }

    #[test]
    fn time_ranges_with_open_and_negative_ends_parse() {
        let s = parse(&["--time", "-5..10"]).unwrap();
        assert_eq!(s.time.unwrap(), "-5..10".parse().unwrap());
        let s = parse(&["--time=..10"]).unwrap();
        assert_eq!(
            (s.time.unwrap().start, s.time.unwrap().end),
            (None, Some(10.0))
        );
        let s = parse(&["--time", "100.."]).unwrap();
        assert_eq!(s.time.unwrap().end, None);
        assert!(parse(&[]).unwrap().lines.is_empty());
    }

    #[test]
    fn bad_values_are_argument_errors_that_say_why() {
        let e = parse(&["--time", "200..100"]).unwrap_err().to_string();
        assert!(
            e.contains("--time") && e.contains("START is after END"),
            "{e}"
        );
        let e = parse(&["--time", "soon"]).unwrap_err().to_string();
        assert!(e.contains("expected START..END"), "{e}");
        let e = parse(&["--line", "1002,,1003"]).unwrap_err().to_string();
        assert!(e.contains("empty line id"), "{e}");
    }

    #[test]
    fn without_flags_the_table_is_kept_whole() {
        let table = Table::from_reader("tt\n0\n1\n".as_bytes(), "f.csv").unwrap();
        let kept = Selection::default().apply(table, Use::Fit).unwrap();
        assert_eq!(kept.len(), 2);
    }

    #[test]
    fn flags_keep_the_selected_rows() {
        let table = Table::from_reader("tt,line\n0,1\n1,2\n2,2\n".as_bytes(), "f.csv").unwrap();
        let s = parse(&["--line", "2", "--time", "..1.5"]).unwrap();
        let kept = s.apply(table, Use::Compensate).unwrap();
        assert_eq!(kept.numeric("tt").unwrap(), [1.0]);
        assert_eq!(kept.line_of(0), 3);
    }
}
