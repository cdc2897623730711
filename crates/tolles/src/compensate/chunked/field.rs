//! Each fit's correction `A·β` (nT) a chunk at a time, for passes 2 and 3, by the compensator
//! the whole-file path also uses (`tolles_core::compensate::chunk`), fed one chunk after
//! another: every row gets the bits reading the file whole gives it.
//!
//! A chunk is given back once every fit has computed it: each waits for the rows after it
//! that its central differences, its fluxgate's lag and its extra channels' shifts read.

use super::check::ReadyFit;
use super::scan::{FitColumns, Plan, Scan};
use std::collections::VecDeque;
use tolles_core::compensate::chunk::{ChunkCompensator, ChunkField, RawRows, Setup};
use tolles_io::IoError;

/// The corrections of a survey's fits, fed a chunk at a time.
pub(super) struct Fields<'a> {
    plan: &'a Plan,
    engines: Vec<ChunkCompensator<'a>>,
    /// Chunks pushed and not yet given back: the columns of [`Plan::read`].
    pending: VecDeque<Vec<Vec<f64>>>,
    /// Per fit, the chunks it has computed that not every fit has.
    computed: Vec<VecDeque<ChunkField>>,
    /// Per fit, the rows given back so far that lie outside what its calibration flew.
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
        let engines = fits.iter().zip(&plan.fits).map(|(fit, columns)| {
            ChunkCompensator::new(Setup {
                lag_s: fit.lag_s,
                flux_offset_nt: fit.flux_offset_nt,
                median_step_s: scan.median_step,
                coverage: fit.coverage.as_ref(),
                network: fit.network.as_ref(),
                network_channels: columns.network.len(),
                ..Setup::new(fit.model(), fit.fs_hz, fit.fs_ratio)
            })
        });
        Self {
            plan,
            engines: engines.collect(),
            pending: VecDeque::new(),
            computed: vec![VecDeque::new(); fits.len()],
            outside: vec![0; fits.len()],
        }
    }

    /// Per fit, the rows given back so far that lie outside what its calibration flew, counted
    /// as the whole-file path counts them.
    pub fn outside(&self) -> &[usize] {
        &self.outside
    }

    /// Takes the next chunk's columns (of [`Plan::read`]; a column no fit uses may be empty,
    /// and is dropped); gives back the chunks before it every fit has now computed, in order.
    pub fn push(&mut self, mut values: Vec<Vec<f64>>) -> Vec<Computed> {
        let rows = values.iter().map(Vec::len).max().unwrap_or(0);
        if rows == 0 {
            return Vec::new();
        }
        let used = self.plan.used();
        for (p, column) in values.iter_mut().enumerate() {
            if used.binary_search(&p).is_err() {
                *column = Vec::new();
            }
        }
        let missing = vec![f64::NAN; rows];
        for ((engine, columns), done) in (self.engines.iter_mut())
            .zip(&self.plan.fits)
            .zip(&mut self.computed)
        {
            let raw = raw_rows(self.plan, columns, &values, &missing);
            done.extend(engine.push(raw));
        }
        self.pending.push_back(values);
        self.give_back()
    }

    /// The chunks still held, computed.
    pub fn finish(&mut self) -> Vec<Computed> {
        for (engine, done) in self.engines.iter_mut().zip(&mut self.computed) {
            done.extend(engine.finish());
        }
        self.give_back()
    }

    /// The pending chunks every fit has computed.
    fn give_back(&mut self) -> Vec<Computed> {
        let mut out = Vec::new();
        while !self.pending.is_empty() && self.computed.iter().all(|c| !c.is_empty()) {
            let values = self.pending.pop_front().expect("a chunk is pending");
            let fields = (self.computed.iter_mut())
                .zip(&mut self.outside)
                .map(|(done, outside)| {
                    let chunk = done.pop_front().expect("every fit computed it");
                    *outside += chunk.outside.iter().filter(|f| **f).count();
                    chunk.field
                })
                .collect();
            out.push(Computed { values, fields });
        }
        out
    }
}

/// The raw channels of the fit whose columns are `fit` in a chunk's `values` (`missing`, all
/// NaN, where the survey has no such column or no fit reads it).
fn raw_rows<'v>(
    plan: &Plan,
    fit: &FitColumns,
    values: &'v [Vec<f64>],
    missing: &'v [f64],
) -> RawRows<'v> {
    let column = |position: &Result<usize, IoError>| -> &'v [f64] {
        match position {
            Ok(p) if !values[*p].is_empty() => &values[*p],
            _ => missing,
        }
    };
    let (_, axes) = &plan.fluxgates[fit.fluxgate];
    RawRows {
        flux: vec![axes.each_ref().map(column)],
        extras: fit.extras.iter().map(column).collect(),
        inputs: fit.network.iter().map(column).collect(),
        tt: plan.tt.map(|p| column(&Ok(p))),
    }
}
