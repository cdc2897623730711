//! Fuzzes the CSV reader: any bytes must give a table or an error, never a panic.
#![no_main]

use libfuzzer_sys::fuzz_target;
use tolles_io::table::Table;

fuzz_target!(|data: &[u8]| {
    if let Ok(table) = Table::csv().reader(data, "fuzz.csv") {
        for k in 0..table.headers().len() {
            let _ = table.numeric_at(k);
        }
    }
});
