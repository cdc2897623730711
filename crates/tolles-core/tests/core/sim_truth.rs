//! Simulation tests: the fit must find the aircraft field the simulator put in.

use crate::common::{compensate_with, error_vs_truth};
use proptest::prelude::*;
use tolles_core::compensate::{compensate, Level};
use tolles_core::fit::{fit, Band, FitSettings, Lambda};
use tolles_core::flight::plan::{BoxPlan, SurveyPlan};
use tolles_core::flight::sim::{simulate, Installation, Scenario, Sensors, SimulatedFlight};
use tolles_core::model::design::Design;
use tolles_core::model::interpret::AircraftField;
use tolles_core::model::terms::TermSet;
use tolles_core::signal::metrics::std_dev;

fn settings(terms: &str, lambda: Lambda) -> FitSettings {
    FitSettings {
        design: Design::new(terms.parse::<TermSet>().unwrap()),
        lambda,
        band: Band {
            pass1_hz: 0.1,
            pass2_hz: 0.9,
        },
        order: 4,
        trim: 20,
        alternative_terms: Vec::new(),
        magnitude: tolles_core::fit::MagnitudeChoice::Linear,
        levels: false,
        target: tolles_core::fit::Target::Band,
        prior: None,
        fluxgate_offset: false,
    }
}

fn fit_flight(flight: &SimulatedFlight, s: &FitSettings) -> tolles_core::fit::Fit {
    fit(&flight.scalar, &flight.flux, 10.0, Some(&flight.tt), s).unwrap()
}

/// Largest |difference| of the 16 patent terms by group, relative to the largest true term
/// (but at least 1 nT, 2·10⁻⁵ or 2·10⁻⁶ s, about 1 nT of signal, so a group that is almost
/// absent is not judged by its noise).
fn errors(found: &AircraftField, truth: &AircraftField) -> [f64; 3] {
    let (f, t) = (found.patent_terms().named(), truth.patent_terms().named());
    let group = |range: std::ops::Range<usize>| {
        let floor: f64 =
            [1.0, 2e-5, 2e-6][[0, 3, 8].iter().position(|s| *s == range.start).unwrap()];
        let scale = t[range.clone()]
            .iter()
            .fold(floor, |m, (_, v)| m.max(v.abs()));
        t[range.clone()]
            .iter()
            .zip(&f[range])
            .map(|((_, a), (_, b))| (a - b).abs() / scale)
            .fold(0.0, f64::max)
    };
    [group(0..3), group(3..8), group(8..16)]
}

#[test]
fn box_fit_recovers_the_cabin_aircraft_field() {
    let truth = Installation::Cabin.aircraft();
    let flight = simulate(&BoxPlan::default().build(), &Scenario::new(truth, 11)).unwrap();
    let s = settings("permanent,i5,e8", Lambda::Fixed(0.0));
    let model = fit_flight(&flight, &s);
    let found = AircraftField::from_coefficients(&s.design, &model.coefficients, 10.0);
    let [perm, induced, eddy] = errors(&found, &truth);
    eprintln!("relative errors: perm {perm:.4}, induced {induced:.4}, eddy {eddy:.4}");
    assert!(
        perm < 0.02 && induced < 0.03 && eddy < 0.05,
        "{perm} {induced} {eddy}"
    );
}

#[test]
fn survey_compensated_with_a_box_model_is_the_earth_field_within_noise() {
    let truth = Installation::TailStinger.aircraft();
    let (before, after) = survey_error(truth, &settings("permanent,i5,e8", Lambda::Fixed(0.0)), 21);
    eprintln!("survey error vs truth: before {before:.4} nT, after {after:.4} nT");
    assert!(after < 0.03, "after {after}");
    assert!(before > 10.0 * after);
}

#[test]
fn zero_interference_is_left_alone() {
    let cal = simulate(
        &BoxPlan::default().build(),
        &Scenario::new(AircraftField::default(), 31),
    )
    .unwrap();
    let s = settings("permanent,i5,e8", Lambda::Fixed(0.0));
    let model = fit_flight(&cal, &s);
    let out = compensate(
        &cal.scalar,
        &cal.flux,
        Some(&cal.tt),
        &s.design,
        &model.coefficients,
        1.0,
        Level::FileMean,
    );
    let change: Vec<f64> = out
        .compensated
        .iter()
        .zip(&cal.scalar)
        .map(|(a, b)| a - b)
        .collect();
    let change = std_dev(&change);
    eprintln!("change {change:.5} nT");
    assert!(
        change < 0.01,
        "compensation changed clean data by {change} nT"
    );
}

fn survey_error(truth: AircraftField, s: &FitSettings, seed: u64) -> (f64, f64) {
    let cal = simulate(&BoxPlan::default().build(), &Scenario::new(truth, seed)).unwrap();
    let survey = simulate(
        &SurveyPlan::default().build(),
        &Scenario::new(truth, seed + 1),
    )
    .unwrap();
    let model = fit_flight(&cal, s);
    let after = compensate_with(&model, &survey.scalar, &survey.flux, &survey.tt);
    (
        error_vs_truth(&survey.scalar, &survey.earth_nt),
        error_vs_truth(&after, &survey.earth_nt),
    )
}

/// Aircraft fields up to about 50 nT. Stronger fields (hundreds of nT) break the linearisation
/// `|B + H| ≈ |B| + B̂·H` by `|H⊥|²/2|B|`, several tenths of a nT, which no linear model fits.
fn arbitrary_aircraft() -> impl Strategy<Value = AircraftField> {
    (
        prop::array::uniform3(-50.0..50.0f64),
        prop::array::uniform9(-3e-4..3e-4f64),
        prop::array::uniform9(-2e-4..2e-4f64),
    )
        .prop_map(|(p, i, e)| AircraftField {
            permanent_nt: p,
            induced: [[i[0], i[1], i[2]], [i[3], i[4], i[5]], [i[6], i[7], i[8]]],
            eddy_s: [[e[0], e[1], e[2]], [e[3], e[4], e[5]], [e[6], e[7], e[8]]],
            bias_nt: 0.0,
        })
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(16))]

    /// Without sensor noise, any aircraft field in the linear range is recovered term by term.
    #[test]
    fn any_aircraft_field_is_recovered_from_noiseless_data(truth in arbitrary_aircraft()) {
        let mut scenario = Scenario::new(truth, 0);
        scenario.sensors = Sensors { scalar_noise_nt: 0.0, flux_noise_nt: 0.0, ..Sensors::default() };
        let flight = simulate(&BoxPlan::default().build(), &scenario).unwrap();
        let s = settings("permanent,i5,e8", Lambda::Fixed(0.0));
        let model = fit_flight(&flight, &s);
        let found = AircraftField::from_coefficients(&s.design, &model.coefficients, 10.0);
        let [perm, induced, eddy] = errors(&found, &truth);
        // 2 % for the induced terms: with permanent fields near the range's edge (|H| about
        // 65 nT) and small induced ones, the linearisation's |H⊥|²/2|B| alone reached 1.002 %
        // of the induced scale (a case proptest found, with no noise and no levels).
        prop_assert!(perm < 0.01 && induced < 0.02 && eddy < 0.01, "{perm} {induced} {eddy}");
    }

    /// With realistic noise, a survey compensated with a box model is the earth field to within
    /// a few times the scalar noise, whatever the aircraft.
    #[test]
    fn any_aircraft_field_is_removed_from_a_noisy_survey(truth in arbitrary_aircraft(), seed in 0u64..1000) {
        let (before, after) = survey_error(truth, &FitSettings::recommended(), seed);
        prop_assert!(after < 0.03, "survey error {before} -> {after} nT");
    }
}

#[test]
#[ignore = "prints a comparison of settings; run with --ignored --nocapture"]
fn compare_settings() {
    for installation in [Installation::TailStinger, Installation::Cabin] {
        for (terms, lambda) in [
            ("permanent,i5,e8", Lambda::Fixed(0.0)),
            ("permanent,i5,e8", Lambda::Fixed(1e-3)),
            ("permanent,i5,e8", Lambda::auto()),
            ("permanent,induced,eddy", Lambda::Fixed(1e-3)),
            ("permanent,induced,eddy", Lambda::Fixed(0.0)),
            ("permanent,induced,eddy", Lambda::auto()),
        ] {
            let (before, after) =
                survey_error(installation.aircraft(), &settings(terms, lambda), 5);
            eprintln!(
                "{installation:?} {terms} λ={lambda:?}: survey error {before:.3} -> {after:.4} nT"
            );
        }
    }
}
