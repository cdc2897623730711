//! Fit and compensate on synthetic calibration flights of 10⁴ … 10⁶ samples, and the stages of
//! a fit at 10⁶ samples (design matrix, band-pass of every column, the folds' QR factors,
//! cross-validation over them, applying a model, the whole default fit).
//!
//! `cargo bench -p tolles-core --bench fit`; the end-to-end comparison with other tools,
//! file reading included, is `bench/run`.

use criterion::{criterion_group, BenchmarkId, Criterion, SamplingMode, Throughput};
use std::f64::consts::PI;
use std::hint::black_box;
use tolles_core::compensate::{compensate, Level};
use tolles_core::fit::crossval::{cross_validate, LAMBDA_GRID};
use tolles_core::fit::ridge::Ridge;
use tolles_core::fit::{fit, FitSettings};
use tolles_core::model::vector::VectorSeries;
use tolles_core::signal::filter::{filtfilt_many_unless_constant, magnav_bandpass};

const FS_HZ: f64 = 10.0;
const SIZES: [usize; 3] = [10_000, 100_000, 1_000_000];

/// Folds of cross-validation in the stage benchmarks.
const FOLDS: usize = 5;

/// A 10 Hz flight rolling, pitching and yawing through a few degrees, and a scalar that sees the
/// earth field plus a permanent, induced and eddy-current aircraft field (nT).
fn flight(n: usize) -> (Vec<f64>, VectorSeries) {
    let earth = [20_000.0, -1_700.0, 45_300.0];
    let mut flux = VectorSeries::new(vec![0.0; n], vec![0.0; n], vec![0.0; n]);
    for k in 0..n {
        let t = k as f64 / FS_HZ;
        let roll = 0.17 * (2.0 * PI * 0.15 * t).sin();
        let pitch = 0.09 * (2.0 * PI * 0.12 * t + 1.0).sin();
        let yaw = 0.07 * (2.0 * PI * 0.1 * t + 2.0).sin() + (k / 3000) as f64 * PI / 2.0;
        let (sy, cy) = yaw.sin_cos();
        let (sp, cp) = pitch.sin_cos();
        let (sr, cr) = roll.sin_cos();
        let x1 = cy * earth[0] + sy * earth[1];
        let y1 = -sy * earth[0] + cy * earth[1];
        let x2 = cp * x1 - sp * earth[2];
        let z2 = sp * x1 + cp * earth[2];
        flux.x[k] = x2;
        flux.y[k] = cr * y1 + sr * z2;
        flux.z[k] = -sr * y1 + cr * z2;
    }
    let scalar = (0..n)
        .map(|k| {
            let m = flux.magnitude(k);
            let u = flux.at(k).map(|v| v / m);
            let next = flux.at((k + 1).min(n - 1));
            m + 12.0 * u[0] - 7.0 * u[1]
                + 25.0 * u[2]
                + 2e-3 * u[0] * flux.x[k]
                + 3e-4 * u[1] * flux.z[k]
                + 4e-2 * u[0] * (next[0] - flux.x[k])
        })
        .collect();
    (scalar, flux)
}

fn settings() -> [(&'static str, FitSettings); 2] {
    [
        ("magnav", FitSettings::magnav()),
        ("auto", FitSettings::recommended()),
    ]
}

fn fit_and_compensate(c: &mut Criterion) {
    let mut group = c.benchmark_group("fit");
    group.sample_size(10).sampling_mode(SamplingMode::Flat);
    for n in SIZES {
        let (scalar, flux) = flight(n);
        group.throughput(Throughput::Elements(n as u64));
        for (name, s) in settings() {
            if n == 1_000_000 && name == "auto" {
                continue; // fit_stages_1e6/whole_fit_defaults
            }
            group.bench_function(BenchmarkId::new(name, n), |b| {
                b.iter(|| black_box(fit(&scalar, &flux, FS_HZ, None, &s).unwrap()))
            });
        }
    }
    group.finish();

    let mut group = c.benchmark_group("compensate");
    group.sample_size(10).sampling_mode(SamplingMode::Flat);
    for n in SIZES {
        let (scalar, flux) = flight(n);
        let s = FitSettings::magnav();
        let model = fit(&scalar, &flux, FS_HZ, None, &s).unwrap();
        group.throughput(Throughput::Elements(n as u64));
        group.bench_function(BenchmarkId::new("magnav", n), |b| {
            b.iter(|| {
                black_box(compensate(
                    &scalar,
                    &flux,
                    None,
                    &s.design,
                    &model.coefficients,
                    1.0,
                    Level::FileMean,
                ))
            })
        });
    }
    group.finish();
}

/// Where a fit's time goes at 10⁶ samples, MagNav settings.
fn stages(c: &mut Criterion) {
    let n = 1_000_000;
    let (scalar, flux) = flight(n);
    let s = FitSettings::magnav();
    let filter = magnav_bandpass(0.1, 0.9, 4, FS_HZ).unwrap().unwrap();
    let a = s.design.matrix(&flux);
    let mut group = c.benchmark_group("fit_stages_1e6");
    group.sample_size(10).sampling_mode(SamplingMode::Flat);
    group.throughput(Throughput::Elements(n as u64));
    group.bench_function("design_matrix", |b| {
        b.iter(|| black_box(s.design.matrix(&flux)))
    });
    group.bench_function("bandpass_19_signals", |b| {
        b.iter(|| {
            let mut a = a.clone();
            let mut y = scalar.clone();
            let mut signals: Vec<&mut [f64]> = a.as_mut_slice().chunks_mut(n).collect();
            signals.push(&mut y);
            filtfilt_many_unless_constant(&filter, &mut signals).unwrap();
            black_box(a)
        })
    });
    group.bench_function("ridge_qr", |b| {
        b.iter(|| {
            let mut ridge = Ridge::new(a.ncols());
            ridge.push(&a, &scalar);
            black_box(ridge.solve(0.001, &s.design.column_names(&[])).unwrap())
        })
    });
    // The folds' factors straight from the columns, as a fit makes them.
    let fold_factors = || -> Vec<Ridge> {
        let share = n.div_ceil(FOLDS);
        (0..FOLDS)
            .map(|f| {
                let rows = f * share..((f + 1) * share).min(n);
                let columns: Vec<&[f64]> = a
                    .as_slice()
                    .chunks_exact(n)
                    .map(|c| &c[rows.clone()])
                    .collect();
                let mut ridge = Ridge::new(a.ncols());
                ridge.push_columns(&columns, &scalar[rows]);
                ridge
            })
            .collect()
    };
    group.bench_function("fold_factors_19_columns", |b| {
        b.iter(|| black_box(fold_factors()))
    });
    let folds = fold_factors();
    let names = s.design.column_names(&[]);
    group.bench_function("cross_validation_9_lambdas", |b| {
        b.iter(|| black_box(cross_validate(&folds, &LAMBDA_GRID, &names, &[])))
    });
    let beta = vec![0.5; a.ncols()];
    group.bench_function("apply_model", |b| {
        b.iter(|| black_box(s.design.apply(&flux, &beta)))
    });
    let recommended = FitSettings::recommended();
    group.bench_function("whole_fit_defaults", |b| {
        b.iter(|| black_box(fit(&scalar, &flux, FS_HZ, None, &recommended).unwrap()))
    });
    group.finish();
}

criterion_group!(benches, fit_and_compensate, stages);

fn main() {
    benches();
    Criterion::default().configure_from_args().final_summary();
}
