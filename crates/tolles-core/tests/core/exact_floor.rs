//! The defaults against the true-model floor on flights simulated with the exact magnitude.
//!
//! Each preset (tail stinger, cabin, UAV without its current) flies a calibration box with a
//! fluxgate that has 18 nT of offset and 0.3 nT of noise, and then a check flight: a second box
//! on other headings and survey lines. The error of the compensated scalar against the true
//! earth field is measured overall (after one constant: heading levels count), band-passed
//! 0.1–0.9 Hz and along lines (the mean of each line's standard deviation). The floor compensates
//! the same data with the true aircraft field, exactly: `|F + H(F)| − |F|` from the fluxgate `F`.

use crate::common::{check_plan, compensate_with};
use tolles_core::fit::{fit, Fit, FitSettings};
use tolles_core::flight::plan::BoxPlan;
use tolles_core::flight::sim::{interference, simulate, Installation, Scenario, SimulatedFlight};
use tolles_core::model::design::central_difference;
use tolles_core::model::interpret::AircraftField;
use tolles_core::signal::filter::Band;
use tolles_core::signal::metrics::std_dev;

/// The project's presets, and two families of random installations: ordinary ones (tens of nT)
/// and strong, cabin-like ones (up to a couple of thousand nT), where the exact magnitude
/// matters most.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Kind {
    Preset(Installation),
    Ordinary,
    Strong,
}

const PRESETS: [(&str, Kind); 5] = [
    ("tail-stinger", Kind::Preset(Installation::TailStinger)),
    ("cabin", Kind::Preset(Installation::Cabin)),
    ("uav", Kind::Preset(Installation::Uav)),
    ("ordinary", Kind::Ordinary),
    ("strong", Kind::Strong),
];

/// A random aircraft field whose terms are uniform within ± `p_nt`, ± `i`, ± `e_s`.
fn random_aircraft(seed: u64, p_nt: f64, i: f64, e_s: f64) -> AircraftField {
    let mut state = seed
        .wrapping_mul(6364136223846793005)
        .wrapping_add(1442695040888963407);
    let mut uniform = move |scale: f64| {
        state = state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        scale * (2.0 * ((state >> 11) as f64 / (1u64 << 53) as f64) - 1.0)
    };
    AircraftField {
        permanent_nt: [0; 3].map(|_| uniform(p_nt)),
        induced: [[0; 3]; 3].map(|row| row.map(|_| uniform(i))),
        eddy_s: [[0; 3]; 3].map(|row| row.map(|_| uniform(e_s))),
        bias_nt: 0.0,
    }
}

fn scenario(kind: Kind, seed: u64) -> Scenario {
    let installation = match kind {
        Kind::Preset(i) => i,
        _ => Installation::TailStinger,
    };
    let mut s = installation.scenario(seed);
    match kind {
        Kind::Ordinary => s.aircraft = random_aircraft(seed % 100, 40.0, 6e-4, 6e-5),
        Kind::Strong => s.aircraft = random_aircraft(seed % 100 + 1000, 600.0, 1e-2, 5e-4),
        Kind::Preset(_) => {}
    }
    s.extras.current = None;
    s.sensors.flux_noise_nt = 0.3;
    s.sensors.fluxgate.bias_nt = [12.0, -10.0, 9.0];
    s
}

/// The floor: the true aircraft field applied exactly through the fluxgate's readings (nT).
fn floor(flight: &SimulatedFlight, scenario: &Scenario) -> Vec<f64> {
    let f = &flight.flux;
    let rate = [&f.x, &f.y, &f.z].map(|c| central_difference(c));
    (0..flight.scalar.len())
        .map(|k| {
            let b = f.at(k);
            let db = [0, 1, 2].map(|i| rate[i][k] * scenario.fs_hz);
            let h = interference(&scenario.aircraft, b, db);
            let total = [b[0] + h[0], b[1] + h[1], b[2] + h[2]];
            flight.scalar[k] - (norm(total) - norm(b))
        })
        .collect()
}

fn norm(v: [f64; 3]) -> f64 {
    (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt()
}

/// Overall, band-passed and along-line error (nT) of `compensated` against the truth.
fn errors(compensated: &[f64], flight: &SimulatedFlight) -> [f64; 3] {
    let error: Vec<f64> = compensated
        .iter()
        .zip(&flight.earth_nt)
        .map(|(c, e)| c - e)
        .collect();
    let filter = Band::MAGNAV.butterworth(4, 10.0).unwrap().unwrap();
    let band = filter.filtfilt(&error).unwrap();
    let mut lines: Vec<f64> = flight.line.clone();
    lines.dedup();
    let along: Vec<f64> = lines
        .iter()
        .filter(|l| **l > 1000.0)
        .map(|l| {
            let on: Vec<f64> = error
                .iter()
                .zip(&flight.line)
                .filter(|(_, x)| *x == l)
                .map(|(e, _)| *e)
                .collect();
            std_dev(&on)
        })
        .collect();
    [
        std_dev(&error),
        std_dev(&band[200..band.len() - 200]),
        along.iter().sum::<f64>() / along.len() as f64,
    ]
}

struct Row {
    name: &'static str,
    fitted: [f64; 3],
    floor: [f64; 3],
}

fn measure(settings: &FitSettings, seeds: std::ops::Range<u64>) -> Vec<Row> {
    let mut rows = Vec::new();
    for (name, installation) in PRESETS {
        for seed in seeds.clone() {
            let cal_scenario = scenario(installation, seed);
            let cal = simulate(&BoxPlan::default().build(), &cal_scenario).unwrap();
            let model: Fit = fit(&cal.scalar, &cal.flux, 10.0, Some(&cal.tt), settings).unwrap();
            let check_scenario = scenario(installation, seed + 100);
            let check = simulate(&check_plan(), &check_scenario).unwrap();
            let compensated = compensate_with(&model, &check.scalar, &check.flux, &check.tt);
            rows.push(Row {
                name,
                fitted: errors(&compensated, &check),
                floor: errors(&floor(&check, &check_scenario), &check),
            });
        }
    }
    rows
}

fn geometric_mean(values: impl Iterator<Item = f64>) -> f64 {
    let (sum, n) = values.fold((0.0, 0), |(s, n), v| (s + v.ln(), n + 1));
    (sum / n as f64).exp()
}

/// Geometric-mean ratios to the floor, overall and band-passed, printing every preset.
fn report(label: &str, rows: &[Row]) -> [f64; 3] {
    eprintln!("{label}");
    for (name, _) in PRESETS {
        let mine: Vec<&Row> = rows.iter().filter(|r| r.name == name).collect();
        let ratio = |i: usize| geometric_mean(mine.iter().map(|r| r.fitted[i] / r.floor[i]));
        eprintln!(
            "  {name:13} overall {:.4} nT (floor {:.4}) {:5.2}×   band {:.4} (floor {:.4}) {:5.2}×   along lines {:.4} (floor {:.4}) {:5.2}×",
            mine.iter().map(|r| r.fitted[0]).sum::<f64>() / mine.len() as f64,
            mine.iter().map(|r| r.floor[0]).sum::<f64>() / mine.len() as f64,
            ratio(0),
            mine.iter().map(|r| r.fitted[1]).sum::<f64>() / mine.len() as f64,
            mine.iter().map(|r| r.floor[1]).sum::<f64>() / mine.len() as f64,
            ratio(1),
            mine.iter().map(|r| r.fitted[2]).sum::<f64>() / mine.len() as f64,
            mine.iter().map(|r| r.floor[2]).sum::<f64>() / mine.len() as f64,
            ratio(2),
        );
    }
    let all = |i: usize| geometric_mean(rows.iter().map(|r| r.fitted[i] / r.floor[i]));
    let overall = [all(0), all(1), all(2)];
    eprintln!(
        "  all presets: overall {:.2}×, band-passed {:.2}×, along lines {:.2}× the floor",
        overall[0], overall[1], overall[2]
    );
    overall
}

#[test]
fn defaults_come_within_a_few_times_the_true_model_floor() {
    let rows = measure(&FitSettings::recommended(), 1..3);
    let [overall, band, _] = report(
        "defaults (patent terms, exact magnitude by CV, heading levels)",
        &rows,
    );
    assert!(overall <= 3.0, "overall {overall:.2}× the floor");
    assert!(band <= 2.0, "band-passed {band:.2}× the floor");
    // Where the exact magnitude matters, a linear fit stays at 2–3× the floor (run
    // `compare_with_earlier_defaults`); the defaults must not.
    let strong: Vec<Row> = rows.into_iter().filter(|r| r.name == "strong").collect();
    let ratio = |i: usize| geometric_mean(strong.iter().map(|r| r.fitted[i] / r.floor[i]));
    assert!(
        ratio(0) <= 1.5,
        "strong installations overall {:.2}×",
        ratio(0)
    );
    assert!(
        ratio(1) <= 1.0,
        "strong installations band-passed {:.2}×",
        ratio(1)
    );
}

#[test]
#[ignore = "prints the settings side by side; run with --ignored --nocapture"]
fn compare_with_earlier_defaults() {
    let old = FitSettings {
        design: tolles_core::model::design::Design::new(
            tolles_core::model::terms::TermSet::identifiable(),
        ),
        magnitude: tolles_core::fit::MagnitudeChoice::Linear,
        levels: false,
        ..FitSettings::recommended()
    };
    let variants = [
        ("MagNav settings", FitSettings::magnav()),
        ("earlier defaults (i5,e8 linear)", old.clone()),
        (
            "patent terms, linear",
            FitSettings {
                magnitude: tolles_core::fit::MagnitudeChoice::Linear,
                levels: false,
                ..FitSettings::recommended()
            },
        ),
        (
            "patent terms, exact, no levels",
            FitSettings {
                levels: false,
                ..FitSettings::recommended()
            },
        ),
        (
            "patent terms, linear, levels",
            FitSettings {
                magnitude: tolles_core::fit::MagnitudeChoice::Linear,
                ..FitSettings::recommended()
            },
        ),
        ("defaults", FitSettings::recommended()),
    ];
    for (label, settings) in variants {
        report(label, &measure(&settings, 1..4));
    }
}
