//! What a compensation report of a flight shows, computed: the scalar before and after
//! compensation (mean removed and band-passed), its error against a simulator's truth, spectra,
//! the figure of merit maneuver by maneuver, and the heading error heading by heading. The
//! `tolles-report` crate lays it out as HTML.

use crate::error::{Error, Result};
use crate::fom::{fit_for, fom, scalar_to_use, straight_levels, FomOutcome, FomRequest};
use crate::lines::{line_table, track, LineInputs, LineKind, LineTable, Track};
use crate::model::{ModelFile, ScalarModel};
use crate::progress::Progress;
use crate::warning::Warning;
use std::path::PathBuf;
use tolles_core::fit::Band;
use tolles_core::maneuvers::detect::Maneuver;
use tolles_core::maneuvers::fom::{bandpassed, FomSettings};
use tolles_core::maneuvers::heading::{HeadingLevels, HeadingSettings};
use tolles_core::maneuvers::ManeuverKind;
use tolles_core::signal::metrics::fourth_difference;
use tolles_core::signal::metrics::std_dev;
use tolles_core::signal::spectrum::{welch, Spectrum};
use tolles_io::schema::{PITCH, ROLL, YAW};
use tolles_io::select::RowSelection;
use tolles_io::table::Table;

/// The column of a simulated flight that holds the true earth field (nT).
pub const TRUTH_COLUMN: &str = "truth_earth";

/// What to report on.
#[derive(Debug, Clone, PartialEq)]
pub struct ReportRequest {
    /// The flight, in any format [`crate::read`] reads, with attitude and the scalar.
    pub flight: PathBuf,
    /// The uncompensated scalar column (nT); `None` takes the scalar of the model's only fit.
    pub scalar: Option<String>,
    /// A model file with a fit for the scalar; without one, only the uncompensated flight.
    pub model: Option<PathBuf>,
    /// Band-pass (Hz) of the figure of merit and the band-passed plots; default 0.05–1 Hz.
    pub band: Band,
    /// Butterworth order per band edge; default 4.
    pub order: usize,
    /// Sample rate (Hz) when the flight has no time column (or to override it).
    pub fs_hz: Option<f64>,
    /// Rows to report on (all when empty).
    pub selection: RowSelection,
    /// Columns renamed `(old, new)` right after reading (see [`crate::read::rename`]).
    pub renames: Vec<(String, String)>,
    /// The straight legs of the heading error, as [`FomRequest::headings`].
    pub headings: HeadingSettings,
    /// How near a cardinal heading a maneuver counts as its (degrees), as
    /// [`FomRequest::cardinal_tolerance_deg`].
    pub cardinal_tolerance_deg: f64,
    /// The survey specification's fourth-difference tolerance (nT): each line passes when
    /// every fourth difference of its (compensated) scalar lies within ±this; default
    /// [`NOISE_TOLERANCE_NT`].
    pub noise_tolerance_nt: f64,
    /// The survey specification's largest figure of merit (nT) of a calibration box: the
    /// compensated FOM passes at or below it; default [`FOM_SPEC_NT`].
    pub fom_spec_nt: f64,
    /// The survey specification's largest heading error (nT) after compensation, judged
    /// against the truth or the reference (legs over different ground cannot judge it);
    /// default [`HEADING_ERROR_SPEC_NT`].
    pub heading_error_spec_nt: f64,
    /// The printed page of `report --pdf`; default A4.
    pub paper: Paper,
    /// A column to judge the compensated scalar against instead of the simulator's truth
    /// (`truth_earth`): a reference magnetometer, or a compensation made elsewhere such as
    /// SGL's `mag_1_c` (nT).
    pub reference: Option<String>,
}

/// The default fourth-difference tolerance (nT), ±0.1 nT: a common total-field survey
/// specification for the normalised fourth difference (x₋₂ − 4x₋₁ + 6x₀ − 4x₊₁ + x₊₂)/16.
pub const NOISE_TOLERANCE_NT: f64 = 0.1;

/// The default largest figure of merit (nT) of a compensated calibration box, 1.5 nT: a common
/// fixed-wing survey specification (the sum of the 12 maneuvers' peak-to-peak, 0.05–1 Hz).
pub const FOM_SPEC_NT: f64 = 1.5;

/// The default largest heading error (nT) after compensation, 1 nT: a common survey
/// specification (the spread of the levels of the four headings).
pub const HEADING_ERROR_SPEC_NT: f64 = 1.0;

/// The printed page's size.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Paper {
    /// ISO A4, 210 × 297 mm, as survey contracts outside North America are written.
    #[default]
    A4,
    /// US Letter, 8.5 × 11 in.
    Letter,
}

impl std::str::FromStr for Paper {
    type Err = String;

    fn from_str(text: &str) -> std::result::Result<Self, Self::Err> {
        match text.to_ascii_lowercase().as_str() {
            "a4" => Ok(Paper::A4),
            "letter" => Ok(Paper::Letter),
            _ => Err(format!("expected a4 or letter, got {text:?}")),
        }
    }
}

impl ReportRequest {
    /// A report on `scalar` of `flight` without a model, in the FOM's default band.
    pub fn new(flight: impl Into<PathBuf>, scalar: &str) -> Self {
        let fom = FomRequest::new(scalar);
        Self {
            flight: flight.into(),
            scalar: Some(scalar.to_string()),
            model: None,
            band: fom.band,
            order: fom.order,
            fs_hz: None,
            selection: RowSelection::default(),
            renames: Vec::new(),
            headings: fom.headings,
            cardinal_tolerance_deg: fom.cardinal_tolerance_deg,
            noise_tolerance_nt: NOISE_TOLERANCE_NT,
            fom_spec_nt: FOM_SPEC_NT,
            heading_error_spec_nt: HEADING_ERROR_SPEC_NT,
            paper: Paper::A4,
            reference: None,
        }
    }

    /// The request with the heading error's legs and the box's headings as
    /// [`FomRequest::with_legs`] sets them (degrees).
    pub fn with_legs(
        self,
        headings_deg: Option<Vec<f64>>,
        heading_tolerance_deg: f64,
        level_tolerance_deg: f64,
        cardinal_tolerance_deg: f64,
    ) -> Self {
        let legs = FomRequest::new("").with_legs(
            headings_deg,
            heading_tolerance_deg,
            level_tolerance_deg,
            cardinal_tolerance_deg,
        );
        Self {
            headings: legs.headings,
            cardinal_tolerance_deg: legs.cardinal_tolerance_deg,
            ..self
        }
    }
}

/// Everything a report shows.
#[derive(Debug, Clone)]
pub struct ReportData {
    /// The request it answers.
    pub request: ReportRequest,
    /// The flight's FOM before and, with a model, after; also its time (s), sample rate (Hz)
    /// and scalar (nT).
    pub fom: FomOutcome,
    /// The scalar's fit, with a model.
    pub fit: Option<ScalarModel>,
    /// The scalar before compensation.
    pub uncompensated: Trace,
    /// The scalar after compensation, with a model.
    pub compensated: Option<Trace>,
    /// The true earth field minus its mean (nT), when the flight has a truth column, or the
    /// reference column's ([`ReportRequest::reference`]).
    pub truth: Option<Vec<f64>>,
    /// Compensated minus truth, with a model and a truth column.
    pub error: Option<TruthError>,
    /// Power spectral density of the scalar before compensation (nT²/Hz); `None` when the
    /// flight is too short for one (a warning says so).
    pub spectrum_before: Option<Spectrum>,
    /// The same after compensation, with a model.
    pub spectrum_after: Option<Spectrum>,
    /// The counted box maneuvers, in the order found.
    pub maneuvers: Vec<ManeuverRow>,
    /// The headings whose straight legs give a level before compensation, in the settings'
    /// order (N, E, S, W); the heading errors themselves are in [`FomOutcome::heading_before`]
    /// and [`FomOutcome::heading_after`].
    pub headings: Vec<HeadingRow>,
    /// Statistics line by line, when the flight has a line column with several lines.
    pub lines: Option<LineTable>,
    /// Where the aircraft was, when the flight has positions.
    pub track: Option<Track>,
    /// Heading levels of the compensated scalar minus the truth, over the straight legs the
    /// heading error uses, when the flight has a truth column, attitude and a model: the
    /// compensation's own heading error, without the geology and diurnal variation between
    /// the legs.
    pub heading_vs_truth: Option<HeadingLevels>,
    /// The aircraft's attitude row by row, as far as the flight records it.
    pub attitude: Attitude,
    /// The linear model's and the network's parts of the correction, when the model has a
    /// network.
    pub network: Option<NetworkShare>,
}

/// How much of a correction a model's network makes, on the flight reported.
#[derive(Debug, Clone, PartialEq)]
pub struct NetworkShare {
    /// The linear model's correction minus its mean (nT).
    pub linear_nt: Vec<f64>,
    /// The network's correction minus its mean (nT).
    pub network_nt: Vec<f64>,
    /// Standard deviation of the linear correction (nT).
    pub linear_std_nt: f64,
    /// Standard deviation of the network's correction (nT).
    pub network_std_nt: f64,
}

/// The attitude of the rows reported (deg), each angle `None` when the flight lacks its
/// column (named in [`tolles_io::schema`]).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Attitude {
    /// Roll, right wing down positive (deg).
    pub roll_deg: Option<Vec<f64>>,
    /// Pitch, nose up positive (deg).
    pub pitch_deg: Option<Vec<f64>>,
    /// Yaw, the heading clockwise from north (deg).
    pub yaw_deg: Option<Vec<f64>>,
}

impl Attitude {
    /// The angles of `table` that it has.
    fn of(table: &Table) -> Self {
        let angle = |name| table.numeric(name).ok();
        Attitude {
            roll_deg: angle(ROLL),
            pitch_deg: angle(PITCH),
            yaw_deg: angle(YAW),
        }
    }

    /// Roll, pitch and yaw, when the flight has all three.
    pub fn all(&self) -> Option<[&[f64]; 3]> {
        Some([
            self.roll_deg.as_deref()?,
            self.pitch_deg.as_deref()?,
            self.yaw_deg.as_deref()?,
        ])
    }

    /// The angle a maneuver of `kind` swings (deg), if the flight has it.
    pub fn angle(&self, kind: ManeuverKind) -> Option<&[f64]> {
        match kind {
            ManeuverKind::Roll => self.roll_deg.as_deref(),
            ManeuverKind::Pitch => self.pitch_deg.as_deref(),
            ManeuverKind::Yaw => self.yaw_deg.as_deref(),
        }
    }
}

/// The scalar's level on one heading's straight legs, before and after compensation.
#[derive(Debug, Clone, PartialEq)]
pub struct HeadingRow {
    /// Nominal heading (deg).
    pub heading_deg: f64,
    /// Straight-and-level samples used (the same before and after).
    pub samples: usize,
    /// Time of the first and last sample used (s).
    pub span_tt: (f64, f64),
    /// Mean uncompensated scalar and its standard error (nT).
    pub before_nt: (f64, f64),
    /// The same compensated (nT), with a model.
    pub after_nt: Option<(f64, f64)>,
}

/// One signal, as plotted.
#[derive(Debug, Clone, PartialEq)]
pub struct Trace {
    /// Minus its mean over the finite samples (nT).
    pub centred: Vec<f64>,
    /// Band-passed in the request's band (nT); NaN where it cannot be.
    pub bandpassed: Vec<f64>,
    /// Its normalised fourth difference (x₋₂ − 4x₋₁ + 6x₀ − 4x₊₁ + x₊₂)/16 (nT); NaN on the
    /// first and last two rows.
    pub fourth_difference: Vec<f64>,
}

/// The compensated scalar's error against a simulator's truth.
#[derive(Debug, Clone, PartialEq)]
pub struct TruthError {
    /// Compensated − truth, minus its mean (nT).
    pub centred: Vec<f64>,
    /// Its standard deviation (nT).
    pub std_nt: f64,
}

/// A counted maneuver of the box and its peak-to-peak before and after compensation.
#[derive(Debug, Clone, PartialEq)]
pub struct ManeuverRow {
    /// The maneuver.
    pub maneuver: Maneuver,
    /// Peak-to-peak of the band-passed uncompensated scalar (nT).
    pub before_nt: f64,
    /// The same compensated (nT), with a model (and the maneuver found in its FOM, as it is).
    pub after_nt: Option<f64>,
}

/// Reads the flight (and the model) of `request` and computes what its report shows; the
/// request kept in it names the scalar used. What was noticed (rows that cannot be compensated,
/// maneuvers with gaps, the rows selected) is added to `warnings`.
pub fn build(
    request: &ReportRequest,
    progress: &dyn Progress,
    warnings: &mut Vec<Warning>,
) -> Result<ReportData> {
    check_tolerance(request)?;
    let model = read_model(request)?;
    let model = model.as_ref().map(|(m, path)| (m, *path));
    let scalar = scalar_to_use(request.scalar.as_deref(), model)?;
    let fit = fit_of(model, &scalar)?;
    let table = read_flight(request, progress, warnings)?;
    build_scalar(&table, request, &scalar, fit, warnings)
}

/// [`build`] for each of `scalars` of one flight, read once: with no scalars, the request's
/// scalar, else every fit of its model, else an error listing the flight's columns. With
/// several scalars, each scalar's warnings name it ([`Warning::ForScalar`]).
pub fn build_each(
    request: &ReportRequest,
    scalars: &[String],
    progress: &dyn Progress,
    warnings: &mut Vec<Warning>,
) -> Result<Vec<ReportData>> {
    check_tolerance(request)?;
    let model = read_model(request)?;
    let model = model.as_ref().map(|(m, path)| (m, *path));
    let mut scalars = scalars.to_vec();
    if scalars.is_empty() {
        scalars = match (&request.scalar, model) {
            (Some(scalar), _) => vec![scalar.clone()],
            (None, Some((model, path))) => {
                crate::compensate::check_model(model, path)?;
                model.fits.iter().map(|f| f.scalar.clone()).collect()
            }
            (None, None) => Vec::new(),
        };
    }
    let fits = scalars
        .iter()
        .map(|scalar| fit_of(model, scalar))
        .collect::<Result<Vec<_>>>()?;
    let table = read_flight(request, progress, warnings)?;
    if scalars.is_empty() {
        return Err(Error::ReportScalarNeeded {
            path: request.flight.clone(),
            columns: table.headers().to_vec(),
        });
    }
    let several = scalars.len() > 1;
    let mut all = Vec::new();
    for (scalar, fit) in scalars.iter().zip(fits) {
        let mut noticed = Vec::new();
        all.push(build_scalar(&table, request, scalar, fit, &mut noticed)?);
        warnings.extend(noticed.into_iter().map(|warning| match several {
            true => Warning::ForScalar {
                scalar: scalar.clone(),
                warning: Box::new(warning),
            },
            false => warning,
        }));
    }
    Ok(all)
}

/// A specification figure that is not a positive number of nT is refused, naming its flag.
fn check_tolerance(request: &ReportRequest) -> Result<()> {
    let figures = [
        (
            request.noise_tolerance_nt,
            "fourth-difference tolerance (--noise-tolerance; noise_tolerance= in Python)",
        ),
        (
            request.fom_spec_nt,
            "FOM specification (--fom-spec; fom_spec= in Python)",
        ),
        (
            request.heading_error_spec_nt,
            "heading-error specification (--heading-error-spec; heading_error_spec= in Python)",
        ),
    ];
    match figures.iter().find(|(v, _)| !(v.is_finite() && *v > 0.0)) {
        None => Ok(()),
        Some((value, what)) => Err(Error::Invalid(format!(
            "the {what} must be a positive number of nT, not {value}"
        ))),
    }
}

/// The model file of `request`, read, with its path.
fn read_model(request: &ReportRequest) -> Result<Option<(ModelFile, &std::path::Path)>> {
    request
        .model
        .as_deref()
        .map(|path| Ok((ModelFile::read(path)?, path)))
        .transpose()
}

fn fit_of(
    model: Option<(&ModelFile, &std::path::Path)>,
    scalar: &str,
) -> Result<Option<ScalarModel>> {
    model
        .map(|(model, path)| fit_for(model, path, scalar).cloned())
        .transpose()
}

/// The flight's selected rows, renamed, with time run on where it steps back.
fn read_flight(
    request: &ReportRequest,
    progress: &dyn Progress,
    warnings: &mut Vec<Warning>,
) -> Result<Table> {
    let mut read = crate::read::read_renamed(
        &request.flight,
        &request.selection,
        &request.renames,
        progress,
        warnings,
    )?;
    warnings.extend(crate::read::run_time_on(&mut read.table)?);
    Ok(read.table)
}

/// What the report of `scalar` of the flight `table` shows, with its `fit` if any.
fn build_scalar(
    table: &Table,
    request: &ReportRequest,
    scalar: &str,
    fit: Option<ScalarModel>,
    warnings: &mut Vec<Warning>,
) -> Result<ReportData> {
    let request = &ReportRequest {
        scalar: Some(scalar.to_string()),
        ..request.clone()
    };
    let truth = match &request.reference {
        Some(column) => Some(table.numeric(column)?),
        None => table.numeric(TRUTH_COLUMN).ok(),
    };
    let fom_request = FomRequest {
        band: request.band,
        order: request.order,
        fs_hz: request.fs_hz,
        headings: request.headings.clone(),
        cardinal_tolerance_deg: request.cardinal_tolerance_deg,
        ..FomRequest::new(scalar)
    };
    let outcome = fom(table, &fom_request, fit.as_ref(), warnings)?;
    let trace_of = |x: &[f64]| trace(x, &outcome, request);
    let lines = line_table(
        table,
        &LineInputs {
            tt: &outcome.tt,
            before: &outcome.scalar,
            after: outcome.compensated.as_deref(),
            truth: truth.as_deref(),
        },
    )
    .map(|lines| with_box_legs(lines, &outcome.maneuvers));
    if lines.is_some() {
        // A survey has no box by design; its page says so where a FOM would be.
        warnings.retain(|w| !matches!(w, Warning::NoManeuvers { .. }));
    }
    let heading_vs_truth = match (&outcome.compensated, &truth, Attitude::of(table).all()) {
        (Some(c), Some(t), Some(attitude)) => {
            let error: Vec<f64> = c.iter().zip(t).map(|(c, t)| c - t).collect();
            let signals = [outcome.scalar.as_slice(), c.as_slice(), error.as_slice()];
            let path = table.path();
            let maneuvers = &outcome.maneuvers;
            let settings = &request.headings;
            let levels =
                straight_levels(path, &outcome.tt, attitude, maneuvers, &signals, settings);
            // Without straight legs there is nothing to level; the FOM says why.
            levels.ok().and_then(|mut l| l.pop())
        }
        _ => None,
    };
    let network = match &fit {
        Some(fit) => network_share(table, fit, request.fs_hz)?,
        None => None,
    };
    Ok(ReportData {
        network,
        lines,
        heading_vs_truth,
        track: track(table),
        attitude: Attitude::of(table),
        uncompensated: trace_of(&outcome.scalar)?,
        compensated: outcome.compensated.as_deref().map(trace_of).transpose()?,
        error: outcome
            .compensated
            .as_deref()
            .zip(truth.as_deref())
            .map(|(c, truth)| truth_error(c, truth)),
        truth: truth.as_deref().map(centred),
        spectrum_before: spectrum(
            table,
            &outcome.scalar,
            outcome.fs_hz,
            "uncompensated",
            warnings,
        ),
        spectrum_after: outcome
            .compensated
            .as_deref()
            .and_then(|c| spectrum(table, c, outcome.fs_hz, "compensated", warnings)),
        maneuvers: maneuver_rows(&outcome),
        headings: heading_rows(&outcome),
        request: request.clone(),
        fit,
        fom: outcome,
    })
}

fn trace(x: &[f64], outcome: &FomOutcome, request: &ReportRequest) -> Result<Trace> {
    let settings = FomSettings {
        band: request.band,
        order: request.order,
    };
    let bandpassed =
        bandpassed(x, Some(&outcome.tt), outcome.fs_hz, &settings).map_err(|cause| Error::Fom {
            path: request.flight.clone(),
            cause,
        })?;
    Ok(Trace {
        centred: centred(x),
        bandpassed,
        fourth_difference: fourth_difference(x),
    })
}

/// `x` minus the mean of its finite values (nT).
fn centred(x: &[f64]) -> Vec<f64> {
    let finite: Vec<f64> = x.iter().copied().filter(|v| v.is_finite()).collect();
    let mean = finite.iter().sum::<f64>() / finite.len().max(1) as f64;
    x.iter().map(|v| v - mean).collect()
}

/// The network's share of `fit`'s correction of `table`, when `fit` has a network.
fn network_share(
    table: &Table,
    fit: &ScalarModel,
    fs_hz: Option<f64>,
) -> Result<Option<NetworkShare>> {
    if fit.network.is_none() {
        return Ok(None);
    }
    let flight = crate::read::Flight::from_table(table, &fit.scalar, &fit.vectors)?
        .with_extras(&fit.fit.settings.design.extras)?;
    let request = crate::compensate::CompensateRequest {
        fs_hz,
        ..Default::default()
    };
    // The warnings were given when the compensated scalar was computed.
    let parts = crate::compensate::correction_parts(&flight, fit, &request, &mut Vec::new())?;
    Ok(parts.map(|parts| NetworkShare {
        linear_std_nt: std_dev(&parts.linear_nt),
        network_std_nt: std_dev(&parts.network_nt),
        linear_nt: centred(&parts.linear_nt),
        network_nt: centred(&parts.network_nt),
    }))
}

fn truth_error(compensated: &[f64], truth: &[f64]) -> TruthError {
    let error: Vec<f64> = compensated.iter().zip(truth).map(|(a, b)| a - b).collect();
    let centred = centred(&error);
    TruthError {
        std_nt: std_dev(&centred),
        centred,
    }
}

/// The spectrum of `x` at `fs_hz` (Hz), or a warning why there is none.
fn spectrum(
    table: &Table,
    x: &[f64],
    fs_hz: f64,
    signal: &'static str,
    warnings: &mut Vec<Warning>,
) -> Option<Spectrum> {
    welch(x, fs_hz)
        .map_err(|reason| {
            warnings.push(Warning::NoSpectrum {
                path: table.path().to_path_buf(),
                signal,
                reason: reason.to_string(),
            })
        })
        .ok()
}

/// `lines` with each line of the box marked a box leg: one that holds a maneuver, or that lies
/// wholly within [`BOX_MARGIN_S`] of the box's first and last maneuver (a lead-in, a turn
/// between legs).
fn with_box_legs(mut lines: LineTable, maneuvers: &[Maneuver]) -> LineTable {
    let (Some(first), Some(last)) = (
        maneuvers.iter().map(|m| m.start_tt).min_by(f64::total_cmp),
        maneuvers.iter().map(|m| m.end_tt).max_by(f64::total_cmp),
    ) else {
        return lines;
    };
    let (from, to) = (first - BOX_MARGIN_S, last + BOX_MARGIN_S);
    let stretches = &lines.stretches;
    for row in &mut lines.rows {
        let stretches = || stretches.iter().filter(|(id, ..)| *id == row.line);
        let holds = |m: &Maneuver| stretches().any(|(_, a, b)| m.start_tt <= *b && m.end_tt >= *a);
        let inside = stretches().all(|(_, a, b)| *a >= from && *b <= to);
        if maneuvers.iter().any(holds) || inside {
            row.kind = LineKind::BoxLeg;
        }
    }
    lines
}

/// How far before the box's first maneuver and after its last a line still belongs to the
/// box (s): a lead-in or the turn onto the next heading.
const BOX_MARGIN_S: f64 = 60.0;

/// The counted maneuvers, each with its compensated peak-to-peak found by its start.
fn maneuver_rows(outcome: &FomOutcome) -> Vec<ManeuverRow> {
    let after_of = |m: &Maneuver| {
        let after = outcome.after.as_ref()?;
        let same = after
            .maneuvers
            .iter()
            .find(|a| a.maneuver.start == m.start)?;
        Some(same.peak_to_peak_nt)
    };
    outcome
        .before
        .counted()
        .map(|m| ManeuverRow {
            maneuver: m.maneuver.clone(),
            before_nt: m.peak_to_peak_nt,
            after_nt: after_of(&m.maneuver),
        })
        .collect()
}

/// A row per heading with a level before compensation, its compensated level matched by heading.
fn heading_rows(outcome: &FomOutcome) -> Vec<HeadingRow> {
    let after_of = |heading_deg: f64| {
        let after = outcome.heading_after.as_ref()?;
        let same = after.levels.iter().find(|l| l.heading_deg == heading_deg)?;
        Some((same.level_nt, same.std_error_nt))
    };
    outcome
        .heading_before
        .levels
        .iter()
        .map(|l| HeadingRow {
            heading_deg: l.heading_deg,
            samples: l.samples,
            span_tt: (l.start_tt, l.end_tt),
            before_nt: (l.level_nt, l.std_error_nt),
            after_nt: after_of(l.heading_deg),
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_report_takes_the_legs_a_fom_would() {
        let request =
            ReportRequest::new("f.csv", "mag_1_uc").with_legs(Some(vec![45.0]), 5.0, 1.0, 30.0);
        let fom = FomRequest::new("mag_1_uc").with_legs(Some(vec![45.0]), 5.0, 1.0, 30.0);
        assert_eq!(request.headings, fom.headings);
        assert_eq!(request.cardinal_tolerance_deg, 30.0);
        assert_eq!(request.headings.max_pitch_deg, 1.0);
    }
    use crate::progress::Silent;
    use crate::simulate::{simulate, write, PlanKind, SimulateRequest};

    #[test]
    fn a_report_of_a_simulated_box_before_and_after() {
        let dir = tempfile::tempdir().unwrap();
        let flight = dir.path().join("box.csv");
        write(
            &simulate(&SimulateRequest::default(), &Silent).unwrap(),
            &flight,
        )
        .unwrap();
        let mut warnings = Vec::new();
        let before = build(
            &ReportRequest::new(&flight, "mag_1_uc"),
            &Silent,
            &mut warnings,
        )
        .unwrap();
        assert!(before.compensated.is_none() && before.error.is_none());
        assert_eq!(before.maneuvers.len(), 12);
        assert!(before.maneuvers.iter().all(|m| m.after_nt.is_none()));
        assert_eq!(before.headings.len(), 4);
        assert!(before.headings.iter().all(|h| h.after_nt.is_none()));
        assert_eq!(before.truth.as_ref().unwrap().len(), before.fom.tt.len());
        for kind in ManeuverKind::ALL {
            let angle = before.attitude.angle(kind).unwrap();
            assert_eq!(angle.len(), before.fom.tt.len());
        }
        // The box's roll maneuvers swing the roll column by ±10°.
        let roll = &before.maneuvers[0].maneuver;
        assert_eq!(roll.kind, ManeuverKind::Roll);
        let swing = &before.attitude.roll_deg.as_ref().unwrap()[roll.start..roll.end];
        assert!(swing.iter().any(|r| *r > 8.0) && swing.iter().any(|r| *r < -8.0));

        let data = crate::read::read(&flight, &Default::default(), &Silent, &mut warnings).unwrap();
        let fit_request =
            crate::fit::FitRequest::new(vec!["mag_1_uc".into()], vec!["flux_a".into()]);
        let model = crate::fit::fit(&data.table, &fit_request, &Silent, &mut warnings).unwrap();
        let model_path = dir.path().join("m.json");
        crate::model::save_model(&model, &model_path).unwrap();
        let request = ReportRequest {
            model: Some(model_path),
            ..ReportRequest::new(&flight, "mag_1_uc")
        };
        let after = build(&request, &Silent, &mut warnings).unwrap();
        assert!(warnings.is_empty(), "{warnings:?}");
        let error = after.error.as_ref().unwrap();
        assert!(error.std_nt < 0.1, "{}", error.std_nt);
        let mean = after.uncompensated.centred.iter().sum::<f64>();
        assert!(mean.abs() < 1e-6 * after.fom.tt.len() as f64);
        let spectrum = after.spectrum_after.as_ref().unwrap();
        assert_eq!(
            spectrum.frequency_hz.len(),
            after.spectrum_before.as_ref().unwrap().frequency_hz.len()
        );
        for m in &after.maneuvers {
            assert!(m.after_nt.unwrap() < m.before_nt / 10.0, "{m:?}");
        }
        let headings: Vec<f64> = after.headings.iter().map(|h| h.heading_deg).collect();
        assert_eq!(headings, [0.0, 90.0, 180.0, 270.0]);
        assert!(after.headings.iter().all(|h| h.after_nt.is_some()));
    }

    /// A box, then (after its last row) survey lines 1001… with turns 2, 4… renumbered +100, as
    /// one CSV file.
    fn box_then_lines(dir: &std::path::Path) -> PathBuf {
        let csv = |plan| {
            let path = dir.join(format!("{}.csv", plan as u8));
            let request = SimulateRequest {
                plan,
                lines: 3,
                ..SimulateRequest::default()
            };
            write(&simulate(&request, &Silent).unwrap(), &path).unwrap();
            std::fs::read_to_string(path).unwrap()
        };
        let (plan_box, survey) = (csv(PlanKind::Box), csv(PlanKind::Survey));
        let header = survey.lines().next().unwrap();
        let column = |name| header.split(',').position(|h| h == name).unwrap();
        let (tt, line) = (column("tt"), column("line"));
        let last_tt: f64 = plan_box
            .lines()
            .last()
            .unwrap()
            .split(',')
            .nth(tt)
            .unwrap()
            .parse()
            .unwrap();
        let mut out = plan_box.clone();
        for row in survey.lines().skip(1) {
            let cells: Vec<String> = (row.split(',').enumerate())
                .map(|(k, c)| match k {
                    k if k == tt => (c.parse::<f64>().unwrap() + last_tt + 0.1).to_string(),
                    k if k == line => (c.parse::<f64>().unwrap() + 100.0).to_string(),
                    _ => c.to_string(),
                })
                .collect();
            out += &(cells.join(",") + "\n");
        }
        let path = dir.join("box-and-lines.csv");
        std::fs::write(&path, out).unwrap();
        path
    }

    #[test]
    fn a_box_then_lines_lists_every_line_and_names_the_rest() {
        let dir = tempfile::tempdir().unwrap();
        let flight = box_then_lines(dir.path());
        let data = build(
            &ReportRequest::new(&flight, "mag_1_uc"),
            &Silent,
            &mut Vec::new(),
        )
        .unwrap();
        assert_eq!(data.maneuvers.len(), 12);
        let of = |kind| -> Vec<String> {
            let lines = data.lines.as_ref().unwrap();
            (lines.rows.iter())
                .filter(|r| r.kind == kind)
                .map(|r| r.line.clone())
                .collect()
        };
        assert_eq!(of(LineKind::Line), ["1101", "1102", "1103"]);
        assert_eq!(of(LineKind::Turn), ["102", "104"]);
        // Every line of the box, its lead-ins and its turns too, is a leg of it.
        assert_eq!(of(LineKind::BoxLeg).len(), 31, "{:?}", of(LineKind::BoxLeg));
        let line = &data
            .lines
            .as_ref()
            .unwrap()
            .rows
            .iter()
            .find(|r| r.line == "1101")
            .unwrap();
        let (start, end) = line.span_s.unwrap();
        assert!(end - start > 60.0, "{start} {end}");
        assert!(line.correction_nt.is_none() && line.error_nt.is_none());

        // With a model (fitted on the box), each line has its correction and its error.
        let mut warnings = Vec::new();
        let read = crate::read::read(&flight, &Default::default(), &Silent, &mut warnings);
        let fit_request =
            crate::fit::FitRequest::new(vec!["mag_1_uc".into()], vec!["flux_a".into()]);
        let model = crate::fit::fit(&read.unwrap().table, &fit_request, &Silent, &mut warnings);
        let model_path = dir.path().join("m.json");
        crate::model::save_model(&model.unwrap(), &model_path).unwrap();
        let request = ReportRequest {
            model: Some(model_path),
            ..ReportRequest::new(&flight, "mag_1_uc")
        };
        let data = build(&request, &Silent, &mut warnings).unwrap();
        for row in (data.lines.as_ref().unwrap().rows.iter()).filter(|r| r.kind == LineKind::Line) {
            let (correction, error) = (row.correction_nt.unwrap(), row.error_nt.unwrap());
            println!(
                "line {}: correction {correction:.3} nT, error {error:.4} nT",
                row.line
            );
            assert!(correction > 1.0 && error < 0.1 * correction, "{row:?}");
        }
    }

    /// A simulated box with a second scalar `mag_2_uc`: `mag_1_uc` plus a 0.5 nT wobble.
    fn box_with_two_scalars(dir: &std::path::Path) -> PathBuf {
        let one = dir.join("one.csv");
        write(
            &simulate(&SimulateRequest::default(), &Silent).unwrap(),
            &one,
        )
        .unwrap();
        let text = std::fs::read_to_string(&one).unwrap();
        let mut lines = text.lines();
        let header = lines.next().unwrap();
        let column = header.split(',').position(|h| h == "mag_1_uc").unwrap();
        let mut out = format!("{header},mag_2_uc\n");
        for (row, line) in lines.enumerate() {
            let value: f64 = line.split(',').nth(column).unwrap().parse().unwrap();
            out += &format!("{line},{}\n", value + 0.5 * (row as f64 * 0.7).sin());
        }
        let two = dir.join("two.csv");
        std::fs::write(&two, out).unwrap();
        two
    }

    #[test]
    fn two_scalars_are_built_from_one_read_each_as_on_its_own() {
        let dir = tempfile::tempdir().unwrap();
        let flight = box_with_two_scalars(dir.path());
        let scalars = vec!["mag_1_uc".to_string(), "mag_2_uc".to_string()];
        let mut warnings = Vec::new();
        let data = crate::read::read(&flight, &Default::default(), &Silent, &mut warnings).unwrap();
        let fit_request = crate::fit::FitRequest::new(scalars.clone(), vec!["flux_a".into()]);
        let model = crate::fit::fit(&data.table, &fit_request, &Silent, &mut warnings).unwrap();
        let model_path = dir.path().join("m.json");
        crate::model::save_model(&model, &model_path).unwrap();
        let request = ReportRequest {
            model: Some(model_path),
            selection: RowSelection {
                time: Some("..100000".parse().unwrap()),
                ..Default::default()
            },
            scalar: None,
            ..ReportRequest::new(&flight, "")
        };

        let mut warnings = Vec::new();
        let both = build_each(&request, &[], &Silent, &mut warnings).unwrap();
        // One read: the rows selected are said once, not per scalar.
        let selected = warnings
            .iter()
            .filter(|w| matches!(w, Warning::RowsSelected { .. }))
            .count();
        assert_eq!(selected, 1, "{warnings:?}");
        let names: Vec<_> = both
            .iter()
            .map(|d| d.request.scalar.clone().unwrap())
            .collect();
        assert_eq!(names, scalars);
        for (data, scalar) in both.iter().zip(&scalars) {
            let alone = build(
                &ReportRequest {
                    scalar: Some(scalar.clone()),
                    ..request.clone()
                },
                &Silent,
                &mut Vec::new(),
            )
            .unwrap();
            assert_eq!(data.fit.as_ref().unwrap().scalar, *scalar);
            assert_eq!(data.fom.scalar, alone.fom.scalar);
            assert_eq!(
                data.fom.after.as_ref().unwrap().fom_nt,
                alone.fom.after.unwrap().fom_nt
            );
            assert_eq!(data.error, alone.error);
        }
        // The wobble is left in mag_2_uc by compensation, so its error against truth is larger.
        let error = |d: &ReportData| d.error.as_ref().unwrap().std_nt;
        assert!(
            error(&both[1]) > 10.0 * error(&both[0]),
            "{} {}",
            error(&both[1]),
            error(&both[0])
        );
    }

    #[test]
    fn warnings_of_several_scalars_name_their_scalar() {
        let dir = tempfile::tempdir().unwrap();
        let flight = box_with_two_scalars(dir.path());
        let scalars = ["mag_1_uc".to_string(), "mag_2_uc".to_string()];
        let mut warnings = Vec::new();
        let request = ReportRequest {
            fs_hz: Some(5.0),
            ..ReportRequest::new(&flight, "")
        };
        build_each(&request, &scalars, &Silent, &mut warnings).unwrap();
        let texts: Vec<String> = warnings.iter().map(|w| w.to_string()).collect();
        for scalar in &scalars {
            let prefix = format!("scalar {scalar}: ");
            assert!(texts.iter().any(|t| t.starts_with(&prefix)), "{texts:?}");
        }
    }

    #[test]
    fn no_scalar_and_no_model_is_an_error_listing_the_columns() {
        let dir = tempfile::tempdir().unwrap();
        let flight = box_with_two_scalars(dir.path());
        let request = ReportRequest {
            scalar: None,
            ..ReportRequest::new(&flight, "")
        };
        let e = build_each(&request, &[], &Silent, &mut Vec::new()).unwrap_err();
        let message = e.to_string();
        assert!(message.contains("mag_1_uc, flux_a_x"), "{message}");
        assert!(message.ends_with("mag_2_uc"), "{message}");
    }

    #[test]
    fn a_model_without_the_scalar_is_an_error_naming_it() {
        let dir = tempfile::tempdir().unwrap();
        let model = dir.path().join("m.json");
        crate::model::save_model(&ModelFile::new(Vec::new()), &model).unwrap();
        let request = ReportRequest {
            model: Some(model),
            ..ReportRequest::new(dir.path().join("none.csv"), "mag_1_uc")
        };
        let e = build(&request, &Silent, &mut Vec::new()).unwrap_err();
        assert!(matches!(e, Error::EmptyModel { .. }), "{e}");
    }
}
