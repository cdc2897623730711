//! HTML text: escaping, the page's style sheet and its self-check.
//!
//! ```
//! use tolles_report::html::escape;
//! assert_eq!(escape("<b>\"σ\" & 'x'</b>"), "&lt;b&gt;&quot;σ&quot; &amp; &#39;x&#39;&lt;/b&gt;");
//! ```

/// `text` made safe for HTML element content and quoted attribute values.
pub fn escape(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    for c in text.chars() {
        match c {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            '\'' => out.push_str("&#39;"),
            _ => out.push(c),
        }
    }
    out
}

/// Whether a table or key–value cell reads as a number (so it is right-aligned in tabular
/// figures): an optional sign, digits, and at most a short unit or percent after a space.
pub fn is_numeric(cell: &str) -> bool {
    let cell = cell.trim();
    let number = cell.split_whitespace().next().unwrap_or("");
    let number = number
        .trim_end_matches('%')
        .replace(['\u{2009}', '\u{202f}'], "");
    let number = number.replace('−', "-").replace('×', "*");
    let words = cell.split_whitespace().count();
    !number.is_empty() && words <= 2 && (number.parse::<f64>().is_ok() || is_scientific(&number))
}

fn is_scientific(s: &str) -> bool {
    // "1.2*10⁻³" as printed by `format_tick`.
    s.split_once("*10")
        .is_some_and(|(m, e)| m.parse::<f64>().is_ok() && !e.is_empty())
}

/// Turns `heading` into an id usable in a URL fragment or a file name.
pub fn slug(heading: &str) -> String {
    let mut out = String::new();
    for c in heading.chars().flat_map(char::to_lowercase) {
        if c.is_ascii_alphanumeric() {
            out.push(c);
        } else if !out.ends_with('-') && !out.is_empty() {
            out.push('-');
        }
        if out.len() >= 40 {
            break;
        }
    }
    let out = out.trim_end_matches('-').to_string();
    if out.is_empty() {
        "plot".to_string()
    } else {
        out
    }
}

/// The page's style sheet: system fonts only, nothing fetched.
pub const STYLE: &str = r#"
:root {
  --ink: #1f2328; --muted: #5f6872; --line: #e3e6ea; --wash: #f6f8fa;
  --accent: #0072b2; --head: #16324f;
}
* { box-sizing: border-box; }
html { -webkit-text-size-adjust: 100%; }
body {
  margin: 0; color: var(--ink); background: #fff;
  font: 16px/1.55 system-ui, -apple-system, "Segoe UI", Roboto, "Noto Sans", "Liberation Sans",
    "DejaVu Sans", Arial, sans-serif;
}
.wrap { max-width: 1060px; margin: 0 auto; padding: 0 28px; }
header.masthead { background: var(--head); color: #fff; padding: 34px 0 30px; }
.kicker { margin: 0 0 4px; font-size: 13px; letter-spacing: .08em;
  color: #9fc3e6; font-weight: 600; }
header h1 { margin: 0; font-size: 32px; line-height: 1.2; font-weight: 650;
  overflow-wrap: anywhere; }
header .subtitle { margin: 8px 0 0; color: #cfdbe7; max-width: 70ch; }
.summary { display: grid; grid-template-columns: repeat(auto-fill, minmax(180px, 1fr));
  gap: 12px; margin: 24px 0 0; }
.summary div { background: rgba(255,255,255,.08); border: 1px solid rgba(255,255,255,.14);
  border-radius: 8px; padding: 10px 14px; }
.summary dt { font-size: 13px; color: #b8cde0; letter-spacing: .02em; }
.summary-note { margin: 14px 0 0; font-size: 13px; color: #b8cde0; max-width: 95ch; }
.summary dd { margin: 2px 0 0; font-size: 21px; font-weight: 600;
  font-variant-numeric: tabular-nums; }
nav.toc { border-bottom: 1px solid var(--line); background: var(--wash); font-size: 14px; }
nav.toc ol { list-style: none; margin: 0; padding: 10px 0; display: flex; flex-wrap: wrap; gap: 4px 22px; }
nav.toc a { color: var(--muted); text-decoration: none; }
nav.toc a:hover { color: var(--accent); }
main { padding: 8px 0 40px; }
h2 { font-size: 23px; margin: 40px 0 12px; padding-bottom: 6px; border-bottom: 2px solid var(--line);
  color: var(--head); }
p { margin: 10px 0; max-width: 80ch; }
dl.kv { display: grid; grid-template-columns: max-content auto; gap: 0; margin: 14px 0;
  border: 1px solid var(--line); border-radius: 8px; overflow: hidden; width: fit-content;
  min-width: 420px; }
dl.kv dt, dl.kv dd { margin: 0; padding: 7px 16px; border-bottom: 1px solid var(--line); }
dl.kv dt { color: var(--muted); background: var(--wash); }
dl.kv dd.num { text-align: right; font-variant-numeric: tabular-nums; }
dl.kv dt:nth-last-of-type(1), dl.kv dd:last-of-type { border-bottom: 0; }
.table-wrap { overflow-x: auto; margin: 14px 0; border: 1px solid var(--line); border-radius: 8px;
  width: fit-content; max-width: 100%; min-width: 420px; }
table { border-collapse: collapse; width: 100%; font-size: 14px; }
th, td { padding: 6px 8px; text-align: left; white-space: nowrap; }
thead th { white-space: normal; vertical-align: bottom; }
thead th { background: var(--wash); color: var(--muted); font-weight: 600; font-size: 13px;
  border-bottom: 1px solid var(--line); }
tbody tr + tr td { border-top: 1px solid var(--line); }
tbody tr:hover { background: #fafbfc; }
td.num, th.num { text-align: right; font-variant-numeric: tabular-nums; }
figure.plot { margin: 22px 0 30px; border: 1px solid var(--line); border-radius: 10px;
  padding: 14px 16px 10px; }
figure.plot h3 { margin: 0; font-size: 17px; }
ul.legend { list-style: none; margin: 6px 0 4px; padding: 0; display: flex; flex-wrap: wrap;
  gap: 4px 18px; font-size: 14px; color: var(--muted); }
ul.legend svg { margin: 0 7px 2px 0; vertical-align: middle; }
figure img { display: block; width: 100%; height: auto; }
figure .note { margin: 4px 0 0; font-size: 13px; color: var(--muted); }
figure .caption { margin: 8px 0 0; font-size: 14px; }
.grid { display: grid; gap: 12px; margin: 18px 0 28px; }
figure.cell { margin: 0; border: 1px solid var(--line); border-radius: 8px; padding: 8px 10px;
  break-inside: avoid; }
figure.cell h3 { margin: 0 0 4px; font-size: 15px; }
figure.cell img + img { margin-top: 2px; }
figure.cell .caption { font-size: 13px; margin-top: 4px; }
footer { border-top: 1px solid var(--line); color: var(--muted); font-size: 13px; padding: 16px 0 30px; }
.live-chart { margin: 6px 0 0; min-height: 0; }
.live-controls { display: flex; gap: 6px; margin: 4px 0 0; }
.live-controls button { font: inherit; font-size: 13px; line-height: 1; padding: 5px 10px;
  border: 1px solid var(--line); border-radius: 6px; background: var(--wash); color: var(--ink);
  cursor: pointer; }
.live-controls button:hover { border-color: var(--accent); color: var(--accent); }
figure:not(.is-live) .live-note, figure:not(.is-live) .live-controls { display: none; }
figure.is-live > img, figure.is-live > .svg-note, figure.is-live > ul.legend { display: none; }
.uplot { font-family: inherit; }
.uplot .u-legend { font-size: 13px; text-align: left; }
@media print { .live-chart, .live-controls, .live-note { display: none !important; }
  figure.is-live > img, figure.is-live > .svg-note, figure.is-live > ul.legend { display: block; }
  figure.is-live > ul.legend { display: flex; } }
/* A4, as survey contracts outside North America are written; numbered pages under a running
   header (the title, in a second @page rule the page adds). */
@page { size: A4; margin: 16mm 12mm 14mm;
  @bottom-right { content: "page " counter(page) " of " counter(pages); font-size: 8pt;
    color: #555; } }
@media print {
  .wrap { max-width: none; padding: 0; }
  header.masthead { background: #fff; color: #000; padding: 0 0 12px; }
  header .kicker, header .subtitle, .summary dt, .summary-note { color: #333; }
  .summary div { background: #fff; border-color: #999; }
  nav.toc, #tolles-check { display: none; }
  main > h2:not(:first-child) { break-before: page; }
  h2, h3 { break-after: avoid; }
  /* A long table splits across pages (its header repeats); every column stays on the page. */
  figure, dl.kv, tr, .grid { break-inside: avoid; }
  /* A short table prints whole, and the sentence that introduces it stays on its page. */
  .table-wrap.short { break-inside: avoid; }
  p:has(+ .table-wrap), p:has(+ .grid), p:has(+ figure) { break-after: avoid; }
  .grid.many { break-inside: auto; }
  p { orphans: 3; widows: 3; }
  footer { break-before: avoid; }
  .table-wrap { overflow: visible; width: auto; max-width: none; min-width: 0; }
  table { font-size: 8.5pt; }
  th, td { padding: 2px 5px; }
  thead { display: table-header-group; }
  .written-by { color: #333; }
  tbody tr:hover { background: none; }
}
"#;

/// Runs first, in the page's head: records script errors, failed loads of scripts, images and
/// style sheets, and `console.error` calls in `window.tollesErrors`, which [`SELF_CHECK`]
/// reports.
pub const ERROR_CAPTURE: &str = r#"
window.tollesErrors = [];
window.addEventListener("error", function (e) {
  var t = e.target;
  if (t && t !== window && (t.src || t.href)) {
    window.tollesErrors.push("failed to load " + (t.getAttribute("src") || t.getAttribute("href")));
  } else {
    window.tollesErrors.push("script error: " + (e.message || "unknown") +
      (e.filename ? " (" + e.filename.split("/").pop() + ":" + e.lineno + ")" : ""));
  }
}, true);
(function () {
  var original = console.error;
  console.error = function () {
    window.tollesErrors.push("console error: " + Array.prototype.join.call(arguments, " "));
    return original.apply(console, arguments);
  };
})();
"#;

/// Runs when the page has loaded: every `<img>` must have decoded, every inline `<svg>` must
/// have a size, every figure meant to be live must hold a started chart with data on a canvas
/// of some size, and no error may have been recorded (see [`ERROR_CAPTURE`]). The verdict goes
/// into `#tolles-check` ("ok N images M inline svg K live" or "broken: …"), which
/// `scripts/check-report` reads from a headless browser.
pub const SELF_CHECK: &str = r#"
window.addEventListener("load", function () {
  var broken = (window.tollesErrors || []).slice();
  var images = document.images;
  for (var i = 0; i < images.length; i++) {
    var im = images[i];
    if (!(im.complete && im.naturalWidth > 0)) broken.push(im.getAttribute("src"));
  }
  var svgs = document.querySelectorAll("svg");
  for (var k = 0; k < svgs.length; k++) {
    if (svgs[k].getClientRects().length === 0) continue; // not displayed (a hidden legend)
    var r = svgs[k].getBoundingClientRect();
    if (!(r.width > 0 && r.height > 0)) broken.push("inline svg #" + (k + 1));
  }
  var wanted = document.querySelectorAll("figure[data-live]").length;
  var started = (window.tollesCharts || []).filter(function (u) {
    return u.data[0].length > 0 && u.ctx.canvas.width > 0 && u.ctx.canvas.height > 0;
  }).length;
  if (started !== wanted) broken.push("live charts: " + started + " of " + wanted + " started");
  document.getElementById("tolles-check").textContent = broken.length
    ? "broken: " + broken.join(" ")
    : "ok " + images.length + " images " + svgs.length + " inline svg " + started + " live";
});
"#;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn escaping_covers_every_special_character() {
        assert_eq!(
            escape("a<b>&\"c\"'d'"),
            "a&lt;b&gt;&amp;&quot;c&quot;&#39;d&#39;"
        );
        assert_eq!(
            escape("</script><script>alert(1)</script>"),
            "&lt;/script&gt;&lt;script&gt;alert(1)&lt;/script&gt;"
        );
        assert_eq!(escape("nT² · σ"), "nT² · σ");
    }

    #[test]
    fn numbers_are_recognised_with_units_but_prose_is_not() {
        for yes in [
            "1.5",
            "-3",
            "1e-4",
            "12 nT",
            "87 %",
            "45%",
            "−0.2",
            "1 234",
            "4.2×10⁻³",
        ] {
            assert!(is_numeric(yes), "{yes}");
        }
        for no in ["", "mag_1_uc", "n/a", "line 1002.0 east", "nT", "auto"] {
            assert!(!is_numeric(no), "{no}");
        }
    }

    #[test]
    fn slugs_are_safe_file_names() {
        assert_eq!(slug("Noise spectrum (nT²/Hz)"), "noise-spectrum-nt-hz");
        assert_eq!(slug("../../etc/passwd"), "etc-passwd");
        assert_eq!(slug("σ"), "plot");
    }
}
