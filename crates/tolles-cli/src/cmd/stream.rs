//! `tolles stream`: real-time compensation of CSV lines from standard input or TCP clients.

use anyhow::{bail, Context, Result};
use std::io::{BufRead, BufReader, ErrorKind, Read, Write};
use std::net::{TcpListener, TcpStream};
use std::path::PathBuf;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};
use tolles_core::adapt::AdaptSettings;
use tolles_core::stream::{Derivative, Output, Sample, ScalarSpec, StreamCompensator};
use tolles_io::model::ModelFile;
use tolles_io::stream_line::{Layout, Line};

const EXAMPLES: &str = "\
Examples:
  tail -f live.csv | tolles stream --model model.json
  tolles stream --model model.json --listen 127.0.0.1:7700 --derivative causal";

/// Compensate a live stream of CSV lines, one output line for every input line.
///
/// Input: a header line, then one sample per line, with the model's columns (`tt` in s, the
/// scalars and fluxgates in nT); other columns are passed through. Output: the header plus one
/// compensated column per scalar (named as `compensate` names them) and `status`, then for every
/// input line, in order, exactly one line: the input as given, the compensated values (empty
/// when not computable) and `status` (`ok` or why not: `nan in flux_a_y`, `time gap 2.300 s`,
/// `time went backwards`, `malformed: 3 fields, header has 9`, ...).
///
/// The level subtracted is the calibration flight's mean of the correction stored in the model
/// (a stream cannot know a file's mean), so the result differs from `tolles compensate` by a
/// constant. A time step over 1.5 nominal steps, a step backwards, a bad value or a malformed
/// line restarts the derivative, as `compensate` splits runs.
///
/// Latency: `central` holds each line until the next one arrives (one sample period + compute);
/// `causal` answers at once (compute only) with a backward difference. Output is flushed whenever
/// no more input is waiting. Writes block when the reader is slow (no unbounded queue); a reader
/// that goes away (broken pipe, reset) ends that stream quietly.
///
/// With `--listen`, each TCP connection is its own stream (own header) answered on the same
/// connection; connections are served concurrently, one thread each. The bound address is
/// printed on stderr as `listening on ADDRESS`. A stream that cannot start (a header without
/// the model's columns) gets one `error: ...` line back and is closed.
///
/// `--adapt` keeps learning the coefficients during maneuvers (Kalman filter on the 0.1–0.9 Hz
/// band-passed design rows and scalar, prior 5 nT per coefficient, updated only when the
/// band-passed row's norm exceeds 0.02); quiet straight flight leaves them alone.
#[derive(clap::Args)]
#[command(after_help = EXAMPLES)]
pub struct Args {
    /// Model file written by `tolles fit`
    #[arg(long)]
    pub model: PathBuf,
    /// Serve TCP clients at this address (e.g. 127.0.0.1:7700; port 0 picks a free one)
    #[arg(long)]
    pub listen: Option<String>,
    /// Fluxgate derivative: central (one sample of look-ahead, as `compensate`) or causal
    #[arg(long, value_enum, default_value_t = DerivativeArg::Central)]
    pub derivative: DerivativeArg,
    /// Nominal sample rate of the stream in Hz (default: the model's)
    #[arg(long)]
    pub fs: Option<f64>,
    /// Adapt the coefficients online (Kalman filter on band-passed rows, updated only during
    /// maneuvers); each stream starts from the model's coefficients
    #[arg(long)]
    pub adapt: bool,
    /// No health lines on stderr
    #[arg(long)]
    pub quiet: bool,
}

#[derive(Clone, Copy, clap::ValueEnum)]
pub enum DerivativeArg {
    Central,
    Causal,
}

/// Everything a new stream needs from the model.
#[derive(Clone)]
struct Setup {
    specs: Vec<ScalarSpec>,
    fluxgates: Vec<String>,
    outputs: Vec<String>,
    fs_hz: f64,
    derivative: Derivative,
    adapt: bool,
}

pub fn run(args: Args) -> Result<()> {
    let setup = Arc::new(setup(&args)?);
    let stats = Arc::new(Stats::default());
    if !args.quiet {
        let stats = Arc::clone(&stats);
        std::thread::spawn(move || loop {
            std::thread::sleep(HEALTH_PERIOD);
            eprintln!("{}", stats.health());
        });
    }
    match &args.listen {
        None => {
            let stdin = BufReader::new(std::io::stdin().lock());
            let result = serve(&setup, &stats, stdin, std::io::stdout().lock());
            if !args.quiet {
                eprintln!("{}", stats.health());
            }
            match result {
                Err(e) if is_disconnect(&e) => Ok(()),
                other => other.context("stream on standard input"),
            }
        }
        Some(address) => listen(address, setup, stats),
    }
}

const HEALTH_PERIOD: Duration = Duration::from_secs(5);

fn setup(args: &Args) -> Result<Setup> {
    let model = ModelFile::read(&args.model)?;
    let Some(first) = model.fits.first() else {
        bail!("{}: the model holds no fits", args.model.display())
    };
    let fs_hz = args.fs.unwrap_or(first.fit.fs_hz);
    if !(fs_hz.is_finite() && fs_hz > 0.0) {
        bail!("--fs must be a positive number of Hz, got {fs_hz}");
    }
    let mut fluxgates: Vec<String> = Vec::new();
    let mut specs = Vec::new();
    for m in &model.fits {
        if m.vectors.len() != 1 {
            bail!(
                "{}: the fit of {} uses {} fluxgates ({}); tolles stream handles one fluxgate per scalar, so use tolles compensate or refit with one --vector",
                args.model.display(),
                m.scalar,
                m.vectors.len(),
                m.vectors.join(",")
            );
        }
        let vector = &m.vectors[0];
        let j = match fluxgates.iter().position(|f| f == vector) {
            Some(j) => j,
            None => {
                fluxgates.push(vector.clone());
                fluxgates.len() - 1
            }
        };
        specs.push(ScalarSpec::new(
            &m.scalar,
            j,
            m.fit.settings.design.clone(),
            &m.fit.coefficients,
            m.fit.level_nt,
            fs_hz / m.fit.fs_hz,
        ));
    }
    Ok(Setup {
        outputs: model.fits.iter().map(|m| m.output_column.clone()).collect(),
        specs,
        fluxgates,
        fs_hz,
        adapt: args.adapt,
        derivative: match args.derivative {
            DerivativeArg::Central => Derivative::Central,
            DerivativeArg::Causal => Derivative::Causal,
        },
    })
}

fn listen(address: &str, setup: Arc<Setup>, stats: Arc<Stats>) -> Result<()> {
    let listener =
        TcpListener::bind(address).with_context(|| format!("cannot listen on {address}"))?;
    eprintln!("listening on {}", listener.local_addr()?);
    for connection in listener.incoming() {
        let connection = match connection {
            Ok(c) => c,
            Err(e) => {
                eprintln!("warning: accepting a connection failed: {e}");
                continue;
            }
        };
        let (setup, stats) = (Arc::clone(&setup), Arc::clone(&stats));
        std::thread::spawn(move || {
            let peer = connection
                .peer_addr()
                .map_or("?".to_string(), |a| a.to_string());
            match serve_tcp(&setup, &stats, connection) {
                Ok(()) => {}
                Err(e) if is_disconnect(&e) => eprintln!("client {peer}: disconnected"),
                Err(e) => eprintln!("client {peer}: error: {e:#}"),
            }
        });
    }
    Ok(())
}

fn serve_tcp(setup: &Setup, stats: &Stats, connection: TcpStream) -> Result<()> {
    connection.set_nodelay(true)?;
    let reader = BufReader::new(connection.try_clone()?);
    let mut reply = connection.try_clone()?;
    let result = serve(setup, stats, reader, connection);
    if let Err(e) = &result {
        if !is_disconnect(e) {
            // The client should learn why its stream ended, too.
            let _ = reply.write_all(format!("error: {e:#}\n").as_bytes());
        }
    }
    result
}

/// One stream: header, then lines until end of input; one output line per input line.
fn serve(
    setup: &Setup,
    stats: &Stats,
    mut input: BufReader<impl Read>,
    output: impl Write,
) -> Result<()> {
    let mut out = std::io::BufWriter::new(output);
    let mut raw = Vec::new();
    if !read_line(&mut input, &mut raw)? {
        return Ok(());
    }
    let header = String::from_utf8_lossy(&raw)
        .trim_start_matches('\u{feff}')
        .to_string();
    let scalars: Vec<&str> = setup.specs.iter().map(|s| s.name.as_str()).collect();
    let fluxgates: Vec<&str> = setup.fluxgates.iter().map(String::as_str).collect();
    let outputs: Vec<&str> = setup.outputs.iter().map(String::as_str).collect();
    let layout = Layout::from_header(&header, &scalars, &fluxgates, &outputs)
        .map_err(|e| anyhow::anyhow!("{e}"))?;
    writeln!(out, "{}", layout.output_header)?;
    out.flush()?;
    let mut stream = StreamCompensator::new(
        setup.specs.clone(),
        setup.fluxgates.clone(),
        setup.fs_hz,
        setup.derivative,
    );
    if setup.adapt {
        stream.adapt(&AdaptSettings::default())?;
    }
    let mut text = String::new();
    while read_line(&mut input, &mut raw)? {
        let arrived = Instant::now();
        stats.samples_in.fetch_add(1, Ordering::Relaxed);
        let line = layout.parse(&raw);
        let (scalars, fluxgates, flags) = (
            line.scalars.clone(),
            line.fluxgates.clone(),
            line.flags.clone(),
        );
        let sample = line.well_formed.then_some(Sample {
            time_s: line.time_s,
            scalars: &scalars,
            fluxgates: &fluxgates,
        });
        stream.push((line, arrived), sample, flags, |o| {
            format_output(&layout, stats, o, &mut text)
        });
        out.write_all(text.as_bytes())?;
        text.clear();
        if input.buffer().is_empty() {
            // Nothing more is waiting: send what we have now, to keep latency low.
            out.flush()?;
        }
    }
    stream.finish(|o| format_output(&layout, stats, o, &mut text));
    out.write_all(text.as_bytes())?;
    out.flush()?;
    Ok(())
}

fn format_output(
    layout: &Layout,
    stats: &Stats,
    o: Output<'_, (Line, Instant)>,
    text: &mut String,
) {
    let (line, arrived) = &o.payload;
    layout.write_output(line, o.compensated, &o.status(), text);
    stats.record_out(arrived.elapsed(), o.is_ok());
}

/// Reads one line into `raw` without its line ending; false at end of input.
fn read_line(input: &mut impl BufRead, raw: &mut Vec<u8>) -> std::io::Result<bool> {
    raw.clear();
    if input.read_until(b'\n', raw)? == 0 {
        return Ok(false);
    }
    if raw.last() == Some(&b'\n') {
        raw.pop();
    }
    if raw.last() == Some(&b'\r') {
        raw.pop();
    }
    Ok(true)
}

/// The reader went away: a broken pipe or a reset connection ends the stream, not the program.
fn is_disconnect(e: &anyhow::Error) -> bool {
    e.chain().any(|c| {
        c.downcast_ref::<std::io::Error>().is_some_and(|io| {
            matches!(
                io.kind(),
                ErrorKind::BrokenPipe | ErrorKind::ConnectionReset | ErrorKind::ConnectionAborted
            )
        })
    })
}

/// Counters shared by all streams, and the latency histogram since the last health line.
#[derive(Default)]
struct Stats {
    samples_in: AtomicU64,
    samples_out: AtomicU64,
    flagged: AtomicU64,
    latency: Mutex<Histogram>,
}

impl Stats {
    fn record_out(&self, latency: Duration, ok: bool) {
        self.samples_out.fetch_add(1, Ordering::Relaxed);
        if !ok {
            self.flagged.fetch_add(1, Ordering::Relaxed);
        }
        if let Ok(mut h) = self.latency.lock() {
            h.record(latency);
        }
    }

    /// One line: counters since start, latency (line read → output line written) since the
    /// previous health line.
    fn health(&self) -> String {
        let latency = match self.latency.lock() {
            Ok(mut h) => std::mem::take(&mut *h).summary(),
            Err(_) => "latency unknown".to_string(),
        };
        format!(
            "stream: {} in, {} out, {} flagged; {latency}",
            self.samples_in.load(Ordering::Relaxed),
            self.samples_out.load(Ordering::Relaxed),
            self.flagged.load(Ordering::Relaxed),
        )
    }
}

/// Latencies in 1 µs bins up to 100 ms; longer ones only count toward the maximum.
struct Histogram {
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
    fn record(&mut self, latency: Duration) {
        let bin = (latency.as_micros() as usize).min(BINS - 1);
        self.bins[bin] += 1;
        self.count += 1;
        self.max = self.max.max(latency);
    }

    /// Upper edge (µs) of the bin holding quantile `q`.
    fn quantile_us(&self, q: f64) -> u64 {
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

    fn summary(&self) -> String {
        if self.count == 0 {
            return "latency: no samples".to_string();
        }
        format!(
            "latency p50 < {} µs, p99 < {} µs, max {} µs",
            self.quantile_us(0.5),
            self.quantile_us(0.99),
            self.max.as_micros()
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;
    use tolles_core::design::Design;

    const HEADER: &str = "tt,line,mag_1_uc,flux_a_x,flux_a_y,flux_a_z";

    fn setup() -> Setup {
        let design = Design::new("p,i,e".parse().unwrap());
        let beta: Vec<f64> = (0..design.width()).map(|k| 1.0 + k as f64).collect();
        Setup {
            specs: vec![ScalarSpec::new("mag_1_uc", 0, design, &beta, 3.0, 1.0)],
            fluxgates: vec!["flux_a".to_string()],
            outputs: vec!["mag_1_c".to_string()],
            fs_hz: 10.0,
            derivative: Derivative::Central,
            adapt: true,
        }
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
            serve(&setup(), &Stats::default(), BufReader::new(&input[..]), &mut output).unwrap();
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
}
