//! The flight against the survey specification the user states (nT): each line's fourth
//! difference, the box's figure of merit and the heading error, each passed or failed, on the
//! first screen, where a QC reviewer signs.

use super::*;

/// One test of the specification: what, the limit, what the flight measured, and the result.
struct Test {
    what: &'static str,
    limit: String,
    measured: String,
    result: String,
}

/// The specification's table, under the summary; a test the flight cannot take says why.
pub(super) fn specification(report: Report, data: &ReportData) -> Report {
    let tests = [fourth_difference(data), fom(data), heading_error(data)];
    let rows: Vec<Vec<String>> = tests
        .into_iter()
        .map(|t| vec![t.what.into(), t.limit, t.measured, t.result])
        .collect();
    report
        .paragraph(
            "Against the survey specification (report --noise-tolerance, --fom-spec and \
             --heading-error-spec set it; the defaults are common fixed-wing figures):",
        )
        .table(&["test", "specification", "this flight", "result"], &rows)
}

/// Every survey line's peak fourth difference within ± the tolerance.
fn fourth_difference(data: &ReportData) -> Test {
    let tolerance = data.request.noise_tolerance_nt;
    let peaks: Vec<Option<f64>> = (data.lines.iter().flat_map(|l| &l.rows))
        .filter(|r| r.kind == LineKind::Line)
        .map(|r| r.peak_fourth_difference_nt)
        .collect();
    let judged: Vec<f64> = peaks.iter().flatten().copied().collect();
    let passed = judged.iter().filter(|p| **p <= tolerance).count();
    let (measured, result) = match (peaks.len(), judged.len()) {
        (0, _) => ("no survey lines".into(), "not judged".into()),
        (_, 0) => ("no line long enough".into(), "not judged".into()),
        (lines, n) if lines == n => (
            format!("{passed} of {n} lines within"),
            verdict(passed == n),
        ),
        (lines, n) => (
            format!("{passed} of {n} judged lines within ({lines} lines)"),
            verdict(passed == n),
        ),
    };
    Test {
        what: "fourth difference, each line",
        limit: format!("within ±{} nT", format_value(tolerance)),
        measured,
        result,
    }
}

/// The box's figure of merit, compensated (or as read, without a model), at most the limit.
fn fom(data: &ReportData) -> Test {
    let limit = data.request.fom_spec_nt;
    let (measured, result) = match (has_box(data), &data.fom.after) {
        (false, _) if data.attitude.all().is_none() => {
            ("no attitude, so no maneuvers".into(), "not judged".into())
        }
        (false, _) => ("no box maneuvers".into(), "not judged".into()),
        (true, Some(after)) => (nt(after.fom_nt, 3), verdict(after.fom_nt <= limit)),
        (true, None) => (
            format!("{} as read", nt(data.fom.before.fom_nt, 3)),
            verdict(data.fom.before.fom_nt <= limit),
        ),
    };
    Test {
        what: "figure of merit (box)",
        limit: format!("at most {} nT", format_value(limit)),
        measured,
        result,
    }
}

/// The compensated heading error against the truth or the reference, at most the limit: the
/// levels of legs over different ground carry the geology, which no compensation removes.
fn heading_error(data: &ReportData) -> Test {
    let limit = data.request.heading_error_spec_nt;
    let vs = against(data).short;
    let error = (data.heading_vs_truth.as_ref()).and_then(|h| h.heading_error_nt);
    let (measured, result) = match (error, &data.compensated, &data.truth) {
        (Some(e), _, _) => (format!("{} vs {vs}", nt(e, 3)), verdict(e <= limit)),
        (None, None, _) => ("no model on this page".into(), "not judged".into()),
        (None, Some(_), _) if data.attitude.all().is_none() => (
            "no attitude, so no straight legs".into(),
            "not judged".into(),
        ),
        (None, Some(_), None) => (
            "legs over different ground".into(),
            "not judged (fly the headings over one point, or give --reference)".into(),
        ),
        (None, Some(_), Some(_)) => ("no straight legs".into(), "not judged".into()),
    };
    Test {
        what: "heading error, compensated",
        limit: format!("at most {} nT", format_value(limit)),
        measured,
        result,
    }
}
