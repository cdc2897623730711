//! `tolles info`: what a flight file holds.

use crate::progress::Terminal;
use crate::render::{self, OrRender, Use};
use anyhow::Result;
use std::io::Write;
use std::path::PathBuf;
use tolles::info::FlightInfo;

const EXAMPLES: &str = "\
Examples:
  tolles info cal.csv
  tolles info Flt1003_sample.xyz --json
  tolles info survey.dfn --rename MAGUC=mag_1_uc
  tolles info cal.csv --line 1002.02
  gunzip -c cal.csv.gz | tolles info -";

/// Say what a flight file holds: columns (with units where the file states them: GDF UNITS=,
/// HDF5 `units` attributes; and the tolles names raw channels answer to), rows, sample rate
/// (from tt, else the file's dt or fs), lines, time span, missing values per column, scalars,
/// arrays of other lengths and what the reader left out.
#[derive(clap::Args)]
#[command(after_help = EXAMPLES)]
pub struct Args {
    #[arg(help = flight_help!("Flight"))]
    pub flight: PathBuf,
    /// Print JSON instead of text
    #[arg(long)]
    pub json: bool,
    #[command(flatten)]
    pub select: crate::select::Selection,
}

pub fn run(args: Args) -> Result<()> {
    let mut warnings = Vec::new();
    let about = tolles::info::info(
        &args.flight,
        &args.select.rows(),
        &args.select.renames,
        &Terminal::default(),
        &mut warnings,
    );
    render::warnings(&mut warnings, Use::Other);
    let about = about.or_render()?;
    let mut out = std::io::stdout().lock();
    if args.json {
        writeln!(out, "{}", serde_json::to_string_pretty(&about.to_json())?)?;
    } else {
        write!(out, "{}", text(&about))?;
    }
    Ok(())
}

/// The description as text, one fact a line and a table of columns.
/// Line ids printed before the rest are counted: a terminal line, not a file of them.
const LINES_SHOWN: usize = 50;

fn text(about: &FlightInfo) -> String {
    let mut s = format!("{} ({})\n", about.path.display(), about.format);
    s += &format!("rows: {}\n", about.rows);
    s += &match about.sample_rate_hz {
        Some(fs) => format!("sample rate: {fs:.6} Hz\n"),
        None => "sample rate: unknown (no usable tt or dt)\n".to_string(),
    };
    if let Some((a, b)) = about.time_span_s {
        let order = match about.time_in_order {
            true => "",
            false => ", not in time order",
        };
        s += &format!("time: {a} .. {b} s ({:.1} s{order})\n", b - a);
    }
    match &about.lines {
        Some(lines) => {
            let mut ids: Vec<String> = (lines.iter().take(LINES_SHOWN))
                .map(|l| format!("{} ({} rows)", l.id, l.rows))
                .collect();
            if lines.len() > LINES_SHOWN {
                ids.push(format!(
                    "… {} more (--json lists every one)",
                    lines.len() - LINES_SHOWN
                ));
            }
            s += &format!("lines: {}: {}\n", lines.len(), ids.join(", "));
        }
        None => s += "lines: no line column\n",
    }
    for (name, value) in &about.metadata {
        s += &format!("{name} = {value}\n");
    }
    if !about.side_columns.is_empty() {
        let list: Vec<String> = about
            .side_columns
            .iter()
            .map(|(name, length)| format!("{name} ({length})"))
            .collect();
        s += &format!(
            "other lengths (not used; tolles convert keeps them): {}\n",
            list.join(", ")
        );
    }
    for note in &about.left_out {
        s += &format!("left out: {note}\n");
    }
    let width = about
        .columns
        .iter()
        .map(|c| c.name.len())
        .max()
        .unwrap_or(6)
        .max(6);
    s += &format!(
        "{:<width$}  {:<8}  {:>8}  {:>11}  also\n",
        "column", "unit", "missing", "non-numeric"
    );
    for c in &about.columns {
        s += &format!(
            "{:<width$}  {:<8}  {:>8}  {:>11}  {}\n",
            c.name,
            c.unit.as_deref().unwrap_or(""),
            c.missing,
            c.non_numeric,
            c.aliases.join(", ")
        );
    }
    s
}
