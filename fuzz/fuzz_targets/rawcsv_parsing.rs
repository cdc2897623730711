//! Fuzzes the CSV reader's columns parsed while the rows are found (`tolles_io::rawcsv` with
//! wanted columns): the first byte picks the wanted columns (bit k: column k), the rest is the
//! file. Any bytes give a table or an error, never a panic, and every column, asked for once
//! and again, has the general reader's values (or its error), bit for bit, as does the written
//! text.
#![no_main]

#[path = "common/same_csv.rs"]
mod same_csv;

use libfuzzer_sys::fuzz_target;
use tolles_io::table::Table;

fuzz_target!(|data: &[u8]| {
    let Some((&mask, text)) = data.split_first() else {
        return;
    };
    let wanted = |headers: &[String]| -> Vec<usize> {
        (0..headers.len().min(8))
            .filter(|k| mask >> k & 1 == 1)
            .collect()
    };
    let raw = Table::csv().parsing(&wanted).bytes(text.to_vec(), "fuzz.csv");
    let general = Table::csv().reader(text, "fuzz.csv");
    same_csv::assert_agree(raw, general, text, 2);
});
