//! What reading (and optionally writing) a flight table costs, for the speed benchmark
//! (`bench/run`): the floor under `tolles compensate` on the same file.
//!
//! ```sh
//! cargo run --release -p tolles-io --example read_cost -- flight.parquet \
//!     --columns tt,mag_1_uc,flux_a_x,flux_a_y,flux_a_z --write copy.parquet
//! ```
//!
//! Prints one JSON line: seconds to read the table (`read_s`), to turn the named columns into
//! numbers (`columns_s`) and to write the table back with one extra column in the format the
//! output's extension names (`write_s`, 0 without `--write`).

use std::path::PathBuf;
use std::time::Instant;
use tolles_io::format::{write_table, Format};
use tolles_io::table::Table;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let mut path = None;
    let mut columns = Vec::new();
    let mut write = None;
    while let Some(arg) = args.next() {
        match arg.as_str() {
            "--columns" => {
                let list = args.next().ok_or("--columns needs a list")?;
                columns = list.split(',').map(str::to_string).collect();
            }
            "--write" => write = Some(PathBuf::from(args.next().ok_or("--write needs a path")?)),
            _ => path = Some(PathBuf::from(arg)),
        }
    }
    let path = path.ok_or("usage: read_cost FILE [--columns a,b,...] [--write OUT]")?;

    let start = Instant::now();
    let table = Table::read(&path, None)?;
    let read_s = start.elapsed().as_secs_f64();

    let start = Instant::now();
    let mut first = Vec::new();
    for name in &columns {
        first = table.numeric(name)?;
    }
    let columns_s = start.elapsed().as_secs_f64();

    let start = Instant::now();
    if let Some(out) = &write {
        let extra = [("copy", first.as_slice())];
        write_table(&table, &extra, out, Format::for_output(out)?)?;
    }
    let write_s = start.elapsed().as_secs_f64();
    println!(
        "{{\"rows\": {}, \"read_s\": {read_s:.6}, \"columns_s\": {columns_s:.6}, \"write_s\": {write_s:.6}}}",
        table.len()
    );
    Ok(())
}
