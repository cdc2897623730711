//! Fuzzes CSV read a chunk at a time (`tolles_io::chunks`, blocks of lines for the raw reader
//! and the general reader from the first block it must take): any bytes give chunks or an
//! error, never a panic, and the same rows, values and written text as the file read whole.
#![no_main]

use libfuzzer_sys::fuzz_target;
use std::io::Write;
use tolles_io::chunks::{ChunkReader, CsvChunkWriter};
use tolles_io::format::Format;
use tolles_io::table::{write_with_column, Table};

fuzz_target!(|data: &[u8]| {
    let Some((&first, text)) = data.split_first() else {
        return;
    };
    let rows = usize::from(first % 8) + 1;
    let mut file = tempfile::NamedTempFile::with_suffix(".csv").unwrap();
    file.write_all(text).unwrap();
    let path = file.path();
    let whole = Table::read(path, Some(Format::Csv));
    let chunked = ChunkReader::open(path, Format::Csv, rows).and_then(|mut reader| {
        let mut writer = CsvChunkWriter::new(Vec::new(), reader.headers(), &["e".into()]).unwrap();
        let mut values: Vec<Vec<u64>> = vec![Vec::new(); reader.headers().len()];
        while let Some(chunk) = reader.next_chunk()? {
            assert!(chunk.len() <= rows);
            writer.write(&chunk, &[&vec![0.5; chunk.len()]]).unwrap();
            for (j, column) in values.iter_mut().enumerate() {
                // A bad cell's error is the whole read's (checked by the tests); here, no panic.
                if let Ok(v) = chunk.numeric_at(j) {
                    column.extend(v.iter().map(|x| x.to_bits()));
                }
            }
        }
        Ok(writer.finish().unwrap())
    });
    match (whole, chunked) {
        (Ok(table), Ok(text)) => {
            let mut expected = Vec::new();
            let extra = vec![("e".to_string(), vec![0.5; table.len()])];
            write_with_column(&table, &extra, &mut expected).unwrap();
            assert_eq!(text, expected);
        }
        (Err(_), Err(_)) => {}
        (a, b) => panic!("{:?} vs {:?}", a.map(|t| t.len()), b.map(|t| t.len())),
    }
});
