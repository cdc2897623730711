//! `tolles procedure`: the Tolles patent's compensation procedure, step by step, on a flight.

use crate::render::{self, OrRender, Use};
use anyhow::{bail, Result};
use std::io::Write;
use std::path::PathBuf;
use tolles::procedure::{Direction, ProcedureOutcome, ProcedureRequest};
use tolles_core::patent::procedure::StepReport;
use tolles_core::patent::Term;

const EXAMPLES: &str = "\
Examples:
  # Simulate the patent's flight in a uniform field (inclination 68°, declination −3°) and run its
  # procedure on it:
  tolles simulate --plan patent --preset cabin --geology 0 --diurnal 0 \\
      --inclination 68 --declination -3 --intensity 52000 --out f.csv
  tolles procedure f.csv --scalar mag_1_uc --vector flux_a --declination -3 --out terms.json

  # Without a fluxgate: direction cosines from the attitude, the inclination and the declination, and
  # the field magnitude H from the median of the scalar:
  tolles procedure f.csv --scalar mag_1_uc --inclination 68 --declination -3

  # What the procedure can still do when the northeast and northwest rolls are missing:
  tolles procedure f.csv --scalar mag_1_uc --vector flux_a --ignore 'roll on 045' --ignore 'roll on 315'

  # The whole report as JSON on stdout:
  tolles procedure f.csv --scalar mag_1_uc --vector flux_a --json

The steps follow the patent (US 2,692,970): eddy terms first from the cos ωt and sin 2ωt parts
of the rolls and pitches (where perm and induced terms give nothing), then TL+LT, LV+VL and
TV+VT, T, L, V with VV−TT (rolls and wing-ups on east and west), VV−LL; the cloverleaf checks the
result. Each step cancels the terms found before it. Maneuvers are found from ins_roll,
ins_pitch and ins_yaw (degrees) and tt (s); the last line of the report lists any maneuver the
procedure needed and did not find.";

/// Run the Tolles patent's compensation procedure (US 2,692,970) on a calibration flight.
///
/// Finds the maneuvers (rolls, pitches, wing-ups, cloverleaf) from the attitude columns
/// ins_roll, ins_pitch, ins_yaw (degrees; yaw clockwise from true north) and tt (s),
/// demodulates the magnetometer on each, and identifies the 16 terms step by step in the
/// patent's order. Terms: perm T, L, V (nT); induced VV−TT, VV−LL, TL+LT, TV+VT, LV+VL
/// (dimensionless); eddy vv−tt, vv−ll, tl, tv, lt, lv, vl, vt (s), with L = x forward,
/// T = y right, V = z down and eddy `ab` = E[b][a]. Also fits the same 16 terms by least
/// squares on the whole flight for comparison.
#[derive(clap::Args)]
#[command(after_help = EXAMPLES)]
pub struct Args {
    #[arg(help = flight_help!("Calibration flight with tt, ins_roll, ins_pitch, ins_yaw and the scalar"))]
    pub flight: PathBuf,
    /// Scalar magnetometer column (nT)
    #[arg(long)]
    pub scalar: String,
    /// Fluxgate columns PREFIX_x/_y/_z (nT, body frame): gives the direction cosines and H
    #[arg(long)]
    pub vector: Option<String>,
    /// Inclination (dip) of the earth field (degrees, positive down); required without --vector
    #[arg(long, visible_alias = "dip", allow_negative_numbers = true)]
    pub inclination: Option<f64>,
    /// Declination (degrees east): magnetic heading = ins_yaw − declination. With --vector it
    /// only names the headings (a maneuver matches a step's heading within 20°)
    #[arg(long, default_value_t = 0.0, allow_negative_numbers = true)]
    pub declination: f64,
    /// Write the terms and the step-by-step report as JSON here (`-`: standard output, in
    /// place of the text report)
    #[arg(short, long)]
    pub out: Option<PathBuf>,
    /// Print the JSON on stdout instead of the text report
    #[arg(long)]
    pub json: bool,
    /// Leave out a maneuver found in the flight, e.g. 'roll on 045' (repeatable)
    #[arg(long)]
    pub ignore: Vec<String>,
    #[command(flatten)]
    pub select: crate::select::Selection,
}

const NO_DIP: &str = "without --vector the direction cosines come from the attitude: give the inclination with --inclination DEG (and --declination DEG)";

pub fn run(args: Args) -> Result<()> {
    let direction = match (&args.vector, args.inclination) {
        (Some(vector), _) => Direction::Fluxgate {
            vector: vector.clone(),
        },
        (None, Some(dip_deg)) => Direction::Attitude { dip_deg },
        (None, None) => bail!(NO_DIP),
    };
    let request = ProcedureRequest {
        declination_deg: args.declination,
        ignore: args.ignore.clone(),
        ..ProcedureRequest::new(&args.scalar, direction)
    };
    let table = args.select.read(&args.flight, Use::Other)?;
    let mut warnings = Vec::new();
    let outcome = tolles::procedure::procedure(&table, &request, &mut warnings);
    render::warnings(&mut warnings, Use::Other);
    let outcome = outcome.or_render()?;
    let text = serde_json::to_string_pretty(&outcome.to_json())?;
    let out_path = crate::input::out_path(args.out.clone());
    if let Some(path) = &out_path {
        tolles::tolles_io::atomic::write_bytes(path, format!("{text}\n").as_bytes())?;
    }
    let mut out = std::io::stdout().lock();
    if args.json || (args.out.is_some() && out_path.is_none()) {
        writeln!(out, "{text}")?;
    } else {
        print_report(&mut out, &outcome)?;
    }
    Ok(())
}

/// Four decimals, in exponent form outside 0.01–10 000.
fn number(x: f64) -> String {
    if x == 0.0 || (1e-2..1e4).contains(&x.abs()) {
        format!("{x:.4}")
    } else {
        format!("{x:.4e}")
    }
}

fn print_step(out: &mut impl Write, step: &StepReport) -> Result<()> {
    writeln!(out, "Step {}: {}", step.number, step.purpose)?;
    let used: Vec<String> = step
        .maneuvers
        .iter()
        .map(|m| format!("{} ({:.1}–{:.1} s)", m.label, m.time_s.0, m.time_s.1))
        .collect();
    if used.is_empty() {
        writeln!(out, "  maneuvers: none flown")?;
    } else {
        writeln!(out, "  maneuvers: {}", used.join(", "))?;
    }
    if !step.missing.is_empty() {
        writeln!(out, "  missing: {}", step.missing.join(", "))?;
    }
    for c in &step.components {
        let [measured, se, after] =
            [c.measured_nt, c.std_error_nt, c.after_nt].map(|x| format!("{x:.3}"));
        let (name, component) = (&c.maneuver, c.component.name());
        writeln!(
            out,
            "    {name:<16} {component:<8} {measured:>10} ± {se:<8} nT  →  {after:>10} nT after"
        )?;
    }
    for (label, estimates) in [
        ("identified", &step.identified),
        ("temporarily", &step.temporary),
    ] {
        for e in estimates {
            let unit = Term::from_name(e.term).map_or("", Term::unit);
            match (e.value.map(number), e.std_error.map(number)) {
                (Some(v), Some(se)) => writeln!(out, "  {label}: {} = {v} ± {se} {unit}", e.term)?,
                _ => writeln!(out, "  {label}: {} undetermined", e.term)?,
            }
        }
    }
    if let Some(note) = &step.note {
        writeln!(out, "  note: {note}")?;
    }
    let (before, after) = (step.rms_before_nt, step.rms_after_nt);
    writeln!(
        out,
        "  signal on these maneuvers: {before:.3} nT rms before, {after:.3} nT after cancelling"
    )?;
    for s in &step.settings {
        let gain = number(s.gain);
        writeln!(out, "  compensator: {}, {gain} {}", s.device, s.unit)?;
    }
    writeln!(out)?;
    Ok(())
}

fn print_report(out: &mut impl Write, outcome: &ProcedureOutcome) -> Result<()> {
    let report = &outcome.report;
    let labels: Vec<&str> = report.maneuvers.iter().map(|m| m.label.as_str()).collect();
    writeln!(out, "Maneuvers found: {}\n", labels.join(", "))?;
    for skipped in &report.skipped {
        writeln!(out, "skipped: {skipped}")?;
    }
    for step in &report.steps {
        print_step(out, step)?;
    }
    let passes = report.passes;
    writeln!(out, "(Steps as in the last of {passes} passes through the sequence; each pass cancels every other term at its latest value.)\n")?;
    if let Some(c) = &report.cloverleaf {
        let ((t0, t1), (lo, hi)) = (c.time_s, c.band_hz);
        let (before, after, improvement) = (c.before_nt, c.after_nt, c.improvement);
        writeln!(out, "Step 12: cloverleaf ({t0:.1}–{t1:.1} s), verification: band-passed {lo}–{hi} Hz noise {before:.4} nT before, {after:.4} nT after compensating with the identified terms (improvement {improvement:.1})\n")?;
    } else {
        writeln!(
            out,
            "Step 12: cloverleaf verification: no cloverleaf in the flight\n"
        )?;
    }
    print_terms(out, outcome)?;
    if report.missing.is_empty() {
        writeln!(out, "Every maneuver of the procedure was flown.")?;
    } else {
        writeln!(out, "Missing maneuvers: {}", report.missing.join(", "))?;
    }
    if report.undetermined.is_empty() {
        writeln!(out, "All 16 terms determined.")?;
    } else {
        let undetermined = report.undetermined.join(", ");
        writeln!(out, "Could not be determined: {undetermined}")?;
    }
    Ok(())
}

/// The 16 terms by the procedure, with standard errors, beside least squares.
fn print_terms(out: &mut impl Write, outcome: &ProcedureOutcome) -> Result<()> {
    let [a, b, c, d, e] = [
        "term",
        "procedure",
        "± std err",
        "least squares",
        "difference",
    ];
    writeln!(out, "{a:<7} {b:>14} {c:>12} {d:>14} {e:>14}")?;
    let show = |v: Option<f64>| v.map_or("undetermined".to_string(), number);
    let blank = |v: Option<f64>| v.map_or(String::new(), number);
    for (c, se) in outcome.comparison().iter().zip(outcome.report.std_errors.0) {
        let (ours, theirs, name) = (show(c.procedure), show(c.least_squares), c.term.name());
        let (se, difference, unit) = (blank(se), blank(c.difference), c.term.unit());
        writeln!(
            out,
            "{name:<7} {ours:>14} {se:>12} {theirs:>14} {difference:>14}  {unit}"
        )?;
    }
    writeln!(out)?;
    Ok(())
}
