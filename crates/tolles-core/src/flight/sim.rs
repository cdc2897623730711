//! Simulated flights whose truth is known.
//!
//! ```
//! use tolles_core::flight::plan::BoxPlan;
//! use tolles_core::flight::sim::{simulate, Installation, Scenario};
//!
//! let scenario = Scenario::new(Installation::Cabin.aircraft(), 7);
//! let flight = simulate(&BoxPlan::default().build(), &scenario).unwrap();
//! assert_eq!(flight.tt.len(), flight.scalar.len());
//! // The scalar reads the exact magnitude |B + H| plus noise.
//! let k = 200;
//! let truth = flight.earth_nt[k] + flight.interference_nt[k];
//! assert!((flight.scalar[k] - truth).abs() < 0.1);
//! ```
//!
//! The earth field `B` comes from the [`Environment`] at the aircraft's position (IGRF-14 or a
//! uniform field, plus geology and diurnal variation); the aircraft's attitude rotates it into
//! the body frame. The aircraft adds `H = P + I·B + E·dB/dt` (see [`AircraftField`]), with
//! `dB/dt` the exact rate of change of the body-frame earth field as the aircraft rotates, plus
//! the optional [`Extras`]: a second-order induced field and a field proportional to an
//! electrical current. The scalar magnetometer reads `|B + H|` without linearisation, plus white
//! noise; the fluxgate reads `B` through its [`Fluxgate`] errors, `lag_s` late.
//!
//! The aircraft flies at `speed_mps` along its heading; the track's position only matters for
//! the main field's gradient and for geology.

use crate::flight::environment::{Environment, Location};
use crate::flight::igrf::IgrfError;
use crate::flight::plan::Plan;
pub use crate::flight::sensor::{Fluxgate, Sensors};
use crate::model::interpret::AircraftField;
use crate::model::vector::VectorSeries;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};
use serde::{Deserialize, Serialize};
use thiserror::Error;

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

/// A field proportional to an electrical current, such as a UAV's motor supply.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct CurrentSource {
    /// Field at the magnetometer per ampere, body frame (nT/A).
    pub field_nt_per_a: [f64; 3],
    /// Mean current (A).
    pub mean_a: f64,
    /// Amplitude of a sinusoidal ripple (A) ...
    pub ripple_a: f64,
    /// ... at this frequency (Hz).
    pub ripple_hz: f64,
    /// A load switched on and off (A) ...
    pub step_a: f64,
    /// ... every this many seconds.
    pub step_every_s: f64,
}

impl CurrentSource {
    /// The current (A) at time `t` (s).
    pub fn at(&self, t: f64) -> f64 {
        let ripple = self.ripple_a * (2.0 * std::f64::consts::PI * self.ripple_hz * t).sin();
        let on = (t / self.step_every_s).floor() as i64 % 2 == 1;
        self.mean_a + ripple + if on { self.step_a } else { 0.0 }
    }
}

/// Effects a real aircraft has beyond the Tolles-Lawson model.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct Extras {
    /// Second-order induced field: `H_i += Σ_j induced2[i][j]·B_j²/|B|` (dimensionless).
    pub induced2: [[f64; 3]; 3],
    /// A current-carrying source, if any; its current is written to the `cur_1` column.
    pub current: Option<CurrentSource>,
}

/// Where the magnetometer sits, and so how strong the aircraft's field is.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Installation {
    /// A tail stinger far from the airframe: a few nT.
    TailStinger,
    /// Inside the cabin: tens to hundreds of nT.
    Cabin,
    /// A small UAV: a moderate airframe field and strong motor currents.
    Uav,
}

impl Installation {
    /// A representative aircraft field for this installation.
    pub fn aircraft(self) -> AircraftField {
        let scale = match self {
            Installation::TailStinger => 1.0,
            Installation::Cabin => 25.0,
            Installation::Uav => 4.0,
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

    /// The effects beyond the Tolles-Lawson model this installation typically has.
    pub fn extras(self) -> Extras {
        match self {
            Installation::TailStinger => Extras::default(),
            Installation::Cabin => Extras {
                induced2: [[2e-6, 0.0, 0.0], [0.0, -1e-6, 0.0], [0.0, 0.0, 3e-6]],
                current: None,
            },
            Installation::Uav => Extras {
                induced2: [[0.0; 3]; 3],
                current: Some(CurrentSource {
                    field_nt_per_a: [1.5, -0.8, 2.5],
                    mean_a: 12.0,
                    ripple_a: 1.5,
                    ripple_hz: 0.35,
                    step_a: 6.0,
                    step_every_s: 45.0,
                }),
            },
        }
    }

    /// A complete scenario for this installation: IGRF at the default location, light geology
    /// and diurnal variation, and the installation's extras.
    pub fn scenario(self, seed: u64) -> Scenario {
        let mut environment = Environment::at(Location::default());
        environment.geology = Some(crate::flight::environment::Geology::random(
            40, 20.0, 15_000.0, seed,
        ));
        environment.diurnal = Some(crate::flight::environment::Diurnal {
            amplitude_nt: 3.0,
            period_s: 3_600.0,
            phase_rad: 0.4,
        });
        Scenario {
            environment,
            extras: self.extras(),
            ..Scenario::new(self.aircraft(), seed)
        }
    }
}

/// Everything about a simulated flight except its plan.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Scenario {
    /// Sample rate (Hz).
    pub fs_hz: f64,
    /// Ground speed (m/s).
    pub speed_mps: f64,
    /// The earth's field.
    pub environment: Environment,
    /// The aircraft's field (truth).
    pub aircraft: AircraftField,
    /// Effects beyond the Tolles-Lawson model.
    pub extras: Extras,
    /// Sensor errors.
    pub sensors: Sensors,
    /// Seed of the noise.
    pub seed: u64,
}

impl Scenario {
    /// 10 Hz, 60 m/s, the default uniform earth field, default sensors, no extras.
    pub fn new(aircraft: AircraftField, seed: u64) -> Self {
        Self {
            fs_hz: 10.0,
            speed_mps: 60.0,
            environment: Environment::uniform(EarthField::default()),
            aircraft,
            extras: Extras::default(),
            sensors: Sensors::default(),
            seed,
        }
    }
}

/// Why a flight could not be simulated.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum SimError {
    /// The sample rate (Hz) is not positive and finite.
    #[error("sample rate must be positive and finite, got {0} Hz")]
    SampleRate(f64),
    /// A noise level is negative or not finite.
    #[error("noise levels must be finite and ≥ 0")]
    Noise,
    /// The flight plan has no segment.
    #[error("the flight plan is empty")]
    EmptyPlan,
    /// The earth's field could not be computed.
    #[error("earth field: {0}")]
    Earth(#[from] IgrfError),
}

/// A simulated flight: what the sensors read and what was true.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct SimulatedFlight {
    /// Time (s).
    pub tt: Vec<f64>,
    /// Line id of each sample.
    pub line: Vec<f64>,
    /// Distance north of the start (m).
    pub north_m: Vec<f64>,
    /// Distance east of the start (m).
    pub east_m: Vec<f64>,
    /// Latitude (degrees); empty when the main field is uniform (no location).
    pub lat_deg: Vec<f64>,
    /// Longitude (degrees); empty when the main field is uniform.
    pub lon_deg: Vec<f64>,
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
    /// Current of the [`CurrentSource`] (A); empty without one.
    pub current_a: Vec<f64>,
    /// Truth: the earth's field magnitude without the aircraft (nT), geology and diurnal
    /// variation included.
    pub earth_nt: Vec<f64>,
    /// Truth: what the aircraft adds to the scalar, `|B + H| − |B|` (nT).
    pub interference_nt: Vec<f64>,
    /// Truth: the geology's total-field anomaly (nT).
    pub anomaly_nt: Vec<f64>,
    /// Truth: the diurnal variation (nT).
    pub diurnal_nt: Vec<f64>,
}

/// Step (s) of the central difference that gives `dB/dt` from the plan's continuous attitude.
const DERIVATIVE_STEP_S: f64 = 1e-4;

/// Flies `plan` through `scenario`, one sample every `1/fs` seconds from t = 0.
pub fn simulate(plan: &Plan, scenario: &Scenario) -> Result<SimulatedFlight, SimError> {
    simulate_with_progress(plan, scenario, &mut |_, _| {})
}

/// Samples between two calls of a progress callback.
const PROGRESS_EVERY: usize = 4096;

/// [`simulate`], calling `progress(done, total)` (samples) now and then.
pub fn simulate_with_progress(
    plan: &Plan,
    scenario: &Scenario,
    progress: &mut dyn FnMut(usize, usize),
) -> Result<SimulatedFlight, SimError> {
    check(plan, scenario)?;
    let n = (plan.duration_s() * scenario.fs_hz).floor() as usize + 1;
    let dt = 1.0 / scenario.fs_hz;
    let mut rng = ChaCha8Rng::seed_from_u64(scenario.seed);
    let scalar_noise = normal(scenario.sensors.scalar_noise_nt);
    let flux_noise = normal(scenario.sensors.flux_noise_nt);
    let env = &scenario.environment;
    let (mut north, mut east) = (0.0, 0.0);
    let mut out = SimulatedFlight::default();
    for k in 0..n {
        if k % PROGRESS_EVERY == 0 {
            progress(k, n);
        }
        let t = k as f64 * dt;
        let attitude = plan.attitude(t);
        let ned = env.field_ned(north, east, t)?;
        let b = attitude.to_body(ned);
        let current = scenario.extras.current.map(|c| c.at(t));
        let h = add(
            interference(&scenario.aircraft, b, body_rate(plan, ned, t)),
            extra_field(&scenario.extras, b, current),
        );
        let total = add(b, h);
        let lagged = plan
            .attitude((t - scenario.sensors.fluxgate.lag_s).max(0.0))
            .to_body(ned);
        let noise = [0; 3].map(|_| flux_noise.sample(&mut rng));
        let flux = scenario.sensors.fluxgate.read(lagged, noise);
        if let crate::flight::environment::MainField::Igrf(location) = env.main {
            let (lat, lon) = location.offset(north, east);
            out.lat_deg.push(lat);
            out.lon_deg.push(lon);
        }
        out.tt.push(t);
        out.line.push(plan.segments()[plan.segment_at(t)].line);
        out.north_m.push(north);
        out.east_m.push(east);
        out.roll_deg.push(attitude.roll.to_degrees());
        out.pitch_deg.push(attitude.pitch.to_degrees());
        out.yaw_deg
            .push(attitude.yaw.to_degrees().rem_euclid(360.0));
        out.earth_nt.push(norm(b));
        out.interference_nt.push(norm(total) - norm(b));
        out.anomaly_nt.push(env.anomaly_nt(north, east));
        out.diurnal_nt.push(env.diurnal_nt(t));
        out.scalar.push(norm(total) + scalar_noise.sample(&mut rng));
        out.flux.x.push(flux[0]);
        out.flux.y.push(flux[1]);
        out.flux.z.push(flux[2]);
        out.current_a.extend(current);
        north += scenario.speed_mps * dt * attitude.yaw.cos();
        east += scenario.speed_mps * dt * attitude.yaw.sin();
    }
    progress(n, n);
    Ok(out)
}

fn check(plan: &Plan, scenario: &Scenario) -> Result<(), SimError> {
    if !(scenario.fs_hz.is_finite() && scenario.fs_hz > 0.0) {
        return Err(SimError::SampleRate(scenario.fs_hz));
    }
    let s = &scenario.sensors;
    if ![s.scalar_noise_nt, s.flux_noise_nt]
        .iter()
        .all(|v| v.is_finite() && *v >= 0.0)
    {
        return Err(SimError::Noise);
    }
    if plan.segments().is_empty() {
        return Err(SimError::EmptyPlan);
    }
    Ok(())
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

/// The field (nT) of the [`Extras`] for body-frame `b` (nT) and current (A).
fn extra_field(extras: &Extras, b: [f64; 3], current_a: Option<f64>) -> [f64; 3] {
    let magnitude = norm(b);
    let mut h = [0.0; 3];
    for (i, hi) in h.iter_mut().enumerate() {
        *hi = (0..3)
            .map(|j| extras.induced2[i][j] * b[j] * b[j] / magnitude)
            .sum();
    }
    if let (Some(source), Some(amps)) = (extras.current, current_a) {
        h = add(h, source.field_nt_per_a.map(|f| f * amps));
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
    Normal::new(0.0, sigma).expect("checked: finite and non-negative")
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
    use crate::flight::plan::BoxPlan;

    #[test]
    fn same_seed_same_flight_other_seed_other_noise() {
        let plan = BoxPlan::default().build();
        let a = simulate(&plan, &Scenario::new(Installation::Cabin.aircraft(), 1)).unwrap();
        let b = simulate(&plan, &Scenario::new(Installation::Cabin.aircraft(), 1)).unwrap();
        let c = simulate(&plan, &Scenario::new(Installation::Cabin.aircraft(), 2)).unwrap();
        assert_eq!(a, b);
        assert_ne!(a.scalar, c.scalar);
        assert_eq!(a.interference_nt, c.interference_nt);
    }

    #[test]
    fn fluxgate_magnitude_is_the_earth_field() {
        let mut scenario = Scenario::new(AircraftField::default(), 3);
        scenario.sensors.flux_noise_nt = 0.0;
        let flight = simulate(&BoxPlan::default().build(), &scenario).unwrap();
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
        let flight = simulate(&BoxPlan::default().build(), &Scenario::new(aircraft, 4)).unwrap();
        assert!(flight.interference_nt[5].abs() < 1e-9); // straight and level
        let peak = flight
            .interference_nt
            .iter()
            .fold(0.0f64, |m, v| m.max(v.abs()));
        assert!(peak > 1.0, "{peak}");
    }

    #[test]
    fn presets_fly_with_their_extras_and_report_them() {
        let plan = BoxPlan::default().build();
        let uav = simulate(&plan, &Installation::Uav.scenario(5)).unwrap();
        assert_eq!(uav.current_a.len(), uav.tt.len());
        assert!(uav.lat_deg[0].is_finite() && uav.lat_deg.last() != uav.lat_deg.first());
        let stinger = simulate(&plan, &Installation::TailStinger.scenario(5)).unwrap();
        assert!(stinger.current_a.is_empty());
        let spread = |x: &[f64]| {
            x.iter().fold(f64::NEG_INFINITY, |m, v| m.max(*v))
                - x.iter().fold(f64::INFINITY, |m, v| m.min(*v))
        };
        assert!(spread(&uav.interference_nt) > spread(&stinger.interference_nt));
        assert!(spread(&stinger.anomaly_nt) > 0.1);
    }

    #[test]
    fn fluxgate_lag_delays_the_reading() {
        let mut scenario = Scenario::new(AircraftField::default(), 6);
        scenario.sensors.flux_noise_nt = 0.0;
        scenario.sensors.fluxgate.lag_s = 0.5;
        let lagged = simulate(&BoxPlan::default().build(), &scenario).unwrap();
        scenario.sensors.fluxgate.lag_s = 0.0;
        let prompt = simulate(&BoxPlan::default().build(), &scenario).unwrap();
        // 0.5 s at 10 Hz is 5 samples.
        assert!((lagged.flux.y[305] - prompt.flux.y[300]).abs() < 1e-6);
    }

    #[test]
    fn bad_scenarios_are_errors() {
        let mut s = Scenario::new(AircraftField::default(), 1);
        s.fs_hz = 0.0;
        assert_eq!(
            simulate(&BoxPlan::default().build(), &s),
            Err(SimError::SampleRate(0.0))
        );
        let s = Scenario::new(AircraftField::default(), 1);
        assert_eq!(simulate(&Plan::default(), &s), Err(SimError::EmptyPlan));
    }
}
