//! MATLAB v5 MAT-files: MagNav's own test data and files written by scipy's `savemat`
//! (compressed and not) read with every 1-D numeric struct field a column equal to what the
//! reference tools read, scalars as metadata, and the rest named in the notes.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use tolles_io::table::Table;

fn fixture(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/fixtures")
        .join(name)
}

/// A column of MagNav's CSV export of `TL_data` (tolles-core's fixtures), one value per line.
fn magnav_csv(name: &str) -> Vec<f64> {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../tolles-core/tests/fixtures/magnav")
        .join(format!("TL_data.{name}.csv"));
    std::fs::read_to_string(path)
        .unwrap()
        .lines()
        .map(|l| l.trim().parse().unwrap())
        .collect()
}

#[test]
fn magnav_test_data_reads_every_field_exactly() {
    // A byte-for-byte copy of MagNav.jl's test/test_data/test_data_TL.mat (MATLAB v5, zlib).
    let t = Table::read(&fixture("magnav_test_data_TL.mat"), None).unwrap();
    assert_eq!(t.len(), 1000);
    for field in [
        "flux_a_x",
        "flux_a_y",
        "flux_a_z",
        "mag_1_uc",
        "mag_1_comp",
        "mag_1_comp_d",
        "mag_1_c",
        "mag_1_c_d",
    ] {
        // %.17g text round-trips doubles exactly.
        assert_eq!(t.numeric(field).unwrap(), magnav_csv(field), "{field}");
    }
    assert_eq!(t.metadata("fs"), Some(magnav_csv("fs")[0]));
    assert_eq!(t.metadata("dt"), Some(1.0 / magnav_csv("fs")[0]));
    assert_eq!(t.file_metadata().count(), 1, "dt is worked out, not read");
    // Fields of other lengths are side columns, every value kept.
    let side: Vec<(&str, &[f64])> = t
        .side_columns()
        .iter()
        .map(|c| (c.name.as_str(), c.values.as_slice()))
        .collect();
    assert_eq!(side.len(), 2, "{side:?}");
    assert_eq!(side[0].0, "TL_a_1");
    assert_eq!(side[0].1, magnav_csv("TL_a_1"));
    assert_eq!(side[1].0, "mag_1_uc_f_t");
    assert_eq!(side[1].1, magnav_csv("mag_1_uc_f_t"));
    let notes = t.notes().join("\n");
    for left_out in [
        "\"TL_data.A_a\" is a 1000×18 double matrix, not a column",
        "\"TL_data.A_a_f_t\" is a 960×18 double matrix",
    ] {
        assert!(notes.contains(left_out), "{left_out} not in {notes}");
    }
    assert_eq!(t.notes().len(), 2, "{notes}");
}

#[test]
fn magnav_params_file_of_scalars_is_a_one_row_table() {
    let t = Table::read(&fixture("magnav_test_data_params.mat"), None).unwrap();
    assert_eq!(t.len(), 1);
    assert!(t.headers().len() > 3, "{:?}", t.headers());
    assert!(t.side_columns().is_empty());
    assert_eq!(t.file_metadata().count(), 0);
}

/// What scipy's `loadmat` read from `matlab_v5.mat` (`scripts/fixtures/gen_mat_fixtures.py`):
/// every 1-D or scalar numeric leaf by its dotted path, NaN as null.
fn loadmat_values() -> BTreeMap<String, Vec<Option<f64>>> {
    let text = std::fs::read_to_string(fixture("matlab_v5.json")).unwrap();
    serde_json::from_str(&text).unwrap()
}

#[test]
fn scipy_savemat_files_read_like_loadmat() {
    let expected = loadmat_values();
    for name in ["matlab_v5.mat", "matlab_v5_plain.mat"] {
        let t = Table::read(&fixture(name), None).unwrap();
        assert_eq!(t.len(), 8, "{name}");
        // Unique field names are columns by themselves; `tt` is both a top-level variable
        // (which keeps its name) and a field of `flight.meta` (named by its path).
        assert_eq!(
            t.headers(),
            [
                "mag_1_uc",
                "flux_a_x",
                "flux_a_y",
                "flux_a_z",
                "ok",
                "flight.meta.tt",
                "tt"
            ],
            "{name}"
        );
        let column = |path: &str| match path {
            "flight.meta.tt" | "tt" => path.to_string(),
            _ => path.rsplit('.').next().unwrap().to_string(),
        };
        for (path, want) in &expected {
            if want.len() == 8 {
                let got = t.numeric(&column(path)).unwrap();
                for (k, (g, w)) in got.iter().zip(want).enumerate() {
                    match w {
                        Some(w) => assert_eq!(g, w, "{name}: {path}[{k}]"),
                        None => assert!(g.is_nan(), "{name}: {path}[{k}]"),
                    }
                }
            } else if want.len() == 1 {
                assert_eq!(t.metadata(&column(path)), want[0], "{name}: {path}");
            }
        }
        assert_eq!(t.metadata("gain"), Some(2.5));
        assert_eq!(t.metadata("N"), Some(8.0));
        assert_eq!(t.metadata("dt"), Some(0.1));
        let short = &t.side_columns()[0];
        assert_eq!(
            (short.name.as_str(), &short.values[..]),
            ("short", &[1.0, 2.0, 3.0][..])
        );
        let notes = t.notes().join("\n");
        for left_out in [
            "\"A\" is a 8×2 double matrix, not a column",
            "\"label\" is a 1×9 char array",
            "\"notes\" is a 1×2 cell array",
        ] {
            assert!(
                notes.contains(left_out),
                "{name}: {left_out} not in {notes}"
            );
        }
    }
}

#[test]
fn damaged_files_give_one_line_errors() {
    let good = std::fs::read(fixture("matlab_v5.mat")).unwrap();
    let plain = std::fs::read(fixture("matlab_v5_plain.mat")).unwrap();
    let mut cases: Vec<Vec<u8>> = Vec::new();
    for len in [130, 200, 400, good.len() - 1] {
        cases.push(good[..len].to_vec());
    }
    for len in [136, 200, 700, plain.len() - 3] {
        cases.push(plain[..len].to_vec());
    }
    let mut flipped = good.clone();
    flipped[300] ^= 0xFF;
    cases.push(flipped);
    let mut huge = plain.clone();
    huge[132..136].copy_from_slice(&u32::MAX.to_le_bytes());
    cases.push(huge);
    for (k, bytes) in cases.iter().enumerate() {
        match tolles_io::mat::from_bytes(bytes, "bad.mat") {
            Ok(_) => {}
            Err(e) => {
                let e = e.to_string();
                assert!(e.starts_with("bad.mat: "), "case {k}: {e}");
                assert_eq!(e.lines().count(), 1, "case {k}: {e}");
            }
        }
    }
}

/// A MAT-file cut short is named for what it claims to be (issue 46, item 29), not "not a
/// readable HDF5 file".
#[test]
fn a_truncated_mat_file_is_called_a_mat_file() {
    let dir = tempfile::TempDir::new().unwrap();
    let cases = [
        (
            "matlab_v5.mat",
            100,
            "a MATLAB v5 MAT-file cut short (100 bytes",
        ),
        ("matlab_v73.mat", 1000, "MATLAB v7.3 MAT-file (HDF5)"),
        ("sgl_flight.h5", 1000, "not a MATLAB MAT-file"),
    ];
    for (name, len, says) in cases {
        let bytes = std::fs::read(fixture(name)).unwrap();
        let path = dir.path().join("cut.mat");
        std::fs::write(&path, &bytes[..len]).unwrap();
        let e = Table::read(&path, None).unwrap_err().to_string();
        assert!(e.contains(says) && !e.contains("HDF5 file"), "{name}: {e}");
        assert_eq!(e.lines().count(), 1, "{e}");
    }
}
