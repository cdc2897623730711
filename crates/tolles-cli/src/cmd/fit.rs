//! `tolles fit`: learn a model from a calibration flight.

use crate::input::{name_list, parse_band};
use crate::progress::Terminal;
use crate::render::{self, OrRender, Use};
use anyhow::{Context, Result};
use std::io::Write;
use std::path::{Path, PathBuf};
use tolles::fit::{FitRequest, NetworkRequest, Terms};
use tolles_core::fit::network::NetworkSettings;
use tolles_core::fit::{Band, FitError, Lambda, MagnitudeChoice};
use tolles_io::table::Table;

/// Default terms: the 16 a scalar magnetometer can identify; over several fluxgates MagNav's 18
/// when cross-validation finds them clearly better (see `--terms`).
pub const DEFAULT_TERMS: &str = "auto";

fn parse_terms(text: &str) -> Result<Terms, String> {
    text.parse()
}

const EXAMPLES: &str = "\
Examples:
  tolles fit cal.csv --scalar mag_1_uc --vector flux_a --out model.json
  # MagNav.jl's exact procedure:
  tolles fit cal.csv --scalar mag_1_uc --vector flux_a --out model.json \\
      --terms permanent,induced,eddy --lambda 0.001 --band 0.1,0.9 --order 4 --trim 20
  # A cabin magnetometer against the compensated tail stinger, in the full band:
  tolles fit flight.h5 --scalar mag_3_uc --vector flux_a --reference mag_1_c --out cabin.json";

/// Learn the aircraft's field from a calibration flight (CSV, XYZ, GDF, HDF5 or Parquet).
///
/// The fluxgate gives the earth field's direction in the aircraft; every design column and the
/// scalar are band-passed with a zero-phase Butterworth filter, trimmed, and fitted by ridge
/// least squares. Prints a summary to stderr; writes the model to --out (or stdout).
#[derive(clap::Args)]
#[command(after_help = EXAMPLES)]
pub struct Args {
    #[arg(
        required = true,
        help = flight_help!("Calibration flight; time column `tt` (s) if present. Several \
            flights (at one sample rate) are fitted together, each its own runs: nothing is \
            filtered or differenced across two files")
    )]
    pub cal: Vec<PathBuf>,
    /// Uncompensated scalar magnetometer column (nT), e.g. mag_1_uc; several, separated by
    /// commas (mag_3_uc,mag_4_uc,mag_5_uc) or by repeating the flag, give one model holding a
    /// fit per scalar
    #[arg(long, required = true)]
    pub scalar: Vec<String>,
    /// Fluxgate column prefix: `flux_a` reads flux_a_x, flux_a_y, flux_a_z (nT, body frame FRD;
    /// the suffixes in any case, so FLUXA reads FLUXA_X …), or three columns X:Y:Z
    /// (FLUXA_X:FLUXA_Y:FLUXA_Z); several separated by commas (flux_a,flux_b,flux_c) build one
    /// design in which each fluxgate adds its own block of terms, for every scalar (the flag
    /// may also repeat)
    #[arg(long, required = true)]
    pub vector: Vec<String>,
    /// Where to write the model (JSON); `-` for standard output, which is also where it goes
    /// when this is left out, unless that is a terminal
    #[arg(short, long)]
    pub out: Option<PathBuf>,
    /// Terms: `auto`, or a list of patent, permanent|p, induced|i, it, i5, i3, eddy|e, et, e8,
    /// e3, bias|b. `auto` fits the patent's 16 traceless terms (`patent` = permanent,it,et) and
    /// `permanent,i5,e8`, and over several fluxgates MagNav.jl's 18 (permanent,induced,eddy),
    /// keeping the 18 only if cross-validation finds them at least 2 % better on held-out data
    #[arg(long, default_value = DEFAULT_TERMS, value_parser = parse_terms)]
    pub terms: Terms,
    /// Ridge strength: `auto` chooses λ·diag(AᵀA) by 5-fold blocked cross-validation over time;
    /// a number X adds X·I to AᵀA with unscaled columns, exactly as MagNav's linreg
    #[arg(long, default_value = "auto", value_parser = parse_lambda)]
    pub lambda: Lambda,
    /// Pass band LO,HI in Hz; an edge ≤ 0 or ≥ fs/2 turns band-pass into low- or high-pass,
    /// both invalid means no filtering
    #[arg(long, default_value = "0.1,0.9", allow_hyphen_values = true)]
    pub band: String,
    /// Butterworth order (per band edge)
    #[arg(long, default_value_t = 4)]
    pub order: usize,
    /// Samples dropped at each end after filtering
    #[arg(long, default_value_t = 20)]
    pub trim: usize,
    /// Sample rate in Hz (required when the file has no `tt` column)
    #[arg(long, allow_negative_numbers = true)]
    pub fs: Option<f64>,
    /// Magnitude model: `linear` (Tolles-Lawson's B̂·H), `exact` (|B + H| − |B|, fitted by
    /// Gauss-Newton) or `auto` (the one cross-validation prefers). Default: `auto` when λ is
    /// cross-validated, `linear` with a fixed λ (MagNav's procedure)
    #[arg(long, value_parser = str::parse::<MagnitudeChoice>)]
    pub magnitude: Option<MagnitudeChoice>,
    /// Heading levels: `on` also fits the low frequencies against the calibrated fluxgate's
    /// magnitude (one fluxgate), `off` fits the band only. Default: off (docs/fitting.md,
    /// `--levels`, has the measurements)
    #[arg(long, value_parser = parse_on_off)]
    pub levels: Option<bool>,
    /// Fluxgate offset: `on` calibrates a lone fluxgate's offset (the aircraft's field where it
    /// sits, thousands of nT in a cabin) against its own magnitude and fits on its readings
    /// without it; compensation takes it out too. `off` uses the readings as they are
    /// (MagNav's procedure). Default: on when λ is cross-validated, there is one fluxgate and
    /// no --reference
    #[arg(long, value_parser = parse_on_off)]
    pub fluxgate_offset: Option<bool>,
    /// Extra channels as regressors, e.g. currents: `--extra cur_strb,cur_1`. Each adds the
    /// columns B̂x·c, B̂y·c, B̂z·c (a field of fixed direction in the aircraft, proportional to
    /// the channel); with λ `auto` the fit keeps them only if they predict held-out data 2 %
    /// better. Per channel, `:lowpass=HZ` (a causal first-order low-pass, for a field smoothed
    /// by inductance) and `:lag=S` (the field follows the channel S seconds late), e.g.
    /// `--extra cur_strb:lowpass=0.5:lag=0.2,cur_1`. The model names them, and `compensate`,
    /// `stream`, `fom` and `report` read and condition them the same way
    #[arg(long)]
    pub extra: Option<String>,
    /// The fluxgate's lag behind the scalar: `auto` estimates it (sub-sample, within ±1 s, on
    /// held-out folds), a number gives it in seconds (negative: the fluxgate samples early),
    /// `none` (default) takes the samples as they come. The model stores it and `compensate`,
    /// `fom` and `report` apply it
    #[arg(long, default_value = "none", allow_hyphen_values = true)]
    pub lag: tolles::fit::Lag,
    /// A compensated reference magnetometer on the same flight (e.g. the tail stinger's
    /// mag_1_c, for cabin sensors): the scalar minus it is the aircraft's field itself, fitted
    /// in the full band, so --band, --order, --trim and --levels do not apply. The
    /// reference's own errors pass into the model; compensation does not need the reference
    #[arg(long, value_name = "COLUMN")]
    pub reference: Option<String>,
    /// Also train a small network on what the linear model leaves of the scalar minus the
    /// --reference (MagNav's model 2b): its inputs are the fluxgate's direction cosines and
    /// magnitude, the --extra channels and the --inputs channels. It is kept only if it
    /// leaves at least 5 % less than the linear model on held-out stretches of the flight
    #[arg(long, requires = "reference")]
    pub network: bool,
    /// Columns the network reads besides the fluxgate and the extra channels, e.g.
    /// `--inputs ins_roll,ins_pitch,volt_bat`
    #[arg(long, value_name = "COLUMNS", requires = "network")]
    pub inputs: Option<String>,
    /// Units of each hidden layer of the network, e.g. `8` or `16,8`
    #[arg(long, value_name = "UNITS", default_value = "8", requires = "network")]
    pub network_layers: String,
    /// The hidden layers' activation: swish, tanh or relu
    #[arg(
        long,
        value_name = "NAME",
        default_value = "swish",
        requires = "network"
    )]
    pub network_activation: tolles_core::model::network::Activation,
    /// The seed of the network's initial weights and of the order of its training rows: the
    /// same data and seed give the same model bytes
    #[arg(long, value_name = "N", default_value_t = 0, requires = "network")]
    pub network_seed: u64,
    /// What the network's training holds out to stop and to judge it: `stretches` (50 equal
    /// stretches of time, the default: the better model on flights measured) or `lines`
    /// (whole flight lines of the `line` column: the harder judge, when there are 10 or more
    /// lines, none over a tenth of the rows; else stretches)
    #[arg(
        long,
        value_name = "WHAT",
        default_value = "stretches",
        requires = "network"
    )]
    pub network_held_out: tolles::model::HeldOut,
    /// Fit the linear model and the network in turn, each on what the other leaves (two
    /// rounds; MagNav's model 2c trains them together), instead of the network on the fixed
    /// linear model (model 2b, the default). Kept only if the pair beats the linear model alone
    #[arg(long, requires = "network")]
    pub network_joint: bool,
    #[command(flatten)]
    pub select: crate::select::Selection,
}

fn parse_lambda(text: &str) -> Result<Lambda, String> {
    if text.eq_ignore_ascii_case("auto") {
        return Ok(Lambda::auto());
    }
    match text.parse::<f64>() {
        Ok(x) if x.is_finite() && x >= 0.0 => Ok(Lambda::Fixed(x)),
        _ => Err(format!("expected `auto` or a number ≥ 0, got {text:?}")),
    }
}

fn parse_on_off(text: &str) -> Result<bool, String> {
    match text.to_ascii_lowercase().as_str() {
        "on" => Ok(true),
        "off" => Ok(false),
        _ => Err(format!("expected on or off, got {text:?}")),
    }
}

pub fn run(args: Args) -> Result<()> {
    let out = crate::input::out_for_programs(args.out.clone(), "the model (JSON)", "model.json")?;
    let request = request(&args)?;
    let flights = (args.cal.iter())
        .map(|path| (args.select).read_parsing(path, Use::Fit, &request.columns()))
        .collect::<Result<Vec<Table>>>()?;
    fit_and_save(&flights, &request, out.as_deref())
}

fn fit_and_save(flights: &[Table], request: &FitRequest, out: Option<&Path>) -> Result<()> {
    let mut warnings = Vec::new();
    let fitted = tolles::fit::fit_flights(flights, request, &Terminal::default(), &mut warnings);
    // The summary ends with each verdict.
    warnings.retain(|w| !matches!(w, tolles::Warning::Verdict { .. }));
    render::warnings(&mut warnings, Use::Fit);
    if let Err(tolles::Error::Fit {
        cause: FitError::Implausible(fault),
        ..
    }) = &fitted
    {
        note!("verdict: refused: the fit found {fault}, even with its terms restrained");
    }
    let model = fitted.or_render()?;
    // The model first: a summary that cannot be shown (standard error closed, a broken pipe)
    // must not cost it.
    match out {
        Some(path) => tolles::model::save_model(&model, path).or_render()?,
        None => writeln!(std::io::stdout(), "{}", model.to_json()).context("writing the model")?,
    }
    let path = model
        .fits
        .first()
        .and_then(|f| f.calibration_flight.clone());
    for fit in &model.fits {
        let _ = render::fit_summary(fit, path.as_deref().map_or(flights[0].path(), Path::new));
    }
    Ok(())
}

/// The network the flags ask for, if any.
fn network_request(args: &Args) -> Result<Option<NetworkRequest>> {
    if !args.network {
        return Ok(None);
    }
    let layers = (args.network_layers.split(',').map(str::trim))
        .map(|units| {
            units.parse::<usize>().map_err(|_| {
                anyhow::anyhow!(
                    "--network-layers: expected units per layer, e.g. 8 or 16,8; got {units:?}"
                )
            })
        })
        .collect::<Result<Vec<_>>>()?;
    let channels = match &args.inputs {
        Some(list) => name_list(list, "--inputs")?,
        None => Vec::new(),
    };
    Ok(Some(NetworkRequest {
        settings: NetworkSettings {
            hidden: layers,
            activation: args.network_activation,
            seed: args.network_seed,
            ..NetworkSettings::default()
        },
        channels,
        held_out: args.network_held_out,
        joint: args.network_joint,
    }))
}

/// The library request the flags ask for.
fn request(args: &Args) -> Result<FitRequest> {
    let (pass1_hz, pass2_hz) = parse_band(&args.band)?;
    Ok(FitRequest {
        terms: args.terms,
        lambda: args.lambda,
        band: Band { pass1_hz, pass2_hz },
        order: args.order,
        trim: args.trim,
        fs_hz: args.fs,
        magnitude: args.magnitude,
        levels: args.levels,
        fluxgate_offset: args.fluxgate_offset,
        lag: args.lag,
        reference: args.reference.clone(),
        network: network_request(args)?,
        extras: match &args.extra {
            Some(list) => tolles::fit::parse_extras(&name_list(list, "--extra")?)
                .map_err(|e| anyhow::anyhow!("--extra {e}"))?,
            None => Vec::new(),
        },
        ..FitRequest::new(
            name_list(&args.scalar.join(","), "--scalar")?,
            name_list(&args.vector.join(","), "--vector")?,
        )
    })
}
