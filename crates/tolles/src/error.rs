//! The library's errors: each is one line that names the file, and where it can the row or
//! column, so a user can fix the input. No message names a command-line flag; the CLI adds its
//! own flag hints where one helps.

use std::io::ErrorKind;
use std::path::PathBuf;
use tolles_core::fit::FitError;
use tolles_core::flight::igrf::IgrfError;
use tolles_core::flight::maneuver_list::ManeuverListError;
use tolles_core::maneuvers::fom::FomError;
use tolles_core::maneuvers::heading::HeadingError;
use tolles_core::maneuvers::identifiability::PlanningError;
use tolles_core::patent::procedure::ProcedureError;
use tolles_core::signal::filter::FilterError;
use tolles_io::schema::TIME_COLUMN;
use tolles_io::select::SelectError;
use tolles_io::IoError;

/// Why a workflow could not be carried out.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// A file could not be read or written, or is malformed.
    #[error(transparent)]
    Io(#[from] IoError),
    /// A column could not be renamed: no column `old`, or `new` is taken.
    #[error("renaming {old:?} to {new:?}: {source}")]
    Rename {
        /// The column to rename, as given.
        old: String,
        /// Its new name.
        new: String,
        /// Why the rename failed.
        source: Box<IoError>,
    },
    /// A fluxgate named neither by a prefix nor by three columns `X:Y:Z`.
    #[error("fluxgate {spec:?}: {reason}")]
    VectorSpec {
        /// The fluxgate as given (a prefix or `X:Y:Z`).
        spec: String,
        /// Why it names no fluxgate.
        reason: &'static str,
    },
    /// Rows could not be selected by line or time.
    #[error(transparent)]
    Select(#[from] SelectError),
    /// A fluxgate magnitude outside the physical range.
    #[error("{}: {place}: fluxgate {vector} magnitude {} nT is outside 1,000–100,000 nT; are columns {vector}_x/_y/_z in nT?", path.display(), tolles_core::fit::show_nt(*magnitude))]
    FluxMagnitude {
        /// The flight file.
        path: PathBuf,
        /// Where the sample is: "line N" or "row N" (1-based).
        place: String,
        /// Prefix of the fluxgate columns `<vector>_x/_y/_z`.
        vector: String,
        /// |B| (nT).
        magnitude: f64,
    },
    /// No row has every column a fit needs.
    #[error("{}: column {column:?} has no usable value (all missing, non-numeric or out of range): there is nothing to fit", path.display())]
    NoUsableRow {
        /// The flight file.
        path: PathBuf,
        /// The column without a usable value.
        column: String,
    },
    /// The scalar does not vary.
    #[error("{}: column {scalar:?} is constant: there is nothing to fit", path.display())]
    ConstantScalar {
        /// The flight file.
        path: PathBuf,
        /// The scalar column.
        scalar: String,
    },
    /// An extra channel does not vary: its columns would be the permanent field's again.
    #[error("{}: extra channel {channel:?} is constant: it carries no current to fit, and would take the permanent field's place; leave it out", path.display())]
    ConstantExtra {
        /// The flight file.
        path: PathBuf,
        /// The extra channel's column.
        channel: String,
    },
    /// An extra channel is a column the fit already uses, or another channel under a second
    /// spelling.
    #[error("{}: extra channel {channel:?} is column {column:?}, which the fit already uses as {role}; an extra channel must be a channel of its own (a current, a voltage)", path.display())]
    ExtraNotItsOwn {
        /// The flight file.
        path: PathBuf,
        /// The extra channel as named.
        channel: String,
        /// The file's column it names.
        column: String,
        /// What the fit already uses that column as (e.g. "a scalar").
        role: &'static str,
    },
    /// The fluxgate does not vary.
    #[error("{}: columns {vector}_x/_y/_z are constant: the aircraft did not maneuver, so no term can be fitted", path.display())]
    ConstantFlux {
        /// The flight file.
        path: PathBuf,
        /// Prefix of the fluxgate columns `<vector>_x/_y/_z`.
        vector: String,
    },
    /// Any other reason a fit failed. (`cause`, not `source`: the message already includes it,
    /// and a `source` would print it twice in a cause chain.)
    #[error("{}: {cause}", path.display())]
    Fit {
        /// The flight file.
        path: PathBuf,
        /// Why the fit failed.
        cause: FitError,
    },
    /// The figure of merit could not be computed.
    #[error("{}: {cause}", path.display())]
    Fom {
        /// The flight file.
        path: PathBuf,
        /// Why the FOM could not be computed.
        cause: FomError,
    },
    /// The heading levels of the straight legs could not be computed.
    #[error("{}: {cause}", path.display())]
    Heading {
        /// The flight file.
        path: PathBuf,
        /// Why the heading levels could not be computed.
        cause: HeadingError,
    },
    /// Neither a time column, a `dt` scalar nor a given rate says how fast the data was sampled.
    #[error("{}: no time column {TIME_COLUMN:?} to take the sample rate from; give the sample rate (--fs; fs= in Python)", path.display())]
    NoSampleRate {
        /// The flight file.
        path: PathBuf,
    },
    /// The time column exists but gives no step: every value missing, or none increasing.
    #[error("{}: time column {TIME_COLUMN:?} has no two successive usable times (all missing, non-numeric or not increasing), so it gives no sample rate; give the sample rate (--fs; fs= in Python)", path.display())]
    TimeUnusable {
        /// The flight file.
        path: PathBuf,
    },
    /// A given sample rate that is not a positive number of hertz.
    #[error("the sample rate must be a positive number of hertz, got {fs_hz}")]
    BadSampleRate {
        /// The sample rate given (Hz).
        fs_hz: f64,
    },
    /// A band edge that is not a finite frequency.
    #[error("the band's edges must be finite frequencies in Hz (0 switches an edge off), got {pass1_hz},{pass2_hz} (--band; band= in Python)")]
    BadBand {
        /// The first band edge given (Hz).
        pass1_hz: f64,
        /// The second band edge given (Hz).
        pass2_hz: f64,
    },
    /// A fit at a sample rate (Hz) no model can be kept at.
    #[error("{}: a model cannot be fitted at {} Hz: the sample rate must lie within {}–{} Hz (is time in seconds? give the rate with --fs; fs= in Python)", path.display(), crate::numbers::hz(*fs_hz), crate::numbers::hz(*lo_hz), crate::numbers::hz(*hi_hz))]
    FitRateOutOfRange {
        /// The flight file.
        path: PathBuf,
        /// The sample rate of the fit (Hz).
        fs_hz: f64,
        /// The lowest sample rate a model can be kept at (Hz).
        lo_hz: f64,
        /// The highest sample rate a model can be kept at (Hz).
        hi_hz: f64,
    },
    /// The model a fit produced would not read back (a number JSON cannot hold).
    #[error("{}: the model fitted cannot be written: {message}", path.display())]
    UnwritableModel {
        /// The calibration flight file.
        path: PathBuf,
        /// Why the model cannot be written.
        message: String,
    },
    /// A model file without fits.
    #[error("{}: the model holds no fits", path.display())]
    EmptyModel {
        /// The model file.
        path: PathBuf,
    },
    /// A model without a fit for the scalar asked for.
    #[error("{}: no fit for scalar {scalar:?}; the model has fits for: {}", path.display(), available.join(", "))]
    NoFitForScalar {
        /// The model file.
        path: PathBuf,
        /// The scalar asked for.
        scalar: String,
        /// The scalars the model has fits for.
        available: Vec<String>,
    },
    /// No scalar named, and no model holding exactly one fit to take it from.
    #[error("{}", scalar_needed(path.as_deref(), available))]
    ScalarNeeded {
        /// The model file, if one was given.
        path: Option<PathBuf>,
        /// The scalars its fits are for.
        available: Vec<String>,
    },
    /// A report with no scalar named and no model to take its scalars from.
    #[error("{}: name a scalar column to report on; its columns are: {}", path.display(), columns.join(", "))]
    ReportScalarNeeded {
        /// The flight.
        path: PathBuf,
        /// Its columns, in file order.
        columns: Vec<String>,
    },
    /// A request without the column names it needs.
    #[error("no {what} column named")]
    NoColumnNamed {
        /// What the column would be (e.g. `scalar`).
        what: &'static str,
    },
    /// A request naming a column twice.
    #[error("{what} column {name:?} is named twice")]
    RepeatedColumn {
        /// What the columns are (e.g. `scalar`).
        what: &'static str,
        /// The column named twice.
        name: String,
    },
    /// The live page's address cannot be served (taken, or not this machine's).
    #[error("--live {address}: cannot serve the page there: {source}")]
    LiveBind {
        /// The address asked for.
        address: String,
        /// Why.
        source: std::io::Error,
    },
    /// A request whose settings contradict each other or are out of range.
    #[error("{0}")]
    Invalid(String),
    /// A chunk size of zero rows.
    #[error("rows per chunk must be positive")]
    NoChunkRows,
    /// The anonymous temporary file that keeps numbers between passes over a file failed.
    #[error("temporary file: {source}")]
    TemporaryFile {
        /// The operating system's error.
        source: std::io::Error,
    },
    /// A file read more than once did not hold the same number of rows each time.
    #[error("{}: the file changed while it was read ({expected} rows, then {rows})", path.display())]
    FileChanged {
        /// The file read.
        path: PathBuf,
        /// Rows met on the first pass (rows).
        expected: usize,
        /// Rows met on a later pass (rows).
        rows: usize,
    },
    /// A flight without the time column a workflow (`what`) needs.
    #[error("{}: {what} needs the time column {TIME_COLUMN:?} (s)", path.display())]
    NoTimeColumn {
        /// The flight file.
        path: PathBuf,
        /// The workflow that needs the time column.
        what: &'static str,
    },
    /// A time column without two increasing finite times.
    #[error("{}: column {TIME_COLUMN:?} has no time step", path.display())]
    NoTimeStep {
        /// The flight file.
        path: PathBuf,
    },
    /// A column without a single finite value.
    #[error("{}: column {column:?} has no finite value", path.display())]
    NoFiniteValue {
        /// The flight file.
        path: PathBuf,
        /// The column without a finite value.
        column: String,
    },
    /// A fluxgate with a missing value where a workflow needs every sample.
    #[error("{}: {place}: the fluxgate has a missing value; {what} needs a complete fluxgate record", path.display())]
    IncompleteFluxgate {
        /// The flight file.
        path: PathBuf,
        /// Where the missing value is: "line N" or "row N" (1-based).
        place: String,
        /// The workflow that needs every sample.
        what: &'static str,
    },
    /// No maneuver found in a flight's attitude.
    #[error("{}: no {kind} maneuvers found in {columns}", path.display())]
    NoManeuversFound {
        /// The flight file.
        path: PathBuf,
        /// The kind of maneuver looked for (e.g. `harmonic`).
        kind: &'static str,
        /// The attitude columns searched, listed.
        columns: String,
    },
    /// A maneuver to leave out that the flight does not have.
    #[error("{}: no maneuver {name:?} in the flight to leave out; found: {}", path.display(), found.join(", "))]
    NoSuchManeuver {
        /// The flight file.
        path: PathBuf,
        /// The maneuver's label as given.
        name: String,
        /// The labels of the maneuvers found (`roll on 045°`).
        found: Vec<String>,
    },
    /// The patent's procedure could not run.
    #[error("{}: {reason}", path.display())]
    Procedure {
        /// The flight file.
        path: PathBuf,
        /// Why the procedure could not run.
        reason: ProcedureError,
    },
    /// A maneuver list (`roll@0,wingup@90`) that is not a plan.
    #[error("maneuver list: {0}")]
    ManeuverList(ManeuverListError),
    /// A planned flight that could not be simulated or filtered.
    #[error(transparent)]
    Planning(#[from] PlanningError),
    /// A flight the band-pass cannot filter (its sample rate, or too few samples).
    #[error("{}: {reason}", path.display())]
    Filter {
        /// The flight file.
        path: PathBuf,
        /// Why the band-pass cannot filter it.
        reason: FilterError,
    },
    /// Writing an output stream failed.
    #[error("{what}: {source}")]
    Write {
        /// What was being written (e.g. "writing the compensated data").
        what: String,
        /// The operating system's error.
        source: std::io::Error,
    },
    /// A date that is not written `YYYY-MM-DD`.
    #[error("the date must be YYYY-MM-DD, got {text:?}")]
    DateFormat {
        /// The date as given.
        text: String,
    },
    /// A `YYYY-MM-DD` date that is not a day of the calendar.
    #[error("date {text}: {reason}")]
    Date {
        /// The date as given.
        text: String,
        /// Why it is not a calendar day.
        reason: IgrfError,
    },
    /// A heading setting of the FOM outside its range (degrees).
    #[error("{flag} ({python}= in Python) must be {range}, got {value}")]
    BadHeadingSetting {
        /// The command-line flag of the setting.
        flag: &'static str,
        /// The Python keyword of the setting.
        python: &'static str,
        /// The setting's allowed range, in words.
        range: &'static str,
        /// The value given (degrees).
        value: f64,
    },
    /// A numeric setting of `simulate` outside its range.
    #[error("{flag} ({python}= in Python) must lie within {low}..={high} {unit}, got {value}")]
    SimulateSetting {
        /// The command-line flag.
        flag: &'static str,
        /// The Python keyword.
        python: &'static str,
        /// The smallest value allowed, in `unit`.
        low: f64,
        /// The largest value allowed, in `unit`.
        high: f64,
        /// The setting's unit.
        unit: &'static str,
        /// The value given, in `unit`.
        value: f64,
    },
    /// A simulated flight longer than the sample limit.
    #[error("the flight would hold {samples:.3e} samples, more than {limit:.0e}: ask for fewer --lines or --cycles, a shorter --line-duration or --period, or a lower --fs")]
    SimulateTooLong {
        /// The samples the plan and rate ask for.
        samples: f64,
        /// The most a flight may hold.
        limit: f64,
    },
    /// A fit whose network `stream --adapt` cannot adapt (`fit --network`).
    #[error("{}: the fit of {scalar} holds a network, which --adapt cannot adapt; stream without --adapt, or fit without --network", path.display())]
    StreamNetwork {
        /// The model file.
        path: PathBuf,
        /// The scalar of the fit.
        scalar: String,
    },
    /// A fit a live stream cannot apply: it uses several fluxgates.
    #[error("{}: the fit of {scalar} uses {} fluxgates ({}); a stream handles one fluxgate per scalar", path.display(), vectors.len(), vectors.join(","))]
    StreamFluxgates {
        /// The model file.
        path: PathBuf,
        /// The scalar of the fit.
        scalar: String,
        /// Prefixes of the fluxgates the fit uses.
        vectors: Vec<String>,
    },
    /// A live stream's header that lacks a column the model needs, or cannot be read.
    #[error("{0}")]
    StreamHeader(String),
    /// A live stream's line longer than the limit; the stream is closed.
    #[error("a line over {limit} bytes; the stream is closed")]
    StreamLineTooLong {
        /// The longest line accepted (bytes).
        limit: usize,
    },
    /// A live stream's client sent nothing for the idle timeout; the connection is closed.
    #[error("no input for {} s; the connection is closed", timeout.as_secs_f64())]
    StreamIdle {
        /// The idle timeout (s).
        timeout: std::time::Duration,
    },
    /// Reading or writing a live stream failed (see [`Error::is_disconnect`]).
    #[error(transparent)]
    StreamIo(std::io::Error),
    /// A filter could not be designed for the data's sample rate.
    #[error(transparent)]
    FilterDesign(#[from] FilterError),
}

/// The result of a workflow.
pub type Result<T, E = Error> = std::result::Result<T, E>;

impl Error {
    /// True when the error is a reader that closed the output early (`… | head`), which a
    /// command line treats as success.
    pub fn is_broken_pipe(&self) -> bool {
        let io = match self {
            Error::Write { source, .. } => Some(source),
            Error::Io(IoError::Write { source, .. }) => Some(source),
            Error::StreamIo(source) => Some(source),
            _ => None,
        };
        io.is_some_and(|e| e.kind() == ErrorKind::BrokenPipe)
    }

    /// True when the other end of a live stream went away (broken pipe, reset or aborted
    /// connection): that ends the stream, not the server.
    pub fn is_disconnect(&self) -> bool {
        matches!(self, Error::StreamIo(e) if matches!(
            e.kind(),
            ErrorKind::BrokenPipe | ErrorKind::ConnectionReset | ErrorKind::ConnectionAborted
        ))
    }
}

/// The text of [`Error::ScalarNeeded`].
fn scalar_needed(model: Option<&std::path::Path>, available: &[String]) -> String {
    match model {
        None => "no scalar column named, and no model to take it from".to_string(),
        Some(path) => format!(
            "{}: the model holds fits for {} scalars ({}); name the one to use",
            path.display(),
            available.len(),
            available.join(", ")
        ),
    }
}
