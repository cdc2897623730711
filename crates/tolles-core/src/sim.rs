//! Simulated flights whose truth is known.
//!
//! ```
//! use tolles_core::plan::BoxPlan;
//! use tolles_core::sim::{simulate, Installation, Scenario};
//!
//! let scenario = Scenario::new(Installation::Cabin.aircraft(), 7);
//! let flight = simulate(&BoxPlan::default().build(), &scenario);
//! assert_eq!(flight.tt.len(), flight.scalar.len());
//! // The scalar reads the exact magnitude |B + H| plus noise.
//! let k = 200;
//! let truth = flight.earth_nt[k] + flight.interference_nt[k];
//! assert!((flight.scalar[k] - truth).abs() < 0.1);
//! ```
//!
//! The earth field `B` is constant in the navigation frame (given by intensity, inclination and
//! declination); the aircraft's attitude rotates it into the body frame. The aircraft adds
//! `H = P + I·B + E·dB/dt` (see [`AircraftField`]), with `dB/dt` the exact rate of change of the
//! body-frame earth field as the aircraft rotates. The scalar magnetometer reads `|B + H|` without
//! linearisation, plus white noise; the fluxgate reads `B` plus white noise.

use crate::interpret::AircraftField;
use crate::plan::Plan;
use crate::vector::VectorSeries;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};
use serde::{Deserialize, Serialize};

/// The earth's field where the aircraft flies.
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

/// Sensor noise.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Sensors {
    /// Standard deviation of the scalar magnetometer's white noise (nT).
    pub scalar_noise_nt: f64,
    /// Standard deviation of each fluxgate component's white noise (nT).
    pub flux_noise_nt: f64,
}

impl Default for Sensors {
    /// A caesium magnetometer (0.01 nT) and a survey fluxgate (0.5 nT).
    fn default() -> Self {
        Self {
            scalar_noise_nt: 0.01,
            flux_noise_nt: 0.5,
        }
    }
}

/// Where the magnetometer sits, and so how strong the aircraft's field is.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Installation {
    /// A tail stinger far from the airframe: a few nT.
    TailStinger,
    /// Inside the cabin: hundreds of nT.
    Cabin,
}

impl Installation {
    /// A representative aircraft field for this installation.
    pub fn aircraft(self) -> AircraftField {
        let scale = match self {
            Installation::TailStinger => 1.0,
            Installation::Cabin => 25.0,
        };
        let p = [4.0, -2.5, 6.0];
        let i = [
            [4.0e-5, 1.5e-5, -2.0e-5],
            [0.5e-5, -3.0e-5, 1.0e-5],
            [-1.0e-5, 2.5e-5, 6.0e-5],
        ];
        let e = [
            [2.0e-5, -1.0e-5, 0.5e-5],
            [1.5e-5, 3.0e-5, -2.0e-5],
            [-0.5e-5, 1.0e-5, -2.5e-5],
        ];
        AircraftField {
            permanent_nt: p.map(|v| v * scale),
            induced: i.map(|row| row.map(|v| v * scale)),
            eddy_s: e.map(|row| row.map(|v| v * scale)),
            bias_nt: 0.0,
        }
    }
}

/// Everything about a simulated flight except its plan.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Scenario {
    /// Sample rate (Hz).
    pub fs_hz: f64,
    /// The earth's field.
    pub earth: EarthField,
    /// The aircraft's field (truth).
    pub aircraft: AircraftField,
    /// Sensor noise.
    pub sensors: Sensors,
    /// Seed of the noise.
    pub seed: u64,
}

impl Scenario {
    /// 10 Hz, the default earth field and sensors.
    pub fn new(aircraft: AircraftField, seed: u64) -> Self {
        Self {
            fs_hz: 10.0,
            earth: EarthField::default(),
            aircraft,
            sensors: Sensors::default(),
            seed,
        }
    }
}

/// A simulated flight: what the sensors read and what was true.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct SimulatedFlight {
    /// Time (s).
    pub tt: Vec<f64>,
    /// Line id of each sample.
    pub line: Vec<f64>,
    /// Roll, right wing down positive (degrees).
    pub roll_deg: Vec<f64>,
    /// Pitch, nose up positive (degrees).
    pub pitch_deg: Vec<f64>,
    /// Yaw, clockwise from true north, in [0, 360) (degrees).
    pub yaw_deg: Vec<f64>,
    /// Scalar magnetometer reading (nT).
    pub scalar: Vec<f64>,
    /// Fluxgate reading, body frame (nT).
    pub flux: VectorSeries,
    /// Truth: the earth's field magnitude without the aircraft (nT).
    pub earth_nt: Vec<f64>,
    /// Truth: what the aircraft adds to the scalar, `|B + H| − |B|` (nT).
    pub interference_nt: Vec<f64>,
}

/// Step (s) of the central difference that gives `dB/dt` from the plan's continuous attitude.
const DERIVATIVE_STEP_S: f64 = 1e-4;

/// Flies `plan` through `scenario`, one sample every `1/fs` seconds from t = 0.
pub fn simulate(plan: &Plan, scenario: &Scenario) -> SimulatedFlight {
    let n = (plan.duration_s() * scenario.fs_hz).floor() as usize + 1;
    let mut rng = ChaCha8Rng::seed_from_u64(scenario.seed);
    let scalar_noise = normal(scenario.sensors.scalar_noise_nt);
    let flux_noise = normal(scenario.sensors.flux_noise_nt);
    let ned = scenario.earth.ned();
    let mut out = SimulatedFlight::default();
    for k in 0..n {
        let t = k as f64 / scenario.fs_hz;
        let attitude = plan.attitude(t);
        let b = attitude.to_body(ned);
        let rate = body_rate(plan, ned, t);
        let h = interference(&scenario.aircraft, b, rate);
        let total = add(b, h);
        out.tt.push(t);
        out.line.push(plan.segments()[plan.segment_at(t)].line);
        out.roll_deg.push(attitude.roll.to_degrees());
        out.pitch_deg.push(attitude.pitch.to_degrees());
        out.yaw_deg
            .push(attitude.yaw.to_degrees().rem_euclid(360.0));
        out.earth_nt.push(norm(b));
        out.interference_nt.push(norm(total) - norm(b));
        out.scalar.push(norm(total) + scalar_noise.sample(&mut rng));
        out.flux.x.push(b[0] + flux_noise.sample(&mut rng));
        out.flux.y.push(b[1] + flux_noise.sample(&mut rng));
        out.flux.z.push(b[2] + flux_noise.sample(&mut rng));
    }
    out
}

/// The aircraft's field `P + I·B + E·dB/dt` (nT) for body-frame `b` (nT) and `rate` (nT/s).
pub fn interference(aircraft: &AircraftField, b: [f64; 3], rate: [f64; 3]) -> [f64; 3] {
    let mut h = aircraft.permanent_nt;
    for (i, hi) in h.iter_mut().enumerate() {
        for j in 0..3 {
            *hi += aircraft.induced[i][j] * b[j] + aircraft.eddy_s[i][j] * rate[j];
        }
    }
    h
}

fn body_rate(plan: &Plan, ned: [f64; 3], t: f64) -> [f64; 3] {
    let h = DERIVATIVE_STEP_S;
    let ahead = plan.attitude(t + h).to_body(ned);
    let behind = plan.attitude((t - h).max(0.0)).to_body(ned);
    let span = t + h - (t - h).max(0.0);
    [0, 1, 2].map(|i| (ahead[i] - behind[i]) / span)
}

fn normal(sigma: f64) -> Normal<f64> {
    Normal::new(0.0, sigma.max(0.0)).expect("a finite, non-negative standard deviation")
}

fn add(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}

fn norm(v: [f64; 3]) -> f64 {
    (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::plan::BoxPlan;

    #[test]
    fn same_seed_same_flight_other_seed_other_noise() {
        let plan = BoxPlan::default().build();
        let a = simulate(&plan, &Scenario::new(Installation::Cabin.aircraft(), 1));
        let b = simulate(&plan, &Scenario::new(Installation::Cabin.aircraft(), 1));
        let c = simulate(&plan, &Scenario::new(Installation::Cabin.aircraft(), 2));
        assert_eq!(a, b);
        assert_ne!(a.scalar, c.scalar);
        assert_eq!(a.interference_nt, c.interference_nt);
    }

    #[test]
    fn fluxgate_magnitude_is_the_earth_field() {
        let mut scenario = Scenario::new(AircraftField::default(), 3);
        scenario.sensors.flux_noise_nt = 0.0;
        let flight = simulate(&BoxPlan::default().build(), &scenario);
        for k in (0..flight.tt.len()).step_by(97) {
            assert!((flight.flux.magnitude(k) - 52_000.0).abs() < 1e-6);
            assert!(flight.interference_nt[k].abs() < 1e-12);
        }
    }

    #[test]
    fn eddy_field_follows_the_rate_of_change() {
        // Pure eddy field: zero when the attitude is steady.
        let mut aircraft = AircraftField::default();
        aircraft.eddy_s[2][1] = 1e-3;
        let flight = simulate(&BoxPlan::default().build(), &Scenario::new(aircraft, 4));
        assert!(flight.interference_nt[5].abs() < 1e-9); // straight and level
        let peak = flight
            .interference_nt
            .iter()
            .fold(0.0f64, |m, v| m.max(v.abs()));
        assert!(peak > 1.0, "{peak}");
    }
}
