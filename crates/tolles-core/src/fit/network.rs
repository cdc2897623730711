//! Training a [`Network`] on what the linear model leaves, with held-out rows for early
//! stopping: mini-batch Adam on the mean squared error, from a fixed seed, on one thread, so
//! the same data and seed give the same weights bit for bit.
//!
//! ```
//! use tolles_core::fit::network::{train, NetworkSettings};
//!
//! // A residual that is a saturating function of a load current (A): no linear term has it.
//! let current: Vec<f64> = (0..2_000).map(|k| 20.0 * ((k as f64) * 0.01).sin()).collect();
//! let residual: Vec<f64> = current.iter().map(|i| 5.0 * (i / 5.0).tanh()).collect();
//! let held_out: Vec<bool> = (0..2_000).map(|k| k % 5 == 0).collect();
//! let trained = train(&["cur_load".into()], &[&current], &residual, &held_out, &NetworkSettings::default()).unwrap();
//! assert!(trained.validation_rms_nt < 0.1 * trained.baseline_rms_nt);
//! ```

use crate::model::network::{Activation, Layer, Network, NetworkError};
use rand::seq::SliceRandom;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// How to train.
#[derive(Debug, Clone, PartialEq)]
pub struct NetworkSettings {
    /// Units of each hidden layer (MagNav's default: one layer of 8).
    pub hidden: Vec<usize>,
    /// The hidden layers' activation.
    pub activation: Activation,
    /// Adam's step size (on inputs and target scaled to unit deviation).
    pub learning_rate: f64,
    /// Rows per mini-batch.
    pub batch_rows: usize,
    /// The most passes over the training rows.
    pub max_epochs: usize,
    /// Passes without a better held-out error before training stops.
    pub patience: usize,
    /// The seed of the initial weights and the order of the rows.
    pub seed: u64,
}

impl Default for NetworkSettings {
    fn default() -> Self {
        Self {
            hidden: vec![8],
            activation: Activation::Swish,
            learning_rate: 0.01,
            batch_rows: 64,
            max_epochs: 200,
            patience: 15,
            seed: 0,
        }
    }
}

/// A trained network and how well it did.
#[derive(Debug, Clone, PartialEq)]
pub struct Trained {
    /// The weights of the epoch with the smallest held-out error.
    pub network: Network,
    /// Passes made over the training rows.
    pub epochs: usize,
    /// The pass whose weights were kept (1-based).
    pub best_epoch: usize,
    /// RMS of target − network on the training rows (nT).
    pub training_rms_nt: f64,
    /// RMS of target − network on the held-out rows (nT).
    pub validation_rms_nt: f64,
    /// RMS of the target on the held-out rows about the training rows' mean (nT): what no
    /// network leaves.
    pub baseline_rms_nt: f64,
}

/// Trains a network mapping `columns` (one per input, named `names`) to `target` (nT) on the
/// rows not `held_out`, stopping when the held-out rows' error has not improved for
/// [`NetworkSettings::patience`] passes. Rows with a non-finite input or target are left out.
pub fn train(
    names: &[String],
    columns: &[&[f64]],
    target: &[f64],
    held_out: &[bool],
    settings: &NetworkSettings,
) -> Result<Trained, NetworkError> {
    let usable = |r: usize| target[r].is_finite() && columns.iter().all(|c| c[r].is_finite());
    let (mut fit_rows, mut check_rows) = (Vec::new(), Vec::new());
    for r in (0..target.len()).filter(|&r| usable(r)) {
        match held_out.get(r).copied().unwrap_or(false) {
            true => check_rows.push(r),
            false => fit_rows.push(r),
        }
    }
    let widths: Vec<usize> = std::iter::once(columns.len())
        .chain(settings.hidden.iter().copied())
        .chain([1])
        .collect();
    let parameters: usize = widths.windows(2).map(|w| w[0] * w[1] + w[1]).sum();
    let needed = (2 * parameters).max(50);
    if fit_rows.len() < needed || check_rows.len() < 10 {
        return Err(NetworkError::TooFewRows {
            usable: fit_rows.len().min(check_rows.len() * 10),
            needed,
        });
    }
    let (input_mean, input_scale): (Vec<f64>, Vec<f64>) = columns
        .iter()
        .map(|c| mean_and_deviation(c, &fit_rows))
        .unzip();
    let (output_mean_nt, output_scale_nt) = mean_and_deviation(target, &fit_rows);
    let normalise = |rows: &[usize]| -> Samples {
        let mut x = Vec::with_capacity(rows.len() * columns.len());
        for &r in rows {
            let row = (columns.iter().zip(&input_mean).zip(&input_scale))
                .map(|((c, m), s)| (c[r] - m) / s);
            x.extend(row);
        }
        let y = rows
            .iter()
            .map(|&r| (target[r] - output_mean_nt) / output_scale_nt)
            .collect();
        Samples {
            x,
            y,
            width: columns.len(),
        }
    };
    let (fit_set, check_set) = (normalise(&fit_rows), normalise(&check_rows));
    let mut rng = ChaCha8Rng::seed_from_u64(settings.seed);
    let mut net = Net::new(&widths, settings.activation, &mut rng);
    let mut adam = Adam::new(net.parameters.len(), settings.learning_rate);
    let (mut best, mut best_error, mut best_epoch) =
        (net.parameters.clone(), net.mse(&check_set), 0);
    let mut order: Vec<usize> = (0..fit_set.y.len()).collect();
    let mut gradient = vec![0.0; net.parameters.len()];
    let mut epochs = 0;
    while epochs < settings.max_epochs && epochs - best_epoch < settings.patience.max(1) {
        epochs += 1;
        order.shuffle(&mut rng);
        for batch in order.chunks(settings.batch_rows.max(1)) {
            net.gradient(&fit_set, batch, &mut gradient);
            adam.step(&mut net.parameters, &gradient);
        }
        let error = net.mse(&check_set);
        if error < best_error {
            (best, best_error, best_epoch) = (net.parameters.clone(), error, epochs);
        }
    }
    net.parameters = best;
    let mut rms = |set: &Samples| net.mse(set).sqrt() * output_scale_nt;
    let baseline =
        (check_set.y.iter().map(|y| y * y).sum::<f64>() / check_set.y.len() as f64).sqrt();
    let (training_rms_nt, validation_rms_nt) = (rms(&fit_set), rms(&check_set));
    Ok(Trained {
        training_rms_nt,
        validation_rms_nt,
        baseline_rms_nt: baseline * output_scale_nt,
        network: Network {
            input_range: columns.iter().map(|c| range(c, &fit_rows)).collect(),
            ..net.into_network(
                names,
                input_mean,
                input_scale,
                output_mean_nt,
                output_scale_nt,
            )
        },
        epochs,
        best_epoch: best_epoch.max(1),
    })
}

/// The lowest and highest of `values` at `rows` (not empty).
fn range(values: &[f64], rows: &[usize]) -> [f64; 2] {
    let at = rows.iter().map(|&r| values[r]);
    [
        at.clone().fold(f64::INFINITY, f64::min),
        at.fold(f64::NEG_INFINITY, f64::max),
    ]
}

/// The mean and standard deviation of `values` at `rows`; a deviation of zero is taken as 1.
fn mean_and_deviation(values: &[f64], rows: &[usize]) -> (f64, f64) {
    let n = rows.len() as f64;
    let mean = rows.iter().map(|&r| values[r]).sum::<f64>() / n;
    let variance = rows
        .iter()
        .map(|&r| (values[r] - mean).powi(2))
        .sum::<f64>()
        / n;
    let deviation = variance.sqrt();
    (mean, if deviation > 0.0 { deviation } else { 1.0 })
}

/// Normalised rows: inputs row-major, `width` per row, and targets.
struct Samples {
    x: Vec<f64>,
    y: Vec<f64>,
    width: usize,
}

impl Samples {
    fn row(&self, r: usize) -> &[f64] {
        &self.x[r * self.width..(r + 1) * self.width]
    }
}

/// The network while it trains: every weight and bias in one vector, layer by layer (each
/// layer's weights row-major, then its biases), as Adam updates them.
struct Net {
    widths: Vec<usize>,
    activation: Activation,
    parameters: Vec<f64>,
    /// Per layer, its pre-activations and outputs for one row.
    before: Vec<Vec<f64>>,
    after: Vec<Vec<f64>>,
    delta: Vec<Vec<f64>>,
}

impl Net {
    /// Glorot-uniform weights, zero biases.
    fn new(widths: &[usize], activation: Activation, rng: &mut ChaCha8Rng) -> Self {
        let mut parameters = Vec::new();
        for w in widths.windows(2) {
            let limit = (6.0 / (w[0] + w[1]) as f64).sqrt();
            parameters.extend((0..w[0] * w[1]).map(|_| rng.random_range(-limit..limit)));
            parameters.extend(std::iter::repeat_n(0.0, w[1]));
        }
        let per_layer = || widths.iter().map(|&n| vec![0.0; n]).collect::<Vec<_>>();
        Self {
            widths: widths.to_vec(),
            activation,
            parameters,
            before: per_layer(),
            after: per_layer(),
            delta: per_layer(),
        }
    }

    /// Where layer `k`'s weights start in [`Net::parameters`].
    fn offsets(&self) -> Vec<usize> {
        let mut at = 0;
        let mut out = Vec::with_capacity(self.widths.len());
        for w in self.widths.windows(2) {
            out.push(at);
            at += w[0] * w[1] + w[1];
        }
        out
    }

    /// The output for row `x`, keeping each layer's values for [`Net::gradient`].
    fn forward(&mut self, x: &[f64], offsets: &[usize]) -> f64 {
        self.after[0].copy_from_slice(x);
        let layers = self.widths.len() - 1;
        for k in 0..layers {
            let (n_in, n_out) = (self.widths[k], self.widths[k + 1]);
            let weights = &self.parameters[offsets[k]..offsets[k] + n_in * n_out];
            let bias =
                &self.parameters[offsets[k] + n_in * n_out..offsets[k] + n_in * n_out + n_out];
            let (done, rest) = self.after.split_at_mut(k + 1);
            let input = &done[k];
            for j in 0..n_out {
                let row = &weights[j * n_in..(j + 1) * n_in];
                let z = bias[j] + row.iter().zip(input).map(|(w, v)| w * v).sum::<f64>();
                self.before[k + 1][j] = z;
                rest[0][j] = if k + 1 < layers {
                    self.activation.value(z)
                } else {
                    z
                };
            }
        }
        self.after[layers][0]
    }

    /// The mean over `batch` of the squared error's gradient (half the squared error per row).
    fn gradient(&mut self, set: &Samples, batch: &[usize], gradient: &mut [f64]) {
        gradient.fill(0.0);
        let offsets = self.offsets();
        let layers = self.widths.len() - 1;
        for &r in batch {
            let out = self.forward(set.row(r), &offsets);
            self.delta[layers][0] = out - set.y[r];
            for k in (0..layers).rev() {
                let (n_in, n_out) = (self.widths[k], self.widths[k + 1]);
                let at = offsets[k];
                for j in 0..n_out {
                    let d = self.delta[k + 1][j];
                    let row = &mut gradient[at + j * n_in..at + (j + 1) * n_in];
                    row.iter_mut()
                        .zip(&self.after[k])
                        .for_each(|(g, v)| *g += d * v);
                    gradient[at + n_in * n_out + j] += d;
                }
                if k > 0 {
                    for i in 0..n_in {
                        let back: f64 = (0..n_out)
                            .map(|j| self.parameters[at + j * n_in + i] * self.delta[k + 1][j])
                            .sum();
                        self.delta[k][i] = back * self.activation.slope(self.before[k][i]);
                    }
                }
            }
        }
        let scale = 1.0 / batch.len() as f64;
        gradient.iter_mut().for_each(|g| *g *= scale);
    }

    /// Mean squared error over `set` (normalised units).
    fn mse(&mut self, set: &Samples) -> f64 {
        let offsets = self.offsets();
        let sum: f64 = (0..set.y.len())
            .map(|r| (self.forward(set.row(r), &offsets) - set.y[r]).powi(2))
            .sum();
        sum / set.y.len() as f64
    }

    fn into_network(
        self,
        names: &[String],
        input_mean: Vec<f64>,
        input_scale: Vec<f64>,
        output_mean_nt: f64,
        output_scale_nt: f64,
    ) -> Network {
        let offsets = self.offsets();
        let layers = (self.widths.windows(2).zip(offsets))
            .map(|(w, at)| {
                let weights = self.parameters[at..at + w[0] * w[1]].to_vec();
                let bias = self.parameters[at + w[0] * w[1]..at + w[0] * w[1] + w[1]].to_vec();
                Layer::new(w[0], w[1], weights, bias)
            })
            .collect();
        Network {
            inputs: names.to_vec(),
            input_mean,
            input_scale,
            output_mean_nt,
            output_scale_nt,
            activation: self.activation,
            layers,
            input_range: Vec::new(),
        }
    }
}

/// Adam's moment estimates.
struct Adam {
    rate: f64,
    m: Vec<f64>,
    v: Vec<f64>,
    steps: i32,
}

impl Adam {
    const BETA1: f64 = 0.9;
    const BETA2: f64 = 0.999;
    const EPSILON: f64 = 1e-8;

    fn new(parameters: usize, rate: f64) -> Self {
        Self {
            rate,
            m: vec![0.0; parameters],
            v: vec![0.0; parameters],
            steps: 0,
        }
    }

    fn step(&mut self, parameters: &mut [f64], gradient: &[f64]) {
        self.steps += 1;
        let c1 = 1.0 - Self::BETA1.powi(self.steps);
        let c2 = 1.0 - Self::BETA2.powi(self.steps);
        for (((p, g), m), v) in parameters
            .iter_mut()
            .zip(gradient)
            .zip(&mut self.m)
            .zip(&mut self.v)
        {
            *m = Self::BETA1 * *m + (1.0 - Self::BETA1) * g;
            *v = Self::BETA2 * *v + (1.0 - Self::BETA2) * g * g;
            *p -= self.rate * (*m / c1) / ((*v / c2).sqrt() + Self::EPSILON);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Two inputs and a target no linear model holds: a saturating load and a turning flap.
    fn data(n: usize) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
        let load: Vec<f64> = (0..n)
            .map(|k| 15.0 + 15.0 * (k as f64 * 0.013).sin())
            .collect();
        let flap: Vec<f64> = (0..n).map(|k| 20.0 * (k as f64 * 0.0071).cos()).collect();
        let target = (load.iter().zip(&flap))
            .map(|(i, a)| 8.0 * (i / 10.0).tanh() + 3.0 * a.to_radians().cos())
            .collect();
        (load, flap, target)
    }

    fn held_out(n: usize) -> Vec<bool> {
        (0..n).map(|k| (k / 100) % 5 == 4).collect()
    }

    #[test]
    fn the_gradient_is_the_derivative_of_the_error() {
        let (load, flap, target) = data(40);
        let set = Samples {
            x: load
                .iter()
                .zip(&flap)
                .flat_map(|(a, b)| [a / 30.0, b / 20.0])
                .collect(),
            y: target.iter().map(|t| t / 10.0).collect(),
            width: 2,
        };
        for activation in [Activation::Swish, Activation::Tanh] {
            let mut net = Net::new(&[2, 5, 3, 1], activation, &mut ChaCha8Rng::seed_from_u64(3));
            let batch: Vec<usize> = (0..40).collect();
            let mut gradient = vec![0.0; net.parameters.len()];
            net.gradient(&set, &batch, &mut gradient);
            for (p, analytic) in gradient.iter().enumerate() {
                let h = 1e-6;
                let keep = net.parameters[p];
                net.parameters[p] = keep + h;
                let up = net.mse(&set) / 2.0;
                net.parameters[p] = keep - h;
                let down = net.mse(&set) / 2.0;
                net.parameters[p] = keep;
                let numeric = (up - down) / (2.0 * h);
                assert!(
                    (numeric - analytic).abs() < 1e-6,
                    "{activation} {p}: {numeric} vs {}",
                    gradient[p]
                );
            }
        }
    }

    #[test]
    fn a_non_linear_residual_is_learnt_and_held_out_rows_judge_it() {
        let n = 5_000;
        let (load, flap, target) = data(n);
        let names = ["cur_load".to_string(), "pos_flap".to_string()];
        let trained = train(
            &names,
            &[&load, &flap],
            &target,
            &held_out(n),
            &NetworkSettings::default(),
        )
        .unwrap();
        println!(
            "held-out rms {:.4} nT of {:.4} nT, {} epochs (best {})",
            trained.validation_rms_nt, trained.baseline_rms_nt, trained.epochs, trained.best_epoch
        );
        assert!(trained.validation_rms_nt < 0.05 * trained.baseline_rms_nt);
        trained.network.validate().unwrap();
        let applied = trained.network.evaluate_rows(&[&load, &flap]);
        let rms = (applied
            .iter()
            .zip(&target)
            .map(|(a, t)| (a - t).powi(2))
            .sum::<f64>()
            / n as f64)
            .sqrt();
        assert!((rms - trained.training_rms_nt).abs() < 0.5 * trained.training_rms_nt + 1e-3);
    }

    #[test]
    fn the_same_seed_gives_the_same_weights_and_another_seed_others() {
        let n = 1_000;
        let (load, flap, target) = data(n);
        let settings = NetworkSettings {
            max_epochs: 5,
            ..NetworkSettings::default()
        };
        let names = ["a".to_string(), "b".to_string()];
        let run = |seed| {
            let settings = NetworkSettings {
                seed,
                ..settings.clone()
            };
            train(&names, &[&load, &flap], &target, &held_out(n), &settings)
                .unwrap()
                .network
        };
        assert_eq!(run(1), run(1));
        assert_ne!(run(1), run(2));
    }

    #[test]
    fn too_few_rows_is_an_error_not_a_network() {
        let (load, flap, target) = data(60);
        let result = train(
            &["a".into(), "b".into()],
            &[&load, &flap],
            &target,
            &held_out(60),
            &NetworkSettings::default(),
        );
        assert!(
            matches!(result, Err(NetworkError::TooFewRows { .. })),
            "{result:?}"
        );
    }
}
