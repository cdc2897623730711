//! Strobe-like currents that switch faster than the fitting band's upper edge.
//!
//! A cabin installation carries a switched current whose field is 30–60 nT per ampere; the
//! current toggles every 0.25–0.5 s (a square wave at 1–2 Hz, wholly or mostly above the
//! 0.9 Hz edge) or ripples at 1.7 Hz. With the current as an extra channel, the survey's error
//! against the truth must come within 1.5× of the same defaults on the same flights with the
//! current's field switched off. The band alone hardly sees such a current (3–15× before the
//! rows above the band were added); see `AboveBand` in `fit/problem.rs`.

use crate::common::survey_error_with_extras;
use tolles_core::flight::sim::{CurrentSource, Installation, Scenario};

/// Survey error (nT) against the truth after a fit on a box, with or without `cur_1`.
fn survey_error(scenario: &Scenario, extra: bool) -> f64 {
    let extras: &[&str] = if extra { &["cur_1"] } else { &[] };
    survey_error_with_extras(scenario, extras).0
}

#[test]
fn fast_switching_currents_are_removed_almost_as_if_they_were_off() {
    let cases = [
        ([60.0, -50.0, 40.0], 0.25, 0.0),
        ([60.0, -50.0, 40.0], 0.3, 0.0),
        ([30.0, 30.0, -45.0], 0.5, 0.0),
        ([-20.0, 60.0, 10.0], 0.3, 1.7),
    ];
    let mut worst: f64 = 0.0;
    for (field_nt_per_a, every_s, ripple_hz) in cases {
        for seed in [11, 12] {
            let mut on = Installation::Cabin.scenario(seed);
            let current = CurrentSource {
                field_nt_per_a,
                mean_a: 0.2,
                ripple_a: if ripple_hz > 0.0 { 0.3 } else { 0.0 },
                ripple_hz,
                step_a: 1.0,
                step_every_s: every_s,
            };
            on.extras.current = Some(current);
            let mut off = on.clone();
            off.extras.current = Some(CurrentSource {
                field_nt_per_a: [0.0; 3],
                ..current
            });
            let floor = survey_error(&off, false);
            let ignored = survey_error(&on, false);
            let with = survey_error(&on, true);
            eprintln!(
                "{field_nt_per_a:?} nT/A, toggling every {every_s} s, ripple {ripple_hz} Hz, seed {seed}: current off {floor:.4} nT, not modelled {ignored:.3} nT, --extra {with:.4} nT ({:.2}× off)",
                with / floor
            );
            worst = worst.max(with / floor);
        }
    }
    eprintln!("worst: {worst:.2}× the current-off error");
    assert!(worst <= 1.5, "worst case {worst:.2}× the current-off error");
}
