//! Pass 3: every row written with the compensated columns, `scalar − (A·β − level)`.

use super::check::ReadyFit;
use super::field::{Computed, Fields};
use super::level::same_rows;
use super::scan::{Plan, Scan};
use crate::error::{Error, Result};
use crate::progress::Progress;
use std::collections::VecDeque;
use std::io::Write;
use std::path::{Path, PathBuf};
use tolles_core::compensate::compensated_value;
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

/// Pass 3: every row of `reader` with the compensated columns `names` of `fits`, each less its
/// level (nT). Returns per fit the number of empty compensated cells written, and of rows
/// outside what its calibration flew.
pub(super) fn write(
    mut reader: ChunkReader,
    target: Target<'_, '_>,
    (plan, scan): (&Plan, &Scan),
    (fits, levels_nt): (&[ReadyFit], &[f64]),
    names: &[String],
    progress: &dyn Progress,
) -> Result<(Vec<usize>, Vec<usize>)> {
    let mut sink = sink(target, reader.headers(), names)?;
    let mut fields = Fields::new(plan, scan, fits);
    let mut empty = vec![0usize; names.len()];
    let mut out = Out {
        plan,
        levels_nt,
        sink: sink.as_mut(),
        empty: &mut empty,
    };
    // A chunk waits for the rows after it that its computation reads (see `field`).
    let mut waiting: VecDeque<Table> = VecDeque::new();
    let mut rows = 0;
    while let Some(chunk) = reader.next_chunk()? {
        if chunk.is_empty() {
            continue;
        }
        progress.advance(chunk.len() as u64);
        rows += chunk.len();
        let computed = fields.push(numbers_of(&chunk, &plan.read)?);
        waiting.push_back(chunk);
        out.write_computed(&mut waiting, computed)?;
    }
    out.write_computed(&mut waiting, fields.finish())?;
    same_rows(reader.path(), rows, scan.rows)?;
    sink.finish()?;
    Ok((empty, fields.outside().to_vec()))
}

/// Chunks computed, written with their compensated columns.
struct Out<'p, 's> {
    plan: &'p Plan,
    levels_nt: &'p [f64],
    sink: &'s mut dyn ChunkSink,
    /// Per fit, the empty compensated cells written so far.
    empty: &'s mut [usize],
}

impl Out<'_, '_> {
    /// Writes the chunks `computed`, the first ones `waiting`.
    fn write_computed(
        &mut self,
        waiting: &mut VecDeque<Table>,
        computed: Vec<Computed>,
    ) -> Result<()> {
        for computed in computed {
            let chunk = waiting.pop_front().expect("a computed chunk was read");
            self.write(&chunk, computed)?;
        }
        Ok(())
    }

    /// Writes `chunk` with each fit's `scalar − (A·β − level)` (nT), empty where it cannot be
    /// computed, as the whole-file path computes it.
    fn write(&mut self, chunk: &Table, computed: Computed) -> Result<()> {
        let columns = computed
            .fields
            .iter()
            .zip(&self.plan.fits)
            .zip(self.levels_nt);
        let extra: Vec<Vec<f64>> = columns
            .map(|((field, fit), &level)| {
                let scalar = computed.scalar(fit);
                let compensated = field.iter().enumerate();
                compensated
                    .map(|(k, &f)| compensated_value(scalar(k), f - level))
                    .collect()
            })
            .collect();
        for (n, column) in self.empty.iter_mut().zip(&extra) {
            *n += column.iter().filter(|v| !v.is_finite()).count();
        }
        let extra: Vec<&[f64]> = extra.iter().map(Vec::as_slice).collect();
        self.sink.write(chunk, &extra)
    }
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
            let out = Box::new(file.direct_writer()?);
            let mut sink = CsvSink::new(out, Some(path), headers, names)?;
            sink.file = Some(file);
            Box::new(sink)
        }
    })
}

/// The numbers of the columns at `positions` of `chunk`. Pass 1 found every bad cell, so an
/// error here means the file changed since.
fn numbers_of(chunk: &Table, positions: &[usize]) -> Result<Vec<Vec<f64>>> {
    let columns = chunk.numeric_many(positions).into_iter();
    columns.map(|c| Ok(c?)).collect()
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
