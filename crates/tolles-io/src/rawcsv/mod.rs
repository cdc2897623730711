//! CSV held as the file's own bytes: a row is a span of the file, a cell is parsed only when a
//! command asks for its column, and a row is written back by copying its bytes.
//!
//! This is how a large CSV file is read whole ([`crate::table::Table::csv`]). The general
//! reader (the `csv` crate, every cell copied into its column) stays the reference: a file this
//! one cannot take exactly as the general reader would — a quote anywhere, a carriage return
//! that does not end a line, a line with another number of cells than the header (whose error
//! the general reader words), text that is not UTF-8 — is handed back to it, so what a command
//! reads, writes and reports does not depend on which reader took the file.
//!
//! - **Lines, in parallel.** The file is memory-mapped (read, where it cannot be) and cut into
//!   pieces at line boundaries; each core finds its pieces' rows, counts their cells and marks
//!   the rows whose cells have white space at an edge ("untidy"), which the general reader
//!   trims. Blank lines are skipped, as the general reader skips them.
//! - **Numbers only on demand**, straight from the bytes: the columns a command names are
//!   parsed while the rows are found, each piece straight into its place in the whole column
//!   (a count of its lines fixes where; blank lines leave gaps closed afterwards), and handed
//!   over without a copy ([`RawRows::parse`]); any other column in one later pass on all cores.
//!   A plain decimal (`-50030.0342`) is converted inline (the private `decimal` module), to the same f64
//!   as `str::parse` gives; anything else goes through [`crate::table::parse_cell`], the
//!   general reader's own rule.
//! - **Rows written by copying** ([`write_rows`]): a tidy row is the same bytes as the general
//!   writer would write (no cell needs quotes, none has white space to trim), so it is copied;
//!   an untidy row is written cell by cell, trimmed. New cells are formatted on all cores
//!   ([`format_number`], the same text as [`crate::table::format_value`]).

mod write;

pub use write::{format_number, write_rows};

use crate::bytemask::{any_of, each_of, with_block, BLOCK};
use crate::decimal::plain_decimal;
use crate::error::IoError;
use crate::header::{check_header, parse_cell};
use rayon::prelude::*;
use std::ops::{Deref, Range};
use std::path::Path;
use std::sync::{Arc, Mutex, PoisonError};

/// A file's bytes: mapped into memory where the file allows it, else read.
pub(crate) enum Bytes {
    Mapped(memmap2::Mmap),
    Owned(Vec<u8>),
}

impl Deref for Bytes {
    type Target = [u8];

    fn deref(&self) -> &[u8] {
        match self {
            Bytes::Mapped(map) => map,
            Bytes::Owned(bytes) => bytes,
        }
    }
}

impl Bytes {
    /// The bytes of the regular file `path`: memory-mapped, so reading costs no copy and the
    /// pages are shared with the page cache.
    pub(crate) fn of_file(path: &Path) -> Result<Self, IoError> {
        let open_error = |source| IoError::Open {
            path: path.to_path_buf(),
            source,
        };
        let file = std::fs::File::open(path).map_err(open_error)?;
        let meta = file.metadata().map_err(open_error)?;
        if !meta.is_file() || meta.len() == 0 {
            let mut bytes = Vec::new();
            std::io::Read::read_to_end(&mut &file, &mut bytes).map_err(open_error)?;
            return Ok(Bytes::Owned(bytes));
        }
        // SAFETY: the map is read only. The one hazard is another process truncating the file
        // while we read it (the access would then fault), the same as for any program that maps
        // its input (ripgrep, the pyarrow reader); a file changed in place reads as changed.
        match unsafe { memmap2::Mmap::map(&file) } {
            Ok(map) => Ok(Bytes::Mapped(map)),
            Err(_) => {
                let mut bytes = Vec::with_capacity(meta.len() as usize);
                std::io::Read::read_to_end(&mut &file, &mut bytes).map_err(open_error)?;
                Ok(Bytes::Owned(bytes))
            }
        }
    }
}

/// The data rows of a CSV file as spans of its bytes.
pub struct RawRows {
    bytes: Arc<Bytes>,
    /// Byte offset of each row's first byte.
    starts: Vec<u64>,
    /// Each row's length in bytes, without its line terminator (`\n` or `\r\n`).
    lens: Vec<u32>,
    /// Rows (ascending) with a cell that has white space at an edge.
    untidy: Vec<u32>,
    /// Cells per row (the header's).
    fields: usize,
    /// Columns parsed while the rows were found, until [`RawRows::parse`] hands them over.
    parsed: Mutex<Vec<ParsedField>>,
}

impl std::fmt::Debug for RawRows {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("RawRows")
            .field("rows", &self.starts.len())
            .field("fields", &self.fields)
            .field("untidy", &self.untidy.len())
            .finish()
    }
}

/// A CSV file taken by this reader: its header names, its rows, and each row's file line when
/// the file has blank lines (otherwise row `k` is line `k + 2`).
pub(crate) struct RawCsv {
    pub headers: Vec<String>,
    pub rows: RawRows,
    pub lines: Option<Vec<u64>>,
}

/// One column parsed while the rows were found.
#[derive(Debug, Clone)]
struct ParsedField {
    field: usize,
    values: Vec<f64>,
    /// The first row whose cell is not a number.
    bad: Option<usize>,
}

/// Smallest piece of a file one core scans on its own (bytes).
const PIECE_BYTES: usize = 1 << 20;

/// Most pieces per core: enough that, of a 667 MB file (10⁷ rows), the core that is done
/// first waits for at most a piece of 1.3 MB (at 64 a piece was 5 MB, 10–20 ms of one core
/// idle at the end of the read).
const PIECES_PER_CORE: usize = 256;

/// Rows one core parses or writes at a time.
const BLOCK_ROWS: usize = 1 << 15;

/// Which cells to parse while reading, given the header's names: their indices.
pub type Wanted<'w> = &'w dyn Fn(&[String]) -> Vec<usize>;

/// Reads the CSV file `path` as [`RawRows`], parsing the cells `wanted` names on the way; `None`
/// when the general reader must take it (see the module documentation). Errors only when the
/// file cannot be opened.
pub(crate) fn read(path: &Path, wanted: Wanted<'_>) -> Result<Option<RawCsv>, IoError> {
    let bytes = Arc::new(Bytes::of_file(path)?);
    Ok(from_bytes(bytes, path, wanted))
}

/// [`read`] of bytes already in memory.
pub(crate) fn from_bytes(bytes: Arc<Bytes>, path: &Path, wanted: Wanted<'_>) -> Option<RawCsv> {
    from_bytes_in_pieces(bytes, path, wanted, PIECE_BYTES)
}

/// [`from_bytes`] with the rows cut into pieces of about `piece_bytes` for the cores.
fn from_bytes_in_pieces(
    bytes: Arc<Bytes>,
    path: &Path,
    wanted: Wanted<'_>,
    piece_bytes: usize,
) -> Option<RawCsv> {
    let header_end = memchr::memchr(b'\n', &bytes)?;
    let headers = header_line_names(&bytes[..=header_end])?;
    check_header(path, &headers).ok()?;
    let fields = wanted(&headers);
    let body = header_end + 1..bytes.len();
    let (rows, lines) = rows_in(
        bytes,
        body,
        2,
        &Layout::new(headers.len(), &fields),
        piece_bytes,
    )?;
    Some(RawCsv {
        headers,
        rows,
        lines,
    })
}

/// The data lines of a CSV file whose header has `width` cells, held in `bytes` from the start
/// of a line (a part of the file read on its own, without the header), the cells `fields`
/// parsed on the way; with the file line of each row when blank lines are among them, the
/// first line of `bytes` being line `first_line`. `None` when the general reader must take
/// them (see the module documentation).
pub(crate) fn body_rows(
    bytes: Arc<Bytes>,
    width: usize,
    fields: &[usize],
    first_line: u64,
) -> Option<(RawRows, Option<Vec<u64>>)> {
    let all = 0..bytes.len();
    // A part of a file is small: cut it for every core, a few pieces each.
    let cores = rayon::current_num_threads().max(1);
    let piece_bytes = (all.len() / (4 * cores)).max(MIN_PIECE_BYTES);
    let layout = Layout::new(width, fields);
    rows_in(bytes, all, first_line, &layout, piece_bytes)
}

/// Smallest piece of a part of a file ([`body_rows`]) one core scans on its own (bytes).
const MIN_PIECE_BYTES: usize = 1 << 16;

/// The rows of the lines `range` of `bytes` (the first being file line `first_line`), in
/// pieces of about `piece_bytes` for the cores, and their file lines if any line is blank.
fn rows_in(
    bytes: Arc<Bytes>,
    range: Range<usize>,
    first_line: u64,
    layout: &Layout,
    piece_bytes: usize,
) -> Option<(RawRows, Option<Vec<u64>>)> {
    let start = range.start;
    let pieces = pieces(&bytes, range, piece_bytes);
    let (rows, blank) = scan_all(Arc::clone(&bytes), &pieces, layout)?;
    let lines = blank.then(|| line_numbers(&bytes[start..], start, first_line, &rows.starts));
    Some((rows, lines))
}

/// The rows of all `pieces` (in order) and whether any line was blank: every piece scanned on
/// its own core straight into its share of the row spans and parsed columns, which a count of
/// its lines fixes beforehand; blank lines leave gaps that are closed afterwards.
fn scan_all(
    bytes: Arc<Bytes>,
    pieces: &[Range<usize>],
    layout: &Layout,
) -> Option<(RawRows, bool)> {
    let surveys: Vec<Survey> = pieces
        .par_iter()
        .map(|range| survey(&bytes[range.clone()]))
        .collect();
    if surveys.iter().any(|s| s.quote) {
        return None;
    }
    let lines: Vec<usize> = surveys.iter().map(|s| s.lines).collect();
    let total: usize = lines.iter().sum();
    u32::try_from(total).ok()?;
    let mut starts = vec![0u64; total];
    let mut lens = vec![0u32; total];
    let mut values: Vec<Vec<f64>> = layout.fields.iter().map(|_| vec![0.0; total]).collect();
    let slots = Slots::cut(&mut starts, &mut lens, &mut values, &lines);
    let scanned: Vec<Scanned> = pieces
        .par_iter()
        .zip(slots)
        .zip(&surveys)
        .map(|((range, slots), survey)| {
            let text = &bytes[range.clone()];
            match survey.ascii {
                true => scan(text, range.start, layout, Piece::new(slots)),
                false => scan_slowly(text, range.start, layout, Piece::new(slots)),
            }
        })
        .collect::<Option<_>>()?;
    let found: Vec<usize> = scanned.iter().map(|s| s.rows).collect();
    close_gaps(&mut starts, &lines, &found);
    close_gaps(&mut lens, &lines, &found);
    values
        .iter_mut()
        .for_each(|v| close_gaps(v, &lines, &found));
    let mut untidy = Vec::new();
    let mut first = 0;
    let mut bad = vec![None; layout.fields.len()];
    for piece in &scanned {
        untidy.extend(piece.untidy.iter().map(|k| k + first as u32));
        for (b, piece_bad) in bad.iter_mut().zip(&piece.bad) {
            *b = b.or(piece_bad.map(|k| k + first));
        }
        first += piece.rows;
    }
    let parsed = layout
        .fields
        .iter()
        .zip(values)
        .zip(bad)
        .map(|((&field, values), bad)| ParsedField { field, values, bad })
        .collect();
    let rows = RawRows {
        bytes,
        starts,
        lens,
        untidy,
        fields: layout.width,
        parsed: Mutex::new(parsed),
    };
    Some((rows, scanned.iter().any(|s| s.blank)))
}

/// What one pass over a piece's bytes tells before its rows are read.
struct Survey {
    /// Its lines, the last one counted even without its line feed: at most its rows.
    lines: usize,
    /// A quote: the general reader must take the file.
    quote: bool,
    /// No byte of a multi-byte character.
    ascii: bool,
}

fn survey(text: &[u8]) -> Survey {
    let (mut feeds, mut quotes, mut high) = (0usize, 0u64, 0u64);
    for at in (0..text.len()).step_by(BLOCK) {
        let ([feed, quote], high_bytes) = with_block(text, at, |b| each_of(b, [b'\n', b'"']));
        feeds += feed.count_ones() as usize;
        quotes |= quote;
        high |= high_bytes;
    }
    Survey {
        lines: feeds + usize::from(text.last().is_some_and(|&b| b != b'\n')),
        quote: quotes != 0,
        ascii: high == 0,
    }
}

/// `v` with each piece's `found` rows moved down after the rows of the pieces before it, where
/// the pieces had room for `room` rows each, and cut to the rows found.
fn close_gaps<T: Copy>(v: &mut Vec<T>, room: &[usize], found: &[usize]) {
    let (mut from, mut to) = (0, 0);
    for (&room, &found) in room.iter().zip(found) {
        if from != to {
            v.copy_within(from..from + found, to);
        }
        from += room;
        to += found;
    }
    v.truncate(to);
}

/// The names of the header `line` (its bytes to its line feed, included) when this reader
/// takes the header: `None` when the general reader must.
pub(crate) fn header_line_names(line: &[u8]) -> Option<Vec<String>> {
    let end = line.len().checked_sub(1)?;
    // A quote may hide a line break in a name, a carriage return inside the line ends the header
    // early for the general reader, and an overlong header is the general reader's error.
    let inside = line.strip_suffix(b"\r\n").unwrap_or(&line[..end]);
    if line.contains(&b'"') || inside.contains(&b'\r') || end > crate::header::MAX_HEADER_BYTES {
        return None;
    }
    header_names(line)
}

/// The header's names as the general reader takes them (trimmed; a UTF-8 byte-order mark
/// dropped).
fn header_names(line: &[u8]) -> Option<Vec<String>> {
    let mut reader = csv::ReaderBuilder::new()
        .has_headers(true)
        .trim(csv::Trim::Headers)
        .from_reader(line);
    let names = reader.headers().ok()?;
    Some(names.iter().map(str::to_string).collect())
}

/// `range` cut into pieces that start at line starts, about one per `piece_bytes` and at most
/// [`PIECES_PER_CORE`] per core.
fn pieces(bytes: &[u8], range: Range<usize>, piece_bytes: usize) -> Vec<Range<usize>> {
    let cores = rayon::current_num_threads().max(1);
    let count = (range.len() / piece_bytes.max(1)).clamp(1, PIECES_PER_CORE * cores);
    let step = range.len().div_ceil(count).max(1);
    let mut out = Vec::with_capacity(count);
    let mut start = range.start;
    while start < range.end {
        let guess = (start + step).min(range.end);
        let end = match memchr::memchr(b'\n', &bytes[guess..range.end]) {
            Some(i) => guess + i + 1,
            None => range.end,
        };
        out.push(start..end);
        start = end;
    }
    out
}

/// Cells per row and which of them are parsed into which slot.
struct Layout {
    width: usize,
    /// For each cell of a row, its slot among the parsed columns.
    slot: Vec<Option<usize>>,
    /// The parsed cells, ascending.
    fields: Vec<usize>,
}

impl Layout {
    /// Rows of `width` cells, of which `fields` (any order, repeats and cells beyond the row
    /// ignored) are parsed.
    fn new(width: usize, fields: &[usize]) -> Self {
        let mut fields = fields.to_vec();
        fields.retain(|&f| f < width);
        fields.sort_unstable();
        fields.dedup();
        let mut slot = vec![None; width];
        for (k, &f) in fields.iter().enumerate() {
            slot[f] = Some(k);
        }
        Self {
            width,
            slot,
            fields,
        }
    }
}

/// One piece's share of the row spans and of each parsed column (a row per line of the piece).
struct Slots<'s> {
    starts: &'s mut [u64],
    lens: &'s mut [u32],
    values: Vec<&'s mut [f64]>,
}

impl<'s> Slots<'s> {
    /// The slots of consecutive pieces with `lines` lines each.
    fn cut(
        starts: &'s mut [u64],
        lens: &'s mut [u32],
        values: &'s mut [Vec<f64>],
        lines: &[usize],
    ) -> Vec<Slots<'s>> {
        let mut rest = Slots {
            starts,
            lens,
            values: values.iter_mut().map(|v| v.as_mut_slice()).collect(),
        };
        let mut out = Vec::with_capacity(lines.len());
        for &n in lines {
            let (starts, after_starts) = std::mem::take(&mut rest.starts).split_at_mut(n);
            let (lens, after_lens) = std::mem::take(&mut rest.lens).split_at_mut(n);
            let (values, after_values): (Vec<_>, Vec<_>) = std::mem::take(&mut rest.values)
                .into_iter()
                .map(|v| v.split_at_mut(n))
                .unzip();
            out.push(Slots {
                starts,
                lens,
                values,
            });
            rest = Slots {
                starts: after_starts,
                lens: after_lens,
                values: after_values,
            };
        }
        out
    }
}

/// One piece being scanned: its slots and what was found so far.
struct Piece<'s> {
    slots: Slots<'s>,
    found: Scanned,
}

/// What scanning one piece found besides the rows written into its slots.
struct Scanned {
    rows: usize,
    /// Untidy rows, counted from the piece's first row.
    untidy: Vec<u32>,
    blank: bool,
    /// Per parsed column, the first row (of the piece) that is no number.
    bad: Vec<Option<usize>>,
}

impl<'s> Piece<'s> {
    fn new(slots: Slots<'s>) -> Self {
        let bad = vec![None; slots.values.len()];
        Self {
            slots,
            found: Scanned {
                rows: 0,
                untidy: Vec::new(),
                blank: false,
                bad,
            },
        }
    }

    /// Stores the value of parsed column `slot` for the row being read.
    fn put(&mut self, slot: usize, value: Option<f64>) {
        let row = self.found.rows;
        let value = value.unwrap_or_else(|| {
            self.found.bad[slot].get_or_insert(row);
            f64::NAN
        });
        // A row per line, and the piece's lines were counted: there is always room.
        if let Some(cell) = self.slots.values[slot].get_mut(row) {
            *cell = value;
        }
    }

    /// Records the line `text[start..end]` (`end` at its `\n` or the end of the text), found
    /// `offset` bytes into the file; `None` if the general reader must take it.
    fn end_line(
        &mut self,
        text: &[u8],
        start: usize,
        end: usize,
        scan: &LineScan,
        fields: usize,
        offset: usize,
    ) -> Option<()> {
        // A carriage return right before the line feed is part of the terminator.
        let (end, refused) = if end > start && text[end - 1] == b'\r' {
            let inside = text[start..end - 1].contains(&b'\r');
            (end - 1, scan.refused && inside)
        } else {
            (end, scan.refused)
        };
        let line = &text[start..end];
        if line.is_empty() {
            self.found.blank = true;
            return Some(());
        }
        if refused || scan.commas + 1 != fields || (scan.high && std::str::from_utf8(line).is_err())
        {
            return None;
        }
        let row = self.found.rows;
        if scan.untidy || maybe_space(line[0]) || maybe_space(line[line.len() - 1]) {
            self.found.untidy.push(row as u32);
        }
        *self.slots.starts.get_mut(row)? = (offset + start) as u64;
        *self.slots.lens.get_mut(row)? = u32::try_from(line.len()).ok()?;
        self.found.rows += 1;
        Some(())
    }
}

/// The rows of `text`, whole lines of ASCII without a quote `offset` bytes into the file,
/// with their parsed cells; `None` if a line must go to the general reader.
fn scan(text: &[u8], offset: usize, layout: &Layout, mut piece: Piece) -> Option<Scanned> {
    // Only separators, line feeds and carriage returns matter: jump between them, parsing the
    // wanted cells as their ends are found.
    let mut line = LineScan::default();
    let (mut start, mut cell_start) = (0usize, 0usize);
    for i in Separators::new(text) {
        match text[i] {
            b',' => {
                if let Some(&Some(slot)) = layout.slot.get(line.commas) {
                    piece.put(slot, cell_value(&text[cell_start..i]));
                }
                line.comma(text, i);
                cell_start = i + 1;
            }
            b'\n' => {
                let end = if i > start && text[i - 1] == b'\r' {
                    i - 1
                } else {
                    i
                };
                if end > start {
                    if let Some(&Some(slot)) = layout.slot.get(line.commas) {
                        piece.put(slot, cell_value(&text[cell_start..end]));
                    }
                }
                piece.end_line(text, start, i, &line, layout.width, offset)?;
                line = LineScan::default();
                start = i + 1;
                cell_start = start;
            }
            _ => line.refused = true,
        }
    }
    if start < text.len() {
        let end = match text.last() {
            Some(b'\r') => text.len() - 1,
            _ => text.len(),
        };
        if end > start {
            if let Some(&Some(slot)) = layout.slot.get(line.commas) {
                piece.put(slot, cell_value(&text[cell_start..end]));
            }
        }
        piece.end_line(text, start, text.len(), &line, layout.width, offset)?;
    }
    Some(piece.found)
}

/// The positions of the commas, line feeds and carriage returns of a text, ascending.
struct Separators<'t> {
    text: &'t [u8],
    /// Where the block of `bits` starts.
    base: usize,
    /// The separators of that block not given yet.
    bits: u64,
}

impl<'t> Separators<'t> {
    fn new(text: &'t [u8]) -> Self {
        let bits = Self::of_block(text, 0);
        Self {
            text,
            base: 0,
            bits,
        }
    }

    fn of_block(text: &[u8], at: usize) -> u64 {
        with_block(text, at, |block| any_of(block, [b',', b'\n', b'\r']))
    }
}

impl Iterator for Separators<'_> {
    type Item = usize;

    fn next(&mut self) -> Option<usize> {
        while self.bits == 0 {
            self.base += BLOCK;
            if self.base >= self.text.len() {
                return None;
            }
            self.bits = Self::of_block(self.text, self.base);
        }
        let i = self.base + self.bits.trailing_zeros() as usize;
        self.bits &= self.bits - 1;
        Some(i)
    }
}

/// [`scan`] of a piece with multi-byte characters: every byte classified, then the wanted
/// cells of each row parsed.
fn scan_slowly(text: &[u8], offset: usize, layout: &Layout, mut piece: Piece) -> Option<Scanned> {
    let mut line = LineScan::default();
    let mut start = 0usize;
    for (i, &b) in text.iter().enumerate() {
        match CLASS[b as usize] {
            PLAIN => {}
            COMMA => line.comma(text, i),
            NEWLINE => {
                piece.end_line(text, start, i, &line, layout.width, offset)?;
                line = LineScan::default();
                start = i + 1;
            }
            HIGH => line.high = true,
            _ => line.refused = true,
        }
    }
    if start < text.len() {
        piece.end_line(text, start, text.len(), &line, layout.width, offset)?;
    }
    let order: Vec<usize> = (0..layout.fields.len()).collect();
    let Piece {
        mut slots,
        mut found,
    } = piece;
    for k in 0..found.rows {
        let from = slots.starts[k] as usize - offset;
        let row = &text[from..from + slots.lens[k] as usize];
        for (slot, value) in parse_line(row, &layout.fields, &order) {
            slots.values[slot][k] = value.unwrap_or(f64::NAN);
            if value.is_none() {
                found.bad[slot].get_or_insert(k);
            }
        }
    }
    Some(found)
}

/// What a pass over one line found.
#[derive(Default)]
struct LineScan {
    commas: usize,
    /// A cell has white space at an edge next to a comma.
    untidy: bool,
    /// A byte of a multi-byte character.
    high: bool,
    /// A byte only the general reader may take (a quote, a carriage return inside a line).
    refused: bool,
}

impl LineScan {
    fn comma(&mut self, text: &[u8], i: usize) {
        self.commas += 1;
        let before = i > 0 && maybe_space(text[i - 1]);
        let after = i + 1 < text.len() && maybe_space(text[i + 1]);
        self.untidy |= before | after;
    }
}

const PLAIN: u8 = 0;
const COMMA: u8 = 1;
const REFUSE: u8 = 2;
const HIGH: u8 = 3;
const NEWLINE: u8 = 4;

/// The class of every byte: a cell separator, a line feed, a byte the general reader must see
/// (a quote; a carriage return, unless it ends a line), a byte of a multi-byte UTF-8 character,
/// or plain.
const CLASS: [u8; 256] = {
    let mut class = [PLAIN; 256];
    class[b',' as usize] = COMMA;
    class[b'\n' as usize] = NEWLINE;
    class[b'"' as usize] = REFUSE;
    class[b'\r' as usize] = REFUSE;
    let mut b = 0x80;
    while b < 256 {
        class[b] = HIGH;
        b += 1;
    }
    class
};

/// True for a byte that may be (part of) white space `str::trim` removes: ASCII space, tab,
/// vertical tab, form feed, or any byte of a multi-byte character (Unicode white space such as
/// U+00A0 is one).
fn maybe_space(b: u8) -> bool {
    matches!(b, b' ' | b'\t' | 0x0b | 0x0c) || b >= 0x80
}

/// The file line (1-based) of each row starting at `starts` (offsets into the bytes of which
/// `text` starts `offset` bytes in, at line `first_line`), counting every line break before it;
/// only needed when blank lines make rows and lines differ.
fn line_numbers(text: &[u8], offset: usize, first_line: u64, starts: &[u64]) -> Vec<u64> {
    let mut lines = Vec::with_capacity(starts.len());
    let (mut line, mut from) = (first_line, 0usize);
    for &start in starts {
        let start = start as usize - offset;
        line += memchr::memchr_iter(b'\n', &text[from..start]).count() as u64;
        from = start;
        lines.push(line);
    }
    lines
}

/// A cell as a number: NaN when missing, `None` when it is not a number.
fn cell_value(cell: &[u8]) -> Option<f64> {
    plain_decimal(cell).or_else(|| general(cell))
}

/// The cells `fields` of `line` (ascending field indices), visited in `order` (indices into
/// `fields`, ascending by field), each as `(index into fields, value)`.
fn parse_line<'l>(
    line: &'l [u8],
    fields: &'l [usize],
    order: &'l [usize],
) -> impl Iterator<Item = (usize, Option<f64>)> + 'l {
    let (mut field, mut pos) = (0usize, 0usize);
    order.iter().map(move |&j| {
        if field > fields[j] {
            // The same field asked for twice.
            (field, pos) = (0, 0);
        }
        while field < fields[j] {
            pos = line[pos..]
                .iter()
                .position(|&b| b == b',')
                .map_or(line.len(), |i| pos + i + 1);
            field += 1;
        }
        let end = line[pos..]
            .iter()
            .position(|&b| b == b',')
            .map_or(line.len(), |i| pos + i);
        let value = cell_value(&line[pos..end]);
        (field, pos) = (field + 1, (end + 1).min(line.len()));
        (j, value)
    })
}

impl RawRows {
    /// Number of rows.
    pub fn len(&self) -> usize {
        self.starts.len()
    }

    /// True when there are no rows.
    pub fn is_empty(&self) -> bool {
        self.starts.is_empty()
    }

    /// Cells per row.
    pub fn fields(&self) -> usize {
        self.fields
    }

    fn line(&self, k: usize) -> &[u8] {
        let start = self.starts[k] as usize;
        &self.bytes[start..start + self.lens[k] as usize]
    }

    /// Cell `field` of row `k`, untrimmed.
    fn raw_cell(&self, k: usize, field: usize) -> &[u8] {
        self.line(k).split(|&b| b == b',').nth(field).unwrap_or(&[])
    }

    /// Cell `field` of row `k`, trimmed, as the general reader stores it.
    pub fn cell(&self, k: usize, field: usize) -> &str {
        // Lines with multi-byte characters were checked to be UTF-8 and cells split at an
        // ASCII comma, so this never falls back.
        std::str::from_utf8(self.raw_cell(k, field))
            .unwrap_or_default()
            .trim()
    }

    /// The rows `kept` (ascending indices), sharing the bytes; columns parsed already and free
    /// of bad cells stay parsed.
    pub fn select(&self, kept: &[usize]) -> RawRows {
        let mut untidy = Vec::new();
        let mut cursor = self.untidy.iter().peekable();
        for (new, &k) in kept.iter().enumerate() {
            while cursor.next_if(|&&u| (u as usize) < k).is_some() {}
            if cursor.peek().is_some_and(|&&u| u as usize == k) {
                untidy.push(new as u32);
            }
        }
        let parsed = self
            .parsed_fields()
            .iter()
            .filter(|p| p.bad.is_none())
            .map(|p| ParsedField {
                field: p.field,
                values: kept.iter().map(|&k| p.values[k]).collect(),
                bad: None,
            })
            .collect();
        RawRows {
            bytes: Arc::clone(&self.bytes),
            starts: kept.iter().map(|&k| self.starts[k]).collect(),
            lens: kept.iter().map(|&k| self.lens[k]).collect(),
            untidy,
            fields: self.fields,
            parsed: Mutex::new(parsed),
        }
    }

    /// The columns parsed while reading and not handed over yet.
    fn parsed_fields(&self) -> std::sync::MutexGuard<'_, Vec<ParsedField>> {
        // The lock is only held to look or to take a column out: no panic can leave it torn.
        self.parsed.lock().unwrap_or_else(PoisonError::into_inner)
    }

    /// The cells of `fields` as numbers (NaN where missing), each with the first row whose
    /// cell is not a number. A column parsed while reading is handed over as it is, once (no
    /// copy); any other, or one asked for again, is parsed now, in one pass over the rows on
    /// all cores — the same values either way.
    pub fn parse(&self, fields: &[usize]) -> Vec<(Vec<f64>, Option<usize>)> {
        let taken: Vec<Option<(Vec<f64>, Option<usize>)>> = {
            let mut parsed = self.parsed_fields();
            fields
                .iter()
                .map(|&f| {
                    let at = parsed.iter().position(|p| p.field == f)?;
                    let p = parsed.swap_remove(at);
                    Some((p.values, p.bad))
                })
                .collect()
        };
        let missing: Vec<usize> = fields
            .iter()
            .zip(&taken)
            .filter(|(_, t)| t.is_none())
            .map(|(&f, _)| f)
            .collect();
        let mut fresh = self.parse_now(&missing).into_iter();
        taken
            .into_iter()
            .map(|t| t.unwrap_or_else(|| fresh.next().unwrap_or_default()))
            .collect()
    }

    fn parse_now(&self, fields: &[usize]) -> Vec<(Vec<f64>, Option<usize>)> {
        if fields.is_empty() {
            return Vec::new();
        }
        let n = self.len();
        let mut values: Vec<Vec<f64>> = fields.iter().map(|_| vec![0.0; n]).collect();
        // Visit the fields in file order.
        let mut order: Vec<usize> = (0..fields.len()).collect();
        order.sort_by_key(|&j| fields[j]);
        let blocks: Vec<Vec<&mut [f64]>> = transpose_chunks(&mut values, BLOCK_ROWS);
        let bad: Vec<Vec<Option<usize>>> = blocks
            .into_par_iter()
            .enumerate()
            .map(|(b, mut out)| {
                let first = b * BLOCK_ROWS;
                let mut bad = vec![None; fields.len()];
                for r in 0..out[0].len() {
                    for (j, value) in parse_line(self.line(first + r), fields, &order) {
                        out[j][r] = value.unwrap_or(f64::NAN);
                        if value.is_none() {
                            bad[j].get_or_insert(first + r);
                        }
                    }
                }
                bad
            })
            .collect();
        values
            .into_iter()
            .enumerate()
            .map(|(j, v)| (v, bad.iter().find_map(|b| b[j])))
            .collect()
    }
}

/// Every vector of `columns` cut into chunks of `rows`, regrouped chunk by chunk: element `b`
/// holds chunk `b` of each column.
fn transpose_chunks(columns: &mut [Vec<f64>], rows: usize) -> Vec<Vec<&mut [f64]>> {
    let mut blocks: Vec<Vec<&mut [f64]>> = Vec::new();
    for column in columns.iter_mut() {
        for (b, chunk) in column.chunks_mut(rows).enumerate() {
            if blocks.len() <= b {
                blocks.push(Vec::new());
            }
            blocks[b].push(chunk);
        }
    }
    blocks
}

/// Any other cell, by the general reader's rule ([`parse_cell`]).
fn general(cell: &[u8]) -> Option<f64> {
    parse_cell(std::str::from_utf8(cell).ok()?)
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::error::IoError;
    use crate::table::{format_value, write_with_column, Column, Table};
    use proptest::prelude::*;
    use proptest::strategy::ValueTree;

    fn formatted(v: f64) -> String {
        let mut out = Vec::new();
        format_number(v, &mut zmij::Buffer::new(), &mut out);
        String::from_utf8(out).unwrap()
    }

    fn general_format(v: f64) -> String {
        let mut s = String::new();
        format_value(v, &mut s);
        s
    }

    #[test]
    fn ties_between_shortest_texts_go_the_general_way() {
        for v in [
            f64::from_bits(4_831_456_087_091_820_650),
            581_340_081_208_420.0 + 0.25,
            -2_132_163_508_601_201.0 - 0.25,
        ] {
            assert_eq!(formatted(v), general_format(v), "{v:e}");
        }
    }

    #[test]
    fn numbers_are_formatted_as_the_general_writer_formats_them() {
        for v in [
            0.0,
            -0.0,
            1.0,
            -3.0,
            0.1,
            50_000.0,
            50_030.034_2,
            1e-5,
            9.999_999e-6,
            1e17,
            9.999_999_999_999_998e16,
            1e16,
            123_456_789_012_345_680.0,
            3.334_722e-11,
            1e300,
            -2e300,
            5e-324,
            f64::MAX,
            f64::MIN_POSITIVE,
            0.000_123,
            1e21,
            1e22,
            f64::NAN,
            f64::INFINITY,
        ] {
            assert_eq!(formatted(v), general_format(v), "{v:e}");
        }
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(20_000))]
        #[test]
        fn any_f64_is_formatted_as_the_general_writer_does(bits in any::<u64>()) {
            let v = f64::from_bits(bits);
            prop_assert_eq!(formatted(v), general_format(v));
        }

        #[test]
        fn survey_sized_values_are_formatted_as_the_general_writer_does(
            v in -1e6f64..1e6, scale in -8i32..12,
        ) {
            let v = v * 10f64.powi(scale);
            prop_assert_eq!(formatted(v), general_format(v));
        }

        #[test]
        fn short_binary_fractions_are_formatted_as_the_general_writer_does(
            int in -(1i64 << 53)..(1i64 << 53), shift in 0i32..70,
        ) {
            // Few bits after the point: where two shortest texts can tie.
            let v = int as f64 * 2f64.powi(-shift);
            prop_assert_eq!(formatted(v), general_format(v));
        }

    }

    fn raw(text: &str) -> Option<RawCsv> {
        let all = |headers: &[String]| (0..headers.len()).collect();
        from_bytes(
            Arc::new(Bytes::Owned(text.as_bytes().to_vec())),
            Path::new("t.csv"),
            &all,
        )
    }

    #[test]
    fn what_the_general_reader_must_see_is_refused() {
        for text in [
            "a,b\n1,\"2\"\n",
            "\"a\",b\n1,2\n",
            "a,b\n1,2\r3,4\n",
            "a,b\n1,2\n3\n",
            "a,b\n1,2,3\n",
            "a,b\n1,\u{fffd}\n",
            "a,b",
            "",
            "\na,b\n1,2\n",
            "a,b\r1,2\n",
        ] {
            let refused = match text {
                "a,b\n1,\u{fffd}\n" => raw(text).is_some(),
                _ => raw(text).is_none(),
            };
            assert!(refused, "{text:?}");
        }
        let mut invalid = b"a,b\n1,".to_vec();
        invalid.extend_from_slice(&[0xff, b'\n']);
        let none = |_: &[String]| Vec::new();
        assert!(from_bytes(Arc::new(Bytes::Owned(invalid)), Path::new("t.csv"), &none).is_none());
    }

    #[test]
    fn rows_lines_and_untidy_cells_are_found() {
        let csv = raw("a,b\r\n1,2\r\n\r\n 3 ,4\n\n5,6").unwrap();
        assert_eq!(csv.headers, ["a", "b"]);
        assert_eq!(csv.rows.len(), 3);
        assert_eq!(csv.rows.cell(1, 0), "3");
        assert_eq!(csv.rows.cell(2, 1), "6");
        assert_eq!(csv.rows.untidy, [1]);
        assert_eq!(csv.lines, Some(vec![2, 4, 6]));
        let mut out = Vec::new();
        write_rows(&csv.rows, &[&[0.5, f64::NAN, 7.0]], &mut out).unwrap();
        assert_eq!(String::from_utf8(out).unwrap(), "1,2,0.5\n3,4,\n5,6,7\n");
        let parsed = csv.rows.parse(&[1, 0]);
        assert_eq!(parsed[0].0, [2.0, 4.0, 6.0]);
        assert_eq!(parsed[1].0, [1.0, 3.0, 5.0]);
        let selected = csv.rows.select(&[1, 2]);
        assert_eq!(selected.untidy, [0]);
        assert_eq!(selected.cell(1, 0), "5");
    }

    /// A CSV text of a few columns whose cells, line ends and blank lines are drawn from what
    /// real files hold and what the general reader must handle itself.
    pub(crate) fn csv_text() -> impl Strategy<Value = String> {
        let cell = prop::sample::select(vec![
            "123",
            "-4.5",
            "50030.0342",
            "1e3",
            ".5",
            "7.",
            "+2",
            "",
            "nan",
            "NaN",
            " 12 ",
            "\t3",
            "x7",
            "é",
            "\u{a0}5",
            "5\u{3000}",
            "1,5",
            "\"q\"",
            "0",
            "-0",
            "9007199254740993",
            "1.23456789012345678901",
            "inf",
        ]);
        let row = prop::collection::vec(cell, 1..5);
        let end = prop::sample::select(vec!["\n", "\n", "\r\n", "\n\n", "\r\n\r\n", "\r", "\n \n"]);
        (
            1usize..4,
            prop::collection::vec((row, end), 1..12),
            any::<bool>(),
        )
            .prop_map(|(width, rows, last_newline)| {
                let header: Vec<String> = (0..width).map(|j| format!("c{j}")).collect();
                let mut text = header.join(",") + "\n";
                let count = rows.len();
                for (k, (cells, end)) in rows.into_iter().enumerate() {
                    // Mostly as wide as the header, sometimes not (a ragged line).
                    let cells: Vec<&str> = cells.iter().cycle().take(width).copied().collect();
                    text += &cells.join(",");
                    if k + 1 < count || last_newline {
                        text += end;
                    }
                }
                text
            })
    }

    /// `text` with the digits of every `line N` hidden.
    pub(crate) fn without_line_numbers(text: &str) -> String {
        let mut out = String::new();
        let mut rest = text;
        while let Some(at) = rest.find("line ") {
            out += &rest[..at + 5];
            rest = rest[at + 5..].trim_start_matches(|c: char| c.is_ascii_digit());
            out += "N";
        }
        out + rest
    }

    /// Whether two tables read from the same text are the same. With `lines_comparable` false
    /// their rows' file lines are not compared: the general reader (the `csv` crate's count)
    /// dates rows after a `\r\n` one line early, and a last row without a line break after
    /// blank lines too; this reader counts the line breaks themselves.
    fn assert_same_table(a: &Table, b: &Table, extra: &[f64], lines_comparable: bool) {
        assert_eq!(a.headers(), b.headers());
        assert_eq!(a.len(), b.len());
        if lines_comparable {
            for k in 0..a.len() {
                assert_eq!(a.place_of(k), b.place_of(k), "row {k}");
            }
        }
        let message = |e: IoError| match lines_comparable {
            true => e.to_string(),
            false => without_line_numbers(&e.to_string()),
        };
        for j in 0..a.headers().len() {
            match (&a.columns()[j], &b.columns()[j]) {
                (Column::Text(x), Column::Text(y)) => {
                    for k in 0..a.len() {
                        assert_eq!(x.get(k), y.get(k), "cell {j} {k}");
                    }
                }
                _ => panic!("text columns"),
            }
            let (x, y) = (a.numeric_at(j), b.numeric_at(j));
            match (x, y) {
                (Ok(x), Ok(y)) => {
                    let bits = |v: &[f64]| v.iter().map(|v| v.to_bits()).collect::<Vec<_>>();
                    assert_eq!(bits(&x), bits(&y));
                }
                (Err(x), Err(y)) => assert_eq!(message(x), message(y)),
                (x, y) => panic!("{x:?} vs {y:?}"),
            }
        }
        let extra = vec![("new".to_string(), extra[..a.len()].to_vec())];
        let (mut x, mut y) = (Vec::new(), Vec::new());
        write_with_column(a, &extra, &mut x).unwrap();
        write_with_column(b, &extra, &mut y).unwrap();
        assert_eq!(String::from_utf8(x).unwrap(), String::from_utf8(y).unwrap());
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(3000))]
        #[test]
        fn both_readers_give_the_same_table(
            text in csv_text(),
            extra in prop::collection::vec(prop::num::f64::ANY, 24),
            keep in prop::collection::vec(any::<bool>(), 24),
        ) {
            let raw = Table::csv().bytes(text.as_bytes().to_vec(), "t.csv");
            let general = Table::csv().reader(text.as_bytes(), "t.csv");
            let comparable = !text.contains('\r') && text.ends_with('\n');
            match (raw, general) {
                (Ok(a), Ok(b)) => {
                    assert_same_table(&a, &b, &extra, comparable);
                    let keep = &keep[..a.len()];
                    let (a, b) = (a.select_rows(keep), b.select_rows(keep));
                    if !a.is_empty() {
                        assert_same_table(&a, &b, &extra, comparable);
                    }
                }
                (Err(a), Err(b)) if comparable => prop_assert_eq!(a.to_string(), b.to_string()),
                (Err(a), Err(b)) => prop_assert_eq!(
                    without_line_numbers(&a.to_string()),
                    without_line_numbers(&b.to_string())
                ),
                (a, b) => prop_assert!(false, "{:?} vs {:?}", a.map(|t| t.len()), b.map(|t| t.len())),
            }
        }
    }

    proptest! {
        #[test]
        fn separators_are_every_comma_line_feed_and_carriage_return(
            text in prop::collection::vec(prop::sample::select(b",\n\r1. ".to_vec()), 0..300),
        ) {
            let want: Vec<usize> = (0..text.len())
                .filter(|&i| matches!(text[i], b',' | b'\n' | b'\r'))
                .collect();
            prop_assert_eq!(Separators::new(&text).collect::<Vec<_>>(), want);
        }
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(2000))]
        #[test]
        fn small_pieces_parsed_while_reading_give_what_one_piece_parsed_later_gives(
            text in csv_text(),
            piece_bytes in 1usize..40,
        ) {
            let read = |wanted: Wanted<'_>, piece_bytes| {
                let bytes = Arc::new(Bytes::Owned(text.as_bytes().to_vec()));
                from_bytes_in_pieces(bytes, Path::new("t.csv"), wanted, piece_bytes)
            };
            let all = |headers: &[String]| (0..headers.len()).collect();
            let none = |_: &[String]| Vec::new();
            match (read(&all, piece_bytes), read(&none, PIECE_BYTES)) {
                (Some(a), Some(b)) => {
                    prop_assert_eq!(&a.rows.starts, &b.rows.starts);
                    prop_assert_eq!(&a.rows.lens, &b.rows.lens);
                    prop_assert_eq!(&a.rows.untidy, &b.rows.untidy);
                    prop_assert_eq!(&a.lines, &b.lines);
                    let fields: Vec<usize> = (0..a.headers.len()).collect();
                    prop_assert_eq!(a.rows.parsed_fields().len(), fields.len());
                    let bits = |parsed: Vec<(Vec<f64>, Option<usize>)>| {
                        parsed
                            .into_iter()
                            .map(|(v, bad)| (v.iter().map(|v| v.to_bits()).collect::<Vec<_>>(), bad))
                            .collect::<Vec<_>>()
                    };
                    let handed_over = bits(a.rows.parse(&fields));
                    prop_assert!(a.rows.parsed_fields().is_empty());
                    prop_assert_eq!(&handed_over, &bits(b.rows.parse(&fields)));
                    // Asked again, the columns are parsed anew, to the same values.
                    prop_assert_eq!(&handed_over, &bits(a.rows.parse(&fields)));
                }
                (None, None) => {}
                (a, b) => prop_assert!(false, "{:?} vs {:?}", a.is_some(), b.is_some()),
            }
        }
    }

    #[test]
    fn most_generated_files_are_taken_by_this_reader() {
        // The property above means little if every file went the general way.
        let mut runner = proptest::test_runner::TestRunner::deterministic();
        let (mut taken, mut total) = (0, 0);
        for _ in 0..500 {
            let text = csv_text().new_tree(&mut runner).unwrap().current();
            let none = |_: &[String]| Vec::new();
            let bytes = Arc::new(Bytes::Owned(text.into_bytes()));
            taken += usize::from(from_bytes(bytes, Path::new("t.csv"), &none).is_some());
            total += 1;
        }
        assert!(taken * 5 > total, "{taken} of {total}");
    }

    #[test]
    fn bad_cells_are_reported_at_their_first_row() {
        let csv = raw("a,b\n1,x\n2,3\nq,y\n").unwrap();
        let parsed = csv.rows.parse(&[0, 1]);
        assert_eq!(parsed[0].1, Some(2));
        assert_eq!(parsed[1].1, Some(0));
        assert!(parsed[1].0[0].is_nan());
    }
}
