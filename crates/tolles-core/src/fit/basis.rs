//! The columns a fit fills, filters and factors: every candidate's terms once, less those that
//! are combinations of other terms held anyway.
//!
//! With the defaults the candidates hold the patent's traceless columns and the plain diagonals
//! they are made of (see [`Column::of_diagonals`]). A filter is linear and a triangular factor
//! `R` of some columns gives `R·T` for any combinations `T` of them (`(R·T)ᵀ(R·T) = Tᵀ·AᵀA·T`),
//! so the four traceless columns are formed from the diagonals' factors and level rows instead
//! of being filled, filtered and factored over every sample: 18 columns instead of 22.
//!
//! [`Column::of_diagonals`]: crate::model::terms::Column::of_diagonals

use super::factor::FoldFactor;
use super::level_rows::LevelRows;
use crate::model::design::Term;
use nalgebra::DMatrix;

/// The terms whose columns are stored, and every term as a combination of them.
pub(super) struct Basis {
    /// Terms whose columns are filled, filtered and factored.
    pub(super) stored: Vec<Term>,
    /// Per term, its stored columns and their weights; `None` when every term is stored.
    terms: Option<Vec<Vec<(usize, f64)>>>,
}

impl Basis {
    /// The basis of `terms`: each term whose parts ([`Column::of_diagonals`]) are all among
    /// `terms` (for its own fluxgate) is formed from them; the others are stored, in their order.
    ///
    /// [`Column::of_diagonals`]: crate::model::terms::Column::of_diagonals
    pub(super) fn of(terms: &[Term]) -> Basis {
        let formed: Vec<Option<Vec<(Term, f64)>>> =
            terms.iter().map(|t| diagonal_parts(t, terms)).collect();
        if formed.iter().all(Option::is_none) {
            return Basis {
                stored: terms.to_vec(),
                terms: None,
            };
        }
        let stored: Vec<Term> = terms
            .iter()
            .zip(&formed)
            .filter(|(_, f)| f.is_none())
            .map(|(t, _)| *t)
            .collect();
        let position = |t: &Term| stored.iter().position(|s| s == t).expect("stored");
        let terms = terms
            .iter()
            .zip(formed)
            .map(|(t, f)| match f {
                None => vec![(position(t), 1.0)],
                Some(parts) => parts.iter().map(|(p, w)| (position(p), *w)).collect(),
            })
            .collect();
        Basis {
            stored,
            terms: Some(terms),
        }
    }

    /// The folds' factors of the stored columns and the target as factors of every term and
    /// the target.
    pub(super) fn folds(&self, folds: Vec<FoldFactor>) -> Vec<FoldFactor> {
        folds
            .into_iter()
            .map(|f| FoldFactor {
                r: self.on_terms(&f.r, true),
                level_r: self.on_terms(&f.level_r, true),
                ..f
            })
            .collect()
    }

    /// Level rows of the stored columns as level rows of every term.
    pub(super) fn level_rows(&self, rows: &[LevelRows]) -> Vec<LevelRows> {
        rows.iter()
            .map(|r| LevelRows {
                a: self.on_terms(&r.a, false),
                y: r.y.clone(),
                at: r.at.clone(),
            })
            .collect()
    }

    /// `m`, whose columns are the stored ones, then the target (`with_target`), perhaps others
    /// after it (the fluxgate's magnitude, for its calibration), with the columns of every term
    /// and the target: a stored term's column is copied, bit for bit, and the others after the
    /// target are dropped.
    /// Coefficients of every term (`beta`, one per term of the basis) as coefficients of the
    /// stored columns: the same fit of the stored columns' rows.
    pub(super) fn on_stored(&self, beta: &[f64]) -> Vec<f64> {
        let Some(terms) = &self.terms else {
            return beta.to_vec();
        };
        let mut out = vec![0.0; self.stored.len()];
        for (parts, b) in terms.iter().zip(beta) {
            for &(stored, w) in parts {
                out[stored] += w * b;
            }
        }
        out
    }

    /// A square matrix of the stored columns (a score covariance, `S`) as one of every term:
    /// `TᵀST` with `T` the terms' weights.
    pub(super) fn square_on_terms(&self, s: &DMatrix<f64>) -> DMatrix<f64> {
        let right = self.on_terms(s, false).transpose();
        self.on_terms(&right, false)
    }

    fn on_terms(&self, m: &DMatrix<f64>, with_target: bool) -> DMatrix<f64> {
        let stored = self.stored.len();
        let Some(terms) = &self.terms else {
            return m.columns(0, stored + usize::from(with_target)).into_owned();
        };
        let width = terms.len() + usize::from(with_target);
        let mut out = DMatrix::zeros(m.nrows(), width);
        for (u, parts) in terms.iter().enumerate() {
            match parts.as_slice() {
                [(b, w)] if *w == 1.0 => out.column_mut(u).copy_from(&m.column(*b)),
                _ => {
                    for &(b, w) in parts {
                        out.column_mut(u).axpy(w, &m.column(b), 1.0);
                    }
                }
            }
        }
        if with_target {
            out.column_mut(width - 1).copy_from(&m.column(stored));
        }
        out
    }
}

/// The parts `term`'s column is made of ([`Column::of_diagonals`]), each a term of its own
/// fluxgate with its weight, when every one of them is among `among`.
///
/// [`Column::of_diagonals`]: crate::model::terms::Column::of_diagonals
pub(super) fn diagonal_parts(term: &Term, among: &[Term]) -> Option<Vec<(Term, f64)>> {
    let parts = term.column.of_diagonals()?;
    let found = parts.map(|(column, w)| {
        let part = Term {
            fluxgate: term.fluxgate,
            column,
        };
        among.contains(&part).then_some((part, w))
    });
    found.into_iter().collect()
}

/// `beta`, the coefficients of `terms`, as coefficients of `columns`: 0 for a column that is
/// none of `terms`.
pub(super) fn on_columns(columns: &[Term], terms: &[Term], beta: &[f64]) -> Vec<f64> {
    columns
        .iter()
        .map(|c| terms.iter().position(|t| t == c).map_or(0.0, |k| beta[k]))
        .collect()
}

/// The entries of `s`, whose rows and columns are `columns`, for the rows and columns
/// `terms` (zero for a term not among `columns`).
pub(super) fn on_column_pairs(columns: &[Term], terms: &[Term], s: &DMatrix<f64>) -> DMatrix<f64> {
    let at: Vec<Option<usize>> = terms
        .iter()
        .map(|t| columns.iter().position(|c| c == t))
        .collect();
    DMatrix::from_fn(terms.len(), terms.len(), |i, j| match (at[i], at[j]) {
        (Some(a), Some(b)) => s[(a, b)],
        _ => 0.0,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fit::choice::union_of_terms;
    use crate::fit::qr::triangular_factor;
    use crate::fit::FitSettings;
    use crate::model::design::Design;
    use crate::model::terms::{Axis, Column, TermSet};
    use crate::model::vector::VectorSeries;

    fn default_union() -> Vec<Term> {
        union_of_terms(&FitSettings::recommended().candidate_designs())
    }

    /// A wobbling fluxgate, nT.
    fn flight(n: usize) -> VectorSeries {
        let w = |k: usize, f: f64, p: f64| (f * k as f64 + p).sin();
        VectorSeries::new(
            (0..n)
                .map(|k| 20_000.0 + 3_000.0 * w(k, 0.05, 0.0))
                .collect(),
            (0..n)
                .map(|k| -4_000.0 + 2_500.0 * w(k, 0.07, 1.0))
                .collect(),
            (0..n).map(|k| 45_000.0 + 900.0 * w(k, 0.11, 2.0)).collect(),
        )
    }

    fn columns(terms: &[Term], flux: &VectorSeries) -> DMatrix<f64> {
        let n = flux.len();
        let mut a = vec![0.0; n * terms.len()];
        Design::new(TermSet::magnav_default()).matrix_over(flux, 0..n, terms, &mut a);
        DMatrix::from_vec(n, terms.len(), a)
    }

    #[test]
    fn the_defaults_store_the_plain_columns_and_form_the_traceless_ones() {
        let union = default_union();
        assert_eq!(union.len(), 22);
        let basis = Basis::of(&union);
        assert_eq!(basis.stored.len(), 18);
        let formed: Vec<Column> = union
            .iter()
            .filter(|t| !basis.stored.contains(t))
            .map(|t| t.column)
            .collect();
        assert_eq!(
            formed,
            [
                Column::InducedTraceless(Axis::X),
                Column::InducedTraceless(Axis::Y),
                Column::EddyTraceless(Axis::X),
                Column::EddyTraceless(Axis::Y),
            ]
        );
        // The patent's terms alone lack the diagonals: all stored, nothing to map.
        let patent = Design::new(TermSet::patent()).design_terms();
        let alone = Basis::of(&patent);
        assert_eq!(alone.stored, patent);
        assert!(alone.terms.is_none());
    }

    #[test]
    fn formed_columns_are_the_design_columns_and_stored_ones_their_bits() {
        let union = default_union();
        let basis = Basis::of(&union);
        let flux = flight(400);
        let stored = columns(&basis.stored, &flux);
        let full = columns(&union, &flux);
        let formed = basis.on_terms(&stored, false);
        for (u, term) in union.iter().enumerate() {
            let (got, want) = (formed.column(u), full.column(u));
            if basis.stored.contains(term) {
                assert_eq!(got, want, "{}", term.column);
            } else {
                let scale = want.amax();
                assert!((got - want).amax() <= 1e-14 * scale, "{}", term.column);
            }
        }
    }

    #[test]
    fn factors_of_the_stored_columns_give_the_gram_matrix_of_every_term() {
        let union = default_union();
        let basis = Basis::of(&union);
        let flux = flight(600);
        let target: Vec<f64> = (0..600).map(|k| (0.3 * k as f64).cos()).collect();
        let with_target = |a: DMatrix<f64>| {
            let width = a.ncols();
            let mut m = a.insert_column(width, 0.0);
            m.column_mut(width).copy_from_slice(&target);
            m
        };
        let factor = |m: &DMatrix<f64>| {
            let cols: Vec<&[f64]> = m.as_slice().chunks_exact(m.nrows()).collect();
            triangular_factor(&cols)
        };
        let stored = with_target(columns(&basis.stored, &flux));
        let full = with_target(columns(&union, &flux));
        let r = basis.on_terms(&factor(&stored), true);
        let (gram, want) = (r.transpose() * &r, full.transpose() * &full);
        let scale = want.amax();
        assert!((gram - want).amax() <= 1e-12 * scale);
    }

    #[test]
    fn coefficients_go_to_the_columns_of_their_terms() {
        use crate::model::terms::{Axis, Column};
        let term = |column| Term {
            fluxgate: 0,
            column,
        };
        let (x, y, z) = (
            term(Column::Permanent(Axis::X)),
            term(Column::Permanent(Axis::Y)),
            term(Column::Permanent(Axis::Z)),
        );
        assert_eq!(
            on_columns(&[x, y, z], &[z, x], &[3.0, 1.0]),
            [1.0, 0.0, 3.0]
        );
    }
}
