//! Every format: files made by the tools people use read as expected, written tables read back
//! identically, and malformed files give a one-line error naming the file.

use std::path::{Path, PathBuf};
use tolles_io::format::{write_everything, write_table, Format};
use tolles_io::table::Table;

fn fixture(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/fixtures")
        .join(name)
}

/// The values `scripts/fixtures/gen_format_fixtures.py` writes in row `k`.
fn expected(column: &str, k: usize) -> f64 {
    let k = k as f64;
    match column {
        "tt" => 0.1 * k,
        "mag_1_uc" if k == 3.0 => f64::NAN,
        "mag_1_uc" => 50_000.0 + k / 4.0,
        "flux_a_x" => 30_000.0 - k,
        "flux_a_y" => 100.0 + 2.0 * k,
        "flux_a_z" => 40_000.0 + k / 8.0,
        other => panic!("no expected values for {other}"),
    }
}

const COLUMNS: [&str; 5] = ["tt", "mag_1_uc", "flux_a_x", "flux_a_y", "flux_a_z"];

fn assert_fixture_values(table: &Table, names: [&str; 5]) {
    assert_eq!(table.len(), 8, "{}", table.path().display());
    for (column, name) in COLUMNS.iter().zip(names) {
        let values = table.numeric(name).unwrap();
        for (k, v) in values.iter().enumerate() {
            let want = expected(column, k);
            assert!(
                (want.is_nan() && v.is_nan()) || (v - want).abs() <= 1e-9 * want.abs(),
                "{}: {name}[{k}] = {v}, expected {want}",
                table.path().display()
            );
        }
    }
}

fn read(name: &str) -> Table {
    Table::read(&fixture(name), None).unwrap()
}

#[test]
fn h5py_file_in_sgl_layout_reads_columns_and_scalars() {
    let t = read("sgl_flight.h5");
    assert_fixture_values(&t, COLUMNS);
    assert_eq!(t.numeric("line").unwrap(), vec![1002.02; 8]);
    assert_eq!(t.numeric("flight").unwrap()[7], 7.0);
    assert_eq!(t.numeric("ins_roll").unwrap()[0], -5.0);
    assert_eq!(t.metadata("dt"), Some(0.1));
    assert_eq!(t.metadata("N"), Some(8.0));
    assert!(!t.has("dt") && !t.has("ins_dcm"));
    let notes = t.notes().join("\n");
    assert!(
        notes.contains("\"ins_dcm\"") && notes.contains("group \"extra\""),
        "{notes}"
    );
    let err = t.numeric("mag_9_uc").unwrap_err().to_string();
    assert!(err.contains("no column \"mag_9_uc\""), "{err}");
}

#[test]
fn matlab_v73_file_with_user_block_reads_its_vectors() {
    let t = read("matlab_v73.mat");
    assert_fixture_values(&t, COLUMNS);
    assert_eq!(t.metadata("dt"), Some(0.1));
    assert!(!t.has("pilot"), "a MATLAB char array is not a column");
    assert!(
        t.notes().iter().any(|n| n.contains("MATLAB char")),
        "{:?}",
        t.notes()
    );
}

#[test]
fn pyarrow_parquet_reads_numbers_nulls_and_integers() {
    for name in ["pyarrow.parquet", "pyarrow_zstd.parquet"] {
        let t = read(name);
        assert_fixture_values(&t, COLUMNS);
        assert_eq!(t.numeric("fid").unwrap()[5], 5.0);
        // A string column reads as text (it was left out before issue 46).
        assert!(t.numeric("pilot").is_err());
        let k = t.index_of("pilot").unwrap();
        let tolles_io::table::Column::Text(pilot) = &t.columns()[k] else {
            panic!("pilot is not text");
        };
        assert_eq!(pilot.get(0), "ana");
        assert!(t.notes().is_empty(), "{:?}", t.notes());
    }
}

#[test]
fn geosoft_xyz_reads_blocks_and_dummies() {
    let t = read("geosoft.xyz");
    assert_fixture_values(&t, COLUMNS);
    let line = t.numeric("line").unwrap();
    assert_eq!(line[..5], [1002.02; 5]);
    assert_eq!(line[5..], [3001.0; 3]);
    assert_eq!(t.line_of(0), 9);
}

#[test]
fn aseg_gdf_pair_reads_from_either_file() {
    let names = ["TT", "MAG_1_UC", "FLUX_A_1", "FLUX_A_2", "FLUX_A_3"];
    for name in ["aseg.dfn", "aseg.dat"] {
        let t = read(name);
        assert_fixture_values(&t, names);
        assert_eq!(t.headers(), names);
        assert_eq!(t.numeric("mag_1_uc").unwrap()[0], 50_000.0, "any case");
    }
}

fn one_line_error(name: &str) -> String {
    let err = Table::read(&fixture(name), None).unwrap_err().to_string();
    assert!(!err.contains('\n'), "{err}");
    assert!(err.contains(name), "{err}");
    err
}

#[test]
fn malformed_files_give_one_line_errors() {
    let ragged = one_line_error("bad_ragged.xyz");
    assert!(
        ragged.ends_with("line 4: 1 fields, but the header has 2"),
        "{ragged}"
    );
    let missing = one_line_error("bad_missing_field.dat");
    assert!(
        missing.contains("line 2: 5 fields, but the .dfn defines 6"),
        "{missing}"
    );
    let truncated = one_line_error("bad_truncated.h5");
    assert!(truncated.contains("HDF5"), "{truncated}");
    let garbage = one_line_error("bad_garbage.parquet");
    assert!(garbage.contains("not a readable Parquet file"), "{garbage}");
    let err = Table::read(&fixture("no_such.dat"), None)
        .unwrap_err()
        .to_string();
    assert!(err.contains("no dfn file beside it"), "{err}");
}

fn round_trip(format: Format, ext: &str) {
    let dir = std::env::temp_dir().join(format!("tolles-formats-{}-{ext}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let source = read("geosoft.xyz");
    let values = [
        1.5,
        f64::NAN,
        -2.25e-7,
        1e300,
        0.1,
        0.2,
        0.3,
        49_999.123_456_789,
    ];
    let extra = [("mag_1_c", values.as_slice())];
    let path = dir.join(format!("out.{ext}"));
    write_table(&source, &extra, &path, format).unwrap();
    let back = Table::read(&path, None).unwrap();
    let mut names: Vec<String> = source.headers().to_vec();
    names.push("mag_1_c".into());
    assert_eq!(back.headers(), names);
    for (k, name) in source.headers().iter().enumerate() {
        let (a, b) = (source.numeric_at(k).unwrap(), back.numeric(name).unwrap());
        assert_same(&a, &b, name);
    }
    assert_same(&values, &back.numeric("mag_1_c").unwrap(), "mag_1_c");
    std::fs::remove_dir_all(&dir).unwrap();
}

fn assert_same(a: &[f64], b: &[f64], name: &str) {
    assert_eq!(a.len(), b.len(), "{name}");
    for (x, y) in a.iter().zip(b) {
        assert!(
            x.to_bits() == y.to_bits() || (x.is_nan() && y.is_nan()),
            "{name}: {x} != {y}"
        );
    }
}

#[test]
fn hdf5_round_trip_is_exact() {
    round_trip(Format::Hdf5, "h5");
}

#[test]
fn parquet_round_trip_is_exact() {
    round_trip(Format::Parquet, "parquet");
}

#[test]
fn csv_round_trip_is_exact() {
    round_trip(Format::Csv, "csv");
}

#[test]
fn text_columns_are_written_as_text_to_binary_formats() {
    let t = Table::csv()
        .reader("a,name,n\n1,ana,7\n2,,\n".as_bytes(), "t.csv")
        .unwrap();
    let dir = tempfile::TempDir::new().unwrap();
    let h5 = dir.path().join("t.h5");
    // compensate's writer wants numbers, as its chunked writer does: the text cell is named.
    let err = write_table(&t, &[], &h5, Format::Hdf5)
        .unwrap_err()
        .to_string();
    assert_eq!(
        err,
        "t.csv: line 2, column \"name\": \"ana\" is not a number"
    );
    assert!(!h5.exists());
    let written = write_everything(&t, &h5, Format::Hdf5).unwrap();
    assert_eq!(written.text_columns, ["name"]);
    let file = hdf5_pure::File::open(&h5).unwrap();
    let names = file.dataset("name").unwrap().read_string().unwrap();
    assert_eq!(names, ["ana", ""]);
    let back = Table::read(&h5, None).unwrap();
    assert_eq!(back.numeric("a").unwrap(), [1.0, 2.0]);
    assert!(back.numeric("n").unwrap()[1].is_nan());

    let pq = dir.path().join("t.parquet");
    let written = write_everything(&t, &pq, Format::Parquet).unwrap();
    assert_eq!(written.text_columns, ["name"]);
    use parquet::file::reader::FileReader;
    let reader =
        parquet::file::reader::SerializedFileReader::new(std::fs::File::open(&pq).unwrap())
            .unwrap();
    let rows: Vec<String> = reader
        .get_row_iter(None)
        .unwrap()
        .map(|row| row.unwrap().to_string())
        .collect();
    assert_eq!(
        rows,
        [
            "{a: 1.0, name: \"ana\", n: 7.0}",
            "{a: 2.0, name: null, n: null}"
        ]
    );
}

/// Cut and corrupted binary files are errors, never panics.
#[test]
fn damaged_binary_files_never_panic() {
    let dir = std::env::temp_dir().join(format!("tolles-damaged-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    for name in ["sgl_flight.h5", "matlab_v73.mat", "pyarrow.parquet"] {
        let bytes = std::fs::read(fixture(name)).unwrap();
        let path = dir.join(name);
        let step = (bytes.len() / 150).max(1);
        for cut in (0..bytes.len()).step_by(step) {
            std::fs::write(&path, &bytes[..cut]).unwrap();
            let read = Table::read(&path, None);
            // A cut that spares the columns' data may still read; one in the first half not.
            assert!(
                read.is_err() || cut > bytes.len() / 2,
                "{name} cut at {cut}"
            );
            let mut flipped = bytes.clone();
            flipped[cut] ^= 0x5a;
            std::fs::write(&path, &flipped).unwrap();
            let _ = Table::read(&path, None);
        }
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

mod round_trips {
    use super::*;
    use proptest::prelude::*;

    fn value() -> impl Strategy<Value = f64> {
        prop_oneof![
            9 => any::<f64>().prop_filter("finite", |v| v.is_finite()),
            1 => Just(f64::NAN),
        ]
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(48))]

        /// Any numbers, missing values included, come back bit for bit from every writer.
        #[test]
        fn written_numbers_read_back_identically(
            a in prop::collection::vec(value(), 1..40),
            seed in any::<u64>(),
        ) {
            let b: Vec<f64> = a.iter().map(|v| v * 0.5 - seed as f64).collect();
            let source = Table::from_columns(
                "p",
                vec!["a".into()],
                vec![tolles_io::table::Column::Numbers(a.clone())],
                None,
            )
            .unwrap();
            let dir = std::env::temp_dir().join(format!("tolles-prop-{}-{seed}", std::process::id()));
            std::fs::create_dir_all(&dir).unwrap();
            for (format, ext) in [(Format::Csv, "csv"), (Format::Hdf5, "h5"), (Format::Parquet, "parquet")] {
                let path = dir.join(format!("p.{ext}"));
                write_table(&source, &[("b", b.as_slice())], &path, format).unwrap();
                let back = Table::read(&path, None).unwrap();
                assert_same(&a, &back.numeric("a").unwrap(), ext);
                assert_same(&b, &back.numeric("b").unwrap(), ext);
            }
            std::fs::remove_dir_all(&dir).unwrap();
        }
    }
}

/// A pandas `datetime64[ns]` time column (Parquet INT64, TIMESTAMP(NANOS)) reads as seconds
/// since 1970, with a note, not as nanoseconds (a 1e-8 Hz flight).
#[test]
fn parquet_timestamps_read_as_seconds() {
    use parquet::basic::{LogicalType, Repetition, TimeUnit, Type as Physical};
    use parquet::data_type::{DoubleType, Int64Type};
    use parquet::file::properties::WriterProperties;
    use parquet::file::writer::SerializedFileWriter;
    use parquet::schema::types::Type;
    use std::sync::Arc;
    let dir = tempfile::TempDir::new().unwrap();
    let path = dir.path().join("t.parquet");
    let time = Type::primitive_type_builder("tt", Physical::INT64)
        .with_repetition(Repetition::REQUIRED)
        .with_logical_type(Some(LogicalType::timestamp(true, TimeUnit::NANOS)))
        .build()
        .unwrap();
    let mag = Type::primitive_type_builder("mag", Physical::DOUBLE)
        .with_repetition(Repetition::REQUIRED)
        .build()
        .unwrap();
    let schema = Type::group_type_builder("flight")
        .with_fields(vec![Arc::new(time), Arc::new(mag)])
        .build()
        .unwrap();
    let file = std::fs::File::create(&path).unwrap();
    let properties = Arc::new(WriterProperties::builder().build());
    let mut writer = SerializedFileWriter::new(file, Arc::new(schema), properties).unwrap();
    let mut group = writer.next_row_group().unwrap();
    let start_ns: i64 = 1_600_000_000_000_000_000;
    let tt: Vec<i64> = (0..4).map(|k| start_ns + k * 100_000_000).collect();
    let mut column = group.next_column().unwrap().unwrap();
    column
        .typed::<Int64Type>()
        .write_batch(&tt, None, None)
        .unwrap();
    column.close().unwrap();
    let mut column = group.next_column().unwrap().unwrap();
    column
        .typed::<DoubleType>()
        .write_batch(&[5e4; 4], None, None)
        .unwrap();
    column.close().unwrap();
    group.close().unwrap();
    writer.close().unwrap();
    let table = Table::read(&path, None).unwrap();
    let tt = table.numeric("tt").unwrap();
    assert_eq!(tt[0], 1.6e9);
    assert!((tt[3] - tt[0] - 0.3).abs() < 1e-6, "{tt:?}");
    assert!(
        table.notes().iter().any(|n| n.contains("timestamps (ns)")),
        "{:?}",
        table.notes()
    );
}

/// Text columns written to Parquet (line ids, dates as text) read back as text, whole and in
/// chunks, as `convert` writes them (issue 46: the reader used to leave them out, so a file it
/// wrote could read back empty).
#[test]
fn parquet_text_columns_read_back_as_text() {
    let dir = tempfile::TempDir::new().unwrap();
    let csv = dir.path().join("t.csv");
    std::fs::write(&csv, "line,tt,mag\nL1,0,1\nL1,0.1,2\n,0.2,3\nL2,0.3,4\n").unwrap();
    let table = Table::read(&csv, None).unwrap();
    let pq = dir.path().join("t.parquet");
    write_everything(&table, &pq, Format::Parquet).unwrap();
    let back = Table::read(&pq, None).unwrap();
    assert_eq!(back.headers(), ["line", "tt", "mag"]);
    let mut text = Vec::new();
    tolles_io::table::write_with_column(&back, &[], &mut text).unwrap();
    assert_eq!(
        String::from_utf8(text).unwrap(),
        "line,tt,mag\nL1,0,1\nL1,0.1,2\n,0.2,3\nL2,0.3,4\n"
    );
    let mut reader = tolles_io::chunks::ChunkReader::open(&pq, Format::Parquet, 3).unwrap();
    let mut rows = 0;
    while let Some(chunk) = reader.next_chunk().unwrap() {
        assert_eq!(chunk.headers(), ["line", "tt", "mag"]);
        rows += chunk.len();
    }
    assert_eq!(rows, 4);
}
