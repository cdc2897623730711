//! How long runs are cut into windows (samples): the window length, its overlap, and how many
//! windows the cores work on at once. Shared by the rows' preparation and the windows
//! themselves, so neither needs the other for it.

/// Samples per window of a long run, which is filtered and factored window by window, each
/// window taken whole by the next core free: the rows of a whole run need not be held at once (at 10⁷
/// samples and 19 columns they are 1.5 GB, which on a virtual machine take seconds to fault in).
/// Runs shorter than two windows are done whole. 2¹⁶ to 2¹⁹ timed the same at 10⁷ samples;
/// 2¹⁸ keeps the overlap a thirtieth of a window and two windows' buffers near 85 MB. Tests
/// run with it too; those about windows ask for shorter ones ([`with_window_samples`]).
const WINDOW_SAMPLES: usize = 1 << 18;

thread_local! {
    /// Samples per window of the fits started on this thread when not [`WINDOW_SAMPLES`]: set
    /// only by [`with_window_samples`], so a test can have a run of tens of thousands of
    /// samples done in windows.
    static WINDOW_SAMPLES_HERE: std::cell::Cell<Option<usize>> = const { std::cell::Cell::new(None) };
}

/// Samples per window of a fit started on this thread.
pub(super) fn window_samples() -> usize {
    WINDOW_SAMPLES_HERE.get().unwrap_or(WINDOW_SAMPLES)
}

/// Runs `f` with the fits it starts on this thread cutting long runs into windows of
/// `samples` (at least 2¹⁰).
#[cfg(test)]
pub(super) fn with_window_samples<T>(samples: usize, f: impl FnOnce() -> T) -> T {
    let before = WINDOW_SAMPLES_HERE.replace(Some(samples.max(1 << 10)));
    let out = f();
    WINDOW_SAMPLES_HERE.set(before);
    out
}

/// Samples of each window's own part (its core) of a run of `n` samples done in windows of
/// `window` samples: the run cut into equal parts of at most `window`, as many as a multiple
/// of [`WINDOW_MULTIPLE`].
pub(super) fn window_core(n: usize, window: usize) -> usize {
    n.div_ceil(n.div_ceil(window).next_multiple_of(WINDOW_MULTIPLE))
}

/// The windows of a run come in a multiple of this many. They are taken whole by the cores:
/// with one window more than a multiple of the cores (39 at 10⁷ samples on two), one core
/// worked through it alone while the other waited, 0.14 s per pass over the rows. The layout
/// does not depend on the cores, so neither do the values; four balances one, two and four.
const WINDOW_MULTIPLE: usize = 4;

/// Samples of the longest window of a run of `n` samples done in windows of `window` samples
/// overlapping by `margin`: a core and a margin on each side.
pub(super) fn window_len(n: usize, window: usize, margin: usize) -> usize {
    window_core(n, window) + 2 * margin
}

/// Windows of a run of `n` samples done in windows of `window` samples that are worked on at
/// once: one per core, at most one per window. A window's buffer is taken for each.
pub(super) fn windows_dealt(n: usize, window: usize) -> usize {
    crate::parallel::cores().min(n.div_ceil(window_core(n, window)))
}

/// In tests, how many runs were done in windows.
#[cfg(test)]
pub(super) mod windows_in_tests {
    use std::cell::Cell;
    thread_local! {
        pub(in crate::fit) static DONE: Cell<usize> = const { Cell::new(0) };
    }
}
