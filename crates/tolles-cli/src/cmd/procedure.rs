//! `tolles procedure`: the Tolles patent's compensation procedure, step by step, on a flight.

use anyhow::{bail, Context, Result};
use serde_json::{json, Value};
use std::io::Write;
use std::path::PathBuf;
use tolles_core::patent::{Section, Term};
use tolles_core::procedure::{
    least_squares_terms, run as run_procedure, Geometry, ManeuverKind, ManeuverWindow,
    ProcedureInput, ProcedureReport, StepReport, TermValues,
};
use tolles_core::segment::median_step;

use crate::input::{read_table, TIME_COLUMN};

const EXAMPLES: &str = "\
Examples:
  # Simulate the patent's flight in a uniform field (dip 68°, declination −3°) and run its
  # procedure on it:
  tolles simulate --plan patent --preset cabin --geology 0 --diurnal 0 \\
      --inclination 68 --declination -3 --intensity 52000 --out f.csv
  tolles procedure f.csv --scalar mag_1_uc --vector flux_a --declination -3 --out terms.json

  # Without a fluxgate: direction cosines from the attitude, the dip and the declination, and
  # the field magnitude H from the median of the scalar:
  tolles procedure f.csv --scalar mag_1_uc --dip 68 --declination -3

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
    /// Flight CSV
    pub flight: PathBuf,
    /// Scalar magnetometer column (nT)
    #[arg(long)]
    pub scalar: String,
    /// Fluxgate columns PREFIX_x/_y/_z (nT, body frame): gives the direction cosines and H
    #[arg(long)]
    pub vector: Option<String>,
    /// Dip of the earth field (degrees, down positive); required without --vector
    #[arg(long, allow_negative_numbers = true)]
    pub dip: Option<f64>,
    /// Declination (degrees east): magnetic heading = ins_yaw − declination. With --vector it
    /// only names the headings (a maneuver matches a step's heading within 20°)
    #[arg(long, default_value_t = 0.0, allow_negative_numbers = true)]
    pub declination: f64,
    /// Write the terms and the step-by-step report as JSON here
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Print the JSON on stdout instead of the text report
    #[arg(long)]
    pub json: bool,
    /// Leave out a maneuver found in the flight, e.g. 'roll on 045' (repeatable)
    #[arg(long)]
    pub ignore: Vec<String>,
}

const ROLL: &str = "ins_roll";
const PITCH: &str = "ins_pitch";
const YAW: &str = "ins_yaw";

pub fn run(args: Args) -> Result<()> {
    let table = read_table(&args.flight)?;
    let file = args.flight.display().to_string();
    let scalar = table.numeric(&args.scalar)?;
    let tt = table.numeric(TIME_COLUMN).with_context(|| {
        format!("{file}: the procedure needs the time column {TIME_COLUMN:?} (s)")
    })?;
    let roll = table.numeric(ROLL)?;
    let pitch = table.numeric(PITCH)?;
    let yaw = table.numeric(YAW)?;
    let dt = median_step(&tt)
        .with_context(|| format!("{file}: column {TIME_COLUMN:?} has no time step"))?;
    let fs = 1.0 / dt;
    let geometry = match &args.vector {
        Some(prefix) => Geometry::from_fluxgate(&tt, &table.vector(prefix)?),
        None => {
            let Some(dip) = args.dip else {
                bail!("without --vector the direction cosines come from the attitude: give the dip with --dip DEG (and --declination DEG)")
            };
            Geometry::from_attitude(
                &tt,
                &roll,
                &pitch,
                &yaw,
                dip,
                args.declination,
                median(&scalar).with_context(|| {
                    format!("{file}: column {:?} has no finite value", args.scalar)
                })?,
            )
        }
    };
    let found = detect_patent_maneuvers(&tt, &roll, &pitch, &yaw, args.declination);
    let windows = without_ignored(found, &args.ignore)?;
    let report = run_procedure(&ProcedureInput {
        tt: &tt,
        scalar: &scalar,
        roll_deg: &roll,
        pitch_deg: &pitch,
        geometry: &geometry,
        windows: &windows,
    })
    .with_context(|| file.clone())?;
    let least_squares = match least_squares_terms(&scalar, &geometry, fs, Some(&tt)) {
        Ok(terms) => Some(terms),
        Err(e) => {
            eprintln!("warning: no least-squares comparison: {e}");
            None
        }
    };
    let document = to_json(&report, least_squares.as_ref());
    let text = serde_json::to_string_pretty(&document)?;
    if let Some(path) = &args.out {
        std::fs::write(path, format!("{text}\n"))
            .with_context(|| format!("cannot write {}", path.display()))?;
    }
    let mut out = std::io::stdout().lock();
    if args.json {
        writeln!(out, "{text}")?;
    } else {
        print_report(&mut out, &report, least_squares.as_ref())?;
    }
    Ok(())
}

fn median(x: &[f64]) -> Option<f64> {
    let mut v: Vec<f64> = x.iter().copied().filter(|v| v.is_finite()).collect();
    if v.is_empty() {
        return None;
    }
    v.sort_by(f64::total_cmp);
    Some(v[v.len() / 2])
}

/// Drops windows whose label matches an `--ignore` entry (`roll on 045`, `°` optional).
fn without_ignored(windows: Vec<ManeuverWindow>, ignore: &[String]) -> Result<Vec<ManeuverWindow>> {
    let plain = |s: &str| s.replace('°', "").trim().to_lowercase();
    for name in ignore {
        if !windows.iter().any(|w| plain(&w.label()) == plain(name)) {
            let found: Vec<String> = windows.iter().map(|w| w.label()).collect();
            bail!(
                "--ignore {name:?}: no such maneuver in the flight; found: {}",
                found.join(", ")
            );
        }
    }
    Ok(windows
        .into_iter()
        .filter(|w| !ignore.iter().any(|name| plain(&w.label()) == plain(name)))
        .collect())
}

/// Oscillations smaller than this (degrees) are not maneuvers.
const OSCILLATION_DEG: f64 = 3.0;
/// A bank held beyond this (degrees) ...
const WING_UP_DEG: f64 = 25.0;
/// ... for longer than this (s) is a wing-up.
const WING_UP_S: f64 = 5.0;
/// A heading that wanders less than this (degrees) is stable.
const STABLE_HEADING_DEG: f64 = 10.0;

/// The patent's maneuvers in the attitude channels:
/// - wing-ups: |roll| beyond 25° for more than 5 s on a stable heading (window from the start
///   of the roll-in to the end of the roll-out);
/// - cloverleaf turns: banked turns through 180° or more;
/// - rolls and pitches: harmonic maneuvers found by `tolles_core::maneuver` (as for the FOM).
///
/// Headings are made magnetic with `declination_deg`.
pub fn detect_patent_maneuvers(
    tt: &[f64],
    roll: &[f64],
    pitch: &[f64],
    yaw: &[f64],
    declination_deg: f64,
) -> Vec<ManeuverWindow> {
    let n = tt.len();
    let fs = median_step(tt).map_or(1.0, |dt| 1.0 / dt);
    let heading = tolles_core::maneuver::unwrap_deg(yaw);
    let mut taken = vec![false; n];
    let mut windows = Vec::new();
    let magnetic = |range: &std::ops::Range<usize>| {
        let mid = (range.start + range.end) / 2;
        heading[mid] - declination_deg
    };
    // Banked runs: wing-ups, cloverleaf turns, and other turns (not maneuvers, but kept out
    // of the oscillations below).
    for run in runs(n, |k| roll[k].abs() > OSCILLATION_DEG) {
        let turned = spread(&heading[run.clone()]);
        let held = runs_within(&run, |k| roll[k].abs() > WING_UP_DEG)
            .into_iter()
            .map(|r| r.len() as f64 / fs)
            .fold(0.0, f64::max);
        let kind = if turned >= 180.0 {
            Some(ManeuverKind::Cloverleaf)
        } else if held > WING_UP_S && turned < STABLE_HEADING_DEG {
            Some(ManeuverKind::WingUp)
        } else if turned >= STABLE_HEADING_DEG {
            None
        } else {
            continue;
        };
        // Out to where the bank returns to zero.
        let sign = roll[run.start].signum();
        let same = |k: usize| roll[k].signum() == sign && roll[k] != 0.0;
        let mut range = run.clone();
        while range.start > 0 && same(range.start - 1) {
            range.start -= 1;
        }
        while range.end < n && same(range.end) {
            range.end += 1;
        }
        taken[range.clone()].iter_mut().for_each(|t| *t = true);
        if let Some(kind) = kind {
            windows.push(ManeuverWindow {
                kind,
                heading_deg: magnetic(&run),
                range,
            });
        }
    }
    // Rolls and pitches: the shared harmonic-maneuver detector (the one `tolles fom` uses),
    // outside the banked runs above.
    let settings = tolles_core::maneuver::ManeuverSettings::default();
    for m in tolles_core::maneuver::detect_harmonic_maneuvers(tt, roll, pitch, yaw, &settings) {
        let kind = match m.kind {
            tolles_core::maneuver::ManeuverKind::Roll => ManeuverKind::Roll,
            tolles_core::maneuver::ManeuverKind::Pitch => ManeuverKind::Pitch,
            tolles_core::maneuver::ManeuverKind::Yaw => continue,
        };
        if taken[m.range()].iter().any(|t| *t) {
            continue;
        }
        windows.push(ManeuverWindow {
            kind,
            heading_deg: m.heading_deg_measured - declination_deg,
            range: m.range(),
        });
    }
    windows.sort_by_key(|w| w.range.start);
    windows
}

fn spread(x: &[f64]) -> f64 {
    let finite = || x.iter().copied().filter(|v| v.is_finite());
    finite().fold(f64::NEG_INFINITY, f64::max) - finite().fold(f64::INFINITY, f64::min)
}

/// Maximal runs of consecutive indices in `0..n` where `test` holds.
fn runs(n: usize, test: impl Fn(usize) -> bool) -> Vec<std::ops::Range<usize>> {
    runs_within(&(0..n), test)
}

/// Maximal runs of consecutive indices in `range` where `test` holds.
fn runs_within(
    range: &std::ops::Range<usize>,
    test: impl Fn(usize) -> bool,
) -> Vec<std::ops::Range<usize>> {
    let holds: Vec<bool> = range.clone().map(test).collect();
    tolles_core::segment::contiguous_runs(&holds, None)
        .into_iter()
        .map(|r| r.start + range.start..r.end + range.start)
        .collect()
}

fn to_json(report: &ProcedureReport, least_squares: Option<&TermValues>) -> Value {
    let mut doc = serde_json::to_value(report.terms).expect("terms serialise");
    let comparison: Vec<Value> = Term::OBSERVABLE
        .iter()
        .enumerate()
        .map(|(k, term)| {
            let ours = report.terms.0[k];
            let theirs = least_squares.and_then(|l| l.0[k]);
            json!({
                "term": term.name(),
                "procedure": ours,
                "least_squares": theirs,
                "difference": ours.zip(theirs).map(|(a, b)| a - b),
            })
        })
        .collect();
    let fields = [
        ("std_errors", serde_json::to_value(report.std_errors)),
        ("steps", serde_json::to_value(&report.steps)),
        ("passes", serde_json::to_value(report.passes)),
        ("missing", serde_json::to_value(&report.missing)),
        ("undetermined", serde_json::to_value(&report.undetermined)),
        ("least_squares", serde_json::to_value(least_squares)),
        ("comparison", Ok(Value::Array(comparison))),
        ("cloverleaf", serde_json::to_value(&report.cloverleaf)),
        ("skipped", serde_json::to_value(&report.skipped)),
        (
            "maneuvers",
            Ok(report
                .maneuvers
                .iter()
                .map(|m| {
                    json!({
                        "label": m.label,
                        "time_s": m.time_s,
                        "period_s": m.period_s,
                        "amplitude_deg": m.amplitude_deg,
                    })
                })
                .collect()),
        ),
    ];
    let object = doc.as_object_mut().expect("an object");
    for (key, value) in fields {
        object.insert(key.into(), value.expect("the report serialises"));
    }
    doc
}

fn unit(term: Term) -> &'static str {
    match term.section() {
        Section::Perm => "nT",
        Section::Induced => "",
        Section::Eddy => "s",
    }
}

fn number(x: f64) -> String {
    if x == 0.0 || (1e-2..1e4).contains(&x.abs()) {
        format!("{x:.4}")
    } else {
        format!("{x:.4e}")
    }
}

fn term_of(name: &str) -> Term {
    *Term::OBSERVABLE
        .iter()
        .find(|t| t.name() == name)
        .expect("a patent term name")
}

fn print_step(out: &mut impl Write, step: &StepReport) -> Result<()> {
    writeln!(out, "Step {}: {}", step.number, step.purpose)?;
    if step.maneuvers.is_empty() {
        writeln!(out, "  maneuvers: none flown")?;
    } else {
        let used: Vec<String> = step
            .maneuvers
            .iter()
            .map(|m| format!("{} ({:.1}–{:.1} s)", m.label, m.time_s.0, m.time_s.1))
            .collect();
        writeln!(out, "  maneuvers: {}", used.join(", "))?;
    }
    if !step.missing.is_empty() {
        writeln!(out, "  missing: {}", step.missing.join(", "))?;
    }
    for c in &step.components {
        writeln!(
            out,
            "    {:<16} {:<8} {:>10} ± {:<8} nT  →  {:>10} nT after",
            c.maneuver,
            c.component.name(),
            format!("{:.3}", c.measured_nt),
            format!("{:.3}", c.std_error_nt),
            format!("{:.3}", c.after_nt)
        )?;
    }
    for (label, estimates) in [
        ("identified", &step.identified),
        ("temporarily", &step.temporary),
    ] {
        for e in estimates.iter() {
            let term = term_of(e.term);
            match (e.value, e.std_error) {
                (Some(v), Some(se)) => writeln!(
                    out,
                    "  {label}: {} = {} ± {} {}",
                    e.term,
                    number(v),
                    number(se),
                    unit(term)
                )?,
                _ => writeln!(out, "  {label}: {} undetermined", e.term)?,
            }
        }
    }
    if let Some(note) = &step.note {
        writeln!(out, "  note: {note}")?;
    }
    writeln!(
        out,
        "  signal on these maneuvers: {:.3} nT rms before, {:.3} nT after cancelling",
        step.rms_before_nt, step.rms_after_nt
    )?;
    for s in &step.settings {
        writeln!(
            out,
            "  compensator: {}, {} {}",
            s.device,
            number(s.gain),
            s.unit
        )?;
    }
    writeln!(out)?;
    Ok(())
}

fn print_report(
    out: &mut impl Write,
    report: &ProcedureReport,
    least_squares: Option<&TermValues>,
) -> Result<()> {
    let labels: Vec<&str> = report.maneuvers.iter().map(|m| m.label.as_str()).collect();
    writeln!(out, "Maneuvers found: {}\n", labels.join(", "))?;
    for skipped in &report.skipped {
        writeln!(out, "skipped: {skipped}")?;
    }
    for step in &report.steps {
        print_step(out, step)?;
    }
    writeln!(
        out,
        "(Steps as in the last of {} passes through the sequence; each pass cancels every other term at its latest value.)\n",
        report.passes
    )?;
    if let Some(c) = &report.cloverleaf {
        writeln!(
            out,
            "Step 12: cloverleaf ({:.1}–{:.1} s), verification: band-passed {}–{} Hz noise {:.4} nT before, {:.4} nT after compensating with the identified terms (improvement {:.1})\n",
            c.time_s.0, c.time_s.1, c.band_hz.0, c.band_hz.1, c.before_nt, c.after_nt, c.improvement
        )?;
    } else {
        writeln!(
            out,
            "Step 12: cloverleaf verification: no cloverleaf in the flight\n"
        )?;
    }
    writeln!(
        out,
        "{:<7} {:>14} {:>12} {:>14} {:>14}",
        "term", "procedure", "± std err", "least squares", "difference"
    )?;
    for (k, term) in Term::OBSERVABLE.iter().enumerate() {
        let show = |v: Option<f64>| v.map_or("undetermined".to_string(), number);
        let ours = report.terms.0[k];
        let theirs = least_squares.and_then(|l| l.0[k]);
        writeln!(
            out,
            "{:<7} {:>14} {:>12} {:>14} {:>14}  {}",
            term.name(),
            show(ours),
            report.std_errors.0[k].map_or(String::new(), number),
            show(theirs),
            ours.zip(theirs)
                .map_or(String::new(), |(a, b)| number(a - b)),
            unit(*term)
        )?;
    }
    writeln!(out)?;
    if report.missing.is_empty() {
        writeln!(out, "Every maneuver of the procedure was flown.")?;
    } else {
        writeln!(out, "Missing maneuvers: {}", report.missing.join(", "))?;
    }
    if report.undetermined.is_empty() {
        writeln!(out, "All 16 terms determined.")?;
    } else {
        writeln!(
            out,
            "Could not be determined: {}",
            report.undetermined.join(", ")
        )?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use tolles_core::interpret::AircraftField;
    use tolles_core::plan::PatentPlan;
    use tolles_core::procedure::windows_from_plan;
    use tolles_core::sim::{simulate, Scenario};

    #[test]
    fn the_detector_finds_the_patent_plans_maneuvers() {
        let plan = PatentPlan::default().build();
        let scenario = Scenario::new(AircraftField::default(), 1);
        let flight = simulate(&plan, &scenario).unwrap();
        let found = detect_patent_maneuvers(
            &flight.tt,
            &flight.roll_deg,
            &flight.pitch_deg,
            &flight.yaw_deg,
            -3.0,
        );
        let planned: Vec<ManeuverWindow> = windows_from_plan(&plan, scenario.fs_hz, -3.0)
            .into_iter()
            .filter(|w| w.kind != ManeuverKind::Cloverleaf)
            .collect();
        let labels = |w: &[ManeuverWindow]| w.iter().map(|w| w.label()).collect::<Vec<_>>();
        let found_maneuvers: Vec<ManeuverWindow> = found
            .iter()
            .filter(|w| w.kind != ManeuverKind::Cloverleaf)
            .cloned()
            .collect();
        assert_eq!(labels(&found_maneuvers), labels(&planned));
        // Each found window lies within a sample or two of the planned one.
        for (f, p) in found_maneuvers.iter().zip(&planned) {
            assert!(f.range.start.abs_diff(p.range.start) <= 2, "{f:?} {p:?}");
            assert!(f.range.end.abs_diff(p.range.end) <= 2, "{f:?} {p:?}");
        }
        // The four cloverleaf turns.
        let clover = found
            .iter()
            .filter(|w| w.kind == ManeuverKind::Cloverleaf)
            .count();
        assert_eq!(clover, 4);
    }

    #[test]
    fn ignoring_matches_labels_with_or_without_the_degree_sign() {
        let window = |heading: f64| ManeuverWindow {
            kind: ManeuverKind::Roll,
            heading_deg: heading,
            range: 0..10,
        };
        let kept = without_ignored(
            vec![window(45.0), window(315.0)],
            &["Roll on 045".to_string(), "roll on 315°".to_string()],
        )
        .unwrap();
        assert!(kept.is_empty());
        assert!(without_ignored(vec![window(45.0)], &["pitch on 045".to_string()]).is_err());
    }
}
