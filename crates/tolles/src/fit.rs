//! Learning a model from a calibration flight: one fit per scalar, in parallel.

pub mod network;

pub use network::NetworkRequest;

use crate::error::{Error, Result};
use crate::model::{ModelFile, ScalarModel};
use crate::progress::{Progress, Stage};
use crate::read::{checked_names, Flight};
// Compensation and the figure of merit give it too; `tolles::fit::verdict_warning` as before.
pub use crate::warning::verdict_warning;
use crate::warning::Warning;
use rayon::prelude::*;
use std::path::Path;
use std::str::FromStr;
use tolles_core::fit::{
    fit as fit_scalar, lag, Band, FitSettings, Lambda, MagnitudeChoice, Target,
};
use tolles_core::model::design::Design;
pub use tolles_core::model::extra::ExtraChannel;
use tolles_core::model::terms::TermSet;
use tolles_io::schema::{LINE_COLUMN, TIME_COLUMN};
use tolles_io::table::Table;

/// Which terms to fit: a fixed set, or a choice by cross-validation.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Terms {
    /// The patent's 16 traceless terms or `permanent,i5,e8`, whichever predicts held-out data
    /// better, and over several fluxgates the 18 of MagNav when they predict it at least 2 %
    /// better (only when λ is cross-validated; with a fixed λ, the 16).
    Auto,
    /// Exactly these terms.
    Fixed(TermSet),
}

impl FromStr for Terms {
    type Err = String;

    /// `auto`, or a term list such as `permanent,induced,eddy` (see [`TermSet`]).
    fn from_str(text: &str) -> Result<Self, String> {
        if text.trim().eq_ignore_ascii_case("auto") {
            return Ok(Terms::Auto);
        }
        text.parse().map(Terms::Fixed).map_err(|e| format!("{e}"))
    }
}

/// What to fit and how. [`FitRequest::new`] gives tolles' defaults.
#[derive(Debug, Clone, PartialEq)]
pub struct FitRequest {
    /// Uncompensated scalar columns (nT); each gets its own fit in one model.
    pub scalars: Vec<String>,
    /// Fluxgate column prefixes (`flux_a` → `flux_a_x/_y/_z`, nT, body frame FRD); each adds
    /// its own block of terms.
    pub vectors: Vec<String>,
    /// Terms to fit.
    pub terms: Terms,
    /// Ridge strength: cross-validated, or fixed as MagNav's `linreg` adds it.
    pub lambda: Lambda,
    /// Pass band (Hz) of the zero-phase Butterworth filter applied to every column.
    pub band: Band,
    /// Butterworth order per band edge.
    pub order: usize,
    /// Samples dropped at each end of each run after filtering.
    pub trim: usize,
    /// Sample rate (Hz) when the flight has no time column (or to override it).
    pub fs_hz: Option<f64>,
    /// Linear, exact or chosen magnitude model; `None`: chosen by cross-validation when λ is,
    /// else linear (MagNav's procedure stays exactly MagNav's).
    pub magnitude: Option<MagnitudeChoice>,
    /// Fit the heading levels against the calibrated fluxgate (one fluxgate); `None`: off,
    /// as [`FitSettings::recommended`] says why.
    pub levels: Option<bool>,
    /// Calibrate a lone fluxgate's offset and fit on its readings without it (see
    /// `FitSettings::fluxgate_offset`); `None`: when λ is cross-validated, there is one
    /// fluxgate and no reference.
    pub fluxgate_offset: Option<bool>,
    /// Extra channels (e.g. currents, A) that each add `B̂x·c, B̂y·c, B̂z·c`; with a
    /// cross-validated λ they are kept only if they predict held-out data 2 % better. Each may
    /// be low-passed and lagged ([`ExtraChannel`]).
    pub extras: Vec<ExtraChannel>,
    /// The fluxgate's lag behind the scalar: none, given (s), or estimated.
    pub lag: Lag,
    /// A compensated reference magnetometer (nT) on the same flight, e.g. the tail stinger's
    /// `mag_1_c` for cabin sensors: each scalar minus it is the aircraft's field itself, fitted
    /// in the full band ([`Target::Interference`]: `band`, `order`, `trim` and heading levels
    /// do not apply).
    pub reference: Option<String>,
    /// A network trained on what the linear model leaves (`--network`; needs `reference`).
    pub network: Option<NetworkRequest>,
}

/// How to line the fluxgate(s) up with the scalar.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub enum Lag {
    /// Take the samples as they come.
    #[default]
    None,
    /// The fluxgate samples this many seconds late (negative: early).
    Seconds(f64),
    /// Estimate it per scalar within ±1 s (see `tolles_core::fit::lag`).
    Auto,
}

impl FromStr for Lag {
    type Err = String;

    /// `auto`, `none` or seconds such as `0.05` or `-0.1`.
    fn from_str(text: &str) -> Result<Self, String> {
        match text.trim().to_ascii_lowercase().as_str() {
            "auto" => Ok(Lag::Auto),
            "none" | "0" => Ok(Lag::None),
            other => match other.parse::<f64>() {
                Ok(s) if s.is_finite() && s.abs() <= 60.0 => Ok(Lag::Seconds(s)),
                _ => Err(format!(
                    "expected auto, none or seconds (|lag| ≤ 60 s), got {text:?}"
                )),
            },
        }
    }
}

/// Extra channel specs `NAME[:lowpass=HZ][:lag=S]` parsed; an error names the spec and the
/// option at fault.
pub fn parse_extras(specs: &[String]) -> std::result::Result<Vec<ExtraChannel>, String> {
    specs.iter().map(|s| s.parse()).collect()
}

/// Largest lag (s) the automatic search tries either way.
const LAG_SEARCH_S: f64 = 1.0;

impl FitRequest {
    /// tolles' defaults for these columns: terms `auto`, λ by cross-validation, MagNav's band
    /// 0.1–0.9 Hz, order 4, trim 20.
    pub fn new(scalars: Vec<String>, vectors: Vec<String>) -> Self {
        let recommended = FitSettings::recommended();
        Self {
            scalars,
            vectors,
            terms: Terms::Auto,
            lambda: recommended.lambda,
            band: recommended.band,
            order: recommended.order,
            trim: recommended.trim,
            fs_hz: None,
            magnitude: None,
            levels: None,
            fluxgate_offset: None,
            extras: Vec::new(),
            lag: Lag::None,
            reference: None,
            network: None,
        }
    }

    /// MagNav.jl's exact procedure: 18 terms, λ = 0.001 fixed, otherwise as [`FitRequest::new`].
    pub fn magnav(scalars: Vec<String>, vectors: Vec<String>) -> Self {
        let magnav = FitSettings::magnav();
        Self {
            terms: Terms::Fixed(magnav.design.terms),
            lambda: magnav.lambda,
            ..Self::new(scalars, vectors)
        }
    }

    /// The core's settings for this request.
    pub fn settings(&self) -> FitSettings {
        let recommended = FitSettings::recommended();
        let (terms, alternative_terms) = match self.terms {
            Terms::Auto => (recommended.design.terms, recommended.alternative_terms),
            Terms::Fixed(terms) => (terms, Vec::new()),
        };
        FitSettings {
            design: Design::new(terms)
                .with_fluxgates(self.vectors.len())
                .with_extras(self.extras.clone()),
            lambda: self.lambda,
            band: self.band,
            order: self.order,
            trim: self.trim,
            alternative_terms,
            magnitude: self.magnitude_choice(),
            levels: self.levels.unwrap_or(recommended.levels),
            target: match self.reference {
                Some(_) => Target::Interference,
                None => Target::Band,
            },
            prior: recommended.prior,
            fluxgate_offset: self.fluxgate_offset.unwrap_or(
                self.cross_validated() && self.vectors.len() == 1 && self.reference.is_none(),
            ),
        }
    }

    /// The magnitude model the request asks for, its default resolved.
    pub fn magnitude_choice(&self) -> MagnitudeChoice {
        self.magnitude.unwrap_or(if self.cross_validated() {
            MagnitudeChoice::Auto
        } else {
            MagnitudeChoice::Linear
        })
    }

    fn cross_validated(&self) -> bool {
        matches!(self.lambda, Lambda::CrossValidated { .. })
    }
}

/// Fits one scalar with the fluxgates lined up as `lag` says; the model records the lag.
fn fit_lagged(
    scalar: &[f64],
    flight: &Flight,
    fs_hz: f64,
    settings: &FitSettings,
    lag: Lag,
) -> std::result::Result<tolles_core::fit::Fit, tolles_core::fit::FitError> {
    let tt = flight.tt.as_deref();
    let lag_s = match lag {
        Lag::None => 0.0,
        Lag::Seconds(s) => s,
        Lag::Auto => lag::estimate(scalar, &flight.flux[0], fs_hz, tt, settings, LAG_SEARCH_S)?,
    };
    let offset = flux_offset(scalar, flight, fs_hz, settings, lag_s);
    let mut fitted = flight.with_inputs(lag_s, offset, fs_hz, |inputs| {
        fit_scalar(scalar, inputs, fs_hz, tt, settings)
    })?;
    fitted.lag_s = lag_s;
    fitted.flux_offset_nt = offset;
    Ok(fitted)
}

/// The lone fluxgate's offset (nT) to take out before fitting, when `settings` ask for it and
/// its calibration against its own magnitude succeeds (`levels::reference`): the samples the
/// scalar has, the fluxgate read `lag_s` later.
fn flux_offset(
    scalar: &[f64],
    flight: &Flight,
    fs_hz: f64,
    settings: &FitSettings,
    lag_s: f64,
) -> Option<[f64; 3]> {
    if !settings.fluxgate_offset || flight.flux.len() != 1 {
        return None;
    }
    // A lag of zero reads the fluxgate as it is: no flight-long copy.
    let shifted;
    let flux = if lag_s == 0.0 {
        &flight.flux[0]
    } else {
        shifted = tolles_core::fit::lag::shifted(&flight.flux[0], lag_s, fs_hz);
        &shifted
    };
    let usable: Vec<bool> = scalar.iter().map(|v| v.is_finite()).collect();
    let tt = flight.tt.as_deref();
    tolles_core::fit::levels::reference(flux, &usable, fs_hz, tt, settings)
        .map(|r| r.calibration.offset_nt)
}

/// Improvement ratio below which a fit is reported as poor.
const POOR_IMPROVEMENT: f64 = 1.5;

/// A warning when `fit` explains little of the scalar or needed the strongest ridge tried.
fn poor_fit(scalar: &str, fit: &tolles_core::fit::Fit) -> Option<Warning> {
    let d = &fit.diagnostics;
    let top = tolles_core::fit::crossval::LAMBDA_GRID.last().copied();
    let top_lambda = d
        .cross_validation
        .as_ref()
        .map(|cv| cv.chosen_lambda_rel)
        .filter(|l| Some(*l) == top && *l > 0.0);
    (d.improvement_ratio < POOR_IMPROVEMENT || top_lambda.is_some()).then(|| Warning::PoorFit {
        scalar: scalar.to_string(),
        improvement: d.improvement_ratio,
        top_lambda,
    })
}

/// The `--extra` channels of `request` that `fit` chose to leave out, by name.
fn dropped_extras(request: &FitRequest, fit: &tolles_core::fit::Fit) -> Vec<String> {
    let kept = &fit.settings.design.extras;
    (request.extras.iter())
        .filter(|e| !kept.iter().any(|k| k.name == e.name))
        .map(|e| e.name.clone())
        .collect()
}

/// A warning naming the `--extra` channels the fit of `scalar` chose to leave out.
fn extras_dropped(
    scalar: &str,
    request: &FitRequest,
    fit: &tolles_core::fit::Fit,
) -> Option<Warning> {
    let channels = dropped_extras(request, fit);
    (!channels.is_empty()).then(|| Warning::ExtrasDropped {
        scalar: scalar.to_string(),
        channels,
    })
}

impl FitRequest {
    /// The columns [`fit`] reads: every scalar, the fluxgates, the extra channels, the
    /// reference and time; what a reader can parse as it reads ([`crate::read::read_parsing`]).
    pub fn columns(&self) -> Vec<String> {
        let mut names: Vec<String> = self
            .scalars
            .iter()
            .flat_map(|s| crate::read::flight_columns(s, &self.vectors, &self.extras))
            .collect();
        names.extend(self.reference.clone());
        names.extend(self.network.iter().flat_map(|n| n.channels.iter().cloned()));
        names
    }
}

/// What each scalar's fit explains (nT): the scalar, or the scalar minus the reference.
/// The first scalar is `first`, already read with the flight: reading it again would parse
/// its text a second time (for 10⁷ samples, 80 MB more and a pass over the file).
fn targets(table: &Table, request: &FitRequest, first: Vec<f64>) -> Result<Vec<Vec<f64>>> {
    let reference = match &request.reference {
        Some(name) if request.scalars.contains(name) => {
            return Err(Error::Invalid(format!(
                "--reference {name:?} is also a scalar to fit; the reference must be another, \
                 already compensated magnetometer"
            )))
        }
        Some(name) => Some(usable_reference(table, name)?),
        None => None,
    };
    let mut first = Some(first);
    request
        .scalars
        .iter()
        .map(|name| {
            let scalar = match first.take() {
                Some(first) => first,
                None => table.numeric(name)?,
            };
            Ok(match &reference {
                Some(r) => scalar.iter().zip(r).map(|(s, r)| s - r).collect(),
                None => scalar,
            })
        })
        .collect()
}

/// The reference column `name` of `table` (nT), an error naming it when no value is a
/// believable field: the scalar minus it would have nothing to fit, and blame the scalar.
fn usable_reference(table: &Table, name: &str) -> Result<Vec<f64>> {
    let values = table.numeric(name)?;
    match values.iter().any(|v| tolles_core::fit::scalar_usable(*v)) {
        true => Ok(values),
        false => Err(Error::NoUsableRow {
            path: table.path().to_path_buf(),
            column: name.to_string(),
        }),
    }
}

/// Fits every scalar of `request` on the calibration flight `table`, on all cores: one model
/// holding a fit per scalar, in the order asked for. What was noticed (a given sample rate
/// that differs from the time column's) is added to `warnings`.
pub fn fit(
    table: &Table,
    request: &FitRequest,
    progress: &dyn Progress,
    warnings: &mut Vec<Warning>,
) -> Result<ModelFile> {
    checked_names(&request.scalars, "scalar")?;
    checked_names(&request.vectors, "fluxgate")?;
    check_band(request.band)?;
    check_extras(table, request)?;
    if let Some(network) = &request.network {
        network::check(network)?;
        network::check_no_target(network, &request.scalars, request.reference.as_deref())?;
    }
    if request.network.is_some() && request.reference.is_none() {
        return Err(Error::Invalid(
            "--network learns what the linear model leaves of the scalar minus a reference: \
             give --reference COL (a compensated magnetometer on the same flight)"
                .into(),
        ));
    }
    let mut flight = Flight::from_table(table, &request.scalars[0], &request.vectors)?
        .with_extras(&request.extras)?;
    let (fs_hz, warning) = flight.sample_rate(request.fs_hz)?;
    warnings.extend(flight.time_steps_back.take());
    warnings.extend(warning);
    check_fit_rate(table, fs_hz)?;
    let mut settings = request.settings();
    settings.band = band_at(settings.band, fs_hz, table.path(), warnings);
    let columns = targets(table, request, std::mem::take(&mut flight.scalar))?;
    progress.begin(Stage::Fitting, None);
    let fitted: Vec<_> = columns
        .par_iter()
        .map(|scalar| fit_lagged(scalar, &flight, fs_hz, &settings, request.lag))
        .collect();
    progress.finish();
    let mut models = request
        .scalars
        .iter()
        .zip(fitted)
        .map(|(name, fitted)| {
            let fitted = fitted.map_err(|e| flight.explain(e, name))?;
            warnings.extend(poor_fit(name, &fitted));
            warnings.extend(extras_dropped(name, request, &fitted));
            warnings.extend(verdict_warning(name, &fitted));
            Ok(ScalarModel::new(name, &request.vectors, fitted)
                .with_reference(request.reference.as_deref())
                .with_calibration_flight(table.path()))
        })
        .collect::<Result<Vec<_>>>()?;
    if let Some(network) = &request.network {
        for (model, target) in models.iter_mut().zip(&columns) {
            let (scalar, lag_s) = (model.scalar.clone(), model.fit.lag_s);
            let refit = |target: &[f64]| {
                let lag = Lag::Seconds(lag_s);
                let fitted = fit_lagged(target, &flight, fs_hz, &settings, lag)
                    .map_err(|e| flight.explain(e, &scalar))?;
                Ok(ScalarModel::new(&scalar, &request.vectors, fitted)
                    .with_reference(request.reference.as_deref())
                    .with_calibration_flight(table.path()))
            };
            // Extras the linear fit dropped may still matter nonlinearly: the network reads them
            // as plain channels.
            let mut network = network.clone();
            for name in dropped_extras(request, &model.fit) {
                if !network.channels.contains(&name) {
                    network.channels.push(name);
                }
            }
            network::learn(model, &flight, target, fs_hz, &network, &refit, warnings)?;
        }
    }
    // What `compensate`, `fom` and Python would refuse to read is refused here, unwritten.
    (ModelFile::new(models).validated("model")).map_err(|e| Error::UnwritableModel {
        path: table.path().to_path_buf(),
        message: match e {
            tolles_io::IoError::Model { message, .. } => message,
            other => other.to_string(),
        },
    })
}

/// Fits every scalar of `request` on several calibration flights at once, each its own runs:
/// the flights' rows are stacked with a missing row between two flights (see
/// [`Table::stacked`]), so no filter, difference or lag reaches from one into the next and time
/// may start again in each. The flights must share a sample rate (within 1 %); with one
/// flight this is [`fit`].
pub fn fit_flights(
    flights: &[Table],
    request: &FitRequest,
    progress: &dyn Progress,
    warnings: &mut Vec<Warning>,
) -> Result<ModelFile> {
    let [first, rest @ ..] = flights else {
        return Err(Error::Invalid(
            "fit needs at least one calibration flight".into(),
        ));
    };
    if rest.is_empty() {
        return fit(first, request, progress, warnings);
    }
    let (fs_hz, steps_back) = shared_rate_and_steps_back(flights, request.fs_hz, warnings)?;
    // Time and lines are kept when every flight has them as numbers; the rest is needed.
    let optional = [TIME_COLUMN, LINE_COLUMN];
    let mut names = request.columns();
    names.retain(|name| !optional.contains(&name.as_str()));
    names.sort();
    names.dedup();
    let label: Vec<String> = flights
        .iter()
        .map(|f| f.path().display().to_string())
        .collect();
    let stacked = Table::stacked(Path::new(&label.join(" + ")), flights, &names, &optional)?;
    let request = FitRequest {
        fs_hz: Some(fs_hz),
        ..request.clone()
    };
    let mut noticed = Vec::new();
    let model = fit(&stacked, &request, progress, &mut noticed).map(|mut model| {
        // The rows between two flights are the stacking's, not missing data of a flight.
        for scalar in &mut model.fits {
            let d = &mut scalar.fit.diagnostics;
            d.samples_total = d.samples_total.saturating_sub(rest.len());
            d.samples_nonfinite = d.samples_nonfinite.saturating_sub(rest.len());
        }
        model
    });
    // Time that starts again in the next flight is no step back: each flight says its own.
    noticed.retain(|w| !matches!(w, Warning::TimeStepsBack { .. }));
    warnings.extend(steps_back);
    warnings.extend(noticed);
    model
}

/// The sample rate (Hz) every one of `flights` has, within 1 % of the first's (`fs_hz` when
/// given), an error naming the first flight that differs; and where each flight's own time
/// steps back.
fn shared_rate_and_steps_back(
    flights: &[Table],
    fs_hz: Option<f64>,
    warnings: &mut Vec<Warning>,
) -> Result<(f64, Vec<Warning>)> {
    let mut rates = Vec::with_capacity(flights.len());
    let mut steps_back = Vec::new();
    for flight in flights {
        let tt = match flight.has(TIME_COLUMN) {
            true => Some(flight.numeric(TIME_COLUMN)?),
            false => None,
        };
        let (rate, warning) = crate::read::sample_rate(flight, tt.as_deref(), fs_hz)?;
        warnings.extend(warning);
        rates.push(rate);
        steps_back.extend(tt.and_then(|tt| crate::read::time_steps_back(flight, &tt)));
    }
    let first = rates[0];
    match rates
        .iter()
        .position(|r| ((r - first) / first).abs() > 0.01)
    {
        None => Ok((first, steps_back)),
        Some(k) => Err(Error::Invalid(format!(
            "{}: sampled at {:.4} Hz, but {} at {:.4} Hz; calibration flights fitted together \
             must share a sample rate (resample one, or fit them apart)",
            flights[k].path().display(),
            rates[k],
            flights[0].path().display(),
            first
        ))),
    }
}

/// Band edges a model can store and a filter can take: finite (0 or ≥ Nyquist turn one off).
pub fn check_band(band: Band) -> Result<()> {
    let (pass1_hz, pass2_hz) = band.edges_hz();
    match pass1_hz.is_finite() && pass2_hz.is_finite() {
        true => Ok(()),
        false => Err(Error::BadBand { pass1_hz, pass2_hz }),
    }
}

/// `band` as a filter at `fs_hz` applies it: an upper edge at or above Nyquist is off, so the
/// band runs to Nyquist, which is what a model or a report should say (warned of).
pub fn band_at(band: Band, fs_hz: f64, path: &Path, warnings: &mut Vec<Warning>) -> Band {
    let nyquist_hz = fs_hz / 2.0;
    match band.pass2_hz.is_finite() && band.pass2_hz > nyquist_hz {
        true => {
            warnings.push(Warning::BandEdgeAboveNyquist {
                path: path.to_path_buf(),
                edge_hz: band.pass2_hz,
                nyquist_hz,
            });
            Band {
                pass2_hz: nyquist_hz,
                ..band
            }
        }
        false => band,
    }
}

/// A sample rate (Hz) a model can be kept at ([`crate::model::FS_RANGE_HZ`]).
fn check_fit_rate(table: &Table, fs_hz: f64) -> Result<()> {
    let (lo_hz, hi_hz) = crate::model::FS_RANGE_HZ;
    match (lo_hz..=hi_hz).contains(&fs_hz) {
        true => Ok(()),
        false => Err(Error::FitRateOutOfRange {
            path: table.path().to_path_buf(),
            fs_hz,
            lo_hz,
            hi_hz,
        }),
    }
}

/// The extra channels of `request` checked: each a column of its own (not a scalar, a
/// fluxgate component or another channel spelled differently) that varies.
fn check_extras(table: &Table, request: &FitRequest) -> Result<()> {
    let path = || table.path().to_path_buf();
    let mut used: Vec<(usize, &'static str)> = Vec::new();
    for scalar in &request.scalars {
        used.extend(table.index_of(scalar).ok().map(|k| (k, "a scalar")));
    }
    for vector in &request.vectors {
        for name in tolles_io::schema::vector_columns(vector) {
            used.extend(
                table
                    .index_of(&name)
                    .ok()
                    .map(|k| (k, "a fluxgate component")),
            );
        }
    }
    for extra in &request.extras {
        let index = table.index_of(&extra.name)?;
        if let Some((_, role)) = used.iter().find(|(k, _)| *k == index) {
            return Err(Error::ExtraNotItsOwn {
                path: path(),
                channel: extra.name.clone(),
                column: table.headers()[index].clone(),
                role,
            });
        }
        let values = table.numeric_at(index)?;
        let finite = || values.iter().copied().filter(|v| v.is_finite());
        let (lo, hi) = finite().fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| {
            (lo.min(v), hi.max(v))
        });
        if finite().next().is_none() {
            return Err(Error::NoUsableRow {
                path: path(),
                column: extra.name.clone(),
            });
        }
        // Rounding of a constant stored as text: a relative 1e-12 is no current.
        if hi - lo <= 1e-12 * lo.abs().max(hi.abs()).max(f64::MIN_POSITIVE) {
            return Err(Error::ConstantExtra {
                path: path(),
                channel: extra.name.clone(),
            });
        }
        used.push((index, "another extra channel"));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::simulate::PlanKind;
    use crate::testing::flight;

    fn names(v: &[&str]) -> Vec<String> {
        v.iter().map(|s| s.to_string()).collect()
    }

    #[test]
    fn several_scalars_give_one_model_in_the_order_asked() {
        let table = flight(PlanKind::Box, 1);
        let request = FitRequest::new(names(&["truth_earth", "mag_1_uc"]), names(&["flux_a"]));
        let model = fit(&table, &request, &crate::Silent, &mut Vec::new()).unwrap();
        let scalars: Vec<&str> = model.fits.iter().map(|f| f.scalar.as_str()).collect();
        assert_eq!(scalars, ["truth_earth", "mag_1_uc"]);
        // The earth field alone has no aircraft in it: its fit explains (almost) nothing.
        let explained = |k: usize| model.fits[k].fit.diagnostics.improvement_ratio;
        assert!(
            explained(1) > 50.0 * explained(0),
            "{} {}",
            explained(0),
            explained(1)
        );
    }

    #[test]
    fn magnav_settings_fit_magnav_s_eighteen_terms() {
        let table = flight(PlanKind::Box, 2);
        let request = FitRequest::magnav(names(&["mag_1_uc"]), names(&["flux_a"]));
        let model = fit(&table, &request, &crate::Silent, &mut Vec::new()).unwrap();
        assert_eq!(model.fits[0].fit.coefficients.len(), 18);
        assert_eq!(model.fits[0].fit.settings.lambda, Lambda::Fixed(0.001));
    }

    #[test]
    fn a_missing_fluxgate_and_a_repeated_scalar_are_errors() {
        let table = flight(PlanKind::Box, 1);
        let mut warnings = Vec::new();
        let request = FitRequest::new(names(&["mag_1_uc"]), names(&["flux_b"]));
        let e = fit(&table, &request, &crate::Silent, &mut warnings).unwrap_err();
        assert!(e.to_string().contains("flux_b_x"), "{e}");
        let request = FitRequest::new(names(&["mag_1_uc", "mag_1_uc"]), names(&["flux_a"]));
        let e = fit(&table, &request, &crate::Silent, &mut warnings).unwrap_err();
        assert!(matches!(e, crate::Error::RepeatedColumn { .. }), "{e}");
    }

    /// `table`'s fit columns (and time, when `with_time`) over `rows`, with the rows in
    /// `blank` missing in every column.
    fn part(
        table: &Table,
        rows: std::ops::Range<usize>,
        blank: &[usize],
        with_time: bool,
    ) -> Table {
        let mut names = names(&["mag_1_uc", "flux_a_x", "flux_a_y", "flux_a_z"]);
        if with_time {
            names.push(TIME_COLUMN.into());
        }
        let columns = (names.iter())
            .map(|name| {
                let values = table.numeric(name).unwrap()[rows.clone()].to_vec();
                let values = (values.iter().enumerate()).map(|(k, v)| {
                    if blank.contains(&(rows.start + k)) {
                        f64::NAN
                    } else {
                        *v
                    }
                });
                tolles_io::table::Column::Numbers(values.collect())
            })
            .collect();
        Table::from_columns(
            format!("{}-{}.csv", rows.start, rows.end),
            names,
            columns,
            None,
        )
        .unwrap()
    }

    #[test]
    fn flights_fitted_together_are_never_differenced_across() {
        let table = flight(PlanKind::Box, 1);
        let (n, k) = (table.len(), table.len() / 2);
        let request = FitRequest {
            fs_hz: Some(10.0),
            ..FitRequest::magnav(names(&["mag_1_uc"]), names(&["flux_a"]))
        };
        let coefficients = |flights: &[Table]| {
            let model = fit_flights(flights, &request, &crate::Silent, &mut Vec::new()).unwrap();
            model.fits[0].fit.coefficients.clone()
        };
        // Without a time column only the row between the files keeps them apart.
        let whole = coefficients(&[part(&table, 0..n, &[k], false)]);
        let apart = coefficients(&[
            part(&table, 0..k, &[], false),
            part(&table, k + 1..n, &[], false),
        ]);
        let joined = coefficients(&[part(&table, 0..n, &[], false)]);
        let differ = |a: &[f64], b: &[f64]| {
            a.iter()
                .zip(b)
                .map(|(x, y)| (x - y).abs() / x.abs().max(1e-12))
                .fold(0.0, f64::max)
        };
        println!(
            "stacked vs split: {:.1e}; vs joined: {:.1e}",
            differ(&whole, &apart),
            differ(&joined, &apart)
        );
        assert!(differ(&whole, &apart) < 1e-9);
        assert!(differ(&joined, &apart) > 1e-6);
    }

    #[test]
    fn the_rows_between_flights_are_not_counted_as_samples() {
        let table = flight(PlanKind::Box, 1);
        let (n, k) = (table.len(), table.len() / 2);
        let request = FitRequest::new(names(&["mag_1_uc"]), names(&["flux_a"]));
        let flights = [part(&table, 0..k, &[], true), part(&table, k..n, &[], true)];
        let model = fit_flights(&flights, &request, &crate::Silent, &mut Vec::new()).unwrap();
        let d = &model.fits[0].fit.diagnostics;
        assert_eq!((d.samples_total, d.samples_nonfinite), (n, 0));
    }

    #[test]
    fn time_starting_again_in_the_next_flight_is_no_step_back_but_one_inside_is() {
        let table = flight(PlanKind::Box, 1);
        let request = FitRequest::new(names(&["mag_1_uc"]), names(&["flux_a"]));
        let steps_back = |flights: &[Table]| {
            let mut warnings = Vec::new();
            fit_flights(flights, &request, &crate::Silent, &mut warnings).unwrap();
            let said = warnings.iter().filter_map(|w| match w {
                Warning::TimeStepsBack { path, .. } => Some(path.display().to_string()),
                _ => None,
            });
            said.collect::<Vec<_>>()
        };
        let first = part(&table, 0..2000, &[], true);
        let again = part(&table, 0..2000, &[], true);
        assert!(steps_back(&[first.clone(), again]).is_empty());
        let mut back = part(&table, 2000..4000, &[], true);
        let mut tt = back.numeric(TIME_COLUMN).unwrap();
        tt[500] = tt[10];
        back.set_numeric(TIME_COLUMN, tt).unwrap();
        assert_eq!(steps_back(&[first, back]), ["2000-4000.csv"]);
    }

    #[test]
    fn flights_at_different_sample_rates_are_refused_naming_one() {
        let table = flight(PlanKind::Box, 1);
        let first = part(&table, 0..2000, &[], true);
        let mut second = part(&table, 2000..4000, &[], true);
        let tt = second.numeric(TIME_COLUMN).unwrap();
        second
            .set_numeric(TIME_COLUMN, tt.iter().map(|t| t / 2.0).collect())
            .unwrap();
        let request = FitRequest::new(names(&["mag_1_uc"]), names(&["flux_a"]));
        let error = fit_flights(&[first, second], &request, &crate::Silent, &mut Vec::new())
            .unwrap_err()
            .to_string();
        assert!(
            error.contains("2000-4000.csv") && error.contains("sample rate"),
            "{error}"
        );
        assert!(!error.contains('\n'), "{error}");
    }

    #[test]
    fn terms_parse_auto_or_a_list() {
        assert_eq!("AUTO".parse::<Terms>().unwrap(), Terms::Auto);
        assert!(matches!("p,i,e".parse::<Terms>().unwrap(), Terms::Fixed(_)));
        assert!("nonsense".parse::<Terms>().is_err());
    }
}
