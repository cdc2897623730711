//! How well a flight's maneuvers determine each term, and which maneuvers would help.
//!
//! ```
//! use nalgebra::DMatrix;
//! use tolles_core::maneuvers::identifiability::{analyse, Block};
//!
//! // Two terms; the first block only excites term a, the second both, nearly alike, so each
//! // block is indispensable and b, which only the second separates, is the less well known.
//! let a = DMatrix::from_row_slice(4, 2, &[1.0, 0.0, -1.0, 0.0, 1.0, 0.9, -1.0, -0.9]);
//! let blocks = vec![Block::from_rows("roll N", &a.rows(0, 2).into_owned()),
//!                   Block::from_rows("pitch N", &a.rows(2, 2).into_owned())];
//! let report = analyse(&blocks, &["a".into(), "b".into()], 0.1);
//! assert!(report.terms[1].std_error > report.terms[0].std_error);
//! assert!(report.terms[1].carried_by.iter().all(|(_, inflation)| inflation.is_infinite()));
//! ```
//!
//! The information a block of (filtered) design rows carries about the coefficients is its Gram
//! matrix `G_m = A_mᵀA_m`; a flight's is the sum `G = Σ G_m`. With white residual noise σ (nT):
//! - the standard error of coefficient j is `σ·√(G⁻¹)_jj`;
//! - its variance inflation factor is `(G⁻¹)_jj·G_jj` — 1 when the column is orthogonal to all
//!   others, large when other columns can mimic it (collinear terms);
//! - the maneuvers that carry its information are those whose removal inflates its variance most,
//!   `((G − G_m)⁻¹)_jj / (G⁻¹)_jj`;
//! - a candidate maneuver `c` that would fix a poorly determined term is one that shrinks
//!   `((G + G_c)⁻¹)_jj` most.
//!
//! Any linear function of the coefficients (such as the 16 patent terms, see
//! [`patent_map`]) is analysed the same way through its covariance `M·G⁻¹·Mᵀ`.

use crate::flight::plan::{Axis, Motion, Plan, Segment};
use crate::flight::sim::{simulate, Scenario, SimError};
use crate::model::design::Design;
use crate::model::interpret::AircraftField;
use crate::model::vector::VectorSeries;
use crate::signal::filter::{Butterworth, FilterError};
use nalgebra::{DMatrix, DVector};
use serde::{Deserialize, Serialize};
use std::ops::Range;

/// Variance inflation above which a term counts as collinear on a flight.
pub const COLLINEAR_VIF: f64 = 10.0;

/// Estimate correlation above which two terms are named as partners of a collinearity.
pub const PARTNER_CORRELATION: f64 = 0.8;

/// The information one maneuver (or any labelled block of samples) carries.
#[derive(Debug, Clone, PartialEq)]
pub struct Block {
    /// What the block is, e.g. `roll on 090°`.
    pub label: String,
    /// Its Gram matrix `AᵀA` of filtered design rows.
    pub gram: DMatrix<f64>,
}

impl Block {
    /// The block of design rows `a` (rows = samples).
    pub fn from_rows(label: &str, a: &DMatrix<f64>) -> Self {
        Self {
            label: label.to_string(),
            gram: a.transpose() * a,
        }
    }
}

/// What a flight says about one term.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TermInformation {
    /// The term's name.
    pub name: String,
    /// Standard error for the given noise level (term units).
    pub std_error: f64,
    /// Variance inflation factor (≥ 1 for a design column; for a derived term, its variance
    /// relative to what it would be if the terms it is made of were uncorrelated).
    pub vif: f64,
    /// True when `vif` exceeds [`COLLINEAR_VIF`] or the term is not determined at all.
    pub collinear: bool,
    /// Terms whose estimates are correlated with this one beyond [`PARTNER_CORRELATION`],
    /// with the correlation.
    pub partners: Vec<(String, f64)>,
    /// Blocks ranked by how much the term's variance grows without them (ratio ≥ 1; infinite
    /// when the term cannot be determined without the block).
    pub carried_by: Vec<(String, f64)>,
}

/// The identifiability of every term on a flight.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Identifiability {
    /// Noise level the standard errors assume (nT).
    pub noise_nt: f64,
    /// One entry per term.
    pub terms: Vec<TermInformation>,
}

impl Identifiability {
    /// The terms flagged as collinear.
    pub fn collinear(&self) -> impl Iterator<Item = &TermInformation> {
        self.terms.iter().filter(|t| t.collinear)
    }
}

/// Analyses the coefficients themselves (one term per design column).
pub fn analyse(blocks: &[Block], names: &[String], noise_nt: f64) -> Identifiability {
    let p = names.len();
    analyse_mapped(blocks, names, &DMatrix::identity(p, p), noise_nt)
}

/// Analyses the linear functions `M·β` of the coefficients, one per row of `map`, named `names`.
pub fn analyse_mapped(
    blocks: &[Block],
    names: &[String],
    map: &DMatrix<f64>,
    noise_nt: f64,
) -> Identifiability {
    let total = sum(blocks.iter().map(|b| &b.gram), map.ncols());
    let covariance = mapped_covariance(&total, map);
    let naive = naive_variances(&total, map);
    let without: Vec<Option<DVector<f64>>> = blocks
        .iter()
        .map(|b| mapped_covariance(&(&total - &b.gram), map).map(|c| c.diagonal()))
        .collect();
    let terms = (0..map.nrows())
        .map(|j| {
            let variance = covariance
                .as_ref()
                .map_or(f64::INFINITY, |c| c[(j, j)].max(0.0));
            let vif = if naive[j] > 0.0 {
                variance / naive[j]
            } else {
                f64::INFINITY
            };
            TermInformation {
                name: names[j].clone(),
                std_error: noise_nt * variance.sqrt(),
                vif,
                collinear: vif.is_nan() || vif > COLLINEAR_VIF,
                partners: covariance
                    .as_ref()
                    .map_or_else(Vec::new, |c| partners(c, names, j)),
                carried_by: carried_by(blocks, &without, variance, j),
            }
        })
        .collect();
    Identifiability { noise_nt, terms }
}

/// Candidate maneuvers ranked by how much each would shrink term `j`'s variance on top of the
/// flight's `blocks`, best first, with the ratio of the new to the old standard error (0 when
/// the term was undetermined before and the candidate determines it).
pub fn suggest(
    blocks: &[Block],
    candidates: &[Block],
    map: &DMatrix<f64>,
    j: usize,
) -> Vec<(String, f64)> {
    let total = sum(blocks.iter().map(|b| &b.gram), map.ncols());
    let variance =
        |g: &DMatrix<f64>| mapped_covariance(g, map).map_or(f64::INFINITY, |c| c[(j, j)]);
    let before = variance(&total);
    let mut ranked: Vec<(String, f64)> = candidates
        .iter()
        .map(|c| (c.label.clone(), variance(&(&total + &c.gram))))
        .collect();
    ranked.sort_by(|a, b| a.1.total_cmp(&b.1));
    ranked
        .into_iter()
        .map(|(label, after)| {
            let ratio = match (before.is_finite(), after.is_finite()) {
                (true, _) => (after / before).sqrt(),
                (false, true) => 0.0,
                (false, false) => 1.0,
            };
            (label, ratio)
        })
        .collect()
}

/// The 16 patent terms as linear functions of a design's coefficients (16 × columns), for a
/// design built at `fs_hz`. Names are those of [`crate::patent::PatentTerms::named`].
pub fn patent_map(design: &Design, fs_hz: f64) -> (Vec<String>, DMatrix<f64>) {
    let p = design.width();
    let names: Vec<String> = AircraftField::default()
        .patent_terms()
        .named()
        .iter()
        .map(|(n, _)| n.to_string())
        .collect();
    let mut map = DMatrix::zeros(names.len(), p);
    for j in 0..p {
        let mut unit = vec![0.0; p];
        unit[j] = 1.0;
        let terms = AircraftField::from_coefficients(design, &unit, fs_hz).patent_terms();
        for (i, (_, value)) in terms.named().iter().enumerate() {
            map[(i, j)] = *value;
        }
    }
    (names, map)
}

/// Blocks of a flight: the filtered design rows of each labelled window (sample ranges of
/// `flux`), and the rest of the flight as one more block named `other flight` when it carries
/// any information. The fluxgate must be finite (nT, body frame).
pub fn flight_blocks(
    flux: &VectorSeries,
    design: &Design,
    filter: Option<&Butterworth>,
    windows: &[(String, Range<usize>)],
) -> Result<Vec<Block>, FilterError> {
    let mut a = design.matrix(flux);
    if let Some(f) = filter {
        for mut column in a.column_iter_mut() {
            // Unlike the fit, constant columns are filtered too: a column that never changes
            // carries no band-passed information, and leaving it unfiltered (MagNav's rule, meant
            // for a bias column) would count its constant level as information.
            let filtered = f.filtfilt(column.as_slice())?;
            column.copy_from_slice(&filtered);
        }
    }
    let mut inside = vec![false; flux.len()];
    let mut blocks = Vec::new();
    for (label, range) in windows {
        inside[range.clone()].iter_mut().for_each(|v| *v = true);
        blocks.push(Block::from_rows(
            label,
            &a.rows(range.start, range.len()).into_owned(),
        ));
    }
    let rest: Vec<usize> = (0..flux.len()).filter(|k| !inside[*k]).collect();
    if !rest.is_empty() {
        blocks.push(Block::from_rows("other flight", &a.select_rows(&rest)));
    }
    Ok(blocks)
}

/// A short name for a segment's maneuver, e.g. `roll on 045°`, or `None` for straight flight.
pub fn maneuver_label(segment: &Segment) -> Option<String> {
    let heading = segment.heading_deg.rem_euclid(360.0).round() as i64 % 360;
    match segment.motion {
        Motion::Harmonic { axis, .. } => Some(format!("{axis} on {heading:03}°")),
        Motion::Hold { roll_deg } => Some(format!("{roll_deg:+.0}° wing-up on {heading:03}°")),
        Motion::Turn { change_deg, .. } => {
            Some(format!("{change_deg:.0}° turn from {heading:03}°"))
        }
        Motion::Straight | Motion::Turbulent { .. } => None,
    }
}

/// Blocks of a planned flight, before it is flown: the plan is simulated without noise and
/// each maneuver segment becomes a block.
pub fn planned_blocks(
    plan: &Plan,
    scenario: &Scenario,
    design: &Design,
    filter: Option<&Butterworth>,
) -> Result<Vec<Block>, PlanningError> {
    let mut quiet = scenario.clone();
    quiet.sensors.scalar_noise_nt = 0.0;
    quiet.sensors.flux_noise_nt = 0.0;
    let flight = simulate(plan, &quiet)?;
    let fs = quiet.fs_hz;
    let windows: Vec<(String, Range<usize>)> = plan
        .segments()
        .iter()
        .zip(plan.starts())
        .filter_map(|(segment, start)| {
            let label = maneuver_label(segment)?;
            let first = (start * fs).ceil() as usize;
            let last = (((start + segment.duration_s) * fs).floor() as usize).min(flight.tt.len());
            (last > first).then_some((label, first..last))
        })
        .collect();
    Ok(flight_blocks(&flight.flux, design, filter, &windows)?)
}

/// Why a planned flight could not be evaluated.
#[derive(Debug, thiserror::Error)]
pub enum PlanningError {
    /// The planned flight could not be simulated.
    #[error(transparent)]
    Sim(#[from] SimError),
    /// The band-pass filter could not be designed or applied.
    #[error(transparent)]
    Filter(#[from] FilterError),
}

/// The standard maneuvers an operator could add: rolls, pitches and yaws on the eight cardinal
/// and intercardinal headings and 40° wing-ups on east and west, each a block of its own,
/// simulated in `scenario` with the amplitudes of a compensation box (10°, 5°, 5°, period 6 s,
/// 3 cycles).
pub fn candidate_blocks(
    scenario: &Scenario,
    design: &Design,
    filter: Option<&Butterworth>,
) -> Result<Vec<Block>, PlanningError> {
    let mut candidates = Vec::new();
    for k in 0..8 {
        let heading = 45.0 * k as f64;
        for (axis, amplitude) in [(Axis::Roll, 10.0), (Axis::Pitch, 5.0), (Axis::Yaw, 5.0)] {
            let motion = Motion::Harmonic {
                axis,
                amplitude_deg: amplitude,
                period_s: 6.0,
            };
            candidates.extend(single(heading, 18.0, motion, scenario, design, filter)?);
        }
    }
    for (heading, roll) in [(90.0, -40.0), (270.0, 40.0)] {
        let motion = Motion::Hold { roll_deg: roll };
        candidates.extend(single(heading, 20.0, motion, scenario, design, filter)?);
    }
    Ok(candidates)
}

/// One maneuver between two straight legs, as a block.
fn single(
    heading: f64,
    duration_s: f64,
    motion: Motion,
    scenario: &Scenario,
    design: &Design,
    filter: Option<&Butterworth>,
) -> Result<Option<Block>, PlanningError> {
    let leg = |motion| Segment {
        line: 1.0,
        heading_deg: heading,
        duration_s: if matches!(motion, Motion::Straight) {
            20.0
        } else {
            duration_s
        },
        motion,
    };
    let plan = Plan::new(vec![
        leg(Motion::Straight),
        leg(motion),
        leg(Motion::Straight),
    ]);
    let blocks = planned_blocks(&plan, scenario, design, filter)?;
    Ok(blocks.into_iter().find(|b| b.label != "other flight"))
}

fn sum<'a>(grams: impl Iterator<Item = &'a DMatrix<f64>>, p: usize) -> DMatrix<f64> {
    grams.fold(DMatrix::zeros(p, p), |acc, g| acc + g)
}

/// `M·G⁻¹·Mᵀ`, or `None` when `G` is singular (some term undetermined).
fn mapped_covariance(gram: &DMatrix<f64>, map: &DMatrix<f64>) -> Option<DMatrix<f64>> {
    let largest = gram.diagonal().iter().fold(0.0f64, |m, v| m.max(v.abs()));
    if largest == 0.0 {
        return None;
    }
    // Scale to unit diagonal so the Cholesky test of definiteness is not fooled by units.
    let d = DVector::from_iterator(
        gram.nrows(),
        gram.diagonal()
            .iter()
            .map(|v| 1.0 / v.max(largest * 1e-300).sqrt()),
    );
    let scaled = DMatrix::from_diagonal(&d) * gram * DMatrix::from_diagonal(&d);
    let cholesky = scaled.cholesky()?;
    let inverse = cholesky.inverse();
    let min_pivot = cholesky
        .l()
        .diagonal()
        .iter()
        .fold(f64::INFINITY, |m, v| m.min(*v));
    if min_pivot < 1e-7 {
        return None;
    }
    let dm = map * DMatrix::from_diagonal(&d);
    Some(&dm * inverse * dm.transpose())
}

/// The variance each mapped term would have if the coefficients were estimated independently:
/// `Σ_k M_jk² / G_kk`.
fn naive_variances(gram: &DMatrix<f64>, map: &DMatrix<f64>) -> Vec<f64> {
    (0..map.nrows())
        .map(|j| {
            (0..map.ncols())
                .filter(|&k| map[(j, k)] != 0.0)
                .map(|k| {
                    if gram[(k, k)] > 0.0 {
                        map[(j, k)].powi(2) / gram[(k, k)]
                    } else {
                        f64::INFINITY
                    }
                })
                .sum()
        })
        .collect()
}

fn partners(covariance: &DMatrix<f64>, names: &[String], j: usize) -> Vec<(String, f64)> {
    let mut found: Vec<(String, f64)> = (0..names.len())
        .filter(|&k| k != j)
        .filter_map(|k| {
            let r = covariance[(j, k)] / (covariance[(j, j)] * covariance[(k, k)]).sqrt();
            (r.abs() > PARTNER_CORRELATION).then(|| (names[k].clone(), r))
        })
        .collect();
    found.sort_by(|a, b| b.1.abs().total_cmp(&a.1.abs()));
    found
}

fn carried_by(
    blocks: &[Block],
    without: &[Option<DVector<f64>>],
    variance: f64,
    j: usize,
) -> Vec<(String, f64)> {
    let mut ranked: Vec<(String, f64)> = blocks
        .iter()
        .zip(without)
        .map(|(b, w)| {
            let ratio = match w {
                Some(v) if variance.is_finite() && variance > 0.0 => v[j] / variance,
                Some(_) => 1.0,
                None => f64::INFINITY,
            };
            (b.label.clone(), ratio)
        })
        .collect();
    ranked.sort_by(|a, b| b.1.total_cmp(&a.1));
    ranked
}

#[cfg(test)]
mod tests {
    use super::*;

    fn names(n: usize) -> Vec<String> {
        (0..n).map(|k| format!("t{k}")).collect()
    }

    #[test]
    fn orthogonal_columns_have_unit_vif_and_textbook_errors() {
        let a = DMatrix::from_row_slice(4, 2, &[1.0, 1.0, 1.0, -1.0, -1.0, 1.0, -1.0, -1.0]);
        let report = analyse(&[Block::from_rows("all", &a)], &names(2), 2.0);
        for t in &report.terms {
            assert!((t.vif - 1.0).abs() < 1e-12);
            assert!((t.std_error - 1.0).abs() < 1e-12); // σ/√(Σa²) = 2/2
            assert!(!t.collinear && t.partners.is_empty());
        }
    }

    #[test]
    fn nearly_collinear_columns_are_flagged_with_their_partner() {
        let a = DMatrix::from_fn(50, 3, |i, j| {
            let x = (i as f64 * 0.7).sin();
            match j {
                0 => x,
                1 => x + 0.01 * (i as f64 * 1.3).cos(),
                _ => (i as f64 * 0.2).cos(),
            }
        });
        let report = analyse(&[Block::from_rows("all", &a)], &names(3), 1.0);
        assert!(report.terms[0].collinear && report.terms[1].collinear);
        assert!(!report.terms[2].collinear);
        assert_eq!(report.terms[0].partners[0].0, "t1");
        assert!(report.terms[0].partners[0].1 < -0.9);
    }

    #[test]
    fn a_term_seen_by_one_block_only_is_carried_by_it_and_undetermined_without_it() {
        let only_first = DMatrix::from_row_slice(2, 2, &[1.0, 0.0, -1.0, 0.0]);
        let both = DMatrix::from_row_slice(2, 2, &[0.0, 1.0, 0.0, -1.0]);
        let blocks = [
            Block::from_rows("A", &only_first),
            Block::from_rows("B", &both),
        ];
        let report = analyse(&blocks, &names(2), 1.0);
        assert_eq!(report.terms[0].carried_by[0].0, "A");
        assert!(report.terms[0].carried_by[0].1.is_infinite());
    }

    #[test]
    fn suggestions_rank_the_maneuver_that_excites_the_weak_term_first() {
        let weak = DMatrix::from_row_slice(2, 2, &[1.0, 0.01, -1.0, -0.01]);
        let good = Block::from_rows(
            "good",
            &DMatrix::from_row_slice(2, 2, &[0.0, 1.0, 0.0, -1.0]),
        );
        let useless = Block::from_rows(
            "useless",
            &DMatrix::from_row_slice(2, 2, &[1.0, 0.0, -1.0, 0.0]),
        );
        let ranked = suggest(
            &[Block::from_rows("flown", &weak)],
            &[useless, good],
            &DMatrix::identity(2, 2),
            1,
        );
        assert_eq!(ranked[0].0, "good");
        // The flown block alone cannot separate the terms: either candidate makes them
        // determinable (ratio 0), the good one far better.
        assert_eq!(ranked[0].1, 0.0);
        let weak_only = vec![
            Block::from_rows("flown", &weak),
            Block::from_rows(
                "useless",
                &DMatrix::from_row_slice(2, 2, &[1.0, 0.0, -1.0, 0.0]),
            ),
        ];
        let good = Block::from_rows(
            "good",
            &DMatrix::from_row_slice(2, 2, &[0.0, 1.0, 0.0, -1.0]),
        );
        let again = suggest(&weak_only, &[good], &DMatrix::identity(2, 2), 1);
        assert!(again[0].1 < 0.1, "{again:?}");
    }

    #[test]
    fn patent_map_reads_perm_terms_from_perm_columns() {
        let design = Design::new("p,i5,e8".parse().unwrap());
        let (names, map) = patent_map(&design, 10.0);
        assert_eq!(names[0], "T");
        assert_eq!(map[(0, 1)], 1.0); // T is the y permanent column
        assert_eq!(map.row(0).iter().filter(|v| **v != 0.0).count(), 1);
    }
}
