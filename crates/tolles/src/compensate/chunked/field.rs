//! Each fit's correction `A·β` (nT) a chunk at a time, computed as the whole-file path
//! computes it (`tolles_core::compensate::model_field`), for passes 2 and 3.
//!
//! A chunk waits for the first row of the next one: it is computed with one row of its
//! neighbours on each side, so the central differences at its edges see what they see in the
//! whole flight, and its runs are split where the whole flight's are (an unusable fluxgate, or
//! a time step beyond the whole file's median step times the gap factor). Every row is then the
//! same sum as in the whole flight.

use super::check::ReadyFit;
use super::scan::{FitColumns, Plan, Scan};
use std::ops::Range;
use tolles_core::compensate::model_field_over_runs;
use tolles_core::compensate::trust::outside_over_runs;
use tolles_core::model::vector::{Fluxgates, VectorSeries};
use tolles_core::signal::segment::contiguous_runs_with_step;
use tolles_io::IoError;

/// The corrections of a survey's fits, fed a chunk at a time.
pub(super) struct Fields<'a> {
    plan: &'a Plan,
    fits: &'a [ReadyFit],
    median_step_s: Option<f64>,
    /// The chunk waiting for the next one's first row: the columns of [`Plan::read`].
    held: Option<Vec<Vec<f64>>>,
    /// The last row of the chunk before the held one, per column of [`Plan::read`].
    before: Option<Vec<f64>>,
    /// Per fit, the rows computed so far that lie outside what its calibration flew.
    outside: Vec<usize>,
}

/// A chunk's columns (of [`Plan::read`], those no fit uses empty) and each fit's correction
/// of its rows (nT; NaN where it cannot be computed).
pub(super) struct Computed {
    pub values: Vec<Vec<f64>>,
    pub fields: Vec<Vec<f64>>,
}

impl Computed {
    /// The scalar (nT) of the fit whose columns are `fit` at each row; NaN where the survey
    /// has no such column.
    pub fn scalar<'c>(&'c self, fit: &FitColumns) -> impl Fn(usize) -> f64 + 'c {
        let column = fit.scalar.as_ref().ok().map(|&p| &self.values[p]);
        move |k| column.map_or(f64::NAN, |s| s[k])
    }
}

impl<'a> Fields<'a> {
    pub fn new(plan: &'a Plan, scan: &Scan, fits: &'a [ReadyFit]) -> Self {
        Self {
            plan,
            fits,
            median_step_s: scan.median_step,
            held: None,
            before: None,
            outside: vec![0; fits.len()],
        }
    }

    /// Per fit, the rows computed so far that lie outside what its calibration flew, counted
    /// as the whole-file path counts them.
    pub fn outside(&self) -> &[usize] {
        &self.outside
    }

    /// Takes the next chunk's columns (of [`Plan::read`]; a column no fit uses may be empty,
    /// and is dropped); gives back the chunk before it, computed.
    pub fn push(&mut self, mut values: Vec<Vec<f64>>) -> Option<Computed> {
        if rows_of(&values) == 0 {
            return None;
        }
        let used = self.plan.used();
        for (p, column) in values.iter_mut().enumerate() {
            if used.binary_search(&p).is_err() {
                *column = Vec::new();
            }
        }
        let after = row(&values, 0);
        let held = self.held.replace(values)?;
        Some(self.compute(held, Some(after)))
    }

    /// The last chunk, computed.
    pub fn finish(&mut self) -> Option<Computed> {
        let held = self.held.take()?;
        Some(self.compute(held, None))
    }

    fn compute(&mut self, values: Vec<Vec<f64>>, after: Option<Vec<f64>>) -> Computed {
        let window = Window {
            before: self.before.as_deref(),
            values: &values,
            n: rows_of(&values),
            after: after.as_deref(),
        };
        let tt = self.plan.tt.map(|p| window.column(&Ok(p)));
        let fluxgates: Vec<(VectorSeries, Vec<Range<usize>>)> = (self.plan.fluxgates.iter())
            .map(|(_, axes)| {
                let [x, y, z] = axes.each_ref().map(|a| window.column(a));
                let flux = VectorSeries::new(x, y, z);
                let runs = contiguous_runs_with_step(
                    &Fluxgates::from(&flux).finite_mask(),
                    tt.as_deref(),
                    self.median_step_s,
                );
                (flux, runs)
            })
            .collect();
        let rows = window.rows();
        let fields = self
            .fits
            .iter()
            .map(|fit| {
                let (flux, runs) = &fluxgates[fit.fluxgate];
                let field = model_field_over_runs(flux.into(), runs, fit.model(), fit.fs_ratio);
                field[rows.clone()].to_vec()
            })
            .collect();
        for (count, fit) in self.outside.iter_mut().zip(self.fits) {
            let (flux, runs) = &fluxgates[fit.fluxgate];
            if let Some(coverage) = &fit.coverage {
                let flags = outside_over_runs(flux.into(), runs, coverage, fit.fs_hz);
                *count += flags[rows.clone()].iter().filter(|f| **f).count();
            }
        }
        self.before = Some(row(&values, window.n - 1));
        Computed { values, fields }
    }
}

/// The rows of a chunk's columns (some may be empty).
fn rows_of(values: &[Vec<f64>]) -> usize {
    values.iter().map(Vec::len).max().unwrap_or(0)
}

/// Row `k` of `values`, NaN in a column that is empty.
fn row(values: &[Vec<f64>], k: usize) -> Vec<f64> {
    let cell = |column: &Vec<f64>| column.get(k).copied().unwrap_or(f64::NAN);
    values.iter().map(cell).collect()
}

/// A chunk with the row before it and the row after it, where there are such rows.
struct Window<'w> {
    before: Option<&'w [f64]>,
    values: &'w [Vec<f64>],
    /// Rows of the chunk.
    n: usize,
    after: Option<&'w [f64]>,
}

impl Window<'_> {
    /// The column at `position` of [`Plan::read`] over the window (NaN where it is missing).
    fn column(&self, position: &Result<usize, IoError>) -> Vec<f64> {
        let n = self.n;
        let Ok(&p) = position.as_ref() else {
            return vec![f64::NAN; self.rows().end + usize::from(self.after.is_some())];
        };
        let mut out = Vec::with_capacity(n + 2);
        out.extend(self.before.map(|r| r[p]));
        match self.values[p].len() {
            0 => out.extend(std::iter::repeat_n(f64::NAN, n)),
            _ => out.extend_from_slice(&self.values[p]),
        }
        out.extend(self.after.map(|r| r[p]));
        out
    }

    /// The chunk's rows in the window.
    fn rows(&self) -> Range<usize> {
        let first = usize::from(self.before.is_some());
        first..first + self.n
    }
}
