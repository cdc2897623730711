//! Cabin effects the Tolles-Lawson model cannot represent, with the channels that drive them.
//!
//! ```
//! use tolles_core::flight::effects::{Effects, EffectsTrack};
//! use tolles_core::model::interpret::AircraftField;
//! let effects = Effects::typical();
//! let track = EffectsTrack::new(&effects, 7, 600.0);
//! let now = track.at(120.0); // cur_load (A), pos_flap (deg), temp (°C)
//! let b = [18_000.0, -1_000.0, 49_000.0]; // earth field, body frame (nT)
//! let h = effects.field(&now, b, &AircraftField::default());
//! assert!(h.iter().all(|v| v.abs() < 100.0));
//! ```
//!
//! Each effect is a static function of channels a user records and of the earth field in the
//! body frame, so a regressor that sees those channels could learn it; none is a sum of the
//! `B̂·channel` columns tolles' `--extra` adds to the design:
//! - **A saturating load** ([`SaturatingLoad`]): a load switched between levels, whose field
//!   along a fixed body-frame direction is `k·I_sat·tanh(I/I_sat)`: `k·I` for small currents,
//!   at most `k·I_sat`. A column `B̂·I` fits its straight part only.
//! - **A control surface** ([`ControlSurface`]): a magnetised part on a flap turns about the
//!   hinge (the body y axis). Its moment and its position turn with the angle `δ`, so its dipole
//!   field at the magnetometer goes as `cos δ` and `sin δ` (and as `1/r³` of a moving
//!   distance), not as `δ`; a moment induced by the earth field makes it a product of `B` and a
//!   function of `δ`.
//! - **Temperature** ([`Temperature`]): the permanent field scales by `1 + α_P·(T − T0)` and
//!   the induced field by `1 + α_I·(T − T0)`. The permanent share, `α_P·(T − T0)·P`, is a sum of
//!   `B̂·T` columns, so `--extra temp` represents it; the induced share, `α_I·(T − T0)·I·B`, is a
//!   product of the temperature and the earth field that no column of the design holds.
//!
//! The channels follow a schedule drawn once per flight from the scenario's seed
//! ([`EffectsTrack`]), on a random stream of its own: the sensor noise of a flight with effects
//! is the noise of the same flight without them.

use super::vec3::{add, norm};
use crate::model::interpret::AircraftField;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

/// μ0/4π in nT·m/A: a dipole of 1 A·m² gives 100 nT on its axis's perpendicular at 1 m.
const MU0_OVER_4PI_NT_M_PER_A: f64 = 100.0;

/// The random stream (of the scenario's seed) the effects' schedules are drawn from; the
/// sensor noise uses stream 0, the reference magnetometer's noise stream 1.
pub const SCHEDULE_STREAM: u64 = 2;

/// The cabin effects a scenario has; each is optional.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct Effects {
    /// A saturating load current, channel `cur_load` (A).
    pub load: Option<SaturatingLoad>,
    /// A magnetised control surface, channel `pos_flap` (degrees).
    pub surface: Option<ControlSurface>,
    /// Temperature-dependent magnetisation, channel `temp` (°C).
    pub temperature: Option<Temperature>,
}

impl Effects {
    /// All three effects with [`SaturatingLoad::typical`], [`ControlSurface::typical`] and
    /// [`Temperature::typical`]: each a few to about 20 nT at a cabin magnetometer.
    pub fn typical() -> Self {
        Self {
            load: Some(SaturatingLoad::typical()),
            surface: Some(ControlSurface::typical()),
            temperature: Some(Temperature::typical()),
        }
    }

    /// True when no effect is switched on.
    pub fn is_empty(&self) -> bool {
        self.load.is_none() && self.surface.is_none() && self.temperature.is_none()
    }

    /// Why these effects cannot be simulated, if they cannot: a number not finite, a time
    /// constant, period, dwell or saturation current not positive, or a control-surface part
    /// that could reach the magnetometer.
    pub fn check(&self) -> Result<(), &'static str> {
        let finite = |values: &[f64]| values.iter().all(|v| v.is_finite());
        if let Some(l) = self.load {
            let k = l.field_nt_per_a;
            if !finite(&[k[0], k[1], k[2], l.max_a, l.ramp_s, l.ripple_a, l.ripple_hz])
                || l.max_a < 0.0
                || l.ramp_s < 0.0
            {
                return Err("the load's field, current and ramp must be finite, ≥ 0 where sizes");
            }
            let positive = l.saturation_a > 0.0 && l.min_dwell_s > 0.0;
            if !(positive
                && l.max_dwell_s >= l.min_dwell_s
                && finite(&[l.saturation_a, l.max_dwell_s]))
            {
                return Err("the load's saturation current and dwell times must be positive");
            }
        }
        if let Some(f) = self.surface {
            let numbers = [f.hinge_m, f.arm_m, f.moment_am2].concat();
            if !finite(&numbers)
                || !finite(&[f.induced_am2_per_nt, f.center_deg, f.swing_deg])
                || !f.periods_s.iter().all(|p| p.is_finite() && *p > 0.0)
            {
                return Err("the control surface's numbers must be finite, its periods positive");
            }
            if norm(f.hinge_m) <= norm(f.arm_m) {
                return Err("the control surface's part must stay away from the magnetometer");
            }
        }
        if let Some(t) = self.temperature {
            let numbers = [
                t.reference_c,
                t.permanent_per_c,
                t.induced_per_c,
                t.start_c,
                t.start_spread_c,
                t.rise_c,
                t.fall_c,
                t.cycle_c,
            ];
            let times = [t.rise_s, t.fall_s, t.cycle_s];
            if !finite(&numbers) || !times.iter().all(|s| s.is_finite() && *s > 0.0) {
                return Err(
                    "the temperature's numbers must be finite, its time constants positive",
                );
            }
        }
        Ok(())
    }

    /// The effects' field (nT, body frame) for the channels `now`, the earth field `b` (nT,
    /// body frame) and the aircraft's terms (whose permanent and induced fields the temperature
    /// scales).
    pub fn field(&self, now: &Channels, b: [f64; 3], aircraft: &AircraftField) -> [f64; 3] {
        let mut h = [0.0; 3];
        if let (Some(load), Some(amps)) = (self.load, now.load_a) {
            h = add(h, load.field(amps));
        }
        if let (Some(surface), Some(deg)) = (self.surface, now.flap_deg) {
            h = add(h, surface.field(deg, b));
        }
        if let (Some(temperature), Some(celsius)) = (self.temperature, now.temperature_c) {
            h = add(h, temperature.field(celsius, b, aircraft));
        }
        h
    }
}

/// The effects' channels at one instant; `None` for an effect that is off.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Channels {
    /// Load current (A).
    pub load_a: Option<f64>,
    /// Control-surface angle, trailing edge down positive (degrees).
    pub flap_deg: Option<f64>,
    /// Temperature of the magnetised structure (°C).
    pub temperature_c: Option<f64>,
}

/// A load whose field saturates: `field_nt_per_a·I_sat·tanh(I/I_sat)` (nT). The current is
/// switched between levels drawn uniformly from `[0, max_a]`, each held for a time drawn
/// uniformly from `[min_dwell_s, max_dwell_s]` and reached by a linear ramp, plus a ripple.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct SaturatingLoad {
    /// Field at the magnetometer per ampere at small currents, body frame (nT/A).
    pub field_nt_per_a: [f64; 3],
    /// Current at which the field saturates (A); the field never exceeds
    /// `|field_nt_per_a|·saturation_a` (nT).
    pub saturation_a: f64,
    /// Largest level of the switched current (A).
    pub max_a: f64,
    /// Shortest time a level is held (s).
    pub min_dwell_s: f64,
    /// Longest time a level is held (s).
    pub max_dwell_s: f64,
    /// Duration of the ramp from one level to the next (s).
    pub ramp_s: f64,
    /// Amplitude of a sinusoidal ripple on the current (A) ...
    pub ripple_a: f64,
    /// ... at this frequency (Hz).
    pub ripple_hz: f64,
}

impl SaturatingLoad {
    /// A load of 0 to 45 A saturating at 12 A, 1.5 nT/A at small currents: up to about 18 nT.
    pub fn typical() -> Self {
        Self {
            field_nt_per_a: [0.7, -0.8, 1.1],
            saturation_a: 12.0,
            max_a: 45.0,
            min_dwell_s: 4.0,
            max_dwell_s: 25.0,
            ramp_s: 1.5,
            ripple_a: 1.0,
            ripple_hz: 0.4,
        }
    }

    /// The load's field (nT, body frame) at current `amps` (A).
    pub fn field(&self, amps: f64) -> [f64; 3] {
        let saturated = self.saturation_a * (amps / self.saturation_a).tanh();
        self.field_nt_per_a.map(|k| k * saturated)
    }
}

/// A magnetised part on a control surface hinged about the body y axis (the wing's span). At
/// angle `δ` its moment is `R(δ)·moment_am2 + induced_am2_per_nt·B` and it sits at
/// `hinge_m + R(δ)·arm_m`, where `R(δ)` turns about +y (trailing edge down for a part aft of
/// the hinge); the magnetometer reads its dipole field. The angle follows
/// `center_deg + swing_deg·(0.6·sin(2πt/P₁ + φ₁) + 0.4·sin(2πt/P₂ + φ₂))` with random phases.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ControlSurface {
    /// A point of the hinge line relative to the magnetometer, body frame (m).
    pub hinge_m: [f64; 3],
    /// The part's offset from that point at 0°, body frame (m).
    pub arm_m: [f64; 3],
    /// The part's permanent moment at 0°, body frame (A·m²).
    pub moment_am2: [f64; 3],
    /// Moment induced along the earth field per nT of it (A·m²/nT).
    pub induced_am2_per_nt: f64,
    /// Mean angle (degrees).
    pub center_deg: f64,
    /// Largest excursion from the mean (degrees).
    pub swing_deg: f64,
    /// Periods of the two sinusoids the angle follows (s).
    pub periods_s: [f64; 2],
}

impl ControlSurface {
    /// A flap hinged 1.9 m out on the right wing, just forward of the magnetometer, with a
    /// 2.1 A·m² part 0.5 m aft of its hinge, swinging from −10° to 50°: as the part sweeps
    /// past the magnetometer the scalar changes by about 20 nT, of which a straight line in the
    /// angle leaves about 1.5 nT (rms).
    pub fn typical() -> Self {
        Self {
            hinge_m: [0.3, 1.9, -0.1],
            arm_m: [-0.5, 0.0, 0.0],
            moment_am2: [-0.4, 0.7, 1.9],
            induced_am2_per_nt: 1.0e-5,
            center_deg: 20.0,
            swing_deg: 30.0,
            periods_s: [71.0, 17.0],
        }
    }

    /// The part's field (nT, body frame) at angle `deg` (degrees) in the earth field `b` (nT,
    /// body frame).
    pub fn field(&self, deg: f64, b: [f64; 3]) -> [f64; 3] {
        let (s, c) = deg.to_radians().sin_cos();
        let turn = |v: [f64; 3]| [c * v[0] + s * v[2], v[1], -s * v[0] + c * v[2]];
        let moment = add(
            turn(self.moment_am2),
            b.map(|v| v * self.induced_am2_per_nt),
        );
        dipole(moment, add(self.hinge_m, turn(self.arm_m)))
    }

    fn angle(&self, t: f64, phases: [f64; 2]) -> f64 {
        let wave =
            |k: usize| (2.0 * std::f64::consts::PI * t / self.periods_s[k] + phases[k]).sin();
        self.center_deg + self.swing_deg * (0.6 * wave(0) + 0.4 * wave(1))
    }
}

/// Temperature-dependent magnetisation: the permanent field `P` scales by
/// `1 + permanent_per_c·(T − reference_c)` and the induced field `I·B` by
/// `1 + induced_per_c·(T − reference_c)`. The temperature climbs after take-off, cools slowly
/// and swings with the cabin heating's cycle:
/// `T(t) = start + rise_c·(1 − e^(−t/rise_s)) − fall_c·(1 − e^(−t/fall_s)) +
/// cycle_c·sin(2πt/cycle_s + φ)`, where the start is `start_c` plus a random offset within
/// `±start_spread_c` and the phase `φ` is random. The cycle keeps the temperature from being a
/// function of the time alone, which on a box would tie it to the heading flown.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Temperature {
    /// Temperature at which the permanent and induced fields are the aircraft's terms (°C).
    pub reference_c: f64,
    /// Relative change of the permanent field per degree (1/°C).
    pub permanent_per_c: f64,
    /// Relative change of the induced field per degree (1/°C).
    pub induced_per_c: f64,
    /// Temperature at take-off (°C) ...
    pub start_c: f64,
    /// ... give or take this much, drawn per flight (°C).
    pub start_spread_c: f64,
    /// Warming after take-off (°C) ...
    pub rise_c: f64,
    /// ... with this time constant (s).
    pub rise_s: f64,
    /// Cooling later in the flight (°C) ...
    pub fall_c: f64,
    /// ... with this time constant (s).
    pub fall_s: f64,
    /// Amplitude of the heating's cycle (°C) ...
    pub cycle_c: f64,
    /// ... and its period (s).
    pub cycle_s: f64,
}

impl Temperature {
    /// 3·10⁻³/°C on the permanent field and 5·10⁻³/°C on the induced field; from about 10 °C
    /// at take-off to about 32 °C after 6 minutes, then cooling by about 10 °C over the next
    /// half hour, ±4 °C with a 140 s heating cycle: about 10 nT from the permanent field of a
    /// cabin installation and a few nT from the induced.
    pub fn typical() -> Self {
        Self {
            reference_c: 20.0,
            permanent_per_c: 3.0e-3,
            induced_per_c: 5.0e-3,
            start_c: 10.0,
            start_spread_c: 3.0,
            rise_c: 30.0,
            rise_s: 120.0,
            fall_c: 20.0,
            fall_s: 900.0,
            cycle_c: 4.0,
            cycle_s: 140.0,
        }
    }

    /// The field (nT, body frame) that a temperature of `celsius` (°C) adds to the aircraft's
    /// permanent and induced fields in the earth field `b` (nT, body frame).
    pub fn field(&self, celsius: f64, b: [f64; 3], aircraft: &AircraftField) -> [f64; 3] {
        let dt = celsius - self.reference_c;
        let mut h = aircraft.permanent_nt.map(|p| p * self.permanent_per_c * dt);
        for (i, hi) in h.iter_mut().enumerate() {
            let induced: f64 = (0..3).map(|j| aircraft.induced[i][j] * b[j]).sum();
            *hi += induced * self.induced_per_c * dt;
        }
        h
    }

    fn at(&self, t: f64, start_c: f64, phase: f64) -> f64 {
        let cycle = (2.0 * std::f64::consts::PI * t / self.cycle_s + phase).sin();
        start_c + self.rise_c * (1.0 - (-t / self.rise_s).exp())
            - self.fall_c * (1.0 - (-t / self.fall_s).exp())
            + self.cycle_c * cycle
    }
}

/// One flight's schedule of the effects' channels, drawn from a seed.
#[derive(Debug, Clone, PartialEq)]
pub struct EffectsTrack {
    effects: Effects,
    /// Times (s) at which the load starts ramping to the level of the same index (A).
    load_switches: Vec<(f64, f64)>,
    flap_phases: [f64; 2],
    start_c: f64,
    cycle_phase: f64,
}

impl EffectsTrack {
    /// The schedule of `effects` for a flight of `duration_s` (s) with `seed`.
    pub fn new(effects: &Effects, seed: u64, duration_s: f64) -> Self {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        rng.set_stream(SCHEDULE_STREAM);
        // The flap's phases and the temperature's start first, the load's switches after (as
        // many as the flight needs): switching an effect off leaves the others' schedules as
        // they were.
        let tau = 2.0 * std::f64::consts::PI;
        let flap_phases = [rng.random::<f64>() * tau, rng.random::<f64>() * tau];
        let spread = effects.temperature.map_or(0.0, |t| t.start_spread_c);
        let start_offset = (2.0 * rng.random::<f64>() - 1.0) * spread;
        let cycle_phase = rng.random::<f64>() * tau;
        let mut load_switches = Vec::new();
        if let Some(load) = effects.load {
            let mut t = 0.0;
            load_switches.push((f64::NEG_INFINITY, rng.random::<f64>() * load.max_a));
            while t <= duration_s {
                let dwell = load.max_dwell_s - load.min_dwell_s;
                t += load.min_dwell_s + rng.random::<f64>() * dwell;
                load_switches.push((t, rng.random::<f64>() * load.max_a));
            }
        }
        Self {
            effects: *effects,
            load_switches,
            flap_phases,
            start_c: effects.temperature.map_or(0.0, |t| t.start_c) + start_offset,
            cycle_phase,
        }
    }

    /// The channels at time `t` (s).
    pub fn at(&self, t: f64) -> Channels {
        Channels {
            load_a: self.effects.load.map(|load| self.load_current(&load, t)),
            flap_deg: self
                .effects
                .surface
                .map(|surface| surface.angle(t, self.flap_phases)),
            temperature_c: self
                .effects
                .temperature
                .map(|temp| temp.at(t, self.start_c, self.cycle_phase)),
        }
    }

    fn load_current(&self, load: &SaturatingLoad, t: f64) -> f64 {
        // The last switch at or before t; the schedule starts at −∞, so there is one.
        let k = self.load_switches.partition_point(|(start, _)| *start <= t) - 1;
        let (start, level) = self.load_switches[k];
        let before = if k == 0 {
            level
        } else {
            self.load_switches[k - 1].1
        };
        let progress = if load.ramp_s > 0.0 {
            ((t - start) / load.ramp_s).clamp(0.0, 1.0)
        } else {
            1.0
        };
        let ripple = load.ripple_a * (2.0 * std::f64::consts::PI * load.ripple_hz * t).sin();
        (before + (level - before) * progress + ripple).max(0.0)
    }
}

/// The field (nT) at the origin of a dipole of moment `m` (A·m²) at `r` (m).
fn dipole(m: [f64; 3], r: [f64; 3]) -> [f64; 3] {
    let distance = norm(r);
    let u = r.map(|v| v / distance);
    let along = m[0] * u[0] + m[1] * u[1] + m[2] * u[2];
    let scale = MU0_OVER_4PI_NT_M_PER_A / distance.powi(3);
    [0, 1, 2].map(|i| scale * (3.0 * along * u[i] - m[i]))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn magnitude(v: [f64; 3]) -> f64 {
        norm(v)
    }

    #[test]
    fn the_load_field_is_linear_when_small_and_saturates() {
        let load = SaturatingLoad::typical();
        let per_amp = magnitude(load.field_nt_per_a);
        // 0.1 A: within 10⁻⁴ of the linear field.
        assert!((magnitude(load.field(0.1)) / (0.1 * per_amp) - 1.0).abs() < 1e-4);
        // Never above k·I_sat, and nearly there at 4·I_sat.
        let ceiling = per_amp * load.saturation_a;
        let strong = magnitude(load.field(4.0 * load.saturation_a));
        assert!(
            strong < ceiling && strong > 0.999 * ceiling,
            "{strong} {ceiling}"
        );
        // Doubling a large current hardly changes the field: 24 A → 48 A adds under 4 %.
        let (a, b) = (magnitude(load.field(24.0)), magnitude(load.field(48.0)));
        assert!(b / a < 1.04, "{a} {b}");
        // Along the fixed direction, and the sign follows the current.
        let (negative, positive) = (load.field(-5.0), load.field(5.0));
        for (n, p) in negative.iter().zip(positive) {
            assert!((n + p).abs() < 1e-12);
        }
    }

    #[test]
    fn the_flap_field_is_its_dipole_turned_about_the_hinge() {
        let surface = ControlSurface {
            hinge_m: [0.0, 2.0, 0.0],
            arm_m: [0.0; 3],
            moment_am2: [1.0, 0.0, 0.0],
            induced_am2_per_nt: 0.0,
            ..ControlSurface::typical()
        };
        let b = [0.0; 3];
        // A moment of 1 A·m² along x, 2 m out along y: perpendicular, −100/8 nT along x.
        let level = surface.field(0.0, b);
        assert!(
            (level[0] + 12.5).abs() < 1e-12 && level[1].abs() < 1e-12,
            "{level:?}"
        );
        // At +90° the moment +x has turned to −z (as an aft arm −x turns to +z, trailing edge
        // down): 12.5 nT along +z.
        let down = surface.field(90.0, b);
        assert!(
            down[0].abs() < 1e-9 && (down[2] - 12.5).abs() < 1e-9,
            "{down:?}"
        );
        // ±30°: the same x component (cos), opposite z components (sin) — not linear in angle.
        let (up, dn) = (surface.field(30.0, b), surface.field(-30.0, b));
        assert!((up[0] - dn[0]).abs() < 1e-12 && (up[2] + dn[2]).abs() < 1e-12);
        assert!((up[0] - level[0] * 30f64.to_radians().cos()).abs() < 1e-12);
        // The mid-point of ±30° is not the field at 0°: a straight line in the angle misses it.
        assert!((0.5 * (up[0] + dn[0]) - level[0]).abs() > 1.0);
    }

    #[test]
    fn the_typical_flap_moves_its_part_and_is_induced_by_the_earth_field() {
        let surface = ControlSurface::typical();
        let b = [15_000.0, 2_000.0, 48_000.0];
        let (low, high) = (surface.field(-10.0, b), surface.field(50.0, b));
        let change = magnitude(add(high, low.map(|v| -v)));
        assert!((10.0..60.0).contains(&change), "{change} nT");
        let without = ControlSurface {
            induced_am2_per_nt: 0.0,
            ..surface
        };
        let induced = magnitude(add(
            surface.field(10.0, b),
            without.field(10.0, b).map(|v| -v),
        ));
        assert!(induced > 1.0, "{induced} nT");
    }

    #[test]
    fn the_temperature_scales_the_permanent_and_induced_fields() {
        let aircraft = AircraftField {
            permanent_nt: [100.0, 0.0, 0.0],
            induced: [[0.0, 0.0, 0.0], [0.0, 0.0, 0.0], [0.0, 0.0, 1e-3]],
            ..AircraftField::default()
        };
        let temperature = Temperature::typical();
        let b = [0.0, 0.0, 50_000.0];
        // At the reference temperature nothing is added.
        assert_eq!(temperature.field(20.0, b, &aircraft), [0.0; 3]);
        // 10 °C warmer: P·α_P·10 = 3 nT along x, I·B·α_I·10 = 2.5 nT along z.
        let warm = temperature.field(30.0, b, &aircraft);
        assert!(
            (warm[0] - 3.0).abs() < 1e-12 && (warm[2] - 2.5).abs() < 1e-12,
            "{warm:?}"
        );
        // Linear in the temperature for each term, a product of temperature and field.
        let colder = temperature.field(10.0, b, &aircraft);
        assert!((colder[0] + 3.0).abs() < 1e-12);
        let weaker = temperature.field(30.0, b.map(|v| v / 2.0), &aircraft);
        assert!((weaker[2] - 1.25).abs() < 1e-12);
    }

    #[test]
    fn the_schedule_climbs_cools_switches_and_depends_on_the_seed() {
        let effects = Effects::typical();
        let track = EffectsTrack::new(&effects, 3, 1_800.0);
        let temps: Vec<f64> = (0..=1_800)
            .step_by(30)
            .map(|t| track.at(t as f64).temperature_c.unwrap())
            .collect();
        let peak = temps.iter().cloned().fold(f64::MIN, f64::max);
        let k = temps.iter().position(|t| *t == peak).unwrap();
        assert!(
            peak - temps[0] > 15.0 && peak - temps.last().unwrap() > 5.0,
            "{temps:?}"
        );
        assert!(k > 0 && k < temps.len() - 1);
        let amps: Vec<f64> = (0..6_000)
            .map(|k| track.at(k as f64 * 0.1).load_a.unwrap())
            .collect();
        let (lo, hi) = (
            amps.iter().cloned().fold(f64::MAX, f64::min),
            amps.iter().cloned().fold(f64::MIN, f64::max),
        );
        assert!((0.0..10.0).contains(&lo) && hi > 30.0, "{lo} {hi}");
        // Continuous: no jump larger than a ramp's 0.1 s share plus ripple.
        let jump = amps
            .windows(2)
            .map(|w| (w[1] - w[0]).abs())
            .fold(0.0, f64::max);
        assert!(jump < 45.0 / 15.0 + 0.3, "{jump}");
        let angles: Vec<f64> = (0..600)
            .map(|k| track.at(k as f64).flap_deg.unwrap())
            .collect();
        assert!(angles.iter().all(|a| (-10.0..=50.0).contains(a)));
        assert!(angles.iter().cloned().fold(f64::MIN, f64::max) > 35.0);
        assert_eq!(track, EffectsTrack::new(&effects, 3, 1_800.0));
        assert_ne!(
            track.at(100.0).load_a,
            EffectsTrack::new(&effects, 4, 1_800.0).at(100.0).load_a
        );
    }

    #[test]
    fn parameters_out_of_range_are_refused() {
        assert_eq!(Effects::typical().check(), Ok(()));
        let mut bad = Effects::typical();
        bad.load.as_mut().unwrap().saturation_a = 0.0;
        assert!(bad.check().is_err());
        let mut bad = Effects::typical();
        bad.surface.as_mut().unwrap().arm_m = [0.0, 3.0, 0.0];
        assert!(bad.check().is_err());
        let mut bad = Effects::typical();
        bad.temperature.as_mut().unwrap().rise_s = f64::NAN;
        assert!(bad.check().is_err());
    }

    #[test]
    fn an_effect_switched_off_has_no_channel_and_leaves_the_others_as_they_were() {
        let all = EffectsTrack::new(&Effects::typical(), 5, 300.0);
        let only_flap = Effects {
            load: None,
            temperature: None,
            ..Effects::typical()
        };
        let some = EffectsTrack::new(&only_flap, 5, 300.0).at(42.0);
        assert_eq!(some.load_a, None);
        assert_eq!(some.temperature_c, None);
        assert_eq!(some.flap_deg, all.at(42.0).flap_deg);
        assert!(Effects::default().is_empty() && !only_flap.is_empty());
    }
}
