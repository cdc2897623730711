//! A CSV file read a block of whole lines at a time, for [`crate::rawcsv`] to take: the cells a
//! pass needs are parsed on all cores straight from the block's bytes, and its rows are written
//! back by copying them, as when the file is read whole. A block holds at most the rows of a
//! chunk and at most [`MAX_BLOCK_BYTES`] (unless one line is longer), so memory stays bounded.

use super::open_error;
use crate::error::IoError;
use crate::header::MAX_HEADER_BYTES;
use crate::rawcsv::{body_rows, header_line_names, Bytes, RawRows};
use std::fs::File;
use std::io::Read;
use std::path::Path;
use std::sync::Arc;

/// Most bytes in a block, unless its one line is longer: a chunk of a wide file ends here
/// rather than at its number of rows.
const MAX_BLOCK_BYTES: usize = 1 << 20;

/// Bytes asked of the file at a time.
const READ_BYTES: usize = 1 << 18;

/// The data lines of a CSV file, a block at a time.
pub(super) struct Blocks {
    file: File,
    /// [`MAX_BLOCK_BYTES`], but in tests.
    max_bytes: usize,
    /// Bytes read and not handed out yet, from the start of a line.
    pending: Vec<u8>,
    /// Where the line feeds of `pending` have been counted to, how many there were, and the end
    /// of the last whole line counted.
    counted: usize,
    feeds: usize,
    whole: usize,
    /// The file line of the first byte of `pending`.
    line: u64,
    /// Whether the file has been read to its end.
    ended: bool,
}

/// Whole lines of a file.
pub(super) struct Block {
    bytes: Vec<u8>,
    /// The file line of the first byte (1-based).
    first_line: u64,
}

impl Block {
    /// The block's rows (of `width` cells), the cells `fields` parsed, with the file line of each
    /// row; `None` when the general reader must take them.
    pub fn rows(self, width: usize, fields: &[usize]) -> Option<(RawRows, Vec<u64>)> {
        let first = self.first_line;
        let (rows, lines) = body_rows(Arc::new(Bytes::Owned(self.bytes)), width, fields, first)?;
        let lines = lines.unwrap_or_else(|| (first..).take(rows.len()).collect());
        Some((rows, lines))
    }
}

impl Blocks {
    /// `path` opened past its header line, when [`crate::rawcsv`] takes that line and finds in
    /// it the `headers` the general reader found; `None` when the general reader must read on.
    pub fn open(path: &Path, headers: &[String]) -> Result<Option<Self>, IoError> {
        let mut file = File::open(path).map_err(|source| open_error(path, source))?;
        let mut pending = Vec::new();
        let mut start = 0;
        let header_end = loop {
            if let Some(i) = memchr::memchr(b'\n', &pending[start..]) {
                break start + i;
            }
            start = pending.len();
            if start > MAX_HEADER_BYTES
                || fill(&mut file, &mut pending).map_err(|e| open_error(path, e))? == 0
            {
                return Ok(None);
            }
        };
        if header_line_names(&pending[..=header_end]).as_deref() != Some(headers) {
            return Ok(None);
        }
        pending.drain(..=header_end);
        Ok(Some(Self {
            file,
            max_bytes: MAX_BLOCK_BYTES,
            pending,
            counted: 0,
            feeds: 0,
            whole: 0,
            line: 2,
            ended: false,
        }))
    }

    /// The next block: whole lines (the file's last may have no line feed), at most `rows` of
    /// them and at most [`MAX_BLOCK_BYTES`] unless its one line is longer; `None` after the
    /// last line.
    pub fn next(&mut self, rows: usize) -> std::io::Result<Option<Block>> {
        let end = loop {
            if let Some(end) = self.line_end(rows.max(1)) {
                break end;
            }
            if self.ended || fill(&mut self.file, &mut self.pending)? == 0 {
                self.ended = true;
                break self.last_end();
            }
        };
        if end == 0 {
            return Ok(None);
        }
        let rest = self.pending.split_off(end);
        let bytes = std::mem::replace(&mut self.pending, rest);
        let first_line = self.line;
        // Every line feed up to the block's end was counted, and none after it.
        self.line += self.feeds as u64;
        (self.counted, self.feeds, self.whole) = (0, 0, 0);
        Ok(Some(Block { bytes, first_line }))
    }

    /// Where the block ends in `pending` if it can end now: after its `rows`-th line feed, or
    /// after its last whole line within [`MAX_BLOCK_BYTES`] once a line goes beyond them (after
    /// that line if it is the first).
    fn line_end(&mut self, rows: usize) -> Option<usize> {
        let from = self.counted;
        for i in memchr::memchr_iter(b'\n', &self.pending[from..]) {
            let at = from + i + 1;
            if at > self.max_bytes && self.whole > 0 {
                return Some(self.whole);
            }
            (self.whole, self.feeds) = (at, self.feeds + 1);
            if self.feeds == rows || at >= self.max_bytes {
                return Some(at);
            }
        }
        self.counted = self.pending.len();
        None
    }

    /// Where the block ends at the end of the file: its end, or its last whole line within
    /// [`MAX_BLOCK_BYTES`] if the unterminated line after it goes beyond them.
    fn last_end(&self) -> usize {
        match self.pending.len() > self.max_bytes && self.whole > 0 {
            true => self.whole,
            false => self.pending.len(),
        }
    }
}

/// Appends up to [`READ_BYTES`] of `file` to `buffer`; how many (0 at the end of the file).
fn fill(file: &mut File, buffer: &mut Vec<u8>) -> std::io::Result<usize> {
    let old = buffer.len();
    buffer.resize(old + READ_BYTES, 0);
    let n = loop {
        match file.read(&mut buffer[old..]) {
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => continue,
            other => break other,
        }
    };
    buffer.truncate(old + n.as_ref().copied().unwrap_or(0));
    n
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(500))]
        #[test]
        fn blocks_are_whole_lines_in_order_within_their_limits(
            lines in prop::collection::vec((0usize..40, prop::sample::select(vec!["\n", "\r\n", "\n\n"])), 0..60),
            last_newline in any::<bool>(),
            rows in 1usize..9,
            max_bytes in 1usize..120,
        ) {
            let mut body = String::new();
            for (k, (len, end)) in lines.iter().enumerate() {
                body += &"7".repeat(*len);
                if k + 1 < lines.len() || last_newline {
                    body += end;
                }
            }
            let dir = tempfile::tempdir().unwrap();
            let path = dir.path().join("f.csv");
            std::fs::write(&path, format!("a\n{body}")).unwrap();
            let mut blocks = Blocks::open(&path, &["a".to_string()]).unwrap().unwrap();
            blocks.max_bytes = max_bytes;
            let (mut joined, mut line) = (Vec::new(), 2u64);
            while let Some(block) = blocks.next(rows).unwrap() {
                let feeds = memchr::memchr_iter(b'\n', &block.bytes).count();
                prop_assert_eq!(block.first_line, line);
                prop_assert!(!block.bytes.is_empty());
                prop_assert!(feeds <= rows);
                let last = joined.len() + block.bytes.len() == body.len();
                // Whole lines: a block ends at a line feed, but the file's unterminated last line.
                prop_assert!(block.bytes.ends_with(b"\n") || last);
                // Beyond the limit only when it is one line.
                let lines = feeds + usize::from(!block.bytes.ends_with(b"\n"));
                prop_assert!(block.bytes.len() <= max_bytes || lines == 1);
                line += feeds as u64;
                joined.extend_from_slice(&block.bytes);
            }
            prop_assert_eq!(String::from_utf8(joined).unwrap(), body);
        }
    }

    #[test]
    fn a_header_the_general_reader_must_take_is_left_to_it() {
        let dir = tempfile::tempdir().unwrap();
        for (text, names) in [
            ("\"a\",b\n1,2\n", ["a", "b"]),
            ("a\rb,c\n1,2\n", ["a\rb", "c"]),
            ("a,b\n1,2\n", ["a", "x"]),
        ] {
            let path = dir.path().join("h.csv");
            std::fs::write(&path, text).unwrap();
            let headers = names.map(String::from);
            assert!(Blocks::open(&path, &headers).unwrap().is_none(), "{text:?}");
        }
        let path = dir.path().join("ok.csv");
        std::fs::write(&path, " a ,b\r\n1,2\n").unwrap();
        let blocks = Blocks::open(&path, &["a".into(), "b".into()]).unwrap();
        assert_eq!(blocks.unwrap().pending, b"1,2\n");
    }
}
