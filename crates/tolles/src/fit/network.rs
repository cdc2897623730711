//! `fit --network`: a network trained on what the linear model leaves of `scalar − reference`
//! (MagNav's model 2b), kept only when it does better on rows it never saw.
//!
//! The calibration is cut into pieces dealt to three roles: training (three fifths of the
//! rows), early stopping (one fifth) and judging (one fifth). The network trains on the first,
//! stops when the second stops improving, and is kept only when on the third it leaves at most
//! `1 − `[`KEEP_MARGIN`] of what the linear model leaves. Pieces, not single rows, so that
//! neighbouring samples, which are nearly equal, do not sit on both sides of the line; none
//! reaches across two flights fitted together.
//!
//! The pieces are [`STRETCHES`] equal stretches of time by default, or on request
//! ([`HeldOut::Lines`]) whole flight lines, when the `line` column gives at least
//! [`MIN_LINES`] of them, none holding more than a tenth of the rows. Whole lines judge the
//! network as a survey will use it, on lines it never saw, but train it worse: fitted on three
//! simulated cabin flights with effects (box, survey, box) and compensating a fourth, four
//! seeds and plans (`bench/network_holdout`), it left 0.17–0.37 of the linear model's error
//! with whole lines against 0.09–0.18 with stretches.

use crate::error::{Error, Result};
use crate::model::ScalarModel;
// Defined with the judged results in the model file, which the warnings also read.
pub use crate::model::KEEP_MARGIN;
use crate::model::{HeldOut, LearnedCorrection};
use crate::read::Flight;
use crate::warning::Warning;
use std::ops::Range;
use tolles_core::fit::network::{train, NetworkSettings, Trained};
use tolles_core::model::network::{feature_names, features};
use tolles_io::schema::LINE_COLUMN;

/// Stretches the flight is cut into, without usable lines.
pub const STRETCHES: usize = 50;

/// The fewest flight lines held out whole; with fewer, stretches of time.
pub const MIN_LINES: usize = 10;

/// Shares of the rows for training, early stopping and judging.
const SHARES: [f64; 3] = [0.6, 0.2, 0.2];

/// What to learn with: the network's settings and its own input channels.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct NetworkRequest {
    /// Layers, activation, seed and the training's pace.
    pub settings: NetworkSettings,
    /// Columns the network reads besides the fluxgate's direction and magnitude and the extra
    /// channels (attitude, rates, voltages; their units).
    pub channels: Vec<String>,
    /// What to hold out from training to stop and to judge.
    pub held_out: HeldOut,
    /// Fit the linear model and the network in turn, each on what the other leaves (MagNav's
    /// model 2c trains them together), instead of the network on a fixed linear model (2b).
    pub joint: bool,
}

/// Rounds of refitting the linear model and retraining the network, with
/// [`NetworkRequest::joint`].
pub const JOINT_ROUNDS: usize = 2;

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

/// An error when a network input is the fit's target: a scalar being compensated or the
/// reference. Either lets the network read its own answer, so the held-out judge overstates
/// its gain, and a survey without the reference could not be compensated at all.
pub fn check_no_target(
    request: &NetworkRequest,
    scalars: &[String],
    reference: Option<&str>,
) -> Result<()> {
    let targets = scalars.iter().map(String::as_str).chain(reference);
    match targets
        .into_iter()
        .find(|t| request.channels.iter().any(|c| c == t))
    {
        None => Ok(()),
        Some(target) => Err(Error::Invalid(format!(
            "--inputs {target} (inputs= in Python): the network would read the target it learns \
             ({target} is the scalar or the reference); give other channels, e.g. currents or \
             attitude"
        ))),
    }
}

/// Trains a network on what `model`'s linear correction leaves of its `target` (nT: the
/// scalar less the reference) on `flight` at `fs_hz` (Hz); puts it in `model` when it earns
/// its place, else says why in `warnings`. With [`NetworkRequest::joint`], the linear model
/// and the network are then fitted in turn, each on what the other leaves ([`JOINT_ROUNDS`]
/// times; `refit` fits the linear model to a target on every row, as the linear model alone
/// was), and `model` becomes the pair when it earns its place against the linear model alone.
pub fn learn(
    model: &mut ScalarModel,
    flight: &Flight,
    target: &[f64],
    fs_hz: f64,
    request: &NetworkRequest,
    refit: &dyn Fn(&[f64]) -> Result<ScalarModel>,
    warnings: &mut Vec<Warning>,
) -> Result<()> {
    let residual = linear_residual(flight, model, target, fs_hz)?;
    let inputs = Inputs::of(model, flight, fs_hz, request)?;
    let lines = flight.table.numeric(LINE_COLUMN).ok();
    let (pieces, held_out) = pieces(&residual, lines.as_deref(), request.held_out);
    let roles = deal(&pieces);
    let judging: Vec<usize> = (0..residual.len())
        .filter(|&r| roles[r] == Role::Judge)
        .collect();
    let train_on = |residual: &[f64]| inputs.train(residual, &roles, &model.scalar, request);
    let mut trained = train_on(&residual)?;
    let linear_rms_nt = rms(judging
        .iter()
        .map(|&r| residual[r] - trained.network.output_mean_nt));
    let (mut paired, mut residual) = (None, residual);
    for _ in 0..if request.joint { JOINT_ROUNDS } else { 0 } {
        let learned = trained.network.evaluate_rows(&inputs.slices());
        // Every row, as the linear model alone was fitted on every row.
        let less: Vec<f64> = target.iter().zip(&learned).map(|(t, n)| t - n).collect();
        let linear = refit(&less)?;
        residual = linear_residual(flight, &linear, target, fs_hz)?;
        trained = train_on(&residual)?;
        paired = Some(linear);
    }
    let learned = trained.network.evaluate_rows(&inputs.slices());
    let network_rms_nt = rms(judging.iter().map(|&r| residual[r] - learned[r]));
    // NaN (no judging row) is not an improvement either.
    let better = network_rms_nt <= (1.0 - KEEP_MARGIN) * linear_rms_nt;
    if !better {
        warnings.push(Warning::NetworkNotKept {
            scalar: model.scalar.clone(),
            linear_rms_nt,
            network_rms_nt,
            held_out,
        });
        return Ok(());
    }
    if let Some(linear) = paired {
        *model = linear;
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
        held_out,
        joint: request.joint,
    });
    Ok(())
}

/// The network's input columns on the calibration, and their names.
struct Inputs {
    names: Vec<String>,
    columns: Vec<Vec<f64>>,
}

impl Inputs {
    /// `model`'s network inputs on `flight` at `fs_hz` (Hz): the fluxgate read as late as the
    /// fit's lag, the extra channels conditioned, and the request's channels.
    fn of(
        model: &ScalarModel,
        flight: &Flight,
        fs_hz: f64,
        request: &NetworkRequest,
    ) -> Result<Self> {
        let flight = flight.keeping_extras(&model.fit.settings.design.extras);
        let inputs = flight.lagged_inputs(model.fit.lag_s, model.fit.flux_offset_nt, fs_hz);
        let channels = flight.columns(request.channels.iter().map(String::as_str))?;
        if let Some((name, _)) = (request.channels.iter().zip(&channels))
            .find(|(_, values)| !values.iter().any(|v| v.is_finite()))
        {
            return Err(Error::Invalid(format!(
                "--inputs {name} (inputs= in Python): {} has no number in column {name:?}, so \
                 the network could learn from no row; give a channel the flight records",
                flight.table.path().display()
            )));
        }
        let channels: Vec<&[f64]> = channels.iter().map(Vec::as_slice).collect();
        let extras: Vec<&[f64]> = inputs.extras.iter().map(Vec::as_slice).collect();
        let design = &model.fit.settings.design;
        Ok(Self {
            names: feature_names(&model.vectors[0], &design.extras, &request.channels),
            columns: features(&inputs.series[0], &extras, &channels),
        })
    }

    fn slices(&self) -> Vec<&[f64]> {
        self.columns.iter().map(Vec::as_slice).collect()
    }

    /// A network trained on `residual` (nT) of the training rows, stopped on the stopping
    /// rows; the judging rows are kept from it as unusable rows are, with a NaN target.
    fn train(
        &self,
        residual: &[f64],
        roles: &[Role],
        scalar: &str,
        request: &NetworkRequest,
    ) -> Result<Trained> {
        let target: Vec<f64> = (residual.iter().zip(roles))
            .map(|(v, role)| if *role == Role::Judge { f64::NAN } else { *v })
            .collect();
        let stopping: Vec<bool> = roles.iter().map(|role| *role == Role::Stop).collect();
        let columns = self.slices();
        train(&self.names, &columns, &target, &stopping, &request.settings)
            .map_err(|e| Error::Invalid(format!("fit of {scalar} --network: {e}{}", self.gaps())))
    }

    /// `; rows without a value: name count, …` for the inputs that lack values, the likely
    /// cause when too few rows are left to train on; empty when none lacks one.
    fn gaps(&self) -> String {
        let gaps: Vec<String> = (self.names.iter().zip(&self.columns))
            .map(|(name, values)| (name, values.iter().filter(|v| !v.is_finite()).count()))
            .filter(|&(_, missing)| missing > 0)
            .map(|(name, missing)| format!("{name} {missing}"))
            .collect();
        match gaps.is_empty() {
            true => String::new(),
            false => format!(" (rows without a value, by input: {})", gaps.join(", ")),
        }
    }
}

/// What `model`'s linear correction leaves of its `target` (nT) on the calibration `flight`.
fn linear_residual(
    flight: &Flight,
    model: &ScalarModel,
    target: &[f64],
    fs_hz: f64,
) -> Result<Vec<f64>> {
    let request = crate::compensate::CompensateRequest {
        fs_hz: Some(fs_hz),
        ..Default::default()
    };
    let flight = flight.keeping_extras(&model.fit.settings.design.extras);
    let field = crate::compensate::flight_field(&flight, model, &request, &mut Vec::new())?.field;
    Ok(target.iter().zip(field).map(|(t, f)| t - f).collect())
}

/// What a row of the calibration is used for.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Role {
    Train,
    Stop,
    Judge,
}

/// The pieces (row ranges, in order, covering every row) the calibration of `residual` (nT) is
/// dealt in, and what they are: with `wanted` lines, whole lines of `lines` (the `line`
/// column) when there are enough of them, none over a tenth of the rows; else equal stretches
/// of time. A row without a residual (the row between two flights fitted together) ends a
/// piece.
fn pieces(
    residual: &[f64],
    lines: Option<&[f64]>,
    wanted: HeldOut,
) -> (Vec<Range<usize>>, HeldOut) {
    let n = residual.len();
    if let (Some(lines), HeldOut::Lines) = (lines, wanted) {
        let blocks = blocks(n, |r| {
            lines[r] == lines[r - 1] && residual[r - 1].is_finite()
        });
        let few = blocks.len() < MIN_LINES;
        if !few && blocks.iter().all(|b| 10 * b.len() <= n) {
            return (blocks, HeldOut::Lines);
        }
    }
    let stretch = |r: usize| r * STRETCHES / n.max(1);
    let blocks = blocks(n, |r| {
        stretch(r) == stretch(r - 1) && residual[r - 1].is_finite()
    });
    (blocks, HeldOut::Stretches)
}

/// The maximal ranges of `0..n` in which `continues(r)` holds for every row `r` but the first.
fn blocks(n: usize, continues: impl Fn(usize) -> bool) -> Vec<Range<usize>> {
    let mut blocks = Vec::new();
    let mut start = 0;
    for r in 1..=n {
        if r == n || !continues(r) {
            blocks.push(start..r);
            start = r;
        }
    }
    blocks
}

/// Each row's role: every piece in turn goes to the role furthest below its share of the rows
/// dealt so far ([`SHARES`]), so that pieces of any length are dealt about 3 : 1 : 1 and each
/// role has pieces from the whole calibration.
fn deal(pieces: &[Range<usize>]) -> Vec<Role> {
    let roles = [Role::Train, Role::Stop, Role::Judge];
    let mut dealt = [0usize; 3];
    let mut out = Vec::with_capacity(pieces.last().map_or(0, |p| p.end));
    for piece in pieces {
        let total = (dealt.iter().sum::<usize>() + piece.len()) as f64;
        let deficit = |k: usize| SHARES[k] * total - dealt[k] as f64;
        let k = (0..3).fold(
            0,
            |best, k| if deficit(k) > deficit(best) { k } else { best },
        );
        dealt[k] += piece.len();
        out.extend(std::iter::repeat_n(roles[k], piece.len()));
    }
    out
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
    fn an_input_without_values_is_named_and_so_is_a_network_that_could_not_be_judged() {
        let table = box_with(true);
        let mut headers = table.headers().to_vec();
        let mut columns = table.columns().to_vec();
        headers.push("cur_dead".into());
        columns.push(Column::Numbers(vec![f64::NAN; table.len()]));
        let table = Table::from_columns("box.csv", headers, columns, None).unwrap();
        let mut request = request();
        request.network.as_mut().unwrap().channels = vec!["cur_dead".into()];
        let error = fit(&table, &request, &crate::Silent, &mut Vec::new()).unwrap_err();
        let said = error.to_string();
        assert!(
            said.contains("--inputs cur_dead") && said.contains("no number"),
            "{said}"
        );
        // Judged on no row: the warning says why, not "leaves NaN nT".
        let unjudged = Warning::NetworkNotKept {
            scalar: "mag_1_uc".into(),
            linear_rms_nt: 0.2,
            network_rms_nt: f64::NAN,
            held_out: crate::model::HeldOut::default(),
        };
        let said = unjudged.to_string();
        assert!(
            said.contains("could not be judged") && !said.contains("NaN"),
            "{said}"
        );
    }

    #[test]
    fn a_network_may_not_read_the_scalar_or_the_reference() {
        let request = |channel: &str| NetworkRequest {
            channels: vec!["cur_1".into(), channel.into()],
            ..NetworkRequest::default()
        };
        let scalars = ["mag_1_uc".to_string()];
        for target in ["mag_1_uc", "mag_ref"] {
            let error = check_no_target(&request(target), &scalars, Some("mag_ref"))
                .unwrap_err()
                .to_string();
            assert!(error.starts_with(&format!("--inputs {target} ")), "{error}");
        }
        assert!(check_no_target(&request("ins_roll"), &scalars, Some("mag_ref")).is_ok());
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
    fn whole_lines_are_held_out_when_there_are_enough_and_none_crosses_two_flights() {
        // Twelve lines of 100 rows; a row between two flights after the sixth.
        let mut residual = vec![1.0; 1201];
        residual[600] = f64::NAN;
        let mut lines: Vec<f64> = (0..1201).map(|r| (r.min(1200) / 100) as f64).collect();
        lines[600] = f64::NAN;
        let (whole_lines, held_out) = pieces(&residual, Some(&lines), HeldOut::Lines);
        assert_eq!(held_out, HeldOut::Lines);
        let apart = [500..600, 600..601, 601..700]
            .iter()
            .all(|p| whole_lines.contains(p));
        assert!(apart && whole_lines.len() == 14, "{whole_lines:?}");
        // One line holding a fifth of the rows, or too few lines: stretches of time.
        let mut big = lines.clone();
        big[..240].fill(0.0);
        assert_eq!(
            pieces(&residual, Some(&big), HeldOut::Lines).1,
            HeldOut::Stretches
        );
        assert_eq!(
            pieces(&residual, Some(&lines), HeldOut::Stretches).1,
            HeldOut::Stretches
        );
        let (stretches, held_out) = pieces(&residual, Some(&vec![1.0; 1201]), HeldOut::Lines);
        assert_eq!(held_out, HeldOut::Stretches);
        assert!(stretches.iter().all(|p| p.len() <= 25) && stretches.len() == 50);
        assert_eq!(pieces(&residual, None, HeldOut::Lines).0, stretches);
    }

    #[test]
    fn pieces_of_any_length_are_dealt_three_to_one_to_one() {
        let lengths = [
            300, 20, 20, 40, 500, 60, 60, 200, 10, 90, 90, 110, 250, 30, 70,
        ];
        let mut start = 0;
        let pieces: Vec<Range<usize>> = (lengths.iter())
            .map(|len| {
                start += len;
                start - len..start
            })
            .collect();
        let roles = deal(&pieces);
        let share = |role: Role| roles.iter().filter(|&&r| r == role).count() as f64 / start as f64;
        let shares = [share(Role::Train), share(Role::Stop), share(Role::Judge)];
        println!("shares {shares:?}");
        for (got, wanted) in shares.iter().zip(SHARES) {
            assert!((got - wanted).abs() < 500.0 / start as f64, "{shares:?}");
        }
        for piece in &pieces {
            assert!(roles[piece.clone()]
                .iter()
                .all(|&r| r == roles[piece.start]));
        }
    }

    #[test]
    fn a_joint_fit_refits_the_linear_model_with_the_network() {
        let table = box_with(true);
        let (alone, _) = fitted(&table);
        let mut request = request();
        request.network.as_mut().unwrap().joint = true;
        let joint = fit(&table, &request, &crate::Silent, &mut Vec::new()).unwrap();
        let (alone, joint) = (&alone.fits[0], &joint.fits[0]);
        let learned = joint.network.as_ref().expect("a network");
        println!(
            "held-out: linear {:.4} nT, 2b {:.4} nT, 2c {:.4} nT",
            learned.judged_linear_rms_nt,
            alone.network.as_ref().unwrap().judged_network_rms_nt,
            learned.judged_network_rms_nt
        );
        assert!(learned.joint && !alone.network.as_ref().unwrap().joint);
        assert!(learned.judged_network_rms_nt < 0.5 * learned.judged_linear_rms_nt);
        let moved = (joint.fit.coefficients.iter().zip(&alone.fit.coefficients))
            .any(|(a, b)| (a - b).abs() > 1e-6 * b.abs());
        assert!(moved, "the linear model was not refitted");
        assert_eq!(
            joint.fit.diagnostics.samples_used,
            alone.fit.diagnostics.samples_used
        );
    }

    #[test]
    fn rows_whose_network_inputs_leave_the_training_range_are_said_to_be_outside() {
        let table = box_with(true);
        let (model, _) = fitted(&table);
        let outside = |shift_deg: f64| {
            let mut shifted = table.clone();
            let roll = table.numeric("ins_roll").unwrap();
            let moved = roll.iter().map(|r| r + shift_deg).collect();
            shifted.set_numeric("ins_roll", moved).unwrap();
            let mut warnings = Vec::new();
            let request = crate::compensate::CompensateRequest::default();
            crate::compensate::compensate(&shifted, &model, &request, &mut warnings).unwrap();
            let said = warnings.iter().find_map(|w| match w {
                Warning::Extrapolated { rows, .. } => Some(*rows),
                _ => None,
            });
            said.unwrap_or(0)
        };
        let (inside, beyond) = (outside(0.0), outside(90.0));
        println!("rows outside: {inside} as flown, {beyond} with the roll 90° off");
        assert!(beyond > inside + table.len() / 2, "{inside} {beyond}");
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
