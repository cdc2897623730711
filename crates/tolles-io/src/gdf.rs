//! ASEG-GDF2: a `.dfn` file defines the fields (name, Fortran format, NULL value, units) of the
//! fixed-width records in a `.dat` file.
//!
//! ```
//! use tolles_io::gdf;
//! let dfn = "DEFN   ST=RECD,RT=COMM;RT:A4;COMMENTS:A76\n\
//!            DEFN 1 ST=RECD,RT=;TT:F10.1:UNITS=s\n\
//!            DEFN 2 ST=RECD,RT=;MAG_1_UC:F12.3:NULL=-99999.000,UNITS=nT\n\
//!            DEFN 3 ST=RECD,RT=;END DEFN\n";
//! let dat = "       0.0   50000.125\n       0.1  -99999.000\n";
//! let table = gdf::from_text(dfn, "f.dfn", dat, "f.dat").unwrap();
//! assert_eq!(table.headers(), ["TT", "MAG_1_UC"]);
//! let mag = table.numeric("MAG_1_UC").unwrap();
//! assert_eq!(mag[0], 50_000.125);
//! assert!(mag[1].is_nan()); // the field's NULL value is a missing value
//! ```
//!
//! A record is cut at the widths of its fields' formats; a record that does not fit them is
//! read as whitespace-separated fields, which GDF also allows. A field with a repeat count
//! (`3F10.3`) becomes columns `NAME_1`, `NAME_2`, `NAME_3`.

use crate::error::IoError;
use crate::table::{Column, Missing, Table, TextColumn};
use std::path::{Path, PathBuf};

/// One field of a data record as the `.dfn` defines it.
#[derive(Debug, Clone, PartialEq)]
pub struct Field {
    /// Column name.
    pub name: String,
    /// Characters the field takes in a fixed-width record.
    pub width: usize,
    /// True for a text (`A`) field.
    pub text: bool,
    /// The value that marks a missing cell, if the `.dfn` gives one.
    pub null: Option<f64>,
    /// Units as the `.dfn` states them (e.g. `nT`), if it does.
    pub units: Option<String>,
}

/// Reads a GDF pair given the path of either its `.dfn` or its `.dat` file.
pub fn read(path: &Path) -> Result<Table, IoError> {
    let (dfn, dat) = pair(path)?;
    from_text(&text(&dfn)?, &dfn, &text(&dat)?, &dat)
}

/// The file's text; bytes that are not UTF-8 are an error naming their line.
fn text(path: &Path) -> Result<String, IoError> {
    let bytes = std::fs::read(path).map_err(|source| IoError::Open {
        path: path.to_path_buf(),
        source,
    })?;
    String::from_utf8(bytes).map_err(|e| {
        let valid = &e.as_bytes()[..e.utf8_error().valid_up_to()];
        IoError::Malformed {
            path: path.to_path_buf(),
            line: valid.iter().filter(|&&b| b == b'\n').count() as u64 + 1,
            message: "not UTF-8 text".to_string(),
        }
    })
}

/// Reads a GDF pair from its texts; the names are used in error messages.
pub fn from_text(
    dfn: &str,
    dfn_name: impl AsRef<Path>,
    dat: &str,
    dat_name: impl AsRef<Path>,
) -> Result<Table, IoError> {
    // Every field takes at least one character of a record, so no .dat holds more fields
    // than it has bytes; a larger repeat count is refused before its columns are made.
    let (record_type, fields) = parse_dfn(dfn, dfn_name.as_ref(), dat.len() + 1)?;
    read_records(dat, dat_name.as_ref(), &record_type, &fields)
}

/// The `.dfn` and `.dat` of the pair `path` belongs to.
fn pair(path: &Path) -> Result<(PathBuf, PathBuf), IoError> {
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .unwrap_or("")
        .to_ascii_lowercase();
    let partner = |wanted: &str| {
        [wanted.to_string(), wanted.to_ascii_uppercase()]
            .into_iter()
            .map(|e| path.with_extension(e))
            .find(|p| p.exists())
            .ok_or_else(|| IoError::Invalid {
                path: path.to_path_buf(),
                message: format!(
                    "no {} file beside it ({} not found); ASEG-GDF2 needs both the .dfn and the .dat",
                    wanted,
                    path.with_extension(wanted).display()
                ),
            })
    };
    if ext == "dfn" {
        Ok((path.to_path_buf(), partner("dat")?))
    } else {
        Ok((partner("dfn")?, path.to_path_buf()))
    }
}

/// The data record type and its fields, from `.dfn` text; more than `max_fields` fields is an
/// error.
pub fn parse_dfn(
    text: &str,
    path: &Path,
    max_fields: usize,
) -> Result<(String, Vec<Field>), IoError> {
    let mut record_type: Option<String> = None;
    let mut fields = Vec::new();
    for (k, line) in text.lines().enumerate() {
        let fail = |message: String| IoError::Malformed {
            path: path.to_path_buf(),
            line: k as u64 + 1,
            message,
        };
        let line = line.trim();
        let Some(rest) = line
            .strip_prefix("DEFN")
            .or_else(|| line.strip_prefix("defn"))
        else {
            continue;
        };
        let Some((head, field)) = rest.split_once(';') else {
            return Err(fail(
                "a DEFN record needs `ST=RECD,RT=...;NAME:FORMAT`".into(),
            ));
        };
        let rt = record_type_of(head);
        if rt.eq_ignore_ascii_case("COMM") || rt.eq_ignore_ascii_case("HEAD") {
            continue;
        }
        match &record_type {
            None => record_type = Some(rt.clone()),
            Some(data) if *data != rt => continue,
            Some(_) => {}
        }
        for field in field.split(';').map(str::trim).filter(|f| !f.is_empty()) {
            if field.to_ascii_uppercase().starts_with("END DEFN") {
                return finish(path, record_type, fields);
            }
            let room = max_fields.saturating_sub(fields.len());
            fields.extend(parse_field(field, room).map_err(fail)?);
        }
    }
    finish(path, record_type, fields)
}

fn finish(
    path: &Path,
    record_type: Option<String>,
    fields: Vec<Field>,
) -> Result<(String, Vec<Field>), IoError> {
    if fields.iter().all(|f| f.name.eq_ignore_ascii_case("RT")) {
        return Err(IoError::Invalid {
            path: path.to_path_buf(),
            message: "no DEFN record defines a data field".into(),
        });
    }
    Ok((record_type.unwrap_or_default(), fields))
}

/// The `RT=` value of a DEFN record's `ST=RECD,RT=...` part.
fn record_type_of(head: &str) -> String {
    head.split(',')
        .filter_map(|part| part.split_once('='))
        .find(|(key, _)| key.trim().ends_with("RT"))
        .map(|(_, value)| value.trim().to_string())
        .unwrap_or_default()
}

/// The columns one `NAME : FORMAT : ATTRIBUTES` definition makes; more than `room` is an error.
fn parse_field(field: &str, room: usize) -> Result<Vec<Field>, String> {
    let mut parts = field.splitn(3, ':');
    let name = parts.next().unwrap_or("").trim();
    let format = parts.next().map(str::trim).unwrap_or("");
    if name.is_empty() {
        return Err(format!("field definition {field:?} has no name"));
    }
    if format.is_empty() {
        return Err(format!("field {name:?} has no format (e.g. F10.3, I5, A4)"));
    }
    let (repeat, kind, width) = parse_format(format)
        .ok_or_else(|| format!("field {name:?}: {format:?} is not a Fortran format like F10.3"))?;
    if repeat > room {
        return Err(format!(
            "field {name:?}: {repeat} repeats are more fields than the .dat file can hold"
        ));
    }
    let attributes = parts.next().unwrap_or("");
    let attribute = |key: &str| {
        attributes
            .split(',')
            .filter_map(|a| a.split_once('='))
            .find(|(k, _)| k.trim().eq_ignore_ascii_case(key))
            .map(|(_, v)| v.trim().to_string())
    };
    let null = match attribute("NULL") {
        Some(v) => Some(
            v.parse::<f64>()
                .map_err(|_| format!("field {name:?}: NULL={v} is not a number"))?,
        ),
        None => None,
    };
    let make = |name: String| Field {
        name,
        width,
        text: kind == 'A',
        null,
        units: attribute("UNITS"),
    };
    Ok(if repeat == 1 {
        vec![make(name.to_string())]
    } else {
        (1..=repeat).map(|i| make(format!("{name}_{i}"))).collect()
    })
}

/// Largest repeat count and field width accepted: far beyond any survey channel (array channels
/// hold hundreds of values), small enough that a damaged `.dfn` cannot make the reader allocate
/// without bound (a repeat count of 10^17 aborted it).
const MAX_COUNT: usize = 1 << 16;

/// Repeat count, kind letter and width of a Fortran format such as `3F10.3`, `I5` or `A4`.
fn parse_format(format: &str) -> Option<(usize, char, usize)> {
    let upper = format.to_ascii_uppercase();
    let letter_at = upper.find(|c: char| c.is_ascii_alphabetic())?;
    let repeat = match &upper[..letter_at] {
        "" => 1,
        digits => digits.parse().ok()?,
    };
    let kind = upper[letter_at..].chars().next()?;
    if !matches!(kind, 'A' | 'I' | 'F' | 'E' | 'D' | 'G') || repeat == 0 {
        return None;
    }
    let spec = &upper[letter_at + 1..];
    let width: usize = spec.split('.').next()?.parse().ok()?;
    (width > 0 && width <= MAX_COUNT && repeat <= MAX_COUNT).then_some((repeat, kind, width))
}

/// The data records of `.dat` text as a table.
fn read_records(
    text: &str,
    path: &Path,
    record_type: &str,
    fields: &[Field],
) -> Result<Table, IoError> {
    let mut columns: Vec<TextColumn> = fields
        .iter()
        .map(|f| {
            TextColumn::new(Missing {
                token: None,
                null: f.null,
            })
        })
        .collect();
    let mut lines = Vec::new();
    for (k, line) in text.lines().enumerate() {
        if line.trim().is_empty() || line.starts_with("COMM") {
            continue;
        }
        let fail = |message| IoError::Malformed {
            path: path.to_path_buf(),
            line: k as u64 + 1,
            message,
        };
        if !line.trim_start().starts_with(record_type) {
            // Never dropped silently: such records are not read yet, so the file is refused.
            return Err(fail(format!(
                "the record does not start with the data record type {record_type:?} the .dfn defines"
            )));
        }
        let cells = split_record(line, fields).map_err(fail)?;
        for (column, cell) in columns.iter_mut().zip(cells) {
            column.push(cell);
        }
        lines.push(k as u64 + 1);
    }
    let mut headers = Vec::new();
    let mut kept = Vec::new();
    for (field, column) in fields.iter().zip(columns) {
        if !field.name.eq_ignore_ascii_case("RT") {
            headers.push(field.name.clone());
            kept.push(Column::Text(column));
        }
    }
    Table::from_columns(path, headers, kept, Some(lines))
}

/// The cells of one record: fixed-width when it fits the formats, else whitespace-separated.
fn split_record<'a>(line: &'a str, fields: &[Field]) -> Result<Vec<&'a str>, String> {
    if let Some(cells) = fixed_width(line, fields) {
        return Ok(cells);
    }
    let cells: Vec<&str> = line.split_whitespace().collect();
    if cells.len() == fields.len() {
        Ok(cells)
    } else {
        let names: Vec<&str> = fields.iter().map(|f| f.name.as_str()).collect();
        Err(format!(
            "{} fields, but the .dfn defines {} ({})",
            cells.len(),
            fields.len(),
            names.join(", ")
        ))
    }
}

/// The record cut at the fields' widths, if it is as long as they add up to and every
/// numeric field holds a number or blanks.
fn fixed_width<'a>(line: &'a str, fields: &[Field]) -> Option<Vec<&'a str>> {
    let line = line.trim_end();
    // Checked: a .dfn may give widths near usize::MAX.
    let total = fields
        .iter()
        .try_fold(0usize, |t, f| t.checked_add(f.width))?;
    let last = fields.last()?.width;
    if !line.is_ascii() || line.len() > total || line.len().saturating_add(last) <= total {
        return None;
    }
    let mut cells = Vec::with_capacity(fields.len());
    let mut start = 0usize;
    for field in fields {
        let end = start.saturating_add(field.width).min(line.len());
        let cell = line[start..end].trim();
        if !field.text && !cell.is_empty() && cell.parse::<f64>().is_err() {
            return None;
        }
        cells.push(cell);
        start = end;
    }
    Some(cells)
}

#[cfg(test)]
mod tests {
    use super::*;

    const DFN: &str = "DEFN 1 ST=RECD,RT=;LINE:I6:NULL=-9999\n\
        DEFN 2 ST=RECD,RT=; FLUX : 3F10.2 : NULL=-99999.00, UNITS=nT\n\
        DEFN 3 ST=RECD,RT=;END DEFN\n";

    fn read(dat: &str) -> Result<Table, IoError> {
        from_text(DFN, "t.dfn", dat, "t.dat")
    }

    #[test]
    fn repeated_fields_become_numbered_columns() {
        let t = read("  1001  30000.00     10.50  40000.00\n").unwrap();
        assert_eq!(t.headers(), ["LINE", "FLUX_1", "FLUX_2", "FLUX_3"]);
        assert_eq!(t.numeric("FLUX_2").unwrap(), [10.5]);
    }

    #[test]
    fn whitespace_records_are_read_too() {
        let t = read("1001 30000 10.5 40000\n1002 1 2 -99999\n").unwrap();
        assert_eq!(t.numeric("LINE").unwrap(), [1001.0, 1002.0]);
        assert!(t.numeric("FLUX_3").unwrap()[1].is_nan());
    }

    #[test]
    fn record_missing_a_field_names_its_line() {
        let err = read("1001 30000 10.5 40000\n1001 30000 10.5\n")
            .unwrap_err()
            .to_string();
        assert_eq!(
            err,
            "t.dat: line 2: 3 fields, but the .dfn defines 4 (LINE, FLUX_1, FLUX_2, FLUX_3)"
        );
    }

    #[test]
    fn bad_definitions_name_their_line() {
        let dfn = "DEFN 1 ST=RECD,RT=;LINE:I6\nDEFN 2 ST=RECD,RT=;MAG\n";
        let err = from_text(dfn, "t.dfn", "1\n", "t.dat")
            .unwrap_err()
            .to_string();
        assert_eq!(
            err,
            "t.dfn: line 2: field \"MAG\" has no format (e.g. F10.3, I5, A4)"
        );
        let err = from_text("DEFN 1 ST=RECD,RT=;MAG:X9\n", "t.dfn", "1\n", "t.dat")
            .unwrap_err()
            .to_string();
        assert!(err.contains("\"X9\" is not a Fortran format"), "{err}");
        let err = from_text("", "t.dfn", "1\n", "t.dat")
            .unwrap_err()
            .to_string();
        assert_eq!(err, "t.dfn: no DEFN record defines a data field");
    }

    #[test]
    fn huge_widths_and_repeats_are_errors_not_panics() {
        let dfn = |f: &str| format!("DEFN 1 ST=RECD,RT=;TT:F10.1\nDEFN 2 ST=RECD,RT=;{f}\n");
        let err = from_text(&dfn("X:60000F10.3"), "t.dfn", "1 2\n", "t.dat")
            .unwrap_err()
            .to_string();
        assert!(
            err.starts_with("t.dfn: line 2: field \"X\": 60000 repeats"),
            "{err}"
        );
        let err = from_text(
            &dfn("X:18446744073709551615F10.3"),
            "t.dfn",
            "1 2\n",
            "t.dat",
        )
        .unwrap_err()
        .to_string();
        assert!(err.contains("is not a Fortran format"), "{err}");
        let err = from_text(&dfn("B:F18446744073709551613.0"), "t.dfn", "1 2\n", "t.dat")
            .unwrap_err()
            .to_string();
        assert!(err.contains("is not a Fortran format"), "{err}");
    }

    #[test]
    fn records_of_another_type_are_errors_not_dropped() {
        let dfn = "DEFN 1 ST=RECD,RT=DATA;RT:A4\nDEFN 2 ST=RECD,RT=DATA;TT:F10.1\n\
                   DEFN 3 ST=RECD,RT=DATA;END DEFN\n";
        let dat = "COMM a comment\nDATA       0.0\nXXXX       0.1\nDATA       0.2\n";
        let err = from_text(dfn, "t.dfn", dat, "t.dat")
            .unwrap_err()
            .to_string();
        assert!(
            err.starts_with("t.dat: line 3: the record does not start"),
            "{err}"
        );
    }

    #[test]
    fn huge_repeat_counts_are_refused() {
        // Found by fuzzing (fuzz/fuzz_targets/gdf.rs): the reader aborted on capacity overflow.
        let dfn = "DEFN   S=;MAG_1_UC:888888888888888888F12.3:NU2.114.000   40000.874\n";
        let err = from_text(dfn, "t.dfn", "", "t.dat")
            .unwrap_err()
            .to_string();
        assert!(err.contains("is not a Fortran format"), "{err}");
        assert!(parse_format("70000F12.3").is_none());
        assert!(parse_format("F99999999.3").is_none());
        assert_eq!(parse_format("256F12.3"), Some((256, 'F', 12)));
    }

    #[test]
    fn formats_parse() {
        assert_eq!(parse_format("F10.3"), Some((1, 'F', 10)));
        assert_eq!(parse_format("3e15.6"), Some((3, 'E', 15)));
        assert_eq!(parse_format("A4"), Some((1, 'A', 4)));
        assert_eq!(parse_format("10"), None);
    }
}
