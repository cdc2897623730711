//! The page `tolles stream --live` serves: what an operator watches in flight (the compensated
//! trace over the last minutes, the fourth-difference noise against the specification, the
//! box's maneuvers and figure of merit as they are flown, each line as it completes, and the
//! stream's health). Values in nT, times in s of the stream's time column.
//!
//! The page is static; its script takes the state the server pushes at `/events` (server-sent
//! events, polling `/state.json` where a browser cannot) and keeps the element `id="live"`'s
//! data attributes (`data-samples`, `data-last-nt`, `data-fom-nt`, `data-verdict`,
//! `data-status`) equal to it, for tests and automation. The server fills that element in
//! before sending the page, so it holds the state even with scripts off.

/// The page's HTML for a stream of `title`; `element` marks where the server puts the state
/// element (see `tolles::live::LIVE_ELEMENT`).
pub fn page(title: &str, element: &str) -> String {
    PAGE.replace("{{TITLE}}", &crate::html::escape(title))
        .replace("{{STYLE}}", STYLE)
        .replace("{{SCRIPT}}", SCRIPT)
        .replace("{{LIVE}}", element)
}

/// uPlot, which the page loads from the server (`/uplot.js`, `/uplot.css`).
pub use crate::live::{UPLOT_CSS, UPLOT_JS};

const PAGE: &str = r#"<!DOCTYPE html>
<html lang="en">
<head>
<meta charset="utf-8">
<meta name="viewport" content="width=device-width, initial-scale=1">
<title>{{TITLE}}</title>
<link rel="stylesheet" href="/uplot.css">
<style>{{STYLE}}</style>
</head>
<body>
{{LIVE}}
<header><h1>{{TITLE}}</h1><p id="status-line">connecting…</p></header>
<main>
<section class="tiles">
  <div class="tile" id="tile-verdict"><span>model verdict</span><b id="verdict">—</b></div>
  <div class="tile" id="tile-samples"><span>lines compensated</span><b id="samples">0</b></div>
  <div class="tile" id="tile-last"><span>last compensated (nT)</span><b id="last">—</b></div>
  <div class="tile" id="tile-noise"><span>4th-difference noise, last 10 s (nT)</span><b id="noise">—</b></div>
  <div class="tile" id="tile-fom"><span>figure of merit after (nT)</span><b id="fom">—</b></div>
  <div class="tile" id="tile-flagged"><span>lines flagged</span><b id="flagged">0</b></div>
</section>
<section><h2>The last minutes</h2><div id="chart"></div>
<p class="note">Uncompensated and compensated scalar, each less its mean over the chart, and the
correction (uncompensated − compensated, less its mean). Drag to zoom; double-click for all.</p></section>
<section><h2>Compensation box</h2><p id="fom-line">No maneuver flown yet.</p>
<table><thead><tr><th>maneuver</th><th>heading (°)</th><th>time (s)</th><th>before (nT)</th>
<th>after (nT)</th><th>counted</th></tr></thead><tbody id="maneuvers"></tbody></table></section>
<section><h2>Lines</h2><table><thead><tr><th>line</th><th>time (s)</th><th>samples</th>
<th>noise (nT)</th><th>peak 4th diff (nT)</th><th>within spec</th></tr></thead>
<tbody id="lines"></tbody></table></section>
</main>
<script src="/uplot.js"></script>
<script>{{SCRIPT}}</script>
</body>
</html>
"#;

const STYLE: &str = r#"
body { font-family: system-ui, sans-serif; margin: 0; color: #1d2733; background: #f6f8fa; }
header { background: #17324d; color: #fff; padding: 14px 24px; }
header h1 { margin: 0; font-size: 20px; }
header p { margin: 4px 0 0; font-size: 14px; color: #cfe0f0; }
main { padding: 12px 24px 40px; max-width: 1200px; }
.tiles { display: grid; grid-template-columns: repeat(auto-fill, minmax(170px, 1fr)); gap: 10px; }
.tile { background: #fff; border: 1px solid #d6dde5; border-radius: 8px; padding: 8px 12px; }
.tile span { display: block; font-size: 12px; color: #5a6877; }
.tile b { font-size: 22px; }
.tile.warn { background: #fff1e6; border-color: #e07b22; }
.tile.bad { background: #fde8e8; border-color: #c43b3b; }
.tile.ok { background: #eaf7ee; border-color: #3f9a5a; }
section { margin-top: 18px; }
h2 { font-size: 16px; margin: 0 0 6px; }
table { border-collapse: collapse; background: #fff; font-size: 13px; }
th, td { border-bottom: 1px solid #e3e8ee; padding: 3px 10px; text-align: right; }
.note { font-size: 12px; color: #5a6877; }
"#;

const SCRIPT: &str = r##"
(function () {
  var chart = null, since = Date.now();
  function fmt(v, d) { return (v === null || v === undefined) ? "—" : Number(v).toFixed(d); }
  function setTile(id, cls) {
    var t = document.getElementById(id); t.classList.remove("ok", "warn", "bad");
    if (cls) { t.classList.add(cls); }
  }
  function draw(c) {
    var data = [c.time_s, c.uncompensated_nt, c.compensated_nt, c.correction_nt];
    if (!window.uPlot) { return; }
    if (!chart) {
      var el = document.getElementById("chart");
      chart = new uPlot({ width: Math.max(400, el.clientWidth || 900), height: 300,
        scales: { x: { time: false } },
        series: [{ label: "time (s)" },
          { label: "uncompensated", stroke: "#c0392b" },
          { label: "compensated", stroke: "#1f6fb2" },
          { label: "correction", stroke: "#7f8c8d" }] }, data, el);
    } else { chart.setData(data); }
  }
  function rows(id, items, cells) {
    var body = document.getElementById(id); body.innerHTML = "";
    items.forEach(function (it) {
      var tr = document.createElement("tr");
      cells(it).forEach(function (c) { var td = document.createElement("td"); td.textContent = c; tr.appendChild(td); });
      body.appendChild(tr);
    });
  }
  function show(s) {
    since = Date.now();
    var live = document.getElementById("live");
    live.dataset.samples = String(s.samples);
    live.dataset.verdict = s.verdict;
    live.dataset.status = s.status;
    if (s.last_nt !== null) { live.dataset.lastNt = String(s.last_nt); }
    if (s.fom) { live.dataset.fomNt = String(s.fom.after_nt); } else { delete live.dataset.fomNt; }
    document.getElementById("verdict").textContent = s.verdict;
    setTile("tile-verdict", s.verdict === "good" ? "ok" : "warn");
    document.getElementById("samples").textContent = s.samples;
    document.getElementById("last").textContent = fmt(s.last_nt, 3);
    document.getElementById("flagged").textContent = s.flagged + (s.dropped ? " (" + s.dropped + " not charted)" : "");
    setTile("tile-flagged", s.flagged ? "warn" : null);
    document.getElementById("noise").textContent = fmt(s.noise_nt, 4) + " / " + s.noise_spec_nt;
    setTile("tile-noise", s.noise_nt === null ? null : (s.noise_nt > s.noise_spec_nt ? "bad" : "ok"));
    if (s.fom) {
      document.getElementById("fom").textContent = fmt(s.fom.after_nt, 3);
      var verdict = s.fom.complete ? (s.fom.pass ? "passes" : "FAILS") + " the " + s.fom.spec_nt + " nT specification" : s.fom.slots + " of 12 maneuvers flown";
      document.getElementById("fom-line").textContent = "FOM " + fmt(s.fom.before_nt, 3) + " nT before, " + fmt(s.fom.after_nt, 3) + " nT after: " + verdict + ".";
      setTile("tile-fom", s.fom.complete ? (s.fom.pass ? "ok" : "bad") : null);
    }
    rows("maneuvers", s.maneuvers || [], function (m) {
      return [m.kind, fmt(m.heading_deg, 0), fmt(m.start_s, 1) + "–" + fmt(m.end_s, 1), fmt(m.before_nt, 3), fmt(m.after_nt, 4), m.counted ? "yes" : ""];
    });
    rows("lines", s.lines || [], function (l) {
      return [l.line, fmt(l.start_s, 1) + "–" + fmt(l.end_s, 1), l.samples, fmt(l.noise_nt, 4), fmt(l.peak_fourth_difference_nt, 3), l.pass ? "pass" : "FAIL"];
    });
    document.getElementById("status-line").textContent = "stream " + s.status + " · " +
      fmt(s.lines_per_s, 1) + " lines/s · last line " + fmt(s.since_last_line_s, 1) + " s ago · " + fmt(s.fs_hz, 3) + " Hz";
    if (s.chart) { draw(s.chart); }
  }
  function poll() {
    fetch("/state.json").then(function (r) { return r.json(); }).then(show)
      .catch(function () { document.getElementById("status-line").textContent = "stream gone: the page shows its last state"; })
      .finally(function () { setTimeout(poll, 1000); });
  }
  if (window.EventSource) {
    var events = new EventSource("/events");
    events.onmessage = function (e) { show(JSON.parse(e.data)); };
    events.onerror = function () {
      events.close();
      setTimeout(poll, 1000);
    };
  } else { poll(); }
})();
"##;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_page_holds_the_state_element_and_escapes_its_title() {
        let html = page("m <1>.json", "<div id=\"live\" data-samples=\"0\"></div>");
        assert!(html.contains("<title>m &lt;1&gt;.json</title>"));
        assert!(html.contains("<div id=\"live\" data-samples=\"0\"></div>"));
        assert!(html.contains("new EventSource(\"/events\")"));
        assert!(!html.contains("{{"));
    }
}
