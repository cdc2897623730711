//! Real-time compensation, one sample in and one sample out, for all of a model's scalars at once.
//!
//! ```
//! use tolles_core::model::design::Design;
//! use tolles_core::compensate::stream::{Derivative, ScalarSpec, Sample, StreamCompensator};
//!
//! let design = Design::new("p".parse().unwrap());
//! let spec = ScalarSpec::new("mag_1_uc", 0, design, &[10.0, 0.0, 0.0], 2.0, 1.0);
//! let mut stream = StreamCompensator::new(vec![spec], vec!["flux_a".into()], 10.0, Derivative::Central);
//! let mut out = Vec::new();
//! for (k, bx) in [30_000.0, 0.0, 30_000.0].into_iter().enumerate() {
//!     let sample = Sample { time_s: Some(0.1 * k as f64), scalars: &[50_000.0], fluxgates: &[[bx, 0.0, 40_000.0]], extras: &[] };
//!     // The payload (here the line number) comes back with the sample's result.
//!     stream.push(k, Some(sample), Vec::new(), |o| out.push((o.payload, o.compensated[0], o.is_ok())));
//! }
//! assert_eq!(out.len(), 2); // central differences hold one sample back
//! stream.finish(|o| out.push((o.payload, o.compensated[0], o.is_ok())));
//! // A·β = 10·B̂x = 6 or 0; the model's level 2 nT stays in the data.
//! assert_eq!(out, [(0, 49_996.0, true), (1, 50_002.0, true), (2, 49_996.0, true)]);
//! ```
//!
//! `compensated = scalar − (A·β − level_nt)` with the calibration flight's mean of `A·β`
//! (`level_nt`, nT) from the model: a stream cannot know the mean over a whole file, which is what
//! `tolles compensate` subtracts. Stream and batch therefore agree up to one constant per scalar.
//!
//! **Derivatives and latency.** The eddy-current columns need the fluxgate's change per sample.
//! - [`Derivative::Central`]: exactly the batch central difference; at the start and end of a run
//!   the one-sided difference, as in batch. The result of sample k is emitted when sample k+1
//!   arrives (or when the run or stream ends): latency one sample period plus compute time.
//! - [`Derivative::Causal`]: backward difference `B[k] − B[k−1]`, zero at a run's first sample;
//!   emitted as soon as the sample arrives: latency is compute time only. Differs from batch.
//!
//! **Runs and flags.** Like batch runs, derivatives never reach across a hole. A sample is flagged
//! (its [`Flag`]s say why) when its time jumps by more than [`GAP_FACTOR`] nominal steps, goes
//! backwards or repeats, when a value is missing, NaN or infinite, or when the line is malformed.
//! - a time gap starts a new run at that sample, which is still compensated (as batch does);
//! - a time that goes backwards or repeats, a bad time or a malformed line: the sample is not
//!   compensated and the next good sample starts a new run;
//! - a bad fluxgate value: no output for the scalars using that fluxgate, whose run restarts at
//!   its next good sample (batch splits runs there too);
//! - a bad scalar value: only that scalar's output is missing; runs are unaffected, since
//!   derivatives use only the fluxgate.
//!
//! Memory is bounded: at most one sample is held back.

use crate::compensate::adapt::{AdaptSettings, Adapter};
use crate::compensate::rescale_eddy;
use crate::model::coverage::Coverage;
use crate::model::design::Design;
use crate::model::limits::{scalar_usable, show_nt, FLUX_MAGNITUDE_RANGE_NT};
use crate::model::magnitude::{exact_at, field_per_unit, Magnitude};
use crate::model::network::{Network, Scratch};
use crate::model::terms::Column;
use crate::model::uncertainty::Uncertainty;
use crate::model::vector::norm3;
use crate::signal::filter::FilterError;
pub use crate::signal::segment::GAP_FACTOR;
use std::fmt;

/// How the fluxgate's change per sample is computed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Derivative {
    /// Central difference, one sample of look-ahead (latency: one sample period + compute).
    Central,
    /// Backward difference, no look-ahead (latency: compute only).
    Causal,
}

/// Why a sample is flagged.
#[derive(Debug, Clone, PartialEq)]
pub enum Flag {
    /// A value is NaN or infinite.
    NotFinite {
        /// Column name.
        column: String,
        /// The value.
        value: f64,
    },
    /// A finite value outside the physical range: a fluxgate magnitude outside
    /// [`FLUX_MAGNITUDE_RANGE_NT`] or a scalar beyond
    /// [`SCALAR_LIMIT_NT`](crate::model::limits::SCALAR_LIMIT_NT). The sample is
    /// uncomputable and kept out of the compensator's state.
    OutOfRange {
        /// Column name (a fluxgate's prefix for its magnitude).
        column: String,
        /// The value or magnitude (nT).
        value: f64,
    },
    /// An empty cell.
    Missing {
        /// Column name.
        column: String,
    },
    /// A cell that is not a number.
    NotANumber {
        /// Column name.
        column: String,
        /// The cell's text.
        text: String,
    },
    /// The line cannot be read (wrong field count, bad quoting, not UTF-8).
    Malformed(String),
    /// Time advanced by more than [`GAP_FACTOR`] nominal steps (seconds since the last sample).
    TimeGap {
        /// Seconds since the previous sample's time.
        seconds: f64,
    },
    /// Time is earlier than the previous sample's.
    TimeBackwards,
    /// Time equals the previous sample's.
    TimeRepeated,
    /// An extra channel read at this line has no conditioned value yet: its lag or low-pass
    /// reaches samples not (or not validly) read — the stream's first lines, or a missing cell.
    NotConditioned {
        /// Column name.
        column: String,
    },
}

impl fmt::Display for Flag {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Flag::NotFinite { column, value } if value.is_nan() => write!(f, "nan in {column}"),
            Flag::NotFinite { column, .. } => write!(f, "inf in {column}"),
            Flag::OutOfRange { column, value } => {
                write!(f, "{column} out of range: {} nT", show_nt(*value))
            }
            Flag::Missing { column } => write!(f, "missing {column}"),
            Flag::NotANumber { column, text } => write!(f, "not a number in {column}: {text:?}"),
            Flag::Malformed(why) => write!(f, "malformed: {why}"),
            Flag::TimeGap { seconds } => write!(f, "time gap {seconds:.3} s"),
            Flag::TimeBackwards => write!(f, "time went backwards"),
            Flag::TimeRepeated => write!(f, "time repeated"),
            Flag::NotConditioned { column } => {
                write!(
                    f,
                    "{column} not yet conditioned (its lag or low-pass reaches past the data)"
                )
            }
        }
    }
}

impl Flag {
    fn column(&self) -> Option<&str> {
        match self {
            Flag::NotFinite { column, .. }
            | Flag::OutOfRange { column, .. }
            | Flag::Missing { column }
            | Flag::NotANumber { column, .. }
            | Flag::NotConditioned { column } => Some(column),
            _ => None,
        }
    }
}

/// One scalar magnetometer's model, ready for streaming.
#[derive(Debug, Clone, PartialEq)]
pub struct ScalarSpec {
    /// Input column of the uncompensated scalar (nT).
    pub name: String,
    /// Index of its fluxgate in the stream's fluxgate list.
    pub fluxgate: usize,
    design: Design,
    columns: Vec<Column>,
    coefficients: Vec<f64>,
    level_nt: f64,
    magnitude: Magnitude,
    /// The fluxgate's offset (nT), taken out of each reading ([`crate::fit::Fit::flux_offset_nt`]).
    flux_offset_nt: Option<[f64; 3]>,
    /// What each sample's standard error and extrapolation flag come from, when asked for.
    trust: Option<Trust>,
    /// A network added to the correction, and the stream's extra channels (indices) it reads
    /// after the fluxgate and the design's extra channels.
    network: Option<(Network, Vec<usize>)>,
}

/// A scalar's uncertainty and the span its calibration flew, for each sample's standard error
/// and extrapolation flag (see [`crate::compensate::trust`]).
#[derive(Debug, Clone, PartialEq)]
pub struct Trust {
    /// `None` for a model file without one: the standard error is then NaN.
    pub uncertainty: Option<Uncertainty>,
    /// `None` for a model file without one: no sample is flagged.
    pub coverage: Option<Coverage>,
    /// The stream's sample rate over the calibration's.
    pub fs_ratio: f64,
    /// The stream's sample rate (Hz).
    pub fs_hz: f64,
}

impl ScalarSpec {
    /// `coefficients` of `design` (nT per unit of the column), `level_nt` (nT) subtracted from
    /// `A·β`, and `fs_ratio` = stream sample rate / calibration sample rate (rescales eddy terms).
    pub fn new(
        name: &str,
        fluxgate: usize,
        design: Design,
        coefficients: &[f64],
        level_nt: f64,
        fs_ratio: f64,
    ) -> Self {
        assert_eq!(
            design.width(),
            coefficients.len(),
            "one coefficient per column"
        );
        Self {
            name: name.to_string(),
            fluxgate,
            columns: design.columns(),
            coefficients: rescale_eddy(&design, coefficients, fs_ratio),
            design,
            level_nt,
            magnitude: Magnitude::Linear,
            flux_offset_nt: None,
            trust: None,
            network: None,
        }
    }

    /// The same model with `network` added to its correction (see
    /// [`crate::model::network::features`]); `channels` are the stream's extra channels
    /// (indices into its list) the network reads after the fluxgate and the design's extra
    /// channels.
    pub fn with_network(self, network: Network, channels: Vec<usize>) -> Self {
        Self {
            network: Some((network, channels)),
            ..self
        }
    }

    /// The network's correction (nT) for field `b` (nT), the design's extra channels `extras`
    /// and the sample's stream extra channels `all_extras`, in `room`; 0 without a network.
    fn learned(
        &self,
        b: [f64; 3],
        (extras, all_extras): (&[f64], &[f64]),
        (x, scratch): &mut (Vec<f64>, Scratch),
    ) -> f64 {
        let Some((network, channels)) = &self.network else {
            return 0.0;
        };
        let magnitude = norm3(b);
        x.clear();
        x.extend(b.iter().map(|v| v / magnitude));
        x.push(magnitude);
        x.extend_from_slice(extras);
        let channel = |c: &usize| all_extras.get(*c).copied().unwrap_or(f64::NAN);
        x.extend(channels.iter().map(channel));
        network.evaluate_with(x, scratch)
    }

    /// The same model giving each sample's standard error and extrapolation flag.
    pub fn with_trust(self, trust: Trust) -> Self {
        Self {
            trust: Some(trust),
            ..self
        }
    }

    /// A sample's standard error (nT; NaN without an uncertainty) and whether it lies outside
    /// the calibration's span, for field `b` (nT) changing by `db` (nT/sample) with the extra
    /// channels `extras`; `row` is room for a design row. `None` when not asked for.
    fn trust_at(
        &self,
        b: [f64; 3],
        db: [f64; 3],
        extras: &[f64],
        row: &mut [f64],
    ) -> Option<(f64, bool)> {
        let trust = self.trust.as_ref()?;
        let sigma = trust.uncertainty.as_ref().map_or(f64::NAN, |u| {
            self.design
                .row_with_extras(&self.columns, b, db, extras, row);
            for (a, c) in row.iter_mut().zip(&self.columns) {
                if matches!(c, Column::Eddy(..) | Column::EddyTraceless(_)) {
                    *a *= trust.fs_ratio;
                }
            }
            u.value_sigma(row)
        });
        let rate = (db[0] * db[0] + db[1] * db[1] + db[2] * db[2]).sqrt() * trust.fs_hz;
        let outside = trust
            .coverage
            .as_ref()
            .is_some_and(|c| c.outside(b, rate, extras));
        Some((sigma, outside))
    }

    /// The same model on the fluxgate's readings less `offset` (nT; none unless set).
    pub fn with_flux_offset(self, offset: Option<[f64; 3]>) -> Self {
        Self {
            flux_offset_nt: offset,
            ..self
        }
    }

    /// A reading `b` (nT) less the fluxgate's offset.
    fn corrected(&self, b: [f64; 3]) -> [f64; 3] {
        let o = self.flux_offset_nt.unwrap_or_default();
        [b[0] - o[0], b[1] - o[1], b[2] - o[2]]
    }

    /// The same model applied with `magnitude` (linear unless set).
    pub fn with_magnitude(self, magnitude: Magnitude) -> Self {
        Self { magnitude, ..self }
    }

    /// The coefficients in use (eddy terms rescaled to the stream's rate).
    pub fn coefficients(&self) -> &[f64] {
        &self.coefficients
    }

    /// The correction (nT) for field `b` (nT) changing by `db` (nT/sample) and the extra
    /// channels `extras` (design order): `A·β`, or the exact `|B + H| − |B|`. Leaves in `row`
    /// the design row, or for the exact model the Jacobian row (see
    /// [`crate::model::magnitude`]), which adaptation regresses on.
    fn field(&self, b: [f64; 3], db: [f64; 3], extras: &[f64], row: &mut [f64]) -> f64 {
        match self.magnitude {
            Magnitude::Linear => {
                self.design
                    .row_with_extras(&self.columns, b, db, extras, row);
                row.iter().zip(&self.coefficients).map(|(a, c)| a * c).sum()
            }
            Magnitude::Exact => {
                let (value, direction) = exact_at(
                    &self.design,
                    &self.columns,
                    &self.coefficients,
                    b,
                    db,
                    extras,
                );
                for (r, column) in row.iter_mut().zip(&self.columns) {
                    let s = self.design.bt_scale;
                    *r = field_per_unit(*column, b, db, extras, s).map_or(1.0, |v| {
                        direction[0] * v[0] + direction[1] * v[1] + direction[2] * v[2]
                    });
                }
                value
            }
        }
    }

    /// The scalar (nT) an adapter should regress on `row` after [`ScalarSpec::field`]: the
    /// scalar itself for a linear model; for the exact one, the Gauss-Newton target
    /// `y − Δ(β) + J·β`.
    fn adaptation_target(&self, scalar: f64, field: f64, row: &[f64]) -> f64 {
        match self.magnitude {
            Magnitude::Linear => scalar,
            Magnitude::Exact => {
                let linearised: f64 = row.iter().zip(&self.coefficients).map(|(a, c)| a * c).sum();
                scalar - field + linearised
            }
        }
    }
}

/// One input sample: borrowed slices, so pushing allocates nothing.
#[derive(Debug, Clone, Copy)]
pub struct Sample<'a> {
    /// Time (s); `None` when the input has no time column (then no gap detection).
    pub time_s: Option<f64>,
    /// One value per [`ScalarSpec`] (nT), in order.
    pub scalars: &'a [f64],
    /// One body-frame vector per fluxgate (nT), in order.
    pub fluxgates: &'a [[f64; 3]],
    /// One value per extra channel of the stream ([`StreamCompensator::with_extras`]), in
    /// order, conditioned as the model says; empty without extra channels.
    pub extras: &'a [f64],
}

/// The result for one input sample.
#[derive(Debug)]
pub struct Output<'a, T> {
    /// What was pushed with the sample.
    pub payload: T,
    /// One compensated value per scalar (nT); NaN where not computable.
    pub compensated: &'a [f64],
    /// Why the sample is not fully usable; empty when it is.
    pub flags: &'a [Flag],
    /// Per scalar whose spec gives it ([`ScalarSpec::with_trust`]): the correction's standard
    /// error (nT, NaN where not computable) and whether the sample lies outside the span its
    /// calibration flew; NaN and `false` for the others.
    pub sigma: &'a [f64],
    /// Per scalar: whether the sample lies outside the span its calibration flew (`false` for
    /// scalars without trust).
    pub extrapolated: &'a [bool],
}

impl<T> Output<'_, T> {
    /// True when nothing is flagged.
    pub fn is_ok(&self) -> bool {
        self.flags.is_empty()
    }

    /// `ok`, or the flags joined by `; `. A row with every value computed can only be flagged
    /// for a cell its value did not read (an extra channel read later through its lag): such
    /// a missing cell says so, rather than reading as the reason for a value it did not stop.
    pub fn status(&self) -> String {
        if self.flags.is_empty() {
            return "ok".to_string();
        }
        let valued = !self.compensated.is_empty() && self.compensated.iter().all(|v| v.is_finite());
        let text: Vec<String> = (self.flags.iter())
            .map(|flag| match flag {
                Flag::Missing { column } if valued => {
                    format!("missing {column}, which this row's value does not read (its lag reads it later)")
                }
                other => other.to_string(),
            })
            .collect();
        text.join("; ")
    }
}

/// A sample held back until its successor is known.
struct Held<T> {
    payload: T,
    scalars: Vec<f64>,
    /// Usable fluxgate values; `None` where not usable.
    flux: Vec<Option<[f64; 3]>>,
    /// The extra channels' values.
    extras: Vec<f64>,
    flags: Vec<Flag>,
}

/// The streaming compensator; `T` is any payload carried through with each sample (a line of
/// text, a sequence number).
pub struct StreamCompensator<T> {
    scalars: Vec<ScalarSpec>,
    fluxgates: Vec<String>,
    step_s: f64,
    derivative: Derivative,
    last_time: Option<f64>,
    /// Per fluxgate, the usable sample before the held one (central) or the last one (causal),
    /// in the current run.
    before: Vec<Option<[f64; 3]>>,
    held: Option<Held<T>>,
    adapters: Vec<Adapter>,
    values: Vec<f64>,
    sigma: Vec<f64>,
    extrapolated: Vec<bool>,
    row: Vec<f64>,
    trust_row: Vec<f64>,
    /// Names of the extra channels.
    extras: Vec<String>,
    /// Per fluxgate, the extra channels (indices into `extras`) its scalars' designs use, in
    /// design order: a sample of the fluxgate is usable only with all of them finite.
    fluxgate_extras: Vec<Vec<usize>>,
    extra_values: Vec<f64>,
    /// Room for a network's inputs and layers, so a sample allocates nothing.
    network_room: (Vec<f64>, Scratch),
}

impl<T> StreamCompensator<T> {
    /// A compensator for `scalars`, whose fluxgates are named by the prefixes `fluxgates`
    /// (`flux_a` → `flux_a_x/_y/_z`), at nominal sample rate `fs_hz` (Hz), which sets the gap
    /// threshold [`GAP_FACTOR`]` / fs_hz` (s).
    pub fn new(
        scalars: Vec<ScalarSpec>,
        fluxgates: Vec<String>,
        fs_hz: f64,
        derivative: Derivative,
    ) -> Self {
        let width = scalars.iter().map(|s| s.columns.len()).max().unwrap_or(0);
        let fluxgates_len = fluxgates.len();
        Self {
            values: vec![f64::NAN; scalars.len()],
            sigma: vec![f64::NAN; scalars.len()],
            extrapolated: vec![false; scalars.len()],
            row: vec![0.0; width],
            trust_row: vec![0.0; width],
            before: vec![None; fluxgates.len()],
            scalars,
            fluxgates,
            step_s: 1.0 / fs_hz,
            derivative,
            last_time: None,
            held: None,
            adapters: Vec::new(),
            fluxgate_extras: vec![Vec::new(); fluxgates_len],
            extras: Vec::new(),
            extra_values: Vec::new(),
            network_room: (Vec::new(), Scratch::default()),
        }
    }

    /// The same compensator with the extra channels `names` (each [`Sample`] carries their
    /// values in this order) and, per fluxgate, the ones its scalars' designs use, in design
    /// order (indices into `names`). Fluxgates that share a series but not the extra channels
    /// are given twice: like batch compensation, a sample whose extra channel is not finite
    /// breaks the run of the scalars that use it.
    pub fn with_extras(self, names: Vec<String>, per_fluxgate: Vec<Vec<usize>>) -> Self {
        assert_eq!(
            per_fluxgate.len(),
            self.fluxgates.len(),
            "one list per fluxgate"
        );
        Self {
            extras: names,
            fluxgate_extras: per_fluxgate,
            ..self
        }
    }

    /// Adapts every scalar's coefficients online from now on (see [`crate::compensate::adapt`]).
    pub fn adapt(&mut self, settings: &AdaptSettings) -> Result<(), FilterError> {
        let fs_hz = 1.0 / self.step_s;
        self.adapters = self
            .scalars
            .iter()
            .map(|s| Adapter::new(&s.coefficients, fs_hz, settings))
            .collect::<Result<_, _>>()?;
        Ok(())
    }

    /// Per scalar, how many samples have updated its coefficients (empty without adaptation).
    pub fn adaptation_updates(&self) -> Vec<u64> {
        self.adapters.iter().map(Adapter::updates).collect()
    }

    /// Number of fluxgates (one vector per [`Sample`]).
    pub fn fluxgate_count(&self) -> usize {
        self.fluxgates.len()
    }

    /// The scalars, in output order.
    pub fn scalars(&self) -> &[ScalarSpec] {
        &self.scalars
    }

    /// Feeds one input line: its `sample` (`None` when it could not be read), the `flags` its
    /// reader already raised, and a `payload` returned with its result. Calls `emit` for every
    /// sample whose result is now known, in input order: in central mode normally the previous
    /// sample; in causal mode this one.
    pub fn push(
        &mut self,
        payload: T,
        sample: Option<Sample<'_>>,
        mut flags: Vec<Flag>,
        mut emit: impl FnMut(Output<'_, T>),
    ) {
        let (breaks_run, placeable) = self.check_time(sample.as_ref(), &mut flags);
        let mut flux = vec![None; self.fluxgates.len()];
        let mut scalars = vec![f64::NAN; self.scalars.len()];
        let mut extras = vec![f64::NAN; self.extras.len()];
        if let Some(s) = sample {
            for (e, v) in s.extras.iter().enumerate().take(extras.len()) {
                flag_non_finite(&self.extras[e], *v, &mut flags);
                extras[e] = *v;
            }
            for (j, b) in s.fluxgates.iter().enumerate().take(flux.len()) {
                let finite = self.check_fluxgate(j, *b, &mut flags)
                    && self.fluxgate_extras[j]
                        .iter()
                        .all(|e| extras[*e].is_finite());
                flux[j] = (finite && placeable).then_some(*b);
            }
            for (i, v) in s.scalars.iter().enumerate().take(scalars.len()) {
                flag_non_finite(&self.scalars[i].name, *v, &mut flags);
                if v.is_finite() && !scalar_usable(*v) {
                    flags.push(Flag::OutOfRange {
                        column: self.scalars[i].name.clone(),
                        value: *v,
                    });
                }
                // A corrupt scalar must reach neither the output nor the adaptation.
                scalars[i] = if scalar_usable(*v) { *v } else { f64::NAN };
            }
        }
        if breaks_run {
            self.end_run(&mut emit);
        }
        let new = Held {
            payload,
            scalars,
            flux,
            extras,
            flags,
        };
        match self.derivative {
            Derivative::Central => self.push_central(new, &mut emit),
            Derivative::Causal => self.push_causal(new, &mut emit),
        }
    }

    /// Ends the stream: emits the held sample, if any, with a one-sided difference.
    pub fn finish(&mut self, mut emit: impl FnMut(Output<'_, T>)) {
        self.end_run(&mut emit);
        self.last_time = None;
    }

    /// Ends every run before the next sample, as a time gap does: the held sample is emitted
    /// with a one-sided difference. For callers that find gaps themselves (`tolles compensate`
    /// reading a file in chunks splits exactly where the batch computation does).
    pub fn split(&mut self, mut emit: impl FnMut(Output<'_, T>)) {
        self.end_run(&mut emit);
    }

    /// Checks the time against the previous sample's; returns (breaks every run, can be placed).
    fn check_time(&mut self, sample: Option<&Sample<'_>>, flags: &mut Vec<Flag>) -> (bool, bool) {
        let Some(sample) = sample else {
            return (true, false);
        };
        let Some(t) = sample.time_s else {
            return (false, true);
        };
        if !t.is_finite() {
            flag_non_finite("tt", t, flags);
            return (true, false);
        }
        let last = self.last_time.replace(t);
        match last {
            Some(l) if t < l => {
                flags.push(Flag::TimeBackwards);
                (true, false)
            }
            Some(l) if t == l => {
                flags.push(Flag::TimeRepeated);
                (true, false)
            }
            Some(l) if t - l > GAP_FACTOR * self.step_s => {
                flags.push(Flag::TimeGap { seconds: t - l });
                (true, true)
            }
            _ => (false, true),
        }
    }

    fn check_fluxgate(&self, j: usize, b: [f64; 3], flags: &mut Vec<Flag>) -> bool {
        let mut finite = true;
        for (axis, v) in ["x", "y", "z"].iter().zip(b) {
            if !v.is_finite() {
                finite = false;
                let column = format!("{}_{axis}", self.fluxgates[j]);
                flag_non_finite(&column, v, flags);
            }
        }
        if !finite {
            return false;
        }
        let magnitude = norm3(b);
        let (lo, hi) = FLUX_MAGNITUDE_RANGE_NT;
        if !(lo..=hi).contains(&magnitude) {
            flags.push(Flag::OutOfRange {
                column: self.fluxgates[j].clone(),
                value: magnitude,
            });
            return false;
        }
        true
    }

    /// Emits the held sample as the last of its run and forgets the run.
    fn end_run(&mut self, emit: &mut impl FnMut(Output<'_, T>)) {
        if let Some(held) = self.held.take() {
            let next = vec![None; self.fluxgates.len()];
            self.emit_central(held, &next, emit);
        }
        self.before.iter_mut().for_each(|b| *b = None);
        self.adapters.iter_mut().for_each(Adapter::restart);
    }

    fn push_central(&mut self, new: Held<T>, emit: &mut impl FnMut(Output<'_, T>)) {
        if let Some(held) = self.held.take() {
            let continues: Vec<Option<[f64; 3]>> = held
                .flux
                .iter()
                .zip(&new.flux)
                .map(|(h, n)| h.and(*n))
                .collect();
            let held_flux = held.flux.clone();
            self.emit_central(held, &continues, emit);
            for (j, before) in self.before.iter_mut().enumerate() {
                *before = continues[j].and(held_flux[j]);
            }
        }
        self.held = Some(new);
    }

    /// Emits `held`; `next[j]` is the following sample of fluxgate j in the same run, if any.
    fn emit_central(
        &mut self,
        held: Held<T>,
        next: &[Option<[f64; 3]>],
        emit: &mut impl FnMut(Output<'_, T>),
    ) {
        let mut db = vec![None; self.fluxgates.len()];
        for (j, d) in db.iter_mut().enumerate() {
            *d = held.flux[j].map(|b| central_change(self.before[j], b, next[j]));
        }
        self.emit(held, &db, emit);
    }

    fn push_causal(&mut self, new: Held<T>, emit: &mut impl FnMut(Output<'_, T>)) {
        let mut db = vec![None; self.fluxgates.len()];
        for (j, d) in db.iter_mut().enumerate() {
            *d = new.flux[j].map(|b| match self.before[j] {
                Some(p) => [b[0] - p[0], b[1] - p[1], b[2] - p[2]],
                None => [0.0; 3],
            });
            self.before[j] = new.flux[j];
        }
        self.emit(new, &db, emit);
    }

    fn emit(
        &mut self,
        held: Held<T>,
        db: &[Option<[f64; 3]>],
        emit: &mut impl FnMut(Output<'_, T>),
    ) {
        for (i, spec) in self.scalars.iter_mut().enumerate() {
            let j = spec.fluxgate;
            let (Some(b), Some(d)) = (held.flux[j], db[j]) else {
                self.values[i] = f64::NAN;
                self.sigma[i] = f64::NAN;
                self.extrapolated[i] = false;
                if let Some(adapter) = self.adapters.get_mut(i) {
                    adapter.restart();
                }
                continue;
            };
            let b = spec.corrected(b);
            let row = &mut self.row[..spec.columns.len()];
            let scalar = held.scalars[i];
            self.extra_values.clear();
            let used = self.fluxgate_extras[j].iter().map(|e| held.extras[*e]);
            self.extra_values.extend(used);
            let field = spec.field(b, d, &self.extra_values, row);
            let room = &mut self.network_room;
            let learned = spec.learned(b, (&self.extra_values, &held.extras), room);
            self.values[i] = scalar - (field + learned - spec.level_nt);
            let trust_row = &mut self.trust_row[..spec.columns.len()];
            let (sigma, outside) = spec
                .trust_at(b, d, &self.extra_values, trust_row)
                .unwrap_or((f64::NAN, false));
            self.sigma[i] = if self.values[i].is_finite() {
                sigma
            } else {
                f64::NAN
            };
            // The network's inputs are still in its room: beyond its training range, the row
            // is outside what the calibration flew too.
            let beyond = (spec.network.as_ref()).is_some_and(|(n, _)| n.beyond_range(&room.0));
            self.extrapolated[i] = outside || beyond;
            if let Some(adapter) = self.adapters.get_mut(i) {
                let target = spec.adaptation_target(scalar, field, row);
                // Adapt after use, so a sample's output never depends on itself.
                if scalar.is_finite() && adapter.update(row, target) {
                    spec.coefficients.copy_from_slice(adapter.coefficients());
                }
            }
        }
        emit(Output {
            payload: held.payload,
            compensated: &self.values,
            flags: &held.flags,
            sigma: &self.sigma,
            extrapolated: &self.extrapolated,
        });
    }
}

/// The change per sample at `b` (nT/sample) from its neighbours in the run, as
/// [`crate::model::design::central_difference`] computes it.
fn central_change(before: Option<[f64; 3]>, b: [f64; 3], after: Option<[f64; 3]>) -> [f64; 3] {
    match (before, after) {
        (Some(p), Some(n)) => [0, 1, 2].map(|i| (n[i] - p[i]) / 2.0),
        (None, Some(n)) => [0, 1, 2].map(|i| n[i] - b[i]),
        (Some(p), None) => [0, 1, 2].map(|i| b[i] - p[i]),
        (None, None) => [0.0; 3],
    }
}

/// Flags a non-finite `value` of `column` unless the reader already flagged that column.
fn flag_non_finite(column: &str, value: f64, flags: &mut Vec<Flag>) {
    if value.is_finite() || flags.iter().any(|f| f.column() == Some(column)) {
        return;
    }
    flags.push(Flag::NotFinite {
        column: column.to_string(),
        value,
    });
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::compensate::{compensate, Level};
    use crate::model::vector::VectorSeries;

    fn spec() -> ScalarSpec {
        let design = Design::new("p,i,e".parse().unwrap());
        let beta: Vec<f64> = (0..design.width()).map(|k| 3.0 - 0.7 * k as f64).collect();
        ScalarSpec::new("mag_1_uc", 0, design, &beta, 1.5, 1.0)
    }

    fn flux(n: usize) -> VectorSeries {
        let f = |k: usize, a: f64, w: f64| a * (w * k as f64).sin();
        VectorSeries::new(
            (0..n).map(|k| 20_000.0 + f(k, 3_000.0, 0.3)).collect(),
            (0..n).map(|k| 5_000.0 + f(k, 2_000.0, 0.17)).collect(),
            (0..n).map(|k| 45_000.0 + f(k, 1_000.0, 0.11)).collect(),
        )
    }

    fn run(
        derivative: Derivative,
        tt: &[f64],
        scalar: &[f64],
        flux: &VectorSeries,
    ) -> Vec<(usize, f64, String)> {
        let mut stream =
            StreamCompensator::new(vec![spec()], vec!["flux_a".into()], 10.0, derivative);
        let mut out = Vec::new();
        let mut record = |o: Output<'_, usize>| out.push((o.payload, o.compensated[0], o.status()));
        for k in 0..tt.len() {
            let sample = Sample {
                time_s: Some(tt[k]),
                scalars: &scalar[k..k + 1],
                fluxgates: &[flux.at(k)],
                extras: &[],
            };
            stream.push(k, Some(sample), Vec::new(), &mut record);
        }
        stream.finish(&mut record);
        out
    }

    #[test]
    fn central_stream_equals_batch_with_the_same_level() {
        let n = 40;
        let mut tt: Vec<f64> = (0..n).map(|k| 0.1 * k as f64).collect();
        tt[20..].iter_mut().for_each(|t| *t += 3.0); // a gap before sample 20
        let scalar: Vec<f64> = (0..n).map(|k| 50_000.0 + k as f64).collect();
        let mut f = flux(n);
        f.y[7] = f64::NAN; // a hole splits the run
        f.x[9] = f64::NAN;
        let s = spec();
        let batch = compensate(
            &scalar,
            &f,
            Some(&tt),
            &s.design,
            s.coefficients(),
            1.0,
            Level::Fixed(1.5),
        );
        let out = run(Derivative::Central, &tt, &scalar, &f);
        assert_eq!(out.len(), n);
        for (k, (payload, value, status)) in out.iter().enumerate() {
            assert_eq!(*payload, k);
            let b = batch.compensated[k];
            assert!(b.is_nan() == value.is_nan(), "{k}: {b} vs {value}");
            if b.is_finite() {
                assert!((b - value).abs() < 1e-9, "{k}: {b} vs {value}");
            }
            let expected = match k {
                7 => "nan in flux_a_y",
                9 => "nan in flux_a_x",
                20 => "time gap 3.100 s",
                _ => "ok",
            };
            assert_eq!(status, expected);
        }
    }

    #[test]
    fn central_stream_of_an_exact_model_equals_batch() {
        let n = 60;
        let tt: Vec<f64> = (0..n).map(|k| 0.1 * k as f64).collect();
        let scalar: Vec<f64> = (0..n).map(|k| 50_000.0 + (k as f64 * 0.4).sin()).collect();
        let f = flux(n);
        let design = Design::new("patent".parse().unwrap());
        let beta: Vec<f64> = (0..16).map(|k| 400.0 - 45.0 * k as f64).collect();
        let spec = ScalarSpec::new("mag_1_uc", 0, design.clone(), &beta, 2.5, 1.0)
            .with_magnitude(Magnitude::Exact);
        let model = crate::compensate::Model {
            design: &design,
            coefficients: &beta,
            magnitude: Magnitude::Exact,
        };
        let batch = crate::compensate::compensate_model(
            &scalar,
            &f,
            Some(&tt),
            model,
            1.0,
            Level::Fixed(2.5),
        );
        let linear = compensate(
            &scalar,
            &f,
            Some(&tt),
            &design,
            &beta,
            1.0,
            Level::Fixed(2.5),
        );
        let mut stream =
            StreamCompensator::new(vec![spec], vec!["flux_a".into()], 10.0, Derivative::Central);
        let mut out = Vec::new();
        for k in 0..n {
            let sample = Sample {
                time_s: Some(tt[k]),
                scalars: &scalar[k..k + 1],
                fluxgates: &[f.at(k)],
                extras: &[],
            };
            stream.push(k, Some(sample), Vec::new(), &mut |o: Output<'_, usize>| {
                out.push(o.compensated[0])
            });
        }
        stream.finish(&mut |o: Output<'_, usize>| out.push(o.compensated[0]));
        let mut second_order: f64 = 0.0;
        assert_eq!(out.len(), n);
        for (k, streamed) in out.iter().enumerate() {
            assert!((streamed - batch.compensated[k]).abs() < 1e-9, "{k}");
            second_order = second_order.max((batch.compensated[k] - linear.compensated[k]).abs());
        }
        assert!(
            second_order > 0.1,
            "the exact model differs from the linear one"
        );
    }

    #[test]
    fn causal_stream_uses_backward_differences_without_delay() {
        let n = 10;
        let tt: Vec<f64> = (0..n).map(|k| 0.1 * k as f64).collect();
        let scalar = vec![50_000.0; n];
        let f = flux(n);
        let mut stream = StreamCompensator::new(
            vec![spec()],
            vec!["flux_a".into()],
            10.0,
            Derivative::Causal,
        );
        let s = spec();
        let mut row = vec![0.0; s.design.width()];
        for k in 0..n {
            let sample = Sample {
                time_s: Some(tt[k]),
                scalars: &scalar[k..k + 1],
                fluxgates: &[f.at(k)],
                extras: &[],
            };
            let mut got = Vec::new();
            stream.push(k, Some(sample), Vec::new(), |o| {
                got.push((o.payload, o.compensated[0]))
            });
            assert_eq!(got.len(), 1, "no look-ahead");
            let (b, p) = (f.at(k), if k == 0 { f.at(0) } else { f.at(k - 1) });
            let db = [b[0] - p[0], b[1] - p[1], b[2] - p[2]];
            let expected = 50_000.0 - (s.field(b, db, &[], &mut row) - 1.5);
            assert_eq!(got[0], (k, expected));
        }
    }

    #[test]
    fn backwards_time_and_malformed_lines_restart_the_run() {
        let n = 12;
        let mut tt: Vec<f64> = (0..n).map(|k| 0.1 * k as f64).collect();
        tt[4] = 0.05;
        let scalar = vec![50_000.0; n];
        let f = flux(n);
        let out = run(Derivative::Central, &tt, &scalar, &f);
        assert_eq!(out[4].2, "time went backwards");
        assert!(out[4].1.is_nan());
        // Sample 5 starts a new run: batch over samples 5.. gives its value.
        let s = spec();
        let tail = f.slice(5..n);
        let batch = compensate(
            &scalar[5..],
            &tail,
            None,
            &s.design,
            s.coefficients(),
            1.0,
            Level::Fixed(1.5),
        );
        assert!((batch.compensated[0] - out[5].1).abs() < 1e-9);
        assert!(out.iter().enumerate().all(|(k, o)| o.0 == k));

        let mut stream = StreamCompensator::new(
            vec![spec()],
            vec!["flux_a".into()],
            10.0,
            Derivative::Central,
        );
        let mut seen = Vec::new();
        let mut record = |o: Output<'_, usize>| seen.push((o.payload, o.status()));
        stream.push(
            0,
            None,
            vec![Flag::Malformed("3 fields, header has 9".into())],
            &mut record,
        );
        stream.finish(&mut record);
        assert_eq!(seen, [(0, "malformed: 3 fields, header has 9".to_string())]);
    }

    #[test]
    fn a_bad_scalar_does_not_break_the_run() {
        let n = 8;
        let tt: Vec<f64> = (0..n).map(|k| 0.1 * k as f64).collect();
        let mut scalar = vec![50_000.0; n];
        scalar[3] = f64::INFINITY;
        let f = flux(n);
        let out = run(Derivative::Central, &tt, &scalar, &f);
        let s = spec();
        let batch = compensate(
            &scalar,
            &f,
            Some(&tt),
            &s.design,
            s.coefficients(),
            1.0,
            Level::Fixed(1.5),
        );
        assert_eq!(out[3].2, "inf in mag_1_uc");
        for k in [2, 4] {
            assert!((batch.compensated[k] - out[k].1).abs() < 1e-9);
        }
    }

    #[test]
    fn out_of_range_cells_are_flagged_and_uncomputable() {
        let n = 8;
        let tt: Vec<f64> = (0..n).map(|k| 0.1 * k as f64).collect();
        let mut scalar = vec![50_000.0; n];
        scalar[2] = 1e308;
        let mut f = flux(n);
        (f.x[5], f.y[5], f.z[5]) = (0.0, 0.0, 0.0);
        f.x[6] = 1e308;
        let out = run(Derivative::Central, &tt, &scalar, &f);
        assert!(out[2].1.is_nan() && out[5].1.is_nan() && out[6].1.is_nan());
        assert_eq!(out[2].2, "mag_1_uc out of range: 1.000e308 nT");
        assert_eq!(out[5].2, "flux_a out of range: 0.0 nT");
        assert!(out[6].2.starts_with("flux_a out of range"), "{}", out[6].2);
        assert!(out[7].1.is_finite() && out[3].1.is_finite());
    }
}
