//! What a fit knows about how far to trust it: the coefficients' covariance, the correction's
//! uncertainty over the calibration, the span the calibration covered, and the verdict.

use crate::fit::outcome::Diagnostics;
use crate::fit::plausible::{self, Fault};
use crate::fit::ridge::RidgeSolution;
use crate::fit::settings::Lambda;
use crate::fit::verdict::{judge, Evidence, Verdict, MIN_TERM_EFFECT_NT};
use crate::model::coverage::Coverage;
use crate::model::design::{central_difference, Design};
use crate::model::magnitude::exact_at;
use crate::model::terms::Column;
use crate::model::vector::Fluxgates;
use nalgebra::{DMatrix, DVector};
use std::ops::Range;

pub use crate::model::uncertainty::Uncertainty;

/// Samples of the calibration looked at for the uncertainty over it (evenly spread).
const SAMPLES: usize = 20_000;

/// One calibration sample as a design row reads it: the fluxgate (nT), its change per sample
/// (nT/sample) and the extra channels' values.
struct Sample {
    b: [f64; 3],
    db: [f64; 3],
    extras: Vec<f64>,
}

/// About [`SAMPLES`] samples spread evenly over `runs`.
fn samples(flux: &Fluxgates, runs: &[Range<usize>]) -> Vec<Sample> {
    let series = flux.series()[0];
    let total: usize = runs.iter().map(|r| r.len()).sum();
    let step = total.div_ceil(SAMPLES).max(1);
    let mut samples = Vec::new();
    for run in runs {
        let components = [&series.x, &series.y, &series.z];
        let rate = components.map(|c| central_difference(&c[run.clone()]));
        for k in run.clone().step_by(step) {
            let i = k - run.start;
            samples.push(Sample {
                b: series.at(k),
                db: [rate[0][i], rate[1][i], rate[2][i]],
                extras: flux.extras().iter().map(|c| c[k]).collect(),
            });
        }
    }
    samples
}

/// Unfiltered design rows of `samples`.
fn sampled_rows(design: &Design, samples: &[Sample]) -> Vec<Vec<f64>> {
    let columns = design.columns();
    samples
        .iter()
        .map(|s| {
            let mut row = vec![0.0; columns.len()];
            design.row_with_extras(&columns, s.b, s.db, &s.extras, &mut row);
            row
        })
        .collect()
}

/// Standard deviation over `samples` (nT) of what a linear magnitude leaves out of the field
/// `coefficients` describe: `|B + H| − |B| − B̂·H`, about `|H⊥|²/(2|B|)`. NaN over several
/// fluxgates, which the exact magnitude does not model.
fn second_order_nt(
    design: &Design,
    coefficients: &[f64],
    samples: &[Sample],
    corrections: &[f64],
) -> f64 {
    if design.fluxgates != 1 {
        return f64::NAN;
    }
    let columns = design.columns();
    let left: Vec<f64> = (samples.iter().zip(corrections))
        .map(|(s, linear)| {
            exact_at(design, &columns, coefficients, s.b, s.db, &s.extras).0 - linear
        })
        .collect();
    crate::signal::metrics::std_dev(&left)
}

/// What the trust in one fit is judged from, besides its diagnostics.
pub(super) struct Inputs<'a> {
    pub design: &'a Design,
    pub coefficients: &'a [f64],
    pub solution: &'a RidgeSolution,
    pub lambda: Lambda,
    pub fs_hz: f64,
    /// The fault that made the prior stronger, if one did.
    pub restrained: Option<Fault>,
    /// RMS change of the fluxgate's direction inside the band (degrees).
    pub excitation_deg: f64,
    /// White noise of the calibration's scalar less the model's correction (nT), from its
    /// fourth difference.
    pub white_noise_nt: f64,
    /// A linear magnitude that no exact fit was tried against (extra channels, several
    /// fluxgates, `--magnitude linear`): one that won against it was chosen knowingly, this one
    /// is judged on what it leaves out.
    pub unrivalled_linear: bool,
    /// The coefficients' covariance (coefficient units squared).
    pub covariance: DMatrix<f64>,
    /// The target was the interference itself (a fit against a reference).
    pub interference: bool,
}

/// What the model leaves of the scalar at every frequency (nT), for each row's σ: the white
/// noise `white_nt` at every frequency, and what the band's residual holds beyond that noise's
/// share of it (a field the model does not describe, which only the band shows). Measured
/// with `bench/installations` (σ's coverage of the survey's error); the band residual taken as
/// white instead put σ at twice the error of simulated tail stingers, whose fluxgate noise the
/// eddy columns carry into the band.
fn left_over_nt(diagnostics: &Diagnostics, white_nt: f64) -> f64 {
    let band = diagnostics.residual_std_nt;
    let fraction = diagnostics.effective_sample_fraction;
    let noise = if white_nt.is_finite() {
        let beyond = (band * band - white_nt * white_nt * fraction).max(0.0);
        white_nt.hypot(beyond.sqrt())
    } else {
        band / fraction.sqrt()
    };
    if noise.is_finite() {
        noise
    } else {
        0.0
    }
}

/// The fit's uncertainty (`None` if its covariance is not finite), the span it covered and its
/// verdict.
pub(super) fn assess(
    inputs: Inputs,
    diagnostics: &Diagnostics,
    flux: &Fluxgates,
    runs: &[Range<usize>],
) -> (Option<Uncertainty>, Coverage, Verdict) {
    let Inputs {
        design,
        coefficients,
        solution,
        lambda,
        fs_hz,
        restrained,
        excitation_deg,
        white_noise_nt,
        unrivalled_linear,
        covariance,
        interference,
    } = inputs;
    let p = coefficients.len();
    let samples = samples(flux, runs);
    let rows = sampled_rows(design, &samples);
    let count = rows.len().max(1) as f64;
    let mean_row: Vec<f64> = (0..p)
        .map(|j| rows.iter().map(|r| r[j]).sum::<f64>() / count)
        .collect();
    let beta = DVector::from_column_slice(coefficients);
    let corrections: Vec<f64> = rows
        .iter()
        .map(|r| DVector::from_column_slice(r).dot(&beta))
        .collect();
    let left_nt = left_over_nt(diagnostics, white_noise_nt);
    let second_order_nt = match unrivalled_linear {
        true => second_order_nt(design, coefficients, &samples, &corrections),
        false => f64::NAN,
    };
    // What a linear magnitude leaves out stays out of σ: the fit absorbs most of it into its
    // coefficients, and added to σ's noise term it put σ at 3–5× the error of fine fits with a
    // current (bench/verdict's 163 and 211 nT cabins).
    let uncertainty = Uncertainty {
        covariance: covariance.transpose().as_slice().to_vec(),
        mean_row,
        noise_nt: left_nt,
    };
    let sigma_rms = (rows
        .iter()
        .map(|r| uncertainty.sigma(r).powi(2))
        .sum::<f64>()
        / count)
        .sqrt();
    let column_std = |j: usize| {
        let m = uncertainty.mean_row[j];
        (rows.iter().map(|r| (r[j] - m).powi(2)).sum::<f64>() / count).sqrt()
    };
    let names = design.column_names(&[]);
    let uncertain_terms = (0..p)
        .filter(|&j| {
            let lf = matches!(
                design.columns()[j],
                Column::Permanent(_)
                    | Column::Induced(..)
                    | Column::InducedTraceless(_)
                    | Column::InducedTrace
            );
            let se = covariance[(j, j)].max(0.0).sqrt();
            lf && se > coefficients[j].abs() && se * column_std(j) > MIN_TERM_EFFECT_NT
        })
        .map(|j| names[j].clone())
        .collect();
    let fixed = matches!(lambda, Lambda::Fixed(_));
    let levels = diagnostics.levels.as_ref();
    let heldout = diagnostics.cross_validation.as_ref();
    let evidence = Evidence {
        excitation_deg,
        uncertainty_nt: sigma_rms,
        correction_nt: crate::signal::metrics::std_dev(&corrections),
        uncertain_terms,
        restrained,
        implausible: fixed
            .then(|| plausible::fault(design, coefficients, fs_hz))
            .flatten(),
        heldout_nt: heldout.map_or(f64::NAN, |cv| cv.expected_heldout_rms_nt),
        insample_nt: (solution.rss / solution.rows.max(1) as f64).sqrt(),
        improvement: diagnostics.improvement_ratio,
        interference,
        level_misfit_nt: levels.map_or(f64::NAN, |l| l.residual_rms_nt),
        level_expected_nt: levels.and_then(|l| l.expected_rms_nt).unwrap_or(f64::NAN),
        fluxgate_offset_nt: levels.map_or(f64::NAN, |l| {
            l.fluxgate.offset_nt.iter().fold(0.0, |m, o| m.max(o.abs()))
        }),
        second_order_nt,
        left_nt,
    };
    // Extra channels that cross-validation dropped are not in the model: nor is their range.
    let extras: &[&[f64]] = if design.extras.is_empty() {
        &[]
    } else {
        flux.extras()
    };
    let coverage = Coverage::of(flux.series()[0], runs, fs_hz, extras);
    // A factor that could not be inverted has no covariance to give: rows get none either.
    let finite = |v: &[f64]| v.iter().all(|x| x.is_finite());
    let usable = finite(&uncertainty.covariance) && finite(&uncertainty.mean_row);
    (usable.then_some(uncertainty), coverage, judge(&evidence))
}

/// RMS change of a fluxgate's direction inside the band (degrees), from the sums of squares of
/// its band-passed permanent columns (the direction cosines) over `rows` band rows; NaN
/// without them.
pub(super) fn excitation_deg(sums_of_squares: &[f64], rows: usize) -> f64 {
    if sums_of_squares.len() != 3 || rows == 0 {
        return f64::NAN;
    }
    (sums_of_squares.iter().sum::<f64>() / rows as f64)
        .sqrt()
        .to_degrees()
}
