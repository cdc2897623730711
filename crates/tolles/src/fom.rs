//! The figure of merit of a compensation box: its maneuvers found in the attitude, the FOM of
//! the scalar before and, given a model, after compensation; and the surveyors' heading error
//! (the spread of the scalar's level over the straight legs of the cardinal headings, see
//! [`tolles_core::maneuvers::heading`]) on the same samples before and after.

use crate::compensate::{compensate_flight, CompensateRequest};
use crate::error::{Error, Result};
use crate::model::{ModelFile, ScalarModel};
use crate::read::{sample_rate, time_column, Flight};
use crate::warning::Warning;
use serde_json::{json, Value};
use std::path::Path;
use tolles_core::fit::Band;
use tolles_core::maneuvers::detect::{detect_maneuvers, Maneuver, ManeuverSettings};
use tolles_core::maneuvers::fom::{
    fom as fom_of, improvement_ratio, FomReport, FomSettings, ManeuverFom, Slot,
};
use tolles_core::maneuvers::heading::{select_straight, HeadingLevels, HeadingSettings};
use tolles_io::schema::{PITCH, ROLL, SAMPLE_INTERVAL, YAW};
use tolles_io::table::Table;

/// What to measure.
#[derive(Debug, Clone, PartialEq)]
pub struct FomRequest {
    /// The scalar column (nT).
    pub scalar: String,
    /// Band-pass (Hz) applied before taking peak-to-peaks; default 0.05–1 Hz.
    pub band: Band,
    /// Butterworth order per band edge; default 4.
    pub order: usize,
    /// Sample rate (Hz) when the flight has no time column (or to override it).
    pub fs_hz: Option<f64>,
    /// What counts as a straight leg for the heading error: the nominal headings (degrees
    /// clockwise from north), how far the yaw may stray from one (degrees, 0–90), the largest
    /// roll and pitch (degrees) and so on; default the four cardinal headings, within 10°.
    pub headings: HeadingSettings,
    /// A maneuver flown on a measured heading within this of north, east, south or west counts
    /// as that heading's (degrees, 0–45); default 20°.
    pub cardinal_tolerance_deg: f64,
}

impl FomRequest {
    /// The FOM of `scalar` in the default band 0.05–1 Hz, order 4.
    pub fn new(scalar: &str) -> Self {
        Self {
            scalar: scalar.to_string(),
            band: Band {
                pass1_hz: 0.05,
                pass2_hz: 1.0,
            },
            order: 4,
            fs_hz: None,
            headings: HeadingSettings::default(),
            cardinal_tolerance_deg: ManeuverSettings::default().cardinal_tolerance_deg,
        }
    }

    /// The request's angles checked: finite, tolerances within their ranges.
    fn check(&self) -> Result<()> {
        let h = &self.headings;
        let angles = [
            (
                "--heading-tolerance",
                "heading_tolerance",
                "an angle from 0 to 90 degrees",
                h.heading_tolerance_deg,
                90.0,
            ),
            (
                "--cardinal-tolerance",
                "cardinal_tolerance",
                "an angle from 0 to 45 degrees",
                self.cardinal_tolerance_deg,
                45.0,
            ),
            (
                "--level-tolerance",
                "level_tolerance",
                "an angle from 0 to 90 degrees",
                h.max_roll_deg,
                90.0,
            ),
            (
                "--level-tolerance",
                "level_tolerance",
                "an angle from 0 to 90 degrees",
                h.max_pitch_deg,
                90.0,
            ),
        ];
        let bad = angles
            .into_iter()
            .find(|(.., value, most)| !(0.0..=*most).contains(value));
        if let Some((flag, python, range, value, _)) = bad {
            return Err(Error::BadHeadingSetting {
                flag,
                python,
                range,
                value,
            });
        }
        match h.headings_deg.iter().find(|v| !v.is_finite()) {
            Some(&value) => Err(Error::BadHeadingSetting {
                flag: "--headings",
                python: "headings",
                range: "finite angles in degrees",
                value,
            }),
            None => Ok(()),
        }
    }

    /// The request with the straight legs of the heading error on `headings_deg` (degrees;
    /// `None` keeps the cardinal headings), the yaw within `heading_tolerance_deg` of one and
    /// roll and pitch within `level_tolerance_deg` (degrees), and box maneuvers assigned to a
    /// cardinal heading within `cardinal_tolerance_deg` (degrees): the flags of `tolles fom`.
    pub fn with_legs(
        self,
        headings_deg: Option<Vec<f64>>,
        heading_tolerance_deg: f64,
        level_tolerance_deg: f64,
        cardinal_tolerance_deg: f64,
    ) -> Self {
        let default = HeadingSettings::default();
        Self {
            headings: HeadingSettings {
                headings_deg: headings_deg.unwrap_or(default.headings_deg),
                heading_tolerance_deg,
                max_roll_deg: level_tolerance_deg,
                max_pitch_deg: level_tolerance_deg,
                ..default
            },
            cardinal_tolerance_deg,
            ..self
        }
    }

    /// The maneuver detector's settings with this request's cardinal tolerance.
    fn maneuver_settings(&self) -> ManeuverSettings {
        ManeuverSettings {
            cardinal_tolerance_deg: self.cardinal_tolerance_deg,
            ..ManeuverSettings::default()
        }
    }
}

/// Where a flight's sample rate came from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RateSource {
    /// The file: its time column, or the sample interval it states.
    File,
    /// The request (`--fs`).
    Given,
    /// Assumed: the model's calibration rate, for a flight that states none.
    Model,
}

/// What [`fom`] found and computed.
#[derive(Debug, Clone)]
pub struct FomOutcome {
    /// Time (s), from the file or made from the sample rate.
    pub tt: Vec<f64>,
    /// Sample rate (Hz).
    pub fs_hz: f64,
    /// Where the sample rate came from.
    pub fs_from: RateSource,
    /// The uncompensated scalar (nT).
    pub scalar: Vec<f64>,
    /// The compensated scalar (nT), with a model.
    pub compensated: Option<Vec<f64>>,
    /// The maneuvers found.
    pub maneuvers: Vec<Maneuver>,
    /// FOM of the uncompensated scalar.
    pub before: FomReport,
    /// FOM of the compensated scalar, with a model.
    pub after: Option<FomReport>,
    /// Heading levels (nT) and heading error of the uncompensated scalar, over the straight
    /// legs' samples where the scalar (and, with a model, the compensated scalar) is finite.
    pub heading_before: HeadingLevels,
    /// The same of the compensated scalar, on the same samples, with a model.
    pub heading_after: Option<HeadingLevels>,
    /// The model's verdict, with a model whose file has one.
    pub verdict: Option<tolles_core::fit::verdict::Verdict>,
}

/// Finds the box maneuvers of the flight `table` in its attitude columns and the FOM of the
/// request's scalar before and, given the scalar's fit, after compensation (as `compensate`
/// does it, the correction's mean kept). What is missing is added to `warnings`: a flight
/// without the attitude columns (a survey file as delivered, say) has no maneuvers, FOM or
/// heading levels, which a [`Warning::NoAttitude`] says, but still its noise.
pub fn fom(
    table: &Table,
    request: &FomRequest,
    fit: Option<&ScalarModel>,
    warnings: &mut Vec<Warning>,
) -> Result<FomOutcome> {
    crate::fit::check_band(request.band)?;
    request.check()?;
    let missing: Vec<&str> = [ROLL, PITCH, YAW]
        .into_iter()
        .filter(|c| !table.has(c))
        .collect();
    if !missing.is_empty() {
        warnings.push(Warning::NoAttitude {
            path: table.path().to_path_buf(),
            columns: missing.join(", "),
        });
        return measure_flight(table, request, fit, None, warnings);
    }
    let attitude = [
        table.numeric(ROLL)?,
        table.numeric(PITCH)?,
        table.numeric(YAW)?,
    ];
    measure_flight(table, request, fit, Some(attitude), warnings)
}

fn measure_flight(
    table: &Table,
    request: &FomRequest,
    fit: Option<&ScalarModel>,
    attitude: Option<[Vec<f64>; 3]>,
    warnings: &mut Vec<Warning>,
) -> Result<FomOutcome> {
    let scalar = table.numeric(&request.scalar)?;
    let (tt, steps_back) = time_column(table)?;
    warnings.extend(steps_back);
    // A flight that states no rate is taken at its model's, as `compensate` takes it.
    let states_rate = tt.is_some() || table.metadata(SAMPLE_INTERVAL).is_some();
    let given = match (request.fs_hz, fit) {
        (None, Some(fit)) if !states_rate => Some(fit.fit.fs_hz),
        (given, _) => given,
    };
    let fs_from = match (request.fs_hz, given) {
        (Some(_), _) => RateSource::Given,
        (None, Some(_)) => RateSource::Model,
        (None, None) => RateSource::File,
    };
    let (fs_hz, warning) = sample_rate(table, tt.as_deref(), given)?;
    warnings.extend(warning);
    let tt = tt.unwrap_or_else(|| (0..table.len()).map(|k| k as f64 / fs_hz).collect());
    let maneuvers = match &attitude {
        Some([roll, pitch, yaw]) => {
            detect_maneuvers(&tt, roll, pitch, yaw, &request.maneuver_settings())
        }
        None => Vec::new(),
    };
    let path = table.path();
    if maneuvers.is_empty() && attitude.is_some() {
        warnings.push(Warning::NoManeuvers {
            path: path.to_path_buf(),
            columns: format!("{ROLL}, {PITCH}, {YAW}"),
        });
    }
    let settings = FomSettings {
        band: crate::fit::band_at(request.band, fs_hz, path, warnings),
        order: request.order,
    };
    let measure = |signal: &[f64]| {
        fom_of(signal, Some(&tt), &maneuvers, fs_hz, &settings).map_err(|cause| Error::Fom {
            path: path.to_path_buf(),
            cause,
        })
    };
    let before = measure(&scalar)?;
    let compensated = fit
        .map(|fit| compensated(table, fit, request.fs_hz, warnings))
        .transpose()?;
    let after = compensated.as_deref().map(measure).transpose()?;
    let (heading_before, heading_after) = match &attitude {
        Some([roll, pitch, yaw]) => headings(
            path,
            &tt,
            [roll, pitch, yaw],
            &maneuvers,
            &scalar,
            compensated.as_deref(),
            &request.headings,
        )?,
        None => (no_levels(), compensated.as_ref().map(|_| no_levels())),
    };
    let outcome = FomOutcome {
        tt,
        fs_hz,
        fs_from,
        scalar,
        compensated,
        maneuvers,
        before,
        after,
        heading_before,
        heading_after,
        verdict: fit.and_then(|f| f.fit.verdict.clone()),
    };
    warnings.extend(gaps(path, &outcome));
    if let Some(f) = fit {
        warnings.extend(crate::warning::verdict_warning(&f.scalar, &f.fit));
    }
    Ok(outcome)
}

/// The heading levels of a flight without attitude: none.
fn no_levels() -> HeadingLevels {
    HeadingLevels {
        levels: Vec::new(),
        skipped: Vec::new(),
        heading_error_nt: None,
        uncertainty_nt: None,
    }
}

/// Heading levels of `scalar` and of `compensated` (nT) over the same straight-and-level
/// samples: those where both are finite.
fn headings(
    path: &Path,
    tt: &[f64],
    attitude: [&[f64]; 3],
    maneuvers: &[Maneuver],
    scalar: &[f64],
    compensated: Option<&[f64]>,
    settings: &HeadingSettings,
) -> Result<(HeadingLevels, Option<HeadingLevels>)> {
    let mut signals = vec![scalar];
    signals.extend(compensated);
    let mut levels =
        straight_levels(path, tt, attitude, maneuvers, &signals, settings)?.into_iter();
    let before = levels.next().expect("the scalar's levels");
    Ok((before, levels.next()))
}

/// Heading levels of each of `signals` (nT) over the same straight-and-level samples of the
/// flight `path`: those where every one of them is finite.
pub(crate) fn straight_levels(
    path: &Path,
    tt: &[f64],
    [roll, pitch, yaw]: [&[f64]; 3],
    maneuvers: &[Maneuver],
    signals: &[&[f64]],
    settings: &HeadingSettings,
) -> Result<Vec<HeadingLevels>> {
    let error = |cause| Error::Heading {
        path: path.to_path_buf(),
        cause,
    };
    let mut selection =
        select_straight(tt, roll, pitch, yaw, maneuvers, settings).map_err(error)?;
    for s in signals {
        selection.require_finite(s).map_err(error)?;
    }
    signals
        .iter()
        .map(|s| selection.levels(s).map_err(error))
        .collect()
}

fn compensated(
    table: &Table,
    fit: &ScalarModel,
    fs_hz: Option<f64>,
    warnings: &mut Vec<Warning>,
) -> Result<Vec<f64>> {
    let flight = Flight::from_table(table, &fit.scalar, &fit.vectors)?
        .with_extras(&fit.fit.settings.design.extras)?;
    let request = CompensateRequest {
        fs_hz,
        ..CompensateRequest::default()
    };
    let result = compensate_flight(&flight, fit, &request, warnings)?;
    if result.uncomputable > 0 {
        warnings.push(Warning::NotCompensated {
            path: table.path().to_path_buf(),
            rows: result.uncomputable,
            of: result.compensated.len(),
        });
    }
    Ok(result.compensated)
}

/// The scalar to work on: `scalar` when one is named, else the scalar of the only fit of the
/// `model` read from the file `path`; [`Error::ScalarNeeded`] when neither says which.
pub fn scalar_to_use(scalar: Option<&str>, model: Option<(&ModelFile, &Path)>) -> Result<String> {
    if let Some(scalar) = scalar {
        return Ok(scalar.to_string());
    }
    match model {
        Some((model, _)) if model.fits.len() == 1 => Ok(model.fits[0].scalar.clone()),
        Some((model, path)) => {
            crate::model::check_model(model, path)?;
            Err(Error::ScalarNeeded {
                path: Some(path.to_path_buf()),
                available: model.fits.iter().map(|f| f.scalar.clone()).collect(),
            })
        }
        None => Err(Error::ScalarNeeded {
            path: None,
            available: Vec::new(),
        }),
    }
}

/// The model's fit for the scalar `scalar`; `path` names the model file in errors.
pub fn fit_for<'m>(model: &'m ModelFile, path: &Path, scalar: &str) -> Result<&'m ScalarModel> {
    crate::model::check_model(model, path)?;
    model
        .fits
        .iter()
        .find(|f| f.scalar == scalar)
        .ok_or_else(|| Error::NoFitForScalar {
            path: path.to_path_buf(),
            scalar: scalar.to_string(),
            available: model.fits.iter().map(|f| f.scalar.clone()).collect(),
        })
}

fn gaps(path: &Path, outcome: &FomOutcome) -> Vec<Warning> {
    let reports = std::iter::once(&outcome.before).chain(&outcome.after);
    reports
        .flat_map(|report| &report.maneuvers)
        .filter(|m| m.unfiltered_samples > 0)
        .map(|m| Warning::ManeuverGap {
            path: path.to_path_buf(),
            kind: m.maneuver.kind.to_string(),
            heading: heading_text(&m.maneuver),
            start_tt: m.maneuver.start_tt,
            end_tt: m.maneuver.end_tt,
            samples: m.unfiltered_samples,
        })
        .collect()
}

impl FomOutcome {
    /// Uncompensated FOM / compensated FOM, when there is a finite one.
    pub fn improvement_ratio(&self) -> Option<f64> {
        self.after
            .as_ref()
            .map(|after| improvement_ratio(&self.before, after))
            .filter(|r| r.is_finite())
    }

    /// The outcome as `tolles fom --json` prints it: FOM (nT), band (Hz), fourth-difference
    /// noise (nT), counted, extra and missing maneuvers, the heading error (`heading_error`,
    /// see [`heading_json`]), the improvement ratio, and the same block for the compensated data
    /// under `compensated`.
    pub fn to_json(&self) -> Value {
        let mut value = block_json(&self.before);
        value["heading_error"] = heading_json(&self.heading_before);
        value["improvement_ratio"] = json!(self.improvement_ratio());
        if let Some(after) = &self.after {
            value["compensated"] = block_json(after);
        }
        if let Some(after) = &self.heading_after {
            value["compensated"]["heading_error"] = heading_json(after);
        }
        if let Some(verdict) = &self.verdict {
            value["verdict"] = json!(verdict);
        }
        value
    }
}

/// The heading levels as JSON: `heading_error_nT` and `uncertainty_nT` (null with fewer than two
/// headings), `levels` (one per heading found: `heading_deg`, `level_nT`, `std_error_nT`,
/// `std_nT`, `samples`, `effective_samples`, `start_tt`, `end_tt` in s) and `skipped` (headings
/// with too little straight flight: `heading_deg`, `samples`, `duration_s`).
pub fn heading_json(levels: &HeadingLevels) -> Value {
    let heading = |h: f64| {
        // Whole headings (the cardinal ones) print as integers, like a maneuver's.
        if h.fract() == 0.0 && (0.0..360.0).contains(&h) {
            json!(h as u16)
        } else {
            json!(h)
        }
    };
    let level = |l: &tolles_core::maneuvers::heading::HeadingLevel| {
        json!({
            "heading_deg": heading(l.heading_deg),
            "level_nT": finite(l.level_nt),
            "std_error_nT": finite(l.std_error_nt),
            "std_nT": finite(l.std_nt),
            "samples": l.samples,
            "effective_samples": finite(l.effective_samples),
            "start_tt": finite(l.start_tt),
            "end_tt": finite(l.end_tt),
        })
    };
    json!({
        "heading_error_nT": levels.heading_error_nt.and_then(|v| v.is_finite().then_some(v)),
        "uncertainty_nT": levels.uncertainty_nt.and_then(|v| v.is_finite().then_some(v)),
        "levels": levels.levels.iter().map(level).collect::<Vec<_>>(),
        "skipped": levels.skipped.iter().map(|s| json!({
            "heading_deg": heading(s.heading_deg),
            "samples": s.samples,
            "duration_s": finite(s.duration_s),
        })).collect::<Vec<_>>(),
    })
}

fn block_json(report: &FomReport) -> Value {
    let maneuver = |m: &ManeuverFom| {
        json!({
            "heading_deg": maneuver_heading_json(&m.maneuver),
            "kind": m.maneuver.kind,
            "start_tt": m.maneuver.start_tt,
            "end_tt": m.maneuver.end_tt,
            "peak_to_peak_nT": finite(m.peak_to_peak_nt),
        })
    };
    json!({
        "fom_nT": finite(report.fom_nt),
        "band_hz": [report.band_hz.0, report.band_hz.1],
        "fourth_difference_nT": finite(report.fourth_difference_nt),
        "maneuvers": report.counted().map(maneuver).collect::<Vec<_>>(),
        "extra_maneuvers": report.maneuvers.iter().filter(|m| !m.counted).map(maneuver).collect::<Vec<_>>(),
        "missing": report.missing.iter().map(|s: &Slot| json!({"heading_deg": s.heading_deg, "kind": s.kind})).collect::<Vec<_>>(),
    })
}

/// A cardinal heading as an integer, any other as measured.
fn maneuver_heading_json(m: &Maneuver) -> Value {
    match m.cardinal_heading_deg() {
        Some(h) => json!(h as u16),
        None => json!(m.heading_deg),
    }
}

/// A maneuver's heading (deg) as text: a cardinal one whole, any other to 0.1°.
pub fn heading_text(m: &Maneuver) -> String {
    match m.cardinal_heading_deg() {
        Some(h) => format!("{h:.0}"),
        None => format!("{:.1}", m.heading_deg),
    }
}

/// NaN is not JSON; it becomes null.
fn finite(v: f64) -> Value {
    if v.is_finite() {
        json!(v)
    } else {
        Value::Null
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fit::{fit, FitRequest};
    use crate::simulate::PlanKind;
    use crate::testing::flight;

    #[test]
    fn a_box_s_fom_drops_with_its_model_and_the_json_says_so() {
        let table = flight(PlanKind::Box, 6);
        let request = FitRequest::new(vec!["mag_1_uc".into()], vec!["flux_a".into()]);
        let model = fit(&table, &request, &crate::Silent, &mut Vec::new()).unwrap();
        let fit = fit_for(&model, Path::new("m.json"), "mag_1_uc").unwrap();
        let mut warnings = Vec::new();
        let outcome = fom(
            &table,
            &FomRequest::new("mag_1_uc"),
            Some(fit),
            &mut warnings,
        )
        .unwrap();
        assert!(warnings.is_empty(), "{warnings:?}");
        assert_eq!(outcome.before.counted().count(), 12);
        let json = outcome.to_json();
        assert!(json["improvement_ratio"].as_f64().unwrap() > 50.0, "{json}");
        assert_eq!(json["maneuvers"].as_array().unwrap().len(), 12);
        assert!(json["compensated"]["fom_nT"].as_f64().unwrap() < json["fom_nT"].as_f64().unwrap());
        let before = &json["heading_error"];
        let after = &json["compensated"]["heading_error"];
        assert_eq!(before["levels"].as_array().unwrap().len(), 4, "{before}");
        assert_eq!(before["levels"][1]["heading_deg"], 90);
        assert!(before["skipped"].as_array().unwrap().is_empty());
        let error = |block: &Value| block["heading_error_nT"].as_f64().unwrap();
        assert!(error(before) > 1.5 * error(after), "{before} -> {after}");
        // The same samples before and after.
        let samples = |block: &Value, k: usize| block["levels"][k]["samples"].clone();
        assert!((0..4).all(|k| samples(before, k) == samples(after, k)));
        the_heading_error_left_is_the_earth_s(&table, &outcome);
    }

    /// Geology under the legs stays in the compensated heading error; the simulator's true
    /// earth field on the same samples accounts for it.
    fn the_heading_error_left_is_the_earth_s(table: &Table, outcome: &FomOutcome) {
        let column = |name| table.numeric(name).unwrap();
        let (roll, pitch, yaw) = (column(ROLL), column(PITCH), column(YAW));
        let attitude = [&roll[..], &pitch, &yaw];
        let compensated = outcome.compensated.as_deref().unwrap();
        let residual: Vec<f64> = compensated
            .iter()
            .zip(column(crate::report::TRUTH_COLUMN))
            .map(|(c, truth)| c - truth)
            .collect();
        let (_, residual) = headings(
            Path::new("t"),
            &outcome.tt,
            attitude,
            &outcome.maneuvers,
            &outcome.scalar,
            Some(&residual),
            &HeadingSettings::default(),
        )
        .unwrap();
        let residual = residual.unwrap();
        assert_eq!(residual.levels.len(), 4);
        let after = outcome.heading_after.as_ref().unwrap();
        let e = residual.heading_error_nt.unwrap();
        assert!(e < 0.5, "{e} nT of {:?} nT", after.heading_error_nt);
    }

    #[test]
    fn a_survey_has_no_maneuvers_and_says_so() {
        let table = flight(PlanKind::Survey, 6);
        let mut warnings = Vec::new();
        let outcome = fom(&table, &FomRequest::new("mag_1_uc"), None, &mut warnings).unwrap();
        assert!(outcome.to_json()["improvement_ratio"].is_null());
        assert!(outcome.heading_after.is_none());
        assert!(outcome.to_json()["compensated"].is_null());
        assert!(
            warnings
                .iter()
                .any(|w| matches!(w, Warning::NoManeuvers { .. })),
            "{warnings:?}"
        );
    }

    #[test]
    fn a_flight_without_attitude_has_its_noise_but_no_maneuvers() {
        let mut table = flight(PlanKind::Survey, 6);
        table.rename(ROLL, "roll_elsewhere").unwrap();
        let request = FomRequest::new("mag_1_uc");
        let mut warnings = Vec::new();
        let outcome = fom(&table, &request, None, &mut warnings).unwrap();
        assert!(outcome.before.fourth_difference_nt > 0.0);
        assert!(outcome.maneuvers.is_empty());
        assert!(outcome.heading_before.levels.is_empty());
        assert_eq!(outcome.scalar.len(), table.len());
        assert_eq!(warnings.len(), 1, "{warnings:?}");
        assert!(warnings[0]
            .to_string()
            .contains("no attitude column ins_roll"));
    }

    #[test]
    fn a_model_without_the_scalar_names_the_ones_it_has() {
        let model = ModelFile::new(Vec::new());
        assert!(matches!(
            fit_for(&model, Path::new("m.json"), "x"),
            Err(Error::EmptyModel { .. })
        ));
    }
}
