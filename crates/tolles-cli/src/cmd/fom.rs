//! `tolles fom`: the figure of merit of a compensation box, maneuvers found automatically.

use crate::cmd::compensate::compensate_flight;
use crate::input::{parse_band, sample_rate, time_column, Flight};
use anyhow::{anyhow, bail, Context, Result};
use serde_json::{json, Value};
use std::io::Write;
use std::path::PathBuf;
use tolles_core::fit::Band;
use tolles_core::fom::{fom, improvement_ratio, FomReport, FomSettings, ManeuverFom, Slot};
use tolles_core::maneuver::{detect_maneuvers, Maneuver, ManeuverSettings};
use tolles_io::model::{ModelFile, ScalarModel};
use tolles_io::table::Table;

/// Attitude columns (degrees) the maneuvers are found in.
const ROLL: &str = "ins_roll";
const PITCH: &str = "ins_pitch";
const YAW: &str = "ins_yaw";

const EXAMPLES: &str = "\
Examples:
  # A simulated box and its model, then its FOM before and after compensation:
  tolles demo --out demo
  tolles fom demo/calibration.csv --scalar mag_1_uc --model demo/model.json

  # Uncompensated only, as JSON, in MagNav's band:
  tolles fom cal.csv --scalar mag_1_uc --band 0.1,0.9 --json";

/// Figure of merit (FOM) of a compensation box: the sum over its 12 maneuvers (roll, pitch and
/// yaw on headings 0, 90, 180 and 270°) of the peak-to-peak of the band-passed scalar.
///
/// The maneuvers are found in the attitude columns ins_roll, ins_pitch and ins_yaw (degrees) and
/// the time column tt (s); no times need marking. The whole signal is band-passed once (zero
/// phase), then the peak-to-peak is taken over each maneuver. A maneuver flown twice counts once
/// (the one with the larger attitude amplitude); maneuvers off the cardinal headings are listed
/// but not counted; box maneuvers not found are listed as missing and the FOM sums the others.
/// With --model the FOM is also computed on the data compensated exactly as `tolles compensate`
/// does, and the improvement ratio is uncompensated FOM / compensated FOM (null without a model).
#[derive(clap::Args)]
#[command(after_help = EXAMPLES)]
pub struct Args {
    /// Flight data (CSV, XYZ, GDF, HDF5 or Parquet, by extension) with tt, ins_roll, ins_pitch, ins_yaw and the scalar column
    pub flight: PathBuf,
    /// Scalar magnetometer column (nT)
    #[arg(long)]
    pub scalar: String,
    /// Model file written by `tolles fit`; also report the FOM after compensation
    #[arg(long)]
    pub model: Option<PathBuf>,
    /// Band-pass edges LO,HI in Hz applied before taking peak-to-peaks
    #[arg(long, default_value = "0.05,1.0")]
    pub band: String,
    /// Butterworth order of the band-pass (per edge)
    #[arg(long, default_value_t = 4)]
    pub order: usize,
    /// Print JSON instead of a table
    #[arg(long)]
    pub json: bool,
    /// Sample rate in Hz (default: from the tt column)
    #[arg(long)]
    pub fs: Option<f64>,
    #[command(flatten)]
    pub select: crate::select::Selection,
}

/// What the command found and computed.
pub struct Outcome {
    /// Time (s), from the file or made from the sample rate.
    pub tt: Vec<f64>,
    /// Sample rate (Hz).
    pub fs_hz: f64,
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
}

pub fn run(args: Args) -> Result<()> {
    let (pass1_hz, pass2_hz) = parse_band(&args.band)?;
    let settings = FomSettings {
        band: Band { pass1_hz, pass2_hz },
        order: args.order,
    };
    let model = args.model.as_deref().map(ModelFile::read).transpose()?;
    let scalar_model = model
        .as_ref()
        .map(|m| model_for(m, args.model.as_deref(), &args.scalar))
        .transpose()?;
    let table = args.select.read(&args.flight, crate::select::Use::Fom)?;
    let outcome = evaluate(table, &args.scalar, scalar_model, args.fs, &settings)?;
    let mut out = std::io::stdout().lock();
    if args.json {
        writeln!(out, "{}", serde_json::to_string_pretty(&to_json(&outcome))?)?;
    } else {
        write_table(&mut out, &args, &outcome)?;
    }
    out.flush()?;
    Ok(())
}

/// Finds the box maneuvers of a flight and its FOM before and (given a model) after
/// compensation, warning on stderr about what is missing.
pub fn evaluate(
    table: Table,
    scalar_name: &str,
    scalar_model: Option<&ScalarModel>,
    fs: Option<f64>,
    settings: &FomSettings,
) -> Result<Outcome> {
    let (roll, pitch, yaw) = (
        table.numeric(ROLL)?,
        table.numeric(PITCH)?,
        table.numeric(YAW)?,
    );
    let scalar = table.numeric(scalar_name)?;
    let tt = time_column(&table)?;
    let fs_hz = sample_rate(&table, tt.as_deref(), fs)?;
    let tt = tt.unwrap_or_else(|| (0..table.len()).map(|k| k as f64 / fs_hz).collect());
    let maneuvers = detect_maneuvers(&tt, &roll, &pitch, &yaw, &ManeuverSettings::default());
    let file = table.path().display().to_string();
    if maneuvers.is_empty() {
        eprintln!("warning: {file}: no roll, pitch or yaw maneuvers found in columns {ROLL}, {PITCH}, {YAW}; is this a compensation flight?");
    }
    let before =
        fom(&scalar, Some(&tt), &maneuvers, fs_hz, settings).with_context(|| file.clone())?;
    let compensated = match scalar_model {
        None => None,
        Some(scalar_model) => {
            let flight = Flight::from_table(&table, &scalar_model.scalar, &scalar_model.vectors)?;
            let result = compensate_flight(&flight, scalar_model, fs)?;
            if result.uncomputable > 0 {
                eprintln!(
                    "warning: {file}: {} of {} rows cannot be compensated (missing scalar or fluxgate values)",
                    result.uncomputable,
                    result.compensated.len()
                );
            }
            Some(result.compensated)
        }
    };
    let after = compensated
        .as_ref()
        .map(|c| fom(c, Some(&tt), &maneuvers, fs_hz, settings).with_context(|| file.clone()))
        .transpose()?;
    let outcome = Outcome {
        tt,
        fs_hz,
        scalar,
        compensated,
        maneuvers,
        before,
        after,
    };
    warn_about_gaps(&file, &outcome);
    Ok(outcome)
}

/// The model's fit for the scalar `scalar`; `path` names the model file in messages.
pub fn model_for<'m>(
    model: &'m ModelFile,
    path: Option<&std::path::Path>,
    scalar: &str,
) -> Result<&'m ScalarModel> {
    let path = path.unwrap_or(std::path::Path::new("")).display();
    if model.fits.is_empty() {
        bail!("{path}: the model holds no fits");
    }
    model
        .fits
        .iter()
        .find(|f| f.scalar == scalar)
        .ok_or_else(|| {
            let names: Vec<&str> = model.fits.iter().map(|f| f.scalar.as_str()).collect();
            anyhow!(
                "{path}: no fit for scalar {scalar:?}; the model has fits for: {}",
                names.join(", ")
            )
        })
}

fn warn_about_gaps(file: &str, outcome: &Outcome) {
    for report in std::iter::once(&outcome.before).chain(&outcome.after) {
        for m in report.maneuvers.iter().filter(|m| m.unfiltered_samples > 0) {
            eprintln!(
                "warning: {file}: {} on heading {}° at {:.1}–{:.1} s: {} samples have no band-passed value (missing data); its peak-to-peak uses the rest",
                m.maneuver.kind,
                heading_text(&m.maneuver),
                m.maneuver.start_tt,
                m.maneuver.end_tt,
                m.unfiltered_samples
            );
        }
    }
}

fn to_json(outcome: &Outcome) -> Value {
    let mut value = block_json(&outcome.before);
    let ratio = outcome
        .after
        .as_ref()
        .map(|after| improvement_ratio(&outcome.before, after))
        .filter(|r| r.is_finite());
    value["improvement_ratio"] = json!(ratio);
    if let Some(after) = &outcome.after {
        value["compensated"] = block_json(after);
    }
    value
}

fn block_json(report: &FomReport) -> Value {
    let maneuver = |m: &ManeuverFom| {
        json!({
            "heading_deg": heading_json(&m.maneuver),
            "kind": m.maneuver.kind,
            "start_tt": m.maneuver.start_tt,
            "end_tt": m.maneuver.end_tt,
            "peak_to_peak_nT": finite(m.peak_to_peak_nt),
        })
    };
    json!({
        "fom_nT": report.fom_nt,
        "band_hz": [report.band_hz.0, report.band_hz.1],
        "fourth_difference_nT": finite(report.fourth_difference_nt),
        "maneuvers": report.counted().map(maneuver).collect::<Vec<_>>(),
        "extra_maneuvers": report.maneuvers.iter().filter(|m| !m.counted).map(maneuver).collect::<Vec<_>>(),
        "missing": report.missing.iter().map(|s: &Slot| json!({"heading_deg": s.heading_deg, "kind": s.kind})).collect::<Vec<_>>(),
    })
}

/// A cardinal heading as an integer, any other as measured.
fn heading_json(m: &Maneuver) -> Value {
    match m.cardinal_heading_deg() {
        Some(h) => json!(h as u16),
        None => json!(m.heading_deg),
    }
}

fn heading_text(m: &Maneuver) -> String {
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

fn write_table(out: &mut impl Write, args: &Args, o: &Outcome) -> Result<()> {
    let (lo, hi) = o.before.band_hz;
    writeln!(
        out,
        "FOM of {}, scalar {}{}",
        args.flight.display(),
        args.scalar,
        args.model
            .as_ref()
            .map(|m| format!(", model {}", m.display()))
            .unwrap_or_default()
    )?;
    writeln!(
        out,
        "Band-pass {lo}–{hi} Hz (Butterworth order {}, zero phase); {} maneuvers found in the attitude; peak-to-peak in nT.\n",
        args.order,
        o.maneuvers.len()
    )?;
    let with_after = o.after.is_some();
    write!(
        out,
        "{:>8}  {:<6}  {:>15}  {:>9}  {:>8}  {:>13}",
        "heading", "kind", "time (s)", "amplitude", "period", "uncompensated"
    )?;
    if with_after {
        write!(out, "  {:>11}", "compensated")?;
    }
    writeln!(out)?;
    let after = o.after.as_ref();
    for (k, m) in o
        .before
        .maneuvers
        .iter()
        .enumerate()
        .filter(|(_, m)| m.counted)
    {
        let man = &m.maneuver;
        write!(
            out,
            "{:>7}°  {:<6}  {:>15}  {:>8.1}°  {:>6.1} s  {:>13.3}",
            heading_text(man),
            man.kind.name(),
            format!("{:.1}–{:.1}", man.start_tt, man.end_tt),
            man.amplitude_deg,
            man.period_s,
            m.peak_to_peak_nt
        )?;
        if let Some(after) = after {
            write!(out, "  {:>11.3}", after.maneuvers[k].peak_to_peak_nt)?;
        }
        writeln!(out)?;
    }
    write!(out, "{:>8}  {:<44}  {:>13.3}", "FOM", "", o.before.fom_nt)?;
    if let Some(after) = after {
        write!(out, "  {:>11.3}", after.fom_nt)?;
    }
    writeln!(out, "\n")?;
    match after {
        Some(after) => writeln!(
            out,
            "improvement ratio (FOM uncompensated / compensated): {:.1}\nfourth-difference noise: {:.4} nT uncompensated, {:.4} nT compensated",
            improvement_ratio(&o.before, after),
            o.before.fourth_difference_nt,
            after.fourth_difference_nt
        )?,
        None => writeln!(
            out,
            "improvement ratio: give --model to compare with the compensated data\nfourth-difference noise: {:.4} nT",
            o.before.fourth_difference_nt
        )?,
    }
    for slot in &o.before.missing {
        writeln!(
            out,
            "missing: {} on heading {}°",
            slot.kind, slot.heading_deg
        )?;
    }
    for (k, m) in o
        .before
        .maneuvers
        .iter()
        .enumerate()
        .filter(|(_, m)| !m.counted)
    {
        let why = match m.maneuver.cardinal_heading_deg() {
            Some(_) => "a repeat; the larger one counts",
            None => "off the cardinal headings",
        };
        write!(
            out,
            "not counted ({why}): {} on heading {}° at {:.1}–{:.1} s, {:.3} nT",
            m.maneuver.kind,
            heading_text(&m.maneuver),
            m.maneuver.start_tt,
            m.maneuver.end_tt,
            m.peak_to_peak_nt
        )?;
        if let Some(after) = after {
            write!(
                out,
                " ({:.3} nT compensated)",
                after.maneuvers[k].peak_to_peak_nt
            )?;
        }
        writeln!(out)?;
    }
    Ok(())
}
