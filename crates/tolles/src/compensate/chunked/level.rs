//! Pass 2: each fit's level, the mean of its correction `A·β` over the file, which the
//! whole-file path keeps in the data; and what passes 2 and 3 share, feeding the streaming
//! compensator with runs split where the batch computation splits them.

use super::check::ReadyFit;
use super::scan::{numbers, temporary, Plan, Scan};
use crate::error::{Error, Result};
use crate::progress::Progress;
use std::path::{Path, PathBuf};
use tolles_core::compensate::stream::{Derivative, Output, Sample, ScalarSpec, StreamCompensator};
use tolles_core::fit::scalar_usable;
use tolles_core::signal::segment::GAP_FACTOR;
use tolles_io::chunks::{ChunkReader, SpillReader};
use tolles_io::IoError;

/// The numbers one pass feeds the compensator, a row at a time, and whether a time gap comes
/// before the row.
pub(super) struct Feed<'a> {
    plan: &'a Plan,
    /// Gap threshold (s): [`GAP_FACTOR`] median steps, as the batch runs use.
    gap_s: Option<f64>,
    /// The time of the row before (s).
    previous_t: f64,
    /// The row's scalars (nT), one per fit.
    pub scalars: Vec<f64>,
    /// The row's fluxgates (nT), one per distinct fluxgate.
    flux: Vec<[f64; 3]>,
}

impl<'a> Feed<'a> {
    pub fn new(plan: &'a Plan, scan: &Scan) -> Self {
        Self {
            plan,
            gap_s: scan.median_step.map(|step| GAP_FACTOR * step),
            previous_t: f64::NAN,
            scalars: vec![0.0; plan.fits.len()],
            flux: vec![[f64::NAN; 3]; plan.fluxgates.len()],
        }
    }

    /// Loads row `k` of `values` (the columns of [`Plan::read`]); true when a time gap comes
    /// before it.
    pub fn load(&mut self, values: &[Vec<f64>], k: usize) -> bool {
        let at = |position: &Result<usize, IoError>| match position {
            Ok(p) => values[*p][k],
            Err(_) => f64::NAN,
        };
        for (flux, (_, axes)) in self.flux.iter_mut().zip(&self.plan.fluxgates) {
            *flux = [0, 1, 2].map(|a| at(&axes[a]));
        }
        for (scalar, fit) in self.scalars.iter_mut().zip(&self.plan.fits) {
            *scalar = at(&fit.scalar);
        }
        let Some(p) = self.plan.tt else { return false };
        let t = values[p][k];
        let dt = t - self.previous_t;
        self.previous_t = t;
        self.gap_s.is_some_and(|gap| dt.is_finite() && dt > gap)
    }

    pub fn sample(&self) -> Sample<'_> {
        Sample {
            time_s: None,
            scalars: &self.scalars,
            fluxgates: &self.flux,
            extras: &[],
        }
    }
}

/// A streaming compensator of `specs` over the fluxgates of `plan`, which the caller splits
/// into runs.
pub(super) fn compensator<T>(specs: Vec<ScalarSpec>, plan: &Plan) -> StreamCompensator<T> {
    let names = plan.fluxgates.iter().map(|(v, _)| v.clone()).collect();
    // No times are fed (runs are split by the caller), so the rate here sets nothing.
    StreamCompensator::new(specs, names, 1.0, Derivative::Central)
}

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

/// A fit's level and how many rows it cannot compensate.
pub(super) struct Level {
    /// The mean of `A·β` over the rows where it is computed (nT); NaN where there are none.
    pub level_nt: f64,
    pub uncomputable: usize,
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
/// mean is. The compensator is fed a scalar of 0, which makes its output exactly −A·β; each
/// row carries whether its scalars are finite, for the count of rows without a result.
pub(super) fn level(
    mut numbers: Numbers,
    plan: &Plan,
    scan: &Scan,
    fits: &[ReadyFit],
    progress: &dyn Progress,
) -> Result<Vec<Level>> {
    let specs = fits.iter().map(|f| f.spec(0.0)).collect();
    let mut stream = compensator::<Vec<bool>>(specs, plan);
    let mut sums = vec![Mean::default(); fits.len()];
    let mut emit = |o: Output<'_, Vec<bool>>| {
        for ((mean, v), scalar_finite) in sums.iter_mut().zip(o.compensated).zip(&o.payload) {
            mean.add(-v, *scalar_finite);
        }
    };
    let mut feed = Feed::new(plan, scan);
    let mut rows = 0;
    while let Some(values) = numbers.next_chunk(plan)? {
        let len = values.first().map_or(0, Vec::len);
        progress.advance(len as u64);
        for k in 0..len {
            if feed.load(&values, k) {
                stream.split(&mut emit);
            }
            let scalar_finite = feed.scalars.iter().map(|s| scalar_usable(*s)).collect();
            feed.scalars.iter_mut().for_each(|s| *s = 0.0);
            stream.push(scalar_finite, Some(feed.sample()), Vec::new(), &mut emit);
        }
        rows += len;
    }
    stream.finish(&mut emit);
    same_rows(&numbers.path(), rows, scan.rows)?;
    Ok(sums.into_iter().map(Mean::level).collect())
}

/// The running mean of one fit's `A·β` (nT) and its count of rows without a result.
#[derive(Clone, Default)]
struct Mean {
    sum: f64,
    n: usize,
    empty: usize,
}

impl Mean {
    /// Adds a row's `A·β` (nT), whose scalar is finite or not.
    fn add(&mut self, field: f64, scalar_finite: bool) {
        if field.is_finite() {
            self.sum += field;
            self.n += 1;
        }
        if !(field.is_finite() && scalar_finite) {
            self.empty += 1;
        }
    }

    fn level(self) -> Level {
        Level {
            level_nt: if self.n == 0 {
                f64::NAN
            } else {
                self.sum / self.n as f64
            },
            uncomputable: self.empty,
        }
    }
}
