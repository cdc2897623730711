//! The model file: everything needed to apply a fitted model later, as versioned JSON.
//!
//! ```
//! use tolles::model::{ModelFile, FORMAT, VERSION};
//! let file = ModelFile::new(vec![]);
//! let text = file.to_json();
//! assert!(text.contains(FORMAT));
//! assert_eq!(ModelFile::from_json(&text, "m.json").unwrap().version, VERSION);
//! ```
//!
//! Layout (version 3):
//! ```json
//! { "format": "tolles-model", "version": 3, "created_by": "tolles 0.1.0",
//!   "fits": [ { "scalar": "mag_1_uc", "vectors": ["flux_a"], "output_column": "mag_1_c",
//!               "settings": {...}, "fs_hz": 10.0, "magnitude": "exact",
//!               "columns": [...], "coefficients": [...],
//!               "level_nt": ..., "diagnostics": {...},
//!               "verdict": {"grade": "good" | "doubtful", "reasons": [...]},
//!               "uncertainty": {"covariance": [...], "mean_row": [...]},
//!               "coverage": {"cells": [...], "rate_nt_per_s": ..., "extras": [...]},
//!               "physical": {...}, "patent": {"perm_nT": {...}, "induced": {...}, "eddy_s": {...}} } ] }
//! ```
//! Version 2 adds `"magnitude": "linear" | "exact"` to each fit (how its field enters the scalar,
//! see `tolles_core::model::magnitude`), the patent's traceless term sets (`it`, `et`) and the
//! heading-level diagnostics; a version 1 file is read as linear. Version 3 adds the settings'
//! physical `prior`, the `verdict` (see `tolles_core::fit::verdict`), the coefficients'
//! `uncertainty` and the calibration's `coverage` (see `tolles_core::model::coverage`); a file
//! of an earlier version has none of them: its verdict is unknown, and compensation can give
//! it neither uncertainties nor extrapolation flags.
//!
//! A later release reads every earlier version; a file from a newer release is refused with a
//! message saying so.

use serde::{Deserialize, Serialize};
use std::path::Path;
use tolles_core::fit::Fit;
use tolles_core::model::extra::{MAX_LAG_S, MAX_LOWPASS_HZ, MIN_LOWPASS_HZ};
use tolles_core::model::interpret::AircraftField;
use tolles_core::model::network::{feature_names, Network};
use tolles_core::patent::PatentTerms;
use tolles_io::IoError;

/// The `format` tag of a model file.
pub const FORMAT: &str = "tolles-model";
/// The newest model file version this release writes and reads.
pub const VERSION: u32 = 3;

/// A model file: one fit per scalar magnetometer.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ModelFile {
    /// Always [`FORMAT`].
    pub format: String,
    /// File layout version.
    pub version: u32,
    /// The program that wrote it.
    pub created_by: String,
    /// One model per scalar.
    pub fits: Vec<ScalarModel>,
}

/// The model of one scalar magnetometer.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ScalarModel {
    /// Input column of the uncompensated scalar (nT).
    pub scalar: String,
    /// Fluxgate column prefixes (`flux_a` → `flux_a_x`, `flux_a_y`, `flux_a_z`, nT), one per
    /// block of the design, in order.
    pub vectors: Vec<String>,
    /// Name of the compensated column that `compensate` adds.
    pub output_column: String,
    /// The compensated reference magnetometer (nT) the scalar was fitted against, when it was
    /// (`fit --reference`): the fit's target was `scalar − reference`, the aircraft's field
    /// itself. Compensation does not read it.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub reference: Option<String>,
    /// The calibration flight's file as `fit` was given it (absent before version 3).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub calibration_flight: Option<String>,
    /// Coefficients, settings and diagnostics.
    #[serde(flatten)]
    pub fit: Fit,
    /// The coefficients as permanent (nT), induced (1) and eddy (s) fields (of the first
    /// fluxgate's block when there are several).
    pub physical: AircraftField,
    /// The 16 terms in the patent's nomenclature (of the first fluxgate's block).
    pub patent: PatentTerms,
    /// A network added to the linear correction (`fit --network`), when the fit kept one.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub network: Option<LearnedCorrection>,
}

/// A network added to the linear model's correction, MagNav's "model 2b": trained on what the
/// linear model leaves of `scalar − reference`, kept only when it does better on held-out rows.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct LearnedCorrection {
    /// The columns it reads besides the fluxgate and the extra channels (`fit --inputs`), in
    /// order, as recorded (their units).
    pub channels: Vec<String>,
    /// Weights, input names and normalisation (see `tolles_core::model::network`).
    pub network: Network,
    /// RMS (nT) on the judging rows of what the linear model leaves.
    pub judged_linear_rms_nt: f64,
    /// RMS (nT) on the judging rows of what the linear model and the network leave.
    pub judged_network_rms_nt: f64,
    /// Passes over the training rows, and the one whose weights were kept.
    pub epochs: usize,
    /// The pass whose weights were kept.
    pub best_epoch: usize,
    /// The seed of the initial weights and the order of the rows.
    pub seed: u64,
    /// What was held out from training to stop and to judge: whole lines or stretches of time
    /// (absent before: stretches).
    #[serde(default)]
    pub held_out: HeldOut,
    /// Whether the linear model was refitted with the network, each on what the other leaves
    /// (MagNav's model 2c), rather than the network trained on a fixed linear model (2b).
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub joint: bool,
}

/// How much less than the linear model a network must leave on the judging rows to be kept.
pub const KEEP_MARGIN: f64 = 0.05;

/// The pieces of a calibration flight that `fit --network` deals to training, stopping and
/// judging.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum HeldOut {
    /// Equal stretches of time, none across two flights.
    #[default]
    Stretches,
    /// Whole flight lines (contiguous rows of one value of the `line` column, in one flight).
    Lines,
}

impl std::str::FromStr for HeldOut {
    type Err = String;

    /// `stretches` or `lines`.
    fn from_str(text: &str) -> Result<Self, String> {
        match text.trim().to_ascii_lowercase().as_str() {
            "stretches" => Ok(HeldOut::Stretches),
            "lines" => Ok(HeldOut::Lines),
            _ => Err(format!("expected stretches or lines, got {text:?}")),
        }
    }
}

impl std::fmt::Display for HeldOut {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            HeldOut::Stretches => "stretches",
            HeldOut::Lines => "lines",
        })
    }
}

impl ScalarModel {
    /// Wraps a fit of `scalar` against the fluxgates `vectors` (one per block of the fit's
    /// design); the fit's column names get the fluxgates' names when there are several.
    pub fn new(scalar: &str, vectors: &[String], mut fit: Fit) -> Self {
        let physical =
            AircraftField::from_coefficients(&fit.settings.design, &fit.coefficients, fit.fs_hz);
        fit.columns = fit.settings.design.column_names(vectors);
        Self {
            scalar: scalar.to_string(),
            vectors: vectors.to_vec(),
            output_column: compensated_name(scalar),
            reference: None,
            calibration_flight: None,
            patent: physical.patent_terms(),
            physical,
            fit,
            network: None,
        }
    }
}

impl ScalarModel {
    /// The unit of coefficient `k`: nT for the aircraft's terms (the induced and eddy columns
    /// are scaled by `bt_scale`), nT per the channel's unit for an extra channel's (`nT/A` for
    /// `cur_*`, [`tolles_io::schema::channel_unit`]), `nT per unit of NAME` when its name does
    /// not say its unit.
    pub fn coefficient_unit(&self, k: usize) -> String {
        let design = &self.fit.settings.design;
        match design.design_terms().get(k).map(|t| t.column) {
            Some(tolles_core::model::terms::Column::Extra { channel, .. }) => {
                let name = design.extras.get(channel).map_or("?", |e| e.name.as_str());
                match tolles_io::schema::channel_unit(name) {
                    Some(unit) => format!("nT/{unit}"),
                    None => format!("nT per unit of {name}"),
                }
            }
            _ => "nT".to_string(),
        }
    }

    /// Records that the fit was made against the reference magnetometer `column`.
    pub fn with_reference(mut self, column: Option<&str>) -> Self {
        self.reference = column.map(str::to_string);
        self
    }

    /// The fitted model to apply: its design, coefficients (for the calibration's sample rate)
    /// and magnitude model.
    pub fn applied(&self) -> tolles_core::compensate::Model<'_> {
        tolles_core::compensate::Model {
            design: &self.fit.settings.design,
            coefficients: &self.fit.coefficients,
            magnitude: self.fit.magnitude,
        }
    }

    /// Records the calibration flight's file.
    pub fn with_calibration_flight(mut self, path: &Path) -> Self {
        self.calibration_flight = Some(path.display().to_string());
        self
    }
}

pub use tolles_io::schema::compensated_name;

impl ModelFile {
    /// A current-version file holding `fits`.
    pub fn new(fits: Vec<ScalarModel>) -> Self {
        Self {
            format: FORMAT.to_string(),
            version: VERSION,
            created_by: format!("tolles {}", env!("CARGO_PKG_VERSION")),
            fits,
        }
    }

    /// Pretty JSON text.
    pub fn to_json(&self) -> String {
        serde_json::to_string_pretty(self).expect("a model always serialises")
    }

    /// Parses JSON text; `name` is used in error messages.
    pub fn from_json(text: &str, name: impl AsRef<Path>) -> Result<Self, IoError> {
        let path = name.as_ref().to_path_buf();
        let fail = |message: String| IoError::Model {
            path: path.clone(),
            message,
        };
        let value: serde_json::Value =
            serde_json::from_str(text).map_err(|e| fail(format!("invalid JSON ({e})")))?;
        if value.get("format").and_then(|f| f.as_str()) != Some(FORMAT) {
            return Err(fail(format!("missing \"format\": \"{FORMAT}\"")));
        }
        let version = value.get("version");
        match version.map(|v| (v, v.as_u64())) {
            Some((_, Some(v))) if v >= 1 && v <= VERSION as u64 => {}
            Some((_, Some(0))) => {
                return Err(fail(
                    "version 0 is not a version tolles wrote (versions start at 1)".to_string(),
                ))
            }
            Some((_, Some(v))) => {
                return Err(fail(format!(
                    "version {v} is newer than this tolles understands ({VERSION}); upgrade tolles"
                )))
            }
            Some((v, None)) => {
                return Err(fail(format!(
                    "\"version\" must be a whole number from 1 to {VERSION}, got {v}"
                )))
            }
            None => return Err(fail("missing \"version\"".to_string())),
        }
        let file: ModelFile =
            serde_json::from_value(value).map_err(|e| fail(format!("bad contents ({e})")))?;
        file.check().map_err(fail)?;
        Ok(file)
    }

    fn check(&self) -> Result<(), String> {
        for fit in &self.fits {
            let width = fit.fit.settings.design.width();
            if fit.fit.coefficients.len() != width {
                return Err(format!(
                    "fit of {} has {} coefficients for {} terms",
                    fit.scalar,
                    fit.fit.coefficients.len(),
                    width
                ));
            }
            let fluxgates = fit.fit.settings.design.fluxgates;
            if fit.vectors.len() != fluxgates || fluxgates == 0 {
                return Err(format!(
                    "fit of {} names {} fluxgates for a design over {fluxgates}",
                    fit.scalar,
                    fit.vectors.len(),
                ));
            }
            check_numbers(fit)?;
        }
        Ok(())
    }

    /// The model as a reader of its file sees it: an error (naming `name`) where writing and
    /// reading it back would fail, a number JSON cannot hold or one no fit can produce.
    pub fn validated(self, name: impl AsRef<Path>) -> Result<Self, IoError> {
        Self::from_json(&self.to_json(), name)
    }

    /// Reads a model file.
    pub fn read(path: &Path) -> Result<Self, IoError> {
        let text = std::fs::read_to_string(path).map_err(|source| IoError::Open {
            path: path.to_path_buf(),
            source,
        })?;
        Self::from_json(&text, path)
    }

    /// Writes a model file.
    pub fn write(&self, path: &Path) -> Result<(), IoError> {
        tolles_io::atomic::write_bytes(path, (self.to_json() + "\n").as_bytes())
    }
}

/// Sample rates (Hz) a model can have been fitted at; outside them eddy terms rescale to garbage.
pub const FS_RANGE_HZ: (f64, f64) = (1e-3, 1e6);
/// The scale (nT) the induced and eddy columns are divided by: MagNav's is 50 000, the earth's
/// field; a subnormal one would turn every row into an infinity, read back as missing data.
const BT_SCALE_RANGE_NT: (f64, f64) = (1.0, 1e6);
/// Largest believable σ noise term (nT): more than any aircraft field.
const NOISE_LIMIT_NT: f64 = 1e5;
/// Largest believable |covariance| or |mean design row| entry (the coefficients' units
/// squared; the columns' units): the square of [`COEFFICIENT_LIMIT`].
const COVARIANCE_LIMIT: f64 = COEFFICIENT_LIMIT * COEFFICIENT_LIMIT;
/// Largest believable |coefficient| or |level| (nT per unit of its column): anything larger is
/// a damaged file, and would otherwise surface later as an unrelated-looking failure.
const COEFFICIENT_LIMIT: f64 = 1e9;

/// Every number a model is applied with: finite, and in a range that can have come from a fit.
fn check_numbers(fit: &ScalarModel) -> Result<(), String> {
    let scalar = &fit.scalar;
    let (lo, hi) = FS_RANGE_HZ;
    let fs = fit.fit.fs_hz;
    if !(lo..=hi).contains(&fs) {
        return Err(format!(
            "fit of {scalar}: fs_hz {} is outside {lo}–{hi} Hz",
            show(fs)
        ));
    }
    let bt = fit.fit.settings.design.bt_scale;
    if !(BT_SCALE_RANGE_NT.0..=BT_SCALE_RANGE_NT.1).contains(&bt) {
        return Err(format!(
            "fit of {scalar}: settings.design.bt_scale {} must lie within {}–{} nT",
            show(bt),
            BT_SCALE_RANGE_NT.0,
            BT_SCALE_RANGE_NT.1
        ));
    }
    if fit.fit.columns.len() != fit.fit.coefficients.len() {
        return Err(format!(
            "fit of {scalar}: {} column names for {} coefficients",
            fit.fit.columns.len(),
            fit.fit.coefficients.len()
        ));
    }
    check_lags(fit)?;
    let level = fit.fit.level_nt;
    if !believable(level) {
        return Err(format!(
            "fit of {scalar}: level_nt {} is not a believable level",
            show(level)
        ));
    }
    for (j, b) in fit.fit.coefficients.iter().enumerate() {
        if !believable(*b) {
            let name = fit.fit.columns.get(j).map_or("?", String::as_str);
            return Err(format!(
                "fit of {scalar}: coefficients[{j}] ({name}) = {} is not finite or beyond ±{COEFFICIENT_LIMIT:e}",
                show(*b)
            ));
        }
    }
    check_trust(fit)?;
    check_network(fit)
}

/// A stored network's shapes and numbers, and its inputs' names: what the fit that made it
/// would have named them.
fn check_network(fit: &ScalarModel) -> Result<(), String> {
    let Some(learned) = &fit.network else {
        return Ok(());
    };
    let scalar = &fit.scalar;
    learned
        .network
        .validate()
        .map_err(|e| format!("fit of {scalar}: {e}"))?;
    let vector = fit.vectors.first().map_or("", String::as_str);
    let extras = &fit.fit.settings.design.extras;
    let expected = feature_names(vector, extras, &learned.channels);
    if learned.network.inputs != expected {
        return Err(format!(
            "fit of {scalar}: network: inputs {:?} are not those of its fluxgate, extra channels and channels {:?}",
            learned.network.inputs, expected
        ));
    }
    Ok(())
}

/// The fluxgate's lag and each extra channel's lag and low-pass, as `fit` accepts them: lags
/// finite within ±[`MAX_LAG_S`] s, a low-pass corner in [[`MIN_LOWPASS_HZ`], [`MAX_LOWPASS_HZ`]] Hz.
fn check_lags(fit: &ScalarModel) -> Result<(), String> {
    let scalar = &fit.scalar;
    let lag_ok = |lag: f64| lag.is_finite() && lag.abs() <= MAX_LAG_S;
    if !lag_ok(fit.fit.lag_s) {
        return Err(format!(
            "fit of {scalar}: lag_s {} is not a lag within ±{MAX_LAG_S} s",
            show(fit.fit.lag_s)
        ));
    }
    if let Some(offset) = fit.fit.flux_offset_nt {
        let bound = tolles_core::fit::levels::MAX_OFFSET_NT;
        if !offset.iter().all(|o| o.is_finite() && o.abs() <= bound) {
            return Err(format!(
                "fit of {scalar}: flux_offset_nt {offset:?} is not a fluxgate offset within ±{bound} nT"
            ));
        }
        if fit.fit.settings.design.fluxgates != 1 {
            return Err(format!(
                "fit of {scalar}: flux_offset_nt is for a lone fluxgate, and the design has {}",
                fit.fit.settings.design.fluxgates
            ));
        }
    }
    for extra in &fit.fit.settings.design.extras {
        let name = &extra.name;
        if !lag_ok(extra.lag_s) {
            return Err(format!(
                "fit of {scalar}: extra channel {name}: lag_s {} is not a lag within ±{MAX_LAG_S} s",
                show(extra.lag_s)
            ));
        }
        if let Some(corner) = extra.lowpass_hz {
            if !(MIN_LOWPASS_HZ..=MAX_LOWPASS_HZ).contains(&corner) {
                return Err(format!(
                    "fit of {scalar}: extra channel {name}: lowpass_hz {} is not a corner in [{MIN_LOWPASS_HZ:e}, {MAX_LOWPASS_HZ:e}] Hz",
                    show(corner)
                ));
            }
        }
    }
    Ok(())
}

/// The uncertainty and coverage a compensation reads: as long as the design needs and finite.
fn check_trust(fit: &ScalarModel) -> Result<(), String> {
    let scalar = &fit.scalar;
    let width = fit.fit.coefficients.len();
    if let Some(u) = &fit.fit.uncertainty {
        if u.mean_row.len() != width || u.covariance.len() != width * width {
            return Err(format!(
                "fit of {scalar}: uncertainty has {} mean values and {} covariances for {width} terms",
                u.mean_row.len(),
                u.covariance.len()
            ));
        }
        let bounded = |v: &[f64]| v.iter().all(|x| x.abs() <= COVARIANCE_LIMIT);
        if !(bounded(&u.mean_row) && bounded(&u.covariance)) {
            return Err(format!(
                "fit of {scalar}: uncertainty holds a value that is not finite or beyond ±{COVARIANCE_LIMIT:e}"
            ));
        }
        // Rounding leaves a variance of zero slightly negative; more than that is damage.
        let diagonal: Vec<f64> = (0..width).map(|j| u.covariance[j * width + j]).collect();
        let rounding = 1e-9 * diagonal.iter().fold(0.0, |m: f64, d| m.max(d.abs()));
        if let Some(j) = diagonal.iter().position(|d| *d < -rounding) {
            return Err(format!(
                "fit of {scalar}: uncertainty.covariance gives coefficient {j} a negative variance"
            ));
        }
        if !(0.0..=NOISE_LIMIT_NT).contains(&u.noise_nt) {
            return Err(format!(
                "fit of {scalar}: uncertainty.noise_nt {} must lie within 0–{NOISE_LIMIT_NT} nT",
                show(u.noise_nt)
            ));
        }
    }
    if let Some(c) = &fit.fit.coverage {
        let extras = fit.fit.settings.design.extras.len();
        if !(c.rate_nt_per_s.is_finite() && c.rate_nt_per_s >= 0.0) {
            return Err(format!(
                "fit of {scalar}: coverage.rate_nt_per_s {} must be a rate ≥ 0",
                show(c.rate_nt_per_s)
            ));
        }
        if !c.extras.is_empty() && c.extras.len() != extras {
            return Err(format!(
                "fit of {scalar}: coverage has {} channel ranges for {extras} extra channels",
                c.extras.len()
            ));
        }
    }
    Ok(())
}

/// Finite and within ±[`COEFFICIENT_LIMIT`] (NaN is not).
fn believable(v: f64) -> bool {
    v.abs() <= COEFFICIENT_LIMIT
}

/// A number for a message: plain when of ordinary size, else in scientific notation.
fn show(v: f64) -> String {
    if v == 0.0 || (1e-3..1e9).contains(&v.abs()) {
        format!("{v}")
    } else {
        format!("{v:e}")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn output_names() {
        assert_eq!(compensated_name("mag_1_uc"), "mag_1_c");
        assert_eq!(compensated_name("mag3"), "mag3_c");
    }

    #[test]
    fn newer_and_foreign_files_are_refused_clearly() {
        let newer = r#"{"format":"tolles-model","version":99,"created_by":"x","fits":[]}"#;
        let err = ModelFile::from_json(newer, "m.json")
            .unwrap_err()
            .to_string();
        assert!(err.contains("upgrade tolles"), "{err}");
        let foreign = r#"{"hello":1}"#;
        let err = ModelFile::from_json(foreign, "m.json")
            .unwrap_err()
            .to_string();
        assert!(err.starts_with("m.json: not a tolles model file"), "{err}");
        assert!(ModelFile::from_json("{", "m.json").is_err());
    }

    #[test]
    fn a_version_1_file_reads_as_a_linear_model_and_exact_round_trips() {
        use tolles_core::model::magnitude::Magnitude;
        let v1 = ModelFile::from_json(&model_with("/version", "1"), "m.json").unwrap();
        assert_eq!(v1.fits[0].fit.magnitude, Magnitude::Linear);
        let mut file = v1.clone();
        file.fits[0].fit.magnitude = Magnitude::Exact;
        let text = file.to_json();
        assert!(text.contains(r#""magnitude": "exact""#), "{text}");
        let back = ModelFile::from_json(&text, "m.json").unwrap();
        assert_eq!(back.fits[0].fit.magnitude, Magnitude::Exact);
    }

    /// A minimal valid model file, with `field` replaced by `value` (JSON text).
    fn model_with(field: &str, value: &str) -> String {
        use tolles_core::fit::FitSettings;
        let fit = Fit {
            settings: FitSettings::magnav(),
            fs_hz: 10.0,
            magnitude: Default::default(),
            lag_s: 0.0,
            flux_offset_nt: None,
            columns: vec![],
            coefficients: vec![1.0; FitSettings::magnav().design.width()],
            level_nt: 0.0,
            diagnostics: serde_json::from_value(serde_json::json!({
                "samples_total": 1, "samples_nonfinite": 0, "samples_in_short_runs": 0,
                "samples_used": 1, "runs_used": 1, "filtered_std_before_nt": 1.0,
                "residual_std_nt": 1.0, "improvement_ratio": 1.0, "condition_number": 1.0,
                "effective_sample_fraction": 1.0, "penalty": [], "cross_validation": null,
                "std_errors": []
            }))
            .unwrap(),
            verdict: None,
            uncertainty: None,
            coverage: None,
        };
        let file = ModelFile::new(vec![ScalarModel::new("mag_1_uc", &["flux_a".into()], fit)]);
        let mut value_json: serde_json::Value = serde_json::from_str(&file.to_json()).unwrap();
        let target = value_json.pointer_mut(field).unwrap();
        *target = serde_json::from_str(value).unwrap();
        value_json.to_string()
    }

    #[test]
    fn every_number_is_validated_with_its_field_named() {
        assert!(ModelFile::from_json(&model_with("/version", "1"), "m.json").is_ok());
        for (field, value, says) in [
            ("/fits/0/fs_hz", "-10", "fs_hz -10"),
            ("/fits/0/fs_hz", "1e-300", "fs_hz 1e-300"),
            ("/fits/0/settings/design/bt_scale", "-5", "bt_scale -5"),
            ("/fits/0/coefficients/2", "1e308", "coefficients[2]"),
            ("/fits/0/level_nt", "1e300", "level_nt"),
            ("/version", "0", "version 0 is not a version tolles wrote"),
            (
                "/version",
                "-1",
                "\"version\" must be a whole number from 1 to 3, got -1",
            ),
            (
                "/version",
                "1.5",
                "must be a whole number from 1 to 3, got 1.5",
            ),
            (
                "/version",
                "\"2\"",
                "must be a whole number from 1 to 3, got \"2\"",
            ),
        ] {
            let err = ModelFile::from_json(&model_with(field, value), "m.json")
                .unwrap_err()
                .to_string();
            assert!(err.contains(says), "{field}: {err}");
            assert_eq!(err.lines().count(), 1, "{err}");
        }
    }

    #[test]
    fn hostile_scales_columns_and_uncertainties_are_refused() {
        use tolles_core::fit::FitSettings;
        let width = FitSettings::magnav().design.width();
        let uncertainty = |diagonal: f64, noise: f64| {
            let mut covariance = vec![0.0; width * width];
            covariance[0] = diagonal;
            serde_json::json!({
                "covariance": covariance, "mean_row": vec![0.0; width], "noise_nt": noise
            })
            .to_string()
        };
        let with_uncertainty = |field: &str, value: &str| {
            let mut json: serde_json::Value =
                serde_json::from_str(&model_with("/version", "3")).unwrap();
            json["fits"][0]["uncertainty"] = serde_json::from_str(&uncertainty(1.0, 0.1)).unwrap();
            *json.pointer_mut(field).unwrap() = serde_json::from_str(value).unwrap();
            json.to_string()
        };
        let good = with_uncertainty("/version", "3");
        assert!(ModelFile::from_json(&good, "m.json").is_ok());
        for (field, value, says) in [
            (
                "/fits/0/settings/design/bt_scale",
                "1e-320".into(),
                "bt_scale",
            ),
            ("/fits/0/columns/0", "null".into(), "invalid"),
            (
                "/fits/0/uncertainty",
                uncertainty(-1.0, 0.1),
                "negative variance",
            ),
            ("/fits/0/uncertainty", uncertainty(1e300, 0.1), "beyond"),
            (
                "/fits/0/uncertainty",
                uncertainty(1.0, 1e300),
                "noise_nt 1e300",
            ),
        ] {
            let err = ModelFile::from_json(&with_uncertainty(field, &value), "m.json")
                .unwrap_err()
                .to_string();
            assert!(err.contains(says), "{field}: {err}");
        }
        let mut json: serde_json::Value = serde_json::from_str(&good).unwrap();
        json.pointer_mut("/fits/0/columns")
            .and_then(serde_json::Value::as_array_mut)
            .unwrap()
            .pop();
        let err = ModelFile::from_json(&json.to_string(), "m.json")
            .unwrap_err()
            .to_string();
        assert!(err.contains("column names for"), "{err}");
    }

    #[test]
    fn hand_edited_lags_and_low_passes_are_refused() {
        let edited = |edit: &dyn Fn(&mut serde_json::Value)| {
            let mut value: serde_json::Value =
                serde_json::from_str(&model_with("/version", "3")).unwrap();
            edit(&mut value["fits"][0]);
            ModelFile::from_json(&value.to_string(), "m.json")
        };
        assert!(edited(&|_| {}).is_ok());
        for lag in [1e300, -61.0] {
            let err = edited(&|fit| fit["lag_s"] = lag.into()).unwrap_err();
            assert!(err.to_string().contains("lag_s"), "{err}");
        }
        let offset = |o: serde_json::Value| edited(&|fit| fit["flux_offset_nt"] = o.clone());
        assert!(offset(serde_json::json!([1500.0, -2200.0, 900.0])).is_ok());
        for bad in [
            serde_json::json!([1e300, 0.0, 0.0]),
            serde_json::json!([0.0, -3e4, 0.0]),
        ] {
            let err = offset(bad).unwrap_err().to_string();
            assert!(err.contains("flux_offset_nt"), "{err}");
        }
        let with_extra = |lowpass: f64, lag: f64| {
            edited(&|fit| {
                fit["settings"]["design"]["extras"] = serde_json::json!([
                    {"name": "cur", "lowpass_hz": lowpass, "lag_s": lag}
                ]);
                let coefficients = fit["coefficients"].as_array_mut().unwrap();
                coefficients.extend([0.0.into(), 0.0.into(), 0.0.into()]);
                let columns = fit["columns"].as_array_mut().unwrap();
                columns.extend(["cur_x".into(), "cur_y".into(), "cur_z".into()]);
            })
        };
        assert!(with_extra(0.5, 0.2).is_ok());
        for (lowpass, lag, says) in [
            (0.0, 0.0, "lowpass_hz 0"),
            (-1.0, 0.0, "lowpass_hz -1"),
            (1e300, 0.0, "lowpass_hz"),
            (0.5, 1e300, "lag_s"),
        ] {
            let err = with_extra(lowpass, lag).unwrap_err().to_string();
            assert!(
                err.contains("extra channel cur") && err.contains(says),
                "{err}"
            );
        }
    }
}
