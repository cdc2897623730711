//! Reading flight tables and turning core errors into messages that name the file and line.

use anyhow::{anyhow, bail, Context, Result};
use std::path::Path;
use tolles_io::table::Table;

/// The time column; when present it gives the sample rate and marks gaps.
pub const TIME_COLUMN: &str = "tt";

/// Reads a flight table whole, saying on stderr what the reader left out.
pub fn read_table(path: &Path) -> Result<Table> {
    crate::select::Selection::default().read(path, crate::render::Use::Other)
}

/// The error for time `t` (s) at `place` of `path` that is not after the time `before` (s).
pub fn time_not_increasing(path: &Path, place: &str, t: f64, before: f64) -> anyhow::Error {
    anyhow!(
        "{}: {place}, column {TIME_COLUMN:?}: time does not increase ({t} after {before}); sort the file or remove repeated rows",
        path.display(),
    )
}

/// The error for a fluxgate `vector` whose magnitude (nT) at `place` of `path` is implausible.
pub fn flux_magnitude_error(
    path: &Path,
    place: &str,
    vector: &str,
    magnitude: f64,
) -> anyhow::Error {
    anyhow!(
        "{}: {place}: fluxgate {vector} magnitude {magnitude:.1} nT is outside 1,000–100,000 nT; are columns {vector}_x/_y/_z in nT?",
        path.display()
    )
}

/// The sample rate (Hz): `fs` (from `--fs`) if given, else 1 / the median step of the time
/// column (s), else 1 / the file's `dt` scalar (s; SGL HDF5 files carry one).
pub fn sample_rate_from(
    path: &Path,
    dt: Option<f64>,
    median_step: Option<f64>,
    fs: Option<f64>,
) -> Result<f64> {
    let from_dt = dt
        .filter(|dt| dt.is_finite() && *dt > 0.0)
        .map(|dt| 1.0 / dt);
    let from_time = median_step.map(|dt| 1.0 / dt).or(from_dt);
    match (fs, from_time) {
        (Some(fs), _) if !(fs.is_finite() && fs > 0.0) => {
            bail!("--fs must be a positive number of hertz, got {fs}")
        }
        (Some(fs), Some(t)) if ((fs - t) / t).abs() > 0.01 => {
            eprintln!(
                "warning: --fs {fs} Hz differs from the {t:.6} Hz of column {TIME_COLUMN:?}; using --fs"
            );
            Ok(fs)
        }
        (Some(fs), _) => Ok(fs),
        (None, Some(t)) => Ok(t),
        (None, None) => Err(anyhow!(
            "{}: no time column {TIME_COLUMN:?} to take the sample rate from; give it with --fs HZ",
            path.display()
        )),
    }
}

/// `mag_3_uc,mag_4_uc` → the names, each once; `what` names the option in errors.
pub fn name_list(list: &str, what: &str) -> Result<Vec<String>> {
    let names: Vec<String> = list
        .split(',')
        .map(str::trim)
        .filter(|s| !s.is_empty())
        .map(String::from)
        .collect();
    if names.is_empty() {
        bail!("{what} needs a column name, or several separated by commas");
    }
    if let Some(k) = (1..names.len()).find(|&k| names[..k].contains(&names[k])) {
        bail!("{what} names {:?} twice", names[k]);
    }
    Ok(names)
}

/// Parses `LO,HI` in hertz.
pub fn parse_band(text: &str) -> Result<(f64, f64)> {
    let parts: Vec<&str> = text.split(',').map(str::trim).collect();
    let [lo, hi] = parts[..] else {
        bail!("--band takes two frequencies in Hz as LO,HI (e.g. 0.1,0.9), got {text:?}")
    };
    let parse = |s: &str| {
        s.parse::<f64>()
            .with_context(|| format!("--band: {s:?} is not a frequency in Hz"))
    };
    Ok((parse(lo)?, parse(hi)?))
}
