//! How the aircraft's field reaches a scalar magnetometer: to first order, or exactly.
//!
//! A scalar magnetometer reads `|B + H|`. Tolles-Lawson keeps the first-order part `B̂·H`, which
//! is linear in the coefficients. With `H` of a few hundred nT the neglected part,
//! `|H⊥|²/(2|B|)` and beyond, changes by 1–60 nT across attitudes, and a linear fit aliases it
//! into wrong coefficients. The exact model subtracts `|B + H| − |B|` instead, with `H` built
//! from the same coefficients:
//!
//! ```
//! use tolles_core::model::design::Design;
//! use tolles_core::model::magnitude::{correction, Magnitude};
//! use tolles_core::model::vector::VectorSeries;
//!
//! // A 300 nT permanent field across a 50 000 nT earth field along x.
//! let flux = VectorSeries::new(vec![50_000.0; 2], vec![0.0; 2], vec![0.0; 2]);
//! let design = Design::new("p".parse().unwrap());
//! let beta = [0.0, 300.0, 0.0];
//! let linear = correction(Magnitude::Linear, &design, &flux, &beta);
//! let exact = correction(Magnitude::Exact, &design, &flux, &beta);
//! assert_eq!(linear[0], 0.0); // B̂·H = 0
//! assert!((exact[0] - 0.9).abs() < 1e-3); // |H|²/(2|B|) = 0.9 nT
//! ```
//!
//! Each column of a [`Design`] is the projection on B̂ of a field vector (nT per unit of its
//! coefficient), [`field_per_unit`]: `H = Σ βk·vk`. Off-diagonal induced columns stand for the
//! symmetric pair `(I_ij + I_ji)/2` each, the traceless ones for `(1/3 − e_a e_aᵀ)·B`. The
//! derivative of `|B + H|` with respect to βk is `unit(B + H)·vk`: the design row with B̂ replaced
//! by the direction of the total field, which is what a Gauss-Newton fit needs.
//!
//! Only one fluxgate's block is modelled exactly; designs over several fluxgates stay linear.

use crate::model::design::{central_difference, central_difference_over, Design, Term};
use crate::model::terms::Column;
use crate::model::vector::{norms3_into, Fluxgates, VectorSeries};
use multiversion::multiversion;
use nalgebra::DMatrix;
use serde::{Deserialize, Serialize};

/// How a model's field enters the scalar reading.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Magnitude {
    /// `B̂·H`: Tolles-Lawson's first-order projection, linear in the coefficients.
    #[default]
    Linear,
    /// `|B + H| − |B|`: the exact change of the magnitude.
    Exact,
}

impl std::fmt::Display for Magnitude {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Magnitude::Linear => "linear",
            Magnitude::Exact => "exact",
        })
    }
}

/// The field vector (nT) that one unit of `column`'s coefficient adds, for the fluxgate reading
/// `b` (nT), its change per sample `db` (nT/sample) and the extra channels' values `extras`
/// (design order): an extra channel's column is a field of fixed direction in the body frame,
/// its axis, times the channel. `None` for the bias, which is no field.
#[inline]
pub fn field_per_unit(
    column: Column,
    b: [f64; 3],
    db: [f64; 3],
    extras: &[f64],
    bt_scale: f64,
) -> Option<[f64; 3]> {
    let axis = |i: usize, value: f64| {
        let mut v = [0.0; 3];
        v[i] = value;
        v
    };
    let traceless = |v: [f64; 3], a: usize| {
        let mut out = v.map(|c| c / 3.0 / bt_scale);
        out[a] -= v[a] / bt_scale;
        out
    };
    Some(match column {
        Column::Permanent(i) => axis(i.index(), 1.0),
        Column::Induced(i, j) if i == j => axis(i.index(), b[i.index()] / bt_scale),
        Column::Induced(i, j) => {
            let (i, j) = (i.index(), j.index());
            let mut v = [0.0; 3];
            v[i] = b[j] / (2.0 * bt_scale);
            v[j] = b[i] / (2.0 * bt_scale);
            v
        }
        Column::Eddy(i, j) => axis(i.index(), db[j.index()] / bt_scale),
        Column::InducedTraceless(a) => traceless(b, a.index()),
        Column::EddyTraceless(a) => traceless(db, a.index()),
        Column::InducedTrace => b.map(|c| c / 3.0 / bt_scale),
        Column::Extra { channel, axis: a } => {
            axis(a.index(), extras.get(channel).copied().unwrap_or(f64::NAN))
        }
        Column::Bias => return None,
    })
}

/// One sample's exact correction `|B + H| − |B| + bias` (nT), and the direction of `B + H`,
/// with the extra channels' values `extras` (design order).
///
/// The difference is computed as `(2B·H + H·H)/(|B + H| + |B|)`, which keeps its digits when
/// `H ≪ B`.
pub fn exact_at(
    design: &Design,
    columns: &[Column],
    coefficients: &[f64],
    b: [f64; 3],
    db: [f64; 3],
    extras: &[f64],
) -> (f64, [f64; 3]) {
    let mut h = [0.0; 3];
    let mut bias = 0.0;
    for (column, beta) in columns.iter().zip(coefficients) {
        match field_per_unit(*column, b, db, extras, design.bt_scale) {
            Some(v) => (0..3).for_each(|i| h[i] += beta * v[i]),
            None => bias += beta,
        }
    }
    change_of_magnitude(b, h, bias)
}

/// `|B + H| − |B| + bias` (nT) as `(2B·H + H·H)/(|B + H| + |B|)`, and the direction of `B + H`.
fn change_of_magnitude(b: [f64; 3], h: [f64; 3], bias: f64) -> (f64, [f64; 3]) {
    let total = [b[0] + h[0], b[1] + h[1], b[2] + h[2]];
    let (nb, nt) = (norm(b), norm(total));
    (change_from_norms(b, h, nb, nt, bias), total.map(|c| c / nt))
}

/// `(2B·H + H·H)/(|B + H| + |B|) + bias` (nT), given `nb = |B|` and `nt = |B + H|`: the one
/// formula of the change of magnitude, sample by sample or over a block.
#[inline(always)]
fn change_from_norms(b: [f64; 3], h: [f64; 3], nb: f64, nt: f64, bias: f64) -> f64 {
    let dot =
        2.0 * (b[0] * h[0] + b[1] * h[1] + b[2] * h[2]) + h[0] * h[0] + h[1] * h[1] + h[2] * h[2];
    dot / (nt + nb) + bias
}

/// The correction (nT) of a model for every sample of one contiguous series from one fluxgate
/// (and the extra channels its design names): `A·β` for [`Magnitude::Linear`],
/// `|B + H| − |B|` (plus any bias) for [`Magnitude::Exact`].
pub fn correction<'a>(
    magnitude: Magnitude,
    design: &Design,
    flux: impl Into<Fluxgates<'a>>,
    coefficients: &[f64],
) -> Vec<f64> {
    let flux = flux.into();
    match magnitude {
        Magnitude::Linear => design.apply(flux, coefficients),
        Magnitude::Exact => {
            let columns = design.columns();
            let series = flux.series()[0];
            let db = derivatives(series);
            let mut extras = vec![0.0; flux.extras().len()];
            (0..series.len())
                .map(|k| {
                    extras_at(flux.extras(), k, &mut extras);
                    let (b, d) = (sample(series, k), at(&db, k));
                    exact_at(design, &columns, coefficients, b, d, &extras).0
                })
                .collect()
        }
    }
}

/// The extra channels' values at sample `k`, into `out`.
fn extras_at(extras: &[&[f64]], k: usize, out: &mut [f64]) {
    out.iter_mut().zip(extras).for_each(|(o, e)| *o = e[k]);
}

/// The exact correction of one contiguous series (nT) and its Jacobian with respect to the
/// coefficients of `terms` (one row per sample): the design matrix with B̂ replaced by the
/// direction of `B + H`.
pub fn exact_jacobian<'a>(
    design: &Design,
    flux: impl Into<Fluxgates<'a>>,
    coefficients: &[f64],
    terms: &[Term],
) -> (Vec<f64>, DMatrix<f64>) {
    let flux = flux.into();
    let series = flux.series()[0];
    let n = series.len();
    let mut jacobian = DMatrix::zeros(n, terms.len());
    let mut delta = vec![0.0; n];
    let mut columns: Vec<&mut [f64]> = jacobian.as_mut_slice().chunks_mut(n.max(1)).collect();
    exact_jacobian_into(
        design,
        [&series.x, &series.y, &series.z],
        flux.extras(),
        coefficients,
        terms,
        0..n,
        &mut columns,
        &mut delta,
    );
    (delta, jacobian)
}

/// [`exact_jacobian`] for the samples `rows` of the series whose x, y, z components (nT) are
/// `flux` and whose extra channels are `extras` (as long, design order), written into
/// `jacobian` (one slice per term, `rows.len()` long) and `delta`, so
/// callers can share a series' samples between threads and decide where the rows live,
/// without copying the series. The changes per sample are those of the whole series.
///
/// Compiled also for AVX2 and AVX-512 and chosen at run time (its loops are over blocks of
/// samples); the same operations on every path, so the same bits.
///
/// # Panics
/// If `rows` is not within the series or a slice is shorter than `rows`: programming errors.
#[multiversion(targets("x86_64+avx512f", "x86_64+avx2"))]
#[allow(clippy::too_many_arguments)]
pub fn exact_jacobian_into(
    design: &Design,
    flux: [&[f64]; 3],
    extras: &[&[f64]],
    coefficients: &[f64],
    terms: &[Term],
    rows: std::ops::Range<usize>,
    jacobian: &mut [&mut [f64]],
    delta: &mut [f64],
) {
    let columns = design.columns();
    let s = design.bt_scale;
    // Each column's field is needed for H and again for its derivative: when the terms are the
    // design's own columns (one fluxgate, the usual case) it is computed once per sample.
    let same =
        terms.len() == columns.len() && terms.iter().zip(&columns).all(|(t, c)| t.column == *c);
    let mut ws = JacobianBlock::new(columns.len());
    // By blocks of samples, column after column within a block so each loop is one formula
    // over many samples; per sample the operations and their order are `exact_at`'s (H summed
    // in column order), so the values are the same.
    for block in crate::parallel::blocks(rows.clone(), JACOBIAN_BLOCK_ROWS) {
        let m = block.len();
        let b = flux.map(|c| &c[block.clone()]);
        let db = flux.map(|c| central_difference_over(c, block.clone()));
        let db = [&db[0][..], &db[1][..], &db[2][..]];
        let e: Vec<&[f64]> = extras.iter().map(|e| &e[block.clone()]).collect();
        ws.start(m);
        for (c, (column, beta)) in columns.iter().zip(coefficients).enumerate() {
            ws.parts[c] = fields_of(*column, b, db, &e, s, &mut ws.fields[c]);
            ws.add_to_h(c, *beta);
        }
        let at = block.start - rows.start..block.end - rows.start;
        ws.change_of_magnitude(b, &mut delta[at.clone()]);
        for (c, (out, term)) in jacobian.iter_mut().zip(terms).enumerate() {
            let out = &mut out[at.clone()];
            if same {
                ws.derivatives(c, out);
            } else {
                let mut field = std::mem::take(&mut ws.spare);
                let parts = fields_of(term.column, b, db, &e, s, &mut field);
                ws.derivatives_of(parts, &field, out);
                ws.spare = field;
            }
        }
    }
}

/// Samples [`exact_jacobian_into`] computes at once: every column's field over a block stays
/// in the second-level cache.
const JACOBIAN_BLOCK_ROWS: usize = 256;

/// One block's fields, total field and direction, reused from block to block.
struct JacobianBlock {
    /// Per column, its field's x, y, z over the block (nT per unit of its coefficient); only
    /// the components of its [`Parts`] are written.
    fields: Vec<[Vec<f64>; 3]>,
    /// Per column, the components its field has, `None` for the bias.
    parts: Vec<Parts>,
    /// Another column's field, for terms that are not the design's columns.
    spare: [Vec<f64>; 3],
    h: [Vec<f64>; 3],
    bias: Vec<f64>,
    direction: [Vec<f64>; 3],
    /// `|B|` and `|B + H|` over the block (nT).
    norm_b: Vec<f64>,
    norm_total: Vec<f64>,
}

impl JacobianBlock {
    fn new(columns: usize) -> Self {
        Self {
            fields: vec![Default::default(); columns],
            parts: vec![None; columns],
            spare: Default::default(),
            h: Default::default(),
            bias: Vec::new(),
            direction: Default::default(),
            norm_b: Vec::new(),
            norm_total: Vec::new(),
        }
    }

    /// Clears the sums for a block of `m` samples.
    #[inline(always)]
    fn start(&mut self, m: usize) {
        let zero = |v: &mut Vec<f64>| {
            v.clear();
            v.resize(m, 0.0);
        };
        self.h
            .iter_mut()
            .chain(self.direction.iter_mut())
            .for_each(zero);
        zero(&mut self.bias);
    }

    /// [`change_of_magnitude`] of every sample of the block, whose readings are `b`, into
    /// `delta`, and the direction of `B + H`: the same operations sample by sample, as loops
    /// over the block the compiler vectorises.
    #[inline(always)]
    fn change_of_magnitude(&mut self, b: [&[f64]; 3], delta: &mut [f64]) {
        let m = delta.len();
        for ((t, b), h) in self.direction.iter_mut().zip(b).zip(&self.h) {
            t.iter_mut()
                .zip(b)
                .zip(h)
                .for_each(|((t, b), h)| *t = b + h);
        }
        self.norm_b.resize(m, 0.0);
        self.norm_total.resize(m, 0.0);
        norms3_into(b, &mut self.norm_b);
        let [t0, t1, t2] = &self.direction;
        norms3_into([t0, t1, t2], &mut self.norm_total);
        let [h0, h1, h2] = &self.h;
        for (k, value) in delta.iter_mut().enumerate() {
            let (b, h) = ([b[0][k], b[1][k], b[2][k]], [h0[k], h1[k], h2[k]]);
            *value = change_from_norms(b, h, self.norm_b[k], self.norm_total[k], self.bias[k]);
        }
        for t in &mut self.direction {
            t.iter_mut()
                .zip(&self.norm_total)
                .for_each(|(t, n)| *t /= n);
        }
    }

    /// Adds `beta` times column `c`'s field to H (the bias to `bias`), as `exact_at` does.
    ///
    /// A component the field lacks would add `β·0`, a signed zero, which leaves every sum as it
    /// is: only the others are added.
    #[inline(always)]
    fn add_to_h(&mut self, c: usize, beta: f64) {
        let Some(parts) = self.parts[c] else {
            self.bias.iter_mut().for_each(|b| *b += beta);
            return;
        };
        for ((h, v), _) in self
            .h
            .iter_mut()
            .zip(&self.fields[c])
            .zip(parts)
            .filter(|p| p.1)
        {
            for (h, v) in h.iter_mut().zip(v) {
                *h += beta * v;
            }
        }
    }

    /// Column `c`'s derivative over the block into `out`.
    #[inline(always)]
    fn derivatives(&self, c: usize, out: &mut [f64]) {
        self.derivatives_of(self.parts[c], &self.fields[c], out);
    }

    /// The derivative `∂|B + H|/∂β` of a column with field `field` (components `parts`; `None`:
    /// the bias, whose derivative is 1) over the block: `d0·v0 + d1·v1 + d2·v2` with `d` the
    /// direction of `B + H`, summed in that order, without the products by a component the
    /// field lacks (signed zeros, which change no sum).
    #[inline(always)]
    fn derivatives_of(&self, parts: Parts, field: &[Vec<f64>; 3], out: &mut [f64]) {
        let Some(parts) = parts else {
            out.fill(1.0);
            return;
        };
        let mut first = true;
        for ((d, v), _) in self.direction.iter().zip(field).zip(parts).filter(|p| p.1) {
            let terms = out.iter_mut().zip(d).zip(v);
            if first {
                terms.for_each(|((o, d), v)| *o = d * v);
            } else {
                terms.for_each(|((o, d), v)| *o += d * v);
            }
            first = false;
        }
    }
}

/// Which of x, y, z a column's field has (the others are 0 at every sample), or `None` for a
/// column that is no field (the bias).
type Parts = Option<[bool; 3]>;

/// The field of `column` (see [`field_per_unit`]) at every sample of a block with readings `b`,
/// changes `db` (one slice per component) and extra channels `extras`, into the components of
/// `out` it has, which it
/// returns; `None`, leaving `out` alone, for a column that is no field. The other components
/// are 0 and left as they were.
///
/// Per sample and component the operations are `field_per_unit`'s, so the values are the same;
/// but each kind of column is its own loop over the block with its axes fixed, which the
/// compiler vectorises (a match on the column per sample kept it scalar, a third of the exact
/// fit's Jacobian).
#[inline(always)]
fn fields_of(
    column: Column,
    b: [&[f64]; 3],
    db: [&[f64]; 3],
    extras: &[&[f64]],
    s: f64,
    out: &mut [Vec<f64>; 3],
) -> Parts {
    if column == Column::Bias {
        return None;
    }
    let m = b[0].len();
    let parts = match column {
        Column::Permanent(i)
        | Column::Induced(i, _)
        | Column::Eddy(i, _)
        | Column::Extra { axis: i, .. } => {
            let mut parts = [false; 3];
            parts[i.index()] = true;
            if let Column::Induced(_, j) = column {
                parts[j.index()] = true;
            }
            parts
        }
        _ => [true; 3],
    };
    for (o, _) in out.iter_mut().zip(parts).filter(|p| p.1) {
        o.clear();
        o.resize(m, 0.0);
    }
    match column {
        Column::Permanent(i) => out[i.index()].fill(1.0),
        Column::Induced(i, j) if i == j => divided(b[i.index()], s, &mut out[i.index()]),
        Column::Induced(i, j) => {
            let (i, j) = (i.index(), j.index());
            divided(b[j], 2.0 * s, &mut out[i]);
            divided(b[i], 2.0 * s, &mut out[j]);
        }
        Column::Eddy(i, j) => divided(db[j.index()], s, &mut out[i.index()]),
        Column::InducedTraceless(a) => traceless_over(b, a.index(), s, out),
        Column::EddyTraceless(a) => traceless_over(db, a.index(), s, out),
        Column::InducedTrace => {
            for (o, v) in out.iter_mut().zip(b) {
                o.iter_mut().zip(v).for_each(|(o, v)| *o = v / 3.0 / s);
            }
        }
        Column::Extra { channel, axis } => out[axis.index()].copy_from_slice(extras[channel]),
        Column::Bias => unreachable!("no field, returned above"),
    }
    Some(parts)
}

/// `out = v / d`, sample by sample.
#[inline(always)]
fn divided(v: &[f64], d: f64, out: &mut [f64]) {
    out.iter_mut().zip(v).for_each(|(o, v)| *o = v / d);
}

/// `field_per_unit`'s traceless combination `zz − aa` of `v` (B or Ḃ) over a block.
#[inline(always)]
fn traceless_over(v: [&[f64]; 3], a: usize, s: f64, out: &mut [Vec<f64>; 3]) {
    for (c, (o, v)) in out.iter_mut().zip(v).enumerate() {
        if c == a {
            o.iter_mut()
                .zip(v)
                .for_each(|(o, v)| *o = v / 3.0 / s - v / s);
        } else {
            o.iter_mut().zip(v).for_each(|(o, v)| *o = v / 3.0 / s);
        }
    }
}

fn derivatives(flux: &VectorSeries) -> [Vec<f64>; 3] {
    [&flux.x, &flux.y, &flux.z].map(|c| central_difference(c))
}

fn sample(flux: &VectorSeries, k: usize) -> [f64; 3] {
    [flux.x[k], flux.y[k], flux.z[k]]
}

fn at(series: &[Vec<f64>; 3], k: usize) -> [f64; 3] {
    [series[0][k], series[1][k], series[2][k]]
}

fn norm(v: [f64; 3]) -> f64 {
    crate::model::vector::norm3(v)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn swinging_flux(n: usize) -> VectorSeries {
        let angle = |k: usize| 0.4 * (k as f64 * 0.13).sin();
        let pitch = |k: usize| 0.2 * (k as f64 * 0.07).cos();
        VectorSeries::new(
            (0..n)
                .map(|k| 20_000.0 * angle(k).cos() + 3_000.0 * pitch(k))
                .collect(),
            (0..n).map(|k| 20_000.0 * angle(k).sin()).collect(),
            (0..n).map(|k| 45_000.0 - 4_000.0 * pitch(k)).collect(),
        )
    }

    #[test]
    fn linear_projection_of_the_field_vectors_is_the_design_row() {
        let flux = swinging_flux(50);
        for terms in ["patent", "p,i,e,b", "p,i5,e8", "i3,e3", "p,it,trace,et"] {
            let design = Design::new(terms.parse().unwrap());
            let a = design.matrix(&flux);
            let db = derivatives(&flux);
            for k in [0, 7, 49] {
                let (b, d) = (sample(&flux, k), at(&db, k));
                let unit = b.map(|c| c / norm(b));
                for (c, column) in design.columns().iter().enumerate() {
                    let value = field_per_unit(*column, b, d, &[], design.bt_scale)
                        .map_or(1.0, |v| unit[0] * v[0] + unit[1] * v[1] + unit[2] * v[2]);
                    assert!((value - a[(k, c)]).abs() < 1e-12, "{terms} {column}");
                }
            }
        }
    }

    #[test]
    fn fields_over_a_block_are_the_fields_sample_by_sample_to_the_bit() {
        let flux = swinging_flux(37);
        let db = derivatives(&flux);
        let b = [&flux.x, &flux.y, &flux.z].map(Vec::as_slice);
        let d = [&db[0], &db[1], &db[2]].map(Vec::as_slice);
        let s = 50_000.0;
        for terms in ["p,i,e,b", "p,it,trace,et"] {
            for column in Design::new(terms.parse().unwrap()).columns() {
                let mut out: [Vec<f64>; 3] = Default::default();
                let parts = fields_of(column, b, d, &[], s, &mut out);
                for k in 0..flux.len() {
                    let one = field_per_unit(column, sample(&flux, k), at(&db, k), &[], s);
                    assert_eq!(parts.is_some(), one.is_some(), "{column}");
                    if let (Some(v), Some(parts)) = (one, parts) {
                        // A component left out is 0 in the field, and one kept is its value.
                        let kept = out.each_ref().map(|o| o.get(k).copied());
                        let block: [f64; 3] = std::array::from_fn(|i| match parts[i] {
                            true => kept[i].expect("a kept component is written"),
                            false => 0.0,
                        });
                        assert_eq!(block.map(f64::to_bits), v.map(f64::to_bits), "{column} {k}");
                    }
                }
            }
        }
    }

    #[test]
    fn exact_correction_is_the_change_of_magnitude_and_tends_to_the_linear_one() {
        let flux = swinging_flux(40);
        let design = Design::new("patent".parse().unwrap());
        let beta: Vec<f64> = (0..16).map(|k| (k as f64 - 7.0) * 30.0).collect();
        let exact = correction(Magnitude::Exact, &design, &flux, &beta);
        let linear = correction(Magnitude::Linear, &design, &flux, &beta);
        let small: Vec<f64> = beta.iter().map(|b| b * 1e-4).collect();
        let exact_small = correction(Magnitude::Exact, &design, &flux, &small);
        let linear_small = correction(Magnitude::Linear, &design, &flux, &small);
        let mut largest_gap: f64 = 0.0;
        for k in 0..40 {
            largest_gap = largest_gap.max((exact[k] - linear[k]).abs());
            let gap = (exact_small[k] - linear_small[k]).abs();
            assert!(gap < 1e-7, "{gap} {} {}", exact_small[k], linear_small[k]);
        }
        assert!(
            largest_gap > 0.01,
            "second order should show: {largest_gap}"
        );
    }

    /// The patent's terms with a bias, and coefficients of a few hundred nT.
    fn patent_with_bias() -> (Design, Vec<f64>) {
        let design = Design::new("patent,b".parse().unwrap());
        let beta = (0..17).map(|k| (k as f64 - 8.0) * 40.0).collect();
        (design, beta)
    }

    #[test]
    fn jacobian_matches_finite_differences() {
        let flux = swinging_flux(30);
        let (design, beta) = patent_with_bias();
        let (delta, j) = exact_jacobian(&design, &flux, &beta, &design.design_terms());
        assert_eq!(delta, correction(Magnitude::Exact, &design, &flux, &beta));
        for c in 0..17 {
            let mut up = beta.clone();
            up[c] += 1e-3;
            let moved = correction(Magnitude::Exact, &design, &flux, &up);
            for k in [0, 11, 29] {
                let numeric = (moved[k] - delta[k]) / 1e-3;
                assert!((numeric - j[(k, c)]).abs() < 1e-6, "column {c} sample {k}");
            }
        }
    }

    #[test]
    fn an_extra_channel_is_a_field_of_fixed_direction_times_the_channel() {
        let flux = swinging_flux(40);
        let current: Vec<f64> = (0..40).map(|k| ((k / 3) % 2) as f64 + 0.2).collect();
        let design = Design::new("patent".parse().unwrap())
            .with_extras(vec![crate::model::extra::ExtraChannel::plain("cur_1")]);
        let mut beta: Vec<f64> = (0..16).map(|k| (k as f64 - 7.0) * 30.0).collect();
        beta.extend([40.0, -35.0, 50.0]);
        let inputs = Fluxgates::from(&flux).with_extras(vec![&current]);
        let exact = correction(Magnitude::Exact, &design, inputs.clone(), &beta);
        let without: Vec<f64> = beta[..16].to_vec();
        let tl = Design::new("patent".parse().unwrap());
        let db = derivatives(&flux);
        for k in [0, 13, 39] {
            let (b, d) = (sample(&flux, k), at(&db, k));
            let mut h = [0.0; 3];
            for (column, w) in tl.columns().iter().zip(&without) {
                let v = field_per_unit(*column, b, d, &[], tl.bt_scale).unwrap();
                (0..3).for_each(|i| h[i] += w * v[i]);
            }
            (0..3).for_each(|i| h[i] += beta[16 + i] * current[k]);
            let total = [b[0] + h[0], b[1] + h[1], b[2] + h[2]];
            let want = norm(total) - norm(b);
            assert!(
                (exact[k] - want).abs() < 1e-9,
                "{k}: {} vs {want}",
                exact[k]
            );
        }
        let (delta, j) = exact_jacobian(&design, inputs.clone(), &beta, &design.design_terms());
        assert_eq!(delta, exact);
        for c in 16..19 {
            let mut up = beta.clone();
            up[c] += 1e-3;
            let moved = correction(Magnitude::Exact, &design, inputs.clone(), &up);
            for k in [0, 11, 29] {
                let numeric = (moved[k] - delta[k]) / 1e-3;
                assert!((numeric - j[(k, c)]).abs() < 1e-6, "column {c} sample {k}");
            }
        }
    }

    #[test]
    fn a_part_of_a_long_series_gives_the_whole_series_correction() {
        // Rows across several blocks of changes, starting and ending inside the series.
        let flux = swinging_flux(6_000);
        let (design, beta) = patent_with_bias();
        let whole = correction(Magnitude::Exact, &design, &flux, &beta);
        let terms = design.design_terms();
        let rows = 1_000..5_999;
        let mut j = vec![vec![0.0; rows.len()]; terms.len()];
        let mut columns: Vec<&mut [f64]> = j.iter_mut().map(Vec::as_mut_slice).collect();
        let mut delta = vec![0.0; rows.len()];
        let series = [&flux.x, &flux.y, &flux.z].map(Vec::as_slice);
        exact_jacobian_into(
            &design,
            series,
            &[],
            &beta,
            &terms,
            rows.clone(),
            &mut columns,
            &mut delta,
        );
        assert_eq!(delta, whole[rows]);
    }
}
