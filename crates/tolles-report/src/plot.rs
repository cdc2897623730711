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

use plotters::coord::types::RangedCoordf64;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

use crate::decimate::polylines;
pub use crate::numbers::{format_log_tick, format_tick, format_value, group_thousands};
use crate::ReportError;

mod bar;

/// Width of every plot (SVG pixels); the page scales it to the column.
pub const PLOT_WIDTH: u32 = 960;
/// Height of every plot (SVG pixels).
pub const PLOT_HEIGHT: u32 = 380;

/// The drawn size of a plot (SVG pixels); plots narrower than [`PlotSize::SMALL_BELOW`] get
/// smaller type and margins, as their page shows them near their own size.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct PlotSize {
    /// Width (SVG pixels).
    pub width: u32,
    /// Height (SVG pixels).
    pub height: u32,
}

impl PlotSize {
    /// [`PLOT_WIDTH`] × [`PLOT_HEIGHT`], a plot across the page's column.
    pub const FULL: PlotSize = PlotSize {
        width: PLOT_WIDTH,
        height: PLOT_HEIGHT,
    };
    /// A panel of a small multiple, three across the page's column.
    pub const SMALL: PlotSize = PlotSize {
        width: 320,
        height: 150,
    };
    /// Half the page's column.
    pub const HALF: PlotSize = PlotSize {
        width: 480,
        height: 300,
    };
    /// Plots narrower than this (SVG pixels) use small type.
    pub const SMALL_BELOW: u32 = 600;

    fn is_small(self) -> bool {
        self.width < Self::SMALL_BELOW
    }

    /// Tick-label and axis-description font sizes (pixels).
    fn fonts(self) -> (u32, u32) {
        if self.is_small() {
            (12, 13)
        } else {
            (17, 18)
        }
    }

    /// About how many labels the y axis gets: fewer on a short plot.
    fn y_label_count(self) -> usize {
        if self.height < 250 {
            4
        } else {
            7
        }
    }

    /// Heights of the x-label area and widths of the y-label area (pixels).
    fn label_areas(self) -> (u32, u32) {
        if self.is_small() {
            (34, 60)
        } else {
            (48, 78)
        }
    }
}

impl Default for PlotSize {
    fn default() -> Self {
        PlotSize::FULL
    }
}

/// How a [`Series`] is drawn.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum SeriesStyle {
    /// A line through the points (thinned per pixel column when long).
    #[default]
    Line,
    /// A filled marker at every point, none thinned: for a few dozen values.
    Points,
}

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
    /// A line or markers.
    pub style: SeriesStyle,
    /// Half-length of an error bar at each point (units of the y axis), as many as `y`;
    /// drawn for [`SeriesStyle::Points`] on a linear y axis. Empty: none.
    pub y_error: Vec<f64>,
    /// For an angle drawn within one turn (a heading in 0–360°, say): the period (units of
    /// the y axis). A line is broken where it jumps by more than half of it, so that a wrap
    /// from 359° to 0° is not drawn as a stroke across the plot. `None`: never broken.
    pub period: Option<f64>,
}

impl Series {
    /// A series named `name` with an automatic colour.
    pub fn new(name: impl Into<String>, x: Vec<f64>, y: Vec<f64>) -> Self {
        Series {
            name: name.into(),
            x,
            y,
            ..Series::default()
        }
    }

    /// The same series drawn in `colour`.
    pub fn colour(mut self, colour: Colour) -> Self {
        self.colour = Some(colour);
        self
    }

    /// The same series drawn as markers, with error bars of half-length `y_error` (units of
    /// the y axis; empty for none).
    pub fn points(mut self, y_error: Vec<f64>) -> Self {
        self.style = SeriesStyle::Points;
        self.y_error = y_error;
        self
    }

    /// The same series taken as an angle of `period` (units of the y axis): see
    /// [`Series::period`].
    pub fn circular(mut self, period: f64) -> Self {
        self.period = Some(period);
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
    /// Logarithmic x axis, decades labelled; values ≤ 0 are gaps.
    pub log_x: bool,
    /// Logarithmic y axis (for spectra), decades labelled; values ≤ 0 are gaps.
    pub log_y: bool,
    /// Shaded intervals of the x axis (pass bands, windows), drawn under the lines.
    pub spans: Vec<Span>,
    /// Fixed x range; `None` spans the finite data.
    pub x_range: Option<(f64, f64)>,
    /// Fixed y range; `None` spans the drawable data with a margin.
    pub y_range: Option<(f64, f64)>,
    /// A sentence shown under the plot.
    pub caption: Option<String>,
    /// Drawn size; the default is [`PlotSize::FULL`].
    pub size: PlotSize,
    /// Where the x axis is labelled (units of the x axis, linear axes only); empty: chosen
    /// from the range.
    pub x_ticks: Vec<f64>,
    /// Where the y axis is labelled, and with what text (linear axes only); empty: chosen
    /// from the range.
    pub y_ticks: Vec<(f64, String)>,
    /// Also drawn as a zoomable chart in the page (see [`crate::live`]), the SVG kept for
    /// printing and as the fallback; all series must share their x values. `None`: SVG only.
    pub live: Option<Live>,
}

/// What a live chart adds to its plot.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Live {
    /// Windows of the x axis shaded and labelled on the chart (maneuvers, say; units of x).
    pub windows: Vec<Span>,
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
    /// `(name, value per category)`; non-finite values (and values ≤ 0 on a log axis) draw
    /// no bar.
    pub series: Vec<BarSeries>,
    /// Logarithmic value axis, decades labelled, for values spanning decades; bars rise from
    /// the bottom of the axis.
    pub log_y: bool,
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
    /// The SVG's size.
    pub size: PlotSize,
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
        self.check_lengths()?;
        let legend: Vec<(String, Colour)> = self
            .series
            .iter()
            .map(|s| s.name.clone())
            .zip(colours(self.series.iter().map(|s| s.colour)))
            .collect();
        // Everything from here on is in axis units: log10 of the value on a log axis, where
        // undrawable values (≤ 0, non-finite) become NaN and so gaps.
        let on_axes: Vec<(Vec<f64>, Vec<f64>)> = self
            .series
            .iter()
            .map(|s| (to_axis(&s.x, self.log_x), to_axis(&s.y, self.log_y)))
            .collect();
        let mut notes = Vec::new();
        let fixed_x = self.x_range.and_then(|r| range_on_axis(r, self.log_x));
        let Some(x_range) = fixed_x.or_else(|| {
            extent(on_axes.iter().flat_map(drawn_x)).map(|r| axis_range(r, self.log_x, false))
        }) else {
            notes.push("No finite values to plot.".to_string());
            return Ok(RenderedPlot {
                svg: empty_svg(self.size),
                legend,
                notes,
                size: self.size,
            });
        };
        let y_range = self
            .y_range
            .and_then(|r| range_on_axis(r, self.log_y))
            .or_else(|| {
                let ends = on_axes
                    .iter()
                    .zip(&self.series)
                    .flat_map(|(xy, s)| self.error_ends(xy, s));
                extent(ends).map(|r| axis_range(r, self.log_y, true))
            })
            .unwrap_or((0.0, 1.0));

        let mut lines = Vec::new();
        let (mut total, mut drawn, mut gaps) = (0, 0, 0);
        for ((xy, series), (_, colour)) in on_axes.iter().zip(&self.series).zip(&legend) {
            let (x, y) = xy;
            let mut shape = Drawn {
                colour: *colour,
                runs: Vec::new(),
                points: Vec::new(),
            };
            match series.style {
                SeriesStyle::Line => {
                    let runs = polylines(x, y, x_range, self.size.width as usize, |_| true);
                    shape.runs = match series.period {
                        Some(period) => break_at_wraps(runs, period),
                        None => runs,
                    };
                    drawn += shape.runs.iter().map(Vec::len).sum::<usize>();
                }
                SeriesStyle::Points => {
                    shape.points = self.markers(xy, series);
                    drawn += shape.points.len();
                }
            }
            total += y.len();
            gaps += x
                .iter()
                .zip(y)
                .filter(|(x, y)| !(x.is_finite() && y.is_finite()))
                .count();
            lines.push(shape);
        }
        if drawn < total.saturating_sub(gaps) {
            notes.push(format!(
                "{} points drawn as {} (lowest and highest value per pixel column kept).",
                group_thousands(total - gaps),
                group_thousands(drawn)
            ));
        }
        if gaps > 0 {
            let what = if self.log_x || self.log_y {
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
            let size = (self.size.width, self.size.height);
            let root = SVGBackend::with_string(&mut svg, size).into_drawing_area();
            root.fill(&WHITE).map_err(|e| plot_error(&self.title, e))?;
            draw_lines(&root, x_range, y_range, self, &lines)
                .map_err(|e| plot_error(&self.title, e))?;
            root.present().map_err(|e| plot_error(&self.title, e))?;
        }
        Ok(RenderedPlot {
            svg,
            legend,
            notes,
            size: self.size,
        })
    }

    /// Every series has as many y values (and error bars, if any) as x values.
    fn check_lengths(&self) -> Result<(), ReportError> {
        for s in &self.series {
            let errors_fit = s.y_error.is_empty() || s.y_error.len() == s.y.len();
            if s.x.len() != s.y.len() || !errors_fit {
                return Err(ReportError::SeriesLength {
                    plot: self.title.clone(),
                    series: s.name.clone(),
                    x: s.x.len(),
                    y: if errors_fit {
                        s.y.len()
                    } else {
                        s.y_error.len()
                    },
                });
            }
        }
        Ok(())
    }

    /// The drawable points of a marker series (axis units) with their error bars' half-lengths
    /// (0 where there is none or the y axis is logarithmic).
    fn markers(&self, (x, y): &(Vec<f64>, Vec<f64>), series: &Series) -> Vec<(f64, f64, f64)> {
        (0..x.len())
            .filter(|&k| x[k].is_finite() && y[k].is_finite())
            .map(|k| {
                let error = series.y_error.get(k).copied().unwrap_or(0.0);
                let error = if self.log_y || !error.is_finite() {
                    0.0
                } else {
                    error.abs()
                };
                (x[k], y[k], error)
            })
            .collect()
    }

    /// The y values (axis units) the range must hold: every drawable value and, for markers,
    /// the ends of its error bar.
    fn error_ends(&self, xy: &(Vec<f64>, Vec<f64>), series: &Series) -> Vec<f64> {
        match series.style {
            SeriesStyle::Line => drawn_y(xy).collect(),
            SeriesStyle::Points => self
                .markers(xy, series)
                .into_iter()
                .flat_map(|(_, y, e)| [y - e, y + e])
                .collect(),
        }
    }
}

/// One series as drawn: line runs, or markers `(x, y, error half-length)` in axis units.
struct Drawn {
    colour: Colour,
    runs: Vec<Vec<(f64, f64)>>,
    points: Vec<(f64, f64, f64)>,
}

/// A shaded interval of the x axis with a label, such as a filter's pass band.
#[derive(Debug, Clone, PartialEq)]
pub struct Span {
    /// Text drawn at the top of the span.
    pub label: String,
    /// Start (units of the plot's x axis).
    pub from: f64,
    /// End (units of the plot's x axis).
    pub to: f64,
    /// Fill colour (drawn translucent).
    pub colour: Colour,
}

/// The values as placed on an axis: unchanged on a linear axis, log10 on a logarithmic one
/// (where values ≤ 0 become NaN, a gap); non-finite values stay non-finite.
fn to_axis(values: &[f64], log: bool) -> Vec<f64> {
    if !log {
        return values.to_vec();
    }
    values
        .iter()
        .map(|&v| if v > 0.0 { v.log10() } else { f64::NAN })
        .collect()
}

/// A fixed range (data units) on the axis; `None` if it cannot be drawn there.
fn range_on_axis((lo, hi): (f64, f64), log: bool) -> Option<(f64, f64)> {
    let r = to_axis(&[lo, hi], log);
    (r[0].is_finite() && r[1].is_finite() && r[0] < r[1]).then_some((r[0], r[1]))
}

fn drawn_points((x, y): &(Vec<f64>, Vec<f64>)) -> impl Iterator<Item = (f64, f64)> + '_ {
    x.iter()
        .zip(y)
        .filter(|(x, y)| x.is_finite() && y.is_finite())
        .map(|(x, y)| (*x, *y))
}

fn drawn_x(xy: &(Vec<f64>, Vec<f64>)) -> impl Iterator<Item = f64> + '_ {
    drawn_points(xy).map(|(x, _)| x)
}

fn drawn_y(xy: &(Vec<f64>, Vec<f64>)) -> impl Iterator<Item = f64> + '_ {
    drawn_points(xy).map(|(_, y)| y)
}

fn extent(values: impl Iterator<Item = f64>) -> Option<(f64, f64)> {
    min_max(values.filter(|v| v.is_finite()))
}

/// The axis range (axis units) for data spanning `(lo, hi)`: whole decades on a log axis, so
/// both ends carry a decade tick; a margin on a linear value axis (`pad`).
fn axis_range((lo, hi): (f64, f64), log: bool, pad: bool) -> (f64, f64) {
    if log {
        let (lo, hi) = (lo.floor(), hi.ceil());
        return if lo < hi {
            (lo, hi)
        } else {
            (lo - 1.0, hi + 1.0)
        };
    }
    if lo < hi {
        let margin = if pad { 0.06 * (hi - lo) } else { 0.0 };
        (lo - margin, hi + margin)
    } else if !pad {
        (lo - 0.5, hi + 0.5)
    } else {
        let margin = if lo == 0.0 { 1.0 } else { 0.1 * lo.abs() };
        (lo - margin, hi + margin)
    }
}

/// How many labels to ask of the mesh: on a log axis one per decade (at most 13, then every
/// second or fifth decade), so the ticks land on whole exponents.
fn label_count((lo, hi): (f64, f64), log: bool, linear: usize) -> usize {
    if log {
        ((hi - lo).round() as usize + 1).clamp(2, 13)
    } else {
        linear
    }
}

/// A tick label at axis position `v` of an axis spanning `range`: the value itself (a zero
/// that rounding left as 3×10⁻¹⁸ printed as 0), or `10ⁿ` on a log axis (nothing between
/// decades, where the mesh may put a grid line).
fn axis_tick(v: f64, log: bool, (lo, hi): (f64, f64)) -> String {
    if !log {
        let zero = v.abs() < 1e-9 * (hi - lo).abs();
        format_tick(if zero { 0.0 } else { v })
    } else if (v - v.round()).abs() < 1e-6 {
        format_log_tick(10f64.powi(v.round() as i32))
    } else {
        String::new()
    }
}

/// The y-label area's width (px) that keeps the axis title clear of the widest tick label:
/// the title's line, a gap, the widest label at 0.62 em a character, and the tick.
fn y_label_area(plot: &LinePlot, y_range: (f64, f64)) -> u32 {
    let (label_font, desc_font) = plot.size.fonts();
    let widest = match (plot.y_ticks.is_empty(), plot.log_y) {
        (false, false) => plot.y_ticks.iter().map(|(_, l)| l.chars().count()).max(),
        (_, true) => Some(4),
        (true, false) => widest_tick(y_range, plot.size.y_label_count()),
    };
    let label_px = 0.62 * f64::from(label_font) * widest.unwrap_or(1) as f64;
    (f64::from(desc_font) + 12.0 + label_px + 10.0).ceil() as u32
}

/// The characters of the widest label among the round ticks (1, 2 or 5 × 10ⁿ apart, about
/// `count` of them) that a linear axis over `lo..hi` shows.
fn widest_tick((lo, hi): (f64, f64), count: usize) -> Option<usize> {
    let rough = (hi - lo) / count.max(1) as f64;
    if !(rough.is_finite() && rough > 0.0) {
        return None;
    }
    let step = crate::numbers::nice_step(rough);
    let (first, last) = ((lo / step).ceil() as i64, (hi / step).floor() as i64);
    (first..=last.min(first + 50))
        .map(|k| axis_tick(k as f64 * step, false, (lo, hi)).chars().count())
        .max()
}

fn draw_lines<DB: DrawingBackend>(
    root: &DrawingArea<DB, plotters::coord::Shift>,
    x_range: (f64, f64),
    y_range: (f64, f64),
    plot: &LinePlot,
    lines: &[Drawn],
) -> Result<(), String> {
    let (label_font, desc_font) = plot.size.fonts();
    let (x_area, y_area) = plot.size.label_areas();
    let y_area = y_area.max(y_label_area(plot, y_range));
    let small = plot.size.is_small();
    let mut chart = ChartBuilder::on(root)
        .margin_top(if small { 8 } else { 14 })
        .margin_right(if small { 12 } else { 24 })
        .margin_left(if small { 4 } else { 8 })
        .margin_bottom(if small { 4 } else { 6 })
        .x_label_area_size(x_area)
        .y_label_area_size(y_area)
        .build_cartesian_2d(x_range.0..x_range.1, y_range.0..y_range.1)
        .map_err(|e| e.to_string())?;
    let fixed_ticks = !plot.x_ticks.is_empty() && !plot.log_x;
    let x_tick = |v: &f64| {
        if fixed_ticks {
            String::new()
        } else {
            axis_tick(*v, plot.log_x, x_range)
        }
    };
    let fixed_y_ticks = !plot.y_ticks.is_empty() && !plot.log_y;
    let y_tick = |v: &f64| {
        if fixed_y_ticks {
            String::new()
        } else {
            axis_tick(*v, plot.log_y, y_range)
        }
    };
    let x_count = if small { 5 } else { 9 };
    let mut mesh = chart.configure_mesh();
    mesh.x_desc(plot.x_label.as_str())
        .y_desc(plot.y_label.as_str())
        .x_labels(if fixed_ticks {
            0
        } else {
            label_count(x_range, plot.log_x, x_count)
        })
        .y_labels(if fixed_y_ticks {
            0
        } else {
            label_count(y_range, plot.log_y, plot.size.y_label_count())
        })
        .x_label_formatter(&x_tick)
        .y_label_formatter(&y_tick)
        .label_style((FONT, label_font).into_font().color(&MUTED))
        .axis_desc_style((FONT, desc_font).into_font().color(&INK))
        .bold_line_style(GRID)
        .light_line_style(TRANSPARENT)
        .axis_style(MUTED);
    if fixed_ticks {
        mesh.disable_x_mesh();
    }
    if fixed_y_ticks {
        mesh.disable_y_mesh();
    }
    mesh.draw().map_err(|e| e.to_string())?;
    if fixed_ticks {
        draw_x_ticks(root, &chart, x_range, y_range, plot)?;
    }
    if fixed_y_ticks {
        draw_y_ticks(root, &chart, x_range, y_range, plot)?;
    }
    draw_spans(&chart, x_range, y_range, plot)?;
    for shape in lines {
        draw_shape(root, &mut chart, shape, small)?;
    }
    draw_span_labels(root, &chart, x_range, y_range, plot)?;
    Ok(())
}

fn draw_shape<DB: DrawingBackend>(
    root: &DrawingArea<DB, plotters::coord::Shift>,
    chart: &mut Chart<DB>,
    shape: &Drawn,
    small: bool,
) -> Result<(), String> {
    let style = ShapeStyle::from(&shape.colour.rgb()).stroke_width(1);
    for run in &shape.runs {
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
    // Error bars in pixels: a vertical stroke with a cap at each end.
    let bar = ShapeStyle::from(&shape.colour.rgb()).stroke_width(2);
    let cap = if small { 4 } else { 6 };
    let area = chart.plotting_area();
    for &(x, y, error) in shape.points.iter().filter(|p| p.2 > 0.0) {
        let (px, top) = area.map_coordinate(&(x, y + error));
        let (_, bottom) = area.map_coordinate(&(x, y - error));
        for path in [
            vec![(px, top), (px, bottom)],
            vec![(px - cap, top), (px + cap, top)],
            vec![(px - cap, bottom), (px + cap, bottom)],
        ] {
            root.draw(&PathElement::new(path, bar))
                .map_err(|e| e.to_string())?;
        }
    }
    let radius = if small { 3 } else { 5 };
    chart
        .draw_series(
            shape
                .points
                .iter()
                .map(|&(x, y, _)| Circle::new((x, y), radius, style.filled())),
        )
        .map_err(|e| e.to_string())?;
    Ok(())
}

/// Grid lines and labels at the plot's own x ticks (those inside the range).
fn draw_x_ticks<DB: DrawingBackend>(
    root: &DrawingArea<DB, plotters::coord::Shift>,
    chart: &Chart<DB>,
    x_range: (f64, f64),
    (y0, y1): (f64, f64),
    plot: &LinePlot,
) -> Result<(), String> {
    let area = chart.plotting_area();
    let (label_font, _) = plot.size.fonts();
    let inside = |v: &&f64| (x_range.0..=x_range.1).contains(*v);
    for &tick in plot.x_ticks.iter().filter(inside) {
        area.draw(&PathElement::new([(tick, y0), (tick, y1)], GRID))
            .map_err(|e| e.to_string())?;
        let (px, py) = area.map_coordinate(&(tick, y0));
        let style = TextStyle::from((FONT, label_font).into_font())
            .color(&MUTED)
            .pos(Pos::new(HPos::Center, VPos::Top));
        root.draw(&Text::new(format_tick(tick), (px, py + 6), style))
            .map_err(|e| e.to_string())?;
    }
    Ok(())
}

/// Grid lines and labels at the plot's own y ticks (those inside the range).
fn draw_y_ticks<DB: DrawingBackend>(
    root: &DrawingArea<DB, plotters::coord::Shift>,
    chart: &Chart<DB>,
    (x0, x1): (f64, f64),
    y_range: (f64, f64),
    plot: &LinePlot,
) -> Result<(), String> {
    let area = chart.plotting_area();
    let (label_font, _) = plot.size.fonts();
    let inside = |tick: &&(f64, String)| (y_range.0..=y_range.1).contains(&tick.0);
    for (tick, label) in plot.y_ticks.iter().filter(inside) {
        area.draw(&PathElement::new([(x0, *tick), (x1, *tick)], GRID))
            .map_err(|e| e.to_string())?;
        let (px, py) = area.map_coordinate(&(x0, *tick));
        let style = TextStyle::from((FONT, label_font).into_font())
            .color(&MUTED)
            .pos(Pos::new(HPos::Right, VPos::Center));
        root.draw(&Text::new(label.clone(), (px - 6, py), style))
            .map_err(|e| e.to_string())?;
    }
    Ok(())
}

/// Splits each run where consecutive points differ by more than half a `period`: an angle
/// that wraps (359° to 0°) is two strokes, not one across the plot.
fn break_at_wraps(runs: Vec<Vec<(f64, f64)>>, period: f64) -> Vec<Vec<(f64, f64)>> {
    let mut out = Vec::with_capacity(runs.len());
    for run in runs {
        let mut piece: Vec<(f64, f64)> = Vec::with_capacity(run.len());
        for point in run {
            if piece
                .last()
                .is_some_and(|last| (point.1 - last.1).abs() > period / 2.0)
            {
                out.push(std::mem::take(&mut piece));
            }
            piece.push(point);
        }
        out.push(piece);
    }
    out
}

type Chart<'a, DB> = ChartContext<'a, DB, Cartesian2d<RangedCoordf64, RangedCoordf64>>;

/// Each span clipped to the x range, in plot units; spans wholly outside are left out.
fn visible_spans(plot: &LinePlot, x_range: (f64, f64)) -> Vec<(&Span, f64, f64)> {
    (plot.spans.iter())
        .filter_map(|span| {
            let (from, to) = range_on_axis((span.from, span.to), plot.log_x)?;
            let (from, to) = (from.max(x_range.0), to.min(x_range.1));
            (from < to).then_some((span, from, to))
        })
        .collect()
}

/// Shades each span (clipped to the x range), under the lines.
fn draw_spans<DB: DrawingBackend>(
    chart: &Chart<DB>,
    x_range: (f64, f64),
    (y0, y1): (f64, f64),
    plot: &LinePlot,
) -> Result<(), String> {
    for (span, from, to) in visible_spans(plot, x_range) {
        let fill = span.colour.rgb().mix(0.13).filled();
        (chart.plotting_area())
            .draw(&Rectangle::new([(from, y0), (to, y1)], fill))
            .map_err(|e| e.to_string())?;
    }
    Ok(())
}

/// Writes each span's label at its top left, one line lower per span so that overlapping
/// spans keep readable labels, over the lines on a white patch: a trace never crosses a label.
fn draw_span_labels<DB: DrawingBackend>(
    root: &DrawingArea<DB, plotters::coord::Shift>,
    chart: &Chart<DB>,
    x_range: (f64, f64),
    (_, y1): (f64, f64),
    plot: &LinePlot,
) -> Result<(), String> {
    let labelled =
        (visible_spans(plot, x_range).into_iter()).filter(|(s, _, _)| !s.label.is_empty());
    for (row, (span, from, _)) in labelled.enumerate() {
        let (px, py) = chart.plotting_area().map_coordinate(&(from, y1));
        let (x, y) = (px + 5, py + 5 + 19 * row as i32);
        // Wide enough for the font's widest digits and letters at 15 px.
        let width = (8.5 * span.label.chars().count() as f64).ceil() as i32;
        let patch = WHITE.mix(0.85).filled();
        root.draw(&Rectangle::new(
            [(x - 2, y - 1), (x + width, y + 17)],
            patch,
        ))
        .map_err(|e| e.to_string())?;
        let ink = span.colour.rgb();
        let style = TextStyle::from((FONT, 15).into_font()).color(&ink);
        root.draw(&Text::new(span.label.clone(), (x, y), style))
            .map_err(|e| e.to_string())?;
    }
    Ok(())
}

fn min_max(values: impl Iterator<Item = f64>) -> Option<(f64, f64)> {
    values.fold(None, |acc, v| match acc {
        None => Some((v, v)),
        Some((lo, hi)) => Some((lo.min(v), hi.max(v))),
    })
}

fn empty_svg(size: PlotSize) -> String {
    let PlotSize { width, height } = size;
    format!(
        "<svg width=\"{width}\" height=\"{height}\" viewBox=\"0 0 {width} {height}\" \
         xmlns=\"http://www.w3.org/2000/svg\"><rect width=\"100%\" height=\"100%\" fill=\"#fafafa\"/>\
         <text x=\"50%\" y=\"50%\" text-anchor=\"middle\" font-family=\"sans-serif\" font-size=\"16\" \
         fill=\"#666\">no data</text></svg>\n"
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn axis_ranges_cover_the_data_with_a_margin() {
        let s = (vec![0.0, 1.0, 2.0], vec![0.02, f64::NAN, 299.0]);
        let log = (s.0.clone(), to_axis(&s.1, true));
        let y = extent(drawn_y(&log)).unwrap();
        assert_eq!(axis_range(y, true, true), (-2.0, 3.0));
        let (lo, hi) = axis_range(extent(drawn_y(&s)).unwrap(), false, true);
        assert!(lo < 0.02 && hi > 299.0 && hi < 320.0);
        assert_eq!(extent(drawn_x(&s)), Some((0.0, 2.0)));
        assert_eq!(axis_range((5.0, 5.0), false, false), (4.5, 5.5));
        let (lo, hi) = axis_range((7.0, 7.0), false, true);
        assert!(lo < 7.0 && hi > 7.0);
        // Axis units are exponents: 10^0.5 sits within one decade, 10^1 alone gets one each side.
        assert_eq!(axis_range((0.5, 0.5), true, true), (0.0, 1.0));
        assert_eq!(axis_range((1.0, 1.0), true, true), (0.0, 2.0));
    }

    #[test]
    fn a_log_axis_skips_nonpositive_values() {
        let on_axis = to_axis(&[100.0, 0.0, -3.0, f64::NAN, 0.01], true);
        assert_eq!(on_axis[0], 2.0);
        assert!(on_axis[1..4].iter().all(|v| v.is_nan()));
        assert!((on_axis[4] + 2.0).abs() < 1e-12);
        assert_eq!(range_on_axis((0.0, 10.0), true), None);
        assert_eq!(range_on_axis((1.0, 1000.0), true), Some((0.0, 3.0)));
    }

    fn psd_plot(log_x: bool) -> LinePlot {
        let f: Vec<f64> = (0..200).map(|k| k as f64 * 0.05).collect();
        // Bin 0 (f = 0) and a zero density cannot sit on log axes.
        let mut psd: Vec<f64> = f.iter().map(|f| 1e-3 / (f * f + 1e-2)).collect();
        psd[7] = 0.0;
        LinePlot {
            title: "psd".into(),
            series: vec![Series::new("psd", f, psd)],
            log_x,
            log_y: true,
            spans: vec![Span {
                label: "fit band".into(),
                from: 0.1,
                to: 0.9,
                colour: Colour::REFERENCE,
            }],
            ..LinePlot::default()
        }
    }

    /// The text of every `<text>` element of an SVG.
    fn texts(svg: &str) -> Vec<String> {
        svg.split("<text")
            .skip(1)
            .filter_map(|t| {
                Some(
                    t.split_once('>')?
                        .1
                        .split_once("</text>")?
                        .0
                        .trim()
                        .to_string(),
                )
            })
            .collect()
    }

    #[test]
    fn log_axes_are_labelled_at_decades_only() {
        let plot = psd_plot(true).to_svg().unwrap();
        let labels = texts(&plot.svg);
        // x from 0.05 to 9.95 Hz: decades 10⁻² to 10¹; y from 1e-3 / 99 to 0.1.
        for decade in ["10⁻²", "10⁻¹", "10⁰", "10¹", "10⁻⁵", "10⁻¹"] {
            assert!(labels.iter().any(|l| l == decade), "{decade} in {labels:?}");
        }
        // Nothing but powers of ten, the span's label and the empty axis descriptions.
        let other: Vec<&String> = labels
            .iter()
            .filter(|l| !(l.starts_with("10") || *l == "fit band" || l.is_empty()))
            .collect();
        assert!(other.is_empty(), "{other:?}");
        // f = 0 and the zero density are the gaps.
        assert!(plot
            .notes
            .iter()
            .any(|n| n.starts_with("2 non-finite or non-positive")));
    }

    #[test]
    fn spans_are_shaded_and_labelled() {
        let plot = psd_plot(true).to_svg().unwrap();
        assert!(texts(&plot.svg).iter().any(|l| l == "fit band"));
        assert!(plot.svg.contains("opacity=\"0.13"), "no translucent span");
        let mut outside = psd_plot(true);
        outside.spans[0].from = 20.0;
        outside.spans[0].to = 30.0;
        assert!(!texts(&outside.to_svg().unwrap().svg)
            .iter()
            .any(|l| l == "fit band"));
    }

    #[test]
    fn all_nonpositive_on_a_log_axis_is_no_data_not_a_panic() {
        let mut plot = psd_plot(false);
        plot.series[0].y = vec![0.0; 200];
        let drawn = plot.to_svg().unwrap();
        assert!(drawn.svg.contains("no data"));
        let bars = BarChart {
            categories: vec!["a".into(), "b".into()],
            series: vec![BarSeries::new("x", vec![0.0, -1.0])],
            log_y: true,
            ..BarChart::default()
        };
        let drawn = bars.to_svg().unwrap();
        assert!(drawn.notes[0].starts_with("2 values are not finite or not positive"));
    }

    #[test]
    fn bars_spanning_decades_get_a_log_axis_and_labels_that_do_not_collide() {
        let categories: Vec<String> = (0..12).map(|k| format!("pitch {:03}°", k * 90)).collect();
        let before: Vec<f64> = (0..12).map(|k| 20.0 + k as f64).collect();
        let after: Vec<f64> = (0..12).map(|k| 0.02 + 0.01 * k as f64).collect();
        let chart = BarChart {
            categories: categories.clone(),
            series: vec![
                BarSeries::new("before", before),
                BarSeries::new("after", after),
            ],
            log_y: true,
            ..BarChart::default()
        };
        let svg = chart.to_svg().unwrap().svg;
        let labels = texts(&svg);
        for decade in ["10⁻²", "10⁻¹", "10⁰", "10¹", "10²"] {
            assert!(labels.iter().any(|l| l == decade), "{decade} in {labels:?}");
        }
        // Twelve names are too wide to sit level in their slots, so they are turned.
        // (and so is the y-axis description).
        assert_eq!(svg.matches("rotate(270").count(), 12 + 1);
        // A value is written only over a bar as wide as its text: "20" fits, "0.02" does not.
        assert!(labels.iter().any(|l| l == "20"));
        assert!(!labels.iter().any(|l| l == "0.02"));
        let few = BarChart {
            categories: vec!["a".into(), "b".into()],
            series: vec![BarSeries::new("x", vec![0.5, 50.0])],
            log_y: true,
            ..BarChart::default()
        };
        let labels = texts(&few.to_svg().unwrap().svg);
        assert!(labels.iter().any(|l| l == "0.5") && labels.iter().any(|l| l == "a"));
    }

    /// Three levels against heading with error bars, on the axis a heading plot uses.
    fn heading_points() -> LinePlot {
        LinePlot {
            title: "levels".into(),
            series: vec![Series::new(
                "level",
                vec![0.0, 90.0, f64::NAN, 270.0],
                vec![1.5, -0.5, 3.0, -1.0],
            )
            .colour(Colour::COMPENSATED)
            .points(vec![0.2, 0.3, 0.1, 0.25])],
            x_range: Some((0.0, 360.0)),
            x_ticks: vec![0.0, 90.0, 180.0, 270.0, 360.0],
            size: PlotSize::HALF,
            ..LinePlot::default()
        }
    }

    #[test]
    fn points_are_markers_with_error_bars_and_no_line() {
        let plot = heading_points().to_svg().unwrap();
        let fill = format!("fill=\"{}\"", Colour::COMPENSATED.css().to_uppercase());
        let markers = plot
            .svg
            .lines()
            .filter(|l| l.starts_with("<circle") && l.contains(&fill))
            .count();
        // The point without a heading is left out, not drawn at NaN.
        assert_eq!(markers, 3, "{}", plot.svg);
        let stroke = format!("stroke=\"{}\"", Colour::COMPENSATED.css().to_uppercase());
        let strokes = plot.svg.lines().filter(|l| l.contains(&stroke)).count();
        // A bar and two caps per point, and no line joining the points.
        assert_eq!(strokes, 3 * 3, "{}", plot.svg);
        assert!(!plot.svg.contains("NaN"));
        assert!(plot.svg.starts_with("<svg width=\"480\" height=\"300\""));
        // The range holds the error bars: 1.5 + 0.2 stays inside.
        let mut tight = heading_points();
        tight.series[0].y_error = vec![10.0; 4];
        let labels = texts(&tight.to_svg().unwrap().svg);
        assert!(labels.iter().any(|l| l == "10"), "{labels:?}");
    }

    #[test]
    fn fixed_x_ticks_label_exactly_those_values() {
        let labels = texts(&heading_points().to_svg().unwrap().svg);
        for tick in ["0", "90", "180", "270", "360"] {
            assert!(labels.iter().any(|l| l == tick), "{tick} in {labels:?}");
        }
        for automatic in ["50", "100", "200", "300"] {
            assert!(!labels.iter().any(|l| l == automatic), "{automatic}");
        }
    }

    #[test]
    fn a_span_label_is_written_over_the_lines_on_a_white_patch() {
        let x: Vec<f64> = (0..100).map(f64::from).collect();
        let plot = LinePlot {
            series: vec![Series::new("s", x.clone(), vec![1.0; 100])],
            spans: vec![Span {
                label: "FOM band".into(),
                from: 10.0,
                to: 50.0,
                colour: Colour::UNCOMPENSATED,
            }],
            ..LinePlot::default()
        };
        let svg = plot.to_svg().unwrap().svg;
        let line = svg
            .find("<polyline fill=\"none\" opacity=\"1\" stroke=\"#0072B2\"")
            .unwrap();
        let label = svg.find("FOM band").unwrap();
        assert!(line < label, "the label is under the line");
        let patch = svg[..label].rfind("<rect").unwrap();
        assert!(patch > line && svg[patch..label].contains("fill=\"#FFFFFF\""));
    }

    #[test]
    fn the_y_axis_title_clears_its_widest_tick_label() {
        let plot = LinePlot::default();
        // ±30 nT: "-30", the fixed area suffices; ±0.0012 nT: "-0.0012" needs more.
        assert!(y_label_area(&plot, (-30.0, 30.0)) <= plot.size.label_areas().1);
        assert_eq!(widest_tick((-0.0012, 0.0012), 7), Some(7));
        assert!(y_label_area(&plot, (-0.0012, 0.0012)) > plot.size.label_areas().1);
    }

    #[test]
    fn an_angle_that_wraps_is_two_strokes() {
        let runs = vec![vec![(0.0, 350.0), (1.0, 359.0), (2.0, 1.0), (3.0, 4.0)]];
        let broken = break_at_wraps(runs.clone(), 360.0);
        assert_eq!(
            broken,
            vec![
                vec![(0.0, 350.0), (1.0, 359.0)],
                vec![(2.0, 1.0), (3.0, 4.0)]
            ]
        );
        // A turn of 170° between two points is a turn, not a wrap.
        let turn = vec![vec![(0.0, 10.0), (1.0, 180.0)]];
        assert_eq!(break_at_wraps(turn.clone(), 360.0), turn);
    }

    #[test]
    fn fixed_y_ticks_carry_their_own_labels() {
        let plot = LinePlot {
            series: vec![Series::new("yaw", vec![0.0, 1.0], vec![100.0, 300.0]).circular(360.0)],
            y_range: Some((45.0, 405.0)),
            y_ticks: vec![
                (90.0, "E".into()),
                (360.0, "N".into()),
                (500.0, "out".into()),
            ],
            ..LinePlot::default()
        };
        let labels = texts(&plot.to_svg().unwrap().svg);
        assert!(labels.iter().any(|l| l == "E") && labels.iter().any(|l| l == "N"));
        assert!(
            !labels.iter().any(|l| l == "out" || l == "100"),
            "{labels:?}"
        );
    }

    #[test]
    fn mismatched_error_bars_are_an_error() {
        let mut plot = heading_points();
        plot.series[0].y_error.pop();
        assert!(matches!(
            plot.to_svg(),
            Err(ReportError::SeriesLength { x: 4, y: 3, .. })
        ));
    }

    #[test]
    fn a_rounded_zero_tick_reads_0() {
        assert_eq!(axis_tick(3.47e-18, false, (-0.02, 0.015)), "0");
        assert_eq!(axis_tick(1e-5, false, (-1e-4, 1e-4)), "10⁻⁵");
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
