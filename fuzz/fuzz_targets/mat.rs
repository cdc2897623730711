//! Fuzzes the MATLAB v5 MAT-file reader on raw file bytes: a damaged file must give an error,
//! never a crash, a hang or an allocation beyond what the file's size allows.
#![no_main]

use libfuzzer_sys::fuzz_target;
use tolles_io::mat;

fuzz_target!(|data: &[u8]| {
    let _ = mat::from_bytes(data, "fuzz.mat");
});
