//! Invariants of zero-phase filtering that hold for any signal.

use proptest::prelude::*;
use tolles_core::signal::filter::{Butterworth, Response};

fn filter_strategy() -> impl Strategy<Value = Butterworth> {
    let response = prop_oneof![
        (0.05..0.45f64, 0.05..0.45f64)
            .prop_filter("distinct edges", |(a, b)| (a - b).abs() > 0.02)
            .prop_map(|(a, b)| Response::BandPass {
                low_hz: a.min(b),
                high_hz: a.max(b),
            }),
        (0.02..0.48f64).prop_map(|f| Response::LowPass { cutoff_hz: f }),
        (0.02..0.48f64).prop_map(|f| Response::HighPass { cutoff_hz: f }),
    ];
    // Frequencies above are fractions of fs, scaled to a sample rate in Hz here.
    (
        1usize..=6,
        response,
        prop_oneof![Just(1.0), Just(10.0), Just(160.0)],
    )
        .prop_map(|(order, response, fs)| {
            let scaled = match response {
                Response::BandPass { low_hz, high_hz } => Response::BandPass {
                    low_hz: low_hz * fs,
                    high_hz: high_hz * fs,
                },
                Response::LowPass { cutoff_hz } => Response::LowPass {
                    cutoff_hz: cutoff_hz * fs,
                },
                Response::HighPass { cutoff_hz } => Response::HighPass {
                    cutoff_hz: cutoff_hz * fs,
                },
            };
            Butterworth::design(order, scaled, fs).unwrap()
        })
}

fn signals(len: usize) -> impl Strategy<Value = (Vec<f64>, Vec<f64>)> {
    (
        prop::collection::vec(-100.0..100.0f64, len),
        prop::collection::vec(-100.0..100.0f64, len),
    )
}

fn close(a: &[f64], b: &[f64], scale: f64) -> bool {
    a.iter().zip(b).all(|(x, y)| (x - y).abs() <= 1e-8 * scale)
}

proptest! {
    #[test]
    fn filtfilt_is_linear(
        f in filter_strategy(),
        (x, y) in signals(120),
        a in -10.0..10.0f64,
        c in -10.0..10.0f64,
    ) {
        let combo: Vec<f64> = x.iter().zip(&y).map(|(xi, yi)| a * xi + c * yi).collect();
        let lhs = f.filtfilt(&combo).unwrap();
        let (fx, fy) = (f.filtfilt(&x).unwrap(), f.filtfilt(&y).unwrap());
        let rhs: Vec<f64> = fx.iter().zip(&fy).map(|(p, q)| a * p + c * q).collect();
        let scale = 1.0 + rhs.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        prop_assert!(close(&lhs, &rhs, scale));
    }

    /// Steady-state initial conditions make a constant pass through without a
    /// transient, so only the DC gain (1 or 0) acts on it. (Exact time-reversal symmetry
    /// does not hold: the edge initial conditions differ between the passes, in scipy too.)
    #[test]
    fn constant_is_scaled_by_dc_gain(f in filter_strategy(), c in -1e5..1e5f64) {
        let y = f.filtfilt(&vec![c; 80]).unwrap();
        let dc_gain: f64 = f
            .sections()
            .iter()
            .map(|s| (s[0] + s[1] + s[2]) / (s[3] + s[4] + s[5]))
            .product();
        prop_assert!(dc_gain.abs() < 1e-12 || (dc_gain - 1.0).abs() < 1e-12);
        let expected = c * dc_gain * dc_gain;
        prop_assert!(y.iter().all(|v| (v - expected).abs() <= 1e-8 * (1.0 + c.abs())));
    }
}
