//! `tolles`: remove an aircraft's own magnetic field from airborne magnetometer data.
//!
//! This crate is only the command line; the numerics live in `tolles-core` and the file formats
//! in `tolles-io`.

/// The help of a flight-file argument: `$what`, then the formats every command reads — one
/// sentence for all of them, so no command's help forgets one.
macro_rules! flight_help {
    ($what:literal) => {
        concat!(
            $what,
            ". Formats, by extension: CSV, Geosoft XYZ, ASEG-GDF (.dfn/.dat), HDF5 (.h5/.hdf5; \
             MATLAB .mat v5 and v7.3), Parquet (.parquet/.pq); any other extension is read as \
             CSV. `-` reads standard input (CSV, XYZ, HDF5, MAT or Parquet, told by content)"
        )
    };
}

/// `eprintln!` that never panics: with standard error closed or a broken pipe, the message is
/// dropped and the command's work (a model, an output file) goes on.
macro_rules! note {
    ($($arg:tt)*) => {{
        use std::io::Write as _;
        let _ = writeln!(std::io::stderr(), $($arg)*);
    }};
}

mod cmd;
mod input;
mod progress;
mod render;
mod select;

use clap::{CommandFactory, FromArgMatches, Parser, Subcommand};
use std::process::ExitCode;

const ABOUT: &str = "Aircraft magnetic compensation (Tolles-Lawson): learn the aircraft's \
permanent, induced and eddy-current field from a calibration flight and remove it from survey data.";

const EXAMPLES: &str = "\
Examples:
  # Learn a model from a calibration flight and apply it to a survey:
  tolles fit cal.csv --scalar mag_1_uc --vector flux_a --out model.json
  tolles compensate survey.csv --model model.json --out survey_c.csv
  tolles fom cal.csv --scalar mag_1_uc --model model.json

  # Reproduce MagNav.jl's procedure exactly:
  tolles fit cal.csv --scalar mag_1_uc --vector flux_a \\
      --terms permanent,induced,eddy --lambda 0.001 --band 0.1,0.9 --order 4 --trim 20

  # What a flight file holds (columns, units, rows, sample rate, lines, missing values):
  tolles info cal.csv

  # Any format tolles reads to CSV, HDF5 or Parquet, nothing lost:
  tolles convert Flt1002.h5 Flt1002.csv

  # Simulate a flight whose truth is known:
  tolles simulate --plan box --seed 1 --out box.csv

  # See it work on a simulated flight, no files needed:
  tolles demo

  # The Tolles patent's roll and pitch tables, computed:
  tolles tables --amplitude 15 --heading 45 --inclination 68

  # The patent's compensation procedure, step by step, on a flight:
  tolles procedure patent.csv --scalar mag_1_uc --vector flux_a --out terms.json

  # Compensate a live stream, one line out for every line in:
  tail -f live.csv | tolles stream --model model.json";

#[derive(Parser)]
#[command(name = "tolles", version, about = ABOUT, after_help = EXAMPLES)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    Fit(cmd::fit::Args),
    Compensate(cmd::compensate::Args),
    Fom(cmd::fom::Args),
    Info(cmd::info::Args),
    Convert(cmd::convert::Args),
    Demo(cmd::demo::Args),
    Simulate(cmd::simulate::Args),
    Plan(cmd::plan::Args),
    Report(cmd::report::Args),
    Tables(cmd::tables::Args),
    Procedure(cmd::procedure::Args),
    Stream(cmd::stream::Args),
}

/// The command line with each subcommand's usage fixed to its own: clap's error messages would
/// otherwise list the flags given (`--out` among them) as if they were required.
fn command() -> clap::Command {
    let mut cli = Cli::command();
    cli.build();
    cli.mut_subcommands(|mut sub| {
        let usage = sub.render_usage().to_string();
        let own = usage.trim_start_matches("Usage:").trim().to_string();
        sub.override_usage(own)
    })
}

fn main() -> ExitCode {
    let cli = Cli::from_arg_matches(&command().get_matches()).unwrap_or_else(|e| e.exit());
    let result = match cli.command {
        Command::Fit(args) => cmd::fit::run(args),
        Command::Compensate(args) => cmd::compensate::run(args),
        Command::Fom(args) => cmd::fom::run(args),
        Command::Info(args) => cmd::info::run(args),
        Command::Convert(args) => cmd::convert::run(args),
        Command::Demo(args) => cmd::demo::run(args),
        Command::Simulate(args) => cmd::simulate::run(args),
        Command::Plan(args) => cmd::plan::run(args),
        Command::Report(args) => cmd::report::run(args),
        Command::Tables(args) => cmd::tables::run(args),
        Command::Procedure(args) => cmd::procedure::run(args),
        Command::Stream(args) => cmd::stream::run(args),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) if is_broken_pipe(&e) => ExitCode::SUCCESS,
        Err(e) => {
            note!("error: {}", one_line(&e));
            ExitCode::FAILURE
        }
    }
}

/// The message and its causes on one line, no backtrace. A cause whose text the message
/// already holds (a library error that formats its source and also chains it) is left out,
/// so an OS error is not printed twice.
fn one_line(e: &anyhow::Error) -> String {
    let mut out = e.to_string();
    for cause in e.chain().skip(1) {
        let text = cause.to_string();
        if !out.contains(&text) {
            out.push_str(": ");
            out.push_str(&text);
        }
    }
    out
}

/// A reader that closed our standard output early (`tolles compensate … | head`) is not an error.
fn is_broken_pipe(e: &anyhow::Error) -> bool {
    e.chain().any(|c| {
        c.downcast_ref::<std::io::Error>()
            .is_some_and(|io| io.kind() == std::io::ErrorKind::BrokenPipe)
    })
}
