//! Writes a sample report with every kind of element, for `scripts/check-report`.
//!
//! ```sh
//! cargo run -p tolles-report --example sample_report -- OUT_DIR [--missing-image]
//! ```
//!
//! `--missing-image` also references an image that does not exist, so the browser check can
//! prove that it notices a broken image.

use std::f64::consts::PI;

use tolles_core::signal::spectrum::welch;
use tolles_report::live::Live;
use tolles_report::plot::{BarChart, BarSeries, Colour, LinePlot, Series, Span};
use tolles_report::Report;

const FS_HZ: f64 = 10.0;
const SAMPLES: usize = 200_000;

/// Deterministic pseudo-random numbers in (-0.5, 0.5) (a linear congruential generator).
fn noise(n: usize, seed: u64) -> Vec<f64> {
    let mut state = seed;
    (0..n)
        .map(|_| {
            state = state
                .wrapping_mul(6_364_136_223_846_793_005)
                .wrapping_add(1_442_695_040_888_963_407);
            (state >> 11) as f64 / (1u64 << 53) as f64 - 0.5
        })
        .collect()
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let dir = args
        .next()
        .ok_or("usage: sample_report OUT_DIR [--missing-image]")?;
    let missing_image = args.any(|a| a == "--missing-image");

    let t: Vec<f64> = (0..SAMPLES).map(|k| k as f64 / FS_HZ).collect();
    let n1 = noise(SAMPLES, 1);
    let n2 = noise(SAMPLES, 2);
    // Manoeuvre noise (slow) and sensor noise (fast); compensation removes the former.
    let mut raw: Vec<f64> = t
        .iter()
        .zip(&n1)
        .map(|(t, n)| 6.0 * (2.0 * PI * 0.25 * t).sin() + 2.0 * (2.0 * PI * 0.07 * t).cos() + n)
        .collect();
    let mut compensated: Vec<f64> = t
        .iter()
        .zip(&n2)
        .map(|(t, n)| 0.3 * (2.0 * PI * 0.25 * t).sin() + 0.4 * n)
        .collect();
    // A data dropout: the plots must show a gap, not a line across it.
    for k in 120_000..121_500 {
        raw[k] = f64::NAN;
        compensated[k] = f64::NAN;
    }
    raw[60_000] = 40.0; // a spike that decimation must keep

    let psd_raw = welch(&raw, FS_HZ)?;
    let psd_comp = welch(&compensated, FS_HZ)?;

    let mut report = Report::new("Sample compensation report")
        .subtitle("Synthetic data: 200 000 samples at 10 Hz with a dropout and a spike, to show every element of a report.")
        .summary(&[
            ("samples", "200 000"),
            ("noise before", "4.62 nT"),
            ("noise after", "0.26 nT"),
            ("improvement", "17.8×"),
        ])
        .section("Summary")
        .paragraph("Compensation removes the slow manoeuvre noise; the fast sensor noise remains. Text is escaped: <b>not bold</b> & \"quoted\".")
        .key_values(&[
            ("scalar magnetometer", "mag_1_uc"),
            ("vector magnetometer", "flux_a"),
            ("sample rate", "10 Hz"),
            ("ridge λ (relative)", "1e-6"),
            ("held-out RMS", "0.012 nT"),
        ])
        .section("Signals")
        .line_plot(LinePlot {
            title: "Scalar anomaly before and after compensation".into(),
            x_label: "time (s)".into(),
            y_label: "anomaly (nT)".into(),
            series: vec![
                Series::new("uncompensated", t.clone(), raw).colour(Colour::UNCOMPENSATED),
                Series::new("compensated", t.clone(), compensated).colour(Colour::COMPENSATED),
            ],
            caption: Some("The dropout near 12 000 s is a gap; the spike at 6 000 s is kept.".into()),
            live: Some(Live {
                windows: vec![Span {
                    label: "a shaded window".into(),
                    from: 3_000.0,
                    to: 3_600.0,
                    colour: Colour::REFERENCE,
                }],
            }),
            ..LinePlot::default()
        })
        .line_plot(LinePlot {
            title: "Power spectral density".into(),
            x_label: "frequency (Hz)".into(),
            y_label: "PSD (nT²/Hz)".into(),
            series: vec![
                // Without the DC bin, which the per-segment mean removal empties.
                Series::new("uncompensated", psd_raw.frequency_hz[1..].to_vec(), psd_raw.density[1..].to_vec())
                    .colour(Colour::UNCOMPENSATED),
                Series::new("compensated", psd_comp.frequency_hz[1..].to_vec(), psd_comp.density[1..].to_vec())
                    .colour(Colour::COMPENSATED),
            ],
            log_y: true,
            caption: Some(format!(
                "Welch's method, Hann window, {} samples per segment, {} segments.",
                psd_raw.segment_len, psd_raw.segments
            )),
            ..LinePlot::default()
        })
        .section("Coefficients")
        .table(
            &["term", "coefficient", "standard error", "unit"],
            &[
                vec!["permanent x".into(), "12.53".into(), "0.04".into(), "nT".into()],
                vec!["permanent y".into(), "−3.1".into(), "0.05".into(), "nT".into()],
                vec!["induced xx".into(), "1.2e-4".into(), "3e-6".into(), "1".into()],
                vec!["eddy xy".into(), "0.0021".into(), "0.0002".into(), "s".into()],
            ],
        )
        .bar_chart(BarChart {
            title: "Noise level per flight line".into(),
            y_label: "noise (nT)".into(),
            categories: ["1002.02", "1002.03", "1002.04", "1002.05"].map(String::from).to_vec(),
            series: vec![
                BarSeries::new("uncompensated", vec![4.6, 5.1, 3.9, 4.4]).colour(Colour::UNCOMPENSATED),
                BarSeries::new("compensated", vec![0.26, 0.31, 0.22, f64::NAN]).colour(Colour::COMPENSATED),
            ],
            caption: Some("Line 1002.05 has no compensated value (no bar).".into()),
            log_y: true,
        });
    if missing_image {
        report = report.image("plots/missing.svg", "an image that does not exist");
    }
    let index = report.write(&dir)?;
    println!("{}", index.display());
    Ok(())
}
