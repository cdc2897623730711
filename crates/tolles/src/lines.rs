//! Statistics of a survey flight line by line, for the report's per-line table: heading,
//! length, residual about the line's trend before and after compensation, high-pass noise and
//! the line's level against the others.

use std::ops::Range;
use tolles_core::signal::metrics::{fourth_difference, std_dev};
use tolles_core::survey::{
    circular_concentration, circular_mean_deg, detrended_std, local_north_east_m, median,
    track_bearings_deg, track_length_m,
};
use tolles_io::schema::{EAST, LATITUDE, LINE_COLUMN, LONGITUDE, NORTH, YAW};
use tolles_io::table::{Column, Table};

/// One flight line's statistics; `None` where the line has too few usable samples.
#[derive(Debug, Clone, PartialEq)]
pub struct LineRow {
    /// The line id as the file writes it (numbers as the shortest decimal).
    pub line: String,
    /// Rows of the flight on this line.
    pub rows: usize,
    /// Where they are: each stretch of consecutive rows on the line, in row order.
    pub runs: Vec<Range<usize>>,
    /// Circular mean heading (deg, clockwise from north, in [0, 360)).
    pub heading_deg: Option<f64>,
    /// Length of the track (km), or without positions the time flown (s).
    pub extent: Option<f64>,
    /// Standard deviation of the uncompensated scalar about its least-squares straight line
    /// in time over the line (nT).
    pub residual_before_nt: Option<f64>,
    /// The same of the compensated scalar (nT), with a model.
    pub residual_after_nt: Option<f64>,
    /// Fourth-difference noise of the uncompensated scalar (nT), as `tolles fom` prints it.
    pub noise_before_nt: Option<f64>,
    /// The same of the compensated scalar (nT), with a model.
    pub noise_after_nt: Option<f64>,
    /// The largest |fourth difference| of the compensated scalar (of the uncompensated without
    /// a model) over the line (nT), what a survey's noise specification bounds.
    pub peak_fourth_difference_nt: Option<f64>,
    /// Mean of the line's compensated scalar (uncompensated without a model) minus the median
    /// of all lines' means (nT).
    pub level_nt: Option<f64>,
    /// The same of the uncompensated scalar, with or without a model (nT).
    pub level_before_nt: Option<f64>,
    /// RMS over the line of the correction (uncompensated − compensated) less its mean over
    /// the flight (nT), with a model: how much compensation changed the line, its level
    /// included.
    pub correction_nt: Option<f64>,
    /// RMS over the line of the compensated scalar less the truth (or reference), less that
    /// difference's mean over the flight (nT), with a model and a truth: the line's error,
    /// its level included.
    pub error_nt: Option<f64>,
    /// Time of the line's first and last row (s, as the time column), when finite.
    pub span_s: Option<(f64, f64)>,
    /// A survey line, a turn, or a leg of the compensation box.
    pub kind: LineKind,
}

/// What a line id of the flight holds.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LineKind {
    /// A straight line: its heading stays within about ±25° of its mean
    /// ([`STRAIGHT_CONCENTRATION`]).
    Line,
    /// A turn or a transit whose heading wanders.
    Turn,
    /// A leg of the compensation box: one of its maneuvers lies in it (set by the report,
    /// which knows the maneuvers).
    BoxLeg,
}

/// The least mean resultant length of a straight line's headings: ±25° of scatter about the
/// mean (a 180° turn has 0.64, a box leg's ±5° of yaw 0.99).
pub const STRAIGHT_CONCENTRATION: f64 = 0.9;

/// Where the heading of a line came from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum HeadingSource {
    /// The `ins_yaw` column.
    Yaw,
    /// The bearing of the track from `lat`/`lon`.
    LatLon,
    /// The bearing of the track from `north_m`/`east_m`.
    NorthEast,
    /// Nothing to take it from.
    None,
}

/// What [`LineRow::extent`] measures.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ExtentSource {
    /// Track length (km) from `lat`/`lon`.
    LatLon,
    /// Track length (km) from `north_m`/`east_m`.
    NorthEast,
    /// Time flown (s) from the time column.
    Duration,
}

/// The per-line table of a flight.
#[derive(Debug, Clone, PartialEq)]
pub struct LineTable {
    /// A row per line id, in order of first appearance.
    pub rows: Vec<LineRow>,
    /// Where the headings came from.
    pub heading_from: HeadingSource,
    /// What the extents measure.
    pub extent_from: ExtentSource,
    /// Each stretch of consecutive rows on one line, in row order: its id and its first and
    /// last time (s), for charts to mark where lines begin and end.
    pub stretches: Vec<(String, f64, f64)>,
}

/// The signals of a flight, row by row, that the table is computed from.
pub struct LineInputs<'a> {
    /// Time (s).
    pub tt: &'a [f64],
    /// Uncompensated scalar (nT).
    pub before: &'a [f64],
    /// Compensated scalar (nT), with a model.
    pub after: Option<&'a [f64]>,
    /// What the compensated scalar should be (nT): the simulator's truth or a reference.
    pub truth: Option<&'a [f64]>,
}

/// The per-line table of `table`, or `None` when it has no line column or only one line id.
pub fn line_table(table: &Table, inputs: &LineInputs) -> Option<LineTable> {
    let ids = line_ids(table)?;
    let lines = group(&ids);
    if lines.len() < 2 || ids.len() != inputs.tt.len() {
        return None;
    }
    let (heading_from, headings, straight) = headings(table, &lines);
    let (extent_from, extents) = extents(table, inputs.tt, &lines);
    let levels = |x: &[f64]| {
        let means: Vec<f64> = lines.iter().map(|l| mean(&pick(x, l))).collect();
        let median_mean = median(&means);
        means
            .iter()
            .map(|m| median_mean.map(|med| m - med).filter(|v| v.is_finite()))
            .collect::<Vec<_>>()
    };
    let levels_before = levels(inputs.before);
    let levels_after = levels(inputs.after.unwrap_or(inputs.before));
    let correction = inputs.after.map(|after| difference(inputs.before, after));
    let error = inputs
        .after
        .zip(inputs.truth)
        .map(|(a, t)| difference(a, t));
    let rows = lines
        .iter()
        .zip(headings.into_iter().zip(straight))
        .zip(extents)
        .zip(levels_after.into_iter().zip(levels_before))
        .map(
            |(((line, (heading_deg, straight)), extent), (level_nt, level_before_nt))| {
                let tt = pick(inputs.tt, line);
                let of = |x: &[f64]| (detrended_std(&tt, &pick(x, line)), noise(x, line));
                let (residual_before_nt, noise_before_nt) = of(inputs.before);
                let (residual_after_nt, noise_after_nt) = inputs.after.map(of).unwrap_or_default();
                let peak_fourth_difference_nt = peak(inputs.after.unwrap_or(inputs.before), line);
                LineRow {
                    line: line.id.clone(),
                    rows: line.len(),
                    runs: line.runs.clone(),
                    heading_deg,
                    extent,
                    residual_before_nt,
                    residual_after_nt,
                    noise_before_nt,
                    noise_after_nt,
                    peak_fourth_difference_nt,
                    level_nt,
                    level_before_nt,
                    correction_nt: correction.as_deref().and_then(|c| rms(c, line)),
                    error_nt: error.as_deref().and_then(|e| rms(e, line)),
                    span_s: span(&tt),
                    kind: match straight {
                        false => LineKind::Turn,
                        true => LineKind::Line,
                    },
                }
            },
        )
        .collect();
    Some(LineTable {
        rows,
        heading_from,
        extent_from,
        stretches: stretches(&lines, inputs.tt),
    })
}

/// The stretches of consecutive rows of `lines`, in row order, with their first and last
/// finite times in `tt` (s); a stretch without a finite time is left out.
fn stretches(lines: &[Line], tt: &[f64]) -> Vec<(String, f64, f64)> {
    let mut out: Vec<(usize, String, f64, f64)> = Vec::new();
    for line in lines {
        for run in &line.runs {
            let times = tt[run.clone()].iter().copied().filter(|t| t.is_finite());
            let (first, last) = times.fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), t| {
                (a.min(t), b.max(t))
            });
            if first <= last {
                out.push((run.start, line.id.clone(), first, last));
            }
        }
    }
    out.sort_by_key(|s| s.0);
    out.into_iter().map(|(_, id, a, b)| (id, a, b)).collect()
}

/// Where the aircraft was, row by row, on a local flat earth.
#[derive(Debug, Clone, PartialEq)]
pub struct Track {
    /// East of the first position (km).
    pub east_km: Vec<f64>,
    /// North of the first position (km).
    pub north_km: Vec<f64>,
    /// True when made from `lat`/`lon`, false from `north_m`/`east_m`.
    pub from_lat_lon: bool,
}

/// The track of `table` from `lat`/`lon`, else `north_m`/`east_m`; `None` without either.
pub fn track(table: &Table) -> Option<Track> {
    let (north, east, from_lat_lon) = positions(table)?;
    let km = |m: Vec<f64>| m.into_iter().map(|v| v / 1000.0).collect();
    Some(Track {
        east_km: km(east),
        north_km: km(north),
        from_lat_lon,
    })
}

/// A line id and the runs of consecutive rows on it.
struct Line {
    id: String,
    runs: Vec<Range<usize>>,
}

impl Line {
    fn len(&self) -> usize {
        self.runs.iter().map(|r| r.len()).sum()
    }
}

/// Each row's line id as text, or `None` without a line column.
fn line_ids(table: &Table) -> Option<Vec<String>> {
    let index = table.index_of(LINE_COLUMN).ok()?;
    // A row without a line id (a survey file's truncated last record) is on no line.
    Some(match &table.columns()[index] {
        Column::Numbers(v) => (v.iter())
            .map(|x| match x.is_nan() {
                true => String::new(),
                false => x.to_string(),
            })
            .collect(),
        Column::Text(t) => (0..t.len()).map(|k| t.get(k).trim().to_string()).collect(),
    })
}

/// The lines in order of first appearance, each with its runs of consecutive rows.
fn group(ids: &[String]) -> Vec<Line> {
    let mut lines: Vec<Line> = Vec::new();
    // Survey files can hold 10⁵ line ids: find each by hash, not by search.
    let mut found: std::collections::HashMap<&str, usize> = std::collections::HashMap::new();
    let mut start = 0;
    for k in 1..=ids.len() {
        if k < ids.len() && ids[k] == ids[start] {
            continue;
        }
        if ids[start].is_empty() {
            start = k;
            continue;
        }
        match found.get(ids[start].as_str()) {
            Some(&j) => lines[j].runs.push(start..k),
            None => {
                found.insert(&ids[start], lines.len());
                lines.push(Line {
                    id: ids[start].clone(),
                    runs: std::iter::once(start..k).collect(),
                });
            }
        }
        start = k;
    }
    lines
}

/// `x` on the line's rows, runs joined.
fn pick(x: &[f64], line: &Line) -> Vec<f64> {
    line.runs
        .iter()
        .flat_map(|r| x[r.clone()].to_vec())
        .collect()
}

/// `a − b` less its mean over the finite rows (nT).
fn difference(a: &[f64], b: &[f64]) -> Vec<f64> {
    let d: Vec<f64> = a.iter().zip(b).map(|(a, b)| a - b).collect();
    let m = mean(&d);
    d.iter().map(|v| v - m).collect()
}

/// RMS of the finite values of `x` on `line`; `None` without one.
fn rms(x: &[f64], line: &Line) -> Option<f64> {
    let finite: Vec<f64> = pick(x, line)
        .into_iter()
        .filter(|v| v.is_finite())
        .collect();
    let n = finite.len() as f64;
    (n > 0.0).then(|| (finite.iter().map(|v| v * v).sum::<f64>() / n).sqrt())
}

fn mean(x: &[f64]) -> f64 {
    let finite: Vec<f64> = x.iter().copied().filter(|v| v.is_finite()).collect();
    finite.iter().sum::<f64>() / finite.len() as f64
}

/// Fourth-difference noise over the line, each run differenced alone so no difference reaches
/// from one pass of the line to the next.
fn noise(x: &[f64], line: &Line) -> Option<f64> {
    let differences: Vec<f64> = line
        .runs
        .iter()
        .flat_map(|r| fourth_difference(&x[r.clone()]))
        .collect();
    Some(std_dev(&differences)).filter(|v| v.is_finite())
}

/// Positions (m) from `lat`/`lon`, else `north_m`/`east_m`.
fn positions(table: &Table) -> Option<(Vec<f64>, Vec<f64>, bool)> {
    let column = |name| table.numeric(name).ok();
    if let (Some(lat), Some(lon)) = (column(LATITUDE), column(LONGITUDE)) {
        let (north, east) = local_north_east_m(&lat, &lon);
        return Some((north, east, true));
    }
    Some((column(NORTH)?, column(EAST)?, false))
}

/// The first and last finite time of a line (s).
fn span(tt: &[f64]) -> Option<(f64, f64)> {
    let first = tt.iter().copied().find(|t| t.is_finite())?;
    let last = tt.iter().copied().rfind(|t| t.is_finite())?;
    Some((first, last))
}

/// The largest |fourth difference| over the line (nT), each run differenced alone.
fn peak(x: &[f64], line: &Line) -> Option<f64> {
    (line.runs.iter())
        .flat_map(|r| fourth_difference(&x[r.clone()]))
        .filter(|d| d.is_finite())
        .map(f64::abs)
        .max_by(f64::total_cmp)
}

/// Each line's mean heading (deg) and whether it is straight ([`STRAIGHT_CONCENTRATION`]; a
/// line with no heading counts as straight).
fn headings(table: &Table, lines: &[Line]) -> (HeadingSource, Vec<Option<f64>>, Vec<bool>) {
    let of = |angles: &[f64]| {
        let straight = circular_concentration(angles).is_none_or(|r| r >= STRAIGHT_CONCENTRATION);
        (circular_mean_deg(angles), straight)
    };
    let (source, per_line): (_, Vec<_>) = if let Ok(yaw) = table.numeric(YAW) {
        let per_line = lines.iter().map(|l| of(&pick(&yaw, l))).collect();
        (HeadingSource::Yaw, per_line)
    } else if let Some((north, east, from_lat_lon)) = positions(table) {
        let per_line = lines
            .iter()
            .map(|l| {
                let bearings: Vec<f64> = l
                    .runs
                    .iter()
                    .flat_map(|r| track_bearings_deg(&north[r.clone()], &east[r.clone()]))
                    .collect();
                of(&bearings)
            })
            .collect();
        let source = match from_lat_lon {
            true => HeadingSource::LatLon,
            false => HeadingSource::NorthEast,
        };
        (source, per_line)
    } else {
        (HeadingSource::None, vec![(None, true); lines.len()])
    };
    let (headings, straight) = per_line.into_iter().unzip();
    (source, headings, straight)
}

fn extents(table: &Table, tt: &[f64], lines: &[Line]) -> (ExtentSource, Vec<Option<f64>>) {
    let finite = |v: f64| Some(v).filter(|v| v.is_finite());
    if let Some((north, east, from_lat_lon)) = positions(table) {
        let km = |l: &Line| {
            let m: f64 = l
                .runs
                .iter()
                .map(|r| track_length_m(&north[r.clone()], &east[r.clone()]))
                .sum();
            finite(m / 1000.0)
        };
        let source = if from_lat_lon {
            ExtentSource::LatLon
        } else {
            ExtentSource::NorthEast
        };
        return (source, lines.iter().map(km).collect());
    }
    let seconds = |l: &Line| {
        let s: f64 = l.runs.iter().map(|r| tt[r.end - 1] - tt[r.start]).sum();
        finite(s)
    };
    (ExtentSource::Duration, lines.iter().map(seconds).collect())
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::Path;

    fn table(columns: &[(&str, Vec<f64>)]) -> Table {
        let headers = columns.iter().map(|(n, _)| n.to_string()).collect();
        let columns = columns
            .iter()
            .map(|(_, v)| Column::Numbers(v.clone()))
            .collect();
        Table::from_columns(Path::new("t"), headers, columns, None).unwrap()
    }

    #[test]
    fn a_row_without_a_line_id_is_on_no_line() {
        let n = 30;
        let tt: Vec<f64> = (0..n).map(|k| k as f64).collect();
        let mut line: Vec<f64> = (0..n).map(|k| if k < 15 { 1.0 } else { 2.0 }).collect();
        line[n - 1] = f64::NAN; // a truncated last record
        let before = vec![1.0; n];
        let t = table(&[("line", line.clone())]);
        let inputs = LineInputs {
            tt: &tt,
            before: &before,
            after: None,
            truth: None,
        };
        let lines = line_table(&t, &inputs).unwrap();
        let ids: Vec<&str> = lines.rows.iter().map(|r| r.line.as_str()).collect();
        assert_eq!(ids, ["1", "2"]);
        assert_eq!(lines.rows[1].rows, 14);
        // One line and a row without an id is a flight of one line: no table.
        line[..15].fill(2.0);
        assert!(line_table(&table(&[("line", line)]), &inputs).is_none());
    }

    #[test]
    fn two_lines_flown_north_and_south_without_positions() {
        let n = 40;
        let tt: Vec<f64> = (0..n).map(|k| k as f64 * 0.5).collect();
        let line: Vec<f64> = (0..n).map(|k| if k < 20 { 7.0 } else { 8.5 }).collect();
        let yaw: Vec<f64> = (0..n).map(|k| if k < 20 { 359.0 } else { 180.0 }).collect();
        // A trend on line 7 and a level 10 nT higher on line 8.5.
        let before: Vec<f64> = (0..n)
            .map(|k| if k < 20 { 100.0 + k as f64 } else { 125.0 })
            .collect();
        let t = table(&[("line", line), ("ins_yaw", yaw)]);
        let inputs = LineInputs {
            tt: &tt,
            before: &before,
            after: None,
            truth: None,
        };
        let lines = line_table(&t, &inputs).unwrap();
        assert_eq!(lines.heading_from, HeadingSource::Yaw);
        assert_eq!(lines.extent_from, ExtentSource::Duration);
        let [a, b] = &lines.rows[..] else { panic!() };
        assert_eq!((a.line.as_str(), b.line.as_str()), ("7", "8.5"));
        assert_eq!((a.rows, b.rows), (20, 20));
        assert!((a.heading_deg.unwrap() - 359.0).abs() < 1e-9);
        assert_eq!(a.extent, Some(9.5));
        assert!(a.residual_before_nt.unwrap() < 1e-9);
        assert!(a.noise_before_nt.unwrap() < 1e-9);
        assert_eq!(a.residual_after_nt, None);
        // Means 109.5 and 125: the median is 117.25.
        assert!((b.level_nt.unwrap() - 7.75).abs() < 1e-9);
        assert_eq!(b.level_before_nt, b.level_nt);
        // Compensated 5 nT lower on line 8.5: its level is, but not its level before.
        let after: Vec<f64> = (0..n)
            .map(|k| before[k] - if k < 20 { 0.0 } else { 5.0 })
            .collect();
        let inputs = LineInputs {
            after: Some(&after),
            ..inputs
        };
        let lines = line_table(&t, &inputs).unwrap();
        let b = &lines.rows[1];
        assert!((b.level_nt.unwrap() - 5.25).abs() < 1e-9);
        assert!((b.level_before_nt.unwrap() - 7.75).abs() < 1e-9);
    }

    #[test]
    fn a_track_from_north_east_in_km_and_none_without_positions() {
        let t = table(&[("north_m", vec![0.0, 1500.0]), ("east_m", vec![0.0, -20.0])]);
        let track = track(&t).unwrap();
        assert_eq!(track.north_km, [0.0, 1.5]);
        assert_eq!(track.east_km, [0.0, -0.02]);
        assert!(!track.from_lat_lon);
        assert!(super::track(&table(&[("lat", vec![1.0])])).is_none());
    }

    #[test]
    fn one_line_or_no_line_column_gives_no_table() {
        let tt = [0.0, 1.0];
        let inputs = LineInputs {
            tt: &tt,
            before: &[1.0, 2.0],
            after: None,
            truth: None,
        };
        assert!(line_table(&table(&[("line", vec![3.0, 3.0])]), &inputs).is_none());
        assert!(line_table(&table(&[("x", vec![3.0, 4.0])]), &inputs).is_none());
    }

    #[test]
    fn tiny_lines_have_no_statistics_but_no_panic() {
        let tt = [0.0, 1.0, 2.0];
        let inputs = LineInputs {
            tt: &tt,
            before: &[1.0, 2.0, f64::NAN],
            after: Some(&[1.0, 2.0, 3.0]),
            truth: None,
        };
        let t = table(&[("line", vec![1.0, 2.0, 1.0])]);
        let lines = line_table(&t, &inputs).unwrap();
        assert_eq!(lines.rows[0].rows, 2);
        assert_eq!(lines.rows[0].residual_before_nt, None);
        assert_eq!(lines.rows[0].noise_after_nt, None);
        assert_eq!(lines.rows[0].heading_deg, None);
        assert_eq!(lines.rows[1].extent, Some(0.0));
    }
}
