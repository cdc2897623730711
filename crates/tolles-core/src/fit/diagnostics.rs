//! A fit's diagnostics: residual scatters before and after, counts of rows and runs, and the
//! score covariance's block length.

use super::outcome::{Diagnostics, TermScore};
use super::ridge::RidgeSolution;
use super::settings::{FitSettings, Target};
use crate::fit::crossval::CrossValidation;
use nalgebra::DMatrix;

/// Rows of a block of the score covariance ([`super::problem::Prepared::score_covariance`]): two
/// periods of the band's low edge, over which a band-passed residual is correlated; twenty
/// seconds for an unfiltered target.
pub(super) fn score_block(settings: &FitSettings, fs_hz: f64) -> usize {
    let low = settings.band.pass1_hz;
    let seconds = match settings.target {
        Target::Band if low > 0.0 && low < fs_hz / 2.0 => 2.0 / low,
        _ => 20.0,
    };
    (seconds * fs_hz).ceil().max(1.0) as usize
}

/// Population standard deviation accumulated block by block: each block's mean and squared
/// deviations by two passes over it, merged into the running ones by Chan, Golub and
/// LeVeque's pairwise update. One value at a time (Welford) is a chain of divisions, 0.06 s
/// for 10⁷ values; this agrees with it to rounding.
#[derive(Debug, Default, Clone, Copy)]
pub(crate) struct RunningStd {
    n: usize,
    mean: f64,
    m2: f64,
}

/// Values [`RunningStd::push_all`] takes at once: a block stays in the L1 cache between its
/// two passes.
pub(super) const STD_BLOCK: usize = 2048;

impl RunningStd {
    pub(super) fn push_all(&mut self, values: &[f64]) {
        for block in Self::blocks(values) {
            self.merge(block);
        }
    }

    /// The blocks [`RunningStd::push_all`] merges, each on its own.
    pub(super) fn blocks(values: &[f64]) -> impl Iterator<Item = Self> + '_ {
        values.chunks(STD_BLOCK).map(Self::of_block)
    }

    /// Count, mean and squared deviations of `x` (not empty); [`sum4`] lets the additions
    /// overlap.
    pub(super) fn of_block(x: &[f64]) -> Self {
        let n = x.len();
        let mean = sum4(x, |v| v) / n as f64;
        let m2 = sum4(x, |v| (v - mean) * (v - mean));
        Self { n, mean, m2 }
    }

    pub(super) fn merge(&mut self, other: Self) {
        if other.n == 0 {
            return;
        }
        let n = self.n + other.n;
        let delta = other.mean - self.mean;
        let share = other.n as f64 / n as f64;
        self.mean += delta * share;
        self.m2 += other.m2 + delta * delta * self.n as f64 * share;
        self.n = n;
    }

    pub(super) fn std(&self) -> f64 {
        if self.n == 0 {
            return f64::NAN;
        }
        (self.m2 / self.n as f64).sqrt()
    }
}

/// `Σ f(v)` over `x`, as four interleaved partial sums.
pub(super) fn sum4(x: &[f64], f: impl Fn(f64) -> f64) -> f64 {
    let mut acc = [0.0; 4];
    let mut quads = x.chunks_exact(4);
    for q in quads.by_ref() {
        for (a, v) in acc.iter_mut().zip(q) {
            *a += f(*v);
        }
    }
    let tail: f64 = quads.remainder().iter().map(|v| f(*v)).sum();
    (acc[0] + acc[1]) + (acc[2] + acc[3]) + tail
}

pub(super) struct DiagnosticCounts {
    /// Level rows in the solution, and their weighted residual sum of squares (nT²).
    pub(super) level_rows: usize,
    pub(super) level_rss: f64,
    /// Rows above the band (extra channels): a second row of samples already counted; and
    /// their residual sum of squares (nT²).
    pub(super) above_rows: usize,
    pub(super) above_rss: f64,
    pub(super) total: usize,
    pub(super) nonfinite: usize,
    pub(super) short: usize,
    pub(super) runs_used: usize,
    pub(super) before_std: f64,
    pub(super) fraction: f64,
}

/// The residual's standard deviation over the band-passed rows of `solution` (nT): without its
/// `level_rows` level rows, whose weighted residual sum of squares is `level_rss` (nT²).
pub(crate) fn band_residual_std(
    solution: &RidgeSolution,
    level_rows: usize,
    level_rss: f64,
) -> f64 {
    let band_rows = solution.rows - level_rows;
    ((solution.rss - level_rss).max(0.0) / band_rows.max(1) as f64).sqrt()
}

pub(super) fn diagnostics(
    solution: &RidgeSolution,
    c: DiagnosticCounts,
    cross_validation: Option<CrossValidation>,
    term_choice: Vec<TermScore>,
) -> Diagnostics {
    let p = solution.coefficients.len();
    let dof = solution.rows.saturating_sub(p).max(1) as f64;
    // The samples and residual of the band-passed rows alone, without the level rows and the
    // rows above the band (an extra channel's fit there leaves the aircraft's other fields).
    let band_rows = solution.rows - c.level_rows;
    let residual_std = band_residual_std(
        solution,
        c.level_rows + c.above_rows,
        c.level_rss + c.above_rss,
    );
    let sigma2 = solution.rss / dof / c.fraction;
    Diagnostics {
        samples_total: c.total,
        samples_nonfinite: c.nonfinite,
        samples_in_short_runs: c.short,
        samples_used: band_rows.saturating_sub(c.above_rows),
        runs_used: c.runs_used,
        filtered_std_before_nt: c.before_std,
        residual_std_nt: residual_std,
        improvement_ratio: c.before_std / residual_std,
        condition_number: solution.condition_number(),
        effective_sample_fraction: c.fraction,
        penalty: solution.penalty().to_vec(),
        cross_validation,
        term_choice,
        std_errors: solution.std_errors(sigma2),
        levels: None,
        untrusted_levels_nt: None,
        exact_iterations: 0,
        excitation_deg: None,
        restrained: None,
    }
}

/// One run's long-run score covariance (see
/// [`super::problem::Prepared::score_covariance`]): with `Bₖ` the centred scores summed over
/// rows `k..k+block`, `n/(block·positions)·Σₖ BₖBₖᵀ`. Block starts step by an eighth of a
/// block, which costs nothing in accuracy next to the block's own.
pub(super) fn run_score_covariance(
    columns: &[&[f64]],
    residual: &[f64],
    block: usize,
) -> DMatrix<f64> {
    let (p, n) = (columns.len(), residual.len());
    let score = |c: usize, t: usize| columns[c][t] * residual[t];
    let mean: Vec<f64> = (0..p)
        .map(|c| (0..n).map(|t| score(c, t)).sum::<f64>() / n as f64)
        .collect();
    // Prefix sums of the centred scores, one row per sample.
    let mut prefix = DMatrix::zeros(n + 1, p);
    for t in 0..n {
        for c in 0..p {
            prefix[(t + 1, c)] = prefix[(t, c)] + score(c, t) - mean[c];
        }
    }
    let step = (block / 8).max(1);
    let mut sum = DMatrix::zeros(p, p);
    let mut positions = 0usize;
    for k in (0..=n - block).step_by(step) {
        let b = (prefix.row(k + block) - prefix.row(k)).transpose();
        sum.ger(1.0, &b, &b, 1.0);
        positions += 1;
    }
    sum * (n as f64 / (block as f64 * positions as f64))
}
