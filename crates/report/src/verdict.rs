//! A run's outcome in calibration.json's words: the solver's status, the
//! verdict with its reasons, data snooping's removals, the directions the
//! data cannot determine.

use parcal_calibrate::observation::ObservationId;
use parcal_calibrate::snooping::Removal;
use parcal_calibrate::verdict::{Outcome, Verdict};
use parcal_solver::{BlockId, SpectrumDiagnostics, Status, WeakDirection};

use crate::places::{location, place_and_row};

/// A solver's status in one sentence: `names` name the global block's
/// parameters, `group(k)` and `point(i)` say what a singular group or
/// point block means.
pub fn solver_status(
    status: &Status,
    names: &[String],
    group: impl Fn(usize) -> String,
    point: impl Fn(usize) -> String,
) -> String {
    match status {
        Status::Converged => "converged".to_string(),
        Status::IterationLimit => "iteration limit reached without convergence".to_string(),
        Status::TimeLimit => "time limit reached without convergence".to_string(),
        Status::Diverged { iteration, reason } => {
            format!("diverged at iteration {iteration}: {reason}")
        }
        Status::ProblemFailed {
            iteration, message, ..
        } => format!("failed at iteration {iteration}: {message}"),
        Status::Singular {
            iteration,
            diagnostics,
        } => format!(
            "the reduced system is singular at iteration {iteration}{}: {}",
            match diagnostics.unidentified() {
                0 => String::new(),
                n => format!(" ({})", unidentified(n)),
            },
            weak_directions(diagnostics, names)
        ),
        Status::SingularBlock { iteration, block } => match block {
            BlockId::Group(k) => format!("at iteration {iteration} {}", group(*k)),
            BlockId::Point(i) => format!("at iteration {iteration} {}", point(*i)),
        },
        Status::Stopped { iteration } => format!("stopped at iteration {iteration}"),
        Status::InvalidProblem { message } => format!("invalid problem: {message}"),
    }
}

/// Writes `verdict` into `record`: the decision, its reasons (the status
/// sentence `status`, the global test), the `warnings` of the run and the
/// global test's own when the fit is better than the noise allows.
pub fn with_verdict(
    record: &mut parcal_dataset::Calibration,
    verdict: &Verdict,
    status: &str,
    mut warnings: Vec<String>,
) {
    record.verdict = if verdict.accepted {
        "accepted"
    } else {
        "rejected"
    }
    .to_string();
    record.reasons = vec![if status == "converged" {
        "the solver converged".to_string()
    } else {
        format!(
            "the solver stopped: {status}; its state is not a least-squares minimum, so no test judges it and no observation is named as a blunder"
        )
    }];
    if let Some(test) = &verdict.global_test {
        let (lower, upper) = test.interval;
        let statement = format!(
            "a-posteriori variance factor {:.3} (redundancy {}; chi-square interval [{lower:.3}, {upper:.3}] at {}% two-sided)",
            test.variance_factor,
            test.redundancy,
            test.level * 100.0
        );
        match test.outcome {
            Outcome::Consistent => record
                .reasons
                .push(format!("global test passed: {statement}")),
            Outcome::TooLarge => record.reasons.push(format!(
                "global test failed: the data do not fit their stated noise: {statement}; look for a blunder, a wrong radius or repeatability, or a model error"
            )),
            Outcome::TooSmall => warnings.push(format!(
                "the fit is better than the stated noise allows: {statement}; the repeatabilities are pessimistic and the sigmas overstated"
            )),
        }
        record.global_test = Some(parcal_dataset::GlobalTestRecord {
            cost: test.cost,
            redundancy: test.redundancy,
            variance_factor: test.variance_factor,
            level: test.level,
            interval: [lower, upper],
            outcome: test.outcome.name().to_string(),
        });
    }
    record.warnings = warnings;
}

/// Adds data snooping's `removals` to `record` (its reasons and
/// `removed_observations`), and why it `stopped` to its warnings.
pub fn with_removals(
    record: &mut parcal_dataset::Calibration,
    removals: &[Removal<ObservationId>],
    stopped: Option<&str>,
) {
    for removal in removals {
        record.reasons.push(format!(
            "data snooping removed {}: normalised residual {:+.1}, estimated gross error {:+.1} sigma; variance factor {:.3} -> {:.3}",
            place_and_row(removal.observation, removal.row),
            removal.normalised,
            removal.gross_error,
            removal.variance_factor_before,
            removal.variance_factor_after
        ));
        let (file, line, field) = location(removal.observation);
        record
            .removed_observations
            .push(parcal_dataset::RemovedObservation {
                file: file.to_string(),
                line,
                field,
                normalised_residual: removal.normalised,
                gross_error_sigmas: removal.gross_error,
                variance_factor: [
                    removal.variance_factor_before,
                    removal.variance_factor_after,
                ],
            });
    }
    if let Some(stopped) = stopped {
        record
            .warnings
            .push(format!("data snooping stopped: {stopped}"));
    }
}

/// The weakest directions of a reduced system: eigenvalue and the
/// parameters that dominate it, named by `names` (the global block's,
/// [`parcal_calibrate::layout::ParameterLayout::names`]).
pub fn weak_directions(spectrum: &SpectrumDiagnostics, names: &[String]) -> String {
    let directions: Vec<String> = spectrum
        .weakest
        .iter()
        .take(3)
        .map(|weak| weak_direction(weak, names))
        .collect();
    format!("smallest eigenvalues: {}", directions.join("; "))
}

/// One weak direction: its eigenvalue, the sigma it leaves (mm) and the
/// parameters that dominate it, named by `names` (the global block's).
pub fn weak_direction(weak: &WeakDirection, names: &[String]) -> String {
    let names: Vec<String> = weak
        .dominant
        .iter()
        .map(|(k, c)| format!("{} {:+.2}", names[*k], c))
        .collect();
    let sigma = if weak.identified {
        format!("sigma {:.3} mm", weak.eigenvalue.sqrt().recip())
    } else {
        "not identified".to_string()
    };
    format!(
        "eigenvalue {:.3e} ({sigma}) along {}",
        weak.eigenvalue,
        names.join(", ")
    )
}

/// What `n` undetermined directions of the parameters mean, and what to do.
pub fn unidentified(n: usize) -> String {
    format!(
        "the data and the prior cannot identify the parameters: {n} direction{} of them {} no information (zero eigenvalues of the reduced matrix, so no finite sigma); measure more balls and contacts, or calibrate with a prior",
        if n == 1 { "" } else { "s" },
        if n == 1 { "has" } else { "have" },
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_stopped_solver_is_worded_with_its_reason() {
        let none = |_: usize| String::new();
        assert_eq!(
            solver_status(&Status::TimeLimit, &[], none, none),
            "time limit reached without convergence"
        );
        assert_eq!(
            solver_status(&Status::Stopped { iteration: 3 }, &[], none, none),
            "stopped at iteration 3"
        );
    }
}
