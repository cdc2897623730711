//! Welch's power spectral density against `scipy.signal.welch`.
//!
//! Fixtures come from `scripts/fixtures/gen_spectrum_fixtures.py` (Hann window, 50 % overlap,
//! constant detrend, density scaling); no Python is needed here.

use serde::Deserialize;
use tolles_core::signal::spectrum::welch_with_segment_len;

const FIXTURE: &str = include_str!("../fixtures/spectrum/scipy_welch.json");
const TOL: f64 = 1e-10;

#[derive(Deserialize)]
struct Fixture {
    cases: Vec<Case>,
}

#[derive(Deserialize)]
struct Case {
    name: String,
    fs: f64,
    nperseg: usize,
    x: Vec<f64>,
    f: Vec<f64>,
    pxx: Vec<f64>,
}

#[test]
fn welch_matches_scipy() {
    let fixture: Fixture = serde_json::from_str(FIXTURE).unwrap();
    assert_eq!(fixture.cases.len(), 4);
    for case in &fixture.cases {
        let psd = welch_with_segment_len(&case.x, case.fs, case.nperseg).unwrap();
        assert_eq!(psd.frequency_hz.len(), case.f.len(), "{}", case.name);
        let largest = case.pxx.iter().cloned().fold(0.0, f64::max);
        for k in 0..case.f.len() {
            assert!(
                (psd.frequency_hz[k] - case.f[k]).abs() < 1e-12,
                "{} f[{k}]",
                case.name
            );
            let err = (psd.density[k] - case.pxx[k]).abs() / largest;
            assert!(
                err < TOL,
                "{} pxx[{k}]: {} vs {} ({err:e})",
                case.name,
                psd.density[k],
                case.pxx[k]
            );
        }
    }
}
