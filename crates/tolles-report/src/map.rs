//! A map of a flight's track as an SVG scatter, each point coloured by a value (nT) less its
//! median on a blue–white–red scale centred on zero (white is the median), out to the larger
//! of the 2nd and 98th percentiles' distances from it, with a colour bar, a km grid, a
//! scale bar, and each flight line's id at its start and an arrowhead at its end.

use crate::html::escape;
use crate::numbers::nice_step;
use std::fmt::Write as _;

/// Width and height of a map (px).
pub const MAP_SIZE: (f64, f64) = (460.0, 420.0);
/// Most points drawn; longer tracks are thinned evenly so the file stays small.
const MAX_POINTS: usize = 6000;
const MARGIN: (f64, f64, f64, f64) = (56.0, 70.0, 24.0, 44.0); // left, right, top, bottom

/// Points east and north (km) and the value (nT) that colours each.
#[derive(Debug, Clone, PartialEq)]
pub struct ScatterMap<'a> {
    /// Title drawn above the map.
    pub title: &'a str,
    /// East of the origin (km).
    pub east_km: &'a [f64],
    /// North of the origin (km).
    pub north_km: &'a [f64],
    /// The colouring value (nT).
    pub value: &'a [f64],
    /// What the value is, for the colour bar.
    pub value_label: &'a str,
    /// The flight lines to name on the track (empty: none).
    pub labels: &'a [TrackLabel],
}

/// A flight line named on a map: its id at its start and an arrowhead at its end, pointing
/// the way it was flown.
#[derive(Debug, Clone, PartialEq)]
pub struct TrackLabel {
    /// The line id, as the file writes it.
    pub text: String,
    /// Where the line starts, east and north of the origin (km).
    pub from_km: (f64, f64),
    /// Where the line ends, east and north of the origin (km).
    pub to_km: (f64, f64),
}

impl ScatterMap<'_> {
    /// The SVG, or `None` when no point has a finite position and value.
    pub fn to_svg(&self) -> Option<String> {
        let points = self.points();
        let values: Vec<f64> = points.iter().map(|p| p.2).collect();
        let median = percentile(&values, 0.5)?;
        let reach = (percentile(&values, 0.02)? - median)
            .abs()
            .max((percentile(&values, 0.98)? - median).abs());
        let (lo, hi) = (median - reach, median + reach);
        let frame = Frame::around(&points);
        let (w, h) = MAP_SIZE;
        let mut svg = format!(
            "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{w}\" height=\"{h}\" \
             viewBox=\"0 0 {w} {h}\" font-family=\"sans-serif\" font-size=\"11\">\
             <rect width=\"{w}\" height=\"{h}\" fill=\"white\"/>\
             <text x=\"{}\" y=\"14\" text-anchor=\"middle\" font-size=\"12\">{}</text>",
            w / 2.0,
            escape(self.title)
        );
        // Under the track, so no grid line crosses a point.
        frame.grid(&mut svg);
        for (e, n, v) in &points {
            let (x, y) = frame.xy(*e, *n);
            let _ = write!(
                svg,
                "<circle cx=\"{x:.1}\" cy=\"{y:.1}\" r=\"1.6\" fill=\"{}\"/>",
                colour(scale(*v, lo, hi))
            );
        }
        frame.labels(&mut svg, self.labels);
        frame.axes(&mut svg);
        colour_bar(
            &mut svg,
            -reach,
            reach,
            &format!("{} − median {median:.1}", self.value_label),
        );
        svg.push_str("</svg>\n");
        Some(svg)
    }

    /// The finite points, thinned to at most [`MAX_POINTS`].
    fn points(&self) -> Vec<(f64, f64, f64)> {
        let finite: Vec<(f64, f64, f64)> = self
            .east_km
            .iter()
            .zip(self.north_km)
            .zip(self.value)
            .map(|((e, n), v)| (*e, *n, *v))
            .filter(|(e, n, v)| e.is_finite() && n.is_finite() && v.is_finite())
            .collect();
        let stride = finite.len().div_ceil(MAX_POINTS).max(1);
        finite.into_iter().step_by(stride).collect()
    }
}

/// The plotting area and the km-to-pixel scale, the same on both axes so the track keeps its
/// shape.
struct Frame {
    east0: f64,
    north0: f64,
    px_per_km: f64,
    span_km: (f64, f64),
}

impl Frame {
    fn around(points: &[(f64, f64, f64)]) -> Frame {
        let (mut e0, mut e1, mut n0, mut n1) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
        for (e, n, _) in points {
            (e0, e1, n0, n1) = (e0.min(*e), e1.max(*e), n0.min(*n), n1.max(*n));
        }
        // A track along one axis (or one point) still needs a width to scale, and the track
        // keeps off the frame by a twentieth of its extent.
        let pad = 0.05 * (e1 - e0).max(n1 - n0).max(1e-3);
        let (e0, e1, n0, n1) = (e0 - pad, e1 + pad, n0 - pad, n1 + pad);
        let span_km = ((e1 - e0).max(1e-3), (n1 - n0).max(1e-3));
        let (w, h) = Self::area();
        let px_per_km = (w / span_km.0).min(h / span_km.1);
        // The frame fills the plotting area at that one scale, the track centred in it: a
        // line flown north keeps an east axis wide enough to label both ends apart.
        let span_km = (w / px_per_km, h / px_per_km);
        Frame {
            east0: (e0 + e1 - span_km.0) / 2.0,
            north0: (n0 + n1 - span_km.1) / 2.0,
            px_per_km,
            span_km,
        }
    }

    fn area() -> (f64, f64) {
        let (l, r, t, b) = MARGIN;
        (MAP_SIZE.0 - l - r, MAP_SIZE.1 - t - b)
    }

    fn xy(&self, east: f64, north: f64) -> (f64, f64) {
        let (l, _, _, b) = MARGIN;
        let x = l + (east - self.east0) * self.px_per_km;
        let y = MAP_SIZE.1 - b - (north - self.north0) * self.px_per_km;
        (x, y)
    }

    /// Grid lines every `step` km with their labels inside the frame, and a scale bar of one
    /// step at the bottom left.
    fn grid(&self, svg: &mut String) {
        // A millimetre at least: a track of one point still gets a grid.
        let step = nice_step((self.span_km.0.max(self.span_km.1) / 5.0).max(1e-6));
        let (x0, y0) = self.xy(self.east0, self.north0);
        let (x1, y1) = self.xy(self.east0 + self.span_km.0, self.north0 + self.span_km.1);
        let ticks = |from: f64, span: f64| {
            let first = (from / step).ceil() as i64;
            let last = ((from + span) / step).floor() as i64;
            (first..=last).map(|k| k as f64 * step)
        };
        for east in ticks(self.east0, self.span_km.0) {
            let (x, _) = self.xy(east, self.north0);
            let _ = write!(
                svg,
                "<line x1=\"{x:.1}\" y1=\"{y1:.1}\" x2=\"{x:.1}\" y2=\"{y0:.1}\" stroke=\"#ddd\" \
                 stroke-width=\"0.6\"/><text x=\"{x:.1}\" y=\"{:.1}\" text-anchor=\"middle\" \
                 font-size=\"9\" fill=\"#777\">{}</text>",
                y1 + 10.0,
                km(east)
            );
        }
        for north in ticks(self.north0, self.span_km.1) {
            let (_, y) = self.xy(self.east0, north);
            let _ = write!(
                svg,
                "<line x1=\"{x0:.1}\" y1=\"{y:.1}\" x2=\"{x1:.1}\" y2=\"{y:.1}\" stroke=\"#ddd\" \
                 stroke-width=\"0.6\"/><text x=\"{:.1}\" y=\"{:.1}\" font-size=\"9\" \
                 fill=\"#777\">{}</text>",
                x0 + 3.0,
                y - 2.0,
                km(north)
            );
        }
        let length = step * self.px_per_km;
        let (bx, by) = (x0 + 8.0, y0 - 8.0);
        let _ = write!(
            svg,
            "<path d=\"M{bx:.1} {:.1}V{by:.1}H{:.1}V{:.1}\" stroke=\"#222\" fill=\"none\" \
             stroke-width=\"1.5\"/><text x=\"{:.1}\" y=\"{:.1}\" text-anchor=\"middle\" \
             font-size=\"10\">{} km</text>",
            by - 4.0,
            bx + length,
            by - 4.0,
            bx + length / 2.0,
            by - 6.0,
            format_step(step)
        );
    }

    /// Each label's arrowhead (8 px, along its line from start to end) at the line's end, and
    /// its id just beyond the line's start, haloed in white so that the track does not cross it
    /// unreadably. Ids that would sit within 12 px of one another (a line flown again) share
    /// one text, joined by commas.
    fn labels(&self, svg: &mut String, labels: &[TrackLabel]) {
        let mut ids: Vec<((f64, f64), Vec<&str>)> = Vec::new();
        for label in labels {
            let (x0, y0) = self.xy(label.from_km.0, label.from_km.1);
            let (x1, y1) = self.xy(label.to_km.0, label.to_km.1);
            let length = (x1 - x0).hypot(y1 - y0);
            if !(length.is_finite() && length >= 1.0) {
                continue;
            }
            let (ux, uy) = ((x1 - x0) / length, (y1 - y0) / length);
            let (bx, by) = (x1 - 8.0 * ux, y1 - 8.0 * uy);
            let _ = write!(
                svg,
                "<path d=\"M{x1:.1} {y1:.1}L{:.1} {:.1}L{:.1} {:.1}Z\" fill=\"#222\"/>",
                bx - 4.0 * uy,
                by + 4.0 * ux,
                bx + 4.0 * uy,
                by - 4.0 * ux,
            );
            if label.text.is_empty() {
                continue;
            }
            let at = (x0 - 10.0 * ux, y0 - 10.0 * uy);
            let near = |p: &(f64, f64)| (p.0 - at.0).hypot(p.1 - at.1) < 12.0;
            match ids.iter_mut().find(|(p, _)| near(p)) {
                Some((_, texts)) => texts.push(&label.text),
                None => ids.push((at, vec![&label.text])),
            }
        }
        for ((x, y), texts) in ids {
            let _ = write!(
                svg,
                "<text class=\"line-id\" x=\"{x:.1}\" y=\"{y:.1}\" text-anchor=\"middle\" \
                 dominant-baseline=\"middle\" font-size=\"10\" stroke=\"white\" \
                 stroke-width=\"3\" paint-order=\"stroke\">{}</text>",
                escape(&texts.join(", "))
            );
        }
    }

    fn axes(&self, svg: &mut String) {
        let (x0, y0) = self.xy(self.east0, self.north0);
        let (x1, y1) = self.xy(self.east0 + self.span_km.0, self.north0 + self.span_km.1);
        let _ = write!(
            svg,
            "<rect x=\"{x0:.1}\" y=\"{y1:.1}\" width=\"{:.1}\" height=\"{:.1}\" fill=\"none\" \
             stroke=\"#888\"/>\
             <text x=\"{x0:.1}\" y=\"{:.1}\">{}</text>\
             <text x=\"{x1:.1}\" y=\"{:.1}\" text-anchor=\"end\">{}</text>\
             <text x=\"{:.1}\" y=\"{:.1}\" text-anchor=\"middle\">east (km)</text>\
             <text x=\"{:.1}\" y=\"{y0:.1}\" text-anchor=\"end\">{}</text>\
             <text x=\"{:.1}\" y=\"{:.1}\" text-anchor=\"end\">{}</text>\
             <text transform=\"translate(14 {:.1}) rotate(-90)\" text-anchor=\"middle\">\
             north (km)</text>",
            x1 - x0,
            y0 - y1,
            y0 + 14.0,
            km(self.east0),
            y0 + 14.0,
            km(self.east0 + self.span_km.0),
            (x0 + x1) / 2.0,
            y0 + 30.0,
            x0 - 4.0,
            km(self.north0),
            x0 - 4.0,
            y1 + 10.0,
            km(self.north0 + self.span_km.1),
            (y0 + y1) / 2.0,
        );
    }
}

/// A grid step (km) without trailing zeros.
fn format_step(step: f64) -> String {
    let text = format!("{step:.3}");
    text.trim_end_matches('0').trim_end_matches('.').to_string()
}

/// A position (km) to 0.1 km, never "-0.0".
fn km(value: f64) -> String {
    let rounded = (value * 10.0).round() / 10.0;
    format!("{:.1}", rounded + 0.0)
}

/// A vertical bar from `lo` (bottom) to `hi` (top) at the right of the map.
fn colour_bar(svg: &mut String, lo: f64, hi: f64, label: &str) {
    let (_, _, t, b) = MARGIN;
    let x = MAP_SIZE.0 - 64.0;
    let height = MAP_SIZE.1 - t - b;
    let steps = 40;
    for k in 0..steps {
        let fraction = (k as f64 + 0.5) / steps as f64;
        let y = t + height * (1.0 - (k + 1) as f64 / steps as f64);
        let _ = write!(
            svg,
            "<rect x=\"{x}\" y=\"{y:.1}\" width=\"12\" height=\"{:.1}\" fill=\"{}\"/>",
            height / steps as f64 + 0.5,
            colour(fraction)
        );
    }
    let _ = write!(
        svg,
        "<text x=\"{}\" y=\"{}\">{hi:.1}</text><text x=\"{}\" y=\"{}\">{lo:.1}</text>\
         <text x=\"{}\" y=\"{}\" font-size=\"10\" text-anchor=\"end\">{}</text>",
        x + 15.0,
        t + 8.0,
        x + 15.0,
        t + height,
        // Ends at the right edge: a median of 53 544.7 nT ran past it from the bar.
        MAP_SIZE.0 - 4.0,
        MAP_SIZE.1 - 8.0,
        escape(label)
    );
}

/// `v` placed in [0, 1] between `lo` and `hi` (0.5 when they are equal).
fn scale(v: f64, lo: f64, hi: f64) -> f64 {
    if hi > lo {
        ((v - lo) / (hi - lo)).clamp(0.0, 1.0)
    } else {
        0.5
    }
}

/// Blue (0) through white (0.5) to red (1): a diverging scale for anomalies about a level.
fn colour(fraction: f64) -> String {
    let (blue, white, red) = (
        [33.0, 102.0, 172.0],
        [247.0, 247.0, 247.0],
        [178.0, 24.0, 43.0],
    );
    let (a, b, f) = if fraction < 0.5 {
        (blue, white, fraction * 2.0)
    } else {
        (white, red, fraction * 2.0 - 1.0)
    };
    let c = |i: usize| (a[i] + (b[i] - a[i]) * f).round() as u8;
    format!("#{:02x}{:02x}{:02x}", c(0), c(1), c(2))
}

/// The `q` quantile of `values` (nearest rank); `None` when empty.
fn percentile(values: &[f64], q: f64) -> Option<f64> {
    let mut sorted = values.to_vec();
    sorted.sort_by(f64::total_cmp);
    let k = ((sorted.len() as f64 - 1.0) * q).round() as usize;
    sorted.get(k).copied()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_map_draws_every_finite_point_and_a_finite_colour_bar() {
        let east: Vec<f64> = (0..100).map(|k| k as f64 * 0.1).collect();
        let north = vec![0.0; 100];
        let mut value: Vec<f64> = east.iter().map(|e| e * 2.0).collect();
        value[3] = f64::NAN;
        let svg = ScatterMap {
            title: "compensated <field>",
            east_km: &east,
            north_km: &north,
            value: &value,
            value_label: "nT",
            labels: &[],
        }
        .to_svg()
        .unwrap();
        assert_eq!(svg.matches("<circle").count(), 99);
        assert!(svg.contains("compensated &lt;field&gt;"));
        assert!(!svg.contains("NaN") && !svg.contains("inf"));
    }

    #[test]
    fn the_scale_is_centred_on_the_median_and_the_map_has_a_grid_and_a_scale_bar() {
        let east: Vec<f64> = (0..101).map(|k| k as f64 * 0.1).collect();
        let north: Vec<f64> = east.iter().map(|e| e * 0.5).collect();
        // Skewed: 100 nT over most of the track, up to 140 nT at its end.
        let value: Vec<f64> = east
            .iter()
            .map(|e| 100.0 + (e - 7.0).max(0.0) * 13.0)
            .collect();
        let svg = ScatterMap {
            title: "t",
            east_km: &east,
            north_km: &north,
            value: &value,
            value_label: "nT",
            labels: &[],
        }
        .to_svg()
        .unwrap();
        // White is the median (100 nT), the bar runs ± the farther percentile from it.
        assert!(svg.contains("nT − median 100.0"), "{svg}");
        assert!(svg.contains("fill=\"#f7f7f7\""));
        // A 5 km grid over an 11 km track, labelled, and a scale bar of one step.
        assert!(svg.contains(">5 km</text>"), "{svg}");
        assert_eq!(svg.matches("stroke=\"#ddd\"").count(), 5);
        assert!(svg.contains(">36.4</text>") && svg.contains(">-36.4</text>"));
        // The track keeps off the frame: its first point is inside the plotting area.
        let first = svg.split("<circle cx=\"").nth(1).unwrap();
        let cx: f64 = first.split('"').next().unwrap().parse().unwrap();
        assert!(cx > MARGIN.0 + 5.0, "{cx}");
    }

    #[test]
    fn each_line_is_named_at_its_start_with_an_arrow_at_its_end() {
        // A line flown north, then one flown south 1 km east of it.
        let east: Vec<f64> = (0..40).map(|k| if k < 20 { 0.0 } else { 1.0 }).collect();
        let north: Vec<f64> = (0..40)
            .map(|k| {
                if k < 20 {
                    k as f64 * 0.5
                } else {
                    (39 - k) as f64 * 0.5
                }
            })
            .collect();
        let labels = [
            TrackLabel {
                text: "1001".into(),
                from_km: (0.0, 0.0),
                to_km: (0.0, 9.5),
            },
            TrackLabel {
                text: "<b>1002".into(),
                from_km: (1.0, 9.5),
                to_km: (1.0, 0.0),
            },
        ];
        let svg = ScatterMap {
            title: "t",
            east_km: &east,
            north_km: &north,
            value: &vec![1.0; 40],
            value_label: "nT",
            labels: &labels,
        }
        .to_svg()
        .unwrap();
        assert_eq!(svg.matches("fill=\"#222\"/>").count(), 2);
        assert!(svg.contains(">1001</text>") && svg.contains(">&lt;b&gt;1002</text>"));
        // 1001 flew north: its id sits below its start, its arrow's tip at the top.
        let y_of = |text: &str| -> f64 {
            let at = svg.find(&format!(">{text}</text>")).unwrap();
            let tag = &svg[svg[..at].rfind("<text").unwrap()..at];
            tag.split("y=\"")
                .nth(1)
                .unwrap()
                .split('"')
                .next()
                .unwrap()
                .parse()
                .unwrap()
        };
        let tips: Vec<f64> = svg
            .split("<path d=\"M")
            .skip(1)
            .filter(|p| p[..p.find('>').unwrap()].contains("Z\""))
            .map(|p| p.split(['L', ' ']).nth(1).unwrap().parse().unwrap())
            .collect();
        assert!(y_of("1001") > tips[0], "{} {}", y_of("1001"), tips[0]);
        assert!(y_of("&lt;b&gt;1002") < tips[1]);
        // The same line flown again: one text names both, and each keeps its arrow.
        let again = [
            labels[0].clone(),
            TrackLabel {
                text: "1003".into(),
                ..labels[0].clone()
            },
        ];
        let ones = vec![1.0; 40];
        let svg = ScatterMap {
            title: "t",
            east_km: &east,
            north_km: &north,
            value: &ones,
            value_label: "nT",
            labels: &again,
        }
        .to_svg()
        .unwrap();
        assert!(svg.contains(">1001, 1003</text>"), "{svg}");
        assert_eq!(svg.matches("fill=\"#222\"/>").count(), 2);
    }

    #[test]
    fn no_finite_point_gives_no_map() {
        let map = ScatterMap {
            title: "t",
            east_km: &[f64::NAN],
            north_km: &[0.0],
            value: &[1.0],
            value_label: "nT",
            labels: &[],
        };
        assert!(map.to_svg().is_none());
    }

    #[test]
    fn the_colour_scale_runs_blue_white_red() {
        assert_eq!(colour(0.0), "#2166ac");
        assert_eq!(colour(0.5), "#f7f7f7");
        assert_eq!(colour(1.0), "#b2182b");
        assert_eq!(scale(5.0, 1.0, 1.0), 0.5);
        assert_eq!(km(-0.00001), "0.0");
        assert_eq!(km(1.26), "1.3");
    }
}
