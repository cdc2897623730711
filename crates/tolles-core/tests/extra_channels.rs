//! Extra channels as regressors: a current drives a field of fixed direction in the body frame,
//! so its effect on the scalar is `B̂·k·I(t)`; with the current as an extra channel the fit
//! removes it, and cross-validation leaves out a channel that does not help.

mod common;

use tolles_core::compensate::{compensate_model, Level, Model};
use tolles_core::fit::{fit, Fit, FitSettings};
use tolles_core::flight::plan::{BoxPlan, SurveyPlan};
use tolles_core::flight::sim::{simulate, CurrentSource, Installation, Scenario, SimulatedFlight};
use tolles_core::model::design::Design;
use tolles_core::model::vector::Fluxgates;

fn settings(extras: &[&str]) -> FitSettings {
    let recommended = FitSettings::recommended();
    FitSettings {
        design: Design {
            extras: extras.iter().map(|s| s.to_string()).collect(),
            ..recommended.design.clone()
        },
        ..recommended
    }
}

fn inputs<'a>(flight: &'a SimulatedFlight, with_current: bool) -> Fluxgates<'a> {
    let flux = Fluxgates::from(&flight.flux);
    if with_current {
        flux.with_extras(vec![&flight.current_a])
    } else {
        flux
    }
}

/// Error (nT) against the truth of a survey compensated with a model fitted on a box.
fn survey_error(scenario: &Scenario, extras: &[&str]) -> (f64, Fit) {
    let cal = simulate(&BoxPlan::default().build(), scenario).unwrap();
    let with = !extras.is_empty();
    let model = fit(
        &cal.scalar,
        inputs(&cal, with),
        10.0,
        Some(&cal.tt),
        &settings(extras),
    )
    .unwrap();
    let mut survey_scenario = scenario.clone();
    survey_scenario.seed += 1;
    let survey = simulate(&SurveyPlan::default().build(), &survey_scenario).unwrap();
    let applied = Model {
        design: &model.settings.design,
        coefficients: &model.coefficients,
        magnitude: model.magnitude,
    };
    let out = compensate_model(
        &survey.scalar,
        inputs(&survey, with && !model.settings.design.extras.is_empty()),
        Some(&survey.tt),
        applied,
        1.0,
        Level::FileMean,
    );
    (
        common::error_vs_truth(&out.compensated, &survey.earth_nt),
        model,
    )
}

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
        let (off, _) = survey_error(&quiet, &[]);
        let (ignored, _) = survey_error(&scenario, &[]);
        let (with, model) = survey_error(&scenario, &["cur_1"]);
        eprintln!(
            "{name}: current off {off:.4} nT, current not modelled {ignored:.4} nT, --extra cur_1 {with:.4} nT ({:.2}× off); columns {:?}",
            with / off,
            &model.columns[model.columns.len() - 3..]
        );
        assert_eq!(model.settings.design.extras, ["cur_1"]);
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
    let (_, model) = survey_error(&scenario, &["cur_1"]);
    let chosen = model.diagnostics.term_choice.iter().find(|t| t.chosen);
    eprintln!(
        "chosen {:?}; extras kept {:?}",
        chosen.map(|t| t.terms),
        model.settings.design.extras
    );
    assert!(model.settings.design.extras.is_empty());
}
