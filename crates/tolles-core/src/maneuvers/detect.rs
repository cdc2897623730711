//! Harmonic maneuvers (rolls, pitches, yaws) found from the attitude channels alone.
//!
//! ```
//! use tolles_core::maneuvers::detect::{detect_maneuvers, ManeuverKind, ManeuverSettings};
//! use tolles_core::flight::plan::BoxPlan;
//! use tolles_core::flight::sim::{simulate, Installation, Scenario};
//!
//! let flight = simulate(
//!     &BoxPlan::default().build(),
//!     &Scenario::new(Installation::Cabin.aircraft(), 1),
//! )
//! .unwrap();
//! let found = detect_maneuvers(
//!     &flight.tt,
//!     &flight.roll_deg,
//!     &flight.pitch_deg,
//!     &flight.yaw_deg,
//!     &ManeuverSettings::default(),
//! );
//! assert_eq!(found.len(), 12); // roll, pitch, yaw on N, E, S, W
//! assert_eq!((found[0].kind, found[0].heading_deg), (ManeuverKind::Roll, 0.0));
//! assert!((found[0].amplitude_deg - 10.0).abs() < 0.5 && (found[0].period_s - 6.0).abs() < 0.05);
//! ```
//!
//! How a maneuver is recognised, and why:
//! - each axis is high-passed (zero phase, [`ManeuverSettings::highpass_hz`]) so that a turn's
//!   slow change of heading and its sustained bank are not mistaken for an oscillation; yaw is
//!   unwrapped first so that crossing north is not a 360° jump;
//! - the high-passed signal is cut at its sign changes into *lobes* (half-cycles); a maneuver
//!   is a chain of lobes of alternating sign, each lasting half a period within the allowed range,
//!   with consecutive durations alike;
//! - half-cycles at the ends of a chain whose excursion or duration is unlike the rest (the end of
//!   a turn's bank just before a roll, a gust, a hesitant entry) are trimmed off; what remains
//!   must have at least [`ManeuverSettings::min_half_cycles`] lobes and a median excursion of the
//!   *unfiltered* angle of at least the axis's minimum amplitude;
//! - a chain whose heading drifts (mean heading over its first full cycle against its last) or
//!   that is flown banked is a turn, not a maneuver;
//! - the maneuver's axis must stand out: turbulence moves all three axes, a maneuver mainly one
//!   ([`ManeuverSettings::min_dominance`]); turbulence stronger than the minimum amplitudes can
//!   still be mistaken for a maneuver now and then, which only the thresholds can prevent;
//! - the ends are then placed where the unfiltered angle leaves and rejoins its mean over the
//!   maneuver, so the window matches the maneuver itself, not the filter's smearing of it;
//! - where maneuvers on two axes overlap, the one standing furthest above its axis's threshold
//!   wins.
//!
//! Angles are in degrees, times in seconds, indices are sample indices into the input.

use crate::signal::filter::{Butterworth, Response};
use crate::signal::segment::{contiguous_runs, median_step};
use serde::{Deserialize, Serialize};
use std::ops::Range;

// A detected maneuver's kind is the shared maneuver axis.
pub use super::ManeuverKind;

/// The cardinal headings of a compensation box (degrees clockwise from north).
pub const CARDINAL_HEADINGS_DEG: [f64; 4] = [0.0, 90.0, 180.0, 270.0];

/// One harmonic maneuver found in the attitude.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Maneuver {
    /// The axis that oscillates.
    pub kind: ManeuverKind,
    /// Nominal heading (degrees, [0, 360)): the nearest cardinal heading when the measured one is
    /// within [`ManeuverSettings::cardinal_tolerance_deg`] of it (from [`detect_maneuvers`]), else
    /// the measured heading.
    pub heading_deg: f64,
    /// Circular mean of the yaw over the maneuver (degrees, [0, 360)).
    pub heading_deg_measured: f64,
    /// First sample of the maneuver (index into the input).
    pub start: usize,
    /// One past the last sample (index into the input).
    pub end: usize,
    /// Time of the first sample (s).
    pub start_tt: f64,
    /// Time of the last sample, `tt[end - 1]` (s).
    pub end_tt: f64,
    /// Median peak excursion of the angle from its mean over the maneuver (degrees).
    pub amplitude_deg: f64,
    /// Mean period (s): `end_tt − start_tt` over the number of cycles.
    pub period_s: f64,
    /// Number of half-cycles (lobes) flown.
    pub half_cycles: usize,
}

impl Maneuver {
    /// The cardinal heading (0, 90, 180 or 270 degrees) this maneuver was assigned, if any.
    pub fn cardinal_heading_deg(&self) -> Option<f64> {
        CARDINAL_HEADINGS_DEG
            .into_iter()
            .find(|&h| h == self.heading_deg)
    }

    /// Sample index range `start..end`.
    pub fn range(&self) -> Range<usize> {
        self.start..self.end
    }
}

/// Thresholds of the detector. Angles in degrees, times in seconds, frequencies in Hz.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ManeuverSettings {
    /// Smallest roll amplitude that counts as a roll maneuver (degrees).
    pub min_roll_deg: f64,
    /// Smallest pitch amplitude that counts as a pitch maneuver (degrees).
    pub min_pitch_deg: f64,
    /// Smallest yaw amplitude that counts as a yaw maneuver (degrees).
    pub min_yaw_deg: f64,
    /// Shortest period accepted (s).
    pub min_period_s: f64,
    /// Longest period accepted (s).
    pub max_period_s: f64,
    /// Fewest half-cycles a maneuver must have (3 = one and a half cycles).
    pub min_half_cycles: usize,
    /// Largest change of mean heading from the first cycle to the last (degrees); more is a turn.
    pub max_heading_drift_deg: f64,
    /// Largest mean roll over a cycle (degrees); more is a banked turn.
    pub max_mean_bank_deg: f64,
    /// A measured heading this close to a cardinal heading is assigned to it (degrees).
    pub cardinal_tolerance_deg: f64,
    /// Cutoff of the zero-phase high-pass applied before cutting lobes (Hz).
    pub highpass_hz: f64,
    /// Order of that high-pass (poles; applied forward and backward).
    pub highpass_order: usize,
    /// A maneuver's amplitude, in multiples of its axis's minimum, must be at least this many
    /// times that of each other axis (√2 × RMS of its high-passed angle over the maneuver, in
    /// multiples of that axis's minimum): turbulence moves all axes, a maneuver mainly one.
    pub min_dominance: f64,
}

impl Default for ManeuverSettings {
    /// Roll 3°, pitch 1.5°, yaw 1.5° (about 2°, 1°, 1° RMS); periods 2.5–12 s; 1.5 cycles;
    /// 15° heading drift; 5° mean bank; cardinal within 20°; 2nd-order high-pass at 0.06 Hz
    /// (a 12 s period keeps 80 % of its amplitude, a 90° turn over 30 s leaves well under 1°);
    /// dominance 2.
    fn default() -> Self {
        Self {
            min_roll_deg: 3.0,
            min_pitch_deg: 1.5,
            min_yaw_deg: 1.5,
            min_period_s: 2.5,
            max_period_s: 12.0,
            min_half_cycles: 3,
            max_heading_drift_deg: 15.0,
            max_mean_bank_deg: 5.0,
            cardinal_tolerance_deg: 20.0,
            highpass_hz: 0.06,
            highpass_order: 2,
            min_dominance: 2.0,
        }
    }
}

impl ManeuverSettings {
    fn min_amplitude_deg(&self, kind: ManeuverKind) -> f64 {
        match kind {
            ManeuverKind::Roll => self.min_roll_deg,
            ManeuverKind::Pitch => self.min_pitch_deg,
            ManeuverKind::Yaw => self.min_yaw_deg,
        }
    }
}

/// Compensation-box maneuvers: [`detect_harmonic_maneuvers`] with headings within
/// [`ManeuverSettings::cardinal_tolerance_deg`] of north, east, south or west set to exactly
/// 0, 90, 180 or 270 degrees in [`Maneuver::heading_deg`].
///
/// `tt` in seconds; `roll_deg`, `pitch_deg`, `yaw_deg` in degrees, all of one length.
pub fn detect_maneuvers(
    tt: &[f64],
    roll_deg: &[f64],
    pitch_deg: &[f64],
    yaw_deg: &[f64],
    settings: &ManeuverSettings,
) -> Vec<Maneuver> {
    let mut found = detect_harmonic_maneuvers(tt, roll_deg, pitch_deg, yaw_deg, settings);
    for m in &mut found {
        if let Some(h) = nearest_cardinal(m.heading_deg_measured, settings.cardinal_tolerance_deg) {
            m.heading_deg = h;
        }
    }
    found
}

/// Harmonic maneuvers on any heading, in time order; [`Maneuver::heading_deg`] is the measured
/// heading.
///
/// `tt` in seconds; `roll_deg`, `pitch_deg`, `yaw_deg` in degrees (yaw may wrap at 0/360 or not).
/// Samples where any of the four is not finite, and time gaps, split the flight; a maneuver never
/// spans such a break. Pieces too short for the high-pass are not searched. Inputs of unequal
/// length are searched over the common length.
pub fn detect_harmonic_maneuvers(
    tt: &[f64],
    roll_deg: &[f64],
    pitch_deg: &[f64],
    yaw_deg: &[f64],
    settings: &ManeuverSettings,
) -> Vec<Maneuver> {
    let n = tt
        .len()
        .min(roll_deg.len())
        .min(pitch_deg.len())
        .min(yaw_deg.len());
    let (tt, roll_deg, pitch_deg, yaw_deg) =
        (&tt[..n], &roll_deg[..n], &pitch_deg[..n], &yaw_deg[..n]);
    let Some(step) = median_step(tt) else {
        return Vec::new();
    };
    let fs_hz = 1.0 / step;
    let Ok(highpass) = Butterworth::design(
        settings.highpass_order,
        Response::HighPass {
            cutoff_hz: settings.highpass_hz,
        },
        fs_hz,
    ) else {
        return Vec::new();
    };
    let usable: Vec<bool> = (0..n)
        .map(|k| {
            tt[k].is_finite()
                && roll_deg[k].is_finite()
                && pitch_deg[k].is_finite()
                && yaw_deg[k].is_finite()
        })
        .collect();
    let mut candidates = Vec::new();
    for run in contiguous_runs(&usable, Some(tt)) {
        if run.len() <= highpass.padlen() {
            continue;
        }
        let angles = [
            roll_deg[run.clone()].to_vec(),
            pitch_deg[run.clone()].to_vec(),
            unwrap_deg(&yaw_deg[run.clone()]),
        ];
        let Ok(filtered) = angles
            .iter()
            .map(|a| highpass.filtfilt(a))
            .collect::<Result<Vec<_>, _>>()
        else {
            continue;
        };
        let piece = Piece {
            offset: run.start,
            fs_hz,
            tt: &tt[run.clone()],
            angles,
            filtered,
        };
        for kind in ManeuverKind::ALL {
            candidates.extend(piece.maneuvers(kind, settings));
        }
    }
    resolve_overlaps(candidates)
}

/// A maneuver and how far it stands above its axis's threshold.
struct Candidate {
    maneuver: Maneuver,
    score: f64,
}

/// A contiguous, all-finite stretch of the flight.
struct Piece<'a> {
    /// Index of the piece's first sample in the input.
    offset: usize,
    fs_hz: f64,
    tt: &'a [f64],
    /// Roll, pitch and unwrapped yaw (degrees), indexed by [`axis`].
    angles: [Vec<f64>; 3],
    /// The same, high-passed.
    filtered: Vec<Vec<f64>>,
}

/// Index of `kind` in [`ManeuverKind::ALL`].
fn axis(kind: ManeuverKind) -> usize {
    kind as usize
}

impl Piece<'_> {
    fn maneuvers(&self, kind: ManeuverKind, settings: &ManeuverSettings) -> Vec<Candidate> {
        let (angle, filtered) = (&self.angles[axis(kind)], &self.filtered[axis(kind)]);
        let min_amplitude = settings.min_amplitude_deg(kind);
        let half_period = |l: &Lobe| l.len() as f64 / self.fs_hz;
        let strong: Vec<Lobe> = lobes(filtered)
            .into_iter()
            .filter(|l| l.peak >= LOBE_FRACTION * min_amplitude)
            .filter(|l| {
                let h = half_period(l);
                h >= settings.min_period_s / 2.0 && h <= settings.max_period_s / 2.0
            })
            .collect();
        chains(&strong)
            .into_iter()
            .map(|chain| consistent_core(angle, chain))
            .filter(|chain| chain.len() >= settings.min_half_cycles.max(1))
            .filter(|chain| self.is_level_and_straight(chain, settings))
            .map(|chain| {
                let maneuver = self.refine(kind, angle, chain);
                let score = maneuver.amplitude_deg / min_amplitude;
                Candidate { maneuver, score }
            })
            .filter(|c| c.maneuver.amplitude_deg >= min_amplitude)
            .filter(|c| self.dominates(&c.maneuver, settings))
            .collect()
    }

    /// The maneuver's axis stands out above the others (turbulence moves all three).
    fn dominates(&self, m: &Maneuver, settings: &ManeuverSettings) -> bool {
        let window = m.start - self.offset..m.end - self.offset;
        let own = m.amplitude_deg / settings.min_amplitude_deg(m.kind);
        ManeuverKind::ALL
            .into_iter()
            .filter(|&k| k != m.kind)
            .all(|k| {
                let x = &self.filtered[axis(k)][window.clone()];
                let rms = (x.iter().map(|v| v * v).sum::<f64>() / x.len() as f64).sqrt();
                let other = std::f64::consts::SQRT_2 * rms / settings.min_amplitude_deg(k);
                own >= settings.min_dominance * other
            })
    }

    /// A turn changes heading between the first cycle and the last, or is flown banked.
    fn is_level_and_straight(&self, chain: &[Lobe], settings: &ManeuverSettings) -> bool {
        // Over whole cycles (two lobes) the oscillation itself averages out.
        let two = 1.min(chain.len() - 1);
        let first = chain[0].start..chain[two].end;
        let last = chain[chain.len() - 1 - two].start..chain[chain.len() - 1].end;
        let (roll, yaw) = (
            &self.angles[axis(ManeuverKind::Roll)],
            &self.angles[axis(ManeuverKind::Yaw)],
        );
        let drift = mean(&yaw[last.clone()]) - mean(&yaw[first.clone()]);
        let bank = mean(&roll[first]).abs().max(mean(&roll[last]).abs());
        drift.abs() <= settings.max_heading_drift_deg && bank <= settings.max_mean_bank_deg
    }

    /// The maneuver with its ends placed on the unfiltered angle.
    fn refine(&self, kind: ManeuverKind, angle: &[f64], chain: &[Lobe]) -> Maneuver {
        let (first, last) = (&chain[0], &chain[chain.len() - 1]);
        let level = mean(&angle[first.start..last.end]);
        let amplitude = median(&excursions(angle, level, chain));
        // The angle is back at its level within this fraction of the amplitude.
        let tolerance = END_TOLERANCE * amplitude;
        let outside = |k: usize, sign: f64| (angle[k] - level) * sign <= tolerance;
        let slack = |l: &Lobe| l.len() / 2;
        let mut start = first.peak_index;
        let lowest = first.start.saturating_sub(slack(first));
        while start > lowest && !outside(start - 1, first.sign) {
            start -= 1;
        }
        // Include the sample where the angle is back at its level.
        start = start.saturating_sub(1).max(lowest);
        let mut end = last.peak_index + 1;
        let highest = (last.end + slack(last)).min(angle.len());
        while end < highest && !outside(end, last.sign) {
            end += 1;
        }
        end = (end + 1).min(highest);
        let heading = circular_mean_deg(&self.angles[axis(ManeuverKind::Yaw)][start..end]);
        // The ends are the crossings themselves, so the duration is between them.
        let duration_s = self.tt[end - 1] - self.tt[start];
        Maneuver {
            kind,
            heading_deg: heading,
            heading_deg_measured: heading,
            start: self.offset + start,
            end: self.offset + end,
            start_tt: self.tt[start],
            end_tt: self.tt[end - 1],
            amplitude_deg: amplitude,
            period_s: duration_s / (chain.len() as f64 / 2.0),
            half_cycles: chain.len(),
        }
    }
}

/// A lobe of the high-passed angle reaching this fraction of the minimum amplitude may belong to
/// a maneuver: the high-pass and the ends of a maneuver shave some amplitude off, and the
/// maneuver as a whole must still reach the minimum on the unfiltered angle.
const LOBE_FRACTION: f64 = 0.5;

/// Within a maneuver, the half-cycles at either end whose peak excursion or duration differs from
/// the median by more than this factor (either way) are not part of it: the end of a turn's bank,
/// a gust, a hesitant entry.
const CONSISTENCY_FACTOR: f64 = 1.6;

/// Fraction of the amplitude within which the angle counts as back at its mean level.
const END_TOLERANCE: f64 = 0.05;

/// Largest ratio of consecutive half-cycle durations within one maneuver.
const MAX_DURATION_RATIO: f64 = 1.8;

/// Largest gap between consecutive strong lobes, as a fraction of the shorter one: noise makes
/// brief sign flips near a zero crossing.
const MAX_GAP_FRACTION: f64 = 0.25;

/// A maximal run of samples of one strict sign.
#[derive(Debug, Clone, PartialEq)]
struct Lobe {
    start: usize,
    end: usize,
    /// +1 or −1.
    sign: f64,
    /// Largest |value| in the lobe.
    peak: f64,
    peak_index: usize,
}

impl Lobe {
    fn len(&self) -> usize {
        self.end - self.start
    }
}

/// The lobes of `x`; exact zeros belong to none.
fn lobes(x: &[f64]) -> Vec<Lobe> {
    let mut out: Vec<Lobe> = Vec::new();
    let mut current: Option<Lobe> = None;
    for (k, &v) in x.iter().enumerate() {
        let sign = if v > 0.0 {
            1.0
        } else if v < 0.0 {
            -1.0
        } else {
            0.0
        };
        if let Some(lobe) = current.as_mut() {
            if lobe.sign == sign {
                lobe.end = k + 1;
                if v.abs() > lobe.peak {
                    lobe.peak = v.abs();
                    lobe.peak_index = k;
                }
                continue;
            }
            out.extend(current.take());
        }
        if sign != 0.0 {
            current = Some(Lobe {
                start: k,
                end: k + 1,
                sign,
                peak: v.abs(),
                peak_index: k,
            });
        }
    }
    out.extend(current);
    out
}

/// Peak excursion of the unfiltered `angle` from `level` in the direction of each lobe (degrees).
fn excursions(angle: &[f64], level: f64, chain: &[Lobe]) -> Vec<f64> {
    chain
        .iter()
        .map(|l| {
            angle[l.start..l.end]
                .iter()
                .map(|a| (a - level) * l.sign)
                .fold(0.0, f64::max)
        })
        .collect()
}

/// `chain` without the end lobes that do not look like the rest (see [`CONSISTENCY_FACTOR`]);
/// the mean level is recomputed after each removal, since an odd lobe also biases it.
fn consistent_core<'c>(angle: &[f64], chain: &'c [Lobe]) -> &'c [Lobe] {
    let mut core = chain;
    while core.len() >= 3 {
        let level = mean(&angle[core[0].start..core[core.len() - 1].end]);
        let peaks = excursions(angle, level, core);
        let (typical_peak, typical_len) = (
            median(&peaks),
            median(&core.iter().map(|l| l.len() as f64).collect::<Vec<_>>()),
        );
        // How many times off the typical lobe a lobe is; 0 when alike.
        let oddness = |k: usize| {
            let off = |ratio: f64| (ratio.ln().abs() - CONSISTENCY_FACTOR.ln()).max(0.0);
            off(peaks[k].max(f64::MIN_POSITIVE) / typical_peak)
                + off(core[k].len() as f64 / typical_len)
        };
        let (head, tail) = (oddness(0), oddness(core.len() - 1));
        if head == 0.0 && tail == 0.0 {
            break;
        }
        core = if head >= tail {
            &core[1..]
        } else {
            &core[..core.len() - 1]
        };
    }
    core
}

/// Splits strong lobes into chains of alternating sign, alike durations and small gaps.
fn chains(strong: &[Lobe]) -> Vec<&[Lobe]> {
    let mut out = Vec::new();
    let mut begin = 0;
    for k in 1..=strong.len() {
        let joined = k < strong.len() && {
            let (a, b) = (&strong[k - 1], &strong[k]);
            let shorter = a.len().min(b.len()) as f64;
            let ratio = a.len().max(b.len()) as f64 / shorter;
            a.sign != b.sign
                && ratio <= MAX_DURATION_RATIO
                && (b.start - a.end) as f64 <= MAX_GAP_FRACTION * shorter
        };
        if !joined {
            out.push(&strong[begin..k]);
            begin = k;
        }
    }
    out.retain(|c| !c.is_empty());
    out
}

/// Keeps, of maneuvers that overlap by more than a quarter of the shorter, the one with the
/// higher score; returns them in time order.
fn resolve_overlaps(mut candidates: Vec<Candidate>) -> Vec<Maneuver> {
    candidates.sort_by(|a, b| b.score.total_cmp(&a.score));
    let mut kept: Vec<Maneuver> = Vec::new();
    for c in candidates {
        let clashes = kept.iter().any(|k| {
            let overlap = c
                .maneuver
                .end
                .min(k.end)
                .saturating_sub(c.maneuver.start.max(k.start));
            let shorter = (c.maneuver.end - c.maneuver.start).min(k.end - k.start);
            4 * overlap > shorter
        });
        if !clashes {
            kept.push(c.maneuver);
        }
    }
    kept.sort_by_key(|m| m.start);
    kept
}

/// The nearest cardinal heading (degrees) if within `tolerance_deg` of `heading_deg`.
fn nearest_cardinal(heading_deg: f64, tolerance_deg: f64) -> Option<f64> {
    let nearest = (heading_deg / 90.0).round().rem_euclid(4.0) * 90.0;
    (angle_between_deg(heading_deg, nearest) <= tolerance_deg).then_some(nearest)
}

/// Smallest absolute angle between two headings (degrees).
fn angle_between_deg(a: f64, b: f64) -> f64 {
    let d = (a - b).rem_euclid(360.0);
    d.min(360.0 - d)
}

/// `yaw` (degrees) with 360° jumps removed, so it is continuous across north.
pub fn unwrap_deg(yaw: &[f64]) -> Vec<f64> {
    let mut out = Vec::with_capacity(yaw.len());
    let mut shift = 0.0;
    let mut previous: Option<f64> = None;
    for &y in yaw {
        if let (Some(p), true) = (previous, y.is_finite()) {
            shift -= ((y - p) / 360.0).round() * 360.0;
        }
        if y.is_finite() {
            previous = Some(y);
        }
        out.push(y + shift);
    }
    out
}

/// Circular mean of headings (degrees), in [0, 360).
fn circular_mean_deg(headings: &[f64]) -> f64 {
    let (s, c) = headings.iter().fold((0.0, 0.0), |(s, c), h| {
        let (sh, ch) = h.to_radians().sin_cos();
        (s + sh, c + ch)
    });
    let mean = s.atan2(c).to_degrees().rem_euclid(360.0);
    // rem_euclid of a tiny negative number can round to exactly 360.
    if mean >= 360.0 {
        0.0
    } else {
        mean
    }
}

fn mean(x: &[f64]) -> f64 {
    x.iter().sum::<f64>() / x.len() as f64
}

fn median(x: &[f64]) -> f64 {
    let mut sorted = x.to_vec();
    sorted.sort_by(f64::total_cmp);
    let mid = sorted.len() / 2;
    if sorted.len() % 2 == 1 {
        sorted[mid]
    } else {
        (sorted[mid - 1] + sorted[mid]) / 2.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    /// Straight and level at `heading` for `lead` s, then `cycles` of a sine of `amplitude` and
    /// `period` on `kind`, then `lead` s straight again, sampled at `fs`.
    fn single(
        kind: ManeuverKind,
        heading: f64,
        amplitude: f64,
        period: f64,
        cycles: f64,
        fs: f64,
    ) -> [Vec<f64>; 4] {
        let lead = 20.0;
        let total = 2.0 * lead + cycles * period;
        let n = (total * fs) as usize;
        let mut out = [vec![], vec![], vec![], vec![]];
        for k in 0..n {
            let t = k as f64 / fs;
            let u = t - lead;
            let a = if (0.0..cycles * period).contains(&u) {
                amplitude * (2.0 * PI * u / period).sin()
            } else {
                0.0
            };
            let (mut r, mut p, mut y) = (0.0, 0.0, heading);
            match kind {
                ManeuverKind::Roll => r = a,
                ManeuverKind::Pitch => p = a,
                ManeuverKind::Yaw => y += a,
            }
            out[0].push(t);
            out[1].push(r);
            out[2].push(p);
            out[3].push(y.rem_euclid(360.0));
        }
        out
    }

    fn detect(data: &[Vec<f64>; 4]) -> Vec<Maneuver> {
        detect_maneuvers(
            &data[0],
            &data[1],
            &data[2],
            &data[3],
            &ManeuverSettings::default(),
        )
    }

    #[test]
    fn a_sine_is_found_with_its_ends_amplitude_and_period() {
        let data = single(ManeuverKind::Pitch, 90.0, 5.0, 6.0, 3.0, 10.0);
        let found = detect(&data);
        assert_eq!(found.len(), 1, "{found:?}");
        let m = &found[0];
        assert_eq!((m.kind, m.heading_deg), (ManeuverKind::Pitch, 90.0));
        assert!((m.start_tt - 20.0).abs() <= 0.1, "{}", m.start_tt);
        assert!((m.end_tt - 38.0).abs() <= 0.1, "{}", m.end_tt);
        assert!((m.amplitude_deg - 5.0).abs() < 0.05);
        assert!((m.period_s - 6.0).abs() < 0.02, "{}", m.period_s);
        assert_eq!(m.half_cycles, 6);
    }

    #[test]
    fn yaw_across_north_is_one_maneuver_on_heading_zero() {
        let data = single(ManeuverKind::Yaw, 0.0, 5.0, 5.0, 2.0, 10.0);
        assert!(data[3].iter().any(|y| *y > 350.0));
        let found = detect(&data);
        assert_eq!(found.len(), 1, "{found:?}");
        assert_eq!(
            (found[0].kind, found[0].heading_deg),
            (ManeuverKind::Yaw, 0.0)
        );
        assert!(found[0].heading_deg_measured < 0.5 || found[0].heading_deg_measured > 359.5);
    }

    #[test]
    fn too_small_too_short_or_too_slow_is_not_a_maneuver() {
        assert!(detect(&single(ManeuverKind::Roll, 0.0, 2.0, 6.0, 3.0, 10.0)).is_empty());
        assert!(detect(&single(ManeuverKind::Roll, 0.0, 10.0, 6.0, 1.0, 10.0)).is_empty());
        assert!(detect(&single(ManeuverKind::Roll, 0.0, 10.0, 30.0, 3.0, 10.0)).is_empty());
    }

    #[test]
    fn off_cardinal_headings_keep_the_measured_heading() {
        let data = single(ManeuverKind::Roll, 45.0, 10.0, 6.0, 3.0, 10.0);
        let found = detect(&data);
        assert_eq!(found.len(), 1);
        assert!((found[0].heading_deg - 45.0).abs() < 1e-9);
        assert_eq!(found[0].cardinal_heading_deg(), None);
    }

    #[test]
    fn nan_splits_a_maneuver_and_is_never_inside_one() {
        let mut data = single(ManeuverKind::Roll, 0.0, 10.0, 6.0, 6.0, 10.0);
        let hole = 20 * 10 + 180; // 18 s into the 36 s maneuver
        data[1][hole] = f64::NAN;
        let found = detect(&data);
        assert_eq!(found.len(), 2, "{found:?}");
        assert!(found.iter().all(|m| !m.range().contains(&hole)));
    }

    /// 20 s level, 18 s of 6 s sines of amplitudes `[roll, pitch, yaw]` together, 20 s level.
    fn together(amplitudes: [f64; 3]) -> [Vec<f64>; 4] {
        let mut out = [vec![], vec![], vec![], vec![]];
        for k in 0..580 {
            let u = k as f64 / 10.0 - 20.0;
            let wave = if (0.0..18.0).contains(&u) {
                (2.0 * PI * u / 6.0).sin()
            } else {
                0.0
            };
            out[0].push(k as f64 / 10.0);
            out[1].push(amplitudes[0] * wave);
            out[2].push(amplitudes[1] * wave);
            out[3].push((180.0 + amplitudes[2] * wave).rem_euclid(360.0));
        }
        out
    }

    #[test]
    fn one_axis_must_stand_out() {
        // All three axes alike (in multiples of their thresholds), as in turbulence: none.
        assert!(detect(&together([6.0, 3.0, 3.0])).is_empty());
        // A roll with some adverse yaw is a roll.
        let found = detect(&together([10.0, 0.0, 1.5]));
        assert_eq!(found.len(), 1, "{found:?}");
        assert_eq!(
            (found[0].kind, found[0].heading_deg),
            (ManeuverKind::Roll, 180.0)
        );
    }

    #[test]
    fn odd_half_cycles_at_the_ends_are_trimmed() {
        // A 6 s, 10° roll of three cycles, preceded by one 12°-excursion lobe twice as long.
        let mut angle = vec![0.0; 50];
        angle.extend((0..60).map(|k| 20.0 * (PI * k as f64 / 60.0).sin()));
        angle.extend((0..180).map(|k| -10.0 * (2.0 * PI * k as f64 / 60.0).sin()));
        angle.extend(vec![0.0; 50]);
        let chain = lobes(&angle);
        assert_eq!(chain.len(), 7);
        let core = consistent_core(&angle, &chain);
        assert_eq!(core.len(), 6);
        assert_eq!(core[0].start, 111);
    }

    #[test]
    fn lobes_alternate_and_skip_zeros() {
        let l = lobes(&[0.0, 1.0, 2.0, -1.0, 0.0, 0.0, 3.0]);
        assert_eq!(l.len(), 3);
        assert_eq!((l[0].start, l[0].end, l[0].peak_index), (1, 3, 2));
        assert_eq!((l[1].start, l[1].end, l[1].sign), (3, 4, -1.0));
        assert_eq!((l[2].start, l[2].peak), (6, 3.0));
    }

    #[test]
    fn unwrap_and_circular_mean_cross_north() {
        let u = unwrap_deg(&[350.0, 359.0, 1.0, 10.0, f64::NAN, 5.0]);
        assert_eq!(&u[..4], &[350.0, 359.0, 361.0, 370.0]);
        assert!(u[4].is_nan());
        assert_eq!(u[5], 365.0);
        assert!(angle_between_deg(circular_mean_deg(&[350.0, 10.0]), 0.0) < 1e-9);
        assert_eq!(nearest_cardinal(355.0, 20.0), Some(0.0));
        assert_eq!(nearest_cardinal(135.0, 20.0), None);
    }
}
