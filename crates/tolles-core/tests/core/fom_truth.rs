//! The figure of merit from detected maneuvers against the simulator's truth.

use proptest::prelude::*;
use tolles_core::flight::plan::{BoxPlan, Motion, Plan, Segment, SurveyPlan, Wave};
use tolles_core::flight::sim::{simulate, Installation, Scenario, SimulatedFlight};
use tolles_core::maneuvers::detect::{detect_maneuvers, Maneuver, ManeuverKind, ManeuverSettings};
use tolles_core::maneuvers::fom::{bandpassed, fom, peak_to_peak, FomSettings, Slot};

fn fly(plan: &Plan, fs_hz: f64, seed: u64) -> SimulatedFlight {
    let mut scenario = Scenario::new(Installation::Cabin.aircraft(), seed);
    scenario.fs_hz = fs_hz;
    simulate(plan, &scenario).unwrap()
}

fn detect(f: &SimulatedFlight) -> Vec<Maneuver> {
    detect_maneuvers(
        &f.tt,
        &f.roll_deg,
        &f.pitch_deg,
        &f.yaw_deg,
        &ManeuverSettings::default(),
    )
}

/// A harmonic segment of the plan: kind, heading and sample window `start..end`.
struct Truth {
    kind: ManeuverKind,
    heading: f64,
    start: usize,
    end: usize,
}

fn truth(plan: &Plan, fs_hz: f64, n: usize) -> Vec<Truth> {
    plan.segments()
        .iter()
        .zip(plan.starts())
        .filter_map(|(s, &t0)| match s.motion {
            Motion::Harmonic { axis, .. } => Some(Truth {
                kind: axis,
                heading: s.heading_deg.rem_euclid(360.0),
                start: (t0 * fs_hz).round() as usize,
                end: (((t0 + s.duration_s) * fs_hz).round() as usize + 1).min(n),
            }),
            _ => None,
        })
        .collect()
}

fn overlap(a: (usize, usize), b: (usize, usize)) -> f64 {
    let common = a.1.min(b.1).saturating_sub(a.0.max(b.0));
    common as f64 / (a.1 - a.0).max(b.1 - b.0) as f64
}

/// Checks detection against truth and returns (FOM detected, FOM truth windows) of `signal`.
fn check_box(plan: &Plan, fs_hz: f64, signal: impl Fn(&SimulatedFlight) -> Vec<f64>) -> (f64, f64) {
    let flight = fly(plan, fs_hz, 3);
    let found = detect(&flight);
    let truth = truth(plan, fs_hz, flight.tt.len());
    assert_eq!(found.len(), truth.len(), "{found:#?}");
    for (m, t) in found.iter().zip(&truth) {
        assert_eq!((m.kind, m.heading_deg), (t.kind, t.heading), "{m:?}");
        let o = overlap((m.start, m.end), (t.start, t.end));
        assert!(o > 0.95, "overlap {o} of {m:?} with {}..{}", t.start, t.end);
    }
    let x = signal(&flight);
    let report = fom(&x, Some(&flight.tt), &found, fs_hz, &FomSettings::default()).unwrap();
    assert!(report.missing.is_empty());
    let filtered = bandpassed(&x, Some(&flight.tt), fs_hz, &FomSettings::default()).unwrap();
    let from_truth: f64 = truth
        .iter()
        .map(|t| peak_to_peak(&filtered[t.start..t.end]))
        .sum();
    (report.fom_nt, from_truth)
}

fn assert_within_5_percent((found, truth): (f64, f64)) {
    let rel = (found - truth).abs() / truth;
    eprintln!("FOM detected {found:.4} nT, truth windows {truth:.4} nT, rel {rel:.5}");
    assert!(rel < 0.05, "detected {found} vs truth {truth}");
}

#[test]
fn default_box_fom_matches_the_truth_windows() {
    let plan = BoxPlan::default().build();
    assert_within_5_percent(check_box(&plan, 10.0, |f| f.scalar.clone()));
    assert_within_5_percent(check_box(&plan, 10.0, |f| f.interference_nt.clone()));
}

#[test]
fn varied_box_at_160_hz_matches_the_truth_windows() {
    let plan = BoxPlan {
        roll_deg: 8.0,
        pitch_deg: 3.0,
        yaw_deg: 4.0,
        period_s: 4.5,
        cycles: 2,
        ..BoxPlan::default()
    }
    .build();
    assert_within_5_percent(check_box(&plan, 160.0, |f| f.scalar.clone()));
    let slow = BoxPlan {
        period_s: 8.0,
        cycles: 4,
        ..BoxPlan::default()
    }
    .build();
    assert_within_5_percent(check_box(&slow, 10.0, |f| f.interference_nt.clone()));
}

/// Light turbulence (0.6° peaks per axis, 0.07–0.4 Hz) instead of every straight leg.
fn turbulent(plan: &Plan) -> Plan {
    let waves = |phase: f64| {
        [(0.3, 0.07), (0.2, 0.23), (0.1, 0.4)]
            .map(|(amplitude_deg, frequency_hz)| Wave {
                amplitude_deg,
                frequency_hz,
                phase_rad: phase * frequency_hz * 10.0,
            })
            .to_vec()
    };
    let segments = plan
        .segments()
        .iter()
        .enumerate()
        .map(|(k, s)| match s.motion {
            Motion::Straight => Segment {
                motion: Motion::Turbulent {
                    roll: waves(k as f64),
                    pitch: waves(k as f64 + 1.0),
                    yaw: waves(k as f64 + 2.0),
                },
                ..s.clone()
            },
            _ => s.clone(),
        })
        .collect();
    Plan::new(segments)
}

/// Deterministic white noise of standard deviation about `sigma`.
fn add_noise(x: &mut [f64], sigma: f64, seed: u64) {
    let mut state = seed;
    for v in x {
        state = state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        *v += sigma * 12f64.sqrt() * ((state >> 11) as f64 / (1u64 << 53) as f64 - 0.5);
    }
}

#[test]
fn turbulence_and_attitude_noise_change_neither_detection_nor_fom() {
    let plan = turbulent(&BoxPlan::default().build());
    let mut flight = fly(&plan, 10.0, 7);
    add_noise(&mut flight.roll_deg, 0.05, 1);
    add_noise(&mut flight.pitch_deg, 0.05, 2);
    add_noise(&mut flight.yaw_deg, 0.05, 3);
    let found = detect(&flight);
    let truth = truth(&plan, 10.0, flight.tt.len());
    assert_eq!(found.len(), 12, "{found:#?}");
    for (m, t) in found.iter().zip(&truth) {
        assert_eq!((m.kind, m.heading_deg), (t.kind, t.heading), "{m:?}");
        let o = overlap((m.start, m.end), (t.start, t.end));
        assert!(o > 0.9, "overlap {o} of {m:?} with {}..{}", t.start, t.end);
    }
    let report = fom(
        &flight.scalar,
        Some(&flight.tt),
        &found,
        10.0,
        &FomSettings::default(),
    )
    .unwrap();
    let filtered = bandpassed(
        &flight.scalar,
        Some(&flight.tt),
        10.0,
        &FomSettings::default(),
    )
    .unwrap();
    let from_truth: f64 = truth
        .iter()
        .map(|t| peak_to_peak(&filtered[t.start..t.end]))
        .sum();
    assert_within_5_percent((report.fom_nt, from_truth));
}

#[test]
fn quick_turns_short_legs_and_faint_slow_maneuvers_are_found_exactly() {
    // The bank of a 12 s turn ends 2 s before the roll starts: it must not join the roll.
    let tight = BoxPlan {
        turn_s: 12.0,
        straight_s: 2.0,
        ..BoxPlan::default()
    }
    .build();
    assert_within_5_percent(check_box(&tight, 10.0, |f| f.scalar.clone()));
    // Barely above the thresholds (3°, 1.5°, 1.5°), at the longest usual period.
    let faint = BoxPlan {
        roll_deg: 4.0,
        pitch_deg: 2.0,
        yaw_deg: 2.0,
        period_s: 10.0,
        cycles: 2,
        ..BoxPlan::default()
    }
    .build();
    assert_within_5_percent(check_box(&faint, 160.0, |f| f.interference_nt.clone()));
}

#[test]
fn a_box_without_yaws_reports_the_four_yaw_slots_missing() {
    let plan = BoxPlan {
        yaw_deg: 0.0,
        ..BoxPlan::default()
    }
    .build();
    let flight = fly(&plan, 10.0, 4);
    let found = detect(&flight);
    assert_eq!(found.len(), 8, "{found:#?}");
    assert!(found.iter().all(|m| m.kind != ManeuverKind::Yaw));
    let report = fom(
        &flight.scalar,
        Some(&flight.tt),
        &found,
        10.0,
        &FomSettings::default(),
    )
    .unwrap();
    let yaws: Vec<Slot> = [0, 90, 180, 270]
        .map(|h| Slot {
            heading_deg: h,
            kind: ManeuverKind::Yaw,
        })
        .to_vec();
    assert_eq!(report.missing, yaws);
}

#[test]
fn a_survey_has_no_maneuvers() {
    for seed in 1..4 {
        let plan = SurveyPlan {
            seed,
            ..SurveyPlan::default()
        }
        .build();
        let found = detect(&fly(&plan, 10.0, seed));
        assert!(found.is_empty(), "{found:#?}");
    }
}

fn box_of(period_s: f64, cycles: u32, first_heading: f64) -> Plan {
    BoxPlan {
        headings_deg: (0..4).map(|k| first_heading + 90.0 * k as f64).collect(),
        period_s,
        cycles,
        ..BoxPlan::default()
    }
    .build()
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(12))]

    /// Adding whole turns to the yaw, or wrapping it into (−180, 180], finds the same maneuvers.
    #[test]
    fn detection_ignores_how_yaw_is_wrapped(
        period_s in 4.0f64..8.0,
        cycles in 2u32..4,
        first in -20.0f64..20.0,
        turns in -2i32..3,
    ) {
        let flight = fly(&box_of(period_s, cycles, first), 10.0, 5);
        let reference = detect(&flight);
        prop_assert_eq!(reference.len(), 12);
        let shifted: Vec<f64> = flight.yaw_deg.iter().map(|y| y + 360.0 * turns as f64).collect();
        let signed: Vec<f64> = flight.yaw_deg.iter().map(|y| if *y > 180.0 { y - 360.0 } else { *y }).collect();
        for yaw in [shifted, signed] {
            let other = detect_maneuvers(&flight.tt, &flight.roll_deg, &flight.pitch_deg, &yaw, &ManeuverSettings::default());
            prop_assert_eq!(other.len(), reference.len());
            for (a, b) in other.iter().zip(&reference) {
                prop_assert_eq!((a.kind, a.heading_deg, a.start, a.end), (b.kind, b.heading_deg, b.start, b.end));
            }
        }
    }

    /// The same box at 10 Hz and 20 Hz gives the same maneuvers at the same times.
    #[test]
    fn detection_does_not_depend_on_the_sample_rate(
        period_s in 4.0f64..8.0,
        cycles in 2u32..4,
    ) {
        let plan = box_of(period_s, cycles, 0.0);
        let slow = detect(&fly(&plan, 10.0, 6));
        let fast = detect(&fly(&plan, 20.0, 6));
        prop_assert_eq!(slow.len(), 12);
        prop_assert_eq!(fast.len(), 12);
        for (a, b) in slow.iter().zip(&fast) {
            prop_assert_eq!((a.kind, a.heading_deg), (b.kind, b.heading_deg));
            prop_assert!((a.start_tt - b.start_tt).abs() <= 0.15, "{} vs {}", a.start_tt, b.start_tt);
            prop_assert!((a.end_tt - b.end_tt).abs() <= 0.15, "{} vs {}", a.end_tt, b.end_tt);
            prop_assert!((a.period_s - b.period_s).abs() < 0.1);
        }
    }
}
