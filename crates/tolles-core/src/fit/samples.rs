//! The samples a fit uses: per sample, whether the scalar and every fluxgate are usable, and the
//! runs of usable samples, split at gaps in time (s).

use crate::model::limits::scalar_usable;
use crate::model::vector::Fluxgates;
use crate::signal::segment::contiguous_runs;
use std::ops::Range;

/// The samples a fit uses and their runs, worked out once per flight: a fluxgate calibration
/// within a fit ([`crate::fit::levels`]) takes the fit's, rather than checking and scanning 10⁷ samples
/// again (0.1 s).
#[derive(Debug, Clone)]
pub(super) struct Samples {
    /// Per sample: every fluxgate finite and the scalar believable ([`scalar_usable`]).
    pub(super) usable: Vec<bool>,
    /// Maximal runs of usable samples, split at gaps in time
    /// ([`crate::signal::segment::contiguous_runs`]).
    pub(super) runs: Vec<Range<usize>>,
}

impl Samples {
    /// The usable samples of `scalar` (nT) and `flux` (as long as it, checked) and their runs,
    /// split at gaps in `tt` (s).
    pub(super) fn of(scalar: &[f64], flux: &Fluxgates, tt: Option<&[f64]>) -> Self {
        let mut usable = flux.finite_mask();
        crate::parallel::split_items(&mut usable, |rows, usable| {
            usable
                .iter_mut()
                .zip(&scalar[rows])
                .for_each(|(u, s)| *u &= scalar_usable(*s));
        });
        Self::within(usable, tt)
    }

    /// The runs of the samples `usable`, split at gaps in `tt` (s).
    pub(super) fn within(usable: Vec<bool>, tt: Option<&[f64]>) -> Self {
        let runs = contiguous_runs(&usable, tt);
        Self { usable, runs }
    }
}
