//! Self-contained HTML reports: headings, prose, key–value lists, tables, line plots and bar
//! charts, written as `DIR/index.html` with every plot an SVG file in `DIR/plots/`.
//!
//! ```
//! use tolles_report::{Report, plot::{LinePlot, Series, Colour}};
//! let dir = std::env::temp_dir().join(format!("tolles-report-doc-{}", std::process::id()));
//! let t: Vec<f64> = (0..1000).map(|k| k as f64 * 0.1).collect();
//! let index = Report::new("Calibration flight 1002")
//!     .summary(&[("noise before", "4.1 nT"), ("noise after", "0.08 nT")])
//!     .section("Signals")
//!     .paragraph("Scalar magnetometer before and after compensation.")
//!     .line_plot(LinePlot {
//!         title: "Scalar field".into(),
//!         x_label: "time (s)".into(),
//!         y_label: "anomaly (nT)".into(),
//!         series: vec![Series::new("compensated", t.clone(), t.iter().map(|v| v.sin()).collect())
//!             .colour(Colour::COMPENSATED)],
//!         ..LinePlot::default()
//!     })
//!     .table(&["term", "value (nT)"], &[vec!["permanent x".into(), "12.5".into()]])
//!     .write(&dir)
//!     .unwrap();
//! assert!(index.ends_with("index.html"));
//! assert!(dir.join("plots/01-scalar-field.svg").is_file());
//! # std::fs::remove_dir_all(&dir).unwrap();
//! ```
//!
//! The page needs no network: the style sheet and a small self-check script are inline, fonts
//! are the system's, and plots are local files. Every text is HTML-escaped. Long series are
//! thinned per pixel column ([`decimate`]) so each SVG stays small; gaps (NaN) break lines.
//! The self-check writes `ok N images` (or `broken: …`) into `<div id="tolles-check">` once
//! the page has loaded; `scripts/check-report` reads it from headless Chromium.
//!
//! [`flight`] lays out the compensation report of a flight from what
//! [`tolles::report::build`] computes.

pub mod decimate;
pub mod export;
pub mod flight;
pub mod html;
pub mod live;
pub mod map;
pub mod numbers;
mod part;
pub mod plot;
pub mod stream_page;

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use html::{escape, is_numeric, slug};
use plot::{BarChart, LinePlot, RenderedPlot};

/// Why a report could not be written.
#[derive(Debug, thiserror::Error)]
pub enum ReportError {
    /// A file or directory could not be created or written.
    #[error("cannot write {path}: {source}")]
    Io {
        /// The path that failed.
        path: PathBuf,
        /// The operating system's reason.
        source: std::io::Error,
    },
    /// A series has a different number of x and y values (or of values and categories).
    #[error("plot '{plot}', series '{series}': {x} x values (or categories) but {y} values")]
    SeriesLength {
        /// Title of the plot.
        plot: String,
        /// Name of the series.
        series: String,
        /// Number of x values (line plot) or categories (bar chart).
        x: usize,
        /// Number of y values.
        y: usize,
    },
    /// The plotting library failed.
    #[error("plot '{title}': {message}")]
    Plot {
        /// Title of the plot.
        title: String,
        /// What went wrong.
        message: String,
    },
}

/// One element of the page, in order.
#[derive(Debug, Clone, PartialEq)]
enum Block {
    Section(String),
    Paragraph(String),
    KeyValues(Vec<(String, String)>),
    Table {
        headers: Vec<String>,
        rows: Vec<Vec<String>>,
    },
    LinePlot(LinePlot),
    BarChart(BarChart),
    Image {
        src: String,
        alt: String,
    },
    Grid(Vec<GridCell>),
}

/// One figure of a grid of small figures (see [`Report::grid`]): a heading, plots stacked
/// beneath it (usually [`plot::PlotSize::SMALL`]) and a caption.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct GridCell {
    /// Heading of the figure.
    pub title: String,
    /// The plots, top to bottom; each plot's title names its file and is its alt text.
    pub plots: Vec<LinePlot>,
    /// A sentence under the plots.
    pub caption: Option<String>,
}

/// A report being assembled; [`Report::write`] renders it.
#[derive(Debug, Clone, PartialEq)]
pub struct Report {
    title: String,
    subtitle: Option<String>,
    provenance: Option<String>,
    summary: Vec<(String, String)>,
    summary_notes: Vec<String>,
    blocks: Vec<Block>,
    paper: tolles::report::Paper,
}

fn owned_pairs(pairs: &[(&str, &str)]) -> Vec<(String, String)> {
    pairs
        .iter()
        .map(|(k, v)| (k.to_string(), v.to_string()))
        .collect()
}

impl Report {
    /// An empty report titled `title`.
    pub fn new(title: impl Into<String>) -> Self {
        Report {
            title: title.into(),
            subtitle: None,
            provenance: None,
            summary: Vec::new(),
            summary_notes: Vec::new(),
            blocks: Vec::new(),
            paper: tolles::report::Paper::A4,
        }
    }

    /// The printed page's size (A4 unless changed).
    pub fn paper(mut self, paper: tolles::report::Paper) -> Self {
        self.paper = paper;
        self
    }

    /// A line of prose under the title.
    pub fn subtitle(mut self, text: impl Into<String>) -> Self {
        self.subtitle = Some(text.into());
        self
    }

    /// Where the page comes from (tool version, date, input files), under the subtitle, so a
    /// printed page says it too.
    pub fn provenance(mut self, text: impl Into<String>) -> Self {
        self.provenance = Some(text.into());
        self
    }

    /// Headline figures shown as cards in the page header, `(label, value with units)`.
    pub fn summary(mut self, items: &[(&str, &str)]) -> Self {
        self.summary.extend(owned_pairs(items));
        self
    }

    /// A sentence under the summary cards, to define what their figures are.
    pub fn summary_note(mut self, text: impl Into<String>) -> Self {
        self.summary_notes.push(text.into());
        self
    }

    /// Starts a section headed `heading` (listed in the table of contents).
    pub fn section(mut self, heading: impl Into<String>) -> Self {
        self.blocks.push(Block::Section(heading.into()));
        self
    }

    /// A paragraph of plain text.
    pub fn paragraph(mut self, text: impl Into<String>) -> Self {
        self.blocks.push(Block::Paragraph(text.into()));
        self
    }

    /// A two-column list of `(name, value with units)`.
    pub fn key_values(mut self, items: &[(&str, &str)]) -> Self {
        self.blocks.push(Block::KeyValues(owned_pairs(items)));
        self
    }

    /// A table; numeric cells are right-aligned.
    pub fn table(mut self, headers: &[&str], rows: &[Vec<String>]) -> Self {
        self.blocks.push(Block::Table {
            headers: headers.iter().map(|h| h.to_string()).collect(),
            rows: rows.to_vec(),
        });
        self
    }

    /// A line plot (see [`LinePlot`]).
    pub fn line_plot(mut self, plot: LinePlot) -> Self {
        self.blocks.push(Block::LinePlot(plot));
        self
    }

    /// A bar chart (see [`BarChart`]).
    pub fn bar_chart(mut self, chart: BarChart) -> Self {
        self.blocks.push(Block::BarChart(chart));
        self
    }

    /// Small figures side by side, as many to a row as fit the page (one on a narrow screen);
    /// each cell as wide as its widest plot at most.
    pub fn grid(mut self, cells: Vec<GridCell>) -> Self {
        self.blocks.push(Block::Grid(cells));
        self
    }

    /// An image the caller places in the report directory, referenced by the relative URL
    /// `src` (e.g. `figures/map.png`); `alt` describes it for readers who cannot see it.
    pub fn image(mut self, src: impl Into<String>, alt: impl Into<String>) -> Self {
        self.blocks.push(Block::Image {
            src: src.into(),
            alt: alt.into(),
        });
        self
    }

    /// Writes `dir/index.html` and `dir/plots/NN-title.svg` (creating the directories) and
    /// returns the path of `index.html`. Existing files of the same names are replaced; other
    /// files in `dir` are left alone. Every file is written in full before any replaces its
    /// old version, and the page last: a failure (a full disk) leaves the old report whole.
    pub fn write(&self, dir: impl AsRef<Path>) -> Result<PathBuf, ReportError> {
        let mut staged = Staged::default();
        let index = self.stage(dir.as_ref(), &mut staged)?;
        staged.commit()?;
        Ok(index)
    }

    /// [`Report::write`], its files left in `staged` to commit with others (maps).
    pub(crate) fn stage(&self, dir: &Path, staged: &mut Staged) -> Result<PathBuf, ReportError> {
        let plots_dir = dir.join("plots");
        create_dir(&plots_dir)?;
        let mut body = String::new();
        let mut plot_number = 0;
        let mut live_scripts = Vec::new();
        for block in &self.blocks {
            match block {
                Block::LinePlot(p) => {
                    plot_number += 1;
                    let rendered = p.to_svg()?;
                    let file = write_svg(&plots_dir, plot_number, &p.title, &rendered, staged)?;
                    let live = match &p.live {
                        Some(options) => {
                            let (src, data) = write_live(dir, &file, p, options, staged)?;
                            live_scripts.push(src.clone());
                            Some((src, data))
                        }
                        None => None,
                    };
                    let live = live.as_ref().map(|(src, data)| (src.as_str(), data));
                    figure(
                        &mut body,
                        &p.title,
                        &file,
                        &rendered,
                        p.caption.as_deref(),
                        live,
                    );
                }
                Block::BarChart(c) => {
                    plot_number += 1;
                    let rendered = c.to_svg()?;
                    let file = write_svg(&plots_dir, plot_number, &c.title, &rendered, staged)?;
                    figure(
                        &mut body,
                        &c.title,
                        &file,
                        &rendered,
                        c.caption.as_deref(),
                        None,
                    );
                }
                Block::Grid(cells) => {
                    body.push_str(&grid_start(cells));
                    for cell in cells {
                        let _ = write!(
                            body,
                            "<figure class=\"cell\">\n<h3>{}</h3>\n",
                            escape(&cell.title)
                        );
                        for p in &cell.plots {
                            plot_number += 1;
                            let rendered = p.to_svg()?;
                            let file =
                                write_svg(&plots_dir, plot_number, &p.title, &rendered, staged)?;
                            image(&mut body, &file, &rendered, &p.title);
                            notes(&mut body, &rendered);
                        }
                        if let Some(c) = &cell.caption {
                            let _ = writeln!(body, "<p class=\"caption\">{}</p>", escape(c));
                        }
                        body.push_str("</figure>\n");
                    }
                    body.push_str("</div>\n");
                }
                other => render_block(&mut body, other),
            }
        }
        if !live_scripts.is_empty() {
            write_uplot(dir, staged)?;
        }
        let index = dir.join("index.html");
        staged.page(&index, &self.page(&body, &live_scripts))?;
        Ok(index)
    }

    fn page(&self, body: &str, live_scripts: &[String]) -> String {
        let mut out = String::new();
        let title = escape(&self.title);
        let _ = write!(
            out,
            "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n\
             <meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">\n\
             <title>{title}</title>\n<style>{}{}</style>\n<script>{}</script>\n{}</head>\n<body>\n\
             <header class=\"masthead\"><div class=\"wrap\">\n<p class=\"kicker\">tolles report</p>\n\
             <h1>{title}</h1>\n",
            html::STYLE,
            running_header(&self.title, self.paper),
            html::ERROR_CAPTURE,
            if live_scripts.is_empty() {
                String::new()
            } else {
                format!("<link rel=\"stylesheet\" href=\"{UPLOT_CSS_FILE}\">\n")
            }
        );
        if let Some(s) = &self.subtitle {
            let _ = writeln!(out, "<p class=\"subtitle\">{}</p>", escape(s));
        }
        if let Some(p) = &self.provenance {
            let _ = writeln!(out, "<p class=\"subtitle written-by\">{}</p>", escape(p));
        }
        if !self.summary.is_empty() {
            out.push_str("<dl class=\"summary\">\n");
            for (k, v) in &self.summary {
                let _ = writeln!(
                    out,
                    "<div><dt>{}</dt><dd>{}</dd></div>",
                    escape(k),
                    escape(v)
                );
            }
            out.push_str("</dl>\n");
        }
        for note in &self.summary_notes {
            let _ = writeln!(out, "<p class=\"summary-note\">{}</p>", escape(note));
        }
        out.push_str("</div></header>\n");
        out.push_str(&self.table_of_contents());
        let _ = write!(
            out,
            "<main class=\"wrap\">\n{body}</main>\n\
             <footer><div class=\"wrap\">Written by tolles-report {}. This page and its plots open \
             without a network connection.</div></footer>\n\
             <div id=\"tolles-check\" hidden>pending</div>\n{}<script>{}</script>\n</body>\n</html>\n",
            env!("CARGO_PKG_VERSION"),
            live_tags(live_scripts),
            html::SELF_CHECK
        );
        out
    }

    fn table_of_contents(&self) -> String {
        let headings: Vec<&String> = self
            .blocks
            .iter()
            .filter_map(|b| match b {
                Block::Section(h) => Some(h),
                _ => None,
            })
            .collect();
        if headings.len() < 2 {
            return String::new();
        }
        let mut out = String::from("<nav class=\"toc\"><div class=\"wrap\"><ol>");
        for h in headings {
            let _ = write!(out, "<li><a href=\"#{}\">{}</a></li>", slug(h), escape(h));
        }
        out.push_str("</ol></div></nav>\n");
        out
    }
}

fn render_block(out: &mut String, block: &Block) {
    match block {
        Block::Section(h) => {
            let _ = writeln!(out, "<h2 id=\"{}\">{}</h2>", slug(h), escape(h));
        }
        Block::Paragraph(p) => {
            let _ = writeln!(out, "<p>{}</p>", escape(p));
        }
        Block::KeyValues(items) => {
            out.push_str("<dl class=\"kv\">\n");
            for (k, v) in items {
                let _ = writeln!(
                    out,
                    "<dt>{}</dt><dd{}>{}</dd>",
                    escape(k),
                    numeric_class(v),
                    escape(v)
                );
            }
            out.push_str("</dl>\n");
        }
        Block::Table { headers, rows } => table(out, headers, rows),
        Block::Image { src, alt } => {
            let _ = writeln!(
                out,
                "<figure class=\"plot\"><img src=\"{}\" alt=\"{}\"></figure>",
                escape(src),
                escape(alt)
            );
        }
        Block::LinePlot(_) | Block::BarChart(_) | Block::Grid(_) => {}
    }
}

fn numeric_class(cell: &str) -> &'static str {
    if is_numeric(cell) {
        " class=\"num\""
    } else {
        ""
    }
}

/// Rows of a table short enough to print on one page, never split (A4 at 8.5 pt holds ~45).
const SHORT_TABLE_ROWS: usize = 24;

fn table(out: &mut String, headers: &[String], rows: &[Vec<String>]) {
    // A column is numeric when all its non-empty cells are, so header and cells align alike.
    let numeric: Vec<bool> = (0..headers.len())
        .map(|c| {
            let cells = || {
                rows.iter()
                    .filter_map(|r| r.get(c))
                    .filter(|v| !v.trim().is_empty())
            };
            cells().count() > 0 && cells().all(|v| is_numeric(v))
        })
        .collect();
    let class = |c: usize| {
        if numeric.get(c).copied().unwrap_or(false) {
            " class=\"num\""
        } else {
            ""
        }
    };
    // A table of up to a page's third is printed whole (see the print style sheet).
    let whole = if rows.len() <= SHORT_TABLE_ROWS {
        " short"
    } else {
        ""
    };
    let _ = write!(out, "<div class=\"table-wrap{whole}\"><table>\n<thead><tr>");
    for (c, h) in headers.iter().enumerate() {
        let _ = write!(out, "<th{}>{}</th>", class(c), escape(h));
    }
    out.push_str("</tr></thead>\n<tbody>\n");
    for row in rows {
        out.push_str("<tr>");
        for (c, cell) in row.iter().enumerate() {
            let _ = write!(out, "<td{}>{}</td>", class(c), escape(cell));
        }
        out.push_str("</tr>\n");
    }
    out.push_str("</tbody></table></div>\n");
}

/// Where the vendored uPlot goes in a report directory (relative URLs of the page).
const UPLOT_JS_FILE: &str = "assets/uPlot.iife.min.js";
const UPLOT_CSS_FILE: &str = "assets/uPlot.min.css";
const UPLOT_LICENSE_FILE: &str = "assets/uPlot-LICENSE.txt";

fn write_uplot(dir: &Path, staged: &mut Staged) -> Result<(), ReportError> {
    create_dir(&dir.join("assets"))?;
    staged.file(&dir.join(UPLOT_JS_FILE), live::UPLOT_JS)?;
    staged.file(&dir.join(UPLOT_CSS_FILE), live::UPLOT_CSS)?;
    staged.file(&dir.join(UPLOT_LICENSE_FILE), live::UPLOT_LICENSE)
}

/// Writes the data of the live chart of `plot` (whose SVG is `svg_file`) as `data/NAME.js`;
/// returns its URL relative to the page and the data.
fn write_live(
    dir: &Path,
    svg_file: &str,
    plot: &LinePlot,
    options: &live::Live,
    staged: &mut Staged,
) -> Result<(String, live::LiveData), ReportError> {
    let id = svg_file.trim_end_matches(".svg");
    let data = live::data_script(id, plot, options)?;
    create_dir(&dir.join("data"))?;
    let src = format!("data/{id}.js");
    staged.file(&dir.join(&src), &data.script)?;
    Ok((src, data))
}

/// The scripts that draw the live charts: uPlot, every chart's data, then the starter.
fn live_tags(live_scripts: &[String]) -> String {
    if live_scripts.is_empty() {
        return String::new();
    }
    let mut out = format!("<script src=\"{UPLOT_JS_FILE}\"></script>\n");
    for src in live_scripts {
        let _ = writeln!(out, "<script src=\"{}\"></script>", escape(src));
    }
    let _ = writeln!(out, "<script>{}</script>", live::START_SCRIPT);
    out
}

/// How to use a live chart, and what its points are.
fn live_note(data: &live::LiveData) -> String {
    let points = if data.per_bucket > 1 {
        format!(
            " Each pair of points is the lowest and highest of {} samples (the static image keeps \
             the same per pixel column).",
            data.per_bucket
        )
    } else {
        " Every sample is drawn.".to_string()
    };
    format!(
        "Drag across the chart to zoom in; ◀ ▶ pan, + − zoom, “all” shows everything (so does a \
         double-click); click a name in the legend to hide its line (the y axis rescales).{points}"
    )
}

fn figure(
    out: &mut String,
    title: &str,
    file: &str,
    plot: &RenderedPlot,
    caption: Option<&str>,
    live: Option<(&str, &live::LiveData)>,
) {
    match live {
        Some((src, _)) => {
            let id = src.trim_start_matches("data/").trim_end_matches(".js");
            let _ = write!(
                out,
                "<figure class=\"plot\" data-live=\"{}\">\n<h3>{}</h3>\n",
                escape(id),
                escape(title)
            );
        }
        None => {
            let _ = write!(out, "<figure class=\"plot\">\n<h3>{}</h3>\n", escape(title));
        }
    }
    if plot.legend.len() > 1 || plot.legend.iter().any(|(n, _)| !n.is_empty()) {
        out.push_str("<ul class=\"legend\">");
        for (name, colour) in &plot.legend {
            let _ = write!(out, "<li>{}{}</li>", legend_sample(*colour), escape(name));
        }
        out.push_str("</ul>\n");
    }
    if let Some((_, data)) = live {
        let _ = writeln!(
            out,
            "<div class=\"live-chart\"></div><div class=\"live-controls\"></div>\n\
             <p class=\"note live-note\">{}</p>",
            escape(&live_note(data))
        );
    }
    image(out, file, plot, title);
    notes(out, plot);
    if let Some(c) = caption {
        let _ = writeln!(out, "<p class=\"caption\">{}</p>", escape(c));
    }
    out.push_str("</figure>\n");
}

/// The opening of a grid: columns as wide as its widest plot, or narrower to fit.
fn grid_start(cells: &[GridCell]) -> String {
    let widest = cells
        .iter()
        .flat_map(|c| &c.plots)
        .map(|p| p.size.width)
        .max()
        .unwrap_or(plot::PLOT_WIDTH);
    // Cells shrink to 85 % of their plots' width before a row gives up a column.
    let min = (widest as f64 * 0.85).round();
    // A grid of more than a page's worth of cells may break between its rows when printed.
    let many = if cells.len() > 4 { " many" } else { "" };
    format!(
        "<div class=\"grid{many}\" style=\"grid-template-columns: repeat(auto-fill, minmax(min({min}px, 100%), 1fr))\">\n"
    )
}

fn image(out: &mut String, file: &str, plot: &RenderedPlot, alt: &str) {
    let _ = writeln!(
        out,
        "<img src=\"plots/{}\" width=\"{}\" height=\"{}\" alt=\"{}\">",
        escape(file),
        plot.size.width,
        plot.size.height,
        escape(alt)
    );
}

fn notes(out: &mut String, plot: &RenderedPlot) {
    for note in &plot.notes {
        let _ = writeln!(out, "<p class=\"note svg-note\">{}</p>", escape(note));
    }
}

/// A short thick line in the series' colour, as an inline SVG: unlike a CSS background it
/// also prints.
fn legend_sample(colour: plot::Colour) -> String {
    format!(
        "<svg width=\"22\" height=\"8\" viewBox=\"0 0 22 8\" aria-hidden=\"true\">\
         <line x1=\"1\" y1=\"4\" x2=\"21\" y2=\"4\" stroke=\"{}\" stroke-width=\"3\" \
         stroke-linecap=\"round\"/></svg>",
        colour.css()
    )
}

fn write_svg(
    dir: &Path,
    number: usize,
    title: &str,
    plot: &RenderedPlot,
    staged: &mut Staged,
) -> Result<String, ReportError> {
    let name = format!("{number:02}-{}.svg", slug(title));
    staged.file(&dir.join(&name), &plot.svg)?;
    Ok(name)
}

fn create_dir(path: &Path) -> Result<(), ReportError> {
    std::fs::create_dir_all(path).map_err(|source| ReportError::Io {
        path: path.to_path_buf(),
        source,
    })
}

/// A report's files written in full to temporary files beside their targets, renamed over
/// them only once every one is written, the page last: until then the old report (page and
/// the plots and data it loads) is untouched, and a failure removes the temporary files.
#[derive(Default)]
pub(crate) struct Staged {
    files: Vec<tolles::tolles_io::atomic::AtomicFile>,
    page: Option<tolles::tolles_io::atomic::AtomicFile>,
}

impl Staged {
    /// Stages `text` for `path`.
    pub(crate) fn file(&mut self, path: &Path, text: &str) -> Result<(), ReportError> {
        self.files.push(staged(path, text)?);
        Ok(())
    }

    /// Stages the page `text` for `path`, renamed after every other file.
    fn page(&mut self, path: &Path, text: &str) -> Result<(), ReportError> {
        self.page = Some(staged(path, text)?);
        Ok(())
    }

    /// Renames every staged file over its target, the page last.
    pub(crate) fn commit(self) -> Result<(), ReportError> {
        for file in self.files.into_iter().chain(self.page) {
            let path = file.target().to_path_buf();
            file.commit().map_err(|e| io_error(&path, e))?;
        }
        Ok(())
    }
}

/// `text` written in full to a temporary file beside `path`.
fn staged(path: &Path, text: &str) -> Result<tolles::tolles_io::atomic::AtomicFile, ReportError> {
    use std::io::Write;
    let file =
        tolles::tolles_io::atomic::AtomicFile::create(path).map_err(|e| io_error(path, e))?;
    let mut writer = std::io::BufWriter::new(file.file());
    writer
        .write_all(text.as_bytes())
        .and_then(|()| writer.flush())
        .map_err(|source| ReportError::Io {
            path: path.to_path_buf(),
            source,
        })?;
    drop(writer);
    Ok(file)
}

fn io_error(path: &Path, e: tolles::tolles_io::IoError) -> ReportError {
    use tolles::tolles_io::IoError;
    match e {
        IoError::Write { source, .. } => ReportError::Io {
            path: path.to_path_buf(),
            source,
        },
        other => ReportError::Io {
            path: path.to_path_buf(),
            source: std::io::Error::other(other.to_string()),
        },
    }
}

/// When a page says it was written: now, or `SOURCE_DATE_EPOCH` (s since 1970) when set, the
/// reproducible-builds convention, so the same inputs can give the same bytes.
pub fn written_at() -> std::time::SystemTime {
    let fixed = std::env::var("SOURCE_DATE_EPOCH").ok();
    match fixed.and_then(|s| s.trim().parse::<u64>().ok()) {
        Some(s) => std::time::UNIX_EPOCH + std::time::Duration::from_secs(s),
        None => std::time::SystemTime::now(),
    }
}

/// The date and time `now` as `YYYY-MM-DD HH:MM UTC`, for a page's provenance line.
pub fn utc_stamp(now: std::time::SystemTime) -> String {
    let seconds = now
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.as_secs()) as i64;
    let (days, rest) = (seconds.div_euclid(86_400), seconds.rem_euclid(86_400));
    let (y, m, d) = civil_from_days(days);
    format!(
        "{y:04}-{m:02}-{d:02} {:02}:{:02} UTC",
        rest / 3600,
        rest % 3600 / 60
    )
}

/// The proleptic Gregorian date of `days` since 1970-01-01 (Hinnant's civil-from-days).
fn civil_from_days(days: i64) -> (i64, i64, i64) {
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z.rem_euclid(146_097);
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = doy - (153 * mp + 2) / 5 + 1;
    let m = if mp < 10 { mp + 3 } else { mp - 9 };
    (yoe + era * 400 + i64::from(m <= 2), m, d)
}

/// The printed page's running header: the report's title, top left, on every page; and its
/// size when it is not the style sheet's A4.
fn running_header(title: &str, paper: tolles::report::Paper) -> String {
    let quoted: String = title
        .chars()
        .filter(|c| !c.is_control())
        .flat_map(|c| match c {
            '"' | '\\' => vec!['\\', c],
            '<' => "\\3c ".chars().collect(),
            _ => vec![c],
        })
        .collect();
    let size = match paper {
        tolles::report::Paper::A4 => "",
        tolles::report::Paper::Letter => "size: letter; ",
    };
    format!(
        "@page {{ {size}@top-left {{ content: \"{quoted}\"; font-size: 8pt; color: #555; }} }}\n"
    )
}

#[cfg(test)]
mod tests {
    #[test]
    fn a_stamp_is_the_utc_date_and_minute() {
        let at = |s: u64| utc_stamp(std::time::UNIX_EPOCH + std::time::Duration::from_secs(s));
        assert_eq!(at(0), "1970-01-01 00:00 UTC");
        assert_eq!(at(951_782_400 + 3_661), "2000-02-29 01:01 UTC");
        assert_eq!(at(1_795_862_700), "2026-11-28 10:45 UTC");
    }

    use super::plot::{BarSeries, Colour, Series};
    use super::*;

    fn sine_plot(n: usize) -> LinePlot {
        let x: Vec<f64> = (0..n).map(|k| k as f64 * 0.1).collect();
        let y: Vec<f64> = x.iter().map(|v| 50_000.0 + 3.0 * (v * 0.7).sin()).collect();
        LinePlot {
            title: "Scalar <field>".into(),
            x_label: "time (s)".into(),
            y_label: "field (nT)".into(),
            series: vec![Series::new("raw", x, y).colour(Colour::UNCOMPENSATED)],
            ..LinePlot::default()
        }
    }

    fn every_element() -> Report {
        Report::new("Flight <1002> & \"friends\"")
            .subtitle("a 'subtitle'")
            .summary(&[("noise", "0.1 nT")])
            .section("One")
            .paragraph("<script>alert(1)</script>")
            .key_values(&[("λ", "1e-3"), ("name", "mag_1_uc")])
            .section("Two")
            .table(
                &["term", "value (nT)"],
                &[
                    vec!["<x>".into(), "1.5".into()],
                    vec!["y".into(), "-2".into()],
                ],
            )
            .line_plot(sine_plot(1000))
            .bar_chart(BarChart {
                title: "Noise".into(),
                y_label: "nT".into(),
                categories: vec!["a".into(), "b".into()],
                series: vec![BarSeries::new("before", vec![3.0, 4.0])],
                ..BarChart::default()
            })
    }

    #[test]
    fn write_creates_the_page_and_one_svg_per_plot() {
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("nested/report");
        let index = every_element().write(&out).unwrap();
        assert_eq!(index, out.join("index.html"));
        let page = std::fs::read_to_string(&index).unwrap();
        for file in ["01-scalar-field.svg", "02-noise.svg"] {
            let svg = std::fs::read_to_string(out.join("plots").join(file)).unwrap();
            assert!(svg.starts_with("<svg") && svg.trim_end().ends_with("</svg>"));
            assert!(
                page.contains(&format!("<img src=\"plots/{file}\"")),
                "{file}"
            );
        }
        assert!(page.contains("<div id=\"tolles-check\" hidden>pending</div>"));
        // Works offline: nothing is fetched from anywhere.
        assert!(!page.contains("http://") && !page.contains("https://"));
        assert!(!page.contains("@import") && !page.contains("url("));
    }

    #[test]
    fn the_printed_page_is_a4_with_the_title_and_page_numbers() {
        let dir = tempfile::tempdir().unwrap();
        let page = std::fs::read_to_string(every_element().write(dir.path()).unwrap()).unwrap();
        assert!(page.contains("size: A4"));
        assert!(page.contains("counter(page) \" of \" counter(pages)"));
        // The title in the running header cannot end the style sheet or the CSS string.
        let header = running_header("a \"b\" </style>\\", tolles::report::Paper::A4);
        assert_eq!(
            header,
            "@page { @top-left { content: \"a \\\"b\\\" \\3c /style>\\\\\"; font-size: 8pt; \
             color: #555; } }\n"
        );
        let letter = running_header("t", tolles::report::Paper::Letter);
        assert!(
            letter.starts_with("@page { size: letter; @top-left"),
            "{letter}"
        );
    }

    #[test]
    fn all_inserted_text_is_escaped() {
        let dir = tempfile::tempdir().unwrap();
        let page = std::fs::read_to_string(every_element().write(dir.path()).unwrap()).unwrap();
        assert!(page.contains("<title>Flight &lt;1002&gt; &amp; &quot;friends&quot;</title>"));
        assert!(page.contains("&lt;script&gt;alert(1)&lt;/script&gt;"));
        assert!(page.contains("<td>&lt;x&gt;</td>"));
        assert!(page.contains("a &#39;subtitle&#39;"));
        assert!(page.contains("<h3>Scalar &lt;field&gt;</h3>"));
        assert_eq!(
            page.matches("<script>").count(),
            2,
            "only the error capture and the self-check run"
        );
    }

    #[test]
    fn a_live_plot_writes_its_data_and_uplot_and_keeps_its_image() {
        let dir = tempfile::tempdir().unwrap();
        let mut plot = sine_plot(300_000);
        plot.live = Some(live::Live::default());
        let index = Report::new("t")
            .line_plot(plot)
            .line_plot(sine_plot(10))
            .write(dir.path())
            .unwrap();
        let page = std::fs::read_to_string(index).unwrap();
        let figure = page
            .split("<figure class=\"plot\" data-live=\"01-scalar-field\">")
            .nth(1)
            .unwrap();
        let figure = figure.split("</figure>").next().unwrap();
        assert!(figure.contains("<div class=\"live-chart\"></div>"));
        assert!(figure.contains("<img src=\"plots/01-scalar-field.svg\""));
        assert!(
            figure.contains("lowest and highest of 5 samples"),
            "{figure}"
        );
        assert_eq!(page.matches("data-live=").count(), 1);
        let tags = page.split("<div id=\"tolles-check\"").nth(1).unwrap();
        let order = [
            "assets/uPlot.iife.min.js",
            "data/01-scalar-field.js",
            "tollesCharts",
        ];
        let at: Vec<usize> = order.iter().map(|t| tags.find(t).unwrap()).collect();
        assert!(
            at.windows(2).all(|w| w[0] < w[1]),
            "uPlot, data, then the starter"
        );
        assert!(page.contains("<link rel=\"stylesheet\" href=\"assets/uPlot.min.css\">"));
        for file in [
            "data/01-scalar-field.js",
            "assets/uPlot.iife.min.js",
            "assets/uPlot.min.css",
            "assets/uPlot-LICENSE.txt",
        ] {
            assert!(dir.path().join(file).is_file(), "{file}");
        }
        let data = std::fs::read_to_string(dir.path().join("data/01-scalar-field.js")).unwrap();
        assert!(data.len() < 2_000_000, "{} bytes", data.len());
        assert!(!page.contains("http") && !data.contains("http"));
    }

    #[test]
    fn a_page_without_live_plots_loads_no_uplot() {
        let dir = tempfile::tempdir().unwrap();
        let page = std::fs::read_to_string(every_element().write(dir.path()).unwrap()).unwrap();
        assert!(!page.contains("assets/uPlot") && !page.contains("data-live=\""));
        assert!(!dir.path().join("assets").exists());
    }

    #[test]
    fn numeric_columns_are_right_aligned() {
        let dir = tempfile::tempdir().unwrap();
        let page = std::fs::read_to_string(every_element().write(dir.path()).unwrap()).unwrap();
        assert!(page.contains("<th>term</th><th class=\"num\">value (nT)</th>"));
        assert!(page.contains("<td class=\"num\">-2</td>"));
        assert!(page.contains("<dd class=\"num\">1e-3</dd>"));
        assert!(page.contains("<dd>mag_1_uc</dd>"));
    }

    #[test]
    fn unwritable_directory_is_an_error_naming_it() {
        let dir = tempfile::tempdir().unwrap();
        let file = dir.path().join("a-file");
        std::fs::write(&file, "not a directory").unwrap();
        let err = every_element().write(file.join("report")).unwrap_err();
        assert!(matches!(err, ReportError::Io { .. }));
        assert!(err.to_string().contains("a-file"), "{err}");
    }

    #[test]
    fn mismatched_series_lengths_are_an_error() {
        let mut plot = sine_plot(10);
        plot.series[0].y.pop();
        let err = Report::new("t")
            .line_plot(plot)
            .write(tempfile::tempdir().unwrap().path())
            .unwrap_err();
        assert_eq!(
            err.to_string(),
            "plot 'Scalar <field>', series 'raw': 10 x values (or categories) but 9 values"
        );
    }

    #[test]
    fn nan_breaks_the_drawn_line() {
        let mut plot = sine_plot(200);
        let whole = plot.to_svg().unwrap();
        assert_eq!(whole.svg.matches("<polyline").count() - axes(&whole.svg), 1);
        plot.series[0].y[50] = f64::NAN;
        plot.series[0].y[120] = f64::NAN;
        let broken = plot.to_svg().unwrap();
        assert_eq!(
            broken.svg.matches("<polyline").count() - axes(&broken.svg),
            3
        );
        assert!(!broken.svg.contains("NaN"));
        assert!(broken.notes.iter().any(|n| n.contains("2 non-finite")));
    }

    /// Polylines that are axes, not data (drawn in the axis colour).
    fn axes(svg: &str) -> usize {
        svg.lines()
            .filter(|l| l.starts_with("<polyline") && l.contains("stroke=\"#666666\""))
            .count()
    }

    #[test]
    fn a_million_points_make_a_small_svg() {
        // Noise is the worst case: every pixel column has four distinct points.
        let mut plot = sine_plot(1_000_000);
        let mut state = 1u64;
        for y in plot.series[0].y.iter_mut() {
            state = state
                .wrapping_mul(6_364_136_223_846_793_005)
                .wrapping_add(1);
            *y += (state >> 40) as f64 / (1u64 << 24) as f64;
        }
        let rendered = plot.to_svg().unwrap();
        assert!(rendered.svg.len() < 100_000, "{} bytes", rendered.svg.len());
        assert!(rendered.notes[0].starts_with("1\u{2009}000\u{2009}000 points drawn as"));
    }

    #[test]
    fn log_axis_skips_non_positive_values_and_uses_whole_decades() {
        let x: Vec<f64> = (0..100).map(f64::from).collect();
        let y: Vec<f64> = x
            .iter()
            .map(|v| if *v == 10.0 { 0.0 } else { 0.02 + v * 3.0 })
            .collect();
        let plot = LinePlot {
            title: "spectrum".into(),
            series: vec![Series::new("psd", x, y)],
            log_y: true,
            ..LinePlot::default()
        };
        let rendered = plot.to_svg().unwrap();
        assert!(rendered.svg.contains("10⁻¹") && rendered.svg.contains("10³"));
        assert!(rendered.notes.iter().any(|n| n.contains("non-positive")));
    }

    #[test]
    fn plots_without_data_say_so() {
        let plot = LinePlot {
            title: "empty".into(),
            series: vec![Series::new("nothing", vec![1.0], vec![f64::NAN])],
            ..LinePlot::default()
        };
        let rendered = plot.to_svg().unwrap();
        assert!(rendered.svg.contains("no data"));
        assert_eq!(
            rendered.notes,
            vec!["No finite values to plot.".to_string()]
        );
    }

    #[test]
    fn legend_entries_show_a_line_in_their_colour() {
        let mut plot = sine_plot(10);
        plot.series
            .push(Series::new("second", vec![0.0, 1.0], vec![1.0, 2.0]));
        let mut out = String::new();
        figure(&mut out, "t", "t.svg", &plot.to_svg().unwrap(), None, None);
        let legend = out.split("<ul class=\"legend\">").nth(1).unwrap();
        let entries: Vec<&str> = legend
            .split("</li>")
            .filter(|e| e.contains("<li>"))
            .collect();
        assert_eq!(entries.len(), 2);
        for (entry, colour) in entries
            .iter()
            .zip([Colour::UNCOMPENSATED, Colour::CYCLE[1]])
        {
            let stroke = format!("stroke=\"{}\"", colour.css());
            assert!(
                entry.contains("<line") && entry.contains(&stroke),
                "{entry}"
            );
            // Sized, so it takes room even before any stylesheet applies.
            assert!(entry.contains("<svg width=\"22\" height=\"8\""), "{entry}");
        }
    }

    #[test]
    fn summary_notes_are_escaped_under_the_cards() {
        let page = Report::new("t")
            .summary(&[("λ", "1")])
            .summary_note("FOM <defined>")
            .page("", &[]);
        let header = page.split("</header>").next().unwrap();
        assert!(header.contains("<p class=\"summary-note\">FOM &lt;defined&gt;</p>"));
        assert!(header.contains("<dt>λ</dt>"));
    }

    #[test]
    fn a_single_category_bar_chart_draws_one_bar() {
        let chart = BarChart {
            title: "one".into(),
            y_label: "nT".into(),
            categories: vec!["only".into()],
            series: vec![BarSeries::new("s", vec![2.5])],
            ..BarChart::default()
        };
        let svg = chart.to_svg().unwrap().svg;
        assert!(
            svg.contains(">\nonly\n<") || svg.contains(">only<"),
            "{svg}"
        );
        assert_eq!(svg.matches(&format!("fill=\"{}\"", "#0072B2")).count(), 1);
    }
}
