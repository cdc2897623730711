//! Flight tables read and written a chunk of rows at a time, so that memory does not grow with
//! the length of the file.
//!
//! ```
//! use tolles_io::chunks::{ChunkReader, CsvChunkWriter};
//! use tolles_io::format::Format;
//! let dir = std::env::temp_dir().join(format!("tolles-chunks-doc-{}", std::process::id()));
//! std::fs::create_dir_all(&dir).unwrap();
//! let path = dir.join("flight.csv");
//! std::fs::write(&path, "tt,mag_1_uc\n0.0,50000\n0.1,\n0.2,50002.5\n").unwrap();
//!
//! let mut reader = ChunkReader::open(&path, Format::Csv, 2).unwrap();
//! let mut writer = CsvChunkWriter::new(Vec::new(), reader.headers(), &["twice".into()]).unwrap();
//! while let Some(chunk) = reader.next_chunk().unwrap() {
//!     assert!(chunk.len() <= 2);
//!     let twice: Vec<f64> = chunk.numeric("mag_1_uc").unwrap().iter().map(|v| 2.0 * v).collect();
//!     writer.write(&chunk, &[&twice]).unwrap();
//! }
//! let text = String::from_utf8(writer.finish().unwrap()).unwrap();
//! assert_eq!(text, "tt,mag_1_uc,twice\n0.0,50000,100000\n0.1,,\n0.2,50002.5,100005\n");
//! # std::fs::remove_dir_all(&dir).unwrap();
//! ```
//!
//! Each chunk is a [`Table`] whose text cells, line numbers and error messages are those of the
//! whole file read at once: a chunked reader meets the same bad cells and ragged lines with the
//! same messages, and [`CsvChunkWriter`] writes the same text as
//! [`crate::table::write_with_column`]. CSV, Geosoft XYZ and Parquet are read in chunks (a
//! Parquet row group is read a chunk at a time too); a reader can be told to keep only some
//! columns ([`ChunkReader::only`]), which for Parquet means the others are never decoded.
//!
//! A CSV file is read a block of whole lines at a time ([`blocks`]) and taken as the whole-file
//! reader takes a file ([`crate::rawcsv`]): the cells a pass needs are parsed on all cores
//! straight from the block, and [`CsvChunkWriter`] writes its rows by copying their bytes. From
//! the first block that reader hands back to the general one (a quote, a ragged line, text that
//! is not UTF-8), the rest of the file is read cell by cell, so what is read, written and
//! reported is the same either way.

mod blocks;

use crate::atomic::AtomicFile;
use crate::error::IoError;
use crate::format::Format;
use crate::header::check_header;
use crate::table::{
    bounded_header, csv_error, read_located, write_header, write_rows, Bounded, Column, Table,
    TextColumn,
};
use crate::xyz::XyzChunks;
use ::parquet::column::reader::ColumnReader;
use ::parquet::errors::ParquetError;
use ::parquet::file::reader::{FileReader, SerializedFileReader};
use ::parquet::file::writer::SerializedFileWriter;
use blocks::Blocks;
use std::fs::File;
use std::io::{BufReader, Write};
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// Rows per chunk when the caller has no reason to choose: a few megabytes of text.
pub const DEFAULT_CHUNK_ROWS: usize = 1 << 16;

/// A flight table read a chunk of rows at a time.
pub struct ChunkReader {
    path: PathBuf,
    format: Format,
    headers: Vec<String>,
    notes: Vec<String>,
    keep: Option<Vec<usize>>,
    /// Columns to parse while reading when all are kept ([`ChunkReader::parsing`]).
    parse: Vec<usize>,
    rows: usize,
    /// Rows returned so far; the first row of the next chunk.
    rows_read: usize,
    /// Row index of the first row of the chunk returned last.
    first_row: usize,
    /// Whether [`ChunkReader::rename`] changed `headers` from the file's.
    renamed: bool,
    source: Source,
}

enum Source {
    /// A CSV file read a block of lines at a time for [`crate::rawcsv`].
    Raw(Box<Blocks>),
    /// A CSV file read cell by cell.
    Csv {
        reader: Box<csv::Reader<Bounded<File>>>,
        record: csv::StringRecord,
    },
    Xyz {
        chunks: Box<XyzChunks<File>>,
        /// The first chunk, read ahead because it names the columns.
        pending: Option<Box<Table>>,
    },
    Parquet(Box<ParquetChunks>),
}

impl ChunkReader {
    /// Opens `path` to read in `format` (CSV, XYZ or Parquet), at most `rows` rows per chunk.
    /// A header that names no column or one twice is an error here (after any ragged line of
    /// the file, as reading it whole reports); a file without data rows is an error at the first
    /// [`ChunkReader::next_chunk`].
    pub fn open(path: &Path, format: Format, rows: usize) -> Result<Self, IoError> {
        let file = File::open(path).map_err(|source| IoError::Open {
            path: path.to_path_buf(),
            source,
        })?;
        let rows = rows.max(1);
        let mut notes = Vec::new();
        let (headers, source) = match format {
            Format::Csv => {
                let (headers, general) = open_csv(file, path)?;
                match Blocks::open(path, &headers)? {
                    Some(blocks) => (headers, Source::Raw(Box::new(blocks))),
                    None => (headers, general),
                }
            }
            Format::Xyz => {
                let mut chunks = Box::new(XyzChunks::new(file, path));
                let first = chunks.next_rows(rows)?;
                let headers = first.as_ref().map_or(Vec::new(), |t| t.headers().to_vec());
                let pending = first.map(Box::new);
                (headers, Source::Xyz { chunks, pending })
            }
            Format::Parquet => {
                let parquet = crate::parquet::contained(path, || ParquetChunks::open(file, path))?;
                notes = parquet.notes.clone();
                check_header(path, &parquet.headers)?;
                (parquet.headers.clone(), Source::Parquet(Box::new(parquet)))
            }
            Format::Gdf | Format::Hdf5 => {
                return Err(IoError::Invalid {
                    path: path.to_path_buf(),
                    message: format!("{format} files are not read in chunks"),
                })
            }
        };
        Ok(Self {
            path: path.to_path_buf(),
            format,
            headers,
            notes,
            keep: None,
            parse: Vec::new(),
            rows,
            rows_read: 0,
            first_row: 0,
            renamed: false,
            source,
        })
    }

    /// True for the formats [`ChunkReader::open`] reads.
    pub fn reads(format: Format) -> bool {
        matches!(format, Format::Csv | Format::Xyz | Format::Parquet)
    }

    /// Keeps only the columns at `indices` (into [`ChunkReader::headers`]), in that order, in
    /// the chunks read from now on.
    pub fn only(mut self, indices: Vec<usize>) -> Self {
        self.keep = Some(indices);
        if let Source::Parquet(p) = &mut self.source {
            p.keep(self.keep.as_deref());
        }
        self
    }

    /// Parses the columns at `indices` (into [`ChunkReader::headers`]) while reading chunks of
    /// every column, where the reader can (a CSV file's blocks): asked for as numbers, they are
    /// there. The chunks are the same.
    pub fn parsing(mut self, indices: Vec<usize>) -> Self {
        self.parse = indices;
        self
    }

    /// Renames column `old` (found as [`crate::table::find_column`] finds it) to `new` in the
    /// headers and in every chunk read from now on, as [`Table::rename`] renames a table read
    /// whole; an error if there is no such column or another is already called `new`.
    pub fn rename(&mut self, old: &str, new: &str) -> Result<(), IoError> {
        crate::header::rename_header(&self.path, &mut self.headers, old, new)?;
        self.renamed = true;
        Ok(())
    }

    /// The file being read.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Every column name of the file (for Parquet, of its numeric columns), in file order.
    pub fn headers(&self) -> &[String] {
        &self.headers
    }

    /// What the reader leaves out of the table (a Parquet text column), one sentence each.
    pub fn notes(&self) -> &[String] {
        &self.notes
    }

    /// Index in the whole file (0-based) of the first row of the chunk returned last.
    pub fn first_row(&self) -> usize {
        self.first_row
    }

    /// Where row `k` of the chunk returned last is, for messages: "line N" of the file for
    /// text, "row N" (1-based, counted over the whole file) for Parquet.
    pub fn place_of(&self, chunk: &Table, k: usize) -> String {
        match self.format {
            Format::Parquet => format!("row {}", self.first_row + k + 1),
            _ => chunk.place_of(k),
        }
    }

    /// The next chunk of at most the chosen number of rows, or `None` after the last row.
    pub fn next_chunk(&mut self) -> Result<Option<Table>, IoError> {
        let table = match &mut self.source {
            Source::Raw(_) => self.next_raw()?,
            Source::Csv { .. } => self.next_chunk_cell_by_cell()?,
            Source::Xyz { chunks, pending } => match pending.take() {
                Some(t) => Some(*t),
                None => chunks.next_rows(self.rows)?,
            }
            .map(|t| select(t, self.keep.as_deref()))
            .transpose()?,
            Source::Parquet(p) => {
                let (path, first) = (&self.path, self.rows_read == 0);
                crate::parquet::contained(path, || p.next_rows(path, self.rows, first))?
            }
        };
        let mut table = table;
        if let Some(t) = &mut table {
            self.first_row = self.rows_read;
            self.rows_read += t.len();
            if self.renamed {
                t.set_headers(self.kept_headers());
            }
        }
        Ok(table)
    }

    /// The next chunk of a CSV file read in blocks: a block's rows as [`crate::rawcsv`] takes
    /// them, or, from the first block it hands back, the rest of the file read cell by cell.
    fn next_raw(&mut self) -> Result<Option<Table>, IoError> {
        let fields = self.keep.clone().unwrap_or_else(|| self.parse.clone());
        let width = self.headers.len();
        while let Source::Raw(blocks) = &mut self.source {
            let block = blocks
                .next(self.rows)
                .map_err(|e| open_error(&self.path, e))?;
            let read = block.is_some();
            match (read, block.and_then(|b| b.rows(width, &fields))) {
                (false, _) if self.rows_read > 0 => return Ok(None),
                (true, Some((rows, _))) if rows.is_empty() => {}
                (true, Some((rows, lines))) => {
                    let keep = self.keep.as_deref();
                    return raw_table(&self.path, &self.headers, keep, rows, lines).map(Some);
                }
                // Lines the general reader must take, or a file without rows, whose error it gives.
                _ => self.source = general_after(&self.path, self.rows_read)?,
            }
        }
        self.next_chunk_cell_by_cell()
    }

    /// The next chunk read by the general reader.
    fn next_chunk_cell_by_cell(&mut self) -> Result<Option<Table>, IoError> {
        let Source::Csv { reader, record } = &mut self.source else {
            return Ok(None);
        };
        read_csv_rows(
            reader,
            record,
            &self.path,
            &self.headers,
            self.keep.as_deref(),
            self.rows,
            self.rows_read,
        )
    }

    /// The (renamed) names of the columns a chunk holds.
    fn kept_headers(&self) -> Vec<String> {
        match &self.keep {
            Some(keep) => keep.iter().map(|&j| self.headers[j].clone()).collect(),
            None => self.headers.clone(),
        }
    }
}

/// The general reader of the CSV file at `path` (`file`), past its header, and the header's
/// names; a bad header is an error after any ragged line of the file, as reading it whole
/// reports.
fn open_csv(file: File, path: &Path) -> Result<(Vec<String>, Source), IoError> {
    let mut reader = csv::ReaderBuilder::new()
        .has_headers(true)
        .trim(csv::Trim::All)
        .from_reader(bounded_header(file, path)?);
    let headers: Vec<String> = reader
        .headers()
        .map_err(|e| csv_error(path, e))?
        .iter()
        .map(str::to_string)
        .collect();
    if let Err(e) = check_header(path, &headers) {
        for record in reader.records() {
            record.map_err(|e| csv_error(path, e))?;
        }
        return Err(e);
    }
    let record = csv::StringRecord::new();
    let reader = Box::new(reader);
    Ok((headers, Source::Csv { reader, record }))
}

/// The general reader of the CSV file at `path` past its first `rows` data rows.
fn general_after(path: &Path, rows: usize) -> Result<Source, IoError> {
    let file = File::open(path).map_err(|e| open_error(path, e))?;
    let (_, mut source) = open_csv(file, path)?;
    if let Source::Csv { reader, record } = &mut source {
        for _ in 0..rows {
            read_located(reader, record, path)?;
        }
    }
    Ok(source)
}

/// The table of the `keep` columns (all when `None`) of `rows` of a CSV file whose columns are
/// `headers`, row `k` being file line `lines[k]`.
fn raw_table(
    path: &Path,
    headers: &[String],
    keep: Option<&[usize]>,
    rows: crate::rawcsv::RawRows,
    lines: Vec<u64>,
) -> Result<Table, IoError> {
    let rows = Arc::new(rows);
    let fields: Vec<usize> = keep.map_or_else(|| (0..rows.fields()).collect(), <[usize]>::to_vec);
    let names = fields.iter().map(|&f| headers[f].clone()).collect();
    let columns = fields
        .iter()
        .map(|&f| Column::Text(TextColumn::raw(Arc::clone(&rows), f)))
        .collect();
    Table::from_columns(path, names, columns, Some(lines))
}

fn open_error(path: &Path, source: std::io::Error) -> IoError {
    IoError::Open {
        path: path.to_path_buf(),
        source,
    }
}

/// Reads up to `rows` CSV records into a table of the `keep` columns (all when `None`).
fn read_csv_rows(
    reader: &mut csv::Reader<Bounded<File>>,
    record: &mut csv::StringRecord,
    path: &Path,
    headers: &[String],
    keep: Option<&[usize]>,
    rows: usize,
    rows_before: usize,
) -> Result<Option<Table>, IoError> {
    let all: Vec<usize>;
    let keep = match keep {
        Some(k) => k,
        None => {
            all = (0..headers.len()).collect();
            &all
        }
    };
    let mut columns = vec![TextColumn::default(); keep.len()];
    let mut lines = Vec::new();
    while lines.len() < rows {
        let Some(line) = read_located(reader, record, path)? else {
            break;
        };
        lines.push(line);
        for (column, &j) in columns.iter_mut().zip(keep) {
            column.push(record.get(j).unwrap_or(""));
        }
    }
    if lines.is_empty() && rows_before > 0 {
        return Ok(None);
    }
    let names = keep.iter().map(|&j| headers[j].clone()).collect();
    let columns = columns.into_iter().map(Column::Text).collect();
    Table::from_columns(path, names, columns, Some(lines)).map(Some)
}

/// The `keep` columns of `table` (all when `None`), rows and line numbers unchanged.
fn select(table: Table, keep: Option<&[usize]>) -> Result<Table, IoError> {
    let Some(keep) = keep else { return Ok(table) };
    let names = keep.iter().map(|&j| table.headers()[j].clone()).collect();
    let columns = keep.iter().map(|&j| table.columns()[j].clone()).collect();
    let lines = (0..table.len()).map(|k| table.line_of(k)).collect();
    Table::from_columns(table.path(), names, columns, Some(lines))
}

/// A Parquet file's numeric columns, read a chunk of rows at a time within its row groups.
struct ParquetChunks {
    reader: SerializedFileReader<File>,
    headers: Vec<String>,
    notes: Vec<String>,
    /// Names and (schema index, max definition level) of the columns read.
    names: Vec<String>,
    wanted: Vec<crate::parquet::NumericColumn>,
    all: Vec<crate::parquet::NumericColumn>,
    group: usize,
    left_in_group: usize,
    columns: Vec<ColumnReader>,
}

impl ParquetChunks {
    fn open(file: File, path: &Path) -> Result<Self, IoError> {
        let reader = SerializedFileReader::new(file).map_err(|e| invalid(path, e))?;
        let (headers, all, notes) = crate::parquet::numeric_columns(&reader);
        Ok(Self {
            reader,
            names: headers.clone(),
            headers,
            notes,
            wanted: all.clone(),
            all,
            group: 0,
            left_in_group: 0,
            columns: Vec::new(),
        })
    }

    fn keep(&mut self, keep: Option<&[usize]>) {
        let all: Vec<usize> = (0..self.all.len()).collect();
        let keep = keep.unwrap_or(&all);
        self.wanted = keep.iter().map(|&j| self.all[j]).collect();
        self.names = keep.iter().map(|&j| self.headers[j].clone()).collect();
    }

    fn next_rows(
        &mut self,
        path: &Path,
        rows: usize,
        first: bool,
    ) -> Result<Option<Table>, IoError> {
        while self.left_in_group == 0 {
            if self.group == self.reader.num_row_groups() {
                if first {
                    // The error reading the file whole gives for a file without rows.
                    let empty = vec![Column::Numbers(Vec::new()); self.headers.len()];
                    return Table::from_columns(path, self.headers.clone(), empty, None).map(Some);
                }
                return Ok(None);
            }
            let group = self
                .reader
                .get_row_group(self.group)
                .map_err(|e| invalid(path, e))?;
            self.left_in_group = group.metadata().num_rows() as usize;
            self.columns = self
                .wanted
                .iter()
                .map(|wanted| group.get_column_reader(wanted.index))
                .collect::<Result<_, _>>()
                .map_err(|e| invalid(path, e))?;
            self.group += 1;
        }
        let n = rows.min(self.left_in_group);
        let mut values = Vec::with_capacity(self.wanted.len());
        for (column, wanted) in self.columns.iter_mut().zip(&self.wanted) {
            let mut out = crate::parquet::empty_column(wanted);
            crate::parquet::read_any_column(column, wanted, n, &mut out)
                .map_err(|e| invalid(path, e))?;
            values.push(out);
        }
        self.left_in_group -= n;
        Table::from_columns(path, self.names.clone(), values, None).map(Some)
    }
}

fn invalid(path: &Path, e: ParquetError) -> IoError {
    IoError::Invalid {
        path: path.to_path_buf(),
        message: format!("not a readable Parquet file: {e}"),
    }
}

/// Writes CSV a chunk at a time: the header first, then each chunk's rows plus extra columns,
/// as [`crate::table::write_with_column`] writes a whole table (rows left in a CSV file's bytes
/// copied).
pub struct CsvChunkWriter<W: Write> {
    out: W,
}

impl<W: Write> CsvChunkWriter<W> {
    /// Writes the header: `headers` then `extra`.
    pub fn new(mut out: W, headers: &[String], extra: &[String]) -> std::io::Result<Self> {
        write_header(headers.iter().chain(extra).map(String::as_str), &mut out)?;
        Ok(Self { out })
    }

    /// Writes the rows of `chunk` plus one value per row of each `extra` column (empty for NaN).
    pub fn write(&mut self, chunk: &Table, extra: &[&[f64]]) -> std::io::Result<()> {
        write_rows(chunk, extra, &mut self.out)
    }

    /// Flushes, and gives back the output.
    pub fn finish(mut self) -> std::io::Result<W> {
        self.out.flush()?;
        Ok(self.out)
    }
}

/// Writes Parquet a chunk at a time, one row group per chunk, in the layout of
/// [`crate::parquet::write`]: optional float64 columns, NaN as null.
/// `path` is replaced only by [`ParquetChunkWriter::finish`] ([`crate::atomic`]).
pub struct ParquetChunkWriter {
    path: PathBuf,
    writer: SerializedFileWriter<File>,
    file: AtomicFile,
}

impl ParquetChunkWriter {
    /// Starts `path` for the columns `names`.
    pub fn create(path: &Path, names: &[String]) -> Result<Self, IoError> {
        let file = AtomicFile::create(path)?;
        let handle = file.file().try_clone().map_err(|source| IoError::Write {
            path: path.to_path_buf(),
            source,
        })?;
        let names: Vec<&str> = names.iter().map(String::as_str).collect();
        let writer = crate::parquet::new_writer(handle, &names).map_err(|e| fail(path, e))?;
        Ok(Self {
            path: path.to_path_buf(),
            writer,
            file,
        })
    }

    /// Writes every column of `chunk` as numbers, then the `extra` columns, as one row group.
    /// A text cell that is not a number is an error naming its line and column.
    pub fn write(&mut self, chunk: &Table, extra: &[&[f64]]) -> Result<(), IoError> {
        let mut columns = Vec::with_capacity(chunk.headers().len());
        for k in 0..chunk.headers().len() {
            columns.push(chunk.numeric_at(k)?);
        }
        let path = &self.path;
        let mut group = self.writer.next_row_group().map_err(|e| fail(path, e))?;
        for values in columns
            .iter()
            .map(Vec::as_slice)
            .chain(extra.iter().copied())
        {
            let Some(mut column) = group.next_column().map_err(|e| fail(path, e))? else {
                break;
            };
            crate::parquet::write_values(&mut column, values).map_err(|e| fail(path, e))?;
            column.close().map_err(|e| fail(path, e))?;
        }
        group.close().map_err(|e| fail(path, e))?;
        Ok(())
    }

    /// Writes the file's footer and puts the file in place.
    pub fn finish(self) -> Result<(), IoError> {
        let path = self.path;
        self.writer.close().map_err(|e| fail(&path, e))?;
        self.file.commit()
    }
}

fn fail(path: &Path, e: ParquetError) -> IoError {
    IoError::Write {
        path: path.to_path_buf(),
        source: std::io::Error::other(e.to_string()),
    }
}

/// Rows of numbers kept in an anonymous temporary file (8 bytes a value, removed when dropped)
/// between passes over a text file, so that a later pass need not parse the text again.
pub struct NumberSpill {
    out: std::io::BufWriter<File>,
    width: usize,
    rows: usize,
}

impl NumberSpill {
    /// A spill for rows of `width` numbers.
    pub fn new(width: usize) -> std::io::Result<Self> {
        Ok(Self {
            out: std::io::BufWriter::with_capacity(1 << 20, tempfile::tempfile()?),
            width,
            rows: 0,
        })
    }

    /// Appends the rows of `columns` (`width` columns of equal length).
    pub fn push(&mut self, columns: &[&[f64]]) -> std::io::Result<()> {
        let rows = columns.first().map_or(0, |c| c.len());
        let columns = &columns[..self.width.min(columns.len())];
        let mut bytes = Vec::with_capacity(rows * columns.len() * 8);
        for k in 0..rows {
            for column in columns {
                bytes.extend_from_slice(&column[k].to_le_bytes());
            }
        }
        self.out.write_all(&bytes)?;
        self.rows += rows;
        Ok(())
    }

    /// Reads the rows back, at most `rows_per_chunk` at a time.
    pub fn into_reader(self, rows_per_chunk: usize) -> std::io::Result<SpillReader> {
        use std::io::Seek;
        let mut file = self.out.into_inner().map_err(|e| e.into_error())?;
        file.rewind()?;
        Ok(SpillReader {
            input: BufReader::with_capacity(1 << 20, file),
            width: self.width,
            left: self.rows,
            rows_per_chunk: rows_per_chunk.max(1),
        })
    }
}

/// The rows of a [`NumberSpill`], read back in order.
pub struct SpillReader {
    input: BufReader<File>,
    width: usize,
    left: usize,
    rows_per_chunk: usize,
}

impl SpillReader {
    /// The next chunk of rows as columns, or `None` after the last row.
    pub fn next_chunk(&mut self) -> std::io::Result<Option<Vec<Vec<f64>>>> {
        use std::io::Read;
        if self.left == 0 {
            return Ok(None);
        }
        let rows = self.left.min(self.rows_per_chunk);
        let mut bytes = vec![0u8; rows * self.width * 8];
        self.input.read_exact(&mut bytes)?;
        let mut columns = vec![Vec::with_capacity(rows); self.width];
        for (j, value) in bytes.chunks_exact(8).enumerate() {
            let v = f64::from_le_bytes(value.try_into().expect("8 bytes"));
            columns[j % self.width].push(v);
        }
        self.left -= rows;
        Ok(Some(columns))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::table::write_with_column;

    /// A file in one directory shared by every run, so runs do not leave a directory each.
    fn temp(name: &str, text: &str) -> PathBuf {
        let dir = std::env::temp_dir().join(format!("tolles-chunks-tests/{name}"));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join(name);
        std::fs::write(&path, text).unwrap();
        path
    }

    fn chunked_csv(path: &Path, format: Format, rows: usize) -> String {
        read_in_chunks(path, format, rows).unwrap().0
    }

    fn whole_csv(path: &Path, format: Format) -> String {
        read_whole(path, format).unwrap().0
    }

    #[test]
    fn chunks_of_any_size_write_the_text_of_the_whole_table() {
        let csv = temp(
            "a.csv",
            "a, b ,c\n1.50,x,\"q,r\"\n,2,3\n4,5,6\n7,8,9\n10,11,12\n",
        );
        let xyz = temp("a.xyz", "/ a b\nLine 1\n1 *\n2 3\nTie 9\n4 5\n6 7\n");
        for rows in [1, 2, 3, 100] {
            assert_eq!(
                chunked_csv(&csv, Format::Csv, rows),
                whole_csv(&csv, Format::Csv)
            );
            assert_eq!(
                chunked_csv(&xyz, Format::Xyz, rows),
                whole_csv(&xyz, Format::Xyz)
            );
        }
    }

    #[test]
    fn errors_are_those_of_reading_whole() {
        for (name, text) in [
            ("r.csv", "a,b\n1,2\n3\n"),
            ("h.csv", "a,b\n"),
            ("d.csv", "a,a\n1,2\n3\n"),
            ("r.xyz", "/ a b\nLine 1\n1 2\n3\n"),
            ("e.xyz", "/ only a comment\n"),
        ] {
            let path = temp(name, text);
            let format = Format::from_path(&path);
            let whole = Table::read(&path, Some(format)).unwrap_err().to_string();
            let chunked = ChunkReader::open(&path, format, 1)
                .and_then(|mut r| while_chunks(&mut r))
                .unwrap_err()
                .to_string();
            assert_eq!(chunked, whole, "{name}");
        }
    }

    fn while_chunks(reader: &mut ChunkReader) -> Result<(), IoError> {
        while reader.next_chunk()?.is_some() {}
        Ok(())
    }

    #[test]
    fn renamed_columns_keep_their_new_names_in_every_chunk() {
        let csv = temp("n.csv", "A,b,c\n1,2,3\n4,5,6\n7,8,9\n");
        let xyz = temp("n.xyz", "/ A b c\n1 2 3\n4 5 6\n7 8 9\n");
        for (path, format) in [(csv, Format::Csv), (xyz, Format::Xyz)] {
            let mut reader = ChunkReader::open(&path, format, 2).unwrap();
            reader.rename("a", "x").unwrap();
            let e = reader.rename("x", "b").unwrap_err();
            assert!(matches!(e, IoError::DuplicateColumn { .. }), "{e}");
            assert!(reader.rename("nope", "y").is_err());
            assert_eq!(reader.headers()[..3], ["x", "b", "c"]);
            let mut reader = reader.only(vec![2, 0]);
            while let Some(chunk) = reader.next_chunk().unwrap() {
                assert_eq!(chunk.headers(), ["c", "x"], "{format}");
            }
        }
    }

    #[test]
    fn spilled_numbers_come_back_bit_for_bit() {
        let mut spill = NumberSpill::new(2).unwrap();
        spill.push(&[&[1.5, f64::NAN], &[-0.0, 3.0]]).unwrap();
        spill.push(&[&[f64::INFINITY], &[1e-300]]).unwrap();
        let mut reader = spill.into_reader(2).unwrap();
        let first = reader.next_chunk().unwrap().unwrap();
        assert_eq!(first[0][0], 1.5);
        assert!(first[0][1].is_nan());
        assert_eq!(first[1][0].to_bits(), (-0.0f64).to_bits());
        let second = reader.next_chunk().unwrap().unwrap();
        assert_eq!(second, [vec![f64::INFINITY], vec![1e-300]]);
        assert!(reader.next_chunk().unwrap().is_none());
    }

    #[test]
    fn parquet_round_trips_in_chunks_and_keeps_only_what_is_asked() {
        let dir = temp("x", "");
        let path = dir.with_file_name("p.parquet");
        let a: Vec<f64> = (0..10).map(f64::from).collect();
        let b: Vec<f64> = (0..10)
            .map(|k| if k == 3 { f64::NAN } else { -f64::from(k) })
            .collect();
        crate::parquet::write(&path, &[("a".into(), a.clone()), ("b".into(), b.clone())]).unwrap();
        let mut reader = ChunkReader::open(&path, Format::Parquet, 4)
            .unwrap()
            .only(vec![1]);
        let out = path.with_file_name("q.parquet");
        let mut writer = ParquetChunkWriter::create(&out, &["b".into(), "c".into()]).unwrap();
        let mut seen = Vec::new();
        while let Some(chunk) = reader.next_chunk().unwrap() {
            assert_eq!(chunk.headers(), ["b"]);
            assert_eq!(
                reader.place_of(&chunk, 0),
                format!("row {}", seen.len() + 1)
            );
            let c: Vec<f64> = vec![1.0; chunk.len()];
            writer.write(&chunk, &[&c]).unwrap();
            seen.extend(chunk.numeric("b").unwrap());
        }
        writer.finish().unwrap();
        let back = Table::read(&out, None).unwrap();
        let got = back.numeric("b").unwrap();
        assert_eq!(got.len(), 10);
        assert!(got[3].is_nan() && seen[3].is_nan());
        assert_eq!(got[5], -5.0);
        assert_eq!(back.numeric("c").unwrap(), [1.0; 10]);
    }

    /// What a reader gives for a CSV file: the text written with one more column (`0.5 k` in
    /// row k), and each column's numbers (as bits) or its first error; or the error reading it.
    type Read = Result<(String, Vec<Result<Vec<u64>, String>>), String>;

    fn read_whole(path: &Path, format: Format) -> Read {
        let table = Table::read(path, Some(format)).map_err(|e| e.to_string())?;
        let extra: Vec<f64> = (1..=table.len()).map(|k| 0.5 * k as f64).collect();
        let mut out = Vec::new();
        write_with_column(&table, &[("e".into(), extra)], &mut out).unwrap();
        let numbers = (0..table.headers().len())
            .map(|j| {
                table
                    .numeric_at(j)
                    .map(|v| bits(&v))
                    .map_err(|e| e.to_string())
            })
            .collect();
        Ok((String::from_utf8(out).unwrap(), numbers))
    }

    fn read_in_chunks(path: &Path, format: Format, rows: usize) -> Read {
        let fail = |e: IoError| e.to_string();
        let mut reader = ChunkReader::open(path, format, rows).map_err(fail)?;
        let width = reader.headers().len();
        let mut writer = CsvChunkWriter::new(Vec::new(), reader.headers(), &["e".into()]).unwrap();
        let mut numbers: Vec<Result<Vec<u64>, String>> = vec![Ok(Vec::new()); width];
        let mut k = 0.0;
        while let Some(chunk) = reader.next_chunk().map_err(fail)? {
            assert!(chunk.len() <= rows);
            let extra: Vec<f64> = (0..chunk.len())
                .map(|_| {
                    k += 0.5;
                    k
                })
                .collect();
            writer.write(&chunk, &[&extra]).unwrap();
            for (j, column) in numbers.iter_mut().enumerate() {
                if let Ok(so_far) = column {
                    match chunk.numeric_at(j) {
                        Ok(v) => so_far.extend(bits(&v)),
                        Err(e) => *column = Err(e.to_string()),
                    }
                }
            }
        }
        Ok((
            String::from_utf8(writer.finish().unwrap()).unwrap(),
            numbers,
        ))
    }

    fn bits(v: &[f64]) -> Vec<u64> {
        v.iter().map(|v| v.to_bits()).collect()
    }

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig::with_cases(1500))]
        #[test]
        fn csv_in_chunks_of_any_size_reads_and_writes_what_reading_whole_does(
            text in crate::rawcsv::tests::csv_text(),
            rows in 1usize..6,
        ) {
            let dir = tempfile::tempdir().unwrap();
            let path = dir.path().join("t.csv");
            std::fs::write(&path, &text).unwrap();
            let whole = read_whole(&path, Format::Csv);
            let chunked = read_in_chunks(&path, Format::Csv, rows);
            // Where a file read whole goes to the general reader but its first blocks do not,
            // their rows' lines are counted apart: the general reader's count differs after a
            // carriage return (see `rawcsv`'s tests).
            let (whole, chunked) = match !text.contains('\r') {
                true => (whole, chunked),
                false => {
                    let hide = |r: Read| {
                        let hide = |e: String| crate::rawcsv::tests::without_line_numbers(&e);
                        r.map(|(t, n)| (t, n.into_iter().map(|c| c.map_err(hide)).collect()))
                            .map_err(hide)
                    };
                    (hide(whole), hide(chunked))
                }
            };
            proptest::prop_assert_eq!(chunked, whole);
        }
    }

    #[test]
    fn most_generated_files_are_read_in_blocks() {
        // The property above means little if every file went the general way.
        use proptest::strategy::{Strategy, ValueTree};
        let mut runner = proptest::test_runner::TestRunner::deterministic();
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("t.csv");
        let (mut in_blocks, mut total) = (0, 0);
        for _ in 0..500 {
            let text = crate::rawcsv::tests::csv_text()
                .new_tree(&mut runner)
                .unwrap()
                .current();
            std::fs::write(&path, &text).unwrap();
            let Ok(mut reader) = ChunkReader::open(&path, Format::Csv, 3) else {
                continue;
            };
            let raw = matches!(reader.next_chunk(), Ok(Some(c)) if c.raw_rows().is_some());
            in_blocks += usize::from(raw);
            total += 1;
        }
        assert!(in_blocks * 5 > total, "{in_blocks} of {total}");
    }
}
