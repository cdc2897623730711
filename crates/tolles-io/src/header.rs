//! A table's header and cells as every reader sees them: finding a column by name (exactly,
//! else the one name equal ignoring case), with near names suggested when none matches;
//! renaming one; checking that a header names each column once; and what one text cell holds
//! ([`parse_cell`]: a number, or missing when empty or NaN). Only the error type is needed here,
//! so the table, the raw CSV reader and the schema can all build on it.

use crate::error::{IoError, Near};
use std::path::Path;

/// The longest header line a CSV file may have (bytes); far beyond any real flight's.
pub const MAX_HEADER_BYTES: usize = 1 << 20;

/// Renames header `old` (found as [`find_column`] finds it) of the file `path` to `new`; an
/// error if there is no such header or another is already called `new`.
pub(crate) fn rename_header(
    path: &Path,
    headers: &mut [String],
    old: &str,
    new: &str,
) -> Result<(), IoError> {
    let index = find_column(path, headers, old)?;
    let new = new.trim();
    if new.is_empty() {
        return Err(IoError::Empty {
            path: path.to_path_buf(),
        });
    }
    if headers
        .iter()
        .enumerate()
        .any(|(k, h)| k != index && h == new)
    {
        return Err(IoError::DuplicateColumn {
            path: path.to_path_buf(),
            column: new.to_string(),
        });
    }
    headers[index] = new.to_string();
    Ok(())
}

/// The index of column `name` in `headers` (of the file `path`), or an error that suggests near
/// names; see [`crate::table::Table::index_of`].
pub fn find_column(path: &Path, headers: &[String], name: &str) -> Result<usize, IoError> {
    let mut caseless = headers
        .iter()
        .enumerate()
        .filter(|(_, h)| h.eq_ignore_ascii_case(name));
    let only_caseless = match (caseless.next(), caseless.next()) {
        (Some((k, _)), None) => Some(k),
        _ => None,
    };
    headers
        .iter()
        .position(|h| h == name)
        .or(only_caseless)
        .ok_or_else(|| IoError::MissingColumn {
            path: path.to_path_buf(),
            column: name.to_string(),
            near: suggest(headers, name),
        })
}

/// The headers near `name` (case-insensitively), or the header's first names when none is
/// near.
pub(crate) fn suggest(headers: &[String], name: &str) -> Near {
    let n = name.to_ascii_lowercase();
    let stem = n.trim_end_matches(['x', 'y', 'z']).trim_end_matches('_');
    // Spelled without its separators (mag1uc, MAG-1-UC) a name is still near.
    let bare = |s: &str| s.replace(['_', '-', ' ', '.'], "");
    let near: Vec<String> = headers
        .iter()
        .filter(|h| {
            let h = h.to_ascii_lowercase();
            h.contains(&n)
                || n.contains(&h)
                || (!stem.is_empty() && h.starts_with(stem))
                || (!h.is_empty() && bare(&h) == bare(&n))
        })
        .take(6)
        .cloned()
        .collect();
    if near.is_empty() {
        let first: Vec<String> = headers.iter().take(12).cloned().collect();
        let more = headers.len().saturating_sub(first.len());
        Near::Header { first, more }
    } else {
        Near::Names(near)
    }
}

/// The fluxgate prefixes in `headers` (names `P_x`, `P_y`, `P_z` in any case) near `prefix`,
/// case-insensitively, and the three columns `PX:PY:PZ` of a fluxgate whose names have no
/// separator (which no prefix reads); `None` when none is near.
pub(crate) fn suggest_vector(headers: &[String], prefix: &str) -> Option<Near> {
    let lower: Vec<String> = headers.iter().map(|h| h.to_ascii_lowercase()).collect();
    let wanted = prefix.to_ascii_lowercase();
    let near: Vec<String> = headers
        .iter()
        .zip(&lower)
        .filter_map(|(h, l)| {
            let (stem, separator) = match l.strip_suffix("_x") {
                Some(stem) => (stem, "_"),
                None => (l.strip_suffix('x')?, ""),
            };
            let sibling = |axis: &str| {
                let name = format!("{stem}{separator}{axis}");
                (lower.iter().position(|o| *o == name)).map(|k| headers[k].as_str())
            };
            let (y, z) = (sibling("y")?, sibling("z")?);
            let close = !stem.is_empty()
                && (stem.starts_with(&wanted)
                    || wanted.starts_with(stem)
                    || stem.contains(&wanted));
            close.then(|| match separator {
                "_" => h[..stem.len()].to_string(),
                _ => format!("{h}:{y}:{z}"),
            })
        })
        .take(6)
        .collect();
    (!near.is_empty()).then_some(Near::Names(near))
}

/// Parses one cell: empty or NaN is missing (NaN); otherwise a number or `None`.
pub fn parse_cell(cell: &str) -> Option<f64> {
    let cell = cell.trim();
    if cell.is_empty() || cell.eq_ignore_ascii_case("nan") {
        return Some(f64::NAN);
    }
    cell.parse::<f64>().ok()
}

/// Errors if `headers` names no column or names one twice.
pub(crate) fn check_header(path: &Path, headers: &[String]) -> Result<(), IoError> {
    if headers.is_empty() || headers.iter().all(String::is_empty) {
        return Err(IoError::Empty {
            path: path.to_path_buf(),
        });
    }
    check_unique(path, headers)
}

fn check_unique(path: &Path, headers: &[String]) -> Result<(), IoError> {
    // A set, not a scan of the names before each: a header of 400 000 names took minutes.
    let mut seen = std::collections::HashSet::with_capacity(headers.len());
    match headers.iter().find(|h| !seen.insert(h.as_str())) {
        Some(h) => Err(IoError::DuplicateColumn {
            path: path.to_path_buf(),
            column: h.clone(),
        }),
        None => Ok(()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_long_header_is_listed_in_part_with_the_rest_counted() {
        let headers: Vec<String> = (0..20).map(|k| format!("col{k}")).collect();
        let said = suggest(&headers, "mag_1_uc").to_string();
        assert!(said.starts_with("; the header has: col0, col1,"), "{said}");
        assert!(
            said.ends_with("col11 and 8 more (tolles info lists them)"),
            "{said}"
        );
        let few = suggest(&headers[..3], "mag_1_uc").to_string();
        assert_eq!(few, "; the header has: col0, col1, col2");
    }
}
