//! Which Tolles-Lawson terms a model uses, and the names of its columns.
//!
//! ```
//! use tolles_core::model::terms::TermSet;
//! let terms: TermSet = "permanent,i5,e8".parse().unwrap();
//! assert_eq!(terms.columns().len(), 3 + 5 + 8);
//! assert_eq!(terms.to_string(), "permanent,i5,e8");
//! ```
//!
//! Whatever order the user lists them in, columns always come in MagNav.jl's `create_TL_A` order:
//! permanent, induced, eddy, bias.

use serde::{Deserialize, Serialize};
use std::fmt;
use std::str::FromStr;
use thiserror::Error;

/// A body axis (FRD): x forward (patent L), y right (patent T), z down (patent V).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Axis {
    /// Forward (patent L).
    X,
    /// Right (patent T).
    Y,
    /// Down (patent V).
    Z,
}

impl Axis {
    /// The three axes in order x, y, z.
    pub const ALL: [Axis; 3] = [Axis::X, Axis::Y, Axis::Z];

    /// Index 0, 1, 2 for x, y, z.
    pub fn index(self) -> usize {
        self as usize
    }

    fn letter(self) -> char {
        ['x', 'y', 'z'][self.index()]
    }
}

/// Which induced columns `B̂i·Bj / Bt_scale` to use.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum InducedTerms {
    /// `induced` / `i`: xx, xy, xz, yy, yz, zz (6 columns).
    Six,
    /// `i5`: the six without zz, which is nearly collinear with the others (`Σ B̂i·Bi = |B|`).
    Five,
    /// `i3`: the diagonal xx, yy, zz.
    Three,
    /// `it`: the patent's five traceless combinations, the only ones a scalar magnetometer can
    /// see: VV−LL and VV−TT (`zz−xx`, `zz−yy`) and TL+LT, LV+VL, TV+VT (`xy`, `xz`, `yz`).
    /// A ridge shrinks them towards an isotropic induced field, not towards `I_zz = 0` as `i5`
    /// implicitly does.
    Traceless,
}

/// Which eddy-current columns `B̂i·Ḃj / Bt_scale` to use (Ḃ per sample).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum EddyTerms {
    /// `eddy` / `e`: all nine, row-major xx, xy, …, zz.
    Nine,
    /// `e8`: the nine without zz (`Σ B̂i·Ḃi = d|B|/dt` carries no attitude signal).
    Eight,
    /// `e3`: the diagonal xx, yy, zz.
    Three,
    /// `et`: the patent's eight traceless combinations: VV−LL and VV−TT (`zz−xx`, `zz−yy`) and
    /// the six off-diagonal terms.
    Traceless,
}

/// One column of the design matrix.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Column {
    /// `B̂i`: the permanent field along axis i (coefficient in nT).
    Permanent(Axis),
    /// `B̂i·Bj / Bt_scale`: induced field (coefficient in nT per unit of `Bj/Bt_scale`).
    Induced(Axis, Axis),
    /// `B̂i·Ḃj / Bt_scale` with Ḃ in nT per sample: eddy-current field.
    Eddy(Axis, Axis),
    /// `(|B|/3 − B̂a·Ba) / Bt_scale`: the traceless induced combination `zz − aa` (patent VV−LL
    /// for a = x, VV−TT for a = y); coefficient `Bt_scale·(I_zz − I_aa)`.
    InducedTraceless(Axis),
    /// `(B̂·Ḃ/3 − B̂a·Ḃa) / Bt_scale`, Ḃ per sample: the traceless eddy combination `zz − aa`;
    /// coefficient `Bt_scale·fs·(E_zz − E_aa)`.
    EddyTraceless(Axis),
    /// `|B| / (3·Bt_scale)`: the isotropic (trace) part of the induced field, parallel to B;
    /// coefficient `Bt_scale·(I_xx + I_yy + I_zz)`. Band-passed it is only the earth field's
    /// own variation, so only low frequencies against a reference (heading levels) pin it.
    InducedTrace,
    /// `B̂a·c` for the extra channel `channel` (e.g. a current, A): the projection of a field
    /// of fixed direction in the body frame proportional to the channel; coefficient in nT per
    /// unit of the channel along axis a.
    Extra {
        /// The extra channel (0-based).
        channel: usize,
        /// The body axis a of the field's direction.
        axis: Axis,
    },
    /// A column of ones (coefficient in nT).
    Bias,
}

impl Column {
    /// The column as weights of the plain diagonal columns `xx`, `yy`, `zz` of its kind, when
    /// it is such a combination: with `|B| = Σ B̂i·Bi` (and `B̂·Ḃ = Σ B̂i·Ḃi`), the traceless
    /// `zz − aa` is `(xx + yy + zz)/3 − aa` and the trace `(xx + yy + zz)/3`. Equal up to
    /// rounding, so a fit that holds the diagonals anyway filters and factors these from them.
    pub fn of_diagonals(self) -> Option<[(Column, f64); 3]> {
        let weights = |minus: Option<Axis>, plain: fn(Axis, Axis) -> Column| {
            Axis::ALL.map(|i| {
                let own = if Some(i) == minus { 1.0 } else { 0.0 };
                (plain(i, i), 1.0 / 3.0 - own)
            })
        };
        match self {
            Column::InducedTraceless(a) => Some(weights(Some(a), Column::Induced)),
            Column::EddyTraceless(a) => Some(weights(Some(a), Column::Eddy)),
            Column::InducedTrace => Some(weights(None, Column::Induced)),
            _ => None,
        }
    }
}

impl fmt::Display for Column {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Column::Permanent(i) => write!(f, "perm_{}", i.letter()),
            Column::Induced(i, j) => write!(f, "induced_{}{}", i.letter(), j.letter()),
            Column::Eddy(i, j) => write!(f, "eddy_{}{}", i.letter(), j.letter()),
            Column::InducedTraceless(a) => write!(f, "induced_zz-{0}{0}", a.letter()),
            Column::EddyTraceless(a) => write!(f, "eddy_zz-{0}{0}", a.letter()),
            Column::InducedTrace => write!(f, "induced_trace"),
            Column::Extra { channel, axis } => write!(f, "extra{}_{}", channel + 1, axis.letter()),
            Column::Bias => write!(f, "bias"),
        }
    }
}

/// The terms of a Tolles-Lawson model.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(try_from = "String", into = "String")]
pub struct TermSet {
    /// Three permanent columns.
    pub permanent: bool,
    /// Induced columns, if any.
    pub induced: Option<InducedTerms>,
    /// The isotropic induced column `trace`.
    pub trace: bool,
    /// Eddy-current columns, if any.
    pub eddy: Option<EddyTerms>,
    /// A column of ones.
    pub bias: bool,
}

/// A term list that cannot be understood.
#[derive(Debug, Clone, Error, PartialEq, Eq)]
pub enum TermsError {
    /// A term name that is not known.
    #[error("unknown term {0:?}; use patent, permanent|p, induced|i, it, i5, i3, trace, eddy|e, et, e8, e3, bias|b")]
    Unknown(String),
    /// A term given twice, or with another set of its kind (the term, and the kind).
    #[error("term {0:?} given twice or together with another {1} set; choose one")]
    Repeated(String, &'static str),
    /// No term at all.
    #[error("no terms given; use e.g. permanent,induced,eddy")]
    Empty,
}

impl TermSet {
    /// MagNav.jl's default: permanent, induced (6), eddy (9) = 18 columns.
    pub fn magnav_default() -> Self {
        Self {
            permanent: true,
            induced: Some(InducedTerms::Six),
            eddy: Some(EddyTerms::Nine),
            trace: false,
            bias: false,
        }
    }

    /// The 16 terms a scalar magnetometer can identify (the patent's 3 + 5 + 8):
    /// permanent, `i5`, `e8`.
    pub fn identifiable() -> Self {
        Self {
            permanent: true,
            induced: Some(InducedTerms::Five),
            eddy: Some(EddyTerms::Eight),
            trace: false,
            bias: false,
        }
    }

    /// The patent's 16 terms in their own traceless form (`patent`, i.e. `permanent,it,et`):
    /// what `tolles fit` uses by default for one fluxgate.
    pub fn patent() -> Self {
        Self {
            permanent: true,
            induced: Some(InducedTerms::Traceless),
            eddy: Some(EddyTerms::Traceless),
            trace: false,
            bias: false,
        }
    }

    /// Whether the columns span an isotropic term, the induced trace `|B|/s` or the eddy trace
    /// `B̂·Ḃ/s`: the fluxgate's own magnitude and its rate, which carry the earth's anomalies
    /// as much as any aircraft field.
    pub fn spans_isotropic(&self) -> bool {
        self.trace
            || matches!(self.induced, Some(InducedTerms::Six | InducedTerms::Three))
            || matches!(self.eddy, Some(EddyTerms::Nine | EddyTerms::Three))
    }

    /// The design-matrix columns in order.
    pub fn columns(&self) -> Vec<Column> {
        use Axis::{X, Y, Z};
        let mut cols = Vec::with_capacity(19);
        if self.permanent {
            cols.extend(Axis::ALL.map(Column::Permanent));
        }
        let induced: &[(Axis, Axis)] = match self.induced {
            Some(InducedTerms::Six) => &[(X, X), (X, Y), (X, Z), (Y, Y), (Y, Z), (Z, Z)],
            Some(InducedTerms::Five) => &[(X, X), (X, Y), (X, Z), (Y, Y), (Y, Z)],
            Some(InducedTerms::Three) => &[(X, X), (Y, Y), (Z, Z)],
            Some(InducedTerms::Traceless) => {
                cols.extend([Column::InducedTraceless(X), Column::InducedTraceless(Y)]);
                &[(X, Y), (X, Z), (Y, Z)]
            }
            None => &[],
        };
        cols.extend(induced.iter().map(|&(i, j)| Column::Induced(i, j)));
        if self.trace {
            cols.push(Column::InducedTrace);
        }
        let all_pairs = Axis::ALL
            .into_iter()
            .flat_map(|i| Axis::ALL.map(|j| (i, j)));
        let eddy: Vec<(Axis, Axis)> = match self.eddy {
            Some(EddyTerms::Nine) => all_pairs.collect(),
            Some(EddyTerms::Eight) => all_pairs.take(8).collect(),
            Some(EddyTerms::Three) => vec![(X, X), (Y, Y), (Z, Z)],
            Some(EddyTerms::Traceless) => {
                cols.extend([Column::EddyTraceless(X), Column::EddyTraceless(Y)]);
                all_pairs.filter(|(i, j)| i != j).collect()
            }
            None => vec![],
        };
        cols.extend(eddy.into_iter().map(|(i, j)| Column::Eddy(i, j)));
        if self.bias {
            cols.push(Column::Bias);
        }
        cols
    }
}

impl FromStr for TermSet {
    type Err = TermsError;

    /// Parses a comma-separated list such as `permanent,induced,eddy` or `p,i5,e8,b`.
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let mut set = TermSet {
            permanent: false,
            induced: None,
            eddy: None,
            trace: false,
            bias: false,
        };
        for raw in s.split(',').map(str::trim).filter(|t| !t.is_empty()) {
            let token = raw.to_ascii_lowercase();
            let repeated = |group| TermsError::Repeated(raw.to_string(), group);
            match token.as_str() {
                "permanent" | "p" => {
                    if std::mem::replace(&mut set.permanent, true) {
                        return Err(repeated("permanent"));
                    }
                }
                "bias" | "b" => {
                    if std::mem::replace(&mut set.bias, true) {
                        return Err(repeated("bias"));
                    }
                }
                "trace" => {
                    if std::mem::replace(&mut set.trace, true) {
                        return Err(repeated("trace"));
                    }
                }
                "patent" => {
                    let patent = TermSet::patent();
                    if set.permanent || set.induced.is_some() || set.eddy.is_some() {
                        return Err(repeated("patent"));
                    }
                    set = TermSet {
                        bias: set.bias,
                        trace: set.trace,
                        ..patent
                    };
                }
                "induced" | "i" | "i6" | "i5" | "i3" | "it" => {
                    let kind = match token.as_str() {
                        "it" => InducedTerms::Traceless,
                        "i5" => InducedTerms::Five,
                        "i3" => InducedTerms::Three,
                        _ => InducedTerms::Six,
                    };
                    if set.induced.replace(kind).is_some() {
                        return Err(repeated("induced"));
                    }
                }
                "eddy" | "e" | "e9" | "e8" | "e3" | "et" => {
                    let kind = match token.as_str() {
                        "et" => EddyTerms::Traceless,
                        "e8" => EddyTerms::Eight,
                        "e3" => EddyTerms::Three,
                        _ => EddyTerms::Nine,
                    };
                    if set.eddy.replace(kind).is_some() {
                        return Err(repeated("eddy"));
                    }
                }
                _ => return Err(TermsError::Unknown(raw.to_string())),
            }
        }
        if set.columns().is_empty() {
            return Err(TermsError::Empty);
        }
        Ok(set)
    }
}

impl fmt::Display for TermSet {
    /// The canonical list, e.g. `permanent,induced,eddy`; it parses back to the same set.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let mut parts: Vec<&str> = Vec::new();
        if self.permanent {
            parts.push("permanent");
        }
        parts.extend(self.induced.map(|k| match k {
            InducedTerms::Six => "induced",
            InducedTerms::Five => "i5",
            InducedTerms::Three => "i3",
            InducedTerms::Traceless => "it",
        }));
        if self.trace {
            parts.push("trace");
        }
        parts.extend(self.eddy.map(|k| match k {
            EddyTerms::Nine => "eddy",
            EddyTerms::Eight => "e8",
            EddyTerms::Three => "e3",
            EddyTerms::Traceless => "et",
        }));
        if self.bias {
            parts.push("bias");
        }
        f.write_str(&parts.join(","))
    }
}

impl TryFrom<String> for TermSet {
    type Error = TermsError;
    fn try_from(s: String) -> Result<Self, Self::Error> {
        s.parse()
    }
}

impl From<TermSet> for String {
    fn from(t: TermSet) -> String {
        t.to_string()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn magnav_order_has_18_columns_in_create_tl_a_order() {
        let names: Vec<String> = TermSet::magnav_default()
            .columns()
            .iter()
            .map(|c| c.to_string())
            .collect();
        assert_eq!(names.len(), 18);
        assert_eq!(&names[..4], ["perm_x", "perm_y", "perm_z", "induced_xx"]);
        assert_eq!(names[8], "induced_zz");
        assert_eq!(names[9], "eddy_xx");
        assert_eq!(names[12], "eddy_yx");
        assert_eq!(names[17], "eddy_zz");
    }

    #[test]
    fn sizes_of_every_set() {
        let n = |s: &str| s.parse::<TermSet>().unwrap().columns().len();
        assert_eq!(n("p"), 3);
        assert_eq!(n("i"), 6);
        assert_eq!(n("i5"), 5);
        assert_eq!(n("i3"), 3);
        assert_eq!(n("e"), 9);
        assert_eq!(n("e8"), 8);
        assert_eq!(n("e3"), 3);
        assert_eq!(n("b"), 1);
        assert_eq!(n("eddy, permanent ,BIAS"), 13);
        assert_eq!(n("it"), 5);
        assert_eq!(n("et"), 8);
        assert_eq!(n("patent"), 16);
        assert_eq!(n("patent,b"), 17);
        assert_eq!(n("patent,trace"), 17);
    }

    #[test]
    fn user_order_does_not_change_column_order() {
        let a: TermSet = "e,i,p".parse().unwrap();
        assert_eq!(a, TermSet::magnav_default());
    }

    #[test]
    fn bad_lists_are_rejected_with_reasons() {
        assert!(matches!("p,q".parse::<TermSet>(), Err(TermsError::Unknown(t)) if t == "q"));
        assert!(matches!(
            "i,i5".parse::<TermSet>(),
            Err(TermsError::Repeated(_, "induced"))
        ));
        assert_eq!("".parse::<TermSet>(), Err(TermsError::Empty));
        assert!(matches!(
            "p,patent".parse::<TermSet>(),
            Err(TermsError::Repeated(_, "patent"))
        ));
    }

    #[test]
    fn display_round_trips() {
        for s in [
            "permanent,induced,eddy",
            "permanent,i5,e8,bias",
            "i3,e3",
            "permanent,it,et",
            "permanent,it,trace,et",
            "bias",
        ] {
            assert_eq!(s.parse::<TermSet>().unwrap().to_string(), s);
        }
    }
}
