//! The figure of merit (FOM) of a compensation box.
//!
//! ```
//! use tolles_core::maneuvers::fom::{fom, FomSettings};
//! use tolles_core::maneuvers::detect::{detect_maneuvers, ManeuverSettings};
//! use tolles_core::flight::plan::BoxPlan;
//! use tolles_core::flight::sim::{simulate, Installation, Scenario};
//!
//! let flight = simulate(
//!     &BoxPlan::default().build(),
//!     &Scenario::new(Installation::Cabin.aircraft(), 1),
//! )
//! .unwrap();
//! let maneuvers = detect_maneuvers(
//!     &flight.tt,
//!     &flight.roll_deg,
//!     &flight.pitch_deg,
//!     &flight.yaw_deg,
//!     &ManeuverSettings::default(),
//! );
//! let report = fom(&flight.scalar, Some(&flight.tt), &maneuvers, 10.0, &FomSettings::default()).unwrap();
//! assert!(report.missing.is_empty());
//! assert!(report.fom_nt > 10.0); // an uncompensated cabin installation: far from the 1–2 nT goal
//! assert_eq!(report.band_hz, (0.05, 1.0));
//! ```
//!
//! The FOM is the sum, over the 12 maneuvers of a box (roll, pitch and yaw on headings 0, 90, 180
//! and 270 degrees), of the peak-to-peak of the band-passed magnetometer signal during each
//! maneuver. Choices made here:
//! - the whole signal is band-passed once (zero phase), then cut into maneuver windows, so a
//!   window's edges carry no filter start-up transient;
//! - the default band is 0.05–1 Hz: it passes the 4–20 s periods of maneuvers flown by hand and
//!   their harmonics, while removing slow changes (geology, diurnal variation, heading effects
//!   between legs); MagNav's fitting band 0.1–0.9 Hz would attenuate an 8 s maneuver;
//! - when a slot (heading, kind) was flown more than once, the repetition with the largest
//!   attitude amplitude counts, the others are reported but not summed. The choice depends on the
//!   attitude only, so compensated and uncompensated FOMs sum the same windows;
//! - maneuvers off the cardinal headings are reported and never summed;
//! - slots with no maneuver are listed in [`FomReport::missing`]; the FOM then sums fewer than 12.

use crate::maneuvers::detect::{Maneuver, ManeuverKind, CARDINAL_HEADINGS_DEG};
use crate::signal::filter::{Band, FilterError};
use crate::signal::metrics::{fourth_difference_noise_over, std_dev};
use crate::signal::segment::contiguous_runs;
use serde::{Deserialize, Serialize};
use thiserror::Error;

/// How to band-pass before taking peak-to-peaks.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FomSettings {
    /// Pass band (Hz).
    pub band: Band,
    /// Butterworth order per band edge (a band-pass has `2 * order` poles), applied forward and
    /// backward.
    pub order: usize,
}

impl Default for FomSettings {
    /// 0.05–1 Hz, order 4.
    fn default() -> Self {
        Self {
            band: Band {
                pass1_hz: 0.05,
                pass2_hz: 1.0,
            },
            order: 4,
        }
    }
}

/// One of the 12 maneuvers of a box.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub struct Slot {
    /// Cardinal heading (degrees): 0, 90, 180 or 270.
    pub heading_deg: u16,
    /// The axis.
    pub kind: ManeuverKind,
}

impl Slot {
    /// The 12 slots, heading by heading, roll, pitch, yaw on each.
    pub fn all() -> Vec<Slot> {
        CARDINAL_HEADINGS_DEG
            .iter()
            .flat_map(|&h| {
                ManeuverKind::ALL.map(|kind| Slot {
                    heading_deg: h as u16,
                    kind,
                })
            })
            .collect()
    }

    /// The slot of `maneuver`, if it is on a cardinal heading.
    pub fn of(maneuver: &Maneuver) -> Option<Slot> {
        maneuver.cardinal_heading_deg().map(|h| Slot {
            heading_deg: h as u16,
            kind: maneuver.kind,
        })
    }
}

/// A maneuver's contribution.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ManeuverFom {
    /// The maneuver.
    pub maneuver: Maneuver,
    /// Peak-to-peak of the band-passed signal over the maneuver (nT); over its finite samples.
    pub peak_to_peak_nt: f64,
    /// True when this maneuver is summed into the FOM.
    pub counted: bool,
    /// Samples of the window with no band-passed value (missing data, or in a run too short to
    /// filter).
    pub unfiltered_samples: usize,
}

/// The figure of merit and what it is made of.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FomReport {
    /// Pass band used (Hz), `(pass1, pass2)`: a pair rather than a [`Band`] so the JSON stays
    /// `[0.05, 1.0]`.
    pub band_hz: (f64, f64),
    /// Sum of the counted peak-to-peaks (nT); NaN when no maneuver was counted.
    pub fom_nt: f64,
    /// Every maneuver given, in time order.
    pub maneuvers: Vec<ManeuverFom>,
    /// Box slots with no maneuver.
    pub missing: Vec<Slot>,
    /// Standard deviation of the band-passed signal over the whole flight (nT).
    pub noise_level_nt: f64,
    /// Standard deviation of the fourth difference of the unfiltered signal (nT).
    pub fourth_difference_nt: f64,
}

impl FomReport {
    /// The maneuvers summed into the FOM.
    pub fn counted(&self) -> impl Iterator<Item = &ManeuverFom> {
        self.maneuvers.iter().filter(|m| m.counted)
    }
}

/// Why a FOM could not be computed.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum FomError {
    /// The band-pass could not be designed (edges outside (0, Nyquist), order 0, bad rate).
    #[error("FOM band-pass: {0}")]
    Filter(#[from] FilterError),
    /// A maneuver's window lies outside the signal.
    #[error("maneuver at samples {start}..{end} is outside the {len} samples of the signal")]
    OutOfRange {
        /// First sample of the window (0-based).
        start: usize,
        /// One past the last sample of the window (0-based, exclusive).
        end: usize,
        /// Length of the signal (samples).
        len: usize,
    },
}

/// The FOM of `signal_nt` (nT, sampled at `fs_hz` Hz) over `maneuvers` (sample windows into it).
///
/// `tt` (s), when given, marks time gaps: the band-pass never reaches across one.
pub fn fom(
    signal_nt: &[f64],
    tt: Option<&[f64]>,
    maneuvers: &[Maneuver],
    fs_hz: f64,
    settings: &FomSettings,
) -> Result<FomReport, FomError> {
    if let Some(m) = maneuvers
        .iter()
        .find(|m| m.end > signal_nt.len() || m.start >= m.end)
    {
        return Err(FomError::OutOfRange {
            start: m.start,
            end: m.end,
            len: signal_nt.len(),
        });
    }
    let filtered = bandpassed(signal_nt, tt, fs_hz, settings)?;
    let counted = counted_flags(maneuvers);
    let maneuvers: Vec<ManeuverFom> = maneuvers
        .iter()
        .zip(counted)
        .map(|(m, counted)| {
            let window = &filtered[m.range()];
            ManeuverFom {
                maneuver: m.clone(),
                peak_to_peak_nt: peak_to_peak(window),
                counted,
                unfiltered_samples: window.iter().filter(|v| !v.is_finite()).count(),
            }
        })
        .collect();
    let found: Vec<Slot> = maneuvers
        .iter()
        .filter(|m| m.counted)
        .filter_map(|m| Slot::of(&m.maneuver))
        .collect();
    Ok(FomReport {
        band_hz: settings.band.edges_hz(),
        fom_nt: match maneuvers.iter().any(|m| m.counted) {
            // No maneuver, no figure of merit: NaN, never a sum of nothing that reads as 0.
            false => f64::NAN,
            true => maneuvers
                .iter()
                .filter(|m| m.counted && m.peak_to_peak_nt.is_finite())
                // A fold from +0: an empty f64 sum is −0, which prints as "-0.000".
                .fold(0.0, |sum, m| sum + m.peak_to_peak_nt),
        },
        missing: Slot::all()
            .into_iter()
            .filter(|s| !found.contains(s))
            .collect(),
        maneuvers,
        noise_level_nt: std_dev(&filtered),
        fourth_difference_nt: fourth_difference_noise_over(
            signal_nt,
            &contiguous_runs(&vec![true; signal_nt.len()], tt),
        ),
    })
}

/// Uncompensated FOM over compensated FOM (dimensionless): how many times smaller the
/// maneuver noise became.
pub fn improvement_ratio(before: &FomReport, after: &FomReport) -> f64 {
    before.fom_nt / after.fom_nt
}

/// `signal_nt` (nT) band-passed with zero phase, run by run of finite samples (runs also end at
/// time gaps in `tt`, seconds); samples in runs too short to filter, and non-finite samples, are
/// NaN.
pub fn bandpassed(
    signal_nt: &[f64],
    tt: Option<&[f64]>,
    fs_hz: f64,
    settings: &FomSettings,
) -> Result<Vec<f64>, FomError> {
    // An edge at or beyond Nyquist is switched off, as for a fit (a 1 Hz survey is high-passed
    // at the lower edge): see `Band::butterworth`.
    let Some(filter) = settings.band.butterworth(settings.order, fs_hz)? else {
        return Ok(signal_nt.to_vec());
    };
    let usable: Vec<bool> = signal_nt.iter().map(|v| v.is_finite()).collect();
    let mut out = vec![f64::NAN; signal_nt.len()];
    for run in contiguous_runs(&usable, tt) {
        if let Ok(part) = filter.filtfilt(&signal_nt[run.clone()]) {
            out[run].copy_from_slice(&part);
        }
    }
    Ok(out)
}

/// Largest minus smallest finite value (units of `x`); NaN when there is none.
pub fn peak_to_peak(x: &[f64]) -> f64 {
    let (lo, hi) = x
        .iter()
        .filter(|v| v.is_finite())
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &v| {
            (lo.min(v), hi.max(v))
        });
    if lo <= hi {
        hi - lo
    } else {
        f64::NAN
    }
}

/// For each maneuver, whether it is the one counted for its slot: the largest attitude
/// amplitude, the earliest on a tie.
fn counted_flags(maneuvers: &[Maneuver]) -> Vec<bool> {
    let mut flags = vec![false; maneuvers.len()];
    for slot in Slot::all() {
        let best = maneuvers
            .iter()
            .enumerate()
            .filter(|(_, m)| Slot::of(m) == Some(slot))
            .reduce(|best, next| {
                if next.1.amplitude_deg > best.1.amplitude_deg {
                    next
                } else {
                    best
                }
            });
        if let Some((k, _)) = best {
            flags[k] = true;
        }
    }
    flags
}

#[cfg(test)]
mod tests {
    use super::*;

    fn maneuver(kind: ManeuverKind, heading: f64, start: usize, end: usize, amp: f64) -> Maneuver {
        Maneuver {
            kind,
            heading_deg: heading,
            heading_deg_measured: heading,
            start,
            end,
            start_tt: start as f64 / 10.0,
            end_tt: (end - 1) as f64 / 10.0,
            amplitude_deg: amp,
            period_s: 6.0,
            half_cycles: 6,
        }
    }

    /// 10 Hz, a 0.2 Hz sine of amplitude `a` nT between samples 100 and 160, else flat.
    fn burst(a: f64) -> Vec<f64> {
        (0..400)
            .map(|k| {
                let t = k as f64 / 10.0;
                if (100..160).contains(&k) {
                    50_000.0 + a * (2.0 * std::f64::consts::PI * 0.2 * t).sin()
                } else {
                    50_000.0
                }
            })
            .collect()
    }

    #[test]
    fn peak_to_peak_of_a_passband_sine_is_twice_its_amplitude() {
        let m = [maneuver(ManeuverKind::Roll, 0.0, 100, 160, 10.0)];
        let r = fom(&burst(3.0), None, &m, 10.0, &FomSettings::default()).unwrap();
        assert!((r.fom_nt - 6.0).abs() < 0.6, "{}", r.fom_nt);
        assert_eq!(r.missing.len(), 11);
        assert!(!r.missing.contains(&Slot {
            heading_deg: 0,
            kind: ManeuverKind::Roll
        }));
    }

    #[test]
    fn a_repeated_slot_counts_once_the_largest_maneuver() {
        let x = burst(3.0);
        let m = [
            maneuver(ManeuverKind::Roll, 0.0, 100, 160, 5.0),
            maneuver(ManeuverKind::Roll, 0.0, 200, 260, 9.0),
            maneuver(ManeuverKind::Roll, 45.0, 100, 160, 9.0),
        ];
        let r = fom(&x, None, &m, 10.0, &FomSettings::default()).unwrap();
        let counted: Vec<bool> = r.maneuvers.iter().map(|m| m.counted).collect();
        assert_eq!(counted, [false, true, false]);
        assert!(
            r.fom_nt < 0.5,
            "the quiet repeat is the one counted: {}",
            r.fom_nt
        );
    }

    #[test]
    fn nan_is_skipped_and_counted() {
        let mut x = burst(3.0);
        x[130] = f64::NAN;
        let m = [maneuver(ManeuverKind::Pitch, 90.0, 100, 160, 5.0)];
        let r = fom(&x, None, &m, 10.0, &FomSettings::default()).unwrap();
        assert_eq!(r.maneuvers[0].unfiltered_samples, 1);
        assert!(r.fom_nt.is_finite() && r.fom_nt > 1.0);
    }

    #[test]
    fn bad_windows_and_bands_are_errors() {
        let x = burst(1.0);
        let m = [maneuver(ManeuverKind::Yaw, 0.0, 390, 410, 5.0)];
        assert!(matches!(
            fom(&x, None, &m, 10.0, &FomSettings::default()),
            Err(FomError::OutOfRange { .. })
        ));
        let mut s = FomSettings::default();
        s.band.pass2_hz = 6.0;
        assert!(
            fom(&x, None, &[], 10.0, &s).is_ok(),
            "an edge beyond Nyquist is switched off, as in a fit"
        );
        s.order = 0;
        assert!(matches!(
            fom(&x, None, &[], 10.0, &s),
            Err(FomError::Filter(_))
        ));
    }

    #[test]
    fn the_band_pass_does_not_reach_across_a_time_gap() {
        // Two quiet stretches at different levels, a minute apart.
        let x: Vec<f64> = (0..400)
            .map(|k| if k < 200 { 50_000.0 } else { 50_100.0 })
            .collect();
        let tt: Vec<f64> = (0..400)
            .map(|k| k as f64 / 10.0 + if k < 200 { 0.0 } else { 60.0 })
            .collect();
        let m = [maneuver(ManeuverKind::Roll, 0.0, 200, 260, 10.0)];
        let split = fom(&x, Some(&tt), &m, 10.0, &FomSettings::default()).unwrap();
        let joined = fom(&x, None, &m, 10.0, &FomSettings::default()).unwrap();
        assert!(split.fom_nt < 1e-6, "{}", split.fom_nt);
        assert!(joined.fom_nt > 10.0, "{}", joined.fom_nt);
    }

    #[test]
    fn improvement_ratio_divides_the_foms() {
        let x = burst(3.0);
        let m = [maneuver(ManeuverKind::Roll, 0.0, 100, 160, 10.0)];
        let before = fom(&x, None, &m, 10.0, &FomSettings::default()).unwrap();
        let after = fom(&burst(0.3), None, &m, 10.0, &FomSettings::default()).unwrap();
        assert!((improvement_ratio(&before, &after) - 10.0).abs() < 1e-6);
        assert!(peak_to_peak(&[f64::NAN]).is_nan());
    }
}
