//! Whether a model can be trusted, on simulated flights whose truth is known: a calibration
//! without maneuvers, a strong cabin installation fitted against a reference, the verdict's
//! reasons, each row's standard error against the true error, and the rows a calibration never
//! flew.

use crate::common::error_vs_truth;
use tolles_core::compensate::trust::{outside_over_runs, sigma_over_runs};
use tolles_core::compensate::{compensate_model, model_field, Level, Model};
use tolles_core::fit::plausible::fault;
use tolles_core::fit::verdict::{Grade, Reason};
use tolles_core::fit::{fit, Fit, FitError, FitSettings, Target};
use tolles_core::flight::plan::{BoxPlan, Motion, Plan, Segment, SurveyPlan, Wave};
use tolles_core::flight::sim::{simulate, Installation, Scenario, SimulatedFlight};
use tolles_core::model::interpret::AircraftField;
use tolles_core::model::vector::Fluxgates;

fn model(fit: &Fit) -> Model<'_> {
    Model {
        design: &fit.settings.design,
        coefficients: &fit.coefficients,
        magnitude: fit.magnitude,
    }
}

/// `flight` compensated with `fit`, the file's mean correction kept (nT).
fn compensated(fit: &Fit, flight: &SimulatedFlight) -> Vec<f64> {
    let (scalar, flux, tt) = (&flight.scalar, &flight.flux, Some(&flight.tt[..]));
    compensate_model(scalar, flux, tt, model(fit), 1.0, Level::FileMean).compensated
}

/// Straight legs in light turbulence, turning gently between headings `from` and `to` and no
/// maneuver: what a transit flight gives to calibrate on.
fn transit(headings: &[f64], leg_s: f64, turbulence_deg: f64) -> Plan {
    let wave = |a: f64, f: f64, p: f64| Wave {
        amplitude_deg: a,
        frequency_hz: f,
        phase_rad: p,
    };
    let waves = |k: usize| {
        [(0.02, 0.3), (0.11, 1.1), (0.23, 2.0), (0.4, 0.7)]
            .map(|(f, p)| wave(turbulence_deg / 2.0, f, p + k as f64))
            .to_vec()
    };
    let mut segments = Vec::new();
    for (k, h) in headings.iter().enumerate() {
        if let Some(before) = k.checked_sub(1).map(|j| headings[j]) {
            segments.push(Segment {
                line: 100.0 + k as f64,
                heading_deg: before,
                duration_s: 30.0,
                motion: Motion::Turn {
                    change_deg: h - before,
                    bank_deg: 5.0,
                },
            });
        }
        segments.push(Segment {
            line: 1.0 + k as f64,
            heading_deg: *h,
            duration_s: leg_s,
            motion: Motion::Turbulent {
                roll: waves(3 * k),
                pitch: waves(3 * k + 1),
                yaw: waves(3 * k + 2),
            },
        });
    }
    Plan::new(segments)
}

fn cabin(seed: u64) -> Scenario {
    let mut s = Installation::Cabin.scenario(seed);
    s.sensors.flux_noise_nt = 0.3;
    s.sensors.fluxgate.bias_nt = [12.0, -10.0, 9.0];
    s
}

#[test]
fn a_calibration_without_maneuvers_is_doubtful_and_never_worse_than_raw() {
    let mut worst: f64 = 0.0;
    for seed in 1..=3 {
        let scenario = cabin(seed);
        let cal = simulate(&transit(&[30.0, 40.0, 25.0], 400.0, 0.3), &scenario).unwrap();
        let model = fit(
            &cal.scalar,
            &cal.flux,
            10.0,
            Some(&cal.tt),
            &FitSettings::recommended(),
        )
        .unwrap();
        let verdict = model.verdict.clone().unwrap();
        assert_eq!(verdict.grade, Grade::Doubtful, "{verdict}");
        assert!(
            verdict
                .reasons
                .iter()
                .any(|r| matches!(r, Reason::NoManeuvers { .. })),
            "{verdict}"
        );
        // A survey on other headings, with more attitude than the transit ever had.
        let mut survey_scenario = scenario.clone();
        survey_scenario.seed += 50;
        let plan = SurveyPlan {
            heading_deg: 90.0,
            turbulence_deg: 1.5,
            ..SurveyPlan::default()
        };
        let survey = simulate(&plan.build(), &survey_scenario).unwrap();
        let raw = error_vs_truth(&survey.scalar, &survey.earth_nt);
        let after = error_vs_truth(&compensated(&model, &survey), &survey.earth_nt);
        eprintln!("seed {seed}: raw {raw:.3} nT, compensated {after:.3} nT; {verdict}");
        worst = worst.max(after / raw);
    }
    assert!(worst <= 1.0, "worse than raw: ×{worst:.2}");
}

/// A strong random cabin installation: hundreds of nT of permanent field, induced coefficients
/// of a percent.
fn strong(seed: u64) -> Scenario {
    let mut s = cabin(seed);
    let mut state = seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1;
    let mut uniform = |scale: f64| {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        scale * (2.0 * (state >> 11) as f64 / (1u64 << 53) as f64 - 1.0)
    };
    s.aircraft = AircraftField {
        permanent_nt: [0; 3].map(|_| uniform(1500.0)),
        induced: [[0; 3]; 3].map(|r| r.map(|_| uniform(0.02))),
        eddy_s: [[0; 3]; 3].map(|r| r.map(|_| uniform(5e-4))),
        bias_nt: 0.0,
    };
    s
}

#[test]
fn a_strong_cabin_installation_against_a_reference_is_plausible_or_refused() {
    for seed in 1..=4 {
        let scenario = strong(seed);
        for plan in [
            BoxPlan::default().build(),
            transit(&[10.0, 20.0], 300.0, 0.2),
        ] {
            let flight = simulate(&plan, &scenario).unwrap();
            // The scalar less a perfect reference: the aircraft's field and the scalar's noise.
            let target: Vec<f64> = flight
                .scalar
                .iter()
                .zip(&flight.earth_nt)
                .map(|(s, e)| s - e)
                .collect();
            let settings = FitSettings {
                target: Target::Interference,
                levels: false,
                ..FitSettings::recommended()
            };
            match fit(&target, &flight.flux, 10.0, Some(&flight.tt), &settings) {
                Ok(model) => {
                    let found = fault(&model.settings.design, &model.coefficients, 10.0);
                    let field = AircraftField::from_coefficients(
                        &model.settings.design,
                        &model.coefficients,
                        10.0,
                    );
                    eprintln!(
                        "seed {seed}: permanent {:?} nT, verdict {}",
                        field.permanent_nt.map(|p| p.round()),
                        model.verdict.as_ref().unwrap()
                    );
                    assert_eq!(found, None);
                }
                Err(FitError::Implausible(f)) => eprintln!("seed {seed}: refused: {f}"),
                Err(e) => panic!("{e}"),
            }
        }
    }
}

#[test]
fn flights_that_have_a_reason_for_doubt_are_judged_doubtful_for_it() {
    let has = |fit: &Fit, pick: fn(&Reason) -> bool| {
        let v = fit.verdict.as_ref().unwrap();
        assert!(v.reasons.iter().any(pick), "{v}");
    };
    // With the heading levels, which calibrate the fluxgate (its offset is one reason).
    let settings = FitSettings {
        levels: true,
        ..FitSettings::recommended()
    };
    // A good box with a fair fluxgate: good.
    let scenario = cabin(7);
    let cal = simulate(&BoxPlan::default().build(), &scenario).unwrap();
    let good = fit(&cal.scalar, &cal.flux, 10.0, Some(&cal.tt), &settings).unwrap();
    assert!(
        good.verdict.as_ref().unwrap().is_good(),
        "{:?}",
        good.verdict
    );
    // The earth field alone: nothing of it is the aircraft's.
    let earth = fit(&cal.earth_nt, &cal.flux, 10.0, Some(&cal.tt), &settings).unwrap();
    has(&earth, |r| matches!(r, Reason::LittleExplained { .. }));
    // A fluxgate whose offset is of a sensor sitting on the airframe.
    let mut offset = scenario.clone();
    offset.sensors.fluxgate.bias_nt = [650.0, -400.0, 300.0];
    let flight = simulate(&BoxPlan::default().build(), &offset).unwrap();
    let model = fit(
        &flight.scalar,
        &flight.flux,
        10.0,
        Some(&flight.tt),
        &settings,
    )
    .unwrap();
    has(&model, |r| matches!(r, Reason::FluxgateOffset { .. }));
    // A transit: no maneuvers.
    let flight = simulate(&transit(&[0.0, 15.0], 300.0, 0.2), &scenario).unwrap();
    let model = fit(
        &flight.scalar,
        &flight.flux,
        10.0,
        Some(&flight.tt),
        &settings,
    )
    .unwrap();
    has(&model, |r| matches!(r, Reason::NoManeuvers { .. }));
}

/// Per row of `flight`, the error of `fit`'s correction against the true interference,
/// relative to the calibration's mean of the same (nT), and the row's standard error.
fn errors_and_sigmas(
    fit: &Fit,
    cal: &SimulatedFlight,
    flight: &SimulatedFlight,
) -> Vec<(f64, f64)> {
    let field = |f: &SimulatedFlight| {
        let c = model_field(&f.flux, Some(&f.tt), model(fit), 1.0);
        let e: Vec<f64> = c
            .iter()
            .zip(&f.interference_nt)
            .map(|(c, h)| c - h)
            .collect();
        e
    };
    let on_cal = field(cal);
    let finite: Vec<f64> = on_cal.iter().copied().filter(|v| v.is_finite()).collect();
    let offset = finite.iter().sum::<f64>() / finite.len() as f64;
    let all = 0..flight.flux.len();
    let runs = std::slice::from_ref(&all);
    let u = fit.uncertainty.as_ref().unwrap();
    let design = &fit.settings.design;
    let sigma = sigma_over_runs(Fluxgates::from(&flight.flux), runs, design, u, 1.0);
    field(flight)
        .iter()
        .zip(sigma)
        .filter(|(e, s)| e.is_finite() && s.is_finite())
        .map(|(e, s)| (e - offset, s))
        .collect()
}

#[test]
fn each_row_s_standard_error_covers_its_true_error_at_its_stated_rate() {
    // Tail stingers with no isotropic induced part: the 16 terms describe their field exactly,
    // so the correction's error is the coefficients' own. σ does not hold a model's error: a
    // cabin fluxgate sits in the aircraft's own field, which bends its direction (measured:
    // 17 % of rows within 1σ).
    let mut within = 0usize;
    let mut total = 0usize;
    for seed in 1..=12 {
        let mut scenario = Installation::TailStinger.scenario(seed);
        scenario.extras = Default::default();
        let a = &mut scenario.aircraft;
        let trace: f64 = (0..3).map(|k| a.induced[k][k]).sum::<f64>() / 3.0;
        (0..3).for_each(|k| a.induced[k][k] -= trace);
        scenario.sensors.flux_noise_nt = 0.3;
        let cal = simulate(&BoxPlan::default().build(), &scenario).unwrap();
        let model = fit(
            &cal.scalar,
            &cal.flux,
            10.0,
            Some(&cal.tt),
            &FitSettings::recommended(),
        )
        .unwrap();
        // σ is the coefficients' uncertainty. The fluxgate's own noise adds an error of each
        // row's correction besides (0.02 nT on a cabin installation's 3000 nT permanent field),
        // so the survey is flown without it: the error measured is the coefficients' alone.
        let mut survey_scenario = scenario.clone();
        survey_scenario.seed += 100;
        survey_scenario.sensors.flux_noise_nt = 0.0;
        let plan = SurveyPlan {
            turbulence_deg: 1.5,
            ..SurveyPlan::default()
        };
        let survey = simulate(&plan.build(), &survey_scenario).unwrap();
        let rows = errors_and_sigmas(&model, &cal, &survey);
        let inside = rows.iter().filter(|(e, s)| e.abs() <= *s).count();
        let rms = |f: fn(&(f64, f64)) -> f64| {
            (rows.iter().map(|r| f(r).powi(2)).sum::<f64>() / rows.len() as f64).sqrt()
        };
        let (error, sigma) = (rms(|r| r.0), rms(|r| r.1));
        eprintln!(
            "seed {seed}: error RMS {error:.4} nT, sigma RMS {sigma:.4} nT, {:.0} % within 1σ",
            100.0 * inside as f64 / rows.len() as f64
        );
        within += inside;
        total += rows.len();
    }
    let share = within as f64 / total as f64;
    eprintln!(
        "all: {:.1} % of {total} rows within 1σ (a Gaussian: 68.3 %)",
        100.0 * share
    );
    assert!((0.55..=0.85).contains(&share), "{share}");
}

#[test]
fn rows_at_attitudes_the_box_never_reached_are_flagged() {
    let scenario = cabin(4);
    let plan = BoxPlan {
        headings_deg: vec![0.0, 180.0],
        ..BoxPlan::default()
    };
    let cal = simulate(&plan.build(), &scenario).unwrap();
    let model = fit(
        &cal.scalar,
        &cal.flux,
        10.0,
        Some(&cal.tt),
        &FitSettings::recommended(),
    )
    .unwrap();
    let coverage = model.coverage.as_ref().unwrap();
    let share = |heading: f64| {
        let survey = SurveyPlan {
            heading_deg: heading,
            lines: 2,
            ..SurveyPlan::default()
        };
        let flight = simulate(&survey.build(), &scenario).unwrap();
        let all = 0..flight.flux.len();
        let runs = std::slice::from_ref(&all);
        let flags = outside_over_runs(Fluxgates::from(&flight.flux), runs, coverage, 10.0);
        let on_lines: Vec<bool> = flags
            .iter()
            .zip(&flight.line)
            .filter(|(_, l)| **l > 1000.0)
            .map(|(f, _)| *f)
            .collect();
        on_lines.iter().filter(|f| **f).count() as f64 / on_lines.len() as f64
    };
    let (along, across) = (share(0.0), share(90.0));
    eprintln!(
        "flagged: {:.1} % of lines flown N-S, {:.1} % of lines flown E-W",
        100.0 * along,
        100.0 * across
    );
    assert!(along < 0.01 && across > 0.9);
}

/// One standard error everywhere: the model's `diagnostics.std_errors` (the table, the report)
/// are the square roots of the covariance each row's σ and the verdict use.
#[test]
fn the_standard_errors_are_those_of_the_covariance_sigma_uses() {
    let cal = simulate(&BoxPlan::default().build(), &cabin(7)).unwrap();
    let model = fit(
        &cal.scalar,
        &cal.flux,
        10.0,
        Some(&cal.tt),
        &FitSettings::recommended(),
    )
    .unwrap();
    let u = model.uncertainty.as_ref().unwrap();
    let p = u.mean_row.len();
    assert_eq!(model.diagnostics.std_errors.len(), p);
    for (j, se) in model.diagnostics.std_errors.iter().enumerate() {
        assert_eq!(*se, u.covariance[j * p + j].max(0.0).sqrt(), "column {j}");
    }
    assert!(u.noise_nt > 0.0 && u.noise_nt.is_finite(), "{}", u.noise_nt);
}
