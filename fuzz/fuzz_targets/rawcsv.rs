//! Fuzzes the CSV reader that leaves rows in the file's bytes (`tolles_io::rawcsv`): any bytes
//! give a table or an error, never a panic, and the same table, cells and written text as the
//! general reader.
#![no_main]

use libfuzzer_sys::fuzz_target;
use tolles_io::table::{write_with_column, Table};

fuzz_target!(|data: &[u8]| {
    let raw = Table::from_csv_bytes(data.to_vec(), "fuzz.csv");
    let general = Table::from_reader(data, "fuzz.csv");
    match (raw, general) {
        (Ok(raw), Ok(general)) => {
            assert_eq!(raw.headers(), general.headers());
            assert_eq!(raw.len(), general.len());
            for k in 0..raw.headers().len() {
                let (a, b) = (raw.numeric_at(k), general.numeric_at(k));
                assert_eq!(a.is_ok(), b.is_ok());
                if let (Ok(a), Ok(b)) = (a, b) {
                    let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
                    assert_eq!(bits(&a), bits(&b));
                }
            }
            let extra = vec![("new".to_string(), vec![0.5; raw.len()])];
            let (mut a, mut b) = (Vec::new(), Vec::new());
            write_with_column(&raw, &extra, &mut a).unwrap();
            write_with_column(&general, &extra, &mut b).unwrap();
            assert_eq!(a, b);
        }
        (Err(_), Err(_)) => {}
        (raw, general) => panic!("{:?} vs {:?}", raw.map(|t| t.len()), general.map(|t| t.len())),
    }
});
