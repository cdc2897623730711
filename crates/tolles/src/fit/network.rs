//! `fit --network`: a network trained on what the linear model leaves of `scalar − reference`
//! (MagNav's model 2b), kept only when it does better on rows it never saw.
//!
//! The flight is cut into [`STRETCHES`] contiguous stretches of time, dealt in turn to three
//! roles: training (three in five), early stopping (one in five) and judging (one in five). The
//! network trains on the first, stops when the second stops improving, and is kept only when
//! on the third it leaves at most `1 − `[`KEEP_MARGIN`] of what the linear model leaves.
//! Stretches, not single rows, so that neighbouring samples, which are nearly equal, do not sit
//! on both sides of the line.

use crate::error::{Error, Result};
use crate::model::LearnedCorrection;
use crate::model::ScalarModel;
use crate::read::Flight;
use crate::warning::Warning;
use tolles_core::fit::network::{train, NetworkSettings};
use tolles_core::model::network::{feature_names, features};

/// Stretches the flight is cut into.
pub const STRETCHES: usize = 50;

/// How much less than the linear model a network must leave on the judging rows to be kept.
pub const KEEP_MARGIN: f64 = 0.05;

/// What to learn with: the network's settings and its own input channels.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct NetworkRequest {
    /// Layers, activation, seed and the training's pace.
    pub settings: NetworkSettings,
    /// Columns the network reads besides the fluxgate's direction and magnitude and the extra
    /// channels (attitude, rates, voltages; their units).
    pub channels: Vec<String>,
}

/// The most units a hidden layer may have.
pub const MAX_UNITS: usize = 256;

/// An error unless `request` asks for a network that can be trained: one to four hidden
/// layers of 1 to [`MAX_UNITS`] units.
pub fn check(request: &NetworkRequest) -> Result<()> {
    let hidden = &request.settings.hidden;
    if hidden.is_empty()
        || hidden.len() > 4
        || hidden.iter().any(|&n| !(1..=MAX_UNITS).contains(&n))
    {
        return Err(Error::Invalid(format!(
            "network layers (--network-layers; network_layers= in Python) must be 1 to 4 layers of 1 to {MAX_UNITS} units, got {hidden:?}"
        )));
    }
    Ok(())
}

/// Trains a network on `residual` (nT: the fit's target less its linear correction) of
/// `model`'s scalar on `flight` at `fs_hz` (Hz); puts it in `model` when it earns its place,
/// else says why in `warnings`.
pub fn learn(
    model: &mut ScalarModel,
    flight: &Flight,
    residual: &[f64],
    fs_hz: f64,
    request: &NetworkRequest,
    warnings: &mut Vec<Warning>,
) -> Result<()> {
    let design = &model.fit.settings.design;
    let inputs = flight.lagged_inputs(model.fit.lag_s, fs_hz);
    let channels = flight.columns(request.channels.iter().map(String::as_str))?;
    let channel_slices: Vec<&[f64]> = channels.iter().map(Vec::as_slice).collect();
    let extras: Vec<&[f64]> = inputs.extras.iter().map(Vec::as_slice).collect();
    let columns = features(&inputs.series[0], &extras, &channel_slices);
    let columns: Vec<&[f64]> = columns.iter().map(Vec::as_slice).collect();
    let names = feature_names(&model.vectors[0], &design.extras, &request.channels);
    let role = |row: usize| (row * STRETCHES / residual.len().max(1)) % 5;
    // The judging rows are kept from training as unusable rows are: a NaN target.
    let target: Vec<f64> = (residual.iter().enumerate())
        .map(|(r, v)| if role(r) == 4 { f64::NAN } else { *v })
        .collect();
    let stopping: Vec<bool> = (0..residual.len()).map(|r| role(r) == 3).collect();
    let trained = train(&names, &columns, &target, &stopping, &request.settings)
        .map_err(|e| Error::Invalid(format!("fit of {} --network: {e}", model.scalar)))?;
    let learned = trained.network.evaluate_rows(&columns);
    let judging = (0..residual.len()).filter(|&r| role(r) == 4);
    let judged = |correction: &dyn Fn(usize) -> f64| {
        rms(judging.clone().map(|r| residual[r] - correction(r)))
    };
    let linear_rms_nt = judged(&|_| trained.network.output_mean_nt);
    let network_rms_nt = judged(&|r| learned[r]);
    // NaN (no judging row) is not an improvement either.
    let better = network_rms_nt <= (1.0 - KEEP_MARGIN) * linear_rms_nt;
    if !better {
        warnings.push(Warning::NetworkNotKept {
            scalar: model.scalar.clone(),
            linear_rms_nt,
            network_rms_nt,
        });
        return Ok(());
    }
    // The model's level is the calibration's mean correction, the network's share included.
    model.fit.level_nt += tolles_core::compensate::finite_mean(&learned);
    model.network = Some(LearnedCorrection {
        channels: request.channels.clone(),
        network: trained.network,
        judged_linear_rms_nt: linear_rms_nt,
        judged_network_rms_nt: network_rms_nt,
        epochs: trained.epochs,
        best_epoch: trained.best_epoch,
        seed: request.settings.seed,
    });
    Ok(())
}

/// Root mean square of the finite values (NaN if none).
fn rms(values: impl Iterator<Item = f64>) -> f64 {
    let (sum, n) = values
        .filter(|v| v.is_finite())
        .fold((0.0, 0usize), |(s, n), v| (s + v * v, n + 1));
    (sum / n as f64).sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fit::{fit, FitRequest};
    use crate::model::ModelFile;
    use crate::simulate::{PlanKind, Preset};
    use crate::testing::flight_of;
    use tolles_io::table::{Column, Table};

    /// A simulated box with a reference magnetometer `mag_ref` (the truth without the
    /// aircraft) and, when `effect`, a field no linear term holds in the scalar:
    /// `5 nT · cos(3 · roll)`; else white noise of 5 nT (uniform), which no input predicts.
    fn box_with(effect: bool) -> Table {
        let table = flight_of(PlanKind::Box, 3, Preset::TailStinger);
        let column = |name: &str| table.numeric(name).unwrap();
        let roll = column("ins_roll");
        let truth: Vec<f64> = (column("truth_earth").iter().zip(column("truth_anomaly")))
            .zip(column("truth_diurnal"))
            .map(|((e, a), d)| e + a + d)
            .collect();
        let mut headers = table.headers().to_vec();
        let mut columns = table.columns().to_vec();
        let mut state = 0x9e37_79b9_7f4a_7c15_u64;
        let mut noise = || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            5.0 * 3f64.sqrt() * (2.0 * (state >> 11) as f64 / (1u64 << 53) as f64 - 1.0)
        };
        let k = headers.iter().position(|h| h == "mag_1_uc").unwrap();
        let scalar = column("mag_1_uc").into_iter().zip(&roll);
        let scalar = scalar.map(|(s, r)| match effect {
            true => s + 5.0 * (3.0 * r.to_radians()).cos(),
            false => s + noise(),
        });
        columns[k] = Column::Numbers(scalar.collect());
        headers.push("mag_ref".into());
        columns.push(Column::Numbers(truth));
        Table::from_columns("box.csv", headers, columns, None).unwrap()
    }

    fn request() -> FitRequest {
        FitRequest {
            reference: Some("mag_ref".into()),
            network: Some(NetworkRequest {
                channels: vec!["ins_roll".into()],
                ..NetworkRequest::default()
            }),
            ..FitRequest::new(vec!["mag_1_uc".into()], vec!["flux_a".into()])
        }
    }

    fn fitted(table: &Table) -> (ModelFile, Vec<Warning>) {
        let mut warnings = Vec::new();
        let model = fit(table, &request(), &crate::Silent, &mut warnings).unwrap();
        (model, warnings)
    }

    #[test]
    fn a_network_is_kept_for_a_field_the_linear_model_cannot_hold_and_only_then() {
        let (model, _) = fitted(&box_with(true));
        let learned = model.fits[0].network.as_ref().expect("a network");
        println!(
            "with the effect: held-out {:.4} nT, linear {:.4} nT",
            learned.judged_network_rms_nt, learned.judged_linear_rms_nt
        );
        assert!(learned.judged_network_rms_nt < 0.5 * learned.judged_linear_rms_nt);
        let (model, warnings) = fitted(&box_with(false));
        assert!(model.fits[0].network.is_none());
        let said = warnings.iter().find_map(|w| match w {
            Warning::NetworkNotKept {
                linear_rms_nt,
                network_rms_nt,
                ..
            } => Some((linear_rms_nt, network_rms_nt)),
            _ => None,
        });
        println!("noise alone: {said:?} (linear, network)");
        assert!(said.is_some(), "{warnings:?}");
    }

    #[test]
    fn the_same_seed_writes_the_same_model_and_a_damaged_network_is_refused() {
        let table = box_with(true);
        let (first, _) = fitted(&table);
        let (again, _) = fitted(&table);
        assert_eq!(first.to_json(), again.to_json());
        let json = first.to_json();
        let damaged = json.replacen("\"outputs\": 8", "\"outputs\": 7", 1);
        assert_ne!(damaged, json);
        let error = ModelFile::from_json(&damaged, "m.json")
            .unwrap_err()
            .to_string();
        assert!(
            error.contains("network") && !error.contains('\n'),
            "{error}"
        );
        let renamed = json.replacen("\"flux_a:cos_x\"", "\"flux_b:cos_x\"", 1);
        let error = ModelFile::from_json(&renamed, "m.json")
            .unwrap_err()
            .to_string();
        assert!(error.contains("inputs"), "{error}");
    }

    #[test]
    fn a_network_needs_a_reference() {
        let request = FitRequest {
            reference: None,
            ..request()
        };
        let error = fit(&box_with(true), &request, &crate::Silent, &mut Vec::new()).unwrap_err();
        assert!(error.to_string().contains("--reference"), "{error}");
    }
}
