//! The computed patent tables against the simulator: a harmonic maneuver flown by an aircraft
//! with a single term gives a magnetometer signal whose demodulated amplitudes are the table's
//! value times the term.

use std::f64::consts::PI;
use tolles_core::flight::environment::Environment;
use tolles_core::flight::plan::{Axis, Motion, Plan, Segment};
use tolles_core::flight::sim::{simulate, EarthField, Scenario};
use tolles_core::model::interpret::AircraftField;
use tolles_core::patent::harmonics::{HarmonicManeuver, HarmonicTable};
use tolles_core::patent::{Maneuver, Section, Term};

const PERIOD_S: f64 = 8.0;
const CYCLES: f64 = 3.0;

/// `(sin ωt, cos ωt, sin 2ωt, cos 2ωt)` amplitudes (nT) of what the aircraft adds to the scalar
/// during the maneuver, flown on a magnetic heading.
fn demodulated(aircraft: AircraftField, maneuver: &HarmonicManeuver) -> (f64, f64, f64, f64, f64) {
    let mut scenario = Scenario::new(aircraft, 1);
    scenario.sensors.scalar_noise_nt = 0.0;
    let axis: Axis = maneuver.maneuver.into();
    let earth = EarthField {
        inclination_deg: maneuver.dip_deg,
        ..EarthField::default()
    };
    scenario.environment = Environment::uniform(earth);
    let plan = Plan::new(vec![Segment {
        line: 1.0,
        // The plan's heading is from true north; the table's from magnetic north.
        heading_deg: maneuver.heading_deg + earth.declination_deg,
        duration_s: PERIOD_S * CYCLES,
        motion: Motion::Harmonic {
            axis,
            amplitude_deg: maneuver.amplitude_deg,
            period_s: PERIOD_S,
        },
    }]);
    let flight = simulate(&plan, &scenario).unwrap();
    // Whole cycles only: drop the sample at the very end.
    let n = (PERIOD_S * CYCLES * scenario.fs_hz).round() as usize;
    let w = 2.0 * PI / PERIOD_S;
    let project = |f: &dyn Fn(f64) -> f64| {
        (0..n)
            .map(|k| (flight.scalar[k] - flight.earth_nt[k]) * f(flight.tt[k]))
            .sum::<f64>()
            * 2.0
            / n as f64
    };
    (
        project(&|t| (w * t).sin()),
        project(&|t| (w * t).cos()),
        project(&|t| (2.0 * w * t).sin()),
        project(&|t| (2.0 * w * t).cos()),
        earth.intensity_nt,
    )
}

/// Flies `maneuver` with `aircraft` (which has only `term`) and compares with the table.
fn assert_table_predicts_the_signal(
    term: Term,
    aircraft: AircraftField,
    maneuver: HarmonicManeuver,
) {
    let table = HarmonicTable::compute(&maneuver).unwrap();
    let row = table.row(term).unwrap();
    let (sin1, cos1, sin2, cos2, h) = demodulated(aircraft, &maneuver);
    let w = 2.0 * PI / PERIOD_S;
    let value = term.value(&aircraft);
    // Perm and induced: sin ωt and cos 2ωt; eddy: ω cos ωt and ω sin 2ωt.
    let (expected, found, absent) = match row.section {
        Section::Perm | Section::Induced => {
            let scale = term.scale(h) * value;
            (
                [scale * row.fundamental, scale * row.second_harmonic],
                [sin1, cos2],
                [cos1, sin2],
            )
        }
        Section::Eddy => {
            let scale = term.scale(h) * value * w;
            (
                [scale * row.fundamental, scale * row.second_harmonic],
                [cos1, sin2],
                [sin1, cos2],
            )
        }
    };
    let size = expected[0].abs().max(expected[1].abs());
    assert!(
        size > 0.5,
        "{}: a test signal of {size} nT is too weak",
        row.name
    );
    // Tolerance: |H|²/(2|B|) from the magnitude's nonlinearity, far below the signal.
    let tol = 1e-3 * size + 1e-3;
    for (e, f) in expected.iter().zip(found) {
        assert!(
            (e - f).abs() < tol,
            "{}: expected {e} nT, demodulated {f} nT",
            row.name
        );
    }
    for a in absent {
        assert!(a.abs() < tol, "{}: {a} nT in the wrong phase", row.name);
    }
}

#[test]
fn perm_t_in_a_roll() {
    let mut aircraft = AircraftField::default();
    aircraft.permanent_nt[1] = 10.0; // T = y
    let maneuver = HarmonicManeuver::new(Maneuver::Roll, 15.0, 0.0, 60.0);
    assert_table_predicts_the_signal(Term::PermT, aircraft, maneuver);
}

#[test]
fn induced_tv_vt_in_a_roll() {
    let mut aircraft = AircraftField::default();
    aircraft.induced[1][2] = 2e-4; // one half of TV+VT
    let maneuver = HarmonicManeuver::new(Maneuver::Roll, 12.0, 30.0, 70.0);
    assert_table_predicts_the_signal(Term::InducedTVVT, aircraft, maneuver);
}

#[test]
fn eddy_tv_in_a_roll() {
    let mut aircraft = AircraftField::default();
    aircraft.eddy_s[2][1] = 5e-4; // tv = E[z][y]: field along V from a change along T
    let maneuver = HarmonicManeuver::new(Maneuver::Roll, 10.0, 45.0, 65.0);
    assert_table_predicts_the_signal(Term::EddyTV, aircraft, maneuver);
}

#[test]
fn perm_l_in_a_pitch() {
    let mut aircraft = AircraftField::default();
    aircraft.permanent_nt[0] = 10.0; // L = x
    let maneuver = HarmonicManeuver::new(Maneuver::Pitch, 10.0, 120.0, 60.0);
    assert_table_predicts_the_signal(Term::PermL, aircraft, maneuver);
}

#[test]
fn eddy_lt_in_a_pitch() {
    // The row the patent prints as 'tl' under "Pitches".
    let mut aircraft = AircraftField::default();
    aircraft.eddy_s[1][0] = 5e-4; // lt = E[y][x]: field along T from a change along L
    let maneuver = HarmonicManeuver::new(Maneuver::Pitch, 10.0, 60.0, 45.0);
    assert_table_predicts_the_signal(Term::EddyLT, aircraft, maneuver);
}

#[test]
fn induced_vv_minus_ll_in_a_pitch() {
    let mut aircraft = AircraftField::default();
    aircraft.induced[2][2] = 3e-4;
    let maneuver = HarmonicManeuver::new(Maneuver::Pitch, 8.0, 200.0, 55.0);
    // VV alone: VV−LL and VV are the same in a pitch up to a constant.
    assert_table_predicts_the_signal(Term::InducedVV, aircraft, maneuver);
    assert_table_predicts_the_signal(Term::InducedVVLL, aircraft, maneuver);
}
