//! Fuzzes the HDF5 reader on raw file bytes: a damaged file must give an error (a panic inside
//! `hdf5-pure` is contained by tolles-io), never a crash or an allocation beyond the file's size.
#![no_main]

use libfuzzer_sys::fuzz_target;
use tolles_io::hdf5;

fuzz_target!(|data: &[u8]| {
    let _ = hdf5::from_bytes(data.to_vec(), "fuzz.h5");
});
