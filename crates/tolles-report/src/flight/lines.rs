//! The lines' table of a flight report: each straight survey line with its times, heading,
//! extent, residual and noise before and after (nT), level (nT) and the noise specification's
//! pass or FAIL; the turns and the box's legs named under it.

use super::*;

/// The per-line table, each column defined in the paragraph above it.
pub(super) fn per_line(
    report: Report,
    lines: &LineTable,
    compensated: bool,
    tolerance: f64,
    vs: &str,
) -> Report {
    let extent_header = match lines.extent_from {
        ExtentSource::Duration => "duration (s)",
        _ => "length (km)",
    };
    let mut headers = vec!["line", "time", "heading (°)", extent_header, "rows"];
    if compensated {
        headers.extend([
            "residual before (nT)",
            "residual after (nT)",
            "noise before (nT)",
            "noise after (nT)",
        ]);
    } else {
        headers.extend(["residual (nT)", "noise (nT)"]);
    }
    headers.push("level (nT)");
    if compensated {
        headers.push("correction (nT)");
    }
    let with_error = lines.rows.iter().any(|r| r.error_nt.is_some());
    let error_header = format!("error vs {vs} (nT)");
    if with_error {
        headers.push(&error_header);
    }
    let spec = format!("within ±{tolerance} nT");
    headers.extend(["peak 4th diff (nT)", spec.as_str()]);
    let cells: Vec<Vec<String>> = (lines.rows.iter())
        .filter(|r| r.kind == LineKind::Line)
        .map(|r| line_cells(r, compensated, with_error, tolerance))
        .collect();
    let report = report
        .section("Lines")
        .paragraph(line_definitions(
            lines,
            compensated,
            with_error.then_some(vs),
        ))
        .table(&headers, &cells);
    match others(lines) {
        Some(text) => report.paragraph(text),
        None => report,
    }
}

/// True when `lines` holds a straight line that is not a leg of the box.
pub(super) fn has_lines(lines: &LineTable) -> bool {
    lines.rows.iter().any(|r| r.kind == LineKind::Line)
}

/// The line ids left out of the lines' table, by what they are.
fn others(lines: &LineTable) -> Option<String> {
    let ids = |kind| {
        let ids: Vec<&str> = (lines.rows.iter())
            .filter(|r| r.kind == kind)
            .map(|r| r.line.as_str())
            .collect();
        (!ids.is_empty()).then(|| ids.join(", "))
    };
    let parts: Vec<String> = [
        (LineKind::Turn, "turns and transits (heading not steady)"),
        (LineKind::BoxLeg, "legs of the compensation box"),
    ]
    .into_iter()
    .filter_map(|(kind, what)| ids(kind).map(|ids| format!("{what}: {ids}")))
    .collect();
    (!parts.is_empty()).then(|| format!("Not in the table: {}.", parts.join("; ")))
}

/// A time (s) as the clock of its day, hh:mm:ss (POSIX seconds give the UTC time of day).
fn clock(t: f64) -> String {
    let s = t.rem_euclid(86_400.0).floor() as u64;
    format!("{:02}:{:02}:{:02}", s / 3600, s / 60 % 60, s % 60)
}

fn line_definitions(lines: &LineTable, compensated: bool, vs: Option<&str>) -> String {
    let heading = match lines.heading_from {
        HeadingSource::Yaw => "the circular mean of ins_yaw",
        HeadingSource::LatLon => "the circular mean bearing of the track from lat/lon",
        HeadingSource::NorthEast => "the circular mean bearing of the track from north_m/east_m",
        HeadingSource::None => "— (the flight has no ins_yaw and no positions)",
    };
    let extent = match lines.extent_from {
        ExtentSource::LatLon => "the track length from lat/lon",
        ExtentSource::NorthEast => "the track length from north_m/east_m",
        ExtentSource::Duration => "the time flown on the line (the flight has no positions)",
    };
    let signal = if compensated {
        "compensated scalar"
    } else {
        "scalar"
    };
    let correction = match compensated {
        true => {
            " Correction: the RMS over the line of uncompensated − compensated, less its \
                 mean over the flight (the line's change of level included)."
        }
        false => "",
    };
    let error = vs.map_or(String::new(), |vs| {
        format!(
            " Error vs {vs}: the RMS over the line of compensated − {vs}, less its mean over the \
             flight (the line's level error included)."
        )
    });
    format!(
        "One row per straight line of the line column, rows of a line wherever they are. \
         Time: of its first and last row, hh:mm:ss (of the UTC day for POSIX \
         times). Heading: \
         {heading}. {}: {extent}. Residual: standard deviation of the scalar about its \
         least-squares straight line in time over the line (the line's trend removed). Noise: \
         standard deviation of the fourth difference (x₋₂ − 4x₋₁ + 6x₀ − 4x₊₁ + x₊₂)/16 of the \
         scalar, as tolles fom prints it. Level: the line's mean {signal} minus the median of \
         all lines' means. Peak 4th diff: the largest |fourth difference| of the line's \
         {signal}, which passes the specification when within the tolerance (report \
         --noise-tolerance).{correction}{error} — : too few finite samples (a residual needs \
         3, a noise 5).",
        match lines.extent_from {
            ExtentSource::Duration => "Duration",
            _ => "Length",
        }
    )
}

fn line_cells(row: &LineRow, compensated: bool, with_error: bool, tolerance: f64) -> Vec<String> {
    let cell = |v: Option<f64>, decimals: usize| {
        v.filter(|v| v.is_finite())
            .map_or("—".into(), |v| format!("{v:.decimals$}"))
    };
    let time = row
        .span_s
        .map_or("—".into(), |(a, b)| format!("{}–{}", clock(a), clock(b)));
    let mut cells = vec![
        row.line.clone(),
        time,
        // 359.96° prints as 0.0, not 360.0.
        cell(
            row.heading_deg.map(|h| ((h * 10.0).round() / 10.0) % 360.0),
            1,
        ),
        cell(row.extent, 2),
        row.rows.to_string(),
        cell(row.residual_before_nt, 3),
    ];
    if compensated {
        cells.push(cell(row.residual_after_nt, 4));
    }
    cells.push(cell(row.noise_before_nt, 4));
    if compensated {
        cells.push(cell(row.noise_after_nt, 4));
    }
    cells.push(cell(row.level_nt, 3));
    if compensated {
        cells.push(cell(row.correction_nt, 3));
    }
    if with_error {
        cells.push(cell(row.error_nt, 4));
    }
    cells.push(cell(row.peak_fourth_difference_nt, 3));
    cells.push(match row.peak_fourth_difference_nt {
        Some(peak) => verdict(peak <= tolerance),
        None => "—".into(),
    });
    cells
}

/// The most lines drawn as profiles: beyond it the page would be mostly profiles.
const MAX_PROFILES: usize = 12;

/// Each straight line's profile (up to [`MAX_PROFILES`]): the scalar before and after
/// compensation, each less its mean over the line, against the time since the line began; and
/// beneath it the line's fourth difference between the ± tolerance lines, with its verdict.
pub(super) fn line_profiles(report: Report, data: &ReportData) -> Report {
    let Some(lines) = data.lines.as_ref().filter(|l| has_lines(l)) else {
        return report;
    };
    let straight: Vec<&LineRow> = (lines.rows.iter())
        .filter(|r| r.kind == LineKind::Line)
        .collect();
    let shown = straight.len().min(MAX_PROFILES);
    let tolerance = data.request.noise_tolerance_nt;
    let intro =
        format!(
        "Each straight line's scalar{} less its mean over the line, against the time since the \
         line began (s): the anomalies a survey delivers, and what compensation took out of \
         them{}. Beneath it, the line's fourth difference (x₋₂ − 4x₋₁ + 6x₀ − 4x₊₁ + x₊₂)/16 \
         of the {} scalar (blue) between the specification's ±{} nT (green; report \
         --noise-tolerance). {} of {} lines{}.",
        if data.compensated.is_some() {
            " before and after compensation"
        } else {
            ""
        },
        if data.compensated.is_some() {
            " (uncompensated orange, compensated blue)"
        } else {
            " (orange)"
        },
        if data.compensated.is_some() { "compensated" } else { "as read" },
        format_value(tolerance),
        shown,
        straight.len(),
        if shown < straight.len() {
            ", the first in the table"
        } else {
            ""
        }
    );
    let cells = (straight[..shown].iter())
        .filter_map(|row| line_cell(row, data, tolerance))
        .collect();
    report.section("Line profiles").paragraph(intro).grid(cells)
}

/// One line's profile and fourth difference, small, with its peak fourth difference and
/// verdict; `None` for a line without rows.
fn line_cell(row: &LineRow, data: &ReportData, tolerance: f64) -> Option<GridCell> {
    let rows: Vec<usize> = row.runs.iter().flat_map(Range::clone).collect();
    let t0 = data.fom.tt[*rows.first()?];
    let x: Vec<f64> = rows.iter().map(|&k| data.fom.tt[k] - t0).collect();
    let on_line = |values: &[f64]| rows.iter().map(|&k| values[k]).collect::<Vec<f64>>();
    let profile = |trace: &tolles::report::Trace| {
        let values = on_line(&trace.centred);
        let finite: Vec<f64> = values.iter().copied().filter(|v| v.is_finite()).collect();
        let mean = finite.iter().sum::<f64>() / finite.len().max(1) as f64;
        values.iter().map(|v| v - mean).collect::<Vec<f64>>()
    };
    let mut series = vec![
        Series::new("uncompensated", x.clone(), profile(&data.uncompensated))
            .colour(Colour::UNCOMPENSATED),
    ];
    if let Some(after) = &data.compensated {
        series.push(
            Series::new("compensated", x.clone(), profile(after)).colour(Colour::COMPENSATED),
        );
    }
    let judged = data.compensated.as_ref().unwrap_or(&data.uncompensated);
    let small = |title: String, y_label: &str, series| LinePlot {
        title,
        x_label: "time since the line began (s)".into(),
        y_label: y_label.into(),
        series,
        size: PlotSize::SMALL,
        ..LinePlot::default()
    };
    let plots = vec![
        small(
            format!("Line {}", row.line),
            "field − line mean (nT)",
            series,
        ),
        small(
            format!("Line {} fourth difference", row.line),
            "fourth difference (nT)",
            vec![Series::new(
                "fourth difference",
                x.clone(),
                on_line(&judged.fourth_difference),
            )
            .colour(Colour::COMPENSATED)]
            .into_iter()
            .chain(tolerance_lines(&x, tolerance))
            .collect(),
        ),
    ];
    let caption = match row.peak_fourth_difference_nt {
        Some(peak) => format!(
            "Peak |fourth difference| {} nT: {} (±{} nT).",
            format_value(peak),
            verdict(peak <= tolerance),
            format_value(tolerance)
        ),
        None => "Too few samples for a fourth difference.".into(),
    };
    Some(GridCell {
        title: format!("Line {}", row.line),
        plots,
        caption: Some(caption),
    })
}
