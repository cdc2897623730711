//! The Map section of a flight report: the track coloured by the compensated field and the
//! correction (nT), each survey line named with the way it was flown.

use super::*;
use crate::map::{ScatterMap, TrackLabel};

/// A map of the track as an SVG, and where the page expects it.
pub(super) struct Map {
    pub(super) src: String,
    pub(super) alt: String,
    pub(super) svg: String,
}

/// Maps of the track coloured by the compensated field and by the correction (with a model),
/// or by the uncompensated field; none without positions. `tag` starts their file names.
pub(super) fn maps(data: &ReportData, tag: &str) -> Vec<Map> {
    let Some(track) = &data.track else {
        return Vec::new();
    };
    let before = &data.fom.scalar;
    let colourings: Vec<(&str, &str, Vec<f64>)> = match &data.fom.compensated {
        Some(after) => vec![
            ("compensated", "compensated field (nT)", after.clone()),
            (
                "correction",
                "correction = uncompensated − compensated (nT)",
                before.iter().zip(after).map(|(b, a)| b - a).collect(),
            ),
        ],
        None => vec![("uncompensated", "field as read (nT)", before.clone())],
    };
    let labels = track_labels(data, &track.east_km, &track.north_km);
    colourings
        .into_iter()
        .filter_map(|(name, label, value)| {
            let svg = ScatterMap {
                title: label,
                east_km: &track.east_km,
                north_km: &track.north_km,
                value: &value,
                value_label: "nT",
                labels: &labels,
            }
            .to_svg()?;
            Some(Map {
                src: format!("plots/map-{tag}{name}.svg"),
                alt: format!("Map of the track coloured by the {label}"),
                svg,
            })
        })
        .collect()
}

/// The most lines named on a map; beyond, every second (third, …) line is, so that the ids
/// stay legible. Every line keeps its arrowhead.
const MAX_MAP_LABELS: usize = 30;

/// Each straight survey line's id and arrow for the map, from its first to its last row with a
/// position (km).
fn track_labels(data: &ReportData, east_km: &[f64], north_km: &[f64]) -> Vec<TrackLabel> {
    let Some(lines) = &data.lines else {
        return Vec::new();
    };
    let straight: Vec<&LineRow> = (lines.rows.iter())
        .filter(|r| r.kind == LineKind::Line)
        .collect();
    let every = straight.len().div_ceil(MAX_MAP_LABELS).max(1);
    let at = |k: usize| Some((*east_km.get(k)?, *north_km.get(k)?));
    let placed = |k: &usize| at(*k).is_some_and(|(e, n)| e.is_finite() && n.is_finite());
    (straight.iter().enumerate())
        .filter_map(|(k, row)| {
            let mut rows = row.runs.iter().flat_map(|r| r.clone());
            let first = rows.clone().find(placed)?;
            let last = rows.rfind(placed)?;
            Some(TrackLabel {
                text: if k % every == 0 {
                    row.line.clone()
                } else {
                    String::new()
                },
                from_km: at(first)?,
                to_km: at(last)?,
            })
        })
        .collect()
}

pub(super) fn map_section(mut report: Report, data: &ReportData, maps: &[Map]) -> Report {
    let Some(track) = data.track.as_ref().filter(|_| !maps.is_empty()) else {
        return report;
    };
    let from = if track.from_lat_lon {
        "lat/lon on a sphere flattened about the first position"
    } else {
        "north_m/east_m"
    };
    report = report.section("Map").paragraph(format!(
        "The track east and north (km) of its start, from {from}, on a km grid with a scale \
         bar; colours run blue–white–red with white at the value's median, out to the farther \
         of its 2nd and 98th percentiles on both sides (values beyond take the end colours). \
         Each survey line's id is at its start and an arrowhead at its end, the way it was \
         flown."
    ));
    for map in maps {
        report = report.image(&map.src, &map.alt);
    }
    report
}
