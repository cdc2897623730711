//! Flag values shared by several commands: name lists, pass bands, output paths.

use anyhow::{bail, Context, Result};
use std::path::PathBuf;

/// An `--out` path; `-` (standard output) is `None`, as when the flag is left out.
pub fn out_path(out: Option<PathBuf>) -> Option<PathBuf> {
    out.filter(|path| path.as_os_str() != "-")
}

/// An `--out` path for a file meant for a program (`what`, e.g. "the model (JSON)"), which
/// goes to standard output when the flag is left out, but not to a terminal: there it would
/// scroll away unsaved, so the command stops before its work and says `-o example`. `-o -`
/// still writes to a terminal when asked to. `None`: standard output.
pub fn out_for_programs(
    out: Option<PathBuf>,
    what: &str,
    example: &str,
) -> Result<Option<PathBuf>> {
    use std::io::IsTerminal;
    out_unless_terminal(out, std::io::stdout().is_terminal(), what, example)
}

fn out_unless_terminal(
    out: Option<PathBuf>,
    terminal: bool,
    what: &str,
    example: &str,
) -> Result<Option<PathBuf>> {
    if out.is_none() && terminal {
        bail!(
            "{what} is not written to a terminal: add `-o {example}`, pipe it, or give `-o -` \
             to see it here"
        );
    }
    Ok(out_path(out))
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

/// How `fom` and `report` tell straight legs and box maneuvers apart by heading.
#[derive(clap::Args, Debug, Clone)]
pub struct Legs {
    /// Nominal headings (degrees clockwise from north) whose straight legs give the heading
    /// error, e.g. 45,225 for a survey flown on those lines
    #[arg(
        long,
        value_name = "DEG,...",
        value_delimiter = ',',
        allow_negative_numbers = true
    )]
    pub headings: Option<Vec<f64>>,
    /// How far the yaw may stray from a nominal heading on a straight leg (degrees, 0–90)
    #[arg(
        long,
        value_name = "DEG",
        default_value_t = 10.0,
        allow_negative_numbers = true
    )]
    pub heading_tolerance: f64,
    /// Largest |roll| and |pitch| on a straight leg (degrees, 0–90)
    #[arg(
        long,
        value_name = "DEG",
        default_value_t = 3.0,
        allow_negative_numbers = true
    )]
    pub level_tolerance: f64,
    /// A box maneuver flown within this of north, east, south or west counts as that
    /// heading's (degrees, 0–45)
    #[arg(
        long,
        value_name = "DEG",
        default_value_t = 20.0,
        allow_negative_numbers = true
    )]
    pub cardinal_tolerance: f64,
}

impl Legs {
    /// `request` with these legs.
    pub fn apply(&self, request: tolles::fom::FomRequest) -> tolles::fom::FomRequest {
        request.with_legs(
            self.headings.clone(),
            self.heading_tolerance,
            self.level_tolerance,
            self.cardinal_tolerance,
        )
    }

    /// The report `request` with these legs.
    pub fn apply_to_report(
        &self,
        request: tolles::report::ReportRequest,
    ) -> tolles::report::ReportRequest {
        request.with_legs(
            self.headings.clone(),
            self.heading_tolerance,
            self.level_tolerance,
            self.cardinal_tolerance,
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_file_for_programs_is_not_dumped_on_a_terminal() {
        let refused = out_unless_terminal(None, true, "the model (JSON)", "model.json");
        let said = refused.unwrap_err().to_string();
        assert!(said.contains("not written to a terminal") && said.contains("-o model.json"));
        // Piped, or asked for with `-o -`, it goes to standard output; a path is a path.
        assert_eq!(out_unless_terminal(None, false, "m", "m").unwrap(), None);
        assert_eq!(
            out_unless_terminal(Some("-".into()), true, "m", "m").unwrap(),
            None
        );
        let path = Some(PathBuf::from("m.json"));
        assert_eq!(
            out_unless_terminal(path.clone(), true, "m", "m").unwrap(),
            path
        );
    }
}
