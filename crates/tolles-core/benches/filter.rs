//! Zero-phase band-pass of a fit's columns: 20 signals of 10⁶ samples (a design matrix of 19
//! columns and the scalar) through MagNav's 4th-order 0.1–0.9 Hz Butterworth at 10 Hz.
//!
//! `per_column` is the old way, `filtfilt_unless_constant` (the constancy test, then
//! `Butterworth::filtfilt`) per signal copied back, on one thread and (`per_column_threads`)
//! shared among the cores as `filtfilt_many_unless_constant` used to; `blocks` is
//! `filtfilt_many_unless_constant` now, eight signals per pass, with the widest kernels the
//! processor has, and `blocks_<simd>` the same with the kernels of each instruction set it
//! has (`blocks_portable` being the x86-64 baseline, SSE2).
//!
//! `level_and_band_rows` is a fit's run with heading levels: the level rows' low-pass and the
//! band-pass as two calls in turn, and as one job (`filtfilt_sampled_then_in_place`).
//!
//! `cargo bench -p tolles-core --bench filter`; under `taskset -c 0` the threaded variants
//! use one core, which compares the single-thread speed of the kernels.

use criterion::{criterion_group, BatchSize, Criterion, SamplingMode, Throughput};
use std::hint::black_box;
use tolles_core::signal::filter::{
    filtfilt_many_unless_constant, filtfilt_many_unless_constant_with,
    filtfilt_sampled_then_in_place, filtfilt_sampled_unless_constant, filtfilt_unless_constant,
    magnav_bandpass, Butterworth, Response, Simd,
};

const FS_HZ: f64 = 10.0;
const SAMPLES: usize = 1_000_000;
const SIGNALS: usize = 20;

/// Slow manoeuvre-like sines on large offsets plus broadband wiggle, different per signal
/// (the values do not change the work, but keep it realistic: no subnormals).
fn signals() -> Vec<Vec<f64>> {
    (0..SIGNALS)
        .map(|j| {
            let (f1, f2) = (0.05 + 0.01 * j as f64, 1.3 + 0.1 * j as f64);
            (0..SAMPLES)
                .map(|k| {
                    let t = k as f64 / FS_HZ;
                    let w = std::f64::consts::TAU * t;
                    1_000.0 * j as f64 + 300.0 * (f1 * w).sin() + 2.0 * (f2 * w).cos()
                })
                .collect()
        })
        .collect()
}

/// One signal at a time, as `filtfilt_many_unless_constant` did before blocks.
fn per_column(filter: &Butterworth, signals: &mut [Vec<f64>]) {
    for x in signals.iter_mut() {
        let filtered = filtfilt_unless_constant(filter, x).unwrap();
        x.copy_from_slice(&filtered);
    }
}

/// [`per_column`] shared among the cores by whole signals, the old threading.
fn per_column_threads(filter: &Butterworth, signals: &mut [Vec<f64>]) {
    let threads = std::thread::available_parallelism()
        .map_or(1, |t| t.get())
        .min(signals.len());
    let per_thread = signals.len().div_ceil(threads);
    std::thread::scope(|scope| {
        for share in signals.chunks_mut(per_thread) {
            scope.spawn(move || per_column(filter, share));
        }
    });
}

/// A way of filtering every signal in place.
type Variant = fn(&Butterworth, &mut [Vec<f64>]);

fn blocks(filter: &Butterworth, signals: &mut [Vec<f64>]) {
    let mut views: Vec<&mut [f64]> = signals.iter_mut().map(|x| x.as_mut_slice()).collect();
    filtfilt_many_unless_constant(filter, &mut views).unwrap();
}

fn bandpass(c: &mut Criterion) {
    let filter = magnav_bandpass(0.1, 0.9, 4, FS_HZ).unwrap().unwrap();
    let input = signals();
    let mut group = c.benchmark_group("filtfilt_20x1e6");
    group.sample_size(10).sampling_mode(SamplingMode::Flat);
    group.throughput(Throughput::Elements((SIGNALS * SAMPLES) as u64));
    let variants: [(&str, Variant); 3] = [
        ("per_column", per_column),
        ("per_column_threads", per_column_threads),
        ("blocks", blocks),
    ];
    for (name, run) in variants {
        group.bench_function(name, |b| {
            b.iter_batched_ref(
                || input.clone(),
                |x| run(&filter, black_box(x)),
                BatchSize::LargeInput,
            )
        });
    }
    for simd in Simd::available() {
        group.bench_function(format!("blocks_{}", simd.name()), |b| {
            b.iter_batched_ref(
                || input.clone(),
                |x| {
                    let mut views: Vec<&mut [f64]> =
                        black_box(x).iter_mut().map(|x| x.as_mut_slice()).collect();
                    filtfilt_many_unless_constant_with(simd, &filter, &mut views).unwrap();
                },
                BatchSize::LargeInput,
            )
        });
    }
    group.finish();
}

/// The heading-level rows' low-pass: 4th order below 0.1 Hz at 10 Hz, one sample in 50 kept,
/// of the 19 signals a default fit's linear step low-passes: `jumps` as a fit does it (the
/// kept samples evenly spaced, the delays jumping from one to the next), `every_sample` with
/// one more kept sample off the stride, which makes the recursion run through every sample.
fn lowpass_sampled(c: &mut Criterion) {
    let filter = Butterworth::design(4, Response::LowPass { cutoff_hz: 0.1 }, FS_HZ).unwrap();
    let input = signals();
    let views: Vec<&[f64]> = input[..19].iter().map(Vec::as_slice).collect();
    let even: Vec<usize> = (50..SAMPLES - 50).step_by(50).collect();
    let uneven: Vec<usize> = even.iter().copied().chain([SAMPLES - 1]).collect();
    let mut group = c.benchmark_group("lowpass_sampled_19x1e6");
    group.sample_size(10).sampling_mode(SamplingMode::Flat);
    group.throughput(Throughput::Elements((19 * SAMPLES) as u64));
    for (name, at) in [("jumps", &even), ("every_sample", &uneven)] {
        group.bench_function(name, |b| {
            b.iter(|| filtfilt_sampled_unless_constant(&filter, black_box(&views), at).unwrap())
        });
    }
    group.finish();
}

/// A fit's run with heading levels: the level rows' low-pass of 19 columns and the target
/// (one sample in 50 kept), then the band-pass of the 19 columns and the scalar in place, in
/// turn as two calls and together as one job on all cores.
fn level_and_band_rows(c: &mut Criterion) {
    let low = Butterworth::design(4, Response::LowPass { cutoff_hz: 0.1 }, FS_HZ).unwrap();
    let band = magnav_bandpass(0.1, 0.9, 4, FS_HZ).unwrap().unwrap();
    let input = signals();
    let target: Vec<f64> = input[SIGNALS - 1].iter().map(|v| v - 50_000.0).collect();
    let at: Vec<usize> = (50..SAMPLES - 50).step_by(50).collect();
    let mut group = c.benchmark_group("level_and_band_rows_20x1e6");
    group.sample_size(10).sampling_mode(SamplingMode::Flat);
    group.throughput(Throughput::Elements((SIGNALS * SAMPLES) as u64));
    group.bench_function("in_turn", |b| {
        b.iter_batched_ref(
            || input.clone(),
            |x| {
                let read: Vec<&[f64]> = x[..SIGNALS - 1]
                    .iter()
                    .map(Vec::as_slice)
                    .chain([target.as_slice()])
                    .collect();
                let rows = filtfilt_sampled_unless_constant(&low, &read, &at).unwrap();
                let mut views: Vec<&mut [f64]> = x.iter_mut().map(Vec::as_mut_slice).collect();
                filtfilt_many_unless_constant(&band, &mut views).unwrap();
                black_box(rows)
            },
            BatchSize::LargeInput,
        )
    });
    group.bench_function("together", |b| {
        b.iter_batched_ref(
            || input.clone(),
            |x| {
                let mut views: Vec<&mut [f64]> = x.iter_mut().map(Vec::as_mut_slice).collect();
                let rows = filtfilt_sampled_then_in_place(&low, &at, &target, &band, &mut views);
                black_box(rows.unwrap())
            },
            BatchSize::LargeInput,
        )
    });
    group.finish();
}

/// The band-pass of 20 signals short enough (4096 samples, 640 KiB) to stay in the second-level
/// cache: the recursion's own speed, which the 10⁶-sample runs above hide behind memory.
fn bandpass_in_cache(c: &mut Criterion) {
    let filter = magnav_bandpass(0.1, 0.9, 4, FS_HZ).unwrap().unwrap();
    let input: Vec<Vec<f64>> = signals().into_iter().map(|s| s[..4096].to_vec()).collect();
    let mut group = c.benchmark_group("filtfilt_20x4096");
    group.throughput(Throughput::Elements((SIGNALS * 4096) as u64));
    for simd in Simd::available() {
        group.bench_function(format!("blocks_{}", simd.name()), |b| {
            let mut x = input.clone();
            b.iter(|| {
                let mut views: Vec<&mut [f64]> = x.iter_mut().map(|x| x.as_mut_slice()).collect();
                filtfilt_many_unless_constant_with(simd, &filter, black_box(&mut views)).unwrap();
            })
        });
    }
    group.finish();
}

criterion_group!(
    benches,
    bandpass,
    lowpass_sampled,
    level_and_band_rows,
    bandpass_in_cache
);

fn main() {
    benches();
    Criterion::default().configure_from_args().final_summary();
}
