//! Is the instrument calibration's covariance honest, and does it predict
//! what it has not seen? Paper-like campaigns of poses, points and both, in
//! three sessions, with re-homed legs and a re-mounted marker body.
//!
//! - `true_block` maps a simulation's truth to the global block; a
//!   low-noise run checks the mapping coordinate by coordinate.
//! - NEES: `e^T Σ^-1 e`, `e` the error of the whole global block, is
//!   chi-square(n) for an honest covariance (`n` the block's size) when the
//!   truth is drawn from the prior, so each seed draws one. Its mean over
//!   the seeds must lie within 4 standard errors of `n` (the standard error
//!   from the seeds' own spread). NEES is chi-square only to first order:
//!   the prior-limited errors of weakly determined directions (the tilt of
//!   the base plane against the instrument frames' common rotation; for
//!   points, the frames' rotations) reach the tightly determined
//!   combinations through the model's curvature, which adds to the NEES
//!   about the fourth power of the design tolerance. With the paper-like
//!   0.1 mm the mean exceeds `n` by more than the test allows; the test
//!   uses 0.02 mm, where the first order holds.
//! - Hold-out: a calibration on two sessions predicts a third one, its
//!   frame, body origin and leg offsets re-fitted on its first rows; the
//!   RMS it predicts must be within 20 % of the observed one (the issue's
//!   requirement).

use crate::common;

use std::time::Instant;

use common::{mean_and_standard_error, nees, true_block};
use parcal_calibrate::instruments::{Calibrated, validate_calibration};
use parcal_calibrate::{CalibrationOptions, calibrate};
use parcal_dataset::{Dataset, PriorSigma, SessionModel, Tracker};
use parcal_kinematics::{Geometry, Vec3};
use parcal_simulate::{Rng, TrackerKind, TrackerScenario, simulate_tracker};

const KINDS: [TrackerKind; 3] = [TrackerKind::Poses, TrackerKind::Points, TrackerKind::Both];

/// Noise seeds of the NEES test, per kind.
const NEES_SEEDS: u64 = 100;
/// The mean NEES must lie within this many of its standard errors of the
/// block's size: an honest covariance fails this with probability about
/// 6e-5 per kind.
const STANDARD_ERRORS: f64 = 4.0;
/// The design tolerance of every input coordinate in the NEES test (mm).
const TOLERANCE: f64 = 0.02;
/// The random stream of a seed's true machine: apart from the sessions'
/// streams `0..sessions` of the simulator.
const TRUTH_STREAM: u64 = 1 << 32;

/// The low-noise run's noise, as a fraction of the paper-like one.
const LOW_NOISE: f64 = 0.01;
/// Every coordinate of the low-noise run must be within this many sigmas
/// of the truth: about 1e-4 for all of them together, by chance.
const MAPPING_SIGMAS: f64 = 5.0;

/// Noise seeds of the hold-out test, per kind.
const HOLD_OUT_SEEDS: u64 = 30;
/// Rows of the held-out session that re-fit its nuisance.
const REFERENCE_ROWS: usize = 12;
/// The bound on `predicted / observed - 1` of the hold-out RMS.
const HOLD_OUT_TOLERANCE: f64 = 0.2;

/// The paper-like campaign of `kind` in 3 sessions of 40 rows; later
/// sessions re-home the legs (0.5 mm) and re-mount the marker body (1 mm).
fn campaign(kind: TrackerKind) -> TrackerScenario {
    TrackerScenario {
        kind,
        sessions: 3,
        rows_per_session: 40,
        session_model: SessionModel {
            leg_offset_sigma: Some(0.5),
            body_origin_sigma: Some(1.0),
            body_rotation_sigma: None,
        },
        ..TrackerScenario::paper_like()
    }
}

/// `scenario` with design tolerances `tolerance` (mm) and a true machine
/// drawn from them: each input coordinate of the design plus `N(0,
/// tolerance²)`, each scale its design value plus `N(0, scale_sigma²)`.
fn with_truth_from_prior(scenario: &TrackerScenario, tolerance: f64, seed: u64) -> TrackerScenario {
    let mut rng = Rng::new(seed, TRUTH_STREAM);
    let mut moved = |v: &Vec3| v + Vec3::from_fn(|_, _| rng.normal(tolerance));
    let design = &scenario.design;
    let truth = Geometry {
        base: design.base.map(|b| moved(&b)),
        platform: design.platform.map(|e| moved(&e)),
        tool: moved(&design.tool),
        legs: design.legs.map(|l| l + rng.normal(tolerance)),
    };
    let sigma = scenario
        .scale_sigma
        .expect("paper-like scales have a prior");
    let true_scale = std::array::from_fn(|i| scenario.design_scale[i] + rng.normal(sigma[i]));
    TrackerScenario {
        truth,
        true_scale,
        prior_sigma: PriorSigma {
            base: tolerance,
            platform: tolerance,
            tool: tolerance,
            leg: tolerance,
        },
        ..scenario.clone()
    }
}

/// The sessions `keep` of `dataset` (indices, renumbered in that order)
/// with their rows in file order, without the truth.
fn sessions_of(dataset: &Dataset, keep: &[usize]) -> Dataset {
    let tracker = &dataset.tracker;
    let renumber = |session: u32| {
        keep.iter()
            .position(|&k| k == session as usize)
            .map(|k| k as u32)
    };
    let mut out = Tracker {
        sessions: keep.iter().map(|&k| tracker.sessions[k].clone()).collect(),
        ..Tracker::default()
    };
    let (poses, points) = (&tracker.poses, &tracker.points);
    for j in 0..poses.len() {
        if let Some(k) = renumber(poses.session[j]) {
            out.poses.session.push(k);
            out.poses.q.push(poses.q[j]);
            out.poses.position.push(poses.position[j]);
            out.poses.orientation.push(poses.orientation[j]);
        }
    }
    for j in 0..points.len() {
        if let Some(k) = renumber(points.session[j]) {
            out.points.session.push(k);
            out.points.q.push(points.q[j]);
            out.points.position.push(points.position[j]);
        }
    }
    Dataset {
        tracker: out,
        truth: None,
        ..dataset.clone()
    }
}

#[test]
fn a_low_noise_calibration_finds_the_true_block() {
    for kind in KINDS {
        let noisy = TrackerScenario {
            session_model: SessionModel {
                body_rotation_sigma: Some(0.01),
                ..campaign(kind).session_model
            },
            ..campaign(kind)
        };
        let scenario = TrackerScenario {
            actuator_sigma: LOW_NOISE * noisy.actuator_sigma,
            position_sigma: LOW_NOISE * noisy.position_sigma,
            orientation_sigma: LOW_NOISE * noisy.orientation_sigma,
            ..with_truth_from_prior(&noisy, TOLERANCE, 1)
        };
        let dataset = simulate_tracker(&scenario, 1).expect("simulation").dataset;
        let run =
            calibrate(&dataset, &CalibrationOptions::default(), &mut |_| {}).expect("calibration");
        assert!(run.converged(), "{kind:?}: {:?}", run.status);
        let error = &run.global
            - true_block(
                &dataset,
                &run.instruments.as_ref().expect("poses or points").model,
            );
        let z = error.component_div(&run.global_sigmas().expect("sigmas"));
        let names = run.names();
        let worst = z.iamax();
        println!(
            "{kind:?}, noise x{LOW_NOISE}: {} parameters, largest |error| / sigma {:.2} ({})",
            z.len(),
            z[worst].abs(),
            names[worst]
        );
        let far: Vec<String> = (0..z.len())
            .filter(|&k| z[k].abs() > MAPPING_SIGMAS)
            .map(|k| format!("{} {:+.1} sigma", names[k], z[k]))
            .collect();
        assert!(far.is_empty(), "{kind:?}: {}", far.join(", "));
    }
}

#[test]
fn mean_nees_of_the_global_block_is_its_size() {
    let start = Instant::now();
    let mut failures = Vec::new();
    for kind in KINDS {
        let campaign = campaign(kind);
        let mut values = Vec::new();
        let mut size = 0;
        for seed in 1..=NEES_SEEDS {
            let scenario = with_truth_from_prior(&campaign, TOLERANCE, seed);
            let dataset = simulate_tracker(&scenario, seed)
                .expect("simulation")
                .dataset;
            let run = calibrate(&dataset, &CalibrationOptions::default(), &mut |_| {})
                .expect("calibration");
            let Some(covariance) = run.global_covariance.as_ref().filter(|_| run.converged())
            else {
                failures.push(format!("{kind:?} seed {seed}: {:?}", run.status));
                continue;
            };
            let error = &run.global
                - true_block(
                    &dataset,
                    &run.instruments.as_ref().expect("poses or points").model,
                );
            size = error.len();
            match nees(&error, covariance) {
                Some(v) => values.push(v),
                None => failures.push(format!("{kind:?} seed {seed}: covariance not SPD")),
            }
        }
        let (mean, standard_error) = mean_and_standard_error(&values);
        println!(
            "{kind:?}: {} seeds, mean NEES {mean:.2} for {size} parameters, standard error \
             {standard_error:.2} ({:+.1} standard errors)",
            values.len(),
            (mean - size as f64) / standard_error,
        );
        if (mean - size as f64).abs() > STANDARD_ERRORS * standard_error {
            failures.push(format!(
                "{kind:?}: mean NEES {mean:.2} is more than {STANDARD_ERRORS} standard errors \
                 ({standard_error:.2}) from {size}"
            ));
        }
    }
    println!("NEES: {:.1} s", start.elapsed().as_secs_f64());
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

#[test]
fn hold_out_rms_is_predicted_within_20_percent() {
    let start = Instant::now();
    let mut failures = Vec::new();
    for kind in KINDS {
        let scenario = campaign(kind);
        let (mut observed, mut predicted) = (Vec::new(), Vec::new());
        let (mut observed_squares, mut predicted_squares) = (0.0, 0.0);
        for seed in 1..=HOLD_OUT_SEEDS {
            let dataset = simulate_tracker(&scenario, seed)
                .expect("simulation")
                .dataset;
            let run = calibrate(
                &sessions_of(&dataset, &[0, 1]),
                &CalibrationOptions::default(),
                &mut |_| {},
            )
            .expect("calibration");
            if !run.converged() {
                failures.push(format!("{kind:?} seed {seed}: {:?}", run.status));
                continue;
            }
            let calibrated = Calibrated::from_record(&run.record(String::new()))
                .expect("a converged calibration");
            // Session 3's label is not one of the calibration's: its
            // nuisance is re-fitted on its first rows.
            let validation = validate_calibration(
                &sessions_of(&dataset, &[2]),
                &calibrated,
                Some(REFERENCE_ROWS),
            )
            .expect("validation");
            observed.push(validation.rms());
            predicted.push(validation.predicted_rms());
            observed_squares += validation.residuals.iter().map(|r| r * r).sum::<f64>();
            predicted_squares += validation
                .predicted_sigmas
                .iter()
                .map(|s| s * s)
                .sum::<f64>();
        }
        let (observed_mean, observed_se) = mean_and_standard_error(&observed);
        let (predicted_mean, predicted_se) = mean_and_standard_error(&predicted);
        let ratio_of_means = predicted_mean / observed_mean;
        let pooled = (predicted_squares / observed_squares).sqrt();
        println!(
            "{kind:?}: {} seeds, observed RMS {observed_mean:.5} ± {observed_se:.5} mm, \
             predicted {predicted_mean:.5} ± {predicted_se:.5} mm; ratio of the means \
             {ratio_of_means:.3}, of the pooled RMS {pooled:.3}",
            observed.len(),
        );
        for (what, ratio) in [("means", ratio_of_means), ("pooled RMS", pooled)] {
            if (ratio - 1.0).abs() > HOLD_OUT_TOLERANCE {
                failures.push(format!(
                    "{kind:?}: predicted / observed hold-out RMS ({what}) {ratio:.3}"
                ));
            }
        }
    }
    println!("hold-out: {:.1} s", start.elapsed().as_secs_f64());
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

/// Seeds of the diagnosis at the paper-like tolerance.
const PAPER_LIKE_SEEDS: u64 = 60;

/// At the paper-like 0.1 mm tolerance the mean NEES of the whole block
/// exceeds its size (module doc). Where the excess is: the NEES of the 33
/// alone must stay within [`STANDARD_ERRORS`] of 33, both for a true
/// machine drawn in the input coordinates and for one drawn in the
/// canonical parameters from the Gaussian prior itself (which takes the
/// linearisation of the prior's propagation out of the question); the
/// whole block's is printed (docs/formulation.md, section 7).
#[test]
#[ignore = "a diagnosis: cargo test -p parcal-workflows --test integration instruments_monte_carlo:: -- --ignored --nocapture"]
fn at_the_paper_like_tolerance_the_kinematic_block_stays_honest() {
    use nalgebra::DVector;
    use parcal_kinematics::{N_PARAMS, Params, params};
    const PAPER_LIKE: f64 = 0.1;
    let mut failures = Vec::new();
    for kind in [TrackerKind::Poses, TrackerKind::Points] {
        let design = with_truth_from_prior(&campaign(kind), PAPER_LIKE, 0);
        let first = simulate_tracker(&design, 0).expect("simulation").dataset;
        let run =
            calibrate(&first, &CalibrationOptions::default(), &mut |_| {}).expect("calibration");
        let prior = run.prior.as_ref().expect("a prior");
        let mean = DVector::from_column_slice(prior.mean().as_slice());
        let information = nalgebra::DMatrix::from_column_slice(
            N_PARAMS,
            N_PARAMS,
            prior.information().as_slice(),
        );
        let factor = information
            .try_inverse()
            .and_then(|c| c.cholesky())
            .expect("a positive definite prior")
            .l();
        for canonical in [false, true] {
            let (mut whole, mut kinematic, mut size) = (Vec::new(), Vec::new(), 0);
            for seed in 1..=PAPER_LIKE_SEEDS {
                let mut scenario = with_truth_from_prior(&campaign(kind), PAPER_LIKE, seed);
                if canonical {
                    let mut rng = Rng::new(seed, TRUTH_STREAM + 1);
                    let z = DVector::from_fn(N_PARAMS, |_, _| rng.normal(1.0));
                    let p = &mean + &factor * z;
                    scenario.truth = params::from_params(&Params::from_iterator(p.iter().copied()));
                }
                let dataset = simulate_tracker(&scenario, seed)
                    .expect("simulation")
                    .dataset;
                let run = calibrate(&dataset, &CalibrationOptions::default(), &mut |_| {})
                    .expect("calibration");
                let covariance = run.global_covariance.as_ref().expect("a covariance");
                let error = &run.global
                    - true_block(
                        &dataset,
                        &run.instruments.as_ref().expect("poses or points").model,
                    );
                size = error.len();
                whole.push(nees(&error, covariance).expect("positive definite"));
                let block = covariance.view((0, 0), (N_PARAMS, N_PARAMS)).into_owned();
                kinematic.push(nees(&error.rows(0, N_PARAMS).into_owned(), &block).expect("SPD"));
            }
            let (m, se) = mean_and_standard_error(&whole);
            let (mk, sek) = mean_and_standard_error(&kinematic);
            let draw = if canonical {
                "canonical parameters"
            } else {
                "input coordinates"
            };
            println!(
                "{kind:?}, truth drawn in the {draw}: whole block {m:.1} +- {se:.1} for {size} \
                 ({:+.1} SE); the 33 {mk:.1} +- {sek:.1} ({:+.1} SE)",
                (m - size as f64) / se,
                (mk - 33.0) / sek
            );
            if (mk - 33.0).abs() > STANDARD_ERRORS * sek {
                failures.push(format!(
                    "{kind:?}, {draw}: the 33's mean NEES {mk:.1} +- {sek:.1}"
                ));
            }
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

/// The prediction test's rejections over `seeds` paper-like campaigns of
/// both poses and points: each calibrated on two sessions (with its global
/// test, as calibration.json holds it), its third session validated with
/// its nuisance re-fitted on its first rows. Returns the rejection count,
/// the too-small count and each seed's `T / n`.
fn prediction_tests(seeds: std::ops::RangeInclusive<u64>) -> (usize, usize, Vec<f64>) {
    let scenario = campaign(TrackerKind::Both);
    let (mut rejected, mut too_small, mut factors) = (0, 0, Vec::new());
    for seed in seeds {
        let dataset = simulate_tracker(&scenario, seed)
            .expect("simulation")
            .dataset;
        let calibration = sessions_of(&dataset, &[0, 1]);
        let run = calibrate(&calibration, &CalibrationOptions::default(), &mut |_| {})
            .expect("calibration");
        assert!(run.converged(), "seed {seed}: {:?}", run.status);
        let calibrated = Calibrated::of_run(&run).expect("a converged calibration");
        let validation = validate_calibration(
            &sessions_of(&dataset, &[2]),
            &calibrated,
            Some(REFERENCE_ROWS),
        )
        .expect("validation");
        let test = validation.test().expect("predicted rows");
        rejected += usize::from(test.rejects());
        too_small += usize::from(test.outcome == parcal_calibrate::verdict::Outcome::TooSmall);
        factors.push(test.statistic / test.rows as f64);
        if test.rejects() {
            println!(
                "seed {seed}: T/n {:.3}, refitted {:?}, RMS {:.4} predicted {:.4}",
                test.statistic / test.rows as f64,
                validation.refitted,
                validation.rms(),
                validation.predicted_rms()
            );
        }
    }
    (rejected, too_small, factors)
}

/// Seeds of the quick check of the prediction test.
const PREDICTION_SEEDS: u64 = 20;

/// With the model and the noise as stated, `T = rᵀ C⁻¹ r` of a validation
/// is `χ²(n)`: the mean of `T / n` over the seeds lies within
/// [`STANDARD_ERRORS`] of 1 (the standard error from the seeds' spread).
#[test]
fn the_prediction_statistic_has_its_degrees_of_freedom_as_mean() {
    let (rejected, too_small, factors) = prediction_tests(1..=PREDICTION_SEEDS);
    let (mean, se) = mean_and_standard_error(&factors);
    println!(
        "{PREDICTION_SEEDS} seeds: mean T/n {mean:.4} ± {se:.4}; {rejected} rejected, {too_small} too small"
    );
    assert!((mean - 1.0).abs() < STANDARD_ERRORS * se, "{mean} ± {se}");
}

/// Seeds of the false-alarm rate of the prediction test.
const FALSE_ALARM_SEEDS: u64 = 400;

/// The prediction test rejects a calibration that does transfer at its
/// nominal rate, `α / 2` (the upper tail of the two-sided test), within
/// [`STANDARD_ERRORS`] binomial standard errors; the too-small outcomes
/// likewise (docs/validation-verdicts.md).
#[test]
#[ignore = "400 calibrations: cargo test -p parcal-workflows --test integration instruments_monte_carlo::prediction_test_false -- --ignored --nocapture"]
fn prediction_test_false_alarms_at_the_nominal_rate() {
    let start = Instant::now();
    let (rejected, too_small, factors) = prediction_tests(1..=FALSE_ALARM_SEEDS);
    let (mean, se) = mean_and_standard_error(&factors);
    let nominal = parcal_calibrate::verdict::GLOBAL_TEST_LEVEL / 2.0;
    let n = FALSE_ALARM_SEEDS as f64;
    let binomial = (nominal * (1.0 - nominal) / n).sqrt();
    let rate = rejected as f64 / n;
    let small_rate = too_small as f64 / n;
    println!(
        "{FALSE_ALARM_SEEDS} seeds: rejected {rejected} ({rate:.4}), too small {too_small} \
         ({small_rate:.4}), nominal {nominal} ± {binomial:.4}; mean T/n {mean:.4} ± {se:.4}; {:.1} s",
        start.elapsed().as_secs_f64()
    );
    assert!(
        (rate - nominal).abs() < STANDARD_ERRORS * binomial,
        "{rate}"
    );
    assert!(
        (small_rate - nominal).abs() < STANDARD_ERRORS * binomial,
        "{small_rate}"
    );
    assert!((mean - 1.0).abs() < STANDARD_ERRORS * se, "{mean} ± {se}");
}
