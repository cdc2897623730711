//! Fuzzes `tolles convert` (the facade's workflow) on any bytes as any input format to every
//! output format: an error or a file that reads back with the rows it was said to hold, never
//! a panic; an existing output is replaced whole or left as it was.
#![no_main]

use libfuzzer_sys::fuzz_target;
use tolles::convert::{convert, ConvertRequest};
use tolles::progress::Silent;
use tolles_io::table::Table;

const INPUTS: [&str; 5] = ["csv", "xyz", "h5", "mat", "parquet"];
const OUTPUTS: [&str; 3] = ["csv", "h5", "parquet"];

fuzz_target!(|data: &[u8]| {
    let Some((&first, bytes)) = data.split_first() else {
        return;
    };
    let input_ext = INPUTS[usize::from(first) % INPUTS.len()];
    let output_ext = OUTPUTS[usize::from(first / 8) % OUTPUTS.len()];
    let dir = tempfile::TempDir::new().unwrap();
    let input = dir.path().join(format!("in.{input_ext}"));
    let output = dir.path().join(format!("out.{output_ext}"));
    std::fs::write(&input, bytes).unwrap();
    std::fs::write(&output, b"before").unwrap();
    let request = ConvertRequest::new(&input, &output);
    match convert(&request, &Silent, &mut Vec::new()) {
        Ok(result) => {
            let back = Table::read(&output, None).expect("a converted file reads back");
            assert_eq!(back.len(), result.rows);
        }
        Err(_) => assert_eq!(std::fs::read(&output).unwrap(), b"before"),
    }
});
