//! `tolles tables`: the Tolles patent's roll and pitch tables, computed for any amplitude,
//! heading and dip, beside the patent's closed forms.

use anyhow::{Context, Result};
use std::io::Write;
use tolles_core::patent::harmonics::{HarmonicManeuver, HarmonicTable, TableRow};
use tolles_core::patent::{Maneuver, Provenance, Section};

const EXAMPLES: &str = "\
Examples:
  # The patent's 15° rolls and pitches heading north at inclination (dip) 68°:
  tolles tables --amplitude 15 --heading 0 --inclination 68

  # Rolls heading east: the T row's fundamental is b·sin φ, the V row's −b·cos φ·sin θp with the
  # patent's θp = −90°:
  tolles tables --maneuver roll --amplitude 10 --heading 90 --inclination 60

  # As JSON, for a script:
  tolles tables --maneuver pitch --amplitude 5 --heading 45 --inclination 55 --json

Reading a row: a term's share of the magnetometer signal is
  perm:     value (nT)        × (fundamental·sin ωt   + second·cos 2ωt   + …)
  induced:  value × H (nT)    × (fundamental·sin ωt   + second·cos 2ωt   + …)
  eddy:     value (s) × H · ω × (fundamental·cos ωt   + second·sin 2ωt   + …)
for roll = b·sin ωt (right wing down) or pitch = a·sin ωt (nose up), H the earth field.";

const SIGNAL: &str = "perm: value (nT)·(fundamental·sin ωt + second_harmonic·cos 2ωt); \
induced: value·H·(fundamental·sin ωt + second_harmonic·cos 2ωt); \
eddy: value (s)·H·ω·(fundamental·cos ωt + second_harmonic·sin 2ωt); H the earth field (nT)";

const CONVENTIONS: &str = "FRD body axes, L = x forward, T = y right, V = z down; heading \
clockwise from magnetic north, roll right wing down, pitch nose up; eddy 'ab' = E[b][a]. The \
patent's closed forms are mapped: θp = −heading, λ = −pitch, eddy sign flipped";

/// The JSON document: how to read it, then the tables.
#[derive(serde::Serialize)]
struct JsonOut<'a> {
    signal: &'static str,
    conventions: &'static str,
    tables: &'a [HarmonicTable],
}

/// Which maneuver's table.
#[derive(Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Which {
    Roll,
    Pitch,
    Both,
}

/// Print the patent's roll and pitch tables (US 2,692,970), computed.
///
/// Each row is a term of the aircraft's field (patent letters: L forward, T right, V down; eddy
/// `ab` is E[b][a]). The computed columns are exact Fourier coefficients of the term's
/// generating function; the patent columns are its printed closed forms (leading order in the
/// amplitude) mapped to our conventions: heading clockwise (the patent's θp = −heading), pitch
/// nose up (the patent's λ = −pitch), eddy signs flipped (the patent's eddy coefficients are
/// −E). Rows the patent misprints are marked; their closed forms follow the mathematics.
#[derive(clap::Args)]
#[command(after_help = EXAMPLES)]
pub struct Args {
    /// Which table: roll, pitch or both
    #[arg(long, value_enum, default_value = "both")]
    pub maneuver: Which,
    /// Maneuver amplitude in degrees (0 < amplitude ≤ 90)
    #[arg(long, default_value_t = 15.0, allow_negative_numbers = true)]
    pub amplitude: f64,
    /// Heading in degrees, clockwise from magnetic north
    #[arg(long, default_value_t = 0.0, allow_negative_numbers = true)]
    pub heading: f64,
    /// Inclination (dip) of the earth field in degrees, positive down
    #[arg(
        long,
        visible_alias = "dip",
        default_value_t = 68.0,
        allow_negative_numbers = true
    )]
    pub inclination: f64,
    /// Print JSON instead of text
    #[arg(long)]
    pub json: bool,
}

pub fn run(args: Args) -> Result<()> {
    let maneuvers: &[Maneuver] = match args.maneuver {
        Which::Roll => &[Maneuver::Roll],
        Which::Pitch => &[Maneuver::Pitch],
        Which::Both => &[Maneuver::Roll, Maneuver::Pitch],
    };
    let tables = maneuvers
        .iter()
        .map(|&m| {
            HarmonicTable::compute(&HarmonicManeuver::new(
                m,
                args.amplitude,
                args.heading,
                args.inclination,
            ))
        })
        .collect::<Result<Vec<_>, _>>()
        .context("cannot compute the tables")?;
    let mut out = std::io::stdout().lock();
    if args.json {
        let json = JsonOut {
            signal: SIGNAL,
            conventions: CONVENTIONS,
            tables: &tables,
        };
        writeln!(out, "{}", serde_json::to_string_pretty(&json)?)?;
        return Ok(());
    }
    for (k, table) in tables.iter().enumerate() {
        if k > 0 {
            writeln!(out)?;
        }
        print_table(&mut out, table)?;
    }
    writeln!(
        out,
        "\nComputed: exact. Patent: its closed forms, leading order, mapped to our conventions \
         (θp = −heading, λ = −pitch, eddy sign flipped)."
    )?;
    Ok(())
}

fn print_table(out: &mut impl Write, table: &HarmonicTable) -> Result<()> {
    let m = &table.maneuver;
    let (title, angle, letter) = match m.maneuver {
        Maneuver::Roll => ("Rolls", "roll (right wing down)", "b"),
        Maneuver::Pitch => ("Pitches", "pitch (nose up)", "a"),
    };
    writeln!(
        out,
        "{title}: {angle} = {letter}·sin ωt, {letter} = {}°, heading {}° (clockwise from magnetic north), dip {}°",
        m.amplitude_deg, m.heading_deg, m.dip_deg
    )?;
    let mut notes: Vec<String> = Vec::new();
    for section in [Section::Perm, Section::Induced, Section::Eddy] {
        let (label, basis) = match section {
            Section::Perm => ("PERM (× value in nT)", ["sin ωt", "cos 2ωt"]),
            Section::Induced => ("INDUCED (× value × H in nT)", ["sin ωt", "cos 2ωt"]),
            Section::Eddy => (
                "EDDY CURRENT (× value in s × H in nT)",
                ["ω cos ωt", "ω sin 2ωt"],
            ),
        };
        writeln!(out, "\n  {label}")?;
        writeln!(
            out,
            "  {:<6} {:<6} {:>22}   {:>22}   patent table",
            "term",
            "g",
            format!("fundamental {}", basis[0]),
            format!("second harmonic {}", basis[1])
        )?;
        writeln!(
            out,
            "  {:<6} {:<6} {:>10} {:>11}   {:>10} {:>11}",
            "", "", "computed", "patent", "computed", "patent"
        )?;
        for row in table.rows.iter().filter(|r| r.section == section) {
            let note = note(row, &mut notes);
            writeln!(
                out,
                "  {:<6} {} {:>10.6} {:>11.6}   {:>10.6} {:>11.6}   {note}",
                row.name,
                pad(&row.generating_function, 6),
                zero(row.fundamental),
                zero(row.closed_fundamental),
                zero(row.second_harmonic),
                zero(row.closed_second_harmonic)
            )?;
        }
    }
    if !notes.is_empty() {
        writeln!(out)?;
        for (k, text) in notes.iter().enumerate() {
            writeln!(out, "  [{}] {text}", k + 1)?;
        }
    }
    Ok(())
}

/// The row's status; misprints get a numbered footnote.
fn note(row: &TableRow, notes: &mut Vec<String>) -> String {
    match &row.printed {
        Provenance::Printed { .. } => "as printed".into(),
        Provenance::Misprint { printed_name, note } => {
            notes.push(if *printed_name == row.name {
                format!("{}: {note}", row.name)
            } else {
                format!("{} (printed '{printed_name}'): {note}", row.name)
            });
            format!("MISPRINT [{}]", notes.len())
        }
        Provenance::NotPrinted { note } => note.clone(),
    }
}

/// Rounding noise printed as 0 rather than −0.000000.
fn zero(x: f64) -> f64 {
    if x.abs() < 5e-13 {
        0.0
    } else {
        x
    }
}

/// Left-aligns to `width` columns, not counting combining marks (the dot in `l̇`).
fn pad(text: &str, width: usize) -> String {
    let shown = text
        .chars()
        .filter(|c| !('\u{300}'..='\u{36f}').contains(c))
        .count();
    format!("{text}{}", " ".repeat(width.saturating_sub(shown)))
}
