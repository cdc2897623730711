//! Per row of a compensated flight: the correction's standard error and whether the row lies
//! outside what the calibration spanned.
//!
//! ```
//! use tolles_core::compensate::trust::{outside_over_runs, sigma_over_runs};
//! use tolles_core::fit::trust::Uncertainty;
//! use tolles_core::model::coverage::Coverage;
//! use tolles_core::model::design::Design;
//! use tolles_core::model::vector::{Fluxgates, VectorSeries};
//!
//! let flux = VectorSeries::new(vec![50_000.0; 4], vec![0.0; 4], vec![0.0; 4]);
//! let design = Design::new("p".parse().unwrap());
//! // 2 nT of uncertainty on the permanent field along x, none on the others.
//! let uncertainty = Uncertainty {
//!     covariance: vec![4.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
//!     mean_row: vec![0.0; 3],
//!     noise_nt: 0.0,
//! };
//! let sigma = sigma_over_runs(Fluxgates::from(&flux), &[0..4], &design, &uncertainty, 1.0);
//! assert!((sigma[0] - 2.0).abs() < 1e-12); // B̂ = x: the x term's error is all of it
//! let coverage = Coverage::of(&flux, &[0..4], 10.0, &[]);
//! let across = VectorSeries::new(vec![0.0; 4], vec![50_000.0; 4], vec![0.0; 4]);
//! let flags = outside_over_runs(Fluxgates::from(&across), &[0..4], &coverage, 10.0);
//! assert_eq!(flags, [true; 4]);
//! ```
//!
//! The standard error is `√((a − ā)ᵀ Σ (a − ā))` for the unfiltered design row `a` (the
//! linear model's: for an exact model, its first-order part), the calibration's mean row `ā`
//! and the coefficients' posterior covariance `Σ` ([`crate::model::uncertainty::Uncertainty`]): the
//! error of the correction relative to the calibration's mean level, which is what remains once
//! a level is subtracted. It does not include the scalar's own noise, nor fields outside the
//! model (an unmodelled current, the earth's anomalies scaled by an isotropic induced term):
//! compensation adds what the fit left ([`Uncertainty::noise_nt`]) for the compensated value's.

use crate::model::coverage::Coverage;
use crate::model::design::{central_difference, Design};
use crate::model::terms::Column;
use crate::model::uncertainty::Uncertainty;
use crate::model::vector::Fluxgates;
use crate::parallel::split_rows;
use std::ops::Range;

/// The standard error (nT) of the correction at every sample of `flux`'s `runs` (NaN outside
/// them), on all cores, for a survey sampled `fs_ratio` times as fast as the calibration (an
/// eddy-current column, a change per sample, is then `1/fs_ratio` of the calibration's).
pub fn sigma_over_runs(
    flux: Fluxgates,
    runs: &[Range<usize>],
    design: &Design,
    uncertainty: &Uncertainty,
    fs_ratio: f64,
) -> Vec<f64> {
    let mut sigma = vec![f64::NAN; flux.len()];
    let columns = design.columns();
    let eddy: Vec<bool> = columns
        .iter()
        .map(|c| matches!(c, Column::Eddy(..) | Column::EddyTraceless(_)))
        .collect();
    for run in runs {
        let series = flux.series()[0];
        let rate = [&series.x, &series.y, &series.z].map(|c| central_difference(&c[run.clone()]));
        split_rows(run.len(), &mut [&mut sigma[run.clone()]], |rows, out| {
            let mut row = vec![0.0; columns.len()];
            let mut extras = vec![0.0; flux.extras().len()];
            for (i, s) in rows.clone().zip(out[0].iter_mut()) {
                let k = run.start + i;
                extras
                    .iter_mut()
                    .zip(flux.extras())
                    .for_each(|(e, c)| *e = c[k]);
                let db = [rate[0][i], rate[1][i], rate[2][i]];
                design.row_with_extras(&columns, series.at(k), db, &extras, &mut row);
                row.iter_mut()
                    .zip(&eddy)
                    .filter(|(_, e)| **e)
                    .for_each(|(a, _)| *a *= fs_ratio);
                *s = uncertainty.sigma(&row);
            }
        });
    }
    sigma
}

/// Whether each sample of `flux`'s `runs` lies outside `coverage` (rates at `fs_hz`, by
/// central differences within the run, as the fit took them); `false` outside the runs, where
/// nothing is compensated.
pub fn outside_over_runs(
    flux: Fluxgates,
    runs: &[Range<usize>],
    coverage: &Coverage,
    fs_hz: f64,
) -> Vec<bool> {
    let mut flags = vec![0.0; flux.len()];
    let series = flux.series()[0];
    for run in runs {
        split_rows(run.len(), &mut [&mut flags[run.clone()]], |rows, out| {
            let mut extras = vec![0.0; flux.extras().len()];
            for (i, f) in rows.clone().zip(out[0].iter_mut()) {
                let k = run.start + i;
                extras
                    .iter_mut()
                    .zip(flux.extras())
                    .for_each(|(e, c)| *e = c[k]);
                let rate = crate::model::coverage::rate_at(series, run, k) * fs_hz;
                *f = f64::from(u8::from(coverage.outside(series.at(k), rate, &extras)));
            }
        });
    }
    flags.into_iter().map(|f| f > 0.0).collect()
}
