//! The maneuver model of the Tolles patent (US 2,692,970): direction cosines, generating
//! functions and the printed roll and pitch tables.
//!
//! ```
//! use tolles_core::flight::attitude::Attitude;
//! use tolles_core::patent::{field_direction, patent_heading, roll_cosines};
//!
//! // A 10° right-wing-down roll heading 30° (clockwise) at dip 60°.
//! let (heading, roll, dip) = (30f64.to_radians(), 10f64.to_radians(), 60f64.to_radians());
//! let ours = field_direction(&Attitude { yaw: heading, pitch: 0.0, roll }, dip);
//! // The patent's equations 4 give (cos X, cos Y, cos Z) = (t, l, v) with its heading θp = −yaw.
//! let [cos_x, cos_y, cos_z] = roll_cosines(roll, patent_heading(heading), dip);
//! assert!((ours[1] - cos_x).abs() < 1e-15); // T = y
//! assert!((ours[0] - cos_y).abs() < 1e-15); // L = x
//! assert!((ours[2] - cos_z).abs() < 1e-15); // V = z
//! ```
//!
//! # Angles
//! Conventions are those of [`crate::model::conventions`]; the patent's own angles map to ours as
//! (section "The patent's angles" there, and the tests below):
//! - heading θp = −yaw (the patent counts counter-clockwise from magnetic north),
//! - roll ψ = roll (right wing down positive in both),
//! - pitch λ = −pitch (the patent's pitch is nose-down positive),
//! - cos X = t = B̂_y, cos Y = l = B̂_x, cos Z = v = B̂_z, the direction cosines of the earth
//!   field in the body frame (FRD).
//!
//! # Generating functions
//! A scalar magnetometer reads, to first order in the aircraft's field, `B̂·(P + I·B + E·dB/dt)`
//! with `B = H·ĉ`, `ĉ = (l, t, v)` ([`signal`]). Written as a sum over the 16 observable terms
//! ([`Term::OBSERVABLE`]) that is `Σ value × scale × g(ĉ, dĉ/dt)` plus the unobservable constant
//! `H·I[z][z]`, with `scale` = 1 for perm (nT), `H` for induced and eddy terms
//! ([`Term::generating`], [`Term::scale`]). Eddy term `ab` is `E[b][a]` (interpret's letters), so
//! its generating function is `c_b·dc_a/dt`.
//!
//! The patent's equations 6 and 7 are the small-angle, rate-proportional form of the same
//! thing with the opposite overall sign: its eddy coefficients are Lenz-signed,
//! `ab (patent) = −E[b][a]`. [`closed_form`] maps the printed tables to our terms, angles and
//! signs; [`printed_table`] keeps them as printed, with the misprints listed in
//! [`PrintedRow::misprint`].

mod analysis;
pub mod detect;
pub mod harmonics;
pub mod procedure;
// The printed tables are long data; they live in their own file but belong to this module's API.
mod tables;
mod terms;

pub use tables::{closed_form, printed_table, ClosedForm, ClosedHarmonics, PrintedRow, Provenance};
pub use terms::{EddyPatentTerms, InducedPatentTerms, PatentTerms, PermTerms};

use crate::flight::attitude::Attitude;
use crate::maneuvers::ManeuverKind;
use crate::model::interpret::AircraftField;
use serde::{Deserialize, Serialize};

/// A harmonic maneuver's axis, as in the patent's tables.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Maneuver {
    /// `roll = b·sin ωt` (right wing down positive).
    Roll,
    /// `pitch = a·sin ωt` (nose up positive).
    Pitch,
}

impl From<Maneuver> for ManeuverKind {
    fn from(maneuver: Maneuver) -> Self {
        match maneuver {
            Maneuver::Roll => ManeuverKind::Roll,
            Maneuver::Pitch => ManeuverKind::Pitch,
        }
    }
}

/// The patent's heading θp (rad) for our heading (rad, clockwise from magnetic north).
pub fn patent_heading(heading_rad: f64) -> f64 {
    -heading_rad
}

/// The patent's roll ψ (rad) for our roll (rad, right wing down positive): the same.
pub fn patent_roll(roll_rad: f64) -> f64 {
    roll_rad
}

/// The patent's pitch λ (rad) for our pitch (rad, nose up positive).
pub fn patent_pitch(pitch_rad: f64) -> f64 {
    -pitch_rad
}

/// The patent's signed maneuver amplitude (rad) for ours (rad).
pub fn patent_amplitude(maneuver: Maneuver, amplitude_rad: f64) -> f64 {
    match maneuver {
        Maneuver::Roll => patent_roll(amplitude_rad),
        Maneuver::Pitch => patent_pitch(amplitude_rad),
    }
}

/// The patent's equations 4: `[cos X, cos Y, cos Z]` for a roll ψ on heading θp at dip φ
/// (all in the patent's angles, radians).
pub fn roll_cosines(psi: f64, theta_p: f64, phi: f64) -> [f64; 3] {
    let (sp, cp) = phi.sin_cos();
    let (st, ct) = theta_p.sin_cos();
    let (sr, cr) = psi.sin_cos();
    [cp * st * cr + sp * sr, cp * ct, sp * cr - cp * st * sr]
}

/// The patent's equations 5: `[cos X, cos Y, cos Z]` for a pitch λ on heading θp at dip φ
/// (all in the patent's angles, radians).
pub fn pitch_cosines(lambda: f64, theta_p: f64, phi: f64) -> [f64; 3] {
    let (sp, cp) = phi.sin_cos();
    let (st, ct) = theta_p.sin_cos();
    let (sl, cl) = lambda.sin_cos();
    [cp * st, cp * ct * cl + sp * sl, sp * cl - cp * ct * sl]
}

/// Unit earth field in the body frame, `ĉ = (l, t, v)` along (x, y, z), for an attitude whose
/// yaw is measured from magnetic north (rad) and a dip (rad, positive down).
pub fn field_direction(attitude: &Attitude, dip_rad: f64) -> [f64; 3] {
    let (s, c) = dip_rad.sin_cos();
    attitude.to_body([c, 0.0, s])
}

/// `dĉ/dt` (1/s) for a pure roll (pitch 0) or pure pitch (roll 0) at angular rate `rate_rad_s`
/// (rad/s, in our sign), given the current direction `c`: the field turns opposite to the body.
pub fn direction_rate(maneuver: Maneuver, c: [f64; 3], rate_rad_s: f64) -> [f64; 3] {
    let [l, t, v] = c;
    match maneuver {
        Maneuver::Roll => [0.0, rate_rad_s * v, -rate_rad_s * t],
        Maneuver::Pitch => [-rate_rad_s * v, 0.0, rate_rad_s * l],
    }
}

/// Perm, induced or eddy-current.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Section {
    /// Permanent-field terms (nT).
    Perm,
    /// Induced terms (dimensionless).
    Induced,
    /// Eddy-current terms (s).
    Eddy,
}

impl Section {
    /// Unit of the section's term values: `"nT"` (perm), `""` (induced, dimensionless) or `"s"`
    /// (eddy).
    pub fn unit(self) -> &'static str {
        match self {
            Section::Perm => "nT",
            Section::Induced => "",
            Section::Eddy => "s",
        }
    }
}

/// A row of the patent's tables: a term (or sum, or difference) of the aircraft's field.
///
/// Letters as in [`crate::model::interpret`]: perm T, L, V (nT); induced `TT = I[y][y]`, `TL+LT =
/// I[x][y] + I[y][x]`, `VV−TT = I[z][z] − I[y][y]`, … (dimensionless); eddy `ab = E[b][a]` (s).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum Term {
    /// T: permanent field along y (nT).
    PermT,
    /// L: permanent field along x (nT).
    PermL,
    /// V: permanent field along z (nT).
    PermV,
    /// TT: `I[y][y]` (dimensionless; not observable alone).
    InducedTT,
    /// LL: `I[x][x]` (dimensionless; not observable alone).
    InducedLL,
    /// VV: `I[z][z]` (dimensionless; not observable alone).
    InducedVV,
    /// TL+LT: `I[x][y] + I[y][x]` (dimensionless).
    InducedTLLT,
    /// TV+VT: `I[y][z] + I[z][y]` (dimensionless).
    InducedTVVT,
    /// LV+VL: `I[x][z] + I[z][x]` (dimensionless).
    InducedLVVL,
    /// VV−TT: `I[z][z] − I[y][y]` (dimensionless).
    InducedVVTT,
    /// VV−LL: `I[z][z] − I[x][x]` (dimensionless).
    InducedVVLL,
    /// vv−tt: `E[z][z] − E[y][y]` (s).
    EddyVVTT,
    /// vv−ll: `E[z][z] − E[x][x]` (s).
    EddyVVLL,
    /// tl: `E[x][y]` (s).
    EddyTL,
    /// tv: `E[z][y]` (s).
    EddyTV,
    /// lt: `E[y][x]` (s).
    EddyLT,
    /// lv: `E[z][x]` (s).
    EddyLV,
    /// vl: `E[x][z]` (s).
    EddyVL,
    /// vt: `E[y][z]` (s).
    EddyVT,
}

const X: usize = 0;
const Y: usize = 1;
const Z: usize = 2;

impl Term {
    /// Every row, in table order (the individual TT, LL, VV too).
    pub const ALL: [Term; 19] = [
        Term::PermT,
        Term::PermL,
        Term::PermV,
        Term::InducedTT,
        Term::InducedLL,
        Term::InducedVV,
        Term::InducedTLLT,
        Term::InducedTVVT,
        Term::InducedLVVL,
        Term::InducedVVTT,
        Term::InducedVVLL,
        Term::EddyVVTT,
        Term::EddyVVLL,
        Term::EddyTL,
        Term::EddyTV,
        Term::EddyLT,
        Term::EddyLV,
        Term::EddyVL,
        Term::EddyVT,
    ];

    /// The 16 terms a scalar magnetometer can see (as in [`PatentTerms`]).
    pub const OBSERVABLE: [Term; 16] = [
        Term::PermT,
        Term::PermL,
        Term::PermV,
        Term::InducedVVTT,
        Term::InducedVVLL,
        Term::InducedTLLT,
        Term::InducedTVVT,
        Term::InducedLVVL,
        Term::EddyVVTT,
        Term::EddyVVLL,
        Term::EddyTL,
        Term::EddyTV,
        Term::EddyLT,
        Term::EddyLV,
        Term::EddyVL,
        Term::EddyVT,
    ];

    /// The patent's name (capitals for perm and induced, lower case for eddy).
    pub fn name(self) -> &'static str {
        match self {
            Term::PermT => "T",
            Term::PermL => "L",
            Term::PermV => "V",
            Term::InducedTT => "TT",
            Term::InducedLL => "LL",
            Term::InducedVV => "VV",
            Term::InducedTLLT => "TL+LT",
            Term::InducedTVVT => "TV+VT",
            Term::InducedLVVL => "LV+VL",
            Term::InducedVVTT => "VV-TT",
            Term::InducedVVLL => "VV-LL",
            Term::EddyVVTT => "vv-tt",
            Term::EddyVVLL => "vv-ll",
            Term::EddyTL => "tl",
            Term::EddyTV => "tv",
            Term::EddyLT => "lt",
            Term::EddyLV => "lv",
            Term::EddyVL => "vl",
            Term::EddyVT => "vt",
        }
    }

    /// The term named `name` as [`Term::name`] spells it (`"T"`, `"VV-TT"`, `"vl"`, …).
    pub fn from_name(name: &str) -> Option<Term> {
        Term::ALL.into_iter().find(|t| t.name() == name)
    }

    /// Position in [`Term::OBSERVABLE`]; `None` for TT, LL and VV alone, which a scalar
    /// magnetometer cannot see.
    pub fn observable_index(self) -> Option<usize> {
        Term::OBSERVABLE.iter().position(|&t| t == self)
    }

    /// Unit of the term's value: `"nT"` (perm), `""` (induced, dimensionless) or `"s"` (eddy).
    pub fn unit(self) -> &'static str {
        self.section().unit()
    }

    /// Perm, induced or eddy.
    pub fn section(self) -> Section {
        match self {
            Term::PermT | Term::PermL | Term::PermV => Section::Perm,
            Term::InducedTT
            | Term::InducedLL
            | Term::InducedVV
            | Term::InducedTLLT
            | Term::InducedTVVT
            | Term::InducedLVVL
            | Term::InducedVVTT
            | Term::InducedVVLL => Section::Induced,
            _ => Section::Eddy,
        }
    }

    /// The generating function in our notation: `l, t, v` are the body-frame direction cosines
    /// of the earth field (x, y, z), a dot is d/dt.
    pub fn formula(self) -> &'static str {
        match self {
            Term::PermT => "t",
            Term::PermL => "l",
            Term::PermV => "v",
            Term::InducedTT => "t²",
            Term::InducedLL => "l²",
            Term::InducedVV => "v²",
            Term::InducedTLLT => "t·l",
            Term::InducedTVVT => "t·v",
            Term::InducedLVVL => "l·v",
            Term::InducedVVTT => "−t²",
            Term::InducedVVLL => "−l²",
            Term::EddyVVTT => "−t·ṫ",
            Term::EddyVVLL => "−l·l̇",
            Term::EddyTL => "l·ṫ",
            Term::EddyTV => "v·ṫ",
            Term::EddyLT => "t·l̇",
            Term::EddyLV => "v·l̇",
            Term::EddyVL => "l·v̇",
            Term::EddyVT => "t·v̇",
        }
    }

    /// The generating function g at direction `c = (l, t, v)` and its rate `c_dot` (1/s);
    /// eddy terms are in 1/s, the others dimensionless.
    pub fn generating(self, c: [f64; 3], c_dot: [f64; 3]) -> f64 {
        let (l, t, v) = (c[X], c[Y], c[Z]);
        // Eddy 'ab' is E[b][a]: the field along b times the change along a.
        let eddy = |a: usize, b: usize| c[b] * c_dot[a];
        match self {
            Term::PermT => t,
            Term::PermL => l,
            Term::PermV => v,
            Term::InducedTT => t * t,
            Term::InducedLL => l * l,
            Term::InducedVV => v * v,
            Term::InducedTLLT => t * l,
            Term::InducedTVVT => t * v,
            Term::InducedLVVL => l * v,
            Term::InducedVVTT => -t * t,
            Term::InducedVVLL => -l * l,
            Term::EddyVVTT => -eddy(Y, Y),
            Term::EddyVVLL => -eddy(X, X),
            Term::EddyTL => eddy(Y, X),
            Term::EddyTV => eddy(Y, Z),
            Term::EddyLT => eddy(X, Y),
            Term::EddyLV => eddy(X, Z),
            Term::EddyVL => eddy(Z, X),
            Term::EddyVT => eddy(Z, Y),
        }
    }

    /// The factor between `value × g` and nT: 1 for perm, the earth field `h_nt` (nT) otherwise.
    pub fn scale(self, h_nt: f64) -> f64 {
        match self.section() {
            Section::Perm => 1.0,
            Section::Induced | Section::Eddy => h_nt,
        }
    }

    /// This term's value for an aircraft: nT (perm), dimensionless (induced), s (eddy).
    pub fn value(self, field: &AircraftField) -> f64 {
        let (p, i, e) = (&field.permanent_nt, &field.induced, &field.eddy_s);
        match self {
            Term::PermT => p[Y],
            Term::PermL => p[X],
            Term::PermV => p[Z],
            Term::InducedTT => i[Y][Y],
            Term::InducedLL => i[X][X],
            Term::InducedVV => i[Z][Z],
            Term::InducedTLLT => i[X][Y] + i[Y][X],
            Term::InducedTVVT => i[Y][Z] + i[Z][Y],
            Term::InducedLVVL => i[X][Z] + i[Z][X],
            Term::InducedVVTT => i[Z][Z] - i[Y][Y],
            Term::InducedVVLL => i[Z][Z] - i[X][X],
            Term::EddyVVTT => e[Z][Z] - e[Y][Y],
            Term::EddyVVLL => e[Z][Z] - e[X][X],
            Term::EddyTL => e[X][Y],
            Term::EddyTV => e[Z][Y],
            Term::EddyLT => e[Y][X],
            Term::EddyLV => e[Z][X],
            Term::EddyVL => e[X][Z],
            Term::EddyVT => e[Y][Z],
        }
    }
}

/// What an aircraft adds to a scalar magnetometer, to first order: `B̂·(P + I·B + E·dB/dt)`
/// (nT), with `B = h_nt·c` for the unit direction `c` and its rate `c_dot` (1/s).
pub fn signal(field: &AircraftField, h_nt: f64, c: [f64; 3], c_dot: [f64; 3]) -> f64 {
    (0..3)
        .map(|i| {
            let row: f64 = (0..3)
                .map(|j| field.induced[i][j] * c[j] + field.eddy_s[i][j] * c_dot[j])
                .sum();
            c[i] * (field.permanent_nt[i] + h_nt * row)
        })
        .sum()
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn close3(a: [f64; 3], b: [f64; 3], tol: f64) -> bool {
        a.iter().zip(&b).all(|(u, v)| (u - v).abs() <= tol)
    }

    /// Patent `[cos X, cos Y, cos Z]` as our `[l, t, v]`.
    fn as_body(p: [f64; 3]) -> [f64; 3] {
        [p[1], p[0], p[2]]
    }

    proptest! {
        #[test]
        fn equations_4_with_the_mapping_are_to_body(
            heading in -360.0f64..360.0, roll in -90.0f64..90.0, dip in -90.0f64..90.0
        ) {
            let (h, r, d) = (heading.to_radians(), roll.to_radians(), dip.to_radians());
            let ours = field_direction(&Attitude { yaw: h, pitch: 0.0, roll: r }, d);
            let patent = roll_cosines(patent_roll(r), patent_heading(h), d);
            prop_assert!(close3(ours, as_body(patent), 1e-14));
        }

        #[test]
        fn equations_5_with_the_mapping_are_to_body(
            heading in -360.0f64..360.0, pitch in -90.0f64..90.0, dip in -90.0f64..90.0
        ) {
            let (h, p, d) = (heading.to_radians(), pitch.to_radians(), dip.to_radians());
            let ours = field_direction(&Attitude { yaw: h, pitch: p, roll: 0.0 }, d);
            let patent = pitch_cosines(patent_pitch(p), patent_heading(h), d);
            prop_assert!(close3(ours, as_body(patent), 1e-14));
        }

        #[test]
        fn the_16_terms_add_up_to_the_magnetometer_signal(
            seed in any::<u64>(), heading in 0.0f64..360.0, angle in -40.0f64..40.0,
            rate in -0.5f64..0.5, dip in -80.0f64..80.0, pitch_not_roll in any::<bool>()
        ) {
            let field = pseudo_random_field(seed);
            let h = 50_000.0;
            let maneuver = if pitch_not_roll { Maneuver::Pitch } else { Maneuver::Roll };
            let attitude = match maneuver {
                Maneuver::Roll => Attitude::from_degrees(heading, 0.0, angle),
                Maneuver::Pitch => Attitude::from_degrees(heading, angle, 0.0),
            };
            let c = field_direction(&attitude, dip.to_radians());
            let c_dot = direction_rate(maneuver, c, rate);
            let sum: f64 = Term::OBSERVABLE
                .iter()
                .map(|t| t.value(&field) * t.scale(h) * t.generating(c, c_dot))
                .sum();
            // The unobservable part is the constant H·I[z][z].
            let expected = signal(&field, h, c, c_dot) - h * field.induced[2][2];
            prop_assert!((sum - expected).abs() < 1e-9 * (1.0 + expected.abs()));
        }
    }

    fn pseudo_random_field(seed: u64) -> AircraftField {
        let mut state = seed;
        let mut next = || {
            state = state
                .wrapping_mul(6_364_136_223_846_793_005)
                .wrapping_add(1_442_695_040_888_963_407);
            (state >> 11) as f64 / (1u64 << 53) as f64 - 0.5
        };
        let mut field = AircraftField::default();
        for i in 0..3 {
            field.permanent_nt[i] = 20.0 * next();
            for j in 0..3 {
                field.induced[i][j] = 1e-3 * next();
                field.eddy_s[i][j] = 1e-3 * next();
            }
        }
        field
    }

    #[test]
    fn direction_rate_is_the_derivative_of_the_direction() {
        let (heading, dip, step) = (0.7, 1.1, 1e-6);
        for maneuver in [Maneuver::Roll, Maneuver::Pitch] {
            let at = |angle: f64| {
                let attitude = match maneuver {
                    Maneuver::Roll => Attitude {
                        yaw: heading,
                        pitch: 0.0,
                        roll: angle,
                    },
                    Maneuver::Pitch => Attitude {
                        yaw: heading,
                        pitch: angle,
                        roll: 0.0,
                    },
                };
                field_direction(&attitude, dip)
            };
            let (ahead, behind) = (at(0.3 + step), at(0.3 - step));
            let numeric = [0, 1, 2].map(|i| (ahead[i] - behind[i]) / (2.0 * step));
            let analytic = direction_rate(maneuver, at(0.3), 1.0);
            assert!(close3(numeric, analytic, 1e-9), "{maneuver:?}");
        }
    }

    /// Equation 6 in the patent's angles, with the vl function as in the table (cos Y cos X).
    fn equation_6(field: &AircraftField, psi: f64, theta_p: f64, phi: f64, psi_dot: f64) -> f64 {
        let [cx, cy, cz] = roll_cosines(psi, theta_p, phi);
        let e = field.patent_terms().eddy_s; // our E[b][a] under the patent's letters
        psi_dot
            * (e.vv_tt * cz * cx + e.vt * cx * cx - e.tl * cy * cz + e.vl * cy * cx
                - e.tv * cz * cz)
    }

    /// Equation 7 in the patent's angles.
    fn equation_7(field: &AircraftField, lambda: f64, theta_p: f64, phi: f64, l_dot: f64) -> f64 {
        let [cx, cy, cz] = pitch_cosines(lambda, theta_p, phi);
        let e = field.patent_terms().eddy_s;
        l_dot
            * (-e.lt * cx * cz + e.vt * cx * cy + e.vv_ll * cy * cz + e.vl * cy * cy
                - e.lv * cz * cz)
    }

    fn eddy_only(seed: u64) -> AircraftField {
        AircraftField {
            eddy_s: pseudo_random_field(seed).eddy_s,
            ..AircraftField::default()
        }
    }

    #[test]
    fn patent_eddy_equations_carry_the_opposite_sign_to_e() {
        // Equations 6 and 7 equal −B̂·E·dB̂/dt: the patent's eddy coefficients are −E[b][a].
        let field = eddy_only(11);
        let (heading, dip, angle, rate) = (0.4, 1.0, 0.2, 0.3);
        let c = field_direction(
            &Attitude {
                yaw: heading,
                pitch: 0.0,
                roll: angle,
            },
            dip,
        );
        let ours = signal(&field, 1.0, c, direction_rate(Maneuver::Roll, c, rate));
        let patent = equation_6(
            &field,
            patent_roll(angle),
            patent_heading(heading),
            dip,
            rate,
        );
        assert!(ours.abs() > 1e-5 && (ours + patent).abs() < 1e-15);

        let c = field_direction(
            &Attitude {
                yaw: heading,
                pitch: angle,
                roll: 0.0,
            },
            dip,
        );
        let ours = signal(&field, 1.0, c, direction_rate(Maneuver::Pitch, c, rate));
        // λ = −pitch, so dλ/dt = −rate.
        let patent = equation_7(
            &field,
            patent_pitch(angle),
            patent_heading(heading),
            dip,
            -rate,
        );
        assert!(ours.abs() > 1e-5 && (ours + patent).abs() < 1e-15);
    }

    #[test]
    fn equation_6_vl_function_is_cos_y_cos_x_not_cos_y_cos_z() {
        // Equation 6 prints "+ vl cos Y cos Z"; its table row says cos Y cos X, and so does the
        // mathematics.
        let mut field = AircraftField::default();
        field.eddy_s[0][2] = 1e-3; // vl = E[x][z]
        let (heading, dip, angle, rate) = (0.4, 1.0, 0.2, 0.3);
        let c = field_direction(
            &Attitude {
                yaw: heading,
                pitch: 0.0,
                roll: angle,
            },
            dip,
        );
        let ours = signal(&field, 1.0, c, direction_rate(Maneuver::Roll, c, rate));
        let [cx, cy, cz] = roll_cosines(angle, patent_heading(heading), dip);
        let as_printed = -rate * 1e-3 * cy * cz;
        let as_tabled = -rate * 1e-3 * cy * cx;
        assert!((ours - as_tabled).abs() < 1e-15);
        assert!((ours - as_printed).abs() > 1e-5);
    }

    #[test]
    fn names_units_and_observable_positions_agree() {
        for term in Term::ALL {
            assert_eq!(Term::from_name(term.name()), Some(term));
        }
        assert_eq!(Term::from_name("X"), None);
        let units: Vec<&str> = Term::OBSERVABLE.iter().map(|t| t.unit()).collect();
        assert_eq!(units, [["nT"; 3].as_slice(), &[""; 5], &["s"; 8]].concat());
        for (k, term) in Term::OBSERVABLE.iter().enumerate() {
            assert_eq!(term.observable_index(), Some(k));
        }
        assert_eq!(Term::InducedTT.observable_index(), None);
    }

    #[test]
    fn terms_are_found_by_name_and_carry_their_unit() {
        for term in Term::ALL {
            assert_eq!(Term::from_name(term.name()), Some(term));
        }
        assert_eq!(Term::from_name("X"), None);
        let units: Vec<&str> = ["T", "VV-TT", "tl"]
            .iter()
            .map(|n| Term::from_name(n).unwrap().unit())
            .collect();
        assert_eq!(units, ["nT", "", "s"]);
    }
}
