//! Pass 2: each fit's level, the mean of its correction `A·β` over the file, which the
//! whole-file path keeps in the data.

use super::check::ReadyFit;
use super::field::Fields;
use super::scan::{numbers, temporary, Plan, Scan};
use crate::error::{Error, Result};
use crate::progress::Progress;
use std::path::{Path, PathBuf};
use tolles_core::compensate::chunk::LevelSum;
use tolles_core::fit::scalar_usable;
use tolles_io::chunks::{ChunkReader, SpillReader};
use tolles_io::IoError;

/// An error unless a later pass over `path` met as many `rows` as pass 1 (`expected`).
pub(super) fn same_rows(path: &Path, rows: usize, expected: usize) -> Result<()> {
    if rows != expected {
        return Err(Error::FileChanged {
            path: path.to_path_buf(),
            expected,
            rows,
        });
    }
    Ok(())
}

/// A fit's level, how many rows it cannot compensate and how many lie outside what its
/// calibration flew.
pub(super) struct Level {
    /// The mean of `A·β` over the rows where it is computed (nT); NaN where there are none.
    pub level_nt: f64,
    pub uncomputable: usize,
    pub outside: usize,
}

/// Where pass 2 takes its numbers: what pass 1 kept (text files, so the text is parsed twice,
/// not three times), or the file again (Parquet: only the columns needed are decoded).
pub(super) enum Numbers {
    Spill(SpillReader),
    File(ChunkReader),
}

impl Numbers {
    /// The next chunk of the columns of [`Plan::read`]; a column not used is empty.
    fn next_chunk(&mut self, plan: &Plan) -> Result<Option<Vec<Vec<f64>>>> {
        match self {
            Numbers::Spill(spill) => {
                let Some(used) = spill.next_chunk().map_err(temporary)? else {
                    return Ok(None);
                };
                let mut values = vec![Vec::new(); plan.read.len()];
                for (p, column) in plan.used().into_iter().zip(used) {
                    values[p] = column;
                }
                Ok(Some(values))
            }
            Numbers::File(reader) => {
                // Bad cells can only be in the columns of fits after one that failed, not
                // computed here.
                let mut bad: Vec<Option<IoError>> = (0..plan.read.len()).map(|_| None).collect();
                Ok(reader.next_chunk()?.map(|c| numbers(&c, &mut bad)))
            }
        }
    }

    /// What an error names as the file read.
    fn path(&self) -> PathBuf {
        match self {
            Numbers::Spill(_) => PathBuf::from("temporary file"),
            Numbers::File(reader) => reader.path().to_path_buf(),
        }
    }
}

/// Pass 2: the mean of each fit's correction over the file, summed in file order as the batch
/// mean is, and the count of rows without a result (no correction, or a scalar not usable).
pub(super) fn level(
    mut numbers: Numbers,
    plan: &Plan,
    scan: &Scan,
    fits: &[ReadyFit],
    progress: &dyn Progress,
) -> Result<Vec<Level>> {
    let mut fields = Fields::new(plan, scan, fits);
    let mut sums = vec![LevelSum::default(); fits.len()];
    let mut add = |computed: super::field::Computed| {
        for ((mean, field), columns) in sums.iter_mut().zip(&computed.fields).zip(&plan.fits) {
            let scalar = computed.scalar(columns);
            for (k, &f) in field.iter().enumerate() {
                mean.add(f, scalar_usable(scalar(k)));
            }
        }
    };
    let mut rows = 0;
    while let Some(values) = numbers.next_chunk(plan)? {
        let len = values.iter().map(Vec::len).max().unwrap_or(0);
        progress.advance(len as u64);
        fields.push(values).into_iter().for_each(&mut add);
        rows += len;
    }
    fields.finish().into_iter().for_each(&mut add);
    same_rows(&numbers.path(), rows, scan.rows)?;
    let levels = sums
        .into_iter()
        .zip(fields.outside())
        .map(|(sum, &outside)| Level {
            level_nt: sum.mean(),
            uncomputable: sum.uncomputable,
            outside,
        });
    Ok(levels.collect())
}
