//! Finding the Tolles patent's maneuvers in a flight's attitude: rolls and pitches, wing-ups
//! and cloverleaf turns, as windows the [`crate::patent::procedure`] reads.
//!
//! ```
//! use tolles_core::patent::detect::detect_patent_maneuvers;
//! use tolles_core::patent::procedure::ManeuverKind;
//!
//! // 60 s at 10 Hz: level, then a 40° bank held for 20 s on a steady heading of 090°.
//! let tt: Vec<f64> = (0..600).map(|k| k as f64 / 10.0).collect();
//! let roll: Vec<f64> = tt.iter().map(|&t| if (20.0..40.0).contains(&t) { 40.0 } else { 0.0 }).collect();
//! let level = vec![0.0; tt.len()];
//! let yaw = vec![90.0; tt.len()];
//! let found = detect_patent_maneuvers(&tt, &roll, &level, &yaw, 0.0);
//! assert_eq!(found.len(), 1);
//! assert_eq!(found[0].kind, ManeuverKind::WingUp);
//! assert_eq!(found[0].label(), "wing-up on 090°");
//! ```

use crate::maneuvers::detect::{detect_harmonic_maneuvers, unwrap_deg, ManeuverSettings};
use crate::patent::procedure::{ManeuverKind, ManeuverWindow};
use crate::signal::segment::{contiguous_runs, median_step};
use std::ops::Range;

/// Oscillations of the roll smaller than this (degrees) are not maneuvers.
pub const OSCILLATION_DEG: f64 = 3.0;
/// A bank held beyond this (degrees) …
pub const WING_UP_DEG: f64 = 25.0;
/// … for longer than this (s) is a wing-up.
pub const WING_UP_S: f64 = 5.0;
/// A heading that wanders less than this (degrees) is stable.
pub const STABLE_HEADING_DEG: f64 = 10.0;
/// A banked run that turns through this much or more (degrees) is a cloverleaf turn.
pub const CLOVERLEAF_TURN_DEG: f64 = 180.0;

/// The patent's maneuvers in the attitude channels, in time order:
/// - wing-ups: |roll| beyond [`WING_UP_DEG`] for more than [`WING_UP_S`] on a stable heading
///   (the window runs from the start of the roll-in to the end of the roll-out);
/// - cloverleaf turns: banked turns through [`CLOVERLEAF_TURN_DEG`] or more;
/// - rolls and pitches: the harmonic maneuvers of [`crate::maneuvers::detect`] (the FOM's detector),
///   outside the banked runs.
///
/// `tt` in s; `roll`, `pitch`, `yaw` in degrees (yaw clockwise from true north); headings are
/// made magnetic by subtracting `declination_deg` (degrees east).
pub fn detect_patent_maneuvers(
    tt: &[f64],
    roll: &[f64],
    pitch: &[f64],
    yaw: &[f64],
    declination_deg: f64,
) -> Vec<ManeuverWindow> {
    let fs_hz = median_step(tt).map_or(1.0, |dt| 1.0 / dt);
    let heading = unwrap_deg(yaw);
    let (mut windows, banked) = banked_windows(roll, &heading, declination_deg, fs_hz);
    windows.extend(harmonic_windows(
        tt,
        roll,
        pitch,
        yaw,
        declination_deg,
        &banked,
    ));
    windows.sort_by_key(|w| w.range.start);
    windows
}

/// Wing-ups and cloverleaf turns among the runs banked beyond [`OSCILLATION_DEG`], and which
/// samples any banked run covers (other turns are no maneuver, but no roll either).
/// `heading` is the unwrapped yaw (degrees, true).
fn banked_windows(
    roll: &[f64],
    heading: &[f64],
    declination_deg: f64,
    fs_hz: f64,
) -> (Vec<ManeuverWindow>, Vec<bool>) {
    let n = roll.len();
    let mut banked = vec![false; n];
    let mut windows = Vec::new();
    for run in runs_within(&(0..n), |k| roll[k].abs() > OSCILLATION_DEG) {
        let turned = spread(&heading[run.clone()]);
        let held_s = runs_within(&run, |k| roll[k].abs() > WING_UP_DEG)
            .into_iter()
            .map(|r| r.len() as f64 / fs_hz)
            .fold(0.0, f64::max);
        let kind = if turned >= CLOVERLEAF_TURN_DEG {
            Some(ManeuverKind::Cloverleaf)
        } else if held_s > WING_UP_S && turned < STABLE_HEADING_DEG {
            Some(ManeuverKind::WingUp)
        } else if turned >= STABLE_HEADING_DEG {
            None
        } else {
            // A small bank on a steady heading: left to the roll detector.
            continue;
        };
        let range = out_to_level(roll, run.clone());
        banked[range.clone()].iter_mut().for_each(|b| *b = true);
        windows.extend(kind.map(|kind| ManeuverWindow {
            kind,
            heading_deg: heading[(run.start + run.end) / 2] - declination_deg,
            range,
        }));
    }
    (windows, banked)
}

/// `run` widened to where the bank returns to zero: the roll-in and roll-out belong to it.
fn out_to_level(roll: &[f64], run: Range<usize>) -> Range<usize> {
    let sign = roll[run.start].signum();
    let same = |k: usize| roll[k].signum() == sign && roll[k] != 0.0;
    let mut range = run;
    while range.start > 0 && same(range.start - 1) {
        range.start -= 1;
    }
    while range.end < roll.len() && same(range.end) {
        range.end += 1;
    }
    range
}

/// Rolls and pitches from the shared harmonic detector (the one the FOM uses), except those
/// overlapping a `banked` sample; yaws are no maneuver of the patent.
fn harmonic_windows(
    tt: &[f64],
    roll: &[f64],
    pitch: &[f64],
    yaw: &[f64],
    declination_deg: f64,
    banked: &[bool],
) -> Vec<ManeuverWindow> {
    let settings = ManeuverSettings::default();
    detect_harmonic_maneuvers(tt, roll, pitch, yaw, &settings)
        .into_iter()
        .filter_map(|m| {
            let kind = match m.kind {
                crate::maneuvers::ManeuverKind::Roll => ManeuverKind::Roll,
                crate::maneuvers::ManeuverKind::Pitch => ManeuverKind::Pitch,
                crate::maneuvers::ManeuverKind::Yaw => return None,
            };
            if banked[m.range()].iter().any(|b| *b) {
                return None;
            }
            Some(ManeuverWindow {
                kind,
                heading_deg: m.heading_deg_measured - declination_deg,
                range: m.range(),
            })
        })
        .collect()
}

/// Largest minus smallest finite value (−∞ when there is none).
fn spread(x: &[f64]) -> f64 {
    let finite = || x.iter().copied().filter(|v| v.is_finite());
    finite().fold(f64::NEG_INFINITY, f64::max) - finite().fold(f64::INFINITY, f64::min)
}

/// Maximal runs of consecutive indices in `range` where `test` holds.
fn runs_within(range: &Range<usize>, test: impl Fn(usize) -> bool) -> Vec<Range<usize>> {
    let holds: Vec<bool> = range.clone().map(test).collect();
    contiguous_runs(&holds, None)
        .into_iter()
        .map(|r| r.start + range.start..r.end + range.start)
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::flight::plan::PatentPlan;
    use crate::flight::sim::{simulate, Scenario};
    use crate::model::interpret::AircraftField;
    use crate::patent::procedure::windows_from_plan;

    fn labels(windows: &[&ManeuverWindow]) -> Vec<String> {
        windows.iter().map(|w| w.label()).collect()
    }

    #[test]
    fn the_detector_finds_the_patent_plans_maneuvers() {
        let plan = PatentPlan::default().build();
        let scenario = Scenario::new(AircraftField::default(), 1);
        let flight = simulate(&plan, &scenario).unwrap();
        let (roll, pitch, yaw) = (&flight.roll_deg, &flight.pitch_deg, &flight.yaw_deg);
        let found = detect_patent_maneuvers(&flight.tt, roll, pitch, yaw, -3.0);
        let planned = windows_from_plan(&plan, scenario.fs_hz, -3.0);
        let not_clover = |w: &&ManeuverWindow| w.kind != ManeuverKind::Cloverleaf;
        let found_maneuvers: Vec<&ManeuverWindow> = found.iter().filter(not_clover).collect();
        let planned: Vec<&ManeuverWindow> = planned.iter().filter(not_clover).collect();
        assert_eq!(labels(&found_maneuvers), labels(&planned));
        // Each found window lies within a sample or two of the planned one.
        for (f, p) in found_maneuvers.iter().zip(&planned) {
            assert!(f.range.start.abs_diff(p.range.start) <= 2, "{f:?} {p:?}");
            assert!(f.range.end.abs_diff(p.range.end) <= 2, "{f:?} {p:?}");
        }
        // The four cloverleaf turns.
        let clover = found.len() - found_maneuvers.len();
        assert_eq!(clover, 4);
    }

    #[test]
    fn a_wing_up_runs_from_roll_in_to_roll_out() {
        // Level, a ramp to −40° and back over 2 s each, held 10 s, on heading 270°.
        let tt: Vec<f64> = (0..400).map(|k| k as f64 / 10.0).collect();
        let roll: Vec<f64> = tt
            .iter()
            .map(|&t| -40.0 * ((t - 10.0).min(24.0 - t) / 2.0).clamp(0.0, 1.0))
            .collect();
        let zero = vec![0.0; tt.len()];
        let yaw = vec![270.0; tt.len()];
        let found = detect_patent_maneuvers(&tt, &roll, &zero, &yaw, 0.0);
        assert_eq!(
            labels(&found.iter().collect::<Vec<_>>()),
            ["wing-up on 270°"]
        );
        // From the first sample off level (t = 10.1 s) to the last (t = 23.9 s).
        assert_eq!(found[0].range, 101..240);
    }

    #[test]
    fn a_banked_turn_short_of_180_degrees_is_no_maneuver() {
        let tt: Vec<f64> = (0..600).map(|k| k as f64 / 10.0).collect();
        let turning = |t: f64| (10.0..40.0).contains(&t);
        let roll: Vec<f64> = tt
            .iter()
            .map(|&t| if turning(t) { 30.0 } else { 0.0 })
            .collect();
        // 3°/s for 30 s: a 90° turn.
        let yaw: Vec<f64> = tt
            .iter()
            .map(|&t| 3.0 * (t.clamp(10.0, 40.0) - 10.0))
            .collect();
        let zero = vec![0.0; tt.len()];
        assert!(detect_patent_maneuvers(&tt, &roll, &zero, &yaw, 0.0).is_empty());
    }

    #[test]
    fn runs_are_offset_into_their_range() {
        let x = [0, 1, 1, 0, 1, 1, 1];
        assert_eq!(runs_within(&(2..7), |k| x[k] == 1), vec![2..3, 4..7]);
        assert_eq!(spread(&[1.0, f64::NAN, -2.0]), 3.0);
    }
}
