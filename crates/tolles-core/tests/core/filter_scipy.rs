//! Butterworth design and zero-phase filtering against scipy reference output.
//!
//! Fixtures come from `scripts/fixtures/gen_filter_fixtures.py` (scipy's `butter` with
//! `output='sos'` and `sosfiltfilt` with default padding); no Python is needed here.

use serde::Deserialize;
use tolles_core::signal::filter::{Butterworth, Response};

const FIXTURE: &str = include_str!("../fixtures/filter/scipy_sosfiltfilt.json");
const TOL: f64 = 1e-9;

#[derive(Deserialize)]
struct Fixture {
    cases: Vec<Case>,
}

#[derive(Deserialize)]
struct Case {
    name: String,
    order: usize,
    kind: String,
    edges: Vec<f64>,
    fs: f64,
    sos: Vec<[f64; 6]>,
    padlen: usize,
    x: Vec<f64>,
    y: Vec<f64>,
}

impl Case {
    fn response(&self) -> Response {
        match self.kind.as_str() {
            "bandpass" => Response::BandPass {
                low_hz: self.edges[0],
                high_hz: self.edges[1],
            },
            "lowpass" => Response::LowPass {
                cutoff_hz: self.edges[0],
            },
            "highpass" => Response::HighPass {
                cutoff_hz: self.edges[0],
            },
            other => panic!("unknown kind {other}"),
        }
    }

    fn design(&self) -> Butterworth {
        Butterworth::design(self.order, self.response(), self.fs).unwrap()
    }
}

fn cases() -> Vec<Case> {
    let fixture: Fixture = serde_json::from_str(FIXTURE).expect("fixture parses");
    assert!(fixture.cases.len() >= 42, "fixture lost cases");
    fixture.cases
}

/// |H(e^{iw})| of cascaded sections at angular frequency `w` (rad/sample).
fn magnitude(sections: &[[f64; 6]], w: f64) -> f64 {
    let (c1, s1, c2, s2) = (w.cos(), -w.sin(), (2.0 * w).cos(), -(2.0 * w).sin());
    sections.iter().fold(1.0, |acc, s| {
        let num = (s[0] + s[1] * c1 + s[2] * c2).hypot(s[1] * s1 + s[2] * s2);
        let den = (s[3] + s[4] * c1 + s[5] * c2).hypot(s[4] * s1 + s[5] * s2);
        acc * num / den
    })
}

fn max_abs(v: &[f64]) -> f64 {
    v.iter().fold(0.0, |m, x| m.max(x.abs()))
}

#[test]
fn covers_required_orders_kinds_and_rates() {
    let cases = cases();
    for fs in [10.0, 160.0] {
        for kind in ["bandpass", "lowpass", "highpass"] {
            for order in 2..=8 {
                assert!(
                    cases
                        .iter()
                        .any(|c| c.fs == fs && c.kind == kind && c.order == order),
                    "missing {kind} order {order} at {fs} Hz"
                );
            }
        }
    }
}

#[test]
fn padlen_and_section_count_match_scipy() {
    for case in cases() {
        let f = case.design();
        assert_eq!(f.padlen(), case.padlen, "{}", case.name);
        assert_eq!(f.sections().len(), case.sos.len(), "{}", case.name);
    }
}

#[test]
fn frequency_response_matches_scipy() {
    for case in cases() {
        let ours = case.design();
        let mut freqs_hz: Vec<f64> = (0..=64).map(|k| k as f64 * case.fs / 128.0).collect();
        freqs_hz.extend(&case.edges);
        for f_hz in freqs_hz {
            let w = 2.0 * std::f64::consts::PI * f_hz / case.fs;
            let (a, b) = (magnitude(ours.sections(), w), magnitude(&case.sos, w));
            assert!(
                (a - b).abs() <= TOL * b.max(1e-3),
                "{} at {f_hz} Hz: ours {a}, scipy {b}",
                case.name
            );
        }
    }
}

#[test]
fn filtfilt_matches_scipy() {
    let mut worst = (0.0, String::new());
    for case in cases() {
        let y = case.design().filtfilt(&case.x).unwrap();
        assert_eq!(y.len(), case.y.len(), "{}", case.name);
        let diff: Vec<f64> = y.iter().zip(&case.y).map(|(a, b)| a - b).collect();
        let rel = max_abs(&diff) / max_abs(&case.y);
        assert!(rel <= TOL, "{}: relative error {rel:e}", case.name);
        if rel > worst.0 {
            worst = (rel, case.name.clone());
        }
    }
    println!("worst relative error {:e} in {}", worst.0, worst.1);
}

#[test]
fn too_short_at_scipy_padlen() {
    for case in cases() {
        let f = case.design();
        assert!(f.filtfilt(&case.x[..case.padlen]).is_err(), "{}", case.name);
    }
}
