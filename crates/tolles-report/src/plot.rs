//! Line plots and bar charts, drawn as SVG.
//!
//! ```
//! use tolles_report::plot::{LinePlot, Series, Colour};
//! let t: Vec<f64> = (0..100).map(|k| k as f64 * 0.1).collect();
//! let plot = LinePlot {
//!     title: "Heading".into(),
//!     x_label: "time (s)".into(),
//!     y_label: "field (nT)".into(),
//!     series: vec![Series::new("raw", t.clone(), t.iter().map(|v| v.sin()).collect())
//!         .colour(Colour::UNCOMPENSATED)],
//!     ..LinePlot::default()
//! };
//! let svg = plot.to_svg().unwrap();
//! assert!(svg.svg.starts_with("<svg") && svg.svg.contains("<polyline"));
//! ```

use plotters::coord::ranged1d::{AsRangedCoord, ValueFormatter};
use plotters::prelude::*;

use crate::decimate::polylines;
use crate::ReportError;

/// Width of every plot (SVG pixels); the page scales it to the column.
pub const PLOT_WIDTH: u32 = 960;
/// Height of every plot (SVG pixels).
pub const PLOT_HEIGHT: u32 = 380;

/// A colour (8-bit sRGB). The named constants are the Okabe–Ito palette, which stays
/// distinguishable for colour-blind readers; the same quantity gets the same colour on every
/// plot of a report.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Colour(pub u8, pub u8, pub u8);

impl Colour {
    /// Uncompensated (raw) magnetometer data: vermillion.
    pub const UNCOMPENSATED: Colour = Colour(213, 94, 0);
    /// Compensated data: blue.
    pub const COMPENSATED: Colour = Colour(0, 114, 178);
    /// Known truth or a reference: bluish green.
    pub const REFERENCE: Colour = Colour(0, 158, 115);
    /// Series without an assigned colour take these in turn.
    pub const CYCLE: [Colour; 7] = [
        Colour(0, 114, 178),
        Colour(213, 94, 0),
        Colour(0, 158, 115),
        Colour(204, 121, 167),
        Colour(86, 180, 233),
        Colour(230, 159, 0),
        Colour(80, 80, 80),
    ];

    /// CSS notation, `#rrggbb`.
    pub fn css(self) -> String {
        format!("#{:02x}{:02x}{:02x}", self.0, self.1, self.2)
    }

    fn rgb(self) -> RGBColor {
        RGBColor(self.0, self.1, self.2)
    }
}

/// One line of a [`LinePlot`]: `y` against `x` in the plot's units. Non-finite values (and
/// values ≤ 0 on a logarithmic axis) leave a gap in the line.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Series {
    /// Legend entry.
    pub name: String,
    /// Abscissae (units of the plot's x axis).
    pub x: Vec<f64>,
    /// Ordinates (units of the plot's y axis), as many as `x`.
    pub y: Vec<f64>,
    /// Line colour; `None` takes the next colour of [`Colour::CYCLE`].
    pub colour: Option<Colour>,
}

impl Series {
    /// A series named `name` with an automatic colour.
    pub fn new(name: impl Into<String>, x: Vec<f64>, y: Vec<f64>) -> Self {
        Series {
            name: name.into(),
            x,
            y,
            colour: None,
        }
    }

    /// The same series drawn in `colour`.
    pub fn colour(mut self, colour: Colour) -> Self {
        self.colour = Some(colour);
        self
    }
}

/// A plot of one or more lines against a shared x axis.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct LinePlot {
    /// Heading shown above the plot.
    pub title: String,
    /// x-axis label, with units.
    pub x_label: String,
    /// y-axis label, with units.
    pub y_label: String,
    /// The lines.
    pub series: Vec<Series>,
    /// Logarithmic y axis (for spectra); values ≤ 0 are gaps.
    pub log_y: bool,
    /// Fixed x range; `None` spans the finite data.
    pub x_range: Option<(f64, f64)>,
    /// Fixed y range; `None` spans the drawable data with a margin.
    pub y_range: Option<(f64, f64)>,
    /// A sentence shown under the plot.
    pub caption: Option<String>,
}

/// A bar chart: one group of bars per category, one bar per series in every group.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct BarChart {
    /// Heading shown above the chart.
    pub title: String,
    /// y-axis label, with units.
    pub y_label: String,
    /// Category names along the x axis.
    pub categories: Vec<String>,
    /// `(name, value per category)`; non-finite values draw no bar.
    pub series: Vec<BarSeries>,
    /// A sentence shown under the chart.
    pub caption: Option<String>,
}

/// One series of a [`BarChart`].
#[derive(Debug, Clone, PartialEq, Default)]
pub struct BarSeries {
    /// Legend entry.
    pub name: String,
    /// One value per category (units of the chart's y axis).
    pub values: Vec<f64>,
    /// Bar colour; `None` takes the next colour of [`Colour::CYCLE`].
    pub colour: Option<Colour>,
}

impl BarSeries {
    /// A series named `name` with an automatic colour.
    pub fn new(name: impl Into<String>, values: Vec<f64>) -> Self {
        BarSeries {
            name: name.into(),
            values,
            colour: None,
        }
    }

    /// The same series drawn in `colour`.
    pub fn colour(mut self, colour: Colour) -> Self {
        self.colour = Some(colour);
        self
    }
}

/// A drawn plot: the SVG text and what the page says about it.
#[derive(Debug, Clone, PartialEq)]
pub struct RenderedPlot {
    /// A complete SVG document.
    pub svg: String,
    /// Legend entries in drawing order.
    pub legend: Vec<(String, Colour)>,
    /// Facts about the drawing worth a reader's notice (decimation, gaps, empty data).
    pub notes: Vec<String>,
}

const INK: RGBColor = RGBColor(51, 51, 51);
const MUTED: RGBColor = RGBColor(102, 102, 102);
const GRID: RGBColor = RGBColor(232, 232, 232);
const FONT: &str = "sans-serif";

fn colours<'a>(
    given: impl Iterator<Item = Option<Colour>> + 'a,
) -> impl Iterator<Item = Colour> + 'a {
    given
        .enumerate()
        .map(|(k, c)| c.unwrap_or(Colour::CYCLE[k % Colour::CYCLE.len()]))
}

fn plot_error(title: &str, e: impl std::fmt::Display) -> ReportError {
    ReportError::Plot {
        title: title.to_string(),
        message: e.to_string(),
    }
}

impl LinePlot {
    /// Draws the plot (long series thinned to what the pixels can show).
    pub fn to_svg(&self) -> Result<RenderedPlot, ReportError> {
        for s in &self.series {
            if s.x.len() != s.y.len() {
                return Err(ReportError::SeriesLength {
                    plot: self.title.clone(),
                    series: s.name.clone(),
                    x: s.x.len(),
                    y: s.y.len(),
                });
            }
        }
        let drawable = |v: f64| v.is_finite() && (!self.log_y || v > 0.0);
        let legend: Vec<(String, Colour)> = self
            .series
            .iter()
            .map(|s| s.name.clone())
            .zip(colours(self.series.iter().map(|s| s.colour)))
            .collect();
        let mut notes = Vec::new();
        let Some(x_range) = self.x_range.or_else(|| x_extent(&self.series, drawable)) else {
            notes.push("No finite values to plot.".to_string());
            return Ok(RenderedPlot {
                svg: empty_svg(),
                legend,
                notes,
            });
        };
        let y_range = self
            .y_range
            .or_else(|| y_extent(&self.series, drawable, self.log_y))
            .unwrap_or((0.0, 1.0));

        let plot_columns = PLOT_WIDTH as usize;
        let mut lines = Vec::new();
        let (mut total, mut drawn, mut gaps) = (0, 0, 0);
        for (s, (_, colour)) in self.series.iter().zip(&legend) {
            let runs = polylines(&s.x, &s.y, x_range, plot_columns, |v| {
                !self.log_y || v > 0.0
            });
            total += s.y.len();
            drawn += runs.iter().map(Vec::len).sum::<usize>();
            gaps +=
                s.x.iter()
                    .zip(&s.y)
                    .filter(|(x, y)| !(x.is_finite() && drawable(**y)))
                    .count();
            lines.push((runs, *colour));
        }
        if drawn < total.saturating_sub(gaps) {
            notes.push(format!(
                "{} points drawn as {} (lowest and highest value per pixel column kept).",
                group_thousands(total - gaps),
                group_thousands(drawn)
            ));
        }
        if gaps > 0 {
            let what = if self.log_y {
                "non-finite or non-positive"
            } else {
                "non-finite"
            };
            notes.push(format!(
                "{} {what} values are shown as gaps.",
                group_thousands(gaps)
            ));
        }

        let mut svg = String::new();
        {
            let root =
                SVGBackend::with_string(&mut svg, (PLOT_WIDTH, PLOT_HEIGHT)).into_drawing_area();
            root.fill(&WHITE).map_err(|e| plot_error(&self.title, e))?;
            let x_spec = x_range.0..x_range.1;
            let result = if self.log_y {
                draw_lines(
                    &root,
                    x_spec,
                    (y_range.0..y_range.1).log_scale(),
                    self,
                    &lines,
                )
            } else {
                draw_lines(&root, x_spec, y_range.0..y_range.1, self, &lines)
            };
            result.map_err(|e| plot_error(&self.title, e))?;
            root.present().map_err(|e| plot_error(&self.title, e))?;
        }
        Ok(RenderedPlot { svg, legend, notes })
    }
}

type Lines = [(Vec<Vec<(f64, f64)>>, Colour)];

fn draw_lines<DB, YS>(
    root: &DrawingArea<DB, plotters::coord::Shift>,
    x_spec: std::ops::Range<f64>,
    y_spec: YS,
    plot: &LinePlot,
    lines: &Lines,
) -> Result<(), String>
where
    DB: DrawingBackend,
    YS: AsRangedCoord<Value = f64>,
    YS::CoordDescType: ValueFormatter<f64>,
{
    let mut chart = ChartBuilder::on(root)
        .margin_top(14)
        .margin_right(24)
        .margin_left(8)
        .margin_bottom(6)
        .x_label_area_size(48)
        .y_label_area_size(78)
        .build_cartesian_2d(x_spec, y_spec)
        .map_err(|e| e.to_string())?;
    let tick = |v: &f64| format_tick(*v);
    let y_tick = |v: &f64| {
        if plot.log_y {
            format_log_tick(*v)
        } else {
            format_tick(*v)
        }
    };
    chart
        .configure_mesh()
        .x_desc(plot.x_label.as_str())
        .y_desc(plot.y_label.as_str())
        .x_labels(9)
        .y_labels(7)
        .x_label_formatter(&tick)
        .y_label_formatter(&y_tick)
        .label_style((FONT, 17).into_font().color(&MUTED))
        .axis_desc_style((FONT, 18).into_font().color(&INK))
        .bold_line_style(GRID)
        .light_line_style(TRANSPARENT)
        .axis_style(MUTED)
        .draw()
        .map_err(|e| e.to_string())?;
    for (runs, colour) in lines {
        let style = ShapeStyle::from(&colour.rgb()).stroke_width(1);
        for run in runs {
            if run.len() == 1 {
                chart
                    .draw_series(std::iter::once(Circle::new(run[0], 2, style.filled())))
                    .map_err(|e| e.to_string())?;
            } else {
                chart
                    .draw_series(LineSeries::new(run.iter().copied(), style))
                    .map_err(|e| e.to_string())?;
            }
        }
    }
    Ok(())
}

fn x_extent(series: &[Series], drawable: impl Fn(f64) -> bool) -> Option<(f64, f64)> {
    let xs = series.iter().flat_map(|s| {
        s.x.iter()
            .zip(&s.y)
            .filter(|(x, y)| x.is_finite() && drawable(**y))
            .map(|(x, _)| *x)
    });
    let (lo, hi) = min_max(xs)?;
    Some(if lo < hi {
        (lo, hi)
    } else {
        (lo - 0.5, hi + 0.5)
    })
}

fn y_extent(series: &[Series], drawable: impl Fn(f64) -> bool, log: bool) -> Option<(f64, f64)> {
    let ys = series.iter().flat_map(|s| {
        s.x.iter()
            .zip(&s.y)
            .filter(|(x, y)| x.is_finite() && drawable(**y))
            .map(|(_, y)| *y)
    });
    let (lo, hi) = min_max(ys)?;
    Some(if log {
        // Whole decades, so the axis reads 10ⁿ at both ends.
        let lo = 10f64.powf(lo.log10().floor());
        let hi = 10f64.powf(hi.log10().ceil());
        if lo < hi {
            (lo, hi)
        } else {
            (lo / 10.0, hi * 10.0)
        }
    } else if lo < hi {
        let pad = 0.06 * (hi - lo);
        (lo - pad, hi + pad)
    } else {
        let pad = if lo == 0.0 { 1.0 } else { 0.1 * lo.abs() };
        (lo - pad, hi + pad)
    })
}

fn min_max(values: impl Iterator<Item = f64>) -> Option<(f64, f64)> {
    values.fold(None, |acc, v| match acc {
        None => Some((v, v)),
        Some((lo, hi)) => Some((lo.min(v), hi.max(v))),
    })
}

fn empty_svg() -> String {
    format!(
        "<svg width=\"{PLOT_WIDTH}\" height=\"{PLOT_HEIGHT}\" viewBox=\"0 0 {PLOT_WIDTH} {PLOT_HEIGHT}\" \
         xmlns=\"http://www.w3.org/2000/svg\"><rect width=\"100%\" height=\"100%\" fill=\"#fafafa\"/>\
         <text x=\"50%\" y=\"50%\" text-anchor=\"middle\" font-family=\"sans-serif\" font-size=\"16\" \
         fill=\"#666\">no data</text></svg>\n"
    )
}

impl BarChart {
    /// Draws the chart.
    pub fn to_svg(&self) -> Result<RenderedPlot, ReportError> {
        for s in &self.series {
            if s.values.len() != self.categories.len() {
                return Err(ReportError::SeriesLength {
                    plot: self.title.clone(),
                    series: s.name.clone(),
                    x: self.categories.len(),
                    y: s.values.len(),
                });
            }
        }
        let legend: Vec<(String, Colour)> = self
            .series
            .iter()
            .map(|s| s.name.clone())
            .zip(colours(self.series.iter().map(|s| s.colour)))
            .collect();
        let values = || self.series.iter().flat_map(|s| s.values.iter().copied());
        let missing = values().filter(|v| !v.is_finite()).count();
        let mut notes = Vec::new();
        if missing > 0 {
            let (values, are, have) = if missing == 1 {
                ("value", "is", "has")
            } else {
                ("values", "are", "have")
            };
            notes.push(format!(
                "{missing} {values} {are} not finite and {have} no bar."
            ));
        }
        if self.categories.is_empty() || self.series.is_empty() {
            notes.push("No values to plot.".to_string());
            return Ok(RenderedPlot {
                svg: empty_svg(),
                legend,
                notes,
            });
        }
        let (lo, hi) = min_max(values().filter(|v| v.is_finite())).unwrap_or((0.0, 1.0));
        let (lo, hi) = (lo.min(0.0), hi.max(0.0));
        let span = if hi > lo { hi - lo } else { 1.0 };
        let y_range = (
            if lo < 0.0 { lo - 0.08 * span } else { 0.0 },
            if hi > 0.0 || lo == hi {
                hi + 0.1 * span
            } else {
                0.0
            },
        );

        let mut svg = String::new();
        {
            let root =
                SVGBackend::with_string(&mut svg, (PLOT_WIDTH, PLOT_HEIGHT)).into_drawing_area();
            root.fill(&WHITE).map_err(|e| plot_error(&self.title, e))?;
            self.draw_bars(&root, y_range, &legend)
                .map_err(|e| plot_error(&self.title, e))?;
            root.present().map_err(|e| plot_error(&self.title, e))?;
        }
        Ok(RenderedPlot { svg, legend, notes })
    }

    fn draw_bars<DB: DrawingBackend>(
        &self,
        root: &DrawingArea<DB, plotters::coord::Shift>,
        (y0, y1): (f64, f64),
        legend: &[(String, Colour)],
    ) -> Result<(), String> {
        let n = self.categories.len();
        let mut chart = ChartBuilder::on(root)
            .margin_top(14)
            .margin_right(24)
            .margin_left(8)
            .margin_bottom(6)
            .x_label_area_size(40)
            .y_label_area_size(78)
            // A segmented 0..m has m + 1 segments, one per category here.
            .build_cartesian_2d((0..n as i32 - 1).into_segmented(), y0..y1)
            .map_err(|e| e.to_string())?;
        let category = |v: &SegmentValue<i32>| match v {
            SegmentValue::CenterOf(i) => self
                .categories
                .get(*i as usize)
                .cloned()
                .unwrap_or_default(),
            _ => String::new(),
        };
        let tick = |v: &f64| format_tick(*v);
        chart
            .configure_mesh()
            .disable_x_mesh()
            .y_desc(self.y_label.as_str())
            .x_labels(n)
            .y_labels(7)
            .x_label_formatter(&category)
            .y_label_formatter(&tick)
            .label_style((FONT, 17).into_font().color(&MUTED))
            .x_label_style((FONT, 18).into_font().color(&INK))
            .axis_desc_style((FONT, 18).into_font().color(&INK))
            .bold_line_style(GRID)
            .light_line_style(TRANSPARENT)
            .axis_style(MUTED)
            .draw()
            .map_err(|e| e.to_string())?;

        let area = chart.plotting_area();
        let s_count = self.series.len() as f64;
        let label_values = n * self.series.len() <= 24;
        for i in 0..n {
            let left = area.map_coordinate(&(SegmentValue::Exact(i as i32), 0.0)).0 as f64;
            let right = area
                .map_coordinate(&(SegmentValue::Exact(i as i32 + 1), 0.0))
                .0 as f64;
            let group = (right - left) * 0.72;
            let bar = group / s_count;
            let start = left + (right - left - group) / 2.0;
            for (k, (s, (_, colour))) in self.series.iter().zip(legend).enumerate() {
                let v = s.values[i];
                if !v.is_finite() {
                    continue;
                }
                let base = area.map_coordinate(&(SegmentValue::Exact(0), 0.0)).1;
                let top = area.map_coordinate(&(SegmentValue::Exact(0), v)).1;
                let x0 = (start + k as f64 * bar + 1.0).round() as i32;
                let x1 = (start + (k + 1) as f64 * bar - 1.0).round() as i32;
                root.draw(&Rectangle::new(
                    [(x0, top.min(base)), (x1.max(x0 + 1), top.max(base))],
                    colour.rgb().filled(),
                ))
                .map_err(|e| e.to_string())?;
                if label_values {
                    let y = if v >= 0.0 { top - 6 } else { top + 16 };
                    let style = TextStyle::from((FONT, 16).into_font()).color(&INK).pos(
                        plotters::style::text_anchor::Pos::new(
                            plotters::style::text_anchor::HPos::Center,
                            plotters::style::text_anchor::VPos::Bottom,
                        ),
                    );
                    root.draw(&Text::new(format_value(v), ((x0 + x1) / 2, y), style))
                        .map_err(|e| e.to_string())?;
                }
            }
        }
        Ok(())
    }
}

/// A tick label: plain decimals for everyday magnitudes, powers of ten otherwise.
pub fn format_tick(v: f64) -> String {
    if v == 0.0 {
        return "0".to_string();
    }
    let a = v.abs();
    if (1e-3..1e6).contains(&a) {
        let s = format!("{v:.6}");
        let s = s.trim_end_matches('0').trim_end_matches('.');
        return s.to_string();
    }
    let exponent = a.log10().floor() as i32;
    let mantissa = v / 10f64.powi(exponent);
    if (mantissa.abs() - 1.0).abs() < 1e-9 {
        format!(
            "{}10{}",
            if v < 0.0 { "−" } else { "" },
            superscript(exponent)
        )
    } else {
        format!("{}×10{}", format_value(mantissa), superscript(exponent))
    }
}

/// A tick label on a logarithmic axis: decades as powers of ten (`10⁻³`), others as
/// [`format_tick`].
pub fn format_log_tick(v: f64) -> String {
    let exponent = v.abs().log10().round();
    if v > 0.0 && (v / 10f64.powf(exponent) - 1.0).abs() < 1e-9 {
        format!("10{}", superscript(exponent as i32))
    } else {
        format_tick(v)
    }
}

/// A value with three significant digits, without trailing zeros (`0.0123`, `45.6`, `1.23e5`).
pub fn format_value(v: f64) -> String {
    if !v.is_finite() {
        return v.to_string();
    }
    if v == 0.0 {
        return "0".to_string();
    }
    let a = v.abs();
    if !(1e-4..1e6).contains(&a) {
        return format!("{v:.2e}");
    }
    let decimals = (2 - a.log10().floor() as i32).max(0) as usize;
    let s = format!("{v:.decimals$}");
    if s.contains('.') {
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        s
    }
}

fn superscript(n: i32) -> String {
    n.to_string()
        .chars()
        .map(|c| match c {
            '-' => '⁻',
            '0' => '⁰',
            '1' => '¹',
            '2' => '²',
            '3' => '³',
            '4' => '⁴',
            '5' => '⁵',
            '6' => '⁶',
            '7' => '⁷',
            '8' => '⁸',
            _ => '⁹',
        })
        .collect()
}

/// `1234567` → `1 234 567` (thin spaces), for counts in prose.
pub fn group_thousands(n: usize) -> String {
    let digits = n.to_string();
    let mut out = String::new();
    for (k, c) in digits.chars().enumerate() {
        if k > 0 && (digits.len() - k) % 3 == 0 {
            out.push('\u{2009}');
        }
        out.push(c);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn axis_ranges_cover_the_data_with_a_margin() {
        let s = [Series::new(
            "a",
            vec![0.0, 1.0, 2.0],
            vec![0.02, f64::NAN, 299.0],
        )];
        let positive = |v: f64| v.is_finite() && v > 0.0;
        assert_eq!(y_extent(&s, positive, true), Some((0.01, 1000.0)));
        let (lo, hi) = y_extent(&s, f64::is_finite, false).unwrap();
        assert!(lo < 0.02 && hi > 299.0 && hi < 320.0);
        assert_eq!(x_extent(&s, f64::is_finite), Some((0.0, 2.0)));
        let flat = [Series::new("b", vec![5.0], vec![7.0])];
        assert_eq!(x_extent(&flat, f64::is_finite), Some((4.5, 5.5)));
        let (lo, hi) = y_extent(&flat, f64::is_finite, false).unwrap();
        assert!(lo < 7.0 && hi > 7.0);
    }

    #[test]
    fn tick_labels_are_short() {
        assert_eq!(format_tick(0.30000000000000004), "0.3");
        assert_eq!(format_tick(15000.0), "15000");
        assert_eq!(format_tick(1e-5), "10⁻⁵");
        assert_eq!(format_tick(2.5e7), "2.5×10⁷");
        assert_eq!(format_log_tick(1000.0), "10³");
        assert_eq!(format_log_tick(0.001), "10⁻³");
        assert_eq!(format_value(0.012345), "0.0123");
        assert_eq!(format_value(45.67), "45.7");
        assert_eq!(group_thousands(1_234_567), "1\u{2009}234\u{2009}567");
    }
}
