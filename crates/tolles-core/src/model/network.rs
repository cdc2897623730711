//! A small feed-forward network that models what the linear Tolles-Lawson model leaves:
//! MagNav's "model 2b", a network added to a fixed linear model.
//!
//! ```
//! use tolles_core::model::network::{Activation, Layer, Network};
//!
//! // One input, one hidden unit: out = 2 nT · swish(x / 10)
//! let network = Network {
//!     inputs: vec!["cur_load".into()],
//!     input_mean: vec![0.0],
//!     input_scale: vec![10.0],
//!     output_mean_nt: 0.0,
//!     output_scale_nt: 2.0,
//!     activation: Activation::Swish,
//!     layers: vec![Layer::new(1, 1, vec![1.0], vec![0.0]), Layer::new(1, 1, vec![1.0], vec![0.0])],
//!     input_range: vec![[0.0, 40.0]], // the training rows' currents (A)
//! };
//! network.validate().unwrap();
//! let swish = |x: f64| x / (1.0 + (-x).exp());
//! assert!((network.evaluate(&[5.0]) - 2.0 * swish(0.5)).abs() < 1e-12);
//! assert!(network.evaluate(&[f64::NAN]).is_nan());
//! // Beyond the range the network holds the range's end, and says the row is outside it.
//! assert_eq!(network.evaluate(&[90.0]), network.evaluate(&[40.0]));
//! assert!(network.beyond_range(&[90.0]) && !network.beyond_range(&[49.0]));
//! ```
//!
//! Each input is normalised as `(x − mean) / scale` (the training rows' mean and standard
//! deviation), the hidden layers apply the activation, the last layer is linear, and its output
//! `y` becomes `output_mean_nt + output_scale_nt · y` (nT). Weights are stored row-major, one row
//! per output unit, so a file is plain numbers a reader in any language can evaluate.

use crate::model::extra::ExtraChannel;
use crate::model::vector::VectorSeries;
use serde::{Deserialize, Serialize};
use std::fmt;

/// The hidden layers' activation.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "lowercase")]
pub enum Activation {
    /// `x · σ(x)` (MagNav's default).
    #[default]
    Swish,
    /// `tanh x`.
    Tanh,
    /// `max(x, 0)`.
    Relu,
}

impl Activation {
    /// The activation of `x`.
    #[inline]
    pub fn value(self, x: f64) -> f64 {
        match self {
            Activation::Swish => x / (1.0 + (-x).exp()),
            Activation::Tanh => x.tanh(),
            Activation::Relu => x.max(0.0),
        }
    }

    /// Its derivative at `x`.
    #[inline]
    pub fn slope(self, x: f64) -> f64 {
        match self {
            Activation::Swish => {
                let s = 1.0 / (1.0 + (-x).exp());
                s * (1.0 + x * (1.0 - s))
            }
            Activation::Tanh => 1.0 - x.tanh().powi(2),
            Activation::Relu => f64::from(u8::from(x > 0.0)),
        }
    }
}

impl std::str::FromStr for Activation {
    type Err = String;

    /// `swish`, `tanh` or `relu`.
    fn from_str(text: &str) -> Result<Self, String> {
        match text.trim().to_ascii_lowercase().as_str() {
            "swish" => Ok(Activation::Swish),
            "tanh" => Ok(Activation::Tanh),
            "relu" => Ok(Activation::Relu),
            _ => Err(format!("expected swish, tanh or relu, got {text:?}")),
        }
    }
}

impl fmt::Display for Activation {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let name = match self {
            Activation::Swish => "swish",
            Activation::Tanh => "tanh",
            Activation::Relu => "relu",
        };
        f.write_str(name)
    }
}

/// One dense layer: `out = W·in + b`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Layer {
    /// Inputs per unit.
    pub inputs: usize,
    /// Units.
    pub outputs: usize,
    /// `outputs × inputs` weights, row-major (one row per unit).
    pub weights: Vec<f64>,
    /// One bias per unit.
    pub bias: Vec<f64>,
}

impl Layer {
    /// A layer of `outputs` units on `inputs` inputs with the given weights (row-major) and
    /// biases.
    pub fn new(inputs: usize, outputs: usize, weights: Vec<f64>, bias: Vec<f64>) -> Self {
        Self {
            inputs,
            outputs,
            weights,
            bias,
        }
    }

    /// `W·x + b` into `out`.
    #[inline]
    pub fn apply(&self, x: &[f64], out: &mut [f64]) {
        for ((o, row), b) in out
            .iter_mut()
            .zip(self.weights.chunks_exact(self.inputs))
            .zip(&self.bias)
        {
            *o = b + row.iter().zip(x).map(|(w, v)| w * v).sum::<f64>();
        }
    }
}

/// A network and what it needs to be applied: its inputs' names and normalisation.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Network {
    /// The input channels, in order (e.g. `flux_a_dx`, `cur_load`); the caller supplies values
    /// in this order.
    pub inputs: Vec<String>,
    /// Per input, the mean subtracted (the input's unit).
    pub input_mean: Vec<f64>,
    /// Per input, the scale divided by (the input's unit; positive).
    pub input_scale: Vec<f64>,
    /// Added to the scaled output (nT).
    pub output_mean_nt: f64,
    /// The output's scale (nT per unit of the last layer's output; positive).
    pub output_scale_nt: f64,
    /// The hidden layers' activation.
    pub activation: Activation,
    /// The layers, first to last; the last has one unit and no activation.
    pub layers: Vec<Layer>,
    /// Per input, the range the training rows spanned (the input's unit), `[lowest, highest]`;
    /// an input beyond it is taken at its end, so a network never extrapolates past what it
    /// was trained on. Empty in files written before: no limit.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub input_range: Vec<[f64; 2]>,
}

/// How far beyond its training range, as a share of the range's width, an input makes a row
/// outside what the calibration flew ([`Network::beyond_range`]), unless the input's training
/// deviation is wider.
pub const RANGE_MARGIN: f64 = 0.1;

/// Why a network cannot be used.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum NetworkError {
    /// Its numbers do not fit together (a damaged or hand-edited file).
    #[error("network: {0}")]
    Malformed(String),
    /// Training found too few usable rows.
    #[error("network: {usable} usable training rows, at least {needed} needed")]
    TooFewRows {
        /// Rows with every input and the target finite.
        usable: usize,
        /// The least the training asks for.
        needed: usize,
    },
}

/// The largest output mean and scale a network may have (nT): an aircraft field beyond this
/// describes no aircraft, and 10³⁰⁰ would pass every finite check and be written as data.
const MAX_OUTPUT_NT: f64 = 100_000.0;
/// The range of an input's scale (its channel's unit): a subnormal scale turns every input into
/// an infinity, which then reads as missing data.
const MIN_SCALE: f64 = 1e-9;
const MAX_SCALE: f64 = 1e12;
/// The largest input mean (its channel's unit).
const MAX_MEAN: f64 = 1e12;

impl Network {
    /// Checks shapes and numbers: one mean and positive scale per input, each layer's input
    /// count that of the layer before, one output unit, finite weights.
    pub fn validate(&self) -> Result<(), NetworkError> {
        let bad = |what: String| Err(NetworkError::Malformed(what));
        let n = self.inputs.len();
        if self.input_mean.len() != n || self.input_scale.len() != n {
            return bad(format!(
                "{n} inputs but {} means and {} scales",
                self.input_mean.len(),
                self.input_scale.len()
            ));
        }
        if let Some(k) = (self.input_mean.iter().zip(&self.input_scale))
            .position(|(m, s)| !(m.abs() <= MAX_MEAN && (MIN_SCALE..=MAX_SCALE).contains(s)))
        {
            return bad(format!(
                "input {} needs a mean within ±{MAX_MEAN:e} and a scale within {MIN_SCALE:e}..={MAX_SCALE:e} \
                 (its channel's unit), got {} and {}",
                self.inputs[k], self.input_mean[k], self.input_scale[k]
            ));
        }
        let range_ok = |[low, high]: [f64; 2]| low.is_finite() && high.is_finite() && low <= high;
        if !self.input_range.is_empty() && self.input_range.len() != n
            || !self.input_range.iter().all(|r| range_ok(*r))
        {
            return bad(format!(
                "{n} inputs but {} ranges, or a range that is not two finite numbers in order",
                self.input_range.len()
            ));
        }
        let (mean, scale) = (self.output_mean_nt, self.output_scale_nt);
        if !(mean.abs() <= MAX_OUTPUT_NT && scale > 0.0 && scale <= MAX_OUTPUT_NT) {
            return bad(format!(
                "the output needs a mean within ±{MAX_OUTPUT_NT} nT and a scale within \
                 0..={MAX_OUTPUT_NT} nT, got {mean:e} and {scale:e} nT"
            ));
        }
        let mut width = n;
        for (k, layer) in self.layers.iter().enumerate() {
            if layer.inputs != width {
                return bad(format!(
                    "layer {k} takes {} inputs, the layer before gives {width}",
                    layer.inputs
                ));
            }
            if layer.weights.len() != layer.inputs * layer.outputs
                || layer.bias.len() != layer.outputs
            {
                return bad(format!(
                    "layer {k} is {}×{} but holds {} weights and {} biases",
                    layer.outputs,
                    layer.inputs,
                    layer.weights.len(),
                    layer.bias.len()
                ));
            }
            if layer
                .weights
                .iter()
                .chain(&layer.bias)
                .any(|w| !w.is_finite())
            {
                return bad(format!(
                    "layer {k} holds a weight that is not a finite number"
                ));
            }
            width = layer.outputs;
        }
        if self.layers.is_empty() || width != 1 {
            return bad(format!("the last layer gives {width} outputs, not 1"));
        }
        Ok(())
    }

    /// The correction (nT) for one row of inputs in [`Network::inputs`]' order; NaN when one
    /// is not finite.
    pub fn evaluate(&self, x: &[f64]) -> f64 {
        let mut scratch = Scratch::new(self);
        self.evaluate_with(x, &mut scratch)
    }

    /// [`Network::evaluate`] with room for the layers' values, so a loop allocates nothing.
    pub fn evaluate_with(&self, x: &[f64], scratch: &mut Scratch) -> f64 {
        if x.len() != self.inputs.len() || x.iter().any(|v| !v.is_finite()) {
            return f64::NAN;
        }
        let input = &mut scratch.a;
        input.clear();
        let within = |k: usize, v: f64| match self.input_range.get(k) {
            Some([low, high]) => v.clamp(*low, *high),
            None => v,
        };
        let normalised = (x
            .iter()
            .enumerate()
            .zip(&self.input_mean)
            .zip(&self.input_scale))
        .map(|(((k, v), m), s)| (within(k, *v) - m) / s);
        input.extend(normalised);
        let last = self.layers.len() - 1;
        for (k, layer) in self.layers.iter().enumerate() {
            scratch.b.resize(layer.outputs, 0.0);
            layer.apply(&scratch.a, &mut scratch.b);
            if k < last {
                scratch
                    .b
                    .iter_mut()
                    .for_each(|v| *v = self.activation.value(*v));
            }
            std::mem::swap(&mut scratch.a, &mut scratch.b);
        }
        self.output_mean_nt + self.output_scale_nt * scratch.a[0]
    }

    /// The correction (nT) of every row of `columns` (one per input, all as long).
    pub fn evaluate_rows(&self, columns: &[&[f64]]) -> Vec<f64> {
        let rows = columns.first().map_or(0, |c| c.len());
        let mut scratch = Scratch::new(self);
        let mut x = vec![0.0; columns.len()];
        (0..rows)
            .map(|r| {
                x.iter_mut().zip(columns).for_each(|(v, c)| *v = c[r]);
                self.evaluate_with(&x, &mut scratch)
            })
            .collect()
    }

    /// Whether any input of the row `x` lies beyond its training range by more than
    /// [`RANGE_MARGIN`] of the range's width or one standard deviation of its training values
    /// ([`Network::input_scale`]), whichever is more: the network holds it at the range's end
    /// there, and the row is outside what the calibration flew. (The deviation keeps a
    /// magnitude a few nT past a calibration's narrow span from counting.)
    pub fn beyond_range(&self, x: &[f64]) -> bool {
        let ranges = self.input_range.iter().zip(&self.input_scale);
        (x.iter().zip(ranges)).any(|(v, ([low, high], scale))| {
            let margin = (RANGE_MARGIN * (high - low)).max(*scale);
            *v < low - margin || *v > high + margin
        })
    }

    /// Units of each hidden layer, first to last (the layers but the one-unit output).
    pub fn hidden_units(&self) -> Vec<usize> {
        let hidden = self.layers.len().saturating_sub(1);
        self.layers[..hidden].iter().map(|l| l.outputs).collect()
    }

    /// Number of weights and biases.
    pub fn parameters(&self) -> usize {
        self.layers
            .iter()
            .map(|l| l.weights.len() + l.bias.len())
            .sum()
    }
}

/// The inputs of a network of `tolles fit --network`, a column each: the fluxgate's direction
/// cosines `B̂x, B̂y, B̂z` and magnitude `|B|` (nT), the extra channels as conditioned (their
/// units), then the network's own `channels` (their units). Named by [`feature_names`].
pub fn features(flux: &VectorSeries, extras: &[&[f64]], channels: &[&[f64]]) -> Vec<Vec<f64>> {
    let n = flux.len();
    let magnitude: Vec<f64> = (0..n).map(|k| flux.magnitude(k)).collect();
    let cosine = |axis: &[f64]| axis.iter().zip(&magnitude).map(|(v, m)| v / m).collect();
    let mut columns: Vec<Vec<f64>> =
        vec![cosine(&flux.x), cosine(&flux.y), cosine(&flux.z), magnitude];
    columns.extend(extras.iter().chain(channels).map(|c| c.to_vec()));
    columns
}

/// The names of [`features`]' columns for the fluxgate `vector`, the extra channels `extras`
/// and the network's `channels`: `flux_a:cos_x`, `flux_a:cos_y`, `flux_a:cos_z`,
/// `flux_a:magnitude`, each extra channel as its spec, then each channel.
pub fn feature_names(vector: &str, extras: &[ExtraChannel], channels: &[String]) -> Vec<String> {
    let mut names: Vec<String> = ["cos_x", "cos_y", "cos_z", "magnitude"]
        .iter()
        .map(|part| format!("{vector}:{part}"))
        .collect();
    names.extend(extras.iter().map(ExtraChannel::to_string));
    names.extend(channels.iter().cloned());
    names
}

/// Room for a network's layer values while evaluating it.
#[derive(Debug, Clone, Default)]
pub struct Scratch {
    a: Vec<f64>,
    b: Vec<f64>,
}

impl Scratch {
    /// Room for `network`.
    pub fn new(network: &Network) -> Self {
        let widest = network
            .layers
            .iter()
            .map(|l| l.outputs)
            .chain([network.inputs.len()])
            .max();
        let widest = widest.unwrap_or(1);
        Self {
            a: Vec::with_capacity(widest),
            b: Vec::with_capacity(widest),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn two_inputs() -> Network {
        Network {
            inputs: vec!["a".into(), "b".into()],
            input_mean: vec![1.0, 0.0],
            input_scale: vec![2.0, 1.0],
            output_mean_nt: 0.5,
            output_scale_nt: 3.0,
            activation: Activation::Tanh,
            layers: vec![
                Layer::new(2, 2, vec![1.0, -1.0, 0.5, 0.25], vec![0.0, 0.1]),
                Layer::new(2, 1, vec![2.0, -1.0], vec![0.3]),
            ],
            input_range: Vec::new(),
        }
    }

    #[test]
    fn a_network_evaluates_as_written_out_by_hand() {
        let net = two_inputs();
        net.validate().unwrap();
        assert_eq!(net.hidden_units(), [2]);
        let (a, b): (f64, f64) = ((3.0 - 1.0) / 2.0, 4.0);
        let h = [(a - b).tanh(), (0.5 * a + 0.25 * b + 0.1).tanh()];
        let expected = 0.5 + 3.0 * (2.0 * h[0] - h[1] + 0.3);
        assert!((net.evaluate(&[3.0, 4.0]) - expected).abs() < 1e-12);
        let rows = net.evaluate_rows(&[&[3.0, f64::NAN], &[4.0, 1.0]]);
        assert_eq!(rows[0], net.evaluate(&[3.0, 4.0]));
        assert!(rows[1].is_nan());
    }

    #[test]
    fn damaged_networks_are_refused_with_what_is_wrong() {
        type Damage = fn(&mut Network);
        let mut cases: Vec<(Damage, &str)> = Vec::new();
        cases.push((|n| n.input_scale[1] = 0.0, "input b"));
        cases.push((
            |n| n.layers[0].weights.pop().map(drop).unwrap_or(()),
            "holds 3 weights",
        ));
        cases.push((|n| n.layers[1].inputs = 3, "layer 1 takes 3"));
        cases.push((|n| n.layers[1].bias[0] = f64::NAN, "not a finite number"));
        cases.push((|n| n.input_mean.push(0.0), "2 inputs but 3 means"));
        cases.push((|n| n.layers.truncate(1), "gives 2 outputs"));
        cases.push((|n| n.output_scale_nt = -1.0, "output"));
        // Hostile round 4: finite but absurd numbers that passed as a model.
        cases.push((|n| n.output_scale_nt = 1e300, "got 5e-1 and 1e300 nT"));
        cases.push((|n| n.output_mean_nt = -1e300, "output needs a mean"));
        cases.push((|n| n.input_scale[0] = 1e-320, "input a needs"));
        cases.push((
            |n| n.input_range = vec![[0.0, 1.0]],
            "2 inputs but 1 ranges",
        ));
        cases.push((|n| n.input_range = vec![[0.0, 1.0], [2.0, 1.0]], "in order"));
        for (damage, said) in cases {
            let mut net = two_inputs();
            damage(&mut net);
            let message = net.validate().unwrap_err().to_string();
            assert!(message.contains(said), "{message}");
        }
    }

    #[test]
    fn slopes_are_the_derivatives_of_the_activations() {
        for activation in [Activation::Swish, Activation::Tanh, Activation::Relu] {
            for x in [-2.3, -0.4, 0.7, 1.9] {
                let h = 1e-6;
                let numeric = (activation.value(x + h) - activation.value(x - h)) / (2.0 * h);
                assert!(
                    (numeric - activation.slope(x)).abs() < 1e-7,
                    "{activation} {x}"
                );
            }
            assert_eq!(
                activation.to_string().parse::<Activation>().unwrap(),
                activation
            );
        }
    }
}
