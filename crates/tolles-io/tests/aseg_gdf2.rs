//! The ten example surveys of the `aseg_gdf2` package (tests/fixtures/aseg_gdf2, MIT) read, and
//! every cell equals an independent reading: the record's whitespace-separated tokens taken in
//! the order the `.dfn` lists the data record's fields, `str::parse::<f64>` for a numeric
//! field, the field's NULL value a missing value (NaN).

mod common;

use common::gdf_independent::{check_table, expected_columns, fixture, SURVEYS};
use tolles_io::gdf;
use tolles_io::table::Table;

/// The reading of `stem` checked against the independent one; its rows and columns.
fn check_survey(stem: &str) -> (usize, usize) {
    let table = Table::read(&fixture(&format!("{stem}.dat")), None)
        .unwrap_or_else(|e| panic!("{stem}: {e}"));
    // The pair reads the same from its .dfn.
    let from_dfn = gdf::read(&fixture(&format!("{stem}.dfn"))).unwrap();
    assert_eq!(from_dfn.headers(), table.headers(), "{stem}");
    assert_eq!(from_dfn.len(), table.len(), "{stem}");

    check_table(stem, &table)
}

/// Every survey: its rows × columns, then a few cells as read by eye from the `.dat` text.
#[test]
fn all_ten_example_surveys_read_and_match_an_independent_reading() {
    let surveys = [
        // RT=DATA declared, records without it; a truncated last record (`0954 `).
        ("Example_AeroMag_MuppetTown_2009", (1051, 17)),
        // RT=DATA, whitespace-separated, a comma after a format (`TYPE:A8,NAME=TYPE`).
        ("Example_Gravity_LooneyTunesValley_1930", (50, 80)),
        // RT:A4 declared, absent from the records; attributes separated by colons.
        ("Example_Gravity_NeverNeverLand_1904", (265, 26)),
        // Tab-separated records, a text first field.
        ("Example_Gravity_Springfield_1989", (56, 13)),
        // RT=DATA;RT:A4 first, the other fields RT=; tab-separated.
        ("Example_GroundMag_Bedrock_6000BC", (304, 10)),
        // A first DEFN of another record type (RT=PROJ).
        ("Example_GroundMag_HillValley_1985", (2055, 13)),
        // A trailing `*` on every record.
        ("Example_Mag_Gondwana_200Ma", (254, 17)),
        // `DEFN001ST=RECORD`: no space after the DEFN number.
        ("Example_Mag_HillValley_1985", (1047, 18)),
        // `256f5.0`: 256 columns RAW_SPEC_1..RAW_SPEC_256; a truncated last record.
        ("Example_Rad256_SeasameSt_2008", (84, 270)),
        // `UNIT:metres` and `UNIT::` among colon-separated attributes.
        ("Example_Rad_BowsersCastle_2012", (94, 29)),
    ];
    for (stem, shape) in surveys {
        assert_eq!(check_survey(stem), shape, "{stem}: rows × columns");
    }

    let read = |stem: &str| Table::read(&fixture(&format!("{stem}.dfn")), None).unwrap();
    let muppet = read("Example_AeroMag_MuppetTown_2009");
    let mag = muppet.numeric("MAGCOMP").unwrap();
    assert_eq!(mag[0], 58268.254);
    assert!(
        mag[1050].is_nan(),
        "the truncated record's cells are missing"
    );
    assert_eq!(muppet.numeric("BGS_JOB").unwrap()[1050], 954.0);
    let gondwana = read("Example_Mag_Gondwana_200Ma");
    assert_eq!(gondwana.numeric("Fluxz").unwrap()[0], -2319.616);
    let sesame = read("Example_Rad256_SeasameSt_2008");
    assert_eq!(sesame.numeric("RAW_SPEC_1").unwrap()[0], 92.0);
    assert_eq!(sesame.numeric("COSMIC").unwrap()[2], 109.0);
    assert!(sesame.numeric("RAW_SPEC_256").unwrap()[83].is_nan());
    let never = read("Example_Gravity_NeverNeverLand_1904");
    assert_eq!(never.numeric("OBS_GRAV").unwrap()[0], 9795386.530);
    let bowser = read("Example_Rad_BowsersCastle_2012");
    assert_eq!(bowser.numeric("EASTMGA56").unwrap()[1], 501541.93);
    let springfield = read("Example_Gravity_Springfield_1989");
    assert_eq!(springfield.numeric("Den").unwrap()[0], 2.67);
    let hill = read("Example_GroundMag_HillValley_1985");
    assert_eq!(hill.numeric("Mag_mlev").unwrap()[0], 57718.8);
}

/// A survey cut anywhere in its last records still reads: every record is a row, the cut one
/// included, and every numeric column stays readable.
#[test]
fn surveys_cut_anywhere_in_their_last_records_still_read() {
    for stem in SURVEYS {
        let dfn = std::fs::read_to_string(fixture(&format!("{stem}.dfn"))).unwrap();
        let dat = std::fs::read_to_string(fixture(&format!("{stem}.dat"))).unwrap();
        let columns = expected_columns(&dfn);
        // Every 7th position in the last 600 bytes.
        let from = dat.len().saturating_sub(600);
        for end in (from..dat.len()).step_by(7) {
            let cut = &dat[..end];
            let rows = cut.lines().filter(|l| !l.trim().is_empty()).count();
            let table = gdf::from_text(&dfn, "t.dfn", cut, "t.dat")
                .unwrap_or_else(|e| panic!("{stem} cut at {end}: {e}"));
            assert_eq!(table.len(), rows, "{stem} cut at {end}");
            for column in columns.iter().filter(|c| !c.text) {
                table
                    .numeric(&column.name)
                    .unwrap_or_else(|e| panic!("{stem} cut at {end}: {e}"));
            }
        }
    }
}
