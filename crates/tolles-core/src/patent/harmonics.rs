//! The patent's roll and pitch tables, computed: Fourier coefficients of every term's exact
//! generating function over one period of a harmonic maneuver.
//!
//! ```
//! use tolles_core::patent::harmonics::{HarmonicManeuver, HarmonicTable};
//! use tolles_core::patent::{Maneuver, Term};
//!
//! // 15° rolls heading north at dip 60°.
//! let maneuver = HarmonicManeuver::new(Maneuver::Roll, 15.0, 0.0, 60.0);
//! let table = HarmonicTable::compute(&maneuver).unwrap();
//! let t = table.row(Term::PermT).unwrap();
//! // The patent: T gives b sin φ at the fundamental (b in radians), up to O(b³).
//! let b = 15f64.to_radians();
//! assert!((t.fundamental - b * 60f64.to_radians().sin()).abs() < b.powi(3));
//! assert!((t.fundamental - t.closed_fundamental).abs() < b.powi(3));
//! ```
//!
//! For `angle = amplitude·sin ωt` on a fixed heading, a term's generating function g (see
//! [`crate::patent`]) is periodic; perm and induced rows give `g = k + A sin ωt + B cos 2ωt + …`,
//! eddy rows `g = A ω cos ωt + B ω sin 2ωt + …`. A and B are computed here from the exact g
//! (no small-angle expansion) by the rectangle rule over one period, which is exact for the
//! harmonics below half the number of points. The magnetometer's signal is
//! `Σ value × scale × g` (perm in nT; induced and eddy times the earth field H in nT).

use crate::flight::attitude::Attitude;
use crate::patent::{
    closed_form, direction_rate, field_direction, Maneuver, Provenance, Section, Term,
};
use serde::{Deserialize, Serialize};
use std::f64::consts::PI;
use thiserror::Error;

/// Points per period of the Fourier sums.
const POINTS: usize = 4096;

/// A harmonic maneuver: `angle = amplitude·sin ωt` about one axis on a fixed heading.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct HarmonicManeuver {
    /// Roll or pitch.
    pub maneuver: Maneuver,
    /// Amplitude (degrees, our sign: right wing down, nose up).
    pub amplitude_deg: f64,
    /// Heading (degrees, clockwise from magnetic north).
    pub heading_deg: f64,
    /// Dip of the earth field (degrees, positive down).
    pub dip_deg: f64,
}

impl HarmonicManeuver {
    /// A maneuver from degrees: amplitude, heading (clockwise from magnetic north), dip.
    pub fn new(maneuver: Maneuver, amplitude_deg: f64, heading_deg: f64, dip_deg: f64) -> Self {
        Self {
            maneuver,
            amplitude_deg,
            heading_deg,
            dip_deg,
        }
    }

    /// The attitude at phase `ωt` (rad).
    fn attitude(&self, phase: f64) -> Attitude {
        let angle = self.amplitude_deg.to_radians() * phase.sin();
        let yaw = self.heading_deg.to_radians();
        match self.maneuver {
            Maneuver::Roll => Attitude {
                yaw,
                pitch: 0.0,
                roll: angle,
            },
            Maneuver::Pitch => Attitude {
                yaw,
                pitch: angle,
                roll: 0.0,
            },
        }
    }

    fn check(&self) -> Result<(), TableError> {
        let bad = |what: &'static str, value: f64| TableError::OutOfRange { what, value };
        if !(self.amplitude_deg.is_finite()
            && self.amplitude_deg > 0.0
            && self.amplitude_deg <= 90.0)
        {
            return Err(bad("amplitude (degrees, 0 < a ≤ 90)", self.amplitude_deg));
        }
        if !self.heading_deg.is_finite() {
            return Err(bad("heading (degrees)", self.heading_deg));
        }
        if !(self.dip_deg.is_finite() && self.dip_deg.abs() <= 90.0) {
            return Err(bad("dip (degrees, −90 ≤ dip ≤ 90)", self.dip_deg));
        }
        Ok(())
    }
}

/// Why a table cannot be computed.
#[derive(Debug, Error, PartialEq)]
pub enum TableError {
    /// A parameter lies outside its range.
    #[error("{what} out of range: {value}")]
    OutOfRange {
        /// The parameter, with its unit and range.
        what: &'static str,
        /// The value given (in the unit `what` names).
        value: f64,
    },
}

/// Fundamental and second-harmonic coefficients of every term's generating function for ω = 1,
/// in [`Term::ALL`] order: `(A, B)` of `A sin ωt + B cos 2ωt` (perm, induced) or
/// `A ω cos ωt + B ω sin 2ωt` (eddy).
pub fn harmonics(maneuver: &HarmonicManeuver) -> [(f64, f64); 19] {
    let dip = maneuver.dip_deg.to_radians();
    let amplitude = maneuver.amplitude_deg.to_radians();
    let mut sums = [(0.0, 0.0); 19];
    for k in 0..POINTS {
        let phase = 2.0 * PI * k as f64 / POINTS as f64;
        let c = field_direction(&maneuver.attitude(phase), dip);
        // d(angle)/dt for ω = 1.
        let c_dot = direction_rate(maneuver.maneuver, c, amplitude * phase.cos());
        for (sum, term) in sums.iter_mut().zip(Term::ALL) {
            let g = term.generating(c, c_dot);
            let (fundamental, second) = match term.section() {
                Section::Eddy => (phase.cos(), (2.0 * phase).sin()),
                Section::Perm | Section::Induced => (phase.sin(), (2.0 * phase).cos()),
            };
            sum.0 += g * fundamental;
            sum.1 += g * second;
        }
    }
    sums.map(|(a, b)| (2.0 * a / POINTS as f64, 2.0 * b / POINTS as f64))
}

/// One row of a computed table.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TableRow {
    /// The term.
    pub term: Term,
    /// The patent's name of the term (our letters: eddy `ab = E[b][a]`).
    pub name: String,
    /// Perm, induced or eddy.
    pub section: Section,
    /// The generating function in our notation (`l, t, v` body direction cosines).
    pub generating_function: String,
    /// Computed fundamental: coefficient of `sin ωt` (perm, induced) or `ω cos ωt` (eddy).
    pub fundamental: f64,
    /// Computed second harmonic: coefficient of `cos 2ωt` or `ω sin 2ωt`.
    pub second_harmonic: f64,
    /// The patent's closed form of the fundamental, mapped to our conventions.
    pub closed_fundamental: f64,
    /// The patent's closed form of the second harmonic, mapped to our conventions.
    pub closed_second_harmonic: f64,
    /// Where the closed form comes from: printed, a corrected misprint, or not printed.
    pub printed: Provenance,
}

/// A computed roll or pitch table.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct HarmonicTable {
    /// The maneuver.
    #[serde(flatten)]
    pub maneuver: HarmonicManeuver,
    /// All rows, in [`Term::ALL`] order.
    pub rows: Vec<TableRow>,
}

impl HarmonicTable {
    /// Computes every row, and the patent's closed form beside it.
    pub fn compute(maneuver: &HarmonicManeuver) -> Result<Self, TableError> {
        maneuver.check()?;
        let (amplitude, heading, dip) = (
            maneuver.amplitude_deg.to_radians(),
            maneuver.heading_deg.to_radians(),
            maneuver.dip_deg.to_radians(),
        );
        let rows = Term::ALL
            .iter()
            .zip(harmonics(maneuver))
            .map(|(&term, (fundamental, second_harmonic))| {
                let closed = closed_form(maneuver.maneuver, term, amplitude, heading, dip);
                TableRow {
                    term,
                    name: term.name().into(),
                    section: term.section(),
                    generating_function: term.formula().into(),
                    fundamental,
                    second_harmonic,
                    closed_fundamental: closed.fundamental,
                    closed_second_harmonic: closed.second_harmonic,
                    printed: closed.provenance,
                }
            })
            .collect();
        Ok(Self {
            maneuver: *maneuver,
            rows,
        })
    }

    /// The row of `term`.
    pub fn row(&self, term: Term) -> Option<&TableRow> {
        self.rows.iter().find(|r| r.term == term)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::patent::{patent_amplitude, patent_heading, printed_table, PrintedRow};

    fn table(maneuver: Maneuver, amplitude: f64, heading: f64, dip: f64) -> HarmonicTable {
        HarmonicTable::compute(&HarmonicManeuver::new(maneuver, amplitude, heading, dip)).unwrap()
    }

    const HEADINGS: [f64; 8] = [0.0, 30.0, 45.0, 90.0, 135.0, 200.0, 270.0, 315.0];
    const DIPS: [f64; 4] = [30.0, 45.0, 60.0, 75.0];
    const AMPLITUDES: [f64; 3] = [5.0, 10.0, 15.0];

    /// |computed − closed| ≤ C·b³ for both harmonics of every row.
    fn assert_closed_forms_hold(maneuver: Maneuver) {
        // The largest cube coefficient is sin 2φ·sin θ / 2 ≤ 1/2 (TT and VV in rolls).
        const C: f64 = 0.6;
        for heading in HEADINGS {
            for dip in DIPS {
                for amplitude in AMPLITUDES {
                    let b3 = amplitude.to_radians().powi(3);
                    for row in table(maneuver, amplitude, heading, dip).rows {
                        let e1 = (row.fundamental - row.closed_fundamental).abs();
                        let e2 = (row.second_harmonic - row.closed_second_harmonic).abs();
                        assert!(
                            e1 <= C * b3 && e2 <= C * b3,
                            "{maneuver:?} {} heading {heading} dip {dip} amplitude {amplitude}: \
                             errors {e1:e} {e2:e} > {:e}",
                            row.name,
                            C * b3
                        );
                    }
                }
            }
        }
    }

    #[test]
    fn roll_table_matches_the_patent_to_third_order() {
        assert_closed_forms_hold(Maneuver::Roll);
    }

    #[test]
    fn pitch_table_matches_the_patent_to_third_order() {
        assert_closed_forms_hold(Maneuver::Pitch);
    }

    #[test]
    fn closed_form_errors_scale_as_the_cube_and_fourth_power() {
        // Halving the amplitude divides the fundamental's error by 8 and the second
        // harmonic's by 16: the closed forms are exact to leading order, no better.
        let (heading, dip) = (37.0, 58.0);
        for maneuver in [Maneuver::Roll, Maneuver::Pitch] {
            let (big, small) = (
                table(maneuver, 10.0, heading, dip),
                table(maneuver, 5.0, heading, dip),
            );
            let mut checked = 0;
            for (b, s) in big.rows.iter().zip(&small.rows) {
                let e1 = |r: &TableRow| r.fundamental - r.closed_fundamental;
                let e2 = |r: &TableRow| r.second_harmonic - r.closed_second_harmonic;
                if e1(b).abs() > 1e-9 {
                    let ratio = e1(b) / e1(s);
                    assert!((7.5..8.5).contains(&ratio), "{} {ratio}", b.name);
                    checked += 1;
                }
                if e2(b).abs() > 1e-9 {
                    let ratio = e2(b) / e2(s);
                    assert!((15.0..17.0).contains(&ratio), "{} {ratio}", b.name);
                    checked += 1;
                }
            }
            assert!(
                checked >= 20,
                "{maneuver:?}: only {checked} rows with an error"
            );
        }
    }

    /// The printed row's closed form in our conventions (eddy sign flipped).
    fn printed_in_ours(
        row: &PrintedRow,
        amplitude_deg: f64,
        heading_deg: f64,
        dip_deg: f64,
    ) -> (f64, f64) {
        let a = patent_amplitude(row.maneuver, amplitude_deg.to_radians());
        let t = patent_heading(heading_deg.to_radians());
        let f = dip_deg.to_radians();
        let sign = if row.term.section() == Section::Eddy {
            -1.0
        } else {
            1.0
        };
        (
            sign * (row.fundamental)(a, t, f),
            sign * (row.second)(a, t, f),
        )
    }

    fn printed_row(maneuver: Maneuver, name: &str) -> &'static PrintedRow {
        printed_table(maneuver)
            .iter()
            .find(|r| r.printed_name == name)
            .unwrap()
    }

    /// Small amplitude, so the O(b³) remainder is far below the disagreements tested.
    const SMALL: f64 = 2.0;

    #[test]
    fn printed_pitch_eddy_row_tl_is_lt() {
        let t = table(Maneuver::Pitch, SMALL, 30.0, 60.0);
        let printed = printed_in_ours(printed_row(Maneuver::Pitch, "tl"), SMALL, 30.0, 60.0);
        let (lt, tl) = (t.row(Term::EddyLT).unwrap(), t.row(Term::EddyTL).unwrap());
        let tol = 1e-5;
        assert!((printed.0 - lt.fundamental).abs() < tol);
        assert!((printed.1 - lt.second_harmonic).abs() < tol);
        // tl itself gives nothing in a pitch.
        assert_eq!(
            (
                tl.fundamental.abs() < 1e-15,
                tl.second_harmonic.abs() < 1e-15
            ),
            (true, true)
        );
        assert!((printed.0 - tl.fundamental).abs() > 100.0 * tol);
    }

    #[test]
    fn printed_pitch_eddy_row_vv_minus_tl_is_vv_minus_ll() {
        let t = table(Maneuver::Pitch, SMALL, 30.0, 60.0);
        let printed = printed_in_ours(printed_row(Maneuver::Pitch, "vv-tl"), SMALL, 30.0, 60.0);
        let vv_ll = t.row(Term::EddyVVLL).unwrap();
        let vv_tt = t.row(Term::EddyVVTT).unwrap();
        let tol = 1e-5;
        assert!((printed.0 - vv_ll.fundamental).abs() < tol);
        assert!((printed.1 - vv_ll.second_harmonic).abs() < tol);
        assert!(
            vv_tt.fundamental.abs() < 1e-15 && (printed.0 - vv_tt.fundamental).abs() > 100.0 * tol
        );
        assert!(matches!(vv_ll.printed, Provenance::Misprint { .. }));
    }

    #[test]
    fn printed_roll_induced_tl_lt_second_harmonic_is_sin_2theta_not_sin_squared() {
        // Heading 30°: sin²θ = 0.25 and sin 2θ = 0.87 tell the two apart.
        let (amplitude, heading, dip) = (SMALL, 30.0, 60.0);
        let t = table(Maneuver::Roll, amplitude, heading, dip);
        let row = printed_row(Maneuver::Roll, "TL+LT");
        let printed = printed_in_ours(row, amplitude, heading, dip);
        let computed = t.row(Term::InducedTLLT).unwrap();
        let b2 = amplitude.to_radians().powi(2);
        assert!((printed.0 - computed.fundamental).abs() < 1e-5); // fundamental is right
        assert!((printed.1 - computed.second_harmonic).abs() > 0.01 * b2);
        assert!((computed.closed_second_harmonic - computed.second_harmonic).abs() < 1e-7);
        assert!(row.misprint.is_some());
    }

    #[test]
    fn only_the_known_misprints_are_flagged() {
        let flagged: Vec<(Maneuver, &str)> = [Maneuver::Roll, Maneuver::Pitch]
            .iter()
            .flat_map(|&m| printed_table(m).iter().map(move |r| (m, r)))
            .filter(|(_, r)| r.misprint.is_some())
            .map(|(m, r)| (m, r.printed_name))
            .collect();
        assert_eq!(
            flagged,
            [
                (Maneuver::Roll, "TL+LT"),
                (Maneuver::Pitch, "tl"),
                (Maneuver::Pitch, "vv-tl")
            ]
        );
    }

    #[test]
    fn every_other_printed_row_is_right_as_printed() {
        // As printed (no correction), in our conventions, to O(b³) at a small amplitude.
        for maneuver in [Maneuver::Roll, Maneuver::Pitch] {
            for heading in HEADINGS {
                let t = table(maneuver, SMALL, heading, 55.0);
                for row in printed_table(maneuver)
                    .iter()
                    .filter(|r| r.misprint.is_none())
                {
                    let printed = printed_in_ours(row, SMALL, heading, 55.0);
                    let computed = t.row(row.term).unwrap();
                    let tol = 0.6 * SMALL.to_radians().powi(3);
                    assert!(
                        (printed.0 - computed.fundamental).abs() < tol
                            && (printed.1 - computed.second_harmonic).abs() < tol,
                        "{maneuver:?} {} at heading {heading}",
                        row.printed_name
                    );
                }
            }
        }
    }

    #[test]
    fn rows_whose_function_is_constant_are_exactly_zero() {
        for (maneuver, terms) in [
            (
                Maneuver::Roll,
                [
                    Term::PermL,
                    Term::InducedLL,
                    Term::InducedVVLL,
                    Term::EddyLT,
                    Term::EddyLV,
                    Term::EddyVVLL,
                ],
            ),
            (
                Maneuver::Pitch,
                [
                    Term::PermT,
                    Term::InducedTT,
                    Term::InducedVVTT,
                    Term::EddyTL,
                    Term::EddyTV,
                    Term::EddyVVTT,
                ],
            ),
        ] {
            let t = table(maneuver, 30.0, 123.0, 64.0);
            for term in terms {
                let row = t.row(term).unwrap();
                assert!(row.fundamental.abs() < 1e-15 && row.second_harmonic.abs() < 1e-15);
            }
        }
    }

    #[test]
    fn out_of_range_input_is_an_error() {
        for (a, h, d) in [(0.0, 0.0, 60.0), (10.0, f64::NAN, 60.0), (10.0, 0.0, 91.0)] {
            let m = HarmonicManeuver::new(Maneuver::Roll, a, h, d);
            assert!(HarmonicTable::compute(&m).is_err());
        }
    }
}
