//! The Tolles-Lawson design matrix: one row per sample, one column per term.
//!
//! ```
//! use tolles_core::model::design::{Design, TermSet};
//! use tolles_core::model::vector::VectorSeries;
//!
//! let flux = VectorSeries::new(vec![30_000.0; 3], vec![0.0; 3], vec![40_000.0; 3]);
//! let a = Design::new(TermSet::magnav_default()).matrix(&flux);
//! assert!((a[(0, 0)] - 0.6).abs() < 1e-15); // B̂x = 30000 / 50000
//! assert!((a[(0, 3)] - 0.6 * 30_000.0 / 50_000.0).abs() < 1e-15); // B̂x·Bx / Bt_scale
//! ```
//!
//! With B the fluxgate vector (nT, body frame), B̂ = B/|B|, Ḃ its central difference per sample
//! (one-sided at the ends) and s = `bt_scale`:
//! - permanent field: `B̂x, B̂y, B̂z` — the projection of a constant body-frame field on the
//!   earth field direction;
//! - induced field: `B̂i·Bj / s` — the projection of a field proportional to the earth field;
//! - **eddy currents**: `B̂i·Ḃj / s` — the projection of a field proportional to the earth
//!   field's rate of change as the aircraft turns (see [`Design::row`]);
//! - bias: `1`.
//!
//! The column order is MagNav.jl's `create_TL_A` (see [`crate::model::terms`]).

use crate::model::extra::ExtraChannel;
pub use crate::model::terms::TermSet;
use crate::model::terms::{Axis, Column};
use crate::model::vector::{norms3_into, Fluxgates};
use crate::parallel::{blocks, split_rows};
use multiversion::multiversion;
use nalgebra::DMatrix;
use serde::{Deserialize, Serialize};
use std::ops::Range;

/// MagNav.jl's scale for the induced and eddy columns (nT), so they are of order one.
pub const MAGNAV_BT_SCALE: f64 = 50_000.0;

/// Builds Tolles-Lawson design rows for a chosen [`TermSet`], over one or more fluxgates.
///
/// With several fluxgates each adds its own block of the chosen columns, computed from its own
/// readings, in the order the fluxgates are given; the bias column, if chosen, appears once, in
/// the first block. A fluxgate near a source of interference (a cable, a motor) sees that source,
/// so its block lets the scalar's interference from that source be fitted too.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Design {
    /// The terms, and so the columns of each fluxgate's block.
    pub terms: TermSet,
    /// Divisor of the induced and eddy columns (nT); MagNav uses 50 000.
    pub bt_scale: f64,
    /// Number of fluxgates whose blocks the design holds.
    #[serde(default = "one", skip_serializing_if = "is_one")]
    pub fluxgates: usize,
    /// Extra channels (e.g. currents) that each add the columns `B̂x·c, B̂y·c, B̂z·c` with the
    /// first fluxgate's B̂, in this order; the data passes them with
    /// [`Fluxgates::with_extras`](crate::model::vector::Fluxgates::with_extras), each already
    /// conditioned as its [`ExtraChannel`] says ([`ExtraChannel::condition`]).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub extras: Vec<ExtraChannel>,
}

fn one() -> usize {
    1
}

fn is_one(n: &usize) -> bool {
    *n == 1
}

/// One design column: a [`Column`] of the block of fluxgate `fluxgate` (0-based).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct Term {
    /// Index of the fluxgate whose readings the column is built from.
    pub fluxgate: usize,
    /// The column.
    pub column: Column,
}

impl Design {
    /// A one-fluxgate design with MagNav's `Bt_scale` of 50 000 nT.
    pub fn new(terms: TermSet) -> Self {
        Self {
            terms,
            bt_scale: MAGNAV_BT_SCALE,
            fluxgates: 1,
            extras: Vec::new(),
        }
    }

    /// The same design with the extra channels `extras` (in the data's order).
    pub fn with_extras(self, extras: Vec<ExtraChannel>) -> Self {
        Self { extras, ..self }
    }

    /// The same terms over `fluxgates` fluxgates.
    pub fn with_fluxgates(self, fluxgates: usize) -> Self {
        Self { fluxgates, ..self }
    }

    /// The columns, in order (blocks after the first without the bias).
    pub fn columns(&self) -> Vec<Column> {
        self.design_terms().into_iter().map(|t| t.column).collect()
    }

    /// The columns with the fluxgate each belongs to, in order: the fluxgates' blocks, then
    /// three columns per extra channel.
    pub fn design_terms(&self) -> Vec<Term> {
        let block = self.terms.columns();
        let mut terms: Vec<Term> = (0..self.fluxgates)
            .flat_map(|fluxgate| {
                block
                    .iter()
                    .filter(move |c| fluxgate == 0 || **c != Column::Bias)
                    .map(move |&column| Term { fluxgate, column })
            })
            .collect();
        for channel in 0..self.extras.len() {
            terms.extend(Axis::ALL.map(|axis| Term {
                fluxgate: 0,
                column: Column::Extra { channel, axis },
            }));
        }
        terms
    }

    /// Column names: `perm_x`, … for one fluxgate; `NAME.perm_x`, … with several, NAME from
    /// `fluxgate_names` (or `fluxgate1`, `fluxgate2`, … when it does not name them all).
    pub fn column_names(&self, fluxgate_names: &[String]) -> Vec<String> {
        self.design_terms()
            .iter()
            .map(|t| {
                if let Column::Extra { channel, axis } = t.column {
                    format!(
                        "{}_{}",
                        self.extras[channel].name,
                        ["x", "y", "z"][axis.index()]
                    )
                } else if self.fluxgates == 1 {
                    t.column.to_string()
                } else if fluxgate_names.len() == self.fluxgates {
                    format!("{}.{}", fluxgate_names[t.fluxgate], t.column)
                } else {
                    format!("fluxgate{}.{}", t.fluxgate + 1, t.column)
                }
            })
            .collect()
    }

    /// Number of columns.
    pub fn width(&self) -> usize {
        self.design_terms().len()
    }

    /// Writes the one-fluxgate design row for field `b` (nT) and its change per sample `db`
    /// (nT/sample) into `out`, one value per entry of `columns`.
    ///
    /// The eddy-current columns are here: `B̂i·Ḃj / s`.
    pub fn row(&self, columns: &[Column], b: [f64; 3], db: [f64; 3], out: &mut [f64]) {
        self.row_with_extras(columns, b, db, &[], out);
    }

    /// [`Design::row`] with the extra channels' values `extras` (conditioned, in design order);
    /// an extra column without its value is NaN.
    pub fn row_with_extras(
        &self,
        columns: &[Column],
        b: [f64; 3],
        db: [f64; 3],
        extras: &[f64],
        out: &mut [f64],
    ) {
        let unit = unit_vector(b);
        for (value, column) in out.iter_mut().zip(columns) {
            *value = self.value(*column, unit, b, db, extras);
        }
    }

    fn value(
        &self,
        column: Column,
        unit: [f64; 3],
        b: [f64; 3],
        db: [f64; 3],
        extras: &[f64],
    ) -> f64 {
        let s = self.bt_scale;
        match column {
            Column::Permanent(i) => unit[i.index()],
            Column::Induced(i, j) => unit[i.index()] * b[j.index()] / s,
            Column::Eddy(i, j) => unit[i.index()] * db[j.index()] / s,
            Column::InducedTraceless(a) => traceless(unit, b, a.index()) / s,
            Column::EddyTraceless(a) => traceless(unit, db, a.index()) / s,
            Column::InducedTrace => trace(unit, b) / s,
            Column::Extra { channel, axis } => extras
                .get(channel)
                .map_or(f64::NAN, |v| unit[axis.index()] * v),
            Column::Bias => 1.0,
        }
    }

    /// The design matrix of one contiguous series (rows = samples), with the columns `terms`
    /// (usually [`Design::design_terms`]).
    ///
    /// Built column by column (the matrix is column-major), with the same arithmetic as
    /// [`Design::row`], so every entry is bit-for-bit what `row` gives.
    ///
    /// # Panics
    /// If `terms` names a fluxgate that `flux` does not have: a programming error.
    pub fn matrix_of<'a>(&self, flux: impl Into<Fluxgates<'a>>, terms: &[Term]) -> DMatrix<f64> {
        let flux = flux.into();
        let mut a = DMatrix::zeros(flux.len(), terms.len());
        self.matrix_into(flux, terms, a.as_mut_slice());
        a
    }

    /// [`Design::matrix_of`] written column after column into `out` (`terms.len()` columns of
    /// one value per sample), so a caller can build it where it will be filtered.
    ///
    /// # Panics
    /// If `out` is shorter than the matrix, or `terms` names a fluxgate that `flux` does not
    /// have: programming errors.
    pub fn matrix_into<'a>(&self, flux: impl Into<Fluxgates<'a>>, terms: &[Term], out: &mut [f64]) {
        let flux = flux.into();
        let n = flux.len();
        self.matrix_over(flux, 0..n, terms, out);
    }

    /// [`Design::matrix_into`] of the samples `span` of `flux`, taken as a series of their own
    /// (changes one-sided at its ends), without copying them: `out` holds `span.len()` values
    /// per column.
    ///
    /// Built by blocks of samples on all cores, each entry with the arithmetic of
    /// [`Design::row`]; no column of derived values (unit vector, changes) as long as the
    /// series is ever stored.
    ///
    /// # Panics
    /// If `span` is not within `flux`, `out` is shorter than the matrix, or `terms` names a
    /// fluxgate that `flux` does not have: programming errors.
    pub fn matrix_over<'a>(
        &self,
        flux: impl Into<Fluxgates<'a>>,
        span: Range<usize>,
        terms: &[Term],
        out: &mut [f64],
    ) {
        let rows = 0..span.len();
        self.matrix_rows_over(flux, span, rows, terms, out);
    }

    /// The rows `rows` (samples of the span, counted from its start) of
    /// [`Design::matrix_over`], the same values: `out` holds `rows.len()` values per column.
    ///
    /// # Panics
    /// As [`Design::matrix_over`], or if `rows` is not within the span.
    pub fn matrix_rows_over<'a>(
        &self,
        flux: impl Into<Fluxgates<'a>>,
        span: Range<usize>,
        rows: Range<usize>,
        terms: &[Term],
        out: &mut [f64],
    ) {
        let mut columns: Vec<&mut [f64]> = out
            .chunks_exact_mut(rows.len().max(1))
            .take(terms.len())
            .collect();
        self.matrix_rows_into_columns(flux, span, rows, terms, &mut columns);
    }

    /// [`Design::matrix_rows_over`] into one slice per column (of `terms`), each
    /// `rows.len()` long.
    ///
    /// # Panics
    /// As [`Design::matrix_rows_over`].
    pub fn matrix_rows_into_columns<'a>(
        &self,
        flux: impl Into<Fluxgates<'a>>,
        span: Range<usize>,
        rows: Range<usize>,
        terms: &[Term],
        columns: &mut [&mut [f64]],
    ) {
        let inputs = Spans::new(&flux.into(), span);
        inputs.by_blocks(rows, columns, |components, rows, columns| {
            for (column, term) in columns.iter_mut().zip(terms) {
                self.write_column(components, &inputs.extras, rows.clone(), *term, column);
            }
        });
    }

    /// Writes the column of `term` for the samples `rows` (of `components`' block) into `out`.
    fn write_column(
        &self,
        components: &[Components],
        extras: &[&[f64]],
        rows: Range<usize>,
        term: Term,
        out: &mut [f64],
    ) {
        let c = &components[term.fluxgate];
        column_into(self.bt_scale, c, extras, rows, term.column, out);
    }

    /// The design matrix of one contiguous series (rows = samples), all columns.
    ///
    /// # Panics
    /// If `flux` holds fewer fluxgates than the design: a programming error.
    pub fn matrix<'a>(&self, flux: impl Into<Fluxgates<'a>>) -> DMatrix<f64> {
        self.matrix_of(flux, &self.design_terms())
    }

    /// `A·β` for one contiguous series, without storing `A` (nT).
    ///
    /// # Panics
    /// If `coefficients` is not [`Design::width`] long or `flux` holds fewer fluxgates than the
    /// design: programming errors.
    pub fn apply<'a>(&self, flux: impl Into<Fluxgates<'a>>, coefficients: &[f64]) -> Vec<f64> {
        let flux = flux.into();
        let n = flux.len();
        self.apply_over(flux, 0..n, coefficients)
    }

    /// [`Design::apply`] to the samples `span` of `flux`, taken as a series of their own
    /// (changes one-sided at its ends), without copying them (nT, one value per sample of
    /// `span`). By blocks of samples on all cores.
    ///
    /// # Panics
    /// If `span` is not within `flux`, `coefficients` is not [`Design::width`] long or `flux`
    /// holds fewer fluxgates than the design: programming errors.
    pub fn apply_over<'a>(
        &self,
        flux: impl Into<Fluxgates<'a>>,
        span: Range<usize>,
        coefficients: &[f64],
    ) -> Vec<f64> {
        let mut out = vec![0.0; span.len()];
        self.apply_over_into(flux, span, coefficients, &mut out);
        out
    }

    /// [`Design::apply_over`] written into `out` (nT, one value per sample of `span`), which
    /// is only written, never read.
    ///
    /// # Panics
    /// As [`Design::apply_over`], and if `out` is not as long as `span`.
    pub fn apply_over_into<'a>(
        &self,
        flux: impl Into<Fluxgates<'a>>,
        span: Range<usize>,
        coefficients: &[f64],
        out: &mut [f64],
    ) {
        let terms = self.design_terms();
        assert_eq!(
            terms.len(),
            coefficients.len(),
            "one coefficient per column"
        );
        assert_eq!(out.len(), span.len(), "one output per sample of the span");
        let inputs = Spans::new(&flux.into(), span);
        inputs.by_blocks(0..inputs.len, &mut [out], |components, rows, out| {
            // Each term's column is written, then added times its coefficient: per sample the
            // sum of `Design::row`'s values times β in column order, as `A·β` row by row.
            let mut column = vec![0.0; rows.len()];
            for (index, (term, &beta)) in terms.iter().zip(coefficients).enumerate() {
                self.write_column(components, &inputs.extras, rows.clone(), *term, &mut column);
                let out = out[0].iter_mut().zip(&column);
                if index == 0 {
                    // The sum starts from 0 as before, but the output is written before it is
                    // read: a fresh page read first is mapped to the zero page, and the write
                    // after it costs a second fault and a TLB flush on every core.
                    out.for_each(|(o, v)| *o = 0.0 + v * beta);
                } else {
                    out.for_each(|(o, v)| *o += v * beta);
                }
            }
        });
    }
}

/// [`Design::write_column`]'s work: the column `column` of one fluxgate's block `c` (rows
/// `rows`, for the extra channels) into `out`, with Bt scale `s` (nT).
///
/// Compiled also for AVX2 and AVX-512 and chosen at run time, like the filters' lanes (the
/// crate's baseline, SSE2, does two divisions at a time); the same operations on every path,
/// so the same bits.
#[multiversion(targets("x86_64+avx512f", "x86_64+avx2"))]
fn column_into(
    s: f64,
    c: &Components,
    extras: &[&[f64]],
    rows: Range<usize>,
    column: Column,
    out: &mut [f64],
) {
    let scaled = |out: &mut [f64], u: &[f64], v: &[f64]| {
        for ((o, u), v) in out.iter_mut().zip(u).zip(v) {
            *o = u * v / s;
        }
    };
    match column {
        Column::Permanent(i) => out.copy_from_slice(&c.unit[i.index()]),
        Column::Induced(i, j) => scaled(out, &c.unit[i.index()], c.b[j.index()]),
        Column::Eddy(i, j) => scaled(out, &c.unit[i.index()], &c.db[j.index()]),
        Column::InducedTraceless(a) => c.traceless(out, false, a.index(), s),
        Column::EddyTraceless(a) => c.traceless(out, true, a.index(), s),
        Column::InducedTrace => c.trace(out, s),
        Column::Extra { channel, axis } => {
            let values = &extras[channel][rows];
            for ((o, u), v) in out.iter_mut().zip(&c.unit[axis.index()]).zip(values) {
                *o = u * v;
            }
        }
        Column::Bias => out.fill(1.0),
    }
}

/// Samples per block of the column builders: a block's fluxgate values, unit vectors and
/// changes stay in the first-level caches while every column of it is written.
const BLOCK_ROWS: usize = 2048;

/// The fluxgates' components (nT) and the extra channels over one span of samples, each a
/// series of its own.
struct Spans<'a> {
    series: Vec<[&'a [f64]; 3]>,
    extras: Vec<&'a [f64]>,
    len: usize,
}

impl<'a> Spans<'a> {
    fn new(flux: &Fluxgates<'a>, span: Range<usize>) -> Self {
        Self {
            series: flux
                .series()
                .iter()
                .map(|s| [&s.x[span.clone()], &s.y[span.clone()], &s.z[span.clone()]])
                .collect(),
            extras: flux.extras().iter().map(|e| &e[span.clone()]).collect(),
            len: span.len(),
        }
    }

    /// Calls `f` on consecutive blocks of the span's samples `rows`, on all cores, with every
    /// fluxgate's [`Components`] at the block, its rows within the span and the block's rows
    /// of each of `columns` (each `rows.len()` long).
    fn by_blocks(
        &self,
        rows: Range<usize>,
        columns: &mut [&mut [f64]],
        f: impl Fn(&[Components], Range<usize>, &mut [&mut [f64]]) + Sync,
    ) {
        assert!(rows.end <= self.len, "rows within the span");
        split_rows(rows.len(), columns, |part, columns| {
            let part = rows.start + part.start..rows.start + part.end;
            for rows in blocks(part.clone(), BLOCK_ROWS) {
                let at = rows.start - part.start..rows.end - part.start;
                let mut block: Vec<&mut [f64]> =
                    columns.iter_mut().map(|c| &mut c[at.clone()]).collect();
                f(&self.components(rows.clone()), rows, &mut block);
            }
        });
    }

    /// Every fluxgate's [`Components`] at the samples `rows`.
    fn components(&self, rows: Range<usize>) -> Vec<Components<'a>> {
        self.series
            .iter()
            .map(|b| components_of(*b, rows.clone()))
            .collect()
    }
}

/// One fluxgate's components (nT), their changes per sample (nT/sample) and the unit vector.
struct Components<'a> {
    b: [&'a [f64]; 3],
    db: [Vec<f64>; 3],
    unit: [Vec<f64>; 3],
}

impl<'a> Components<'a> {
    /// Writes the traceless column `(B̂·v/3 − B̂a·va) / s` with v = B, or Ḃ when `eddy`.
    #[inline(always)]
    fn traceless(&self, out: &mut [f64], eddy: bool, a: usize, s: f64) {
        let v: [&[f64]; 3] = if eddy {
            [&self.db[0], &self.db[1], &self.db[2]]
        } else {
            self.b
        };
        self.each_sample(out, v, |unit, v| traceless(unit, v, a) / s);
    }

    /// Writes the trace column `B̂·B / (3s)`.
    #[inline(always)]
    fn trace(&self, out: &mut [f64], s: f64) {
        self.each_sample(out, self.b, |unit, v| trace(unit, v) / s);
    }

    /// Writes `f(B̂, v)` for every sample, by iterators rather than indices so the loop carries
    /// no bounds checks.
    #[inline(always)]
    fn each_sample(&self, out: &mut [f64], v: [&[f64]; 3], f: impl Fn([f64; 3], [f64; 3]) -> f64) {
        let units = self.unit[0].iter().zip(&self.unit[1]).zip(&self.unit[2]);
        let values = v[0].iter().zip(v[1]).zip(v[2]);
        for ((o, ((u0, u1), u2)), ((v0, v1), v2)) in out.iter_mut().zip(units).zip(values) {
            *o = f([*u0, *u1, *u2], [*v0, *v1, *v2]);
        }
    }
}

/// One fluxgate's [`Components`] (x, y, z of `series`; nT) at the samples `rows`, with their
/// changes as [`central_difference`] gives them over the whole series. Compiled also for AVX2
/// and AVX-512, as [`column_into`] is.
#[multiversion(targets("x86_64+avx512f", "x86_64+avx2"))]
fn components_of<'a>(series: [&'a [f64]; 3], rows: Range<usize>) -> Components<'a> {
    let b = series.map(|c| &c[rows.clone()]);
    let mut norm = vec![0.0; rows.len()];
    norms3_into(b, &mut norm);
    Components {
        b,
        db: series.map(|c| central_difference_over(c, rows.clone())),
        unit: b.map(|c| c.iter().zip(&norm).map(|(v, m)| v / m).collect()),
    }
}

/// `û·v/3 − ûa·va`: the projection on û of the traceless field `(1/3 − e_a e_aᵀ)·v`.
#[inline(always)]
fn traceless(unit: [f64; 3], v: [f64; 3], a: usize) -> f64 {
    (unit[0] * v[0] + unit[1] * v[1] + unit[2] * v[2]) / 3.0 - unit[a] * v[a]
}

/// `û·v/3`: the projection on û of the isotropic field `v/3`.
#[inline(always)]
fn trace(unit: [f64; 3], v: [f64; 3]) -> f64 {
    (unit[0] * v[0] + unit[1] * v[1] + unit[2] * v[2]) / 3.0
}

fn unit_vector(b: [f64; 3]) -> [f64; 3] {
    let norm = (b[0] * b[0] + b[1] * b[1] + b[2] * b[2]).sqrt();
    b.map(|v| v / norm)
}

/// Change per sample by central differences, one-sided at both ends (MagNav's `fdm`).
///
/// Units: those of `x` per sample. A series of one sample has zero change.
pub fn central_difference(x: &[f64]) -> Vec<f64> {
    central_difference_over(x, 0..x.len())
}

/// [`central_difference`] of `x` at the samples `rows` only (one value per sample of `rows`).
///
/// # Panics
/// If `rows` is not within `x`: a programming error.
#[inline(always)]
pub fn central_difference_over(x: &[f64], rows: Range<usize>) -> Vec<f64> {
    let n = x.len();
    assert!(
        rows.start <= rows.end && rows.end <= n,
        "rows within the series"
    );
    if n < 2 {
        return vec![0.0; rows.len()];
    }
    let mut out = Vec::with_capacity(rows.len());
    if rows.start == 0 && rows.end > 0 {
        out.push(x[1] - x[0]);
    }
    // The samples with a neighbour on each side, as slices so the loop vectorises.
    let inner = rows.start.max(1)..rows.end.min(n - 1);
    if inner.start < inner.end {
        let after = &x[inner.start + 1..inner.end + 1];
        let before = &x[inner.start - 1..inner.end - 1];
        out.extend(after.iter().zip(before).map(|(a, b)| (a - b) / 2.0));
    }
    if rows.end == n && rows.start < n {
        out.push(x[n - 1] - x[n - 2]);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::extra::ExtraChannel;
    use crate::model::vector::VectorSeries;

    /// A long record of two fluxgates and a channel, every sample different.
    fn long_record(n: usize) -> (VectorSeries, VectorSeries, Vec<f64>) {
        let wave = |k: usize, f: f64, a: f64, c: f64| c + a * (k as f64 * f).sin();
        let fluxgate = |p: f64| {
            VectorSeries::new(
                (0..n).map(|k| wave(k, 0.013 + p, 9e3, 2e4)).collect(),
                (0..n).map(|k| wave(k, 0.007, 5e3 + p, -3e3)).collect(),
                (0..n)
                    .map(|k| wave(k, 0.0031 * (1.0 + p), 2e3, 4.5e4))
                    .collect(),
            )
        };
        let channel = (0..n).map(|k| wave(k, 0.11, 3.0, 1.0)).collect();
        (fluxgate(0.0), fluxgate(0.001), channel)
    }

    #[test]
    fn a_span_built_by_blocks_on_all_cores_is_bit_for_bit_its_rows() {
        // Long enough for two cores and many blocks; the span starts and ends inside.
        let n = 230_017;
        let (f0, f1, channel) = long_record(n);
        let span = 1_999..n - 3;
        let patent = Design::new("patent".parse().unwrap()).with_fluxgates(2);
        let design = Design::new("p,i,e,b".parse().unwrap())
            .with_fluxgates(2)
            .with_extras(vec![ExtraChannel::plain("cur")]);
        let mut terms = design.design_terms();
        terms.extend(patent.design_terms());
        let flux = Fluxgates::from(vec![&f0, &f1]).with_extras(vec![channel.as_slice()]);
        let m = span.len();
        let mut a = vec![0.0; m * terms.len()];
        design.matrix_over(flux.clone(), span.clone(), &terms, &mut a);
        let beta: Vec<f64> = (0..design.width()).map(|k| k as f64 * 0.37 - 3.0).collect();
        let applied = design.apply_over(flux, span.clone(), &beta);
        let own = |s: &VectorSeries| {
            let part = s.slice(span.clone());
            [&part.x, &part.y, &part.z].map(|c| central_difference(c))
        };
        let (d0, d1) = (own(&f0), own(&f1));
        let mut value = [0.0];
        let edges = [
            0,
            1,
            2047,
            2048,
            2049,
            m / 2 - 1,
            m / 2,
            m / 2 + 1,
            m - 2,
            m - 1,
        ];
        for r in (0..m).step_by(997).chain(edges) {
            let k = span.start + r;
            let b = [f0.at(k), f1.at(k)];
            let db = [d0.each_ref().map(|c| c[r]), d1.each_ref().map(|c| c[r])];
            let mut sum = 0.0;
            for (c, t) in terms.iter().enumerate() {
                let f = t.fluxgate;
                design.row_with_extras(&[t.column], b[f], db[f], &[channel[k]], &mut value);
                assert_eq!(a[c * m + r].to_bits(), value[0].to_bits(), "row {r} {t:?}");
                if c < beta.len() {
                    sum += value[0] * beta[c];
                }
            }
            assert!(
                (applied[r] - sum).abs() <= 1e-9 * sum.abs().max(1.0),
                "row {r}"
            );
        }
    }

    fn swinging(phase: f64) -> VectorSeries {
        let n = 6;
        let angle = |k: usize| 0.3 * (k as f64 + phase).sin();
        VectorSeries::new(
            (0..n).map(|k| 20_000.0 * angle(k).cos()).collect(),
            (0..n).map(|k| 20_000.0 * angle(k).sin()).collect(),
            (0..n).map(|k| 45_000.0 + 10.0 * k as f64).collect(),
        )
    }

    #[test]
    fn several_fluxgates_give_side_by_side_blocks_with_one_bias() {
        let (a, b) = (swinging(0.0), swinging(1.0));
        let one = Design::new("p,i5,e8,b".parse().unwrap());
        let two = one.clone().with_fluxgates(2);
        let width = one.width();
        assert_eq!(two.width(), 2 * width - 1);
        let both = two.matrix(vec![&a, &b]);
        let (ma, mb) = (one.matrix(&a), one.matrix(&b));
        assert_eq!(both.columns(0, width), ma.columns(0, width));
        assert_eq!(both.columns(width, width - 1), mb.columns(0, width - 1));
        let names = two.column_names(&["flux_a".into(), "flux_b".into()]);
        assert_eq!(names[width - 1], "flux_a.bias");
        assert_eq!(names[width], "flux_b.perm_x");
        assert_eq!(two.column_names(&[])[width], "fluxgate2.perm_x");
    }

    #[test]
    fn matrix_entries_are_bit_for_bit_the_design_rows() {
        let (f0, f1) = (swinging(0.3), swinging(2.0));
        let d = Design::new("p,i,e,b".parse().unwrap()).with_fluxgates(2);
        let terms = d.design_terms();
        let a = d.matrix(vec![&f0, &f1]);
        let change = |s: &VectorSeries| [&s.x, &s.y, &s.z].map(|c| central_difference(c));
        let (d0, d1) = (change(&f0), change(&f1));
        let mut value = [0.0];
        for k in 0..f0.len() {
            let b = [f0.at(k), f1.at(k)];
            let db = [d0.each_ref().map(|c| c[k]), d1.each_ref().map(|c| c[k])];
            for (c, t) in terms.iter().enumerate() {
                let f = t.fluxgate;
                d.row(&[t.column], b[f], db[f], &mut value);
                assert_eq!(
                    a[(k, c)].to_bits(),
                    value[0].to_bits(),
                    "row {k} column {c}"
                );
            }
        }
    }

    #[test]
    fn a_one_fluxgate_design_is_stored_as_before() {
        let json = serde_json::to_string(&Design::new("p".parse().unwrap())).unwrap();
        assert!(!json.contains("fluxgates"), "{json}");
        let two: Design = serde_json::from_str(&json.replace('}', r#","fluxgates":2}"#)).unwrap();
        assert_eq!(two.fluxgates, 2);
    }

    proptest::proptest! {
        #[test]
        fn central_differences_over_rows_are_those_of_the_whole_series(
            x in proptest::collection::vec(-1e5f64..1e5, 0..40),
            start in 0usize..40,
            len in 0usize..40,
        ) {
            let n = x.len();
            let rows = start.min(n)..(start + len).min(n);
            let at = |k: usize| match k {
                _ if n < 2 => 0.0,
                0 => x[1] - x[0],
                k if k + 1 == n => x[n - 1] - x[n - 2],
                k => (x[k + 1] - x[k - 1]) / 2.0,
            };
            let want: Vec<u64> = rows.clone().map(|k| at(k).to_bits()).collect();
            let got: Vec<u64> = central_difference_over(&x, rows).iter().map(|v| v.to_bits()).collect();
            proptest::prop_assert_eq!(got, want);
        }
    }

    #[test]
    fn central_difference_is_one_sided_at_ends() {
        assert_eq!(
            central_difference(&[0.0, 1.0, 4.0, 9.0]),
            [1.0, 2.0, 4.0, 5.0]
        );
        assert_eq!(central_difference(&[5.0]), [0.0]);
        assert!(central_difference(&[]).is_empty());
    }

    #[test]
    fn apply_equals_matrix_times_coefficients() {
        let flux = VectorSeries::new(
            vec![20_000.0, 20_100.0, 20_050.0, 19_900.0],
            vec![1_000.0, -500.0, 300.0, 0.0],
            vec![45_000.0, 44_900.0, 45_100.0, 45_050.0],
        );
        let d = Design::new("p,i,e,b".parse().unwrap());
        let beta: Vec<f64> = (0..d.width()).map(|k| k as f64 - 7.5).collect();
        let a = d.matrix(&flux);
        let direct = a * nalgebra::DVector::from_vec(beta.clone());
        let applied = d.apply(&flux, &beta);
        for (u, v) in direct.iter().zip(&applied) {
            assert!((u - v).abs() < 1e-9);
        }
    }

    #[test]
    fn matrix_rows_are_exactly_design_rows() {
        let flux = VectorSeries::new(
            vec![20_000.0, 20_100.3, 20_050.7, 19_900.1, 19_850.0],
            vec![1_000.0, -500.2, 300.9, 0.0, 12.5],
            vec![45_000.0, 44_900.4, 45_100.6, 45_050.8, 44_990.0],
        );
        let d = Design::new("p,i,e,b".parse().unwrap());
        let columns = d.columns();
        let a = d.matrix(&flux);
        let db = [
            central_difference(&flux.x),
            central_difference(&flux.y),
            central_difference(&flux.z),
        ];
        let mut row = vec![0.0; columns.len()];
        for k in 0..flux.len() {
            d.row(
                &columns,
                flux.at(k),
                [db[0][k], db[1][k], db[2][k]],
                &mut row,
            );
            for (c, v) in row.iter().enumerate() {
                assert_eq!(a[(k, c)].to_bits(), v.to_bits(), "row {k} column {c}");
            }
        }
    }

    #[test]
    fn permanent_columns_are_the_unit_vector() {
        let flux = VectorSeries::new(
            vec![0.0, 0.0],
            vec![0.0, 48_000.0],
            vec![50_000.0, 14_000.0],
        );
        let a = Design::new("p".parse().unwrap()).matrix(&flux);
        assert_eq!(
            a.row(0).iter().copied().collect::<Vec<_>>(),
            [0.0, 0.0, 1.0]
        );
        assert!((a[(1, 1)] - 0.96).abs() < 1e-15 && (a[(1, 2)] - 0.28).abs() < 1e-15);
    }
}
