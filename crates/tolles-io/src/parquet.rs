//! Apache Parquet flight tables: one numeric column per channel; a null is a missing value.
//!
//! ```
//! use tolles_io::parquet;
//! let dir = std::env::temp_dir().join(format!("tolles-parquet-doc-{}", std::process::id()));
//! std::fs::create_dir_all(&dir).unwrap();
//! let path = dir.join("flight.parquet");
//! parquet::write(&path, &[("tt".into(), vec![0.0, 0.1]), ("mag_1_uc".into(), vec![5e4, f64::NAN])]).unwrap();
//! let table = parquet::read(&path).unwrap();
//! assert_eq!(table.numeric("tt").unwrap(), [0.0, 0.1]);
//! assert!(table.numeric("mag_1_uc").unwrap()[1].is_nan());
//! # std::fs::remove_dir_all(&dir).unwrap();
//! ```
//!
//! Double, float, integer and boolean columns are read as numbers; other columns (text,
//! nested) are left out and named in [`Table::notes`]. Written files hold optional float64
//! columns, NaN written as null, and optional UTF-8 string columns for text that is not numbers
//! ([`write_padded`]).

use crate::error::IoError;
use crate::table::{Column, Table, TextColumn};
use ::parquet::basic::{LogicalType, Repetition, Type as PhysicalType};
use ::parquet::column::reader::{ColumnReader, ColumnReaderImpl};
use ::parquet::data_type::{ByteArray, ByteArrayType, DataType, DoubleType};
use ::parquet::errors::ParquetError;
use ::parquet::file::properties::WriterProperties;
use ::parquet::file::reader::{ChunkReader, FileReader, SerializedFileReader};
use ::parquet::file::writer::{SerializedColumnWriter, SerializedFileWriter};
use ::parquet::schema::types::Type;
use std::path::Path;
use std::sync::Arc;

/// Rows per row group in written files: large enough to compress well, small enough to stream.
const ROW_GROUP: usize = 1 << 20;

/// Rows decoded per call when reading: memory grows with the values actually decoded, never
/// with a row count the file merely declares.
const BATCH_ROWS: usize = 1 << 16;

/// Reads the numeric columns of a Parquet file.
pub fn read(path: &Path) -> Result<Table, IoError> {
    let file = std::fs::File::open(path).map_err(|source| IoError::Open {
        path: path.to_path_buf(),
        source,
    })?;
    contained(path, || read_from(file, path))
}

/// Reads the numeric columns of a Parquet file from its bytes; `name` is used in error messages.
pub fn from_bytes(bytes: Vec<u8>, name: impl AsRef<Path>) -> Result<Table, IoError> {
    let path = name.as_ref();
    contained(path, || read_from(bytes::Bytes::from(bytes), path))
}

/// Runs `read` with a panic inside the `parquet` crate reported as an unreadable file.
pub(crate) fn contained<T>(
    path: &Path,
    read: impl FnOnce() -> Result<T, IoError>,
) -> Result<T, IoError> {
    crate::guard::contain(read, |why| IoError::Invalid {
        path: path.to_path_buf(),
        message: format!("not a readable Parquet file ({why})"),
    })
}

fn read_from<R: ChunkReader + 'static>(source: R, path: &Path) -> Result<Table, IoError> {
    let invalid = |e: ParquetError| IoError::Invalid {
        path: path.to_path_buf(),
        message: format!("not a readable Parquet file: {e}"),
    };
    let reader = SerializedFileReader::new(source).map_err(invalid)?;
    let (headers, wanted, notes) = numeric_columns(&reader);
    let mut columns: Vec<Column> = wanted.iter().map(empty_column).collect();
    for g in 0..reader.num_row_groups() {
        let group = reader.get_row_group(g).map_err(invalid)?;
        let rows = group.metadata().num_rows() as usize;
        for (wanted, out) in wanted.iter().zip(columns.iter_mut()) {
            let mut column = group.get_column_reader(wanted.index).map_err(invalid)?;
            read_any_column(&mut column, wanted, rows, out).map_err(invalid)?;
        }
    }
    Ok(Table::from_columns(path, headers, columns, None)?.with_notes(notes))
}

/// A column of a Parquet file tolles reads: numbers, or UTF-8 text.
#[derive(Debug, Clone, Copy)]
pub(crate) struct NumericColumn {
    /// Its index in the file's schema.
    pub index: usize,
    /// Its maximum definition level (0: no nulls possible).
    pub max_def: i16,
    /// Seconds per stored unit, for a timestamp or date (read as seconds since 1970).
    pub seconds_per: Option<f64>,
    /// A string column (line ids, dates as text), read as text cells.
    pub text: bool,
}

/// The columns of a file tolles reads (numbers and UTF-8 strings): their names, how to read
/// each, and a note for every column left out or converted.
pub(crate) fn numeric_columns<R: ChunkReader + 'static>(
    reader: &SerializedFileReader<R>,
) -> (Vec<String>, Vec<NumericColumn>, Vec<String>) {
    let schema = reader.metadata().file_metadata().schema_descr_ptr();
    let mut headers = Vec::new();
    let mut wanted = Vec::new();
    let mut notes = Vec::new();
    for (k, column) in schema.columns().iter().enumerate() {
        let name = column.path().string();
        let numeric = matches!(
            column.physical_type(),
            PhysicalType::DOUBLE
                | PhysicalType::FLOAT
                | PhysicalType::INT32
                | PhysicalType::INT64
                | PhysicalType::BOOLEAN
        );
        let text = column.physical_type() == PhysicalType::BYTE_ARRAY
            && matches!(column.logical_type_ref(), Some(LogicalType::String))
            || column.converted_type() == ::parquet::basic::ConvertedType::UTF8;
        if column.max_rep_level() > 0 || !(numeric || text) {
            notes.push(format!(
                "column {name:?} is not a numeric or text column; left out"
            ));
            continue;
        }
        let seconds_per = seconds_per_unit(column.logical_type_ref());
        if let Some((unit, _)) = seconds_per {
            notes.push(format!(
                "column {name:?} holds {unit}: read as seconds since 1970-01-01"
            ));
        }
        headers.push(name);
        wanted.push(NumericColumn {
            index: k,
            max_def: column.max_def_level(),
            seconds_per: seconds_per.map(|(_, s)| s),
            text,
        });
    }
    (headers, wanted, notes)
}

/// For a timestamp or date column, what it holds and the seconds per stored unit.
fn seconds_per_unit(logical: Option<&LogicalType>) -> Option<(&'static str, f64)> {
    use ::parquet::basic::TimeUnit;
    match logical? {
        LogicalType::Timestamp(timestamp) => Some(match timestamp.unit {
            TimeUnit::MILLIS => ("timestamps (ms)", 1e-3),
            TimeUnit::MICROS => ("timestamps (µs)", 1e-6),
            TimeUnit::NANOS => ("timestamps (ns)", 1e-9),
        }),
        LogicalType::Date => Some(("dates (days)", 86_400.0)),
        _ => None,
    }
}

/// An empty column of the kind `wanted` reads into.
pub(crate) fn empty_column(wanted: &NumericColumn) -> Column {
    match wanted.text {
        true => Column::Text(TextColumn::new(Default::default())),
        false => Column::Numbers(Vec::new()),
    }
}

/// Appends the next `rows` cells of one column chunk to `out`, numbers or text as it holds.
pub(crate) fn read_any_column(
    column: &mut ColumnReader,
    wanted: &NumericColumn,
    rows: usize,
    out: &mut Column,
) -> Result<(), ParquetError> {
    match out {
        Column::Text(text) => read_text_column(column, wanted, rows, text),
        Column::Numbers(values) => read_column(column, wanted, rows, values),
    }
}

/// Appends the next `rows` values of one column chunk to `out`, NaN for nulls, timestamps and
/// dates in seconds.
pub(crate) fn read_column(
    column: &mut ColumnReader,
    wanted: &NumericColumn,
    rows: usize,
    out: &mut Vec<f64>,
) -> Result<(), ParquetError> {
    let (max_def, from) = (wanted.max_def, out.len());
    match column {
        ColumnReader::DoubleColumnReader(r) => read_typed(r, max_def, rows, out, |v| v),
        ColumnReader::FloatColumnReader(r) => read_typed(r, max_def, rows, out, f64::from),
        ColumnReader::Int32ColumnReader(r) => read_typed(r, max_def, rows, out, f64::from),
        ColumnReader::Int64ColumnReader(r) => read_typed(r, max_def, rows, out, |v| v as f64),
        ColumnReader::BoolColumnReader(r) => {
            read_typed(r, max_def, rows, out, |v| f64::from(u8::from(v)))
        }
        _ => Err(ParquetError::General("not a numeric column".into())),
    }?;
    if let Some(seconds) = wanted.seconds_per {
        out[from..].iter_mut().for_each(|v| *v *= seconds);
    }
    Ok(())
}

/// Appends the next `rows` cells of one UTF-8 column chunk to `out`; a null is an empty cell
/// (a missing value), text that is not UTF-8 is read with replacement characters.
pub(crate) fn read_text_column(
    column: &mut ColumnReader,
    wanted: &NumericColumn,
    rows: usize,
    out: &mut TextColumn,
) -> Result<(), ParquetError> {
    let ColumnReader::ByteArrayColumnReader(reader) = column else {
        return Err(ParquetError::General("not a text column".into()));
    };
    let mut cells: Vec<Option<String>> = Vec::with_capacity(rows);
    let text = |v: ByteArray| Some(String::from_utf8_lossy(v.data()).into_owned());
    read_typed_into(reader, wanted.max_def, rows, &mut cells, text, None)?;
    for cell in cells {
        out.push(cell.as_deref().unwrap_or(""));
    }
    Ok(())
}

fn read_typed<T: DataType>(
    reader: &mut ColumnReaderImpl<T>,
    max_def: i16,
    rows: usize,
    out: &mut Vec<f64>,
    convert: impl Fn(T::T) -> f64,
) -> Result<(), ParquetError>
where
    T::T: Clone,
{
    read_typed_into(reader, max_def, rows, out, convert, f64::NAN)
}

/// Appends the next `rows` values of one column chunk to `out`, converted, `null` for nulls.
fn read_typed_into<T: DataType, V: Clone>(
    reader: &mut ColumnReaderImpl<T>,
    max_def: i16,
    rows: usize,
    out: &mut Vec<V>,
    convert: impl Fn(T::T) -> V,
    null: V,
) -> Result<(), ParquetError>
where
    T::T: Clone,
{
    let mut defs = Vec::new();
    let mut present = Vec::new();
    let mut read = 0;
    while read < rows {
        defs.clear();
        present.clear();
        // A bounded batch: `rows` comes from the file's metadata and may be a damaged count.
        let batch = (rows - read).min(BATCH_ROWS);
        let (records, _, _) = reader.read_records(batch, Some(&mut defs), None, &mut present)?;
        if records == 0 {
            return Err(ParquetError::General(format!(
                "column chunk ends after {read} of {rows} rows"
            )));
        }
        let mut values = present.iter().cloned();
        if max_def == 0 {
            out.extend(values.map(&convert));
        } else {
            for def in &defs {
                let value = if *def == max_def { values.next() } else { None };
                out.push(value.map_or(null.clone(), &convert));
            }
        }
        read += records;
    }
    Ok(())
}

/// Writes `columns` as optional float64 columns (NaN as null) to a new Parquet file, whole or
/// not at all ([`crate::atomic`]).
pub fn write(path: &Path, columns: &[(String, Vec<f64>)]) -> Result<(), IoError> {
    let outputs: Vec<Output<'_>> = columns
        .iter()
        .map(|(name, values)| Output::Numbers(name, values))
        .collect();
    let rows = columns.first().map_or(0, |(_, v)| v.len());
    write_padded(path, &outputs, rows)
}

/// One column [`write_padded`] writes.
#[derive(Debug, Clone, Copy)]
pub enum Output<'a> {
    /// An optional float64 column; NaN is null.
    Numbers(&'a str, &'a [f64]),
    /// An optional UTF-8 string column of a text column's cells as written; an empty cell or
    /// the format's dummy (XYZ's `*`) is null.
    Text(&'a str, &'a TextColumn),
}

/// Writes `columns` as a Parquet file of `rows` rows, whole or not at all ([`crate::atomic`]):
/// a column shorter than `rows` is null in the rows past its end.
pub fn write_padded(path: &Path, columns: &[Output<'_>], rows: usize) -> Result<(), IoError> {
    let fail = |e: ParquetError| IoError::Write {
        path: path.to_path_buf(),
        source: std::io::Error::other(e.to_string()),
    };
    let file = crate::atomic::AtomicFile::create(path)?;
    let handle = file.file().try_clone().map_err(|source| IoError::Write {
        path: path.to_path_buf(),
        source,
    })?;
    let properties = Arc::new(WriterProperties::builder().build());
    let mut writer =
        SerializedFileWriter::new(handle, output_schema(columns).map_err(fail)?, properties)
            .map_err(fail)?;
    for start in (0..rows).step_by(ROW_GROUP) {
        let end = (start + ROW_GROUP).min(rows);
        let mut group = writer.next_row_group().map_err(fail)?;
        for output in columns {
            let Some(mut column) = group.next_column().map_err(fail)? else {
                break;
            };
            match output {
                Output::Numbers(_, values) => {
                    let mut part: Vec<f64> = values
                        .get(start..end.min(values.len()))
                        .unwrap_or(&[])
                        .to_vec();
                    part.resize(end - start, f64::NAN);
                    write_values(&mut column, &part)
                }
                Output::Text(_, text) => write_text(&mut column, text, start..end),
            }
            .map_err(fail)?;
            column.close().map_err(fail)?;
        }
        group.close().map_err(fail)?;
    }
    writer.close().map_err(fail)?;
    file.commit()
}

/// Writes the cells `rows` of `text` to one column of a row group: null for a missing cell
/// (empty or the format's dummy) and for rows past the column's end.
fn write_text(
    column: &mut SerializedColumnWriter<'_>,
    text: &TextColumn,
    rows: std::ops::Range<usize>,
) -> Result<(), ParquetError> {
    let mut present = Vec::new();
    let mut defs = Vec::with_capacity(rows.len());
    for k in rows {
        let cell = (k < text.len())
            .then(|| text.get(k))
            .filter(|c| !c.is_empty());
        match cell.filter(|_| !text.is_dummy(k)) {
            Some(cell) => {
                present.push(ByteArray::from(cell));
                defs.push(1);
            }
            None => defs.push(0),
        }
    }
    column
        .typed::<ByteArrayType>()
        .write_batch(&present, Some(&defs), None)?;
    Ok(())
}

/// The schema of `columns`: optional float64 and UTF-8 string columns.
fn output_schema(columns: &[Output<'_>]) -> Result<Arc<Type>, ParquetError> {
    let fields = columns
        .iter()
        .map(|output| {
            let builder = match output {
                Output::Numbers(name, _) => {
                    Type::primitive_type_builder(name, PhysicalType::DOUBLE)
                }
                Output::Text(name, _) => {
                    Type::primitive_type_builder(name, PhysicalType::BYTE_ARRAY)
                        .with_logical_type(Some(LogicalType::String))
                }
            };
            builder
                .with_repetition(Repetition::OPTIONAL)
                .build()
                .map(Arc::new)
        })
        .collect::<Result<Vec<_>, _>>()?;
    Ok(Arc::new(
        Type::group_type_builder("flight")
            .with_fields(fields)
            .build()?,
    ))
}

/// A writer of optional float64 columns `names`; NaN is written as null.
pub(crate) fn new_writer(
    file: std::fs::File,
    names: &[&str],
) -> Result<SerializedFileWriter<std::fs::File>, ParquetError> {
    let properties = Arc::new(WriterProperties::builder().build());
    SerializedFileWriter::new(file, schema(names)?, properties)
}

/// Writes `values` to one column of a row group, NaN as null.
pub(crate) fn write_values(
    column: &mut SerializedColumnWriter<'_>,
    values: &[f64],
) -> Result<(), ParquetError> {
    let present: Vec<f64> = values.iter().copied().filter(|v| !v.is_nan()).collect();
    let defs: Vec<i16> = values.iter().map(|v| i16::from(!v.is_nan())).collect();
    column
        .typed::<DoubleType>()
        .write_batch(&present, Some(&defs), None)?;
    Ok(())
}

fn schema(names: &[&str]) -> Result<Arc<Type>, ParquetError> {
    let fields = names
        .iter()
        .map(|name| {
            Type::primitive_type_builder(name, PhysicalType::DOUBLE)
                .with_repetition(Repetition::OPTIONAL)
                .build()
                .map(Arc::new)
        })
        .collect::<Result<Vec<_>, _>>()?;
    Ok(Arc::new(
        Type::group_type_builder("flight")
            .with_fields(fields)
            .build()?,
    ))
}
