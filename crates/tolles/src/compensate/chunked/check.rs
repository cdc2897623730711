//! What pass 1 found, checked fit by fit in the order the whole-file path meets it, so that
//! both paths fail with the same error and warn the same way before it.

use super::scan::{clone_error, FitColumns, Plan, Scan};
use crate::error::{Error, Result};
use crate::model::{ModelFile, ScalarModel};
use crate::read::sample_rate_from;
use crate::warning::Warning;
use std::path::Path;
use tolles_core::compensate::Model;
use tolles_core::model::coverage::Coverage;
use tolles_core::model::design::Design;
use tolles_core::model::magnitude::Magnitude;
use tolles_io::IoError;

/// One fit, checked and ready to compute.
pub(super) struct ReadyFit {
    /// The compensated column the model names (before any renaming).
    pub output: String,
    design: Design,
    coefficients: Vec<f64>,
    /// Linear or exact (see `tolles_core::model::magnitude`).
    model_magnitude: Magnitude,
    /// The survey's sample rate / the calibration flight's.
    pub fs_ratio: f64,
    /// The calibration flight's mean `A·β` stored in the model (nT).
    pub model_level_nt: f64,
    /// A given sample rate far from the time column's.
    pub rate_warning: Option<Warning>,
    /// The model's verdict when it is not good.
    pub verdict: Option<Warning>,
    /// What the calibration flew, to count the rows outside it.
    pub coverage: Option<Coverage>,
    /// The survey's sample rate (Hz).
    pub fs_hz: f64,
    /// The fluxgate's lag (s).
    pub lag_s: f64,
    /// The fluxgate's offset (nT) the model takes out of its readings.
    pub flux_offset_nt: Option<[f64; 3]>,
    /// The network added to the linear correction, if any.
    pub network: Option<tolles_core::model::network::Network>,
}

impl ReadyFit {
    /// The fitted model, its coefficients for the calibration flight's sample rate.
    pub fn model(&self) -> Model<'_> {
        Model {
            design: &self.design,
            coefficients: &self.coefficients,
            magnitude: self.model_magnitude,
        }
    }
}

/// Checks the fits of `model` in order: per fit its scalar, its fluxgate's x, y, z, the time
/// column, its extra channels, the fluxgate's magnitude, then the sample rate (`fs_hz` if given, Hz). Returns the
/// fits before the first that fails, and its error.
pub(super) fn check_in_order(
    survey: &Path,
    plan: &Plan,
    scan: &Scan,
    model: &ModelFile,
    fs_hz: Option<f64>,
) -> (Vec<ReadyFit>, Option<Error>) {
    let mut ready = Vec::new();
    for (fit, columns) in model.fits.iter().zip(&plan.fits) {
        match check_fit(survey, plan, scan, fit, columns, fs_hz) {
            Ok(f) => ready.push(f),
            Err(e) => return (ready, Some(e)),
        }
    }
    (ready, None)
}

fn check_fit(
    survey: &Path,
    plan: &Plan,
    scan: &Scan,
    fit: &ScalarModel,
    columns: &FitColumns,
    fs_hz: Option<f64>,
) -> Result<ReadyFit> {
    let column = |position: &Result<usize, IoError>| -> Result<()> {
        let found = position.as_ref().map_err(clone_error)?;
        match &scan.bad_cell[*found] {
            Some(e) => Err(clone_error(e).into()),
            None => Ok(()),
        }
    };
    column(&columns.scalar)?;
    let (vector, axes) = &plan.fluxgates[columns.fluxgate];
    axes.iter().try_for_each(column)?;
    if let Some(p) = plan.tt {
        column(&Ok(p))?;
    }
    columns.extras.iter().try_for_each(column)?;
    columns.network.iter().try_for_each(column)?;
    if let Some((place, magnitude)) = &scan.bad_magnitude[columns.fluxgate] {
        return Err(Error::FluxMagnitude {
            path: survey.to_path_buf(),
            place: place.clone(),
            vector: vector.clone(),
            magnitude: *magnitude,
        });
    }
    // Chunked formats carry no `dt` scalar: the rate comes from the time column or is given.
    let (fs_hz, rate_warning) = match (fs_hz, plan.tt) {
        (None, None) => (fit.fit.fs_hz, None),
        (fs, _) => sample_rate_from(survey, None, scan.sampling_step, fs)?,
    };
    Ok(ReadyFit {
        output: fit.output_column.clone(),
        design: fit.fit.settings.design.clone(),
        coefficients: fit.fit.coefficients.clone(),
        model_magnitude: fit.fit.magnitude,
        fs_ratio: fs_hz / fit.fit.fs_hz,
        model_level_nt: fit.fit.level_nt,
        rate_warning,
        verdict: crate::fit::verdict_warning(&fit.scalar, &fit.fit),
        coverage: fit.fit.coverage.clone(),
        fs_hz,
        lag_s: fit.fit.lag_s,
        flux_offset_nt: fit.fit.flux_offset_nt,
        network: fit.network.as_ref().map(|learned| learned.network.clone()),
    })
}
