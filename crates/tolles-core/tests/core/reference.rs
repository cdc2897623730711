//! Fitting a cabin magnetometer against a compensated reference (`Target::Interference`).
//!
//! The calibration box is flown once; a second magnetometer, already compensated, reads the
//! earth field with its own small errors: 0.05 nT of noise and a 0.1 nT heading error (what a
//! good tail-stinger compensation leaves). The cabin scalar minus that reference is the
//! aircraft's field itself, so it is fitted in the full band. The model then compensates a
//! check flight (another box and survey lines), whose error against the true earth field is
//! printed next to the band-passed defaults and to the floor of the true aircraft model.

use crate::common;

use crate::common::{check_plan, compensate_with, error_vs_truth};
use tolles_core::fit::{fit, FitSettings, Target};
use tolles_core::flight::plan::BoxPlan;
use tolles_core::flight::sim::{simulate, Installation, Scenario, SimulatedFlight};

fn scenario(seed: u64) -> Scenario {
    let mut s = Installation::Cabin.scenario(seed);
    s.extras.current = None;
    s
}

/// The reference magnetometer: the true earth field plus noise and a heading error (nT).
fn reference(flight: &SimulatedFlight, seed: u64) -> Vec<f64> {
    let mut state = seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1;
    let mut noise = move || {
        // Sum of uniforms: close enough to Gaussian for a test's noise.
        (0..12)
            .map(|_| {
                state ^= state << 13;
                state ^= state >> 7;
                state ^= state << 17;
                (state >> 11) as f64 / (1u64 << 53) as f64
            })
            .sum::<f64>()
            - 6.0
    };
    flight
        .earth_nt
        .iter()
        .zip(&flight.yaw_deg)
        .map(|(e, yaw)| e + 0.02 * yaw.to_radians().cos() + 0.05 * noise())
        .collect()
}

#[test]
fn a_reference_fit_is_closer_to_the_truth_than_the_band_pass() {
    let (mut band_sum, mut reference_sum, mut floor_sum) = (0.0, 0.0, 0.0);
    for seed in 1..4 {
        let cal_scenario = scenario(seed);
        let cal = simulate(&BoxPlan::default().build(), &cal_scenario).unwrap();
        let check = simulate(&check_plan(), &scenario(seed + 100)).unwrap();
        let defaults = FitSettings::recommended();
        let band = fit(&cal.scalar, &cal.flux, 10.0, Some(&cal.tt), &defaults).unwrap();
        let interference: Vec<f64> = cal
            .scalar
            .iter()
            .zip(reference(&cal, seed))
            .map(|(s, r)| s - r)
            .collect();
        let settings = FitSettings {
            target: Target::Interference,
            ..defaults
        };
        let against = fit(&interference, &cal.flux, 10.0, Some(&cal.tt), &settings).unwrap();
        let truth: Vec<f64> = check
            .scalar
            .iter()
            .zip(&check.interference_nt)
            .map(|(s, h)| s - h)
            .collect();
        let [b, r, f] = [
            error_vs_truth(
                &compensate_with(&band, &check.scalar, &check.flux, &check.tt),
                &check.earth_nt,
            ),
            error_vs_truth(
                &compensate_with(&against, &check.scalar, &check.flux, &check.tt),
                &check.earth_nt,
            ),
            error_vs_truth(&truth, &check.earth_nt),
        ];
        eprintln!(
            "seed {seed}: band-passed defaults {b:.4} nT, against the reference {r:.4} nT, true model {f:.4} nT"
        );
        band_sum += b;
        reference_sum += r;
        floor_sum += f;
    }
    eprintln!(
        "mean: band-passed {:.4} nT, reference {:.4} nT, floor {:.4} nT",
        band_sum / 3.0,
        reference_sum / 3.0,
        floor_sum / 3.0
    );
    assert!(reference_sum < band_sum, "the reference fit must do better");
    assert!(
        reference_sum < 3.0 * floor_sum,
        "reference fit {:.4} nT against a floor of {:.4} nT",
        reference_sum / 3.0,
        floor_sum / 3.0
    );
}

/// A current the fit is not told of stays in the interference against a reference and bends
/// the terms it has (the permanent field found was twice the truth): the verdict says so and
/// names `--extra`; told of it (`cur_1`), the fit finds the permanent field, and is good once
/// its magnitude is exact (a linear one, the default with extra channels, leaves out a
/// second-order field 13× what the fit leaves, and says so).
#[test]
fn a_reference_fit_that_leaves_a_current_out_is_doubtful_and_names_extra() {
    use common::{inputs_with_current, settings_with_extras};
    use tolles_core::fit::verdict::Reason;
    use tolles_core::fit::MagnitudeChoice;
    use tolles_core::model::interpret::AircraftField;
    let mut s = scenario(1);
    s.extras.current = Installation::Uav.scenario(1).extras.current;
    let truth = s.aircraft.permanent_nt;
    let cal = simulate(&BoxPlan::default().build(), &s).unwrap();
    // A perfect reference: the interference itself and the scalar's noise.
    let target: Vec<f64> = cal
        .scalar
        .iter()
        .zip(&cal.earth_nt)
        .map(|(a, e)| a - e)
        .collect();
    let cases = [
        (&[][..], MagnitudeChoice::Auto),
        (&["cur_1"][..], MagnitudeChoice::Auto),
        (&["cur_1"][..], MagnitudeChoice::Exact),
    ];
    for (extras, magnitude) in cases {
        let settings = FitSettings {
            target: Target::Interference,
            magnitude,
            ..settings_with_extras(extras)
        };
        let inputs = inputs_with_current(&cal, !extras.is_empty());
        let model = fit(&target, inputs, 10.0, Some(&cal.tt), &settings).unwrap();
        let verdict = model.verdict.as_ref().unwrap();
        let found =
            AircraftField::from_coefficients(&model.settings.design, &model.coefficients, 10.0);
        let worst = (0..3)
            .map(|k| (found.permanent_nt[k] - truth[k]).abs())
            .fold(0.0, f64::max);
        eprintln!(
            "extras {extras:?}, {magnitude:?}: permanent {:?} nT (truth {:?}), improvement ×{:.1}, {verdict}",
            found.permanent_nt.map(|p| p.round()),
            truth.map(|p| p.round()),
            model.diagnostics.improvement_ratio
        );
        if extras.is_empty() {
            assert!(
                worst > 50.0,
                "the current bends the permanent field: {worst:.1} nT"
            );
            assert!(
                verdict
                    .reasons
                    .iter()
                    .any(|r| matches!(r, Reason::UnexplainedInterference { .. })),
                "{verdict}"
            );
            assert!(verdict.to_string().contains("--extra"), "{verdict}");
        } else if magnitude == MagnitudeChoice::Auto {
            assert!(worst < 5.0, "{worst:.1} nT from the true permanent field");
            let second_order = |r: &Reason| matches!(r, Reason::SecondOrder { .. });
            assert!(verdict.reasons.iter().all(second_order), "{verdict}");
            assert!(
                verdict.to_string().contains("--magnitude exact"),
                "{verdict}"
            );
        } else {
            assert!(worst < 5.0, "{worst:.1} nT from the true permanent field");
            assert!(verdict.is_good(), "{verdict}");
        }
    }
}
