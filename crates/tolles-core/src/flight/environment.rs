//! The earth's field along a flight: the main field, geology and diurnal variation.
//!
//! ```
//! use tolles_core::flight::environment::{Environment, Location};
//! let env = Environment::at(Location::default());
//! let b = env.field_ned(0.0, 0.0, 0.0).unwrap(); // nT, at the start point
//! let f = (b[0] * b[0] + b[1] * b[1] + b[2] * b[2]).sqrt();
//! assert!(f > 40_000.0 && f < 60_000.0);
//! ```
//!
//! Positions are offsets north and east of the start point (metres, a flat-earth approximation
//! good over a survey block); times are seconds from the start. Geology and diurnal variation are
//! total-field effects: they are added along the direction of the main field.

use crate::flight::igrf::{self, IgrfError};
use serde::{Deserialize, Serialize};

/// Mean earth radius for the flat-earth offsets (m).
const EARTH_RADIUS_M: f64 = 6_371_000.0;

/// A uniform earth field.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct EarthField {
    /// Total intensity (nT).
    pub intensity_nt: f64,
    /// Inclination (dip), positive down (degrees).
    pub inclination_deg: f64,
    /// Declination, clockwise from true north (degrees).
    pub declination_deg: f64,
}

impl Default for EarthField {
    /// A mid-latitude northern field: 52 000 nT, dip 68°, declination −3°.
    fn default() -> Self {
        Self {
            intensity_nt: 52_000.0,
            inclination_deg: 68.0,
            declination_deg: -3.0,
        }
    }
}

impl EarthField {
    /// The field in NED (nT).
    pub fn ned(&self) -> [f64; 3] {
        let (si, ci) = self.inclination_deg.to_radians().sin_cos();
        let (sd, cd) = self.declination_deg.to_radians().sin_cos();
        let f = self.intensity_nt;
        [f * ci * cd, f * ci * sd, f * si]
    }
}

/// Where and when the flight starts.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Location {
    /// Geodetic latitude (degrees).
    pub lat_deg: f64,
    /// Longitude, east positive (degrees).
    pub lon_deg: f64,
    /// Altitude above the WGS84 ellipsoid (m).
    pub alt_m: f64,
    /// Date as a decimal year.
    pub year: f64,
}

impl Default for Location {
    /// Near Ottawa, 3000 m, mid-2025 (dip about 69°).
    fn default() -> Self {
        Self {
            lat_deg: 45.4,
            lon_deg: -75.7,
            alt_m: 3_000.0,
            year: 2025.5,
        }
    }
}

impl Location {
    /// Latitude and longitude (degrees) of a point `north_m`, `east_m` from here.
    pub fn offset(&self, north_m: f64, east_m: f64) -> (f64, f64) {
        let lat = self.lat_deg + (north_m / EARTH_RADIUS_M).to_degrees();
        let lon = self.lon_deg
            + (east_m / (EARTH_RADIUS_M * self.lat_deg.to_radians().cos())).to_degrees();
        (lat, lon)
    }
}

/// Where the main field comes from.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum MainField {
    /// A uniform field given by intensity, inclination and declination.
    Uniform(EarthField),
    /// IGRF-14 along the track.
    Igrf(Location),
}

/// A smooth anomaly field from buried sources: a sum of Gaussian bumps.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Geology {
    /// The sources: north and east position (m), amplitude (nT), width (m).
    pub sources: Vec<[f64; 4]>,
}

impl Geology {
    /// `count` sources within `extent_m` of the start, amplitudes up to `amplitude_nt`, widths
    /// 300–2000 m, from `seed`.
    pub fn random(count: usize, amplitude_nt: f64, extent_m: f64, seed: u64) -> Self {
        let mut u = crate::flight::plan::SplitMix::new(seed ^ 0x6E0);
        let sources = (0..count)
            .map(|_| {
                [
                    extent_m * (2.0 * u.uniform() - 1.0),
                    extent_m * (2.0 * u.uniform() - 1.0),
                    amplitude_nt * (2.0 * u.uniform() - 1.0),
                    300.0 + 1700.0 * u.uniform(),
                ]
            })
            .collect();
        Self { sources }
    }

    /// Total-field anomaly (nT) at `north_m`, `east_m`.
    pub fn anomaly_nt(&self, north_m: f64, east_m: f64) -> f64 {
        self.sources
            .iter()
            .map(|[n, e, a, w]| {
                let r2 = (north_m - n).powi(2) + (east_m - e).powi(2);
                a * (-r2 / (2.0 * w * w)).exp()
            })
            .sum()
    }
}

/// Diurnal variation: a slow sinusoid (nT, s).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Diurnal {
    /// Amplitude (nT).
    pub amplitude_nt: f64,
    /// Period (s); a solar day is 86 400 s, storms and pulsations are faster.
    pub period_s: f64,
    /// Phase at t = 0 (rad).
    pub phase_rad: f64,
}

impl Diurnal {
    /// Variation (nT) at time `t` (s).
    pub fn at(&self, t: f64) -> f64 {
        self.amplitude_nt * (2.0 * std::f64::consts::PI * t / self.period_s + self.phase_rad).sin()
    }
}

/// Everything outside the aircraft.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Environment {
    /// The main field.
    pub main: MainField,
    /// Geology, if any.
    pub geology: Option<Geology>,
    /// Diurnal variation, if any.
    pub diurnal: Option<Diurnal>,
}

impl Environment {
    /// IGRF at `location`, no geology, no diurnal variation.
    pub fn at(location: Location) -> Self {
        Self {
            main: MainField::Igrf(location),
            geology: None,
            diurnal: None,
        }
    }

    /// A uniform main field, no geology, no diurnal variation.
    pub fn uniform(earth: EarthField) -> Self {
        Self {
            main: MainField::Uniform(earth),
            geology: None,
            diurnal: None,
        }
    }

    /// The main field (nT, NED) at an offset from the start (m).
    pub fn main_ned(&self, north_m: f64, east_m: f64) -> Result<[f64; 3], IgrfError> {
        match self.main {
            MainField::Uniform(earth) => Ok(earth.ned()),
            MainField::Igrf(location) => {
                let (lat, lon) = location.offset(north_m, east_m);
                let b = igrf::field(lat, lon, location.alt_m, location.year)?;
                Ok([b.x, b.y, b.z])
            }
        }
    }

    /// Geology (nT) at an offset from the start (m).
    pub fn anomaly_nt(&self, north_m: f64, east_m: f64) -> f64 {
        self.geology
            .as_ref()
            .map_or(0.0, |g| g.anomaly_nt(north_m, east_m))
    }

    /// Diurnal variation (nT) at time `t` (s).
    pub fn diurnal_nt(&self, t: f64) -> f64 {
        self.diurnal.map_or(0.0, |d| d.at(t))
    }

    /// The whole earth field (nT, NED) at an offset (m) and time (s).
    pub fn field_ned(&self, north_m: f64, east_m: f64, t: f64) -> Result<[f64; 3], IgrfError> {
        let main = self.main_ned(north_m, east_m)?;
        let extra = self.anomaly_nt(north_m, east_m) + self.diurnal_nt(t);
        let norm = (main[0] * main[0] + main[1] * main[1] + main[2] * main[2]).sqrt();
        Ok(main.map(|c| c + extra * c / norm))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn geology_is_smooth_and_local() {
        let g = Geology {
            sources: vec![[0.0, 0.0, 10.0, 500.0]],
        };
        assert_eq!(g.anomaly_nt(0.0, 0.0), 10.0);
        assert!((g.anomaly_nt(500.0, 0.0) - 10.0 * (-0.5f64).exp()).abs() < 1e-12);
        assert!(g.anomaly_nt(10_000.0, 0.0).abs() < 1e-9);
    }

    #[test]
    fn extra_fields_add_to_the_total_intensity() {
        let mut env = Environment::uniform(EarthField::default());
        env.diurnal = Some(Diurnal {
            amplitude_nt: 5.0,
            period_s: 400.0,
            phase_rad: 0.0,
        });
        let b = env.field_ned(0.0, 0.0, 100.0).unwrap();
        let f = (b[0] * b[0] + b[1] * b[1] + b[2] * b[2]).sqrt();
        assert!((f - 52_005.0).abs() < 1e-9);
    }

    #[test]
    fn igrf_changes_slowly_along_a_survey() {
        let env = Environment::at(Location::default());
        let f = |n: f64| {
            let b = env.main_ned(n, 0.0).unwrap();
            (b[0] * b[0] + b[1] * b[1] + b[2] * b[2]).sqrt()
        };
        let gradient = (f(10_000.0) - f(0.0)) / 10.0; // nT per km
        assert!(gradient.abs() > 0.1 && gradient.abs() < 10.0, "{gradient}");
    }
}
