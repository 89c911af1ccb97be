//! Verdicts on simulated data against the truth: a blunder is found and
//! removed by data snooping, and clean data raise false alarms at the
//! tests' nominal rates only.

mod common;

use common::{removed, snoop, true_registered_rms};
use parcal_calibrate::reliability::{ObservationId, minimal_detectable_bias};
use parcal_calibrate::snooping::SNOOPING_LEVEL;
use parcal_calibrate::verdict::Outcome;
use parcal_calibrate::{CalibrationOptions, CalibrationRun, RadiusModel, calibrate};
use parcal_simulate::{Scenario, simulate};

/// A reading off by 50 um (50 sigma of the actuators) among the 189 of the
/// paper scenario: the global test rejects the run, data snooping removes
/// exactly that contact, the result is accepted, and its true registered
/// error is within 20 % of the clean run's.
#[test]
fn a_blunder_is_found_and_removed() {
    let clean = simulate(&Scenario::paper(), 1).unwrap().dataset;
    let options = CalibrationOptions::default();
    let clean_run = calibrate(&clean, &options, &mut |_| {}).unwrap();
    assert!(clean_run.verdict().accepted);
    let mut blundered = clean.clone();
    let row = 38;
    blundered.measurements.q[row][2] += 0.05;
    let run = calibrate(&blundered, &options, &mut |_| {}).unwrap();
    let test = run.global_test.unwrap();
    assert_eq!(test.outcome, Outcome::TooLarge, "{test:?}");
    assert!(!run.verdict().accepted);
    let snooped = snoop(&blundered, &options);
    let removed = removed(&snooped);
    assert_eq!(
        removed,
        [ObservationId::Contact(row)],
        "removed observations"
    );
    assert!(snooped.run.verdict().accepted);
    let (clean_rms, snooped_rms) = (
        true_registered_rms(&clean, &clean_run),
        true_registered_rms(&blundered, &snooped.run),
    );
    println!("true registered RMS: clean {clean_rms:.6} mm, after snooping {snooped_rms:.6} mm");
    assert!((snooped_rms / clean_rms - 1.0).abs() < 0.2);
}

/// One ball's radius entered 20 um too small (20 of its sigmas). With each
/// ball's radius an unknown (the default), the radius priors' conflict test
/// names that radius alone, and the global test rejects the run.
#[test]
fn a_wrong_radius_is_named_by_its_radius_prior() {
    let mut dataset = simulate(&Scenario::paper(), 1).unwrap().dataset;
    dataset.artefacts.balls[4].radius -= 0.02;
    let run = calibrate(&dataset, &CalibrationOptions::default(), &mut |_| {}).unwrap();
    assert!(run.converged());
    let radii = run
        .conflicts
        .iter()
        .find(|c| c.what == "ball radii")
        .expect("the radius priors' test");
    let offenders: Vec<(&str, f64)> = radii
        .offenders()
        .iter()
        .map(|i| (i.name.as_str(), i.z.unwrap()))
        .collect();
    println!("radius priors' offenders: {offenders:?}");
    assert_eq!(offenders.len(), 1, "{offenders:?}");
    assert_eq!(offenders[0].0, "radius b05");
    // The estimate is above the radius given: the touches pull it back.
    assert!(offenders[0].1 > 0.0);
    let warning = parcal_report::sentences::conflict_warning(radii).unwrap();
    assert!(warning.contains("radius b05"), "{warning}");
    assert_eq!(run.global_test.unwrap().outcome, Outcome::TooLarge);
}

/// Every ball's radius entered 20 um too small (the nominal radius instead
/// of the calibrated one), with each ball's radius an unknown: the global
/// test rejects the run, but the radius priors do not name the radii. Seven
/// touches per ball inform each radius little (its posterior sigma is 0.88
/// to 0.98 of the prior's), and a shift common to every ball goes into the
/// kinematic parameters and the centres rather than into the radii.
#[test]
fn a_common_radius_error_is_rejected_by_the_global_test() {
    let mut dataset = simulate(&Scenario::paper(), 1).unwrap().dataset;
    for ball in &mut dataset.artefacts.balls {
        ball.radius -= 0.02;
    }
    let run = calibrate(&dataset, &CalibrationOptions::default(), &mut |_| {}).unwrap();
    let test = run.global_test.unwrap();
    let radii = run
        .conflicts
        .iter()
        .find(|c| c.what == "ball radii")
        .unwrap();
    println!(
        "variance factor {:.2}; radius priors' chi-square {:.1} for {}",
        test.variance_factor, radii.chi_square, radii.degrees_of_freedom
    );
    assert_eq!(test.outcome, Outcome::TooLarge, "{test:?}");
    assert!(!run.verdict().accepted);
}

/// The same with the radius error per contact (paper eq. 5): the global
/// test rejects the run, and the ball touches' variance component is above
/// the interval. (The priors' component is as large: the wrong radius pulls
/// the leg lengths away from their prior, so the components do not single
/// out the touches.)
#[test]
fn a_wrong_radius_per_contact_is_rejected_and_the_touches_named() {
    let mut dataset = simulate(&Scenario::paper(), 1).unwrap().dataset;
    for ball in &mut dataset.artefacts.balls {
        ball.radius -= 0.02;
    }
    let options = CalibrationOptions {
        radius: RadiusModel::PerContact,
        ..CalibrationOptions::default()
    };
    let run = calibrate(&dataset, &options, &mut |_| {}).unwrap();
    let test = run.global_test.unwrap();
    println!("variance factor {:.2}", test.variance_factor);
    assert_eq!(test.outcome, Outcome::TooLarge, "{test:?}");
    assert!(!run.verdict().accepted);
    let components = &run.reliability.as_ref().unwrap().components;
    let factor = |group: &str| {
        components
            .iter()
            .find(|c| c.group == group)
            .map(|c| c.factor())
            .unwrap()
    };
    println!(
        "touches {:.2}, priors {:.2}",
        factor("ball touches"),
        factor("priors")
    );
    assert!(factor("ball touches") > test.interval.1);
}

/// Over clean Monte Carlo draws of the paper scenario: the global test
/// (5 %, two-sided) rejects at its nominal rate, within the binomial
/// interval (4 standard errors of 5 % over the draws), and data snooping
/// removes something in at most 5 % of them (plus 4 standard errors).
#[test]
fn clean_data_raise_false_alarms_at_the_nominal_rate() {
    let draws = 200u64;
    let options = CalibrationOptions::default();
    let (mut rejected, mut snooped_any, mut verdict_rejected) = (0usize, 0usize, 0usize);
    for seed in 1..=draws {
        let dataset = simulate(&Scenario::paper(), seed).unwrap().dataset;
        let snooped = snoop(&dataset, &options);
        // The data as given: the first calibration's global test, which is
        // the final run's when nothing was removed.
        let first = match snooped.removals.first() {
            None => snooped.run.global_test.unwrap().outcome != Outcome::Consistent,
            Some(removal) => {
                snooped_any += 1;
                let interval = snooped.run.global_test.unwrap().interval;
                !(interval.0..=interval.1).contains(&removal.variance_factor_before)
            }
        };
        rejected += usize::from(first);
        // The verdict on the data as given: a failing data-snooping test
        // (something was removed) rejects it, as a global test above its
        // interval does.
        let too_large = match snooped.removals.first() {
            None => !snooped.run.verdict().accepted,
            Some(_) => true,
        };
        verdict_rejected += usize::from(too_large);
    }
    let rate = rejected as f64 / draws as f64;
    let se = (0.05 * 0.95 / draws as f64).sqrt();
    println!(
        "global test rejects {rejected} of {draws} ({rate:.3}, nominal 0.05 +- {se:.3}); snooping removed something in {snooped_any}; the verdict rejects {verdict_rejected}"
    );
    // At most the global test's upper tail (2.5 %) plus snooping's 5 %,
    // with 4 standard errors.
    let bound = 0.075 + 4.0 * (0.075 * 0.925 / draws as f64).sqrt();
    assert!(verdict_rejected as f64 <= bound * draws as f64);
    assert!((rate - 0.05).abs() < 4.0 * se, "rejection rate {rate}");
    // Bonferroni makes 5 % an upper bound of the family-wise rate; the
    // count is binomial, allowed 4 of its standard errors above it.
    let allowed = draws as f64 * (0.05 + 4.0 * se);
    assert!(
        snooped_any as f64 <= allowed,
        "{snooped_any} draws lost contacts (allowed {allowed:.1})"
    );
}

/// artefacts.json claiming `"frame": "canonical"` for centres given in the
/// design frame: rejected by the global test, and the priors' variance
/// component (the centres' priors, now in the wrong frame) is the largest.
#[test]
fn a_mislabelled_artefact_frame_is_rejected_and_the_priors_named() {
    let mut dataset = simulate(&Scenario::paper(), 1).unwrap().dataset;
    dataset.artefacts.frame = parcal_dataset::ArtefactFrame::Canonical;
    let run = calibrate(&dataset, &CalibrationOptions::default(), &mut |_| {}).unwrap();
    assert!(!run.verdict().accepted);
    let test = run.global_test.unwrap();
    assert_eq!(test.outcome, Outcome::TooLarge, "{test:?}");
    let components = &run.reliability.as_ref().unwrap().components;
    let largest = components
        .iter()
        .max_by(|a, b| a.factor().total_cmp(&b.factor()))
        .unwrap();
    println!(
        "variance factor {:.0}; largest component {} {:.0}",
        test.variance_factor,
        largest.group,
        largest.factor()
    );
    assert_eq!(largest.group, "priors");
}

/// The normalised residual of the contact of measurements.csv row `row`
/// in a run (its rows' largest).
fn contact_w(run: &CalibrationRun, row: usize) -> f64 {
    run.reliability
        .as_ref()
        .unwrap()
        .observations()
        .find(|c| c.observation() == ObservationId::Contact(row))
        .and_then(|c| c.normalised())
        .unwrap()
}

/// Blunders of 0.02 to 5 mm in one reading of the paper scenario (seed 1,
/// row 38, leg 3). The reading's minimal detectable bias (mm) follows from
/// the linear response of the contact's normalised residual to a blunder
/// `b`, `w(b) = w(0) + s b`: `MDB = δ₀ / |s|`, `δ₀` at the data-snooping
/// level of one test (Bonferroni) with power 80 %; `|s|` from blunders of
/// ±50 um (`(|w(+b)| + |w(−b)|) / 2b`, exact while `|s b| > |w(0)|`).
/// Every blunder above the MDB is detected: the run is rejected without
/// snooping, and snooping removes that contact alone; detection never gets
/// worse as the blunder grows.
#[test]
fn detection_is_monotone_in_the_blunder_above_its_minimal_detectable_bias() {
    let clean = simulate(&Scenario::paper(), 1).unwrap().dataset;
    let options = CalibrationOptions::default();
    let (row, leg) = (38, 2);
    let with_blunder = |b: f64| {
        let mut d = clean.clone();
        d.measurements.q[row][leg] += b;
        d
    };
    let probe = 0.05;
    let w = |b: f64| {
        contact_w(
            &calibrate(&with_blunder(b), &options, &mut |_| {}).unwrap(),
            row,
        )
    };
    let slope = (w(probe).abs() + w(-probe).abs()) / (2.0 * probe);
    let reliability_tests = calibrate(&clean, &options, &mut |_| {})
        .unwrap()
        .reliability
        .unwrap()
        .tests();
    let level = SNOOPING_LEVEL / reliability_tests as f64;
    let mdb = minimal_detectable_bias(1.0, level) / slope;
    println!("slope {slope:.1} per mm, MDB {:.1} um", 1e3 * mdb);
    let mut detected_before = false;
    for blunder in [0.02, 0.05, 0.1, 0.2, 0.5, 1.0, 2.0, 5.0] {
        let dataset = with_blunder(blunder);
        let run = calibrate(&dataset, &options, &mut |_| {}).unwrap();
        let rejected = !run.verdict().accepted;
        let snooped = snoop(&dataset, &options);
        let removed = removed(&snooped);
        let found = removed == [ObservationId::Contact(row)] && snooped.run.verdict().accepted;
        println!(
            "{:>6.0} um: {}, variance factor {:.2}, rejected {rejected}, w {:+.1}, snooping removed {removed:?}, accepted {}",
            1e3 * blunder,
            if run.converged() {
                "converged"
            } else {
                "not converged"
            },
            run.global_test.map_or(f64::NAN, |t| t.variance_factor),
            contact_w(&run, row),
            snooped.run.verdict().accepted
        );
        let detected = rejected && found;
        if blunder > mdb {
            assert!(
                detected,
                "a blunder of {blunder} mm above the MDB {mdb:.4} mm"
            );
        }
        assert!(
            detected || !detected_before,
            "{blunder} mm is not detected where a smaller blunder was"
        );
        detected_before = detected;
    }
}

/// A zero time budget: the run stops at its first iterate with the time
/// limit (not a divergence, and not made again with Levenberg-Marquardt),
/// says so, and is rejected.
#[test]
fn a_time_limit_stops_the_run_and_rejects_it() {
    let dataset = simulate(&Scenario::paper(), 1).unwrap().dataset;
    let options = CalibrationOptions {
        time_limit: Some(std::time::Duration::ZERO),
        ..CalibrationOptions::default()
    };
    let run = calibrate(&dataset, &options, &mut |_| {}).unwrap();
    assert_eq!(run.status, parcal_solver::Status::TimeLimit);
    assert!(run.gauss_newton.is_none());
    assert_eq!(run.iterations(), 0);
    assert!(!run.verdict().accepted);
    assert_eq!(
        parcal_report::sentences::status(&run),
        "time limit reached without convergence"
    );
}
