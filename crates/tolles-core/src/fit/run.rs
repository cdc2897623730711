//! One fit of checked inputs from start to end: its rows made and factored once, the design
//! and λ chosen on held-out folds, the heading levels and the exact magnitude tried, the result
//! judged. The fluxgate calibration the heading levels need is itself such a fit, so it is made
//! here too ([`reference()`]).

use crate::compensate::{write_runs, Model};
use crate::fit::basis::{on_column_pairs, on_columns, Basis};
use crate::fit::choice::{choose_design, pick_magnitude, union_of_terms};
use crate::fit::diagnostics::{diagnostics, score_block, DiagnosticCounts};
use crate::fit::error::FitError;
use crate::fit::factor::FoldFactor;
use crate::fit::inputs::{check_flux_magnitude, check_not_constant};
use crate::fit::level_setup::LevelSetup;
use crate::fit::levels::{self, Reference};
use crate::fit::outcome::{Diagnostics, Fit};
use crate::fit::problem::{fold_count, AboveBand, LevelChoice, Plan, Problem};
use crate::fit::samples::Samples;
use crate::fit::settings::{passband_fraction, FitSettings, Lambda, Target};
use crate::fit::spare::Spare;
use crate::fit::window_size::window_samples;
use crate::fit::{trust, verdict};
use crate::model::design::Term;
use crate::model::limits::scalar_usable;
use crate::model::magnitude::Magnitude;
use crate::model::vector::{Fluxgates, VectorSeries};
use std::ops::Range;
use std::sync::atomic::Ordering::Relaxed;

/// What the caller of [`fit_reusing`] reads of the fit.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) enum Wanted {
    /// Every part of the [`Fit`].
    Everything,
    /// The coefficients and the residual's standard deviation only (a fluxgate calibration):
    /// the mean correction and the scatter before the fit, each a pass over every sample,
    /// are left out (`level_nt` 0, `filtered_std_before_nt` NaN).
    Coefficients,
}

/// [`crate::fit::fit`] of the checked inputs on `samples` (those of `scalar`: a sample of it
/// that is not believable is not among them), with its large buffers from `spare`, and given
/// back to it when done.
pub(super) fn fit_reusing(
    scalar: &[f64],
    flux: Fluxgates,
    fs_hz: f64,
    samples: &Samples,
    settings: &FitSettings,
    spare: &Spare,
    wanted: Wanted,
) -> Result<Fit, FitError> {
    let usable = &samples.usable;
    check_not_constant(scalar, flux.series()[0], usable)?;
    let designs = settings.candidate_designs();
    let union = union_of_terms(&designs);
    // The rows hold the columns of `basis.stored`; factors and level rows are mapped onto
    // `union` before the candidates take theirs.
    let basis = Basis::of(&union);
    let stored = &basis.stored;
    let problem = Problem {
        scalar,
        flux: &flux,
        samples,
        filter: settings.filter(fs_hz)?,
        above: AboveBand::of(settings, fs_hz, stored)?,
        settings,
        spare,
        fs_hz,
        window_samples: window_samples(),
        parsimonious: std::sync::atomic::AtomicBool::new(false),
    };
    let above = problem.above.as_ref();
    // The linear rows are the largest buffer; a calibration of the fluxgate in a pass of its own
    // uses its first part.
    let longest = samples.runs.iter().map(|r| r.len()).max().unwrap_or(0);
    let low = problem.level_low_pass(fs_hz)?;
    // With levels, the fluxgate is calibrated in this pass when it can be: its magnitude is
    // one more signal, after the target.
    let in_pass = low
        .as_ref()
        .and_then(|_| levels::InPass::of(settings, stored, above.is_some(), fs_hz));
    let extra = usize::from(in_pass.is_some());
    spare.reserve(problem.buffer_len(longest, stored.len() + extra, low.as_ref(), above));
    let mut levels = match in_pass {
        Some(_) => problem.level_setup_pending(fs_hz)?,
        None => level_setup(&problem, fs_hz)?,
    };
    let series = flux.series()[0];
    let linear = |run: Range<usize>, rows: Range<usize>, out: &mut [&mut [f64]]| {
        let (a, after) = out.split_at_mut(stored.len());
        let (y, magnitude) = after.split_at_mut(1);
        settings.design.matrix_rows_into_columns(
            flux.clone(),
            run.clone(),
            rows.clone(),
            stored,
            a,
        );
        let samples = run.start + rows.start..run.start + rows.end;
        if let Some(m) = magnitude.first_mut() {
            let components = [&series.x, &series.y, &series.z].map(|c| &c[samples.clone()]);
            crate::model::vector::norms3_into(components, m);
        }
        y[0].copy_from_slice(&scalar[samples]);
    };
    let count = fold_count(settings.lambda);
    // The band rows are factored once, cut where the folds of any plan start: the folds
    // move when the level rows join, and the calibration's may be more or fewer.
    let mut plans = problem.plans_ahead(levels.as_ref(), above, &[false, true], count);
    let level_plan = plans.pop().filter(|_| levels.is_some());
    let band_plan = plans.pop().expect("the band rows' plan");
    let calibration_plan = in_pass
        .as_ref()
        .and_then(|_| problem.calibration_plan(levels.as_ref(), above, &band_plan));
    let plans: Vec<&Plan> = std::iter::once(&band_plan)
        .chain(&level_plan)
        .chain(&calibration_plan)
        .collect();
    let mut prepared =
        problem.prepare(stored.len(), extra, &linear, levels.as_ref(), above, &plans)?;
    debug_assert!(prepared.plan(false, count) == band_plan);
    let band = prepared.band_factors(&plans);
    let band_folds = prepared.fold_factors(&band_plan, 0.0, &band);
    if let Some(in_pass) = &in_pass {
        let folds = match &calibration_plan {
            Some(plan) => prepared.fold_factors(plan, 0.0, &band),
            None => band_folds.clone(),
        };
        levels = levels.and_then(|setup| {
            problem.calibrated_in_pass(setup, in_pass, &folds, &mut prepared.levels, fs_hz)
        });
    }
    let excitation = excitation_of(&band_folds, stored, prepared.band_row_count());
    // Without maneuvers the folds cannot separate the terms: among priors they cannot tell
    // apart, the strongest (MagNav's real snippet, 0.72° RMS: 0.205 → 0.039 nT on its other half).
    problem
        .parsimonious
        .store(excitation < verdict::MIN_EXCITATION_DEG, Relaxed);
    let prior = problem.prior_weights(&union);
    let band_folds = basis.folds(band_folds);
    let mut chosen = choose_design(
        &band_folds,
        &designs,
        &union,
        settings.lambda,
        0.0,
        prior.as_ref(),
        fs_hz,
    )?;
    let (mut untrusted, mut untrusted_levels_nt) = (false, None);
    if let (Some(setup), Some(plan)) = (levels.as_mut(), &level_plan) {
        let rows = basis.level_rows(&prepared.levels);
        let candidates = (union.as_slice(), designs.as_slice());
        let terms = designs[chosen.index].design_terms();
        let on_union = on_columns(&union, &terms, &chosen.solution.coefficients);
        let above = prepared.above_residual(&basis.on_stored(&on_union));
        let choice =
            problem.choose_with_levels(setup, (&chosen, above), candidates, rows, |setup| {
                let folds = basis.folds(prepared.fold_factors(plan, setup.weight(), &band));
                let weight = setup.weight();
                let prior = prior.as_ref();
                choose_design(
                    &folds,
                    &designs,
                    &union,
                    settings.lambda,
                    weight,
                    prior,
                    fs_hz,
                )
            })?;
        match choice {
            LevelChoice::Used(with_levels) => chosen = *with_levels,
            LevelChoice::Untrusted { misfit_nt } => {
                untrusted = true;
                untrusted_levels_nt = misfit_nt.is_finite().then_some(misfit_nt);
            }
        }
    }
    if untrusted {
        levels = None;
    }
    let design = designs[chosen.index].clone();
    let before = match wanted {
        Wanted::Everything => prepared.band_std(),
        Wanted::Coefficients => f64::NAN,
    };
    let (short, runs_used) = (prepared.short, prepared.runs_used());
    let above_rows = prepared.above_rows();
    let chosen_terms = designs[chosen.index].design_terms();
    let on_stored = basis.on_stored(&on_columns(
        &union,
        &chosen_terms,
        &chosen.solution.coefficients,
    ));
    // The rows above the band hold what only the extra channels explain there: the aircraft's
    // other fields above the band are left in them, so they are no part of the band's residual.
    let mut above_rss = prepared.above_residual(&on_stored).0;
    let mut band_scores = match wanted {
        Wanted::Everything => {
            let block = score_block(settings, fs_hz);
            prepared
                .score_covariance(&on_stored, block)
                .map(|s| on_column_pairs(&union, &chosen_terms, &basis.square_on_terms(&s)))
        }
        Wanted::Coefficients => None,
    };
    spare.give(prepared.into_buffers());
    let terms = design.design_terms();
    let exact = problem.exact(&design, &chosen, levels.as_ref())?;
    let exact_tried = exact.is_some();
    let (magnitude, chosen, iterations) = match exact {
        Some(exact) => {
            let picked = pick_magnitude(chosen, exact.chosen, exact.iterations, settings.magnitude);
            // The level rows describe the fit kept: the Gauss-Newton ones only for the exact.
            if picked.0 == Magnitude::Exact {
                if let Some(setup) = levels.as_mut() {
                    setup.rows = exact.level_rows;
                    setup.row_terms = terms.clone();
                }
                band_scores = band_scores.and(exact.band_scores);
                above_rss = exact.above_rss;
            }
            picked
        }
        None => (Magnitude::Linear, chosen, 0),
    };
    let model = Model {
        design: &design,
        coefficients: &chosen.solution.coefficients,
        magnitude,
    };
    let (level_nt, white_noise_nt) = match wanted {
        Wanted::Everything => level_and_noise(scalar, &flux, &samples.runs, model, spare),
        Wanted::Coefficients => (0.0, f64::NAN),
    };
    let mut diagnostics = diagnostics(
        &chosen.solution,
        DiagnosticCounts {
            level_rows: levels.as_ref().map_or(0, |l| l.row_count()),
            above_rows,
            above_rss,
            level_rss: levels.as_ref().map_or(0.0, |l| {
                l.weighted_rss(&terms, &chosen.solution.coefficients)
            }),
            total: scalar.len(),
            nonfinite: usable.iter().filter(|u| !**u).count(),
            short,
            runs_used,
            before_std: before,
            fraction: match settings.target {
                Target::Band => passband_fraction(settings.band, fs_hz),
                Target::Interference => 1.0,
            },
        },
        chosen.cross_validation,
        chosen.scores,
    );
    diagnostics.levels = levels
        .as_ref()
        .map(|l| l.diagnostics(&terms, &chosen.solution.coefficients));
    diagnostics.untrusted_levels_nt = untrusted_levels_nt;
    diagnostics.exact_iterations = iterations;
    diagnostics.excitation_deg = excitation.is_finite().then_some(excitation);
    diagnostics.restrained = chosen.restrained.clone();
    check_finite(&chosen.solution.coefficients, &diagnostics, wanted)?;
    let assessed = (wanted == Wanted::Everything).then(|| {
        let solution = &chosen.solution;
        let dof = solution
            .rows
            .saturating_sub(solution.coefficients.len())
            .max(1);
        let inputs = trust::Inputs {
            design: &design,
            coefficients: &solution.coefficients,
            solution,
            lambda: settings.lambda,
            fs_hz,
            restrained: chosen.restrained.clone(),
            excitation_deg: excitation,
            white_noise_nt,
            unrivalled_linear: magnitude == Magnitude::Linear && !exact_tried,
            covariance: match &band_scores {
                Some(band) => {
                    let level = levels.as_ref().map(|l| {
                        let s = l.score_covariance(&terms, &solution.coefficients, fs_hz);
                        on_column_pairs(&l.row_terms, &terms, &s)
                    });
                    solution.sandwich(&level.map_or_else(|| band.clone(), |l| band + l))
                }
                None => solution
                    .covariance(solution.rss / dof as f64 / diagnostics.effective_sample_fraction),
            },
            interference: !settings.target.is_band(),
        };
        trust::assess(inputs, &diagnostics, &flux, &samples.runs)
    });
    let (uncertainty, coverage, verdict) = match assessed {
        Some((u, c, v)) => (u, Some(c), Some(v)),
        None => (None, None, None),
    };
    // One standard error everywhere: the table, the model file and the report show the
    // covariance the verdict and each row's σ use.
    if let Some(u) = &uncertainty {
        let p = u.mean_row.len();
        diagnostics.std_errors = (0..p)
            .map(|j| u.covariance[j * p + j].max(0.0).sqrt())
            .collect();
    }
    Ok(Fit {
        settings: FitSettings {
            design: design.clone(),
            ..settings.clone()
        },
        fs_hz,
        magnitude,
        lag_s: 0.0,
        flux_offset_nt: None,
        columns: design.column_names(&[]),
        coefficients: chosen.solution.coefficients,
        level_nt,
        diagnostics,
        verdict,
        uncertainty,
        coverage,
    })
}

/// RMS change (degrees) of the first fluxgate's direction inside the band, from the folds'
/// factors of the band rows (`band_rows` of them) over the `stored` columns: their permanent
/// columns are its band-passed direction cosines. NaN without those columns.
fn excitation_of(folds: &[FoldFactor], stored: &[Term], band_rows: usize) -> f64 {
    let cosines: Vec<usize> = crate::model::terms::Axis::ALL
        .iter()
        .filter_map(|a| {
            stored.iter().position(|t| {
                t.fluxgate == 0 && t.column == crate::model::terms::Column::Permanent(*a)
            })
        })
        .collect();
    let sums: Vec<f64> = cosines
        .iter()
        .map(|&j| folds.iter().map(|f| f.r.column(j).norm_squared()).sum())
        .collect();
    trust::excitation_deg(&sums, band_rows)
}

/// Refuses a fit that overflowed: a model with NaN coefficients would be refused only later,
/// by whoever applies it, far from the cause.
pub(super) fn check_finite(
    coefficients: &[f64],
    diagnostics: &Diagnostics,
    wanted: Wanted,
) -> Result<(), FitError> {
    if !coefficients.iter().all(|b| b.is_finite()) {
        return Err(FitError::NotFinite {
            what: "coefficients",
        });
    }
    let before = diagnostics.filtered_std_before_nt;
    if !(diagnostics.residual_std_nt.is_finite()
        && (before.is_finite() || wanted == Wanted::Coefficients))
    {
        return Err(FitError::NotFinite { what: "residual" });
    }
    Ok(())
}

/// The mean of the model's unfiltered correction over the calibration's `runs` (nT), and the
/// white noise of the scalar less it (nT): the standard deviation of its fourth difference
/// over `√70 / 16`, what that difference keeps of white noise.
fn level_and_noise(
    scalar: &[f64],
    flux: &Fluxgates,
    runs: &[Range<usize>],
    model: Model,
    spare: &Spare,
) -> (f64, f64) {
    let mut field = spare.take(flux.len());
    write_runs(flux.clone(), runs, model, &mut field[..flux.len()]);
    // Run by run, each summed from its first sample: the same additions as ever.
    let mut sum = 0.0;
    let mut count = 0usize;
    for run in runs {
        sum += field[run.clone()].iter().sum::<f64>();
        count += run.len();
    }
    // What the model leaves, in place of the correction (no fresh flight-long vector).
    field[..flux.len()]
        .iter_mut()
        .zip(scalar)
        .for_each(|(f, y)| *f = y - *f);
    let white = crate::signal::metrics::fourth_difference_noise_over(&field[..flux.len()], runs)
        / (70f64.sqrt() / 16.0);
    spare.give([field]);
    let level = if count == 0 { 0.0 } else { sum / count as f64 };
    (level, white)
}

/// The reference and low-pass for heading levels of `problem`, when its settings ask for them
/// and the fluxgate can be calibrated (by a fit of its own, [`reference_reusing`]).
fn level_setup(problem: &Problem, fs_hz: f64) -> Result<Option<LevelSetup>, FitError> {
    let s = problem.settings;
    let Some(setup) = problem.level_setup_pending(fs_hz)? else {
        return Ok(None);
    };
    let flux = problem.flux.series()[0];
    let reference = reference_reusing(flux, problem.samples, fs_hz, s, problem.spare);
    Ok(reference.map(|r| setup.with_reference(r, s, fs_hz)))
}

/// Calibrates the fluxgate against its own band-passed magnitude and returns the reference, or
/// `None` when the calibration cannot be fitted (too little data, constant attitude) or found
/// an offset or distortion no fluxgate has (see [`levels::MAX_OFFSET_NT`],
/// [`levels::MAX_DISTORTION`]).
pub fn reference(
    flux: &VectorSeries,
    usable: &[bool],
    fs_hz: f64,
    tt: Option<&[f64]>,
    settings: &FitSettings,
) -> Option<Reference> {
    // As a fit would check them: a fluxgate out of range gives no reference, and a sample it
    // does not have is not usable whatever `usable` says.
    check_flux_magnitude(flux).ok()?;
    let finite = Fluxgates::from(flux).finite_mask();
    let usable = usable.iter().zip(finite).map(|(u, f)| *u && f).collect();
    let samples = Samples::within(usable, tt);
    reference_reusing(flux, &samples, fs_hz, settings, &Spare::default())
}

/// [`reference()`] on the fit's `samples` (the usable ones of `flux` and their runs), with the
/// calibration fit's buffers from `spare`, and given back to it.
pub(super) fn reference_reusing(
    flux: &VectorSeries,
    samples: &Samples,
    fs_hz: f64,
    settings: &FitSettings,
    spare: &Spare,
) -> Option<Reference> {
    let magnitude = levels::magnitude_of(flux, &samples.usable);
    let design = levels::calibration_design();
    let calibration_settings = FitSettings {
        design: design.clone(),
        lambda: Lambda::auto(),
        alternative_terms: Vec::new(),
        levels: false,
        magnitude: Default::default(),
        prior: levels::calibration_prior(settings),
        ..settings.clone()
    };
    // The magnitude is believable wherever the fluxgate is usable (its check bounds it far
    // below the scalar's limit) and NaN elsewhere, so the fit's samples are the magnitude's.
    debug_assert!(magnitude
        .iter()
        .zip(&samples.usable)
        .all(|(m, u)| scalar_usable(*m) == *u));
    let cal = fit_reusing(
        &magnitude,
        flux.into(),
        fs_hz,
        samples,
        &calibration_settings,
        spare,
        Wanted::Coefficients,
    )
    .ok()?;
    let fitted = levels::Calibrated {
        coefficients: cal.coefficients,
        residual_std_nt: cal.diagnostics.residual_std_nt,
    };
    levels::reference_of(flux, samples, magnitude, &design, &fitted, spare)
}
