//! The box's sections of a flight report: the figure of merit, maneuver by maneuver before
//! and after (peak-to-peak, nT), and a small figure per maneuver with the angle it swings
//! (deg).

use super::*;

pub(super) fn figure_of_merit(mut report: Report, data: &ReportData) -> Report {
    report = report.section("Figure of merit");
    let rows = &data.maneuvers;
    if rows.is_empty() {
        return report.paragraph("No compensation-box maneuvers were found in the attitude channels, so there is no figure of merit.");
    }
    report = report.bar_chart(fom_chart(data));
    let cells: Vec<Vec<String>> = rows.iter().map(maneuver_cells).collect();
    report = report.table(
        &[
            "maneuver",
            "time (s)",
            "amplitude (°)",
            "before (nT)",
            "after (nT)",
        ],
        &cells,
    );
    let missing = &data.fom.before.missing;
    if !missing.is_empty() {
        let missing: Vec<String> = missing
            .iter()
            .map(|s| format!("{} on {}°", s.kind, s.heading_deg))
            .collect();
        report = report.paragraph(format!("Missing from the box: {}.", missing.join(", ")));
    }
    report
}

pub(super) fn fom_chart(data: &ReportData) -> BarChart {
    let rows = &data.maneuvers;
    let before: Vec<f64> = rows.iter().map(|m| m.before_nt).collect();
    let mut series = vec![BarSeries::new("uncompensated", before).colour(Colour::UNCOMPENSATED)];
    if data.fom.after.is_some() {
        // A gap in the bars where the compensated FOM lacks the maneuver.
        let after = rows
            .iter()
            .map(|m| m.after_nt.unwrap_or(f64::NAN))
            .collect();
        series.push(BarSeries::new("compensated", after).colour(Colour::COMPENSATED));
    }
    let after = data
        .fom
        .after
        .as_ref()
        .map_or(String::new(), |a| format!(", {:.3} nT after", a.fom_nt));
    BarChart {
        title: "Peak-to-peak of the band-passed scalar, maneuver by maneuver".into(),
        y_label: "peak-to-peak (nT)".into(),
        categories: rows.iter().map(|m| label(&m.maneuver)).collect(),
        series,
        caption: Some(format!(
            "FOM = sum of the bars: {:.3} nT before{after}. The axis is logarithmic; the \
             table below gives every value.",
            data.fom.before.fom_nt
        )),
        log_y: true,
    }
}

/// `roll 090°`: the kind and the cardinal heading (or the measured one).
pub(super) fn label(m: &Maneuver) -> String {
    format!(
        "{} {:03.0}°",
        m.kind,
        m.cardinal_heading_deg().unwrap_or(m.heading_deg)
    )
}

pub(super) fn maneuver_cells(row: &ManeuverRow) -> Vec<String> {
    let m = &row.maneuver;
    vec![
        label(m),
        format!("{:.1}–{:.1}", m.start_tt, m.end_tt),
        format!("{:.1}", m.amplitude_deg),
        format!("{:.3}", row.before_nt),
        row.after_nt.map_or("—".into(), |a| format!("{a:.4}")),
    ]
}

/// Time (s) shown either side of a maneuver in its small figure.
pub(super) const MANEUVER_MARGIN_S: f64 = 5.0;

/// A small figure per counted maneuver: the band-passed scalar before and after (each on its
/// own axis) and the angle the maneuver swings; nothing for a flight without a box.
pub(super) fn maneuver_detail(report: Report, data: &ReportData) -> Report {
    if data.maneuvers.is_empty() {
        return report;
    }
    let band = &data.request.band;
    let after = if data.compensated.is_some() {
        " and after (its own axis: compensation shrinks it a hundred- to a thousandfold)"
    } else {
        ""
    };
    let cells = data
        .maneuvers
        .iter()
        .map(|row| maneuver_cell(row, data))
        .collect();
    report
        .section("Maneuvers")
        .paragraph(format!(
            "Each maneuver the figure of merit counts, {MANEUVER_MARGIN_S} s either side of it              (shaded: the maneuver): the scalar band-passed {}–{} Hz before compensation{after},              and beneath it the angle the maneuver swings (a yaw as its departure from the              maneuver's heading). Peak-to-peak: over the shaded window, as the FOM takes it.",
            band.pass1_hz, band.pass2_hz
        ))
        .grid(cells)
}

pub(super) fn maneuver_cell(row: &ManeuverRow, data: &ReportData) -> GridCell {
    let m = &row.maneuver;
    let window = maneuver_window(m, data.fom.fs_hz, data.fom.tt.len());
    let t = data.fom.tt[window.clone()].to_vec();
    let name = label(m);
    let panel = |what: &str, y_label: String, y: &[f64], colour: Colour| LinePlot {
        title: format!("{name} {what}"),
        y_label,
        series: vec![Series::new(what, t.clone(), y[window.clone()].to_vec()).colour(colour)],
        spans: vec![Span {
            label: String::new(),
            from: m.start_tt,
            to: m.end_tt,
            colour: Colour::REFERENCE,
        }],
        size: PlotSize::SMALL,
        ..LinePlot::default()
    };
    let mut plots = vec![panel(
        "before",
        "before (nT)".into(),
        &data.uncompensated.bandpassed,
        Colour::UNCOMPENSATED,
    )];
    if let Some(after) = &data.compensated {
        plots.push(panel(
            "after",
            "after (nT)".into(),
            &after.bandpassed,
            Colour::COMPENSATED,
        ));
    }
    if let Some(angle) = data.attitude.angle(m.kind) {
        let (y_label, angle) = maneuver_angle(m, angle);
        plots.push(panel("attitude", y_label, &angle, Colour::CYCLE[6]));
    }
    if let Some(last) = plots.last_mut() {
        last.x_label = "time (s)".into();
    }
    let after = row
        .after_nt
        .map_or(String::new(), |a| format!(", {} nT after", format_value(a)));
    GridCell {
        title: name,
        plots,
        caption: Some(format!(
            "Peak-to-peak {} nT before{after}.",
            format_value(row.before_nt)
        )),
    }
}

/// The rows of `m` with [`MANEUVER_MARGIN_S`] either side, within the flight's `len` rows.
pub(super) fn maneuver_window(m: &Maneuver, fs_hz: f64, len: usize) -> Range<usize> {
    let margin = (MANEUVER_MARGIN_S * fs_hz).round().max(0.0) as usize;
    let end = m.end.saturating_add(margin).min(len);
    m.start.saturating_sub(margin).min(end)..end
}

/// The axis label and the values of the angle `m` swings: roll and pitch as they are, yaw as
/// its departure from the maneuver's heading in (−180°, 180°], so a box flown north does not
/// jump between 0° and 360°.
pub(super) fn maneuver_angle(m: &Maneuver, angle: &[f64]) -> (String, Vec<f64>) {
    if m.kind != tolles::tolles_core::maneuvers::ManeuverKind::Yaw {
        return (format!("{} (°)", m.kind), angle.to_vec());
    }
    let heading = m.heading_deg_measured;
    let departure = |a: &f64| -((heading - a + 180.0).rem_euclid(360.0) - 180.0);
    (
        format!("yaw − {heading:.0}° (°)"),
        angle.iter().map(departure).collect(),
    )
}
