//! Whether to trust a fitted model: `good`, `doubtful` with reasons, or `refused`.
//!
//! ```
//! use tolles_core::fit::verdict::{Grade, Reason, Verdict};
//!
//! let verdict = Verdict::of(vec![Reason::FluxgateOffset { offset_nt: 693.0 }]);
//! assert_eq!(verdict.grade, Grade::Doubtful);
//! assert_eq!(
//!     verdict.to_string(),
//!     "doubtful: the fluxgate's calibration found an offset of 693 nT (a fluxgate's own offset \
//!      is tens of nT; beyond 300 nT it sees the aircraft: --fluxgate-offset on takes it out \
//!      before the fit)"
//! );
//! assert_eq!(Verdict::of(vec![]).to_string(), "good");
//! ```
//!
//! A fit always finds coefficients; whether they describe the aircraft is another matter. The
//! verdict collects what the fit itself can tell, each with a threshold stated here and in the
//! README's "When not to trust a model":
//!
//! | reason | doubtful when |
//! |---|---|
//! | no maneuvers | the fluxgate's direction moved less than [`MIN_EXCITATION_DEG`] RMS inside the band |
//! | uncertain model | the correction's own uncertainty reaches [`MAX_UNCERTAINTY_RATIO`] of the correction |
//! | implausible, restrained | the fit found a field beyond [`crate::fit::plausible`]'s bounds and its prior was strengthened until it did not |
//! | held out much worse | held-out RMS more than [`MAX_HELDOUT_RATIO`] × the in-sample residual |
//! | little explained | the band-passed scalar improved less than [`MIN_IMPROVEMENT`] × |
//! | unexplained interference | against a reference, the interference improved less than [`MIN_INTERFERENCE_IMPROVEMENT`] × |
//! | heading levels | the low-frequency rows miss the levels by more than [`MAX_LEVEL_MISFIT_NT`], or by more than [`MAX_LEVEL_MISFIT_RATIO`] times what the reference's noise leaves |
//! | fluxgate offset | the fluxgate's calibrated offset exceeds [`MAX_FLUXGATE_OFFSET_NT`] |
//! | second order | a linear magnitude that no exact fit was tried against leaves out a field [`MAX_SECOND_ORDER_RATIO`] × what the model leaves |
//!
//! Each reason's text names its remedy. A *note* does not lower the grade: terms whose standard
//! error exceeds their value and moves the correction by more than [`MIN_TERM_EFFECT_NT`]
//! ([`Reason::UncertainTerms`]) are noted, since each row's σ carries their cost and on real
//! boxes they did not predict a worse held-out residual.
//!
//! `refused` is a fit that found an implausible field even with its terms restrained: `tolles
//! fit` writes no model then.

use crate::fit::plausible::Fault;
use serde::{Deserialize, Serialize};
use std::fmt;

/// RMS change of the fluxgate's direction inside the fitting band (degrees) below which the
/// calibration had no maneuvers: turbulence moves it a few tenths of a degree, a box's rolls
/// and pitches several degrees.
pub const MIN_EXCITATION_DEG: f64 = 1.0;

/// Ratio of the correction's RMS uncertainty to its standard deviation over the calibration
/// flight from which the model is doubtful.
pub const MAX_UNCERTAINTY_RATIO: f64 = 0.3;

/// Smallest change (nT RMS) a term's standard error must make to the correction to count.
pub const MIN_TERM_EFFECT_NT: f64 = 1.0;

/// Held-out RMS over in-sample residual from which the fit is doubtful: it fits its own data
/// much better than data it has not seen. Blocked folds of a box leave out a heading at a
/// time, and good fits of simulated boxes reach 1.2–1.7.
pub const MAX_HELDOUT_RATIO: f64 = 3.0;

/// Improvement of the band-passed scalar's scatter below which the model explains little.
pub const MIN_IMPROVEMENT: f64 = 1.5;

/// Improvement of the interference's scatter (a fit against a reference, in the full band)
/// below which the model leaves a source its terms do not describe. The target is the
/// aircraft's field itself, which a model of it explains to the reference's own errors: a
/// simulated cabin against a perfect reference improved ×1 900–2 000; with a UAV's motor
/// current left out, ×4.1, and the permanent field it found was twice the truth.
pub const MIN_INTERFERENCE_IMPROVEMENT: f64 = 10.0;

/// RMS misfit of the heading levels (nT) from which the model is doubtful.
pub const MAX_LEVEL_MISFIT_NT: f64 = 2.0;

/// Ratio of the heading levels' RMS misfit to what the fluxgate reference's noise leaves of
/// them from which the model is doubtful: no candidate describes the band and the low
/// frequencies together, and the compromise may serve a survey worse than the band alone. On
/// `bench/installations` the ratio was 3.0–3.5 where the levels cost a survey 3–7× (its
/// installations 5 and 11; also 3.0 on 3 and 14, at 2.8× and 1.2× the oracle), at most 2.0 on
/// the other eleven, and 1.1–2.2 on eight of our simulator's cabin and tail-stinger boxes.
pub const MAX_LEVEL_MISFIT_RATIO: f64 = 2.5;

/// A fluxgate offset (nT) beyond which its calibration is doubtful.
pub const MAX_FLUXGATE_OFFSET_NT: f64 = 300.0;

/// Ratio of the second-order field a linear magnitude leaves out (RMS over the calibration) to
/// what the model leaves of the scalar, from which the model is doubtful. The fit absorbs most
/// of that field into its coefficients, the more the weaker it is: on `bench/verdict`'s cabins
/// with a current, fits at 1.0–1.6× the oracle reached ratios up to 5.0, and the 420 nT cabin
/// that left 34× the oracle 12.8.
pub const MAX_SECOND_ORDER_RATIO: f64 = 8.0;

/// How far to trust a model.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Grade {
    /// Nothing the fit can see speaks against it.
    Good,
    /// Use with care: the reasons say why.
    Doubtful,
    /// Not to be used: no model is written.
    Refused,
}

impl fmt::Display for Grade {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Grade::Good => "good",
            Grade::Doubtful => "doubtful",
            Grade::Refused => "refused",
        })
    }
}

/// One reason for doubt.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "reason", rename_all = "snake_case")]
pub enum Reason {
    /// The fluxgate's direction hardly moved inside the band.
    NoManeuvers {
        /// Its RMS change inside the band (degrees).
        excitation_deg: f64,
    },
    /// The correction is about as uncertain as it is large.
    Uncertain {
        /// RMS of the correction's standard error over the calibration (nT).
        uncertainty_nt: f64,
        /// Standard deviation of the correction over the calibration (nT).
        correction_nt: f64,
    },
    /// Terms whose standard error exceeds their value and matters.
    UncertainTerms {
        /// The terms' names.
        terms: Vec<String>,
    },
    /// The fit found an implausible field and its terms were restrained.
    Restrained {
        /// What was implausible before restraint.
        fault: Fault,
    },
    /// A field beyond the bounds, left as found (a fixed λ: MagNav's procedure exactly).
    Implausible {
        /// What is implausible.
        fault: Fault,
    },
    /// Held-out data fits much worse than the data fitted.
    HeldOutWorse {
        /// Held-out RMS (nT).
        heldout_nt: f64,
        /// In-sample residual (nT).
        insample_nt: f64,
    },
    /// The model explains little of the band-passed scalar.
    LittleExplained {
        /// Band-passed std before over after.
        improvement: f64,
    },
    /// Against a reference, the model leaves much of the interference unexplained.
    UnexplainedInterference {
        /// The interference's std before over after.
        improvement: f64,
    },
    /// The heading levels disagree with the model.
    LevelMisfit {
        /// RMS misfit of the level rows (nT).
        misfit_nt: f64,
        /// What the reference's noise would leave of them (nT); absent in files before it.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        expected_nt: Option<f64>,
    },
    /// The fluxgate's calibration found an offset no fluxgate has.
    FluxgateOffset {
        /// The largest offset component (nT).
        offset_nt: f64,
    },
    /// A linear magnitude leaves out a second-order field larger than what the model leaves.
    SecondOrder {
        /// Standard deviation over the calibration of `|B + H| − |B| − B̂·H` (nT).
        second_order_nt: f64,
        /// What the model leaves of the scalar at every frequency (nT), σ's noise term.
        left_nt: f64,
    },
}

impl fmt::Display for Reason {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Reason::NoManeuvers { excitation_deg } => write!(
                f,
                "no maneuvers: the fluxgate's direction moved {excitation_deg:.2}° RMS inside the band \
                 (below {MIN_EXCITATION_DEG}°; a box's rolls and pitches move it several degrees): \
                 fit a calibration box (rolls ±10°, pitches ±5°, yaws ±5° on four headings)"
            ),
            Reason::Uncertain {
                uncertainty_nt,
                correction_nt,
            } => write!(
                f,
                "the correction's own uncertainty is {uncertainty_nt:.3} nT RMS against a correction of \
                 {correction_nt:.3} nT: fly more or larger maneuvers, or fit fewer terms (--terms)"
            ),
            Reason::UncertainTerms { terms } => write!(
                f,
                "standard errors as large as the coefficients of {} (the maneuvers hardly tell them \
                 apart from other terms; each row's σ, --uncertainty, carries what that costs)",
                terms.join(", ")
            ),
            Reason::Restrained { fault } => write!(
                f,
                "the fit found {fault}; its terms were held to physical sizes by a stronger prior \
                 (check the scalar and fluxgate columns; a current's field needs --extra)"
            ),
            Reason::Implausible { fault } => write!(
                f,
                "the model has {fault}, a field no aircraft has (a fixed λ leaves it as fitted; \
                 --lambda auto restrains it)"
            ),
            Reason::HeldOutWorse {
                heldout_nt,
                insample_nt,
            } => write!(
                f,
                "held-out data fits to {heldout_nt:.3} nT, against {insample_nt:.3} nT in sample: \
                 fly more maneuvers, or fit fewer terms (--terms patent)"
            ),
            Reason::LittleExplained { improvement } => write!(
                f,
                "the band-passed scalar improved only ×{improvement:.2}: an interference source may be \
                 missing from the regressors"
            ),
            Reason::UnexplainedInterference { improvement } => write!(
                f,
                "against the reference the model explains the interference only ×{improvement:.1} \
                 (below ×{MIN_INTERFERENCE_IMPROVEMENT}): a source its terms do not describe is \
                 left, and it bends the terms it has (--extra for a current's channel; check the \
                 reference)"
            ),
            Reason::LevelMisfit {
                misfit_nt,
                expected_nt,
            } => {
                write!(f, "the heading levels miss the model by {misfit_nt:.2} nT RMS")?;
                if let Some(e) = expected_nt {
                    write!(f, " where the fluxgate reference allows {e:.2} nT")?;
                }
                write!(
                    f,
                    " (geology or diurnal variation under the legs, or terms the model lacks: \
                     --levels off fits the band alone)"
                )
            }
            Reason::FluxgateOffset { offset_nt } => write!(
                f,
                "the fluxgate's calibration found an offset of {offset_nt:.0} nT (a fluxgate's own offset \
                 is tens of nT; beyond {MAX_FLUXGATE_OFFSET_NT:.0} nT it sees the aircraft: \
                 --fluxgate-offset on takes it out before the fit)"
            ),
            Reason::SecondOrder {
                second_order_nt,
                left_nt,
            } => write!(
                f,
                "the linear magnitude leaves out a second-order field of {second_order_nt:.3} nT \
                 RMS (|H⊥|²/2|B| of the field it found), more than the {left_nt:.3} nT the model \
                 leaves: it varies with attitude and reaches the survey (extra channels and \
                 several fluxgates stay linear by default: --magnitude exact models it)"
            ),
        }
    }
}

/// A grade, its reasons and what else the fit noticed.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Verdict {
    /// How far the fit can be trusted.
    pub grade: Grade,
    /// Why the grade is not good; empty when it is.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub reasons: Vec<Reason>,
    /// What the fit noticed that does not lower the grade, because it does not predict a worse
    /// compensation: terms the maneuvers hardly tell apart ([`Reason::UncertainTerms`]), whose
    /// cost each row's σ already carries. On deinterf's real SGL box it named terms of six of
    /// nine pairs whose held-out residual was as good as the other three's.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub notes: Vec<Reason>,
}

impl Verdict {
    /// `good` without reasons, `doubtful` with.
    pub fn of(reasons: Vec<Reason>) -> Self {
        let grade = match reasons.is_empty() {
            true => Grade::Good,
            false => Grade::Doubtful,
        };
        Self {
            grade,
            reasons,
            notes: Vec::new(),
        }
    }

    /// The same verdict with `notes`.
    pub fn with_notes(self, notes: Vec<Reason>) -> Self {
        Self { notes, ..self }
    }

    /// A refusal for `reasons`.
    pub fn refused(reasons: Vec<Reason>) -> Self {
        Self {
            grade: Grade::Refused,
            reasons,
            notes: Vec::new(),
        }
    }

    /// True for [`Grade::Good`].
    pub fn is_good(&self) -> bool {
        self.grade == Grade::Good
    }
}

impl fmt::Display for Verdict {
    /// The grade, then its reasons separated by semicolons.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", self.grade)?;
        for (k, reason) in self.reasons.iter().enumerate() {
            write!(f, "{}{reason}", if k == 0 { ": " } else { "; " })?;
        }
        Ok(())
    }
}

/// What [`judge`] reads of a fit.
#[derive(Debug, Clone, PartialEq)]
pub struct Evidence {
    /// RMS change of the fluxgate's direction inside the band (degrees); NaN when unknown.
    pub excitation_deg: f64,
    /// RMS uncertainty and standard deviation of the correction over the calibration (nT).
    pub uncertainty_nt: f64,
    /// Standard deviation of the correction over the calibration (nT).
    pub correction_nt: f64,
    /// Terms whose standard error exceeds their value and matters.
    pub uncertain_terms: Vec<String>,
    /// The fault restrained, or found and left (fixed λ).
    pub restrained: Option<Fault>,
    /// The fault found and left as it was (fixed λ); `None` when there is none.
    pub implausible: Option<Fault>,
    /// Held-out RMS and in-sample residual (nT); NaN without cross-validation.
    pub heldout_nt: f64,
    /// In-sample residual (nT).
    pub insample_nt: f64,
    /// Band-passed std before over after (the interference's, against a reference).
    pub improvement: f64,
    /// True when the target was the interference itself (a reference subtracted, the full
    /// band fitted) rather than the band-passed scalar.
    pub interference: bool,
    /// Level rows' RMS misfit (nT), NaN without levels.
    pub level_misfit_nt: f64,
    /// What the level rows' misfit would be if the model described the low frequencies (nT),
    /// NaN without levels.
    pub level_expected_nt: f64,
    /// Largest fluxgate offset found (nT), NaN without levels.
    pub fluxgate_offset_nt: f64,
    /// What a linear magnitude leaves out (nT RMS over the calibration); NaN for an exact one.
    pub second_order_nt: f64,
    /// What the model leaves of the scalar at every frequency (nT).
    pub left_nt: f64,
}

/// The verdict on the evidence, reasons in the order of the table above.
pub fn judge(e: &Evidence) -> Verdict {
    let mut reasons = Vec::new();
    if e.excitation_deg < MIN_EXCITATION_DEG {
        reasons.push(Reason::NoManeuvers {
            excitation_deg: e.excitation_deg,
        });
    }
    if e.uncertainty_nt >= MAX_UNCERTAINTY_RATIO * e.correction_nt && e.uncertainty_nt > 0.0 {
        reasons.push(Reason::Uncertain {
            uncertainty_nt: e.uncertainty_nt,
            correction_nt: e.correction_nt,
        });
    }
    let mut notes = Vec::new();
    if !e.uncertain_terms.is_empty() {
        notes.push(Reason::UncertainTerms {
            terms: e.uncertain_terms.clone(),
        });
    }
    if let Some(fault) = &e.restrained {
        reasons.push(Reason::Restrained {
            fault: fault.clone(),
        });
    }
    if let Some(fault) = &e.implausible {
        reasons.push(Reason::Implausible {
            fault: fault.clone(),
        });
    }
    if e.heldout_nt > MAX_HELDOUT_RATIO * e.insample_nt {
        reasons.push(Reason::HeldOutWorse {
            heldout_nt: e.heldout_nt,
            insample_nt: e.insample_nt,
        });
    }
    if e.interference && e.improvement < MIN_INTERFERENCE_IMPROVEMENT {
        reasons.push(Reason::UnexplainedInterference {
            improvement: e.improvement,
        });
    } else if e.improvement < MIN_IMPROVEMENT {
        reasons.push(Reason::LittleExplained {
            improvement: e.improvement,
        });
    }
    if e.level_misfit_nt > MAX_LEVEL_MISFIT_NT
        || e.level_misfit_nt > MAX_LEVEL_MISFIT_RATIO * e.level_expected_nt
    {
        reasons.push(Reason::LevelMisfit {
            misfit_nt: e.level_misfit_nt,
            expected_nt: Some(e.level_expected_nt).filter(|x| x.is_finite()),
        });
    }
    if e.fluxgate_offset_nt > MAX_FLUXGATE_OFFSET_NT {
        reasons.push(Reason::FluxgateOffset {
            offset_nt: e.fluxgate_offset_nt,
        });
    }
    if e.second_order_nt > MAX_SECOND_ORDER_RATIO * e.left_nt {
        reasons.push(Reason::SecondOrder {
            second_order_nt: e.second_order_nt,
            left_nt: e.left_nt,
        });
    }
    Verdict::of(reasons).with_notes(notes)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn clean() -> Evidence {
        Evidence {
            excitation_deg: 5.0,
            uncertainty_nt: 0.01,
            correction_nt: 100.0,
            uncertain_terms: Vec::new(),
            restrained: None,
            implausible: None,
            heldout_nt: 0.011,
            insample_nt: 0.01,
            improvement: 50.0,
            interference: false,
            level_misfit_nt: 0.1,
            level_expected_nt: 0.05,
            fluxgate_offset_nt: 12.0,
            second_order_nt: f64::NAN,
            left_nt: 0.01,
        }
    }

    #[test]
    fn each_threshold_gives_its_reason_and_nan_evidence_none() {
        assert!(judge(&clean()).is_good());
        let unknown = Evidence {
            excitation_deg: f64::NAN,
            heldout_nt: f64::NAN,
            level_misfit_nt: f64::NAN,
            level_expected_nt: f64::NAN,
            fluxgate_offset_nt: f64::NAN,
            ..clean()
        };
        assert!(judge(&unknown).is_good());
        let fault = Fault::Permanent {
            fluxgate: 0,
            axis: "L".into(),
            value_nt: 1e5,
        };
        let cases: Vec<(Evidence, (&str, &str))> = vec![
            (
                Evidence {
                    excitation_deg: 0.3,
                    ..clean()
                },
                ("no maneuvers", "calibration box"),
            ),
            (
                Evidence {
                    uncertainty_nt: 40.0,
                    ..clean()
                },
                ("own uncertainty", "--terms"),
            ),
            (
                Evidence {
                    restrained: Some(fault.clone()),
                    ..clean()
                },
                ("held to physical", "--extra"),
            ),
            (
                Evidence {
                    implausible: Some(fault),
                    ..clean()
                },
                ("no aircraft has", "--lambda auto"),
            ),
            (
                Evidence {
                    heldout_nt: 0.04,
                    ..clean()
                },
                ("held-out", "--terms patent"),
            ),
            (
                Evidence {
                    improvement: 1.2,
                    ..clean()
                },
                ("improved only", "regressors"),
            ),
            (
                Evidence {
                    improvement: 4.1,
                    interference: true,
                    ..clean()
                },
                ("interference only ×4.1", "--extra"),
            ),
            (
                Evidence {
                    level_misfit_nt: 18.8,
                    ..clean()
                },
                ("heading levels", "--levels off"),
            ),
            (
                Evidence {
                    second_order_nt: 0.18,
                    left_nt: 0.014,
                    ..clean()
                },
                ("second-order field of 0.180 nT", "--magnitude exact"),
            ),
            (
                Evidence {
                    level_misfit_nt: 0.6,
                    level_expected_nt: 0.06,
                    ..clean()
                },
                ("allows 0.06 nT", "--levels off"),
            ),
            (
                Evidence {
                    fluxgate_offset_nt: 693.0,
                    ..clean()
                },
                ("offset of 693", "--fluxgate-offset on"),
            ),
        ];
        for (evidence, (words, remedy)) in cases {
            let v = judge(&evidence);
            assert_eq!(v.grade, Grade::Doubtful, "{words}");
            assert_eq!(v.reasons.len(), 1, "{v}");
            assert!(v.to_string().contains(words), "{v}");
            assert!(
                v.to_string().contains(remedy),
                "{v} names no remedy {remedy}"
            );
        }
    }

    /// Terms the maneuvers hardly tell apart are noted, and the grade stays.
    #[test]
    fn uncertain_terms_are_a_note_not_a_reason() {
        let v = judge(&Evidence {
            uncertain_terms: vec!["perm_x".into()],
            ..clean()
        });
        assert_eq!(v.grade, Grade::Good);
        assert!(v.reasons.is_empty());
        assert!(v.notes[0].to_string().contains("perm_x"), "{:?}", v.notes);
        let back: Verdict = serde_json::from_str(&serde_json::to_string(&v).unwrap()).unwrap();
        assert_eq!(back, v);
    }

    #[test]
    fn a_verdict_reads_back_from_json() {
        let v = judge(&Evidence {
            excitation_deg: 0.2,
            fluxgate_offset_nt: 693.0,
            ..clean()
        });
        let text = serde_json::to_string(&v).unwrap();
        assert!(text.contains("\"grade\":\"doubtful\""), "{text}");
        let back: Verdict = serde_json::from_str(&text).unwrap();
        assert_eq!(back, v);
    }
}
