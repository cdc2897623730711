//! An independent reading of the ASEG-GDF2 example surveys (tests/fixtures/aseg_gdf2, MIT),
//! shared by the reader's tests and the CLI's `convert` tests: the record's
//! whitespace-separated tokens taken in the order the `.dfn` lists the data record's fields,
//! `str::parse::<f64>` for a numeric field, the field's NULL value a missing value (NaN).
#![allow(dead_code)]

use std::path::{Path, PathBuf};
use tolles_io::table::{Column, Table};

/// The ten example surveys' stems.
pub const SURVEYS: [&str; 10] = [
    "Example_AeroMag_MuppetTown_2009",
    "Example_Gravity_LooneyTunesValley_1930",
    "Example_Gravity_NeverNeverLand_1904",
    "Example_Gravity_Springfield_1989",
    "Example_GroundMag_Bedrock_6000BC",
    "Example_GroundMag_HillValley_1985",
    "Example_Mag_Gondwana_200Ma",
    "Example_Mag_HillValley_1985",
    "Example_Rad256_SeasameSt_2008",
    "Example_Rad_BowsersCastle_2012",
];

pub fn fixture(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        // Through the crates' parent, so the CLI's tests, which include this file, find it too.
        .join("../tolles-io/tests/fixtures/aseg_gdf2")
        .join(name)
}

/// One column as the independent reading of the `.dfn` gives it.
pub struct Expected {
    pub name: String,
    pub text: bool,
    pub null: Option<f64>,
}

/// The data record's columns, read from the `.dfn` with none of the reader's code: every
/// definition after a DEFN's first `;`, except those of `COMM` and `PROJ` records, the `RT`
/// field and `END DEFN`.
pub fn expected_columns(dfn: &str) -> Vec<Expected> {
    let mut columns = Vec::new();
    for line in dfn.lines().filter(|l| l.starts_with("DEFN")) {
        let (head, defs) = line.split_once(';').unwrap();
        if head.contains("RT=COMM") || head.contains("RT=PROJ") {
            continue;
        }
        for def in defs.split(';').map(str::trim) {
            if def.starts_with("END DEFN") {
                return columns;
            }
            let (name, rest) = def.split_once(':').unwrap();
            let name = name.trim();
            if name == "RT" {
                continue;
            }
            let format: String = rest
                .trim()
                .chars()
                .take_while(|c| c.is_ascii_alphanumeric() || *c == '.')
                .collect();
            let digits: String = format.chars().take_while(char::is_ascii_digit).collect();
            let repeat: usize = if digits.is_empty() {
                1
            } else {
                digits.parse().unwrap()
            };
            let text = format[digits.len()..].starts_with(['A', 'a']);
            let null = rest.find("NULL=").map(|at| {
                let value: String = rest[at + 5..]
                    .chars()
                    .take_while(|c| *c != ',' && *c != ':')
                    .collect();
                value.trim().parse::<f64>().unwrap()
            });
            for i in 1..=repeat {
                let name = if repeat == 1 {
                    name.to_string()
                } else {
                    format!("{name}_{i}")
                };
                columns.push(Expected { name, text, null });
            }
        }
    }
    columns
}

/// `table` (read from survey `stem` in any way) checked cell by cell against the independent
/// reading of the survey's `.dfn` and `.dat`: the same column names, rows, numbers (NaN where
/// missing) and text. Returns its rows and columns.
pub fn check_table(stem: &str, table: &Table) -> (usize, usize) {
    let dfn = std::fs::read_to_string(fixture(&format!("{stem}.dfn"))).unwrap();
    let dat = std::fs::read_to_string(fixture(&format!("{stem}.dat"))).unwrap();
    let columns = expected_columns(&dfn);
    let names: Vec<&str> = columns.iter().map(|c| c.name.as_str()).collect();
    assert_eq!(table.headers(), names, "{stem}");
    let records: Vec<Vec<&str>> = dat
        .lines()
        .filter(|l| !l.trim().is_empty())
        .map(|l| {
            let mut tokens: Vec<&str> = l.split_whitespace().collect();
            if tokens.last() == Some(&"*") {
                tokens.pop();
            }
            assert!(tokens.len() <= columns.len(), "{stem}: {l}");
            tokens
        })
        .collect();
    assert_eq!(table.len(), records.len(), "{stem}: every record is a row");

    for (c, column) in columns.iter().enumerate() {
        if column.text {
            let Column::Text(cells) = &table.columns()[c] else {
                panic!("{stem}: {} is not text", column.name)
            };
            for (k, record) in records.iter().enumerate() {
                let want = record.get(c).copied().unwrap_or("");
                assert_eq!(cells.get(k).trim(), want, "{stem}: {}[{k}]", column.name);
            }
            continue;
        }
        let values = table
            .numeric(&column.name)
            .unwrap_or_else(|e| panic!("{stem}: {e}"));
        for (k, record) in records.iter().enumerate() {
            let want = match record.get(c) {
                None => f64::NAN,
                Some(token) => {
                    let v: f64 = token.parse().unwrap();
                    if Some(v) == column.null {
                        f64::NAN
                    } else {
                        v
                    }
                }
            };
            let got = values[k];
            assert!(
                got == want || got.is_nan() && want.is_nan(),
                "{stem}: {}[{k}] = {got}, expected {want}",
                column.name
            );
        }
    }
    (table.len(), table.headers().len())
}
