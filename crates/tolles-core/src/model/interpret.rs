//! Fitted coefficients as physical fields and in the Tolles patent's nomenclature.
//!
//! ```
//! use tolles_core::model::design::Design;
//! use tolles_core::model::interpret::AircraftField;
//!
//! let design = Design::new("p,i,e".parse().unwrap());
//! let mut beta = vec![0.0; 18];
//! beta[0] = 12.0; // permanent field along x (nT)
//! beta[4] = 500.0; // induced xy column: s·(I_xy + I_yx)
//! beta[10] = 5_000.0; // eddy xy column: s·fs·E_xy
//! let field = AircraftField::from_coefficients(&design, &beta, 10.0);
//! assert_eq!(field.permanent_nt, [12.0, 0.0, 0.0]);
//! assert_eq!(field.induced[0][1], 0.005); // half of 500/50000: only the symmetric part is seen
//! assert_eq!(field.eddy_s[0][1], 0.01); // 5000 / (50000 · 10 Hz)
//! let patent = field.patent_terms();
//! assert_eq!(patent.perm_nt.l, 12.0);
//! assert_eq!(patent.induced.tl_lt, 0.01);
//! assert_eq!(patent.eddy_s.tl, 0.01); // patent 'tl' = E[x][y]
//! ```
//!
//! Conventions are those of [`crate::model::conventions`]. Only the symmetric, traceless part of the
//! induced matrix and the traceless part of the eddy matrix reach a scalar magnetometer; the
//! physical matrices reported here split each fitted off-diagonal column equally between `[i][j]`
//! and `[j][i]`, and keep whatever trace the chosen terms imply (zero `zz` for `i5`/`e8`). The
//! patent terms are differences and sums that do not depend on those choices.

use crate::model::design::Design;
use crate::model::terms::Column;
// The patent's names for these values (`PatentTerms`, read with `AircraftField::patent_terms`)
// are `crate::patent`'s, which builds on this module; re-exported here where they were first.
pub use crate::patent::{EddyPatentTerms, InducedPatentTerms, PatentTerms, PermTerms};
use serde::{Deserialize, Serialize};

/// The aircraft's field model `H = P + I·B + E·dB/dt` in the body frame (FRD).
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct AircraftField {
    /// Permanent field P (nT), `[x, y, z]`.
    pub permanent_nt: [f64; 3],
    /// Induced matrix I (dimensionless): `I[i][j]` is the field along i per unit earth field
    /// along j.
    pub induced: [[f64; 3]; 3],
    /// Eddy-current matrix E (seconds): `E[i][j]` is the field along i (nT) per unit rate of
    /// change (nT/s) of the earth field along j.
    pub eddy_s: [[f64; 3]; 3],
    /// Constant offset of the scalar (nT), from a `bias` column.
    pub bias_nt: f64,
}

impl AircraftField {
    /// Reads fitted coefficients; `fs_hz` is the sample rate (Hz) the eddy columns were built at.
    ///
    /// With several fluxgates only the first fluxgate's block is read: the other blocks describe
    /// sources near the other fluxgates, not the aircraft's response to the earth field.
    pub fn from_coefficients(design: &Design, coefficients: &[f64], fs_hz: f64) -> Self {
        Self::from_block(design, coefficients, fs_hz, 0)
    }

    /// [`AircraftField::from_coefficients`] of the block of fluxgate `fluxgate` (0-based); the
    /// extra channels' and bias columns are read with the first block only.
    pub fn from_block(design: &Design, coefficients: &[f64], fs_hz: f64, fluxgate: usize) -> Self {
        let s = design.bt_scale;
        let mut field = Self::default();
        // `zz − xx` and `zz − yy` of the induced and eddy matrices, when the design has them.
        let mut traceless = [[f64::NAN; 2]; 2];
        let mut trace = 0.0;
        for (term, beta) in design.design_terms().iter().zip(coefficients) {
            if term.fluxgate != fluxgate {
                continue;
            }
            match term.column {
                Column::Permanent(i) => field.permanent_nt[i.index()] = *beta,
                Column::Induced(i, j) if i == j => field.induced[i.index()][i.index()] = beta / s,
                Column::Induced(i, j) => {
                    field.induced[i.index()][j.index()] = beta / (2.0 * s);
                    field.induced[j.index()][i.index()] = beta / (2.0 * s);
                }
                Column::Eddy(i, j) => field.eddy_s[i.index()][j.index()] = beta / (s * fs_hz),
                Column::InducedTraceless(a) => traceless[0][a.index()] = beta / s,
                Column::EddyTraceless(a) => traceless[1][a.index()] = beta / (s * fs_hz),
                Column::InducedTrace => trace = beta / s,
                Column::Extra { .. } => {}
                Column::Bias => field.bias_nt = *beta,
            }
        }
        set_traceless_diagonal(&mut field.induced, traceless[0]);
        set_traceless_diagonal(&mut field.eddy_s, traceless[1]);
        (0..3).for_each(|k| field.induced[k][k] += trace / 3.0);
        field
    }

    /// The coefficients a fit with `design` at `fs_hz` should find for this field (to first
    /// order in `H/|B|`, and up to the unobservable traces); zero for the blocks of fluxgates
    /// after the first.
    pub fn to_coefficients(&self, design: &Design, fs_hz: f64) -> Vec<f64> {
        let s = design.bt_scale;
        design
            .design_terms()
            .iter()
            .map(|term| match term.column {
                _ if term.fluxgate != 0 => 0.0,
                Column::Permanent(i) => self.permanent_nt[i.index()],
                Column::Induced(i, j) if i == j => s * self.induced[i.index()][i.index()],
                Column::Induced(i, j) => {
                    s * (self.induced[i.index()][j.index()] + self.induced[j.index()][i.index()])
                }
                Column::Eddy(i, j) => s * fs_hz * self.eddy_s[i.index()][j.index()],
                Column::InducedTraceless(a) => s * zz_minus(&self.induced, a.index()),
                Column::EddyTraceless(a) => s * fs_hz * zz_minus(&self.eddy_s, a.index()),
                Column::InducedTrace => s * (0..3).map(|k| self.induced[k][k]).sum::<f64>(),
                Column::Extra { .. } => 0.0,
                Column::Bias => self.bias_nt,
            })
            .collect()
    }
}

/// `m[z][z] − m[a][a]`.
fn zz_minus(m: &[[f64; 3]; 3], a: usize) -> f64 {
    m[2][2] - m[a][a]
}

/// Sets a traceless diagonal from `zz − xx` and `zz − yy` (left alone when not fitted).
fn set_traceless_diagonal(m: &mut [[f64; 3]; 3], [zx, zy]: [f64; 2]) {
    if zx.is_nan() || zy.is_nan() {
        return;
    }
    let zz = (zx + zy) / 3.0;
    m[2][2] = zz;
    m[0][0] = zz - zx;
    m[1][1] = zz - zy;
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn coefficients_round_trip_through_the_physical_field() {
        let design = Design::new("p,i,e,b".parse().unwrap());
        let beta: Vec<f64> = (0..design.width()).map(|k| k as f64 * 3.0 - 20.0).collect();
        let field = AircraftField::from_coefficients(&design, &beta, 160.0);
        let back = field.to_coefficients(&design, 160.0);
        for (u, v) in beta.iter().zip(&back) {
            assert!((u - v).abs() < 1e-9);
        }
    }

    #[test]
    fn traceless_coefficients_round_trip_and_read_as_patent_terms() {
        let design = Design::new("patent".parse().unwrap());
        let beta: Vec<f64> = (0..16).map(|k| k as f64 * 7.0 - 40.0).collect();
        let field = AircraftField::from_coefficients(&design, &beta, 10.0);
        let trace: f64 = (0..3).map(|k| field.induced[k][k]).sum();
        assert!(trace.abs() < 1e-15);
        let with_trace = Design::new("p,it,trace,et".parse().unwrap());
        let mut more = beta.clone();
        more.insert(8, 150.0);
        let back = AircraftField::from_coefficients(&with_trace, &more, 10.0)
            .to_coefficients(&with_trace, 10.0);
        assert!((back[8] - 150.0).abs() < 1e-9 && (back[3] - beta[3]).abs() < 1e-9);
        let back = field.to_coefficients(&design, 10.0);
        for (u, v) in beta.iter().zip(&back) {
            assert!((u - v).abs() < 1e-9, "{u} {v}");
        }
        // VV−LL is the `zz − xx` column's coefficient over Bt_scale.
        let vv_ll = field.patent_terms().induced.vv_ll;
        assert!((vv_ll - beta[3] / 50_000.0).abs() < 1e-15);
    }
}
