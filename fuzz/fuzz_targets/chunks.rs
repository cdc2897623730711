//! Fuzzes the chunked readers of Geosoft XYZ and Parquet (`tolles_io::chunks`, what bounded-
//! memory compensation reads): any bytes give chunks or an error, never a panic, and the same
//! rows and values as the file read whole.
#![no_main]

use libfuzzer_sys::fuzz_target;
use tolles_io::chunks::ChunkReader;
use tolles_io::format::Format;
use tolles_io::table::Table;

fuzz_target!(|data: &[u8]| {
    let Some((&first, bytes)) = data.split_first() else {
        return;
    };
    let (format, ext) = match first % 2 {
        0 => (Format::Xyz, "xyz"),
        _ => (Format::Parquet, "parquet"),
    };
    let rows = usize::from(first / 2 % 8) + 1;
    let mut file = tempfile::Builder::new().suffix(&format!(".{ext}")).tempfile().unwrap();
    std::io::Write::write_all(&mut file, bytes).unwrap();
    let path = file.path();
    let whole = Table::read(path, Some(format));
    let chunked = ChunkReader::open(path, format, rows).and_then(|mut reader| {
        let mut values: Vec<Vec<u64>> = vec![Vec::new(); reader.headers().len()];
        let mut count = 0;
        while let Some(chunk) = reader.next_chunk()? {
            assert!(chunk.len() <= rows);
            count += chunk.len();
            for (j, column) in values.iter_mut().enumerate() {
                if let Ok(v) = chunk.numeric_at(j) {
                    column.extend(v.iter().map(|x| x.to_bits()));
                }
            }
        }
        Ok((count, values))
    });
    if let (Ok(table), Ok((count, values))) = (whole, chunked) {
        assert_eq!(table.len(), count);
        for (j, column) in values.iter().enumerate() {
            if let Ok(v) = table.numeric_at(j) {
                if column.len() == v.len() {
                    let bits: Vec<u64> = v.iter().map(|x| x.to_bits()).collect();
                    assert_eq!(&bits, column, "column {j}");
                }
            }
        }
    }
});
