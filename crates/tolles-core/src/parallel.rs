//! Sharing long columns between the cores by rows.

use std::ops::Range;

thread_local! {
    /// Cores this thread may use, when a caller has said (see [`on_one_core`]).
    static CORES: std::cell::Cell<Option<usize>> = const { std::cell::Cell::new(None) };
}

/// Cores the work of this thread may spread over: the machine's, or one inside
/// [`on_one_core`].
pub(crate) fn cores() -> usize {
    CORES.get().unwrap_or_else(machine_cores)
}

/// The cores this process may use, asked once: the standard library reads the control
/// group's files at every call (six system calls), which a survey compensated in small
/// chunks paid thousands of times.
pub(crate) fn machine_cores() -> usize {
    static MACHINE: std::sync::OnceLock<usize> = std::sync::OnceLock::new();
    *MACHINE.get_or_init(|| std::thread::available_parallelism().map_or(1, |t| t.get()))
}

/// Runs `f` with every step inside it on this thread alone: for work dealt to the cores in
/// whole pieces, whose steps would otherwise each start a thread per core.
pub(crate) fn on_one_core<R>(f: impl FnOnce() -> R) -> R {
    on_cores(1, f)
}

/// Runs `f` as if the machine had `cores` cores (at least one).
pub(crate) fn on_cores<R>(cores: usize, f: impl FnOnce() -> R) -> R {
    let before = CORES.replace(Some(cores.max(1)));
    let out = f();
    CORES.set(before);
    out
}

/// Rows below which a thread costs more than it saves.
pub(crate) const PARALLEL_ROWS: usize = 100_000;

/// Calls `f` on parts of the rows `0..n` of `columns` (each `n` long) from as many threads as
/// there are cores, each with its rows of every column.
pub(crate) fn split_rows(
    n: usize,
    columns: &mut [&mut [f64]],
    f: impl Fn(Range<usize>, &mut [&mut [f64]]) + Sync,
) {
    let threads = threads_for_rows(n);
    if threads == 1 {
        f(0..n, columns);
        return;
    }
    let share = n.div_ceil(threads);
    let mut parts: Vec<Vec<&mut [f64]>> = (0..threads).map(|_| Vec::new()).collect();
    for column in columns.iter_mut() {
        for (part, piece) in parts.iter_mut().zip(column.chunks_mut(share)) {
            part.push(piece);
        }
    }
    std::thread::scope(|scope| {
        for (t, mut part) in parts.into_iter().enumerate().filter(|(_, p)| !p.is_empty()) {
            let f = &f;
            scope.spawn(move || f(t * share..((t + 1) * share).min(n), &mut part));
        }
    });
}

/// Calls `f` on consecutive parts of `items` from as many threads as there are cores, each
/// with the range of indices its part covers: [`split_rows`] for one column of any type.
pub(crate) fn split_items<T: Send>(items: &mut [T], f: impl Fn(Range<usize>, &mut [T]) + Sync) {
    split_among(items, threads_for_rows(items.len()), f);
}

/// [`split_items`] with `threads` threads (at most one per item).
fn split_among<T: Send>(
    items: &mut [T],
    threads: usize,
    f: impl Fn(Range<usize>, &mut [T]) + Sync,
) {
    let n = items.len();
    let threads = threads.min(n).max(1);
    let share = n.div_ceil(threads).max(1);
    if threads == 1 {
        f(0..n, items);
        return;
    }
    std::thread::scope(|scope| {
        for (t, part) in items.chunks_mut(share).enumerate() {
            let f = &f;
            scope.spawn(move || f(t * share..t * share + part.len(), part));
        }
    });
}

/// `f` of each of `items`, in order, computed on as many threads as there are cores, each
/// taking the next item not yet taken: for a few items of much work each (`rows`, the rows
/// they cover together, decides as in [`split_rows`] whether threads are worth starting).
pub(crate) fn map_items<T: Sync, R: Send>(
    items: &[T],
    rows: usize,
    f: impl Fn(&T) -> R + Sync,
) -> Vec<R> {
    let threads = threads_for_rows(rows).min(items.len());
    if threads <= 1 {
        return items.iter().map(f).collect();
    }
    let next = std::sync::atomic::AtomicUsize::new(0);
    let take = || {
        let mut done = Vec::new();
        loop {
            let k = next.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
            let Some(item) = items.get(k) else { break done };
            done.push((k, f(item)));
        }
    };
    let mut done: Vec<(usize, R)> = std::thread::scope(|scope| {
        let others: Vec<_> = (1..threads).map(|_| scope.spawn(take)).collect();
        let mut all = take();
        for other in others {
            all.extend(
                other
                    .join()
                    .unwrap_or_else(|e| std::panic::resume_unwind(e)),
            );
        }
        all
    });
    done.sort_unstable_by_key(|(k, _)| *k);
    done.into_iter().map(|(_, r)| r).collect()
}

/// `f` of each of consecutive parts of the rows `0..n`, one part per core (each at least
/// `least` rows), in order: [`map_items`] of the parts.
pub(crate) fn map_parts<R: Send>(
    n: usize,
    least: usize,
    f: impl Fn(Range<usize>) -> R + Sync,
) -> Vec<R> {
    let parts: Vec<Range<usize>> = blocks(0..n, n.div_ceil(cores()).max(least)).collect();
    map_items(&parts, n, |part| f(part.clone()))
}

/// `f` of each of `items`, the items cut into one consecutive part per core (for items of
/// about equal work; `rows`, the rows they cover together, decides as in [`split_rows`]
/// whether threads are worth starting).
pub(crate) fn for_each_item<T: Send>(items: &mut [T], rows: usize, f: impl Fn(&mut T) + Sync) {
    split_among(items, threads_for_rows(rows), |_, part| {
        part.iter_mut().for_each(&f)
    });
}

/// Threads worth starting for `n` rows: one per core, but none for fewer than
/// [`PARALLEL_ROWS`] rows each.
fn threads_for_rows(n: usize) -> usize {
    cores().min(n.div_ceil(PARALLEL_ROWS)).max(1)
}

/// `rows` cut into consecutive blocks of at most `size` rows.
pub(crate) fn blocks(rows: Range<usize>, size: usize) -> impl Iterator<Item = Range<usize>> {
    let size = size.max(1);
    (rows.start..rows.end)
        .step_by(size)
        .map(move |start| start..(start + size).min(rows.end))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_item_is_visited_once_with_its_own_index() {
        for n in [0, 7, 250_001] {
            let mut items = vec![0usize; n];
            split_items(&mut items, |range, part| {
                assert_eq!(part.len(), range.len());
                for (v, k) in part.iter_mut().zip(range) {
                    *v += k + 1;
                }
            });
            assert!(items.iter().enumerate().all(|(k, v)| *v == k + 1));
        }
    }

    #[test]
    fn every_row_of_every_column_is_visited_once_with_its_own_index() {
        for n in [0, 7, 250_001] {
            let mut data = vec![vec![0.0; n]; 3];
            let mut columns: Vec<&mut [f64]> = data.iter_mut().map(Vec::as_mut_slice).collect();
            split_rows(n, &mut columns, |rows, part| {
                for (c, column) in part.iter_mut().enumerate() {
                    assert_eq!(column.len(), rows.len());
                    for (v, k) in column.iter_mut().zip(rows.clone()) {
                        *v += (k * 3 + c) as f64;
                    }
                }
            });
            for (c, column) in data.iter().enumerate() {
                assert!(column
                    .iter()
                    .enumerate()
                    .all(|(k, v)| *v == (k * 3 + c) as f64));
            }
        }
    }

    #[test]
    fn mapped_items_come_back_in_order_each_once() {
        for (n, rows) in [(0, 0), (5, 10), (5, 1_000_000), (37, 1_000_000)] {
            let items: Vec<usize> = (0..n).collect();
            let calls = std::sync::atomic::AtomicUsize::new(0);
            let out = map_items(&items, rows, |k| {
                calls.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
                k * k
            });
            assert_eq!(out, items.iter().map(|k| k * k).collect::<Vec<_>>());
            assert_eq!(calls.into_inner(), n);
        }
    }

    #[test]
    fn blocks_cover_the_rows_in_order() {
        let cut: Vec<_> = blocks(3..10, 3).collect();
        assert_eq!(cut, [3..6, 6..9, 9..10]);
        assert_eq!(blocks(4..4, 3).count(), 0);
    }
}
