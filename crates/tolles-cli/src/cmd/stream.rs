//! `tolles stream`: real-time compensation of CSV lines from standard input or TCP clients.

use crate::render::{self, OrRender};
use anyhow::{anyhow, Context, Result};
use std::net::TcpListener;
use std::path::PathBuf;
use std::sync::Arc;
use std::time::Duration;
use tolles::live::{Live, LivePage, LiveRequest, LIVE_ELEMENT};
use tolles::model::ModelFile;
use tolles::stream::{Derivative, Event, Setup, Stats, StreamRequest};
use tolles::Error;

const EXAMPLES: &str = "\
Examples:
  tail -f live.csv | tolles stream --model model.json
  tolles stream --model model.json --listen 127.0.0.1:7700 --derivative causal
  # In flight: the stream on stdout as ever, and a page to watch at http://127.0.0.1:8080/
  tolles simulate --plan box --out box.csv && tolles stream --model model.json --live 127.0.0.1:8080 < box.csv";

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
    #[arg(long, allow_negative_numbers = true)]
    pub fs: Option<f64>,
    /// Adapt the coefficients online (Kalman filter on band-passed rows, updated only during
    /// maneuvers); each stream starts from the model's coefficients
    #[arg(long)]
    pub adapt: bool,
    /// After each compensated column NAME, also NAME_sigma (the compensated value's standard
    /// error up to a constant level, nT) and NAME_extrapolated (1 where the sample lies outside what the calibration flew),
    /// as `compensate --uncertainty` writes them
    #[arg(long)]
    pub uncertainty: bool,
    /// No health lines on stderr
    #[arg(long)]
    pub quiet: bool,
    /// Rename header columns before the model's are looked up, e.g. --rename MAGUC=mag_1_uc (the
    /// flag may repeat); the output header has the new names. SGL's raw channel names (TIME,
    /// UNCOMPMAGn, FLUXA_X, …) need none. A stream has no --line or --time: every line in gets
    /// its line out
    #[arg(long = "rename", value_name = "OLD=NEW", value_delimiter = ',', value_parser = crate::select::parse_rename)]
    pub renames: Vec<(String, String)>,
    /// Close a TCP client that sends nothing for this many seconds (0: never)
    #[arg(
        long,
        value_name = "SECONDS",
        default_value_t = 300.0,
        allow_negative_numbers = true
    )]
    pub idle_timeout: f64,
    /// Also serve a page to watch at this address while the stream runs (e.g. 127.0.0.1:8080;
    /// port 0 picks a free one, printed on stderr): the compensated trace, the noise against
    /// --noise-spec, the box's maneuvers and FOM as they are flown, each line as it completes.
    /// The stream never waits for the page; its state is also at /state.json
    #[arg(long, value_name = "ADDR")]
    pub live: Option<String>,
    /// The survey specification's fourth-difference noise (nT) the live page judges against
    #[arg(long, value_name = "NT", default_value_t = 0.1, requires = "live")]
    pub noise_spec: f64,
    /// The figure of merit (nT) the box must pass on the live page
    #[arg(long, value_name = "NT", default_value_t = 1.5, requires = "live")]
    pub fom_spec: f64,
    /// How long the live page stays up after standard input ends (s), to read its last state
    #[arg(
        long,
        value_name = "SECONDS",
        default_value_t = 15.0,
        requires = "live"
    )]
    pub live_linger: f64,
}

#[derive(Clone, Copy, clap::ValueEnum)]
pub enum DerivativeArg {
    Central,
    Causal,
}

pub fn run(args: Args) -> Result<()> {
    let model = tolles::model::load_model(&args.model).or_render()?;
    let request = StreamRequest {
        derivative: match args.derivative {
            DerivativeArg::Central => Derivative::Central,
            DerivativeArg::Causal => Derivative::Causal,
        },
        fs_hz: args.fs,
        adapt: args.adapt,
        uncertainty: args.uncertainty,
        idle_timeout: idle_timeout(args.idle_timeout)?,
        ..StreamRequest::default()
    };
    let setup = Setup::new(&model, &args.model, &request).map_err(setup_error)?;
    render::warnings(&mut setup.warnings().to_vec(), render::Use::Other);
    let setup = setup.with_renames(args.renames.clone());
    let live = args
        .live
        .as_ref()
        .map(|address| live_page(&args, address, &model, &setup))
        .transpose()?;
    let setup = Arc::new(match &live {
        Some(live) => setup.with_live(live.feed()),
        None => setup,
    });
    let stats = Arc::new(Stats::default());
    if !args.quiet {
        let stats = Arc::clone(&stats);
        std::thread::spawn(move || loop {
            std::thread::sleep(HEALTH_PERIOD);
            note!("{}", health(&stats));
        });
    }
    match &args.listen {
        None => {
            let input = std::io::stdin().lock();
            // With the page, standard output is closed when the input ends, so a reader sees
            // the end of the answers while the page lingers.
            let owned = live.as_ref().and_then(|_| owned_stdout());
            let result = match owned {
                Some(out) => tolles::stream::serve(&setup, &stats, input, out),
                None => tolles::stream::serve(&setup, &stats, input, std::io::stdout().lock()),
            };
            if !args.quiet {
                note!("{}", health(&stats));
            }
            if let Some(live) = &live {
                live.feed().end();
                linger(live, args.live_linger);
            }
            match result {
                Err(e) if e.is_disconnect() => Ok(()),
                other => other.or_render().context("stream on standard input"),
            }
        }
        Some(address) => listen(address, setup, stats),
    }
}

const HEALTH_PERIOD: Duration = Duration::from_secs(5);

/// Starts the live page at `address` (see `tolles::live`), saying where on stderr.
fn live_page(args: &Args, address: &str, model: &ModelFile, setup: &Setup) -> Result<Live> {
    let request = LiveRequest {
        address: address.to_string(),
        noise_spec_nt: args.noise_spec,
        fom_spec_nt: args.fom_spec,
        fs_hz: setup.fs_hz(),
        verdict: LiveRequest::verdict_of(model),
    };
    let title = format!("tolles stream: {}", args.model.display());
    let page = LivePage {
        html: tolles_report::stream_page::page(&title, LIVE_ELEMENT),
        uplot_js: tolles_report::stream_page::UPLOT_JS,
        uplot_css: tolles_report::stream_page::UPLOT_CSS,
    };
    let live = Live::start(request, page).or_render()?;
    note!("live page at http://{}/", live.address());
    Ok(live)
}

/// Standard output as a file this command owns, so dropping it closes it.
#[cfg(unix)]
fn owned_stdout() -> Option<std::fs::File> {
    use std::os::fd::FromRawFd;
    // SAFETY: descriptor 1 is open for the life of the process, and nothing in `stream` writes
    // to standard output once the stream's writer (this file) has been dropped.
    Some(unsafe { std::fs::File::from_raw_fd(1) })
}

#[cfg(not(unix))]
fn owned_stdout() -> Option<std::fs::File> {
    None
}

/// Keeps the live page up `seconds` after the input ended, so its last state can be read.
fn linger(live: &Live, seconds: f64) {
    if seconds > 0.0 && seconds.is_finite() {
        note!(
            "stream: input ended; the live page stays at http://{}/ for {seconds} s",
            live.address()
        );
        std::thread::sleep(Duration::from_secs_f64(seconds));
    }
}

/// A model the stream cannot use, said with the flags and commands that help.
fn setup_error(e: Error) -> anyhow::Error {
    match e {
        Error::BadSampleRate { fs_hz } => anyhow!("--fs must be a positive number of Hz, got {fs_hz}"),
        Error::StreamFluxgates { path, scalar, vectors } => anyhow!(
            "{}: the fit of {scalar} uses {} fluxgates ({}); tolles stream handles one fluxgate per scalar, so use tolles compensate or refit with one --vector",
            path.display(),
            vectors.len(),
            vectors.join(",")
        ),
        other => render::error(other),
    }
}

fn listen(address: &str, setup: Arc<Setup>, stats: Arc<Stats>) -> Result<()> {
    let listener =
        TcpListener::bind(address).with_context(|| format!("cannot listen on {address}"))?;
    note!("listening on {}", listener.local_addr()?);
    tolles::stream::listen(&listener, setup, stats, |event| match event {
        Event::AcceptFailed(e) => note!("warning: accepting a connection failed: {e}"),
        Event::Ended { result: Ok(()), .. } => {}
        Event::Ended {
            peer,
            result: Err(e),
        } if e.is_disconnect() => {
            note!("client {peer}: disconnected")
        }
        Event::Ended {
            peer,
            result: Err(e),
        } => {
            note!("client {peer}: error: {:#}", render::error(e))
        }
    });
    Ok(())
}

/// One line: counters since start, latency (line read → output line written) since the
/// previous health line.
fn health(stats: &Stats) -> String {
    let h = stats.take_health();
    let latency = match h.latency {
        None => "latency: no samples".to_string(),
        Some(l) => format!(
            "latency p50 < {} µs, p99 < {} µs, max {} µs",
            l.p50_us, l.p99_us, l.max_us
        ),
    };
    format!(
        "stream: {} in, {} out, {} flagged; {latency}",
        h.samples_in, h.samples_out, h.flagged
    )
}

/// `--idle-timeout` as a duration; 0 waits for ever.
fn idle_timeout(seconds: f64) -> Result<Option<std::time::Duration>> {
    match std::time::Duration::try_from_secs_f64(seconds) {
        Ok(d) if d.is_zero() => Ok(None),
        Ok(d) => Ok(Some(d)),
        Err(_) => Err(anyhow!(
            "--idle-timeout must be a number of seconds ≥ 0, got {seconds}"
        )),
    }
}
