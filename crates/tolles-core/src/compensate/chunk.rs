//! The one compensator behind every path: a flight's raw channels go in a chunk of rows at a
//! time, and out comes each chunk's correction `A·β` (nT), with its rows outside what the
//! calibration flew and, when asked, each row's standard error.
//!
//! - A flight read whole is one chunk ([`ChunkCompensator::whole`]).
//! - A file read in bounded memory is many ([`ChunkCompensator::push`], then
//!   [`ChunkCompensator::finish`]). Every row gets the bits the whole flight gives it.
//!
//! ```
//! use tolles_core::compensate::chunk::{ChunkCompensator, RawRows, Setup};
//! use tolles_core::compensate::Model;
//! use tolles_core::model::design::Design;
//! use tolles_core::model::magnitude::Magnitude;
//!
//! let design = Design::new("p,e".parse().unwrap());
//! let beta: Vec<f64> = (0..design.width()).map(|k| 1.0 + k as f64).collect();
//! let model = Model { design: &design, coefficients: &beta, magnitude: Magnitude::Linear };
//! let x: Vec<f64> = (0..7).map(|k| 30_000.0 + 100.0 * k as f64).collect();
//! let (y, z) = (vec![1_000.0; 7], vec![40_000.0; 7]);
//! let rows = |r: std::ops::Range<usize>| RawRows {
//!     flux: vec![[&x[r.clone()], &y[r.clone()], &z[r.clone()]]],
//!     extras: Vec::new(),
//!     inputs: Vec::new(),
//!     tt: None,
//! };
//! let whole = ChunkCompensator::new(Setup::new(model, 10.0, 1.0)).whole(rows(0..7));
//! let mut chunked = ChunkCompensator::new(Setup::new(model, 10.0, 1.0));
//! let mut field = Vec::new();
//! for part in [0..3, 3..4, 4..7] {
//!     chunked.push(rows(part)).into_iter().for_each(|c| field.extend(c.field));
//! }
//! chunked.finish().into_iter().for_each(|c| field.extend(c.field));
//! assert_eq!(field, whole.field); // the same bits, chunk edges included
//! ```
//!
//! The fluxgates are read `lag_s` later and the extra channels low-passed and lagged as the
//! model says, by one [`Conditioner`] (which the stream's aligner also is). A chunk is computed
//! once the rows its last row's shifts and central difference read have arrived, with one
//! conditioned row of its neighbours on each side, and its runs split where the whole flight's
//! are (an unusable row, or a time step beyond the whole flight's median step times the gap
//! factor): each row is then the same sum as in the whole flight.

use super::align::{Channel, Conditioned, Conditioner};
use super::trust::{outside_over_runs, sigma_over_runs};
use super::{model_field_over_runs, Model};
use crate::model::coverage::Coverage;
use crate::model::extra::LowPass;
use crate::model::network::{features, Network, Scratch};
use crate::model::uncertainty::Uncertainty;
use crate::model::vector::{Fluxgates, VectorSeries};
use crate::signal::segment::contiguous_runs_with_step;
use crate::signal::shift::Shift;
use std::collections::VecDeque;
use std::ops::Range;

/// What to compute and at which rate.
#[derive(Debug, Clone, Copy)]
pub struct Setup<'m> {
    /// The fitted model (its coefficients for the calibration's sample rate).
    pub model: Model<'m>,
    /// The survey's sample rate (Hz): the lag's and the low-passes' unit.
    pub fs_hz: f64,
    /// The survey's sample rate over the calibration's (rescales the eddy terms).
    pub fs_ratio: f64,
    /// The fluxgate's lag (s): it is read this much later.
    pub lag_s: f64,
    /// The first fluxgate's offset (nT; x, y, z), taken out of its readings
    /// ([`crate::fit::Fit::flux_offset_nt`]).
    pub flux_offset_nt: Option<[f64; 3]>,
    /// The whole flight's median time step (s), which sets the gap threshold; `None` splits
    /// runs at unusable rows only.
    pub median_step_s: Option<f64>,
    /// What the calibration flew: rows outside it are flagged.
    pub coverage: Option<&'m Coverage>,
    /// The model's uncertainty: each row's standard error (nT) is computed when given.
    pub uncertainty: Option<&'m Uncertainty>,
    /// A network added to the linear model's correction (see [`crate::model::network`]).
    pub network: Option<&'m Network>,
    /// The raw channels the network reads besides the fluxgate and the extra channels
    /// ([`RawRows::inputs`]).
    pub network_channels: usize,
}

impl<'m> Setup<'m> {
    /// `model` at `fs_hz` (Hz), `fs_ratio` times the calibration's rate: no lag, no time
    /// gaps, no trust.
    pub fn new(model: Model<'m>, fs_hz: f64, fs_ratio: f64) -> Self {
        Self {
            model,
            fs_hz,
            fs_ratio,
            lag_s: 0.0,
            flux_offset_nt: None,
            median_step_s: None,
            coverage: None,
            uncertainty: None,
            network: None,
            network_channels: 0,
        }
    }
}

/// Consecutive rows of a flight's raw channels, all of the same length.
#[derive(Debug, Clone, Default)]
pub struct RawRows<'a> {
    /// Per fluxgate of the design, its x, y, z (nT, body frame).
    pub flux: Vec<[&'a [f64]; 3]>,
    /// Per extra channel of the design, in its order, as recorded (its own unit).
    pub extras: Vec<&'a [f64]>,
    /// The network's own input channels, in its order ([`Setup::network_channels`]).
    pub inputs: Vec<&'a [f64]>,
    /// Time (s), if the flight has it.
    pub tt: Option<&'a [f64]>,
}

impl RawRows<'_> {
    fn len(&self) -> usize {
        self.flux.first().map_or(0, |axes| axes[0].len())
    }
}

/// One chunk's rows, computed.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct ChunkField {
    /// The rows of the flight it holds (counted from the first row pushed).
    pub rows: Range<usize>,
    /// `A·β` (nT, the level not subtracted), the network's output included; NaN where it
    /// cannot be computed.
    pub field: Vec<f64>,
    /// The network's share of `field` (nT), with [`Setup::network`].
    pub learned: Option<Vec<f64>>,
    /// Whether each row lies outside what the calibration flew (all `false` without a coverage).
    pub outside: Vec<bool>,
    /// Each row's standard error (nT), with [`Setup::uncertainty`].
    pub sigma: Option<Vec<f64>>,
}

/// The compensator of one fit (see the module documentation).
pub struct ChunkCompensator<'m> {
    setup: Setup<'m>,
    fluxgates: usize,
    extras: usize,
    has_time: Option<bool>,
    conditioner: Option<Conditioner>,
    /// Conditioned rows not yet computed (and the one before them).
    ready: Conditioned,
    /// Rows pushed and not yet computed, chunk by chunk.
    chunks: VecDeque<Range<usize>>,
    /// The conditioned row before the first chunk not computed.
    before: Option<Vec<f64>>,
    pushed: usize,
}

impl<'m> ChunkCompensator<'m> {
    /// A compensator of `setup`'s model.
    pub fn new(setup: Setup<'m>) -> Self {
        Self {
            fluxgates: setup.model.design.fluxgates.max(1),
            extras: setup.model.design.extras.len(),
            setup,
            has_time: None,
            conditioner: None,
            ready: Conditioned::default(),
            chunks: VecDeque::new(),
            before: None,
            pushed: 0,
        }
    }

    /// The whole flight as one chunk.
    pub fn whole(self, rows: RawRows<'_>) -> ChunkField {
        let n = rows.len();
        let mut sources: Vec<&[f64]> = rows.flux.iter().flat_map(|axes| *axes).collect();
        sources.extend(&rows.extras);
        sources.extend(&rows.inputs);
        // A channel at a time: besides the flight and its conditioned channels, only one
        // channel's low-passed values are held.
        let columns = self.channels(false).into_iter().map(|channel| {
            let source = sources[channel.source];
            let mut one = Conditioner::new(vec![Channel {
                source: 0,
                ..channel
            }]);
            let mut column = one.push(&[source], n).columns.pop().unwrap_or_default();
            column.extend(one.finish().columns.pop().unwrap_or_default());
            column
        });
        self.compute_columns(columns.collect(), rows.tt, 0..n)
    }

    /// [`ChunkCompensator::whole`] for fluxgates already held as series: without a lag or a
    /// low-pass the channels are used as given, not copied (a 10⁷-row fluxgate is 240 MB).
    pub fn whole_series(
        self,
        flux: &[VectorSeries],
        extras: &[&[f64]],
        inputs: &[&[f64]],
        tt: Option<&[f64]>,
    ) -> ChunkField {
        let plain = Conditioner::new(self.channels(tt.is_some())).is_identity();
        if plain {
            let n = flux.first().map_or(0, VectorSeries::len);
            return self.compute_inputs(flux, (extras, inputs), tt, 0..n);
        }
        let axes = flux.iter().map(|f| [&f.x[..], &f.y[..], &f.z[..]]);
        let rows = RawRows {
            flux: axes.collect(),
            extras: extras.to_vec(),
            inputs: inputs.to_vec(),
            tt,
        };
        self.whole(rows)
    }

    /// Takes the next rows; gives back every chunk now computable, in order.
    pub fn push(&mut self, rows: RawRows<'_>) -> Vec<ChunkField> {
        let n = rows.len();
        if n == 0 {
            return Vec::new();
        }
        let has_time = *self.has_time.get_or_insert(rows.tt.is_some());
        let channels = self.channels(has_time);
        let conditioner = self
            .conditioner
            .get_or_insert_with(|| Conditioner::new(channels));
        let mut sources: Vec<&[f64]> = rows.flux.iter().flat_map(|axes| *axes).collect();
        sources.extend(&rows.extras);
        sources.extend(&rows.inputs);
        sources.extend(rows.tt.filter(|_| has_time));
        let conditioned = conditioner.push(&sources, n);
        self.append(conditioned);
        self.chunks.push_back(self.pushed..self.pushed + n);
        self.pushed += n;
        self.compute_ready(false)
    }

    /// Ends the flight: every chunk still held, computed.
    pub fn finish(&mut self) -> Vec<ChunkField> {
        if let Some(conditioner) = self.conditioner.as_mut() {
            let rest = conditioner.finish();
            self.append(rest);
        }
        self.compute_ready(true)
    }

    /// The conditioner's channels: each fluxgate's x, y, z read `lag_s` later, the extra
    /// channels conditioned as their specs say, and time as it is.
    fn channels(&self, has_time: bool) -> Vec<Channel> {
        let fs_hz = self.setup.fs_hz;
        let lag = Shift::new(self.setup.lag_s * fs_hz);
        let flux = (0..3 * self.fluxgates).map(|s| Channel::shifted(s, lag));
        let extras = self.setup.model.design.extras.iter().enumerate();
        let extras = extras.map(|(e, spec)| Channel {
            source: 3 * self.fluxgates + e,
            lowpass: spec.lowpass_hz.map(|hz| LowPass::new(hz, fs_hz)),
            shift: spec.shift(fs_hz),
        });
        let first_input = 3 * self.fluxgates + self.extras;
        let inputs = first_input..first_input + self.setup.network_channels;
        let inputs = inputs.map(|s| Channel::shifted(s, lag0()));
        let time_source = first_input + self.setup.network_channels;
        let time = has_time.then(|| Channel::shifted(time_source, lag0()));
        flux.chain(extras).chain(inputs).chain(time).collect()
    }

    fn append(&mut self, conditioned: Conditioned) {
        if self.ready.columns.is_empty() {
            self.ready = conditioned;
            return;
        }
        for (column, more) in self.ready.columns.iter_mut().zip(conditioned.columns) {
            column.extend(more);
        }
    }

    /// Computes the chunks whose rows and the row after them are conditioned (at the end of
    /// the flight, every chunk).
    fn compute_ready(&mut self, at_end: bool) -> Vec<ChunkField> {
        let mut out = Vec::new();
        while let Some(chunk) = self.chunks.front().cloned() {
            let ready_end = self.ready.start + self.ready.len();
            // The row after the chunk, for its last central difference, unless the flight ended.
            if ready_end < chunk.end + usize::from(!at_end) {
                break;
            }
            self.chunks.pop_front();
            out.push(self.compute_chunk(chunk, ready_end));
        }
        out
    }

    /// `chunk`, with the conditioned row before it and the one after it (when conditioned,
    /// below `ready_end`).
    fn compute_chunk(&mut self, chunk: Range<usize>, ready_end: usize) -> ChunkField {
        let offset = chunk.start - self.ready.start;
        let through = (chunk.end + 1).min(ready_end) - self.ready.start;
        let skip = usize::from(self.before.is_some());
        let mut columns: Vec<Vec<f64>> = (self.ready.columns.iter().enumerate())
            .map(|(c, column)| {
                let mut window = Vec::with_capacity(through - offset + 1);
                window.extend(self.before.as_ref().map(|row| row[c]));
                window.extend_from_slice(&column[offset..through]);
                window
            })
            .collect();
        let last = chunk.end - 1 - self.ready.start;
        self.before = Some(self.ready.columns.iter().map(|c| c[last]).collect());
        let drop = chunk.end - self.ready.start;
        self.ready.columns.iter_mut().for_each(|c| {
            c.drain(..drop);
        });
        self.ready.start = chunk.end;
        let tt = match self.has_time {
            Some(true) => columns.pop(),
            _ => None,
        };
        let mut field = self.compute_columns(columns, tt.as_deref(), skip..skip + chunk.len());
        field.rows = chunk;
        field
    }

    /// The conditioned `columns` (the channels' order, time left out) and time `tt` (s)
    /// computed, kept for `rows` of them.
    fn compute_columns(
        &self,
        mut columns: Vec<Vec<f64>>,
        tt: Option<&[f64]>,
        rows: Range<usize>,
    ) -> ChunkField {
        let mut extras = columns.split_off(3 * self.fluxgates);
        let inputs = extras.split_off(self.extras);
        let mut axes = columns.into_iter();
        let flux: Vec<VectorSeries> = (0..self.fluxgates)
            .map(|_| {
                let mut next = || axes.next().unwrap_or_default();
                let (x, y, z) = (next(), next(), next());
                VectorSeries::new(x, y, z)
            })
            .collect();
        let extras: Vec<&[f64]> = extras.iter().map(Vec::as_slice).collect();
        let inputs: Vec<&[f64]> = inputs.iter().map(Vec::as_slice).collect();
        self.compute_inputs(&flux, (&extras, &inputs), tt, rows)
    }

    /// The correction and trust of `rows` of conditioned fluxgates, extra channels and the
    /// network's channels.
    fn compute_inputs(
        &self,
        flux: &[VectorSeries],
        (extras, channels): (&[&[f64]], &[&[f64]]),
        tt: Option<&[f64]>,
        rows: Range<usize>,
    ) -> ChunkField {
        let setup = self.setup;
        let corrected: Vec<VectorSeries>;
        let flux = match setup.flux_offset_nt {
            Some(offset) if !flux.is_empty() => {
                let mut owned = flux.to_vec();
                owned[0].remove_offset(offset);
                corrected = owned;
                &corrected[..]
            }
            _ => flux,
        };
        let inputs = Fluxgates::from(flux).with_extras(extras.to_vec());
        let usable = inputs.finite_mask();
        let runs = contiguous_runs_with_step(&usable, tt, setup.median_step_s);
        let mut field = model_field_over_runs(inputs.clone(), &runs, setup.model, setup.fs_ratio);
        let mut outside = match setup.coverage {
            Some(coverage) => outside_over_runs(inputs.clone(), &runs, coverage, setup.fs_hz),
            None => vec![false; usable.len()],
        };
        let learned = match (setup.network, flux.first()) {
            (Some(network), Some(first)) => {
                let features = features(first, extras, channels);
                let learned = learned_over_rows(network, &features, &mut outside);
                field.iter_mut().zip(&learned).for_each(|(f, n)| *f += n);
                Some(learned)
            }
            _ => None,
        };
        // The compensated value's error: the correction's and what the model leaves.
        let sigma = setup.uncertainty.map(|u| {
            let design = setup.model.design;
            let mut sigma = sigma_over_runs(inputs, &runs, design, u, setup.fs_ratio);
            sigma.iter_mut().for_each(|s| *s = s.hypot(u.noise_nt));
            sigma
        });
        let keep = |v: Vec<f64>| match rows == (0..v.len()) {
            true => v,
            false => v[rows.clone()].to_vec(),
        };
        ChunkField {
            field: keep(field),
            learned: learned.map(keep),
            outside: outside[rows.clone()].to_vec(),
            sigma: sigma.map(keep),
            rows,
        }
    }
}

/// `network`'s output (nT) for each row of its input `columns`, marking in `outside` the rows
/// with an input beyond its training range.
fn learned_over_rows(network: &Network, columns: &[Vec<f64>], outside: &mut [bool]) -> Vec<f64> {
    let mut scratch = Scratch::new(network);
    let mut row = vec![0.0; columns.len()];
    (outside.iter_mut().enumerate())
        .map(|(r, out)| {
            row.iter_mut().zip(columns).for_each(|(v, c)| *v = c[r]);
            *out |= network.beyond_range(&row);
            network.evaluate_with(&row, &mut scratch)
        })
        .collect()
}

/// No shift.
fn lag0() -> Shift {
    Shift::new(0.0)
}

/// The running mean of a fit's `A·β` (nT) over a flight fed a chunk at a time, summed in row
/// order as the whole flight's mean is, and its count of rows without a result.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct LevelSum {
    sum: f64,
    n: usize,
    /// Rows without a result: no correction, or a scalar that is not usable.
    pub uncomputable: usize,
}

impl LevelSum {
    /// Adds a row's `A·β` (nT), whose scalar is usable or not.
    pub fn add(&mut self, field: f64, scalar_usable: bool) {
        if field.is_finite() {
            self.sum += field;
            self.n += 1;
        }
        if !(field.is_finite() && scalar_usable) {
            self.uncomputable += 1;
        }
    }

    /// The mean of the finite values added (nT); NaN when there are none.
    pub fn mean(&self) -> f64 {
        match self.n {
            0 => f64::NAN,
            n => self.sum / n as f64,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::design::Design;
    use crate::model::extra::ExtraChannel;
    use crate::model::magnitude::Magnitude;

    struct Flight {
        flux: VectorSeries,
        extra: Vec<f64>,
        tt: Vec<f64>,
    }

    /// A swinging fluxgate with holes, a current and a clock with a gap and a repeat.
    fn flight(n: usize) -> Flight {
        let angle = |k: usize| 0.3 * (k as f64 * 0.013).sin() + 0.1 * (k as f64 * 0.31).cos();
        let mut flux = VectorSeries::new(
            (0..n).map(|k| 20_000.0 * angle(k).cos()).collect(),
            (0..n).map(|k| 20_000.0 * angle(k).sin()).collect(),
            (0..n).map(|k| 45_000.0 + (k as f64 * 0.07).sin()).collect(),
        );
        flux.y[17] = f64::NAN;
        let mut extra: Vec<f64> = (0..n).map(|k| 5.0 + (k as f64 * 0.05).sin()).collect();
        extra[60] = f64::NAN;
        let mut tt: Vec<f64> = (0..n).map(|k| 0.1 * k as f64).collect();
        tt[90..].iter_mut().for_each(|t| *t += 3.0);
        tt[130] = tt[129];
        Flight { flux, extra, tt }
    }

    fn rows<'a>(f: &'a Flight, r: Range<usize>, extra: bool) -> RawRows<'a> {
        let flux = [
            &f.flux.x[r.clone()],
            &f.flux.y[r.clone()],
            &f.flux.z[r.clone()],
        ];
        RawRows {
            flux: vec![flux],
            extras: if extra {
                vec![&f.extra[r.clone()]]
            } else {
                vec![]
            },
            inputs: Vec::new(),
            tt: Some(&f.tt[r]),
        }
    }

    /// The correction of the whole flight conditioned series by series (the fluxgate by
    /// `fit::lag::shifted`, the extra channel by `ExtraChannel::condition`).
    fn series_field(f: &Flight, setup: Setup, extra: bool) -> Vec<f64> {
        let flux = crate::fit::lag::shifted(&f.flux, setup.lag_s, setup.fs_hz);
        let specs = &setup.model.design.extras;
        let extras: Vec<Vec<f64>> = match extra {
            true => vec![specs[0].condition(&f.extra, setup.fs_hz)],
            false => Vec::new(),
        };
        let inputs = Fluxgates::from(&flux).with_extras(extras.iter().map(Vec::as_slice).collect());
        let runs =
            contiguous_runs_with_step(&inputs.finite_mask(), Some(&f.tt), setup.median_step_s);
        model_field_over_runs(inputs, &runs, setup.model, setup.fs_ratio)
    }

    fn bits(v: &[f64]) -> Vec<u64> {
        v.iter().map(|x| x.to_bits()).collect()
    }

    /// Every split of the flight into chunks gives each row the bits of the whole flight,
    /// with a lag and a low-passed, lagged extra channel, for both magnitude models.
    #[test]
    fn chunks_of_any_size_give_the_whole_flights_bits() {
        let n = 200;
        let f = flight(n);
        for (terms, extra, lag_s) in [
            ("p,i,e", false, 0.0),
            ("p,i,e", true, 0.37),
            ("p,i", true, -1.2),
        ] {
            let mut design = Design::new(terms.parse().unwrap());
            if extra {
                design.extras = vec!["c:lowpass=0.5:lag=0.23".parse::<ExtraChannel>().unwrap()];
            }
            let beta: Vec<f64> = (0..design.width()).map(|k| 0.5 + k as f64).collect();
            for magnitude in [Magnitude::Linear, Magnitude::Exact] {
                let model = Model {
                    design: &design,
                    coefficients: &beta,
                    magnitude,
                };
                let setup = Setup {
                    lag_s,
                    median_step_s: Some(0.1),
                    ..Setup::new(model, 10.0, 1.0)
                };
                let whole = ChunkCompensator::new(setup).whole(rows(&f, 0..n, extra));
                assert_eq!(bits(&whole.field), bits(&series_field(&f, setup, extra)));
                assert!(whole.field.iter().filter(|v| v.is_finite()).count() > n / 2);
                for size in [1, 2, 3, 7, 64, 199] {
                    let mut engine = ChunkCompensator::new(setup);
                    let mut field = Vec::new();
                    let mut expected_start = 0;
                    let mut take = |chunks: Vec<ChunkField>| {
                        for c in chunks {
                            assert_eq!(c.rows.start, expected_start);
                            expected_start = c.rows.end;
                            field.extend(c.field);
                        }
                    };
                    for start in (0..n).step_by(size) {
                        take(engine.push(rows(&f, start..(start + size).min(n), extra)));
                    }
                    take(engine.finish());
                    assert_eq!(
                        bits(&field),
                        bits(&whole.field),
                        "{terms} {magnitude:?} {size}"
                    );
                }
            }
        }
    }

    /// The offset is taken out of the first fluxgate's readings however they arrive: whole
    /// series (no conditioning), whole rows with a lag, or chunk by chunk.
    #[test]
    fn a_fluxgate_offset_is_the_same_as_readings_without_it() {
        let n = 400;
        let f = flight(n);
        let offset = [1_500.0, -2_200.0, 900.0];
        let mut corrected = flight(n);
        corrected.flux.remove_offset(offset);
        let design = Design::new("p,i,e".parse().unwrap());
        let beta: Vec<f64> = (0..design.width()).map(|k| 1.0 + k as f64).collect();
        let model = Model {
            design: &design,
            coefficients: &beta,
            magnitude: Magnitude::Linear,
        };
        for lag_s in [0.0, 0.37] {
            let plain = Setup {
                lag_s,
                ..Setup::new(model, 10.0, 1.0)
            };
            let with_offset = Setup {
                flux_offset_nt: Some(offset),
                ..plain
            };
            let expected = ChunkCompensator::new(plain).whole_series(
                std::slice::from_ref(&corrected.flux),
                &[],
                &[],
                Some(&f.tt),
            );
            let got = ChunkCompensator::new(with_offset).whole_series(
                std::slice::from_ref(&f.flux),
                &[],
                &[],
                Some(&f.tt),
            );
            // Shifting then subtracting (what fit and compensation do) rounds differently from
            // the other order, by an ulp.
            let same = |a: &[f64], b: &[f64]| {
                a.len() == b.len()
                    && a.iter().zip(b).all(|(x, y)| {
                        (x.is_nan() && y.is_nan()) || (x - y).abs() <= 1e-12 * y.abs().max(1.0)
                    })
            };
            assert!(same(&got.field, &expected.field), "lag {lag_s}");
            let mut engine = ChunkCompensator::new(with_offset);
            let mut field = Vec::new();
            for start in (0..n).step_by(64) {
                let chunks = engine.push(rows(&f, start..(start + 64).min(n), false));
                field.extend(chunks.into_iter().flat_map(|c| c.field));
            }
            field.extend(engine.finish().into_iter().flat_map(|c| c.field));
            assert!(same(&field, &expected.field), "lag {lag_s}");
            // And the offset matters: without it the field differs.
            let raw = ChunkCompensator::new(plain).whole_series(
                std::slice::from_ref(&f.flux),
                &[],
                &[],
                Some(&f.tt),
            );
            assert_ne!(bits(&raw.field), bits(&expected.field));
        }
    }

    /// Memory is bounded: what is held is the chunk and the few rows the shifts read.
    #[test]
    fn only_a_few_rows_are_held_between_chunks() {
        let n = 1_000;
        let f = flight(n);
        let mut design = Design::new("p,i,e".parse().unwrap());
        design.extras = vec!["c:lowpass=0.5:lag=0.23".parse::<ExtraChannel>().unwrap()];
        let beta = vec![1.0; design.width()];
        let model = Model {
            design: &design,
            coefficients: &beta,
            magnitude: Magnitude::Linear,
        };
        let setup = Setup {
            lag_s: 0.37,
            ..Setup::new(model, 10.0, 1.0)
        };
        let mut engine = ChunkCompensator::new(setup);
        for start in (0..n).step_by(100) {
            engine.push(rows(&f, start..start + 100, true));
            // This chunk's rows conditioned so far, and no more.
            assert!(engine.ready.len() <= 100, "{}", engine.ready.len());
            assert!(engine.chunks.len() <= 1);
        }
    }

    #[test]
    fn the_level_sum_is_the_mean_of_finite_fields() {
        let mut sum = LevelSum::default();
        sum.add(1.0, true);
        sum.add(f64::NAN, true);
        sum.add(3.0, false);
        assert_eq!(sum.mean(), 2.0);
        assert_eq!(sum.uncomputable, 2);
    }
}
