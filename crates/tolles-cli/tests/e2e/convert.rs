//! `tolles convert`: every format to CSV, HDF5 and Parquet with nothing lost, checked against
//! independent readings (MagNav's CSV export of its `.mat`, an independent GDF reading).

#[path = "../../../tolles-io/tests/common/gdf_independent.rs"]
mod gdf_independent;

use crate::common::{magnav, tolles};
use std::path::{Path, PathBuf};
use tempfile::TempDir;
use tolles_io::table::Table;

fn io_fixture(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../tolles-io/tests/fixtures")
        .join(name)
}

/// Runs `tolles convert input output` and returns its stderr; panics if it fails.
fn convert(input: &Path, output: &Path) -> String {
    let out = tolles()
        .arg("convert")
        .arg(input)
        .arg(output)
        .output()
        .unwrap();
    let stderr = String::from_utf8(out.stderr).unwrap();
    assert!(out.status.success(), "{stderr}");
    stderr
}

/// The 1-D fields of MagNav's `TL_data` struct: the eight 1000-long ones, and the two of other
/// lengths.
const TL_COLUMNS: [&str; 8] = [
    "flux_a_x",
    "flux_a_y",
    "flux_a_z",
    "mag_1_uc",
    "mag_1_comp",
    "mag_1_comp_d",
    "mag_1_c",
    "mag_1_c_d",
];

/// `values` with its trailing missing (padding) cells dropped.
fn unpadded(mut values: Vec<f64>) -> Vec<f64> {
    while values.last().is_some_and(|v| v.is_nan()) {
        values.pop();
    }
    values
}

#[test]
fn magnav_mat_converts_to_csv_with_every_1d_field_exact() {
    let dir = TempDir::new().unwrap();
    let csv = dir.path().join("tl.csv");
    let stderr = convert(&io_fixture("magnav_test_data_TL.mat"), &csv);
    assert!(
        stderr.contains(
            "padded to 1000 rows with empty cells: TL_a_1 (18), mag_1_uc_f_t (960), fs (1)"
        ),
        "{stderr}"
    );
    assert!(
        stderr.contains("\"TL_data.A_a\" is a 1000×18 double matrix"),
        "{stderr}"
    );
    assert!(
        stderr.contains("wrote 1000 rows, 11 columns (csv)"),
        "{stderr}"
    );
    let t = Table::read(&csv, None).unwrap();
    assert_eq!(t.len(), 1000);
    for field in TL_COLUMNS {
        assert_eq!(t.numeric(field).unwrap(), magnav(field), "{field}");
    }
    for field in ["TL_a_1", "mag_1_uc_f_t", "fs"] {
        assert_eq!(
            unpadded(t.numeric(field).unwrap()),
            magnav(field),
            "{field}"
        );
    }
}

#[test]
fn magnav_mat_converts_to_hdf5_with_every_field_at_its_own_length() {
    let dir = TempDir::new().unwrap();
    let h5 = dir.path().join("tl.h5");
    let stderr = convert(&io_fixture("magnav_test_data_TL.mat"), &h5);
    assert!(!stderr.contains("padded"), "{stderr}");
    let t = Table::read(&h5, None).unwrap();
    assert_eq!(t.len(), 1000);
    for field in TL_COLUMNS {
        assert_eq!(t.numeric(field).unwrap(), magnav(field), "{field}");
    }
    let side: Vec<(&str, &[f64])> = t
        .side_columns()
        .iter()
        .map(|c| (c.name.as_str(), c.values.as_slice()))
        .collect();
    assert_eq!(side.len(), 2, "{side:?}");
    assert_eq!(side[0], ("TL_a_1", magnav("TL_a_1").as_slice()));
    assert_eq!(side[1], ("mag_1_uc_f_t", magnav("mag_1_uc_f_t").as_slice()));
    assert_eq!(t.metadata("fs"), Some(magnav("fs")[0]), "a scalar dataset");
    assert_eq!(t.metadata("dt"), Some(1.0 / magnav("fs")[0]));
    assert_eq!(
        t.file_metadata().count(),
        1,
        "dt is not written: the input has none"
    );

    // And back to CSV from the HDF5: the same as from the .mat.
    let csv = dir.path().join("tl.csv");
    convert(&h5, &csv);
    let direct = dir.path().join("direct.csv");
    convert(&io_fixture("magnav_test_data_TL.mat"), &direct);
    assert_eq!(
        std::fs::read_to_string(&csv).unwrap(),
        std::fs::read_to_string(&direct).unwrap()
    );
}

#[test]
fn a_file_of_scalars_converts_to_a_one_row_table() {
    let dir = TempDir::new().unwrap();
    let csv = dir.path().join("params.csv");
    let stderr = convert(&io_fixture("magnav_test_data_params.mat"), &csv);
    assert!(stderr.contains("wrote 1 rows"), "{stderr}");
    let t = Table::read(&csv, None).unwrap();
    assert_eq!(t.len(), 1);
    assert!(t.headers().len() > 30, "{:?}", t.headers());
}

#[test]
fn a_longer_side_column_pads_the_table() {
    let dir = TempDir::new().unwrap();
    let h5 = dir.path().join("long.h5");
    let columns = [
        ("a".to_string(), vec![1.0, 2.0]),
        ("b".to_string(), vec![3.0, 4.0]),
        ("long".to_string(), vec![5.0, 6.0, 7.0]),
    ];
    tolles_io::hdf5::write(&h5, &columns).unwrap();
    let csv = dir.path().join("long.csv");
    let stderr = convert(&h5, &csv);
    assert!(
        stderr.contains("padded to 3 rows with empty cells: a (2), b (2)"),
        "{stderr}"
    );
    assert_eq!(
        std::fs::read_to_string(&csv).unwrap(),
        "a,b,long\n1,3,5\n2,4,6\n,,7\n"
    );
    let pq = dir.path().join("long.parquet");
    convert(&h5, &pq);
    let back = Table::read(&pq, None).unwrap();
    assert_eq!(back.len(), 3);
    assert!(back.numeric("a").unwrap()[2].is_nan());
    assert_eq!(back.numeric("long").unwrap(), [5.0, 6.0, 7.0]);
}

#[test]
fn every_gdf_survey_converts_to_csv_cell_for_cell() {
    let dir = TempDir::new().unwrap();
    for stem in gdf_independent::SURVEYS {
        let csv = dir.path().join(format!("{stem}.csv"));
        convert(&gdf_independent::fixture(&format!("{stem}.dfn")), &csv);
        let table = Table::read(&csv, None).unwrap_or_else(|e| panic!("{stem}: {e}"));
        gdf_independent::check_table(stem, &table);
    }
}

/// NeverNeverLand has three text columns that are not numbers (TIME, GRAV_METER,
/// METER_SERIAL): Parquet holds them as string columns (which tolles' Parquet reader, reading
/// numbers only, names as left out), and every numeric column equal to the CSV's.
#[test]
fn gdf_text_columns_survive_parquet() {
    let dir = TempDir::new().unwrap();
    let dfn = gdf_independent::fixture("Example_Gravity_NeverNeverLand_1904.dfn");
    let pq = dir.path().join("n.parquet");
    let stderr = convert(&dfn, &pq);
    assert!(
        stderr.contains("wrote 265 rows, 26 columns (parquet)"),
        "{stderr}"
    );
    let csv = dir.path().join("n.csv");
    convert(&dfn, &csv);
    let from_csv = Table::read(&csv, None).unwrap();
    let from_pq = Table::read(&pq, None).unwrap();
    let text = ["TIME", "GRAV_METER", "METER_SERIAL"];
    for name in from_pq
        .headers()
        .iter()
        .filter(|h| !text.contains(&h.as_str()))
    {
        let (a, b) = (
            from_pq.numeric(name).unwrap(),
            from_csv.numeric(name).unwrap(),
        );
        assert!(
            a.iter()
                .zip(&b)
                .all(|(x, y)| x == y || x.is_nan() && y.is_nan()),
            "{name}"
        );
    }
    // The text columns read back as written, as the CSV holds them.
    let cells = |t: &Table, name: &str| -> Vec<String> {
        let k = t.index_of(name).unwrap();
        match &t.columns()[k] {
            tolles_io::table::Column::Text(c) => {
                (0..c.len()).map(|r| c.get(r).to_string()).collect()
            }
            tolles_io::table::Column::Numbers(_) => panic!("{name} is not text"),
        }
    };
    for name in text {
        assert_eq!(cells(&from_pq, name), cells(&from_csv, name), "{name}");
    }
    assert_eq!(from_pq.headers(), from_csv.headers());
}

#[test]
fn unknown_output_extensions_are_errors_that_list_the_allowed_ones() {
    let dir = TempDir::new().unwrap();
    let input = io_fixture("geosoft.xyz");
    for name in ["out.xlsx", "out.xyz", "out.dfn", "out.mat", "out"] {
        let out = dir.path().join(name);
        let result = tolles()
            .arg("convert")
            .arg(&input)
            .arg(&out)
            .output()
            .unwrap();
        let stderr = String::from_utf8(result.stderr).unwrap();
        assert!(!result.status.success(), "{name}");
        assert!(
            stderr.contains("use .csv, .h5/.hdf5 or .parquet/.pq"),
            "{name}: {stderr}"
        );
        assert_eq!(stderr.lines().count(), 1, "{stderr}");
        assert!(!out.exists(), "{name}");
    }
    // simulate and compensate --out too.
    let out = dir.path().join("box.xlsx");
    let result = tolles()
        .args(["simulate", "--plan", "box", "--out"])
        .arg(&out)
        .output()
        .unwrap();
    let stderr = String::from_utf8(result.stderr).unwrap();
    assert!(
        !result.status.success() && stderr.contains("cannot write .xlsx files"),
        "{stderr}"
    );
    assert!(!out.exists());
    let csv = dir.path().join("box.csv");
    tolles()
        .args(["simulate", "--plan", "box", "--out"])
        .arg(&csv)
        .assert()
        .success();
    let model = dir.path().join("model.json");
    tolles()
        .arg("fit")
        .arg(&csv)
        .args(["--scalar", "mag_1_uc", "--vector", "flux_a", "--out"])
        .arg(&model)
        .assert()
        .success();
    let result = tolles()
        .arg("compensate")
        .arg(&csv)
        .arg("--model")
        .arg(&model)
        .arg("--out")
        .arg(&out)
        .output()
        .unwrap();
    let stderr = String::from_utf8(result.stderr).unwrap();
    assert!(
        !result.status.success() && stderr.contains("cannot write .xlsx files"),
        "{stderr}"
    );
    assert!(!out.exists());
}

#[test]
fn selection_and_renames_apply() {
    let dir = TempDir::new().unwrap();
    let input = dir.path().join("in.csv");
    std::fs::write(&input, "tt,line,MAGUC\n0,1,5\n0.1,1,6\n0.2,2,7\n").unwrap();
    let out = dir.path().join("out.csv");
    let result = tolles()
        .arg("convert")
        .arg(&input)
        .arg(&out)
        .args(["--line", "2", "--rename", "MAGUC=mag_1_uc"])
        .output()
        .unwrap();
    let stderr = String::from_utf8(result.stderr).unwrap();
    assert!(result.status.success(), "{stderr}");
    assert!(stderr.contains("2 rows not selected"), "{stderr}");
    assert_eq!(
        std::fs::read_to_string(&out).unwrap(),
        "tt,line,mag_1_uc\n0.2,2,7\n"
    );
}

#[test]
fn renames_reach_side_columns_and_scalars_and_refuse_a_name_they_would_share() {
    let dir = TempDir::new().unwrap();
    let mat = io_fixture("magnav_test_data_TL.mat");
    let h5 = dir.path().join("renamed.h5");
    let result = tolles()
        .arg("convert")
        .arg(&mat)
        .arg(&h5)
        .args(["--rename", "TL_a_1=tl_coefficients,fs=rate_hz,mag_1_uc=mag"])
        .output()
        .unwrap();
    let stderr = String::from_utf8(result.stderr).unwrap();
    assert!(result.status.success(), "{stderr}");
    let t = Table::read(&h5, None).unwrap();
    assert_eq!(t.numeric("mag").unwrap(), magnav("mag_1_uc"));
    let side: Vec<&str> = t.side_columns().iter().map(|c| c.name.as_str()).collect();
    assert_eq!(side, ["tl_coefficients", "mag_1_uc_f_t"]);
    assert_eq!(t.side_columns()[0].values, magnav("TL_a_1"));
    assert_eq!(t.metadata("rate_hz"), Some(magnav("fs")[0]));
    assert_eq!(t.metadata("fs"), None);

    for clash in ["mag_1_uc=TL_a_1", "TL_a_1=mag_1_uc", "fs=TL_a_1"] {
        let out = dir.path().join("clash.h5");
        let result = tolles()
            .arg("convert")
            .arg(&mat)
            .arg(&out)
            .args(["--rename", clash])
            .output()
            .unwrap();
        let stderr = String::from_utf8(result.stderr).unwrap();
        assert!(!result.status.success(), "{clash}: {stderr}");
        let errors: Vec<&str> = stderr.lines().filter(|l| l.starts_with("error")).collect();
        assert_eq!(errors.len(), 1, "{clash}: {stderr}");
        assert!(errors[0].contains("more than once"), "{clash}: {stderr}");
        assert!(!out.exists(), "{clash}");
    }
}

/// Text columns survive a trip through HDF5 and Parquet in their place (a file of text alone
/// too: the fuzzer's find, which converted but did not read back).
#[test]
fn text_columns_travel_through_every_format_and_back() {
    let dir = TempDir::new().unwrap();
    for original in ["tt,name,v\n0,abc,1\n1,,2\n2,é x,3\n", "M\nfirst\n"] {
        let input = dir.path().join("in.csv");
        std::fs::write(&input, original).unwrap();
        for via in ["h5", "parquet"] {
            let middle = dir.path().join(format!("mid.{via}"));
            let back = dir.path().join("back.csv");
            convert(&input, &middle);
            convert(&middle, &back);
            let text = std::fs::read_to_string(&back).unwrap();
            assert_eq!(text, original, "via {via}");
        }
    }
}

/// A one-column row whose cell is only blanks is a missing cell, not a blank line a reader
/// skips: every row reaches the output (the fuzzer's second find).
#[test]
fn a_one_column_row_of_blanks_stays_a_row() {
    let dir = TempDir::new().unwrap();
    let input = dir.path().join("in.csv");
    std::fs::write(&input, "a\n1\n\t\n3\n").unwrap();
    let out = dir.path().join("out.csv");
    convert(&input, &out);
    assert_eq!(std::fs::read_to_string(&out).unwrap(), "a\n1\n\"\"\n3\n");
    assert_eq!(Table::read(&out, None).unwrap().len(), 3);
}
