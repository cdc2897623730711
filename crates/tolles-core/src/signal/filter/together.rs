//! Two filters over one set of signals, their blocks shared among the cores as one list of
//! work: a fit's level rows (kept samples of a low-pass of its columns) and its band rows
//! (the same columns band-passed in place).
//!
//! Run one after the other, each filter's blocks of lanes divide unevenly among the cores
//! (20 signals are three blocks, 17 too), so at the end of each filter one core waits while
//! the other finishes a block. As one list, a core that has run out of one filter's blocks
//! takes the other's. A band-pass block overwrites its columns, so it starts only once every
//! low-pass block that reads one of them has finished; the low-pass blocks come first in the
//! list, so that is never long.
//!
//! Each block is filtered by the same kernels as in [`filtfilt_sampled_unless_constant`] and
//! [`filtfilt_many_unless_constant`], and lanes never mix, so every value is the same bit for
//! bit whichever core runs which block.

use super::{
    assert_samples_within, constancy, lanes, samples_at, threads_for, Butterworth, Ends,
    FilterError, Simd,
};
#[cfg(doc)]
use super::{filtfilt_many_unless_constant, filtfilt_sampled_unless_constant};
use std::panic::{self, AssertUnwindSafe};
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::Mutex;
use std::thread;

/// [`filtfilt_sampled_unless_constant`] of `low` over all of `signals` but the last, then
/// `last_low` (as long as they are), followed by [`filtfilt_many_unless_constant`] of `band`
/// over all of `signals` in place: the samples at `at` of each low-passed signal (one vector
/// per signal, `last_low`'s last), with the band-passed signals written back, bit for bit as
/// the two calls in turn give them, in the time of less.
///
/// For a fit's run: `signals` are its columns and target, `last_low` the target the level
/// rows take instead (the scalar less the reference).
///
/// # Errors
/// [`FilterError::TooShort`] if a signal that is not constant is too short for `low`, then
/// for `band`, as the two calls in turn would report it; nothing is written then.
///
/// # Panics
/// If the signals and `last_low` differ in length or `at` is not ascending within them:
/// programming errors.
pub fn filtfilt_sampled_then_in_place(
    low: &Butterworth,
    at: &[usize],
    last_low: &[f64],
    band: &Butterworth,
    signals: &mut [&mut [f64]],
) -> Result<Vec<Vec<f64>>, FilterError> {
    let kernels = Simd::best().0;
    let width = signals.len().saturating_sub(1);
    let read: Vec<&[f64]> = signals.iter().map(|x| &**x).collect();
    let low_signals: Vec<&[f64]> = read[..width].iter().copied().chain([last_low]).collect();
    let (n, low_constant) = constancy(kernels, low, &low_signals)?;
    assert_samples_within(at, n);
    let (_, band_constant) = constancy(kernels, band, &read)?;
    Ok(sampled_then_in_place(
        kernels,
        (low, band),
        at,
        last_low,
        signals,
        (&low_constant, &band_constant),
    ))
}

/// The work of [`filtfilt_sampled_then_in_place`] once the constant signals (of the low-pass,
/// then of the band-pass) are known.
fn sampled_then_in_place(
    kernels: lanes::Kernels,
    (low, band): (&Butterworth, &Butterworth),
    at: &[usize],
    last_low: &[f64],
    signals: &mut [&mut [f64]],
    (low_constant, band_constant): (&[bool], &[bool]),
) -> Vec<Vec<f64>> {
    let ends = Ends::WHOLE;
    let n = last_low.len();
    let width = signals.len().saturating_sub(1);
    let read: Vec<&[f64]> = signals.iter().map(|x| &**x).collect();
    let low_signals: Vec<&[f64]> = read[..width].iter().copied().chain([last_low]).collect();
    // A constant signal's samples are its own values, taken before anything is overwritten.
    let mut out: Vec<Option<Vec<f64>>> = low_signals
        .iter()
        .zip(low_constant)
        .map(|(x, &constant)| constant.then(|| samples_at(x, at)))
        .collect();
    let plan = Plan::new(low_constant, band_constant);
    let columns = Columns::new(signals, last_low);
    let filtered = plan.run(n, |task| match task {
        Task::Low(block) => Some((kernels.filtfilt_sampled_all)(
            low,
            &columns.read(block),
            at,
            ends,
        )),
        Task::Band(block) => {
            (kernels.filtfilt_all)(band, &mut columns.write(block), ends);
            None
        }
    });
    let mut filtered = filtered.into_iter().flatten().flatten();
    for slot in out.iter_mut().filter(|slot| slot.is_none()) {
        *slot = filtered.next();
    }
    out.into_iter()
        .map(|v| v.expect("one result per varying signal"))
        .collect()
}

/// One block of work: the indices of the signals it filters (in the low-pass's numbering,
/// where `width` is `last_low`, or in the band-pass's, where it is the last of `signals`).
#[derive(Debug, Clone, PartialEq)]
enum Task<'p> {
    Low(&'p [usize]),
    Band(&'p [usize]),
}

/// The blocks of both filters and which low-pass blocks each band-pass block waits for.
#[derive(Debug)]
struct Plan {
    /// The varying signals of the low-pass, in blocks of [`lanes::LANES`].
    low: Vec<Vec<usize>>,
    /// The same for the band-pass.
    band: Vec<Vec<usize>>,
    /// For each band-pass block, the low-pass blocks that read one of its signals.
    waits_for: Vec<Vec<usize>>,
}

impl Plan {
    /// The blocks over the signals that are not constant; the last signal of each filter is
    /// its own (the low-pass's `last_low`, the band-pass's last signal), so neither waits.
    fn new(low_constant: &[bool], band_constant: &[bool]) -> Self {
        let width = band_constant.len().saturating_sub(1);
        let blocks = |constant: &[bool]| -> Vec<Vec<usize>> {
            let varying: Vec<usize> = (0..constant.len()).filter(|&i| !constant[i]).collect();
            varying
                .chunks(lanes::LANES)
                .map(<[usize]>::to_vec)
                .collect()
        };
        let (low, band) = (blocks(low_constant), blocks(band_constant));
        let waits_for = band
            .iter()
            .map(|written| {
                let shared = |read: &Vec<usize>| {
                    read.iter()
                        .any(|&i| i < width && written.binary_search(&i).is_ok())
                };
                (0..low.len()).filter(|&b| shared(&low[b])).collect()
            })
            .collect();
        Self {
            low,
            band,
            waits_for,
        }
    }

    /// Every task in list order, the low-pass blocks first.
    fn tasks(&self) -> Vec<Task<'_>> {
        let low = self.low.iter().map(|b| Task::Low(b));
        low.chain(self.band.iter().map(|b| Task::Band(b))).collect()
    }

    /// Runs `work` on every task, on all cores for signals of `n` samples worth it, and
    /// returns the results in list order.
    fn run<R: Send>(&self, n: usize, work: impl Fn(Task) -> R + Sync) -> Vec<R> {
        let tasks = self.tasks();
        let signals: usize = self.low.iter().chain(&self.band).map(Vec::len).sum();
        let threads = threads_for(tasks.len(), n * signals);
        if threads <= 1 {
            return tasks.into_iter().map(work).collect();
        }
        let next = AtomicUsize::new(0);
        let low_done: Vec<AtomicBool> = self.low.iter().map(|_| AtomicBool::new(false)).collect();
        let results: Vec<Mutex<Option<thread::Result<R>>>> =
            tasks.iter().map(|_| Mutex::new(None)).collect();
        let worker = || loop {
            let t = next.fetch_add(1, Ordering::Relaxed);
            let Some(task) = tasks.get(t) else { break };
            if let Task::Band(_) = task {
                // The low-pass blocks were all handed out before this one, so each one
                // waited for is running on another core.
                for &b in &self.waits_for[t - self.low.len()] {
                    while !low_done[b].load(Ordering::Acquire) {
                        thread::yield_now();
                    }
                }
            }
            // A panic is caught and passed on after the scope, so no core waits for a
            // low-pass block that will never finish; its views are gone by then.
            let result = panic::catch_unwind(AssertUnwindSafe(|| work(task.clone())));
            *results[t].lock().unwrap_or_else(|e| e.into_inner()) = Some(result);
            if t < self.low.len() {
                low_done[t].store(true, Ordering::Release);
            }
        };
        thread::scope(|scope| {
            (1..threads).for_each(|_| {
                scope.spawn(worker);
            });
            worker();
        });
        results
            .into_iter()
            .map(|r| {
                let ran = r.into_inner().unwrap_or_else(|e| e.into_inner());
                ran.expect("every task ran")
                    .unwrap_or_else(|e| panic::resume_unwind(e))
            })
            .collect()
    }
}

/// The signals as pointers, so that low-pass blocks can read columns that band-pass blocks
/// later write in place.
///
/// Sound because of how [`Plan::run`] orders the tasks: blocks of one filter touch disjoint
/// signals, and a band-pass block's mutable views are made only after every low-pass block
/// reading one of its signals has finished (its `Release` store seen by the `Acquire` load),
/// so no shared view of a signal is alive while a mutable one exists.
struct Columns {
    signals: Vec<(*mut f64, usize)>,
    last_low: (*const f64, usize),
}

// SAFETY: the pointers are only dereferenced as `Plan::run` orders the tasks (see above), and
// the data they point to outlives the scope of `filtfilt_sampled_then_in_place`.
unsafe impl Sync for Columns {}

impl Columns {
    fn new(signals: &mut [&mut [f64]], last_low: &[f64]) -> Self {
        Self {
            signals: signals
                .iter_mut()
                .map(|x| (x.as_mut_ptr(), x.len()))
                .collect(),
            last_low: (last_low.as_ptr(), last_low.len()),
        }
    }

    /// Shared views of the low-pass's signals `block`.
    fn read(&self, block: &[usize]) -> Vec<&[f64]> {
        let width = self.signals.len().saturating_sub(1);
        block
            .iter()
            .map(|&i| {
                let (ptr, len) = match i < width {
                    true => (self.signals[i].0.cast_const(), self.signals[i].1),
                    false => self.last_low,
                };
                // SAFETY: see `Columns`; no mutable view of signal `i` exists now.
                unsafe { std::slice::from_raw_parts(ptr, len) }
            })
            .collect()
    }

    /// Mutable views of the band-pass's signals `block`.
    #[allow(clippy::mut_from_ref)] // the exclusivity is `Plan::run`'s ordering, see `Columns`
    fn write(&self, block: &[usize]) -> Vec<&mut [f64]> {
        block
            .iter()
            .map(|&i| {
                let (ptr, len) = self.signals[i];
                // SAFETY: see `Columns`; no other view of signal `i` exists now.
                unsafe { std::slice::from_raw_parts_mut(ptr, len) }
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::super::{
        filtfilt_many_unless_constant, filtfilt_sampled_unless_constant, magnav_bandpass,
        Butterworth, Response,
    };
    use super::*;

    /// Slow sines on offsets, different per signal; `constant` ones are flat.
    fn signals(count: usize, n: usize, constant: &[usize]) -> Vec<Vec<f64>> {
        (0..count)
            .map(|j| {
                (0..n)
                    .map(|k| match constant.contains(&j) {
                        true => 3.0 * j as f64,
                        false => 100.0 * j as f64 + (0.013 * (j + 1) as f64 * k as f64).sin(),
                    })
                    .collect()
            })
            .collect()
    }

    fn same_bits(a: &[f64], b: &[f64]) -> bool {
        a.len() == b.len() && a.iter().zip(b).all(|(x, y)| x.to_bits() == y.to_bits())
    }

    #[test]
    fn together_equals_the_two_calls_in_turn() {
        let low = Butterworth::design(4, Response::LowPass { cutoff_hz: 0.1 }, 10.0).unwrap();
        let band = magnav_bandpass(0.1, 0.9, 4, 10.0).unwrap().unwrap();
        // Enough samples for threads; 20 and 17 signals are a fit's usual widths.
        let n = 120_000;
        for (count, constant) in [(20, vec![]), (17, vec![0, 9]), (3, vec![2]), (10, vec![])] {
            let original = signals(count, n, &constant);
            let last_low: Vec<f64> = original[count - 1].iter().map(|v| v - 7.0).collect();
            let at: Vec<usize> = (40..n - 40).step_by(50).collect();

            let read: Vec<&[f64]> = original[..count - 1]
                .iter()
                .map(Vec::as_slice)
                .chain([last_low.as_slice()])
                .collect();
            let expected_low = filtfilt_sampled_unless_constant(&low, &read, &at).unwrap();
            let mut expected_band = original.clone();
            let mut views: Vec<&mut [f64]> =
                expected_band.iter_mut().map(Vec::as_mut_slice).collect();
            filtfilt_many_unless_constant(&band, &mut views).unwrap();

            let mut together = original.clone();
            let mut views: Vec<&mut [f64]> = together.iter_mut().map(Vec::as_mut_slice).collect();
            let sampled =
                filtfilt_sampled_then_in_place(&low, &at, &last_low, &band, &mut views).unwrap();
            assert_eq!(sampled.len(), count);
            for (a, b) in sampled.iter().zip(&expected_low) {
                assert!(same_bits(a, b), "{count} signals: low-pass samples differ");
            }
            for (a, b) in together.iter().zip(&expected_band) {
                assert!(same_bits(a, b), "{count} signals: band-pass differs");
            }
        }
    }

    #[test]
    fn a_band_block_waits_for_the_low_blocks_reading_its_signals() {
        // 20 signals: 19 columns and the target; the low-pass's last is its own target.
        let plan = Plan::new(&[false; 20], &[false; 20]);
        assert_eq!(plan.low.len(), 3);
        assert_eq!(plan.waits_for, [vec![0], vec![1], vec![2]]);
        // Column 3 constant for both: the blocks shift, and the band-pass's second block
        // (columns 9..=16) reads from the low-pass's second and third.
        let mut constant = [false; 20];
        constant[3] = true;
        let plan = Plan::new(&constant, &constant);
        assert_eq!(plan.band[1], [9, 10, 11, 12, 13, 14, 15, 16]);
        assert_eq!(plan.waits_for[1], [1]);
        // The low-pass's target constant but not the band-pass's: blocks differ in length.
        let mut low_constant = [false; 20];
        low_constant[19] = true;
        let plan = Plan::new(&low_constant, &[false; 20]);
        assert_eq!(plan.low[2], [16, 17, 18]);
        assert_eq!(plan.band[2], [16, 17, 18, 19]);
        assert_eq!(plan.waits_for[2], [2]);
    }

    #[test]
    fn too_short_for_the_low_pass_is_reported_first_and_nothing_written() {
        let low = Butterworth::design(4, Response::LowPass { cutoff_hz: 0.1 }, 10.0).unwrap();
        let band = magnav_bandpass(0.1, 0.9, 4, 10.0).unwrap().unwrap();
        let n = low.padlen().min(band.padlen());
        let original = signals(3, n, &[]);
        let mut data = original.clone();
        let mut views: Vec<&mut [f64]> = data.iter_mut().map(Vec::as_mut_slice).collect();
        let last = original[2].clone();
        let err = filtfilt_sampled_then_in_place(&low, &[1], &last, &band, &mut views);
        assert_eq!(
            err.unwrap_err(),
            FilterError::TooShort {
                len: n,
                padlen: low.padlen()
            }
        );
        assert_eq!(data, original);
    }
}
