//! Reading CSV text with a header row into a [`Table`]: one builder, [`CsvReader`], for a file,
//! bytes in memory or any reader.
//!
//! ```
//! use tolles_io::table::Table;
//! let table = Table::csv().reader("tt,mag_1_uc\n0,50000\n0.1,50001\n".as_bytes(), "f.csv").unwrap();
//! assert_eq!(table.numeric("mag_1_uc").unwrap(), [50_000.0, 50_001.0]);
//! ```
//!
//! A file or bytes in memory are left in their bytes and parsed on demand ([`crate::rawcsv`])
//! where that reader takes them, else read cell by cell with the `csv` crate; the table, its
//! messages and what it writes are the same either way. A reader (a stream) is read cell by
//! cell.

use crate::error::IoError;
// Defined with the other header checks, which the raw reader shares; still public here.
pub use crate::header::MAX_HEADER_BYTES;
use crate::rawcsv::{Bytes, RawCsv, Wanted};
use crate::table::{Column, Table, TextColumn};
use std::io::Read;
use std::path::Path;
use std::sync::Arc;

/// How CSV text is read into a [`Table`] ([`Table::csv`]); set what to parse while the rows
/// are found and whether the text may be kept in its bytes, then read a path, bytes or a reader.
#[derive(Clone, Copy)]
pub struct CsvReader<'w> {
    wanted: Option<Wanted<'w>>,
    in_place: bool,
}

impl Default for CsvReader<'static> {
    fn default() -> Self {
        Self::new()
    }
}

impl CsvReader<'static> {
    /// Text left in its bytes where it can be, nothing parsed before it is asked for.
    pub fn new() -> Self {
        Self {
            wanted: None,
            in_place: true,
        }
    }
}

impl<'w> CsvReader<'w> {
    /// Also parses the columns `wanted` picks (given the header's names, their indices) while
    /// the rows are found: later asked for as numbers, they are there.
    pub fn parsing<'v>(self, wanted: Wanted<'v>) -> CsvReader<'v> {
        CsvReader {
            wanted: Some(wanted),
            in_place: self.in_place,
        }
    }

    /// Reads cell by cell with the `csv` crate, never keeping the text in its bytes.
    pub fn cell_by_cell(self) -> Self {
        Self {
            in_place: false,
            ..self
        }
    }

    /// The CSV file `path`.
    pub fn path(&self, path: &Path) -> Result<Table, IoError> {
        match self.path_in_place(path)? {
            Some(table) => Ok(table),
            None => {
                let file = std::fs::File::open(path).map_err(|source| IoError::Open {
                    path: path.to_path_buf(),
                    source,
                })?;
                general(std::io::BufReader::new(file), path)
            }
        }
    }

    /// The CSV file `path` left in its bytes ([`crate::rawcsv`]); `None` when that reader hands
    /// it to the general one (or [`CsvReader::cell_by_cell`] was asked for), so a caller can
    /// read it cell by cell its own way (showing progress, say).
    pub fn path_in_place(&self, path: &Path) -> Result<Option<Table>, IoError> {
        if !self.in_place {
            return Ok(None);
        }
        match crate::rawcsv::read(path, self.wanted())? {
            Some(csv) => from_raw(path, csv).map(Some),
            None => Ok(None),
        }
    }

    /// CSV text held in memory (standard input, say), named `name` in messages.
    pub fn bytes(&self, bytes: Vec<u8>, name: impl AsRef<Path>) -> Result<Table, IoError> {
        let path = name.as_ref();
        if !self.in_place {
            return general(&bytes[..], path);
        }
        let bytes = Arc::new(Bytes::Owned(bytes));
        match crate::rawcsv::from_bytes(Arc::clone(&bytes), path, self.wanted()) {
            Some(csv) => from_raw(path, csv),
            None => general(&bytes[..], path),
        }
    }

    /// CSV text from any reader, cell by cell; `name` is used in error messages.
    pub fn reader(&self, reader: impl Read, name: impl AsRef<Path>) -> Result<Table, IoError> {
        general(reader, name.as_ref())
    }

    fn wanted(&self) -> Wanted<'w> {
        self.wanted.unwrap_or(&|_| Vec::new())
    }
}

/// The table of a CSV file [`crate::rawcsv`] took.
fn from_raw(path: &Path, csv: RawCsv) -> Result<Table, IoError> {
    let rows = Arc::new(csv.rows);
    let columns = (0..csv.headers.len())
        .map(|field| Column::Text(TextColumn::raw(Arc::clone(&rows), field)))
        .collect();
    let table = Table::from_columns(path, csv.headers, columns, csv.lines.clone())?;
    // Without line numbers, the header is line 1 and no line is blank.
    Ok(match csv.lines {
        None => table.with_lines_from(2),
        Some(_) => table,
    })
}

/// CSV text read cell by cell with the `csv` crate.
fn general(reader: impl Read, path: &Path) -> Result<Table, IoError> {
    let reader = bounded_header(reader, path)?;
    // Cells are trimmed as they are stored: the reader's own field trimming copies every
    // record twice, which was a third of the time to read a large file.
    let mut csv = csv::ReaderBuilder::new()
        .has_headers(true)
        .trim(csv::Trim::Headers)
        .from_reader(reader);
    let headers: Vec<String> = csv
        .headers()
        .map_err(|e| csv_error(path, e))?
        .iter()
        .map(str::to_string)
        .collect();
    let mut columns = vec![TextColumn::default(); headers.len()];
    let mut lines = Vec::new();
    let mut record = csv::StringRecord::new();
    while let Some(line) = read_located(&mut csv, &mut record, path)? {
        lines.push(line);
        for (column, cell) in columns.iter_mut().zip(record.iter()) {
            column.push(cell.trim());
        }
    }
    let columns = columns.into_iter().map(Column::Text).collect();
    Table::from_columns(path, headers, columns, Some(lines))
}

/// A reader whose header line was checked by [`bounded_header`], which also notes how it ended:
/// the csv crate does not say whether the last row had a newline of its own, and without one
/// that row's line is counted differently (see [`read_located`]).
pub(crate) struct Bounded<R> {
    inner: std::io::Chain<std::io::Cursor<Vec<u8>>, std::io::BufReader<R>>,
    /// Bytes read so far.
    read: u64,
    /// The last byte read.
    last: Option<u8>,
    /// Whether the end of the input was reached.
    ended: bool,
}

impl<R: Read> Read for Bounded<R> {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        let n = self.inner.read(buf)?;
        match n {
            0 => self.ended |= !buf.is_empty(),
            _ => {
                self.read += n as u64;
                self.last = Some(buf[n - 1]);
            }
        }
        Ok(n)
    }
}

impl<R> Bounded<R> {
    /// Whether a row that ends at byte `at` is the input's last and has no newline of its own.
    fn unterminated_at(&self, at: u64) -> bool {
        self.ended && at == self.read && self.last != Some(b'\n')
    }
}

/// `reader` with its first line checked to be at most [`MAX_HEADER_BYTES`] long, so a huge
/// header is refused before the header's names are held in memory.
pub(crate) fn bounded_header<R: Read>(reader: R, path: &Path) -> Result<Bounded<R>, IoError> {
    use std::io::BufRead;
    let mut reader = std::io::BufReader::new(reader);
    let mut first = Vec::new();
    (&mut reader)
        .take(MAX_HEADER_BYTES as u64 + 1)
        .read_until(b'\n', &mut first)
        .map_err(|source| IoError::Open {
            path: path.to_path_buf(),
            source,
        })?;
    if first.len() > MAX_HEADER_BYTES {
        return Err(IoError::Malformed {
            path: path.to_path_buf(),
            line: 1,
            message: format!("the header line is longer than {MAX_HEADER_BYTES} bytes"),
        });
    }
    Ok(Bounded {
        inner: std::io::Cursor::new(first).chain(reader),
        read: 0,
        last: None,
        ended: false,
    })
}

/// Lines the terminator of the row just read adds to the reader's count: 1, or 0 for a last row
/// with no newline of its own.
fn terminator<R: Read>(reader: &csv::Reader<Bounded<R>>) -> u64 {
    u64::from(!reader.get_ref().unterminated_at(reader.position().byte()))
}

/// Reads the next record into `record` and returns its file line (1-based), `None` at the end.
///
/// The csv crate dates a record from where it started reading it, which is before any blank
/// lines it skipped; so the line is counted back from where the record ended instead (less its
/// terminator, unless it is the last row and has none, and any newlines inside quoted cells).
/// Errors name the line the same way.
pub(crate) fn read_located<R: Read>(
    reader: &mut csv::Reader<Bounded<R>>,
    record: &mut csv::StringRecord,
    path: &Path,
) -> Result<Option<u64>, IoError> {
    match reader.read_record(record) {
        Ok(false) => Ok(None),
        Ok(true) => {
            let start = record.position().map_or(1, |p| p.line());
            let text = record.as_slice();
            let inside = if text.contains('\n') {
                text.matches('\n').count() as u64
            } else {
                0
            };
            let end = reader.position().line();
            Ok(Some(
                start.max(end.saturating_sub(terminator(reader) + inside)),
            ))
        }
        Err(error) => {
            let end = reader.position().line();
            let start = error.position().map_or(0, |p| p.line());
            if unterminated_quote(reader, record, &error) {
                return Err(IoError::Malformed {
                    path: path.to_path_buf(),
                    line: start,
                    message: "a quote opened on this line is never closed".to_string(),
                });
            }
            let line = start.max(end.saturating_sub(terminator(reader)));
            Err(csv_error_at(path, error, line))
        }
    }
}

/// True when a ragged `record` (the csv crate fills it before checking its length) has a
/// line break in a cell and runs to the end of the file: the csv crate reads an unclosed
/// quote to the end, so without this the error named the last line.
fn unterminated_quote<R: Read>(
    reader: &mut csv::Reader<R>,
    record: &csv::StringRecord,
    error: &csv::Error,
) -> bool {
    let ragged = matches!(error.kind(), csv::ErrorKind::UnequalLengths { .. });
    // The file is failing anyway, so reading on to see whether it ended costs nothing.
    let mut at_end = || matches!(reader.read_record(&mut csv::StringRecord::new()), Ok(false));
    ragged && record.as_slice().contains('\n') && at_end()
}

pub(crate) fn csv_error(path: &Path, error: csv::Error) -> IoError {
    let line = error.position().map_or(0, |p| p.line());
    csv_error_at(path, error, line)
}

fn csv_error_at(path: &Path, error: csv::Error, line: u64) -> IoError {
    // The csv crate's Display is one line; its kinds' Debug form is a struct.
    let message = error.to_string();
    match error.into_kind() {
        csv::ErrorKind::UnequalLengths {
            expected_len, len, ..
        } => IoError::Ragged {
            path: path.to_path_buf(),
            line,
            expected: expected_len as usize,
            found: len as usize,
        },
        csv::ErrorKind::Io(source) => IoError::Open {
            path: path.to_path_buf(),
            source,
        },
        csv::ErrorKind::Utf8 { pos, err } => IoError::Malformed {
            path: path.to_path_buf(),
            line: pos.map_or(line, |p| p.line()).max(1),
            message: format!("field {} is not UTF-8 text", err.field() + 1),
        },
        _ => IoError::Malformed {
            path: path.to_path_buf(),
            line,
            message,
        },
    }
}
