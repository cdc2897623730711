//! Pass 3: every row written with the compensated columns, `scalar − (A·β − level)`.

use super::level::{compensator, same_rows, Feed};
use super::scan::{Plan, Scan};
use crate::error::{Error, Result};
use crate::progress::Progress;
use std::io::Write;
use std::path::{Path, PathBuf};
use tolles_core::compensate::stream::{Output, ScalarSpec};
use tolles_io::atomic::AtomicFile;
use tolles_io::chunks::{ChunkReader, CsvChunkWriter, ParquetChunkWriter};
use tolles_io::format::Format;
use tolles_io::table::Table;
use tolles_io::IoError;

/// Where pass 3 writes: the file `out` (CSV or Parquet by extension), or CSV to `writer`.
pub(super) struct Target<'a, 'w> {
    pub out: Option<&'a Path>,
    pub writer: &'w mut dyn Write,
}

/// Pass 3: every row of `reader` with the compensated columns `names` computed by `specs`.
/// Returns per fit the number of empty compensated cells written.
pub(super) fn write(
    mut reader: ChunkReader,
    target: Target<'_, '_>,
    (plan, scan): (&Plan, &Scan),
    specs: Vec<ScalarSpec>,
    names: &[String],
    progress: &dyn Progress,
) -> Result<Vec<usize>> {
    let mut sink = sink(target, reader.headers(), names)?;
    let mut stream = compensator::<usize>(specs, plan);
    let mut feed = Feed::new(plan, scan);
    let mut empty = vec![0usize; names.len()];
    // The chunk before the current one waits for its last row, which the compensator holds
    // back until it sees the next row.
    let mut previous: Option<Pending> = None;
    let mut rows = 0;
    while let Some(chunk) = reader.next_chunk()? {
        progress.advance(chunk.len() as u64);
        let all = numbers_of(&chunk, &plan.read)?;
        let mut current = Pending::new(chunk, rows, names.len());
        for k in 0..current.chunk.len() {
            let gap = feed.load(&all, k);
            let mut emit = |o: Output<'_, usize>| place(o, previous.as_mut(), &mut current);
            if gap {
                stream.split(&mut emit);
            }
            stream.push(rows + k, Some(feed.sample()), Vec::new(), &mut emit);
        }
        rows += current.chunk.len();
        if let Some(done) = previous.take() {
            done.write(sink.as_mut(), &mut empty)?;
        }
        previous = Some(current);
    }
    if let Some(mut last) = previous.take() {
        stream.finish(|o| place(o, None, &mut last));
        last.write(sink.as_mut(), &mut empty)?;
    }
    same_rows(reader.path(), rows, scan.rows)?;
    sink.finish()?;
    Ok(empty)
}

/// The sink for `target`, its header written: the file's `headers`, then `names`.
fn sink<'w>(
    target: Target<'_, 'w>,
    headers: &[String],
    names: &[String],
) -> Result<Box<dyn ChunkSink + 'w>> {
    Ok(match target.out {
        None => Box::new(CsvSink::new(Box::new(target.writer), None, headers, names)?),
        Some(path) if Format::from_path(path) == Format::Parquet => {
            let all: Vec<String> = headers.iter().chain(names).cloned().collect();
            Box::new(ParquetChunkWriter::create(path, &all)?)
        }
        Some(path) => {
            let file = AtomicFile::create(path)?;
            let handle = file.file().try_clone().map_err(|source| IoError::Write {
                path: path.to_path_buf(),
                source,
            })?;
            let out = Box::new(std::io::BufWriter::new(handle));
            let mut sink = CsvSink::new(out, Some(path), headers, names)?;
            sink.file = Some(file);
            Box::new(sink)
        }
    })
}

/// The numbers of the columns at `positions` of `chunk`. Pass 1 found every bad cell, so an
/// error here means the file changed since.
fn numbers_of(chunk: &Table, positions: &[usize]) -> Result<Vec<Vec<f64>>> {
    positions
        .iter()
        .map(|&j| Ok(chunk.numeric_at(j)?))
        .collect()
}

/// A chunk whose compensated values are being filled in.
struct Pending {
    chunk: Table,
    /// Index in the file of the chunk's first row.
    first: usize,
    /// Per fit, the compensated values (nT); NaN until computed, or where they cannot be.
    extra: Vec<Vec<f64>>,
}

impl Pending {
    fn new(chunk: Table, first: usize, fits: usize) -> Self {
        let extra = vec![vec![f64::NAN; chunk.len()]; fits];
        Self {
            chunk,
            first,
            extra,
        }
    }

    /// Writes the chunk, adding its empty cells per fit to `empty`.
    fn write(self, sink: &mut dyn ChunkSink, empty: &mut [usize]) -> Result<()> {
        for (n, column) in empty.iter_mut().zip(&self.extra) {
            *n += column.iter().filter(|v| !v.is_finite()).count();
        }
        let extra: Vec<&[f64]> = self.extra.iter().map(Vec::as_slice).collect();
        sink.write(&self.chunk, &extra)
    }
}

/// Puts an emitted result into the chunk its row belongs to: `current`, or the one before.
fn place(o: Output<'_, usize>, previous: Option<&mut Pending>, current: &mut Pending) {
    let target = match previous {
        Some(p) if o.payload < current.first => p,
        _ => current,
    };
    let row = o.payload - target.first;
    for (column, v) in target.extra.iter_mut().zip(o.compensated) {
        column[row] = *v;
    }
}

/// Where pass 3 writes.
trait ChunkSink {
    fn write(&mut self, chunk: &Table, extra: &[&[f64]]) -> Result<()>;
    fn finish(self: Box<Self>) -> Result<()>;
}

struct CsvSink<'w> {
    writer: CsvChunkWriter<Box<dyn Write + 'w>>,
    /// The file written, or `None` for the caller's writer.
    path: Option<PathBuf>,
    /// What is renamed over `path` once every row is written, so a failure leaves it as it was.
    file: Option<AtomicFile>,
}

impl<'w> CsvSink<'w> {
    /// Writes the header to `out`, which is the file `path` if one is given.
    fn new(
        out: Box<dyn Write + 'w>,
        path: Option<&Path>,
        headers: &[String],
        names: &[String],
    ) -> Result<Self> {
        let path = path.map(Path::to_path_buf);
        let writer = CsvChunkWriter::new(out, headers, names).map_err(|e| fail(&path, e))?;
        Ok(Self {
            writer,
            path,
            file: None,
        })
    }
}

/// A write error, naming the file or, for the caller's writer, saying what was written (as
/// the whole-file path does).
fn fail(path: &Option<PathBuf>, source: std::io::Error) -> Error {
    match path {
        Some(path) => IoError::Write {
            path: path.clone(),
            source,
        }
        .into(),
        None => Error::Write {
            what: "writing the compensated data".to_string(),
            source,
        },
    }
}

impl ChunkSink for CsvSink<'_> {
    fn write(&mut self, chunk: &Table, extra: &[&[f64]]) -> Result<()> {
        self.writer
            .write(chunk, extra)
            .map_err(|e| fail(&self.path, e))
    }

    fn finish(self: Box<Self>) -> Result<()> {
        let path = self.path;
        let mut out = self.writer.finish().map_err(|e| fail(&path, e))?;
        out.flush().map_err(|e| fail(&path, e))?;
        match self.file {
            Some(file) => Ok(file.commit()?),
            None => Ok(()),
        }
    }
}

impl ChunkSink for ParquetChunkWriter {
    fn write(&mut self, chunk: &Table, extra: &[&[f64]]) -> Result<()> {
        Ok(ParquetChunkWriter::write(self, chunk, extra)?)
    }

    fn finish(self: Box<Self>) -> Result<()> {
        Ok(ParquetChunkWriter::finish(*self)?)
    }
}
