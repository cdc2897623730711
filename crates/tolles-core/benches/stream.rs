//! Throughput and per-sample latency of the streaming compensator.
//!
//! `cargo bench -p tolles-core --bench stream`: criterion measures the sustained throughput
//! (8 magnetometers, full 18-term model, central and causal derivatives); then the per-sample
//! compute latency (push → output) is printed as p50/p99/max, at full speed and paced at
//! 1280 Hz.

use criterion::{criterion_group, Criterion, Throughput};
use std::hint::black_box;
use std::time::{Duration, Instant};
use tolles_core::compensate::chunk::{ChunkCompensator, RawRows, Setup};
use tolles_core::compensate::stream::{Derivative, Sample, ScalarSpec, StreamCompensator};
use tolles_core::compensate::Model;
use tolles_core::model::design::Design;
use tolles_core::model::magnitude::Magnitude;

const MAGNETOMETERS: usize = 8;
const FS_HZ: f64 = 1280.0;

fn compensator(derivative: Derivative) -> StreamCompensator<usize> {
    let design = Design::new("p,i,e".parse().unwrap());
    let specs = (0..MAGNETOMETERS)
        .map(|i| {
            let beta: Vec<f64> = (0..design.width()).map(|k| (k + i) as f64 * 0.3).collect();
            ScalarSpec::new(
                &format!("mag_{i}_uc"),
                i % 2,
                design.clone(),
                &beta,
                1.0,
                1.0,
            )
        })
        .collect();
    StreamCompensator::new(
        specs,
        vec!["flux_a".into(), "flux_b".into()],
        FS_HZ,
        derivative,
    )
}

/// Sample `k`: a slowly rolling aircraft.
fn sample(k: usize) -> ([f64; MAGNETOMETERS], [[f64; 3]; 2]) {
    let t = k as f64 / FS_HZ;
    let b = [
        20_000.0 + 2_000.0 * (0.8 * t).sin(),
        -3_000.0 + 1_000.0 * (0.5 * t).cos(),
        45_000.0,
    ];
    ([50_000.0 + t; MAGNETOMETERS], [b, [b[0] + 5.0, b[1], b[2]]])
}

fn feed(stream: &mut StreamCompensator<usize>, k: usize) -> f64 {
    let (scalars, flux) = sample(k);
    let s = Sample {
        time_s: Some(k as f64 / FS_HZ),
        scalars: &scalars,
        fluxgates: &flux,
        extras: &[],
    };
    let mut sum = 0.0;
    stream.push(k, Some(s), Vec::new(), |o| sum += o.compensated[0]);
    sum
}

fn throughput(c: &mut Criterion) {
    const LINES: usize = 10_000;
    let mut group = c.benchmark_group("stream");
    group.throughput(Throughput::Elements((LINES * MAGNETOMETERS) as u64));
    for (name, derivative) in [
        ("central", Derivative::Central),
        ("causal", Derivative::Causal),
    ] {
        group.bench_function(format!("{name}_8_magnetometers"), |b| {
            let mut stream = compensator(derivative);
            let mut k = 0;
            b.iter(|| {
                let mut sum = 0.0;
                for _ in 0..LINES {
                    sum += feed(&mut stream, k);
                    k += 1;
                }
                black_box(sum)
            })
        });
    }
    // The batch compensator fed a row at a time, as `stream` would call it to share its
    // kernel: the price of one engine for all three paths.
    group.bench_function("chunk_engine_row_by_row_8_magnetometers", |b| {
        let design = Design::new("p,i,e".parse().unwrap());
        let betas: Vec<Vec<f64>> = (0..MAGNETOMETERS)
            .map(|i| (0..design.width()).map(|k| (k + i) as f64 * 0.3).collect())
            .collect();
        let mut engines: Vec<ChunkCompensator> = (betas.iter())
            .map(|beta| {
                let model = Model {
                    design: &design,
                    coefficients: beta,
                    magnitude: Magnitude::Linear,
                };
                ChunkCompensator::new(Setup {
                    median_step_s: Some(1.0 / FS_HZ),
                    ..Setup::new(model, FS_HZ, 1.0)
                })
            })
            .collect();
        let mut k = 0;
        b.iter(|| {
            let mut sum = 0.0;
            for _ in 0..LINES {
                let (_, flux) = sample(k);
                let t = [k as f64 / FS_HZ];
                for (i, engine) in engines.iter_mut().enumerate() {
                    let [x, y, z] = flux[i % 2].map(|v| [v]);
                    let rows = RawRows {
                        flux: vec![[&x, &y, &z]],
                        extras: Vec::new(),
                        inputs: Vec::new(),
                        tt: Some(&t),
                    };
                    for chunk in engine.push(rows) {
                        sum += chunk.field[0];
                    }
                }
                k += 1;
            }
            black_box(sum)
        })
    });
    group.finish();
}

/// p50, p99 and max of the compute latency of `lines` pushes, optionally paced at 1280 Hz.
fn latency(lines: usize, paced: bool) -> [Duration; 3] {
    let mut stream = compensator(Derivative::Causal);
    let mut times = Vec::with_capacity(lines);
    let start = Instant::now();
    for k in 0..lines {
        if paced {
            let due = start + Duration::from_secs_f64(k as f64 / FS_HZ);
            while Instant::now() < due {
                std::thread::sleep(Duration::from_micros(50));
            }
        }
        let t = Instant::now();
        black_box(feed(&mut stream, k));
        times.push(t.elapsed());
    }
    times.sort();
    [times[lines / 2], times[lines * 99 / 100], times[lines - 1]]
}

fn report_latency() {
    for (name, lines, paced) in [
        ("full speed", 1_000_000, false),
        ("paced at 1280 Hz", 6_400, true),
    ] {
        let [p50, p99, max] = latency(lines, paced);
        println!("stream latency, 8 magnetometers, {name} ({lines} lines): p50 {p50:?}, p99 {p99:?}, max {max:?}");
    }
}

criterion_group!(benches, throughput);

fn main() {
    benches();
    report_latency();
    Criterion::default().configure_from_args().final_summary();
}
