//! `tolles report`: a self-contained HTML report of a flight, before and after compensation.

use crate::input::parse_band;
use crate::render;
use anyhow::Result;
use std::path::PathBuf;
use tolles::report::ReportRequest;
use tolles_core::fit::Band;

const EXAMPLES: &str = "\
Examples:
  tolles demo --out demo
  tolles report demo/calibration.csv --scalar mag_1_uc --model demo/model.json --out demo/report
  # then open demo/report/index.html in a browser (no network needed);
  # the demo also writes demo/survey-report, the survey against the simulator's truth
  # Two magnetometers compared on one page, also printed to PDF (needs Chromium):
  tolles report survey.csv --scalar mag_4_uc --scalar mag_5_uc --model m.json --out rep --pdf rep.pdf";

/// Write an HTML report of a flight: zoomable time series (maneuvers shaded) and spectra before
/// and after compensation,
/// the figure of merit maneuver by maneuver with each maneuver and its attitude drawn small,
/// level against heading (a box's headings or a survey's lines), the model's coefficients with
/// standard errors, its patent terms and fit diagnostics. Opens in a browser with no network.
#[derive(clap::Args)]
#[command(after_help = EXAMPLES)]
pub struct Args {
    #[arg(help = flight_help!("Flight with tt, ins_roll, ins_pitch, ins_yaw, the scalar, and the model's fluxgate"))]
    pub flight: PathBuf,
    /// Uncompensated scalar column (nT); repeat (or separate by commas) for several scalars on
    /// one page: a table comparing them, then each one's sections. Default: every fit of the
    /// --model
    #[arg(long, value_delimiter = ',')]
    pub scalar: Vec<String>,
    /// Model from `tolles fit`; without it the report shows the uncompensated flight only
    #[arg(long)]
    pub model: Option<PathBuf>,
    /// Directory for index.html and its plots
    #[arg(short, long)]
    pub out: PathBuf,
    /// Also print the page to this PDF with headless Chromium (found as $TOLLES_CHROMIUM, or
    /// chromium, chromium-browser or google-chrome on PATH)
    #[arg(long, value_name = "FILE.pdf")]
    pub pdf: Option<PathBuf>,
    /// Pass band LO,HI (Hz) of the figure of merit and the band-passed plots
    #[arg(long, default_value = "0.05,1", allow_hyphen_values = true)]
    pub band: String,
    /// Butterworth order of the band-pass (per edge)
    #[arg(long, default_value_t = 4)]
    pub order: usize,
    /// The survey specification's fourth-difference tolerance (nT): the report draws ± it
    /// under the fourth difference and passes each line whose every fourth difference lies
    /// within it
    #[arg(long, value_name = "NT", default_value_t = tolles::report::NOISE_TOLERANCE_NT)]
    pub noise_tolerance: f64,
    /// The survey specification's largest figure of merit of a box (nT): the compensated FOM
    /// passes at or below it
    #[arg(long, value_name = "NT", default_value_t = tolles::report::FOM_SPEC_NT)]
    pub fom_spec: f64,
    /// The survey specification's largest heading error after compensation (nT), judged
    /// against the truth or --reference (legs over different ground cannot judge it)
    #[arg(long, value_name = "NT", default_value_t = tolles::report::HEADING_ERROR_SPEC_NT)]
    pub heading_error_spec: f64,
    /// Page size of --pdf: a4 or letter
    #[arg(long, default_value = "a4")]
    pub paper: tolles::report::Paper,
    /// Sample rate (Hz), if the file has no tt column
    #[arg(long, allow_negative_numbers = true)]
    pub fs: Option<f64>,
    /// Judge the compensated scalar against this column (nT) instead of the simulator's
    /// truth_earth: a reference magnetometer, or a compensation made elsewhere (SGL's mag_1_c)
    #[arg(long, value_name = "COLUMN")]
    pub reference: Option<String>,
    #[command(flatten)]
    pub legs: crate::input::Legs,
    #[command(flatten)]
    pub select: crate::select::Selection,
}

pub fn run(args: Args) -> Result<()> {
    let (pass1_hz, pass2_hz) = parse_band(&args.band)?;
    let request = args.legs.apply_to_report(ReportRequest {
        model: args.model,
        band: Band { pass1_hz, pass2_hz },
        order: args.order,
        fs_hz: args.fs,
        scalar: None,
        selection: args.select.rows(),
        renames: args.select.renames.clone(),
        noise_tolerance_nt: args.noise_tolerance,
        fom_spec_nt: args.fom_spec,
        heading_error_spec_nt: args.heading_error_spec,
        paper: args.paper,
        reference: args.reference,
        ..ReportRequest::new(args.flight, "")
    });
    let index = render::report(&request, &args.scalar, &args.out)?;
    note!("report written to {}", index.display());
    if let Some(pdf) = &args.pdf {
        tolles_report::export::print_pdf(&index, pdf)?;
        note!("PDF written to {}", pdf.display());
    }
    Ok(())
}
