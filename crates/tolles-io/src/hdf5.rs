//! HDF5 flight files in the layout of the DAF-MIT/SGL archive: every channel a 1-D numeric
//! dataset at the root (`tt`, `mag_1_uc`, `flux_a_x`, ...), plus scalars such as `N` and `dt`.
//! MATLAB v7.3 `.mat` files are HDF5 too and are read the same way.
//!
//! ```
//! use tolles_io::hdf5;
//! let dir = std::env::temp_dir().join(format!("tolles-hdf5-doc-{}", std::process::id()));
//! std::fs::create_dir_all(&dir).unwrap();
//! let path = dir.join("flight.h5");
//! hdf5::write(&path, &[("tt".into(), vec![0.0, 0.1]), ("mag_1_uc".into(), vec![5e4, f64::NAN])]).unwrap();
//! let table = hdf5::read(&path).unwrap();
//! assert_eq!(table.numeric("tt").unwrap(), [0.0, 0.1]);
//! assert!(table.numeric("mag_1_uc").unwrap()[1].is_nan());
//! # std::fs::remove_dir_all(&dir).unwrap();
//! ```
//!
//! The table's rows are as many as the most common length among the 1-D datasets; 1-D datasets
//! of other lengths are side columns ([`Table::side_columns`]). Scalar datasets (shape `()` or
//! MATLAB's 1×1) become metadata ([`Table::metadata`]), or, in a file of scalars only, the
//! columns of a one-row table; anything else (matrices, text, groups) is left out and named in
//! [`Table::notes`].
//!
//! The crate used is `hdf5-pure` (pure Rust, no C library to install); it reads files written
//! by h5py and MATLAB v7.3 (whose 512-byte user block precedes the HDF5 superblock).

use crate::error::IoError;
use crate::table::{Column, SideColumn, Table, TextColumn};
use hdf5_pure::{AttrValue, DType, Dataset, File, FileBuilder};
use std::path::Path;

/// How many times larger than the file a dataset may declare itself: deflate's best ratio is
/// about 1032:1, so no honest file holds more. A larger declared size is a damaged (or hostile)
/// header, refused before `hdf5-pure` allocates for it.
const MAX_EXPANSION: u64 = 1032;

/// Reads an HDF5 file with one 1-D dataset per column at its root.
pub fn read(path: &Path) -> Result<Table, IoError> {
    let bytes = std::fs::read(path).map_err(|source| IoError::Open {
        path: path.to_path_buf(),
        source,
    })?;
    from_bytes(bytes, path)
}

/// Reads an HDF5 file from its bytes; `name` is used in error messages. A file that makes the
/// HDF5 library panic is reported as not readable (see the private `guard` module).
pub fn from_bytes(bytes: Vec<u8>, name: impl AsRef<Path>) -> Result<Table, IoError> {
    let path = name.as_ref();
    crate::guard::contain(
        || read_bytes(bytes, path),
        |why| IoError::Invalid {
            path: path.to_path_buf(),
            message: format!("not a readable HDF5 file ({why})"),
        },
    )
}

fn read_bytes(bytes: Vec<u8>, path: &Path) -> Result<Table, IoError> {
    let invalid = |message: String| IoError::Invalid {
        path: path.to_path_buf(),
        message,
    };
    let limit = (bytes.len() as u64).saturating_mul(MAX_EXPANSION);
    let file = File::from_bytes(without_user_block(bytes))
        .map_err(|e| invalid(format!("not a readable HDF5 file: {e}")))?;
    let root = file.root();
    let names = root
        .datasets()
        .map_err(|e| invalid(format!("cannot list the datasets at the root: {e}")))?;
    let mut arrays = Vec::new();
    let mut metadata = Vec::new();
    let mut notes = Vec::new();
    for name in names {
        let dataset = root
            .dataset(&name)
            .map_err(|e| invalid(format!("dataset {name:?}: {e}")))?;
        match classify(&dataset).map_err(|e| invalid(format!("dataset {name:?}: {e}")))? {
            Kind::Scalar => {
                let v = read_values(&dataset, &name, path, limit)?;
                metadata.push((name, v[0]));
            }
            Kind::Vector(n) => arrays.push(Array {
                name,
                dataset,
                len: n,
                text: false,
            }),
            Kind::Text(n) => arrays.push(Array {
                name,
                dataset,
                len: n,
                text: true,
            }),
            Kind::Other(why) => notes.push(format!("dataset {name:?} is {why}; left out")),
        }
    }
    if let Ok(groups) = root.groups() {
        notes.extend(
            groups
                .into_iter()
                .map(|g| format!("group {g:?} is not a column; left out")),
        );
    }
    // The rows are the numbers' most common length; a file of text only has the text's.
    let lengths = |text: bool| arrays.iter().filter(move |a| a.text == text).map(|a| a.len);
    let rows = crate::table::most_common_length(lengths(false))
        .or_else(|| crate::table::most_common_length(lengths(true)));
    let Some(rows) = rows else {
        return scalars_only(path, metadata, notes);
    };
    let mut headers = Vec::new();
    let mut columns = Vec::new();
    let mut side = Vec::new();
    let mut units = Vec::new();
    for Array {
        name,
        dataset,
        len,
        text,
    } in arrays
    {
        if text && len != rows {
            notes.push(format!(
                "dataset {name:?} holds {len} text cells, not one per row ({rows}); left out"
            ));
        } else if text {
            match read_text(&dataset, &name, path, limit)? {
                Some(cells) => {
                    headers.push(name);
                    columns.push(Column::Text(cells));
                }
                None => notes.push(format!("dataset {name:?} is unreadable text; left out")),
            }
        } else {
            let values = read_values(&dataset, &name, path, limit)?;
            if values.len() == rows {
                units.extend(dataset_unit(&dataset).map(|u| (name.clone(), u)));
                headers.push(name);
                columns.push(Column::Numbers(values));
            } else {
                side.push(SideColumn { name, values });
            }
        }
    }
    Ok(Table::from_columns(path, headers, columns, None)?
        .with_units(units)
        .with_metadata(metadata)
        .with_side_columns(side)
        .with_notes(notes)
        .with_dt_from_fs())
}

/// A 1-D dataset at the root: numbers or text, `len` long.
struct Array<'f> {
    name: String,
    dataset: Dataset<'f>,
    len: usize,
    text: bool,
}

/// A file of scalars only, as a one-row table of them (the sample interval also as metadata,
/// so the sample rate is known).
fn scalars_only(
    path: &Path,
    scalars: Vec<(String, f64)>,
    notes: Vec<String>,
) -> Result<Table, IoError> {
    if scalars.is_empty() {
        return Err(IoError::Invalid {
            path: path.to_path_buf(),
            message: "no numeric dataset at the root to read as a column".to_string(),
        });
    }
    let (headers, values): (Vec<String>, Vec<f64>) = scalars.into_iter().unzip();
    let columns = values
        .into_iter()
        .map(|v| Column::Numbers(vec![v]))
        .collect();
    Ok(Table::from_columns(path, headers, columns, None)?
        .with_notes(notes)
        .with_dt_from_fs())
}

/// The units each dataset at the root of the HDF5 file `path` states in a `units` (or `unit`,
/// any case) text attribute, as `(dataset, units)`; empty when the file cannot be read (this
/// only describes a file that was read already).
pub fn units(path: &Path) -> Vec<(String, String)> {
    let Ok(bytes) = std::fs::read(path) else {
        return Vec::new();
    };
    let read = || -> Option<Vec<(String, String)>> {
        let file = File::from_bytes(without_user_block(bytes)).ok()?;
        let root = file.root();
        let mut out = Vec::new();
        for name in root.datasets().ok()? {
            let Ok(dataset) = root.dataset(&name) else {
                continue;
            };
            out.extend(dataset_unit(&dataset).map(|u| (name, u)));
        }
        Some(out)
    };
    crate::guard::contain(
        || Ok(read().unwrap_or_default()),
        |message| IoError::Invalid {
            path: path.to_path_buf(),
            message,
        },
    )
    .unwrap_or_default()
}

/// The unit a dataset states in a `units` (or `unit`, any case) text attribute, if any.
fn dataset_unit(dataset: &Dataset) -> Option<String> {
    let attrs = dataset.attrs().ok()?;
    attrs
        .iter()
        .find_map(|(key, value)| match value {
            AttrValue::String(u) | AttrValue::AsciiString(u)
                if key.eq_ignore_ascii_case("units") || key.eq_ignore_ascii_case("unit") =>
            {
                Some(u.trim().to_string())
            }
            _ => None,
        })
        .filter(|u| !u.is_empty())
}

/// Writes `columns` as 1-D float64 datasets at the root of a new HDF5 file.
pub fn write(path: &Path, columns: &[(String, Vec<f64>)]) -> Result<(), IoError> {
    let datasets: Vec<Output<'_>> = columns
        .iter()
        .map(|(name, values)| Output::Numbers(name, values))
        .collect();
    write_datasets(path, &datasets, &[])
}

/// One dataset [`write_datasets`] writes at the root of a file.
#[derive(Debug, Clone, Copy)]
pub enum Output<'a> {
    /// A 1-D float64 dataset of any length; NaN is missing.
    Numbers(&'a str, &'a [f64]),
    /// A 1-D fixed-length UTF-8 string dataset of a text column's cells as written.
    Text(&'a str, &'a TextColumn),
    /// A scalar (shape `()`) float64 dataset, as the DAF-MIT/SGL files hold `dt` and `N`.
    Scalar(&'a str, f64),
}

impl Output<'_> {
    fn name(&self) -> &str {
        match self {
            Output::Numbers(name, _) | Output::Text(name, _) | Output::Scalar(name, _) => name,
        }
    }
}

/// Writes `datasets` at the root of a new HDF5 file, whole or not at all ([`crate::atomic`]);
/// a dataset named in `units` as `(name, unit)` gets that text as its `units` attribute.
pub fn write_datasets(
    path: &Path,
    datasets: &[Output<'_>],
    units: &[(&str, &str)],
) -> Result<(), IoError> {
    for dataset in datasets {
        check_name(path, dataset.name())?;
    }
    let mut builder = FileBuilder::new();
    for dataset in datasets {
        let created = builder.create_dataset(dataset.name());
        if let Some((_, unit)) = units.iter().find(|(name, _)| *name == dataset.name()) {
            created.set_attr("units", AttrValue::String(unit.to_string()));
        }
        match dataset {
            Output::Numbers(_, values) => {
                created.with_f64_data(values);
            }
            Output::Scalar(_, value) => {
                created.with_f64_data(&[*value]).with_shape(&[]);
            }
            Output::Text(_, text) => {
                let (datatype, bytes) = fixed_strings(text);
                created.with_raw_data(datatype, bytes, text.len() as u64);
            }
        }
    }
    let bytes = builder.finish().map_err(|e| IoError::Write {
        path: path.to_path_buf(),
        source: std::io::Error::other(e.to_string()),
    })?;
    crate::atomic::write_bytes(path, &bytes)
}

/// The cells of `text` as one fixed-length UTF-8 string type (as long as the longest cell,
/// shorter ones padded with NULs, which readers strip) and its bytes.
fn fixed_strings(text: &TextColumn) -> (hdf5_pure::Datatype, Vec<u8>) {
    let size = (0..text.len())
        .map(|k| text.get(k).len())
        .max()
        .unwrap_or(0)
        .max(1);
    let mut bytes = Vec::with_capacity(size * text.len());
    for k in 0..text.len() {
        let cell = text.get(k).as_bytes();
        bytes.extend_from_slice(cell);
        bytes.resize(bytes.len() + size - cell.len(), 0);
    }
    let datatype = hdf5_pure::Datatype::String {
        size: size as u32,
        padding: hdf5_pure::StringPadding::NullPad,
        charset: hdf5_pure::CharacterSet::Utf8,
    };
    (datatype, bytes)
}

/// The longest dataset name written (bytes). A name is stored in a message whose size has 16
/// bits, so a longer name gives a file nothing reads; with `hdf5-pure` 0.13 names of up to
/// 65 523 bytes read back, and this keeps a margin.
const MAX_NAME_BYTES: usize = 65_000;

/// Errors for a column name the file could not hold, before anything is written.
fn check_name(path: &Path, name: &str) -> Result<(), IoError> {
    let shown: String = name.chars().take(20).collect();
    let more = if shown.len() < name.len() { "..." } else { "" };
    let refuse = |why: String| {
        Err(IoError::Invalid {
            path: path.to_path_buf(),
            message: format!("cannot write column {shown:?}{more}: {why}"),
        })
    };
    if name.is_empty() || name.len() > MAX_NAME_BYTES {
        return refuse(format!(
            "an HDF5 column name must be 1 to {MAX_NAME_BYTES} bytes long, not {}",
            name.len()
        ));
    }
    // HDF5 reads '/' as a path into groups, "." as the group itself, and a name up to its
    // first NUL: such a dataset would not open under its own name in h5py or MATLAB.
    if name.contains(['/', '\0']) || name == "." {
        return refuse(
            "HDF5 takes '/' as a group path, '.' as the group and a NUL as the name's end; rename the column (--rename OLD=NEW)".to_string(),
        );
    }
    Ok(())
}

/// The file from its superblock on, with the superblock's base address set to 0. A user block
/// (MATLAB v7.3 writes 512 bytes of header text before the superblock) moves the base address
/// that every other address counts from; `hdf5-pure` 0.13 applies it to object headers but not
/// to chunk indexes, so chunked (compressed) MATLAB variables would not read.
fn without_user_block(mut bytes: Vec<u8>) -> Vec<u8> {
    const SIGNATURE: &[u8] = b"\x89HDF\r\n\x1a\n";
    if bytes.starts_with(SIGNATURE) {
        return bytes;
    }
    let Some(start) = std::iter::successors(Some(512usize), |at| at.checked_mul(2))
        .take_while(|&at| at + SIGNATURE.len() <= bytes.len())
        .find(|&at| bytes[at..].starts_with(SIGNATURE))
    else {
        return bytes;
    };
    bytes.drain(..start);
    let base_address_at = match bytes.get(8) {
        Some(0) => 24,
        Some(1) => 28,
        Some(2 | 3) => 12,
        _ => return bytes,
    };
    let offsets_size = match bytes.get(8) {
        Some(0 | 1) => bytes.get(13).copied(),
        _ => bytes.get(9).copied(),
    };
    if offsets_size == Some(8) {
        if let Some(field) = bytes.get_mut(base_address_at..base_address_at + 8) {
            field.fill(0);
        }
    }
    bytes
}

enum Kind {
    Scalar,
    Vector(usize),
    /// A 1-D dataset of strings, of this length.
    Text(usize),
    Other(String),
}

fn classify(dataset: &Dataset) -> Result<Kind, hdf5_pure::Error> {
    if let Ok(attrs) = dataset.attrs() {
        if let Some(AttrValue::String(class) | AttrValue::AsciiString(class)) =
            attrs.get("MATLAB_class")
        {
            if !matches!(
                class.as_str(),
                "double"
                    | "single"
                    | "int8"
                    | "int16"
                    | "int32"
                    | "int64"
                    | "uint8"
                    | "uint16"
                    | "uint32"
                    | "uint64"
                    | "logical"
            ) {
                return Ok(Kind::Other(format!("a MATLAB {class}")));
            }
        }
    }
    let dtype = dataset.dtype()?;
    if matches!(dtype, DType::String | DType::VariableLengthString) {
        return Ok(match dataset.shape()?[..] {
            [n] => Kind::Text(n as usize),
            _ => Kind::Other("text, not a column".to_string()),
        });
    }
    let numeric = matches!(
        dtype,
        DType::F32
            | DType::F64
            | DType::I8
            | DType::I16
            | DType::I32
            | DType::I64
            | DType::U8
            | DType::U16
            | DType::U32
            | DType::U64
    );
    if !numeric {
        return Ok(Kind::Other("not numeric".to_string()));
    }
    let shape = dataset.shape()?;
    if let [n] = shape[..] {
        return Ok(Kind::Vector(n as usize)); // even of length 1: a one-row table
    }
    // MATLAB stores a column vector as 1×N and a scalar as 1×1.
    let long: Vec<u64> = shape.iter().copied().filter(|&d| d != 1).collect();
    Ok(match long[..] {
        [] => Kind::Scalar,
        [n] => Kind::Vector(n as usize),
        _ => Kind::Other(format!("of shape {shape:?}, not a column")),
    })
}

/// The cells of a 1-D string dataset (as [`write_datasets`] writes a text column), refused
/// unread when its cells would take more than `limit` bytes (32 each at least); `None` when
/// the library cannot read them as text.
fn read_text(
    dataset: &Dataset,
    name: &str,
    path: &Path,
    limit: u64,
) -> Result<Option<TextColumn>, IoError> {
    let cells = dataset.shape().ok().and_then(|s| s.first().copied());
    if cells.is_none_or(|n| n.saturating_mul(32) > limit) {
        return Err(IoError::Invalid {
            path: path.to_path_buf(),
            message: format!(
                "dataset {name:?}: its declared shape is larger than the file could hold"
            ),
        });
    }
    let Ok(strings) = dataset.read_string() else {
        return Ok(None);
    };
    let mut text = TextColumn::new(Default::default());
    for cell in &strings {
        text.push(cell);
    }
    Ok(Some(text))
}

/// The values of `dataset` as numbers, refused unclaimed when their declared size (8 bytes
/// each, as read) exceeds `limit` bytes.
fn read_values(
    dataset: &Dataset,
    name: &str,
    path: &Path,
    limit: u64,
) -> Result<Vec<f64>, IoError> {
    let fail = |why: String| IoError::Invalid {
        path: path.to_path_buf(),
        message: format!("dataset {name:?}: cannot read its values as numbers: {why}"),
    };
    let shape = dataset.shape().map_err(|e| fail(e.to_string()))?;
    let bytes = shape
        .iter()
        .try_fold(8u64, |size, &d| size.checked_mul(d))
        .filter(|&size| size <= limit);
    if bytes.is_none() {
        return Err(fail(format!(
            "its declared shape {shape:?} is larger than the file could hold"
        )));
    }
    let values = dataset.read_f64().map_err(|e| fail(e.to_string()))?;
    if values.is_empty() {
        return Err(fail("it is empty".into()));
    }
    Ok(values)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_no_reader_could_read_are_refused_before_writing() {
        let dir = tempfile::TempDir::new().unwrap();
        let path = dir.path().join("bad.h5");
        for name in [String::new(), "m".repeat(65_536), "m".repeat(65_524)] {
            let err = write(&path, &[(name, vec![1.0])]).unwrap_err().to_string();
            assert!(
                err.contains("an HDF5 column name must be 1 to 65000 bytes"),
                "{err}"
            );
            assert_eq!(err.lines().count(), 1);
            assert!(!path.exists());
        }
        let longest = "m".repeat(MAX_NAME_BYTES);
        write(&path, &[(longest.clone(), vec![1.0])]).unwrap();
        assert_eq!(read(&path).unwrap().headers(), [longest]);
    }

    /// A chunked, compressed 37-value dataset whose declared length is then set to `length`.
    fn chunked_with_declared_length(length: u64) -> Vec<u8> {
        let mut builder = FileBuilder::new();
        let values: Vec<f64> = (0..37).map(|k| f64::from(k) * 0.5).collect();
        builder
            .create_dataset("tt")
            .with_f64_data(&values)
            .with_chunks(&[8])
            .with_deflate(4);
        let mut bytes = builder.finish().unwrap();
        let dims = 37u64.to_le_bytes();
        let at = bytes.windows(8).position(|w| w == dims).unwrap();
        bytes[at..at + 8].copy_from_slice(&length.to_le_bytes());
        bytes
    }

    #[test]
    fn units_attributes_are_found_in_any_case() {
        let dir = tempfile::TempDir::new().unwrap();
        let path = dir.path().join("u.h5");
        let mut builder = FileBuilder::new();
        builder
            .create_dataset("tt")
            .with_f64_data(&[0.0, 0.1])
            .set_attr("units", AttrValue::String("s".into()));
        builder
            .create_dataset("mag_1_uc")
            .with_f64_data(&[5.0, 6.0])
            .set_attr("Units", AttrValue::String(" nT ".into()));
        builder.create_dataset("x").with_f64_data(&[1.0, 2.0]);
        std::fs::write(&path, builder.finish().unwrap()).unwrap();
        let mut units = super::units(&path);
        units.sort();
        assert_eq!(
            units,
            [("mag_1_uc".into(), "nT".into()), ("tt".into(), "s".into())]
        );
        assert!(super::units(&dir.path().join("absent.h5")).is_empty());
    }

    #[test]
    fn text_and_scalar_datasets_are_written() {
        let dir = tempfile::TempDir::new().unwrap();
        let path = dir.path().join("t.h5");
        let table = Table::csv()
            .reader("a,s\n1,x\n2,long é\n".as_bytes(), "t.csv")
            .unwrap();
        let Column::Text(text) = &table.columns()[1] else {
            panic!("text")
        };
        write_datasets(
            &path,
            &[
                Output::Numbers("a", &[1.0, 2.0]),
                Output::Text("s", text),
                Output::Scalar("dt", 0.1),
                Output::Numbers("side", &[3.0]),
            ],
            &[("a", "h")],
        )
        .unwrap();
        assert_eq!(super::units(&path), [("a".to_string(), "h".to_string())]);
        let file = File::open(&path).unwrap();
        assert_eq!(
            file.dataset("s").unwrap().read_string().unwrap(),
            ["x", "long é"]
        );
        let back = read(&path).unwrap();
        assert_eq!(back.metadata("dt"), Some(0.1));
        assert_eq!(back.side_columns()[0].values, [3.0]);
        assert_eq!(back.headers(), ["a", "s"]);
        let Column::Text(cells) = &back.columns()[1] else {
            panic!("text read back as text")
        };
        assert_eq!((cells.get(0), cells.get(1)), ("x", "long é"));
    }

    #[test]
    fn a_chunked_dataset_reads() {
        let table = from_bytes(chunked_with_declared_length(37), "ok.h5").unwrap();
        assert_eq!(table.numeric("tt").unwrap()[36], 18.0);
    }

    /// `hdf5-pure` would allocate 8.8 TB for this dataset and abort the process.
    #[test]
    fn a_huge_declared_shape_is_refused_before_allocating() {
        let err = from_bytes(chunked_with_declared_length(1_100_000_000_000), "huge.h5")
            .unwrap_err()
            .to_string();
        assert!(err.starts_with("huge.h5: dataset \"tt\":"), "{err}");
        assert!(err.contains("larger than the file could hold"), "{err}");
    }
}
