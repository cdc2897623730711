//! Geosoft XYZ text: `/` comment lines (one of which names the columns), `Line`/`Tie` block
//! headers, whitespace-separated columns, `*` for a missing value.
//!
//! ```
//! use tolles_io::xyz;
//! let text = "/ exported by Oasis montaj\n/ tt mag_1_uc\nLine 1002.02\n0.0 50000.5\n0.1 *\nTie 3001\n0.2 50001.0\n";
//! let table = xyz::from_reader(text.as_bytes(), "flight.xyz").unwrap();
//! assert_eq!(table.headers(), ["tt", "mag_1_uc", "line"]);
//! assert!(table.numeric("mag_1_uc").unwrap()[1].is_nan());
//! assert_eq!(table.numeric("line").unwrap(), [1002.02, 1002.02, 3001.0]);
//! ```
//!
//! The header is the last `/` line before the first data row whose number of names equals the
//! number of fields in that row. When the file has no `line` column, one is added holding the
//! number of the `Line`/`Tie` block each row is in (empty before the first block).

use crate::error::IoError;
use crate::table::{Column, Missing, Table, TextColumn};
use std::io::{BufRead, BufReader, Read};
use std::path::Path;

/// Geosoft's dummy: a cell written `*` is a missing value.
pub const DUMMY: &str = "*";

// The column that receives each row's `Line`/`Tie` number.
use crate::schema::LINE_COLUMN;

/// Reads a Geosoft XYZ file.
pub fn read(path: &Path) -> Result<Table, IoError> {
    let file = std::fs::File::open(path).map_err(|source| IoError::Open {
        path: path.to_path_buf(),
        source,
    })?;
    from_reader(file, path)
}

/// Reads Geosoft XYZ text from any reader; `name` is used in error messages.
pub fn from_reader(reader: impl Read, name: impl AsRef<Path>) -> Result<Table, IoError> {
    let path = name.as_ref();
    let mut state = Parser::default();
    for (k, line) in BufReader::new(reader).lines().enumerate() {
        let line = line.map_err(|source| line_error(path, k as u64 + 1, source))?;
        state
            .line(k as u64 + 1, &line)
            .map_err(|message| IoError::Malformed {
                path: path.to_path_buf(),
                line: k as u64 + 1,
                message,
            })?;
    }
    state.finish(path)
}

/// The error for a line that could not be read: text that is not UTF-8 names its line.
fn line_error(path: &Path, line: u64, source: std::io::Error) -> IoError {
    if source.kind() == std::io::ErrorKind::InvalidData {
        IoError::Malformed {
            path: path.to_path_buf(),
            line,
            message: "not UTF-8 text".to_string(),
        }
    } else {
        IoError::Open {
            path: path.to_path_buf(),
            source,
        }
    }
}

/// The `/` lines that may name the columns: for each number of names, only the last such
/// line, and at most [`CANDIDATE_BYTES`] of them, so a file of comments needs little memory.
#[derive(Default)]
struct Candidates {
    /// (number of names, the line), oldest first.
    lines: Vec<(usize, String)>,
    bytes: usize,
}

/// The most text of candidate header lines kept; the oldest go first.
const CANDIDATE_BYTES: usize = 8 << 20;

impl Candidates {
    fn push(&mut self, comment: &str) {
        if comment.len() > crate::header::MAX_HEADER_BYTES {
            return; // no header is that long; it is only a comment
        }
        let count = comment.split_whitespace().count();
        if let Some(k) = self.lines.iter().position(|(n, _)| *n == count) {
            self.bytes -= self.lines.remove(k).1.len();
        }
        self.bytes += comment.len();
        self.lines.push((count, comment.to_string()));
        while self.bytes > CANDIDATE_BYTES {
            self.bytes -= self.lines.remove(0).1.len();
        }
    }

    /// The names of the last line with `count` names.
    fn names(&self, count: usize) -> Option<Vec<String>> {
        let (_, line) = self.lines.iter().find(|(n, _)| *n == count)?;
        Some(line.split_whitespace().map(str::to_string).collect())
    }
}

#[derive(Default)]
struct Parser {
    comments: Candidates,
    headers: Option<Vec<String>>,
    columns: Vec<TextColumn>,
    block: Option<TextColumn>,
    current_block: String,
    lines: Vec<u64>,
}

impl Parser {
    fn line(&mut self, number: u64, line: &str) -> Result<(), String> {
        let trimmed = line.trim();
        if trimmed.is_empty() {
            return Ok(());
        }
        if let Some(comment) = trimmed.strip_prefix('/') {
            if self.headers.is_none() {
                self.comments.push(comment.trim_start_matches('/'));
            }
            return Ok(());
        }
        if let Some(number) = block_number(trimmed) {
            self.current_block = number.to_string();
            return Ok(());
        }
        let cells: Vec<&str> = trimmed.split_whitespace().collect();
        if self.headers.is_none() {
            self.start(cells.len())?;
        }
        if cells.len() != self.columns.len() {
            return Err(format!(
                "{} fields, but the header has {}",
                cells.len(),
                self.columns.len()
            ));
        }
        for (column, cell) in self.columns.iter_mut().zip(cells) {
            column.push(cell);
        }
        if let Some(block) = &mut self.block {
            block.push(&self.current_block);
        }
        self.lines.push(number);
        Ok(())
    }

    /// Picks the header for a first data row of `fields` fields.
    fn start(&mut self, fields: usize) -> Result<(), String> {
        let headers = self.comments.names(fields).ok_or_else(|| {
            format!("{fields} fields, but no `/` header line before it names {fields} columns")
        })?;
        self.columns = vec![TextColumn::new(dummy()); fields];
        if !headers.iter().any(|h| h.eq_ignore_ascii_case(LINE_COLUMN)) {
            self.block = Some(TextColumn::new(dummy()));
        }
        self.headers = Some(headers);
        Ok(())
    }

    fn finish(mut self, path: &Path) -> Result<Table, IoError> {
        self.take_rows(path)
    }

    /// The rows read so far as a table; the parser goes on with the rows after them.
    fn take_rows(&mut self, path: &Path) -> Result<Table, IoError> {
        let Some(mut headers) = self.headers.clone() else {
            return Err(IoError::Empty {
                path: path.to_path_buf(),
            });
        };
        let fresh = || TextColumn::new(dummy());
        let mut columns: Vec<Column> = self
            .columns
            .iter_mut()
            .map(|c| Column::Text(std::mem::replace(c, fresh())))
            .collect();
        if let Some(block) = &mut self.block {
            headers.push(LINE_COLUMN.to_string());
            columns.push(Column::Text(std::mem::replace(block, fresh())));
        }
        Table::from_columns(
            path,
            headers,
            columns,
            Some(std::mem::take(&mut self.lines)),
        )
    }
}

fn dummy() -> Missing {
    Missing {
        token: Some(DUMMY.to_string()),
        null: None,
    }
}

/// Geosoft XYZ text read a chunk of rows at a time (see [`crate::chunks`]).
pub(crate) struct XyzChunks<R> {
    lines: std::io::Lines<BufReader<R>>,
    number: u64,
    parser: Parser,
    path: std::path::PathBuf,
    rows_taken: usize,
}

impl<R: Read> XyzChunks<R> {
    pub(crate) fn new(reader: R, path: &Path) -> Self {
        Self {
            lines: BufReader::new(reader).lines(),
            number: 0,
            parser: Parser::default(),
            path: path.to_path_buf(),
            rows_taken: 0,
        }
    }

    /// The next at most `rows` data rows, or `None` after the last; reading a file without
    /// data rows gives the error reading it whole gives.
    pub(crate) fn next_rows(&mut self, rows: usize) -> Result<Option<Table>, IoError> {
        while self.parser.lines.len() < rows {
            let Some(line) = self.lines.next() else { break };
            self.number += 1;
            let line = line.map_err(|source| line_error(&self.path, self.number, source))?;
            self.parser
                .line(self.number, &line)
                .map_err(|message| IoError::Malformed {
                    path: self.path.clone(),
                    line: self.number,
                    message,
                })?;
        }
        if self.parser.lines.is_empty() && self.rows_taken > 0 {
            return Ok(None);
        }
        let table = self.parser.take_rows(&self.path)?;
        self.rows_taken += table.len();
        Ok(Some(table))
    }
}

/// The number of a `Line 1002.02` / `Tie 3001` / `LINE L1002` block header, or `None` when
/// `line` is not one.
fn block_number(line: &str) -> Option<&str> {
    let mut words = line.split_whitespace();
    let keyword = words.next()?;
    if !(keyword.eq_ignore_ascii_case("line") || keyword.eq_ignore_ascii_case("tie")) {
        return None;
    }
    let id = words.next()?;
    if words.next().is_some() {
        return None;
    }
    let number = id.trim_start_matches(|c: char| c.is_ascii_alphabetic());
    number.parse::<f64>().is_ok().then_some(number)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn read(text: &str) -> Result<Table, IoError> {
        from_reader(text.as_bytes(), "t.xyz")
    }

    #[test]
    fn comment_lines_keep_bounded_memory() {
        let mut parser = Parser::default();
        for k in 0..100_000u64 {
            parser.line(k + 1, "/ a comment of six words").unwrap();
            parser
                .line(k + 1, &format!("/{}", " x".repeat(k as usize % 3000)))
                .unwrap();
        }
        let kept = &parser.comments;
        assert!(kept.bytes <= CANDIDATE_BYTES && kept.lines.len() <= 3000);
        parser.line(100_001, "1 2 3 4 5").unwrap();
        assert_eq!(
            parser.headers.unwrap(),
            ["a", "comment", "of", "six", "words"]
        );
    }

    #[test]
    fn header_is_the_comment_line_that_fits_the_data() {
        let t = read("/ XYZ export 2024-05-01\n/ a b c\n\nLine L7\n1 2 3\n").unwrap();
        assert_eq!(t.headers(), ["a", "b", "c", "line"]);
        assert_eq!(t.numeric("line").unwrap(), [7.0]);
        assert_eq!(t.line_of(0), 5);
    }

    #[test]
    fn an_existing_line_column_is_kept() {
        let t = read("/ line x\nLine 5\n9 1\n").unwrap();
        assert_eq!(t.headers(), ["line", "x"]);
        assert_eq!(t.numeric("line").unwrap(), [9.0]);
    }

    #[test]
    fn rows_before_any_block_have_no_line() {
        let t = read("/ x\n1\nTie 30\n2\n").unwrap();
        let line = t.numeric("line").unwrap();
        assert!(line[0].is_nan());
        assert_eq!(line[1], 30.0);
    }

    #[test]
    fn ragged_row_names_its_line() {
        let err = read("/ a b\nLine 1\n1 2\n3\n").unwrap_err().to_string();
        assert_eq!(err, "t.xyz: line 4: 1 fields, but the header has 2");
    }

    #[test]
    fn data_without_a_header_is_an_error() {
        let err = read("/ a b\n1 2 3\n").unwrap_err().to_string();
        assert!(
            err.starts_with("t.xyz: line 2: 3 fields, but no `/` header"),
            "{err}"
        );
        assert!(matches!(
            read("/ only a comment\n"),
            Err(IoError::Empty { .. })
        ));
    }

    #[test]
    fn bad_cell_names_line_and_column() {
        let t = read("/ a\nLine 1\n1\nx\n").unwrap();
        let err = t.numeric("a").unwrap_err().to_string();
        assert_eq!(err, "t.xyz: line 4, column \"a\": \"x\" is not a number");
    }
}
