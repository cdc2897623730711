//! `--line` and `--time`: which rows of a flight a command works on; `--rename`: what its
//! columns are called.
//!
//! The same flags and help for every command that reads a flight (a flattened [`Selection`]);
//! the rows are chosen by the library. What was selected is said on stderr, with what becomes
//! of the rest.

use crate::progress::Terminal;
use crate::render::{self, OrRender, Use};
use anyhow::Result;
use std::path::Path;
use tolles_io::select::{LineId, RowSelection, TimeRange};
use tolles_io::table::Table;

/// The selection flags.
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
    /// Rename columns right after reading, e.g. --rename MAGUC=mag_1_uc,HDG=ins_yaw (the flag
    /// may repeat); every other flag then uses the new names. An unknown OLD is an error.
    /// Not needed for SGL's raw channel names (TIME, ROLL, PITCH, AZIMUTH, UNCOMPMAGn,
    /// FLUXA_X, …): they answer to tolles' names when the file has no columns of those
    #[arg(long = "rename", value_name = "OLD=NEW", value_delimiter = ',', value_parser = parse_rename)]
    pub renames: Vec<(String, String)>,
}

/// `OLD=NEW` → the two names.
pub fn parse_rename(text: &str) -> Result<(String, String), String> {
    match text.split_once('=') {
        Some((old, new)) if !old.trim().is_empty() && !new.trim().is_empty() => {
            Ok((old.trim().to_string(), new.trim().to_string()))
        }
        _ => Err(format!("expected OLD=NEW, got {text:?}")),
    }
}

impl Selection {
    /// The library's row selection.
    pub fn rows(&self) -> RowSelection {
        RowSelection {
            lines: self.lines.clone(),
            time: self.time,
        }
    }

    /// Reads `path` and keeps the selected rows (all without flags), saying on stderr what the
    /// reader left out and which rows were selected.
    pub fn read(&self, path: &Path, purpose: Use) -> Result<Table> {
        self.read_parsing(path, purpose, &[])
    }

    /// [`Selection::read`], parsing the columns `needed` as the file is read (see
    /// `tolles::read::read_parsing`).
    pub fn read_parsing(&self, path: &Path, purpose: Use, needed: &[String]) -> Result<Table> {
        let mut warnings = Vec::new();
        let read = tolles::read::read_parsing(
            path,
            &self.rows(),
            &self.renames,
            needed,
            &Terminal::default(),
            &mut warnings,
        );
        render::warnings(&mut warnings, purpose);
        Ok(read.or_render()?.table)
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
    fn renames_are_old_new_pairs() {
        let s = parse(&["--rename", "A=a, B = b", "--rename", "C=c"]).unwrap();
        let pairs: Vec<(&str, &str)> = s
            .renames
            .iter()
            .map(|(o, n)| (o.as_str(), n.as_str()))
            .collect();
        assert_eq!(pairs, [("A", "a"), ("B", "b"), ("C", "c")]);
        let e = parse(&["--rename", "A"]).unwrap_err().to_string();
        assert!(e.contains("expected OLD=NEW"), "{e}");
    }

    #[test]
    fn flags_become_the_library_selection() {
        let s = parse(&["--line", "2", "--time", "..1.5"]).unwrap();
        let rows = s.rows();
        assert_eq!(rows.lines.len(), 1);
        assert_eq!(rows.time, Some("..1.5".parse().unwrap()));
        assert!(Selection::default().rows().is_empty());
    }
}
