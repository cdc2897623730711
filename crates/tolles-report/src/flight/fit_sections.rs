//! The model's sections of a flight report: coefficients, the physical and patent terms, the
//! fit's diagnostics and the choice of terms.

use super::*;

/// Coefficients with standard errors, the aircraft's field they describe and the patent's terms,
/// after `from`: which flight the model was fitted on.
pub(super) fn model(report: Report, model: &ScalarModel, from: &str) -> Report {
    let fit = &model.fit;
    let rows: Vec<Vec<String>> = fit
        .columns
        .iter()
        .zip(&fit.coefficients)
        .zip(&fit.diagnostics.std_errors)
        .enumerate()
        .map(|(k, ((name, beta), se))| {
            // To the standard error's digits: the rest is noise (the model file keeps them).
            let (beta, se) = crate::numbers::to_error(*beta, *se);
            vec![name.clone(), beta, se, model.coefficient_unit(k)]
        })
        .collect();
    let fluxgates = if model.vectors.len() > 1 {
        "fluxgates"
    } else {
        "fluxgate"
    };
    let report = report
        .section("Model")
        .paragraph(from)
        .paragraph(format!(
            "Fit of {} against {fluxgates} {} with terms {} and the {} magnitude; sample rate {:.3} Hz. \
             Each column is dimensionless (B̂ = B/|B| for the permanent terms, B̂ᵢ·Bⱼ/Bt_scale \
             for the induced and B̂ᵢ·Ḃⱼ/Bt_scale, Ḃ per sample, for the eddy terms), so every \
             coefficient is in nT (an extra channel's in nT per its unit). Each is shown to its \
             standard error's two significant digits; the model file keeps every digit.",
            model.scalar,
            model.vectors.join(", "),
            fit.settings.design.terms,
            match fit.magnitude {
                tolles::tolles_core::model::magnitude::Magnitude::Linear => "linear (B̂·H)",
                tolles::tolles_core::model::magnitude::Magnitude::Exact => "exact (|B + H| − |B|)",
            },
            fit.fs_hz
        ))
        .table(&["column", "coefficient", "standard error", "unit"], &rows);
    let report = physical(report, model);
    patent(report, model)
}

/// The aircraft's field the coefficients describe: permanent vector (nT), induced matrix
/// (dimensionless) and eddy-current matrix (s).
pub(super) fn physical(report: Report, model: &ScalarModel) -> Report {
    let field = &model.physical;
    let axes = ["x (forward)", "y (right)", "z (down)"];
    let matrix_rows = |m: &[[f64; 3]; 3]| -> Vec<Vec<String>> {
        axes.iter()
            .zip(m)
            .map(|(axis, row)| {
                let cells = row.iter().map(|v| format_value(*v));
                std::iter::once(axis.to_string()).chain(cells).collect()
            })
            .collect()
    };
    let headers = ["aircraft field along ↓, earth field along →", "x", "y", "z"];
    let p = field.permanent_nt;
    report
        .paragraph(format!(
            "The same coefficients as the aircraft's field{}: permanent field P = ({:.3}, {:.3}, \
             {:.3}) nT (x, y, z); the induced matrix I (dimensionless: nT of aircraft field per nT \
             of earth field) and the eddy-current matrix E (s: nT of aircraft field per nT/s of \
             change of the earth field). Terms the fit did not have are zero. Only the traceless \
             part of each matrix (and the symmetric part of I) reaches a scalar magnetometer, so \
             the trace shown is the one the chosen terms imply.",
            if model.vectors.len() > 1 {
                " at the first fluxgate"
            } else {
                ""
            },
            p[0],
            p[1],
            p[2]
        ))
        .paragraph("Induced matrix I (dimensionless):")
        .table(&headers, &matrix_rows(&field.induced))
        .paragraph("Eddy-current matrix E (s):")
        .table(&headers, &matrix_rows(&field.eddy_s))
}

pub(super) fn patent(report: Report, model: &ScalarModel) -> Report {
    let rows: Vec<Vec<String>> = model
        .patent
        .named()
        .iter()
        .map(|(name, value)| {
            // Eddy terms are lower case (s), permanent ones T, L, V (nT), induced ones ratios.
            let unit = match name.chars().next() {
                Some(c) if c.is_lowercase() => "s",
                _ if ["T", "L", "V"].contains(name) => "nT",
                _ => "1",
            };
            vec![name.to_string(), format!("{value:.5e}"), unit.into()]
        })
        .collect();
    report
        .paragraph(if model.vectors.len() > 1 {
            "The first fluxgate's block in the Tolles patent's terms (L = forward, T = right, V = down):"
        } else {
            "The same model in the Tolles patent's terms (L = forward, T = right, V = down):"
        })
        .table(&["term", "value", "unit"], &rows)
}

/// The fit's diagnostics, its cross-validation and the term sets it compared, after `from`:
/// which flight the model was fitted on.
pub(super) fn diagnostics(mut report: Report, model: &ScalarModel, from: &str) -> Report {
    let d = &model.fit.diagnostics;
    let band = model.fit.settings.target == Target::Band;
    let mut items = vec![
        (
            "samples used",
            format!("{} of {}", d.samples_used, d.samples_total),
        ),
        (
            "samples skipped (missing values)",
            d.samples_nonfinite.to_string(),
        ),
        (
            match band {
                true => "scalar in the fit's band, before",
                false => "scalar minus the reference, before (unfiltered)",
            },
            format!("{:.4} nT", d.filtered_std_before_nt),
        ),
        (
            match band {
                true => "residual in the fit's band",
                false => "residual (unfiltered)",
            },
            format!("{:.4} nT", d.residual_std_nt),
        ),
        (
            "fit's improvement (before / residual; not the FOM's)",
            format!("×{:.2}", d.improvement_ratio),
        ),
        (
            "condition number of AᵀA + ridge penalty",
            format!("{:.3e}", d.condition_number),
        ),
    ];
    if let Some(cv) = &d.cross_validation {
        items.push((
            "ridge λ (× diag AᵀA)",
            format!("{:e}", cv.chosen_lambda_rel),
        ));
        items.push((
            match model.network {
                Some(_) => "expected held-out residual, linear model alone",
                None => "expected held-out residual",
            },
            format!("{:.4} nT", cv.expected_heldout_rms_nt),
        ));
    }
    if let Some(network) = &model.network {
        // What the model as applied leaves: the linear model's figures above are without it.
        items.push((
            "held-out residual with the network",
            format!(
                "{:.4} nT (the linear model alone: {:.4} nT, on the same held-out {})",
                network.judged_network_rms_nt, network.judged_linear_rms_nt, network.held_out
            ),
        ));
    }
    if d.exact_iterations > 0 {
        items.push((
            "Gauss-Newton iterations (exact magnitude)",
            d.exact_iterations.to_string(),
        ));
    }
    if let Some(levels) = &d.levels {
        let o = levels.fluxgate.offset_nt;
        items.push((
            "fluxgate offset found (x, y, z)",
            format!("{:.1}, {:.1}, {:.1} nT", o[0], o[1], o[2]),
        ));
        items.push((
            "heading-level rows, misfit",
            format!(
                "{} below {} Hz, {:.4} nT",
                levels.rows, levels.cutoff_hz, levels.residual_rms_nt
            ),
        ));
        items.push((
            "a heading's level determined to",
            format!("± {:.4} nT", levels.level_std_error_nt),
        ));
    }
    report = report
        .section("Fit diagnostics")
        .paragraph(from)
        .key_values(&borrowed(&items))
        .paragraph(fit_definitions(model));
    if let Some(cv) = &d.cross_validation {
        // With a prior the sweep is over its multiplier at one λ: that is the column to show.
        let prior = cv.grid.iter().any(|p| p.prior_multiplier.is_some());
        let rows: Vec<Vec<String>> = cv
            .grid
            .iter()
            .map(|p| {
                let rms = p.heldout_rms_nt;
                let rms = rms.map_or("not solvable".into(), |r| format!("{r:.5}"));
                let chosen = p.lambda_rel == cv.chosen_lambda_rel
                    && p.prior_multiplier == cv.chosen_prior_multiplier;
                let mut row = vec![format!("{:e}", p.lambda_rel)];
                if prior {
                    row.push(p.prior_multiplier.map_or("-".into(), |m| format!("{m:e}")));
                }
                row.extend([rms, if chosen { "chosen" } else { "" }.into()]);
                row
            })
            .collect();
        let mut headers = vec!["λ (× diag AᵀA)"];
        if prior {
            headers.push("× the physical prior");
        }
        headers.extend(["held-out RMS (nT)", ""]);
        report = report
            .paragraph(format!(
                "{}-fold blocked cross-validation over time{}:",
                cv.folds,
                match prior {
                    true => ", the physical prior's strength swept (its groups then tuned apart)",
                    false => "",
                }
            ))
            .table(&headers, &rows);
    }
    term_choice(report, model)
}

/// What the diagnostics' standard deviations are taken of.
pub(super) fn fit_definitions(model: &ScalarModel) -> String {
    let settings = &model.fit.settings;
    let filtered = if settings.target == Target::Band {
        format!(
            "band-passed {}–{} Hz, as the fit saw it",
            settings.band.pass1_hz, settings.band.pass2_hz
        )
    } else {
        "unfiltered: the fit's target was the aircraft's field itself".to_string()
    };
    format!(
        "Scalar before and residual: standard deviations over the samples used of the scalar \
         and of the scalar minus the model ({filtered}). The fit's improvement: the first \
         divided by the second (the summary's improvement is the FOM's ratio, on this \
         flight). The condition number (2-norm) measures how well the \
         coefficients are determined: each factor of ten costs about a digit."
    )
}

/// A compared model's terms, with `+` the extra channels it used (rows alike otherwise).
fn with_extras(score: &tolles::tolles_core::fit::TermScore) -> String {
    let extras: Vec<String> = score.extras.iter().map(ToString::to_string).collect();
    match extras.is_empty() {
        true => score.terms.to_string(),
        false => format!("{}+{}", score.terms, extras.join("+")),
    }
}

pub(super) fn term_choice(report: Report, model: &ScalarModel) -> Report {
    let choice = &model.fit.diagnostics.term_choice;
    if choice.is_empty() {
        return report;
    }
    let rows: Vec<Vec<String>> = choice
        .iter()
        .map(|t| {
            vec![
                with_extras(t),
                t.magnitude.to_string(),
                t.lambda_rel.map_or("-".into(), |l| format!("{l:e}")),
                t.heldout_rms_nt
                    .map_or("could not be fitted".into(), |r| format!("{r:.5}")),
                t.heldout_low_rms_nt
                    .map_or("-".into(), |r| format!("{r:.5}")),
                if t.chosen { "chosen" } else { "" }.into(),
            ]
        })
        .collect();
    report
        .paragraph(
            "Models compared on the same folds (a larger term set must be 2 % better; the score is the band's and the heading levels' held-out RMS added in quadrature):",
        )
        .table(
            &[
                "terms",
                "magnitude",
                "λ (× diag AᵀA)",
                "held-out RMS (nT)",
                "held-out levels (nT)",
                "",
            ],
            &rows,
        )
}

#[cfg(test)]
mod tests {
    use super::*;
    use tolles::tolles_core::fit::TermScore;

    #[test]
    fn a_compared_model_with_extras_is_named_with_them() {
        let mut score = TermScore {
            terms: "permanent,i5,e8".parse().unwrap(),
            extras: Vec::new(),
            magnitude: Default::default(),
            lambda_rel: Some(1e-9),
            heldout_rms_nt: Some(0.01),
            heldout_low_rms_nt: None,
            chosen: true,
        };
        assert_eq!(with_extras(&score), "permanent,i5,e8");
        score.extras = vec!["cur_1".parse().unwrap(), "cur_2".parse().unwrap()];
        assert_eq!(with_extras(&score), "permanent,i5,e8+cur_1+cur_2");
    }
}
