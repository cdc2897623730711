//! What the library returns, said on the command line: warnings on standard error, errors
//! with the flag that fixes them where there is one, a fit's summary, and a report as HTML.
//! Shared by the commands whose results these are and by `demo`, which shows them all.

use crate::progress::Terminal;
use anyhow::Context;
use std::io::Write;
use std::path::{Path, PathBuf};
use tolles::model::ScalarModel;
use tolles::report::ReportRequest;
use tolles::{Error, Warning};
use tolles_io::error::{IoError, Near};
use tolles_io::select::SelectError;

/// What a command does with the rows a selection kept, for the message that says so.
#[derive(Clone, Copy)]
pub enum Use {
    Fit,
    Compensate,
    Fom,
    Other,
}

/// Prints `warnings` on standard error, one line each, and empties the vector.
pub fn warnings(warnings: &mut Vec<Warning>, purpose: Use) {
    let mut said = Vec::new();
    for warning in warnings.drain(..) {
        // Two scalars read from one file notice the same things of it: said once.
        let text = warning_text(&warning, purpose);
        if !said.contains(&text) {
            note!("{text}");
            said.push(text);
        }
    }
}

/// One warning as the command line says it.
pub fn warning_text(warning: &Warning, purpose: Use) -> String {
    match warning {
        Warning::SampleRateDiffers {
            given_hz,
            from_time_hz,
        } => format!(
            "warning: --fs {} Hz differs from the {from_time_hz:.6} Hz of column \"tt\"; using --fs",
            tolles::warning::hz(*given_hz)
        ),
        Warning::RowsSelected { path, selection } => {
            let consequence = match purpose {
                Use::Fit => "the fit uses only these".to_string(),
                Use::Fom => "the FOM uses only these".to_string(),
                Use::Other => "only these are used".to_string(),
                Use::Compensate => format!(
                    "only these are compensated and written (the other {} rows are left out), and the correction's mean is taken over them",
                    selection.left_out
                ),
            };
            format!("{}: {}; {consequence}", path.display(), selection.summary)
        }
        Warning::ColumnsAliased { .. } => warning.to_string(),
        other => format!("warning: {other}"),
    }
}

/// A library error, with the flag that fixes it where one does.
pub fn error(e: Error) -> anyhow::Error {
    match e {
        Error::NoSampleRate { path } => anyhow::anyhow!(
            "{}: no time column \"tt\" to take the sample rate from; give it with --fs HZ",
            path.display()
        ),
        Error::TimeUnusable { path } => anyhow::anyhow!(
            "{}: time column \"tt\" has no two successive usable times (all missing, non-numeric or not increasing), so it gives no sample rate; give it with --fs HZ",
            path.display()
        ),
        Error::BadSampleRate { fs_hz } => {
            anyhow::anyhow!("--fs must be a positive number of hertz, got {fs_hz}")
        }
        Error::Select(SelectError::NoColumn {
            path,
            by,
            column,
            near,
        }) => anyhow::anyhow!("{}: --{by} needs a column {column:?}{near}", path.display()),
        Error::Select(SelectError::UnknownLine {
            path,
            line,
            present,
        }) => anyhow::anyhow!(
            "{}: --line {line}: no row is on that line; the file's lines are {present}",
            path.display()
        ),
        Error::Rename { old, new, source } => {
            anyhow::anyhow!("--rename {old}={new}: {source}")
        }
        Error::VectorSpec { spec, reason } => anyhow::anyhow!("--vector {spec:?}: {reason}"),
        Error::NoSuchManeuver { name, found, .. } => anyhow::anyhow!(
            "--ignore {name:?}: no such maneuver in the flight; found: {}",
            found.join(", ")
        ),
        Error::ManeuverList(e) => anyhow::anyhow!("--maneuvers: {e}"),
        Error::ScalarNeeded { path: None, .. } => {
            anyhow::anyhow!("--scalar is needed: name the scalar column (or give a --model with one fit)")
        }
        Error::ScalarNeeded {
            path: Some(path),
            available,
        } => anyhow::anyhow!(
            "{}: the model holds fits for {} scalars; choose one with --scalar {}",
            path.display(),
            available.len(),
            available.join("|")
        ),
        Error::Io(IoError::MissingColumn { path, column, near }) => {
            anyhow::anyhow!(
                "{}: no column {column:?}{near}{}",
                path.display(),
                rename_hint(&column, &near)
            )
        }
        other => anyhow::Error::new(other),
    }
}

/// ` (if it is, --rename NEAR=COLUMN)` when one column is near `column`: the flag that lets
/// any command read a file whose names differ from the model's or the schema's.
fn rename_hint(column: &str, near: &Near) -> String {
    let near = near
        .only()
        .filter(|near| !near.contains([',', ':', ' ']))
        // A fluxgate's component suggests a fluxgate's prefix: --vector names it.
        .filter(|_| {
            let column = column.to_ascii_lowercase();
            !["_x", "_y", "_z"].iter().any(|axis| column.ends_with(axis))
        });
    match near {
        Some(near) if !near.eq_ignore_ascii_case(column) => {
            format!(" (if it is, --rename {near}={column})")
        }
        _ => String::new(),
    }
}

/// `result` with a library error rendered by [`error`].
pub trait OrRender<T> {
    fn or_render(self) -> anyhow::Result<T>;
}

impl<T> OrRender<T> for Result<T, Error> {
    fn or_render(self) -> anyhow::Result<T> {
        self.map_err(error)
    }
}

/// Builds the report `request` asks for, of each of `scalars` (see
/// [`tolles::report::build_each`]), and writes it as HTML to the directory `out`, saying
/// on stderr what was noticed; returns the path of index.html.
pub fn report(request: &ReportRequest, scalars: &[String], out: &Path) -> anyhow::Result<PathBuf> {
    let mut noticed = Vec::new();
    let data = tolles::report::build_each(request, scalars, &Terminal::default(), &mut noticed);
    let on_page = noticed.clone();
    warnings(&mut noticed, Use::Other);
    tolles_report::flight::write_each(&data.or_render()?, &on_page, out)
        .with_context(|| format!("writing the report to {}", out.display()))
}

/// What a fit of the flight `cal` found, on stderr: samples used, residual, the term sets and
/// ridge compared, the coefficients and the patent's terms.
pub fn fit_summary(model: &ScalarModel, cal: &Path) -> std::io::Result<()> {
    let d = &model.fit.diagnostics;
    let mut err = std::io::stderr().lock();
    writeln!(
        err,
        "fit {} ~ {} ({}, {} magnitude) on {}: {} of {} samples used",
        model.scalar,
        model.vectors.join(","),
        model.fit.settings.design.terms,
        model.fit.magnitude,
        cal.display(),
        d.samples_used,
        d.samples_total
    )?;
    if d.samples_nonfinite > 0 {
        writeln!(
            err,
            "  skipped {} samples with missing or non-finite values",
            d.samples_nonfinite
        )?;
    }
    if d.samples_in_short_runs > 0 {
        writeln!(
            err,
            "  skipped {} samples in runs too short to filter",
            d.samples_in_short_runs
        )?;
    }
    let target = match &model.reference {
        Some(reference) => format!("{} − {reference} (full band)", model.scalar),
        None => "filtered scalar".to_string(),
    };
    writeln!(
        err,
        "  {target} {:.4} nT -> residual {:.4} nT (improvement ×{:.2}), cond(AᵀA+Λ) = {:.3e}",
        d.filtered_std_before_nt, d.residual_std_nt, d.improvement_ratio, d.condition_number
    )?;
    for score in &d.term_choice {
        writeln!(
            err,
            "  terms {:<34} held-out residual {}{}",
            if score.extras.is_empty() {
                format!("{} {}", score.terms, score.magnitude)
            } else {
                format!(
                    "{}+{} {}",
                    score.terms,
                    score
                        .extras
                        .iter()
                        .map(ToString::to_string)
                        .collect::<Vec<_>>()
                        .join("+"),
                    score.magnitude
                )
            },
            held_out_text(score),
            if score.chosen { "  <- chosen" } else { "" }
        )?;
    }
    if let Some(learned) = &model.network {
        let layers: Vec<String> = (learned.network.hidden_units().iter())
            .map(ToString::to_string)
            .collect();
        writeln!(
            err,
            "  network ({} inputs, layers {}, {}, seed {}): on held-out {} it leaves {} nT where the linear model leaves {} nT ({:.1} % less); kept (epoch {} of {})",
            learned.network.inputs.len(),
            layers.join(","),
            learned.network.activation,
            learned.seed,
            learned.held_out,
            tolles::warning::significant(learned.judged_network_rms_nt),
            tolles::warning::significant(learned.judged_linear_rms_nt),
            100.0 * (1.0 - learned.judged_network_rms_nt / learned.judged_linear_rms_nt),
            learned.best_epoch,
            learned.epochs
        )?;
    }
    if model.fit.lag_s != 0.0 {
        writeln!(
            err,
            "  fluxgate lag behind the scalar: {:.4} s ({:.3} samples); compensation applies it",
            model.fit.lag_s,
            model.fit.lag_s * model.fit.fs_hz
        )?;
    }
    if let Some([x, y, z]) = model.fit.flux_offset_nt {
        writeln!(
            err,
            "  fluxgate offset taken out before the design: {x:.1}, {y:.1}, {z:.1} nT (x, y, z); compensation takes it out too"
        )?;
    }
    if d.exact_iterations > 0 {
        writeln!(
            err,
            "  exact magnitude |B + H| − |B|: {} Gauss-Newton iterations",
            d.exact_iterations
        )?;
    }
    if let Some(levels) = &d.levels {
        let o = levels.fluxgate.offset_nt;
        writeln!(
            err,
            "  heading levels: {} rows below {} Hz against the calibrated fluxgate (offset {:.1}, {:.1}, {:.1} nT); misfit {:.4} nT, a heading's level to ±{:.4} nT",
            levels.rows, levels.cutoff_hz, o[0], o[1], o[2], levels.residual_rms_nt, levels.level_std_error_nt
        )?;
    }
    if let Some(misfit) = d.untrusted_levels_nt {
        writeln!(
            err,
            "  heading levels: not used: the calibration's low frequencies miss the band's model by {misfit:.1} nT RMS, more than geology-free levels would (geology under legs far apart, diurnal variation); the fit is the band's alone"
        )?;
    }
    if let Some(cv) = &d.cross_validation {
        let ridge = match cv.chosen_prior_multiplier {
            Some(_) => format!("the physical prior ×{}", prior_multipliers(model)),
            None => format!("λ = {}·diag(AᵀA)", short_number(cv.chosen_lambda_rel)),
        };
        writeln!(
            err,
            "  ridge: {ridge} chosen by {}-fold blocked cross-validation; expected residual on new data {:.4} nT",
            cv.folds,
            cv.expected_heldout_rms_nt
        )?;
    }
    if let Some(e) = d.excitation_deg {
        writeln!(
            err,
            "  maneuvers: the fluxgate's direction moved {e:.2}° RMS inside the band"
        )?;
    }
    writeln!(
        err,
        "  {:<12} {:>14} {:>12}  unit",
        "term", "coefficient", "std error"
    )?;
    let columns = model.fit.columns.iter().zip(&model.fit.coefficients);
    for (k, ((name, beta), se)) in columns.zip(&d.std_errors).enumerate() {
        let unit = model.coefficient_unit(k);
        writeln!(err, "  {name:<12} {beta:>14.6} {se:>12.4}  {unit}")?;
    }
    let p = &model.patent;
    writeln!(
        err,
        // Induced terms span 1e-6 to 1e-1: significant digits, never a row of zeros.
        "  patent terms: perm T {:.3} L {:.3} V {:.3} nT; induced VV-TT {:.4e} VV-LL {:.4e} TL+LT {:.4e} TV+VT {:.4e} LV+VL {:.4e}",
        p.perm_nt.t, p.perm_nt.l, p.perm_nt.v, p.induced.vv_tt, p.induced.vv_ll, p.induced.tl_lt, p.induced.tv_vt, p.induced.lv_vl
    )?;
    if let Some(v) = &model.fit.verdict {
        verdict(&mut err, &model.scalar, v)?;
    }
    Ok(())
}

/// `verdict: good`, or the grade and one reason per line; then one line per note.
pub fn verdict(
    out: &mut dyn Write,
    scalar: &str,
    v: &tolles_core::fit::verdict::Verdict,
) -> std::io::Result<()> {
    writeln!(out, "verdict for {scalar}: {}", v.grade)?;
    for reason in &v.reasons {
        writeln!(out, "  - {reason}")?;
    }
    for note in &v.notes {
        writeln!(out, "  note: {note}")?;
    }
    Ok(())
}

/// A term set's held-out residual, and with heading levels the level rows' and the score the
/// choice compares (their `hypot`), so the chosen set is seen to have the lowest.
fn held_out_text(score: &tolles_core::fit::TermScore) -> String {
    match (score.heldout_rms_nt, score.heldout_low_rms_nt) {
        (None, _) => "(could not be fitted)".to_string(),
        (Some(band), None) => format!("{band:.4} nT"),
        (Some(band), Some(low)) => format!(
            "{band:.4} nT, levels {low:.4} nT: score {:.4} nT",
            band.hypot(low)
        ),
    }
}

/// The prior's multiples chosen: one, or per kind of term when they differ.
fn prior_multipliers(model: &ScalarModel) -> String {
    let d = &model.fit.diagnostics;
    let Some(cv) = &d.cross_validation else {
        return String::new();
    };
    let common = cv.chosen_prior_multiplier.unwrap_or(1.0);
    if cv.prior_multipliers.iter().all(|m| *m == common) {
        return short_number(common);
    }
    let mut kinds: Vec<(&str, f64)> = Vec::new();
    let columns = model.fit.settings.design.columns();
    for (column, m) in columns.iter().zip(&cv.prior_multipliers) {
        let Some(group) = tolles_core::fit::prior::Group::of(*column) else {
            continue;
        };
        let name = match group {
            tolles_core::fit::prior::Group::Permanent => "permanent",
            tolles_core::fit::prior::Group::Induced => "induced",
            tolles_core::fit::prior::Group::Eddy => "eddy",
            tolles_core::fit::prior::Group::Extra => "extra",
        };
        if !kinds.iter().any(|(n, _)| *n == name) {
            kinds.push((name, *m));
        }
    }
    let list: Vec<String> = kinds
        .iter()
        .map(|(n, m)| format!("{} {n}", short_number(*m)))
        .collect();
    list.join(", ")
}

/// `0`, `1e-8`, `0.001`: the shortest honest text for a ridge strength.
fn short_number(x: f64) -> String {
    if x == 0.0 || (1e-3..1e3).contains(&x.abs()) {
        format!("{x}")
    } else {
        format!("{x:e}")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn one_near_name_suggests_the_rename_that_reads_it() {
        let one = Near::Names(vec!["MAG".into()]);
        assert_eq!(
            rename_hint("mag_1_uc", &one),
            " (if it is, --rename MAG=mag_1_uc)"
        );
        // Several names, a fluxgate's spelling, the header itself: nothing to rename to.
        for near in [
            Near::Names(vec!["A".into(), "B".into()]),
            Near::Names(vec!["FX:FY:FZ".into()]),
            Near::Header {
                first: vec!["MAG".into()],
                more: 0,
            },
        ] {
            assert_eq!(rename_hint("mag_1_uc", &near), "", "{near}");
        }
        // A fluxgate's component: --vector names the fluxgate, not --rename.
        assert_eq!(
            rename_hint("flux_a_x", &Near::Names(vec!["FLUXA".into()])),
            ""
        );
    }
}
