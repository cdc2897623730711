//! The aircraft's field under the patent's names: its 16 observable terms, 3 permanent (nT),
//! 5 induced (dimensionless) and 8 eddy-current (s), as [`Term::value`] reads each from an
//! [`AircraftField`].

use super::Term;
use crate::model::interpret::AircraftField;
use serde::{Deserialize, Serialize};

impl AircraftField {
    /// The 16 terms of the patent (L = x, T = y, V = z; eddy `ab` is the field along b from a
    /// change along a, `E[b][a]`), as [`Term::value`] defines each.
    pub fn patent_terms(&self) -> PatentTerms {
        PatentTerms::from_values(Term::OBSERVABLE.map(|t| t.value(self)))
    }
}

/// The patent's perm terms (nT): T along y (right), L along x (forward), V along z (down).
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct PermTerms {
    /// T: permanent field along y, right (nT).
    #[serde(rename = "T")]
    pub t: f64,
    /// L: permanent field along x, forward (nT).
    #[serde(rename = "L")]
    pub l: f64,
    /// V: permanent field along z, down (nT).
    #[serde(rename = "V")]
    pub v: f64,
}

/// The patent's five observable induced terms (dimensionless).
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct InducedPatentTerms {
    /// VV−TT: `I[z][z] − I[y][y]` (dimensionless).
    #[serde(rename = "VV-TT")]
    pub vv_tt: f64,
    /// VV−LL: `I[z][z] − I[x][x]` (dimensionless).
    #[serde(rename = "VV-LL")]
    pub vv_ll: f64,
    /// TL+LT: `I[x][y] + I[y][x]` (dimensionless).
    #[serde(rename = "TL+LT")]
    pub tl_lt: f64,
    /// TV+VT: `I[y][z] + I[z][y]` (dimensionless).
    #[serde(rename = "TV+VT")]
    pub tv_vt: f64,
    /// LV+VL: `I[x][z] + I[z][x]` (dimensionless).
    #[serde(rename = "LV+VL")]
    pub lv_vl: f64,
}

/// The patent's eight observable eddy-current terms (seconds).
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct EddyPatentTerms {
    /// vv−tt: `E[z][z] − E[y][y]` (s).
    #[serde(rename = "vv-tt")]
    pub vv_tt: f64,
    /// vv−ll: `E[z][z] − E[x][x]` (s).
    #[serde(rename = "vv-ll")]
    pub vv_ll: f64,
    /// tl: `E[x][y]`, field along x (L) from a change along y (T) (s).
    pub tl: f64,
    /// tv: `E[z][y]`, field along z (V) from a change along y (T) (s).
    pub tv: f64,
    /// lt: `E[y][x]`, field along y (T) from a change along x (L) (s).
    pub lt: f64,
    /// lv: `E[z][x]`, field along z (V) from a change along x (L) (s).
    pub lv: f64,
    /// vl: `E[x][z]`, field along x (L) from a change along z (V) (s).
    pub vl: f64,
    /// vt: `E[y][z]`, field along y (T) from a change along z (V) (s).
    pub vt: f64,
}

/// The 16 patent terms: 3 perm (nT), 5 induced (dimensionless), 8 eddy (s).
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct PatentTerms {
    /// The 3 permanent terms (nT).
    #[serde(rename = "perm_nT")]
    pub perm_nt: PermTerms,
    /// The 5 induced terms (dimensionless).
    pub induced: InducedPatentTerms,
    /// The 8 eddy-current terms (s).
    pub eddy_s: EddyPatentTerms,
}

impl PatentTerms {
    /// From the 16 values in [`Term::OBSERVABLE`] order (nT, dimensionless, s by section).
    pub fn from_values(values: [f64; 16]) -> Self {
        let [t, l, v, vv_tt, vv_ll, tl_lt, tv_vt, lv_vl, ev_tt, ev_ll, tl, tv, lt, lv, vl, vt] =
            values;
        PatentTerms {
            perm_nt: PermTerms { t, l, v },
            induced: InducedPatentTerms {
                vv_tt,
                vv_ll,
                tl_lt,
                tv_vt,
                lv_vl,
            },
            eddy_s: EddyPatentTerms {
                vv_tt: ev_tt,
                vv_ll: ev_ll,
                tl,
                tv,
                lt,
                lv,
                vl,
                vt,
            },
        }
    }

    /// The 16 values in [`Term::OBSERVABLE`] order (nT, dimensionless, s by section).
    pub fn values(&self) -> [f64; 16] {
        let (p, i, e) = (&self.perm_nt, &self.induced, &self.eddy_s);
        [
            p.t, p.l, p.v, i.vv_tt, i.vv_ll, i.tl_lt, i.tv_vt, i.lv_vl, e.vv_tt, e.vv_ll, e.tl,
            e.tv, e.lt, e.lv, e.vl, e.vt,
        ]
    }

    /// The value of `term` (unit [`Term::unit`]); `None` for TT, LL and VV alone.
    pub fn get(&self, term: Term) -> Option<f64> {
        Some(self.values()[term.observable_index()?])
    }

    /// The 16 values in the patent's order with their names.
    pub fn named(&self) -> [(&'static str, f64); 16] {
        let values = self.values();
        std::array::from_fn(|k| (Term::OBSERVABLE[k].name(), values[k]))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn patent_terms_read_back_by_term_and_name() {
        let mut field = AircraftField::default();
        for k in 0..3 {
            field.permanent_nt[k] = 10.0 + k as f64;
            for j in 0..3 {
                field.induced[k][j] = 1e-3 * (3 * k + j) as f64;
                field.eddy_s[k][j] = 1e-4 * (3 * k + j + 1) as f64;
            }
        }
        let terms = field.patent_terms();
        assert_eq!(PatentTerms::from_values(terms.values()), terms);
        for (term, (name, value)) in Term::OBSERVABLE.iter().zip(terms.named()) {
            assert_eq!(term.name(), name);
            assert_eq!(terms.get(*term), Some(value));
        }
        assert_eq!(
            terms.induced.tl_lt,
            field.induced[0][1] + field.induced[1][0]
        );
        assert_eq!(terms.get(Term::InducedTT), None);
    }

    #[test]
    fn patent_eddy_letters_read_the_transposed_matrix() {
        let mut field = AircraftField::default();
        field.eddy_s[1][2] = 0.3; // field along y (T) from a change along z (V): patent 'vt'
        field.eddy_s[2][0] = 0.7; // field along z (V) from a change along x (L): patent 'lv'
        let e = field.patent_terms().eddy_s;
        assert_eq!((e.vt, e.lv, e.tv, e.vl), (0.3, 0.7, 0.0, 0.0));
    }

    #[test]
    fn patent_terms_ignore_the_trace() {
        let a = AircraftField {
            induced: [[0.01, 0.0, 0.0], [0.0, 0.02, 0.0], [0.0, 0.0, 0.05]],
            ..AircraftField::default()
        };
        let mut b = a;
        for k in 0..3 {
            b.induced[k][k] += 0.1;
        }
        assert!((a.patent_terms().induced.vv_tt - 0.03).abs() < 1e-15);
        let (ta, tb) = (a.patent_terms().induced, b.patent_terms().induced);
        assert!((ta.vv_tt - tb.vv_tt).abs() < 1e-15 && (ta.vv_ll - tb.vv_ll).abs() < 1e-15);
    }
}
