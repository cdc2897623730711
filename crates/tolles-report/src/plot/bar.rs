//! Drawing a [`BarChart`]: grouped bars with their values over them and category names
//! under them (heights in the chart's units, nT for the FOM's maneuvers).

use super::*;

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
        let drawable = |v: f64| v.is_finite() && (!self.log_y || v > 0.0);
        let missing = values().filter(|v| !drawable(*v)).count();
        let mut notes = Vec::new();
        if missing > 0 {
            let (values, are, have) = if missing == 1 {
                ("value", "is", "has")
            } else {
                ("values", "are", "have")
            };
            let what = if self.log_y {
                "not finite or not positive (the axis is logarithmic)"
            } else {
                "not finite"
            };
            notes.push(format!(
                "{missing} {values} {are} {what} and {have} no bar."
            ));
        }
        if self.categories.is_empty() || self.series.is_empty() {
            notes.push("No values to plot.".to_string());
            return Ok(RenderedPlot {
                svg: empty_svg(PlotSize::FULL),
                legend,
                notes,
                size: PlotSize::FULL,
            });
        }
        let y_range = self.y_range(values().filter(|v| drawable(*v)));
        let mut svg = String::new();
        {
            let root =
                SVGBackend::with_string(&mut svg, (PLOT_WIDTH, PLOT_HEIGHT)).into_drawing_area();
            root.fill(&WHITE).map_err(|e| plot_error(&self.title, e))?;
            self.draw_bars(&root, y_range, &legend)
                .map_err(|e| plot_error(&self.title, e))?;
            root.present().map_err(|e| plot_error(&self.title, e))?;
        }
        Ok(RenderedPlot {
            svg,
            legend,
            notes,
            size: PlotSize::FULL,
        })
    }

    /// The value axis (axis units) for the drawable values: whole decades on a log axis, else
    /// from zero (or below the lowest negative bar) to above the highest.
    fn y_range(&self, values: impl Iterator<Item = f64>) -> (f64, f64) {
        if self.log_y {
            let exponents = values.map(f64::log10);
            return extent(exponents).map_or((0.0, 1.0), |r| axis_range(r, true, false));
        }
        let (lo, hi) = min_max(values).unwrap_or((0.0, 1.0));
        let (lo, hi) = (lo.min(0.0), hi.max(0.0));
        let span = if hi > lo { hi - lo } else { 1.0 };
        (
            if lo < 0.0 { lo - 0.08 * span } else { 0.0 },
            if hi > 0.0 || lo == hi {
                hi + 0.1 * span
            } else {
                0.0
            },
        )
    }

    fn draw_bars<DB: DrawingBackend>(
        &self,
        root: &DrawingArea<DB, plotters::coord::Shift>,
        (y0, y1): (f64, f64),
        legend: &[(String, Colour)],
    ) -> Result<(), String> {
        let n = self.categories.len();
        let layout = CategoryLayout::new(&self.categories);
        let mut chart = ChartBuilder::on(root)
            .margin_top(14)
            .margin_right(24)
            .margin_left(8)
            .margin_bottom(6)
            .x_label_area_size(layout.area_height)
            .y_label_area_size(78)
            // A segmented 0..m has m + 1 segments, one per category here.
            .build_cartesian_2d((0..n as i32 - 1).into_segmented(), y0..y1)
            .map_err(|e| e.to_string())?;
        // Category names are drawn below (they may need turning); the mesh gives the grid.
        let no_label = |_: &SegmentValue<i32>| String::new();
        let tick = |v: &f64| axis_tick(*v, self.log_y, (y0, y1));
        chart
            .configure_mesh()
            .disable_x_mesh()
            .y_desc(self.y_label.as_str())
            .x_labels(n)
            .y_labels(label_count((y0, y1), self.log_y, 7))
            .x_label_formatter(&no_label)
            .y_label_formatter(&tick)
            .label_style((FONT, 17).into_font().color(&MUTED))
            .axis_desc_style((FONT, 18).into_font().color(&INK))
            .bold_line_style(GRID)
            .light_line_style(TRANSPARENT)
            .axis_style(MUTED)
            .draw()
            .map_err(|e| e.to_string())?;

        let area = chart.plotting_area();
        let x_at = |i: usize| area.map_coordinate(&(SegmentValue::Exact(i as i32), y0)).0 as f64;
        let slot = x_at(1) - x_at(0);
        layout.draw(
            root,
            area.map_coordinate(&(SegmentValue::Exact(0), y0)).1,
            slot,
            x_at,
        )?;
        let bar_width = slot * 0.72 / self.series.len() as f64;
        // A value is written over its bar only where it fits the bar's width.
        let value_fits = |text: &str| text_width(text, VALUE_FONT) <= bar_width + 4.0;
        let base_value = if self.log_y { y0 } else { 0.0 };
        for i in 0..n {
            let start = x_at(i) + slot * 0.14;
            for (k, (s, (_, colour))) in self.series.iter().zip(legend).enumerate() {
                let v = s.values[i];
                let Some(at) = self.on_axis(v) else {
                    continue;
                };
                let base = area.map_coordinate(&(SegmentValue::Exact(0), base_value)).1;
                let top = area.map_coordinate(&(SegmentValue::Exact(0), at)).1;
                let x0 = (start + k as f64 * bar_width + 1.0).round() as i32;
                let x1 = (start + (k + 1) as f64 * bar_width - 1.0).round() as i32;
                root.draw(&Rectangle::new(
                    [(x0, top.min(base)), (x1.max(x0 + 1), top.max(base))],
                    colour.rgb().filled(),
                ))
                .map_err(|e| e.to_string())?;
                let text = format_value(v);
                if value_fits(&text) {
                    let y = if at >= base_value { top - 6 } else { top + 16 };
                    let style = TextStyle::from((FONT, VALUE_FONT).into_font())
                        .color(&INK)
                        .pos(Pos::new(HPos::Center, VPos::Bottom));
                    root.draw(&Text::new(text, ((x0 + x1) / 2, y), style))
                        .map_err(|e| e.to_string())?;
                }
            }
        }
        Ok(())
    }

    /// Where `v` sits on the value axis; `None` if it has no bar.
    fn on_axis(&self, v: f64) -> Option<f64> {
        let at = to_axis(&[v], self.log_y)[0];
        at.is_finite().then_some(at)
    }
}

const VALUE_FONT: f64 = 16.0;
const CATEGORY_FONT: f64 = 16.0;

/// Rough width (pixels) of `text` in the sans-serif font at `size` pixels: enough to tell
/// whether labels would collide.
fn text_width(text: &str, size: f64) -> f64 {
    text.chars().count() as f64 * 0.58 * size
}

/// How the category names go under the bars: level when every name fits its slot, else
/// turned to read upwards so that neighbours cannot overlap.
struct CategoryLayout<'a> {
    names: &'a [String],
    turned: bool,
    /// Height (pixels) of the label area under the axis.
    area_height: u32,
}

impl<'a> CategoryLayout<'a> {
    fn new(names: &'a [String]) -> Self {
        let plot_width = f64::from(PLOT_WIDTH) - 110.0;
        let slot = plot_width / names.len().max(1) as f64;
        let widest = names
            .iter()
            .map(|n| text_width(n, CATEGORY_FONT))
            .fold(0.0, f64::max);
        let turned = widest > slot * 0.92;
        let area_height = if turned {
            // `text_width` errs wide so that level labels never touch; a turned label's
            // room need not.
            (0.8 * widest + 14.0).clamp(40.0, 160.0) as u32
        } else {
            40
        };
        CategoryLayout {
            names,
            turned,
            area_height,
        }
    }

    fn draw<DB: DrawingBackend>(
        &self,
        root: &DrawingArea<DB, plotters::coord::Shift>,
        axis_y: i32,
        slot: f64,
        x_at: impl Fn(usize) -> f64,
    ) -> Result<(), String> {
        for (i, name) in self.names.iter().enumerate() {
            let centre = (x_at(i) + slot / 2.0).round() as i32;
            let font = (FONT, CATEGORY_FONT).into_font();
            let style = if self.turned {
                // Turned a quarter anticlockwise and anchored at its end: reads upwards and
                // ends just under the axis.
                TextStyle::from(font.transform(FontTransform::Rotate270))
                    .color(&INK)
                    .pos(Pos::new(HPos::Right, VPos::Center))
            } else {
                TextStyle::from(font)
                    .color(&INK)
                    .pos(Pos::new(HPos::Center, VPos::Top))
            };
            root.draw(&Text::new(name.clone(), (centre, axis_y + 8), style))
                .map_err(|e| e.to_string())?;
        }
        Ok(())
    }
}
