//! The range of every numeric setting of a [`SimulateRequest`], as a table, and the largest
//! flight it may ask for. Outside them the simulator would describe no aircraft (a roll of
//! 10³⁰⁸ degrees), overflow to infinities (a noise of 10³⁰⁸ nT) or exhaust memory (4·10⁹
//! survey lines), so a request beyond them is refused, naming its flag.

use super::SimulateRequest;
use crate::error::{Error, Result};

/// One setting's allowed closed range, in its unit.
struct Limit {
    /// The command-line flag.
    flag: &'static str,
    /// The Python keyword.
    python: &'static str,
    /// The unit, as printed after the range.
    unit: &'static str,
    low: f64,
    high: f64,
}

const fn limit(
    flag: &'static str,
    python: &'static str,
    unit: &'static str,
    low: f64,
    high: f64,
) -> Limit {
    Limit {
        flag,
        python,
        unit,
        low,
        high,
    }
}

/// Generous physical ranges: anything an aircraft flies or a sensor reads fits inside.
const FS: Limit = limit("--fs", "fs", "Hz", 1e-3, 10_000.0);
const SPEED: Limit = limit("--speed", "speed", "m/s", 1e-3, 1_000.0);
const LAT: Limit = limit("--lat", "lat", "deg", -90.0, 90.0);
const LON: Limit = limit("--lon", "lon", "deg", -360.0, 360.0);
const ALT: Limit = limit("--alt", "alt", "m", -1_000.0, 100_000.0);
const INCLINATION: Limit = limit("--inclination", "uniform[0]", "deg", -90.0, 90.0);
const DECLINATION: Limit = limit("--declination", "uniform[1]", "deg", -360.0, 360.0);
const INTENSITY: Limit = limit("--intensity", "uniform[2]", "nT", 1.0, 200_000.0);
const PERIOD: Limit = limit("--period", "period", "s", 0.1, 3_600.0);
const ROLL: Limit = limit("--roll", "roll", "deg", -60.0, 60.0);
const PITCH: Limit = limit("--pitch", "pitch", "deg", -45.0, 45.0);
const YAW: Limit = limit("--yaw", "yaw", "deg", -45.0, 45.0);
const LINE_DURATION: Limit = limit("--line-duration", "line_duration", "s", 1.0, 86_400.0);
const TURBULENCE: Limit = limit("--turbulence", "turbulence", "deg", 0.0, 20.0);
const GEOLOGY: Limit = limit("--geology", "geology", "nT", 0.0, 100_000.0);
const DIURNAL: Limit = limit("--diurnal", "diurnal", "nT", 0.0, 10_000.0);
const SCALAR_NOISE: Limit = limit("--scalar-noise", "scalar_noise", "nT", 0.0, 10_000.0);
const FLUX_NOISE: Limit = limit("--flux-noise", "flux_noise", "nT", 0.0, 10_000.0);
const FLUX_LAG: Limit = limit("--flux-lag", "flux_lag", "s", -10.0, 10.0);
const REFERENCE_NOISE: Limit = limit("--reference-noise", "reference_noise", "nT", 0.0, 10_000.0);
const CYCLES: Limit = limit("--cycles", "cycles", "", 1.0, 1_000.0);
const LINES: Limit = limit("--lines", "lines", "", 1.0, 10_000.0);

/// The most samples one simulated flight may hold: a day at 100 Hz, about 1.5 GB of columns.
pub const MAX_SAMPLES: f64 = 1e7;

/// Checks every setting of `r` against its range; the first one outside is the error.
pub fn check_settings(r: &SimulateRequest) -> Result<()> {
    let mut settings = vec![
        (&FS, r.fs_hz),
        (&SPEED, r.speed_mps),
        (&LAT, r.lat_deg),
        (&LON, r.lon_deg),
        (&ALT, r.alt_m),
        (&PERIOD, r.period_s),
        (&YAW, r.yaw_deg),
        (&LINE_DURATION, r.line_duration_s),
        (&TURBULENCE, r.turbulence_deg),
        (&GEOLOGY, r.geology_nt),
        (&DIURNAL, r.diurnal_nt),
        (&SCALAR_NOISE, r.scalar_noise_nt),
        (&FLUX_NOISE, r.flux_noise_nt),
        (&FLUX_LAG, r.flux_lag_s),
        (&REFERENCE_NOISE, r.reference_noise_nt),
        (&CYCLES, f64::from(r.cycles)),
        (&LINES, f64::from(r.lines)),
    ];
    settings.extend(r.roll_deg.map(|v| (&ROLL, v)));
    settings.extend(r.pitch_deg.map(|v| (&PITCH, v)));
    if let Some(u) = r.uniform {
        settings.push((&INCLINATION, u.inclination_deg));
        settings.push((&DECLINATION, u.declination_deg));
        settings.push((&INTENSITY, u.intensity_nt));
    }
    match settings
        .into_iter()
        .find(|(l, v)| !(l.low..=l.high).contains(v))
    {
        None => Ok(()),
        Some((l, value)) => Err(Error::SimulateSetting {
            flag: l.flag,
            python: l.python,
            low: l.low,
            high: l.high,
            unit: l.unit,
            value,
        }),
    }
}

/// Refuses a flight of `duration_s` (s) at `fs_hz` (Hz) longer than [`MAX_SAMPLES`].
pub fn check_length(duration_s: f64, fs_hz: f64) -> Result<()> {
    let samples = duration_s * fs_hz;
    if samples <= MAX_SAMPLES {
        return Ok(());
    }
    Err(Error::SimulateTooLong {
        samples,
        limit: MAX_SAMPLES,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_default_is_inside_its_range() {
        check_settings(&SimulateRequest::default()).unwrap();
    }

    #[test]
    fn a_setting_outside_names_its_flag_and_python_keyword() {
        let huge = SimulateRequest {
            reference_noise_nt: 1e308,
            ..SimulateRequest::default()
        };
        let text = check_settings(&huge).unwrap_err().to_string();
        assert!(
            text.contains("--reference-noise") && text.contains("reference_noise="),
            "{text}"
        );
        let nan = SimulateRequest {
            geology_nt: f64::NAN,
            ..SimulateRequest::default()
        };
        assert!(check_settings(&nan)
            .unwrap_err()
            .to_string()
            .contains("--geology"));
    }

    #[test]
    fn a_flight_beyond_the_sample_limit_is_refused() {
        assert!(check_length(1e6, 10.0).is_ok());
        assert!(check_length(1e6, 10.01).is_err());
    }
}
