//! Reading and writing a 500 000-row survey CSV (six columns, 33 MB), stage by stage: finding
//! the rows with the five numeric columns a compensation needs parsed on the way, the general
//! cell-by-cell reader for comparison, parsing a column later on demand, and writing every row
//! back with one new column (rows copied, the new cells formatted on all cores).
//!
//! `cargo bench -p tolles-io --bench csv`; the whole commands next to pyarrow and NumPy are
//! `bench/limit`.

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use std::hint::black_box;
use std::io::Write;
use std::path::Path;
use tolles_io::table::{indices_after_renames, write_with_column, Table};

const ROWS: usize = 500_000;
const NEEDED: [&str; 5] = ["tt", "mag_1_uc", "flux_a_x", "flux_a_y", "flux_a_z"];

/// A survey in the layout of `bench/gen_flight.py`, written once per run.
fn survey(path: &Path) {
    let mut out = std::io::BufWriter::new(std::fs::File::create(path).unwrap());
    writeln!(out, "tt,mag_1_uc,flux_a_x,flux_a_y,flux_a_z,truth_earth").unwrap();
    for k in 0..ROWS {
        let t = k as f64 / 10.0;
        let a = (t * 0.37).sin();
        writeln!(
            out,
            "{t:.4},{:.4},{:.4},{:.4},{:.4},{:.4}",
            50_000.0 + 30.0 * a,
            20_697.394 + 900.0 * a,
            -1_724.18 + 2_000.0 * (t * 0.11).cos(),
            45_482.42 - 300.0 * a,
            50_000.0 + 0.1 * t
        )
        .unwrap();
    }
}

fn stages(c: &mut Criterion) {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("survey.csv");
    survey(&path);
    let bytes = std::fs::metadata(&path).unwrap().len();
    let needed: Vec<String> = NEEDED.iter().map(|s| s.to_string()).collect();
    let wanted = |headers: &[String]| indices_after_renames(headers, &[], &needed);
    let mut group = c.benchmark_group("csv");
    group.sample_size(10).throughput(Throughput::Bytes(bytes));
    group.bench_function("read, 5 columns parsed on the way", |b| {
        b.iter(|| black_box(Table::csv().parsing(&wanted).path_in_place(&path).unwrap()))
    });
    group.bench_function("read cell by cell (general reader)", |b| {
        b.iter(|| black_box(Table::csv().cell_by_cell().path(&path).unwrap()))
    });
    let table = Table::csv().path_in_place(&path).unwrap().unwrap();
    group.bench_function("parse 5 columns on demand", |b| {
        b.iter(|| black_box(table.parse_together(&NEEDED).numeric("flux_a_z").unwrap()))
    });
    let extra = vec![("mag_1_c".to_string(), table.numeric("mag_1_uc").unwrap())];
    group.bench_function("write rows + 1 column", |b| {
        b.iter(|| write_with_column(&table, &extra, std::io::sink()).unwrap())
    });
    group.finish();
}

criterion_group!(benches, stages);
criterion_main!(benches);
