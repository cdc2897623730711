//! End-to-end: `tolles fit` on XYZ, HDF5 and Parquet flights gives the model it gives on the
//! same flight as CSV, and `tolles compensate` writes HDF5 and Parquet by `--out`'s extension.

use crate::common::{magnav, tolles};

use std::path::{Path, PathBuf};
use tempfile::TempDir;
use tolles_io::table::Table;

/// MagNav's golden flight as rows of tt, mag_1_uc, flux_a_x/y/z.
fn magnav_rows() -> Vec<[f64; 5]> {
    let fs = magnav("fs")[0];
    let (x, y, z, m) = (
        magnav("flux_a_x"),
        magnav("flux_a_y"),
        magnav("flux_a_z"),
        magnav("mag_1_uc"),
    );
    (0..m.len())
        .map(|k| [k as f64 / fs, m[k], x[k], y[k], z[k]])
        .collect()
}

fn write_csv(dir: &Path) -> PathBuf {
    let mut text = String::from("tt,mag_1_uc,flux_a_x,flux_a_y,flux_a_z\n");
    for r in magnav_rows() {
        text += &format!("{},{},{},{},{}\n", r[0], r[1], r[2], r[3], r[4]);
    }
    let path = dir.join("magnav.csv");
    std::fs::write(&path, text).unwrap();
    path
}

/// The same flight as Geosoft XYZ: comment lines, a `/` header, two Line blocks.
fn write_xyz(dir: &Path) -> PathBuf {
    let rows = magnav_rows();
    let mut text =
        String::from("/ XYZ EXPORT [magnav]\n/ tt mag_1_uc flux_a_x flux_a_y flux_a_z\n");
    for (k, r) in rows.iter().enumerate() {
        if k == 0 || k == rows.len() / 2 {
            text += &format!("\nLine {}\n", 1000 + k);
        }
        text += &format!("{} {} {} {} {}\n", r[0], r[1], r[2], r[3], r[4]);
    }
    let path = dir.join("magnav.xyz");
    std::fs::write(&path, text).unwrap();
    path
}

const FIT_ARGS: [&str; 14] = [
    "--scalar",
    "mag_1_uc",
    "--vector",
    "flux_a",
    "--terms",
    "permanent,induced,eddy",
    "--lambda",
    "0.001",
    "--band",
    "0.1,0.9",
    "--order",
    "4",
    "--trim",
    "20",
];

/// Fits `flight` and returns the model's coefficients.
fn fit(flight: &Path, model: &Path) -> Vec<f64> {
    tolles()
        .arg("fit")
        .arg(flight)
        .args(FIT_ARGS)
        .arg("--out")
        .arg(model)
        .assert()
        .success();
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(model).unwrap()).unwrap();
    json["fits"][0]["coefficients"]
        .as_array()
        .unwrap()
        .iter()
        .map(|c| c.as_f64().unwrap())
        .collect()
}

#[test]
fn every_format_fits_and_compensates_like_csv() {
    let dir = TempDir::new().unwrap();
    let csv = write_csv(dir.path());
    let model = dir.path().join("model.json");
    let reference = fit(&csv, &model);
    assert_eq!(reference.len(), 18);

    let xyz = write_xyz(dir.path());
    assert_eq!(fit(&xyz, &dir.path().join("xyz.json")), reference);

    let from_csv = compensated(&csv, &model, &dir.path().join("out.csv"));
    for ext in ["h5", "parquet"] {
        let out = dir.path().join(format!("out.{ext}"));
        let table = compensated(&csv, &model, &out);
        assert_eq!(table.headers(), from_csv.headers(), "{ext}");
        for name in from_csv.headers() {
            assert_eq!(
                table.numeric(name).unwrap(),
                from_csv.numeric(name).unwrap(),
                "{ext}: column {name}"
            );
        }
        let refit = fit(&out, &dir.path().join(format!("{ext}.json")));
        assert_eq!(refit, reference, "fit on the {ext} flight");
    }
}

/// MagNav's own `test_data_TL.mat` (MATLAB v5, struct `TL_data`, no time column: the sample
/// rate comes from `TL_data.fs`) fits as the same flight does as CSV, and compensates to
/// MagNav's `mag_1_c`.
#[test]
fn magnav_v5_mat_file_fits_like_csv() {
    let dir = TempDir::new().unwrap();
    let mat = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../tolles-io/tests/fixtures/magnav_test_data_TL.mat");
    let reference = fit(&write_csv(dir.path()), &dir.path().join("csv.json"));
    let model = dir.path().join("mat.json");
    let ours = fit(&mat, &model);
    assert_eq!(ours.len(), reference.len());
    for (k, (a, b)) in ours.iter().zip(&reference).enumerate() {
        assert!(
            (a - b).abs() <= 1e-9 * b.abs().max(1e-3),
            "coefficient {k}: {a} from the .mat, {b} from the CSV"
        );
    }
    let table = compensated(&mat, &model, &dir.path().join("out.csv"));
    let diff: Vec<f64> = table
        .numeric("mag_1_c")
        .unwrap()
        .iter()
        .zip(magnav("mag_1_c"))
        .map(|(a, b)| a - b)
        .collect();
    let mean = diff.iter().sum::<f64>() / diff.len() as f64;
    let std = (diff.iter().map(|d| (d - mean).powi(2)).sum::<f64>() / diff.len() as f64).sqrt();
    assert!(std < 0.1, "std(ours − mag_1_c) = {std}");
    // The brief form, with the default band, order and trim, reads the file too.
    tolles()
        .arg("fit")
        .arg(&mat)
        .args(&FIT_ARGS[..8])
        .arg("--out")
        .arg(dir.path().join("defaults.json"))
        .assert()
        .success();
}

/// Runs `tolles compensate FLIGHT --model MODEL --out OUT` and reads OUT back.
fn compensated(flight: &Path, model: &Path, out: &Path) -> Table {
    tolles()
        .arg("compensate")
        .arg(flight)
        .arg("--model")
        .arg(model)
        .arg("--out")
        .arg(out)
        .assert()
        .success();
    let table = Table::read(out, None).unwrap();
    assert!(table.has("mag_1_c"), "{}", out.display());
    table
}

#[test]
fn malformed_flights_give_one_line_errors() {
    let dir = TempDir::new().unwrap();
    for (name, bytes, expected) in [
        (
            "bad.h5",
            &b"\x89HDF\r\n\x1a\n\0\0"[..],
            "not a readable HDF5 file",
        ),
        (
            "bad.parquet",
            b"PAR1 not parquet PAR1",
            "not a readable Parquet file",
        ),
        (
            "bad.xyz",
            b"/ a b\n1 2\n3\n",
            "line 3: 1 fields, but the header has 2",
        ),
    ] {
        let path = dir.path().join(name);
        std::fs::write(&path, bytes).unwrap();
        let out = tolles()
            .arg("fit")
            .arg(&path)
            .args(FIT_ARGS)
            .output()
            .unwrap();
        assert!(!out.status.success(), "{name}");
        let err = String::from_utf8(out.stderr).unwrap();
        assert_eq!(err.lines().count(), 1, "{err}");
        assert!(
            err.starts_with("error: ") && err.contains(expected),
            "{err}"
        );
    }
}
