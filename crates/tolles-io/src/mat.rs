//! MATLAB v5 MAT-files (`save -v6`, `save -v7`, the default before R2006b, and scipy's
//! `savemat`): a 128-byte header whose text starts `MATLAB 5.0 MAT-file`, then one data element
//! per variable, each `miMATRIX` or a zlib-compressed `miCOMPRESSED` holding one. (MATLAB
//! v7.3 files are HDF5 and are read by [`crate::hdf5`]; [`crate::format`] tells them apart by
//! their content, whatever the extension.)
//!
//! Variables are flattened the way MagNav's test data needs:
//! - a 1-D numeric array (N×1 or 1×N; double, single, int*, uint*, logical) is a column;
//! - a 1×1 numeric array is a scalar ([`Table::metadata`]); in a file of scalars only, each is a
//!   column of a one-row table instead;
//! - a 1×1 struct contributes its fields, nested structs too, each named by its path
//!   (`TL_data.flux_a_x`, `params.TL.lambda`);
//! - anything else (matrices, text, cells, sparse, complex, objects, struct arrays, empty
//!   arrays) is left out and named in [`Table::notes`].
//!
//! A struct field is named by its own name (`flux_a_x`) where no other variable or field in the
//! file has that name, so `--vector flux_a` finds MagNav's `TL_data` fields; otherwise by its
//! dotted path (`TL_data.flux_a_x`). Each column has one name, so a table written back out has
//! no column twice. As in [`crate::hdf5`], the rows are as many as the most common column
//! length (the longer on a tie); a 1-D array of another length is kept as a side column
//! ([`Table::side_columns`]), which fit and compensate do not use. When the
//! file has no scalar `dt` but a scalar `fs` (Hz, as in MagNav's `TL_data`), `dt = 1 / fs` is
//! added to the metadata so the sample rate is known (as derived metadata, which a converted
//! file does not hold: see [`Table::file_metadata`]).
//!
//! The parser is our own (about 400 lines): `matfile` reads no structs, and `matrw` (0.1) says
//! its API is not stable yet; bounding every allocation by the file's size is easier to hold to
//! here than to audit there. Every size in the file is checked against the bytes that hold it
//! before anything is allocated, decompression stops at 1032 times the compressed size
//! (deflate's best ratio), and structs nest at most [`MAX_DEPTH`] deep.

use crate::error::IoError;
use crate::table::{Column, SideColumn, Table};
use std::io::Read;
use std::path::Path;

/// How many times larger than its compressed bytes a compressed variable may be (deflate's
/// best ratio is about 1032:1).
const MAX_EXPANSION: u64 = 1032;

/// How deeply structs may nest inside one another.
pub const MAX_DEPTH: usize = 32;

const HEADER_LEN: usize = 128;

// Data types of data elements.
const MI_INT8: u32 = 1;
const MI_UINT8: u32 = 2;
const MI_INT16: u32 = 3;
const MI_UINT16: u32 = 4;
const MI_INT32: u32 = 5;
const MI_UINT32: u32 = 6;
const MI_SINGLE: u32 = 7;
const MI_DOUBLE: u32 = 9;
const MI_INT64: u32 = 12;
const MI_UINT64: u32 = 13;
const MI_MATRIX: u32 = 14;
const MI_COMPRESSED: u32 = 15;

// Array classes.
const MX_CELL: u8 = 1;
const MX_STRUCT: u8 = 2;
const MX_OBJECT: u8 = 3;
const MX_CHAR: u8 = 4;
const MX_SPARSE: u8 = 5;

/// True when `bytes` start with a MATLAB v5 MAT-file header (text, then version 0x0100 and the
/// endian indicator `IM` or `MI`); false for v7.3 (HDF5) files and anything else.
pub fn is_v5(bytes: &[u8]) -> bool {
    if bytes.len() < HEADER_LEN || !bytes.starts_with(b"MATLAB 5.0 MAT-file") {
        return false;
    }
    matches!(
        &bytes[124..128],
        [0x00, 0x01, b'I', b'M'] | [0x01, 0x00, b'M', b'I']
    )
}

/// Reads a MATLAB v5 MAT-file.
pub fn read(path: &Path) -> Result<Table, IoError> {
    let bytes = std::fs::read(path).map_err(|source| IoError::Open {
        path: path.to_path_buf(),
        source,
    })?;
    from_bytes(&bytes, path)
}

/// Reads a MATLAB v5 MAT-file from its bytes; `name` is used in error messages.
pub fn from_bytes(bytes: &[u8], name: impl AsRef<Path>) -> Result<Table, IoError> {
    let path = name.as_ref();
    // The parser is ours and checks every size, but the decompressor is not: contain it.
    crate::guard::contain(
        || read_bytes(bytes, path),
        |why| IoError::Invalid {
            path: path.to_path_buf(),
            message: format!("not a readable MATLAB v5 MAT-file ({why})"),
        },
    )
}

/// One variable or struct field as read: its path of names and what it holds.
struct Entry {
    path: Vec<String>,
    value: Value,
}

enum Value {
    Scalar(f64),
    Vector(Vec<f64>),
    /// Left out; the text says what it is ("a 1000×18 double matrix").
    Other(String),
}

struct Parser<'p> {
    path: &'p Path,
    big_endian: bool,
    /// Bytes that decompression may still produce in this file.
    budget: u64,
    entries: Vec<Entry>,
}

fn read_bytes(bytes: &[u8], path: &Path) -> Result<Table, IoError> {
    let invalid = |message: String| IoError::Invalid {
        path: path.to_path_buf(),
        message,
    };
    if !is_v5(bytes) {
        return Err(invalid(
            "not a MATLAB v5 MAT-file (no \"MATLAB 5.0 MAT-file\" header)".to_string(),
        ));
    }
    let mut parser = Parser {
        path,
        big_endian: &bytes[126..128] == b"MI",
        budget: (bytes.len() as u64).saturating_mul(MAX_EXPANSION),
        entries: Vec::new(),
    };
    let mut at = HEADER_LEN;
    let mut index = 0usize;
    while at < bytes.len() {
        index += 1;
        let (kind, data, next) = parser
            .element(bytes, at)
            .map_err(|why| invalid(format!("variable {index} (at byte {at}): {why}")))?;
        // A compressed element is not padded to 8 bytes; others are.
        at = if kind == MI_COMPRESSED {
            next
        } else {
            next.div_ceil(8).saturating_mul(8)
        };
        parser.top_level(kind, data, index, at)?;
    }
    parser.into_table()
}

impl Parser<'_> {
    fn invalid(&self, message: String) -> IoError {
        IoError::Invalid {
            path: self.path.to_path_buf(),
            message,
        }
    }

    fn u32_at(&self, bytes: &[u8], at: usize) -> Option<u32> {
        let b: [u8; 4] = bytes.get(at..at.checked_add(4)?)?.try_into().ok()?;
        Some(if self.big_endian {
            u32::from_be_bytes(b)
        } else {
            u32::from_le_bytes(b)
        })
    }

    /// The data element at `at` in `bytes`: its type, its data, and where its data ends
    /// (before padding).
    fn element<'b>(&self, bytes: &'b [u8], at: usize) -> Result<(u32, &'b [u8], usize), String> {
        let first = self
            .u32_at(bytes, at)
            .ok_or("the file ends inside a data element's tag")?;
        if first >> 16 != 0 {
            // Small data element: type and size in one word, up to 4 bytes of data after it.
            let (kind, len) = (first & 0xFFFF, (first >> 16) as usize);
            if len > 4 {
                return Err(format!(
                    "a small data element claims {len} bytes (at most 4)"
                ));
            }
            let data = bytes
                .get(at + 4..at + 4 + len)
                .ok_or("the file ends inside a small data element")?;
            return Ok((kind, data, at + 8));
        }
        let len = self
            .u32_at(bytes, at + 4)
            .ok_or("the file ends inside a data element's tag")? as usize;
        let start = at + 8;
        let end = start
            .checked_add(len)
            .filter(|&end| end <= bytes.len())
            .ok_or_else(|| {
                format!(
                    "a data element claims {len} bytes, but only {} follow",
                    bytes.len().saturating_sub(start)
                )
            })?;
        Ok((first, &bytes[start..end], end))
    }

    fn top_level(
        &mut self,
        kind: u32,
        data: &[u8],
        index: usize,
        at: usize,
    ) -> Result<(), IoError> {
        match kind {
            MI_MATRIX => self.variable(data, index),
            MI_COMPRESSED => {
                let inflated = self.inflate(data).map_err(|why| {
                    self.invalid(format!("variable {index} (before byte {at}): {why}"))
                })?;
                let (kind, inner, _) = self
                    .element(&inflated, 0)
                    .map_err(|why| self.invalid(format!("variable {index} (compressed): {why}")))?;
                if kind == MI_MATRIX {
                    self.variable(inner, index)
                } else {
                    Err(self.invalid(format!(
                        "variable {index}: a compressed element holds data type {kind}, not a matrix"
                    )))
                }
            }
            other => Err(self.invalid(format!(
                "variable {index}: data type {other} at the top level, not a matrix"
            ))),
        }
    }

    /// The zlib stream `data` decompressed, refused past 1032 times its size or the file's
    /// remaining budget.
    fn inflate(&mut self, data: &[u8]) -> Result<Vec<u8>, String> {
        let limit = (data.len() as u64)
            .saturating_mul(MAX_EXPANSION)
            .saturating_add(64)
            .min(self.budget);
        let mut out = Vec::new();
        flate2::read::ZlibDecoder::new(data)
            .take(limit.saturating_add(1))
            .read_to_end(&mut out)
            .map_err(|e| format!("cannot decompress: {e}"))?;
        if out.len() as u64 > limit {
            return Err(format!(
                "decompresses to more than {limit} bytes, more than its {} compressed bytes could honestly hold",
                data.len()
            ));
        }
        self.budget -= out.len() as u64;
        Ok(out)
    }

    /// A top-level variable: the contents of its `miMATRIX` element.
    fn variable(&mut self, data: &[u8], index: usize) -> Result<(), IoError> {
        if data.is_empty() {
            return Ok(()); // an empty matrix element: nothing to read
        }
        self.matrix(data, Vec::new(), 0).map_err(|(name, why)| {
            let name = if name.is_empty() {
                format!("variable {index}")
            } else {
                format!("variable {name:?}")
            };
            self.invalid(format!("{name}: {why}"))
        })
    }

    /// Reads the array in `data` (an `miMATRIX`'s contents) whose enclosing names are `parents`
    /// (empty at the top level, where the array carries its own name). Errors carry the dotted
    /// name read so far.
    fn matrix(
        &mut self,
        data: &[u8],
        parents: Vec<String>,
        depth: usize,
    ) -> Result<(), (String, String)> {
        let dotted = |p: &[String]| p.join(".");
        let fail = |p: &[String], why: String| (dotted(p), why);
        let (kind, flags, at) = self.element(data, 0).map_err(|e| fail(&parents, e))?;
        if kind != MI_UINT32 || flags.len() != 8 {
            return Err(fail(&parents, "no array flags".into()));
        }
        let word = self.u32_at(flags, 0).unwrap_or(0);
        let class = (word & 0xFF) as u8;
        let complex = word & 0x0800 != 0;
        let logical = word & 0x0200 != 0;
        let (kind, dims_data, end) = self
            .element(data, at.div_ceil(8) * 8)
            .map_err(|e| fail(&parents, e))?;
        if kind != MI_INT32 || dims_data.len() < 8 || dims_data.len() % 4 != 0 {
            return Err(fail(&parents, "no dimensions".into()));
        }
        let mut dims = Vec::with_capacity(dims_data.len() / 4);
        for k in 0..dims_data.len() / 4 {
            let d = self.u32_at(dims_data, 4 * k).unwrap_or(0) as i32;
            dims.push(usize::try_from(d).map_err(|_| fail(&parents, format!("dimension {d}")))?);
        }
        let (kind, name, end) = self
            .element(data, end.div_ceil(8) * 8)
            .map_err(|e| fail(&parents, e))?;
        if kind != MI_INT8 {
            return Err(fail(&parents, "no array name".into()));
        }
        let mut path = parents;
        if path.is_empty() {
            path.push(String::from_utf8_lossy(name).into_owned());
        }
        let rest = data.get(end.div_ceil(8) * 8..).unwrap_or(&[]);
        let shape = dims
            .iter()
            .map(usize::to_string)
            .collect::<Vec<_>>()
            .join("×");
        let count = dims.iter().try_fold(1usize, |n, &d| n.checked_mul(d));
        let other = |what: &str| Value::Other(format!("a {shape} {what}"));
        let value = match class {
            MX_STRUCT => {
                if count != Some(1) {
                    other("struct array")
                } else if depth >= MAX_DEPTH {
                    return Err(fail(
                        &path,
                        format!("structs nest more than {MAX_DEPTH} deep"),
                    ));
                } else {
                    return self.fields(rest, path, depth + 1);
                }
            }
            MX_CELL => other("cell array (cells are not read)"),
            MX_OBJECT => other("MATLAB object"),
            MX_CHAR => other("char array (text)"),
            MX_SPARSE => other("sparse matrix (sparse arrays are not read)"),
            6..=15 if complex => other("complex array"),
            6..=15 => {
                let class_name = if logical {
                    "logical"
                } else {
                    [
                        "double", "single", "int8", "uint8", "int16", "uint16", "int32", "uint32",
                        "int64", "uint64",
                    ][usize::from(class - 6)]
                };
                let long: Vec<usize> = dims.iter().copied().filter(|&d| d != 1).collect();
                match long[..] {
                    _ if count == Some(0) => other(&format!("{class_name} array (empty)")),
                    [] | [_] => {
                        let values = self
                            .numbers(rest, count.unwrap_or(0))
                            .map_err(|e| fail(&path, e))?;
                        if long.is_empty() {
                            Value::Scalar(values[0])
                        } else {
                            Value::Vector(values)
                        }
                    }
                    _ => other(&format!("{class_name} matrix, not a column")),
                }
            }
            other_class => Value::Other(format!("of MATLAB array class {other_class}")),
        };
        self.entries.push(Entry { path, value });
        Ok(())
    }

    /// The fields of a 1×1 struct whose contents after its name are `data`.
    fn fields(
        &mut self,
        data: &[u8],
        path: Vec<String>,
        depth: usize,
    ) -> Result<(), (String, String)> {
        let fail = |why: String| (path.join("."), why);
        let (kind, len_data, end) = self.element(data, 0).map_err(fail)?;
        let name_len = match (kind, self.u32_at(len_data, 0)) {
            (MI_INT32, Some(n)) if n > 0 => n as usize,
            _ => return Err(fail("no field name length".into())),
        };
        let (kind, names, mut end) = self.element(data, end.div_ceil(8) * 8).map_err(fail)?;
        if kind != MI_INT8 || names.len() % name_len != 0 {
            return Err(fail("no field names".into()));
        }
        for chunk in names.chunks(name_len) {
            let field = chunk.split(|&b| b == 0).next().unwrap_or(&[]);
            let mut child = path.clone();
            child.push(String::from_utf8_lossy(field).into_owned());
            let (kind, contents, next) = self
                .element(data, end.div_ceil(8) * 8)
                .map_err(|e| (child.join("."), e))?;
            end = next;
            if kind != MI_MATRIX {
                return Err((child.join("."), format!("data type {kind}, not a matrix")));
            }
            if contents.is_empty() {
                self.entries.push(Entry {
                    path: child,
                    value: Value::Other("an empty array".into()),
                });
            } else {
                self.matrix(contents, child, depth)?;
            }
        }
        Ok(())
    }

    /// The real part in `data` (the element after the array name) as `count` numbers.
    fn numbers(&self, data: &[u8], count: usize) -> Result<Vec<f64>, String> {
        let (kind, bytes, _) = self.element(data, 0)?;
        let size = match kind {
            MI_INT8 | MI_UINT8 => 1,
            MI_INT16 | MI_UINT16 => 2,
            MI_INT32 | MI_UINT32 | MI_SINGLE => 4,
            MI_DOUBLE | MI_INT64 | MI_UINT64 => 8,
            other => return Err(format!("numbers stored as data type {other}")),
        };
        if bytes.len() / size != count || bytes.len() % size != 0 {
            return Err(format!(
                "its dimensions say {count} values, but its data holds {} bytes of {size}-byte numbers",
                bytes.len()
            ));
        }
        let be = self.big_endian;
        let values = bytes
            .chunks_exact(size)
            .map(|c| {
                let mut b = [0u8; 8];
                b[..size].copy_from_slice(c);
                if be {
                    b[..size].reverse();
                }
                match kind {
                    MI_INT8 => f64::from(c[0] as i8),
                    MI_UINT8 => f64::from(c[0]),
                    MI_INT16 => f64::from(i16::from_le_bytes([b[0], b[1]])),
                    MI_UINT16 => f64::from(u16::from_le_bytes([b[0], b[1]])),
                    MI_INT32 => f64::from(i32::from_le_bytes([b[0], b[1], b[2], b[3]])),
                    MI_UINT32 => f64::from(u32::from_le_bytes([b[0], b[1], b[2], b[3]])),
                    MI_SINGLE => f64::from(f32::from_le_bytes([b[0], b[1], b[2], b[3]])),
                    MI_INT64 => i64::from_le_bytes(b) as f64,
                    MI_UINT64 => u64::from_le_bytes(b) as f64,
                    _ => f64::from_le_bytes(b),
                }
            })
            .collect();
        Ok(values)
    }

    fn into_table(self) -> Result<Table, IoError> {
        let path = self.path;
        let entries = self.entries;
        // A leaf's own name is used where no other leaf in the file has it.
        let mut counts = std::collections::HashMap::<&str, usize>::new();
        for e in &entries {
            *counts
                .entry(e.path.last().map_or("", String::as_str))
                .or_default() += 1;
        }
        let name_of = |e: &Entry| {
            let last = e.path.last().map_or("", String::as_str);
            if e.path.len() == 1 || counts[last] == 1 {
                last.to_string()
            } else {
                e.path.join(".")
            }
        };
        let lengths: Vec<usize> = entries
            .iter()
            .filter_map(|e| match &e.value {
                Value::Vector(v) => Some(v.len()),
                _ => None,
            })
            .collect();
        let scalars_only = lengths.is_empty();
        let rows = match crate::table::most_common_length(lengths) {
            Some(rows) => rows,
            // A file of scalars only (MagNav's `test_data_params.mat`) is a one-row table.
            None if entries.iter().any(|e| matches!(e.value, Value::Scalar(_))) => 1,
            None => {
                return Err(IoError::Invalid {
                    path: path.to_path_buf(),
                    message: "no numeric variable or struct field to read as a column".into(),
                })
            }
        };
        let mut headers = Vec::new();
        let mut columns = Vec::new();
        let mut metadata = Vec::new();
        let mut side = Vec::new();
        let mut notes = Vec::new();
        for e in &entries {
            if e.path.iter().any(String::is_empty) {
                notes
                    .push("a variable without a name (MATLAB's subsystem data) is left out".into());
                continue;
            }
            let name = name_of(e);
            match &e.value {
                Value::Scalar(v) if scalars_only => {
                    headers.push(name);
                    columns.push(Column::Numbers(vec![*v]));
                }
                Value::Scalar(v) => metadata.push((name, *v)),
                Value::Vector(v) if v.len() == rows => {
                    headers.push(name);
                    columns.push(Column::Numbers(v.clone()));
                }
                Value::Vector(v) => side.push(SideColumn {
                    name,
                    values: v.clone(),
                }),
                Value::Other(what) => notes.push(format!(
                    "variable {:?} is {what}; left out",
                    e.path.join(".")
                )),
            }
        }
        Ok(Table::from_columns(path, headers, columns, None)?
            .with_metadata(metadata)
            .with_side_columns(side)
            .with_notes(notes)
            .with_dt_from_fs())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A little-endian data element: tag, data, padding to 8 bytes.
    fn element(kind: u32, data: &[u8]) -> Vec<u8> {
        let mut out = kind.to_le_bytes().to_vec();
        out.extend((data.len() as u32).to_le_bytes());
        out.extend(data);
        out.resize(out.len().div_ceil(8) * 8, 0);
        out
    }

    fn header() -> Vec<u8> {
        let mut out = b"MATLAB 5.0 MAT-file, made by a test".to_vec();
        out.resize(116, b' ');
        out.resize(124, 0);
        out.extend([0x00, 0x01, b'I', b'M']);
        out
    }

    /// The contents of an `miMATRIX` of `class` named `name`, of shape `dims`, then `rest`.
    fn matrix(class: u8, dims: &[i32], name: &str, rest: &[u8]) -> Vec<u8> {
        let mut out = element(MI_UINT32, &[class, 0, 0, 0, 0, 0, 0, 0]);
        let dims: Vec<u8> = dims.iter().flat_map(|d| d.to_le_bytes()).collect();
        out.extend(element(MI_INT32, &dims));
        out.extend(element(MI_INT8, name.as_bytes()));
        out.extend(rest);
        out
    }

    fn doubles(values: &[f64]) -> Vec<u8> {
        let bytes: Vec<u8> = values.iter().flat_map(|v| v.to_le_bytes()).collect();
        element(MI_DOUBLE, &bytes)
    }

    fn file(variables: &[Vec<u8>]) -> Vec<u8> {
        let mut out = header();
        for v in variables {
            out.extend(element(MI_MATRIX, v));
        }
        out
    }

    #[test]
    fn v5_is_told_from_v73_and_other_files() {
        assert!(is_v5(&header()));
        let mut v73 = header();
        v73[..19].copy_from_slice(b"MATLAB 7.3 MAT-file");
        v73[124..126].copy_from_slice(&[0x00, 0x02]);
        assert!(!is_v5(&v73));
        assert!(!is_v5(b"MATLAB 5.0 MAT-file"));
        assert!(!is_v5(b"\x89HDF\r\n\x1a\n"));
    }

    #[test]
    fn a_hand_made_file_reads() {
        let bytes = file(&[
            matrix(6, &[3, 1], "x", &doubles(&[1.0, 2.0, 3.0])),
            matrix(6, &[1, 1], "fs", &doubles(&[4.0])),
        ]);
        let t = from_bytes(&bytes, "x.mat").unwrap();
        assert_eq!(t.numeric("x").unwrap(), [1.0, 2.0, 3.0]);
        assert_eq!(t.metadata("fs"), Some(4.0));
        assert_eq!(t.metadata("dt"), Some(0.25));
    }

    #[test]
    fn dimensions_that_disagree_with_the_data_are_refused() {
        let bytes = file(&[matrix(6, &[1_000_000, 1], "x", &doubles(&[1.0]))]);
        let err = from_bytes(&bytes, "x.mat").unwrap_err().to_string();
        assert!(
            err.starts_with("x.mat: variable \"x\": its dimensions say 1000000 values"),
            "{err}"
        );
        let bytes = file(&[matrix(6, &[-1, 1], "x", &doubles(&[1.0]))]);
        let err = from_bytes(&bytes, "x.mat").unwrap_err().to_string();
        assert!(err.contains("dimension -1"), "{err}");
    }

    #[test]
    fn structs_nested_too_deep_are_refused() {
        // A 1×1 struct whose one field `s` is again such a struct, 40 deep.
        let mut inner = matrix(6, &[1, 1], "", &doubles(&[1.0]));
        for _ in 0..40 {
            let mut rest = element(MI_INT32, &4i32.to_le_bytes());
            rest.extend(element(MI_INT8, b"s\0\0\0"));
            rest.extend(element(MI_MATRIX, &inner));
            inner = matrix(MX_STRUCT, &[1, 1], "", &rest);
        }
        let named = {
            let mut rest = element(MI_INT32, &4i32.to_le_bytes());
            rest.extend(element(MI_INT8, b"s\0\0\0"));
            rest.extend(element(MI_MATRIX, &inner));
            matrix(MX_STRUCT, &[1, 1], "top", &rest)
        };
        let err = from_bytes(&file(&[named]), "deep.mat")
            .unwrap_err()
            .to_string();
        assert!(err.contains("structs nest more than 32 deep"), "{err}");
        assert!(err.starts_with("deep.mat: variable \"top.s.s."), "{err}");
    }

    #[test]
    fn decompression_stops_at_the_budget() {
        use std::io::Write;
        let mut z = flate2::write::ZlibEncoder::new(Vec::new(), flate2::Compression::best());
        z.write_all(&vec![0; 1_000_000]).unwrap();
        let compressed = z.finish().unwrap();
        let mut parser = Parser {
            path: Path::new("bomb.mat"),
            big_endian: false,
            budget: 100_000,
            entries: Vec::new(),
        };
        let err = parser.inflate(&compressed).unwrap_err();
        assert!(
            err.contains("decompresses to more than 100000 bytes"),
            "{err}"
        );
        parser.budget = 1_000_000;
        assert_eq!(parser.inflate(&compressed).unwrap().len(), 1_000_000);
        assert_eq!(parser.budget, 0);
    }
}
