//! The surveyors' heading error: how much the scalar's level depends on the heading flown.
//!
//! ```
//! use tolles_core::flight::plan::BoxPlan;
//! use tolles_core::flight::sim::{simulate, Installation, Scenario};
//! use tolles_core::maneuvers::detect::{detect_maneuvers, ManeuverSettings};
//! use tolles_core::maneuvers::heading::{heading_levels, HeadingSettings};
//!
//! let flight = simulate(
//!     &BoxPlan::default().build(),
//!     &Scenario::new(Installation::Cabin.aircraft(), 1),
//! )
//! .unwrap();
//! let (tt, roll, pitch, yaw) = (&flight.tt, &flight.roll_deg, &flight.pitch_deg, &flight.yaw_deg);
//! let maneuvers = detect_maneuvers(tt, roll, pitch, yaw, &ManeuverSettings::default());
//! let levels = heading_levels(
//!     tt, roll, pitch, yaw, &flight.scalar, &maneuvers, &HeadingSettings::default(),
//! )
//! .unwrap();
//! assert_eq!(levels.levels.len(), 4); // N, E, S, W
//! assert!(levels.heading_error_nt.unwrap() > 10.0); // an uncompensated cabin installation
//! ```
//!
//! Definition. On a compensation box the aircraft flies straight and level legs on (usually) the
//! four cardinal headings. A sample is *straight and level on heading h* when
//! - it lies in no detected maneuver, nor within [`HeadingSettings::maneuver_margin_s`] of one
//!   (the eddy-current and pilot transients around a maneuver are not level flight);
//! - |roll| ≤ [`HeadingSettings::max_roll_deg`] (3°) and |pitch| ≤
//!   [`HeadingSettings::max_pitch_deg`] (3°);
//! - the yaw is within [`HeadingSettings::heading_tolerance_deg`] (10°) of h and steady: its rate
//!   (central difference) is at most [`HeadingSettings::max_yaw_rate_deg_s`] (1°/s, a third of a
//!   standard-rate turn);
//! - time, attitude and scalar are all finite.
//!
//! The *level* of a heading is the mean of the scalar (nT) over those samples. A heading with
//! less than [`HeadingSettings::min_duration_s`] (3 s) of them (samples × median time step) is
//! skipped and listed. The *heading error* is the largest level minus the smallest (nT); its
//! uncertainty combines the standard errors of those two levels in quadrature.
//!
//! A level's standard error is the samples' standard deviation over √n_eff, where
//! n_eff = n / τ and τ (samples, at least 1) is the integrated autocorrelation time of the
//! scalar about the level: 1 + 2 Σ ρ(lag), summed over lags until ρ first falls to zero or
//! below (or at [`MAX_LAG_SAMPLES`]), with ρ computed over pairs of samples within the same
//! straight run. White noise gives τ ≈ 1; a slow drift along the leg, or runs of the same
//! heading at different levels, raise τ and so the error. A box usually has one leg per heading, so a spread of per-leg means would
//! not be available.
//!
//! What the heading error contains besides the aircraft: the legs are flown at different places
//! and times, so geology under each leg and diurnal variation between them stay in the level
//! differences, uncompensated and compensated alike. Compensation can remove only the aircraft's
//! part; the compensated heading error is an upper bound on what the aircraft still adds.
//!
//! To compare a signal before and after compensation on the same samples, select once with
//! [`select_straight`], [`StraightSelection::require_finite`] each signal, then call
//! [`StraightSelection::levels`] for each.

use crate::maneuvers::detect::{Maneuver, CARDINAL_HEADINGS_DEG};
use crate::signal::segment::{contiguous_runs, median_step};
use serde::{Deserialize, Serialize};
use std::ops::Range;
use thiserror::Error;

/// What counts as straight and level flight on a heading. Angles in degrees, times in seconds.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct HeadingSettings {
    /// The nominal headings looked for (degrees clockwise from north, the yaw's reference).
    pub headings_deg: Vec<f64>,
    /// Largest difference between yaw and a nominal heading (degrees).
    pub heading_tolerance_deg: f64,
    /// Largest |roll| (degrees).
    pub max_roll_deg: f64,
    /// Largest |pitch| (degrees).
    pub max_pitch_deg: f64,
    /// Largest |yaw rate| (degrees per second).
    pub max_yaw_rate_deg_s: f64,
    /// Samples this close to a detected maneuver are left out (s).
    pub maneuver_margin_s: f64,
    /// A heading with less straight flight than this is skipped (s).
    pub min_duration_s: f64,
}

impl Default for HeadingSettings {
    /// The cardinal headings; within 10°; roll and pitch within 3°; yaw rate at most 1°/s;
    /// 2 s clear of maneuvers; at least 3 s per heading.
    fn default() -> Self {
        Self {
            headings_deg: CARDINAL_HEADINGS_DEG.to_vec(),
            heading_tolerance_deg: 10.0,
            max_roll_deg: 3.0,
            max_pitch_deg: 3.0,
            max_yaw_rate_deg_s: 1.0,
            maneuver_margin_s: 2.0,
            min_duration_s: 3.0,
        }
    }
}

/// The level of the scalar on one heading.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct HeadingLevel {
    /// Nominal heading (degrees).
    pub heading_deg: f64,
    /// Circular mean of the yaw over the samples used (degrees, [0, 360)).
    pub heading_deg_measured: f64,
    /// Mean of the scalar over the straight-and-level samples (nT).
    pub level_nt: f64,
    /// Standard deviation of those samples (nT).
    pub std_nt: f64,
    /// Standard error of the level (nT): `std_nt / √effective_samples`.
    pub std_error_nt: f64,
    /// Number of samples used.
    pub samples: usize,
    /// Samples over the integrated autocorrelation time (at least 1).
    pub effective_samples: f64,
    /// Number of separate straight runs the samples come from.
    pub runs: usize,
    /// Time of the first sample used (s).
    pub start_tt: f64,
    /// Time of the last sample used (s).
    pub end_tt: f64,
}

/// A nominal heading with too little straight-and-level flight to give a level.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SkippedHeading {
    /// Nominal heading (degrees).
    pub heading_deg: f64,
    /// Straight-and-level samples found.
    pub samples: usize,
    /// Their duration, samples × median time step (s).
    pub duration_s: f64,
}

/// The heading levels of one signal and its heading error.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct HeadingLevels {
    /// One per nominal heading with enough straight flight, in the settings' order.
    pub levels: Vec<HeadingLevel>,
    /// The nominal headings skipped, in the settings' order.
    pub skipped: Vec<SkippedHeading>,
    /// Largest level minus smallest (nT); `None` with fewer than two levels.
    pub heading_error_nt: Option<f64>,
    /// Standard errors of the highest and lowest levels combined in quadrature (nT).
    pub uncertainty_nt: Option<f64>,
}

impl HeadingLevels {
    /// The levels with the highest and lowest level, in that order, given two or more.
    pub fn extremes(&self) -> Option<(&HeadingLevel, &HeadingLevel)> {
        if self.levels.len() < 2 {
            return None;
        }
        let by_level = |a: &&HeadingLevel, b: &&HeadingLevel| a.level_nt.total_cmp(&b.level_nt);
        let high = self.levels.iter().max_by(by_level)?;
        let low = self.levels.iter().min_by(by_level)?;
        Some((high, low))
    }
}

/// Why heading levels could not be computed.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum HeadingError {
    /// The input series differ in length.
    #[error("heading levels: {what} has {len} samples, the time column {expected}")]
    Length {
        /// The input that differs.
        what: &'static str,
        /// Its length (samples).
        len: usize,
        /// Length of the time column (samples).
        expected: usize,
    },
    /// A setting is not finite, or (all but the headings) negative.
    #[error(
        "heading levels: setting {name} must be finite (and ≥ 0 unless a heading), got {value}"
    )]
    Setting {
        /// The setting's name.
        name: &'static str,
        /// The value given (in the setting's unit).
        value: f64,
    },
    /// A maneuver's window lies outside the series.
    #[error("maneuver at samples {start}..{end} is outside the {len} samples of the flight")]
    OutOfRange {
        /// First sample of the window (0-based).
        start: usize,
        /// One past the last sample of the window (0-based, exclusive).
        end: usize,
        /// Length of the flight (samples).
        len: usize,
    },
}

/// The straight-and-level samples of each nominal heading; signals are measured on it.
#[derive(Debug, Clone, PartialEq)]
pub struct StraightSelection {
    tt: Vec<f64>,
    yaw_deg: Vec<f64>,
    /// Per nominal heading, its sample indices in increasing order.
    samples: Vec<(f64, Vec<usize>)>,
    step_s: f64,
    min_duration_s: f64,
}

/// The heading levels of `scalar_nt` (nT) on the straight-and-level legs of a flight: `tt` (s),
/// `roll_deg`, `pitch_deg`, `yaw_deg` (degrees), `maneuvers` as found by
/// [`detect_maneuvers`](crate::maneuvers::detect::detect_maneuvers). See the module's
/// definition.
pub fn heading_levels(
    tt: &[f64],
    roll_deg: &[f64],
    pitch_deg: &[f64],
    yaw_deg: &[f64],
    scalar_nt: &[f64],
    maneuvers: &[Maneuver],
    settings: &HeadingSettings,
) -> Result<HeadingLevels, HeadingError> {
    let mut selection = select_straight(tt, roll_deg, pitch_deg, yaw_deg, maneuvers, settings)?;
    selection.require_finite(scalar_nt)?;
    selection.levels(scalar_nt)
}

/// The straight-and-level samples of each of the settings' headings (module definition), before
/// any signal is looked at. Inputs as for [`heading_levels`].
pub fn select_straight(
    tt: &[f64],
    roll_deg: &[f64],
    pitch_deg: &[f64],
    yaw_deg: &[f64],
    maneuvers: &[Maneuver],
    settings: &HeadingSettings,
) -> Result<StraightSelection, HeadingError> {
    check_settings(settings)?;
    let n = tt.len();
    for (what, x) in [("roll", roll_deg), ("pitch", pitch_deg), ("yaw", yaw_deg)] {
        check_len(what, x.len(), n)?;
    }
    let step_s = median_step(tt).unwrap_or(f64::NAN);
    let clear = clear_of_maneuvers(tt, maneuvers, settings.maneuver_margin_s)?;
    let rate = yaw_rate_deg_s(tt, yaw_deg);
    let level: Vec<bool> = (0..n)
        .map(|k| {
            clear[k]
                && tt[k].is_finite()
                && roll_deg[k].abs() <= settings.max_roll_deg
                && pitch_deg[k].abs() <= settings.max_pitch_deg
                && rate[k].abs() <= settings.max_yaw_rate_deg_s
        })
        .collect();
    let samples = settings
        .headings_deg
        .iter()
        .map(|&h| {
            let on: Vec<usize> = (0..n)
                .filter(|&k| {
                    level[k] && angle_between(yaw_deg[k], h) <= settings.heading_tolerance_deg
                })
                .collect();
            (h, on)
        })
        .collect();
    Ok(StraightSelection {
        tt: tt.to_vec(),
        yaw_deg: yaw_deg.to_vec(),
        samples,
        step_s,
        min_duration_s: settings.min_duration_s,
    })
}

impl StraightSelection {
    /// Drops the samples where `signal` is not finite, so that every signal measured afterwards
    /// uses the same samples.
    pub fn require_finite(&mut self, signal: &[f64]) -> Result<(), HeadingError> {
        check_len("signal", signal.len(), self.tt.len())?;
        for (_, on) in &mut self.samples {
            on.retain(|&k| signal[k].is_finite());
        }
        Ok(())
    }

    /// Number of samples selected for each nominal heading `(heading_deg, samples)`.
    pub fn counts(&self) -> Vec<(f64, usize)> {
        self.samples.iter().map(|(h, on)| (*h, on.len())).collect()
    }

    /// The heading levels of `signal` (nT) over the selected samples (a sample where it is not
    /// finite is left out, which can make it differ from another signal's: call
    /// [`Self::require_finite`] first to prevent that).
    pub fn levels(&self, signal: &[f64]) -> Result<HeadingLevels, HeadingError> {
        check_len("signal", signal.len(), self.tt.len())?;
        let mut levels = Vec::new();
        let mut skipped = Vec::new();
        for (h, on) in &self.samples {
            let on: Vec<usize> = on
                .iter()
                .copied()
                .filter(|&k| signal[k].is_finite())
                .collect();
            let duration_s = on.len() as f64 * self.step_s;
            // A NaN step (fewer than two times) means no duration can be shown: skip.
            if on.is_empty() || duration_s.is_nan() || duration_s < self.min_duration_s {
                skipped.push(SkippedHeading {
                    heading_deg: *h,
                    samples: on.len(),
                    duration_s,
                });
            } else {
                levels.push(self.level(*h, &on, signal));
            }
        }
        Ok(summarise(levels, skipped))
    }

    fn level(&self, heading_deg: f64, on: &[usize], signal: &[f64]) -> HeadingLevel {
        let values: Vec<f64> = on.iter().map(|&k| signal[k]).collect();
        let n = values.len() as f64;
        let mean = values.iter().sum::<f64>() / n;
        let var = values.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1.0).max(1.0);
        let runs = self.runs_of(on);
        let tau = autocorrelation_time(&values, mean, &runs);
        let effective = (n / tau).max(1.0);
        HeadingLevel {
            heading_deg,
            heading_deg_measured: circular_mean_deg(on.iter().map(|&k| self.yaw_deg[k])),
            level_nt: mean,
            std_nt: var.sqrt(),
            std_error_nt: (var / effective).sqrt(),
            samples: on.len(),
            effective_samples: effective,
            runs: runs.len(),
            start_tt: self.tt[on[0]],
            end_tt: self.tt[on[on.len() - 1]],
        }
    }

    /// Runs of consecutive selected samples, as ranges into `on`; a skipped index or a time gap
    /// ends a run.
    fn runs_of(&self, on: &[usize]) -> Vec<Range<usize>> {
        let mut marks = vec![false; self.tt.len()];
        for &k in on {
            marks[k] = true;
        }
        // `on` is sorted, so a run of samples maps to a run of positions in `on`.
        let mut position = 0;
        contiguous_runs(&marks, Some(&self.tt))
            .into_iter()
            .map(|run| {
                let start = position;
                position += run.len();
                start..position
            })
            .collect()
    }
}

fn summarise(levels: Vec<HeadingLevel>, skipped: Vec<SkippedHeading>) -> HeadingLevels {
    let mut out = HeadingLevels {
        levels,
        skipped,
        heading_error_nt: None,
        uncertainty_nt: None,
    };
    if let Some((high, low)) = out.extremes() {
        let error = high.level_nt - low.level_nt;
        let uncertainty = high.std_error_nt.hypot(low.std_error_nt);
        out.heading_error_nt = Some(error);
        out.uncertainty_nt = Some(uncertainty);
    }
    out
}

fn check_len(what: &'static str, len: usize, expected: usize) -> Result<(), HeadingError> {
    if len == expected {
        Ok(())
    } else {
        Err(HeadingError::Length {
            what,
            len,
            expected,
        })
    }
}

fn check_settings(s: &HeadingSettings) -> Result<(), HeadingError> {
    let values = [
        ("heading_tolerance_deg", s.heading_tolerance_deg),
        ("max_roll_deg", s.max_roll_deg),
        ("max_pitch_deg", s.max_pitch_deg),
        ("max_yaw_rate_deg_s", s.max_yaw_rate_deg_s),
        ("maneuver_margin_s", s.maneuver_margin_s),
        ("min_duration_s", s.min_duration_s),
    ];
    if let Some((name, value)) = values
        .into_iter()
        .find(|(_, v)| !(v.is_finite() && *v >= 0.0))
    {
        return Err(HeadingError::Setting { name, value });
    }
    match s.headings_deg.iter().find(|h| !h.is_finite()) {
        Some(&value) => Err(HeadingError::Setting {
            name: "headings_deg",
            value,
        }),
        None => Ok(()),
    }
}

/// Per sample, true when no maneuver (widened by `margin_s` seconds each side) covers it.
fn clear_of_maneuvers(
    tt: &[f64],
    maneuvers: &[Maneuver],
    margin_s: f64,
) -> Result<Vec<bool>, HeadingError> {
    let n = tt.len();
    let mut clear = vec![true; n];
    for m in maneuvers {
        if m.start >= m.end || m.end > n {
            return Err(HeadingError::OutOfRange {
                start: m.start,
                end: m.end,
                len: n,
            });
        }
        let (from, to) = (tt[m.start] - margin_s, tt[m.end - 1] + margin_s);
        // Times are increasing in a flight, but a search that needs it would misplace the margin
        // on bad input; a scan cannot.
        for (k, c) in clear.iter_mut().enumerate() {
            if m.range().contains(&k) || (tt[k] >= from && tt[k] <= to) {
                *c = false;
            }
        }
    }
    Ok(clear)
}

/// Yaw rate (degrees per second) by central difference, wrapped across north; NaN at the ends of
/// the flight, where a non-finite value is involved, or where time does not advance.
fn yaw_rate_deg_s(tt: &[f64], yaw_deg: &[f64]) -> Vec<f64> {
    let n = tt.len();
    (0..n)
        .map(|k| {
            if k == 0 || k + 1 >= n {
                return f64::NAN;
            }
            let dt = tt[k + 1] - tt[k - 1];
            let dy = wrap_180(yaw_deg[k + 1] - yaw_deg[k - 1]);
            if dt > 0.0 {
                dy / dt
            } else {
                f64::NAN
            }
        })
        .collect()
}

/// `a` wrapped into [−180, 180) degrees; NaN stays NaN.
fn wrap_180(a: f64) -> f64 {
    (a + 180.0).rem_euclid(360.0) - 180.0
}

/// Absolute angular distance between two headings (degrees, [0, 180]); NaN if either is.
fn angle_between(a: f64, b: f64) -> f64 {
    wrap_180(a - b).abs()
}

/// Circular mean of headings (degrees, [0, 360)).
fn circular_mean_deg(headings: impl Iterator<Item = f64>) -> f64 {
    let (s, c) = headings.fold((0.0, 0.0), |(s, c), h| {
        let (sh, ch) = h.to_radians().sin_cos();
        (s + sh, c + ch)
    });
    f64::atan2(s, c).to_degrees().rem_euclid(360.0)
}

/// Lags summed into the autocorrelation time at most (samples): bounds the work on hours of
/// straight flight at a cost of underestimating correlations longer than this (410 s at 10 Hz).
pub const MAX_LAG_SAMPLES: usize = 4096;

/// Integrated autocorrelation time (samples, at least 1) of `values` about `mean`, pairs taken
/// only within each of `runs` (ranges into `values`): 1 + 2 Σ ρ(lag) up to the first lag whose
/// ρ is not positive, or [`MAX_LAG_SAMPLES`].
fn autocorrelation_time(values: &[f64], mean: f64, runs: &[Range<usize>]) -> f64 {
    let r: Vec<f64> = values.iter().map(|v| v - mean).collect();
    let c0 = r.iter().map(|v| v * v).sum::<f64>() / r.len() as f64;
    if c0 <= 0.0 || !c0.is_finite() {
        return 1.0;
    }
    let longest = runs.iter().map(|run| run.len()).max().unwrap_or(0);
    let mut tau = 1.0;
    for lag in 1..longest.min(MAX_LAG_SAMPLES + 1) {
        let (sum, pairs) =
            runs.iter()
                .filter(|run| run.len() > lag)
                .fold((0.0, 0usize), |(sum, pairs), run| {
                    let x = &r[run.clone()];
                    let s: f64 = x.iter().zip(&x[lag..]).map(|(a, b)| a * b).sum();
                    (sum + s, pairs + x.len() - lag)
                });
        let rho = sum / pairs as f64 / c0;
        if rho.is_nan() || rho <= 0.0 {
            break;
        }
        tau += 2.0 * rho;
    }
    tau.max(1.0)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::flight::plan::BoxPlan;
    use crate::flight::sim::{simulate, Installation, Scenario, SimulatedFlight};
    use crate::maneuvers::detect::{detect_maneuvers, ManeuverSettings};

    fn cabin_box(seed: u64) -> SimulatedFlight {
        simulate(
            &BoxPlan::default().build(),
            &Scenario::new(Installation::Cabin.aircraft(), seed),
        )
        .unwrap()
    }

    fn maneuvers(f: &SimulatedFlight) -> Vec<Maneuver> {
        detect_maneuvers(
            &f.tt,
            &f.roll_deg,
            &f.pitch_deg,
            &f.yaw_deg,
            &ManeuverSettings::default(),
        )
    }

    fn select(f: &SimulatedFlight, m: &[Maneuver]) -> StraightSelection {
        select_straight(
            &f.tt,
            &f.roll_deg,
            &f.pitch_deg,
            &f.yaw_deg,
            m,
            &HeadingSettings::default(),
        )
        .unwrap()
    }

    #[test]
    fn the_heading_error_of_a_cabin_box_matches_its_truth() {
        let f = cabin_box(3);
        let m = maneuvers(&f);
        let selection = select(&f, &m);
        let measured = selection.levels(&f.scalar).unwrap();
        // The aircraft's own field on the same samples, from the simulator's truth: the earth
        // field is uniform here, so it is all the heading error there is.
        let truth = selection.levels(&f.interference_nt).unwrap();
        assert_eq!(measured.levels.len(), 4, "{measured:?}");
        assert!(measured.skipped.is_empty());
        let (e, u) = (
            measured.heading_error_nt.unwrap(),
            measured.uncertainty_nt.unwrap(),
        );
        let expected = truth.heading_error_nt.unwrap();
        assert!(expected > 30.0, "a cabin's permanent field: {expected}");
        assert!(
            (e - expected).abs() < 5.0 * u + 1e-3,
            "{e} ± {u} vs {expected}"
        );
        assert!(u > 0.0 && u < 0.1, "{u}");
        for level in &measured.levels {
            assert!(level.samples as f64 * 0.1 > 20.0, "{level:?}");
            assert!(angle_between(level.heading_deg, level.heading_deg_measured) < 1.0);
            assert!(level.runs >= 1 && level.end_tt > level.start_tt);
        }
    }

    #[test]
    fn a_perfectly_compensated_signal_has_no_heading_error_beyond_noise() {
        let f = cabin_box(4);
        let m = maneuvers(&f);
        let clean: Vec<f64> = f
            .scalar
            .iter()
            .zip(&f.interference_nt)
            .map(|(s, i)| s - i)
            .collect();
        let r = select(&f, &m).levels(&clean).unwrap();
        let (e, u) = (r.heading_error_nt.unwrap(), r.uncertainty_nt.unwrap());
        assert!(e < 6.0 * u, "{e} ± {u}");
    }

    #[test]
    fn no_sample_inside_a_maneuver_or_its_margin_is_used() {
        let f = cabin_box(5);
        let m = maneuvers(&f);
        assert_eq!(m.len(), 12);
        let selection = select(&f, &m);
        for (_, on) in &selection.samples {
            for &k in on {
                for man in &m {
                    assert!(
                        f.tt[k] < man.start_tt - 2.0 || f.tt[k] > man.end_tt + 2.0,
                        "sample {k} near {man:?}"
                    );
                }
            }
        }
    }

    #[test]
    fn too_short_a_heading_is_skipped_and_listed() {
        let f = cabin_box(6);
        let m = maneuvers(&f);
        let settings = HeadingSettings {
            headings_deg: vec![0.0, 90.0, 45.0],
            ..HeadingSettings::default()
        };
        let r = heading_levels(
            &f.tt,
            &f.roll_deg,
            &f.pitch_deg,
            &f.yaw_deg,
            &f.scalar,
            &m,
            &settings,
        )
        .unwrap();
        assert_eq!(r.levels.len(), 2);
        assert_eq!(r.skipped.len(), 1);
        assert_eq!(r.skipped[0].heading_deg, 45.0);
        assert!(r.skipped[0].duration_s < 3.0);
    }

    #[test]
    fn one_heading_gives_no_heading_error() {
        let n = 100;
        let tt: Vec<f64> = (0..n).map(|k| k as f64 / 10.0).collect();
        let zero = vec![0.0; n];
        let yaw = vec![359.0; n];
        let scalar: Vec<f64> = (0..n).map(|k| 50_000.0 + (k % 2) as f64).collect();
        let r = heading_levels(
            &tt,
            &zero,
            &zero,
            &yaw,
            &scalar,
            &[],
            &HeadingSettings::default(),
        )
        .unwrap();
        assert_eq!(r.levels.len(), 1);
        assert!((r.levels[0].level_nt - 50_000.5).abs() < 1e-9);
        assert_eq!(r.levels[0].heading_deg, 0.0);
        assert!(r.levels[0].heading_deg_measured > 358.9);
        assert_eq!((r.heading_error_nt, r.uncertainty_nt), (None, None));
        assert_eq!(r.skipped.len(), 3);
    }

    #[test]
    fn a_slow_drift_raises_the_standard_error_above_the_white_noise_one() {
        let n = 600;
        let tt: Vec<f64> = (0..n).map(|k| k as f64 / 10.0).collect();
        let zero = vec![0.0; n];
        let white: Vec<f64> = (0..n)
            .map(|k| if k % 2 == 0 { 1.0 } else { -1.0 })
            .collect();
        let drift: Vec<f64> = (0..n)
            .map(|k| (k as f64 / 100.0).sin() + 0.1 * white[k])
            .collect();
        let level = |x: &[f64]| {
            heading_levels(
                &tt,
                &zero,
                &zero,
                &zero,
                x,
                &[],
                &HeadingSettings::default(),
            )
            .unwrap()
            .levels[0]
                .clone()
        };
        let (w, d) = (level(&white), level(&drift));
        // The first and last samples have no yaw rate, so are not known to be steady.
        assert_eq!(w.samples, n - 2);
        assert!(
            (w.effective_samples - w.samples as f64).abs() < 1e-9,
            "{w:?}"
        );
        assert!(d.effective_samples < 60.0, "{d:?}");
        assert!(d.std_error_nt > d.std_nt / 8.0, "{d:?}");
    }

    #[test]
    fn a_drift_longer_than_the_lag_limit_stops_there() {
        let n = 3 * MAX_LAG_SAMPLES;
        let tt: Vec<f64> = (0..n).map(|k| k as f64 / 10.0).collect();
        let zero = vec![0.0; n];
        let ramp: Vec<f64> = (0..n).map(|k| k as f64 * 1e-3).collect();
        let r = heading_levels(
            &tt,
            &zero,
            &zero,
            &zero,
            &ramp,
            &[],
            &HeadingSettings::default(),
        )
        .unwrap();
        let level = &r.levels[0];
        assert!(
            level.effective_samples >= 1.0 && level.std_error_nt.is_finite(),
            "{level:?}"
        );
        assert!(level.effective_samples < 10.0, "{level:?}");
    }

    #[test]
    fn bad_input_is_an_error_not_a_panic() {
        let tt = [0.0, 0.1, 0.2];
        let x = [0.0; 3];
        let s = HeadingSettings::default();
        assert!(matches!(
            heading_levels(&tt, &x, &x[..2], &x, &x, &[], &s),
            Err(HeadingError::Length { what: "pitch", .. })
        ));
        assert!(matches!(
            heading_levels(&tt, &x, &x, &x, &x[..1], &[], &s),
            Err(HeadingError::Length { .. })
        ));
        let bad = HeadingSettings {
            max_roll_deg: f64::NAN,
            ..HeadingSettings::default()
        };
        assert!(matches!(
            heading_levels(&tt, &x, &x, &x, &x, &[], &bad),
            Err(HeadingError::Setting { .. })
        ));
        let nan = [f64::NAN; 3];
        let r = heading_levels(&nan, &nan, &nan, &nan, &nan, &[], &s).unwrap();
        assert!(r.levels.is_empty() && r.heading_error_nt.is_none());
        let empty = heading_levels(&[], &[], &[], &[], &[], &[], &s).unwrap();
        assert_eq!(empty.skipped.len(), 4);
    }
}
