//! `-` as a flight file: standard input, read whole into memory, its format told by its
//! content (standard input has no extension to go by).
//!
//! ```
//! use tolles_io::format::Format;
//! use tolles_io::stdin::sniff;
//! assert_eq!(sniff(b"tt,mag_1_uc\n0,50000\n"), Format::Csv);
//! assert_eq!(sniff(b"/ tt mag_1_uc\nLine 1\n0 50000\n"), Format::Xyz);
//! assert_eq!(sniff(b"PAR1\0\0"), Format::Parquet);
//! ```

use crate::error::IoError;
use crate::format::Format;
use crate::table::Table;
use std::io::Read;
use std::path::Path;

/// The file name that stands for standard input.
pub const STDIN: &str = "-";

/// How messages name standard input (in place of a file name).
pub const STDIN_NAME: &str = "<stdin>";

/// Whether `path` is `-`, standard input.
pub fn is_stdin(path: &Path) -> bool {
    path.as_os_str() == STDIN
}

/// Reads a flight table from standard input, in `format` or else in the format its content
/// shows ([`sniff`]).
pub fn read(format: Option<Format>) -> Result<Table, IoError> {
    let mut bytes = Vec::new();
    std::io::stdin()
        .lock()
        .read_to_end(&mut bytes)
        .map_err(|source| IoError::Open {
            path: STDIN_NAME.into(),
            source,
        })?;
    from_bytes(bytes, format)
}

/// A flight table from the bytes of standard input, in `format` or the one [`sniff`] finds.
pub fn from_bytes(bytes: Vec<u8>, format: Option<Format>) -> Result<Table, IoError> {
    let name = Path::new(STDIN_NAME);
    let format = format.unwrap_or_else(|| sniff(&bytes));
    let table = match format {
        Format::Csv => Table::csv().bytes(bytes, name),
        Format::Xyz => crate::xyz::from_reader(bytes.as_slice(), name),
        Format::Parquet => crate::parquet::from_bytes(bytes, name),
        Format::Hdf5 if crate::mat::is_v5(&bytes) => {
            return Ok(crate::mat::from_bytes(&bytes, name)?.with_format_name("mat"))
        }
        Format::Hdf5 => crate::hdf5::from_bytes(bytes, name),
        // Its data file is named by its definition file; there is no second standard input.
        Format::Gdf => Err(IoError::Invalid {
            path: name.to_path_buf(),
            message: "ASEG-GDF (a .dfn and a .dat file) cannot be read from standard input; \
                      give the .dfn file's name"
                .into(),
        }),
    };
    Ok(table?.with_format_name(format.names()[0]))
}

/// The format `bytes` are in: HDF5 (also MATLAB v7.3, whose HDF5 signature follows a 512-byte
/// user block), MATLAB v5 (read with HDF5's `.mat`), Parquet by their signatures; Geosoft XYZ
/// when the first line that is not blank starts with `/` or is a `Line`/`Tie` block header;
/// CSV otherwise.
pub fn sniff(bytes: &[u8]) -> Format {
    const HDF5_SIGNATURE: &[u8] = b"\x89HDF\r\n\x1a\n";
    let hdf5 = [0, 512, 1024, 2048].iter().any(|&at| {
        bytes
            .get(at..)
            .is_some_and(|b| b.starts_with(HDF5_SIGNATURE))
    });
    if hdf5 || crate::mat::is_v5(bytes) {
        return Format::Hdf5;
    }
    if bytes.starts_with(b"PAR1") {
        return Format::Parquet;
    }
    let text = String::from_utf8_lossy(&bytes[..bytes.len().min(4096)]);
    let first = text
        .trim_start_matches('\u{feff}')
        .lines()
        .map(str::trim)
        .find(|l| !l.is_empty())
        .unwrap_or("");
    let block = |word: &str| {
        first
            .get(..word.len())
            .is_some_and(|w| w.eq_ignore_ascii_case(word))
            && first[word.len()..].starts_with(char::is_whitespace)
    };
    if first.starts_with('/') || block("line") || block("tie") {
        Format::Xyz
    } else {
        Format::Csv
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn text_is_csv_unless_it_looks_like_geosoft_xyz() {
        assert_eq!(sniff(b""), Format::Csv);
        assert_eq!(sniff(b"\n\nline,tt\n1,0\n"), Format::Csv);
        assert_eq!(sniff(b"  LINE 1002.02\n0 1\n"), Format::Xyz);
        assert_eq!(sniff(b"Tie\t3001\n"), Format::Xyz);
    }

    #[test]
    fn binary_formats_are_known_by_their_signatures() {
        let mut v73 = vec![0u8; 512];
        v73.extend_from_slice(b"\x89HDF\r\n\x1a\n");
        assert_eq!(sniff(&v73), Format::Hdf5);
        assert_eq!(sniff(b"\x89HDF\r\n\x1a\n"), Format::Hdf5);
        let mut v5 = b"MATLAB 5.0 MAT-file".to_vec();
        v5.resize(128, b' ');
        v5[124..128].copy_from_slice(&[0x00, 0x01, b'I', b'M']);
        assert_eq!(sniff(&v5), Format::Hdf5);
    }

    #[test]
    fn tables_from_bytes_are_named_stdin() {
        let t = from_bytes(b"tt,x\n0,1\n1,2\n".to_vec(), None).unwrap();
        assert_eq!(t.path(), Path::new(STDIN_NAME));
        assert_eq!(t.numeric("x").unwrap(), [1.0, 2.0]);
        let t = from_bytes(b"/ tt x\n0 1\n".to_vec(), None).unwrap();
        assert_eq!(t.numeric("x").unwrap(), [1.0]);
        let e = from_bytes(Vec::new(), Some(Format::Gdf)).unwrap_err();
        assert!(e.to_string().contains("standard input"), "{e}");
    }
}
