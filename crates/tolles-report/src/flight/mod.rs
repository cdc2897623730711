//! The compensation report of a flight: [`tolles::report::ReportData`] laid out as a page —
//! summary cards, signals, spectra, the figure of merit maneuver by maneuver, the heading error
//! heading by heading and, with a model, its coefficients, patent terms and fit diagnostics.

mod fit_sections;
mod headings;
mod lines;
mod maneuvers;
mod maps;
mod spec;

use crate::live::Live;
use crate::plot::{format_value, BarChart, BarSeries, Colour, LinePlot, PlotSize, Series, Span};
use crate::{GridCell, Report, ReportError};
use fit_sections::*;
use headings::*;
use lines::*;
use maneuvers::*;
use maps::*;
use spec::specification;
use std::ops::Range;
use std::path::{Path, PathBuf};
use tolles::fom::RateSource;
use tolles::lines::{ExtentSource, HeadingSource, LineKind, LineRow, LineTable};
use tolles::model::ScalarModel;
use tolles::report::{HeadingRow, ManeuverRow, ReportData};
use tolles::tolles_core::fit::Target;
use tolles::tolles_core::maneuvers::detect::Maneuver;
use tolles::tolles_core::maneuvers::heading::HeadingLevels;
use tolles::tolles_core::signal::metrics::std_dev;
use tolles::tolles_core::signal::spectrum::Spectrum;
use tolles::warning::Warning;

/// Said in place of the figure-of-merit sections when the flight has no box maneuvers.
const NO_BOX: &str =
    "This flight has no compensation-box maneuvers, so it has no figure of merit (FOM).";

/// Said in place of the figure-of-merit sections when the flight lacks an attitude column.
const NO_ATTITUDE: &str = "This flight lacks attitude (ins_roll, ins_pitch and ins_yaw are \
    needed), so no maneuver can be found in it and it has no figure of merit (FOM). A file \
    that names them otherwise can say which with --rename (e.g. --rename ROLL=ins_roll).";

/// Lays out `data` and writes it as `dir/index.html` with its plots; returns the page's path.
pub fn write(data: &ReportData, dir: &Path) -> Result<PathBuf, ReportError> {
    write_each(std::slice::from_ref(data), &[], dir)
}

/// The report of `data`, its maps referenced but not written (see [`write()`]).
pub fn page(data: &ReportData) -> Report {
    page_with(data, &maps(data, ""))
}

/// Lays out the reports of several scalars of one flight on one page (see [`page_each`]) and
/// writes it as `dir/index.html` with its plots; returns the page's path. `warnings`, what
/// building `data` noticed, head the page as they head the command's output.
pub fn write_each(
    data: &[ReportData],
    warnings: &[Warning],
    dir: &Path,
) -> Result<PathBuf, ReportError> {
    let (page, maps) = page_and_maps(data, warnings);
    let mut staged = crate::Staged::default();
    let index = page.stage(dir, &mut staged)?;
    for map in &maps {
        staged.file(&dir.join(&map.src), &map.svg)?;
    }
    staged.commit()?;
    Ok(index)
}

/// One scalar's report as [`page`]; several: a table comparing them, then each one's sections
/// headed with its name. Maps are referenced but not written (see [`write_each`]).
pub fn page_each(data: &[ReportData], warnings: &[Warning]) -> Report {
    page_and_maps(data, warnings).0
}

fn page_and_maps(data: &[ReportData], warnings: &[Warning]) -> (Report, Vec<Map>) {
    let (report, maps) = pages_and_maps(data);
    (with_warnings(report, warnings), maps)
}

/// `report` with each of `warnings` (once) under its summary, as the command line says them.
fn with_warnings(report: Report, warnings: &[Warning]) -> Report {
    let mut said: Vec<String> = Vec::new();
    for warning in warnings {
        let text = format!("Warning: {warning}");
        if !said.contains(&text) {
            said.push(text);
        }
    }
    said.into_iter().fold(report, Report::summary_note)
}

fn pages_and_maps(data: &[ReportData]) -> (Report, Vec<Map>) {
    if let [one] = data {
        let maps = maps(one, "");
        return (page_with(one, &maps), maps);
    }
    let mut report = several_header(data);
    let mut all_maps = Vec::new();
    for (number, d) in data.iter().enumerate() {
        let maps = maps(d, &format!("{}-", number + 1));
        report = report.part(scalar_of(d), page_with(d, &maps));
        all_maps.extend(maps);
    }
    (report, all_maps)
}

fn scalar_of(data: &ReportData) -> &str {
    data.request.scalar.as_deref().unwrap_or_default()
}

/// The title of a report of several scalars and the table comparing them.
fn several_header(data: &[ReportData]) -> Report {
    let scalars: Vec<&str> = data.iter().map(scalar_of).collect();
    let first = data.first();
    let mut report = Report::new(format!(
        "Compensation report: {}",
        first.map_or(String::new(), |d| d.request.flight.display().to_string())
    ));
    if let Some(d) = first {
        report = report
            .subtitle(format!(
                "Scalars {} at {:.3} Hz, {} samples; figure-of-merit band {}–{} Hz.",
                scalars.join(", "),
                d.fom.fs_hz,
                d.fom.tt.len(),
                d.request.band.pass1_hz,
                d.request.band.pass2_hz
            ))
            .provenance(provenance(d))
            .paper(d.request.paper);
    }
    let rows: Vec<Vec<String>> = data.iter().map(comparison_cells).collect();
    let vs = first.map_or_else(|| "truth".to_string(), |d| against(d).short);
    let error_vs = format!("error vs {vs}");
    report
        .section("Scalars compared")
        .paragraph(format!(
            "Each scalar before and after compensation, as its own sections below define the \
             figures: FOM (box maneuvers), 4th-difference noise, heading error, and the \
             standard deviation of compensated minus {}.",
            first.map_or_else(|| "the truth".to_string(), |d| against(d).long)
        ))
        .table(
            &[
                "scalar",
                "FOM before",
                "FOM after",
                "4th-diff. noise before",
                "4th-diff. noise after",
                "heading error before",
                "heading error after",
                &error_vs,
            ],
            &rows,
        )
}

/// A row of the comparison table; "—" with the reason where a figure does not exist.
fn comparison_cells(data: &ReportData) -> Vec<String> {
    const NO_MODEL: &str = "— (no model)";
    let after = data.fom.after.as_ref();
    let fom = |value: Option<f64>| match (has_box(data), value) {
        (false, _) => "— (no box)".to_string(),
        (true, None) => NO_MODEL.to_string(),
        (true, Some(v)) => nt(v, 3),
    };
    let heading = |levels: Option<&HeadingLevels>| match levels {
        None => NO_MODEL.to_string(),
        Some(l) => l
            .heading_error_nt
            .map_or("— (fewer than two headings)".into(), |e| nt(e, 3)),
    };
    let truth = match (&data.error, &data.truth) {
        (Some(e), _) => nt(e.std_nt, 4),
        (None, Some(_)) => NO_MODEL.to_string(),
        (None, None) => "— (no truth column)".to_string(),
    };
    vec![
        scalar_of(data).to_string(),
        fom(Some(data.fom.before.fom_nt)),
        fom(after.map(|a| a.fom_nt)),
        nt(data.fom.before.fourth_difference_nt, 4),
        after.map_or(NO_MODEL.into(), |a| nt(a.fourth_difference_nt, 4)),
        heading(Some(&data.fom.heading_before)),
        heading(data.fom.heading_after.as_ref()),
        truth,
    ]
}

fn page_with(data: &ReportData, maps: &[Map]) -> Report {
    let request = &data.request;
    let mut report = Report::new(format!("Compensation report: {}", request.flight.display()))
        .paper(request.paper)
        .subtitle(format!(
            "Scalar {} at {:.3} Hz{}, {} samples; figure-of-merit band {}–{} Hz.",
            request.scalar.as_deref().unwrap_or_default(),
            data.fom.fs_hz,
            match data.fom.fs_from {
                RateSource::File => "",
                RateSource::Given => " (given with --fs)",
                RateSource::Model => " (assumed: the model's rate; the file states none)",
            },
            data.fom.tt.len(),
            data.fom.before.band_hz.0,
            data.fom.before.band_hz.1
        ))
        .provenance(provenance(data));
    report = summary(report, data);
    if let Some(fit) = &data.fit {
        report = model_banner(report, fit, request.model.as_deref());
    }
    report = specification(report, data);
    if !has_box(data) {
        report = report.paragraph(match data.attitude.all() {
            Some(_) => NO_BOX,
            None => NO_ATTITUDE,
        });
    }
    // A box's legs and the turns are not survey lines: the maneuver sections describe the
    // legs, and the lines' table names the rest below it.
    if let Some(lines) = data.lines.as_ref().filter(|l| has_lines(l)) {
        let tolerance = data.request.noise_tolerance_nt;
        let vs = against(data).short;
        report = per_line(report, lines, data.compensated.is_some(), tolerance, &vs);
    }
    report = map_section(report, data, maps);
    // The spectrum is a figure of the Signals section; the line profiles are their own.
    report = signals(report, data);
    report = spectra(report, data);
    report = line_profiles(report, data);
    if has_box(data) {
        report = figure_of_merit(report, data);
    }
    report = maneuver_detail(report, data);
    report = heading_error(report, data);
    report = level_against_heading(report, data);
    if let Some(fit) = &data.fit {
        // Said first in both sections: whether what follows is independent of this flight.
        let from = fitted_on(fit, &request.flight);
        report = model(report, fit, &from);
        report = diagnostics(report, fit, &from);
    }
    report
}

/// The tool, the time of writing and the files a page comes from.
fn provenance(data: &ReportData) -> String {
    let model =
        (data.request.model.as_deref()).map_or("none".to_string(), |m| m.display().to_string());
    format!(
        "Written by tolles {} on {}; flight {}; model {model}.",
        env!("CARGO_PKG_VERSION"),
        crate::utc_stamp(crate::written_at()),
        data.request.flight.display()
    )
}

/// Which flight the model's sections describe: the calibration flight, which is this page's
/// flight only for a calibration report.
fn fitted_on(fit: &ScalarModel, flight: &std::path::Path) -> String {
    let Some(calibration) = fit.calibration_flight.as_deref() else {
        return "From the model's calibration flight (its file does not name it), not this one."
            .to_string();
    };
    // A fit of several flights names them joined by " + ".
    let same = |part: &str| {
        let part = std::path::Path::new(part.trim());
        match (part.canonicalize(), flight.canonicalize()) {
            (Ok(a), Ok(b)) => a == b,
            _ => part.file_name() == flight.file_name(),
        }
    };
    match calibration.split(" + ").any(same) {
        true => format!(
            "From a calibration that includes this flight ({calibration}): what this page \
             shows of the compensation is not independent of the fit."
        ),
        false => format!("From the calibration flight {calibration}, not this flight."),
    }
}

/// What the page's model is and whether to trust it, under the summary: the model file, its
/// calibration flight, fluxgates and terms, and its verdict with every reason.
fn model_banner(report: Report, fit: &ScalarModel, path: Option<&std::path::Path>) -> Report {
    let file = path.map_or("the model".to_string(), |p| p.display().to_string());
    let calibration = fit
        .calibration_flight
        .as_deref()
        .map_or(String::new(), |c| format!(", fitted on {c}"));
    let magnitude = match fit.fit.magnitude {
        tolles::tolles_core::model::magnitude::Magnitude::Linear => "linear",
        tolles::tolles_core::model::magnitude::Magnitude::Exact => "exact",
    };
    let mut text = format!(
        "Model {file}{calibration}: {} against fluxgate {}, terms {} ({magnitude} magnitude).",
        fit.scalar,
        fit.vectors.join(", "),
        fit.fit.settings.design.terms
    );
    text += &match &fit.fit.verdict {
        None => " Verdict: unknown (a model file written before verdicts).".to_string(),
        Some(v) if v.reasons.is_empty() => format!(" Verdict: {}.", v.grade),
        Some(v) => {
            let reasons: Vec<String> = v.reasons.iter().map(ToString::to_string).collect();
            format!(" Verdict: {}: {}.", v.grade, reasons.join("; "))
        }
    };
    if let Some(v) = fit.fit.verdict.as_ref().filter(|v| !v.notes.is_empty()) {
        let notes: Vec<String> = v.notes.iter().map(ToString::to_string).collect();
        text += &format!(" Noted: {}.", notes.join("; "));
    }
    text += &fit.network.as_ref().map_or(String::new(), network_sentence);
    report.paragraph(text)
}

/// What the model's network is and what it earned on the calibration flight.
fn network_sentence(learned: &tolles::model::LearnedCorrection) -> String {
    let network = &learned.network;
    let hidden: Vec<String> = (network.hidden_units().iter())
        .map(ToString::to_string)
        .collect();
    format!(
        " A network ({} hidden units, {}, {} inputs) adds a learned correction to the linear \
         one: on the calibration's held-out {} it left {:.4} nT (rms) where the linear model \
         left {:.4} nT.",
        hidden.join(" + "),
        network.activation,
        network.inputs.len(),
        learned.held_out,
        learned.judged_network_rms_nt,
        learned.judged_linear_rms_nt
    )
}

fn summary(report: Report, data: &ReportData) -> Report {
    let before = &data.fom.before;
    let vs = against(data);
    let heading_vs = format!("heading error after, vs {}", vs.short);
    let (error_before, error_after) = (
        format!("error vs {} before", vs.short),
        format!("error vs {} after", vs.short),
    );
    let mut items = Vec::new();
    if let Some(v) = data.fit.as_ref().and_then(|f| f.fit.verdict.as_ref()) {
        items.push(("model verdict", v.grade.to_string()));
    }
    let scatter = |t: &tolles::report::Trace| {
        let finite: Vec<f64> = t
            .bandpassed
            .iter()
            .copied()
            .filter(|v| v.is_finite())
            .collect();
        std_dev(&finite)
    };
    items.push((
        "band-passed scatter before",
        nt(scatter(&data.uncompensated), 3),
    ));
    if let Some(after) = &data.compensated {
        items.push(("band-passed scatter after", nt(scatter(after), 3)));
    }
    if has_box(data) {
        items.push(("FOM before", nt(before.fom_nt, 3)));
    }
    items.push((
        "4th-difference noise before",
        nt(before.fourth_difference_nt, 4),
    ));
    if let Some(after) = &data.fom.after {
        if has_box(data) {
            items.push(("FOM after", nt(after.fom_nt, 3)));
        }
        items.push((
            "4th-difference noise after",
            nt(after.fourth_difference_nt, 4),
        ));
        if has_box(data) {
            items.push(("improvement", ratio(before.fom_nt, after.fom_nt)));
        }
    }
    if let Some(error) = data.fom.heading_before.heading_error_nt {
        items.push(("heading error before, geology included", nt(error, 2)));
    }
    if let Some(error) = data
        .fom
        .heading_after
        .as_ref()
        .and_then(|h| h.heading_error_nt)
    {
        items.push(("heading error after, geology included", nt(error, 3)));
    }
    if let Some(error) = data
        .heading_vs_truth
        .as_ref()
        .and_then(|h| h.heading_error_nt)
    {
        items.push((heading_vs.as_str(), nt(error, 3)));
    }
    if let Some((before, after)) = truth_errors(data) {
        items.push((error_before.as_str(), nt(before, 3)));
        items.push((error_after.as_str(), nt(after, 4)));
    }
    if let Some(share) = &data.network {
        // The network's part of the correction beside the linear model's: whether it matters.
        items.push((
            "network share of the correction",
            format!(
                "{} % ({} of {} nT)",
                crate::numbers::format_value(100.0 * share.network_std_nt / share.linear_std_nt),
                crate::numbers::format_value(share.network_std_nt),
                crate::numbers::format_value(share.linear_std_nt),
            ),
        ));
    }
    if has_box(data) {
        items.push((
            "maneuvers found",
            format!("{} of 12", 12 - before.missing.len()),
        ));
    }
    report
        .summary(&borrowed(&items))
        .summary_note(summary_definitions(data))
}

/// What the summary's figures are, in the words `tolles fom` uses.
fn summary_definitions(data: &ReportData) -> String {
    let band = &data.request.band;
    let mut text = String::new();
    if has_box(data) {
        text += &format!(
            "FOM: the sum over the box's maneuvers of the peak-to-peak of the scalar band-passed \
             {}–{} Hz. ",
            band.pass1_hz, band.pass2_hz
        );
    }
    text += &format!(
        "Band-passed scatter: the standard deviation of the scalar band-passed {}–{} Hz over \
         the whole flight, which needs no maneuvers. ",
        band.pass1_hz, band.pass2_hz
    );
    text += "4th-difference noise: the standard deviation of the fourth difference of the \
             unfiltered scalar over the whole flight, as tolles fom prints it.";
    if has_box(data) && data.fom.after.is_some() {
        text += " Improvement: the uncompensated FOM divided by the compensated one.";
    }
    if data.fom.heading_before.heading_error_nt.is_some() {
        text += " Heading error: the largest minus the smallest heading level (see Heading \
                 error); the legs lie over different ground at different times, so geology and \
                 diurnal variation between them stay in it, however good the compensation.";
    }
    let vs = against(data);
    if data.heading_vs_truth.is_some() {
        text += &format!(
            " Heading error vs {}: the same of the compensated scalar minus {}: what the \
             compensation itself leaves.",
            vs.short, vs.long
        );
    }
    if truth_errors(data).is_some() {
        text += &format!(
            " Error vs {}: the standard deviation of the scalar minus {}, before and after \
             compensation.",
            vs.short, vs.long
        );
    }
    text
}

/// The standard deviations (nT) of the uncompensated and the compensated scalar minus the truth,
/// when the flight has a truth column and a model.
fn truth_errors(data: &ReportData) -> Option<(f64, f64)> {
    let (truth, after) = (data.truth.as_ref()?, data.error.as_ref()?);
    let before: Vec<f64> = data
        .uncompensated
        .centred
        .iter()
        .zip(truth)
        .map(|(s, t)| s - t)
        .collect();
    Some((std_dev(&before), after.std_nt))
}

/// What the compensated scalar is judged against: the simulator's truth, or the reference
/// column the request names.
struct Against {
    /// As a label says it: `truth` or the column's name.
    short: String,
    /// As a sentence says it.
    long: String,
}

fn against(data: &ReportData) -> Against {
    match &data.request.reference {
        Some(column) => Against {
            short: column.clone(),
            long: format!("the reference column {column}"),
        },
        None => Against {
            short: "truth".into(),
            long: format!(
                "the simulator's true earth field ({})",
                tolles::report::TRUTH_COLUMN
            ),
        },
    }
}

/// True when the flight has compensation-box maneuvers, so a figure of merit.
fn has_box(data: &ReportData) -> bool {
    !data.maneuvers.is_empty()
}

/// `value` in nT with `decimals` places, or "—" when it is not a finite number.
fn nt(value: f64, decimals: usize) -> String {
    if value.is_finite() {
        format!("{value:.decimals$} nT")
    } else {
        "— (not computable)".into()
    }
}

/// `×before/after`, or "—" when the ratio is not finite (an after of 0).
fn ratio(before: f64, after: f64) -> String {
    let r = before / after;
    if r.is_finite() {
        format!("×{r:.1}")
    } else {
        "— (FOM after is 0)".into()
    }
}

fn borrowed<'a>(items: &'a [(&'a str, String)]) -> Vec<(&'a str, &'a str)> {
    items.iter().map(|(k, v)| (*k, v.as_str())).collect()
}

fn signals(mut report: Report, data: &ReportData) -> Report {
    let t = &data.fom.tt;
    let series =
        |name: &str, y: &[f64], colour| Series::new(name, t.clone(), y.to_vec()).colour(colour);
    let (before, after) = (&data.uncompensated, data.compensated.as_ref());
    // Without a model the scalar is shown as read: it may be a compensated channel already.
    let scalar = data.request.scalar.as_deref().unwrap_or("scalar");
    let as_read = match after {
        Some(_) => "uncompensated".to_string(),
        None => format!("{scalar} as read"),
    };
    let mut raw = vec![series(&as_read, &before.centred, Colour::UNCOMPENSATED)];
    let mut filtered = vec![series(&as_read, &before.bandpassed, Colour::UNCOMPENSATED)];
    // The truth goes under the compensated curve, which it should hide where they agree.
    if let Some(truth) = &data.truth {
        let name = match &data.request.reference {
            Some(column) => column.clone(),
            None => "truth (earth field)".into(),
        };
        raw.push(series(&name, truth, Colour::REFERENCE));
    }
    if let Some(after) = after {
        raw.push(series("compensated", &after.centred, Colour::COMPENSATED));
        filtered.push(series(
            "compensated",
            &after.bandpassed,
            Colour::COMPENSATED,
        ));
    }
    let raw_caption = after.map(|_| {
        "What compensation removes is the difference between the uncompensated and compensated curves."
            .to_string()
    });
    let band_is = match has_box(data) {
        true => "the maneuver noise",
        false => "the figure of merit's band",
    };
    let band = &data.request.band;
    let windows = match has_box(data) {
        true => maneuver_windows(data),
        false => line_windows(data),
    };
    let over_time = |title: String, y_label: &str, series, caption: Option<String>| LinePlot {
        title,
        x_label: "time (s)".into(),
        y_label: y_label.into(),
        series,
        caption,
        spans: shading_only(&windows),
        live: Some(Live {
            windows: windows.clone(),
        }),
        ..LinePlot::default()
    };
    report = report
        .section("Signals")
        .paragraph(signals_intro(&windows, has_box(data)))
        .line_plot(over_time(
            "Scalar magnetometer, mean removed".into(),
            "field − mean (nT)",
            raw,
            raw_caption,
        ))
        .line_plot(over_time(
            format!(
                "Band-passed {}–{} Hz ({band_is})",
                band.pass1_hz, band.pass2_hz
            ),
            "band-passed field (nT)",
            filtered,
            None,
        ));
    report = report.line_plot(fourth_difference_plot(data, &over_time));
    if let Some(error) = &data.error {
        let vs = against(data);
        report = report.line_plot(over_time(
            format!("Compensated minus {}", vs.short),
            "error (nT)",
            vec![series(
                &format!("compensated − {}", vs.short),
                &error.centred,
                Colour::COMPENSATED,
            )],
            Some(format!(
                "Standard deviation {:.4} nT (against {}).",
                error.std_nt, vs.long
            )),
        ));
    }
    if let Some(share) = &data.network {
        report = report.line_plot(over_time(
            "The correction's parts, mean removed".into(),
            "correction − mean (nT)",
            vec![
                series("linear model", &share.linear_nt, Colour::UNCOMPENSATED),
                series("network", &share.network_nt, Colour::COMPENSATED),
            ],
            Some(network_caption(share)),
        ));
    }
    let attitude: Vec<Series> = [
        ("roll", data.attitude.roll_deg.as_deref(), Colour::CYCLE[3]),
        (
            "pitch",
            data.attitude.pitch_deg.as_deref(),
            Colour::CYCLE[4],
        ),
    ]
    .into_iter()
    .filter_map(|(name, angle, colour)| Some(series(name, angle?, colour)))
    .collect();
    if !attitude.is_empty() {
        report = report.line_plot(over_time(
            "Attitude".into(),
            "angle (°)",
            attitude,
            Some("Roll (right wing down positive) and pitch (nose up positive).".into()),
        ));
    }
    // Yaw on its own axis: 0–360° would flatten a ±10° roll beside it.
    if let Some(yaw) = data.attitude.yaw_deg.as_deref() {
        let cut = heading_cut(yaw);
        let shown: Vec<f64> = yaw
            .iter()
            .map(|v| cut + (v - cut).rem_euclid(360.0))
            .collect();
        let caption = if cut == 0.0 {
            "Yaw: the heading, clockwise from north (0–360°).".to_string()
        } else {
            format!(
                "Yaw: the heading, clockwise from north. The axis runs from {cut:.0}° round \
                 to {cut:.0}° again, a heading this flight seldom flies, so that no straight \
                 leg is drawn across the wrap from 360° to 0°."
            )
        };
        report = report.line_plot(LinePlot {
            y_range: Some((cut, cut + 360.0)),
            y_ticks: (0..=8)
                .map(|k| f64::from(k) * 90.0)
                .filter(|t| (cut..=cut + 360.0).contains(t))
                .map(|t| (t, format!("{:.0}", t.rem_euclid(360.0))))
                .collect(),
            // The zoomable chart would join the wraps; the drawing breaks them.
            live: None,
            ..over_time(
                "Heading".into(),
                "yaw (°)",
                vec![series("yaw", &shown, Colour::CYCLE[2]).circular(360.0)],
                Some(caption),
            )
        });
    }
    report
}

/// Where the heading chart's axis starts (deg, a multiple of 45°): a heading with next to no
/// samples within 15° of it (no more than 1 % of the flight above the fewest), 0° first and
/// then the diagonals, whose axis ends are not themselves tick labels. A survey flown
/// north–south would otherwise wrap between 359° and 0° on every northbound line.
fn heading_cut(yaw_deg: &[f64]) -> f64 {
    const CANDIDATES: [f64; 8] = [0.0, 45.0, 135.0, 225.0, 315.0, 90.0, 180.0, 270.0];
    let near = |cut: f64| {
        yaw_deg
            .iter()
            .filter(|v| {
                let d = (*v - cut).rem_euclid(360.0);
                d.min(360.0 - d) < 15.0
            })
            .count()
    };
    let counts = CANDIDATES.map(near);
    let fewest = counts.iter().copied().min().unwrap_or(0);
    let enough = fewest + yaw_deg.len() / 100;
    CANDIDATES
        .into_iter()
        .zip(counts)
        .find(|&(_, n)| n <= enough)
        .map_or(0.0, |(cut, _)| cut)
}

/// A chart over the flight's time: title, y label, series and caption.
type OverTime<'a> = dyn Fn(String, &str, Vec<Series>, Option<String>) -> LinePlot + 'a;

/// The fourth difference of the compensated scalar (as read without a model) against the
/// survey specification's ± tolerance, the core figure of a survey's noise QC.
fn fourth_difference_plot(data: &ReportData, plot: &OverTime<'_>) -> LinePlot {
    let t = &data.fom.tt;
    let (trace, name) = match &data.compensated {
        Some(after) => (after, "compensated"),
        None => (&data.uncompensated, "as read"),
    };
    let tolerance = data.request.noise_tolerance_nt;
    plot(
        format!("Fourth difference ({name}) against ±{tolerance} nT"),
        "fourth difference (nT)",
        vec![
            Series::new(name, t.clone(), trace.fourth_difference.clone())
                .colour(Colour::COMPENSATED),
        ]
        .into_iter()
        .chain(tolerance_lines(t, tolerance))
        .collect(),
        Some(format!(
            "(x₋₂ − 4x₋₁ + 6x₀ − 4x₊₁ + x₊₂)/16 of the {name} scalar, sample by sample; the \
             survey specification's tolerance ±{tolerance} nT (report --noise-tolerance). A \
             line passes when all of it lies within (the lines' table)."
        )),
    )
}

/// The specification's ± `tolerance` (nT) as two level lines over `x`.
fn tolerance_lines(x: &[f64], tolerance: f64) -> [Series; 2] {
    let level = |v: f64, sign: &str| {
        Series::new(
            format!("{sign}{tolerance} nT"),
            x.to_vec(),
            vec![v; x.len()],
        )
        .colour(Colour::REFERENCE)
    };
    [level(tolerance, "+"), level(-tolerance, "−")]
}

/// `pass` or `FAIL`, as a specification's test ends.
fn verdict(pass: bool) -> String {
    if pass { "pass" } else { "FAIL" }.into()
}

/// The network's share of the correction, in words.
fn network_caption(share: &tolles::report::NetworkShare) -> String {
    format!(
        "What compensation subtracts is the sum of the two. The network's part varies by {:.4} nT \
         (standard deviation), {:.1} % of the linear part's {:.4} nT.",
        share.network_std_nt,
        100.0 * share.network_std_nt / share.linear_std_nt,
        share.linear_std_nt
    )
}

/// Says what the shaded windows of the time series are, when there are any.
fn signals_intro(windows: &[Span], maneuvers: bool) -> String {
    let mut text =
        String::from("Each time series is a chart you can zoom (its static image is what prints).");
    match (windows.is_empty(), maneuvers) {
        (true, _) => {}
        (false, true) => {
            text += &format!(
            " Shaded: the {} maneuvers the figure of merit counts, labelled when there is room.",
            windows.len()
        )
        }
        (false, false) => {
            text += " Shaded: every other flight line, labelled with its id when there is room, \
                     so each line's start and end show."
        }
    }
    text
}

/// The counted maneuvers as labelled windows of time (s).
fn maneuver_windows(data: &ReportData) -> Vec<Span> {
    data.maneuvers
        .iter()
        .map(|row| Span {
            label: label(&row.maneuver),
            from: row.maneuver.start_tt,
            to: row.maneuver.end_tt,
            colour: Colour::REFERENCE,
        })
        .collect()
}

/// The same windows unlabelled: a static image has no room for a dozen labels.
/// Most line stretches marked on a chart; beyond, the shading would be a grey wash.
const MOST_LINES_MARKED: usize = 80;

/// A survey's lines as alternate shaded spans labelled with their ids, so a chart shows where
/// each line begins and ends (none when there are too many to tell apart).
fn line_windows(data: &ReportData) -> Vec<Span> {
    let Some(lines) = &data.lines else {
        return Vec::new();
    };
    if lines.stretches.len() > MOST_LINES_MARKED {
        return Vec::new();
    }
    (lines.stretches.iter().enumerate())
        .filter(|(k, _)| k % 2 == 0)
        .map(|(_, (id, from, to))| Span {
            label: id.clone(),
            from: *from,
            to: *to,
            colour: Colour::CYCLE[5],
        })
        .collect()
}

fn shading_only(windows: &[Span]) -> Vec<Span> {
    windows
        .iter()
        .map(|w| Span {
            label: String::new(),
            ..w.clone()
        })
        .collect()
}

/// The spectrum's lowest frequency above 0 Hz (Hz).
fn lowest_bin(data: &ReportData) -> Option<f64> {
    (data.spectrum_before.as_ref()?.frequency_hz.iter())
        .copied()
        .find(|f| *f > 0.0 && f.is_finite())
}

/// The spectra before and after; nothing when the flight was too short for one (the warnings
/// panel says why).
fn spectra(report: Report, data: &ReportData) -> Report {
    let Some(before) = &data.spectrum_before else {
        return report;
    };
    let inputs = std::iter::once(("uncompensated", before, Colour::UNCOMPENSATED)).chain(
        data.spectrum_after
            .iter()
            .map(|psd| ("compensated", psd, Colour::COMPENSATED)),
    );
    let mut series = Vec::new();
    let mut caption = String::new();
    for (name, psd, colour) in inputs {
        caption = spectrum_caption(psd);
        // Bin 0 (the mean, at 0 Hz) cannot sit on a log-frequency axis.
        let f = psd.frequency_hz.iter().skip(1).copied().collect();
        let density = psd.density.iter().skip(1).copied().collect();
        series.push(Series::new(name, f, density).colour(colour));
    }
    report.line_plot(LinePlot {
        title: "Power spectral density".into(),
        x_label: "frequency (Hz)".into(),
        y_label: "PSD (nT²/Hz)".into(),
        series,
        log_x: true,
        log_y: true,
        // Up to Nyquist, not the decade above it: nothing is measured there.
        x_range: lowest_bin(data).map(|lo| (lo, data.fom.fs_hz / 2.0)),
        spans: bands(data),
        caption: Some(format!(
            "{caption} Shaded: the band the figure of merit is measured in{}.",
            if data.fit.is_some() {
                " and the band the model was fitted in"
            } else {
                ""
            }
        )),
        ..LinePlot::default()
    })
}

/// The figure-of-merit band and, with a model fitted to a band, the fit's band.
fn bands(data: &ReportData) -> Vec<Span> {
    let band = &data.request.band;
    let mut spans = vec![Span {
        label: format!("FOM band {}–{} Hz", band.pass1_hz, band.pass2_hz),
        from: band.pass1_hz,
        to: band.pass2_hz,
        colour: Colour::UNCOMPENSATED,
    }];
    if let Some(model) = data.fit.as_ref() {
        let settings = &model.fit.settings;
        if settings.target == Target::Band {
            let band = &settings.band;
            spans.push(Span {
                label: format!("fit band {}–{} Hz", band.pass1_hz, band.pass2_hz),
                from: band.pass1_hz,
                to: band.pass2_hz,
                colour: Colour::REFERENCE,
            });
        }
    }
    spans
}

fn spectrum_caption(psd: &Spectrum) -> String {
    format!(
        "Welch's method, Hann window, {} samples per segment ({:.4} Hz resolution), {} segments.",
        psd.segment_len,
        psd.resolution_hz(),
        psd.segments
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use tolles::report::{build, ReportRequest};
    use tolles::{fit, simulate, Silent};

    #[test]
    fn a_simulated_box_gives_every_section_and_plot() {
        let dir = tempfile::tempdir().unwrap();
        let flight = dir.path().join("box.csv");
        let simulated = simulate::simulate(&Default::default(), &Silent).unwrap();
        simulate::write(&simulated, &flight).unwrap();
        let mut warnings = Vec::new();
        let table = tolles::read::read(&flight, &Default::default(), &Silent, &mut warnings)
            .unwrap()
            .table;
        let request = fit::FitRequest::new(vec!["mag_1_uc".into()], vec!["flux_a".into()]);
        let model = fit::fit(&table, &request, &Silent, &mut warnings).unwrap();
        let model_path = dir.path().join("m.json");
        tolles::model::save_model(&model, &model_path).unwrap();
        let request = ReportRequest {
            model: Some(model_path),
            ..ReportRequest::new(&flight, "mag_1_uc")
        };
        let data = build(&request, &Silent, &mut warnings).unwrap();
        let index = write(&data, &dir.path().join("report")).unwrap();
        let html = std::fs::read_to_string(index).unwrap();
        for text in [
            "FOM after",
            "12 of 12",
            "Compensated minus truth",
            "Fit diagnostics",
            "Models compared",
            "roll 090°",
            "Heading error",
            "heading error after",
            "error vs truth before</dt>",
            &format!(
                "error vs truth after</dt><dd>{:.4} nT",
                data.error.as_ref().unwrap().std_nt
            ),
        ] {
            assert!(html.contains(text), "{text} missing");
        }
        // CSS upper-casing would turn λ into Λ; the page itself must not need a capital Λ.
        assert!(!html.contains('Λ') && !html.contains("uppercase"));
        // The summary's noise is the quantity `tolles fom` prints, defined under the cards.
        let noise = format!("{:.4} nT", data.fom.before.fourth_difference_nt);
        assert!(html.contains(&format!("4th-difference noise before</dt><dd>{noise}")));
        assert!(html.contains("class=\"summary-note\">FOM: the sum"));
        for text in [
            "Induced matrix I (dimensionless)",
            "Eddy-current matrix E (s)",
            "so every coefficient is in nT",
            "of the scalar minus the model (band-passed 0.1–0.9 Hz",
        ] {
            assert!(html.contains(text), "{text} missing");
        }
        assert!(!html.contains("per column unit"));
        let plots = dir.path().join("report/plots");
        // Eight plots, three per maneuver, one of level against heading and the two maps.
        assert_eq!(
            std::fs::read_dir(&plots).unwrap().count(),
            8 + 3 * 12 + 1 + 2
        );
        let svg = |name: &str| std::fs::read_to_string(plots.join(name)).unwrap();
        // Compensated bars (hundredths of a nT) beside uncompensated ones (tens of nT) need
        // a log axis to be seen at all.
        let fom = svg("08-peak-to-peak-of-the-band-passed-scalar-m.svg");
        for decade in ["10⁻²", "10⁰", "10²"] {
            assert!(fom.contains(decade), "FOM chart lacks the decade {decade}");
        }
        let psd = svg("07-power-spectral-density.svg");
        for mark in ["FOM band 0.05–1 Hz", "fit band 0.1–0.9 Hz", "10⁻¹"] {
            assert!(psd.contains(mark), "PSD lacks {mark}");
        }
    }

    #[test]
    fn a_flight_in_the_calibration_is_said_to_be_in_it() {
        let dir = tempfile::tempdir().unwrap();
        let model = tolles::model::ModelFile::read(&box_model(dir.path())).unwrap();
        let mut fit = model.fits[0].clone();
        let flight = dir.path().join("box.csv");
        // The same file by another spelling of its path, alone or among several.
        let other_spelling = dir.path().join(".").join("box.csv");
        for calibration in [
            other_spelling.display().to_string(),
            format!("a.csv + {}", flight.display()),
        ] {
            fit.calibration_flight = Some(calibration.clone());
            let said = fitted_on(&fit, &other_spelling);
            assert!(
                said.contains("includes this flight"),
                "{calibration}: {said}"
            );
        }
        let said = fitted_on(&fit, &dir.path().join("survey.csv"));
        assert!(said.ends_with("not this flight."), "{said}");
    }

    /// A model fitted on a simulated box, saved in `dir`.
    fn box_model(dir: &Path) -> PathBuf {
        let flight = dir.join("box.csv");
        let simulated = simulate::simulate(&Default::default(), &Silent).unwrap();
        simulate::write(&simulated, &flight).unwrap();
        let mut warnings = Vec::new();
        let table = tolles::read::read(&flight, &Default::default(), &Silent, &mut warnings)
            .unwrap()
            .table;
        let request = fit::FitRequest::new(vec!["mag_1_uc".into()], vec!["flux_a".into()]);
        let model = fit::fit(&table, &request, &Silent, &mut warnings).unwrap();
        let model_path = dir.join("m.json");
        tolles::model::save_model(&model, &model_path).unwrap();
        model_path
    }

    /// The report of the simulated box `box_model` wrote, compensated by its model, with the
    /// attitude columns `keep_attitude` says.
    fn box_report(dir: &Path, keep_attitude: bool) -> (ReportData, String) {
        let request = ReportRequest {
            model: Some(box_model(dir)),
            ..ReportRequest::new(dir.join("box.csv"), "mag_1_uc")
        };
        let mut data = build(&request, &Silent, &mut Vec::new()).unwrap();
        if !keep_attitude {
            data.attitude = Default::default();
        }
        let index = write(&data, &dir.join("report")).unwrap();
        (data, std::fs::read_to_string(index).unwrap())
    }

    /// The part of `html` from the section headed `heading` to the next section.
    fn section<'a>(html: &'a str, heading: &str) -> &'a str {
        let start = html.find(&format!(">{heading}</h2>")).unwrap();
        let rest = &html[start..];
        &rest[..rest[5..].find("<h2").map_or(rest.len(), |k| k + 5)]
    }

    /// Every plot the page shows, read from `dir/report`.
    fn shown_svgs(dir: &Path, html: &str) -> Vec<String> {
        html.split("src=\"plots/")
            .skip(1)
            .map(|s| s.split('"').next().unwrap())
            .map(|f| std::fs::read_to_string(dir.join("report/plots").join(f)).unwrap())
            .collect()
    }

    #[test]
    fn every_counted_maneuver_gets_a_small_figure_with_its_attitude() {
        let dir = tempfile::tempdir().unwrap();
        let (data, html) = box_report(dir.path(), true);
        let maneuvers = section(&html, "Maneuvers");
        let cells = maneuvers.matches("<figure class=\"cell\">").count();
        assert_eq!(cells, data.maneuvers.len());
        assert_eq!(cells, 12);
        // Before, after and the attitude, small.
        assert_eq!(maneuvers.matches("<img ").count(), 3 * 12);
        assert_eq!(
            maneuvers.matches("width=\"320\" height=\"150\"").count(),
            3 * 12
        );
        for row in &data.maneuvers {
            let p2p = format!("Peak-to-peak {} nT before", format_value(row.before_nt));
            assert!(maneuvers.contains(&p2p), "{p2p}");
            assert!(maneuvers.contains(&format!("<h3>{}</h3>", label(&row.maneuver))));
        }
        let svgs = shown_svgs(dir.path(), &html);
        for axis in ["roll (°)", "pitch (°)", "yaw − "] {
            let panels = svgs.iter().filter(|svg| svg.contains(axis)).count();
            assert_eq!(panels, 4, "{axis}");
        }
        // The time series are live charts, with the maneuvers as their windows; the heading
        // is drawn only, its wraps broken.
        assert_eq!(html.matches("data-live=").count(), 5);
        let data = std::fs::read_to_string(dir.path().join("report/data/05-attitude.js")).unwrap();
        assert_eq!(data.matches("\"label\":\"roll ").count(), 4);
        assert_eq!(svgs.len(), 8 + 3 * 12 + 1 + 2);
        for svg in &svgs {
            assert!(svg.starts_with("<svg") && svg.trim_end().ends_with("</svg>"));
            for bad in ["NaN", "inf", "no data"] {
                assert!(!svg.contains(bad), "{bad} in a plot");
            }
        }
        for bad in ["NaN", "inf"] {
            assert!(!html.contains(bad), "{bad} in the page");
        }
    }

    #[test]
    fn a_box_lists_its_legs_as_maneuvers_not_as_lines() {
        let dir = tempfile::tempdir().unwrap();
        let (data, html) = box_report(dir.path(), true);
        assert!(
            data.lines.is_some(),
            "the box's line column numbers its legs"
        );
        assert!(!html.contains(">Lines<") && html.contains(">Maneuvers<"));
    }

    #[test]
    fn a_box_without_attitude_still_reports_its_maneuvers() {
        let dir = tempfile::tempdir().unwrap();
        let (_, html) = box_report(dir.path(), false);
        let maneuvers = section(&html, "Maneuvers");
        assert_eq!(maneuvers.matches("<figure class=\"cell\">").count(), 12);
        assert_eq!(maneuvers.matches("<img ").count(), 2 * 12);
    }

    #[test]
    fn the_window_of_a_maneuver_keeps_its_margin_inside_the_flight() {
        let m = Maneuver {
            kind: tolles::tolles_core::maneuvers::ManeuverKind::Roll,
            heading_deg: 0.0,
            heading_deg_measured: 0.0,
            start: 30,
            end: 200,
            start_tt: 3.0,
            end_tt: 19.9,
            amplitude_deg: 10.0,
            period_s: 6.0,
            half_cycles: 6,
        };
        assert_eq!(maneuver_window(&m, 10.0, 1000), 0..250);
        assert_eq!(maneuver_window(&m, 2.0, 205), 20..205);
    }

    #[test]
    fn the_heading_axis_starts_where_the_flight_seldom_heads() {
        // North–south lines (noise about 0° and 180°) and their turns through 90°.
        let mut yaw: Vec<f64> = (0..400)
            .map(|k| if k % 2 == 0 { 359.5 } else { 0.5 })
            .collect();
        yaw.extend((0..400).map(|k| 180.0 + if k % 2 == 0 { 0.5 } else { -0.5 }));
        yaw.extend((0..180).map(f64::from));
        // The turns pass 45° and 135°: 225° is the first heading nobody flies.
        assert_eq!(heading_cut(&yaw), 225.0);
        // Turns through every heading: a diagonal, where few samples lie, not 0° or 180°.
        yaw.extend((180..360).map(f64::from));
        assert_eq!(heading_cut(&yaw), 45.0);
        // A box flies all four; its headings' diagonals are free, the first of them chosen.
        let boxed: Vec<f64> = [0.0, 90.0, 180.0, 270.0].repeat(100);
        assert_eq!(heading_cut(&boxed), 45.0);
        // East–west lines keep the plain 0–360° axis.
        let east_west: Vec<f64> = [90.0, 270.0].repeat(100);
        assert_eq!(heading_cut(&east_west), 0.0);
    }

    #[test]
    fn a_yaw_is_plotted_as_its_departure_from_the_heading() {
        let mut m = Maneuver {
            kind: tolles::tolles_core::maneuvers::ManeuverKind::Yaw,
            heading_deg: 0.0,
            heading_deg_measured: 359.0,
            start: 0,
            end: 3,
            start_tt: 0.0,
            end_tt: 0.2,
            amplitude_deg: 5.0,
            period_s: 6.0,
            half_cycles: 6,
        };
        let (label, yaw) = maneuver_angle(&m, &[355.0, 359.0, 4.0]);
        assert_eq!(label, "yaw − 359° (°)");
        let expected = [-4.0, 0.0, 5.0];
        assert!(
            yaw.iter().zip(expected).all(|(a, b)| (a - b).abs() < 1e-9),
            "{yaw:?}"
        );
        m.kind = tolles::tolles_core::maneuvers::ManeuverKind::Pitch;
        assert_eq!(maneuver_angle(&m, &[4.0]), ("pitch (°)".into(), vec![4.0]));
    }

    /// Markers drawn in `colour` in an SVG.
    fn markers(svg: &str, colour: Colour) -> usize {
        let fill = format!("fill=\"{}\"", colour.css().to_uppercase());
        svg.lines()
            .filter(|l| l.starts_with("<circle") && l.contains(&fill))
            .count()
    }

    #[test]
    fn level_against_heading_has_a_point_per_heading_level() {
        let dir = tempfile::tempdir().unwrap();
        let (data, html) = box_report(dir.path(), true);
        // Before and after on one axis.
        let svgs = shown_svgs(dir.path(), section(&html, "Heading error"));
        let [svg] = &svgs[..] else {
            panic!("{} plots", svgs.len())
        };
        assert_eq!(markers(svg, Colour::UNCOMPENSATED), data.headings.len());
        assert_eq!(markers(svg, Colour::COMPENSATED), data.headings.len());
        assert_eq!(data.headings.len(), 4);
        assert!(!svg.contains("NaN"));
        assert!(svg.contains(">\n270\n<") || svg.contains(">270<"), "{svg}");
        let points = heading_levels(&data.headings);
        let mean: f64 = points[0].level_nt.iter().sum();
        assert!(mean.abs() < 1e-9, "levels relative to their mean");
        assert_eq!(points[1].error_nt.len(), 4);
        // The correction per heading, on the same axis: before − after, the ground cancelled;
        // its spread is said, and each heading's is in the table.
        assert_eq!(markers(svg, Colour::CYCLE[3]), 4);
        let expected: Vec<f64> = (points[0].level_nt.iter().zip(&points[1].level_nt))
            .map(|(b, a)| b - a)
            .collect();
        assert!((points[2].level_nt.iter().zip(&expected)).all(|(c, e)| (c - e).abs() < 1e-9));
        let text = section(&html, "Heading error");
        assert!(
            text.contains("<th class=\"num\">correction (nT)</th>")
                || text.contains("correction (nT)</th>")
        );
        assert!(
            text.contains("which geology does not change, spreads "),
            "{text}"
        );
    }

    /// The report page of a simulated four-line survey compensated by a box model.
    fn survey_report(dir: &Path) -> (ReportData, String) {
        let flight = dir.join("survey.csv");
        let request = simulate::SimulateRequest {
            plan: simulate::PlanKind::Survey,
            lines: 4,
            ..Default::default()
        };
        simulate::write(&simulate::simulate(&request, &Silent).unwrap(), &flight).unwrap();
        let request = ReportRequest {
            model: Some(box_model(dir)),
            ..ReportRequest::new(&flight, "mag_1_uc")
        };
        let mut warnings = Vec::new();
        let data = build(&request, &Silent, &mut warnings).unwrap();
        // No "is this a compensation flight?": the page says it has no box. The survey's
        // turns bank beyond the box's rolls, as `compensate` also says.
        let extrapolated =
            |w: &Warning| matches!(w, Warning::Extrapolated { rows, .. } if *rows < 100);
        assert!(warnings.iter().all(extrapolated), "{warnings:?}");
        let index =
            write_each(std::slice::from_ref(&data), &warnings, &dir.join("report")).unwrap();
        (data, std::fs::read_to_string(index).unwrap())
    }

    #[test]
    fn a_flight_without_attitude_is_said_to_lack_it() {
        let dir = tempfile::tempdir().unwrap();
        let flight = dir.path().join("box.csv");
        let simulated = simulate::simulate(&Default::default(), &Silent).unwrap();
        simulate::write(&simulated, &flight).unwrap();
        let request = ReportRequest {
            renames: vec![("ins_roll".into(), "roll_deg".into())],
            ..ReportRequest::new(&flight, "mag_1_uc")
        };
        let mut warnings = Vec::new();
        let data = build(&request, &Silent, &mut warnings).unwrap();
        let html = std::fs::read_to_string(write(&data, &dir.path().join("r")).unwrap()).unwrap();
        assert!(html.contains(NO_ATTITUDE) && !html.contains(NO_BOX));
        // The specification says why its FOM is not judged: no attitude, not "no box".
        assert!(html.contains("<td>no attitude, so no maneuvers</td><td>not judged</td>"));
    }

    #[test]
    fn a_survey_report_has_no_fom_and_no_undefined_number() {
        let dir = tempfile::tempdir().unwrap();
        let (data, html) = survey_report(dir.path());
        assert!(data.maneuvers.is_empty());
        assert!(html.contains(NO_BOX));
        for text in [
            "FOM before",
            "Figure of merit",
            "of 12",
            "<dt>improvement</dt>",
        ] {
            assert!(!html.contains(text), "{text} present");
        }
        for text in ["NaN", "nan", "inf", "∞"] {
            let at = html
                .find(text)
                .map(|k| &html[k.saturating_sub(80)..(k + 40).min(html.len())]);
            assert!(at.is_none(), "{text} in the page: {at:?}");
        }
    }

    #[test]
    fn a_survey_report_marks_where_each_line_begins_and_ends() {
        let dir = tempfile::tempdir().unwrap();
        let (data, html) = survey_report(dir.path());
        let stretches = &data.lines.as_ref().unwrap().stretches;
        // Four lines and the turns between them, each a stretch, in time order.
        assert!(stretches.len() >= 4, "{stretches:?}");
        assert!(
            stretches.windows(2).all(|w| w[0].2 < w[1].1),
            "{stretches:?}"
        );
        assert_eq!(line_windows(&data).len(), stretches.len().div_ceil(2));
        assert!(html.contains("Shaded: every other flight line"));
        assert!(!html.contains("(the maneuver noise)"));
    }

    #[test]
    fn fit_diagnostics_say_what_each_figure_is_and_which_row_was_chosen() {
        let dir = tempfile::tempdir().unwrap();
        let (data, html) = box_report(dir.path(), true);
        let d = section(&html, "Fit diagnostics");
        // Labels that cannot be mistaken: the band's scalar, the fit's ratio (not the FOM's).
        assert!(
            d.contains("scalar in the fit&#39;s band, before")
                || d.contains("scalar in the fit's band, before")
        );
        assert!(
            d.contains("not the FOM&#39;s") || d.contains("not the FOM's"),
            "{d}"
        );
        // The cross-validation sweeps the physical prior's multiplier: its column, and one
        // chosen row in it and one among the compared models.
        assert!(d.contains("× the physical prior</th>"), "{d}");
        assert_eq!(d.matches("<td>chosen</td>").count(), 2);
        let cv = data
            .fit
            .as_ref()
            .unwrap()
            .fit
            .diagnostics
            .cross_validation
            .as_ref()
            .unwrap();
        let multipliers: std::collections::BTreeSet<String> = (cv.grid.iter())
            .filter_map(|p| p.prior_multiplier.map(|m| format!("{m:e}")))
            .collect();
        assert!(multipliers.len() > 3, "{multipliers:?}");
        // The spectrum ends at Nyquist (5 Hz on 10 Hz data), not the decade above.
        let psd = shown_svgs(dir.path(), &html)
            .into_iter()
            .find(|svg| svg.contains("frequency (Hz)"))
            .unwrap();
        let x_labels: Vec<&str> = (psd.split("<text ").skip(1))
            .filter(|t| {
                let y = t.split("y=\"").nth(1).and_then(|v| v.split('"').next());
                y.and_then(|v| v.parse::<f64>().ok())
                    .is_some_and(|y| y > 330.0)
            })
            .filter_map(|t| t.split('>').nth(1)?.split('<').next().map(str::trim))
            .collect();
        assert!(
            x_labels.contains(&"10⁰") && !x_labels.contains(&"10¹"),
            "{x_labels:?}"
        );
        // Yaw is drawn, on its own axis of one turn.
        assert!(shown_svgs(dir.path(), &html)
            .iter()
            .any(|svg| svg.contains("yaw (°)")));
        for m in &multipliers {
            assert!(d.contains(&format!("<td class=\"num\">{m}</td>")), "{m}");
        }
    }

    #[test]
    fn a_box_passes_or_fails_the_fom_the_user_specifies() {
        let dir = tempfile::tempdir().unwrap();
        let fom_row = |fom_spec_nt: f64| {
            let request = ReportRequest {
                model: Some(box_model(dir.path())),
                fom_spec_nt,
                ..ReportRequest::new(dir.path().join("box.csv"), "mag_1_uc")
            };
            let data = build(&request, &Silent, &mut Vec::new()).unwrap();
            let html = std::fs::read_to_string(write(&data, &dir.path().join("r")).unwrap());
            let html = html.unwrap();
            let after = data.fom.after.as_ref().unwrap().fom_nt;
            let start = html.find("<td>figure of merit (box)</td>").unwrap();
            let row = &html[start..start + html[start..].find("</tr>").unwrap()];
            (after, row.to_string())
        };
        let (after, row) = fom_row(1.5);
        assert!(
            after < 1.5 && row.ends_with("<td>pass</td>"),
            "{after} {row}"
        );
        let (_, row) = fom_row(after / 2.0);
        assert!(row.ends_with("<td>FAIL</td>"), "{row}");
        // A box has no survey lines; a compensated box without a truth column has no judge
        // of its heading error.
        let request = ReportRequest::new(dir.path().join("box.csv"), "mag_1_uc");
        let data = build(&request, &Silent, &mut Vec::new()).unwrap();
        let html = std::fs::read_to_string(write(&data, &dir.path().join("r2")).unwrap());
        assert!(html
            .unwrap()
            .contains("<td>no survey lines</td><td>not judged</td>"));
    }

    #[test]
    fn a_survey_report_names_every_line_with_finite_statistics() {
        let dir = tempfile::tempdir().unwrap();
        let (data, html) = survey_report(dir.path());
        let lines = data.lines.as_ref().unwrap();
        // Four lines joined by three turns, each turn its own line id: the lines in the
        // table, each with its specification's verdict, the turns named below it.
        assert_eq!(lines.rows.len(), 7);
        assert_eq!(lines.extent_from, ExtentSource::LatLon);
        let kinds: Vec<LineKind> = lines.rows.iter().map(|r| r.kind).collect();
        use LineKind::{Line, Turn};
        assert_eq!(kinds, [Line, Turn, Line, Turn, Line, Turn, Line]);
        assert!(
            html.contains("Not in the table: turns and transits (heading not steady): 2, 4, 6.")
        );
        assert_eq!(section(&html, "Lines").matches("<td>pass</td>").count(), 4);
        // Each line's profile and, beneath it, its fourth difference between the ± tolerance
        // lines, with its verdict.
        let profiles = section(&html, "Line profiles");
        assert_eq!(profiles.matches("<figure class=\"cell\">").count(), 4);
        assert_eq!(profiles.matches("<img ").count(), 8);
        assert_eq!(profiles.matches(": pass (±0.1 nT).").count(), 4);
        let fourth = shown_svgs(dir.path(), profiles)
            .into_iter()
            .filter(|svg| svg.contains("fourth difference (nT)"))
            .count();
        assert_eq!(fourth, 4);
        // The specification's table, before the first section: every test passed, failed or
        // said why it is not judged.
        let first_screen = &html[..html.find("<h2").unwrap()];
        for row in [
            "<td>4 of 4 lines within</td><td>pass</td>",
            "<td>figure of merit (box)</td><td>at most 1.5 nT</td><td>no box maneuvers</td><td>not judged</td>",
            "vs truth</td><td>pass</td>",
        ] {
            assert!(first_screen.contains(row), "{row}");
        }
        // What `compensate` would warn of heads the page, once.
        assert_eq!(html.matches("Warning: ").count(), 1);
        assert!(html.contains("the model extrapolates there"));
        for row in lines.rows.iter().filter(|r| r.kind == Line) {
            assert!(
                html.contains(&format!(">{}</td><td>00:", row.line)),
                "{}",
                row.line
            );
            let numbers = [
                row.heading_deg,
                row.extent,
                row.residual_before_nt,
                row.residual_after_nt,
                row.noise_before_nt,
                row.noise_after_nt,
                row.level_nt,
                row.peak_fourth_difference_nt,
            ];
            assert!(
                numbers.iter().all(|v| v.is_some_and(f64::is_finite)),
                "{row:?}"
            );
            // Compensation removes the aircraft's field from the line's residual.
            assert!(row.residual_after_nt < row.residual_before_nt, "{row:?}");
        }
        for map in ["map-compensated.svg", "map-correction.svg"] {
            let svg = std::fs::read_to_string(dir.path().join("report/plots").join(map)).unwrap();
            assert!(svg.matches("<circle").count() > 1000, "{map}");
            assert!(html.contains(&format!("src=\"plots/{map}\"")), "{map}");
        }
        for id in ["1001", "1002", "1003", "1004"] {
            assert!(lines.rows.iter().any(|r| r.line == id), "{id}");
        }
    }

    #[test]
    fn a_survey_plots_each_line_level_against_its_heading() {
        let dir = tempfile::tempdir().unwrap();
        let (data, html) = survey_report(dir.path());
        assert!(!html.contains(">Maneuvers</h2>"));
        let svgs = shown_svgs(dir.path(), section(&html, "Heading error"));
        let [svg] = &svgs[..] else {
            panic!("{} plots", svgs.len())
        };
        // A point per straight line, before and after; the turns have no heading.
        let lines = data.lines.as_ref().unwrap();
        let straight = lines
            .rows
            .iter()
            .filter(|r| r.kind == LineKind::Line)
            .count();
        assert_eq!(straight, 4);
        assert_eq!(markers(svg, Colour::UNCOMPENSATED), straight);
        assert_eq!(markers(svg, Colour::COMPENSATED), straight);
        assert!(html.contains("each straight line&#39;s mean scalar"));
        // Not "too little straight flight on 90°, 270°": a survey meant none there.
        assert!(!html.contains("Too little straight flight"));
    }

    #[test]
    fn nothing_to_level_is_no_heading_plot() {
        let dir = tempfile::tempdir().unwrap();
        let (mut data, _) = survey_report(dir.path());
        data.lines = None;
        data.headings.clear();
        let index = write(&data, &dir.path().join("bare")).unwrap();
        let html = std::fs::read_to_string(index).unwrap();
        assert!(!html.contains("Level against heading"));
    }
}
