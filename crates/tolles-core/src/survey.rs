//! Statistics of survey lines: mean heading, track length, residual about a line's linear trend.
//!
//! ```
//! use tolles_core::survey::{circular_mean_deg, detrended_std, track_length_m};
//! // 350° and 10° average to north, not to south.
//! assert!(circular_mean_deg(&[350.0, 10.0]).unwrap().abs() < 1e-9);
//! assert_eq!(track_length_m(&[0.0, 3.0], &[0.0, 4.0]), 5.0);
//! let t = [0.0, 1.0, 2.0, 3.0];
//! assert!(detrended_std(&t, &[1.0, 3.0, 5.0, 7.0]).unwrap() < 1e-12);
//! ```

/// Mean radius of the earth (m), for the local flat-earth track of a line.
const EARTH_RADIUS_M: f64 = 6_371_008.8;

/// Circular mean of angles (deg), in [0, 360); non-finite angles are ignored. `None` when none
/// is finite or the angles cancel (their mean direction is undefined).
pub fn circular_mean_deg(angles_deg: &[f64]) -> Option<f64> {
    let (mut s, mut c, mut n) = (0.0, 0.0, 0usize);
    for a in angles_deg.iter().filter(|a| a.is_finite()) {
        s += a.to_radians().sin();
        c += a.to_radians().cos();
        n += 1;
    }
    // A resultant this short is rounding, not a direction.
    if n == 0 || s.hypot(c) < 1e-9 * n as f64 {
        return None;
    }
    Some(wrap_deg(s.atan2(c).to_degrees()))
}

/// Mean resultant length of angles (deg), in [0, 1]: 1 when all point one way, 0.64 over a
/// steady 180° turn, 0 when they cancel; non-finite angles are ignored (`None` when none is
/// finite).
pub fn circular_concentration(angles_deg: &[f64]) -> Option<f64> {
    let (mut s, mut c, mut n) = (0.0, 0.0, 0usize);
    for a in angles_deg.iter().filter(|a| a.is_finite()) {
        s += a.to_radians().sin();
        c += a.to_radians().cos();
        n += 1;
    }
    (n > 0).then(|| s.hypot(c) / n as f64)
}

/// `angle_deg` in [0, 360): `rem_euclid` alone rounds a tiny negative angle up to 360.
fn wrap_deg(angle_deg: f64) -> f64 {
    let wrapped = angle_deg.rem_euclid(360.0);
    if wrapped >= 360.0 {
        0.0
    } else {
        wrapped
    }
}

/// North and east (m) of each point relative to the first finite one, on a sphere flattened
/// about it: ample for the kilometres of a survey line. Non-finite inputs give NaN.
pub fn local_north_east_m(lat_deg: &[f64], lon_deg: &[f64]) -> (Vec<f64>, Vec<f64>) {
    let origin = lat_deg
        .iter()
        .zip(lon_deg)
        .find(|(a, b)| a.is_finite() && b.is_finite());
    let Some((&lat0, &lon0)) = origin else {
        return (vec![f64::NAN; lat_deg.len()], vec![f64::NAN; lat_deg.len()]);
    };
    let cos_lat0 = lat0.to_radians().cos();
    let north = lat_deg
        .iter()
        .map(|lat| (lat - lat0).to_radians() * EARTH_RADIUS_M)
        .collect();
    let east = lon_deg
        .iter()
        .map(|lon| (lon - lon0).to_radians() * EARTH_RADIUS_M * cos_lat0)
        .collect();
    (north, east)
}

/// Length (m) of the track through the points, summing the steps whose ends are finite.
pub fn track_length_m(north_m: &[f64], east_m: &[f64]) -> f64 {
    steps(north_m, east_m).map(|(dn, de)| dn.hypot(de)).sum()
}

/// Bearing (deg clockwise from north, in [0, 360)) of each step of the track that moves.
pub fn track_bearings_deg(north_m: &[f64], east_m: &[f64]) -> Vec<f64> {
    steps(north_m, east_m)
        .filter(|(dn, de)| dn.hypot(*de) > 0.0)
        .map(|(dn, de)| wrap_deg(de.atan2(dn).to_degrees()))
        .collect()
}

/// `(Δnorth, Δeast)` of consecutive points, both finite.
fn steps<'a>(north: &'a [f64], east: &'a [f64]) -> impl Iterator<Item = (f64, f64)> + 'a {
    let points = north.iter().zip(east);
    points
        .clone()
        .zip(points.skip(1))
        .map(|((n0, e0), (n1, e1))| (n1 - n0, e1 - e0))
        .filter(|(dn, de)| dn.is_finite() && de.is_finite())
}

/// Standard deviation (units of `x`) of `x` about its least-squares straight line in `t`, over
/// the pairs where both are finite. `None` with fewer than 3 such pairs or a constant `t`.
pub fn detrended_std(t: &[f64], x: &[f64]) -> Option<f64> {
    let pairs: Vec<(f64, f64)> = t
        .iter()
        .zip(x)
        .filter(|(a, b)| a.is_finite() && b.is_finite())
        .map(|(a, b)| (*a, *b))
        .collect();
    let n = pairs.len() as f64;
    if pairs.len() < 3 {
        return None;
    }
    let t_mean = pairs.iter().map(|p| p.0).sum::<f64>() / n;
    let x_mean = pairs.iter().map(|p| p.1).sum::<f64>() / n;
    let stt: f64 = pairs.iter().map(|p| (p.0 - t_mean).powi(2)).sum();
    if stt <= 0.0 {
        return None;
    }
    let stx: f64 = pairs.iter().map(|p| (p.0 - t_mean) * (p.1 - x_mean)).sum();
    let slope = stx / stt;
    let ss: f64 = pairs
        .iter()
        .map(|p| (p.1 - x_mean - slope * (p.0 - t_mean)).powi(2))
        .sum();
    Some((ss / n).sqrt())
}

/// Median of the finite values; `None` when there are none.
pub fn median(values: &[f64]) -> Option<f64> {
    let mut v: Vec<f64> = values.iter().copied().filter(|x| x.is_finite()).collect();
    if v.is_empty() {
        return None;
    }
    v.sort_by(f64::total_cmp);
    let mid = v.len() / 2;
    Some(if v.len() % 2 == 1 {
        v[mid]
    } else {
        (v[mid - 1] + v[mid]) / 2.0
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn circular_mean_wraps_and_is_undefined_for_opposites() {
        let m = circular_mean_deg(&[270.0, 300.0, f64::NAN]).unwrap();
        assert!((m - 285.0).abs() < 1e-9, "{m}");
        assert_eq!(circular_mean_deg(&[0.0, 180.0]), None);
        assert_eq!(circular_mean_deg(&[f64::NAN]), None);
        assert_eq!(circular_mean_deg(&[]), None);
        assert_eq!(circular_mean_deg(&[-1e-15]), Some(0.0));
    }

    #[test]
    fn a_degree_of_latitude_is_about_111_km_due_north() {
        let (n, e) = local_north_east_m(&[45.0, 46.0], &[-75.0, -75.0]);
        assert!((track_length_m(&n, &e) - 111_195.0).abs() < 10.0);
        assert_eq!(track_bearings_deg(&n, &e), [0.0]);
        let (n, e) = local_north_east_m(&[45.0, 45.0], &[-75.0, -76.0]);
        let bearing = track_bearings_deg(&n, &e)[0];
        assert!((bearing - 270.0).abs() < 1e-9, "{bearing}");
        assert!((track_length_m(&n, &e) - 111_195.0 * 45f64.to_radians().cos()).abs() < 10.0);
    }

    #[test]
    fn gaps_and_standing_still_add_no_length_or_bearing() {
        let north = [0.0, 1.0, f64::NAN, 5.0, 5.0];
        let east = [0.0, 0.0, 0.0, 0.0, 0.0];
        assert_eq!(track_length_m(&north, &east), 1.0);
        assert_eq!(track_bearings_deg(&north, &east), [0.0]);
        let (n, _) = local_north_east_m(&[f64::NAN], &[1.0]);
        assert!(n[0].is_nan());
    }

    #[test]
    fn detrended_std_removes_the_line_and_keeps_the_wiggle() {
        let t: Vec<f64> = (0..1000).map(|k| k as f64).collect();
        // A trend plus ±1 alternating: the residual's std is 1.
        let x: Vec<f64> = t
            .iter()
            .map(|v| 3.0 + 0.5 * v + if *v as i64 % 2 == 0 { 1.0 } else { -1.0 })
            .collect();
        let s = detrended_std(&t, &x).unwrap();
        assert!((s - 1.0).abs() < 1e-3, "{s}");
        assert_eq!(detrended_std(&[0.0, 1.0], &[1.0, 2.0]), None);
        assert_eq!(detrended_std(&[1.0; 5], &[1.0, 2.0, 3.0, 4.0, 5.0]), None);
    }

    #[test]
    fn median_of_odd_even_and_empty() {
        assert_eq!(median(&[3.0, 1.0, 2.0]), Some(2.0));
        assert_eq!(median(&[4.0, 1.0, f64::NAN, 2.0, 3.0]), Some(2.5));
        assert_eq!(median(&[f64::NAN]), None);
    }

    #[test]
    fn concentration_of_a_straight_leg_and_of_a_turn() {
        assert!((circular_concentration(&[359.0, 1.0]).unwrap() - 1.0).abs() < 1e-3);
        let turn: Vec<f64> = (0..=180).map(f64::from).collect();
        let r = circular_concentration(&turn).unwrap();
        assert!((r - 2.0 / std::f64::consts::PI).abs() < 0.01, "{r}");
        assert_eq!(circular_concentration(&[f64::NAN]), None);
    }
}
