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
//! electrical current, and the optional cabin [`Effects`] that the Tolles-Lawson model cannot
//! represent (a saturating load, a control surface, temperature-dependent magnetisation; see
//! [`crate::flight::effects`]). The scalar magnetometer reads `|B + H|` without linearisation,
//! plus white noise; the fluxgate reads `B` through its [`Fluxgate`] errors, `lag_s` late; a
//! reference magnetometer, if the [`Sensors`] have one, reads `|B|` plus its own noise.
//!
//! The aircraft flies at `speed_mps` along its heading; the track's position only matters for
//! the main field's gradient and for geology.

pub use crate::flight::effects::Effects;
use crate::flight::effects::EffectsTrack;
// The uniform field is the environment's; kept public here, where it was first defined.
pub use crate::flight::environment::EarthField;
use crate::flight::environment::{Environment, Location};
use crate::flight::igrf::IgrfError;
use crate::flight::plan::Plan;
pub use crate::flight::sensor::{Fluxgate, Sensors};
use crate::flight::vec3::{add, norm};
use crate::model::interpret::AircraftField;
use crate::model::vector::VectorSeries;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};
use serde::{Deserialize, Serialize};
use thiserror::Error;

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
    /// A cabin as real survey aircraft measure (issue 56): a field of a thousand nT, a
    /// fluxgate that sees the aircraft (an offset of thousands of nT, gain and axis errors, and
    /// an offset that drifts by tens of nT over minutes), and an unmodelled current that
    /// ripples inside the fitting band and switches. `docs/simulation.md` compares its
    /// statistics with real boxes'.
    Realistic,
}

impl Installation {
    /// A representative aircraft field for this installation.
    pub fn aircraft(self) -> AircraftField {
        let scale = match self {
            Installation::TailStinger => 1.0,
            Installation::Cabin => 25.0,
            Installation::Uav => 4.0,
            // Real cabin fits: a permanent field of 1–5·10³ nT, induced terms of 10⁻³–10⁻².
            Installation::Realistic => 250.0,
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
            // Currents the calibration does not record: real cabin boxes leave 50–170 times the
            // scalar's own noise inside the band after the best linear fit.
            Installation::Realistic => Extras {
                induced2: [[2e-5, 0.0, 0.0], [0.0, -1e-5, 0.0], [0.0, 0.0, 3e-5]],
                current: Some(CurrentSource {
                    field_nt_per_a: [0.9, -0.6, 0.7],
                    mean_a: 20.0,
                    ripple_a: 2.5,
                    ripple_hz: 0.27,
                    step_a: 6.0,
                    step_every_s: 23.0,
                }),
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
            sensors: self.sensors(),
            ..Scenario::new(self.aircraft(), seed)
        }
    }

    /// The sensors this installation typically has: a clean fluxgate, but for
    /// [`Installation::Realistic`], whose fluxgate sees the aircraft.
    pub fn sensors(self) -> Sensors {
        match self {
            Installation::Realistic => Sensors {
                fluxgate: Fluxgate {
                    bias_nt: [1_800.0, -2_200.0, 1_500.0],
                    scale_error: [8e-3, -5e-3, 6e-3],
                    nonorthogonality_deg: [0.3, -0.2, 0.4],
                    drift_nt: [110.0, -80.0, 90.0],
                    drift_period_s: 700.0,
                    ..Fluxgate::default()
                },
                ..Sensors::default()
            },
            _ => Sensors::default(),
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
    /// Cabin effects the Tolles-Lawson model cannot represent, with their channels; none by
    /// default.
    #[serde(default, skip_serializing_if = "Effects::is_empty")]
    pub effects: Effects,
    /// Sensor errors.
    pub sensors: Sensors,
    /// Seed of the noise.
    pub seed: u64,
}

impl Scenario {
    /// 10 Hz, 60 m/s, the default uniform earth field, default sensors, no extras, no effects.
    pub fn new(aircraft: AircraftField, seed: u64) -> Self {
        Self {
            fs_hz: 10.0,
            speed_mps: 60.0,
            environment: Environment::uniform(EarthField::default()),
            aircraft,
            extras: Extras::default(),
            effects: Effects::default(),
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
    /// A parameter of the cabin effects is out of range.
    #[error("cabin effects: {0}")]
    Effects(&'static str),
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
    /// The reference magnetometer's reading (nT); empty without one.
    pub reference_nt: Vec<f64>,
    /// Current of the effects' saturating load (A); empty without one.
    pub load_a: Vec<f64>,
    /// Angle of the effects' control surface (degrees); empty without one.
    pub flap_deg: Vec<f64>,
    /// Temperature of the effects' magnetised structure (°C); empty without it.
    pub temperature_c: Vec<f64>,
    /// Truth: the earth's field magnitude without the aircraft (nT), geology and diurnal
    /// variation included.
    pub earth_nt: Vec<f64>,
    /// Truth: what the aircraft adds to the scalar, `|B + H| − |B|` (nT).
    pub interference_nt: Vec<f64>,
    /// Truth: the geology's total-field anomaly (nT).
    pub anomaly_nt: Vec<f64>,
    /// Truth: the diurnal variation (nT).
    pub diurnal_nt: Vec<f64>,
    /// Truth: what the cabin effects add to the scalar, `|B + H| − |B + H − H_effects|` (nT);
    /// empty without effects.
    pub effects_nt: Vec<f64>,
}

/// The random stream (of the scenario's seed) of the reference magnetometer's noise; the
/// sensor noise uses stream 0, the effects' schedules
/// [`crate::flight::effects::SCHEDULE_STREAM`].
const REFERENCE_STREAM: u64 = 1;

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
    // The reference's noise and the effects' schedules come from streams of their own, so a
    // flight with them has the sensor noise of the same flight without them.
    let mut reference_rng = ChaCha8Rng::seed_from_u64(scenario.seed);
    reference_rng.set_stream(REFERENCE_STREAM);
    let reference_noise = scenario.sensors.reference_noise_nt.map(normal);
    let effects = &scenario.effects;
    let track =
        (!effects.is_empty()).then(|| EffectsTrack::new(effects, scenario.seed, plan.duration_s()));
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
        let mut h = add(
            interference(&scenario.aircraft, b, body_rate(plan, ned, t)),
            extra_field(&scenario.extras, b, current),
        );
        if let Some(track) = &track {
            let now = track.at(t);
            let without = norm(add(b, h));
            h = add(h, effects.field(&now, b, &scenario.aircraft));
            out.effects_nt.push(norm(add(b, h)) - without);
            out.load_a.extend(now.load_a);
            out.flap_deg.extend(now.flap_deg);
            out.temperature_c.extend(now.temperature_c);
        }
        let total = add(b, h);
        let lagged = plan
            .attitude((t - scenario.sensors.fluxgate.lag_s).max(0.0))
            .to_body(ned);
        let noise = [0; 3].map(|_| flux_noise.sample(&mut rng));
        let flux = scenario.sensors.fluxgate.read(lagged, noise);
        let drift = scenario.sensors.fluxgate.drift_at(t);
        let flux = [0, 1, 2].map(|i| flux[i] + drift[i]);
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
        if let Some(noise) = &reference_noise {
            out.reference_nt
                .push(norm(b) + noise.sample(&mut reference_rng));
        }
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
        .chain(&s.reference_noise_nt)
        .all(|v| v.is_finite() && *v >= 0.0)
    {
        return Err(SimError::Noise);
    }
    scenario.effects.check().map_err(SimError::Effects)?;
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
    fn effects_add_their_truth_and_channels_and_keep_the_noise() {
        let plan = BoxPlan::default().build();
        let plain = Installation::Cabin.scenario(8);
        let with = Scenario {
            effects: Effects::typical(),
            ..plain.clone()
        };
        let (a, b) = (
            simulate(&plan, &plain).unwrap(),
            simulate(&plan, &with).unwrap(),
        );
        assert!(a.effects_nt.is_empty() && a.load_a.is_empty() && a.reference_nt.is_empty());
        let n = b.tt.len();
        for column in [&b.effects_nt, &b.load_a, &b.flap_deg, &b.temperature_c] {
            assert_eq!(column.len(), n);
        }
        // The same noise: the scalars differ by the effects' truth alone.
        assert_eq!(a.flux, b.flux);
        for k in 0..n {
            let added = b.scalar[k] - a.scalar[k];
            assert!((added - b.effects_nt[k]).abs() < 1e-6, "{k}: {added}");
            let aircraft = b.interference_nt[k] - a.interference_nt[k];
            assert!((aircraft - b.effects_nt[k]).abs() < 1e-6);
        }
        let spread = b.effects_nt.iter().fold(f64::MIN, |m, v| m.max(*v))
            - b.effects_nt.iter().fold(f64::MAX, |m, v| m.min(*v));
        assert!((5.0..80.0).contains(&spread), "{spread} nT");
    }

    #[test]
    fn the_reference_reads_the_earth_field_with_noise_of_its_own() {
        let plan = BoxPlan::default().build();
        let plain = Installation::Cabin.scenario(9);
        let mut with = plain.clone();
        with.sensors.reference_noise_nt = Some(0.02);
        let (a, b) = (
            simulate(&plan, &plain).unwrap(),
            simulate(&plan, &with).unwrap(),
        );
        assert_eq!(a.scalar, b.scalar);
        let noise: Vec<f64> = (0..b.tt.len())
            .map(|k| b.reference_nt[k] - b.earth_nt[k])
            .collect();
        let rms = (noise.iter().map(|v| v * v).sum::<f64>() / noise.len() as f64).sqrt();
        assert!((0.015..0.025).contains(&rms), "{rms}");
        // Independent of the scalar's noise.
        let scalar_noise: Vec<f64> = (0..b.tt.len())
            .map(|k| b.scalar[k] - b.earth_nt[k] - b.interference_nt[k])
            .collect();
        let dot: f64 = noise.iter().zip(&scalar_noise).map(|(x, y)| x * y).sum();
        let correlation = dot / (noise.len() as f64 * rms * 0.01);
        assert!(correlation.abs() < 0.1, "{correlation}");
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
        let mut s = Scenario::new(AircraftField::default(), 1);
        s.sensors.reference_noise_nt = Some(-1.0);
        assert_eq!(
            simulate(&BoxPlan::default().build(), &s),
            Err(SimError::Noise)
        );
        s.sensors.reference_noise_nt = None;
        s.effects = Effects::typical();
        s.effects.load.as_mut().unwrap().saturation_a = -1.0;
        assert!(matches!(
            simulate(&BoxPlan::default().build(), &s),
            Err(SimError::Effects(_))
        ));
    }
}
