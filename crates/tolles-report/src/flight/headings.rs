//! The heading sections of a flight report: the heading error's table and the level of the
//! scalar against heading, per cardinal heading or per survey line.

use super::*;
use tolles::tolles_core::maneuvers::fom::peak_to_peak;

/// The heading levels before and after, and what the heading error is.
pub(super) fn heading_error(mut report: Report, data: &ReportData) -> Report {
    // Nothing levelled (no attitude, no straight legs): no section, rather than one that
    // only says "none".
    if data.headings.is_empty() && data.fom.heading_before.heading_error_nt.is_none() {
        return report;
    }
    report = report.section("Heading error");
    let (before, after) = (&data.fom.heading_before, data.fom.heading_after.as_ref());
    let mut text = format!(
        "Mean scalar over the straight and level samples of each heading (outside maneuvers, \
         roll and pitch within 3°, yaw within 10° of the heading and steady); the heading error \
         is the largest level minus the smallest: {} before compensation",
        heading_error_text(before)
    );
    if let Some(after) = after {
        text += &format!(", {} after", heading_error_text(after));
    }
    text += ". Geology and diurnal variation between the legs stay in both.";
    if let Some(spread) = correction_spread(&data.headings) {
        text += &format!(
            " The correction per heading (before − after), which geology does not change, \
             spreads {} nT: the aircraft's own heading effect, which compensation took out.",
            format_value(spread)
        );
    }
    report = report.paragraph(text);
    if data.headings.is_empty() {
        return report;
    }
    let cells: Vec<Vec<String>> = data.headings.iter().map(heading_cells).collect();
    report = report.table(
        &[
            "heading (°)",
            "samples",
            "time (s)",
            "before (nT)",
            "after (nT)",
            "correction (nT)",
        ],
        &cells,
    );
    // A survey passes the other headings only in its turns: no straight flight was meant there.
    if !before.skipped.is_empty() && has_box(data) {
        let skipped: Vec<String> = before
            .skipped
            .iter()
            .map(|s| format!("{:.0}° ({:.1} s)", s.heading_deg, s.duration_s))
            .collect();
        report = report.paragraph(format!(
            "Too little straight flight (under 3 s) on: {}.",
            skipped.join(", ")
        ));
    }
    report
}

pub(super) fn heading_error_text(levels: &HeadingLevels) -> String {
    match (levels.heading_error_nt, levels.uncertainty_nt) {
        (Some(e), Some(u)) => format!("{} nT", crate::numbers::with_error(e, u)),
        _ => "none (fewer than two headings)".into(),
    }
}

pub(super) fn heading_cells(row: &HeadingRow) -> Vec<String> {
    let level = |(l, se): (f64, f64)| crate::numbers::with_error(l, se);
    vec![
        format!("{:.0}", row.heading_deg),
        row.samples.to_string(),
        format!("{:.1}–{:.1}", row.span_tt.0, row.span_tt.1),
        level(row.before_nt),
        row.after_nt.map_or("—".into(), level),
        correction(row).map_or("—".into(), |c| format!("{c:.3}")),
    ]
}

/// A heading's mean correction (nT): its level before compensation minus after, the same
/// samples, so the ground under them cancels.
fn correction(row: &HeadingRow) -> Option<f64> {
    row.after_nt.map(|(after, _)| row.before_nt.0 - after)
}

/// The largest heading's correction minus the smallest (nT); `None` with fewer than two.
fn correction_spread(rows: &[HeadingRow]) -> Option<f64> {
    let corrections: Vec<f64> = rows.iter().filter_map(correction).collect();
    (corrections.len() >= 2).then(|| peak_to_peak(&corrections))
}

/// Where the x axis of a level-against-heading plot is labelled (deg).
pub(super) const HEADING_TICKS: [f64; 5] = [0.0, 90.0, 180.0, 270.0, 360.0];

/// Level against heading before and after compensation: a box's heading levels; a survey's
/// lines (or, without a line column, its heading levels); nothing when there is no level.
pub(super) fn level_against_heading(report: Report, data: &ReportData) -> Report {
    let (points, caption) = if !has_box(data) && data.lines.is_some() {
        (line_levels(data), LINE_LEVELS)
    } else {
        (heading_levels(&data.headings), HEADING_LEVELS)
    };
    let points: Vec<LevelPoints> = (points.into_iter())
        .filter(|p| !p.heading_deg.is_empty())
        .collect();
    if points.is_empty() {
        return report;
    }
    report.paragraph(caption).line_plot(heading_plot(&points))
}

pub(super) const HEADING_LEVELS: &str = "Level against heading: each heading's mean scalar over \
    its straight and level samples minus the mean of the headings' levels (nT), with ± one \
    standard error of the mean; before and after compensation, and the correction (before − \
    after, which geology does not change), on one axis. The spread is the heading error.";

pub(super) const LINE_LEVELS: &str = "Level against heading: each straight line's mean scalar \
    minus the mean of the lines' means (nT), at the line's circular mean heading (the Lines \
    table's heading); before and after compensation, and the correction (before − after, \
    which geology does not change), on one axis. Turns are left out: a turn has no heading.";

/// The correction's colour on a level-against-heading plot.
const CORRECTION: Colour = Colour::CYCLE[3];

/// The points of one level-against-heading plot (deg, nT, nT); error bars may be empty.
pub(super) struct LevelPoints {
    pub(super) when: &'static str,
    pub(super) colour: Colour,
    pub(super) heading_deg: Vec<f64>,
    pub(super) level_nt: Vec<f64>,
    pub(super) error_nt: Vec<f64>,
}

impl LevelPoints {
    /// `(heading, level, error)` with finite heading and level, levels made relative to
    /// their mean.
    fn new(when: &'static str, colour: Colour, points: Vec<(f64, f64, f64)>) -> Self {
        let points: Vec<_> = points
            .into_iter()
            .filter(|(h, l, _)| h.is_finite() && l.is_finite())
            .collect();
        let mean = points.iter().map(|p| p.1).sum::<f64>() / points.len().max(1) as f64;
        let error_nt = if points.iter().all(|p| p.2.is_finite()) {
            points.iter().map(|p| p.2).collect()
        } else {
            Vec::new()
        };
        LevelPoints {
            when,
            colour,
            heading_deg: points.iter().map(|p| p.0).collect(),
            level_nt: points.iter().map(|p| p.1 - mean).collect(),
            error_nt,
        }
    }
}

pub(super) fn heading_levels(rows: &[HeadingRow]) -> Vec<LevelPoints> {
    let before = rows
        .iter()
        .map(|r| (r.heading_deg, r.before_nt.0, r.before_nt.1))
        .collect();
    let mut points = vec![LevelPoints::new("Before", Colour::UNCOMPENSATED, before)];
    if rows.iter().all(|r| r.after_nt.is_some()) {
        let after = rows
            .iter()
            .filter_map(|r| r.after_nt.map(|(l, se)| (r.heading_deg, l, se)))
            .collect();
        points.push(LevelPoints::new("After", Colour::COMPENSATED, after));
        let corrections = rows
            .iter()
            .filter_map(|r| Some((r.heading_deg, correction(r)?, f64::NAN)))
            .collect();
        points.push(LevelPoints::new("Correction", CORRECTION, corrections));
    }
    points
}

pub(super) fn line_levels(data: &ReportData) -> Vec<LevelPoints> {
    let Some(lines) = &data.lines else {
        return Vec::new();
    };
    let nan = f64::NAN;
    let of = |level: fn(&LineRow) -> Option<f64>| -> Vec<(f64, f64, f64)> {
        lines
            .rows
            .iter()
            .filter(|r| r.kind == LineKind::Line)
            .map(|r| (r.heading_deg.unwrap_or(nan), level(r).unwrap_or(nan), nan))
            .collect()
    };
    let mut points = vec![LevelPoints::new(
        "Before",
        Colour::UNCOMPENSATED,
        of(|r| r.level_before_nt),
    )];
    if data.compensated.is_some() {
        points.push(LevelPoints::new(
            "After",
            Colour::COMPENSATED,
            of(|r| r.level_nt),
        ));
        let correction = |r: &LineRow| Some(r.level_before_nt? - r.level_nt?);
        points.push(LevelPoints::new("Correction", CORRECTION, of(correction)));
    }
    points
}

pub(super) fn heading_plot(points: &[LevelPoints]) -> LinePlot {
    // 359.96° belongs beside 0°, not beyond the axis.
    let series = (points.iter())
        .map(|p| {
            let heading = p.heading_deg.iter().map(|h| h.rem_euclid(360.0)).collect();
            Series::new(p.when.to_lowercase(), heading, p.level_nt.clone())
                .colour(p.colour)
                .points(p.error_nt.clone())
        })
        .collect();
    LinePlot {
        title: "Level against heading: before, after and the correction".into(),
        x_label: "heading (°)".into(),
        y_label: "level − mean (nT)".into(),
        series,
        x_range: Some((0.0, 360.0)),
        x_ticks: HEADING_TICKS.to_vec(),
        ..LinePlot::default()
    }
}
