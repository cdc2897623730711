//! Zoomable charts. A [`LinePlot`] with [`Live`] options is drawn twice:
//! as its static SVG (shown when scripts are off, and when printing) and as an interactive
//! chart drawn by uPlot (MIT, vendored in `vendor/uplot`, written beside the page in `assets/`)
//! from a data file `data/NN-slug.js` (float32 in a [`base64`] that cannot spell NaN or inf).
//! Both load from `file://` with no network: a `<script src>` works there where `fetch` does
//! not.
//!
//! Long series stay fast and small: up to [`MAX_POINTS`] samples are kept as they are; beyond,
//! each bucket of consecutive samples is kept as its first and last time with each series' lowest
//! and highest value in the order they occur, so peaks survive at every zoom.
//!
//! ```
//! use tolles_report::live::envelope;
//! let x: Vec<f64> = (0..10).map(f64::from).collect();
//! let y = [0.0, 5.0, 1.0, 2.0, -3.0, 0.0, 1.0, 1.0, 9.0, 0.0];
//! let (ex, ey, per_bucket) = envelope(&x, &[&y[..]], 4);
//! assert_eq!(per_bucket, 5);
//! assert_eq!(ex, [0.0, 4.0, 5.0, 9.0]);
//! assert_eq!(ey[0], [5.0, -3.0, 0.0, 9.0]);
//! ```

// `Live` is defined with the plot that holds it, so the plot needs nothing from this module.
pub use crate::plot::Live;
use crate::plot::{Colour, LinePlot};
use crate::ReportError;

/// The uPlot release vendored in `vendor/uplot`.
pub const UPLOT_VERSION: &str = "1.6.32";
/// uPlot's script, as released.
pub const UPLOT_JS: &str = include_str!("../vendor/uplot/uPlot.iife.min.js");
/// uPlot's style sheet, as released.
pub const UPLOT_CSS: &str = include_str!("../vendor/uplot/uPlot.min.css");
/// uPlot's licence, written beside the script.
pub const UPLOT_LICENSE: &str = include_str!("../vendor/uplot/LICENSE");

/// Most points (per series) a chart's data holds; longer series are kept as an envelope.
pub const MAX_POINTS: usize = 1 << 17;

/// A live chart's data file and what its caption should say about it.
#[derive(Debug, Clone, PartialEq)]
pub struct LiveData {
    /// JavaScript that files the chart's data under its id in `window.TOLLES_LIVE`.
    pub script: String,
    /// Samples per envelope bucket; 1 when every sample is kept.
    pub per_bucket: usize,
}

/// The data file of `plot` drawn live as chart `id`. Every series must share the first series'
/// x values (time, say), which must increase where finite; samples with a non-finite x are left
/// out, non-finite y values are gaps.
pub fn data_script(id: &str, plot: &LinePlot, live: &Live) -> Result<LiveData, ReportError> {
    let x = shared_x(plot)?;
    let keep: Vec<usize> = (0..x.len()).filter(|&k| x[k].is_finite()).collect();
    let xs: Vec<f64> = keep.iter().map(|&k| x[k]).collect();
    let ys: Vec<Vec<f64>> = plot
        .series
        .iter()
        .map(|s| keep.iter().map(|&k| s.y[k]).collect())
        .collect();
    let columns: Vec<&[f64]> = ys.iter().map(Vec::as_slice).collect();
    let (ex, ey, per_bucket) = envelope(&xs, &columns, MAX_POINTS);
    let x0 = ex.first().copied().unwrap_or(0.0);
    let offsets: Vec<f64> = ex.iter().map(|t| t - x0).collect();
    let series: Vec<serde_json::Value> = plot
        .series
        .iter()
        .zip(&ey)
        .enumerate()
        .map(|(k, (s, y))| {
            let colour = s.colour.unwrap_or(Colour::CYCLE[k % Colour::CYCLE.len()]);
            serde_json::json!({ "name": s.name, "colour": colour.css(), "y": f32_base64(y) })
        })
        .collect();
    let windows: Vec<serde_json::Value> = live
        .windows
        .iter()
        .filter(|w| w.from.is_finite() && w.to.is_finite())
        .map(|w| {
            serde_json::json!({ "from": w.from, "to": w.to, "label": w.label,
                                 "colour": w.colour.css() })
        })
        .collect();
    let data = serde_json::json!({
        "title": plot.title,
        "x_label": plot.x_label,
        "y_label": plot.y_label,
        "x0": x0,
        "x_sum": offsets.iter().map(|&t| f64::from(t as f32)).sum::<f64>(),
        "x": f32_base64(&offsets),
        "points": ex.len(),
        "per_bucket": per_bucket,
        "series": series,
        "windows": windows,
    });
    let id = serde_json::to_string(id).expect("a string serialises");
    Ok(LiveData {
        script: format!("(window.TOLLES_LIVE = window.TOLLES_LIVE || {{}})[{id}] = {data};\n"),
        per_bucket,
    })
}

/// The x values all series of `plot` share; an error naming the first series that differs.
fn shared_x(plot: &LinePlot) -> Result<&[f64], ReportError> {
    let Some(first) = plot.series.first() else {
        return Ok(&[]);
    };
    for s in &plot.series {
        let same = s.x.len() == first.x.len()
            && s.x
                .iter()
                .zip(&first.x)
                .all(|(a, b)| a.to_bits() == b.to_bits());
        if !same || s.y.len() != s.x.len() {
            return Err(ReportError::Plot {
                title: plot.title.clone(),
                message: format!(
                    "series '{}' does not share the first series' x values, so it cannot be drawn live",
                    s.name
                ),
            });
        }
    }
    Ok(&first.x)
}

/// `x` and the series `ys` (each as long as `x`) in at most `max_points` points: unchanged when
/// they fit, else buckets of `per_bucket` consecutive samples, each kept as its first and last x
/// with every series' lowest and highest finite value in the order they occur (NaN, NaN when a
/// bucket has none). Returns `(x, ys, per_bucket)`.
pub fn envelope(x: &[f64], ys: &[&[f64]], max_points: usize) -> (Vec<f64>, Vec<Vec<f64>>, usize) {
    let n = x.len();
    if n <= max_points.max(2) {
        return (x.to_vec(), ys.iter().map(|y| y.to_vec()).collect(), 1);
    }
    let per_bucket = n.div_ceil((max_points / 2).max(1));
    let mut ex = Vec::with_capacity(max_points);
    let mut ey: Vec<Vec<f64>> = vec![Vec::with_capacity(max_points); ys.len()];
    for start in (0..n).step_by(per_bucket) {
        let end = (start + per_bucket).min(n);
        if end - start == 1 {
            ex.push(x[start]);
            for (out, y) in ey.iter_mut().zip(ys) {
                out.push(y[start]);
            }
            continue;
        }
        ex.extend([x[start], x[end - 1]]);
        for (out, y) in ey.iter_mut().zip(ys) {
            out.extend(extremes_in_order(&y[start..end]));
        }
    }
    (ex, ey, per_bucket)
}

/// The lowest and highest finite value of `y`, the earlier first; NaN, NaN when none is finite.
fn extremes_in_order(y: &[f64]) -> [f64; 2] {
    let mut low: Option<(usize, f64)> = None;
    let mut high: Option<(usize, f64)> = None;
    for (k, &v) in y.iter().enumerate().filter(|(_, v)| v.is_finite()) {
        if low.is_none_or(|(_, l)| v < l) {
            low = Some((k, v));
        }
        if high.is_none_or(|(_, h)| v > h) {
            high = Some((k, v));
        }
    }
    match (low, high) {
        (Some((kl, l)), Some((kh, h))) if kl <= kh => [l, h],
        (Some((_, l)), Some((_, h))) => [h, l],
        _ => [f64::NAN; 2],
    }
}

/// `values` as little-endian 32-bit floats in [`base64`] (NaN stays NaN): half the size of f64,
/// and exact to 6·10⁻⁸ of each value, far below what a chart can show.
pub fn f32_base64(values: &[f64]) -> String {
    let bytes: Vec<u8> = values
        .iter()
        .flat_map(|&v| (v as f32).to_le_bytes())
        .collect();
    base64(&bytes)
}

/// The 64 digits of [`base64`]: RFC 4648's without `N` and `n`, with `-` and `_` instead, so
/// that no run of digits reads `NaN`, `nan` or `inf` (a reader checking a report's files for
/// those finds only real ones). [`START_SCRIPT`] decodes with the same digits.
pub const ALPHABET: &str = "ABCDEFGHIJKLMOPQRSTUVWXYZabcdefghijklmopqrstuvwxyz0123456789+/-_";

/// Base64 with RFC 4648's layout and padding but the digits of [`ALPHABET`].
pub fn base64(bytes: &[u8]) -> String {
    let alphabet = ALPHABET.as_bytes();
    let mut out = String::with_capacity(bytes.len().div_ceil(3) * 4);
    for chunk in bytes.chunks(3) {
        let b = [
            chunk[0],
            chunk.get(1).copied().unwrap_or(0),
            chunk.get(2).copied().unwrap_or(0),
        ];
        let word = (u32::from(b[0]) << 16) | (u32::from(b[1]) << 8) | u32::from(b[2]);
        for k in 0..4 {
            if k <= chunk.len() {
                out.push(alphabet[(word >> (18 - 6 * k) & 63) as usize] as char);
            } else {
                out.push('=');
            }
        }
    }
    out
}

/// Starts every live chart of the page from its data, with controls to pan and zoom, and the
/// windows shaded and labelled; a chart that cannot start is recorded in `window.tollesErrors`
/// (see [`crate::html::ERROR_CAPTURE`]), which the page's self-check reports.
pub const START_SCRIPT: &str = r##"
(function () {
  var store = window.TOLLES_LIVE || {};
  window.tollesCharts = [];
  var DIGITS = "ABCDEFGHIJKLMOPQRSTUVWXYZabcdefghijklmopqrstuvwxyz0123456789+/-_";
  var CODE = new Uint8Array(128);
  for (var d = 0; d < 64; d++) CODE[DIGITS.charCodeAt(d)] = d;
  function buffer(text) {
    var pads = text.endsWith("==") ? 2 : text.endsWith("=") ? 1 : 0;
    var out = new Uint8Array(text.length / 4 * 3 - pads), o = 0;
    for (var i = 0; i < text.length; i += 4) {
      var w = (CODE[text.charCodeAt(i)] << 18) | (CODE[text.charCodeAt(i + 1)] << 12) |
              (CODE[text.charCodeAt(i + 2)] << 6) | CODE[text.charCodeAt(i + 3)];
      out[o++] = (w >> 16) & 255;
      if (o < out.length) out[o++] = (w >> 8) & 255;
      if (o < out.length) out[o++] = w & 255;
    }
    return out.buffer;
  }
  function values(b64, offset) {
    var f = new Float32Array(buffer(b64)), out = new Array(f.length);
    for (var i = 0; i < f.length; i++) out[i] = isFinite(f[i]) ? f[i] + offset : null;
    return out;
  }
  function shading(windows) {
    return { hooks: { drawClear: function (u) {
      var ctx = u.ctx, box = u.bbox, px = window.devicePixelRatio || 1;
      ctx.save();
      ctx.font = Math.round(12 * px) + "px system-ui, sans-serif";
      ctx.textBaseline = "top";
      windows.forEach(function (w) {
        var l = Math.max(u.valToPos(w.from, "x", true), box.left);
        var r = Math.min(u.valToPos(w.to, "x", true), box.left + box.width);
        if (!(r > l)) return;
        ctx.globalAlpha = 0.14; ctx.fillStyle = w.colour;
        ctx.fillRect(l, box.top, r - l, box.height);
        ctx.globalAlpha = 1;
        ctx.fillStyle = "#1f2328";
        if (r - l > ctx.measureText(w.label).width + 6 * px) {
          ctx.fillText(w.label, l + 3 * px, box.top + 3 * px);
        } else if (r - l > 15 * px) {
          // Too narrow to write across: write it down the window's left edge.
          ctx.save();
          ctx.translate(l + 2 * px, box.top + 4 * px);
          ctx.rotate(Math.PI / 2);
          ctx.textBaseline = "bottom";
          ctx.fillText(w.label, 0, 0);
          ctx.restore();
        }
      });
      ctx.restore();
    } } };
  }
  function button(bar, text, title, act) {
    var b = document.createElement("button");
    b.type = "button"; b.textContent = text; b.title = title; b.onclick = act;
    bar.appendChild(b);
  }
  function controls(fig, u, x) {
    var bar = fig.querySelector(".live-controls");
    function shift(f) {
      var s = u.scales.x, w = s.max - s.min;
      u.setScale("x", { min: s.min + f * w, max: s.max + f * w });
    }
    function zoom(f) {
      var s = u.scales.x, c = (s.min + s.max) / 2, h = (s.max - s.min) * f / 2;
      u.setScale("x", { min: c - h, max: c + h });
    }
    button(bar, "\u25C0", "pan left by half the view", function () { shift(-0.5); });
    button(bar, "\u25B6", "pan right by half the view", function () { shift(0.5); });
    button(bar, "+", "zoom in", function () { zoom(0.5); });
    button(bar, "\u2212", "zoom out", function () { zoom(2); });
    button(bar, "all", "show everything", function () {
      u.setScale("x", { min: x[0], max: x[x.length - 1] });
    });
  }
  function start(fig) {
    var id = fig.getAttribute("data-live"), d = store[id];
    if (!d) throw new Error("no data loaded for chart " + id);
    // The sum of the encoded times, written beside them, proves the decoding.
    var offsets = new Float32Array(buffer(d.x)), sum = 0;
    for (var k = 0; k < offsets.length; k++) sum += offsets[k];
    if (!(Math.abs(sum - d.x_sum) <= 1e-9 * Math.abs(d.x_sum)))
      throw new Error("its data did not decode (times sum to " + sum + ", not " + d.x_sum + ")");
    var x = values(d.x, d.x0), data = [x], series = [{ label: d.x_label }];
    d.series.forEach(function (s) {
      data.push(values(s.y, 0));
      series.push({ label: s.name, stroke: s.colour, width: 1.25, spanGaps: false,
                    points: { show: false } });
    });
    var box = fig.querySelector(".live-chart");
    var u = new uPlot({
      width: Math.max(box.clientWidth, 320), height: 360,
      scales: { x: { time: false } },
      series: series,
      axes: [{ label: d.x_label }, { label: d.y_label }],
      cursor: { drag: { x: true, y: false } },
      plugins: [shading(d.windows)]
    }, data, box);
    controls(fig, u, x);
    fig.classList.add("is-live");
    window.tollesCharts.push(u);
    window.addEventListener("resize", function () {
      u.setSize({ width: Math.max(box.clientWidth, 320), height: 360 });
    });
  }
  var figures = document.querySelectorAll("figure[data-live]");
  for (var i = 0; i < figures.length; i++) {
    try {
      if (typeof uPlot === "undefined") throw new Error("uPlot did not load");
      start(figures[i]);
    } catch (e) {
      window.tollesErrors.push("live chart " + figures[i].getAttribute("data-live") + ": " + e.message);
    }
  }
})();
"##;

#[cfg(test)]
mod tests {
    use super::*;
    use crate::plot::{Series, Span};

    fn decode_base64(text: &str) -> Vec<u8> {
        let value = |c: u8| ALPHABET.bytes().position(|a| a == c).unwrap() as u32;
        let mut out = Vec::new();
        for quad in text.as_bytes().chunks(4) {
            let pads = quad.iter().filter(|&&c| c == b'=').count();
            let word = quad
                .iter()
                .map(|&c| if c == b'=' { 0 } else { value(c) })
                .fold(0u32, |w, v| (w << 6) | v);
            out.extend(&word.to_be_bytes()[1..4 - pads]);
        }
        out
    }

    fn decode_f32(text: &str) -> Vec<f32> {
        decode_base64(text)
            .chunks(4)
            .map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]]))
            .collect()
    }

    #[test]
    fn base64_has_the_standard_layout_and_never_spells_nan_or_inf() {
        // RFC 4648's test vectors, each standard digit replaced by ours of the same value.
        const STANDARD: &str = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
        let ours = |standard: &str| -> String {
            standard
                .chars()
                .map(|c| match STANDARD.find(c) {
                    Some(k) => ALPHABET.as_bytes()[k] as char,
                    None => c,
                })
                .collect()
        };
        for (plain, coded) in [
            ("", ""),
            ("f", "Zg=="),
            ("fo", "Zm8="),
            ("foo", "Zm9v"),
            ("foob", "Zm9vYg=="),
            ("fooba", "Zm9vYmE="),
            ("foobar", "Zm9vYmFy"),
        ] {
            assert_eq!(base64(plain.as_bytes()), ours(coded), "{plain}");
            assert_eq!(decode_base64(&ours(coded)), plain.as_bytes());
        }
        let digits: std::collections::BTreeSet<char> = ALPHABET.chars().collect();
        assert_eq!(digits.len(), 64);
        assert!(!digits.contains(&'n') && !digits.contains(&'N'));
        assert!(!digits.contains(&'=') && !digits.contains(&'"') && !digits.contains(&'\\'));
        assert!(START_SCRIPT.contains(&format!("var DIGITS = \"{ALPHABET}\"")));
        let every_byte: Vec<u8> = (0..=255).cycle().take(3 * 4096).collect();
        assert_eq!(decode_base64(&base64(&every_byte)), every_byte);
    }

    #[test]
    fn floats_round_trip_through_base64_to_f32_precision() {
        let values = [0.0, -1.5, 53_512.25, 1e-3, f64::NAN, 0.123_456_789];
        let back = decode_f32(&f32_base64(&values));
        for (v, b) in values.iter().zip(&back) {
            if v.is_nan() {
                assert!(b.is_nan());
            } else {
                assert!(
                    (f64::from(*b) - v).abs() <= 1e-7 * v.abs().max(1e-30),
                    "{v} {b}"
                );
            }
        }
    }

    #[test]
    fn the_envelope_keeps_every_extreme_in_time_order_and_gaps() {
        let n = 1000;
        let x: Vec<f64> = (0..n).map(|k| k as f64 * 0.1).collect();
        let mut y: Vec<f64> = (0..n).map(|k| (k as f64 * 0.37).sin()).collect();
        y[500] = 7.0;
        y[501] = -7.0;
        for v in &mut y[900..n] {
            *v = f64::NAN;
        }
        let (ex, ey, per_bucket) = envelope(&x, &[&y], 100);
        assert_eq!(per_bucket, 20);
        assert_eq!(ex.len(), 100);
        assert!(ex.windows(2).all(|w| w[0] <= w[1]));
        let bucket = 500 / per_bucket;
        assert_eq!(ex[2 * bucket], x[500]);
        assert_eq!(&ey[0][2 * bucket..2 * bucket + 2], [7.0, -7.0]);
        assert!(ey[0][90..].iter().all(|v| v.is_nan()));
        // Every bucket's extremes are those of its samples.
        for b in 0..45 {
            let part = &y[b * 20..(b + 1) * 20];
            let hi = part.iter().copied().fold(f64::MIN, f64::max);
            let lo = part.iter().copied().fold(f64::MAX, f64::min);
            let kept = &ey[0][2 * b..2 * b + 2];
            assert!(kept.contains(&hi) && kept.contains(&lo), "bucket {b}");
        }
        let (same_x, same_y, one) = envelope(&x, &[&y], n);
        assert_eq!((same_x, one), (x.clone(), 1));
        assert_eq!(same_y[0].len(), n);
    }

    #[test]
    fn the_data_file_holds_the_series_and_windows_and_no_address() {
        let x: Vec<f64> = (0..50).map(|k| 1000.0 + k as f64).collect();
        let y: Vec<f64> = x.iter().map(|v| v.sin()).collect();
        let plot = LinePlot {
            title: "t </script>".into(),
            series: vec![
                Series::new("a", x.clone(), y.clone()).colour(Colour::COMPENSATED),
                Series::new("b", x.clone(), y.clone()),
            ],
            ..LinePlot::default()
        };
        let live = Live {
            windows: vec![Span {
                label: "roll 0°".into(),
                from: 1010.0,
                to: 1020.0,
                colour: Colour::REFERENCE,
            }],
        };
        let data = data_script("03-t", &plot, &live).unwrap();
        assert_eq!(data.per_bucket, 1);
        let json = data
            .script
            .strip_prefix("(window.TOLLES_LIVE = window.TOLLES_LIVE || {})[\"03-t\"] = ")
            .and_then(|s| s.strip_suffix(";\n"))
            .unwrap();
        let value: serde_json::Value = serde_json::from_str(json).unwrap();
        assert_eq!(value["x0"], 1000.0);
        let offsets = decode_f32(value["x"].as_str().unwrap());
        assert_eq!(offsets.len(), 50);
        assert_eq!(offsets[49], 49.0);
        assert_eq!(value["series"][0]["colour"], "#0072b2");
        assert_eq!(value["windows"][0]["label"], "roll 0°");
        assert!(!data.script.contains("http"));
    }

    #[test]
    fn series_on_other_x_values_are_an_error_naming_them() {
        let plot = LinePlot {
            title: "t".into(),
            series: vec![
                Series::new("a", vec![0.0, 1.0], vec![1.0, 2.0]),
                Series::new("b", vec![0.0, 2.0], vec![1.0, 2.0]),
            ],
            ..LinePlot::default()
        };
        let e = data_script("t", &plot, &Live::default()).unwrap_err();
        assert!(e.to_string().contains("series 'b'"), "{e}");
    }
}
