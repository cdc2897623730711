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
//! read as whitespace-separated (or tab-separated) fields, which GDF also allows. A field with
//! a repeat count (`3F10.3`) becomes columns `NAME_1`, `NAME_2`, `NAME_3`.
//!
//! What real surveys write is read too: a `.dfn` whose first DEFN is another record type
//! (`RT=PROJ`; only the data record's fields make columns, other types' lines in the `.dat`
//! are skipped); `RT=DATA` declared while the records carry no `DATA` (and records carrying it
//! though the `.dfn` does not say so); `RT:A4` declared but absent from the records;
//! attributes separated by colons, commas or semicolons, or after a comma straight after the
//! format (`A8,NAME=TYPE`); a trailing `*` on every record; and a truncated last record, whose
//! row is kept with its missing cells missing. Any other record that does not fit the
//! definition is an error naming its line.

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
    let definition = parse_dfn(dfn, dfn_name.as_ref(), dat.len() + 1)?;
    read_records(dat, dat_name.as_ref(), &definition)
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

/// What a `.dfn` defines: the data record's fields, and the other record types whose lines
/// the `.dat` may hold.
#[derive(Debug, Clone, PartialEq)]
pub struct Definition {
    /// The data record's type (`RT=DATA`), or empty when the `.dfn` leaves it blank.
    pub record_type: String,
    /// Width of the `RT` field the data record declares first (`RT:A4`), if it declares one.
    /// Real files often declare it and then write records without it; both are read.
    pub rt_width: Option<usize>,
    /// The data record's fields, without `RT`: one column each.
    pub fields: Vec<Field>,
    /// The other record types (`COMM`, `PROJ`, ...): their lines in the `.dat` are skipped.
    pub others: Vec<String>,
}

/// Most record types a `.dfn` may define; every `.dat` line is compared with each.
const MAX_RECORD_TYPES: usize = 256;

fn is_comment_type(rt: &str) -> bool {
    rt.eq_ignore_ascii_case("COMM") || rt.eq_ignore_ascii_case("HEAD")
}

/// The data record and the other record types, from `.dfn` text; more than `max_fields`
/// fields is an error.
///
/// A DEFN with a blank `RT=` continues the record type defined before it (files declare
/// `RT=DATA;RT:A4;FLTLINE:F10.1` and then give the other fields `RT=`), or starts the blank
/// type when no record is being defined. The data record is the type with the most fields.
pub fn parse_dfn(text: &str, path: &Path, max_fields: usize) -> Result<Definition, IoError> {
    // Record types in the order they are defined, with their fields (RT included).
    let mut types: Vec<(String, Vec<Field>)> = Vec::new();
    let mut current: Option<usize> = None;
    let mut count = 0usize;
    'lines: for (k, line) in text.lines().enumerate() {
        let fail = |message: String| IoError::Malformed {
            path: path.to_path_buf(),
            line: k as u64 + 1,
            message,
        };
        let line = line.trim();
        let Some(rest) = line
            .get(..4)
            .filter(|d| d.eq_ignore_ascii_case("DEFN"))
            .map(|_| &line[4..])
        else {
            continue;
        };
        let Some((head, defs)) = rest.split_once(';') else {
            return Err(fail(
                "a DEFN record needs `ST=RECD,RT=...;NAME:FORMAT`".into(),
            ));
        };
        let rt = record_type_of(head);
        let known = types
            .iter()
            .position(|(name, _)| name.eq_ignore_ascii_case(&rt));
        let at = match (rt.is_empty(), current, known) {
            (true, Some(at), _) => at,
            (_, _, Some(at)) => at,
            _ => {
                if types.len() == MAX_RECORD_TYPES {
                    return Err(fail(format!(
                        "more than {MAX_RECORD_TYPES} record types are defined"
                    )));
                }
                types.push((rt.clone(), Vec::new()));
                types.len() - 1
            }
        };
        // Comment records' fields make no columns; blank RT= after them is not a comment.
        current = (!is_comment_type(&rt)).then_some(at);
        for def in defs.split(';').map(str::trim).filter(|f| !f.is_empty()) {
            if def.to_ascii_uppercase().starts_with("END DEFN") {
                break 'lines;
            }
            if is_comment_type(&rt) {
                continue;
            }
            let made = parse_field(def, max_fields.saturating_sub(count)).map_err(fail)?;
            count += made.len();
            types[at].1.extend(made);
        }
    }
    let is_rt = |f: &Field| f.name.eq_ignore_ascii_case("RT");
    let data = types
        .iter()
        .enumerate()
        .filter(|(_, (rt, _))| !is_comment_type(rt))
        .map(|(at, (_, fields))| (at, fields.iter().filter(|f| !is_rt(f)).count()))
        .filter(|&(_, n)| n > 0)
        // The most fields; the first defined of equals.
        .min_by_key(|&(at, n)| (std::cmp::Reverse(n), at))
        .map(|(at, _)| at)
        .ok_or_else(|| IoError::Invalid {
            path: path.to_path_buf(),
            message: "no DEFN record defines a data field".into(),
        })?;
    let (record_type, mut fields) = types[data].clone();
    let rt_width = match fields.first() {
        Some(f) if is_rt(f) => Some(fields.remove(0).width),
        _ => None,
    };
    let mut others: Vec<String> = types
        .into_iter()
        .enumerate()
        .filter(|(at, (rt, _))| *at != data && !rt.is_empty())
        .map(|(_, (rt, _))| rt)
        .collect();
    if !others.iter().any(|rt| rt.eq_ignore_ascii_case("COMM")) {
        others.push("COMM".into());
    }
    Ok(Definition {
        record_type,
        rt_width,
        fields,
        others,
    })
}

/// The `RT=` value of a DEFN record's `ST=RECD,RT=...` part.
fn record_type_of(head: &str) -> String {
    head.split(',')
        .filter_map(|part| part.split_once('='))
        .find(|(key, _)| key.trim().to_ascii_uppercase().ends_with("RT"))
        .map(|(_, value)| value.trim().to_string())
        .unwrap_or_default()
}

/// The columns one `NAME : FORMAT : ATTRIBUTES` definition makes; more than `room` is an error.
///
/// Attributes (`NULL=`, `UNITS=` or `UNIT=`, `NAME=`, ...) may be separated by commas, colons
/// or semicolons, and may follow the format after a comma (`A8,NAME=TYPE`); words without `=`
/// among them are ignored.
fn parse_field(field: &str, room: usize) -> Result<Vec<Field>, String> {
    let (name, rest) = field.split_once(':').unwrap_or((field, ""));
    let name = name.trim();
    let (format, attributes) = rest
        .split_once([':', ','])
        .map_or((rest, ""), |(f, a)| (f, a));
    let format = format.trim();
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
    let attribute = |keys: &[&str]| {
        attributes
            .split([',', ':', ';'])
            .filter_map(|a| a.split_once('='))
            .find(|(k, _)| keys.iter().any(|key| k.trim().eq_ignore_ascii_case(key)))
            .map(|(_, v)| v.trim().to_string())
    };
    let null = match attribute(&["NULL"]) {
        Some(v) if v.is_empty() => None,
        Some(v) => Some(
            v.parse::<f64>()
                .map_err(|_| format!("field {name:?}: NULL={v} is not a number"))?,
        ),
        None => None,
    };
    let units = attribute(&["UNITS", "UNIT"]).filter(|u| !u.is_empty());
    let make = |name: String| Field {
        name,
        width,
        text: kind == 'A',
        null,
        units: units.clone(),
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

/// `line` without its leading `prefix` (any case), if it starts with it.
fn strip_prefix_ignore_case<'a>(line: &'a str, prefix: &str) -> Option<&'a str> {
    let head = line.get(..prefix.len())?;
    head.eq_ignore_ascii_case(prefix)
        .then(|| &line[prefix.len()..])
}

/// The data part of a `.dat` line: `None` for a line to skip (blank, or a record of another
/// type), the line without its record-type prefix for a data record, or an error for a record
/// of a type the `.dfn` does not define.
fn data_part<'a>(line: &'a str, def: &Definition) -> Result<Option<&'a str>, String> {
    let line = line.strip_suffix('\r').unwrap_or(line);
    let start = line.trim_start();
    if start.is_empty() {
        return Ok(None);
    }
    let rt = def.record_type.as_str();
    // The data type first: its name may begin with another type's.
    if !rt.is_empty() {
        if let Some(rest) = strip_prefix_ignore_case(start, rt) {
            // The rest of a wider RT cell (`RT:A4` holding `DAT`) is blank.
            let pad = def.rt_width.unwrap_or(0).saturating_sub(rt.len());
            let blank = rest.len() - rest.trim_start_matches(' ').len();
            return Ok(Some(&rest[pad.min(blank)..]));
        }
    }
    if def
        .others
        .iter()
        .any(|other| strip_prefix_ignore_case(start, other).is_some())
    {
        return Ok(None);
    }
    // A numeric first field that starts with a word: the word is a record type.
    let first_numeric = def.fields.first().is_some_and(|f| !f.text);
    let word: &str = start.split_whitespace().next().unwrap_or("");
    let lead = word
        .find(|c: char| !c.is_ascii_alphabetic())
        .map_or(word, |at| &word[..at]);
    if first_numeric && !lead.is_empty() && crate::header::parse_cell(word).is_none() {
        // Records that carry `DATA` though the .dfn names no data type.
        if rt.is_empty() && lead.eq_ignore_ascii_case("DATA") {
            return Ok(Some(&start[4..]));
        }
        return Err(if rt.is_empty() {
            format!("a record of type {lead:?}, which the .dfn does not define")
        } else {
            format!(
                "the record does not start with the data record type {rt:?} the .dfn defines \
                 (it starts with {lead:?}, which the .dfn does not define)"
            )
        });
    }
    Ok(Some(line))
}

/// The data records of `.dat` text as a table.
fn read_records(text: &str, path: &Path, def: &Definition) -> Result<Table, IoError> {
    let fields = &def.fields;
    let mut records = Vec::new();
    for (k, line) in text.lines().enumerate() {
        let fail = |message| IoError::Malformed {
            path: path.to_path_buf(),
            line: k as u64 + 1,
            message,
        };
        if let Some(body) = data_part(line, def).map_err(fail)? {
            records.push((k as u64 + 1, body));
        }
    }
    if records.is_empty() {
        return Err(IoError::Invalid {
            path: path.to_path_buf(),
            message: "no data records: every line is blank, a comment or a record of another \
                      type than the data record the .dfn defines"
                .into(),
        });
    }
    let mut columns: Vec<TextColumn> = fields
        .iter()
        .map(|f| {
            TextColumn::new(Missing {
                token: None,
                null: f.null,
            })
        })
        .collect();
    let mut lines = Vec::with_capacity(records.len());
    let mut fixed = None;
    let last = records.len() - 1;
    // The file ends inside its last record (no newline after it).
    let open_end = !text.ends_with('\n') && records[last].0 == text.lines().count() as u64;
    for (at, &(line, body)) in records.iter().enumerate() {
        let (cells, was_fixed) =
            split_record(body, fields, at == last, at == last && open_end, fixed).map_err(
                |message| IoError::Malformed {
                    path: path.to_path_buf(),
                    line,
                    message,
                },
            )?;
        fixed.get_or_insert(was_fixed);
        for (column, cell) in columns.iter_mut().zip(cells) {
            column.push(cell);
        }
        lines.push(line);
    }
    let headers = fields.iter().map(|f| f.name.clone()).collect();
    let kept = columns.into_iter().map(Column::Text).collect();
    let units = fields
        .iter()
        .filter_map(|f| Some((f.name.clone(), f.units.clone()?)))
        .collect();
    Ok(Table::from_columns(path, headers, kept, Some(lines))?.with_units(units))
}

/// The cells of one record, and whether they were cut at the fields' widths (else split at
/// whitespace). The last record of a file may be truncated: its missing cells are blank (a
/// missing value), cut at the widths when the file's records are (`fixed` says how the earlier
/// records were read) and the record fits them, else split at whitespace; `open_end` says the
/// file ends inside it, so its last token may have lost digits.
fn split_record<'a>(
    line: &'a str,
    fields: &[Field],
    last: bool,
    open_end: bool,
    fixed: Option<bool>,
) -> Result<(Vec<&'a str>, bool), String> {
    let line = without_end_mark(line, fields);
    // The file ends inside a fixed-width record: its cut field is missing, not a wrong value.
    if open_end && fixed == Some(true) {
        if let Some(cells) = fixed_width(line, fields, true) {
            return Ok((cells, true));
        }
    }
    if let Some(cells) = fixed_width(line, fields, false) {
        return Ok((cells, true));
    }
    let mut cells: Vec<&str> = line.split_whitespace().collect();
    if cells.len() == fields.len() {
        return Ok((cells, false));
    }
    if last && cells.len() < fields.len() {
        if fixed != Some(false) {
            if let Some(cells) = fixed_width(line, fields, true) {
                return Ok((cells, true));
            }
        }
        // The last token of a record the file ends inside may have lost digits, and one that
        // is not a number was cut; either is missing rather than a wrong value.
        if let Some(at) = cells.len().checked_sub(1) {
            let cut = open_end && !line.ends_with(char::is_whitespace);
            if !fields[at].text && (cut || crate::header::parse_cell(cells[at]).is_none()) {
                cells[at] = "";
            }
        }
        cells.resize(fields.len(), "");
        return Ok((cells, false));
    }
    let names: Vec<&str> = fields.iter().map(|f| f.name.as_str()).collect();
    Err(format!(
        "{} fields, but the .dfn defines {} ({})",
        cells.len(),
        fields.len(),
        names.join(", ")
    ))
}

/// `line` without a trailing `*` token, which some writers end every record with, when the
/// last field is numeric (so the `*` cannot be its value).
fn without_end_mark<'a>(line: &'a str, fields: &[Field]) -> &'a str {
    let trimmed = line.trim_end();
    match trimmed.strip_suffix('*') {
        Some(rest) if rest.ends_with([' ', '\t']) && fields.last().is_some_and(|f| !f.text) => rest,
        _ => line,
    }
}

/// The record cut at the fields' widths, if it is as long as they add up to and every
/// numeric field holds a number or blanks. With `truncated`, a shorter record is cut too: the
/// fields past its end are blank, and a numeric field it ends inside is blank (its digits are
/// cut off).
fn fixed_width<'a>(line: &'a str, fields: &[Field], truncated: bool) -> Option<Vec<&'a str>> {
    let full = line.len();
    let line = line.trim_end();
    // Checked: a .dfn may give widths near usize::MAX.
    let total = fields
        .iter()
        .try_fold(0usize, |t, f| t.checked_add(f.width))?;
    let last = fields.last()?.width;
    if !line.is_ascii() || line.contains('\t') || line.len() > total {
        return None;
    }
    if !truncated && line.len().saturating_add(last) <= total {
        return None;
    }
    let mut cells = Vec::with_capacity(fields.len());
    let mut start = 0usize;
    for field in fields {
        let end = start.saturating_add(field.width);
        let cut_off = truncated && end > full && start < full;
        let end = end.min(line.len());
        let start_at = start.min(end);
        let cell = line[start_at..end].trim();
        let cell = if cut_off && !field.text { "" } else { cell };
        if !field.text && crate::header::parse_cell(cell).is_none() {
            return None;
        }
        cells.push(cell);
        start = start.saturating_add(field.width);
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
        let err = read("1001 30000 10.5 40000\n1001 30000 10.5\n1003 1 2 3\n")
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
    fn data_record_after_another_record_type_and_blank_rt_continuing_it() {
        let dfn = "DEFN   ST=RECD,RT=PROJ; RT: A4\n\
                   DEFN 1 ST=RECD,RT=DATA;RT:A4;LINE:F10.1:NAME=Line number\n\
                   DEFN 2 ST=RECD,RT=;MAG:F10.2:NULL=-99999.99:UNIT=nT:NAME=mag\n\
                   DEFN 3 ST=RECD,RT=;END DEFN\n";
        let def = parse_dfn(dfn, Path::new("t.dfn"), 100).unwrap();
        assert_eq!(def.record_type, "DATA");
        assert_eq!(def.rt_width, Some(4));
        assert_eq!(def.fields.len(), 2);
        assert_eq!(def.fields[1].null, Some(-99999.99));
        assert_eq!(def.fields[1].units.as_deref(), Some("nT"));
        assert!(def.others.iter().any(|o| o == "PROJ"));
        // RT absent from tab-separated records; PROJ and COMM lines skipped.
        let dat = "PROJ my project\nCOMM a comment\n690\t57743.27\n690\t-99999.99\n";
        let t = from_text(dfn, "t.dfn", dat, "t.dat").unwrap();
        assert_eq!(t.headers(), ["LINE", "MAG"]);
        assert_eq!(t.numeric("LINE").unwrap(), [690.0, 690.0]);
        assert!(t.numeric("MAG").unwrap()[1].is_nan());
        assert_eq!(t.line_of(0), 3);
        // The same records with the DATA prefix, fixed width.
        let dat = "DATA     690.0  57743.27\nDATA     691.0 -99999.99\n";
        let t = from_text(dfn, "t.dfn", dat, "t.dat").unwrap();
        assert_eq!(t.numeric("LINE").unwrap(), [690.0, 691.0]);
        assert_eq!(t.numeric("MAG").unwrap()[0], 57743.27);
    }

    #[test]
    fn data_prefix_on_records_of_a_blank_record_type_is_skipped() {
        let dat = "DATA  1001  30000.00     10.50  40000.00\nDATA 1002 1 2 3\n";
        let t = read(dat).unwrap();
        assert_eq!(t.numeric("LINE").unwrap(), [1001.0, 1002.0]);
        assert_eq!(t.numeric("FLUX_3").unwrap(), [40000.0, 3.0]);
    }

    #[test]
    fn attributes_after_colons_commas_and_a_comma_after_the_format() {
        let fields = parse_field("TYPE:A8,NAME=TYPE", 10).unwrap();
        assert_eq!((fields[0].width, fields[0].text), (8, true));
        let f = &parse_field("SERIAL:I7:NULL=-99999:NAME=SERIAL", 10).unwrap()[0];
        assert_eq!(f.null, Some(-99999.0));
        let f = &parse_field(
            "E:F11.2:NULL=9999999.99:UNIT:metres:NAME=Easting (MGA56)",
            10,
        )
        .unwrap()[0];
        assert_eq!((f.null, f.units.as_deref()), (Some(9_999_999.99), None));
        let f = &parse_field("FID:f10.1:FIDUCIAL ,NULL=-999999.0,NAME=fiducial", 10).unwrap()[0];
        assert_eq!((f.width, f.null), (10, Some(-999_999.0)));
        let f = &parse_field("FID:F9.0:NULL=99999999:UNIT::NAME=Fiducial", 10).unwrap()[0];
        assert_eq!(f.units, None);
        let err = parse_field("X:F9.0:NULL=abc", 10).unwrap_err();
        assert_eq!(err, "field \"X\": NULL=abc is not a number");
    }

    #[test]
    fn a_trailing_star_ends_records() {
        let t = read("  1001  30000.00     10.50  40000.00 *\n1002 1 2 3 *\n").unwrap();
        assert_eq!(t.numeric("FLUX_3").unwrap(), [40000.0, 3.0]);
    }

    #[test]
    fn a_truncated_last_record_keeps_its_row() {
        // Fixed width: the field the record ends inside is missing too (its digits are cut).
        let t = read("  1001  30000.00     10.50  40000.00\n  1002  30001.00     1\n").unwrap();
        assert_eq!(t.len(), 2);
        assert_eq!(t.numeric("FLUX_1").unwrap(), [30000.0, 30001.0]);
        assert!(t.numeric("FLUX_2").unwrap()[1].is_nan());
        assert!(t.numeric("FLUX_3").unwrap()[1].is_nan());
        // The file ends inside the last field of a full-looking fixed-width record.
        let t =
            read("  1001  30000.00     10.50  40000.00\n  1002  30001.00     10.50  400").unwrap();
        assert_eq!(t.numeric("FLUX_2").unwrap(), [10.5, 10.5]);
        assert!(t.numeric("FLUX_3").unwrap()[1].is_nan());
        // Whitespace-separated: the last token of a file that ends inside it may be cut.
        let t = read("1001 30000 10.5 40000\n1002 7 1").unwrap();
        assert_eq!(t.numeric("FLUX_1").unwrap(), [30000.0, 7.0]);
        assert!(t.numeric("FLUX_2").unwrap()[1].is_nan());
        let t = read("1001 30000 10.5 40000\n1002 7 1\n").unwrap();
        assert_eq!(t.numeric("FLUX_2").unwrap(), [10.5, 1.0]);
        assert!(t.numeric("FLUX_3").unwrap()[1].is_nan());
        let t = read("1001 30000 10.5 40000\n1002 7 -\n").unwrap();
        assert!(t.numeric("FLUX_2").unwrap()[1].is_nan());
        // Only the prefix of a record.
        let dfn = "DEFN 1 ST=RECD,RT=DATA;RT:A4;TT:F10.1\nDEFN 2 ST=RECD,RT=DATA;MAG:F10.1\n";
        let t = from_text(dfn, "t.dfn", "DATA       0.0      50.0\nDATA", "t.dat").unwrap();
        assert_eq!(t.len(), 2);
        assert!(t.numeric("TT").unwrap()[1].is_nan());
    }

    #[test]
    fn a_dat_without_data_records_says_so() {
        let err = read("COMM only a comment\n\n").unwrap_err().to_string();
        assert!(err.starts_with("t.dat: no data records"), "{err}");
        assert!(!err.contains("header"), "{err}");
        let dfn = "DEFN 1 ST=RECD,RT=;TT:F10.1\n";
        let err = from_text(dfn, "t.dfn", "", "t.dat")
            .unwrap_err()
            .to_string();
        assert!(err.starts_with("t.dat: no data records"), "{err}");
    }

    #[test]
    fn a_bad_number_names_its_line_and_column() {
        let t = read("1001 30000 10.5 40000\n1002 30000 x1.5 40000\n").unwrap();
        let err = t.numeric("FLUX_2").unwrap_err().to_string();
        assert!(err.contains("line 2") && err.contains("FLUX_2"), "{err}");
    }

    #[test]
    fn formats_parse() {
        assert_eq!(parse_format("F10.3"), Some((1, 'F', 10)));
        assert_eq!(parse_format("3e15.6"), Some((3, 'E', 15)));
        assert_eq!(parse_format("A4"), Some((1, 'A', 4)));
        assert_eq!(parse_format("10"), None);
    }
}
