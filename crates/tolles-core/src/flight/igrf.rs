//! IGRF-14, the International Geomagnetic Reference Field (14th generation), main field.
//!
//! ```
//! use tolles_core::flight::igrf::{decimal_year, field};
//!
//! // London, at sea level, on 1 July 2025.
//! let b = field(51.5, -0.1, 0.0, decimal_year(2025, 7, 1).unwrap()).unwrap();
//! assert!((b.f - 49_080.0).abs() < 50.0); // total intensity, nT
//! assert!(b.inclination > 60.0 && b.declination.abs() < 3.0); // degrees
//! ```
//!
//! # Model
//! The field is the gradient of a degree-13 spherical-harmonic potential whose Schmidt
//! semi-normalised Gauss coefficients (nT) are given every 5 years from 1900.0 to 2025.0, plus a
//! secular variation (nT/yr) valid from 2025.0 to 2030.0. Between epochs the coefficients are
//! interpolated linearly in decimal years; after 2025.0 they are extrapolated with the secular
//! variation. Dates outside 1900.0..=2030.0 are refused.
//!
//! The coefficients are the official IGRF-14 table (`data/igrf14coeffs.txt`, IAGA Working Group
//! V-MOD, 2024), embedded at compile time and parsed once.
//!
//! # Units and frames
//! - Inputs: geodetic latitude and longitude in degrees (WGS84), altitude in metres above the
//!   WGS84 ellipsoid, date as a decimal year (see [`decimal_year`]).
//! - Outputs: nanotesla (nT) in the local geodetic north-east-down frame, angles in degrees
//!   (inclination positive down, declination clockwise/east from true north), as in
//!   [`crate::model::conventions`].
//!
//! # Poles
//! No small offset is used. The east component needs `P_n^m(cos θ) / sin θ`, which is
//! computed by its own recursion (the same three-term recursion as `P_n^m`, started from
//! `P_m^m / sin θ`), so nothing is divided by `sin θ` and the result is finite at θ = 0 and π.
//! At a geographic pole, north and east are the limits along the meridian of the given
//! longitude, so X, Y and the declination depend on that longitude there, while Z, H, F and
//! the inclination do not.

use serde::{Deserialize, Serialize};
use std::f64::consts::FRAC_PI_2;
use std::sync::OnceLock;
use thiserror::Error;

/// First date covered by IGRF-14 (decimal year).
pub const FIRST_YEAR: f64 = 1900.0;
/// Last date covered by IGRF-14 (decimal year): the end of the 2025–2030 secular variation.
pub const LAST_YEAR: f64 = 2030.0;
/// Highest spherical-harmonic degree of the model.
pub const MAX_DEGREE: usize = 13;
/// Reference radius of the spherical-harmonic expansion, metres (6371.2 km).
pub const REFERENCE_RADIUS_M: f64 = 6_371_200.0;

/// WGS84 semi-major axis, metres.
const WGS84_A_M: f64 = 6_378_137.0;
/// WGS84 flattening.
const WGS84_F: f64 = 1.0 / 298.257_223_563;

/// The official coefficient table, kept verbatim with its header.
const COEFFICIENT_TABLE: &str = include_str!("../../data/igrf14coeffs.txt");

/// Why a field could not be computed.
#[derive(Debug, Clone, Copy, PartialEq, Error)]
pub enum IgrfError {
    /// The date (decimal year) lies outside 1900.0..=2030.0, or is not a number.
    #[error("date {0} is outside the IGRF-14 validity 1900.0..=2030.0 (decimal years)")]
    DateOutOfRange(f64),
    /// The latitude (degrees) lies outside -90..=90, or is not a number.
    #[error("latitude {0} degrees is outside -90..=90")]
    InvalidLatitude(f64),
    /// The longitude (degrees) is infinite or not a number.
    #[error("longitude {0} degrees is not finite")]
    InvalidLongitude(f64),
    /// The altitude or radius (metres) is not finite, or puts the point at the earth's centre.
    #[error("altitude or radius {0} m is not finite or reaches the earth's centre")]
    InvalidAltitude(f64),
    /// The calendar date does not exist.
    #[error("{year}-{month:02}-{day:02} is not a calendar date")]
    InvalidDate {
        /// The year given.
        year: i32,
        /// The month given (1–12 if valid).
        month: u32,
        /// The day of the month given (1-based).
        day: u32,
    },
}

/// The geomagnetic field at one point, in the local geodetic north-east-down frame.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct MagneticField {
    /// North component X, nT (along the meridian, tangent to the ellipsoid).
    pub x: f64,
    /// East component Y, nT.
    pub y: f64,
    /// Down component Z, nT (along the ellipsoid normal, positive down).
    pub z: f64,
    /// Total intensity F = |(X, Y, Z)|, nT.
    pub f: f64,
    /// Horizontal intensity H = |(X, Y)|, nT.
    pub h: f64,
    /// Inclination (dip), degrees, positive when the field points down.
    pub inclination: f64,
    /// Declination, degrees, clockwise (east) from true north, in -180..=180.
    pub declination: f64,
}

impl MagneticField {
    /// Builds the derived quantities from north, east and down components (nT).
    ///
    /// ```
    /// use tolles_core::flight::igrf::MagneticField;
    ///
    /// let b = MagneticField::from_ned(3.0, 0.0, 4.0);
    /// assert_eq!(b.f, 5.0); // nT
    /// assert!((b.inclination - 53.130_102).abs() < 1e-6); // degrees
    /// ```
    pub fn from_ned(x: f64, y: f64, z: f64) -> Self {
        let h = x.hypot(y);
        Self {
            x,
            y,
            z,
            f: h.hypot(z),
            h,
            inclination: z.atan2(h).to_degrees(),
            declination: y.atan2(x).to_degrees(),
        }
    }
}

/// Field components in the geocentric spherical frame (nT): `north = -B_θ`, `east = B_φ`,
/// `down = -B_r`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct GeocentricField {
    /// Geocentric north component, nT (toward decreasing colatitude).
    pub north: f64,
    /// East component, nT.
    pub east: f64,
    /// Geocentric down component, nT (toward the earth's centre).
    pub down: f64,
}

/// IGRF-14 field at a geodetic position and date.
///
/// `lat_deg` is the geodetic latitude in degrees (-90..=90), `lon_deg` the longitude in degrees
/// east (any finite value), `alt_m` the altitude in metres above the WGS84 ellipsoid and
/// `year` a decimal year in 1900.0..=2030.0. Components are in nT, angles in degrees. The result
/// is finite at the poles (see the module documentation for what X, Y and D mean there).
///
/// # Errors
/// [`IgrfError`] for a date outside 1900.0..=2030.0, a latitude outside -90..=90, or a
/// non-finite longitude or altitude.
///
/// ```
/// use tolles_core::flight::igrf::field;
///
/// let pole = field(90.0, 0.0, 0.0, 2020.0).unwrap();
/// assert!(pole.z > 50_000.0 && pole.y.is_finite()); // nT
/// assert!(field(45.0, 0.0, 0.0, 1899.0).is_err());
/// ```
pub fn field(
    lat_deg: f64,
    lon_deg: f64,
    alt_m: f64,
    year: f64,
) -> Result<MagneticField, IgrfError> {
    check_latitude(lat_deg)?;
    check_longitude(lon_deg)?;
    if !alt_m.is_finite() {
        return Err(IgrfError::InvalidAltitude(alt_m));
    }
    let gauss = coefficients_at(year)?;
    let point = geodetic_to_geocentric(lat_deg.to_radians(), alt_m);
    if point.radius_m <= 0.0 {
        return Err(IgrfError::InvalidAltitude(alt_m));
    }
    // Colatitude straight from radians: a round trip through degrees could step past the pole.
    let legendre = Legendre::new(FRAC_PI_2 - point.lat_rad);
    let gc = synthesise(&gauss, &legendre, lon_deg.to_radians(), point.radius_m);
    // Tilt the geocentric north/down pair onto the ellipsoid's tangent plane and normal.
    let delta = lat_deg.to_radians() - point.lat_rad;
    let (sd, cd) = delta.sin_cos();
    let x = gc.north * cd + gc.down * sd;
    let z = gc.down * cd - gc.north * sd;
    Ok(MagneticField::from_ned(x, gc.east, z))
}

/// IGRF-14 field at a geocentric spherical position and date.
///
/// `colat_deg` is the geocentric colatitude in degrees (0..=180), `lon_deg` the longitude in
/// degrees east, `radius_m` the distance from the earth's centre in metres and `year` a
/// decimal year in 1900.0..=2030.0. Components are in nT. A colatitude outside 0..=180 is
/// reported as [`IgrfError::InvalidLatitude`] of `90 − colat_deg`.
///
/// ```
/// use tolles_core::flight::igrf::geocentric_field;
///
/// // On the equator at 6371.2 km radius the dipole term alone is about 29 400 nT north.
/// let b = geocentric_field(90.0, 0.0, 6_371_200.0, 2025.0).unwrap();
/// assert!(b.north > 25_000.0);
/// ```
pub fn geocentric_field(
    colat_deg: f64,
    lon_deg: f64,
    radius_m: f64,
    year: f64,
) -> Result<GeocentricField, IgrfError> {
    check_latitude(90.0 - colat_deg)?;
    check_longitude(lon_deg)?;
    if !(radius_m.is_finite() && radius_m > 0.0) {
        return Err(IgrfError::InvalidAltitude(radius_m));
    }
    let gauss = coefficients_at(year)?;
    let legendre = Legendre::new(colat_deg.to_radians());
    Ok(synthesise(
        &gauss,
        &legendre,
        lon_deg.to_radians(),
        radius_m,
    ))
}

/// Decimal year of the start (00:00) of a calendar day: 2025-01-01 is 2025.0 and each day adds
/// `1/365` (`1/366` in a leap year).
///
/// ```
/// use tolles_core::flight::igrf::decimal_year;
///
/// assert_eq!(decimal_year(2025, 1, 1), Ok(2025.0));
/// assert_eq!(decimal_year(2024, 12, 31), Ok(2024.0 + 365.0 / 366.0));
/// assert!(decimal_year(2025, 2, 29).is_err());
/// ```
///
/// # Errors
/// [`IgrfError::InvalidDate`] if `month` is not in 1..=12 or `day` is not a day of that month.
pub fn decimal_year(year: i32, month: u32, day: u32) -> Result<f64, IgrfError> {
    let invalid = IgrfError::InvalidDate { year, month, day };
    if !(1..=12).contains(&month) {
        return Err(invalid);
    }
    let lengths = month_lengths(year);
    if !(1..=lengths[month as usize - 1]).contains(&day) {
        return Err(invalid);
    }
    let before: u32 = lengths[..month as usize - 1].iter().sum();
    let year_len: u32 = lengths.iter().sum();
    Ok(f64::from(year) + f64::from(before + day - 1) / f64::from(year_len))
}

fn month_lengths(year: i32) -> [u32; 12] {
    let leap = (year % 4 == 0 && year % 100 != 0) || year % 400 == 0;
    let feb = if leap { 29 } else { 28 };
    [31, feb, 31, 30, 31, 30, 31, 31, 30, 31, 30, 31]
}

fn check_latitude(lat_deg: f64) -> Result<(), IgrfError> {
    // `contains` is false for NaN, so NaN is refused too.
    if (-90.0..=90.0).contains(&lat_deg) {
        Ok(())
    } else {
        Err(IgrfError::InvalidLatitude(lat_deg))
    }
}

fn check_longitude(lon_deg: f64) -> Result<(), IgrfError> {
    if lon_deg.is_finite() {
        Ok(())
    } else {
        Err(IgrfError::InvalidLongitude(lon_deg))
    }
}

/// A point in geocentric spherical coordinates.
struct GeocentricPoint {
    lat_rad: f64,
    radius_m: f64,
}

/// Converts geodetic latitude (radians) and ellipsoidal height (m) to geocentric latitude and
/// radius, through the cylindrical coordinates of the point on the WGS84 ellipsoid's normal.
fn geodetic_to_geocentric(lat_rad: f64, alt_m: f64) -> GeocentricPoint {
    let e2 = WGS84_F * (2.0 - WGS84_F);
    let (s, c) = lat_rad.sin_cos();
    let prime_vertical = WGS84_A_M / (1.0 - e2 * s * s).sqrt();
    let rho = (prime_vertical + alt_m) * c;
    let z = (prime_vertical * (1.0 - e2) + alt_m) * s;
    GeocentricPoint {
        lat_rad: z.atan2(rho),
        radius_m: rho.hypot(z),
    }
}

/// Gauss coefficients g_n^m, h_n^m (nT) for one date, indexed `[n][m]`.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Gauss {
    g: [[f64; MAX_DEGREE + 1]; MAX_DEGREE + 1],
    h: [[f64; MAX_DEGREE + 1]; MAX_DEGREE + 1],
}

impl Gauss {
    const ZERO: Self = Self {
        g: [[0.0; MAX_DEGREE + 1]; MAX_DEGREE + 1],
        h: [[0.0; MAX_DEGREE + 1]; MAX_DEGREE + 1],
    };

    /// `self + t · (other - self)`, coefficient by coefficient.
    fn lerp(&self, other: &Self, t: f64) -> Self {
        let mut out = *self;
        for n in 1..=MAX_DEGREE {
            for m in 0..=n {
                out.g[n][m] += t * (other.g[n][m] - self.g[n][m]);
                out.h[n][m] += t * (other.h[n][m] - self.h[n][m]);
            }
        }
        out
    }

    /// `self + t · rate`, for extrapolation with the secular variation.
    fn advance(&self, rate: &Self, t: f64) -> Self {
        let mut out = *self;
        for n in 1..=MAX_DEGREE {
            for m in 0..=n {
                out.g[n][m] += t * rate.g[n][m];
                out.h[n][m] += t * rate.h[n][m];
            }
        }
        out
    }
}

/// The whole model: coefficients at each epoch and the secular variation after the last one.
struct Model {
    epochs: Vec<f64>,
    main: Vec<Gauss>,
    secular: Gauss,
}

fn model() -> &'static Model {
    static MODEL: OnceLock<Model> = OnceLock::new();
    MODEL.get_or_init(|| parse_table(COEFFICIENT_TABLE))
}

/// Parses the official table: a `g/h n m <epochs…> <SV range>` header, then one
/// `g|h n m <values…> <SV>` row per coefficient. The table is compiled in, so a malformed one
/// is a build defect and panics (a unit test parses it).
fn parse_table(text: &str) -> Model {
    let header = text
        .lines()
        .find(|l| l.starts_with("g/h"))
        .expect("IGRF table has a g/h header line");
    let epochs: Vec<f64> = header
        .split_whitespace()
        .skip(3)
        .filter_map(|t| t.parse().ok())
        .collect();
    let mut main = vec![Gauss::ZERO; epochs.len()];
    let mut secular = Gauss::ZERO;
    for line in text
        .lines()
        .filter(|l| l.starts_with("g ") || l.starts_with("h "))
    {
        let fields: Vec<&str> = line.split_whitespace().collect();
        let n: usize = fields[1].parse().expect("degree is an integer");
        let m: usize = fields[2].parse().expect("order is an integer");
        let values: Vec<f64> = fields[3..]
            .iter()
            .map(|t| t.parse().expect("coefficient is a number"))
            .collect();
        assert_eq!(
            values.len(),
            epochs.len() + 1,
            "row {line:?} has one value per epoch + SV"
        );
        let is_g = fields[0] == "g";
        for (gauss, &v) in main
            .iter_mut()
            .chain(std::iter::once(&mut secular))
            .zip(&values)
        {
            let slot = if is_g { &mut gauss.g } else { &mut gauss.h };
            slot[n][m] = v;
        }
    }
    Model {
        epochs,
        main,
        secular,
    }
}

/// Coefficients at a decimal year: linear between epochs, secular variation after the last.
fn coefficients_at(year: f64) -> Result<Gauss, IgrfError> {
    if !(FIRST_YEAR..=LAST_YEAR).contains(&year) {
        return Err(IgrfError::DateOutOfRange(year));
    }
    let m = model();
    let last = m.epochs.len() - 1;
    if year >= m.epochs[last] {
        return Ok(m.main[last].advance(&m.secular, year - m.epochs[last]));
    }
    // Index of the epoch at or before `year`; epochs are sorted and start at FIRST_YEAR.
    let i = m.epochs.partition_point(|&e| e <= year) - 1;
    let t = (year - m.epochs[i]) / (m.epochs[i + 1] - m.epochs[i]);
    Ok(m.main[i].lerp(&m.main[i + 1], t))
}

/// Schmidt semi-normalised associated Legendre functions of cos θ and what the field needs of
/// them, indexed `[n][m]`.
struct Legendre {
    /// P_n^m(cos θ).
    p: [[f64; MAX_DEGREE + 1]; MAX_DEGREE + 1],
    /// dP_n^m/dθ.
    dp: [[f64; MAX_DEGREE + 1]; MAX_DEGREE + 1],
    /// P_n^m(cos θ) / sin θ for m ≥ 1, finite at the poles (zero for m = 0, unused there).
    p_over_sin: [[f64; MAX_DEGREE + 1]; MAX_DEGREE + 1],
}

impl Legendre {
    /// Evaluates the three tables at colatitude `theta` (radians).
    ///
    /// Sectoral terms: `P_1^1 = sin θ` and `P_n^n = √((2n−1)/(2n)) sin θ P_{n−1}^{n−1}`;
    /// then for n > m,
    /// `P_n^m = ((2n−1) cos θ P_{n−1}^m − √((n−1)²−m²) P_{n−2}^m) / √(n²−m²)`.
    /// `dP/dθ` follows by differentiating each recursion, and `P/sin θ` obeys the same
    /// recursion in n (it is linear and has no θ-dependent coefficient other than cos θ),
    /// started from `P_m^m / sin θ`, which needs no division.
    fn new(theta: f64) -> Self {
        let zero = [[0.0; MAX_DEGREE + 1]; MAX_DEGREE + 1];
        let mut leg = Self {
            p: zero,
            dp: zero,
            p_over_sin: zero,
        };
        let (s, c) = theta.sin_cos();
        leg.fill_sectoral(s, c);
        leg.fill_by_degree(s, c);
        leg
    }

    /// The diagonal m = n, from `P_0^0 = 1`.
    fn fill_sectoral(&mut self, s: f64, c: f64) {
        let (p, dp, q) = (&mut self.p, &mut self.dp, &mut self.p_over_sin);
        p[0][0] = 1.0;
        for m in 1..=MAX_DEGREE {
            // √((2m−1)/(2m)) for m ≥ 2; 1 for m = 1 because m = 0 is not √2-normalised.
            let k = if m == 1 {
                1.0
            } else {
                ((2 * m - 1) as f64 / (2 * m) as f64).sqrt()
            };
            q[m][m] = k * p[m - 1][m - 1];
            p[m][m] = s * q[m][m];
            dp[m][m] = k * (c * p[m - 1][m - 1] + s * dp[m - 1][m - 1]);
        }
    }

    /// Every n > m from the diagonal, by the three-term recursion in n.
    fn fill_by_degree(&mut self, s: f64, c: f64) {
        let (p, dp, q) = (&mut self.p, &mut self.dp, &mut self.p_over_sin);
        // Entry n − 2 of column m; zero above the diagonal and before n = 2, where its weight
        // is zero anyway.
        let two_back = |t: &[[f64; MAX_DEGREE + 1]; MAX_DEGREE + 1], n: usize, m: usize| {
            n.checked_sub(2).map_or(0.0, |k| t[k][m])
        };
        for m in 0..MAX_DEGREE {
            for n in (m + 1)..=MAX_DEGREE {
                let (a, b) = recursion_weights(n, m);
                let (p1, p2) = (p[n - 1][m], two_back(p, n, m));
                p[n][m] = a * c * p1 - b * p2;
                dp[n][m] = a * (c * dp[n - 1][m] - s * p1) - b * two_back(dp, n, m);
                // P/sin θ is only needed (and only started) for m ≥ 1.
                q[n][m] = a * c * q[n - 1][m] - b * two_back(q, n, m);
            }
        }
    }
}

/// Weights `a, b` of `P_n^m = a cos θ P_{n−1}^m − b P_{n−2}^m` (n > m).
fn recursion_weights(n: usize, m: usize) -> (f64, f64) {
    let (nf, mf) = (n as f64, m as f64);
    let norm = (nf * nf - mf * mf).sqrt();
    let a = (2.0 * nf - 1.0) / norm;
    let b = (((nf - 1.0) * (nf - 1.0) - mf * mf).max(0.0)).sqrt() / norm;
    (a, b)
}

/// Sums the gradient of the potential `V = a Σ (a/r)^{n+1} Σ (g cos mλ + h sin mλ) P_n^m`.
fn synthesise(gauss: &Gauss, leg: &Legendre, lon_rad: f64, radius_m: f64) -> GeocentricField {
    let ratio = REFERENCE_RADIUS_M / radius_m;
    let (mut north, mut east, mut down) = (0.0, 0.0, 0.0);
    let mut scale = ratio * ratio; // (a/r)^{n+2}, starting at n = 0
    for n in 1..=MAX_DEGREE {
        scale *= ratio;
        let (mut sn, mut se, mut sd) = (0.0, 0.0, 0.0);
        for m in 0..=n {
            let (sin_m, cos_m) = (m as f64 * lon_rad).sin_cos();
            let (g, h) = (gauss.g[n][m], gauss.h[n][m]);
            let even = g * cos_m + h * sin_m;
            sn += even * leg.dp[n][m];
            se += m as f64 * (g * sin_m - h * cos_m) * leg.p_over_sin[n][m];
            sd += even * leg.p[n][m];
        }
        north += scale * sn;
        east += scale * se;
        down -= scale * (n as f64 + 1.0) * sd;
    }
    GeocentricField { north, east, down }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: f64, b: f64, tol: f64) -> bool {
        (a - b).abs() <= tol
    }

    #[test]
    fn table_parses_to_26_epochs_and_secular_variation() {
        let m = model();
        assert_eq!(m.epochs.len(), 26);
        assert_eq!(m.epochs[0], 1900.0);
        assert_eq!(m.epochs[25], 2025.0);
        assert_eq!(m.main[25].g[1][0], -29350.0);
        assert_eq!(m.main[25].h[13][13], -0.5);
        assert_eq!(m.secular.g[1][0], 12.6);
        assert_eq!(m.main[0].g[1][1], -2298.0);
        assert_eq!(m.main[0].h[1][1], 5922.0);
    }

    #[test]
    fn coefficients_interpolate_and_extrapolate() {
        let g10 = |y: f64| coefficients_at(y).unwrap().g[1][0];
        assert!(close(g10(2022.5), 0.5 * (-29403.41 - 29350.0), 1e-9));
        assert!(close(g10(2030.0), -29350.0 + 5.0 * 12.6, 1e-9));
        assert_eq!(g10(1900.0), -31543.0);
    }

    #[test]
    fn legendre_matches_closed_forms() {
        let theta = 0.7_f64;
        let (s, c) = theta.sin_cos();
        let l = Legendre::new(theta);
        assert!(close(l.p[2][0], 1.5 * c * c - 0.5, 1e-14));
        assert!(close(l.p[2][1], 3f64.sqrt() * s * c, 1e-14));
        assert!(close(l.p[2][2], 3f64.sqrt() / 2.0 * s * s, 1e-14));
        assert!(close(l.dp[2][1], 3f64.sqrt() * (c * c - s * s), 1e-14));
        assert!(close(l.p_over_sin[3][2] * s, l.p[3][2], 1e-14));
    }

    #[test]
    fn legendre_derivative_matches_finite_difference() {
        let (theta, e) = (1.1_f64, 1e-6);
        let (a, b, l) = (
            Legendre::new(theta + e),
            Legendre::new(theta - e),
            Legendre::new(theta),
        );
        for n in 1..=MAX_DEGREE {
            for m in 0..=n {
                let fd = (a.p[n][m] - b.p[n][m]) / (2.0 * e);
                assert!(close(fd, l.dp[n][m], 1e-7), "n={n} m={m}");
            }
        }
    }

    #[test]
    fn poles_are_finite_and_continuous() {
        for lat in [90.0, -90.0] {
            let at = field(lat, 30.0, 0.0, 2020.0).unwrap();
            let near = field(lat - lat.signum() * 1e-7, 30.0, 0.0, 2020.0).unwrap();
            for (a, b) in [
                (at.x, near.x),
                (at.y, near.y),
                (at.z, near.z),
                (at.f, near.f),
            ] {
                assert!(a.is_finite() && close(a, b, 0.01), "lat {lat}: {a} vs {b}");
            }
            assert!(at.declination.is_finite() && at.inclination.is_finite());
        }
    }

    #[test]
    fn refuses_bad_dates_and_latitudes() {
        assert_eq!(
            field(0.0, 0.0, 0.0, 1899.99),
            Err(IgrfError::DateOutOfRange(1899.99))
        );
        assert_eq!(
            field(0.0, 0.0, 0.0, 2030.01),
            Err(IgrfError::DateOutOfRange(2030.01))
        );
        assert!(matches!(
            field(0.0, 0.0, 0.0, f64::NAN),
            Err(IgrfError::DateOutOfRange(_))
        ));
        assert_eq!(
            field(90.5, 0.0, 0.0, 2020.0),
            Err(IgrfError::InvalidLatitude(90.5))
        );
        assert!(matches!(
            field(f64::NAN, 0.0, 0.0, 2020.0),
            Err(IgrfError::InvalidLatitude(_))
        ));
        assert!(matches!(
            field(0.0, f64::INFINITY, 0.0, 2020.0),
            Err(IgrfError::InvalidLongitude(_))
        ));
        assert!(matches!(
            field(0.0, 0.0, f64::NAN, 2020.0),
            Err(IgrfError::InvalidAltitude(_))
        ));
        assert!(field(0.0, 0.0, 0.0, 1900.0).is_ok() && field(0.0, 0.0, 0.0, 2030.0).is_ok());
    }

    #[test]
    fn decimal_year_handles_leap_years() {
        assert_eq!(decimal_year(2000, 3, 1), Ok(2000.0 + 60.0 / 366.0));
        assert_eq!(decimal_year(1900, 3, 1), Ok(1900.0 + 59.0 / 365.0));
        assert_eq!(decimal_year(2025, 7, 2), Ok(2025.0 + 182.0 / 365.0));
    }

    #[test]
    fn decimal_year_refuses_dates_that_do_not_exist() {
        assert!(decimal_year(2023, 2, 29).is_err());
        assert!(decimal_year(2024, 2, 29).is_ok());
        assert!(decimal_year(2024, 13, 1).is_err());
        assert!(decimal_year(2024, 4, 31).is_err());
    }

    #[test]
    fn output_round_trips_through_serde() {
        let b = field(10.0, 20.0, 1000.0, 2010.0).unwrap();
        let json = serde_json::to_string(&b).unwrap();
        assert_eq!(serde_json::from_str::<MagneticField>(&json).unwrap(), b);
    }
}
