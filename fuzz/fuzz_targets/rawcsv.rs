//! Fuzzes the CSV reader that leaves rows in the file's bytes (`tolles_io::rawcsv`): any bytes
//! give a table or an error, never a panic, and the same table, cells and written text as the
//! general reader.
#![no_main]

#[path = "common/same_csv.rs"]
mod same_csv;

use libfuzzer_sys::fuzz_target;
use tolles_io::table::Table;

fuzz_target!(|data: &[u8]| {
    let raw = Table::csv().bytes(data.to_vec(), "fuzz.csv");
    let general = Table::csv().reader(data, "fuzz.csv");
    same_csv::assert_agree(raw, general, data, 1);
});
