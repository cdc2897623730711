//! Shared helpers for integration tests.
#![allow(dead_code)]

use std::path::PathBuf;

/// Reads a MagNav golden CSV (one matrix row per line) as rows of numbers.
pub fn magnav(name: &str) -> Vec<Vec<f64>> {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("tests/fixtures/magnav")
        .join(format!("TL_data.{name}.csv"));
    let text = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    text.lines()
        .filter(|l| !l.trim().is_empty())
        .map(|l| {
            l.split(',')
                .map(|v| v.trim().parse::<f64>().unwrap())
                .collect()
        })
        .collect()
}

/// A MagNav golden column vector.
pub fn magnav_vector(name: &str) -> Vec<f64> {
    magnav(name).into_iter().map(|row| row[0]).collect()
}

/// Population standard deviation.
pub fn std(x: &[f64]) -> f64 {
    let mean = x.iter().sum::<f64>() / x.len() as f64;
    (x.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / x.len() as f64).sqrt()
}

/// How far a survey is from the simulator's true earth field: std of `values − earth_nt` (nT).
pub fn error_vs_truth(values: &[f64], earth_nt: &[f64]) -> f64 {
    let error: Vec<f64> = values.iter().zip(earth_nt).map(|(v, e)| v - e).collect();
    tolles_core::signal::metrics::std_dev(&error)
}

/// `scalar` (nT) compensated with `model` as `tolles compensate` does it: the model's chosen
/// design, the correction's file mean kept, the same sample rate as the calibration.
pub fn compensate_with<'a>(
    model: &tolles_core::fit::Fit,
    scalar: &[f64],
    flux: impl Into<tolles_core::model::vector::Fluxgates<'a>>,
    tt: &[f64],
) -> Vec<f64> {
    let applied = tolles_core::compensate::Model {
        design: &model.settings.design,
        coefficients: &model.coefficients,
        magnitude: model.magnitude,
    };
    tolles_core::compensate::compensate_model(
        scalar,
        flux,
        Some(tt),
        applied,
        1.0,
        tolles_core::compensate::Level::FileMean,
    )
    .compensated
}

use tolles_core::compensate::{compensate_model, Level, Model};
use tolles_core::fit::{fit, Fit, FitSettings};
use tolles_core::flight::plan::{BoxPlan, Plan, SurveyPlan};
use tolles_core::flight::sim::{simulate, Scenario, SimulatedFlight};
use tolles_core::model::design::Design;
use tolles_core::model::vector::Fluxgates;

/// The defaults with the extra channels `extras` (specs such as `cur_1:lowpass=0.3`).
pub fn settings_with_extras(extras: &[&str]) -> FitSettings {
    let recommended = FitSettings::recommended();
    FitSettings {
        design: Design {
            extras: extras.iter().map(|s| s.parse().unwrap()).collect(),
            ..recommended.design.clone()
        },
        ..recommended
    }
}

pub fn inputs_with_current<'a>(flight: &'a SimulatedFlight, with_current: bool) -> Fluxgates<'a> {
    let flux = Fluxgates::from(&flight.flux);
    if with_current {
        flux.with_extras(vec![&flight.current_a])
    } else {
        flux
    }
}

/// Error (nT) against the truth of a survey compensated with a model fitted on a box, the
/// flight's current (`cur_1`) given as the channels `extras` name (none: not given).
pub fn survey_error_with_extras(scenario: &Scenario, extras: &[&str]) -> (f64, Fit) {
    let cal = simulate(&BoxPlan::default().build(), scenario).unwrap();
    let with = !extras.is_empty();
    let model = fit(
        &cal.scalar,
        inputs_with_current(&cal, with),
        10.0,
        Some(&cal.tt),
        &settings_with_extras(extras),
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
        inputs_with_current(&survey, with && !model.settings.design.extras.is_empty()),
        Some(&survey.tt),
        applied,
        1.0,
        Level::FileMean,
    );
    (error_vs_truth(&out.compensated, &survey.earth_nt), model)
}

/// A check flight: a box on the intercardinal headings, then survey lines on its last heading
/// and back. The lines start on the box's last heading: a jump of attitude would be a spike of
/// eddy field no fluxgate at 10 Hz can follow.
pub fn check_plan() -> Plan {
    let mut segments = BoxPlan {
        headings_deg: vec![45.0, 135.0, 225.0, 315.0],
        ..BoxPlan::default()
    }
    .build()
    .segments()
    .to_vec();
    let survey = SurveyPlan {
        heading_deg: 315.0,
        ..SurveyPlan::default()
    };
    segments.extend(survey.build().segments().iter().cloned());
    Plan::new(segments)
}
