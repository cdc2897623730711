//! `stream --live`: a page an operator watches while the aircraft flies, served over HTTP
//! beside the stream. Values in nT, times in s (the stream's time column), rates in Hz.
//!
//! The stream never waits for the page: each compensated line is counted in atomics and handed
//! to a worker thread through a bounded channel with `try_send` (a full channel drops the
//! line from the charts and says so; the counters stay exact). The worker keeps the rolling
//! charts, the per-line statistics and the live box ([`tolles_core::maneuvers::live`]) and
//! publishes a snapshot a few times a second; each browser is served from that snapshot by a
//! thread of its own with socket timeouts, so a slow, stalled or closed browser costs only its
//! own thread. The same state is served as JSON at `/state.json` and pushed as server-sent
//! events at `/events`.

use crate::error::{Error, Result};
use serde_json::{json, Value};
use std::collections::VecDeque;
use std::io::{BufRead, BufReader, Write};
use std::net::{SocketAddr, TcpListener, TcpStream};
use std::sync::atomic::{AtomicBool, AtomicU64, AtomicUsize, Ordering};
use std::sync::mpsc::{sync_channel, Receiver, SyncSender, TryRecvError, TrySendError};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};
use tolles_core::maneuvers::live::{BoxSample, LiveBox, LiveBoxSettings};
use tolles_core::signal::metrics::{fourth_difference, std_dev};

/// What the live page serves and judges against.
#[derive(Debug, Clone, PartialEq)]
pub struct LiveRequest {
    /// Where to serve (e.g. `127.0.0.1:8080`; port 0 picks a free one).
    pub address: String,
    /// The survey specification's fourth-difference noise (nT): the noise tile turns to a
    /// warning above it, and a line fails.
    pub noise_spec_nt: f64,
    /// The figure of merit the box must pass (nT).
    pub fom_spec_nt: f64,
    /// The sample rate of the stream (Hz).
    pub fs_hz: f64,
    /// The model's verdict, as the page shows it.
    pub verdict: String,
}

impl LiveRequest {
    /// The verdict of `model`'s first fit (the scalar the page shows), `unknown` for a model
    /// file that has none.
    pub fn verdict_of(model: &crate::model::ModelFile) -> String {
        (model.fits.first().and_then(|f| f.fit.verdict.as_ref()))
            .map_or("unknown".to_string(), |v| v.grade.to_string())
    }

    /// A specification that is not a positive number of nT is refused.
    fn check(&self) -> Result<()> {
        for (what, value) in [
            ("--noise-spec", self.noise_spec_nt),
            ("--fom-spec", self.fom_spec_nt),
        ] {
            if !(value.is_finite() && value > 0.0) {
                return Err(Error::Invalid(format!(
                    "{what} must be a positive number of nT, got {value}"
                )));
            }
        }
        Ok(())
    }
}

/// The page's files: the HTML (with [`LIVE_ELEMENT`] where the state element goes) and the
/// chart library it loads.
#[derive(Debug, Clone)]
pub struct LivePage {
    /// The page.
    pub html: String,
    /// uPlot's script, served at `/uplot.js`.
    pub uplot_js: &'static str,
    /// uPlot's style sheet, served at `/uplot.css`.
    pub uplot_css: &'static str,
}

/// Where the page's HTML takes the state element, filled in when the page is served so a
/// browser (or a test dumping the DOM) sees the state without running a script.
pub const LIVE_ELEMENT: &str = "<!--live-state-->";

/// Lines queued for the worker before the charts start dropping some.
const QUEUE: usize = 1 << 18;
/// Seconds of flight the time chart shows (s).
const CHART_S: f64 = 300.0;
/// Most points a chart receives.
const CHART_POINTS: usize = 1500;
/// Seconds of flight the noise tile is taken over (s).
const NOISE_S: f64 = 10.0;
/// How often the worker takes what the stream queued.
const DRAIN: Duration = Duration::from_millis(20);
/// How often the worker publishes (and an event stream sends) a snapshot.
const PUBLISH: Duration = Duration::from_millis(250);
/// No line for this long and the stream reads as stalled.
const STALL: Duration = Duration::from_secs(3);
/// Browsers served at once; more wait to be accepted.
const MOST_CLIENTS: usize = 16;
/// A browser that takes longer than this to send its request or take a write is dropped.
const SOCKET_TIMEOUT: Duration = Duration::from_secs(2);

/// One compensated line, as the worker takes it.
#[derive(Debug, Clone, Copy)]
struct Sample {
    time_s: f64,
    raw_nt: f64,
    compensated_nt: f64,
    attitude_deg: Option<[f64; 3]>,
    line_id: Option<f64>,
}

/// What the stream hands the page, line by line; cheap and never blocking.
#[derive(Debug)]
pub struct LiveFeed {
    samples: AtomicU64,
    last_bits: AtomicU64,
    flagged: AtomicU64,
    dropped: AtomicU64,
    sender: SyncSender<Message>,
}

enum Message {
    Sample(Sample),
    Ended,
}

impl LiveFeed {
    /// Records one output line: its time (s), the uncompensated and compensated values (nT),
    /// its attitude (deg) and line id when the stream has them, and whether its status is ok.
    pub fn record(
        &self,
        time_s: f64,
        (raw_nt, compensated_nt): (f64, f64),
        attitude_deg: Option<[f64; 3]>,
        line_id: Option<f64>,
        ok: bool,
    ) {
        self.samples.fetch_add(1, Ordering::Relaxed);
        if compensated_nt.is_finite() {
            self.last_bits
                .store(compensated_nt.to_bits(), Ordering::Relaxed);
        }
        if !ok {
            self.flagged.fetch_add(1, Ordering::Relaxed);
        }
        let sample = Sample {
            time_s,
            raw_nt,
            compensated_nt,
            attitude_deg,
            line_id,
        };
        if let Err(TrySendError::Full(_)) = self.sender.try_send(Message::Sample(sample)) {
            self.dropped.fetch_add(1, Ordering::Relaxed);
        }
    }

    /// Says the input has ended: the worker scores what remains of the box.
    pub fn end(&self) {
        // Blocking here is fine: the stream has no more lines to answer.
        let _ = self.sender.send(Message::Ended);
    }

    fn counters(&self) -> (u64, Option<f64>, u64, u64) {
        let last = f64::from_bits(self.last_bits.load(Ordering::Relaxed));
        (
            self.samples.load(Ordering::Relaxed),
            last.is_finite().then_some(last),
            self.flagged.load(Ordering::Relaxed),
            self.dropped.load(Ordering::Relaxed),
        )
    }
}

/// The running page: its address and the feed the stream records into.
pub struct Live {
    address: SocketAddr,
    feed: Arc<LiveFeed>,
}

impl Live {
    /// Binds `request.address` (an error naming it when taken) and starts the worker and the
    /// server threads.
    pub fn start(request: LiveRequest, page: LivePage) -> Result<Live> {
        request.check()?;
        let listener = TcpListener::bind(&request.address).map_err(|source| Error::LiveBind {
            address: request.address.clone(),
            source,
        })?;
        let address = listener.local_addr().map_err(Error::StreamIo)?;
        let (sender, receiver) = sync_channel(QUEUE);
        let feed = Arc::new(LiveFeed {
            samples: AtomicU64::new(0),
            last_bits: AtomicU64::new(f64::NAN.to_bits()),
            flagged: AtomicU64::new(0),
            dropped: AtomicU64::new(0),
            sender,
        });
        let published = Arc::new(Mutex::new(Arc::new(Value::Null)));
        let ended = Arc::new(AtomicBool::new(false));
        let worker = Worker::new(&request, Arc::clone(&published), Arc::clone(&ended));
        std::thread::spawn(move || worker.run(receiver));
        let server = Server {
            feed: Arc::clone(&feed),
            published,
            ended,
            page: Arc::new(page),
            verdict: request.verdict,
            clients: Arc::new(AtomicUsize::new(0)),
        };
        std::thread::spawn(move || server.accept(listener));
        Ok(Live { address, feed })
    }

    /// The address served (with the port picked when 0 was asked for).
    pub fn address(&self) -> SocketAddr {
        self.address
    }

    /// The feed the stream records into.
    pub fn feed(&self) -> Arc<LiveFeed> {
        Arc::clone(&self.feed)
    }
}

/// The worker's state: charts, noise, lines and the box.
struct Worker {
    request: LiveRequest,
    published: Arc<Mutex<Arc<Value>>>,
    ended: Arc<AtomicBool>,
    chart: VecDeque<[f64; 3]>,
    chart_every: usize,
    seen: usize,
    noise: VecDeque<f64>,
    live_box: LiveBox,
    lines: Vec<Value>,
    line: Option<LineStats>,
    last_arrival: Option<Instant>,
    arrivals: VecDeque<Instant>,
}

impl Worker {
    fn new(
        request: &LiveRequest,
        published: Arc<Mutex<Arc<Value>>>,
        ended: Arc<AtomicBool>,
    ) -> Self {
        let fs_hz = request.fs_hz;
        let chart_every = ((CHART_S * fs_hz) / (4.0 * CHART_POINTS as f64))
            .ceil()
            .max(1.0);
        Self {
            request: request.clone(),
            published,
            ended,
            chart: VecDeque::new(),
            chart_every: chart_every as usize,
            seen: 0,
            noise: VecDeque::new(),
            live_box: LiveBox::new(fs_hz, LiveBoxSettings::default()),
            lines: Vec::new(),
            line: None,
            last_arrival: None,
            arrivals: VecDeque::new(),
        }
    }

    /// Drains the queue every [`DRAIN`] instead of waiting on it: a receiver blocked on the
    /// channel makes every send a wake-up system call, which the stream would pay line by line.
    fn run(mut self, receiver: Receiver<Message>) {
        let mut published_at = Instant::now();
        let mut idle_since = Instant::now();
        loop {
            std::thread::sleep(DRAIN);
            let mut took = false;
            loop {
                match receiver.try_recv() {
                    Ok(Message::Sample(s)) => {
                        self.take(s);
                        took = true;
                    }
                    Ok(Message::Ended) | Err(TryRecvError::Disconnected) => {
                        self.live_box.finish();
                        self.close_line();
                        self.ended.store(true, Ordering::Relaxed);
                        self.publish();
                        return;
                    }
                    Err(TryRecvError::Empty) => break,
                }
            }
            match took {
                true => idle_since = Instant::now(),
                // Nothing for a while: a paused stream shows what it has flown so far.
                false if idle_since.elapsed() >= PUBLISH => {
                    self.live_box.score_now();
                    idle_since = Instant::now();
                }
                false => {}
            }
            if published_at.elapsed() >= PUBLISH {
                self.publish();
                published_at = Instant::now();
            }
        }
    }

    fn take(&mut self, s: Sample) {
        let now = Instant::now();
        self.last_arrival = Some(now);
        self.arrivals.push_back(now);
        while self
            .arrivals
            .front()
            .is_some_and(|a| now - *a > Duration::from_secs(5))
        {
            self.arrivals.pop_front();
        }
        if self.seen.is_multiple_of(self.chart_every) {
            self.chart.push_back([s.time_s, s.raw_nt, s.compensated_nt]);
            let most = (CHART_S * self.request.fs_hz / self.chart_every as f64).ceil() as usize;
            while self.chart.len() > most.max(2) {
                self.chart.pop_front();
            }
        }
        self.seen += 1;
        self.noise.push_back(s.compensated_nt);
        while self.noise.len() as f64 > NOISE_S * self.request.fs_hz {
            self.noise.pop_front();
        }
        if let Some(attitude_deg) = s.attitude_deg {
            self.live_box.push(BoxSample {
                time_s: s.time_s,
                attitude_deg,
                raw_nt: s.raw_nt,
                compensated_nt: s.compensated_nt,
            });
        }
        self.follow_line(&s);
    }

    /// Per-line statistics: a new line id closes the previous line.
    fn follow_line(&mut self, s: &Sample) {
        let Some(id) = s.line_id.filter(|v| v.is_finite()) else {
            return;
        };
        if self.line.as_ref().is_some_and(|l| l.id != id) {
            self.close_line();
        }
        let line = self
            .line
            .get_or_insert_with(|| LineStats::new(id, s.time_s));
        line.push(s.time_s, s.compensated_nt);
    }

    fn close_line(&mut self) {
        if let Some(line) = self.line.take() {
            self.lines.push(line.to_json(self.request.noise_spec_nt));
        }
    }

    fn publish(&mut self) {
        let snapshot = Arc::new(self.snapshot());
        if let Ok(mut published) = self.published.lock() {
            *published = snapshot;
        }
    }

    fn snapshot(&self) -> Value {
        let stride = self.chart.len().div_ceil(CHART_POINTS).max(1);
        let points: Vec<&[f64; 3]> = self.chart.iter().step_by(stride).collect();
        let mean = |k: usize| {
            let finite: Vec<f64> = points
                .iter()
                .map(|p| p[k])
                .filter(|v| v.is_finite())
                .collect();
            finite.iter().sum::<f64>() / finite.len().max(1) as f64
        };
        let (raw_mean, comp_mean) = (mean(1), mean(2));
        let column = |f: &dyn Fn(&[f64; 3]) -> f64| -> Vec<Value> {
            points.iter().map(|p| finite_json(f(p))).collect()
        };
        let noise: Vec<f64> = self.noise.iter().copied().collect();
        let noise_nt = std_dev(&fourth_difference(&noise));
        let maneuvers: Vec<Value> = (self.live_box.flown().iter())
            .map(|m| {
                json!({
                    "kind": m.maneuver.kind.name(),
                    "heading_deg": m.maneuver.heading_deg,
                    "start_s": m.maneuver.start_tt,
                    "end_s": m.maneuver.end_tt,
                    "before_nt": finite_json(m.before_nt),
                    "after_nt": finite_json(m.after_nt),
                    "counted": m.counted,
                })
            })
            .collect();
        let slots = self.live_box.slots_flown();
        let fom = self.live_box.fom_nt().map(|(before, after)| {
            json!({
                "before_nt": before,
                "after_nt": after,
                "slots": slots,
                "complete": slots == 12,
                "spec_nt": self.request.fom_spec_nt,
                "pass": (slots == 12).then_some(after <= self.request.fom_spec_nt),
            })
        });
        let lines_per_s = self.arrivals.len() as f64 / 5.0;
        json!({
            "fs_hz": self.request.fs_hz,
            "lines_per_s": lines_per_s,
            "since_last_line_s": self.last_arrival.map(|t| t.elapsed().as_secs_f64()),
            "chart": {
                "time_s": column(&|p| p[0]),
                "uncompensated_nt": column(&|p| p[1] - raw_mean),
                "compensated_nt": column(&|p| p[2] - comp_mean),
                "correction_nt": column(&|p| p[1] - p[2]),
            },
            "noise_nt": finite_json(noise_nt),
            "noise_spec_nt": self.request.noise_spec_nt,
            "maneuvers": maneuvers,
            "fom": fom,
            "lines": self.lines,
            "current_line": self.line.as_ref().map(|l| l.id),
        })
    }
}

/// A flight line's running statistics.
struct LineStats {
    id: f64,
    start_s: f64,
    end_s: f64,
    samples: usize,
    recent: VecDeque<f64>,
    sum: f64,
    d4_sum: f64,
    d4_squares: f64,
    d4_count: usize,
    d4_peak: f64,
}

impl LineStats {
    fn new(id: f64, start_s: f64) -> Self {
        Self {
            id,
            start_s,
            end_s: start_s,
            samples: 0,
            recent: VecDeque::new(),
            sum: 0.0,
            d4_sum: 0.0,
            d4_squares: 0.0,
            d4_count: 0,
            d4_peak: 0.0,
        }
    }

    fn push(&mut self, time_s: f64, value: f64) {
        self.end_s = time_s;
        self.samples += 1;
        if !value.is_finite() {
            self.recent.clear();
            return;
        }
        self.sum += value;
        self.recent.push_back(value);
        if self.recent.len() > 5 {
            self.recent.pop_front();
        }
        if let [a, b, c, d, e] = self.recent.iter().copied().collect::<Vec<_>>()[..] {
            let d4 = (a - 4.0 * b + 6.0 * c - 4.0 * d + e) / 16.0;
            self.d4_sum += d4;
            self.d4_squares += d4 * d4;
            self.d4_count += 1;
            self.d4_peak = self.d4_peak.max(d4.abs());
        }
    }

    fn to_json(&self, spec_nt: f64) -> Value {
        let n = self.d4_count as f64;
        let noise = match self.d4_count {
            0 => f64::NAN,
            _ => (self.d4_squares / n - (self.d4_sum / n).powi(2))
                .max(0.0)
                .sqrt(),
        };
        json!({
            "line": self.id,
            "start_s": self.start_s,
            "end_s": self.end_s,
            "samples": self.samples,
            "mean_nt": finite_json(self.sum / self.samples.max(1) as f64),
            "noise_nt": finite_json(noise),
            "peak_fourth_difference_nt": finite_json(self.d4_peak),
            "pass": self.d4_count > 0 && self.d4_peak <= spec_nt,
        })
    }
}

fn finite_json(v: f64) -> Value {
    match v.is_finite() {
        true => json!(v),
        false => Value::Null,
    }
}

/// The HTTP side: one thread accepting, one per browser.
struct Server {
    feed: Arc<LiveFeed>,
    published: Arc<Mutex<Arc<Value>>>,
    ended: Arc<AtomicBool>,
    page: Arc<LivePage>,
    verdict: String,
    clients: Arc<AtomicUsize>,
}

impl Server {
    fn accept(self, listener: TcpListener) {
        let server = Arc::new(self);
        for connection in listener.incoming().flatten() {
            if server.clients.load(Ordering::Relaxed) >= MOST_CLIENTS {
                continue; // dropped: a browser retries
            }
            server.clients.fetch_add(1, Ordering::Relaxed);
            let server = Arc::clone(&server);
            std::thread::spawn(move || {
                let _ = server.answer(connection);
                server.clients.fetch_sub(1, Ordering::Relaxed);
            });
        }
    }

    fn answer(&self, connection: TcpStream) -> std::io::Result<()> {
        connection.set_read_timeout(Some(SOCKET_TIMEOUT))?;
        connection.set_write_timeout(Some(SOCKET_TIMEOUT))?;
        let path = request_path(&connection)?;
        let mut out = connection;
        match path.as_str() {
            "/" | "/index.html" => {
                let html = self.page.html.replace(LIVE_ELEMENT, &self.element());
                respond(&mut out, "text/html; charset=utf-8", html.as_bytes())
            }
            "/state.json" => {
                let state = self.state().to_string();
                respond(&mut out, "application/json", state.as_bytes())
            }
            "/uplot.js" => respond(&mut out, "text/javascript", self.page.uplot_js.as_bytes()),
            "/uplot.css" => respond(&mut out, "text/css", self.page.uplot_css.as_bytes()),
            "/events" => self.events(&mut out),
            _ => {
                let head =
                    "HTTP/1.1 404 Not Found\r\nContent-Length: 0\r\nConnection: close\r\n\r\n";
                out.write_all(head.as_bytes())
            }
        }
    }

    /// Server-sent events: the state a few times a second until the stream has ended (then
    /// once more) or the browser goes away.
    fn events(&self, out: &mut TcpStream) -> std::io::Result<()> {
        let head =
            "HTTP/1.1 200 OK\r\nContent-Type: text/event-stream\r\nCache-Control: no-cache\r\n\
                    Connection: keep-alive\r\n\r\n";
        out.write_all(head.as_bytes())?;
        loop {
            let ended = self.ended.load(Ordering::Relaxed);
            write!(out, "data: {}\n\n", self.state())?;
            out.flush()?;
            if ended {
                return Ok(());
            }
            std::thread::sleep(PUBLISH);
        }
    }

    /// The worker's snapshot with the exact counters.
    fn state(&self) -> Value {
        let (samples, last, flagged, dropped) = self.feed.counters();
        let snapshot = self
            .published
            .lock()
            .map(|p| Arc::clone(&p))
            .unwrap_or_default();
        let mut state = match snapshot.as_ref() {
            Value::Object(map) => map.clone(),
            _ => serde_json::Map::new(),
        };
        let ended = self.ended.load(Ordering::Relaxed);
        let stalled = state
            .get("since_last_line_s")
            .and_then(Value::as_f64)
            .is_some_and(|s| s > STALL.as_secs_f64());
        let status = match (ended, stalled, samples) {
            (true, _, _) => "ended",
            (false, _, 0) => "waiting",
            (false, true, _) => "stalled",
            (false, false, _) => "running",
        };
        state.insert("samples".into(), json!(samples));
        state.insert("last_nt".into(), last.map_or(Value::Null, |v| json!(v)));
        state.insert("flagged".into(), json!(flagged));
        state.insert("dropped".into(), json!(dropped));
        state.insert("verdict".into(), json!(self.verdict));
        state.insert("status".into(), json!(status));
        Value::Object(state)
    }

    /// The element `id="live"` with the state in data attributes (values as the stream
    /// prints them: shortest round-trip decimals).
    fn element(&self) -> String {
        let state = self.state();
        let number = |key: &str| state.get(key).and_then(Value::as_f64);
        let fom = state.pointer("/fom/after_nt").and_then(Value::as_f64);
        let mut attributes = format!(
            "data-samples=\"{}\" data-verdict=\"{}\" data-status=\"{}\"",
            state.get("samples").and_then(Value::as_u64).unwrap_or(0),
            attribute(&self.verdict),
            state.get("status").and_then(Value::as_str).unwrap_or(""),
        );
        if let Some(last) = number("last_nt") {
            attributes += &format!(" data-last-nt=\"{last}\"");
        }
        if let Some(fom) = fom {
            attributes += &format!(" data-fom-nt=\"{fom}\"");
        }
        format!("<div id=\"live\" {attributes}></div>")
    }
}

/// `text` safe inside a double-quoted HTML attribute.
fn attribute(text: &str) -> String {
    text.replace('&', "&amp;")
        .replace('"', "&quot;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
}

/// The path of the request on `connection` (headers read and dropped, at most 8 KiB).
fn request_path(connection: &TcpStream) -> std::io::Result<String> {
    let mut reader = BufReader::new(std::io::Read::take(connection, 8192));
    let mut first = String::new();
    reader.read_line(&mut first)?;
    let mut header = String::new();
    while reader.read_line(&mut header)? > 2 {
        header.clear();
    }
    let path = first.split_whitespace().nth(1).unwrap_or("/");
    Ok(path.split('?').next().unwrap_or("/").to_string())
}

fn respond(out: &mut TcpStream, kind: &str, body: &[u8]) -> std::io::Result<()> {
    write!(
        out,
        "HTTP/1.1 200 OK\r\nContent-Type: {kind}\r\nContent-Length: {}\r\nCache-Control: no-store\r\n\
         Connection: close\r\n\r\n",
        body.len()
    )?;
    out.write_all(body)?;
    out.flush()
}
