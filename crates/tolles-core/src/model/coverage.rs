//! What a calibration flight spanned, and which samples of another flight lie outside it.
//!
//! ```
//! use tolles_core::model::coverage::Coverage;
//! use tolles_core::model::vector::VectorSeries;
//!
//! // A calibration that only ever saw the field along +x, swinging by a few degrees.
//! let n = 200;
//! let swing = |k: usize| 0.05 * (k as f64 * 0.3).sin();
//! let cal = VectorSeries::new(
//!     (0..n).map(|k| 50_000.0 * swing(k).cos()).collect(),
//!     (0..n).map(|k| 50_000.0 * swing(k).sin()).collect(),
//!     vec![0.0; n],
//! );
//! let coverage = Coverage::of(&cal, &[0..n], 10.0, &[]);
//! assert!(!coverage.outside([50_000.0, 0.0, 0.0], 0.0, &[]));
//! assert!(coverage.outside([0.0, 50_000.0, 0.0], 0.0, &[])); // a heading it never flew
//! ```
//!
//! A model is fitted to the attitudes, rates and channel values its calibration flew. The
//! interference depends on the attitude only through the earth field's direction in the
//! aircraft (two angles: a heading and a tilt), so the span of directions is what matters: the
//! directions are binned on the faces of a cube (cells 1.6–3.2° across), and a cell counts
//! as covered when a calibration direction lies within [`TOLERANCE_DEG`] of it. Rates of change
//! of the field (eddy currents) and extra channels (currents) are covered up to
//! [`MARGIN`] beyond the largest the calibration saw. A sample outside is extrapolated: the
//! model may still hold there, but nothing in the calibration showed that it does.

use crate::model::vector::VectorSeries;
use serde::{Deserialize, Serialize};
use std::ops::Range;

/// Cells along each edge of a cube face.
const CELLS: usize = 36;

/// Angle (degrees) within which a calibration direction covers a cell.
pub const TOLERANCE_DEG: f64 = 10.0;

/// Fraction beyond the calibration's largest rate and its channels' range that still counts as
/// covered.
pub const MARGIN: f64 = 0.25;

/// Samples of a long calibration looked at (evenly spread): directions change slowly, so a few
/// per second are as good as all of them.
const MAX_SAMPLES: usize = 20_000;

/// What a calibration flight spanned.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct Coverage {
    /// Covered direction cells (sorted ids: face·36² + row·36 + column).
    pub cells: Vec<u32>,
    /// Largest rate of change of the field the calibration saw (nT/s).
    pub rate_nt_per_s: f64,
    /// Per extra channel, the smallest and largest value the calibration saw (its units).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub extras: Vec<[f64; 2]>,
}

impl Coverage {
    /// The span of the samples `runs` of `flux` (nT, body frame) at `fs_hz`, and of the extra
    /// channels `extras` over the same samples.
    pub fn of(flux: &VectorSeries, runs: &[Range<usize>], fs_hz: f64, extras: &[&[f64]]) -> Self {
        let total: usize = runs.iter().map(|r| r.len()).sum();
        let step = total.div_ceil(MAX_SAMPLES).max(1);
        let mut cells = Vec::new();
        let mut rate: f64 = 0.0;
        let mut ranges = vec![[f64::INFINITY, f64::NEG_INFINITY]; extras.len()];
        for run in runs {
            for k in run.clone() {
                let b = flux.at(k);
                let speed = rate_at(flux, run, k) * fs_hz;
                if speed.is_finite() {
                    rate = rate.max(speed);
                }
                for (range, channel) in ranges.iter_mut().zip(extras) {
                    let v = channel[k];
                    if v.is_finite() {
                        *range = [range[0].min(v), range[1].max(v)];
                    }
                }
                if (k - run.start) % step == 0 {
                    mark(&mut cells, b);
                }
            }
        }
        cells.sort_unstable();
        cells.dedup();
        Self {
            cells,
            rate_nt_per_s: rate,
            extras: ranges,
        }
    }

    /// Whether a sample with field `b` (nT, body frame), changing at `rate_nt_per_s` (nT/s),
    /// and extra channels `extras` lies outside the span. A sample without a direction (a
    /// missing fluxgate value) is not judged.
    pub fn outside(&self, b: [f64; 3], rate_nt_per_s: f64, extras: &[f64]) -> bool {
        let direction = match cell(b) {
            Some(c) => self.cells.binary_search(&c).is_err(),
            None => return false,
        };
        let fast = rate_nt_per_s > self.rate_nt_per_s * (1.0 + MARGIN);
        let channel = self.extras.iter().zip(extras).any(|([lo, hi], v)| {
            let slack = MARGIN * (hi - lo).abs().max(hi.abs().max(lo.abs()) * 0.1);
            *v < lo - slack || *v > hi + slack
        });
        direction || fast || channel
    }
}

/// `|Ḃ|` at sample `k` of `run` (nT per sample), by central differences (one-sided at its ends).
pub fn rate_at(flux: &VectorSeries, run: &Range<usize>, k: usize) -> f64 {
    let (lo, hi) = (k.saturating_sub(1).max(run.start), (k + 1).min(run.end - 1));
    if hi == lo {
        return 0.0;
    }
    let (a, b) = (flux.at(lo), flux.at(hi));
    let d = [0, 1, 2].map(|i| (b[i] - a[i]) / (hi - lo) as f64);
    (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt()
}

/// Marks the cells within [`TOLERANCE_DEG`] of the direction of `b`: its own and those of the
/// direction tilted by a quarter, half, three quarters and all of the tolerance, sixteen ways
/// each (points closer together than a cell, so no covered cell is skipped).
fn mark(cells: &mut Vec<u32>, b: [f64; 3]) {
    let Some(unit) = unit(b) else { return };
    let (u, v) = tangents(unit);
    cells.extend(cell(unit));
    for ring in 1..=4 {
        let (sr, cr) = (TOLERANCE_DEG.to_radians() * ring as f64 / 4.0).sin_cos();
        for k in 0..16 {
            let (s, c) = (k as f64 * std::f64::consts::PI / 8.0).sin_cos();
            cells.extend(cell(
                [0, 1, 2].map(|i| cr * unit[i] + sr * (c * u[i] + s * v[i])),
            ));
        }
    }
}

fn unit(b: [f64; 3]) -> Option<[f64; 3]> {
    let n = (b[0] * b[0] + b[1] * b[1] + b[2] * b[2]).sqrt();
    (n.is_finite() && n > 0.0).then(|| b.map(|c| c / n))
}

/// Two unit vectors orthogonal to `d` and to each other.
fn tangents(d: [f64; 3]) -> ([f64; 3], [f64; 3]) {
    let helper = if d[0].abs() < 0.9 {
        [1.0, 0.0, 0.0]
    } else {
        [0.0, 1.0, 0.0]
    };
    let cross = |a: [f64; 3], b: [f64; 3]| {
        [
            a[1] * b[2] - a[2] * b[1],
            a[2] * b[0] - a[0] * b[2],
            a[0] * b[1] - a[1] * b[0],
        ]
    };
    let u = unit(cross(d, helper)).expect("d is not along the helper");
    (u, cross(d, u))
}

/// The cube-face cell of the direction of `b`; `None` for a zero or non-finite vector.
fn cell(b: [f64; 3]) -> Option<u32> {
    let d = unit(b)?;
    let axis = (0..3)
        .max_by(|&i, &j| d[i].abs().total_cmp(&d[j].abs()))
        .expect("three axes");
    let face = 2 * axis + usize::from(d[axis] < 0.0);
    let (i, j) = match axis {
        0 => (1, 2),
        1 => (0, 2),
        _ => (0, 1),
    };
    // Equal lengths on the face (the gnomonic projection): cells from 1.6° across at the
    // face's centre to 3.2° at its edges, and no trigonometry per sample.
    let index = |c: f64| {
        let a = c / d[axis].abs(); // −1…1
        (((a + 1.0) / 2.0 * CELLS as f64) as usize).min(CELLS - 1)
    };
    Some((face * CELLS * CELLS + index(d[i]) * CELLS + index(d[j])) as u32)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::flight::plan::{BoxPlan, SurveyPlan};
    use crate::flight::sim::{simulate, Installation};

    fn runs(n: usize) -> Vec<Range<usize>> {
        std::iter::once(0..n).collect()
    }

    #[test]
    fn a_box_on_two_headings_covers_lines_on_them_and_not_across() {
        let scenario = Installation::TailStinger.scenario(2);
        let plan = BoxPlan {
            headings_deg: vec![0.0, 180.0],
            ..BoxPlan::default()
        }
        .build();
        let cal = simulate(&plan, &scenario).unwrap();
        // The box's legs alone: its turns sweep every heading between them, banked.
        let turns: Vec<f64> = plan
            .segments()
            .iter()
            .filter(|s| matches!(s.motion, crate::flight::plan::Motion::Turn { .. }))
            .map(|s| s.line)
            .collect();
        let mut legs: Vec<Range<usize>> = Vec::new();
        for k in 0..cal.tt.len() {
            if turns.contains(&cal.line[k]) {
                continue;
            }
            match legs.last_mut() {
                Some(last) if last.end == k => last.end = k + 1,
                _ => legs.push(k..k + 1),
            }
        }
        let coverage = Coverage::of(&cal.flux, &legs, 10.0, &[]);
        let outside = |heading: f64| {
            let plan = SurveyPlan {
                heading_deg: heading,
                lines: 2,
                ..SurveyPlan::default()
            };
            let survey = simulate(&plan.build(), &scenario).unwrap();
            let lines: Vec<usize> = (0..survey.tt.len())
                .filter(|&k| survey.line[k] > 1000.0)
                .collect();
            let out = lines
                .iter()
                .filter(|&&k| coverage.outside(survey.flux.at(k), 0.0, &[]))
                .count();
            out as f64 / lines.len() as f64
        };
        // Lines north and south are what the box's legs flew; lines east and west never were.
        // (At a dip of 69° a heading turns the field's direction in the aircraft by only a
        // third as much, and a box's 10° rolls sweep it by 10°: lines at 45° between four
        // headings are covered.)
        assert!(outside(0.0) < 0.01, "{}", outside(0.0));
        assert!(outside(90.0) > 0.9, "{}", outside(90.0));
    }

    #[test]
    fn rates_and_channels_beyond_the_calibration_are_outside() {
        let n = 100;
        let flux = VectorSeries::new(
            (0..n).map(|k| 50_000.0 + k as f64).collect(),
            vec![0.0; n],
            vec![0.0; n],
        );
        let current: Vec<f64> = (0..n).map(|k| (k % 10) as f64).collect();
        let c = Coverage::of(&flux, &runs(n), 10.0, &[&current]);
        assert_eq!(c.rate_nt_per_s, 10.0);
        assert_eq!(c.extras, [[0.0, 9.0]]);
        let b = [50_000.0, 0.0, 0.0];
        assert!(!c.outside(b, 12.0, &[9.0]));
        assert!(c.outside(b, 13.0, &[9.0]));
        assert!(c.outside(b, 1.0, &[12.0]));
        assert!(!c.outside(b, 1.0, &[11.0]));
    }

    #[test]
    fn every_direction_has_one_cell_and_neighbours_differ_little() {
        for k in 0..2000 {
            let t = k as f64 * 0.37;
            let d = [
                t.sin() * (1.3 * t).cos(),
                t.cos(),
                t.sin() * (1.3 * t).sin(),
            ];
            let c = cell(d).unwrap();
            assert!((c as usize) < 6 * CELLS * CELLS);
        }
        assert_eq!(cell([0.0; 3]), None);
        assert_eq!(cell([f64::NAN, 0.0, 1.0]), None);
    }
}
