//! A calibration run in sentences: its status (calibration.json's
//! `status`), what it did beyond the iteration, its warnings, its weak
//! directions. Calibrate keeps the numbers; this module words them.

use parcal_calibrate::CalibrationRun;
use parcal_calibrate::conflict::{ConflictTest, PaperPriorInconsistency};
use parcal_calibrate::fit::BallMisfit;
use parcal_calibrate::systematic::{Effect, SYSTEMATIC_LEVEL, SystematicTest};
use parcal_calibrate::verdict::{GlobalTest, Outcome};
use parcal_dataset::SystematicSensitivityRecord;
use parcal_kinematics::PARAM_NAMES;

use crate::checks::{and_more, re_seeded_sentences};
use crate::verdict::solver_status;

/// The status in one sentence (calibration.json's `status`), naming
/// parameters, balls and measurements.csv lines.
pub fn status(run: &CalibrationRun) -> String {
    solver_status(
        &run.status,
        &run.names(),
        |k| {
            format!(
                "the centre of ball {} is not determined by its contacts",
                run.balls.ids[k]
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

/// What the run did beyond the method's iteration, one sentence each (the
/// balls re-seeded on the other side of their contacts: the first 10, then
/// their count).
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
    let re_seeded = re_seeded_sentences(
        &run.balls.mirrored,
        |m| {
            format!(
                "ball {} was on the wrong side of its contacts at iteration {} (chi-square {:.1}; its contact points at that iterate's geometry fit the mirror image of its centre {:.0} times better): re-seeded there, and the calibration resumed",
                m.id,
                m.iteration,
                m.side.chi_square,
                m.side.side.cost / m.side.mirror.cost
            )
        },
        |more| {
            format!(
                "{more} more balls were on the wrong side of their contacts and were re-seeded likewise"
            )
        },
    );
    run_away.into_iter().chain(re_seeded).collect()
}

/// Every warning about the priors and the balls' fit, one sentence each.
pub fn warnings(run: &CalibrationRun) -> Vec<String> {
    let conflicts = run.conflicts.iter().filter_map(conflict_warning);
    run.prior_consistency
        .iter()
        .map(paper_prior_warning)
        .chain(conflicts)
        .chain(misfit_warning(&run.balls.misfits))
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
    let offenders = &test.offenders;
    if !offenders.is_empty() {
        let listed: Vec<String> = offenders
            .iter()
            .take(8)
            .map(|i| format!("{} (z = {:+.1})", i.name, i.z))
            .collect();
        findings.push(format!(
            "{} of the {} values the data inform lie beyond |z| = {:.2} (0.1% family-wise): {}{}",
            offenders.len(),
            test.informed,
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_conflict_warning_names_the_offender_and_only_failed_tests() {
        let names = || |k: usize| ["a", "b", "c"][k].to_string();
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
