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
/// own `mag_1_c`), ours becomes `wanted_tolles`, or `wanted_tolles2`, `…3` when that is taken
/// too, so no input column is overwritten and no name repeats (tolles reads its own output).
/// A column counts as taken when [`crate::table::find_column`] would find it (also by case).
pub fn output_name(headers: &[String], wanted: &str) -> (String, bool) {
    let taken =
        |name: &str| crate::table::find_column(std::path::Path::new(""), headers, name).is_ok();
    if !taken(wanted) {
        return (wanted.to_string(), false);
    }
    let renamed = (1..)
        .map(|k| match k {
            1 => format!("{wanted}{RENAMED_SUFFIX}"),
            k => format!("{wanted}{RENAMED_SUFFIX}{k}"),
        })
        .find(|name| !taken(name))
        .expect("a finite header leaves some suffix free");
    (renamed, true)
}

/// [`output_name`] for several added columns at once: each is also kept apart from those
/// named before it, so two added columns never share a name.
pub fn output_names(headers: &[String], wanted: &[&str]) -> Vec<(String, bool)> {
    let mut taken = headers.to_vec();
    wanted
        .iter()
        .map(|w| {
            let named = output_name(&taken, w);
            taken.push(named.0.clone());
            named
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn strings(names: &[&str]) -> Vec<String> {
        names.iter().map(|s| s.to_string()).collect()
    }

    #[test]
    fn renamed_past_every_taken_name() {
        let headers = strings(&["mag_1_c", "mag_1_c_tolles", "MAG_1_C_TOLLES2"]);
        let name = output_name(&headers, "mag_1_c");
        assert_eq!(name, ("mag_1_c_tolles3".to_string(), true));
    }

    #[test]
    fn added_columns_never_repeat() {
        let headers = strings(&["mag_1_c"]);
        let names = output_names(&headers, &["mag_1_c", "mag_1_c_tolles", "status"]);
        let names: Vec<&str> = names.iter().map(|(n, _)| n.as_str()).collect();
        assert_eq!(names, ["mag_1_c_tolles", "mag_1_c_tolles_tolles", "status"]);
    }
}
