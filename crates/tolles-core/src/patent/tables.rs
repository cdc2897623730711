//! The patent's printed roll and pitch tables, as printed (misprints included and listed) and as
//! closed forms in our conventions.

use super::{patent_amplitude, patent_heading, Maneuver, Section, Term};
use serde::{Deserialize, Serialize};

/// A closed form in the patent's own angles: `(amplitude, θp, φ)` in radians, amplitude with
/// the patent's sign (b for rolls, a for pitches).
pub type ClosedForm = fn(f64, f64, f64) -> f64;

/// A row of the patent's printed roll and pitch tables.
#[derive(Debug, Clone, Copy)]
pub struct PrintedRow {
    /// The table it is in.
    pub maneuver: Maneuver,
    /// The name as printed.
    pub printed_name: &'static str,
    /// The term the mathematics says the row is.
    pub term: Term,
    /// The generating function column as printed (without the sign of equations 6 and 7).
    pub printed_function: &'static str,
    /// The fundamental as printed (text).
    pub printed_fundamental: &'static str,
    /// The second harmonic as printed (text).
    pub printed_second: &'static str,
    /// The fundamental as printed: coefficient of `sin ωt` (perm, induced) or `ω cos ωt` (eddy).
    pub fundamental: ClosedForm,
    /// The second harmonic as printed: coefficient of `cos 2ωt` or `ω sin 2ωt`.
    pub second: ClosedForm,
    /// The fundamental the mathematics gives (same as printed unless a misprint says otherwise).
    pub corrected_fundamental: ClosedForm,
    /// The second harmonic the mathematics gives.
    pub corrected_second: ClosedForm,
    /// What is wrong with the print, if anything.
    pub misprint: Option<&'static str>,
}

fn s2(x: f64) -> f64 {
    x.sin().powi(2)
}
fn c2(x: f64) -> f64 {
    x.cos().powi(2)
}

macro_rules! row {
    ($m:ident, $name:literal, $term:ident, $g:literal, $ft:literal, $f:expr, $st:literal, $s:expr) => {
        PrintedRow {
            maneuver: Maneuver::$m,
            printed_name: $name,
            term: Term::$term,
            printed_function: $g,
            printed_fundamental: $ft,
            printed_second: $st,
            fundamental: $f,
            second: $s,
            corrected_fundamental: $f,
            corrected_second: $s,
            misprint: None,
        }
    };
}

/// The printed roll table (b = roll amplitude, θ the patent's heading, φ the dip).
static ROLL_TABLE: [PrintedRow; 12] = [
    row!(
        Roll,
        "T",
        PermT,
        "cos X",
        "b sin φ",
        |b, _t, f| b * f.sin(),
        "b²/4 cos φ sin θ",
        |b, t, f| b * b / 4.0 * f.cos() * t.sin()
    ),
    row!(
        Roll,
        "V",
        PermV,
        "cos Z",
        "−b cos φ sin θ",
        |b, t, f| -b * f.cos() * t.sin(),
        "b²/4 sin φ",
        |b, _t, f| b * b / 4.0 * f.sin()
    ),
    row!(
        Roll,
        "TT",
        InducedTT,
        "cos² X",
        "b sin 2φ sin θ",
        |b, t, f| b * (2.0 * f).sin() * t.sin(),
        "b²/2 (cos²φ sin²θ − sin²φ)",
        |b, t, f| b * b / 2.0 * (c2(f) * s2(t) - s2(f))
    ),
    row!(
        Roll,
        "VV",
        InducedVV,
        "cos² Z",
        "−b sin 2φ sin θ",
        |b, t, f| -b * (2.0 * f).sin() * t.sin(),
        "−b²/2 (cos²φ sin²θ − sin²φ)",
        |b, t, f| -b * b / 2.0 * (c2(f) * s2(t) - s2(f))
    ),
    PrintedRow {
        misprint: Some(
            "second harmonic printed b²/8 cos²φ sin²θ; the mathematics gives b²/8 cos²φ sin 2θ",
        ),
        corrected_second: |b, t, f| b * b / 8.0 * c2(f) * (2.0 * t).sin(),
        ..row!(
            Roll,
            "TL+LT",
            InducedTLLT,
            "cos X cos Y",
            "b/2 sin 2φ cos θ",
            |b, t, f| b / 2.0 * (2.0 * f).sin() * t.cos(),
            "b²/8 cos²φ sin²θ",
            |b, t, f| b * b / 8.0 * c2(f) * s2(t)
        )
    },
    row!(
        Roll,
        "TV+VT",
        InducedTVVT,
        "cos X cos Z",
        "−b (cos²φ sin²θ − sin²φ)",
        |b, t, f| -b * (c2(f) * s2(t) - s2(f)),
        "b²/2 sin 2φ sin θ",
        |b, t, f| b * b / 2.0 * (2.0 * f).sin() * t.sin()
    ),
    row!(
        Roll,
        "LV+VL",
        InducedLVVL,
        "cos Y cos Z",
        "−b/2 cos²φ sin 2θ",
        |b, t, f| -b / 2.0 * c2(f) * (2.0 * t).sin(),
        "b²/8 sin 2φ cos θ",
        |b, t, f| b * b / 8.0 * (2.0 * f).sin() * t.cos()
    ),
    row!(
        Roll,
        "vv-tt",
        EddyVVTT,
        "cos X cos Z",
        "b/2 sin 2φ sin θ",
        |b, t, f| b / 2.0 * (2.0 * f).sin() * t.sin(),
        "b²/2 (sin²φ − cos²φ sin²θ)",
        |b, t, f| b * b / 2.0 * (s2(f) - c2(f) * s2(t))
    ),
    row!(
        Roll,
        "tl",
        EddyTL,
        "cos Y cos Z",
        "−b/2 sin 2φ cos θ",
        |b, t, f| -b / 2.0 * (2.0 * f).sin() * t.cos(),
        "b²/4 cos²φ sin 2θ",
        |b, t, f| b * b / 4.0 * c2(f) * (2.0 * t).sin()
    ),
    row!(
        Roll,
        "vl",
        EddyVL,
        "cos Y cos X",
        "b/2 cos²φ sin 2θ",
        |b, t, f| b / 2.0 * c2(f) * (2.0 * t).sin(),
        "b²/4 sin 2φ cos θ",
        |b, t, f| b * b / 4.0 * (2.0 * f).sin() * t.cos()
    ),
    row!(
        Roll,
        "vt",
        EddyVT,
        "cos² X",
        "b cos²φ sin²θ",
        |b, t, f| b * c2(f) * s2(t),
        "b²/2 sin 2φ sin θ",
        |b, t, f| b * b / 2.0 * (2.0 * f).sin() * t.sin()
    ),
    row!(
        Roll,
        "tv",
        EddyTV,
        "cos² Z",
        "−b sin²φ",
        |b, _t, f| -b * s2(f),
        "b²/2 sin 2φ sin θ",
        |b, t, f| b * b / 2.0 * (2.0 * f).sin() * t.sin()
    ),
];

/// The printed pitch table (a = pitch amplitude, θ the patent's heading, φ the dip).
static PITCH_TABLE: [PrintedRow; 12] = [
    row!(
        Pitch,
        "L",
        PermL,
        "cos Y",
        "a sin φ",
        |a, _t, f| a * f.sin(),
        "a²/4 cos φ cos θ",
        |a, t, f| a * a / 4.0 * f.cos() * t.cos()
    ),
    row!(
        Pitch,
        "V",
        PermV,
        "cos Z",
        "−a cos φ cos θ",
        |a, t, f| -a * f.cos() * t.cos(),
        "a²/4 sin φ",
        |a, _t, f| a * a / 4.0 * f.sin()
    ),
    row!(
        Pitch,
        "LL",
        InducedLL,
        "cos² Y",
        "a sin 2φ cos θ",
        |a, t, f| a * (2.0 * f).sin() * t.cos(),
        "a²/2 (cos²φ cos²θ − sin²φ)",
        |a, t, f| a * a / 2.0 * (c2(f) * c2(t) - s2(f))
    ),
    row!(
        Pitch,
        "VV",
        InducedVV,
        "cos² Z",
        "−a sin 2φ cos θ",
        |a, t, f| -a * (2.0 * f).sin() * t.cos(),
        "a²/2 (sin²φ − cos²φ cos²θ)",
        |a, t, f| a * a / 2.0 * (s2(f) - c2(f) * c2(t))
    ),
    row!(
        Pitch,
        "TL+LT",
        InducedTLLT,
        "cos X cos Y",
        "a/2 sin 2φ sin θ",
        |a, t, f| a / 2.0 * (2.0 * f).sin() * t.sin(),
        "a²/8 cos²φ sin 2θ",
        |a, t, f| a * a / 8.0 * c2(f) * (2.0 * t).sin()
    ),
    row!(
        Pitch,
        "TV+VT",
        InducedTVVT,
        "cos X cos Z",
        "−a/2 cos²φ sin 2θ",
        |a, t, f| -a / 2.0 * c2(f) * (2.0 * t).sin(),
        "a²/8 sin 2φ sin θ",
        |a, t, f| a * a / 8.0 * (2.0 * f).sin() * t.sin()
    ),
    row!(
        Pitch,
        "LV+VL",
        InducedLVVL,
        "cos Y cos Z",
        "−a (cos²φ cos²θ − sin²φ)",
        |a, t, f| -a * (c2(f) * c2(t) - s2(f)),
        "a²/2 sin 2φ cos θ",
        |a, t, f| a * a / 2.0 * (2.0 * f).sin() * t.cos()
    ),
    PrintedRow {
        misprint: Some(
            "a pitch leaves t = cos X constant, so tl gives no signal; the row is lt \
             (equation 7: −lt cos X cos Z)",
        ),
        ..row!(
            Pitch,
            "tl",
            EddyLT,
            "cos X cos Z",
            "−a/2 sin 2φ sin θ",
            |a, t, f| -a / 2.0 * (2.0 * f).sin() * t.sin(),
            "a²/4 cos²φ sin 2θ",
            |a, t, f| a * a / 4.0 * c2(f) * (2.0 * t).sin()
        )
    },
    PrintedRow {
        misprint: Some(
            "there is no term vv−tl; the row is vv−ll (equation 7: (vv − ll) cos Y cos Z)",
        ),
        ..row!(
            Pitch,
            "vv-tl",
            EddyVVLL,
            "cos Y cos Z",
            "a/2 sin 2φ cos θ",
            |a, t, f| a / 2.0 * (2.0 * f).sin() * t.cos(),
            "a²/2 (sin²φ − cos²φ cos²θ)",
            |a, t, f| a * a / 2.0 * (s2(f) - c2(f) * c2(t))
        )
    },
    row!(
        Pitch,
        "vt",
        EddyVT,
        "cos X cos Y",
        "a/2 cos²φ sin 2θ",
        |a, t, f| a / 2.0 * c2(f) * (2.0 * t).sin(),
        "a²/4 sin 2φ sin θ",
        |a, t, f| a * a / 4.0 * (2.0 * f).sin() * t.sin()
    ),
    row!(
        Pitch,
        "vl",
        EddyVL,
        "cos² Y",
        "a cos²φ cos²θ",
        |a, t, f| a * c2(f) * c2(t),
        "a²/2 sin 2φ cos θ",
        |a, t, f| a * a / 2.0 * (2.0 * f).sin() * t.cos()
    ),
    row!(
        Pitch,
        "lv",
        EddyLV,
        "cos² Z",
        "−a sin²φ",
        |a, _t, f| -a * s2(f),
        "a²/2 sin 2φ cos θ",
        |a, t, f| a * a / 2.0 * (2.0 * f).sin() * t.cos()
    ),
];

/// The patent's printed table for a maneuver, row by row as printed.
pub fn printed_table(maneuver: Maneuver) -> &'static [PrintedRow] {
    match maneuver {
        Maneuver::Roll => &ROLL_TABLE,
        Maneuver::Pitch => &PITCH_TABLE,
    }
}

/// Where a closed form comes from.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(tag = "status", rename_all = "snake_case")]
pub enum Provenance {
    /// A printed row, correct as printed.
    Printed {
        /// The row's name as printed.
        printed_name: String,
    },
    /// A printed row with a misprint; the closed form follows the mathematics.
    Misprint {
        /// The row's name as printed.
        printed_name: String,
        /// What is misprinted.
        note: String,
    },
    /// Not printed; derived from the mathematics.
    NotPrinted {
        /// How the closed form is derived, or why it is constant.
        note: String,
    },
}

/// A term's closed-form harmonics in our conventions.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ClosedHarmonics {
    /// Coefficient of `sin ωt` (perm, induced) or of `ω cos ωt` (eddy).
    pub fundamental: f64,
    /// Coefficient of `cos 2ωt` (perm, induced) or of `ω sin 2ωt` (eddy).
    pub second_harmonic: f64,
    /// Which printed row it comes from and whether it was corrected.
    pub provenance: Provenance,
}

/// The patent's closed form (leading order in the amplitude) of `term`'s harmonics for our
/// maneuver `angle = amplitude·sin ωt` on `heading_rad` (clockwise from magnetic north) at
/// `dip_rad`; amplitude in radians, our sign. The printed rows are evaluated in the patent's
/// angles (θp = −heading, λ = −pitch), eddy rows with the sign flipped (the patent's eddy
/// coefficients are −E), misprints corrected; rows the patent does not print are derived.
pub fn closed_form(
    maneuver: Maneuver,
    term: Term,
    amplitude_rad: f64,
    heading_rad: f64,
    dip_rad: f64,
) -> ClosedHarmonics {
    let amplitude = patent_amplitude(maneuver, amplitude_rad);
    let theta = patent_heading(heading_rad);
    let evaluate = |row: &PrintedRow, sign: f64| {
        (
            sign * (row.corrected_fundamental)(amplitude, theta, dip_rad),
            sign * (row.corrected_second)(amplitude, theta, dip_rad),
        )
    };
    let printed = |term: Term| printed_table(maneuver).iter().find(|r| r.term == term);
    if let Some(row) = printed(term) {
        let sign = if term.section() == Section::Eddy {
            -1.0
        } else {
            1.0
        };
        let (fundamental, second_harmonic) = evaluate(row, sign);
        let provenance = match row.misprint {
            None => Provenance::Printed {
                printed_name: row.printed_name.into(),
            },
            Some(note) => Provenance::Misprint {
                printed_name: row.printed_name.into(),
                note: note.into(),
            },
        };
        return ClosedHarmonics {
            fundamental,
            second_harmonic,
            provenance,
        };
    }
    // VV−TT is −TT (and VV−LL is −LL) up to the unobservable constant.
    let negated = match (maneuver, term) {
        (Maneuver::Roll, Term::InducedVVTT) => Some(Term::InducedTT),
        (Maneuver::Pitch, Term::InducedVVLL) => Some(Term::InducedLL),
        _ => None,
    };
    if let Some(row) = negated.and_then(printed) {
        let (fundamental, second_harmonic) = evaluate(row, -1.0);
        return ClosedHarmonics {
            fundamental,
            second_harmonic,
            provenance: Provenance::NotPrinted {
                note: format!("not printed: −{} up to a constant", row.printed_name),
            },
        };
    }
    ClosedHarmonics {
        fundamental: 0.0,
        second_harmonic: 0.0,
        provenance: Provenance::NotPrinted {
            note: constant_reason(maneuver).into(),
        },
    }
}

fn constant_reason(maneuver: Maneuver) -> &'static str {
    match maneuver {
        Maneuver::Roll => "not printed: zero, a roll leaves l = cos Y constant",
        Maneuver::Pitch => "not printed: zero, a pitch leaves t = cos X constant",
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_printed_row_names_a_term_of_its_maneuver_once() {
        for maneuver in [Maneuver::Roll, Maneuver::Pitch] {
            let rows = printed_table(maneuver);
            for (k, row) in rows.iter().enumerate() {
                assert_eq!(row.maneuver, maneuver);
                assert!(rows[k + 1..].iter().all(|r| r.term != row.term));
            }
        }
    }

    #[test]
    fn closed_forms_of_unprinted_rows_say_why() {
        let c = closed_form(Maneuver::Roll, Term::PermL, 0.2, 0.3, 1.0);
        assert_eq!((c.fundamental, c.second_harmonic), (0.0, 0.0));
        assert!(matches!(c.provenance, Provenance::NotPrinted { .. }));
        let vv_tt = closed_form(Maneuver::Roll, Term::InducedVVTT, 0.2, 0.3, 1.0);
        let tt = closed_form(Maneuver::Roll, Term::InducedTT, 0.2, 0.3, 1.0);
        assert_eq!(vv_tt.fundamental, -tt.fundamental);
    }
}
