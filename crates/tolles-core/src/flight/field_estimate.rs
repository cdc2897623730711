//! The earth field a flight flew in, estimated from its own sensors when no model of the field
//! is at hand: dip and intensity from the fluxgate in level flight, intensity from the scalar.
//!
//! ```
//! use tolles_core::flight::field_estimate::level_field;
//! use tolles_core::model::vector::VectorSeries;
//!
//! // Level flight north at dip 60°, intensity 50 000 nT (FRD: x north, z down).
//! let (h, dip) = (50_000.0, 60f64.to_radians());
//! let flux = VectorSeries::new(vec![h * dip.cos(); 3], vec![0.0; 3], vec![h * dip.sin(); 3]);
//! let field = level_field(&flux, &[0.0; 3], &[0.0; 3]);
//! assert!((field.dip_deg - 60.0).abs() < 1e-9 && (field.intensity_nt - h).abs() < 1e-9);
//! ```

use crate::model::vector::VectorSeries;

/// Samples count as level when both roll and pitch are within this (degrees).
pub const LEVEL_DEG: f64 = 2.0;

/// The earth field as a fluxgate saw it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LevelField {
    /// Dip (inclination) of the field below the horizontal (degrees, down positive).
    pub dip_deg: f64,
    /// Field magnitude (nT).
    pub intensity_nt: f64,
}

/// The mean dip (degrees) and intensity (nT) of the fluxgate `flux` (nT, body frame FRD) over
/// the samples flown level, roll and pitch within [`LEVEL_DEG`] (degrees); over every sample
/// when none is level. Level, the body z axis is down, so the dip is `asin(Bz / |B|)`.
pub fn level_field(flux: &VectorSeries, roll_deg: &[f64], pitch_deg: &[f64]) -> LevelField {
    let level: Vec<usize> = (0..flux.len())
        .filter(|&k| roll_deg[k].abs() < LEVEL_DEG && pitch_deg[k].abs() < LEVEL_DEG)
        .collect();
    let chosen: Vec<usize> = if level.is_empty() {
        (0..flux.len()).collect()
    } else {
        level
    };
    let n = chosen.len().max(1) as f64;
    let intensity_nt = chosen.iter().map(|&k| flux.magnitude(k)).sum::<f64>() / n;
    let dip_rad = chosen
        .iter()
        .map(|&k| (flux.z[k] / flux.magnitude(k)).asin())
        .sum::<f64>()
        / n;
    LevelField {
        dip_deg: dip_rad.to_degrees(),
        intensity_nt,
    }
}

/// The field magnitude (nT) a scalar magnetometer `scalar` (nT) reads: the median of its
/// finite values (the upper one of an even count), `None` when it has none. The aircraft's
/// own field is small beside the earth's, so this is the earth field to a few parts in 10⁴.
pub fn scalar_intensity(scalar: &[f64]) -> Option<f64> {
    let mut v: Vec<f64> = scalar.iter().copied().filter(|v| v.is_finite()).collect();
    if v.is_empty() {
        return None;
    }
    v.sort_by(f64::total_cmp);
    Some(v[v.len() / 2])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn only_level_samples_count_when_there_are_any() {
        // A level sample at dip 90° and a banked one pointing the field along x.
        let flux = VectorSeries::new(vec![0.0, 50_000.0], vec![0.0; 2], vec![40_000.0, 0.0]);
        let field = level_field(&flux, &[0.0, 30.0], &[0.0, 0.0]);
        assert_eq!(field.dip_deg, 90.0);
        assert_eq!(field.intensity_nt, 40_000.0);
        let all = level_field(&flux, &[30.0, 30.0], &[0.0, 0.0]);
        assert!((all.dip_deg - 45.0).abs() < 1e-12);
        assert_eq!(all.intensity_nt, 45_000.0);
    }

    #[test]
    fn the_scalar_intensity_is_the_median_of_finite_values() {
        assert_eq!(scalar_intensity(&[3.0, f64::NAN, 1.0, 2.0]), Some(2.0));
        assert_eq!(scalar_intensity(&[4.0, 1.0, 3.0, 2.0]), Some(3.0));
        assert_eq!(scalar_intensity(&[f64::NAN]), None);
    }
}
