//! Choosing between candidate models on the same cross-validation folds: term sets, the
//! magnitude model, and the ridge strength.

use super::crossval::{
    cross_validate, cross_validate_prior_groups, heldout_sum_of_squares_on, penalty,
    CrossValidation, LAMBDA_GRID, PRIOR_GRID,
};
use super::error::FitError;
use super::factor::FoldFactor;
use super::outcome::TermScore;
use super::plausible::{self, Fault};
use super::prior::PriorWeights;
use super::qr::upper_factor;
use super::ridge::{Ridge, RidgeSolution};
use super::settings::{Lambda, MagnitudeChoice, LAMBDA_MAX_RATIO, TERM_CHOICE_MARGIN};
use crate::model::design::{Design, Term};
use crate::model::magnitude::Magnitude;
use crate::model::terms::TermSet;
use nalgebra::DMatrix;

/// The linear or the exact fit, as `choice` says; with `Auto`, the exact one when it predicts
/// held-out data at least as well. The exact fit's score joins the term scores.
pub(super) fn pick_magnitude(
    linear: Chosen,
    exact: Chosen,
    iterations: usize,
    choice: MagnitudeChoice,
) -> (Magnitude, Chosen, usize) {
    let use_exact = match choice {
        MagnitudeChoice::Linear => false,
        MagnitudeChoice::Exact => true,
        MagnitudeChoice::Auto => exact.score() <= linear.score(),
    };
    let mut scores = linear.scores.clone();
    if scores.is_empty() {
        scores.push(term_score(&linear, false));
    }
    scores.iter_mut().for_each(|s| s.chosen &= !use_exact);
    scores.push(TermScore {
        magnitude: Magnitude::Exact,
        ..term_score(&exact, use_exact)
    });
    let (magnitude, mut chosen, iterations) = if use_exact {
        (Magnitude::Exact, exact, iterations)
    } else {
        (Magnitude::Linear, linear, 0)
    };
    chosen.scores = scores;
    (magnitude, chosen, iterations)
}

pub(super) fn term_score(chosen: &Chosen, is_chosen: bool) -> TermScore {
    TermScore {
        terms: chosen.terms,
        extras: chosen.extras.clone(),
        magnitude: Magnitude::Linear,
        lambda_rel: chosen
            .cross_validation
            .as_ref()
            .map(|c| c.chosen_lambda_rel),
        heldout_rms_nt: chosen
            .cross_validation
            .as_ref()
            .map(|c| c.expected_heldout_rms_nt),
        heldout_low_rms_nt: chosen.heldout_low_nt,
        chosen: is_chosen,
    }
}

/// Every term of `designs`, each once, in order of first appearance; then the plain diagonal
/// that completes the parts of a traceless term when the union holds all of them but that one
/// (see [`Column::of_diagonals`](crate::model::terms::Column::of_diagonals)): stored, it lets
/// the fit form the kind's two traceless columns from three stored diagonals instead of storing
/// them (the patent's terms beside `i5,e8` lack only `zz`).
pub(super) fn union_of_terms(designs: &[Design]) -> Vec<Term> {
    let mut union: Vec<Term> = Vec::new();
    for term in designs.iter().flat_map(Design::design_terms) {
        if !union.contains(&term) {
            union.push(term);
        }
    }
    let mut completing: Vec<Term> = Vec::new();
    for term in &union {
        let Some(parts) = term.column.of_diagonals() else {
            continue;
        };
        let part = |column| Term {
            fluxgate: term.fluxgate,
            column,
        };
        let missing: Vec<Term> = parts
            .iter()
            .map(|(column, _)| part(*column))
            .filter(|p| !union.contains(p))
            .collect();
        if let [one] = missing[..] {
            if !completing.contains(&one) {
                completing.push(one);
            }
        }
    }
    union.extend(completing);
    union
}

/// The candidate design that won, its solution and the scores of all candidates.
#[derive(Clone)]
pub(super) struct Chosen {
    pub(super) index: usize,
    pub(super) terms: TermSet,
    pub(super) extras: Vec<crate::model::extra::ExtraChannel>,
    pub(super) solution: RidgeSolution,
    pub(super) cross_validation: Option<CrossValidation>,
    /// Held-out RMS of the low-frequency rows alone, unweighted (nT), with levels.
    pub(super) heldout_low_nt: Option<f64>,
    pub(super) scores: Vec<TermScore>,
    /// What the fit found before its prior was strengthened to make it believable, if it was.
    pub(super) restrained: Option<Fault>,
}

impl Chosen {
    /// What the choice between candidates compares (nT): the held-out error of the band and,
    /// with levels, of the low frequencies, added in quadrature as parts of one error; without
    /// cross-validation, the in-sample RMS (candidates then have as many coefficients).
    pub(super) fn score(&self) -> f64 {
        let band = match &self.cross_validation {
            Some(cv) => cv.expected_heldout_rms_nt,
            None => return (self.solution.rss / self.solution.rows.max(1) as f64).sqrt(),
        };
        band.hypot(self.heldout_low_nt.unwrap_or(0.0))
    }
}

/// Solves every candidate design on the same folds and keeps the first one unless another
/// predicts held-out data [`TERM_CHOICE_MARGIN`] better. The first design's failure is the
/// fit's failure; an alternative that fails is only scored as such. `prior` holds the union's
/// precisions, when the fit has a prior.
pub(super) fn choose_design(
    folds: &[FoldFactor],
    designs: &[Design],
    union: &[Term],
    lambda: Lambda,
    weight: f64,
    prior: Option<&PriorWeights>,
    fs_hz: f64,
) -> Result<Chosen, FitError> {
    let mut solved: Vec<Chosen> = Vec::new();
    let mut implausible: Option<FitError> = None;
    for (index, design) in designs.iter().enumerate() {
        let picks: Vec<usize> = design
            .design_terms()
            .iter()
            .map(|t| {
                union
                    .iter()
                    .position(|u| u == t)
                    .expect("union holds every term")
            })
            .collect();
        let (folds, level_folds) = fold_problems(folds, &picks);
        let rows: usize = folds.iter().map(Ridge::rows).sum();
        let columns = design.column_names(&[]);
        let outcome = if rows < picks.len() {
            Err(FitError::TooFewSamples {
                usable: rows,
                terms: picks.len(),
            })
        } else {
            let prior = prior.map(|p| p.picked(&picks));
            let fault = |beta: &[f64]| plausible::fault(design, beta, fs_hz);
            solve(&folds, lambda, &columns, prior.as_ref(), &fault)
        };
        match outcome {
            Ok(Solved {
                solution,
                cross_validation,
                prior_penalty,
                restrained,
            }) => {
                let heldout_low_nt = cross_validation.as_ref().and_then(|cv| {
                    let lambda_rel = cv.chosen_lambda_rel;
                    let penalty = &prior_penalty;
                    heldout_low(&folds, &level_folds, lambda_rel, &columns, weight, penalty)
                });
                solved.push(Chosen {
                    index,
                    terms: design.terms,
                    extras: design.extras.clone(),
                    solution,
                    cross_validation,
                    heldout_low_nt,
                    scores: Vec::new(),
                    restrained,
                });
            }
            // An implausible candidate is left out; the fit fails only if every one is.
            Err(e @ FitError::Implausible(_)) => {
                implausible.get_or_insert(e);
            }
            Err(e) if index == 0 => return Err(e),
            Err(_) => {}
        }
    }
    if solved.is_empty() {
        return Err(implausible.expect("a candidate failed"));
    }
    let scored: Vec<Option<f64>> = solved
        .iter()
        .map(|c| c.cross_validation.as_ref().map(|_| c.score()))
        .collect();
    let mut best = 0;
    if let Some(first) = scored[0] {
        let width = |k: usize| designs[solved[k].index].width();
        for (k, score) in scored.iter().enumerate().skip(1) {
            // A larger set must clear the margin; one no larger (another parameterisation of
            // as many terms) only has to be better.
            let margin = if width(k) > width(0) {
                TERM_CHOICE_MARGIN
            } else {
                0.0
            };
            let to_clear = first * (1.0 - margin);
            // The current best always has a score: the first one, or one that cleared the bar.
            if score.is_some_and(|s| s < to_clear && scored[best].is_some_and(|b| s < b)) {
                best = k;
            }
        }
    }
    let scores = if designs.len() > 1 {
        designs
            .iter()
            .enumerate()
            .map(
                |(index, design)| match solved.iter().position(|c| c.index == index) {
                    Some(k) => term_score(&solved[k], k == best),
                    None => TermScore {
                        terms: design.terms,
                        extras: design.extras.clone(),
                        magnitude: Magnitude::Linear,
                        lambda_rel: None,
                        heldout_rms_nt: None,
                        heldout_low_rms_nt: None,
                        chosen: false,
                    },
                },
            )
            .collect()
    } else {
        Vec::new()
    };
    let mut chosen = solved.swap_remove(best);
    chosen.scores = scores;
    Ok(chosen)
}

/// Held-out RMS (nT) of the level rows: each fold's level rows predicted by a fit on the other
/// folds (with the prior's `prior_penalty`), unweighted; `None` without level rows.
pub(super) fn heldout_low(
    folds: &[Ridge],
    level_folds: &[Ridge],
    lambda_rel: f64,
    columns: &[String],
    weight: f64,
    prior_penalty: &[f64],
) -> Option<f64> {
    let rows: usize = level_folds.iter().map(Ridge::rows).sum();
    if rows == 0 || weight <= 0.0 {
        return None;
    }
    let rss = heldout_sum_of_squares_on(folds, level_folds, lambda_rel, columns, prior_penalty)?;
    Some((rss / rows as f64).sqrt() / weight)
}

/// Each fold's problem in the columns `picks` of the fold factors (and the target, their last
/// column), and its level rows' problem on their own.
///
/// The factor of some columns of a matrix is the factor of those columns of its factor: with
/// `[A | y] = Q·R`, `[A·S | y] = Q·(R·S')`, so re-triangularising the small `R·S'` gives it
/// without touching the rows again.
pub(super) fn fold_problems(folds: &[FoldFactor], picks: &[usize]) -> (Vec<Ridge>, Vec<Ridge>) {
    let derive = |r: &DMatrix<f64>, rows: usize| {
        let target = r.ncols() - 1;
        let columns: Vec<usize> = picks.iter().copied().chain([target]).collect();
        let selected = r.select_columns(&columns);
        let factor = upper_factor(selected);
        let keep = factor.nrows().min(rows);
        Ridge::from_factor(picks.len(), factor.rows(0, keep).into_owned(), rows)
    };
    folds
        .iter()
        .map(|f| (derive(&f.r, f.rows), derive(&f.level_r, f.level_rows)))
        .unzip()
}

/// A final solve: the solution, how λ was chosen, the prior's part of its penalty, and the
/// fault that made the prior stronger, if one did.
pub(super) struct Solved {
    pub(super) solution: RidgeSolution,
    pub(super) cross_validation: Option<CrossValidation>,
    pub(super) prior_penalty: Vec<f64>,
    pub(super) restrained: Option<Fault>,
}

/// The final solve on all rows, with λ fixed or cross-validated. With a cross-validated λ and
/// a `prior`, the prior's penalty is scaled by the residual variance of the fit without it
/// (see [`crate::fit::prior`]) and every candidate λ is validated with it; a solution that
/// `fault` finds unbelievable is restrained by ever stronger multiples of the prior, or refused
/// ([`FitError::Implausible`]) when even the strongest leaves it so. A fixed λ is MagNav's
/// procedure and is solved as it is.
pub(super) fn solve(
    folds: &[Ridge],
    lambda: Lambda,
    columns: &[String],
    prior: Option<&PriorWeights>,
    fault: &dyn Fn(&[f64]) -> Option<Fault>,
) -> Result<Solved, FitError> {
    let mut all = folds[0].clone();
    folds[1..].iter().for_each(|f| all.merge(f));
    match lambda {
        Lambda::Fixed(lambda) => {
            let largest = all.column_sums_of_squares().into_iter().fold(0.0, f64::max);
            if lambda > LAMBDA_MAX_RATIO * largest {
                return Err(FitError::LambdaTooLarge { lambda, largest });
            }
            Ok(Solved {
                solution: all.solve(lambda, columns)?,
                cross_validation: None,
                prior_penalty: Vec::new(),
                restrained: None,
            })
        }
        Lambda::CrossValidated { .. } => {
            let failed = || FitError::CrossValidation {
                terms: columns.len(),
            };
            let sums = all.column_sums_of_squares();
            let mut cv = cross_validate(folds, &LAMBDA_GRID, columns, &[]).ok_or_else(failed)?;
            let Some(prior) = prior else {
                let solution = all.solve_penalised(&cv.chosen_penalty(&sums, &[]), columns)?;
                return Ok(Solved {
                    solution,
                    cross_validation: Some(cv),
                    prior_penalty: Vec::new(),
                    restrained: None,
                });
            };
            // The prior's strength per unit of residual variance, from the fit without it;
            // then the multiple of it that predicts held-out rows best.
            let first = all.solve_penalised(&cv.chosen_penalty(&sums, &[]), columns)?;
            let prior_unit = prior.penalty(first.rss / first.rows.max(1) as f64);
            cv = cross_validate_prior_groups(
                folds,
                &PRIOR_GRID,
                columns,
                &prior_unit,
                &prior.groups,
                prior.parsimonious,
            )
            .ok_or_else(failed)?;
            let mut solution =
                all.solve_penalised(&cv.chosen_penalty(&sums, &prior_unit), columns)?;
            let restrained = fault(&solution.coefficients);
            if let Some(found) = &restrained {
                let chosen = cv.chosen_prior(&prior_unit);
                let believable = RESTRAINTS.iter().find_map(|r| {
                    let prior: Vec<f64> = chosen.iter().map(|p| p * r).collect();
                    let penalty = penalty(cv.chosen_lambda_rel, &sums, &prior);
                    let s = all.solve_penalised(&penalty, columns).ok()?;
                    fault(&s.coefficients).is_none().then_some((r, s))
                });
                let (restraint, believed) =
                    believable.ok_or_else(|| FitError::Implausible(found.clone()))?;
                let common = cv.chosen_prior_multiplier.unwrap_or(1.0);
                cv.prior_multipliers = match cv.prior_multipliers.len() {
                    0 => vec![common * restraint; prior_unit.len()],
                    _ => cv.prior_multipliers.iter().map(|m| m * restraint).collect(),
                };
                // The error to expect is the restrained model's, not the one it replaced.
                let rows: usize = folds.iter().map(Ridge::rows).sum();
                let prior = cv.chosen_prior(&prior_unit);
                let lambda_rel = cv.chosen_lambda_rel;
                if let Some(sum) =
                    heldout_sum_of_squares_on(folds, folds, lambda_rel, columns, &prior)
                {
                    cv.expected_heldout_rms_nt = (sum / rows.max(1) as f64).sqrt();
                }
                solution = believed;
            }
            let prior_penalty = cv.chosen_prior(&prior_unit);
            Ok(Solved {
                solution,
                cross_validation: Some(cv),
                prior_penalty,
                restrained,
            })
        }
    }
}

/// Factors by which a fit's prior is strengthened, in turn, until its model is believable.
const RESTRAINTS: [f64; 6] = [10.0, 1e2, 1e3, 1e4, 1e5, 1e6];

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fit::qr::triangular_factor;
    use proptest::prelude::*;

    /// Columns of made-up values.
    fn columns(m: usize, k: usize, seed: f64) -> Vec<Vec<f64>> {
        (0..k)
            .map(|j| {
                (0..m)
                    .map(|i| ((i * (j + 3)) as f64 * 0.29 + seed).sin() + 0.1 * j as f64)
                    .collect()
            })
            .collect()
    }

    /// A restrained fit reports the held-out error of the model it writes, not of the one its
    /// restraint replaced.
    #[test]
    fn a_restrained_fit_expects_its_own_held_out_error() {
        // y = 50·x0 + x1 + noise: a "fault" is any first coefficient above 10.
        let cols = columns(500, 3, 0.4);
        let folds: Vec<Ridge> = (0..5)
            .map(|k| {
                let rows = k * 100..(k + 1) * 100;
                let x: Vec<&[f64]> = cols[..2].iter().map(|c| &c[rows.clone()]).collect();
                let y: Vec<f64> = rows
                    .clone()
                    .map(|i| 50.0 * cols[0][i] + cols[1][i] + 0.1 * cols[2][i])
                    .collect();
                let mut fold = Ridge::new(2);
                fold.push_columns(&x, &y);
                fold
            })
            .collect();
        let names = ["a".to_string(), "b".to_string()];
        let prior = PriorWeights {
            precision: vec![1.0, 1.0],
            groups: vec![None, None],
            rows_per_residual: 1.0,
            parsimonious: false,
        };
        let fault = |beta: &[f64]| {
            (beta[0].abs() > 10.0).then(|| Fault::Permanent {
                fluxgate: 0,
                axis: "L".into(),
                value_nt: beta[0],
            })
        };
        let solved = solve(&folds, Lambda::auto(), &names, Some(&prior), &fault).unwrap();
        assert!(solved.restrained.is_some());
        assert!(solved.solution.coefficients[0].abs() <= 10.0);
        let cv = solved.cross_validation.unwrap();
        let rows: usize = folds.iter().map(Ridge::rows).sum();
        let own = heldout_sum_of_squares_on(
            &folds,
            &folds,
            cv.chosen_lambda_rel,
            &names,
            &solved.prior_penalty,
        )
        .unwrap();
        let expected = (own / rows as f64).sqrt();
        assert!((cv.expected_heldout_rms_nt - expected).abs() <= 1e-12 * expected);
        // Restrained to a tenth of the truth, it predicts far worse than the unrestrained 0.1.
        assert!(
            cv.expected_heldout_rms_nt > 1.0,
            "{}",
            cv.expected_heldout_rms_nt
        );
    }

    proptest! {
        /// The factor of some columns derived from the factor of all of them gives the same
        /// problem as pushing those columns directly.
        #[test]
        fn a_candidate_factor_derived_from_the_union_equals_a_direct_qr(
            m in 6usize..400,
            seed in -2.0f64..2.0,
            picks in proptest::sample::subsequence(vec![0usize, 1, 2, 3, 4], 1..5),
        ) {
            let all = columns(m, 6, seed);
            let refs: Vec<&[f64]> = all.iter().map(Vec::as_slice).collect();
            let fold = FoldFactor {
                r: triangular_factor(&refs),
                rows: m,
                level_r: DMatrix::zeros(0, 6),
                level_rows: 0,
            };
            let (derived, _) = fold_problems(std::slice::from_ref(&fold), &picks);
            let mut direct = Ridge::new(picks.len());
            let chosen: Vec<&[f64]> = picks.iter().map(|&c| refs[c]).collect();
            direct.push_columns(&chosen, refs[5]);
            let names: Vec<String> = picks.iter().map(|c| c.to_string()).collect();
            let (u, v) = (
                derived[0].solve(1e-3, &names).unwrap(),
                direct.solve(1e-3, &names).unwrap(),
            );
            for (x, y) in u.coefficients.iter().zip(&v.coefficients) {
                prop_assert!((x - y).abs() <= 1e-9 * y.abs().max(1.0), "{} vs {}", x, y);
            }
            prop_assert!((u.rss - v.rss).abs() <= 1e-9 * v.rss.max(1e-9));
            prop_assert_eq!(derived[0].rows(), m);
        }
    }
}
