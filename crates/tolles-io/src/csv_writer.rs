//! Tables written as CSV: every row, in order, its cells as they were read, and added columns
//! of numbers in the shortest text that reads back the same.

use crate::error::IoError;
use crate::table::Table;
use std::path::Path;

/// Writes `table` plus the `extra` columns (empty cell for NaN) as CSV.
///
/// Every input row is written, in order, with its cells unchanged (a format's own dummy, such as
/// XYZ's `*`, is written as an empty cell; numbers from binary files as [`format_value`] writes
/// them).
pub fn write_with_column(
    table: &Table,
    extra: &[(String, Vec<f64>)],
    out: impl std::io::Write,
) -> std::io::Result<()> {
    let extra: Vec<(&str, &[f64])> = extra
        .iter()
        .map(|(n, v)| (n.as_str(), v.as_slice()))
        .collect();
    write_padded(table, &extra, table.len(), out)
}

/// Writes the rows of `table` plus the `extra` columns (no header), as [`write_with_column`]
/// does; a file written in chunks is the same text as one written whole.
pub(crate) fn write_rows(
    table: &Table,
    extra: &[&[f64]],
    out: &mut dyn std::io::Write,
) -> std::io::Result<()> {
    write_body(table, extra, table.len(), out)
}

/// Writes `names` as a CSV header row.
pub(crate) fn write_header<'n>(
    names: impl IntoIterator<Item = &'n str>,
    out: &mut dyn std::io::Write,
) -> std::io::Result<()> {
    let mut writer = csv::WriterBuilder::new().from_writer(WithoutFlush(out));
    writer.write_record(names).map_err(into_io)?;
    writer.flush()
}

/// Writes [`write_padded`]'s `rows` rows, without the header: rows of a CSV file left in its
/// bytes are copied ([`crate::rawcsv::write_rows`]) when nothing is padded.
fn write_body(
    table: &Table,
    extra: &[&[f64]],
    rows: usize,
    out: &mut dyn std::io::Write,
) -> std::io::Result<()> {
    match table.raw_rows() {
        Some(raw) if rows == table.len() && extra.iter().all(|v| v.len() == rows) => {
            crate::rawcsv::write_rows(raw, extra, out)
        }
        _ => {
            let mut writer = csv::WriterBuilder::new().from_writer(WithoutFlush(out));
            write_padded_rows(table, extra, rows, &mut writer)?;
            writer.flush()
        }
    }
}

/// A writer whose [`Write::flush`] does nothing: the csv crate's flush of its own buffer
/// would otherwise flush the output under it too, which for [`crate::atomic::DirectWriter`]
/// ends its direct writes.
struct WithoutFlush<'w>(&'w mut dyn std::io::Write);

impl std::io::Write for WithoutFlush<'_> {
    fn write(&mut self, bytes: &[u8]) -> std::io::Result<usize> {
        self.0.write(bytes)
    }

    fn flush(&mut self) -> std::io::Result<()> {
        Ok(())
    }
}

/// Writes `table` plus the `extra` columns, of any lengths, as CSV of `rows` rows with a header
/// row: a row past the end of the table or of an extra column has an empty cell there (a
/// missing value). `rows` below the longest column is raised to it, so nothing is cut off.
pub fn write_padded(
    table: &Table,
    extra: &[(&str, &[f64])],
    rows: usize,
    mut out: impl std::io::Write,
) -> std::io::Result<()> {
    let mut header: Vec<&str> = table.headers().iter().map(String::as_str).collect();
    header.extend(extra.iter().map(|(name, _)| *name));
    let values: Vec<&[f64]> = extra.iter().map(|(_, v)| *v).collect();
    let longest = values.iter().map(|v| v.len()).max().unwrap_or(0);
    let rows = rows.max(table.len()).max(longest);
    write_header(header, &mut out)?;
    write_body(table, &values, rows, &mut out)?;
    out.flush()
}

fn write_padded_rows<W: std::io::Write>(
    table: &Table,
    extra: &[&[f64]],
    rows: usize,
    writer: &mut csv::Writer<W>,
) -> std::io::Result<()> {
    let width = table.headers().len();
    let mut cells = vec![String::new(); width + extra.len()];
    for k in 0..rows {
        for (j, cell) in cells.iter_mut().enumerate() {
            cell.clear();
            match j.checked_sub(width) {
                None if k < table.len() => table.cell_text(j, k, cell),
                None => {}
                Some(e) => format_value(extra[e].get(k).copied().unwrap_or(f64::NAN), cell),
            }
        }
        writer.write_record(&cells).map_err(into_io)?;
    }
    Ok(())
}

/// Writes named numeric columns of equal length as CSV with a header row.
pub fn write_columns(columns: &[(&str, &[f64])], out: impl std::io::Write) -> std::io::Result<()> {
    let mut writer = csv::WriterBuilder::new().from_writer(out);
    writer
        .write_record(columns.iter().map(|(name, _)| *name))
        .map_err(into_io)?;
    let rows = columns.first().map_or(0, |(_, v)| v.len());
    let mut cells = vec![String::new(); columns.len()];
    for k in 0..rows {
        for (cell, (_, values)) in cells.iter_mut().zip(columns) {
            cell.clear();
            format_value(values[k], cell);
        }
        writer.write_record(&cells).map_err(into_io)?;
    }
    writer.flush()
}

/// Writes `columns` to `path` (see [`write_columns`]), whole or not at all ([`crate::atomic`]).
pub fn write_columns_to(path: &Path, columns: &[(&str, &[f64])]) -> Result<(), IoError> {
    crate::atomic::write_with(path, |out| write_columns(columns, out))
}

/// Shortest text that reads back as the same f64; `inf`/`-inf` for an infinite value (as pandas
/// writes it), empty for a missing one. Magnitudes below 1e-5 or from 1e17 on are written with
/// an exponent (`3.3347e-11`), not as dozens of zeros.
pub fn format_value(v: f64, out: &mut String) {
    use std::fmt::Write;
    if !v.is_finite() {
        out.push_str(non_finite_text(v));
        return;
    }
    let magnitude = v.abs();
    if magnitude != 0.0 && !(1e-5..1e17).contains(&magnitude) {
        let _ = write!(out, "{v:e}");
    } else {
        let _ = write!(out, "{v}");
    }
}

/// The cell text of a value that is not finite: an infinity keeps its sign, NaN is missing.
pub(crate) fn non_finite_text(v: f64) -> &'static str {
    match v {
        f64::INFINITY => "inf",
        f64::NEG_INFINITY => "-inf",
        _ => "",
    }
}

pub(crate) fn into_io(e: csv::Error) -> std::io::Error {
    match e.into_kind() {
        csv::ErrorKind::Io(io) => io,
        other => std::io::Error::other(format!("{other:?}")),
    }
}
