//! The flight schema: every column name tolles gives a meaning to, and the rule that names the
//! columns it adds. Nothing else in the workspace spells these names.
//!
//! ```
//! use tolles_io::schema::{compensated_name, output_name};
//! assert_eq!(compensated_name("mag_1_uc"), "mag_1_c");
//! assert_eq!(compensated_name("mag"), "mag_c");
//! let headers = ["tt".to_string(), "mag_1_c".to_string()];
//! assert_eq!(output_name(&headers, "mag_1_c"), ("mag_1_c_tolles".to_string(), true));
//! ```

/// Time (s); when present it gives the sample rate and marks gaps.
pub const TIME_COLUMN: &str = "tt";
/// Flight line ids.
pub const LINE_COLUMN: &str = "line";
/// Roll (deg), right wing down positive.
pub const ROLL: &str = "ins_roll";
/// Pitch (deg), nose up positive.
pub const PITCH: &str = "ins_pitch";
/// Yaw, the heading (deg), clockwise from north.
pub const YAW: &str = "ins_yaw";
/// The scalar a file may carry besides its columns (HDF5) holding the sample interval (s).
pub const SAMPLE_INTERVAL: &str = "dt";
/// Suffixes of a fluxgate's three body-frame components (FRD): `flux_a` → `flux_a_x` …
pub const AXES: [&str; 3] = ["_x", "_y", "_z"];
/// What [`output_name`] appends when the compensated column's name is taken.
pub const RENAMED_SUFFIX: &str = "_tolles";

/// The three columns of fluxgate `prefix`.
pub fn vector_columns(prefix: &str) -> [String; 3] {
    AXES.map(|axis| format!("{prefix}{axis}"))
}

/// The compensated column of `scalar`: `mag_1_uc` → `mag_1_c`; a name without `_uc` gets `_c`
/// appended.
pub fn compensated_name(scalar: &str) -> String {
    match scalar.strip_suffix("_uc") {
        Some(stem) => format!("{stem}_c"),
        None => format!("{scalar}_c"),
    }
}

/// The name a compensated column `wanted` is written under in a table with `headers`, and
/// whether it had to be renamed: when the input already has `wanted` (SGL files carry their
/// own `mag_1_c`), ours becomes `wanted_tolles` so no input column is overwritten.
/// A column counts as taken when [`crate::table::find_column`] would find it (also by case).
pub fn output_name(headers: &[String], wanted: &str) -> (String, bool) {
    if crate::table::find_column(std::path::Path::new(""), headers, wanted).is_ok() {
        (format!("{wanted}{RENAMED_SUFFIX}"), true)
    } else {
        (wanted.to_string(), false)
    }
}
