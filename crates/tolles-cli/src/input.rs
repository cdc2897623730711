//! Reading flight tables and turning core errors into messages that name the file and line.

use anyhow::{anyhow, bail, Context, Result};
use std::path::Path;
use tolles_core::fit::FitError;
use tolles_core::segment::{first_non_increasing, median_step};
use tolles_core::vector::VectorSeries;
use tolles_io::format::Format;
use tolles_io::table::Table;

/// The time column; when present it gives the sample rate and marks gaps.
pub const TIME_COLUMN: &str = "tt";

/// The columns of a flight table that one scalar model needs.
pub struct Flight<'t> {
    pub table: &'t Table,
    pub scalar: Vec<f64>,
    /// The fluxgates, one per name in `vectors`.
    pub flux: Vec<VectorSeries>,
    /// The fluxgates' column prefixes.
    pub vectors: Vec<String>,
    pub tt: Option<Vec<f64>>,
}

impl<'t> Flight<'t> {
    /// The columns `scalar` and `V_x/_y/_z` for every V in `vectors` of an already read table.
    pub fn from_table(table: &'t Table, scalar: &str, vectors: &[String]) -> Result<Self> {
        let scalar = table.numeric(scalar)?;
        let flux = vectors
            .iter()
            .map(|v| table.vector(v))
            .collect::<Result<Vec<_>, _>>()?;
        let tt = time_column(table)?;
        Ok(Self {
            table,
            scalar,
            flux,
            vectors: vectors.to_vec(),
            tt,
        })
    }

    /// The sample rate (Hz): `--fs` if given, else 1 / median step of `tt`.
    pub fn sample_rate(&self, fs: Option<f64>) -> Result<f64> {
        sample_rate(self.table, self.tt.as_deref(), fs)
    }

    /// Adds file and line to a core fit error.
    pub fn explain(&self, error: FitError, scalar: &str) -> anyhow::Error {
        let file = self.table.path().display();
        match error {
            FitError::FluxMagnitude {
                fluxgate,
                index,
                magnitude,
            } => flux_magnitude_error(
                self.table.path(),
                &self.table.place_of(index),
                &self.vectors[fluxgate],
                magnitude,
            ),
            FitError::ConstantScalar => {
                anyhow!("{file}: column {scalar:?} is constant: there is nothing to fit")
            }
            FitError::ConstantFlux => anyhow!(
                "{file}: columns {v}_x/_y/_z are constant: the aircraft did not maneuver, so no term can be fitted",
                v = self.vectors[0]
            ),
            other => anyhow::Error::new(other).context(format!("{file}")),
        }
    }
}

/// Reads a flight table in the format its extension names (CSV, XYZ, GDF, HDF5, Parquet), with a
/// progress bar over the bytes of a text file on a terminal. What the reader left out of the
/// table (e.g. a 2-D HDF5 dataset) is named on stderr.
pub fn read_table(path: &Path) -> Result<Table> {
    let format = Format::from_path(path);
    let table = match format {
        Format::Csv | Format::Xyz => {
            let file = std::fs::File::open(path).map_err(|source| tolles_io::IoError::Open {
                path: path.to_path_buf(),
                source,
            })?;
            let size = file.metadata().map_or(0, |m| m.len());
            let bar = crate::progress::bytes(size, "reading");
            let reader = std::io::BufReader::new(bar.wrap_read(file));
            let table = match format {
                Format::Xyz => tolles_io::xyz::from_reader(reader, path),
                _ => Table::from_reader(reader, path),
            };
            bar.finish_and_clear();
            table?
        }
        other => Table::read(path, Some(other))?,
    };
    for note in table.notes() {
        eprintln!("warning: {}: {note}", path.display());
    }
    Ok(table)
}

/// The time column of `table` (s), if it has one; an error if time does not increase.
pub fn time_column(table: &Table) -> Result<Option<Vec<f64>>> {
    if !table.has(TIME_COLUMN) {
        return Ok(None);
    }
    let tt = table.numeric(TIME_COLUMN)?;
    if let Some(k) = first_non_increasing(&tt) {
        let before = tt[..k].iter().rev().find(|t| t.is_finite()).copied();
        return Err(time_not_increasing(
            table.path(),
            &table.place_of(k),
            tt[k],
            before.unwrap_or(f64::NAN),
        ));
    }
    Ok(Some(tt))
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

/// The sample rate (Hz) of `table`: `fs` (from `--fs`) if given, else 1 / median step of `tt`,
/// else 1 / the file's `dt` scalar (s; SGL HDF5 files carry one).
pub fn sample_rate(table: &Table, tt: Option<&[f64]>, fs: Option<f64>) -> Result<f64> {
    let step = tt.and_then(median_step);
    sample_rate_from(table.path(), table.metadata("dt"), step, fs)
}

/// [`sample_rate`] from its ingredients: the file's `dt` scalar (s) and the median step of its
/// time column (s), if any.
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
