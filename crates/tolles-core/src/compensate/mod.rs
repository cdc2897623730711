//! Applying a fitted model: `compensated = uncompensated − (A·β − level)`.
//!
//! ```
//! use tolles_core::compensate::{compensate, Level};
//! use tolles_core::model::design::Design;
//! use tolles_core::model::vector::VectorSeries;
//!
//! let flux = VectorSeries::new(vec![30_000.0, 0.0], vec![0.0, 30_000.0], vec![40_000.0; 2]);
//! let design = Design::new("p".parse().unwrap());
//! let out = compensate(&[50_010.0, 50_000.0], &flux, None, &design, &[10.0, 0.0, 0.0], 1.0, Level::FileMean);
//! // A·β = [6, 0]; its mean 3 is kept in the data, the variation is removed.
//! assert_eq!(out.compensated, [50_007.0, 50_003.0]);
//! ```
//!
//! The design matrix comes from the survey's own fluxgate. Its eddy columns are changes per
//! sample, so when the survey's sample rate differs from the calibration's the eddy coefficients
//! are rescaled by `fs_survey / fs_calibration` to keep the physical eddy terms (seconds).

pub mod adapt;
pub mod align;
pub mod chunk;
pub mod stream;
pub mod trust;

use crate::model::design::Design;
use crate::model::limits::scalar_usable;
use crate::model::magnitude::{correction, Magnitude};
use crate::model::terms::Column;
use crate::model::vector::Fluxgates;
use crate::parallel::split_rows;
use crate::signal::segment::contiguous_runs;
use serde::{Deserialize, Serialize};
use std::ops::Range;

/// Which constant level of the correction is kept in the compensated data.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub enum Level {
    /// Subtract the mean of `A·β` over this data (MagNav's choice; needs the whole file).
    FileMean,
    /// Subtract the least-squares straight line (in sample index) through `A·β` over this data,
    /// MagNav's `detrend`, which also keeps a slow drift of the correction in the data.
    FileLinearTrend,
    /// Subtract this level (nT), e.g. the calibration flight's mean stored in the model, as a
    /// streaming compensator must.
    Fixed(f64),
}

/// The result of compensating one scalar.
#[derive(Debug, Clone, PartialEq)]
pub struct Compensation {
    /// Compensated scalar (nT); NaN where it cannot be computed.
    pub compensated: Vec<f64>,
    /// The removed aircraft field `A·β − level` (nT); NaN where the fluxgate is not usable.
    pub correction: Vec<f64>,
    /// The level that was subtracted from `A·β` (nT); for a linear trend, the mean of `A·β`.
    pub level_nt: f64,
    /// Samples whose compensated value is NaN.
    pub uncomputable: usize,
}

/// Compensates `scalar` (nT) with the fluxgate `flux` (nT, body frame), or several, one per
/// block of `design`.
///
/// `fs_ratio` is the survey's sample rate divided by the calibration's (1 when equal).
/// Samples with a non-finite fluxgate get no correction; runs are split there and at time gaps in
/// `tt` (seconds), so derivatives never reach across a hole.
pub fn compensate<'a>(
    scalar: &[f64],
    flux: impl Into<Fluxgates<'a>>,
    tt: Option<&[f64]>,
    design: &Design,
    coefficients: &[f64],
    fs_ratio: f64,
    level: Level,
) -> Compensation {
    compensate_model(
        scalar,
        flux,
        tt,
        Model {
            design,
            coefficients,
            magnitude: Magnitude::Linear,
        },
        fs_ratio,
        level,
    )
}

/// A fitted model to apply: its design, coefficients and magnitude model.
#[derive(Debug, Clone, Copy)]
pub struct Model<'m> {
    /// Terms and `Bt_scale`.
    pub design: &'m Design,
    /// One coefficient per column.
    pub coefficients: &'m [f64],
    /// Linear or exact (see [`crate::model::magnitude`]).
    pub magnitude: Magnitude,
}

/// [`compensate`] with any magnitude model.
pub fn compensate_model<'a>(
    scalar: &[f64],
    flux: impl Into<Fluxgates<'a>>,
    tt: Option<&[f64]>,
    model: Model<'_>,
    fs_ratio: f64,
    level: Level,
) -> Compensation {
    let correction = model_field(flux, tt, model, fs_ratio);
    with_level(scalar, correction, level)
}

/// `scalar` (nT) less its `correction` `A·β` (nT) with `level` subtracted from it, on all
/// cores.
pub fn with_level(scalar: &[f64], mut correction: Vec<f64>, level: Level) -> Compensation {
    let level_nt = match level {
        Level::Fixed(v) => v,
        Level::FileMean | Level::FileLinearTrend => finite_mean(&correction),
    };
    let subtract = match level {
        Level::FileLinearTrend => {
            correction = detrend(&correction);
            0.0
        }
        _ => level_nt,
    };
    let n = scalar.len().min(correction.len());
    correction[n..].iter_mut().for_each(|c| *c -= subtract);
    let mut compensated = vec![0.0; n];
    split_rows(
        n,
        &mut [&mut correction[..n], &mut compensated],
        |rows, parts| {
            if let [correction, compensated] = parts {
                let pairs = correction.iter_mut().zip(compensated.iter_mut());
                for ((c, out), s) in pairs.zip(&scalar[rows]) {
                    *c -= subtract;
                    *out = compensated_value(*s, *c);
                }
            }
        },
    );
    let uncomputable = compensated.iter().filter(|v| !v.is_finite()).count();
    Compensation {
        compensated,
        correction,
        level_nt,
        uncomputable,
    }
}

/// `scalar` less its `correction` `A·β − level` (nT); NaN where the correction is missing, or
/// the scalar is not usable: a corrupt scalar cell is uncomputable, not a huge number passed
/// through.
#[inline]
pub fn compensated_value(scalar: f64, correction: f64) -> f64 {
    if scalar_usable(scalar) {
        scalar - correction
    } else {
        f64::NAN
    }
}

/// `A·β` (nT) for every sample, NaN where a fluxgate is not finite.
pub fn aircraft_field<'a>(
    flux: impl Into<Fluxgates<'a>>,
    tt: Option<&[f64]>,
    design: &Design,
    coefficients: &[f64],
    fs_ratio: f64,
) -> Vec<f64> {
    let model = Model {
        design,
        coefficients,
        magnitude: Magnitude::Linear,
    };
    model_field(flux, tt, model, fs_ratio)
}

/// The model's correction (nT) for every sample, NaN where a fluxgate is not finite.
pub fn model_field<'a>(
    flux: impl Into<Fluxgates<'a>>,
    tt: Option<&[f64]>,
    model: Model<'_>,
    fs_ratio: f64,
) -> Vec<f64> {
    let flux = flux.into();
    let runs = contiguous_runs(&flux.finite_mask(), tt);
    model_field_over_runs(flux, &runs, model, fs_ratio)
}

/// [`model_field`] with its `runs` given (ascending, apart): rows outside them are NaN. A
/// part of a flight cut with one more row on each side where its runs go on gets the values of
/// its rows in the whole flight.
pub fn model_field_over_runs(
    flux: Fluxgates<'_>,
    runs: &[Range<usize>],
    model: Model<'_>,
    fs_ratio: f64,
) -> Vec<f64> {
    let beta = rescale_eddy(model.design, model.coefficients, fs_ratio);
    // Written run by run below, on all cores; only the rows between runs are set here.
    let mut field = vec![0.0; flux.len()];
    let mut after_run = 0;
    for run in runs.iter().chain([&(flux.len()..flux.len())]) {
        field[after_run..run.start].fill(f64::NAN);
        after_run = run.end;
    }
    let model = Model {
        coefficients: &beta,
        ..model
    };
    write_runs(flux, runs, model, &mut field);
    field
}

/// The model's correction (nT) of each of `runs` of `flux`, each run a series of its own,
/// written into its rows of `field` by blocks on all cores (rows between runs are left as
/// they are). The coefficients are used as given, for the sample rate they were fitted at.
pub(crate) fn write_runs(flux: Fluxgates, runs: &[Range<usize>], model: Model, field: &mut [f64]) {
    if model.magnitude == Magnitude::Exact && flux.count() == 1 {
        exact_field(flux, runs, model.design, model.coefficients, field);
        return;
    }
    for run in runs {
        let rows = &mut field[run.clone()];
        model
            .design
            .apply_over_into(flux.clone(), run.clone(), model.coefficients, rows);
    }
}

/// The exact-magnitude correction (nT) of each of the `runs` of `flux`, written into their
/// rows of `field`, by blocks on all cores.
fn exact_field(
    flux: Fluxgates,
    runs: &[Range<usize>],
    design: &Design,
    beta: &[f64],
    field: &mut [f64],
) {
    let blocks = blocks(runs, FIELD_BLOCK_ROWS);
    let block_field = |block: &Block, out: &mut [f64]| {
        let sliced = flux.slice(block.with_halo.clone());
        let part = correction(Magnitude::Exact, design, &sliced, beta);
        let skip = block.rows.start - block.with_halo.start;
        out.copy_from_slice(&part[skip..skip + block.rows.len()]);
    };
    // Each block's rows of `field`, taken in order (rows between blocks stay as they are).
    let mut outputs: Vec<(&Block, &mut [f64])> = Vec::with_capacity(blocks.len());
    let mut rest: &mut [f64] = field;
    let mut at = 0;
    for block in &blocks {
        let (_, after) = std::mem::take(&mut rest).split_at_mut(block.rows.start - at);
        let (rows, after) = after.split_at_mut(block.rows.len());
        outputs.push((block, rows));
        (rest, at) = (after, block.rows.end);
    }
    // Blocks on all cores: every row's value is the same sum as over its whole run, because
    // each block carries the neighbours its central differences need.
    let threads = crate::parallel::cores().min(blocks.len()).max(1);
    let mut shares: Vec<Vec<(&Block, &mut [f64])>> = (0..threads).map(|_| Vec::new()).collect();
    for (b, output) in outputs.into_iter().enumerate() {
        shares[b % threads].push(output);
    }
    std::thread::scope(|scope| {
        for share in shares {
            let block_field = &block_field;
            scope.spawn(move || {
                for (block, out) in share {
                    block_field(block, out);
                }
            });
        }
    });
}

/// Rows per block of [`model_field`].
const FIELD_BLOCK_ROWS: usize = 1 << 16;

/// A block of rows of one run, and the rows computed for it: one more on each side where the
/// run goes on, for the central differences at its edges.
struct Block {
    rows: Range<usize>,
    with_halo: Range<usize>,
}

/// The `runs` cut into blocks of at most `size` rows.
fn blocks(runs: &[Range<usize>], size: usize) -> Vec<Block> {
    let mut out = Vec::new();
    for run in runs {
        let mut start = run.start;
        while start < run.end {
            let end = (start + size).min(run.end);
            out.push(Block {
                rows: start..end,
                with_halo: start.saturating_sub(1).max(run.start)..(end + 1).min(run.end),
            });
            start = end;
        }
    }
    out
}

/// The coefficients with the eddy-current ones multiplied by `fs_ratio` (survey rate / calibration rate).
pub fn rescale_eddy(design: &Design, coefficients: &[f64], fs_ratio: f64) -> Vec<f64> {
    design
        .columns()
        .iter()
        .zip(coefficients)
        .map(|(c, b)| match c {
            Column::Eddy(..) | Column::EddyTraceless(_) => b * fs_ratio,
            _ => *b,
        })
        .collect()
}

/// `x` minus its least-squares straight line `a + b·k` over the sample index k, fitted to the
/// finite values (MagNav's `detrend`). Non-finite values stay as they are.
pub fn detrend(x: &[f64]) -> Vec<f64> {
    let points = || x.iter().enumerate().filter(|(_, v)| v.is_finite());
    let n = points().count() as f64;
    if n < 2.0 {
        let mean = finite_mean(x);
        return x.iter().map(|v| v - mean).collect();
    }
    let k_mean = points().map(|(k, _)| k as f64).sum::<f64>() / n;
    let x_mean = points().map(|(_, v)| *v).sum::<f64>() / n;
    let (sxy, sxx) = points().fold((0.0, 0.0), |(sxy, sxx), (k, v)| {
        let dk = k as f64 - k_mean;
        (sxy + dk * (v - x_mean), sxx + dk * dk)
    });
    let slope = sxy / sxx;
    x.iter()
        .enumerate()
        .map(|(k, v)| v - x_mean - slope * (k as f64 - k_mean))
        .collect()
}

/// Mean of the finite values (NaN if none).
pub fn finite_mean(x: &[f64]) -> f64 {
    let (sum, n) = x
        .iter()
        .filter(|v| v.is_finite())
        .fold((0.0, 0usize), |(s, n), v| (s + v, n + 1));
    if n == 0 {
        f64::NAN
    } else {
        sum / n as f64
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::vector::VectorSeries;

    fn flux4() -> VectorSeries {
        VectorSeries::new(
            vec![20_000.0, 20_100.0, f64::NAN, 19_900.0],
            vec![1_000.0, -500.0, 300.0, 0.0],
            vec![45_000.0, 44_900.0, 45_100.0, 45_050.0],
        )
    }

    /// A swinging fluxgate of `n` samples with holes at `holes`.
    fn swinging(n: usize, holes: &[usize]) -> VectorSeries {
        let angle = |k: usize| 0.3 * (k as f64 * 0.013).sin() + 0.1 * (k as f64 * 0.31).cos();
        let mut flux = VectorSeries::new(
            (0..n).map(|k| 20_000.0 * angle(k).cos()).collect(),
            (0..n).map(|k| 20_000.0 * angle(k).sin()).collect(),
            (0..n).map(|k| 45_000.0 + (k as f64 * 0.07).sin()).collect(),
        );
        holes.iter().for_each(|&k| flux.y[k] = f64::NAN);
        flux
    }

    #[test]
    fn blocks_on_all_cores_give_each_run_the_values_of_one_pass() {
        let n = 3 * FIELD_BLOCK_ROWS + 123;
        let holes = [5, FIELD_BLOCK_ROWS - 1, FIELD_BLOCK_ROWS + 1, n - 2];
        let flux = swinging(n, &holes);
        for magnitude in [Magnitude::Linear, Magnitude::Exact] {
            let design = Design::new("p,i,e".parse().unwrap());
            let beta: Vec<f64> = (0..design.width()).map(|k| 0.5 + k as f64).collect();
            let model = Model {
                design: &design,
                coefficients: &beta,
                magnitude,
            };
            let field = model_field(&flux, None, model, 1.0);
            let usable = Fluxgates::from(&flux).finite_mask();
            for run in contiguous_runs(&usable, None) {
                let whole = correction(magnitude, &design, &flux.slice(run.clone()), &beta);
                for (k, v) in run.clone().zip(whole) {
                    assert_eq!(field[k].to_bits(), v.to_bits(), "{magnitude:?} row {k}");
                }
            }
            assert!(holes.iter().all(|&k| field[k].is_nan()));
        }
    }

    #[test]
    fn holes_in_the_fluxgate_are_marked_not_dropped() {
        let design = Design::new("p,e".parse().unwrap());
        let beta = vec![1.0; design.width()];
        let out = compensate(
            &[1.0; 4],
            &flux4(),
            None,
            &design,
            &beta,
            1.0,
            Level::FileMean,
        );
        assert_eq!(out.compensated.len(), 4);
        assert!(out.compensated[2].is_nan());
        assert_eq!(out.uncomputable, 1);
    }

    #[test]
    fn a_corrupt_scalar_is_uncomputable() {
        let design = Design::new("p".parse().unwrap());
        let scalar = [50_000.0, 1e300, 50_000.0, 50_000.0];
        let out = compensate(
            &scalar,
            &flux4(),
            None,
            &design,
            &[1.0; 3],
            1.0,
            Level::Fixed(0.0),
        );
        assert!(out.compensated[1].is_nan());
        assert_eq!(out.uncomputable, 2);
    }

    #[test]
    fn fixed_level_is_subtracted_as_given() {
        let design = Design::new("b".parse().unwrap());
        let out = compensate(
            &[5.0; 4],
            &flux4(),
            None,
            &design,
            &[2.0],
            1.0,
            Level::Fixed(0.5),
        );
        assert_eq!(out.correction[0], 1.5);
        assert_eq!(out.compensated[0], 3.5);
    }

    #[test]
    fn detrend_removes_a_line_exactly() {
        let x: Vec<f64> = (0..10).map(|k| 3.0 + 0.5 * k as f64).collect();
        assert!(detrend(&x).iter().all(|v| v.abs() < 1e-12));
        let with_hole = [1.0, f64::NAN, 3.0, 4.0];
        let d = detrend(&with_hole);
        assert!(d[1].is_nan() && d[0].abs() < 1e-12 && d[3].abs() < 1e-12);
    }

    #[test]
    fn eddy_coefficients_scale_with_the_sample_rate() {
        let design = Design::new("e3".parse().unwrap());
        let flux = VectorSeries::new(
            (0..20).map(|k| 20_000.0 + 10.0 * k as f64).collect(),
            vec![0.0; 20],
            vec![45_000.0; 20],
        );
        // Twice the sample rate halves the change per sample; doubling β keeps the field.
        let slow = aircraft_field(&flux, None, &design, &[100.0, 0.0, 0.0], 1.0);
        let fast = aircraft_field(&flux, None, &design, &[50.0, 0.0, 0.0], 2.0);
        assert!((slow[5] - fast[5]).abs() < 1e-12);
    }
}
