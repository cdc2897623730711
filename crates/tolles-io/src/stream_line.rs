//! CSV lines of a live stream: one record per line, read and written one at a time.
//!
//! ```
//! use tolles_io::stream_line::Layout;
//! let layout = Layout::from_header("tt,mag_1_uc,flux_a_x,flux_a_y,flux_a_z", &["mag_1_uc"], &["flux_a"], &["mag_1_c"]).unwrap();
//! let line = layout.parse(b"0.1,50000,20000,,45000");
//! assert_eq!(line.time_s, Some(0.1));
//! use tolles_io::stream_line::CellFlag;
//! assert_eq!(line.flags[0], CellFlag::Missing { column: "flux_a_y".into() });
//! let mut out = String::new();
//! layout.write_output(&line, &[f64::NAN], "missing flux_a_y", &mut out);
//! assert_eq!(out, "0.1,50000,20000,,45000,,missing flux_a_y\n");
//! ```
//!
//! A line is split at commas; a field may be quoted (`"a,b"`, `""` for a quote), but a record
//! never spans lines. A line that cannot be split, is not UTF-8, or has a different number of
//! fields than the header is *malformed*: it still gets its output line, with its fields as far
//! as they could be read (padded with empty cells, extra fields dropped) and the reason in the
//! status. Cells are numbers as Rust reads them (`1e3`, `NaN`, `inf`); an empty cell is missing.

use std::borrow::Cow;
use std::fmt::Write;

pub use crate::schema::TIME_COLUMN;
use crate::schema::{LINE_COLUMN, PITCH, ROLL, YAW};

/// Where a stream's header puts the columns a model needs.
#[derive(Debug, Clone, PartialEq)]
pub struct Layout {
    width: usize,
    time: Option<usize>,
    scalars: Vec<(usize, String)>,
    fluxgates: Vec<[(usize, String); 3]>,
    extras: Vec<(usize, String)>,
    /// Roll, pitch and yaw, when the header has all three (for a live view, not compensation).
    attitude: Option<[usize; 3]>,
    /// The line id column, when the header has one.
    line_id: Option<usize>,
    /// The output header line (without newline): the input's plus the added columns.
    pub output_header: String,
}

/// What was wrong with a line or one of its cells; the compensator's own flags (see
/// `tolles_core::compensate::stream::Flag`) say the same in its words.
#[derive(Debug, Clone, PartialEq)]
pub enum CellFlag {
    /// An empty cell.
    Missing {
        /// Column name.
        column: String,
    },
    /// A cell that is not a number.
    NotANumber {
        /// Column name.
        column: String,
        /// The cell's text.
        text: String,
    },
    /// The line cannot be read (wrong field count, bad quoting, not UTF-8).
    Malformed(String),
}

/// One parsed input line.
#[derive(Debug, Clone, PartialEq)]
pub struct Line {
    /// The line as received, without its line ending.
    pub raw: Vec<u8>,
    /// The fields, if the line could be split (owned copies only for malformed lines).
    pub fields: Option<Vec<String>>,
    /// True when the line has the header's field count and could be read.
    pub well_formed: bool,
    /// Time (s), if the header has a time column; NaN when unreadable.
    pub time_s: Option<f64>,
    /// Scalars (nT), NaN when unreadable.
    pub scalars: Vec<f64>,
    /// Fluxgate vectors (nT), NaN components when unreadable.
    pub fluxgates: Vec<[f64; 3]>,
    /// Extra channels ([`Layout::from_header_with_extras`]), NaN when unreadable.
    pub extras: Vec<f64>,
    /// What was wrong with the line or its cells.
    pub flags: Vec<CellFlag>,
    /// Roll, pitch, yaw (deg) when the header has them, NaN when unreadable; read quietly
    /// (compensation does not need them, so they flag nothing).
    pub attitude: Option<[f64; 3]>,
    /// The line id when the header has a line column, NaN when unreadable.
    pub line_id: Option<f64>,
}

impl Layout {
    /// Finds `scalars` and the fluxgate prefixes `fluxgates` (`flux_a` → `flux_a_x/_y/_z`) in
    /// `header`; `added` are the compensated columns' names, followed by `status`, each renamed
    /// by [`crate::schema::output_names`] when taken. Err names a missing column.
    pub fn from_header(
        header: &str,
        scalars: &[&str],
        fluxgates: &[&str],
        added: &[&str],
    ) -> Result<Self, String> {
        Self::from_header_renamed(header, &[], scalars, fluxgates, added)
    }

    /// [`Layout::from_header`], with the header's columns renamed `(old, new)` first (as
    /// [`crate::table::Table::rename`] renames; the output header then has the new names). A
    /// column is found as in a table read whole: by name, by case when only one matches, or
    /// as the raw channel that answers to it ([`crate::schema::aliases`]: SGL's `TIME`,
    /// `UNCOMPMAG1`, `FLUXA_X`, …).
    pub fn from_header_renamed(
        header: &str,
        renames: &[(String, String)],
        scalars: &[&str],
        fluxgates: &[&str],
        added: &[&str],
    ) -> Result<Self, String> {
        Self::from_header_with_extras(header, renames, scalars, fluxgates, &[], added)
    }

    /// [`Layout::from_header_renamed`], also finding the extra channel columns `extras` (e.g.
    /// currents).
    pub fn from_header_with_extras(
        header: &str,
        renames: &[(String, String)],
        scalars: &[&str],
        fluxgates: &[&str],
        extras: &[&str],
        added: &[&str],
    ) -> Result<Self, String> {
        let mut names: Vec<String> = split_fields(header)
            .map_err(|e| format!("header: {e}"))?
            .iter()
            .map(|f| f.trim().to_string())
            .collect();
        let here = std::path::Path::new("header");
        for (old, new) in renames {
            crate::header::rename_header(here, &mut names, old, new)
                .map_err(|e| format!("renaming {old} to {new}: {e}"))?;
        }
        let aliases = crate::schema::aliases(&names);
        let index = |name: &str| {
            crate::header::find_column(here, &names, name)
                .ok()
                .or_else(|| {
                    let alias = aliases.iter().find(|(a, _)| a.eq_ignore_ascii_case(name));
                    alias.map(|(_, k)| *k)
                })
        };
        let find = |name: &str| {
            index(name).map(|k| (k, name.to_string())).ok_or_else(|| {
                let near = crate::header::suggest(&names, name);
                format!("header has no column {name:?}{near}")
            })
        };
        let scalars = scalars.iter().map(|s| find(s)).collect::<Result<_, _>>()?;
        let fluxgates = fluxgates
            .iter()
            .map(|p| {
                let [x, y, z] = crate::schema::vector_columns(p);
                Ok([find(&x)?, find(&y)?, find(&z)?])
            })
            .collect::<Result<_, String>>()?;
        let extras = extras.iter().map(|e| find(e)).collect::<Result<_, _>>()?;
        let mut output_header = match renames.is_empty() {
            true => header.to_string(),
            false => {
                let mut text = String::new();
                for (k, name) in names.iter().enumerate() {
                    if k > 0 {
                        text.push(',');
                    }
                    push_field(&mut text, name);
                }
                text
            }
        };
        let wanted: Vec<&str> = (added.iter().copied())
            .chain([crate::schema::STATUS_COLUMN])
            .collect();
        for (name, _) in crate::schema::output_names(&names, &wanted) {
            output_header.push(',');
            push_field(&mut output_header, &name);
        }
        Ok(Self {
            width: names.len(),
            time: index(TIME_COLUMN),
            attitude: (|| {
                let [r, p, y] = [ROLL, PITCH, YAW].map(index);
                Some([r?, p?, y?])
            })(),
            line_id: index(LINE_COLUMN),
            scalars,
            fluxgates,
            extras,
            output_header,
        })
    }

    /// Number of header fields.
    pub fn width(&self) -> usize {
        self.width
    }

    /// Reads one line (without its line ending). Never fails: problems become flags.
    pub fn parse(&self, raw: &[u8]) -> Line {
        let mut line = Line {
            raw: raw.to_vec(),
            fields: None,
            well_formed: false,
            time_s: self.time.map(|_| f64::NAN),
            scalars: vec![f64::NAN; self.scalars.len()],
            fluxgates: vec![[f64::NAN; 3]; self.fluxgates.len()],
            extras: vec![f64::NAN; self.extras.len()],
            flags: Vec::new(),
            attitude: self.attitude.map(|_| [f64::NAN; 3]),
            line_id: self.line_id.map(|_| f64::NAN),
        };
        let Ok(text) = std::str::from_utf8(raw) else {
            line.flags
                .push(CellFlag::Malformed("not UTF-8".to_string()));
            return line;
        };
        let fields = match split_fields(text) {
            Ok(f) => f,
            Err(e) => {
                line.flags.push(CellFlag::Malformed(e));
                return line;
            }
        };
        if fields.len() != self.width {
            line.flags.push(CellFlag::Malformed(format!(
                "{} fields, header has {}",
                fields.len(),
                self.width
            )));
            line.fields = Some(fields.iter().map(|f| f.to_string()).collect());
            return line;
        }
        line.well_formed = true;
        let mut cell = |(k, name): &(usize, String)| read_cell(&fields[*k], name, &mut line.flags);
        let time = self.time.map(|k| cell(&(k, TIME_COLUMN.to_string())));
        let scalars: Vec<f64> = self.scalars.iter().map(&mut cell).collect();
        let fluxgates: Vec<[f64; 3]> = self
            .fluxgates
            .iter()
            .map(|axes| axes.each_ref().map(&mut cell))
            .collect();
        let extras: Vec<f64> = self.extras.iter().map(&mut cell).collect();
        let quiet = |k: usize| fields[k].trim().parse::<f64>().unwrap_or(f64::NAN);
        line.attitude = self.attitude.map(|columns| columns.map(quiet));
        line.line_id = self.line_id.map(quiet);
        line.time_s = time;
        line.scalars = scalars;
        line.fluxgates = fluxgates;
        line.extras = extras;
        line
    }

    /// Appends the output line for `line` to `out`: its fields, the `compensated` values (nT,
    /// empty when NaN) and `status`, then a newline.
    pub fn write_output(&self, line: &Line, compensated: &[f64], status: &str, out: &mut String) {
        if line.well_formed {
            // Verbatim, so the input's columns are passed through exactly as given.
            out.push_str(&String::from_utf8_lossy(&line.raw));
        } else {
            let empty = Vec::new();
            let fields = line.fields.as_ref().unwrap_or(&empty);
            for k in 0..self.width {
                if k > 0 {
                    out.push(',');
                }
                push_field(out, fields.get(k).map_or("", String::as_str));
            }
        }
        for v in compensated {
            out.push(',');
            if v.is_finite() {
                let _ = write!(out, "{v}");
            }
        }
        out.push(',');
        push_field(out, status);
        out.push('\n');
    }
}

/// Splits one CSV record at commas; fields may be quoted. Err says why it cannot be split.
pub fn split_fields(line: &str) -> Result<Vec<Cow<'_, str>>, String> {
    let mut fields = Vec::new();
    let mut rest = line;
    loop {
        if let Some(quoted) = rest.strip_prefix('"') {
            let (value, after) = unquote(quoted)?;
            fields.push(Cow::Owned(value));
            match after.strip_prefix(',') {
                Some(r) => rest = r,
                None if after.is_empty() => return Ok(fields),
                None => return Err("text after a closing quote".to_string()),
            }
        } else {
            match rest.find(',') {
                Some(i) => {
                    fields.push(Cow::Borrowed(&rest[..i]));
                    rest = &rest[i + 1..];
                }
                None => {
                    fields.push(Cow::Borrowed(rest));
                    return Ok(fields);
                }
            }
        }
    }
}

/// The value of a quoted field whose opening quote is already consumed, and the text after it.
fn unquote(text: &str) -> Result<(String, &str), String> {
    let mut value = String::new();
    let mut rest = text;
    loop {
        let Some(i) = rest.find('"') else {
            return Err("unterminated quote".to_string());
        };
        value.push_str(&rest[..i]);
        rest = &rest[i + 1..];
        match rest.strip_prefix('"') {
            Some(r) => {
                value.push('"');
                rest = r;
            }
            None => return Ok((value, rest)),
        }
    }
}

/// Appends `field`, quoted when it holds a comma, quote or line break.
fn push_field(out: &mut String, field: &str) {
    if field.contains([',', '"', '\n', '\r']) {
        out.push('"');
        out.push_str(&field.replace('"', "\"\""));
        out.push('"');
    } else {
        out.push_str(field);
    }
}

fn read_cell(cell: &str, column: &str, flags: &mut Vec<CellFlag>) -> f64 {
    let cell = cell.trim();
    if cell.is_empty() {
        flags.push(CellFlag::Missing {
            column: column.to_string(),
        });
        return f64::NAN;
    }
    cell.parse::<f64>().unwrap_or_else(|_| {
        flags.push(CellFlag::NotANumber {
            column: column.to_string(),
            text: cell.to_string(),
        });
        f64::NAN
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn layout() -> Layout {
        Layout::from_header(
            "tt,line,mag_1_uc,flux_a_x,flux_a_y,flux_a_z",
            &["mag_1_uc"],
            &["flux_a"],
            &["mag_1_c"],
        )
        .unwrap()
    }

    #[test]
    fn raw_channel_names_and_renamed_columns_are_found() {
        let raw = "TIME,UNCOMPMAG1,FLUXA_X,FLUXA_Y,FLUXA_Z";
        let layout = Layout::from_header(raw, &["mag_1_uc"], &["flux_a"], &["mag_1_c"]).unwrap();
        let line = layout.parse(b"0.5,50000,1,2,3");
        assert_eq!(
            (line.time_s, line.fluxgates[0]),
            (Some(0.5), [1.0, 2.0, 3.0])
        );
        assert_eq!(layout.output_header, format!("{raw},mag_1_c,status"));
        let renames = [("M".to_string(), "mag_1_uc".to_string())];
        let header = "tt,M,flux_a_x,flux_a_y,flux_a_z";
        let layout =
            Layout::from_header_renamed(header, &renames, &["mag_1_uc"], &["flux_a"], &[]).unwrap();
        assert_eq!(layout.parse(b"0,7,1,2,3").scalars, [7.0]);
        assert!(layout.output_header.starts_with("tt,mag_1_uc,flux_a_x"));
        let e = Layout::from_header_renamed("tt", &renames, &[], &[], &[]).unwrap_err();
        assert!(e.starts_with("renaming M to mag_1_uc: header: "), "{e}");
    }

    #[test]
    fn quoted_fields_split_and_round_trip() {
        let f = split_fields(r#"a,"b,c","say ""hi""",,"#).unwrap();
        assert_eq!(f, ["a", "b,c", r#"say "hi""#, "", ""]);
        assert!(split_fields(r#"a,"b"#).is_err());
        assert!(split_fields(r#""b"x,c"#).is_err());
        let mut out = String::new();
        push_field(&mut out, r#"say "hi", ok"#);
        assert_eq!(split_fields(&out).unwrap(), [r#"say "hi", ok"#]);
    }

    #[test]
    fn missing_columns_are_named() {
        let e = Layout::from_header(
            "tt,mag_1_uc,flux_a_x",
            &["mag_1_uc"],
            &["flux_a"],
            &["mag_1_c"],
        );
        assert_eq!(
            e.unwrap_err(),
            "header has no column \"flux_a_y\"; did you mean flux_a_x?"
        );
    }

    #[test]
    fn added_columns_take_names_free_in_the_header() {
        let header = "mag_1_c_tolles,mag_1_c,mag_1_uc,flux_a_x,flux_a_y,flux_a_z,status";
        let l = Layout::from_header(header, &["mag_1_uc"], &["flux_a"], &["mag_1_c"]).unwrap();
        let added = l.output_header.strip_prefix(header).unwrap();
        assert_eq!(added, ",mag_1_c_tolles2,status_tolles");
    }

    #[test]
    fn malformed_lines_keep_their_place_and_width() {
        let l = layout();
        let line = l.parse(b"1,2,3");
        assert!(!line.well_formed);
        let why = "3 fields, header has 6";
        assert_eq!(line.flags, [CellFlag::Malformed(why.into())]);
        let mut out = String::new();
        l.write_output(&line, &[f64::NAN], why, &mut out);
        assert_eq!(out, "1,2,3,,,,,\"3 fields, header has 6\"\n");
        let bad = l.parse(&[0xff, b',']);
        assert_eq!(bad.flags, [CellFlag::Malformed("not UTF-8".into())]);
    }

    #[test]
    fn cells_are_read_or_flagged() {
        let line = layout().parse(b"0.5,7,abc,1e4,NaN,45000");
        assert_eq!(line.time_s, Some(0.5));
        assert!(line.scalars[0].is_nan() && line.fluxgates[0][1].is_nan());
        assert_eq!(line.fluxgates[0][0], 10_000.0);
        let abc = CellFlag::NotANumber {
            column: "mag_1_uc".into(),
            text: "abc".into(),
        };
        assert_eq!(line.flags, [abc]);
    }

    #[test]
    fn existing_output_columns_are_not_overwritten() {
        let l = Layout::from_header(
            "mag_1_uc,mag_1_c,flux_a_x,flux_a_y,flux_a_z",
            &["mag_1_uc"],
            &["flux_a"],
            &["mag_1_c"],
        )
        .unwrap();
        assert_eq!(
            l.output_header,
            "mag_1_uc,mag_1_c,flux_a_x,flux_a_y,flux_a_z,mag_1_c_tolles,status"
        );
    }
}
