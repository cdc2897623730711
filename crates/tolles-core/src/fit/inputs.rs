//! What a fit refuses before it starts: inputs of unequal length, rates and settings out of
//! range, a fluxgate of impossible magnitude, a flight with nothing that varies.

use super::error::FitError;
use super::settings::{FitSettings, Lambda};
use crate::model::limits::{scalar_usable, FLUX_MAGNITUDE_RANGE_NT};
use crate::model::vector::{Fluxgates, VectorSeries};
use std::ops::Range;

pub(super) fn check_inputs(
    scalar: &[f64],
    flux: &Fluxgates,
    fs_hz: f64,
    settings: &FitSettings,
) -> Result<(), FitError> {
    if flux.count() != settings.design.fluxgates {
        return Err(FitError::FluxgateCount {
            design: settings.design.fluxgates,
            given: flux.count(),
        });
    }
    if flux.extras().len() != settings.design.extras.len() {
        return Err(FitError::ExtraCount {
            design: settings.design.extras.len(),
            given: flux.extras().len(),
        });
    }
    if let Some(channel) = (0..flux.extras().len()).find(|&c| flux.extras()[c].len() != flux.len())
    {
        return Err(FitError::ExtraLength {
            channel,
            samples: flux.extras()[channel].len(),
            first: flux.len(),
        });
    }
    if let Some(fluxgate) = (0..flux.count()).find(|&f| flux.series()[f].len() != flux.len()) {
        return Err(FitError::FluxgateLength {
            fluxgate,
            samples: flux.series()[fluxgate].len(),
            first: flux.len(),
        });
    }
    if scalar.len() != flux.len() {
        return Err(FitError::LengthMismatch {
            scalar: scalar.len(),
            flux: flux.len(),
        });
    }
    if !(fs_hz.is_finite() && fs_hz > 0.0) {
        return Err(FitError::SampleRate(fs_hz));
    }
    match settings.lambda {
        Lambda::Fixed(l) if !(l.is_finite() && l >= 0.0) => return Err(FitError::Lambda(l)),
        Lambda::CrossValidated { folds } if folds < 2 => return Err(FitError::Folds(folds)),
        _ => {}
    }
    check_flux_magnitude(flux.clone())
}

/// Rejects fluxgates whose samples have a magnitude outside [`FLUX_MAGNITUDE_RANGE_NT`];
/// reports the first such sample. NaN (a missing component) is not checked here: such samples
/// are skipped as uncomputable. An infinite component is rejected like any other absurd value,
/// so a corrupt cell can never reach the arithmetic.
pub fn check_flux_magnitude<'a>(flux: impl Into<Fluxgates<'a>>) -> Result<(), FitError> {
    let (lo, hi) = FLUX_MAGNITUDE_RANGE_NT;
    for (fluxgate, series) in flux.into().series().iter().enumerate() {
        // A block whose every sum of squares lies strictly between lo² and hi² (both exact)
        // has every magnitude in range, because a rounded square root keeps the order; only
        // a block with any other sample (NaN included) is looked at sample by sample.
        let inside = |k: usize| {
            let squares =
                series.x[k] * series.x[k] + series.y[k] * series.y[k] + series.z[k] * series.z[k];
            squares > lo * lo && squares < hi * hi
        };
        let first_outside = |part: Range<usize>| {
            crate::parallel::blocks(part, MAGNITUDE_BLOCK)
                .filter(|block| !block.clone().fold(true, |all, k| all & inside(k)))
                .flat_map(|block| block.map(|k| (k, series.magnitude(k))))
                .find(|(_, m)| !m.is_nan() && !(lo..=hi).contains(m))
        };
        // A part per core; the first sample outside is the first part's that has one.
        let found = crate::parallel::map_parts(series.len(), MAGNITUDE_BLOCK, first_outside);
        if let Some((index, magnitude)) = found.into_iter().flatten().next() {
            return Err(FitError::FluxMagnitude {
                fluxgate,
                index,
                magnitude,
            });
        }
    }
    Ok(())
}

/// Samples [`check_flux_magnitude`] checks at once.
pub(super) const MAGNITUDE_BLOCK: usize = 1024;

pub(crate) fn check_not_constant(
    scalar: &[f64],
    flux: &VectorSeries,
    usable: &[bool],
) -> Result<(), FitError> {
    let varies = |x: &[f64]| {
        let mut values = x.iter().zip(usable).filter(|(_, u)| **u).map(|(v, _)| *v);
        let first = values.next();
        first.is_some_and(|f| values.any(|v| v != f))
    };
    if !usable.iter().any(|u| *u) {
        return Err(FitError::NothingUsable(never_usable(scalar, flux)));
    }
    if !varies(scalar) {
        return Err(FitError::ConstantScalar);
    }
    if !(varies(&flux.x) || varies(&flux.y) || varies(&flux.z)) {
        return Err(FitError::ConstantFlux);
    }
    Ok(())
}

/// Which input (scalar, or the first fluxgate's x/y/z component) has no usable value at all,
/// so a file with one empty column is not reported as "constant".
pub(super) fn never_usable(scalar: &[f64], flux: &VectorSeries) -> String {
    if !scalar.iter().any(|v| scalar_usable(*v)) {
        return "the scalar".to_string();
    }
    let empty = |c: &[f64]| !c.iter().any(|v| v.is_finite());
    for (axis, c) in [("x", &flux.x), ("y", &flux.y), ("z", &flux.z)] {
        if empty(c) {
            return format!("fluxgate component {axis}");
        }
    }
    "one input or another".to_string()
}
