//! The measured poses and points of a calibration in sentences and
//! tables, and their validation.

use std::fmt::Write;

use parcal_calibrate::CalibrationRun;
use parcal_calibrate::instruments::{SessionGroup, Validation};
use parcal_calibrate::prediction::PredictionTest;
use parcal_calibrate::verdict::Outcome;
use parcal_dataset::{Calibration, NuisanceCandidate, PredictionTestRecord, ValidationRecord};

use crate::checks::{NAMED_MIRRORED, and_more};
use crate::diagnostics::determined_by;
use crate::sentences::status;

/// The summary of a run of poses and points alone: rows, residuals,
/// iterations, status, and the verdict of its calibration.json `record`.
pub fn summary(run: &CalibrationRun, record: &Calibration) -> String {
    let mut out = String::new();
    let Some(instruments) = &run.instruments else {
        return out;
    };
    let _ = writeln!(
        out,
        "{} sessions, {} poses, {} points; {} unknowns",
        instruments.model.sessions.len(),
        instruments.leg_residuals.len(),
        instruments.point_residuals.len(),
        run.global.len()
    );
    residuals(&mut out, "", instruments.leg_rms(), instruments.point_rms());
    let _ = writeln!(
        out,
        "whitened residual RMS {:.3} (1 when the repeatabilities of machine.json are right)",
        run.residual_rms()
    );
    let _ = writeln!(out, "{} after {} iterations", status(run), run.iterations());
    let _ = writeln!(out, "verdict: {}", record.verdict);
    for reason in record.reasons.iter().chain(&record.warnings) {
        let _ = writeln!(out, "  {reason}");
    }
    out
}

/// The poses and points calibrated with ball touches: their residuals
/// and the instrument parameters (the kinematic ones are in the touch
/// calibration's table); empty without poses and points.
pub fn mixed_summary(run: &CalibrationRun) -> String {
    let mut out = String::new();
    let Some(instruments) = &run.instruments else {
        return out;
    };
    let _ = writeln!(
        out,
        "with {} sessions, {} poses, {} points:",
        instruments.model.sessions.len(),
        instruments.leg_residuals.len(),
        instruments.point_residuals.len()
    );
    residuals(
        &mut out,
        "  ",
        instruments.leg_rms(),
        instruments.point_rms(),
    );
    out.push_str("\n| parameter | identified | sigma |\n|---|---:|---:|\n");
    for (name, value, sigma) in run.instrument_parameters() {
        let _ = writeln!(out, "| {name} | {value:.4} | {sigma:.4} |");
    }
    out
}

/// The RMS of the poses' leg-length residuals and of the points'
/// coordinates (mm), those there are, one line each after `indent`.
fn residuals(out: &mut String, indent: &str, legs: Option<f64>, points: Option<f64>) {
    if let Some(rms) = legs {
        let _ = writeln!(out, "{indent}pose residual (leg length): RMS {rms:.4} mm");
    }
    if let Some(rms) = points {
        let _ = writeln!(
            out,
            "{indent}point residual (per coordinate): RMS {rms:.4} mm"
        );
    }
}

/// Parameter, initial and identified value, posterior and prior sigma, and
/// what determined it ([`determined_by`]), of a run of poses and points
/// alone (empty otherwise). Frame parameters are the corrections of the
/// frames (rad, mm); calibration.json's `sessions` has the frames
/// themselves.
pub fn parameters(run: &CalibrationRun) -> String {
    let Some((instruments, information)) = run
        .instruments
        .as_ref()
        .and_then(|i| Some((i, i.information.as_ref()?)))
    else {
        return String::new();
    };
    let sigmas = run.global_sigmas();
    let mut out = String::from(
        "| parameter | initial | identified | sigma | prior sigma | determined by |\n|---|---:|---:|---:|---:|---|\n",
    );
    for (k, name) in run.names().iter().enumerate() {
        let sigma = sigmas.as_ref().map(|s| s[k]);
        let prior_sigma = information.prior_sigmas[k];
        let _ = writeln!(
            out,
            "| {name} | {:.4} | {:.4} | {} | {} | {} |",
            instruments.initial[k],
            run.global[k],
            sigma.map_or("-".to_string(), |s| format!("{s:.4}")),
            if prior_sigma.is_finite() {
                format!("{prior_sigma:.4}")
            } else {
                "none".to_string()
            },
            sigma.map_or("-", |s| determined_by(information.data[k], s, prior_sigma))
        );
    }
    out
}

/// validation.json's record of `validation`, a validation of `calibration`
/// (its file, or `K-fold cross-validation`): the numbers, the verdict and
/// its reasons.
pub fn validation_record(validation: &Validation, calibration: String) -> ValidationRecord {
    let test = validation.test();
    let accepted = validation.accepted();
    let mut reasons: Vec<String> = test.iter().map(|t| test_sentence(validation, t)).collect();
    if !accepted {
        reasons.push(rejection_advice(validation));
    }
    ValidationRecord {
        calibration,
        reference_rows: validation.reference,
        refitted: validation.refitted.clone(),
        selection: validation
            .selection
            .iter()
            .map(|(model, rms)| NuisanceCandidate {
                model: model.clone(),
                expected_rms_mm: *rms,
            })
            .collect(),
        rows: validation.poses + validation.points + validation.contacts,
        poses: validation.poses,
        points: validation.points,
        contacts: validation.contacts,
        rms_mm: validation.rms(),
        max_mm: validation.max(),
        per_leg_rms_mm: if validation.poses > 0 {
            validation.per_leg_rms()
        } else {
            [0.0; 6]
        },
        predicted_rms_mm: validation.predicted_rms(),
        verdict: if accepted { "accepted" } else { "rejected" }.to_owned(),
        reasons,
        test: test.as_ref().map(test_record),
        mirrored_balls: validation.mirrored_balls.clone(),
    }
}

/// validation.json's record of the prediction test `t`.
pub(crate) fn test_record(t: &PredictionTest) -> PredictionTestRecord {
    PredictionTestRecord {
        statistic: t.statistic,
        degrees_of_freedom: t.rows,
        calibration_variance_factor: t.calibration.map(|(cost, r)| cost / r as f64),
        calibration_redundancy: t.calibration.map(|(_, r)| r),
        ratio: t.ratio,
        level: t.level,
        interval: [t.interval.0, t.interval.1],
        outcome: t.outcome.name().to_owned(),
    }
}

/// The prediction test of `validation` in one sentence.
fn test_sentence(validation: &Validation, test: &PredictionTest) -> String {
    let (rms, predicted) = (validation.rms(), validation.predicted_rms());
    let statement = test_statement(test);
    match test.outcome {
        Outcome::Consistent => format!(
            "prediction test passed: the residuals (RMS {rms:.4} mm) are as large as the calibration predicts ({predicted:.4} mm): {statement}"
        ),
        Outcome::TooLarge => format!(
            "prediction test failed: the residuals are {:.1} times the predicted (RMS {rms:.4} mm against {predicted:.4} mm): {statement}: the calibration does not predict these data",
            rms / predicted
        ),
        Outcome::TooSmall => format!(
            "prediction test: the residuals are smaller than predicted (RMS {rms:.4} mm against {predicted:.4} mm): {statement}: the calibration's covariance or the repeatabilities are pessimistic"
        ),
    }
}

/// The numbers of `test`: `T`, `n`, the calibration's `s₀²` and the
/// interval of `F`.
pub(crate) fn test_statement(test: &PredictionTest) -> String {
    let n = test.rows;
    let (reference, distribution) = match test.calibration {
        Some((cost, r)) => (
            format!("the calibration's s₀² = {:.3}", cost / r as f64),
            format!("F({n}, {r})"),
        ),
        None => ("1".to_owned(), format!("χ²({n})/{n}")),
    };
    format!(
        "rᵀC⁻¹r = {:.1} over {n} rows, (T/n) / s₀² = {:.3} against {reference}, two-sided {}% interval [{:.3}, {:.3}] of {distribution}",
        test.statistic,
        test.ratio,
        (1.0 - test.level) * 100.0,
        test.interval.0,
        test.interval.1,
    )
}

/// What may have changed since the calibration, and what to do, for a
/// rejected `validation`.
fn rejection_advice(validation: &Validation) -> String {
    if let Some(best) = validation.explanations.first() {
        let names = |groups: &[SessionGroup]| {
            groups
                .iter()
                .map(|g| format!("the {}", g.name()))
                .collect::<Vec<_>>()
                .join(" and ")
        };
        let what = format!(
            "re-fitting {} would explain them (residual RMS {:.4} mm against {:.4} mm predicted; (T/n) / s₀² = {:.3} within [{:.3}, {:.3}])",
            if best.groups.is_empty() {
                "the instrument frame alone".to_owned()
            } else {
                names(&best.groups)
            },
            best.rms,
            best.predicted_rms,
            best.test.ratio,
            best.test.interval.0,
            best.test.interval.1,
        );
        let todo = if best.undeclared.is_empty() {
            format!(
                "machine.json declares them, but the model selection preferred {} from the reference rows alone: give more reference rows, spread over the workspace",
                validation.refitted.join(" + ")
            )
        } else {
            let settings: Vec<String> = best
                .undeclared
                .iter()
                .map(|g| format!("{} in machine.json if {}", g.setting(), g.cause()))
                .collect();
            format!("declare {}", settings.join("; and "))
        };
        format!("{what}: {todo}")
    } else if validation.reference > 0 && validation.contacts == 0 {
        "no re-fit of the body origin, body rotation or leg offsets explains them: the machine has changed since the calibration (a joint, a leg, a scale), or the calibration does not transfer to these data; re-calibrate on data of the machine as it is".to_owned()
    } else if validation.contacts > 0 {
        "each ball's centre was re-fitted: the machine has changed since the calibration (a joint, a leg, a scale), or a ball's radius is wrong; re-calibrate on touches of the machine as it is".to_owned()
    } else {
        "the calibration does not predict these rows of its sessions (their frames the calibration's): if they were measured after it, the instrument or the marker body may have moved since, which reference rows re-fit (validate with reference rows); if not, the repeatabilities of machine.json understate the noise, or the model misses an effect of the data (the calibration's global test and residuals say which)".to_owned()
    }
}

/// What a validation did for the balls named `balls` whose first
/// `reference` touches fit their centre's mirror image about as well (the
/// first [`NAMED_MIRRORED`] named, the others counted: validation.json
/// lists every one).
pub(crate) fn mirrored_sentence(balls: &[String], reference: usize) -> String {
    let named = &balls[..balls.len().min(NAMED_MIRRORED)];
    let (these, each) = match balls {
        [one] => (format!("ball {one}"), "the ball's"),
        _ => (
            format!(
                "balls {}{}",
                named.join(", "),
                and_more(balls.len() - named.len())
            ),
            "each ball's",
        ),
    };
    format!(
        "{these}: the first {reference} touches fit the centre and its mirror image through their plane about as well; the image all {each} touches fit was kept (more reference touches, spread over the ball, would tell them apart)"
    )
}

/// A validation in a few lines: its verdict and reasons, what was
/// applied, what was re-fitted, the residuals observed and predicted.
pub fn validation(record: &ValidationRecord) -> String {
    let mut out = String::new();
    if !record.verdict.is_empty() {
        let _ = writeln!(out, "verdict: {}", record.verdict);
        for reason in &record.reasons {
            let _ = writeln!(out, "  - {reason}");
        }
    }
    let _ = writeln!(out, "applied: {}", record.calibration);
    if record.reference_rows > 0 {
        let _ = writeln!(
            out,
            "re-fitted on the first {} rows of each session (touches of each ball): {}",
            record.reference_rows,
            record.refitted.join(", ")
        );
        for candidate in &record.selection {
            let _ = writeln!(
                out,
                "  candidate {}: expected prediction RMS {:.4} mm",
                candidate.model, candidate.expected_rms_mm
            );
        }
        if !record.mirrored_balls.is_empty() {
            let _ = writeln!(
                out,
                "  {}",
                mirrored_sentence(&record.mirrored_balls, record.reference_rows)
            );
        }
    }
    let _ = writeln!(
        out,
        "predicted {} rows ({} poses, {} points, {} ball touches): residual RMS {:.4} mm, max {:.4} mm; the calibration predicts RMS {:.4} mm",
        record.rows,
        record.poses,
        record.points,
        record.contacts,
        record.rms_mm,
        record.max_mm,
        record.predicted_rms_mm
    );
    if record.poses > 0 {
        let legs: Vec<String> = record
            .per_leg_rms_mm
            .iter()
            .enumerate()
            .map(|(i, r)| format!("leg {} {r:.4}", i + 1))
            .collect();
        let _ = writeln!(
            out,
            "leg-length residual RMS per leg, mm: {}",
            legs.join(", ")
        );
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Past [`NAMED_MIRRORED`] balls, the sentence names the first and
    /// counts the rest.
    #[test]
    fn a_sentence_on_many_mirrored_balls_names_the_first_and_counts_the_rest() {
        let balls: Vec<String> = (0..NAMED_MIRRORED + 3)
            .map(|b| format!("b{b:03}"))
            .collect();
        let sentence = mirrored_sentence(&balls, 4);
        let last = format!("b{:03}", NAMED_MIRRORED - 1);
        assert!(sentence.starts_with("balls b000, b001, "), "{sentence}");
        assert!(
            sentence.contains(&format!("{last} and 3 more: the first 4 touches")),
            "{sentence}"
        );
        assert!(
            !sentence.contains(&format!("b{NAMED_MIRRORED:03}")),
            "{sentence}"
        );
        let one = mirrored_sentence(&balls[..1], 4);
        assert!(one.starts_with("ball b000: the first 4 touches"), "{one}");
    }
}
