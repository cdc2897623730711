//! The built-in example: a cabin installation flies a calibration box and a survey whose truth
//! is known; after fitting the box and compensating the survey, [`compare`] says how close the
//! result came to the truth.

use crate::error::Result;
use crate::model::ScalarModel;
use crate::progress::Progress;
use crate::report::ReportRequest;
use crate::simulate::{simulate_plan, PlanKind, Simulated};
use std::path::Path;
use tolles_core::flight::plan::{BoxPlan, SurveyPlan};
use tolles_core::flight::sim::Installation;
use tolles_core::signal::filter::magnav_bandpass;
use tolles_core::signal::metrics::{improvement_ratio, noise_level, std_dev};
use tolles_io::simulation::SCALAR;
use tolles_io::table::Table;

/// Pass band (Hz) of the survey's noise levels: MagNav's 0.1–0.9 Hz.
pub const NOISE_BAND_HZ: (f64, f64) = (0.1, 0.9);

/// Butterworth order per edge of the noise band.
const NOISE_ORDER: usize = 4;

/// The demo's two flights.
#[derive(Debug, Clone)]
pub struct DemoFlights {
    /// The compensation box: N, E, S, W; roll ±10°, pitch ±5°, yaw ±5°.
    pub calibration: Simulated,
    /// Four survey lines.
    pub survey: Simulated,
}

/// Simulates the demo's flights: a cabin installation at 10 Hz over IGRF-14 with geology and
/// diurnal variation, the box with noise seed `seed`, the survey with `seed + 1`.
pub fn flights(seed: u64, progress: &dyn Progress) -> Result<DemoFlights> {
    let installation = Installation::Cabin;
    let calibration = simulate_plan(
        PlanKind::Box,
        BoxPlan::default().build(),
        installation.scenario(seed),
        progress,
    )?;
    let survey = simulate_plan(
        PlanKind::Survey,
        SurveyPlan::default().build(),
        installation.scenario(seed + 1),
        progress,
    )?;
    Ok(DemoFlights {
        calibration,
        survey,
    })
}

/// How the compensated survey compares with the simulator's truth.
#[derive(Debug, Clone, PartialEq)]
pub struct DemoOutcome {
    /// Standard deviation of scalar − earth field before compensation (nT).
    pub error_before_nt: f64,
    /// The same after compensation (nT).
    pub error_after_nt: f64,
    /// Band ([`NOISE_BAND_HZ`]) of the noise levels (Hz).
    pub band_hz: (f64, f64),
    /// Standard deviation of the band-passed scalar before compensation (nT).
    pub noise_before_nt: f64,
    /// The same after compensation (nT).
    pub noise_after_nt: f64,
    /// Noise before / after (dimensionless).
    pub improvement: f64,
    /// The aircraft's field in the Tolles patent's 16 terms, true and fitted (perm in nT,
    /// induced dimensionless, eddy in s).
    pub terms: Vec<Term>,
}

/// One of the patent's terms.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Term {
    /// The patent's name (`T`, `VV-TT`, `tl`, …).
    pub name: &'static str,
    /// The simulated aircraft's value.
    pub truth: f64,
    /// The fit's value.
    pub fitted: f64,
}

/// Compares the survey compensated by `fit` (column `fit.output_column` of the CSV file
/// `compensated`, one row per survey sample) with the survey's truth.
pub fn compare(survey: &Simulated, compensated: &Path, fit: &ScalarModel) -> Result<DemoOutcome> {
    let table = Table::csv().path(compensated)?;
    let clean = table.numeric(&fit.output_column)?;
    let flight = &survey.flight;
    let error =
        |x: &[f64]| -> Vec<f64> { x.iter().zip(&flight.earth_nt).map(|(a, b)| a - b).collect() };
    let (lo, hi) = NOISE_BAND_HZ;
    let filter = magnav_bandpass(lo, hi, NOISE_ORDER, survey.scenario.fs_hz)?;
    let noise_before_nt = noise_level(&flight.scalar, filter.as_ref())?;
    let noise_after_nt = noise_level(&clean, filter.as_ref())?;
    let truth = survey.scenario.aircraft.patent_terms();
    let terms = truth
        .named()
        .iter()
        .zip(fit.patent.named())
        .map(|(&(name, truth), (_, fitted))| Term {
            name,
            truth,
            fitted,
        })
        .collect();
    Ok(DemoOutcome {
        error_before_nt: std_dev(&error(&flight.scalar)),
        error_after_nt: std_dev(&error(&clean)),
        band_hz: NOISE_BAND_HZ,
        noise_before_nt,
        noise_after_nt,
        improvement: improvement_ratio(noise_before_nt, noise_after_nt),
        terms,
    })
}

/// One of the demo's reports: what it shows, where it goes and what it asks for.
#[derive(Debug, Clone, PartialEq)]
pub struct DemoReport {
    /// A few words on what it reports on.
    pub what: &'static str,
    /// Its directory, relative to the demo's output directory.
    pub dir: &'static str,
    /// The report.
    pub request: ReportRequest,
}

/// The demo's two reports: the calibration box compensated with its own model, and the
/// survey compensated with the box's model out of sample, where the survey file's truth
/// column ([`crate::report::TRUTH_COLUMN`]) gives the compensated field's error.
pub fn reports(calibration: &Path, survey: &Path, model: &Path) -> [DemoReport; 2] {
    let request = |flight: &Path| ReportRequest {
        model: Some(model.to_path_buf()),
        ..ReportRequest::new(flight, SCALAR)
    };
    [
        DemoReport {
            what: "the calibration box",
            dir: "report",
            request: request(calibration),
        },
        DemoReport {
            what: "the survey, compensated out of sample, against the simulator's truth",
            dir: "survey-report",
            request: request(survey),
        },
    ]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::compensate::{compensate_file, FileRequest};
    use crate::fit::{fit, FitRequest};
    use crate::progress::Silent;
    use crate::warning::Warning;

    #[test]
    fn the_demo_recovers_the_truth() {
        let flights = flights(1, &Silent).unwrap();
        assert_eq!(flights.calibration.flight.tt.len(), 4661);
        assert_eq!(flights.survey.flight.tt.len(), 6601);
        assert_eq!(flights.survey.plan_kind, PlanKind::Survey);
        let dir = tempfile::tempdir().unwrap();
        let (cal, survey, out) = (
            dir.path().join("cal.csv"),
            dir.path().join("survey.csv"),
            dir.path().join("out.csv"),
        );
        crate::simulate::write(&flights.calibration, &cal).unwrap();
        crate::simulate::write(&flights.survey, &survey).unwrap();
        let mut warnings = Vec::new();
        let data = crate::read::read(&cal, &Default::default(), &Silent, &mut warnings).unwrap();
        let request = FitRequest::new(vec!["mag_1_uc".into()], vec!["flux_a".into()]);
        let model = fit(&data.table, &request, &Silent, &mut warnings).unwrap();
        let request = FileRequest {
            survey,
            out: Some(out.clone()),
            ..FileRequest::default()
        };
        compensate_file(
            &model,
            &request,
            &mut std::io::sink(),
            &Silent,
            &mut warnings,
        )
        .unwrap();
        let outcome = compare(&flights.survey, &out, &model.fits[0]).unwrap();
        // The survey's last turn banks through headings the box never turned through: those
        // rows are extrapolated, and said to be; nothing else is worth a warning.
        let extrapolated =
            |w: &Warning| matches!(w, Warning::Extrapolated { rows, of, .. } if rows * 50 < *of);
        assert!(warnings.iter().all(extrapolated), "{warnings:?}");
        assert!(
            outcome.error_before_nt > 10.0 && outcome.error_after_nt < 0.1,
            "{outcome:?}"
        );
        assert!(outcome.improvement > 50.0, "{outcome:?}");
        assert_eq!(outcome.terms.len(), 16);
        let l = outcome.terms.iter().find(|t| t.name == "L").unwrap();
        assert!((l.fitted - l.truth).abs() < 0.02 * l.truth.abs(), "{l:?}");
    }
}
