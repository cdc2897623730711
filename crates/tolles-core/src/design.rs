//! The Tolles-Lawson design matrix: one row per sample, one column per term.
//!
//! ```
//! use tolles_core::design::{Design, TermSet};
//! use tolles_core::vector::VectorSeries;
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
//! The column order is MagNav.jl's `create_TL_A` (see [`crate::terms`]).

use crate::terms::Column;
pub use crate::terms::TermSet;
use crate::vector::VectorSeries;
use nalgebra::DMatrix;
use serde::{Deserialize, Serialize};

/// MagNav.jl's scale for the induced and eddy columns (nT), so they are of order one.
pub const MAGNAV_BT_SCALE: f64 = 50_000.0;

/// Builds Tolles-Lawson design rows for a chosen [`TermSet`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Design {
    /// The terms, and so the columns.
    pub terms: TermSet,
    /// Divisor of the induced and eddy columns (nT); MagNav uses 50 000.
    pub bt_scale: f64,
}

impl Design {
    /// A design with MagNav's `Bt_scale` of 50 000 nT.
    pub fn new(terms: TermSet) -> Self {
        Self {
            terms,
            bt_scale: MAGNAV_BT_SCALE,
        }
    }

    /// The columns, in order.
    pub fn columns(&self) -> Vec<Column> {
        self.terms.columns()
    }

    /// Number of columns.
    pub fn width(&self) -> usize {
        self.columns().len()
    }

    /// Writes the design row for field `b` (nT) and its change per sample `db` (nT/sample) into
    /// `out`, which must be [`Design::width`] long.
    ///
    /// The eddy-current columns are here: `B̂i·Ḃj / s`.
    pub fn row(&self, columns: &[Column], b: [f64; 3], db: [f64; 3], out: &mut [f64]) {
        let norm = (b[0] * b[0] + b[1] * b[1] + b[2] * b[2]).sqrt();
        let unit = b.map(|v| v / norm);
        for (value, column) in out.iter_mut().zip(columns) {
            *value = match *column {
                Column::Permanent(i) => unit[i.index()],
                Column::Induced(i, j) => unit[i.index()] * b[j.index()] / self.bt_scale,
                Column::Eddy(i, j) => unit[i.index()] * db[j.index()] / self.bt_scale,
                Column::Bias => 1.0,
            };
        }
    }

    /// The design matrix of one contiguous series (rows = samples).
    ///
    /// Built column by column (the matrix is column-major), with the same arithmetic as
    /// [`Design::row`], so every entry is bit-for-bit what `row` gives.
    pub fn matrix(&self, flux: &VectorSeries) -> DMatrix<f64> {
        let columns = self.columns();
        let n = flux.len();
        let b = [&flux.x, &flux.y, &flux.z];
        let db = [
            central_difference(&flux.x),
            central_difference(&flux.y),
            central_difference(&flux.z),
        ];
        let norm: Vec<f64> = (0..n).map(|k| flux.magnitude(k)).collect();
        let unit: Vec<Vec<f64>> = b
            .iter()
            .map(|c| c.iter().zip(&norm).map(|(v, m)| v / m).collect())
            .collect();
        let mut a = DMatrix::zeros(n, columns.len());
        for (mut out, column) in a.column_iter_mut().zip(&columns) {
            let out = out.as_mut_slice();
            let scaled = |out: &mut [f64], u: &[f64], v: &[f64]| {
                for ((o, u), v) in out.iter_mut().zip(u).zip(v) {
                    *o = u * v / self.bt_scale;
                }
            };
            match *column {
                Column::Permanent(i) => out.copy_from_slice(&unit[i.index()]),
                Column::Induced(i, j) => scaled(out, &unit[i.index()], b[j.index()]),
                Column::Eddy(i, j) => scaled(out, &unit[i.index()], &db[j.index()]),
                Column::Bias => out.fill(1.0),
            }
        }
        a
    }

    /// `A·β` for one contiguous series, without storing `A` (nT).
    pub fn apply(&self, flux: &VectorSeries, coefficients: &[f64]) -> Vec<f64> {
        let columns = self.columns();
        assert_eq!(
            columns.len(),
            coefficients.len(),
            "one coefficient per column"
        );
        let mut out = vec![0.0; flux.len()];
        let mut row = vec![0.0; columns.len()];
        self.for_each_row(flux, |k, b, db| {
            self.row(&columns, b, db, &mut row);
            out[k] = row.iter().zip(coefficients).map(|(a, c)| a * c).sum();
        });
        out
    }

    fn for_each_row(&self, flux: &VectorSeries, mut f: impl FnMut(usize, [f64; 3], [f64; 3])) {
        let dx = central_difference(&flux.x);
        let dy = central_difference(&flux.y);
        let dz = central_difference(&flux.z);
        for k in 0..flux.len() {
            f(k, flux.at(k), [dx[k], dy[k], dz[k]]);
        }
    }
}

/// Change per sample by central differences, one-sided at both ends (MagNav's `fdm`).
///
/// Units: those of `x` per sample. A series of one sample has zero change.
pub fn central_difference(x: &[f64]) -> Vec<f64> {
    let n = x.len();
    match n {
        0 => Vec::new(),
        1 => vec![0.0],
        _ => {
            let mut d = vec![0.0; n];
            d[0] = x[1] - x[0];
            d[n - 1] = x[n - 1] - x[n - 2];
            for k in 1..n - 1 {
                d[k] = (x[k + 1] - x[k - 1]) / 2.0;
            }
            d
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

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
