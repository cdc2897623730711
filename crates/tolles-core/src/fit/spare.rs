//! Buffers a fit has finished with, for its next step to reuse.

use std::sync::Mutex;

/// Buffers a fit has finished with, for its next step to reuse. On a long flight, touching
/// fresh memory costs more than the arithmetic done in it (on a virtual machine, gigabytes take
/// seconds to fault in), so every large buffer of a fit comes from here and goes back.
#[derive(Default)]
pub(super) struct Spare(Mutex<Vec<Vec<f64>>>);

impl Spare {
    /// A buffer of at least `len` values, of which the taker uses the first `len`: the
    /// smallest spare one that is long enough, as its last user left it (so every taker writes
    /// all it uses before reading it: zeroing a gigabyte that is about to be overwritten costs
    /// a tenth of a second), or a new one of `len` zeros.
    ///
    /// A new one is zeroed by the system as its pages are first written, by whichever thread
    /// writes them, so the fills that write on all cores also fault its pages in on all cores.
    pub(super) fn take(&self, len: usize) -> Vec<f64> {
        let mut spare = self.0.lock().unwrap_or_else(|e| e.into_inner());
        let fits = (0..spare.len())
            .filter(|&i| spare[i].len() >= len)
            .min_by_key(|&i| spare[i].len());
        match fits {
            Some(i) => spare.swap_remove(i),
            None => vec![0.0; len],
        }
    }

    /// [`Spare::take`] of each of `lens`, the longest first, so that the longest need gets the
    /// longest buffer rather than one a shorter need took first. Empty for a length of 0.
    pub(super) fn take_each(&self, lens: &[usize]) -> Vec<Vec<f64>> {
        let mut order: Vec<usize> = (0..lens.len()).collect();
        order.sort_by_key(|&i| std::cmp::Reverse(lens[i]));
        let mut out = vec![Vec::new(); lens.len()];
        for i in order.into_iter().filter(|&i| lens[i] > 0) {
            out[i] = self.take(lens[i]);
        }
        out
    }

    /// Makes sure a spare buffer of at least `len` values is there, for a fit that will need
    /// one that long after smaller ones: the smaller needs are then met by its first part,
    /// and its pages are faulted in once, as far as each use reaches, rather than those of
    /// every size in turn (on a virtual machine each new gigabyte costs about a second).
    pub(super) fn reserve(&self, len: usize) {
        let mut spare = self.0.lock().unwrap_or_else(|e| e.into_inner());
        if spare.iter().all(|b| b.len() < len) {
            spare.push(vec![0.0; len]);
        }
    }

    /// Returns `buffers` for a later [`Spare::take`].
    pub(super) fn give(&self, buffers: impl IntoIterator<Item = Vec<f64>>) {
        let mut spare = self.0.lock().unwrap_or_else(|e| e.into_inner());
        spare.extend(buffers.into_iter().filter(|b| !b.is_empty()));
    }
}
