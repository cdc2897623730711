//! Fuzzes the Parquet reader on raw file bytes: a damaged file must give an error (a panic
//! inside `parquet` is contained by tolles-io), never a crash.
#![no_main]

use libfuzzer_sys::fuzz_target;
use tolles_io::parquet;

fuzz_target!(|data: &[u8]| {
    let _ = parquet::from_bytes(data.to_vec(), "fuzz.parquet");
});
