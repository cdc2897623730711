//! Several fluxgates as regressors: interference from sources near two other fluxgates.
//!
//! A tail-stinger aircraft carries two current loops, one beside fluxgate B and one beside
//! fluxgate C. Each loop's field is strong at its own fluxgate and weaker at the scalar
//! magnetometer; fluxgate A, on the stinger, sees neither. The scalar's interference thus
//! depends on where both B and C are: no single fluxgate's design can describe it, the design
//! over A, B and C can.

use crate::common::{compensate_with, error_vs_truth};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use tolles_core::fit::{fit, FitSettings};
use tolles_core::flight::plan::{BoxPlan, Plan, SurveyPlan};
use tolles_core::flight::sim::{simulate, Installation, Scenario};
use tolles_core::model::design::Design;
use tolles_core::model::terms::TermSet;
use tolles_core::model::vector::VectorSeries;
use tolles_core::signal::metrics::std_dev;

/// A current loop: a current made of a few random tones inside the fit's pass band, and its
/// field per ampere (nT/A, body frame) at its fluxgate and at the scalar magnetometer.
struct Loop {
    at_fluxgate: [f64; 3],
    at_scalar: [f64; 3],
    tones: Vec<(f64, f64, f64)>,
}

impl Loop {
    fn random(rng: &mut ChaCha8Rng, at_fluxgate: [f64; 3], at_scalar: [f64; 3]) -> Self {
        let tones = (0..4)
            .map(|_| {
                (
                    rng.random_range(2.0..6.0),
                    rng.random_range(0.12..0.8),
                    rng.random_range(0.0..std::f64::consts::TAU),
                )
            })
            .collect();
        Self {
            at_fluxgate,
            at_scalar,
            tones,
        }
    }

    /// Current (A) at time `t` (s).
    fn current(&self, t: f64) -> f64 {
        self.tones
            .iter()
            .map(|(a, f, p)| a * (std::f64::consts::TAU * f * t + p).sin())
            .sum()
    }
}

/// A simulated flight with the loops' fields added to the scalar and to fluxgates B and C.
struct Flight {
    tt: Vec<f64>,
    scalar: Vec<f64>,
    earth_nt: Vec<f64>,
    /// Fluxgates A (clean), B and C (nT, body frame).
    flux: [VectorSeries; 3],
}

fn fly(plan: &Plan, seed: u64) -> Flight {
    let sim = simulate(
        plan,
        &Scenario::new(Installation::TailStinger.aircraft(), seed),
    )
    .unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let loops = [
        Loop::random(&mut rng, [40.0, -25.0, 30.0], [3.0, 2.0, -4.0]),
        Loop::random(&mut rng, [-20.0, 35.0, 45.0], [-2.5, 4.0, 3.0]),
    ];
    let mut scalar = sim.scalar.clone();
    let mut flux = [sim.flux.clone(), sim.flux.clone(), sim.flux.clone()];
    for (k, reading) in scalar.iter_mut().enumerate() {
        let field = sim.flux.at(k);
        let mut at_scalar = field;
        for (l, source) in loops.iter().enumerate() {
            let i = source.current(sim.tt[k]);
            let own = &mut flux[l + 1];
            let noise = [0; 3].map(|_| rng.random_range(-0.3..0.3));
            own.x[k] += i * source.at_fluxgate[0] + noise[0];
            own.y[k] += i * source.at_fluxgate[1] + noise[1];
            own.z[k] += i * source.at_fluxgate[2] + noise[2];
            for (a, h) in at_scalar.iter_mut().zip(source.at_scalar) {
                *a += i * h;
            }
        }
        let norm = |v: [f64; 3]| (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
        *reading += norm(at_scalar) - norm(field);
    }
    Flight {
        tt: sim.tt,
        scalar,
        earth_nt: sim.earth_nt,
        flux,
    }
}

/// Survey error (nT, std of compensated − earth) of a model fitted on `cal` with the
/// fluxgates `which`, applied to `survey`, and the term set the fit chose.
fn survey_error(cal: &Flight, survey: &Flight, which: &[usize]) -> (f64, TermSet) {
    let settings = FitSettings {
        design: Design::new(FitSettings::recommended().design.terms).with_fluxgates(which.len()),
        ..FitSettings::recommended()
    };
    let pick = |f: &'_ Flight| which.iter().map(|&w| f.flux[w].clone()).collect::<Vec<_>>();
    let model = fit(&cal.scalar, &pick(cal), 10.0, Some(&cal.tt), &settings).unwrap();
    let after = compensate_with(&model, &survey.scalar, &pick(survey), &survey.tt);
    (
        error_vs_truth(&after, &survey.earth_nt),
        model.settings.design.terms,
    )
}

#[test]
fn the_design_over_all_fluxgates_beats_every_single_fluxgate() {
    let cal = fly(&BoxPlan::default().build(), 7);
    let survey = fly(&SurveyPlan::default().build(), 8);
    let before: Vec<f64> = survey
        .scalar
        .iter()
        .zip(&survey.earth_nt)
        .map(|(s, e)| s - e)
        .collect();
    let single: Vec<f64> = (0..3)
        .map(|f| survey_error(&cal, &survey, &[f]).0)
        .collect();
    let (all, terms) = survey_error(&cal, &survey, &[0, 1, 2]);
    eprintln!(
        "survey error: uncompensated {:.3} nT; fluxgate A {:.3}, B {:.3}, C {:.3}; A+B+C {all:.3} ({terms})",
        std_dev(&before),
        single[0],
        single[1],
        single[2]
    );
    let best_single = single.iter().copied().fold(f64::INFINITY, f64::min);
    assert!(
        all < 0.5 * best_single,
        "A+B+C leaves {all} nT, the best single fluxgate {best_single} nT"
    );
    // A loop changes its fluxgate's magnitude, which only the full induced set (with its
    // trace B̂·B = |B|) sees: cross-validation must have found that.
    assert_eq!(terms, TermSet::magnav_default());
}
