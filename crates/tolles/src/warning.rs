//! Warnings: what a workflow noticed but worked around, returned as values for the caller to
//! show (the CLI prints them on standard error, Python raises `UserWarning`s).

// Errors write rates the same way; `tolles::warning::hz` stays the public path.
pub use crate::numbers::{hz, significant};
use std::fmt;
use std::path::{Path, PathBuf};
use tolles_io::schema::TIME_COLUMN;

/// Something a caller should know about a result.
#[derive(Debug, Clone, PartialEq)]
pub enum Warning {
    /// What a reader left out of a table (e.g. a 2-D HDF5 dataset).
    ReaderNote {
        /// The file read.
        path: PathBuf,
        /// What was left out, as a sentence.
        note: String,
    },
    /// A sample rate was given that differs by more than 1 % from the time column's; the given
    /// one is used.
    SampleRateDiffers {
        /// The given rate (Hz).
        given_hz: f64,
        /// 1 / the median step of the time column (Hz).
        from_time_hz: f64,
    },
    /// A band edge at or above the Nyquist frequency: that edge is off, and the band runs up
    /// to Nyquist (what the model stores and the output says).
    BandEdgeAboveNyquist {
        /// The flight file.
        path: PathBuf,
        /// The edge asked for (Hz).
        edge_hz: f64,
        /// Half the sample rate (Hz).
        nyquist_hz: f64,
    },
    /// The time column gives a sample rate no magnetometer samples at.
    UnlikelySampleRate {
        /// The flight file.
        path: PathBuf,
        /// 1 / the median step of the time column (Hz).
        hz: f64,
    },
    /// Rows of a compensated column left empty because a value they need is missing.
    Uncomputable {
        /// The flight file.
        path: PathBuf,
        /// Rows left empty (rows).
        rows: usize,
        /// Rows in the file (rows).
        of: usize,
        /// The compensated column.
        column: String,
    },
    /// The input already has the compensated column's name, so ours is written as `renamed`.
    OutputRenamed {
        /// The input file.
        path: PathBuf,
        /// The compensated column's name, which the input already has.
        wanted: String,
        /// The name it is written under instead.
        renamed: String,
    },
    /// Rows of a flight the FOM's compensation could not compute.
    NotCompensated {
        /// The flight file.
        path: PathBuf,
        /// Rows not compensated (rows).
        rows: usize,
        /// Rows in the flight (rows).
        of: usize,
    },
    /// A report's spectrum could not be computed (a flight shorter than a segment, or cut by
    /// gaps into shorter runs): the page goes without it.
    NoSpectrum {
        /// The flight file.
        path: PathBuf,
        /// Which signal: `uncompensated` or `compensated`.
        signal: &'static str,
        /// Why, as the spectrum said.
        reason: String,
    },
    /// No maneuvers were found in the attitude.
    NoManeuvers {
        /// The flight file.
        path: PathBuf,
        /// The attitude columns searched, listed.
        columns: String,
    },
    /// The time column steps back or repeats at `places` places (the first at `place`): each
    /// stretch between them is taken on its own, as after a gap. With `run_on`, the times
    /// used after the first are moved on so they increase (reports, FOM, the procedure).
    TimeStepsBack {
        /// The flight file.
        path: PathBuf,
        /// Where the first step back is: "line N" or "row N" (1-based).
        place: String,
        /// Number of places the time steps back or repeats.
        places: usize,
        /// Whether the times after the first such place are moved on so they increase.
        run_on: bool,
    },
    /// The flight has no attitude columns, so no maneuvers and no heading levels.
    NoAttitude {
        /// The flight file.
        path: PathBuf,
        /// The attitude columns missing, listed.
        columns: String,
    },
    /// A maneuver window with samples that have no band-passed value.
    ManeuverGap {
        /// The flight file.
        path: PathBuf,
        /// The maneuver's kind (`roll`, `pitch` or `yaw`).
        kind: String,
        /// The maneuver's heading (degrees clockwise from north), as written in the message.
        heading: String,
        /// Window start and end (s).
        start_tt: f64,
        /// Window end (s).
        end_tt: f64,
        /// Samples of the window without a band-passed value (samples).
        samples: usize,
    },
    /// The least-squares fit the patent's procedure is compared with failed.
    NoLeastSquares {
        /// The flight file.
        path: PathBuf,
        /// Why the fit failed.
        reason: String,
    },
    /// Not a problem: which rows a selection kept, so the caller can say what it works on.
    RowsSelected {
        /// The file read.
        path: PathBuf,
        /// The selection and what it kept.
        selection: crate::selection::Selection,
    },
    /// A fit that barely improved on the data, or needed the strongest ridge tried: the model
    /// explains little, often because an interference source is not among the regressors.
    PoorFit {
        /// The scalar of the fit.
        scalar: String,
        /// Filtered scalar std / residual std.
        improvement: f64,
        /// The chosen relative ridge strength, when it is the largest tried.
        top_lambda: Option<f64>,
    },
    /// `fit --network` trained a network that did not leave clearly less than the linear model
    /// on the rows kept for judging it; the model holds the linear fit alone.
    NetworkNotKept {
        /// The scalar of the fit.
        scalar: String,
        /// RMS (nT) the linear model leaves on the judging rows.
        linear_rms_nt: f64,
        /// RMS (nT) the linear model and the network leave there.
        network_rms_nt: f64,
        /// What was held out to judge.
        held_out: crate::model::HeldOut,
    },
    /// `fit --extra` channels that cross-validation found no better than leaving them out: the
    /// model holds no terms, and no coverage, for them.
    ExtrasDropped {
        /// The scalar of the fit.
        scalar: String,
        /// The channels dropped, as given to `--extra`.
        channels: Vec<String>,
    },
    /// `--uncertainty` asked of a model without the coefficients' covariance (a file written
    /// before version 3): each row's σ is empty.
    NoUncertainty {
        /// The scalar of the fit.
        scalar: String,
    },
    /// Not a problem: raw channels (SGL's `AZIMUTH`, …) a table also answers to under tolles'
    /// names, as `(raw, tolles)`, because it has no columns of those names.
    ColumnsAliased {
        /// The file read.
        path: PathBuf,
        /// The aliases used, as `(raw, tolles)` column names.
        aliases: Vec<(String, String)>,
    },
    /// 1-D arrays of a MATLAB or HDF5 file whose length is not the table's `rows`, as
    /// `(name, length)`: kept beside the table ([`tolles_io::table::Table::side_columns`]) but
    /// not used, except by `convert`.
    SideColumns {
        /// The file read.
        path: PathBuf,
        /// Rows of the table (rows).
        rows: usize,
        /// The arrays kept beside the table, as `(name, length in samples)`.
        columns: Vec<(String, usize)>,
    },
    /// Columns of a written file shorter than its `rows`, padded with missing cells (a MATLAB
    /// or HDF5 array of another length converted to CSV or Parquet), as `(name, own length)`.
    Padded {
        /// The file written.
        path: PathBuf,
        /// Rows of the file written (rows).
        rows: usize,
        /// The columns padded, as `(name, own length in rows)`.
        columns: Vec<(String, usize)>,
    },
    /// A time column the input declared in a unit other than seconds, written as read to CSV,
    /// which cannot declare units: read back, its times are taken as seconds.
    TimeUnitNotWritten {
        /// The file written.
        path: PathBuf,
        /// The time column.
        column: String,
        /// The unit the input declared for it.
        unit: String,
    },
    /// A model whose verdict is not `good` (see `tolles_core::fit::verdict`).
    Verdict {
        /// The scalar of the model.
        scalar: String,
        /// The verdict: its grade and reasons.
        verdict: tolles_core::fit::verdict::Verdict,
    },
    /// Rows whose fluxgate direction, its rate of change or an extra channel's value lies
    /// outside what the calibration flew: the model extrapolates there.
    Extrapolated {
        /// The flight file.
        path: PathBuf,
        /// Rows outside what the calibration flew (rows).
        rows: usize,
        /// Rows in the file (rows).
        of: usize,
        /// The compensated column.
        column: String,
    },
    /// A warning about one scalar of a report of several.
    ForScalar {
        /// The scalar the warning is about.
        scalar: String,
        /// The warning.
        warning: Box<Warning>,
    },
    /// Anything else, as a sentence that names the file.
    Other(String),
}

impl Warning {
    /// [`Warning::Extrapolated`] for `rows` of the `of` rows of `column` in `path`, when there
    /// are any: the whole-file and the chunked compensation say it alike.
    pub(crate) fn extrapolated(path: &Path, rows: usize, of: usize, column: &str) -> Option<Self> {
        (rows > 0).then(|| Warning::Extrapolated {
            path: path.to_path_buf(),
            rows,
            of,
            column: column.to_string(),
        })
    }

    /// [`Warning::Uncomputable`] for `rows` of the `of` rows of `column` in `path`, when there
    /// are any.
    pub(crate) fn uncomputable(path: &Path, rows: usize, of: usize, column: &str) -> Option<Self> {
        (rows > 0).then(|| Warning::Uncomputable {
            path: path.to_path_buf(),
            rows,
            of,
            column: column.to_string(),
        })
    }
}

impl fmt::Display for Warning {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Warning::ReaderNote { path, note } => write!(f, "{}: {note}", path.display()),
            Warning::BandEdgeAboveNyquist {
                path,
                edge_hz,
                nyquist_hz,
            } => write!(
                f,
                "{}: the band's upper edge {} Hz is at or above the Nyquist frequency {} Hz of \
                 its sample rate; the band runs up to {} Hz (a high-pass), and says so",
                path.display(),
                hz(*edge_hz),
                hz(*nyquist_hz),
                hz(*nyquist_hz)
            ),
            Warning::PoorFit {
                scalar,
                improvement,
                top_lambda,
            } => {
                write!(f, "the fit of {scalar} improves the filtered scalar only ×{improvement:.2}")?;
                if let Some(l) = top_lambda {
                    write!(f, " and needed the strongest ridge tried (λ = {l}·diag(AᵀA))")?;
                }
                write!(f, ": an interference source may be missing from the regressors (a current? try --extra)")
            }
            Warning::NetworkNotKept {
                scalar,
                linear_rms_nt,
                network_rms_nt,
                held_out,
            } if !network_rms_nt.is_finite() => write!(
                f,
                "the network for {scalar} was not kept: no held-out row ({held_out}) has a value of every network input, so it could not be judged against the linear model's {} nT; give --inputs the flight records throughout",
                significant(*linear_rms_nt)
            ),
            Warning::NetworkNotKept {
                scalar,
                linear_rms_nt,
                network_rms_nt,
                held_out,
            } => write!(
                f,
                "the network for {scalar} was not kept: on held-out {held_out} it leaves {} nT against the linear model's {} nT (it must leave at least {:.0} % less)",
                significant(*network_rms_nt),
                significant(*linear_rms_nt),
                100.0 * crate::model::KEEP_MARGIN
            ),
            Warning::ExtrasDropped { scalar, channels } => write!(
                f,
                "the fit of {scalar} dropped --extra {}: cross-validation found the model no better with them (they carry nothing of {scalar}'s interference, or too little to tell); the model leaves them out",
                channels.join(",")
            ),
            Warning::NoUncertainty { scalar } => write!(
                f,
                "the model of {scalar} holds no covariance of its coefficients (a file written before version 3): its σ column is empty; fit again to have one"
            ),
            Warning::UnlikelySampleRate { path, hz } => write!(
                f,
                "{}: column {TIME_COLUMN:?} gives a sample rate of {hz:.6} Hz, which no magnetometer samples at: is time in seconds? Give its unit in the file, or the rate with --fs",
                path.display()
            ),
            Warning::SampleRateDiffers {
                given_hz,
                from_time_hz,
            } => write!(
                f,
                "the given sample rate {} Hz differs from the {from_time_hz:.6} Hz of column {TIME_COLUMN:?}; using the given rate", hz(*given_hz)
            ),
            Warning::Uncomputable { path, rows, of, column } => write!(
                f,
                "{}: {rows} of {of} rows have no {column} (a value their correction reads is missing: the scalar, a fluxgate, or an extra or network input channel, through its lag); their cells are empty",
                path.display()
            ),
            Warning::OutputRenamed { path, wanted, renamed } => write!(
                f,
                "{} already has a column {wanted:?}; writing ours as {renamed:?}",
                path.display()
            ),
            Warning::NotCompensated { path, rows, of } => write!(
                f,
                "{}: {rows} of {of} rows cannot be compensated (a value their correction reads is missing: the scalar, a fluxgate, or an extra or network input channel, through its lag)",
                path.display()
            ),
            Warning::NoSpectrum {
                path,
                signal,
                reason,
            } => write!(
                f,
                "{}: no spectrum of the {signal} scalar ({reason}); the report goes without it",
                path.display()
            ),
            Warning::NoManeuvers { path, columns } => write!(
                f,
                "{}: no roll, pitch or yaw maneuvers found in columns {columns}; is this a compensation flight?",
                path.display()
            ),
            Warning::TimeStepsBack { path, place, places, run_on } => write!(
                f,
                "{}: time steps back or repeats at {places} place(s), the first at {place} (a file sorted by line?); each stretch is filtered on its own, as after a gap{}",
                path.display(),
                match run_on {
                    true => ", and its times are run on after the stretch before, so times after there are not the file's",
                    false => "",
                }
            ),
            Warning::NoAttitude { path, columns } => write!(
                f,
                "{}: no attitude column {columns}, so no maneuvers, figure of merit or heading levels",
                path.display()
            ),
            Warning::ManeuverGap { path, kind, heading, start_tt, end_tt, samples } => write!(
                f,
                "{}: {kind} on heading {heading}° at {start_tt:.1}–{end_tt:.1} s: {samples} samples have no band-passed value (missing data); its peak-to-peak uses the rest",
                path.display()
            ),
            Warning::NoLeastSquares { path, reason } => write!(
                f,
                "{}: no least-squares comparison: {reason}",
                path.display()
            ),
            Warning::RowsSelected { path, selection } => {
                write!(f, "{}: {}", path.display(), selection.summary)
            }
            Warning::ColumnsAliased { path, aliases } => {
                // A file under its own names (29 of an SGL flight's) needs no essay each time.
                let mut list: Vec<String> = (aliases.iter().take(ALIASES_NAMED))
                    .map(|(raw, name)| format!("{raw} as {name}"))
                    .collect();
                if aliases.len() > ALIASES_NAMED {
                    let more = aliases.len() - ALIASES_NAMED;
                    list.push(format!("and {more} more (tolles info shows each)"));
                }
                write!(f, "{}: using columns {}", path.display(), list.join(", "))
            }
            Warning::SideColumns { path, rows, columns } => write!(
                f,
                "{}: not used, as their lengths are not the {rows} rows of the other columns: {}",
                path.display(),
                name_lengths(columns)
            ),
            Warning::Padded { path, rows, columns } => {
                write!(
                    f,
                    "{}: padded to {rows} rows with empty cells: {}",
                    path.display(),
                    name_lengths(columns)
                )
            }
            Warning::TimeUnitNotWritten { path, column, unit } => write!(
                f,
                "{}: time column {column:?} is written in {unit:?} as read, which CSV cannot \
                 declare: read back, its times count as seconds (write .h5 or .parquet, which \
                 hold it in seconds, or give --fs when reading it)",
                path.display()
            ),
            Warning::Verdict { scalar, verdict } => {
                write!(f, "the model of {scalar} is {verdict}")
            }
            Warning::Extrapolated { path, rows, of, column } => write!(
                f,
                "{}: {rows} of {of} rows of {column} lie outside what the calibration flew (the field's direction in the aircraft, its rate of change, an extra channel's value, or a network input beyond its training range): the model extrapolates there",
                path.display()
            ),
            Warning::ForScalar { scalar, warning } => write!(f, "scalar {scalar}: {warning}"),
            Warning::Other(text) => f.write_str(text),
        }
    }
}

/// A warning when `fit`'s verdict is not `good`.
pub fn verdict_warning(scalar: &str, fit: &tolles_core::fit::Fit) -> Option<Warning> {
    let verdict = fit.verdict.as_ref()?;
    (!verdict.is_good()).then(|| Warning::Verdict {
        scalar: scalar.to_string(),
        verdict: verdict.clone(),
    })
}

/// `a (960), b (18)`.
fn name_lengths(columns: &[(String, usize)]) -> String {
    let list: Vec<String> = columns
        .iter()
        .map(|(name, len)| format!("{name} ({len})"))
        .collect();
    list.join(", ")
}

/// Aliased columns a warning names before it counts the rest.
const ALIASES_NAMED: usize = 5;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn many_aliased_columns_are_named_in_part() {
        let aliases = |n: usize| -> Vec<(String, String)> {
            (0..n)
                .map(|k| (format!("RAW{k}"), format!("name{k}")))
                .collect()
        };
        let path = PathBuf::from("f.h5");
        let many = Warning::ColumnsAliased {
            path: path.clone(),
            aliases: aliases(29),
        };
        assert_eq!(
            many.to_string(),
            "f.h5: using columns RAW0 as name0, RAW1 as name1, RAW2 as name2, RAW3 as name3, \
             RAW4 as name4, and 24 more (tolles info shows each)"
        );
        let few = Warning::ColumnsAliased {
            path,
            aliases: aliases(2),
        };
        assert_eq!(
            few.to_string(),
            "f.h5: using columns RAW0 as name0, RAW1 as name1"
        );
    }
}
