//! Every run's rows made ready for the folds: each run long enough filled, filtered (its level
//! rows low-passed beside) and, when long, factored window by window as it is filtered. Apart
//! from [`Problem`]'s other work so that the windows, which build on it, are needed only here.

use super::error::FitError;
use super::level_rows::centre;
use super::level_setup::LevelSetup;
use super::problem::{cuts_of, AboveBand, FillRun, Plan, Prepared, Problem, RunRows};
use super::windows::Windows;

impl Problem<'_, '_> {
    /// Band rows (and, with `levels`, level rows; with `above_band`, rows above the band) of
    /// every run long enough, from the `width` columns, the target and the `extra` signals after
    /// it that `fill` writes. The signals after the target are filtered and factored with the
    /// others (after the target: the leading columns of a factor are those of the columns
    /// before, whatever follows) and have no level rows: the fluxgate's magnitude, whose
    /// calibration [`super::levels::InPass`] takes from these rows.
    ///
    /// Runs of two windows or more are filtered and factored window by window, their band
    /// rows cut where the folds of `plans` start (see [`Problem::plans_ahead`]).
    pub(super) fn prepare(
        &self,
        width: usize,
        extra: usize,
        fill: &FillRun<'_>,
        levels: Option<&LevelSetup>,
        above_band: Option<&AboveBand>,
        plans: &[&Plan],
    ) -> Result<Prepared, FitError> {
        let (trim, needed) = self.trim_and_needed(above_band);
        let signals = width + 1 + extra;
        let low = levels.map(|l| &l.low);
        let sizes: Vec<usize> = self
            .samples
            .runs
            .iter()
            .map(|r| match r.len() < needed {
                true => 0,
                false => self.buffer_len(r.len(), width + extra, low, above_band),
            })
            .collect();
        let mut buffers = self.spare.take_each(&sizes).into_iter();
        let mut runs = Vec::new();
        let mut level_rows = Vec::new();
        let mut short = 0;
        for (run, used) in self.samples.runs.iter().zip(sizes) {
            let n = run.len();
            let mut buffer = buffers.next().expect("one buffer per run");
            if used == 0 {
                short += n;
                continue;
            }
            if let Some(margin) = self.window_margin(n, low, above_band) {
                let windows = Windows {
                    run: run.clone(),
                    margin,
                    width,
                    extra,
                    trim,
                };
                let cuts = cuts_of(plans, runs.len(), n - 2 * trim);
                if let Some((factored, rows)) =
                    windows.factor(self, fill, levels, &cuts, &mut buffer)
                {
                    #[cfg(test)]
                    super::window_size::windows_in_tests::DONE
                        .set(super::window_size::windows_in_tests::DONE.get() + 1);
                    self.spare.give([buffer]);
                    level_rows.extend(rows);
                    runs.push(RunRows {
                        data: Vec::new(),
                        len: n,
                        above: None,
                        factored: Some(factored),
                    });
                    continue;
                }
                // A constant column: the whole run decides what its filters do.
                buffer.resize(n * signals, 0.0);
            }
            let data = &mut buffer[..n * signals];
            fill(
                run.clone(),
                0..n,
                &mut data.chunks_mut(n).collect::<Vec<_>>(),
            );
            let above = match above_band {
                Some(above) => Some(above.rows(data, n, trim)?),
                None => None,
            };
            let mut signals: Vec<&mut [f64]> = data.chunks_mut(n).collect();
            if let Some(rows) = self.filter_run(run.clone(), &mut signals, extra, levels)? {
                level_rows.push(rows);
            }
            runs.push(RunRows {
                data: buffer,
                len: n,
                above,
                factored: None,
            });
        }
        centre(&mut level_rows);
        Ok(Prepared {
            width: signals,
            extra,
            trim,
            runs,
            levels: level_rows,
            short,
        })
    }
}
