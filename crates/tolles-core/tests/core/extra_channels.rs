//! Extra channels as regressors: a current drives a field of fixed direction in the body frame,
//! so its effect on the scalar is `B̂·k·I(t)`; with the current as an extra channel the fit
//! removes it, and cross-validation leaves out a channel that does not help.

use crate::common;

use crate::common::survey_error_with_extras;

use tolles_core::compensate::{compensate_model, Level, Model};
use tolles_core::fit::{fit, FitSettings};
use tolles_core::flight::plan::{BoxPlan, SurveyPlan};
use tolles_core::flight::sim::{simulate, CurrentSource, Installation, Scenario, SimulatedFlight};
use tolles_core::model::design::Design;
use tolles_core::model::extra::ExtraChannel;
use tolles_core::model::vector::Fluxgates;

fn strobe(seed: u64) -> Scenario {
    let mut s = Installation::Cabin.scenario(seed);
    s.extras.current = Some(CurrentSource {
        field_nt_per_a: [30.0, -40.0, 45.0],
        mean_a: 0.5,
        ripple_a: 0.0,
        ripple_hz: 0.0,
        step_a: 1.0,
        step_every_s: 7.0,
    });
    s
}

#[test]
fn a_current_as_an_extra_channel_is_removed_almost_as_if_it_were_off() {
    for (name, scenario) in [
        ("UAV motor", Installation::Uav.scenario(3)),
        ("strobe", strobe(4)),
    ] {
        let mut quiet = scenario.clone();
        let current = quiet.extras.current.take().unwrap();
        // Keep the current channel's values (the simulator writes it only with a source), but
        // with no field.
        quiet.extras.current = Some(CurrentSource {
            field_nt_per_a: [0.0; 3],
            ..current
        });
        let (off, _) = survey_error_with_extras(&quiet, &[]);
        let (ignored, _) = survey_error_with_extras(&scenario, &[]);
        let (with, model) = survey_error_with_extras(&scenario, &["cur_1"]);
        eprintln!(
            "{name}: current off {off:.4} nT, current not modelled {ignored:.4} nT, --extra cur_1 {with:.4} nT ({:.2}× off); columns {:?}",
            with / off,
            &model.columns[model.columns.len() - 3..]
        );
        assert_eq!(model.settings.design.extras, [ExtraChannel::plain("cur_1")]);
        assert!(with <= 1.5 * off, "{name}: {with} vs {off}");
        assert!(ignored > 5.0 * with, "{name}: {ignored} vs {with}");
    }
}

#[test]
fn a_channel_that_carries_nothing_is_left_out_by_cross_validation() {
    let mut scenario = Installation::Cabin.scenario(6);
    scenario.extras.current = Some(CurrentSource {
        field_nt_per_a: [0.0; 3],
        mean_a: 2.0,
        ripple_a: 1.0,
        ripple_hz: 0.3,
        step_a: 0.0,
        step_every_s: 10.0,
    });
    let (_, model) = survey_error_with_extras(&scenario, &["cur_1"]);
    let chosen = model.diagnostics.term_choice.iter().find(|t| t.chosen);
    eprintln!(
        "chosen {:?}; extras kept {:?}",
        chosen.map(|t| t.terms),
        model.settings.design.extras
    );
    assert!(model.settings.design.extras.is_empty());
}

/// A flight of `scenario` (its current's field off) with the field of its current added as the
/// aircraft would see it: `field_nt_per_a · I_field(t)`, where `I_field` is `response` of the
/// recorded current, computed finely from the current's exact waveform.
fn with_field_of(
    plan: &tolles_core::flight::plan::Plan,
    scenario: &Scenario,
    source: CurrentSource,
    response: Response,
) -> SimulatedFlight {
    let mut flight = simulate(plan, scenario).unwrap();
    let fine_steps = 200;
    let h = 1.0 / (scenario.fs_hz * fine_steps as f64);
    let mut smoothed = source.at(flight.tt[0]);
    let mut t_prev = flight.tt[0];
    for k in 0..flight.tt.len() {
        let t = flight.tt[k];
        let amps = match response {
            Response::LowPass { corner_hz } => {
                let tau = 1.0 / (2.0 * std::f64::consts::PI * corner_hz);
                let steps = ((t - t_prev) / h).round() as usize;
                for s in 1..=steps {
                    let x = source.at(t_prev + s as f64 * h);
                    smoothed = x + (smoothed - x) * (-h / tau).exp();
                }
                t_prev = t;
                smoothed
            }
            Response::Lag { seconds } => source.at(t - seconds),
        };
        let b = flight.flux.at(k);
        let norm = (b[0] * b[0] + b[1] * b[1] + b[2] * b[2]).sqrt();
        let along: f64 = (0..3).map(|i| b[i] / norm * source.field_nt_per_a[i]).sum();
        flight.scalar[k] += along * amps;
    }
    flight
}

#[derive(Clone, Copy)]
enum Response {
    LowPass { corner_hz: f64 },
    Lag { seconds: f64 },
}

fn with<'a>(f: &'a SimulatedFlight, c: &'a Option<Vec<f64>>, keep: bool) -> Fluxgates<'a> {
    let flux = Fluxgates::from(&f.flux);
    match c {
        Some(c) if keep => flux.with_extras(vec![c.as_slice()]),
        _ => flux,
    }
}

/// Error (nT) against the truth of a survey compensated with a model fitted on a box, both
/// with the current's field seen through `response`, the current channel conditioned as `spec`
/// (none: not modelled).
fn conditioned_error(
    scenario: &Scenario,
    source: CurrentSource,
    response: Option<Response>,
    spec: Option<&str>,
) -> f64 {
    let fly = |plan, seed| {
        let mut s = scenario.clone();
        s.seed = seed;
        match response {
            Some(r) => with_field_of(&plan, &s, source, r),
            None => simulate(&plan, &s).unwrap(),
        }
    };
    let cal = fly(BoxPlan::default().build(), scenario.seed);
    let survey = fly(SurveyPlan::default().build(), scenario.seed + 1);
    let spec: Option<ExtraChannel> = spec.map(|s| s.parse().unwrap());
    let extras: Vec<ExtraChannel> = spec.iter().cloned().collect();
    let channel = |f: &SimulatedFlight| spec.as_ref().map(|s| s.condition(&f.current_a, 10.0));
    let cal_current = channel(&cal);
    let settings = FitSettings {
        design: Design {
            extras,
            ..FitSettings::recommended().design
        },
        ..FitSettings::recommended()
    };
    let model = fit(
        &cal.scalar,
        with(&cal, &cal_current, true),
        10.0,
        Some(&cal.tt),
        &settings,
    )
    .unwrap();
    let survey_current = channel(&survey);
    let kept = !model.settings.design.extras.is_empty();
    let out = compensate_model(
        &survey.scalar,
        with(&survey, &survey_current, kept),
        Some(&survey.tt),
        Model {
            design: &model.settings.design,
            coefficients: &model.coefficients,
            magnitude: model.magnitude,
        },
        1.0,
        Level::FileMean,
    );
    // Samples a lag leaves without a value are not part of the comparison.
    let (values, earth): (Vec<f64>, Vec<f64>) = out
        .compensated
        .iter()
        .zip(&survey.earth_nt)
        .filter(|(v, _)| v.is_finite())
        .unzip();
    common::error_vs_truth(&values, &earth)
}

/// A current whose field the wiring smooths (a 0.3 Hz low-pass) or delays (0.25 s): the plain
/// channel leaves most of it, the matching option removes it. For a smooth current down to the
/// current-off floor; for a load switched between samples down to what the samples can tell
/// (the moment of a switch within a sample step is unknown, which the low-pass turns into an
/// error of about `field·step·h/(2τ)` decaying with τ).
#[test]
fn a_smoothed_or_late_current_field_is_removed_with_the_matching_option() {
    let smooth = CurrentSource {
        field_nt_per_a: [30.0, -40.0, 45.0],
        mean_a: 0.5,
        ripple_a: 0.8,
        ripple_hz: 0.4,
        step_a: 0.0,
        step_every_s: 7.0,
    };
    let switched = CurrentSource {
        step_a: 1.0,
        // Switched between samples, as a real load is.
        step_every_s: 7.03,
        ..smooth
    };
    let (low, late) = (
        (Response::LowPass { corner_hz: 0.3 }, "cur_1:lowpass=0.3"),
        (Response::Lag { seconds: 0.25 }, "cur_1:lag=0.25"),
    );
    // (current, response, option, bound on matched/off, least plain/matched)
    let cases = [
        ("smooth", smooth, low, 1.5, 100.0),
        ("smooth", smooth, late, 1.5, 100.0),
        ("switched", switched, low, 40.0, 20.0),
        // A step seen 2.5 samples late is the worst case: it cannot be placed within a sample.
        ("switched", switched, late, f64::INFINITY, 5.0),
    ];
    for (name, source, (response, option), near_off, gain) in cases {
        let mut scenario = Installation::Cabin.scenario(11);
        // The simulator records the current but adds no field of its own: the tests add it.
        scenario.extras.current = Some(CurrentSource {
            field_nt_per_a: [0.0; 3],
            ..source
        });
        let off = conditioned_error(&scenario, source, None, None);
        let plain = conditioned_error(&scenario, source, Some(response), Some("cur_1"));
        let matched = conditioned_error(&scenario, source, Some(response), Some(option));
        eprintln!(
            "{name}: current off {off:.4} nT; --extra cur_1 {plain:.4} nT; --extra {option} {matched:.4} nT ({:.2}× off)",
            matched / off
        );
        assert!(
            matched <= near_off * off,
            "{name} {option}: {matched} vs off {off}"
        );
        assert!(
            plain > gain * matched,
            "{name} {option}: plain {plain} vs {matched}"
        );
    }
}
