//! Fuzzes the ASEG-GDF2 reader. The input is the `.dfn` text, a NUL byte, then the `.dat` text
//! (the seeds are built that way); an input without NUL is a `.dfn` with an empty `.dat`.
#![no_main]

use libfuzzer_sys::fuzz_target;
use tolles_io::gdf;

fuzz_target!(|data: &[u8]| {
    let (dfn, dat) = match data.iter().position(|&b| b == 0) {
        Some(at) => (&data[..at], &data[at + 1..]),
        None => (data, &[][..]),
    };
    let dfn = String::from_utf8_lossy(dfn);
    let dat = String::from_utf8_lossy(dat);
    if let Ok(table) = gdf::from_text(&dfn, "fuzz.dfn", &dat, "fuzz.dat") {
        for k in 0..table.headers().len() {
            let _ = table.numeric_at(k);
        }
    }
});
