//! Heading levels: the low frequencies a band-passed fit throws away.
//!
//! Band-passing the scalar removes the earth field's slow changes, and with them every
//! difference of level between headings. Some combinations of terms (the patent's T with TV+VT,
//! L with LV+VL, V with VV−TT and VV−LL) look alike inside the band on every heading but leave
//! different levels at DC, hundreds of nT for a strong installation. A calibration box flown on
//! four headings carries those levels.
//!
//! To read them we need the earth field's magnitude at low frequencies without the aircraft.
//! The fluxgate gives it once it is calibrated: its magnitude `|F| ≈ |B| + B̂·o + B̂ᵀK·B` moves
//! with attitude only through its own offset `o` and distortion `K`, which are fitted like a
//! permanent and (traceless) induced field against the band-passed `|F|` itself. The calibrated
//! magnitude `R` is then an earth-field reference: `y − R` is the aircraft's field at every
//! frequency, geology, diurnal variation and IGRF cancelling.
//!
//! The fit adds, to the band-passed rows, low-passed (below the band's lower edge) rows of
//! `y − R` against the low-passed design, one every `fs/(2·f_low)` samples so they are nearly
//! independent, centred (the constant between `y` and `R` is unknown) and weighted by the ratio
//! of the band-passed residual's scatter to theirs.
//!
//! The calibration's columns are combinations of the columns a default fit fills anyway, so
//! such a fit calibrates the fluxgate from its own band-passed rows (`InPass`): the magnitude
//! is one more signal of the same pass, and the level rows' target is `y − |F|` until the
//! calibration's correction, low-passed with the columns, joins it. Other fits calibrate in a
//! pass of their own first ([`reference()`]); both give the same calibration, to rounding.

use crate::fit::basis::diagonal_parts;
use crate::fit::choice::choose_design;
use crate::fit::diagnostics::band_residual_std;
use crate::fit::factor::FoldFactor;
use crate::fit::inputs::check_not_constant;
use crate::fit::level_rows::combination;
use crate::fit::prior::{Prior, PriorWeights};
use crate::fit::samples::Samples;
use crate::fit::settings::{FitSettings, Lambda};
use crate::fit::spare::Spare;
use crate::model::design::{Design, Term};
use crate::model::terms::TermSet;
use crate::model::vector::{norms3_into, VectorSeries};
use crate::parallel::split_rows;
use crate::signal::filter::Band;
use crate::signal::filter::{
    filtfilt_many_unless_constant, filtfilt_sampled_then_in_place,
    filtfilt_sampled_unless_constant, Butterworth, FilterError,
};
use nalgebra::DMatrix;
use std::ops::Range;

// Public here, where they were first: the level rows and the calibration's diagnostics are
// defined in modules of their own, and the calibration ([`reference()`]) is a fit, made where
// fits are.
pub use crate::fit::level_rows::{centre, rms_misfit, LevelRows};
pub use crate::fit::outcome::{FluxgateCalibration, LevelDiagnostics};
pub use crate::fit::run::reference;

/// The calibrated fluxgate magnitude used as an earth-field reference.
#[derive(Debug, Clone, PartialEq)]
pub struct Reference {
    /// `|F|` with the fluxgate's fitted offset and distortion removed (nT); NaN where unusable.
    pub values: Vec<f64>,
    /// What the calibration found.
    pub calibration: FluxgateCalibration,
}

/// Largest believable fluxgate offset (nT): beyond it the calibration has fitted something else
/// (too little attitude change to tell the terms apart) and is not used. A fluxgate in a cabin
/// sees the aircraft's permanent field, thousands of nT on real boxes (deinterf's SGL box: 1100
/// to 5600 nT), so the bound is the aircraft's own ([`crate::fit::plausible::MAX_PERMANENT_NT`]);
/// levels the calibration then misses are not trusted (`problem::UNTRUSTED_LEVELS_NT`).
pub const MAX_OFFSET_NT: f64 = crate::fit::plausible::MAX_PERMANENT_NT;

/// Largest believable distortion (dimensionless), likewise.
pub const MAX_DISTORTION: f64 = 0.05;

/// The prior of a fluxgate calibration within a fit of `settings`: the fluxgate's own, when the
/// fit has one.
pub(super) fn calibration_prior(settings: &FitSettings) -> Option<Prior> {
    settings.prior.map(|_| Prior::FLUXGATE)
}

/// The design of the fluxgate's calibration: a permanent and a traceless induced field.
pub(super) fn calibration_design() -> Design {
    Design::new(TermSet {
        permanent: true,
        induced: Some(crate::model::terms::InducedTerms::Traceless),
        trace: false,
        eddy: None,
        bias: false,
    })
}

/// `|F|` of every sample of `flux` (nT), NaN where not `usable`.
pub(super) fn magnitude_of(flux: &VectorSeries, usable: &[bool]) -> Vec<f64> {
    let mut magnitude = vec![0.0; flux.len()];
    split_rows(flux.len(), &mut [&mut magnitude], |rows, out| {
        let components = [&flux.x, &flux.y, &flux.z].map(|c| &c[rows.clone()]);
        norms3_into(components, out[0]);
        for (m, u) in out[0].iter_mut().zip(&usable[rows]) {
            if !u {
                *m = f64::NAN;
            }
        }
    });
    magnitude
}

/// What a calibration fit found: its coefficients (the calibration design's) and the scatter
/// of its band-passed residual (nT).
pub(super) struct Calibrated {
    pub(super) coefficients: Vec<f64>,
    pub(super) residual_std_nt: f64,
}

/// The reference of the calibration `fitted`: `magnitude` (of every sample, NaN where not
/// usable, taken over) less its calibrated correction; `None` if the calibration is not
/// believable.
pub(super) fn reference_of(
    flux: &VectorSeries,
    samples: &Samples,
    mut magnitude: Vec<f64>,
    design: &Design,
    fitted: &Calibrated,
    spare: &Spare,
) -> Option<Reference> {
    let c = &fitted.coefficients;
    let believable = c[..3].iter().all(|o| o.abs() <= MAX_OFFSET_NT)
        && c[3..]
            .iter()
            .all(|k| (k / design.bt_scale).abs() <= MAX_DISTORTION);
    if !believable {
        return None;
    }
    // The correction goes into a spare buffer, and the calibrated magnitude in place of the
    // magnitude: no fresh vector of the flight's length. Outside the runs (the unusable
    // samples) the magnitude is NaN already.
    let n = flux.len();
    let mut correction = spare.take(n);
    for run in &samples.runs {
        design.apply_over_into(flux, run.clone(), c, &mut correction[run.clone()]);
    }
    split_rows(n, &mut [&mut magnitude], |rows, out| {
        for ((m, v), u) in out[0]
            .iter_mut()
            .zip(&correction[rows.clone()])
            .zip(&samples.usable[rows])
        {
            if *u {
                *m -= v;
            }
        }
    });
    spare.give([correction]);
    Some(Reference {
        values: magnitude,
        calibration: FluxgateCalibration {
            offset_nt: [c[0], c[1], c[2]],
            distortion: std::array::from_fn(|k| c[3 + k] / design.bt_scale),
            residual_std_nt: fitted.residual_std_nt,
        },
    })
}

/// The fluxgate's calibration fitted from the linear fit's own band rows rather than in a pass
/// of its own: its columns (permanent and traceless induced) are combinations of the linear
/// fit's stored columns, and the magnitude rides along as one more column after them, so the
/// band-passed rows of both fits come from one fill, one band-pass and one factorisation (a
/// filter is linear, and `R·T` is a factor of the columns `A·T`).
pub(super) struct InPass {
    design: Design,
    terms: Vec<Term>,
    /// The calibration's prior on its terms, as a calibration in a pass of its own has it.
    prior: Option<PriorWeights>,
    /// Sample rate (Hz).
    fs_hz: f64,
    /// Rows: the stored columns, the target, the magnitude; columns: the calibration's terms,
    /// then the magnitude as their target.
    map: DMatrix<f64>,
}

impl InPass {
    /// The calibration in the pass of the linear fit whose stored columns are `stored`, when
    /// its columns are among their combinations (the same `Bt_scale`, one fluxgate, no rows
    /// above the band, which the calibration would not have).
    pub(super) fn of(
        settings: &FitSettings,
        stored: &[Term],
        above_band: bool,
        fs_hz: f64,
    ) -> Option<Self> {
        let design = calibration_design();
        if above_band
            || settings.design.fluxgates != 1
            || settings.design.bt_scale != design.bt_scale
        {
            return None;
        }
        let terms = design.design_terms();
        let width = stored.len();
        let mut map = DMatrix::zeros(width + 2, terms.len() + 1);
        for (j, term) in terms.iter().enumerate() {
            for (i, w) in parts_among(term, stored)? {
                map[(i, j)] = w;
            }
        }
        map[(width + 1, terms.len())] = 1.0;
        let prior = FitSettings {
            design: design.clone(),
            lambda: Lambda::auto(),
            prior: calibration_prior(settings),
            ..settings.clone()
        }
        .prior_weights(&terms, fs_hz);
        Some(Self {
            design,
            terms,
            prior,
            fs_hz,
            map,
        })
    }

    /// The reference from the fold factors `folds` of the linear fit's band rows (of its stored
    /// columns, its target and the magnitude, folded as the calibration fit folds them), and
    /// the calibration's coefficients; `None` as [`reference()`] gives it.
    pub(super) fn reference(
        &self,
        flux: &VectorSeries,
        samples: &Samples,
        folds: &[FoldFactor],
        spare: &Spare,
    ) -> Option<(Reference, Vec<f64>)> {
        let magnitude = magnitude_of(flux, &samples.usable);
        check_not_constant(&magnitude, flux, &samples.usable).ok()?;
        let fitted = self.fit(folds)?;
        let reference = reference_of(flux, samples, magnitude, &self.design, &fitted, spare)?;
        Some((reference, fitted.coefficients))
    }

    /// The calibration fit on the calibration's columns of `folds`, as
    /// [`crate::fit::fit_reusing`] makes it: λ cross-validated, no level rows.
    fn fit(&self, folds: &[FoldFactor]) -> Option<Calibrated> {
        let folds: Vec<FoldFactor> = folds
            .iter()
            .map(|f| FoldFactor {
                r: &f.r * &self.map,
                rows: f.rows,
                level_r: DMatrix::zeros(0, self.map.ncols()),
                level_rows: 0,
            })
            .collect();
        let designs = [self.design.clone()];
        let prior = self.prior.as_ref();
        let chosen = choose_design(
            &folds,
            &designs,
            &self.terms,
            Lambda::auto(),
            0.0,
            prior,
            self.fs_hz,
        )
        .ok()?;
        let solution = &chosen.solution;
        let residual_std_nt = band_residual_std(solution, 0, 0.0);
        let finite = solution.coefficients.iter().all(|c| c.is_finite());
        (finite && residual_std_nt.is_finite()).then(|| Calibrated {
            coefficients: solution.coefficients.clone(),
            residual_std_nt,
        })
    }

    /// Level rows of the stored columns (`A`) whose target is the scalar less the fluxgate's
    /// magnitude, `y − m`: their target becomes `y − R` for the reference
    /// `R = m − A·c`, all low-passed alike, `c` the calibration's `coefficients`.
    pub(super) fn subtract_reference(&self, rows: &mut [LevelRows], coefficients: &[f64]) {
        let width = self.map.nrows() - 2;
        // The calibration's correction as a combination of the stored columns.
        let on_stored: Vec<f64> = (0..width)
            .map(|i| {
                (0..self.terms.len())
                    .map(|j| self.map[(i, j)] * coefficients[j])
                    .sum()
            })
            .collect();
        for r in rows {
            let LevelRows { a, y, .. } = r;
            crate::parallel::split_items(y, |part, y| {
                let correction = combination(a, &on_stored, part);
                y.iter_mut().zip(&correction).for_each(|(y, c)| *y += c);
            });
        }
    }
}

/// The stored columns (their positions among `stored`) and weights that make `term`'s column:
/// its own, or the parts it is formed of as [`Basis`](crate::fit::basis::Basis) forms it.
fn parts_among(term: &Term, stored: &[Term]) -> Option<Vec<(usize, f64)>> {
    let position = |t: &Term| stored.iter().position(|s| s == t);
    if let Some(i) = position(term) {
        return Some(vec![(i, 1.0)]);
    }
    diagonal_parts(term, stored)?
        .into_iter()
        .map(|(part, w)| position(&part).map(|i| (i, w)))
        .collect()
}

/// The low-pass filter and decimation of the level rows.
#[derive(Debug, Clone)]
pub struct LowFrequency {
    filter: Butterworth,
    /// Cut-off (Hz).
    pub cutoff_hz: f64,
    /// One row every this many samples.
    pub step: usize,
    /// Samples dropped at each end of a run.
    pub trim: usize,
}

impl LowFrequency {
    /// Low-pass below the fit band's lower edge; `None` when the band has none (the fit then
    /// already sees the low frequencies).
    pub fn new(
        band: Band,
        order: usize,
        trim: usize,
        fs_hz: f64,
    ) -> Result<Option<Self>, FilterError> {
        let cutoff_hz = band.pass1_hz;
        if !(cutoff_hz > 0.0 && cutoff_hz < fs_hz / 2.0) {
            return Ok(None);
        }
        let low = Band {
            pass1_hz: 0.0,
            pass2_hz: cutoff_hz,
        };
        let Some(filter) = low.butterworth(order, fs_hz)? else {
            return Ok(None);
        };
        let step = ((fs_hz / (2.0 * cutoff_hz)).round() as usize).max(1);
        Ok(Some(Self {
            filter,
            cutoff_hz,
            step,
            trim: trim.max(step),
        }))
    }

    /// Low-passes the columns of `a` and the target `y` of one run (unfiltered, `a` has one row
    /// per sample) and keeps every `step`-th row after trimming; no rows if the run is too short.
    pub fn rows(&self, a: DMatrix<f64>, y: Vec<f64>) -> Result<LevelRows, FilterError> {
        let n = y.len();
        let columns: Vec<&[f64]> = a.as_slice().chunks_exact(n.max(1)).collect();
        self.rows_of(&columns[..a.ncols().min(columns.len())], &y)
    }

    /// [`LowFrequency::rows`] of columns given one by one (each as long as `y`), left as they
    /// are: only the kept samples of their low-passed versions are ever written.
    pub fn rows_of(&self, columns: &[&[f64]], y: &[f64]) -> Result<LevelRows, FilterError> {
        self.rows_against(columns, y, None, &mut [])
    }

    /// [`LowFrequency::rows_of`] with the target `y − reference` (nT) when a reference is
    /// given, formed in `target` (as long as `y`).
    pub(super) fn rows_against(
        &self,
        columns: &[&[f64]],
        y: &[f64],
        reference: Option<&[f64]>,
        target: &mut [f64],
    ) -> Result<LevelRows, FilterError> {
        let Some(keep) = self.kept(y.len()) else {
            return Ok(LevelRows::none(columns.len()));
        };
        let y = match reference {
            Some(r) => {
                difference_on_all_cores(y, r, target);
                &*target
            }
            None => y,
        };
        let signals: Vec<&[f64]> = columns.iter().copied().chain([y]).collect();
        let sampled = filtfilt_sampled_unless_constant(&self.filter, &signals, &keep)?;
        Ok(LevelRows::from_sampled(sampled, keep))
    }

    /// [`LowFrequency::rows_against`] of a run's `signals` (its columns, then its target `y`)
    /// and `reference`, and then `band` of every one of `signals` in place, as
    /// [`filtfilt_many_unless_constant`] does: both filters' work shared among the cores at
    /// once ([`filtfilt_sampled_then_in_place`]), with the same values as one after the other.
    pub(crate) fn rows_against_then_band(
        &self,
        signals: &mut [&mut [f64]],
        reference: &[f64],
        target: &mut [f64],
        band: &Butterworth,
    ) -> Result<LevelRows, FilterError> {
        let width = signals.len() - 1;
        let Some(keep) = self.kept(signals[width].len()) else {
            filtfilt_many_unless_constant(band, signals)?;
            return Ok(LevelRows::none(width));
        };
        difference_on_all_cores(&signals[width][..], reference, target);
        let sampled = filtfilt_sampled_then_in_place(&self.filter, &keep, target, band, signals)?;
        Ok(LevelRows::from_sampled(sampled, keep))
    }

    /// The low-pass.
    pub(super) fn filter(&self) -> &Butterworth {
        &self.filter
    }

    /// The samples of a run of `n` that give level rows; `None` if it is too short for any.
    pub(super) fn kept(&self, n: usize) -> Option<Vec<usize>> {
        if n <= self.filter.padlen() + 1 || n <= 2 * self.trim + self.step {
            return None;
        }
        Some((self.trim..n - self.trim).step_by(self.step).collect())
    }
}

/// `out = y − r`, by rows on all cores: a new buffer's pages are faulted in as it is written.
fn difference_on_all_cores(y: &[f64], r: &[f64], out: &mut [f64]) {
    split_rows(y.len(), &mut [out], |rows, parts| {
        let (y, r) = (&y[rows.clone()], &r[rows]);
        for ((o, y), r) in parts[0].iter_mut().zip(y).zip(r) {
            *o = y - r;
        }
    });
}

/// The reference's values over `run`.
pub fn reference_over(reference: &Reference, run: Range<usize>) -> &[f64] {
    &reference.values[run]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_sample_the_fluxgate_lacks_is_not_usable_whatever_the_mask_says() {
        use crate::flight::plan::BoxPlan;
        use crate::flight::sim::{simulate, Installation};
        let mut flight = simulate(
            &BoxPlan::default().build(),
            &Installation::TailStinger.scenario(3),
        )
        .unwrap();
        let n = flight.flux.len();
        flight.flux.x[n / 2] = f64::NAN;
        let settings = FitSettings::recommended();
        let tt = Some(flight.tt.as_slice());
        let mut without = vec![true; n];
        without[n / 2] = false;
        let told = reference(&flight.flux, &without, 10.0, tt, &settings).unwrap();
        let all = reference(&flight.flux, &vec![true; n], 10.0, tt, &settings).unwrap();
        let bits = |r: &Reference| r.values.iter().map(|v| v.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(&all), bits(&told));
        assert!(all.values[n / 2].is_nan());
    }

    #[test]
    fn the_reference_is_the_calibrated_magnitude_on_usable_samples_and_nan_elsewhere() {
        use crate::flight::plan::BoxPlan;
        use crate::flight::sim::{simulate, Installation};
        let flight = simulate(
            &BoxPlan::default().build(),
            &Installation::TailStinger.scenario(3),
        )
        .unwrap();
        let flux = &flight.flux;
        let n = flux.len();
        let mut usable = vec![true; n];
        usable[n / 3..n / 3 + 50].fill(false);
        let settings = FitSettings::recommended();
        let r = reference(flux, &usable, 10.0, Some(&flight.tt), &settings).unwrap();
        let design = Design::new("p,it".parse().unwrap());
        let c = &r.calibration;
        let beta: Vec<f64> = c
            .offset_nt
            .iter()
            .copied()
            .chain(c.distortion.iter().map(|d| d * design.bt_scale))
            .collect();
        for run in [0..n / 3, n / 3 + 50..n] {
            let correction = design.apply_over(flux, run.clone(), &beta);
            for (k, v) in run.zip(correction) {
                // β is rebuilt from the calibration's distortions (divided by Bt_scale).
                let expected = flux.magnitude(k) - v;
                assert!((r.values[k] - expected).abs() <= 1e-9, "sample {k}");
            }
        }
        assert!(r.values[n / 3..n / 3 + 50].iter().all(|v| v.is_nan()));
    }

    #[test]
    fn centring_removes_the_common_mean_over_runs() {
        let mut rows = vec![
            LevelRows {
                a: DMatrix::from_row_slice(2, 1, &[1.0, 3.0]),
                y: vec![10.0, 12.0],
                at: vec![0, 5],
            },
            LevelRows {
                a: DMatrix::from_row_slice(1, 1, &[5.0]),
                y: vec![14.0],
                at: vec![0],
            },
        ];
        centre(&mut rows);
        assert_eq!(rows[0].a.as_slice(), [-2.0, 0.0]);
        assert_eq!(rows[1].y, [2.0]);
        assert!((rms_misfit(&rows, &[1.0]) - 0.0).abs() < 1e-12);
    }
}
