//! Flag values shared by several commands: name lists, pass bands, output paths.

use anyhow::{bail, Context, Result};
use std::path::PathBuf;

/// An `--out` path; `-` (standard output) is `None`, as when the flag is left out.
pub fn out_path(out: Option<PathBuf>) -> Option<PathBuf> {
    out.filter(|path| path.as_os_str() != "-")
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
