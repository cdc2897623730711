//! `tolles demo`: the built-in example.

use anyhow::Result;
use std::path::PathBuf;

/// Simulate a calibration flight and a survey, fit, compensate and report against the truth.
#[derive(clap::Args)]
pub struct Args {
    /// Directory for the simulated flights, the model and the compensated survey
    #[arg(long, default_value = "tolles-demo")]
    pub out: PathBuf,
}

pub fn run(_args: Args) -> Result<()> {
    anyhow::bail!("demo is not written yet")
}
