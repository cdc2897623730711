//! `tolles report`: a self-contained HTML report of a flight, before and after compensation.

use crate::input::parse_band;
use crate::render::{self, OrRender, Use};
use anyhow::{Context, Result};
use std::path::PathBuf;
use tolles::fom::{FomOutcome as Outcome, FomRequest};
use tolles_core::fit::Band;
use tolles_core::fom::{bandpassed, FomReport, FomSettings};
use tolles_core::metrics::std_dev;
use tolles_core::spectrum::welch;
use tolles_io::model::{ModelFile, ScalarModel};
use tolles_report::plot::{BarChart, BarSeries, Colour, LinePlot, Series};
use tolles_report::Report;

const EXAMPLES: &str = "\
Examples:
  tolles demo --out demo
  tolles report demo/calibration.csv --scalar mag_1_uc --model demo/model.json --out demo/report
  # then open demo/report/index.html in a browser (no network needed)";

/// Write an HTML report of a flight: time series and spectra before and after compensation,
/// the figure of merit maneuver by maneuver, the model's coefficients with standard errors, its
/// patent terms and fit diagnostics. Opens in a browser with no network.
#[derive(clap::Args)]
#[command(after_help = EXAMPLES)]
pub struct Args {
    /// Flight in any format `fit` reads (tt, ins_roll, ins_pitch, ins_yaw, the scalar, and the model's fluxgate)
    pub flight: PathBuf,
    /// Uncompensated scalar column (nT)
    #[arg(long)]
    pub scalar: String,
    /// Model from `tolles fit`; without it the report shows the uncompensated flight only
    #[arg(long)]
    pub model: Option<PathBuf>,
    /// Directory for index.html and its plots
    #[arg(long)]
    pub out: PathBuf,
    /// Pass band LO,HI (Hz) of the figure of merit and the band-passed plots
    #[arg(long, default_value = "0.05,1")]
    pub band: String,
    /// Sample rate (Hz), if the file has no tt column
    #[arg(long)]
    pub fs: Option<f64>,
}

pub fn run(args: Args) -> Result<()> {
    let index = write(&args)?;
    eprintln!("report written to {}", index.display());
    Ok(())
}

/// Builds and writes the report; returns the path of index.html.
pub fn write(args: &Args) -> Result<PathBuf> {
    let (pass1_hz, pass2_hz) = parse_band(&args.band)?;
    let settings = FomSettings {
        band: Band { pass1_hz, pass2_hz },
        order: 4,
    };
    let model = args
        .model
        .as_deref()
        .map(|path| ModelFile::read(path).map(|m| (m, path)))
        .transpose()?;
    let scalar_model = model
        .as_ref()
        .map(|(model, path)| tolles::fom::fit_for(model, path, &args.scalar))
        .transpose()
        .or_render()?;
    let table = crate::select::Selection::default().read(&args.flight, Use::Other)?;
    let truth = table.numeric("truth_earth").ok();
    let request = FomRequest {
        band: settings.band,
        order: settings.order,
        fs_hz: args.fs,
        ..FomRequest::new(&args.scalar)
    };
    let mut warnings = Vec::new();
    let outcome = tolles::fom::fom(&table, &request, scalar_model, &mut warnings);
    render::warnings(&mut warnings, Use::Other);
    let outcome = outcome.or_render()?;
    let mut report = Report::new(format!("Compensation report: {}", args.flight.display()))
        .subtitle(format!(
            "Scalar {} at {:.3} Hz, {} samples; figure-of-merit band {}–{} Hz.",
            args.scalar,
            outcome.fs_hz,
            outcome.tt.len(),
            pass1_hz,
            pass2_hz
        ));
    report = summary(report, &outcome);
    report = signals(report, &outcome, &settings, truth.as_deref())?;
    report = figure_of_merit(report, &outcome);
    if let Some(scalar_model) = scalar_model {
        report = model_sections(report, scalar_model);
    }
    report
        .write(&args.out)
        .with_context(|| format!("writing the report to {}", args.out.display()))
}

fn summary(report: Report, outcome: &Outcome) -> Report {
    let before = &outcome.before;
    let mut items = vec![
        ("FOM before".to_string(), format!("{:.3} nT", before.fom_nt)),
        (
            "noise before".to_string(),
            format!("{:.3} nT", before.noise_level_nt),
        ),
    ];
    if let Some(after) = &outcome.after {
        items.push(("FOM after".into(), format!("{:.3} nT", after.fom_nt)));
        items.push((
            "noise after".into(),
            format!("{:.4} nT", after.noise_level_nt),
        ));
        items.push((
            "improvement".into(),
            format!("×{:.1}", before.fom_nt / after.fom_nt),
        ));
    }
    items.push((
        "maneuvers found".into(),
        format!("{} of 12", 12 - before.missing.len()),
    ));
    let borrowed: Vec<(&str, &str)> = items
        .iter()
        .map(|(k, v)| (k.as_str(), v.as_str()))
        .collect();
    report.summary(&borrowed)
}

fn centred(x: &[f64]) -> Vec<f64> {
    let finite: Vec<f64> = x.iter().copied().filter(|v| v.is_finite()).collect();
    let mean = finite.iter().sum::<f64>() / finite.len().max(1) as f64;
    x.iter().map(|v| v - mean).collect()
}

fn signals(
    mut report: Report,
    outcome: &Outcome,
    settings: &FomSettings,
    truth: Option<&[f64]>,
) -> Result<Report> {
    let t = &outcome.tt;
    let mut raw = vec![
        Series::new("uncompensated", t.clone(), centred(&outcome.scalar))
            .colour(Colour::UNCOMPENSATED),
    ];
    let mut filtered = vec![Series::new(
        "uncompensated",
        t.clone(),
        bandpassed(&outcome.scalar, Some(t), outcome.fs_hz, settings)?,
    )
    .colour(Colour::UNCOMPENSATED)];
    if let Some(c) = &outcome.compensated {
        raw.push(Series::new("compensated", t.clone(), centred(c)).colour(Colour::COMPENSATED));
        filtered.push(
            Series::new(
                "compensated",
                t.clone(),
                bandpassed(c, Some(t), outcome.fs_hz, settings)?,
            )
            .colour(Colour::COMPENSATED),
        );
    }
    if let Some(truth) = truth {
        raw.push(
            Series::new("truth (earth field)", t.clone(), centred(truth)).colour(Colour::REFERENCE),
        );
    }
    report = report
        .section("Signals")
        .line_plot(LinePlot {
            title: "Scalar magnetometer, mean removed".into(),
            x_label: "time (s)".into(),
            y_label: "field − mean (nT)".into(),
            series: raw,
            caption: Some(
                "What compensation removes is the difference between the two curves.".into(),
            ),
            ..LinePlot::default()
        })
        .line_plot(LinePlot {
            title: format!(
                "Band-passed {}–{} Hz (the maneuver noise)",
                settings.band.pass1_hz, settings.band.pass2_hz
            ),
            x_label: "time (s)".into(),
            y_label: "band-passed field (nT)".into(),
            series: filtered,
            ..LinePlot::default()
        });
    if let (Some(c), Some(truth)) = (&outcome.compensated, truth) {
        let error: Vec<f64> = c.iter().zip(truth).map(|(a, b)| a - b).collect();
        let error = centred(&error);
        report = report.line_plot(LinePlot {
            title: "Compensated minus truth".into(),
            x_label: "time (s)".into(),
            y_label: "error (nT)".into(),
            series: vec![Series::new("compensated − truth", t.clone(), error.clone())
                .colour(Colour::COMPENSATED)],
            caption: Some(format!(
                "Standard deviation {:.4} nT (the simulator's truth column truth_earth).",
                std_dev(&error)
            )),
            ..LinePlot::default()
        });
    }
    spectra(report, outcome)
}

fn spectra(report: Report, outcome: &Outcome) -> Result<Report> {
    let mut series = Vec::new();
    let mut caption = String::new();
    let inputs = std::iter::once(("uncompensated", &outcome.scalar, Colour::UNCOMPENSATED)).chain(
        outcome
            .compensated
            .iter()
            .map(|c| ("compensated", c, Colour::COMPENSATED)),
    );
    for (name, x, colour) in inputs {
        let psd =
            welch(x, outcome.fs_hz).with_context(|| format!("spectrum of the {name} scalar"))?;
        caption = format!(
            "Welch's method, Hann window, {} samples per segment ({:.4} Hz resolution), {} segments.",
            psd.segment_len,
            psd.resolution_hz(),
            psd.segments
        );
        series.push(
            Series::new(
                name,
                psd.frequency_hz[1..].to_vec(),
                psd.density[1..].to_vec(),
            )
            .colour(colour),
        );
    }
    Ok(report.line_plot(LinePlot {
        title: "Power spectral density".into(),
        x_label: "frequency (Hz)".into(),
        y_label: "PSD (nT²/Hz)".into(),
        series,
        log_y: true,
        caption: Some(caption),
        ..LinePlot::default()
    }))
}

fn figure_of_merit(mut report: Report, outcome: &Outcome) -> Report {
    report = report.section("Figure of merit");
    let counted: Vec<_> = outcome.before.counted().collect();
    if counted.is_empty() {
        return report.paragraph("No compensation-box maneuvers were found in the attitude channels, so there is no figure of merit.");
    }
    let label = |m: &tolles_core::maneuver::Maneuver| {
        format!(
            "{} {:03.0}°",
            m.kind,
            m.cardinal_heading_deg().unwrap_or(m.heading_deg)
        )
    };
    let categories: Vec<String> = counted.iter().map(|m| label(&m.maneuver)).collect();
    let after_of = |after: &FomReport| -> Vec<f64> {
        counted
            .iter()
            .map(|m| {
                after
                    .maneuvers
                    .iter()
                    .find(|a| a.maneuver.start == m.maneuver.start)
                    .map_or(f64::NAN, |a| a.peak_to_peak_nt)
            })
            .collect()
    };
    let mut series = vec![BarSeries::new(
        "uncompensated",
        counted.iter().map(|m| m.peak_to_peak_nt).collect(),
    )
    .colour(Colour::UNCOMPENSATED)];
    if let Some(after) = &outcome.after {
        series.push(BarSeries::new("compensated", after_of(after)).colour(Colour::COMPENSATED));
    }
    report = report.bar_chart(BarChart {
        title: "Peak-to-peak of the band-passed scalar, maneuver by maneuver".into(),
        y_label: "peak-to-peak (nT)".into(),
        categories,
        series,
        caption: Some(format!(
            "FOM = sum of the bars: {:.3} nT before{}.",
            outcome.before.fom_nt,
            outcome
                .after
                .as_ref()
                .map_or(String::new(), |a| format!(", {:.3} nT after", a.fom_nt))
        )),
    });
    let rows: Vec<Vec<String>> = counted
        .iter()
        .map(|m| {
            let after = outcome.after.as_ref().and_then(|a| {
                a.maneuvers
                    .iter()
                    .find(|x| x.maneuver.start == m.maneuver.start)
            });
            vec![
                label(&m.maneuver),
                format!("{:.1}–{:.1}", m.maneuver.start_tt, m.maneuver.end_tt),
                format!("{:.1}", m.maneuver.amplitude_deg),
                format!("{:.3}", m.peak_to_peak_nt),
                after.map_or("—".into(), |a| format!("{:.4}", a.peak_to_peak_nt)),
            ]
        })
        .collect();
    report = report.table(
        &[
            "maneuver",
            "time (s)",
            "amplitude (°)",
            "before (nT)",
            "after (nT)",
        ],
        &rows,
    );
    if !outcome.before.missing.is_empty() {
        let missing: Vec<String> = outcome
            .before
            .missing
            .iter()
            .map(|s| format!("{} on {}°", s.kind, s.heading_deg))
            .collect();
        report = report.paragraph(format!("Missing from the box: {}.", missing.join(", ")));
    }
    report
}

fn model_sections(mut report: Report, model: &ScalarModel) -> Report {
    let fit = &model.fit;
    let d = &fit.diagnostics;
    // Several fluxgates name their columns `flux_b.perm_x`: the unit follows the column part.
    let unit = |name: &str| match name.rsplit('.').next().unwrap_or(name).split('_').next() {
        Some("perm") | Some("bias") => "nT",
        _ => "nT per column unit",
    };
    let rows: Vec<Vec<String>> = fit
        .columns
        .iter()
        .zip(&fit.coefficients)
        .zip(&d.std_errors)
        .map(|((name, beta), se)| {
            vec![
                name.clone(),
                format!("{beta:.6}"),
                format!("{se:.4}"),
                unit(name).into(),
            ]
        })
        .collect();
    report = report
        .section("Model")
        .paragraph(format!(
            "Fit of {} against {} {} with terms {}; sample rate {:.3} Hz.",
            model.scalar,
            if model.vectors.len() > 1 {
                "fluxgates"
            } else {
                "fluxgate"
            },
            model.vectors.join(", "),
            fit.settings.design.terms,
            fit.fs_hz
        ))
        .table(&["column", "coefficient", "standard error", "unit"], &rows);
    let patent: Vec<Vec<String>> = model
        .patent
        .named()
        .iter()
        .map(|(name, value)| {
            let unit = match name.chars().next() {
                Some(c) if c.is_lowercase() => "s",
                _ if ["T", "L", "V"].contains(name) => "nT",
                _ => "1",
            };
            vec![name.to_string(), format!("{value:.5e}"), unit.into()]
        })
        .collect();
    report = report
        .paragraph(if model.vectors.len() > 1 {
            "The first fluxgate's block in the Tolles patent's terms (L = forward, T = right, V = down):"
        } else {
            "The same model in the Tolles patent's terms (L = forward, T = right, V = down):"
        })
        .table(&["term", "value", "unit"], &patent);
    let mut diagnostics = vec![
        (
            "samples used".to_string(),
            format!("{} of {}", d.samples_used, d.samples_total),
        ),
        (
            "samples skipped (missing values)".to_string(),
            d.samples_nonfinite.to_string(),
        ),
        (
            "filtered scalar before".to_string(),
            format!("{:.4} nT", d.filtered_std_before_nt),
        ),
        (
            "filtered residual".to_string(),
            format!("{:.4} nT", d.residual_std_nt),
        ),
        (
            "improvement ratio".to_string(),
            format!("{:.2}", d.improvement_ratio),
        ),
        (
            "condition number of AᵀA + Λ".to_string(),
            format!("{:.3e}", d.condition_number),
        ),
    ];
    if let Some(cv) = &d.cross_validation {
        diagnostics.push((
            "ridge λ (× diag AᵀA)".into(),
            format!("{:e}", cv.chosen_lambda_rel),
        ));
        diagnostics.push((
            "expected held-out residual".into(),
            format!("{:.4} nT", cv.expected_heldout_rms_nt),
        ));
    }
    let borrowed: Vec<(&str, &str)> = diagnostics
        .iter()
        .map(|(k, v)| (k.as_str(), v.as_str()))
        .collect();
    report = report.section("Fit diagnostics").key_values(&borrowed);
    if let Some(cv) = &d.cross_validation {
        let rows: Vec<Vec<String>> = cv
            .grid
            .iter()
            .map(|p| {
                vec![
                    format!("{:e}", p.lambda_rel),
                    p.heldout_rms_nt
                        .map_or("not solvable".into(), |r| format!("{r:.5}")),
                ]
            })
            .collect();
        report = report
            .paragraph(format!(
                "{}-fold blocked cross-validation over time:",
                cv.folds
            ))
            .table(&["λ (× diag AᵀA)", "held-out RMS (nT)"], &rows);
    }
    if !d.term_choice.is_empty() {
        let rows: Vec<Vec<String>> = d
            .term_choice
            .iter()
            .map(|t| {
                vec![
                    t.terms.to_string(),
                    t.lambda_rel.map_or("-".into(), |l| format!("{l:e}")),
                    t.heldout_rms_nt
                        .map_or("could not be fitted".into(), |r| format!("{r:.5}")),
                    if t.chosen { "chosen" } else { "" }.into(),
                ]
            })
            .collect();
        report = report
            .paragraph(
                "Term sets compared on the same folds (an alternative to the first must be 2 % better):",
            )
            .table(
                &["terms", "λ (× diag AᵀA)", "held-out RMS (nT)", ""],
                &rows,
            );
    }
    report
}
