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
/// Latitude (deg).
pub const LATITUDE: &str = "lat";
/// Longitude (deg).
pub const LONGITUDE: &str = "lon";
/// Distance north of a local origin (m), as the simulator writes it.
pub const NORTH: &str = "north_m";
/// Distance east of a local origin (m), as the simulator writes it.
pub const EAST: &str = "east_m";
/// A reference magnetometer free of the aircraft's field (nT), such as a tail stinger's, as the
/// simulator writes it (`tolles fit --reference mag_ref`).
pub const REFERENCE_MAGNETOMETER: &str = "mag_ref";
/// Current of a saturating electrical load (A), as the simulator writes it.
pub const LOAD_CURRENT: &str = "cur_load";
/// Angle of a control surface (deg), trailing edge down positive, as the simulator writes it.
pub const FLAP_ANGLE: &str = "pos_flap";
/// Temperature of the aircraft's magnetised structure (°C), as the simulator writes it.
pub const TEMPERATURE: &str = "temp";
/// The unit of an extra channel by its name, for its coefficient's unit (nT per it): the
/// simulator's channels by name, then DAF-MIT/SGL's families by prefix (`cur_*` currents,
/// `vol_*` voltages); first match wins.
const CHANNEL_UNITS: [(&str, &str); 8] = [
    (LOAD_CURRENT, "A"),
    (FLAP_ANGLE, "°"),
    (TEMPERATURE, "°C"),
    ("cur_", "A"),
    ("vol_", "V"),
    ("volt", "V"),
    ("temp_", "°C"),
    ("ins_", "°"),
];

/// The unit of the channel `name` ([`CHANNEL_UNITS`]: `A`, `V`, `°`, `°C`), or `None` when
/// its name does not say it.
pub fn channel_unit(name: &str) -> Option<&'static str> {
    let name = name.to_ascii_lowercase();
    CHANNEL_UNITS
        .iter()
        .find(|(pattern, _)| {
            name == *pattern || (pattern.ends_with('_') && name.starts_with(pattern))
        })
        .map(|(_, unit)| *unit)
}

/// Truth: what the simulated cabin effects add to the scalar (nT).
pub const TRUTH_EFFECTS: &str = "truth_effects";
/// Diurnal variation (nT), as a base station measured it.
pub const DIURNAL: &str = "diurnal";
/// The core field of the IGRF model at the aircraft (nT).
pub const IGRF: &str = "igrf";
/// The scalar a file may carry besides its columns (HDF5) holding the sample interval (s).
pub const SAMPLE_INTERVAL: &str = "dt";
/// Suffixes of a fluxgate's three body-frame components (FRD): `flux_a` → `flux_a_x` …
pub const AXES: [&str; 3] = ["_x", "_y", "_z"];
/// What [`output_name`] appends when the compensated column's name is taken.
pub const RENAMED_SUFFIX: &str = "_tolles";

/// What separates the three columns of a fluxgate named explicitly: `FLUXA_X:FLUXA_Y:FLUXA_Z`.
pub const TRIPLE_SEPARATOR: char = ':';

/// The three columns of fluxgate `spec`: a prefix (`flux_a` → `flux_a_x`, `flux_a_y`,
/// `flux_a_z`; a table finds them whatever the suffixes' case, so `FLUXA` reads `FLUXA_X` …)
/// or three names separated by [`TRIPLE_SEPARATOR`] (`BX:BY:BZ` → `BX`, `BY`, `BZ`). Models
/// store `spec` as given, so a triple round-trips. A spec with separators but not three
/// non-empty names is refused by [`vector_spec_error`]; here it is read as a prefix.
///
/// ```
/// use tolles_io::schema::vector_columns;
/// assert_eq!(vector_columns("flux_a"), ["flux_a_x", "flux_a_y", "flux_a_z"]);
/// assert_eq!(vector_columns("BX:BY:BZ"), ["BX", "BY", "BZ"]);
/// ```
pub fn vector_columns(spec: &str) -> [String; 3] {
    let parts: Vec<&str> = spec.split(TRIPLE_SEPARATOR).map(str::trim).collect();
    match parts[..] {
        [x, y, z] if vector_spec_error(spec).is_none() => [x, y, z].map(String::from),
        _ => AXES.map(|axis| format!("{spec}{axis}")),
    }
}

/// Why `spec` names no fluxgate, if it does not: it is empty, or it holds a
/// [`TRIPLE_SEPARATOR`] but not exactly three non-empty names.
pub fn vector_spec_error(spec: &str) -> Option<&'static str> {
    if spec.trim().is_empty() {
        return Some("a fluxgate needs a column prefix or three columns X:Y:Z");
    }
    if !spec.contains(TRIPLE_SEPARATOR) {
        return None;
    }
    let parts: Vec<&str> = spec.split(TRIPLE_SEPARATOR).map(str::trim).collect();
    if parts.len() != 3 || parts.iter().any(|p| p.is_empty()) {
        return Some("three columns are named X:Y:Z, each non-empty");
    }
    None
}

/// Raw channel names that stand for tolles' own when a file does not have those: SGL's raw
/// export (MagNav.jl's `Flt1003_sample.xyz`) and ASEG-GDF2 survey files name their channels so. Names match whatever their
/// case; `n` is a magnetometer's number, `L` a fluxgate's letter.
///
/// | raw | tolles |
/// |---|---|
/// | `TIME` (s of day) | `tt` |
/// | `LINE` | `line` |
/// | `ROLL`, `PITCH`, `AZIMUTH` | `ins_roll`, `ins_pitch`, `ins_yaw` |
/// | `LAT`, `LONG`; `LATITUDE`, `LONGITUDE` | `lat`, `lon` |
/// | `NORTHING`, `EASTING` (projected, m) | `north_m`, `east_m` |
/// | `DIURNAL` | `diurnal` |
/// | `UNCOMPMAGn` | `mag_n_uc` |
/// | `COMPMAGn` | `mag_n_c` |
/// | `IGRFMAGn` | `mag_n_igrf`; the lowest `n` also `igrf` |
/// | `FLUXL_X`, `FLUXL_Y`, `FLUXL_Z`, `FLUXL_TOT` | `flux_l_x`, `flux_l_y`, `flux_l_z`, `flux_l_tot` |
pub const ALIASES: [(&str, &str); 12] = [
    ("TIME", TIME_COLUMN),
    ("LINE", LINE_COLUMN),
    ("ROLL", ROLL),
    ("PITCH", PITCH),
    ("AZIMUTH", YAW),
    ("LAT", LATITUDE),
    ("LONG", LONGITUDE),
    ("LATITUDE", LATITUDE),
    ("LONGITUDE", LONGITUDE),
    ("NORTHING", NORTH),
    ("EASTING", EAST),
    ("DIURNAL", DIURNAL),
];

/// The tolles names a raw channel `raw` stands for ([`ALIASES`] and its numbered patterns),
/// matched whatever its case.
///
/// ```
/// use tolles_io::schema::canonical_names;
/// assert_eq!(canonical_names("AZIMUTH"), ["ins_yaw"]);
/// assert_eq!(canonical_names("uncompmag3"), ["mag_3_uc"]);
/// assert_eq!(canonical_names("FLUXB_Y"), ["flux_b_y"]);
/// assert!(canonical_names("mag_1_uc").is_empty());
/// ```
pub fn canonical_names(raw: &str) -> Vec<String> {
    let upper = raw.trim().to_ascii_uppercase();
    if let Some((_, name)) = ALIASES.iter().find(|(r, _)| *r == upper) {
        return vec![name.to_string()];
    }
    let numbered = |prefix: &str| {
        upper
            .strip_prefix(prefix)
            .filter(|n| !n.is_empty() && n.bytes().all(|b| b.is_ascii_digit()))
            .map(|n| n.to_string())
    };
    if let Some(n) = numbered("UNCOMPMAG") {
        return vec![format!("mag_{n}_uc")];
    }
    if let Some(n) = numbered("COMPMAG") {
        return vec![format!("mag_{n}_c")];
    }
    if let Some(n) = numbered("IGRFMAG") {
        return vec![format!("mag_{n}_igrf")];
    }
    if let Some(rest) = upper.strip_prefix("FLUX") {
        let mut chars = rest.chars();
        if let (Some(letter @ 'A'..='Z'), Some('_')) = (chars.next(), chars.next()) {
            let axis = chars.as_str();
            if matches!(axis, "X" | "Y" | "Z" | "TOT") {
                let letter = letter.to_ascii_lowercase();
                return vec![format!("flux_{letter}_{}", axis.to_ascii_lowercase())];
            }
        }
    }
    Vec::new()
}

/// Datum and projection tokens survey files add to coordinate names (`GDA94LAT`,
/// `EAST_MGA`, `EASTMGA56`, `AMG84EAST`, `LAT_GDA94`); a zone number may follow.
const COORDINATE_TOKENS: [&str; 11] = [
    "GDA2020", "GDA94", "WGS84", "AGD66", "AGD84", "NAD83", "NAD27", "AMG84", "AMG", "MGA", "UTM",
];

/// The tolles name a survey file's own spelling of a channel stands for when neither the file
/// nor [`canonical_names`] gives it: a fiducial as time (s) when the file has no time, a
/// heading (`HEADING`, `HDG`, `YAW`; degrees clockwise from north) as the yaw when the file has
/// no `AZIMUTH` (a track heading differs from the aircraft's by its crab angle, a few degrees,
/// well inside the heading error's 10° tolerance), and coordinates under their datum or
/// projection (`GDA94LAT` latitude, `EAST_MGA` or `X` easting in m, …).
///
/// ```
/// use tolles_io::schema::fallback_name;
/// assert_eq!(fallback_name("FIDUCIAL"), Some("tt"));
/// assert_eq!(fallback_name("Heading"), Some("ins_yaw"));
/// assert_eq!(fallback_name("GDA94LAT"), Some("lat"));
/// assert_eq!(fallback_name("LONG_GDA94"), Some("lon"));
/// assert_eq!(fallback_name("EASTMGA56"), Some("east_m"));
/// assert_eq!(fallback_name("MGA_N"), Some("north_m"));
/// assert_eq!(fallback_name("Y"), Some("north_m"));
/// assert_eq!(fallback_name("E"), None); // a bare letter could be anything
/// ```
pub fn fallback_name(raw: &str) -> Option<&'static str> {
    let upper = raw.trim().to_ascii_uppercase();
    match upper.as_str() {
        "FIDUCIAL" | "FID" | "FIDU" => return Some(TIME_COLUMN),
        "HEADING" | "HDG" | "YAW" => return Some(YAW),
        "X" => return Some(EAST),
        "Y" => return Some(NORTH),
        _ => {}
    }
    let (core, projected) = without_coordinate_tokens(&upper);
    match core.as_str() {
        "LAT" | "LATITUDE" => Some(LATITUDE),
        "LON" | "LONG" | "LNG" | "LLG" | "LONGITUDE" => Some(LONGITUDE),
        "EAST" | "EASTING" | "X" => Some(EAST),
        "NORTH" | "NORTHING" | "Y" => Some(NORTH),
        "E" if projected => Some(EAST),
        "N" if projected => Some(NORTH),
        _ => None,
    }
}

/// `name` without its datum and projection tokens (each with the zone number after it) and
/// underscores, and whether it had any token.
fn without_coordinate_tokens(name: &str) -> (String, bool) {
    let mut rest = name.replace('_', "");
    let mut found = false;
    for token in COORDINATE_TOKENS {
        while let Some(at) = rest.find(token) {
            let end = at + token.len();
            let digits = rest[end..].bytes().take_while(u8::is_ascii_digit).count();
            rest.replace_range(at..end + digits, "");
            found = true;
        }
    }
    (rest, found)
}

/// The aliases a table with `headers` gets: `(tolles name, column index)` for every raw
/// channel (see [`canonical_names`]) whose tolles name no column has (as
/// [`crate::table::find_column`] finds names, also by case); each name once, from the first
/// raw channel that gives it. `igrf` also comes from the lowest-numbered `IGRFMAGn`.
pub fn aliases(headers: &[String]) -> Vec<(String, usize)> {
    let present =
        |name: &str| crate::header::find_column(std::path::Path::new(""), headers, name).is_ok();
    let mut out: Vec<(String, usize)> = Vec::new();
    let mut igrf: Option<(u64, usize)> = None;
    for (k, header) in headers.iter().enumerate() {
        for name in canonical_names(header) {
            if let Some(n) = name
                .strip_prefix("mag_")
                .and_then(|r| r.strip_suffix("_igrf"))
                .and_then(|n| n.parse::<u64>().ok())
            {
                if igrf.is_none_or(|(m, _)| n < m) {
                    igrf = Some((n, k));
                }
            }
            if !present(&name) && !out.iter().any(|(o, _)| *o == name) {
                out.push((name, k));
            }
        }
    }
    if let Some((_, k)) = igrf.filter(|_| !present(IGRF)) {
        out.push((IGRF.to_string(), k));
    }
    // A survey's own spellings, for what neither the file nor the names above give.
    for (k, header) in headers.iter().enumerate() {
        if let Some(name) = fallback_name(header) {
            if !present(name) && !out.iter().any(|(o, _)| o == name) {
                out.push((name.to_string(), k));
            }
        }
    }
    out
}

/// Seconds in one `unit` of a time column, for the units survey files declare (ASEG-GDF2
/// `UNITS=`, an HDF5 `units` attribute): seconds, milliseconds, microseconds, minutes, hours and
/// days, in their usual spellings and any case; `None` for any other unit.
///
/// ```
/// use tolles_io::schema::seconds_per;
/// assert_eq!(seconds_per("hours"), Some(3600.0));
/// assert_eq!(seconds_per("MSEC"), Some(1e-3));
/// assert_eq!(seconds_per("s"), Some(1.0));
/// assert_eq!(seconds_per("furlongs"), None);
/// ```
pub fn seconds_per(unit: &str) -> Option<f64> {
    let unit = unit.trim().trim_end_matches('.').to_ascii_lowercase();
    let seconds = match unit.as_str() {
        "s" | "sec" | "secs" | "second" | "seconds" => 1.0,
        "ms" | "msec" | "msecs" | "millisecond" | "milliseconds" => 1e-3,
        "us" | "µs" | "usec" | "microsecond" | "microseconds" => 1e-6,
        "min" | "mins" | "minute" | "minutes" => 60.0,
        "h" | "hr" | "hrs" | "hour" | "hours" => 3600.0,
        "d" | "day" | "days" => 86_400.0,
        _ => return None,
    };
    Some(seconds)
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
        |name: &str| crate::header::find_column(std::path::Path::new(""), headers, name).is_ok();
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

/// The columns written beside a compensated column `name` by `--uncertainty`: its standard
/// error `name_sigma` (nT) and its extrapolation flag `name_extrapolated` (1 or 0).
pub fn trust_columns(name: &str) -> [String; 2] {
    [format!("{name}_sigma"), format!("{name}_extrapolated")]
}

/// The column `stream` adds after the compensated ones: each line's status (`ok`, or why not).
pub const STATUS_COLUMN: &str = "status";

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

    #[test]
    fn channel_units_come_from_known_names_and_families() {
        assert_eq!(channel_unit("cur_strb"), Some("A"));
        assert_eq!(channel_unit("CUR_FLAP"), Some("A"));
        assert_eq!(channel_unit("cur_load"), Some("A"));
        assert_eq!(channel_unit("vol_bat_1"), Some("V"));
        assert_eq!(channel_unit("pos_flap"), Some("°"));
        assert_eq!(channel_unit("temp"), Some("°C"));
        assert_eq!(channel_unit("ins_roll"), Some("°"));
        assert_eq!(channel_unit("current"), None);
        assert_eq!(channel_unit("mystery"), None);
    }

    use super::*;

    fn strings(names: &[&str]) -> Vec<String> {
        names.iter().map(|s| s.to_string()).collect()
    }

    #[test]
    fn sgl_raw_names_alias_tolles_names_only_when_those_are_absent() {
        let headers = strings(&[
            "TIME", "ROLL", "AZIMUTH", "IGRFMAG2", "IGRFMAG1", "FLUXA_X", "ins_roll", "LAT",
            "LATITUDE",
        ]);
        let got = aliases(&headers);
        let names: Vec<(&str, usize)> = got.iter().map(|(n, k)| (n.as_str(), *k)).collect();
        assert_eq!(
            names,
            [
                ("tt", 0),
                ("ins_yaw", 2),
                ("mag_2_igrf", 3),
                ("mag_1_igrf", 4),
                ("flux_a_x", 5),
                ("igrf", 4)
            ]
        );
        // LAT is found as `lat` by case already; no alias is needed, not even for LATITUDE.
        assert!(canonical_names("FLUXA_W").is_empty());
        assert!(canonical_names("COMPMAG").is_empty());
    }

    #[test]
    fn a_triple_names_three_columns_and_bad_ones_are_refused() {
        assert_eq!(vector_columns(" a : b :c"), ["a", "b", "c"]);
        assert!(vector_spec_error("a:b").is_some());
        assert!(vector_spec_error("a::c").is_some());
        assert!(vector_spec_error("").is_some());
        assert!(vector_spec_error("flux_a").is_none());
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
