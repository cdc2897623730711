//! The self-tuned default fit against every fixed ridge strength, on held-out survey data.
//!
//! For each installation the default (`FitSettings::recommended`: λ and the 16- or 18-term set
//! chosen by blocked cross-validation on the calibration flight alone) is compared with
//! MagNav-style fits at fixed λ over a wide grid, for both term sets. The measure is what a user
//! cares about: the error of the compensated survey against the simulator's true earth field.
//! The default cannot look at the survey, so it may lose a little to the best fixed λ chosen in
//! hindsight, but never materially: by more than 10 % plus the scalar magnetometer's own noise
//! (a difference below the sensor's noise is not one a user can act on).

use crate::common::{compensate_with, error_vs_truth};
use tolles_core::fit::{fit, FitSettings, Lambda};
use tolles_core::flight::plan::{BoxPlan, SurveyPlan};
use tolles_core::flight::sim::{simulate, Installation, SimulatedFlight};
use tolles_core::model::design::Design;
use tolles_core::model::terms::TermSet;

/// Fixed λ (unscaled columns, added to every diagonal entry of AᵀA as MagNav's `linreg` does).
const FIXED_LAMBDAS: [f64; 8] = [0.0, 1e-6, 1e-5, 1e-4, 1e-3, 1e-2, 1e-1, 1.0];

/// Survey error (nT): std of compensated − true earth field.
fn survey_error(cal: &SimulatedFlight, survey: &SimulatedFlight, settings: &FitSettings) -> f64 {
    let model = fit(&cal.scalar, &cal.flux, 10.0, Some(&cal.tt), settings).unwrap();
    let after = compensate_with(&model, &survey.scalar, &survey.flux, &survey.tt);
    error_vs_truth(&after, &survey.earth_nt)
}

#[test]
fn the_self_tuned_default_is_never_materially_worse_than_the_best_fixed_lambda() {
    // The last case has a noisy fluxgate (3 nT), where a ridge is needed.
    for (installation, seed, flux_noise_nt) in [
        (Installation::TailStinger, 3, 0.5),
        (Installation::Cabin, 4, 0.5),
        (Installation::Uav, 5, 0.5),
        (Installation::Cabin, 6, 3.0),
    ] {
        let scenario = |seed| {
            let mut s = installation.scenario(seed);
            s.sensors.flux_noise_nt = flux_noise_nt;
            s
        };
        let noise = scenario(seed).sensors.scalar_noise_nt;
        let cal = simulate(&BoxPlan::default().build(), &scenario(seed)).unwrap();
        let survey = simulate(&SurveyPlan::default().build(), &scenario(seed + 100)).unwrap();
        let default = survey_error(&cal, &survey, &FitSettings::recommended());
        let mut best = (f64::INFINITY, String::new());
        for terms in [TermSet::identifiable(), TermSet::magnav_default()] {
            for lambda in FIXED_LAMBDAS {
                let settings = FitSettings {
                    design: Design::new(terms),
                    lambda: Lambda::Fixed(lambda),
                    ..FitSettings::magnav()
                };
                let error = survey_error(&cal, &survey, &settings);
                if error < best.0 {
                    best = (error, format!("{terms} λ={lambda}"));
                }
            }
        }
        let magnav = survey_error(&cal, &survey, &FitSettings::magnav());
        eprintln!(
            "{installation:?}, fluxgate noise {flux_noise_nt} nT: self-tuned {default:.4} nT, best fixed {:.4} nT ({}), MagNav's default {magnav:.4} nT",
            best.0, best.1
        );
        assert!(
            default <= 1.1 * best.0 + noise,
            "{installation:?}: self-tuned {default} nT vs best fixed {} nT ({})",
            best.0,
            best.1
        );
    }
}
