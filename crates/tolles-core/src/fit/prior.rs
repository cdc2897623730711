//! Physical sizes of the terms: a ridge prior in the units of the coefficients.
//!
//! ```
//! use tolles_core::fit::prior::Prior;
//! use tolles_core::model::design::Design;
//!
//! let design = Design::new("p,it,et".parse().unwrap());
//! let scales = Prior::AIRCRAFT.scales(&design.design_terms(), design.bt_scale, 10.0);
//! assert_eq!(scales[0], Some(Prior::AIRCRAFT.permanent_nt)); // a permanent field, nT
//! // A traceless induced coefficient is Bt_scale·(I_zz − I_aa): the scale of an induced
//! // coefficient times Bt_scale.
//! assert_eq!(scales[3], Some(Prior::AIRCRAFT.induced * 50_000.0));
//! ```
//!
//! Cross-validation scales its ridge by each column's own sum of squares (a ridge on
//! standardised columns), which says nothing of how large a coefficient may be: a column the
//! calibration hardly moved gets almost no penalty, and its coefficient may grow until it
//! describes a field no aircraft has (a permanent field of 10⁵ nT, an induced coefficient of
//! −0.9) whose effect inside the fitting band cancels against another term's. Outside the band,
//! on another heading, it does not cancel.
//!
//! A [`Prior`] states the sizes a physicist would expect: a permanent field of thousands of nT,
//! induced coefficients of a few hundredths, eddy-current terms of milliseconds, and fields of
//! tens of nT per unit of an extra channel (nT/A for a current). Each coefficient `β_j` then
//! adds `ν·(β_j / s_j)²` to the least-squares sum, where `s_j` is its scale in coefficient
//! units and `ν` the variance of one independent residual, so the data outweigh the prior
//! wherever they determine a term, and the prior decides where they do not: a Gaussian prior
//! of standard deviation `s_j` on each coefficient.

use crate::model::design::Term;
use crate::model::terms::Column;
use serde::{Deserialize, Serialize};

/// The standard deviation of each kind of term a fit expects before it sees data.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Prior {
    /// A permanent field component (nT).
    pub permanent_nt: f64,
    /// An induced coefficient (dimensionless: nT of aircraft field per nT of earth field).
    pub induced: f64,
    /// An eddy-current coefficient (s: nT of field per nT/s of the earth field's rate).
    pub eddy_s: f64,
    /// The field of an extra channel along one axis, per unit of the channel (nT/A for a
    /// current).
    pub extra_nt_per_unit: f64,
}

impl Prior {
    /// An aircraft's own field: a cabin installation reaches a few thousand nT of permanent
    /// field and induced coefficients of a few hundredths; eddy currents respond within
    /// milliseconds; a cable or motor gives tens of nT per ampere.
    pub const AIRCRAFT: Prior = Prior {
        permanent_nt: 3_000.0,
        induced: 0.03,
        eddy_s: 0.003,
        extra_nt_per_unit: 200.0,
    };

    /// A fluxgate's own errors as its magnitude shows them: offsets of up to hundreds of nT
    /// (more when it sits near the airframe) and a distortion (scale and axis errors) of about
    /// a thousandth.
    pub const FLUXGATE: Prior = Prior {
        permanent_nt: 1_000.0,
        induced: 1e-3,
        eddy_s: 1e-3,
        extra_nt_per_unit: 200.0,
    };

    /// The scale `s_j` of each term's coefficient, in the coefficient's units (see
    /// [`Column`]); `None` for the bias, which no physics bounds.
    pub fn scales(&self, terms: &[Term], bt_scale: f64, fs_hz: f64) -> Vec<Option<f64>> {
        terms
            .iter()
            .map(|t| self.scale(t.column, bt_scale, fs_hz))
            .collect()
    }

    /// The kind of each term whose prior cross-validation scales as one (see [`Group`]);
    /// `None` for the bias.
    pub fn groups(terms: &[Term]) -> Vec<Option<Group>> {
        terms.iter().map(|t| Group::of(t.column)).collect()
    }

    fn scale(&self, column: Column, bt_scale: f64, fs_hz: f64) -> Option<f64> {
        match column {
            Column::Permanent(_) => Some(self.permanent_nt),
            Column::Induced(..) | Column::InducedTraceless(_) | Column::InducedTrace => {
                Some(self.induced * bt_scale)
            }
            Column::Eddy(..) | Column::EddyTraceless(_) => Some(self.eddy_s * bt_scale * fs_hz),
            Column::Extra { .. } => Some(self.extra_nt_per_unit),
            Column::Bias => None,
        }
    }

    /// `1/s_j²` of each term (0 for the bias): the prior's penalty per unit of residual
    /// variance.
    pub fn precisions(&self, terms: &[Term], bt_scale: f64, fs_hz: f64) -> Vec<f64> {
        self.scales(terms, bt_scale, fs_hz)
            .into_iter()
            .map(|s| s.map_or(0.0, |s| 1.0 / (s * s)))
            .collect()
    }
}

/// Terms whose prior is scaled together: an aircraft whose permanent field is small may still
/// carry a strong current's field, so cross-validation tunes each kind's strength on its own.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Group {
    /// The permanent-field terms (nT).
    Permanent,
    /// The induced-field terms (dimensionless).
    Induced,
    /// The eddy-current terms (s).
    Eddy,
    /// The extra channels' terms (nT per unit of the channel).
    Extra,
}

impl Group {
    /// The group of a column; `None` for the bias.
    pub fn of(column: Column) -> Option<Group> {
        match column {
            Column::Permanent(_) => Some(Group::Permanent),
            Column::Induced(..) | Column::InducedTraceless(_) | Column::InducedTrace => {
                Some(Group::Induced)
            }
            Column::Eddy(..) | Column::EddyTraceless(_) => Some(Group::Eddy),
            Column::Extra { .. } => Some(Group::Extra),
            Column::Bias => None,
        }
    }
}

/// A prior as a fit's choice of terms uses it: the precision `1/s²` of each of the union's
/// columns, and by how much the variance of one independent residual exceeds that of one row
/// (band-passed rows are correlated over about `1/fraction` samples).
#[derive(Debug, Clone, PartialEq)]
pub struct PriorWeights {
    /// `1/s_j²` per column of the union of the candidate designs.
    pub precision: Vec<f64>,
    /// The group of each column.
    pub groups: Vec<Option<Group>>,
    /// Rows per independent residual.
    pub rows_per_residual: f64,
    /// Prefer the strongest prior the held-out folds cannot tell from the best (the calibration
    /// did not maneuver enough to separate the terms; see `crossval::cross_validate_prior`).
    pub parsimonious: bool,
}

impl PriorWeights {
    /// The precisions of the columns `picks` of the union.
    pub fn picked(&self, picks: &[usize]) -> PriorWeights {
        PriorWeights {
            precision: picks.iter().map(|&k| self.precision[k]).collect(),
            groups: picks.iter().map(|&k| self.groups[k]).collect(),
            rows_per_residual: self.rows_per_residual,
            parsimonious: self.parsimonious,
        }
    }

    /// The diagonal penalty for a residual variance per row of `row_variance` (nT²).
    pub fn penalty(&self, row_variance: f64) -> Vec<f64> {
        let nu = row_variance * self.rows_per_residual;
        self.precision.iter().map(|p| nu * p).collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::design::Design;

    #[test]
    fn eddy_scales_follow_the_sample_rate_and_the_bias_is_free() {
        let design = Design::new("p,et,b".parse().unwrap());
        let terms = design.design_terms();
        let at10 = Prior::AIRCRAFT.scales(&terms, 50_000.0, 10.0);
        let at20 = Prior::AIRCRAFT.scales(&terms, 50_000.0, 20.0);
        // An eddy coefficient is Bt_scale·fs·E: twice the rate, twice the scale.
        assert_eq!(at20[3].unwrap(), 2.0 * at10[3].unwrap());
        assert_eq!(at10[3].unwrap(), 0.003 * 50_000.0 * 10.0);
        assert_eq!(*at10.last().unwrap(), None);
        let precision = Prior::AIRCRAFT.precisions(&terms, 50_000.0, 10.0);
        assert_eq!(*precision.last().unwrap(), 0.0);
        assert_eq!(precision[0], 1.0 / 3_000.0f64.powi(2));
    }
}
