//! Text tables of a calibration (Markdown pipe tables: readable in a
//! terminal and in report.md).

use std::fmt::Write;

use parcal_calibrate::CalibrationRun;
use parcal_kinematics::{N_PARAMS, PARAM_NAMES};
use parcal_workflows::evaluate::{Accuracy, BeforeAfter, TrueMachine};

use crate::compare::nees_sentence;
use crate::sentences;
use crate::verdict::{unidentified, weak_direction};

/// Parameter, value, sigma and, with a truth, the true value, the error and
/// error / sigma (paper tables 3 and 4, with truth columns).
pub fn parameters(run: &CalibrationRun, truth: Option<&TrueMachine>) -> String {
    let sigmas = run.sigmas();
    let mut out = String::new();
    let _ = write!(out, "| parameter | design | identified | sigma |");
    if truth.is_some() {
        let _ = write!(out, " true | error | error/sigma |");
    }
    out.push('\n');
    out.push_str(if truth.is_some() {
        "|---|---:|---:|---:|---:|---:|---:|\n"
    } else {
        "|---|---:|---:|---:|\n"
    });
    for (k, name) in PARAM_NAMES.iter().enumerate() {
        let sigma = sigmas.map(|s| s[k]);
        let _ = write!(
            out,
            "| {name} | {:.3} | {:.4} | {} |",
            run.initial_params[k],
            run.params[k],
            sigma.map_or("-".to_string(), |s| format!("{s:.4}"))
        );
        if let Some(t) = truth {
            let error = run.params[k] - t.params[k];
            let normalised = sigma.map_or("-".to_string(), |s| format!("{:+.2}", error / s));
            let _ = write!(out, " {:.4} | {error:+.4} | {normalised} |", t.params[k]);
        }
        out.push('\n');
    }
    out
}

/// The RMS and max of the maps, um, one row per map.
pub fn accuracy(rows: &[(&str, &BeforeAfter)]) -> String {
    let mut out = String::from(
        "| map | predicted absolute RMS / max | predicted registered RMS / max | true absolute RMS / max | true registered RMS / max |\n|---|---:|---:|---:|---:|\n",
    );
    let cell = |summary: parcal_accuracy::MapSummary| {
        format!("{:.1} / {:.1}", summary.rms * 1e3, summary.max * 1e3)
    };
    for (name, maps) in rows {
        for (when, accuracy) in [("before", &maps.before), ("after", &maps.after)] {
            let Some(Accuracy {
                predicted,
                true_error,
            }) = accuracy
            else {
                continue;
            };
            let (true_abs, true_reg) = true_error.as_ref().map_or(("-".into(), "-".into()), |t| {
                (cell(t.absolute_summary()), cell(t.registered_summary()))
            });
            let _ = writeln!(
                out,
                "| {name}, {when} | {} | {} | {true_abs} | {true_reg} |",
                cell(predicted.absolute_summary()),
                cell(predicted.registered_summary())
            );
        }
    }
    out
}

/// Status, iterations, residuals, conditioning and warnings of a run.
pub fn run_summary(run: &CalibrationRun, truth: Option<&TrueMachine>) -> String {
    let mut out = String::new();
    let _ = writeln!(
        out,
        "status: {} after {} iterations",
        sentences::status(run),
        run.iterations()
    );
    if let (Some(first), Some(last)) = (run.history.first(), run.history.last()) {
        let _ = writeln!(
            out,
            "weighted |O|: {:.4} -> {:.4} (cost {:.4e} -> {:.4e}); whitened residual RMS {:.3} over {} rows",
            first.cost.sqrt(),
            last.cost.sqrt(),
            first.cost,
            last.cost,
            run.residual_rms(),
            run.residual_rows
        );
    }
    if let Some(spectrum) = &run.spectrum
        && let Some(condition) = run.condition_number()
    {
        let _ = match spectrum.unidentified() {
            0 => writeln!(
                out,
                "condition number of the posterior covariance: {condition:.3e}"
            ),
            n => writeln!(out, "{}", unidentified(n)),
        };
    }
    if let Some(last) = run.history.last()
        && run.distances_used > 0
    {
        let _ = writeln!(
            out,
            "ball distances: {} used, whitened residual RMS {:.3}",
            run.distances_used,
            (last.global_observation_cost / run.distances_used as f64).sqrt()
        );
    }
    if let Some(spectrum) = &run.spectrum {
        let names = run.names();
        for weak in spectrum.weakest.iter().take(2) {
            let _ = writeln!(out, "weak direction: {}", weak_direction(weak, &names));
        }
    }
    if let (Some(t), Some(covariance)) = (truth, &run.covariance)
        && let Some(nees) = t.nees(&run.params, covariance)
    {
        let _ = writeln!(
            out,
            "NEES against the truth: {}",
            nees_sentence(nees, N_PARAMS)
        );
    }
    for note in sentences::notes(run) {
        let _ = writeln!(out, "NOTE: {note}");
    }
    for warning in sentences::warnings(run) {
        let _ = writeln!(out, "WARNING: {warning}");
    }
    out
}
