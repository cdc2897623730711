//! Real-time compensation of CSV lines: one output line for every input line, from any reader
//! (standard input, a TCP connection) to any writer, with counters and a latency histogram.
//!
//! ```
//! use std::path::Path;
//! use tolles::stream::{serve, Setup, Stats, StreamRequest};
//! # use tolles::{fit, simulate, Silent};
//! # let flight = simulate::simulate(&Default::default(), &Silent).unwrap();
//! # let dir = tempfile::tempdir().unwrap();
//! # let path = dir.path().join("box.csv");
//! # simulate::write(&flight, &path).unwrap();
//! # let data = tolles::read::read(&path, &Default::default(), &Silent, &mut Vec::new()).unwrap();
//! # let request = fit::FitRequest::new(vec!["mag_1_uc".into()], vec!["flux_a".into()]);
//! # let model = fit::fit(&data.table, &request, &Silent, &mut Vec::new()).unwrap();
//! let setup = Setup::new(&model, Path::new("model.json"), &StreamRequest::default()).unwrap();
//! let stats = Stats::default();
//! let input = "tt,mag_1_uc,flux_a_x,flux_a_y,flux_a_z\n0,50000,20000,3000,45000\n0.1,50001,,3000,45000\n";
//! let mut output = Vec::new();
//! serve(&setup, &stats, input.as_bytes(), &mut output).unwrap();
//! let text = String::from_utf8(output).unwrap();
//! let lines: Vec<&str> = text.lines().collect();
//! assert_eq!(lines[0], "tt,mag_1_uc,flux_a_x,flux_a_y,flux_a_z,mag_1_c,status");
//! assert_eq!(lines.len(), 3); // one line out for every line in
//! assert!(lines[2].ends_with(",missing flux_a_x"));
//! assert_eq!(stats.take_health().flagged, 1);
//! ```
//!
//! The level subtracted is the calibration flight's mean of the correction stored in the model
//! (a stream cannot know a file's mean), so the result differs from [`crate::compensate`] by a
//! constant. A time step over 1.5 nominal steps, a step backwards, a bad value or a malformed
//! line restarts the derivative, as batch compensation splits runs (see
//! [`tolles_core::compensate::stream`]). Extra channels are read from each line and low-passed
//! and lagged as the model says; a lag that needs later samples (a fluxgate lag, an extra
//! channel's negative lag) holds lines back until they arrive ([`Setup::delay_samples`]), and
//! the values are then exactly those of [`crate::compensate`]
//! ([`tolles_core::compensate::align`]). Output is flushed whenever no more input is waiting; writes block
//! when the reader is slow, so nothing queues without bound.

use crate::error::{Error, Result};
use crate::live::LiveFeed;
use crate::model::ModelFile;
use std::io::{BufRead, BufReader, ErrorKind, Read, Write};
use std::net::{TcpListener, TcpStream};
use std::path::Path;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex, PoisonError};
use std::time::{Duration, Instant};
use tolles_core::compensate::adapt::AdaptSettings;
use tolles_core::compensate::align::{Aligner, Channel};
pub use tolles_core::compensate::stream::Derivative;
use tolles_core::compensate::stream::{Flag, Output, Sample, ScalarSpec, StreamCompensator, Trust};
use tolles_core::model::extra::{ExtraChannel, LowPass};
use tolles_core::signal::shift::Shift;
use tolles_io::stream_line::{CellFlag, Layout, Line};

/// How to stream.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StreamRequest {
    /// Fluxgate derivative: `Central` waits one sample for the next (as batch compensation),
    /// `Causal` answers at once with a backward difference.
    pub derivative: Derivative,
    /// Nominal sample rate of the stream (Hz); default: the model's.
    pub fs_hz: Option<f64>,
    /// Keep learning the coefficients during maneuvers (Kalman filter on the 0.1–0.9 Hz
    /// band-passed design rows, prior 5 nT per coefficient, updated only when a band-passed
    /// row's norm exceeds 0.02); each stream starts from the model's coefficients.
    pub adapt: bool,
    /// The longest line accepted (bytes, without its line ending), so one client cannot grow
    /// the server without bound: on standard input a longer line gets a `malformed` output
    /// line, over TCP it ends that client's stream. Default [`DEFAULT_MAX_LINE_BYTES`].
    pub max_line_bytes: usize,
    /// How long a TCP client may send nothing before its connection is closed (its thread
    /// freed); `None` waits for ever. Default [`DEFAULT_IDLE_TIMEOUT`].
    pub idle_timeout: Option<Duration>,
    /// After each compensated column NAME, also NAME_sigma (the compensated value's standard
    /// error up to a constant level, nT) and NAME_extrapolated (1 outside what the calibration flew, else 0), as
    /// `compensate --uncertainty` writes them.
    pub uncertainty: bool,
}

/// The default longest line: 1 MiB, far beyond any flight record.
pub const DEFAULT_MAX_LINE_BYTES: usize = 1 << 20;
/// The default idle timeout of a TCP client: 5 minutes.
pub const DEFAULT_IDLE_TIMEOUT: Duration = Duration::from_secs(300);

impl Default for StreamRequest {
    fn default() -> Self {
        Self {
            derivative: Derivative::Central,
            fs_hz: None,
            adapt: false,
            max_line_bytes: DEFAULT_MAX_LINE_BYTES,
            idle_timeout: Some(DEFAULT_IDLE_TIMEOUT),
            uncertainty: false,
        }
    }
}

/// Everything a new stream needs from the model; one setup serves any number of streams.
#[derive(Debug, Clone)]
pub struct Setup {
    specs: Vec<ScalarSpec>,
    /// The fluxgate prefixes the header must have.
    fluxgates: Vec<String>,
    /// The extra channel columns the header must have.
    extra_columns: Vec<String>,
    /// The fluxgates as the scalars' models read them: one per fluxgate, lag and extra channels.
    groups: Vec<Group>,
    /// The extra channels as the models condition them, each once.
    extras: Vec<ExtraChannel>,
    outputs: Vec<String>,
    /// Whether each compensated column is followed by its standard error and flag.
    uncertainty: bool,
    fs_hz: f64,
    derivative: Derivative,
    adapt: bool,
    max_line_bytes: usize,
    idle_timeout: Option<Duration>,
    /// Columns of every stream's header renamed `(old, new)` before the model's are looked up.
    renames: Vec<(String, String)>,
    /// What the caller should be told before the first line (see [`Setup::warnings`]).
    warnings: Vec<crate::Warning>,
    /// Where each output line of the first scalar is also recorded for the live page.
    live: Option<Arc<LiveFeed>>,
}

impl Setup {
    /// The same setup with each stream's header columns renamed `(old, new)` first (see
    /// [`Layout::from_header_renamed`]); an unknown `old` is an error of that stream's header.
    pub fn with_renames(mut self, renames: Vec<(String, String)>) -> Self {
        self.renames = renames;
        self
    }

    /// The streaming form of `model` (read from `path`, which names it in errors). Every fit
    /// must use a single fluxgate; fits may share one. Extra channels are read from each line
    /// and conditioned (low-pass, lag) as in `compensate`; a lag of the fluxgate or an extra
    /// channel that needs later samples holds every line back until they arrive
    /// ([`Setup::delay_samples`]).
    pub fn new(model: &ModelFile, path: &Path, request: &StreamRequest) -> Result<Self> {
        crate::compensate::check_model(model, path)?;
        let fs_hz = request.fs_hz.unwrap_or(model.fits[0].fit.fs_hz);
        if !(fs_hz.is_finite() && fs_hz > 0.0) {
            return Err(Error::BadSampleRate { fs_hz });
        }
        let mut fluxgates: Vec<String> = Vec::new();
        let mut groups: Vec<Group> = Vec::new();
        let mut extras: Vec<ExtraChannel> = Vec::new();
        let mut specs = Vec::new();
        let mut warnings = Vec::new();
        for m in &model.fits {
            if m.network.is_some() && request.adapt {
                return Err(Error::StreamNetwork {
                    path: path.to_path_buf(),
                    scalar: m.scalar.clone(),
                });
            }
            let [vector] = &m.vectors[..] else {
                return Err(Error::StreamFluxgates {
                    path: path.to_path_buf(),
                    scalar: m.scalar.clone(),
                    vectors: m.vectors.clone(),
                });
            };
            let group = Group {
                fluxgate: index_of(&mut fluxgates, vector.clone()),
                lag_s: m.fit.lag_s,
                extras: (m.fit.settings.design.extras.iter())
                    .map(|e| index_of(&mut extras, e.clone()))
                    .collect(),
            };
            let j = index_of(&mut groups, group);
            let fit = &m.fit;
            let design = fit.settings.design.clone();
            let ratio = fs_hz / fit.fs_hz;
            let spec =
                ScalarSpec::new(&m.scalar, j, design, &fit.coefficients, fit.level_nt, ratio)
                    .with_magnitude(fit.magnitude)
                    .with_flux_offset(fit.flux_offset_nt);
            // The network's own channels are read and passed like extra channels, unfiltered.
            let spec = match &m.network {
                Some(learned) => {
                    let channels = (learned.channels.iter())
                        .map(|name| index_of(&mut extras, ExtraChannel::plain(name)))
                        .collect();
                    spec.with_network(learned.network.clone(), channels)
                }
                None => spec,
            };
            warnings.extend(crate::compensate::no_uncertainty(m, request.uncertainty));
            specs.push(match request.uncertainty {
                true => spec.with_trust(Trust {
                    uncertainty: fit.uncertainty.clone(),
                    coverage: fit.coverage.clone(),
                    fs_ratio: ratio,
                    fs_hz,
                }),
                false => spec,
            });
        }
        let mut extra_columns = Vec::new();
        for e in &extras {
            index_of(&mut extra_columns, e.name.clone());
        }
        let outputs = model.fits.iter().flat_map(|m| {
            let name = &m.output_column;
            let trust = tolles_io::schema::trust_columns(name);
            std::iter::once(name.clone()).chain(trust.into_iter().filter(|_| request.uncertainty))
        });
        Ok(Setup {
            outputs: outputs.collect(),
            uncertainty: request.uncertainty,
            specs,
            fluxgates,
            extra_columns,
            groups,
            extras,
            fs_hz,
            derivative: request.derivative,
            adapt: request.adapt,
            max_line_bytes: request.max_line_bytes,
            idle_timeout: request.idle_timeout,
            renames: Vec::new(),
            warnings,
            live: None,
        })
    }

    /// The setup with every output line of the first scalar also recorded in `feed` (see
    /// [`crate::live`]); the stream never waits for it.
    pub fn with_live(mut self, feed: Arc<LiveFeed>) -> Self {
        self.live = Some(feed);
        self
    }

    /// What the caller should be told before the first line: σ asked of a model that holds
    /// no covariance (a file written before version 3), whose σ column stays empty.
    pub fn warnings(&self) -> &[crate::Warning] {
        &self.warnings
    }

    /// The stream's nominal sample rate (Hz).
    pub fn fs_hz(&self) -> f64 {
        self.fs_hz
    }

    /// How many lines an output line waits for beyond its own: the samples ahead that the
    /// lags need (a fluxgate read later, an extra channel whose field leads it), plus one for
    /// central differences.
    pub fn delay_samples(&self) -> usize {
        let central = usize::from(self.derivative == Derivative::Central);
        Aligner::<()>::new(self.channels()).delay() + central
    }

    /// The aligner's channels: every group's fluxgate components shifted by its lag, then every
    /// extra channel low-passed and lagged; sources are the line's fluxgate components, then
    /// its extra columns.
    fn channels(&self) -> Vec<Channel> {
        let flux = self.groups.iter().flat_map(|g| {
            let shift = Shift::new(g.lag_s * self.fs_hz);
            (0..3).map(move |axis| Channel::shifted(3 * g.fluxgate + axis, shift))
        });
        let extras = self.extras.iter().map(|e| {
            let column = self.extra_column(e);
            Channel {
                source: 3 * self.fluxgates.len() + column.expect("every name is listed"),
                lowpass: e.lowpass_hz.map(|hz| LowPass::new(hz, self.fs_hz)),
                shift: e.shift(self.fs_hz),
            }
        });
        flux.chain(extras).collect()
    }

    /// Where `channel`'s column is among a line's extra columns ([`Setup::extra_columns`]).
    fn extra_column(&self, channel: &ExtraChannel) -> Option<usize> {
        self.extra_columns.iter().position(|c| *c == channel.name)
    }

    /// A new compensator for one stream.
    fn compensator<T>(&self) -> StreamCompensator<T> {
        let names = self
            .groups
            .iter()
            .map(|g| self.fluxgates[g.fluxgate].clone());
        StreamCompensator::new(
            self.specs.clone(),
            names.collect(),
            self.fs_hz,
            self.derivative,
        )
        .with_extras(
            self.extras.iter().map(|e| e.name.clone()).collect(),
            self.groups.iter().map(|g| g.extras.clone()).collect(),
        )
    }
}

/// A fluxgate as some scalars' models read it: shifted by their lag, usable where their extra
/// channels are.
#[derive(Debug, Clone, PartialEq)]
struct Group {
    /// Index into [`Setup::fluxgates`].
    fluxgate: usize,
    /// The model's lag (s).
    lag_s: f64,
    /// Indices into [`Setup::extras`], in design order.
    extras: Vec<usize>,
}

/// The index of `item` in `list`, added at the end if new.
fn index_of<T: PartialEq>(list: &mut Vec<T>, item: T) -> usize {
    match list.iter().position(|x| *x == item) {
        Some(k) => k,
        None => {
            list.push(item);
            list.len() - 1
        }
    }
}

/// The line's values the aligner takes: fluxgate components, then extra channels.
fn sources(line: &Line) -> Vec<f64> {
    let flux = line.fluxgates.iter().flatten().copied();
    flux.chain(line.extras.iter().copied()).collect()
}

/// One stream: a header line, then lines until the end of `input`; exactly one line out for
/// every line in, in order (the input as given, the compensated values, `status`). A header
/// without the model's columns is an error before anything is written.
/// A line over [`StreamRequest::max_line_bytes`] gets a `malformed` output line.
pub fn serve(setup: &Setup, stats: &Stats, input: impl Read, output: impl Write) -> Result<()> {
    serve_lines(setup, stats, input, output, LongLine::Flag)
}

/// What a line over the limit does to the stream.
#[derive(Clone, Copy, PartialEq)]
enum LongLine {
    /// One `malformed` output line, and the stream goes on.
    Flag,
    /// The stream ends with [`Error::StreamLineTooLong`].
    End,
}

fn serve_lines(
    setup: &Setup,
    stats: &Stats,
    input: impl Read,
    output: impl Write,
    long: LongLine,
) -> Result<()> {
    let limit = setup.max_line_bytes;
    let mut input = BufReader::new(input);
    let mut out = std::io::BufWriter::new(output);
    let mut raw = Vec::new();
    match read_line(&mut input, &mut raw, limit)? {
        Got::End => return Ok(()),
        Got::TooLong => return Err(Error::StreamLineTooLong { limit }),
        Got::Line => {}
    }
    let layout = layout(setup, &raw)?;
    writeln!(out, "{}", layout.output_header).map_err(Error::StreamIo)?;
    out.flush().map_err(Error::StreamIo)?;
    let mut stream = setup.compensator();
    let mut aligner = Aligner::new(setup.channels());
    if setup.adapt {
        stream.adapt(&AdaptSettings::default())?;
    }
    let mut text = String::new();
    loop {
        let got = read_line(&mut input, &mut raw, limit)?;
        let line = match got {
            Got::End => break,
            Got::TooLong if long == LongLine::End => {
                return Err(Error::StreamLineTooLong { limit });
            }
            Got::TooLong => too_long(&layout, limit),
            Got::Line => layout.parse(&raw),
        };
        let arrived = Instant::now();
        stats.samples_in.fetch_add(1, Ordering::Relaxed);
        let values = sources(&line);
        aligner.push((line, arrived), &values, |payload, aligned| {
            compensate_line(
                &mut stream,
                (&layout, setup),
                stats,
                payload,
                aligned,
                &mut text,
            )
        });
        out.write_all(text.as_bytes()).map_err(Error::StreamIo)?;
        text.clear();
        if input.buffer().is_empty() {
            // Nothing more is waiting: send what we have now, to keep latency low.
            out.flush().map_err(Error::StreamIo)?;
        }
    }
    aligner.finish(|payload, aligned| {
        compensate_line(
            &mut stream,
            (&layout, setup),
            stats,
            payload,
            aligned,
            &mut text,
        )
    });
    let live = setup.live.as_deref();
    stream.finish(|o| format_output((&layout, setup.uncertainty, live), stats, o, &mut text));
    out.write_all(text.as_bytes()).map_err(Error::StreamIo)?;
    out.flush().map_err(Error::StreamIo)
}

/// Pushes a line, its fluxgates and extra channels `aligned` (as [`Setup::channels`] orders
/// them), into the compensator; appends the output lines that are ready to `text`.
fn compensate_line(
    stream: &mut StreamCompensator<(Line, Instant)>,
    (layout, setup): (&Layout, &Setup),
    stats: &Stats,
    (line, arrived): (Line, Instant),
    aligned: &[f64],
    text: &mut String,
) {
    let layout = (layout, setup.uncertainty, setup.live.as_deref());
    let (vectors, extras) = aligned.split_at(3 * stream.fluxgate_count());
    let fluxgates: Vec<[f64; 3]> = vectors.chunks(3).map(|v| [v[0], v[1], v[2]]).collect();
    let scalars = line.scalars.clone();
    let mut flags: Vec<Flag> = line.flags.iter().map(flag).collect();
    // A channel read fine on this line whose conditioned value is missing waits on its lag
    // or low-pass, which is not what "nan in" the channel would say.
    for (conditioned, channel) in extras.iter().zip(&setup.extras) {
        let read = setup.extra_column(channel).and_then(|k| line.extras.get(k));
        if conditioned.is_nan() && read.is_some_and(|v| v.is_finite()) {
            flags.push(Flag::NotConditioned {
                column: channel.name.clone(),
            });
        }
    }
    let sample = line.well_formed.then_some(Sample {
        time_s: line.time_s,
        scalars: &scalars,
        fluxgates: &fluxgates,
        extras,
    });
    stream.push((line, arrived), sample, flags, |o| {
        format_output(layout, stats, o, text)
    });
}

/// Where the header line `raw` puts the model's columns.
fn layout(setup: &Setup, raw: &[u8]) -> Result<Layout> {
    let header = String::from_utf8_lossy(raw);
    let header = header.trim_start_matches('\u{feff}');
    let scalars: Vec<&str> = setup.specs.iter().map(|s| s.name.as_str()).collect();
    let fluxgates: Vec<&str> = setup.fluxgates.iter().map(String::as_str).collect();
    let extras: Vec<&str> = setup.extra_columns.iter().map(String::as_str).collect();
    let outputs: Vec<&str> = setup.outputs.iter().map(String::as_str).collect();
    Layout::from_header_with_extras(
        header,
        &setup.renames,
        &scalars,
        &fluxgates,
        &extras,
        &outputs,
    )
    .map_err(Error::StreamHeader)
}

/// Appends the output line of `o` to `text`: with `uncertainty`, each compensated value
/// followed by its standard error and extrapolation flag (see [`StreamRequest::uncertainty`]).
fn format_output(
    (layout, uncertainty, live): (&Layout, bool, Option<&LiveFeed>),
    stats: &Stats,
    o: Output<'_, (Line, Instant)>,
    text: &mut String,
) {
    let (line, arrived) = &o.payload;
    if let Some(feed) = live {
        let values = (
            line.scalars.first().copied(),
            o.compensated.first().copied(),
        );
        let value = |v: Option<f64>| v.unwrap_or(f64::NAN);
        let time_s = line.time_s.unwrap_or(f64::NAN);
        let (raw, compensated) = (value(values.0), value(values.1));
        feed.record(
            time_s,
            (raw, compensated),
            line.attitude,
            line.line_id,
            o.is_ok(),
        );
    }
    match !uncertainty {
        true => layout.write_output(line, o.compensated, &o.status(), text),
        false => {
            let mut values = Vec::with_capacity(3 * o.compensated.len());
            for ((v, s), e) in o.compensated.iter().zip(o.sigma).zip(o.extrapolated) {
                let flag = match v.is_finite() {
                    true => f64::from(u8::from(*e)),
                    false => f64::NAN,
                };
                values.extend([*v, *s, flag]);
            }
            layout.write_output(line, &values, &o.status(), text);
        }
    }
    stats.record_out(arrived.elapsed(), o.is_ok());
}

/// The compensator's flag for what the line reader found wrong.
pub fn flag(cell: &CellFlag) -> Flag {
    match cell.clone() {
        CellFlag::Missing { column } => Flag::Missing { column },
        CellFlag::NotANumber { column, text } => Flag::NotANumber { column, text },
        CellFlag::Malformed(why) => Flag::Malformed(why),
    }
}

/// The output line of an input line over `limit` bytes: its cells are not kept.
fn too_long(layout: &Layout, limit: usize) -> Line {
    let mut line = layout.parse(b"");
    line.flags = vec![CellFlag::Malformed(format!("line over {limit} bytes"))];
    line
}

/// What [`read_line`] found.
enum Got {
    End,
    Line,
    /// A line over the limit, read to its end and dropped.
    TooLong,
}

/// Reads one line into `raw` without its line ending, keeping at most `limit` bytes (+2 for
/// the line ending): a longer line is read on to its end but not kept.
fn read_line(input: &mut impl BufRead, raw: &mut Vec<u8>, limit: usize) -> Result<Got> {
    raw.clear();
    let cap = limit.saturating_add(2) as u64;
    let n = input
        .take(cap)
        .read_until(b'\n', raw)
        .map_err(Error::StreamIo)?;
    if n == 0 {
        return Ok(Got::End);
    }
    let ended = raw.last() == Some(&b'\n');
    if ended {
        raw.pop();
    }
    if raw.last() == Some(&b'\r') {
        raw.pop();
    }
    if raw.len() > limit {
        if !ended {
            skip_line(input)?;
        }
        raw.clear();
        return Ok(Got::TooLong);
    }
    Ok(Got::Line)
}

/// Reads past the rest of a line without keeping it.
fn skip_line(input: &mut impl BufRead) -> Result<()> {
    loop {
        let buffer = input.fill_buf().map_err(Error::StreamIo)?;
        if buffer.is_empty() {
            return Ok(());
        }
        match buffer.iter().position(|&b| b == b'\n') {
            Some(k) => {
                input.consume(k + 1);
                return Ok(());
            }
            None => {
                let n = buffer.len();
                input.consume(n);
            }
        }
    }
}

/// One TCP client's stream, answered on the same connection. When it fails for a reason other
/// than the client going away, the client gets one `error: …` line saying why.
/// A line over the limit or no input for the idle timeout ends the stream the same way.
pub fn serve_tcp(setup: &Setup, stats: &Stats, connection: TcpStream) -> Result<()> {
    let io = Error::StreamIo;
    connection.set_nodelay(true).map_err(io)?;
    connection
        .set_read_timeout(setup.idle_timeout)
        .map_err(io)?;
    let reader = connection.try_clone().map_err(io)?;
    let mut reply = connection.try_clone().map_err(io)?;
    let result = serve_lines(setup, stats, reader, connection, LongLine::End);
    let result = result.map_err(|e| idle(e, setup.idle_timeout));
    if let Err(e) = &result {
        if !e.is_disconnect() {
            // The client should learn why its stream ended, too; if it cannot, it is gone.
            let _ = reply.write_all(format!("error: {}\n", one_line(e)).as_bytes());
            close_gently(&reply);
        }
    }
    result
}

/// A read that timed out, as [`Error::StreamIdle`].
fn idle(e: Error, timeout: Option<Duration>) -> Error {
    match (&e, timeout) {
        (Error::StreamIo(io), Some(timeout))
            if matches!(io.kind(), ErrorKind::WouldBlock | ErrorKind::TimedOut) =>
        {
            Error::StreamIdle { timeout }
        }
        _ => e,
    }
}

/// Ends the reply and reads briefly on: closing with unread input would reset the connection,
/// and the client could lose the `error:` line before reading it.
fn close_gently(connection: &TcpStream) {
    let _ = connection.shutdown(std::net::Shutdown::Write);
    let _ = connection.set_read_timeout(Some(Duration::from_secs(1)));
    let mut rest = connection.take(64 << 20);
    let _ = std::io::copy(&mut rest, &mut std::io::sink());
}

/// `e` and its causes on one line, `cause: deeper cause`.
fn one_line(e: &dyn std::error::Error) -> String {
    let mut text = e.to_string();
    let mut cause = e.source();
    while let Some(c) = cause {
        text.push_str(&format!(": {c}"));
        cause = c.source();
    }
    text
}

/// What happened to a TCP client, for the caller to report.
#[derive(Debug)]
pub enum Event {
    /// Accepting a connection failed; the server goes on.
    AcceptFailed(std::io::Error),
    /// A client's stream ended: `Ok` at the end of its input, else why
    /// ([`Error::is_disconnect`] when the client went away).
    Ended {
        /// The client's address (`?` when unknown).
        peer: String,
        /// `Ok` at the end of its input, else why the stream ended.
        result: Result<()>,
    },
}

/// Serves every client of `listener`, each on its own thread, until accepting ends (in
/// practice, never); `on_event` hears of failed accepts and of each stream's end.
pub fn listen(
    listener: &TcpListener,
    setup: Arc<Setup>,
    stats: Arc<Stats>,
    on_event: impl Fn(Event) + Send + Sync + 'static,
) {
    let on_event = Arc::new(on_event);
    for connection in listener.incoming() {
        let connection = match connection {
            Ok(c) => c,
            Err(e) => {
                on_event(Event::AcceptFailed(e));
                continue;
            }
        };
        let (setup, stats, on_event) = (setup.clone(), stats.clone(), on_event.clone());
        std::thread::spawn(move || {
            let peer = connection
                .peer_addr()
                .map_or("?".to_string(), |a| a.to_string());
            let result = serve_tcp(&setup, &stats, connection);
            on_event(Event::Ended { peer, result });
        });
    }
}

/// Counters shared by all streams, and the latency histogram since the last
/// [`Stats::take_health`].
#[derive(Debug, Default)]
pub struct Stats {
    samples_in: AtomicU64,
    samples_out: AtomicU64,
    flagged: AtomicU64,
    latency: Mutex<Histogram>,
}

/// A stream's health: counters since the start, latency since the previous report.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Health {
    /// Input lines read (after the header).
    pub samples_in: u64,
    /// Output lines written.
    pub samples_out: u64,
    /// Output lines whose status is not `ok`.
    pub flagged: u64,
    /// Latency from a line read to its output line written; `None` when no line was written.
    pub latency: Option<Latency>,
}

/// Latency quantiles, each the upper edge of a 1 µs bin (µs).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Latency {
    /// Half the lines took less than this (µs).
    pub p50_us: u64,
    /// 99 % of the lines took less than this (µs).
    pub p99_us: u64,
    /// The longest (µs), even past the histogram's 100 ms.
    pub max_us: u128,
}

impl Stats {
    fn record_out(&self, latency: Duration, ok: bool) {
        self.samples_out.fetch_add(1, Ordering::Relaxed);
        if !ok {
            self.flagged.fetch_add(1, Ordering::Relaxed);
        }
        self.histogram().record(latency);
    }

    /// The counters since the start and the latency since the previous call, which starts a
    /// new latency window.
    pub fn take_health(&self) -> Health {
        let latency = std::mem::take(&mut *self.histogram()).summary();
        Health {
            samples_in: self.samples_in.load(Ordering::Relaxed),
            samples_out: self.samples_out.load(Ordering::Relaxed),
            flagged: self.flagged.load(Ordering::Relaxed),
            latency,
        }
    }

    fn histogram(&self) -> std::sync::MutexGuard<'_, Histogram> {
        // A thread that panicked cannot have left the counts half-updated in a way that
        // matters for a health line, so they are still worth reporting.
        self.latency.lock().unwrap_or_else(PoisonError::into_inner)
    }
}

/// Latencies in 1 µs bins up to 100 ms; longer ones only count toward the maximum.
#[derive(Debug, Clone)]
pub struct Histogram {
    bins: Vec<u64>,
    count: u64,
    max: Duration,
}

const BINS: usize = 100_000;

impl Default for Histogram {
    fn default() -> Self {
        Self {
            bins: vec![0; BINS],
            count: 0,
            max: Duration::ZERO,
        }
    }
}

impl Histogram {
    /// Counts one latency.
    pub fn record(&mut self, latency: Duration) {
        let bin = (latency.as_micros() as usize).min(BINS - 1);
        self.bins[bin] += 1;
        self.count += 1;
        self.max = self.max.max(latency);
    }

    /// Upper edge (µs) of the bin holding quantile `q` (0–1).
    pub fn quantile_us(&self, q: f64) -> u64 {
        let target = ((q * self.count as f64).ceil() as u64).max(1);
        let mut seen = 0;
        for (k, n) in self.bins.iter().enumerate() {
            seen += n;
            if seen >= target {
                return k as u64 + 1;
            }
        }
        BINS as u64
    }

    /// p50, p99 and the maximum; `None` when nothing was recorded.
    pub fn summary(&self) -> Option<Latency> {
        (self.count > 0).then(|| Latency {
            p50_us: self.quantile_us(0.5),
            p99_us: self.quantile_us(0.99),
            max_us: self.max.as_micros(),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;
    use tolles_core::model::design::Design;

    const HEADER: &str = "tt,line,mag_1_uc,flux_a_x,flux_a_y,flux_a_z";

    fn setup() -> Setup {
        let design = Design::new("p,i,e".parse().unwrap());
        let beta: Vec<f64> = (0..design.width()).map(|k| 1.0 + k as f64).collect();
        Setup {
            specs: vec![ScalarSpec::new("mag_1_uc", 0, design, &beta, 3.0, 1.0)],
            fluxgates: vec!["flux_a".to_string()],
            extra_columns: Vec::new(),
            groups: vec![Group {
                fluxgate: 0,
                lag_s: 0.0,
                extras: Vec::new(),
            }],
            extras: Vec::new(),
            outputs: vec!["mag_1_c".to_string()],
            uncertainty: false,
            fs_hz: 10.0,
            derivative: Derivative::Central,
            adapt: true,
            max_line_bytes: DEFAULT_MAX_LINE_BYTES,
            idle_timeout: None,
            renames: Vec::new(),
            warnings: Vec::new(),
            live: None,
        }
    }

    /// Issue 11 item 5: a line over the limit is not kept; it gets one `malformed` line out.
    #[test]
    fn a_line_over_the_limit_gets_one_malformed_line() {
        let setup = Setup {
            max_line_bytes: 100,
            ..setup()
        };
        let mut input = format!("{HEADER}\n").into_bytes();
        for line in [
            valid_line(0),
            vec![b'9'; 5000],
            valid_line(1),
            vec![b'8'; 101],
        ] {
            input.extend(line);
            input.push(b'\n');
        }
        input.extend(valid_line(2));
        let mut output = Vec::new();
        serve(&setup, &Stats::default(), &input[..], &mut output).unwrap();
        let text = String::from_utf8(output).unwrap();
        let lines: Vec<&str> = text.lines().collect();
        assert_eq!(lines.len(), 6, "{text}");
        for k in [2, 4] {
            assert!(
                lines[k].ends_with(",malformed: line over 100 bytes"),
                "{}",
                lines[k]
            );
        }
        assert!(lines[5].starts_with("0.2,7,"), "{}", lines[5]);
    }

    fn valid_line(k: usize) -> Vec<u8> {
        let t = k as f64;
        format!(
            "{},7,{},{},{},{}",
            0.1 * t,
            50_000.0 + t,
            20_000.0 + 100.0 * (0.3 * t).sin(),
            -3_000.0 + 50.0 * (0.2 * t).cos(),
            45_000.0
        )
        .into_bytes()
    }

    /// Garbage: any bytes but line breaks, with fewer commas than a real line.
    fn garbage() -> impl Strategy<Value = Vec<u8>> {
        proptest::collection::vec(
            any::<u8>().prop_filter("no line breaks", |b| *b != b'\n' && *b != b'\r'),
            0..40,
        )
        .prop_filter("not a full record", |g| {
            g.iter().filter(|b| **b == b',').count() < 5
        })
    }

    proptest! {
        #[test]
        fn every_line_in_gets_one_line_out_in_order(
            items in proptest::collection::vec(prop_oneof![3 => Just(None), 1 => garbage().prop_map(Some)], 0..60),
        ) {
            let mut input = HEADER.as_bytes().to_vec();
            input.push(b'\n');
            let mut lines = Vec::new();
            let mut valid = 0;
            for item in &items {
                let line = item.clone().unwrap_or_else(|| { valid += 1; valid_line(valid - 1) });
                input.extend_from_slice(&line);
                input.push(b'\n');
                lines.push((item.is_none(), line));
            }
            let mut output = Vec::new();
            serve(&setup(), &Stats::default(), &input[..], &mut output).unwrap();
            let text = String::from_utf8(output).unwrap();
            let out: Vec<&str> = text.lines().collect();
            prop_assert_eq!(out.len(), lines.len() + 1);
            prop_assert_eq!(out[0], format!("{HEADER},mag_1_c,status"));
            for (k, (is_valid, line)) in lines.iter().enumerate() {
                let row = out[k + 1];
                if *is_valid {
                    let line = std::str::from_utf8(line).unwrap();
                    prop_assert!(row.starts_with(line), "{} vs {}", row, line);
                    let beside_garbage = (k > 0 && !lines[k - 1].0) || lines.get(k + 1).is_some_and(|l| !l.0);
                    if !beside_garbage {
                        prop_assert!(row.ends_with(",ok"), "{}", row);
                    }
                } else {
                    prop_assert!(row.contains("malformed"), "{}", row);
                }
            }
        }
    }

    #[test]
    fn stats_count_lines_and_flags_and_each_report_starts_a_new_latency_window() {
        let stats = Stats::default();
        let input = format!(
            "{HEADER}\n{}\nnot a line\n",
            String::from_utf8(valid_line(0)).unwrap()
        );
        serve(&setup(), &stats, input.as_bytes(), std::io::sink()).unwrap();
        let health = stats.take_health();
        assert_eq!((health.samples_in, health.samples_out), (2, 2));
        assert_eq!(health.flagged, 1);
        assert!(health.latency.is_some());
        assert_eq!(stats.take_health().latency, None);
    }

    #[test]
    fn a_header_without_the_model_columns_is_an_error_and_nothing_is_written() {
        let mut output = Vec::new();
        let input = "tt,mag_1_uc,flux_a_x,flux_a_z\n1,2,3,4\n";
        let e = serve(&setup(), &Stats::default(), input.as_bytes(), &mut output).unwrap_err();
        assert!(matches!(&e, Error::StreamHeader(_)));
        assert_eq!(
            e.to_string(),
            "header has no column \"flux_a_y\"; did you mean flux_a_x, flux_a_z?"
        );
        assert!(output.is_empty());
    }

    #[test]
    fn a_reader_that_went_away_is_a_disconnect() {
        struct Gone;
        impl Write for Gone {
            fn write(&mut self, _: &[u8]) -> std::io::Result<usize> {
                Err(std::io::ErrorKind::BrokenPipe.into())
            }
            fn flush(&mut self) -> std::io::Result<()> {
                Err(std::io::ErrorKind::BrokenPipe.into())
            }
        }
        let input = format!("{HEADER}\n");
        let e = serve(&setup(), &Stats::default(), input.as_bytes(), Gone).unwrap_err();
        assert!(e.is_disconnect() && e.is_broken_pipe());
    }

    #[test]
    fn histogram_quantiles_are_upper_bin_edges() {
        let mut h = Histogram::default();
        assert_eq!(h.summary(), None);
        for us in 0..100 {
            h.record(Duration::from_micros(us));
        }
        h.record(Duration::from_millis(250));
        let s = h.summary().unwrap();
        assert_eq!((s.p50_us, s.p99_us, s.max_us), (51, 100, 250_000));
    }

    #[test]
    fn fits_with_several_fluxgates_cannot_stream() {
        let mut model = fitted_model();
        model.fits[0].vectors.push("flux_b".into());
        let e = Setup::new(&model, Path::new("m.json"), &StreamRequest::default()).unwrap_err();
        assert!(matches!(e, Error::StreamFluxgates { .. }), "{e}");
        let model = fitted_model();
        let request = StreamRequest {
            fs_hz: Some(0.0),
            ..StreamRequest::default()
        };
        let e = Setup::new(&model, Path::new("m.json"), &request).unwrap_err();
        assert!(matches!(e, Error::BadSampleRate { .. }), "{e}");
        let setup = Setup::new(&model, Path::new("m.json"), &StreamRequest::default()).unwrap();
        assert_eq!(setup.fs_hz(), model.fits[0].fit.fs_hz);
    }

    /// A model of one scalar on one fluxgate, fitted to a short simulated box.
    fn fitted_model() -> ModelFile {
        use crate::{fit, simulate, Silent};
        let request = simulate::SimulateRequest {
            cycles: 1,
            ..Default::default()
        };
        let flight = simulate::simulate(&request, &Silent).unwrap();
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("box.csv");
        simulate::write(&flight, &path).unwrap();
        let data = crate::read::read(&path, &Default::default(), &Silent, &mut Vec::new()).unwrap();
        let request = fit::FitRequest::magnav(vec!["mag_1_uc".into()], vec!["flux_a".into()]);
        fit::fit(&data.table, &request, &Silent, &mut Vec::new()).unwrap()
    }
}
