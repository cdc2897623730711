//! What the raw CSV reader's fuzz targets check: its table is the general reader's.

use tolles_io::table::{write_with_column, Table};
use tolles_io::IoError;

/// Both readers of `text` give a table or both refuse it; their tables are [`assert_same`].
pub fn assert_agree(
    raw: Result<Table, IoError>,
    general: Result<Table, IoError>,
    text: &[u8],
    asks: usize,
) {
    match (raw, general) {
        (Ok(raw), Ok(general)) => assert_same(&raw, &general, text, asks),
        (Err(_), Err(_)) => {}
        (raw, general) => panic!(
            "{:?} vs {:?}",
            raw.map(|t| t.len()),
            general.map(|t| t.len())
        ),
    }
}

/// `raw` and `general`, read from `text`, have the same headers, rows, values or errors (bit
/// for bit; messages too where both readers count lines alike), asked for `asks` times, and
/// write the same text with one more column.
pub fn assert_same(raw: &Table, general: &Table, text: &[u8], asks: usize) {
    assert_eq!(raw.headers(), general.headers());
    assert_eq!(raw.len(), general.len());
    let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
    // Row numbers after a `\r\n` differ on purpose (README).
    let same_lines = !text.contains(&b'\r');
    for _ in 0..asks {
        for k in 0..raw.headers().len() {
            match (raw.numeric_at(k), general.numeric_at(k)) {
                (Ok(a), Ok(b)) => assert_eq!(bits(&a), bits(&b)),
                (Err(a), Err(b)) if same_lines => assert_eq!(a.to_string(), b.to_string()),
                (Err(_), Err(_)) => {}
                (a, b) => panic!("column {k}: {:?} vs {:?}", a.is_ok(), b.is_ok()),
            }
        }
    }
    let extra = vec![("new".to_string(), vec![0.5; raw.len()])];
    let (mut a, mut b) = (Vec::new(), Vec::new());
    write_with_column(raw, &extra, &mut a).unwrap();
    write_with_column(general, &extra, &mut b).unwrap();
    assert_eq!(a, b);
}
