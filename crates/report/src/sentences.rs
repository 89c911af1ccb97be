//! A calibration run in sentences: its status (calibration.json's
//! `status`), what it did beyond the iteration, its warnings, its weak
//! directions. Calibrate keeps the numbers; this module words them.

use parcal_calibrate::CalibrationRun;
use parcal_calibrate::conflict::{ConflictTest, PaperPriorInconsistency};
use parcal_calibrate::fit::BallMisfit;
use parcal_calibrate::reliability::{
    ObservationId, Reliability, UNCONTROLLED, VarianceComponent, critical_value,
};
use parcal_calibrate::robust::{DOWN_WEIGHTED, DownWeighted, too_many};
use parcal_calibrate::snooping::{MAX_REMOVALS, Removal, SNOOPING_LEVEL, Snooped};
use parcal_calibrate::systematic::{Effect, SYSTEMATIC_LEVEL, SystematicTest};
use parcal_calibrate::verdict::{GlobalTest, Outcome, Verdict};
use parcal_dataset::{
    ARTEFACTS_FILE, Dataset, MEASUREMENTS_FILE, POINTS_FILE, POSES_FILE,
    SystematicSensitivityRecord,
};
use parcal_kinematics::PARAM_NAMES;
use parcal_solver::{BlockId, SpectrumDiagnostics, Status, WeakDirection};

use crate::diagnostics;

/// The status in one sentence (calibration.json's `status`), naming
/// parameters, balls and measurements.csv lines.
pub fn status(run: &CalibrationRun) -> String {
    solver_status(
        &run.status,
        &run.names(),
        |k| {
            format!(
                "the centre of ball {} is not determined by its contacts",
                run.ball_ids[k]
            )
        },
        |i| {
            format!(
                "the angles of the contact of measurements.csv line {} are not determined",
                run.rows[i] + 2
            )
        },
    )
}

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

/// The calibration.json record of `run` of `dataset`: its status,
/// verdict, reasons and warnings in words, its diagnostics.
pub fn record(run: &CalibrationRun, dataset: &Dataset) -> parcal_dataset::Calibration {
    record_of(run, dataset, &|observation| observation)
}

/// [`record`] of a run whose observation `o` is `original(o)` in the
/// dataset given.
fn record_of(
    run: &CalibrationRun,
    dataset: &Dataset,
    original: &dyn Fn(ObservationId) -> ObservationId,
) -> parcal_dataset::Calibration {
    let status = status(run);
    let mut record = run.record(status.clone());
    let mut warnings = warnings(run);
    let mut reasons = Vec::new();
    let diagnostics = diagnostics::of_ball_run(run, dataset, original);
    if let Some(reliability) = &run.reliability {
        checks(reliability, original, &mut reasons, &mut warnings);
        record.down_weighted_observations = down_weighted_records(reliability, original);
        if let Some(global) = run.global_test.filter(|t| t.outcome == Outcome::TooLarge) {
            reasons.extend(
                reliability
                    .systematic
                    .iter()
                    .filter_map(|t| systematic_sentence(t, &global)),
            );
        }
    }
    reasons.extend(
        diagnostics
            .systematic_sensitivity
            .iter()
            .map(sensitivity_sentence),
    );
    with_verdict(&mut record, &run.verdict(), &status, warnings);
    record.reasons.extend(reasons);
    record.diagnostics = Some(diagnostics);
    record
}

/// What an undetectable common error of the entered data could do, in
/// one sentence: its minimal detectable bias (µm, ppm) and the registered
/// error an undetected one of that size adds at most (and in RMS) over
/// the accuracy grid.
pub fn sensitivity_sentence(record: &SystematicSensitivityRecord) -> String {
    let (mdb, unit) = match record.unit.as_str() {
        "mm" => (record.mdb * 1e3, "um"),
        _ => (record.mdb * 1e6, "ppm"),
    };
    let test = format!(
        "the smallest its test finds at {}% with {:.0}% power",
        record.level * 100.0,
        record.power * 100.0
    );
    match (record.map_max_um, record.map_rms_um) {
        (Some(max), Some(rms)) => format!(
            "an undetectable common {} error of up to {mdb:.1} {unit} ({test}) could add up to {max:.1} um to the registered error (RMS {rms:.1} um over the accuracy grid)",
            record.effect
        ),
        _ => format!(
            "an undetectable common {} error could be up to {mdb:.1} {unit} ({test})",
            record.effect
        ),
    }
}

/// The test of a common error of the entered data in one sentence: the
/// correction it asks for, its significance, and whether it explains the
/// misfit of the run whose global test is `global` alone.
pub fn systematic_sentence(test: &SystematicTest, global: &GlobalTest) -> Option<String> {
    let without = test.without(global)?;
    let (w, critical) = (test.normalised(), test.critical_value());
    let correction = match test.effect {
        Effect::BallRadius => format!(
            "every ball's radius corrected by {:+.4} +- {:.4} mm",
            test.estimate, test.sigma
        ),
        Effect::DistanceScale => format!(
            "every calibrated distance corrected by {:+.1} +- {:.1} ppm",
            test.estimate * 1e6,
            test.sigma * 1e6
        ),
    };
    let statistic = format!(
        "w = {w:+.2}, critical value {critical:.2} at {}%",
        SYSTEMATIC_LEVEL * 100.0
    );
    let after = format!(
        "variance factor {:.3} without it, interval [{:.3}, {:.3}]",
        without.variance_factor, without.interval.0, without.interval.1
    );
    let what = match test.effect {
        Effect::BallRadius => {
            "check artefacts.json's radii (the calibrated radius, not the nominal one; the stylus tip's radius) and calibrate again"
        }
        Effect::DistanceScale => {
            "check the distances' calibration and the plate's temperature against the calibration's, and calibrate again"
        }
    };
    Some(if !test.significant() {
        format!(
            "no common {} error shows: the data ask for {correction} ({statistic})",
            test.effect.name()
        )
    } else if without.outcome == Outcome::Consistent {
        format!(
            "a common {} error explains the misfit: the data ask for {correction} ({statistic}; {after}): {what}",
            test.effect.name()
        )
    } else {
        format!(
            "a common {} error is significant but does not explain the misfit alone: the data ask for {correction} ({statistic}; {after})",
            test.effect.name()
        )
    })
}

/// Where an observation is, as a user finds it: `measurements.csv line
/// 40` (the header is line 1), `artefacts.json distances[3]`.
pub fn place(observation: ObservationId) -> String {
    let (file, line, field) = location(observation);
    match (line, field) {
        (Some(line), _) => format!("{file} line {line}"),
        (None, Some(field)) => format!("{file} {field}"),
        (None, None) => file.to_string(),
    }
}

/// An observation's file and its line (CSV, header = line 1) or field
/// (JSON).
pub(crate) fn location(observation: ObservationId) -> (&'static str, Option<u64>, Option<String>) {
    let line = |row: usize| Some(row as u64 + 2);
    match observation {
        ObservationId::Contact(row) => (MEASUREMENTS_FILE, line(row), None),
        ObservationId::Distance(k) => (ARTEFACTS_FILE, None, Some(format!("distances[{k}]"))),
        ObservationId::Pose(row) => (POSES_FILE, line(row), None),
        ObservationId::Point(row) => (POINTS_FILE, line(row), None),
    }
}

/// An observation's place and, for one of several rows, the row (a pose's
/// leg, a point's coordinate).
fn place_and_row(observation: ObservationId, row: usize) -> String {
    match observation {
        ObservationId::Pose(_) => format!("{}, leg {}", place(observation), row + 1),
        ObservationId::Point(_) => format!("{}, {}", place(observation), ["x", "y", "z"][row]),
        _ => place(observation),
    }
}

/// The observations' checks in words: the variance components, the
/// largest normalised residual against the data-snooping critical value
/// (with a robust loss, the observations it down-weighted instead), the
/// uncontrolled observations; `original` gives an observation's place in
/// the dataset given.
pub fn checks(
    reliability: &Reliability,
    original: &dyn Fn(ObservationId) -> ObservationId,
    reasons: &mut Vec<String>,
    warnings: &mut Vec<String>,
) {
    reasons.push(variance_components(&reliability.components));
    if let Some(down_weighted) = &reliability.down_weighted {
        reasons.push(down_weighted_sentence(down_weighted, original));
    } else if let Some(worst) = reliability.worst() {
        let w = worst.normalised().unwrap_or(0.0);
        let tests = reliability.tests();
        let critical = critical_value(SNOOPING_LEVEL, tests);
        let test = format!(
            "largest normalised residual {w:+.2} at {} (critical value {critical:.2} for {tests} tests at {}% family-wise)",
            place_and_row(original(worst.observation()), worst.row()),
            SNOOPING_LEVEL * 100.0
        );
        if w.abs() > critical {
            reasons.push(format!(
                "data-snooping test failed: {test}: that observation is likely a blunder; calibrate --snoop finds and removes blunders"
            ));
        } else {
            reasons.push(format!(
                "every observation passes the data-snooping test: {test}"
            ));
        }
    }
    let least: Vec<String> = reliability
        .least_reliable(3)
        .iter()
        .map(|(observation, lambda)| format!("{lambda:.1} at {}", place(original(*observation))))
        .collect();
    if !least.is_empty() {
        reasons.push(format!(
            "external reliability (what an undetected blunder of an observation's minimal detectable bias moves the parameters by, in their sigmas), largest: {}",
            least.join(", ")
        ));
    }
    let uncontrolled: Vec<String> = reliability
        .uncontrolled()
        .map(|c| place(original(c.observation())))
        .collect();
    if !uncontrolled.is_empty() {
        warnings.push(format!(
            "{} observations have a redundancy under {UNCONTROLLED} per test: an error in them would go into the parameters unseen ({})",
            uncontrolled.len(),
            uncontrolled.iter().take(10).cloned().collect::<Vec<_>>().join(", ")
        ));
    }
}

/// The observations a robust loss down-weighted in one sentence (the ten
/// most down-weighted named), in the place of data snooping's test
/// ([`parcal_calibrate::robust`]).
pub fn down_weighted_sentence(
    down_weighted: &[DownWeighted],
    original: &dyn Fn(ObservationId) -> ObservationId,
) -> String {
    if down_weighted.is_empty() {
        return format!(
            "the robust loss down-weighted no observation (none has a weight under {DOWN_WEIGHTED})"
        );
    }
    let mut worst: Vec<&DownWeighted> = down_weighted.iter().collect();
    worst.sort_by(|a, b| a.weight.total_cmp(&b.weight));
    let named: Vec<String> = worst
        .iter()
        .take(10)
        .map(|d| {
            format!(
                "{} (weight {:.2e}, residual {:.1} sigmas)",
                place(original(d.observation)),
                d.weight,
                d.residual
            )
        })
        .collect();
    let verdict = if too_many(down_weighted) {
        format!(
            "; more than the {MAX_REMOVALS} blunders data snooping would remove: the model, not a few observations, is wrong"
        )
    } else {
        String::new()
    };
    format!(
        "the robust loss down-weighted {} observation{} to a weight under {DOWN_WEIGHTED}, likely blunders: {}{}{verdict}",
        down_weighted.len(),
        if down_weighted.len() == 1 { "" } else { "s" },
        named.join(", "),
        and_more(down_weighted.len() - named.len()),
    )
}

/// The down-weighted observations of `reliability` as calibration.json
/// lists them, each with its file and line or field.
pub fn down_weighted_records(
    reliability: &Reliability,
    original: &dyn Fn(ObservationId) -> ObservationId,
) -> Vec<parcal_dataset::DownWeightedObservation> {
    let listed = reliability.down_weighted.as_deref().unwrap_or_default();
    listed
        .iter()
        .map(|d| {
            let (file, line, field) = location(original(d.observation));
            parcal_dataset::DownWeightedObservation {
                file: file.to_string(),
                line,
                field,
                weight: d.weight,
                residual_sigmas: d.residual,
            }
        })
        .collect()
}

/// The variance components of a run in one sentence.
pub fn variance_components(components: &[VarianceComponent]) -> String {
    let parts: Vec<String> = components
        .iter()
        .map(|c| {
            if c.estimable() {
                format!(
                    "{} {:.3} (redundancy {:.1})",
                    c.group,
                    c.factor(),
                    c.redundancy
                )
            } else {
                format!(
                    "{} not estimable (redundancy {:.1}: nothing checks them)",
                    c.group, c.redundancy
                )
            }
        })
        .collect();
    format!("variance components: {}", parts.join(", "))
}

/// The calibration.json record of a calibration with data snooping: the
/// remaining observations' run, and every removal with its place and what
/// it did to the variance factor; `dataset` is the dataset given.
pub fn snooped_record(snooped: &Snooped, dataset: &Dataset) -> parcal_dataset::Calibration {
    let mut record = record_of(&snooped.run, dataset, &|o| snooped.remaining.original(o));
    with_removals(&mut record, &snooped.removals, snooped.stopped.as_deref());
    record
}

/// Adds data snooping's `removals` to `record` (its reasons and
/// `removed_observations`), and why it `stopped` to its warnings.
pub fn with_removals(
    record: &mut parcal_dataset::Calibration,
    removals: &[Removal],
    stopped: Option<&str>,
) {
    for removal in removals {
        record.reasons.push(format!(
            "data snooping removed {}: normalised residual {:+.1}, estimated gross error {:+.1} (its row's sigmas); variance factor {:.3} -> {:.3}",
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

/// What the run did beyond the method's iteration, one sentence each (the
/// balls re-seeded on the other side of their contacts).
pub fn notes(run: &CalibrationRun) -> Vec<String> {
    let run_away = run.gauss_newton.as_ref().map(|g| {
        format!(
            "Gauss-Newton did not converge ({} after {} iterations, cost {:.3e} -> {:.3e}): the calibration was made again with Levenberg-Marquardt",
            solver_status(&g.status, &run.names(), |_| String::new(), |_| String::new()),
            g.iterations,
            g.initial_cost,
            g.final_cost
        )
    });
    run_away
        .into_iter()
        .chain(run.mirrored.iter().map(|m| {
            format!(
                "ball {} was on the wrong side of its contacts at iteration {} (chi-square {:.1}; its contact points at that iterate's geometry fit the mirror image of its centre {:.0} times better): re-seeded there, and the calibration resumed",
                m.id,
                m.iteration,
                m.side.chi_square,
                m.side.side.cost / m.side.mirror.cost
            )
        }))
        .collect()
}

/// Every warning about the priors and the balls' fit, one sentence each.
pub fn warnings(run: &CalibrationRun) -> Vec<String> {
    let conflicts = run.conflicts.iter().filter_map(conflict_warning);
    run.prior_consistency
        .iter()
        .map(paper_prior_warning)
        .chain(conflicts)
        .chain(misfit_warning(&run.ball_misfits))
        .collect()
}

/// A one-paragraph warning naming the conflict test that failed and the
/// worst offenders, or `None`. Only a failed test is stated: a global
/// chi-square within its limit beside contradicted values would read as a
/// contradiction (it happens with a prior much tighter than the data, whose
/// chi-square is near 0 while the data still move values).
pub fn conflict_warning(test: &ConflictTest) -> Option<String> {
    if !test.conflicts() {
        return None;
    }
    let mut findings = Vec::new();
    if test.chi_square > test.limit {
        findings.push(format!(
            "chi-square {:.1} for {} (99.9% limit {:.1})",
            test.chi_square, test.degrees_of_freedom, test.limit
        ));
    }
    let offenders = test.offenders();
    if !offenders.is_empty() {
        let listed: Vec<String> = offenders
            .iter()
            .take(8)
            .map(|i| format!("{} (z = {:+.1})", i.name, i.z.unwrap_or_default()))
            .collect();
        findings.push(format!(
            "{} of the {} values the data inform lie beyond |z| = {:.2} (0.1% family-wise): {}{}",
            offenders.len(),
            test.informed(),
            test.z_limit(),
            listed.join(", "),
            and_more(offenders.len() - listed.len()),
        ));
    }
    Some(format!(
        "the prior on the {} contradicts the data: {}",
        test.what,
        findings.join("; ")
    ))
}

/// The paper-form prior's over-confidence in one sentence.
pub fn paper_prior_warning(found: &PaperPriorInconsistency) -> String {
    let listed: Vec<String> = found
        .understated
        .iter()
        .map(|&(k, tolerance, paper)| {
            format!(
                "{} ({tolerance:.3} vs {paper:.3} mm, x{:.1})",
                PARAM_NAMES[k],
                tolerance / paper
            )
        })
        .collect();
    format!(
        "the paper-form prior is over-confident: a machine within the design tolerances has an expected chi-square of {:.0} for {} under it (99.9% limit {:.1}), because the canonical frames tilt with the joints; the tolerances imply larger sigmas for {}. Use the propagated prior.",
        found.expected_chi_square,
        found.degrees_of_freedom,
        found.limit,
        listed.join(", ")
    )
}

/// One sentence naming the misfit balls (the five worst), if any.
pub fn misfit_warning(misfits: &[BallMisfit]) -> Option<String> {
    if misfits.is_empty() {
        return None;
    }
    let mut worst: Vec<&BallMisfit> = misfits.iter().collect();
    worst.sort_by(|a, b| b.chi_square.total_cmp(&a.chi_square));
    let named: Vec<String> = worst
        .iter()
        .take(5)
        .map(|m| {
            format!(
                "{} (chi-square {:.1} for {})",
                m.id, m.chi_square, m.degrees_of_freedom
            )
        })
        .collect();
    let more = and_more(misfits.len().saturating_sub(named.len()));
    Some(match misfits.len() {
        1 => format!(
            "ball {} fits its contacts far worse than the noise allows: its centre is in a wrong local minimum or its contacts hold a blunder",
            named[0]
        ),
        n => format!(
            "{n} balls fit their contacts far worse than the noise allows: {}{more}; each has its centre in a wrong local minimum or a blunder among its contacts",
            named.join(", ")
        ),
    })
}

/// " and N more" after a list cut short, nothing if it was not.
fn and_more(more: usize) -> String {
    if more > 0 {
        format!(" and {more} more")
    } else {
        String::new()
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
    fn a_conflict_warning_names_the_offender_and_only_failed_tests() {
        let names = || ["a", "b", "c"].map(String::from);
        let conflict = ConflictTest::new(
            "test",
            names(),
            &[0.1, -1.0, 0.0],
            &[0.01; 3],
            &[0.001; 3],
            101.0,
        );
        let warning = conflict_warning(&conflict).unwrap();
        assert!(warning.contains("b (z = -10.5)"), "{warning}");
        assert!(warning.contains("chi-square 101.0 for 3"), "{warning}");
        // One value far out, the global chi-square within its limit: the
        // warning names the value and not the passing chi-square.
        let one = ConflictTest::new(
            "test",
            names(),
            &[0.0, 0.05, 0.0],
            &[0.01; 3],
            &[0.0099; 3],
            0.25,
        );
        let warning = conflict_warning(&one).unwrap();
        assert!(
            warning.contains("1 of the 3 values the data inform lie beyond"),
            "{warning}"
        );
        assert!(!warning.contains("chi-square"), "{warning}");
        let agree = ConflictTest::new("test", names(), &[0.0; 3], &[0.01; 3], &[0.001; 3], 0.0);
        assert_eq!(conflict_warning(&agree), None);
    }

    #[test]
    fn a_misfit_warning_names_the_worst_balls() {
        let misfit = |id: &str, chi_square| BallMisfit {
            ball: 0,
            id: id.to_string(),
            chi_square,
            degrees_of_freedom: 4,
        };
        let warning = misfit_warning(&[misfit("b900", f64::NAN), misfit("b500", 500.0)]).unwrap();
        assert!(
            warning.starts_with("2 balls fit their contacts"),
            "{warning}"
        );
        assert!(
            warning.contains("b500 (chi-square 500.0 for 4)"),
            "{warning}"
        );
        assert_eq!(misfit_warning(&[]), None);
    }
}
