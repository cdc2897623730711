//! `tolles fom`: the figure of merit of a compensation box, maneuvers found automatically.

use crate::input::parse_band;
use crate::render::{self, OrRender, Use};
use anyhow::Result;
use std::io::Write;
use std::path::PathBuf;
use tolles::fom::{heading_text, FomOutcome, FomRequest};
use tolles_core::fit::Band;
use tolles_core::maneuvers::heading::{HeadingLevel, HeadingLevels};

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
///
/// The heading error is the surveyors' measure: the scalar's mean level over the straight and
/// level samples of each cardinal heading (or those of --headings; outside maneuvers and 2 s
/// around them, roll and pitch within 3° (--level-tolerance), yaw within 10° of the heading
/// (--heading-tolerance) and turning less than 1°/s; headings with less than 3 s of such flight
/// are skipped), largest level minus smallest, ± the two levels' standard
/// errors combined (each allows for autocorrelation). Before and after compensation it uses the
/// same samples. Geology and diurnal variation between the legs stay in both numbers.
#[derive(clap::Args)]
#[command(after_help = EXAMPLES)]
pub struct Args {
    #[arg(help = flight_help!("Flight data with tt, ins_roll, ins_pitch, ins_yaw and the scalar column"))]
    pub flight: PathBuf,
    /// Scalar magnetometer column (nT); with a --model holding one fit, that fit's scalar by
    /// default
    #[arg(long)]
    pub scalar: Option<String>,
    /// Model file written by `tolles fit`; also report the FOM after compensation
    #[arg(long)]
    pub model: Option<PathBuf>,
    /// Band-pass edges LO,HI in Hz applied before taking peak-to-peaks
    #[arg(long, default_value = "0.05,1.0", allow_hyphen_values = true)]
    pub band: String,
    /// Butterworth order of the band-pass (per edge)
    #[arg(long, default_value_t = 4)]
    pub order: usize,
    /// Print JSON instead of a table
    #[arg(long)]
    pub json: bool,
    /// Sample rate in Hz (default: from the tt column)
    #[arg(long, allow_negative_numbers = true)]
    pub fs: Option<f64>,
    #[command(flatten)]
    pub legs: crate::input::Legs,
    #[command(flatten)]
    pub select: crate::select::Selection,
}

pub fn run(args: Args) -> Result<()> {
    let (scalar, outcome) = evaluate(&args)?;
    let mut out = std::io::stdout().lock();
    if args.json {
        writeln!(out, "{}", serde_json::to_string_pretty(&outcome.to_json())?)?;
    } else {
        write_table(&mut out, &args, &scalar, &outcome)?;
    }
    out.flush()?;
    Ok(())
}

/// The scalar and the library's FOM of the flight the flags name, its warnings said on stderr.
fn evaluate(args: &Args) -> Result<(String, FomOutcome)> {
    let (pass1_hz, pass2_hz) = parse_band(&args.band)?;
    let model = args
        .model
        .as_deref()
        .map(|path| tolles::model::ModelFile::read(path).map(|m| (m, path)))
        .transpose()?;
    let model = model.as_ref().map(|(m, path)| (m, *path));
    let scalar = tolles::fom::scalar_to_use(args.scalar.as_deref(), model).or_render()?;
    let request = args.legs.apply(FomRequest {
        band: Band { pass1_hz, pass2_hz },
        order: args.order,
        fs_hz: args.fs,
        ..FomRequest::new(&scalar)
    });
    let fit = model
        .map(|(model, path)| tolles::fom::fit_for(model, path, &scalar))
        .transpose()
        .or_render()?;
    let table = args.select.read(&args.flight, Use::Fom)?;
    let mut warnings = Vec::new();
    let outcome = tolles::fom::fom(&table, &request, fit, &mut warnings);
    render::warnings(&mut warnings, Use::Fom);
    Ok((scalar, outcome.or_render()?))
}

/// A fourth-difference noise (nT), or why there is none: it needs five finite rows in a row.
fn noise(nt: f64) -> String {
    match nt.is_finite() {
        true => format!("{nt:.4} nT"),
        false => "— (fewer than five usable rows in a row)".into(),
    }
}

fn write_table(out: &mut impl Write, args: &Args, scalar: &str, o: &FomOutcome) -> Result<()> {
    let (lo, hi) = o.before.band_hz;
    writeln!(
        out,
        "FOM of {}, scalar {}{}",
        args.flight.display(),
        scalar,
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
    if o.before.fom_nt.is_nan() {
        writeln!(
            out,
            "{:>8}  none: no compensation-box maneuvers were found in the attitude\n",
            "FOM"
        )?;
    } else {
        write!(out, "{:>8}  {:<44}  {:>13.3}", "FOM", "", o.before.fom_nt)?;
        if let Some(after) = after {
            write!(out, "  {:>11.3}", after.fom_nt)?;
        }
        writeln!(out, "\n")?;
    }
    match after.filter(|_| o.before.fom_nt.is_finite()) {
        Some(after) => writeln!(
            out,
            "improvement ratio (FOM uncompensated / compensated): {:.1}\nfourth-difference noise: {} uncompensated, {} compensated",
            o.improvement_ratio().unwrap_or(f64::NAN),
            noise(o.before.fourth_difference_nt),
            noise(after.fourth_difference_nt)
        )?,
        None => match after {
            Some(after) => writeln!(
                out,
                "fourth-difference noise: {} uncompensated, {} compensated",
                noise(o.before.fourth_difference_nt),
                noise(after.fourth_difference_nt)
            )?,
            None => writeln!(
                out,
                "improvement ratio: give --model to compare with the compensated data\nfourth-difference noise: {}",
                noise(o.before.fourth_difference_nt)
            )?,
        },
    }
    write_headings(out, &o.heading_before, o.heading_after.as_ref())?;
    // With no maneuver at all, the FOM line has said so; twelve "missing" lines add nothing.
    let missing = if o.maneuvers.is_empty() {
        &[][..]
    } else {
        &o.before.missing[..]
    };
    for slot in missing {
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

/// The heading error line, then a row per heading: its levels before and after (nT).
fn write_headings(
    out: &mut impl Write,
    before: &HeadingLevels,
    after: Option<&HeadingLevels>,
) -> Result<()> {
    let error = |h: &HeadingLevels| match (h.heading_error_nt, h.uncertainty_nt) {
        (Some(e), Some(u)) => {
            let d = decimals(u);
            format!("{e:.d$} ± {u:.d$} nT")
        }
        _ => "none (fewer than two headings)".to_string(),
    };
    write!(out, "heading error: {} before", error(before))?;
    if let Some(after) = after {
        write!(out, ", {} after", error(after))?;
    }
    writeln!(
        out,
        "\n  (largest minus smallest mean level of the straight legs; geology and diurnal variation between legs stay in it)"
    )?;
    if before.levels.is_empty() {
        return Ok(());
    }
    write!(
        out,
        "{:>12}  {:>7}  {:>13}  {:>20}",
        "heading (°)", "samples", "time (s)", "level (nT)"
    )?;
    if after.is_some() {
        write!(out, "  {:>20}", "compensated (nT)")?;
    }
    writeln!(out)?;
    let cell = |l: &HeadingLevel| {
        let d = decimals(l.std_error_nt);
        format!("{:.d$} ± {:.d$}", l.level_nt, l.std_error_nt)
    };
    for level in &before.levels {
        write!(
            out,
            "{:>12}  {:>7}  {:>13}  {:>20}",
            format!("{:.0}", level.heading_deg),
            level.samples,
            format!("{:.1}–{:.1}", level.start_tt, level.end_tt),
            cell(level)
        )?;
        let same = after.and_then(|a| a.levels.iter().find(|l| l.heading_deg == level.heading_deg));
        if let Some(same) = same {
            write!(out, "  {:>20}", cell(same))?;
        }
        writeln!(out)?;
    }
    for skipped in &before.skipped {
        writeln!(
            out,
            "heading {:.0}°: skipped, {:.1} s of straight and level flight",
            skipped.heading_deg, skipped.duration_s
        )?;
    }
    Ok(())
}

/// Decimals that show an uncertainty (nT) to two significant digits, between 2 and 4.
fn decimals(uncertainty: f64) -> usize {
    if uncertainty > 0.0 && uncertainty.is_finite() {
        (1.0 - uncertainty.log10().floor()).clamp(2.0, 4.0) as usize
    } else {
        2
    }
}
