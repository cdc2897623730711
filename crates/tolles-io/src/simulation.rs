//! The columns of a simulated flight (the layout `tolles fit` reads), and writing named columns
//! in the format a file's extension names. The simulation itself and its JSON sidecar are the
//! facade's (`tolles::simulate`).

use crate::error::IoError;
use crate::format::Format;
use crate::schema;
use crate::table::write_columns_to;
use std::path::Path;

/// The scalar column of a simulated flight (SGL's name for an uncompensated magnetometer).
pub const SCALAR: &str = "mag_1_uc";
/// The fluxgate prefix of a simulated flight.
pub const VECTOR: &str = "flux_a";

/// Every column a simulated flight can have, with its meaning.
pub const COLUMNS: [(&str, &str); 18] = [
    (schema::TIME_COLUMN, "time (s)"),
    (schema::LINE_COLUMN, "line id of the flight segment"),
    ("lat", "latitude (degrees), when the main field is IGRF"),
    (
        "lon",
        "longitude (degrees, east positive), when the main field is IGRF",
    ),
    ("north_m", "distance north of the start (m)"),
    ("east_m", "distance east of the start (m)"),
    (schema::ROLL, "roll, right wing down positive (degrees)"),
    (schema::PITCH, "pitch, nose up positive (degrees)"),
    (schema::YAW, "yaw, clockwise from true north (degrees)"),
    ("mag_1_uc", "scalar magnetometer, uncompensated (nT)"),
    ("flux_a_x", "fluxgate, forward (nT)"),
    ("flux_a_y", "fluxgate, right (nT)"),
    ("flux_a_z", "fluxgate, down (nT)"),
    (
        "cur_1",
        "current of the current source (A), when there is one",
    ),
    (
        "truth_earth",
        "truth: earth field magnitude without the aircraft (nT)",
    ),
    (
        "truth_aircraft",
        "truth: the aircraft's contribution to the scalar, |B+H|-|B| (nT)",
    ),
    ("truth_anomaly", "truth: geology's total-field anomaly (nT)"),
    ("truth_diurnal", "truth: diurnal variation (nT)"),
];

/// The columns a simulated flight adds after [`COLUMNS`] when it has a reference magnetometer
/// or cabin effects (each only when it has it), with their meanings.
pub const EFFECT_COLUMNS: [(&str, &str); 5] = [
    (
        schema::REFERENCE_MAGNETOMETER,
        "reference magnetometer free of the aircraft's field: earth field plus its own noise (nT)",
    ),
    (
        schema::LOAD_CURRENT,
        "current of the saturating load (A), when the flight has it",
    ),
    (
        schema::FLAP_ANGLE,
        "control-surface angle, trailing edge down positive (degrees), when the flight has it",
    ),
    (
        schema::TEMPERATURE,
        "temperature of the magnetised structure (degrees C), when the flight has it",
    ),
    (
        schema::TRUTH_EFFECTS,
        "truth: what the cabin effects add to the scalar (nT), when the flight has any",
    ),
];

/// Writes named numeric `columns` of equal length in the format `path`'s extension names (CSV,
/// HDF5 or Parquet; any other extension is an error, see [`Format::for_output`]), whole or not
/// at all.
pub fn write_named_columns(path: &Path, columns: &[(&str, &[f64])]) -> Result<(), IoError> {
    match Format::for_output(path)? {
        Format::Csv => write_columns_to(path, columns),
        format => {
            let owned: Vec<(String, Vec<f64>)> = columns
                .iter()
                .map(|(name, values)| (name.to_string(), values.to_vec()))
                .collect();
            match format {
                Format::Parquet => crate::parquet::write(path, &owned),
                _ => crate::hdf5::write(path, &owned),
            }
        }
    }
}
