//! The calibration of a linear delta through the `Mechanism` trait
//! (`parcal_calibrate::mechanism`), on printers simulated by
//! `parcal_simulate::delta`: the estimate's consistency with its
//! covariance (NEES), a probe blunder found by snooping, what probe
//! heights alone cannot determine and what a part distance or calibrated
//! balls add, readings at unknown poses, and touches of calibrated balls
//! at unknown centres.

use nalgebra::DVector;
use parcal_calibrate::Observation;
use parcal_calibrate::mechanism::{
    Ball, CentrePrior, MechanismCalibration, MechanismCalibrationError, MechanismData,
    MechanismOptions, ObservationKind, ObservationRef, Observations, TRIGGER_HEIGHT,
    calibrate_mechanism,
};
use parcal_dataset::mechanism::{BallPlacement, MechanismDataset};
use parcal_kinematics::delta::DeltaParams;
use parcal_kinematics::mechanism::Mechanism;
use parcal_observe::mechanism::CommandedPoint;
use parcal_simulate::delta::{DeltaScenario, simulate_delta};
use parcal_simulate::{Plate, PlatePairs, Rng};
use parcal_solver::{IterationRecord, Status};

use crate::mean;
use crate::nees;

use mean::mean_and_standard_error;
use nees::nees;

/// A printer of the range: rods 250-300 mm, radius 120-150 mm,
/// drawn from stream `seed`.
fn scenario(seed: u64, distances: usize) -> DeltaScenario {
    let mut rng = Rng::new(seed, 1000);
    DeltaScenario {
        design: DeltaParams::symmetric(
            rng.uniform(250.0, 300.0),
            rng.uniform(120.0, 150.0),
            rng.uniform(280.0, 350.0),
        ),
        distances,
        ..DeltaScenario::typical()
    }
}

fn calibrate(dataset: &MechanismDataset, options: &MechanismOptions) -> MechanismCalibration {
    let data = MechanismData::from_dataset(dataset).expect("a simulated dataset converts");
    calibrate_mechanism(&data, options, &mut |_| {}).expect("a simulated printer calibrates")
}

/// The true unknowns in the canonical frame: the parameters
/// canonicalised, then the trigger height.
fn canonical_truth(dataset: &MechanismDataset) -> DVector<f64> {
    let truth = dataset.truth.as_ref().expect("simulated");
    let delta = parcal_kinematics::delta::LinearDelta::typical();
    let canonical = delta.canonicalize(&truth.parameters).unwrap();
    let mut values: Vec<f64> = canonical.iter().copied().collect();
    values.push(truth.trigger_height.expect("a delta's trigger height"));
    DVector::from_vec(values)
}

/// NEES over `draws` printers, with `distances` part distances each: the
/// mean, its standard error from the draws, and the identifiable count.
fn nees_over(draws: u64, distances: usize) -> (f64, f64, usize) {
    let mut values = Vec::new();
    let mut ranks = Vec::new();
    for seed in 0..draws {
        let dataset = simulate_delta(&scenario(seed, distances), seed).unwrap();
        let run = calibrate(&dataset, &MechanismOptions::default());
        assert!(run.converged(), "seed {seed}: {:?}", run.reasons);
        let error = run.values() - canonical_truth(&dataset);
        let (value, rank) = nees(&error, run.covariance.as_ref().unwrap());
        values.push(value);
        ranks.push(rank);
    }
    ranks.dedup();
    assert_eq!(ranks.len(), 1, "the identifiable count varies: {ranks:?}");
    let (mean, standard_error) = mean_and_standard_error(&values);
    (mean, standard_error, ranks[0])
}

#[test]
fn nees_over_simulated_printers_matches_the_identifiable_count() {
    // 16 parameters and the trigger height, less the delta's 5 gauge
    // freedoms (its `gauge_freedoms`): 12 identifiable unknowns, the rank
    // of the canonical covariance (checked draw by draw). The true
    // printers are drawn from the priors, so the posterior covariance is
    // the error's: E[NEES] = 12.
    let delta = parcal_kinematics::delta::LinearDelta::typical();
    let design = parcal_kinematics::mechanism::design(&delta);
    let gauge = delta.gauge_freedoms(design.as_slice()).unwrap().len();
    let expected = delta.parameters().len() + 1 - gauge;
    let (mean, standard_error, rank) = nees_over(30, 4);
    eprintln!("NEES over 30 printers: {mean:.3} +- {standard_error:.3} (rank {rank})");
    assert_eq!(rank, expected);
    assert!(
        (mean - expected as f64).abs() < 4.0 * standard_error,
        "mean NEES {mean:.3} +- {standard_error:.3}, expected {expected}"
    );
}

#[test]
fn manual_heights_determine_the_trigger_height_consistently() {
    // Five heights measured by hand to 20 µm on each of 30 printers: the
    // estimate stays consistent with its covariance (NEES of mean 12),
    // and the trigger height, which probe heights see only against the
    // homed height, is known far better than its prior's 50 µm.
    let (mut values, mut trigger_sigmas) = (Vec::new(), Vec::new());
    for seed in 0..30 {
        let scenario = DeltaScenario {
            manual_heights: 5,
            height_sigma: 0.02,
            ..scenario(seed, 4)
        };
        let dataset = simulate_delta(&scenario, seed).unwrap();
        assert_eq!(dataset.heights.len(), 5);
        let run = calibrate(&dataset, &MechanismOptions::default());
        assert!(run.converged(), "seed {seed}: {:?}", run.reasons);
        let covariance = run.covariance.as_ref().unwrap();
        let (value, rank) = nees(&(run.values() - canonical_truth(&dataset)), covariance);
        assert_eq!(rank, 12, "seed {seed}");
        values.push(value);
        let n = covariance.nrows() - 1;
        trigger_sigmas.push(covariance[(n, n)].sqrt());
    }
    let (mean, standard_error) = mean_and_standard_error(&values);
    let largest = trigger_sigmas.iter().copied().fold(0.0, f64::max);
    eprintln!(
        "with 5 manual heights, NEES over 30 printers: {mean:.3} +- {standard_error:.3}; trigger height's sigma at most {largest:.4} mm"
    );
    assert!(
        (mean - 12.0).abs() < 4.0 * standard_error,
        "mean NEES {mean:.3} +- {standard_error:.3}"
    );
    assert!(
        largest < 0.5 * DeltaScenario::typical().trigger_sigma,
        "{largest}"
    );
}

/// The undetermined directions in which every diagonal rod has a
/// component of one sign (at least 0.25 prior sigma each): the common
/// scale of the rods, which with the radius sets the XY scale.
fn rod_scale_directions(run: &MechanismCalibration) -> usize {
    let identifiability = run.identifiability.as_ref().expect("a covariance");
    identifiability
        .undetermined
        .iter()
        .filter(|direction| {
            let rods: Vec<f64> = ["diagonal_a", "diagonal_b", "diagonal_c"]
                .iter()
                .filter_map(|rod| {
                    direction
                        .components
                        .iter()
                        .find(|(name, _)| name == rod)
                        .map(|c| c.1)
                })
                .collect();
            rods.len() == 3 && (rods.iter().all(|&v| v > 0.0) || rods.iter().all(|&v| v < 0.0))
        })
        .count()
}

#[test]
fn probe_heights_leave_the_xy_scale_to_the_prior_and_a_part_distance_sets_it() {
    let probes_only = simulate_delta(&scenario(3, 0), 3).unwrap();
    let run = calibrate(&probes_only, &MechanismOptions::default());
    assert!(run.verdict.accepted, "{:?}", run.reasons);
    let statements = &run.identifiability.as_ref().unwrap().statements;
    eprintln!("probe heights alone: {statements:#?}");
    assert_eq!(rod_scale_directions(&run), 1, "{statements:?}");
    assert!(
        statements
            .iter()
            .any(|s| s.contains("diagonal_a") && s.contains("its prior sets it")),
        "{statements:?}"
    );
    // The trigger height against the bed's height: no probe tells them
    // apart, its prior alone sets it.
    let ratio = |run: &MechanismCalibration, name: &str| {
        let k = run.parameters.iter().position(|p| p.name == name).unwrap();
        run.identifiability.as_ref().unwrap().sigma_ratio[k].unwrap()
    };
    assert!(ratio(&run, TRIGGER_HEIGHT) > 0.99);

    // The same printer with four part distances: the rods' common scale
    // is determined, and the rods' sigmas shrink.
    let with_distances = simulate_delta(&scenario(3, 4), 3).unwrap();
    let measured = calibrate(&with_distances, &MechanismOptions::default());
    assert!(measured.verdict.accepted, "{:?}", measured.reasons);
    eprintln!(
        "with four part distances: {:#?}",
        measured.identifiability.as_ref().unwrap().statements
    );
    assert_eq!(rod_scale_directions(&measured), 0);
    for rod in ["diagonal_a", "diagonal_b", "diagonal_c", "radius"] {
        assert!(
            ratio(&measured, rod) < ratio(&run, rod),
            "{rod}: {} with distances, {} without",
            ratio(&measured, rod),
            ratio(&run, rod)
        );
    }
}

/// The calibrations of `dataset`, whose `blunder` is off, under `options`
/// without and with data snooping (`observer` seeing the latter's
/// iterations): the plain one rejected with the blunder the worst
/// observation, named in its reasons; snooping removing it, and only it,
/// and accepting the rest.
fn blunder_is_named_and_removed(
    dataset: &MechanismDataset,
    blunder: ObservationRef,
    options: &MechanismOptions,
    observer: &mut dyn FnMut(&IterationRecord),
) -> (MechanismCalibration, MechanismCalibration) {
    let plain = calibrate(dataset, options);
    assert!(!plain.verdict.accepted);
    assert_eq!(plain.worst().map(|w| w.observation), Some(blunder));
    assert!(
        plain
            .reasons
            .iter()
            .any(|r| r.contains(&blunder.to_string())),
        "{:?}",
        plain.reasons
    );
    let data = MechanismData::from_dataset(dataset).unwrap();
    let snooping = options.clone().with_snooping(true);
    let snooped = calibrate_mechanism(&data, &snooping, observer).unwrap();
    eprintln!("{:#?}", snooped.reasons);
    assert_eq!(snooped.removals.len(), 1, "{:?}", snooped.removals);
    assert_eq!(snooped.removals[0].observation, blunder);
    assert!(snooped.verdict.accepted, "{:?}", snooped.reasons);
    (plain, snooped)
}

#[test]
fn a_probe_blunder_of_0_3_mm_is_named_and_removed_by_snooping() {
    let mut dataset = simulate_delta(&scenario(5, 4), 5).unwrap();
    let blunder = 11;
    dataset.probes[blunder][2] += 0.3;
    let probe = ObservationRef {
        kind: ObservationKind::Probe,
        index: blunder,
    };
    // The observer sees both fits' iterations: the first, the plain one,
    // then the fit without the blunder.
    let mut seen = 0;
    let default = MechanismOptions::default();
    let (plain, snooped) =
        blunder_is_named_and_removed(&dataset, probe, &default, &mut |_| seen += 1);
    assert_eq!(seen, plain.iterations + snooped.iterations);
    assert!(snooped.snooping_stopped.is_none());
    // A spent time budget stops the first fit at its start: nothing is
    // tested, so snooping stops there, and the verdict says why.
    let data = MechanismData::from_dataset(&dataset).unwrap();
    let spent = MechanismOptions::default()
        .with_snooping(true)
        .with_time_limit(Some(std::time::Duration::ZERO));
    let stopped = calibrate_mechanism(&data, &spent, &mut |_| {}).unwrap();
    assert_eq!(stopped.status, Status::TimeLimit);
    assert!(!stopped.verdict.accepted && stopped.removals.is_empty());
    assert!(stopped.snooping_stopped.is_some());
    assert!(
        stopped.reasons[0].contains("(it reached the time limit)"),
        "{:?}",
        stopped.reasons
    );
    // The remaining observations keep their places in the data given.
    assert!(snooped.observations.iter().all(|c| c.observation != probe));
    assert!(snooped.observations.iter().any(
        |c| c.observation.index == blunder + 1 && c.observation.kind == ObservationKind::Probe
    ));
}

/// A probe height typed 350 mm off (the decimal point lost): Gauss-Newton's
/// first full step goes where a tower no longer reaches the effector, so
/// the fit is made again with Levenberg-Marquardt, which names the blunder
/// (a rejected calibration, not an error), and snooping removes it.
#[test]
fn a_gross_probe_blunder_makes_gauss_newton_run_away_and_is_still_named() {
    let mut dataset = simulate_delta(&scenario(5, 4), 5).unwrap();
    let blunder = 11;
    dataset.probes[blunder][2] += 350.0;
    let probe = ObservationRef {
        kind: ObservationKind::Probe,
        index: blunder,
    };
    let default = MechanismOptions::default();
    let (plain, snooped) = blunder_is_named_and_removed(&dataset, probe, &default, &mut |_| {});
    let run_away = plain.gauss_newton.as_ref().expect("Gauss-Newton ran away");
    assert!(
        matches!(run_away.status, Status::ProblemFailed { .. }),
        "{:?}",
        run_away.status
    );
    assert_eq!(plain.status, Status::Converged);
    // Without the blunder, Gauss-Newton converges on its own.
    assert!(snooped.gauss_newton.is_none());
    // The record says so.
    let record = plain.record();
    let ran = record.gauss_newton.expect("recorded");
    assert!(ran.status.contains("failed"), "{}", ran.status);
    assert_eq!(ran.iterations, run_away.iterations);
}

#[test]
fn readings_at_unknown_and_measured_poses_calibrate_a_delta() {
    // Point samples only: 40 at unknown poses (three readings fix a pose
    // of three coordinates: they carry no redundancy), 12 at measured
    // poses (10 um per coordinate), which determine the parameters.
    let scenario = DeltaScenario {
        rings: 1,
        per_ring: 3,
        unknown_samples: 40,
        known_samples: 12,
        ..scenario(9, 0)
    };
    let mut dataset = simulate_delta(&scenario, 9).unwrap();
    dataset.probes.clear();
    let run = calibrate(&dataset, &MechanismOptions::default());
    assert!(run.converged(), "{:?}", run.reasons);
    assert!(run.parameter(TRIGGER_HEIGHT).is_none());
    assert_eq!(run.poses.len(), 52);
    // A sample at an unknown pose is not checked by the others.
    let unknown = run
        .observations
        .iter()
        .find(|c| c.observation.kind == ObservationKind::Sample && c.observation.index == 20)
        .unwrap();
    assert!(
        unknown.rows.iter().all(|r| r.redundancy < 1e-8),
        "{unknown:?}"
    );
    // Its pose absorbs its readings whole: no residual is left but what
    // the stopping rule leaves (its pose's own step, which would remove
    // it, is below SIGMA_TOLERANCE in sigmas, the residual whitened).
    assert!(
        (unknown.rows.iter()).all(|r| f64::from(r.residual).abs() < parcal_solver::SIGMA_TOLERANCE),
        "{unknown:?}"
    );
    let n = 16;
    // The estimate is consistent with the truth: its NEES within the
    // chi-square's 99.9 % quantile of its rank (11: no trigger height).
    let truth = canonical_truth(&dataset);
    let error = run.values() - truth.rows(0, n);
    let (value, rank) = nees(&error, run.covariance.as_ref().unwrap());
    assert_eq!(rank, 11);
    assert!(value < 31.26, "NEES {value:.2} over 11 dimensions");
}

#[test]
fn positions_measured_at_commanded_positions_calibrate_a_delta() {
    // A tracker measures the nozzle at 27 commanded positions (10 um per
    // coordinate) of 30 printers drawn from their priors: no trigger
    // height, 16 parameters less 5 gauge freedoms, 11 identifiable
    // unknowns; the mean NEES within 4 standard errors of 11.
    let values: Vec<f64> = (0..30).map(commanded_points_nees).collect();
    let (mean, standard_error) = mean_and_standard_error(&values);
    eprintln!(
        "NEES over 30 printers measured at commanded positions: {mean:.3} +- {standard_error:.3}"
    );
    assert!(
        (mean - 11.0).abs() < 4.0 * standard_error,
        "mean NEES {mean:.3} +- {standard_error:.3}, expected 11"
    );
}

/// The NEES of the calibration of printer `seed` from 27 positions
/// measured at commanded positions.
fn commanded_points_nees(seed: u64) -> f64 {
    let dataset = simulate_delta(&scenario(seed, 0), seed).unwrap();
    let truth = &dataset.truth.as_ref().unwrap().parameters;
    let data = MechanismData::from_dataset(&dataset).unwrap();
    let delta = data.mechanism.clone();
    let mut noise = Rng::new(seed, 2000);
    let mut points = Vec::new();
    for i in 0..27 {
        let grid = |k: usize| 60.0 * (k % 3) as f64 - 60.0;
        let commanded = [grid(i), grid(i / 3), 20.0 + 50.0 * (i / 9) as f64];
        let q = delta.inverse(&data.configured, &commanded).unwrap();
        let reached = delta.forward(truth, q.as_slice(), &commanded).unwrap();
        points.push(CommandedPoint {
            commanded,
            measured: std::array::from_fn(|k| reached[k] + noise.normal(0.01)),
            sigma: [0.01; 3],
        });
    }
    let data = data.with_observations(Observations {
        points,
        ..Observations::default()
    });
    let run = calibrate_mechanism(&data, &MechanismOptions::default(), &mut |_| {}).unwrap();
    assert!(run.converged(), "seed {seed}: {:?}", run.reasons);
    let n = delta.parameters().len();
    let error = run.values() - canonical_truth(&dataset).rows(0, n);
    let (value, rank) = nees(&error, run.covariance.as_ref().unwrap());
    assert_eq!(rank, 11, "seed {seed}");
    value
}

/// `scenario(seed, 0)` with `balls` calibrated balls touched 7 times each.
fn touched(seed: u64, balls: usize) -> MechanismDataset {
    let scenario = DeltaScenario {
        balls,
        ..scenario(seed, 0)
    };
    simulate_delta(&scenario, seed).unwrap()
}

/// The NEES of a calibration of `dataset` over the parameters and the
/// trigger height (canonical frame), and its rank.
fn nees_of(dataset: &MechanismDataset, run: &MechanismCalibration) -> (f64, usize) {
    let error = run.values() - canonical_truth(dataset);
    nees(&error, run.covariance.as_ref().unwrap())
}

#[test]
fn probes_and_ball_touches_calibrate_a_delta_within_its_sigmas() {
    // 25 probes and 3 balls of 7 touches: the parameters and the trigger
    // height (12 identifiable unknowns, as with probes alone) consistent
    // with their covariance, the NEES below the chi-square's 99.9 %
    // quantile of 12 degrees (32.91); every ball located, its radius
    // estimated with its calibration's prior (the true radius drawn from
    // it: within 4 of its sigmas of the calibrated value).
    let dataset = touched(21, 3);
    assert_eq!((dataset.balls.len(), dataset.touches.len()), (3, 21));
    let run = calibrate(&dataset, &MechanismOptions::default());
    assert!(run.verdict.accepted, "{:?}", run.reasons);
    let (value, rank) = nees_of(&dataset, &run);
    eprintln!("probes and 3 balls: NEES {value:.2} over {rank}");
    assert_eq!(rank, 12);
    assert!(value < 32.91, "NEES {value:.2}");
    assert_eq!(run.balls.len(), 3);
    for ball in &run.balls {
        let sigma = ball.centre_sigma.expect("centre sigmas");
        assert!(sigma.iter().all(|&s| s.is_finite() && s > 0.0), "{ball:?}");
        assert!(ball.radius_sigma.is_some_and(|s| s > 0.0 && s <= 0.001));
        assert!((ball.radius - 12.7).abs() < 4.0 * 0.001, "{ball:?}");
    }
    let touches = run
        .observations
        .iter()
        .filter(|c| c.observation.kind == ObservationKind::Touch)
        .count();
    assert_eq!(touches, 21);
    // The record carries the balls, and the dataset's files read back.
    assert_eq!(run.record().balls.len(), 3);
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("delta");
    dataset.write(&path).unwrap();
    assert_eq!(MechanismDataset::read(&path).unwrap(), dataset);
}

#[test]
fn nees_over_printers_with_ball_touches_matches_the_identifiable_count() {
    // Probes and 3 balls of 7 touches on 30 printers drawn from their
    // priors (the balls' radii from their calibration's): 12 identifiable
    // unknowns, the mean NEES within 4 standard errors of 12.
    nees_over_touched_printers("ball touches", |seed| touched(seed, 3));
}

#[test]
fn nees_over_printers_with_a_ball_plate_matches_the_identifiable_count() {
    // The same with the three balls' distances calibrated to 2 um: the
    // balls tied in the global block, still 12 identifiable unknowns.
    nees_over_touched_printers("a ball plate", |seed| plated(seed, 3, 0.002));
}

/// The mean NEES over the 30 printers `dataset` simulates (seeds 0..30)
/// within 4 standard errors of the 12 identifiable unknowns.
fn nees_over_touched_printers(what: &str, dataset: impl Fn(u64) -> MechanismDataset) {
    let mut values = Vec::new();
    for seed in 0..30 {
        let dataset = dataset(seed);
        let run = calibrate(&dataset, &MechanismOptions::default());
        assert!(run.converged(), "seed {seed}: {:?}", run.reasons);
        let (value, rank) = nees_of(&dataset, &run);
        assert_eq!(rank, 12, "seed {seed}");
        values.push(value);
    }
    let (mean, standard_error) = mean_and_standard_error(&values);
    eprintln!("NEES over 30 printers with {what}: {mean:.3} +- {standard_error:.3}");
    assert!(
        (mean - 12.0).abs() < 4.0 * standard_error,
        "mean NEES {mean:.3} +- {standard_error:.3}, expected 12"
    );
}

#[test]
fn a_touch_blunder_of_0_3_mm_is_named_and_removed_by_snooping() {
    let mut dataset = touched(5, 3);
    let blunder = 9;
    dataset.touches[blunder].commanded[2] += 0.3;
    let touch = ObservationRef {
        kind: ObservationKind::Touch,
        index: blunder,
    };
    // By its radius row and by its coordinates (eq. 10): named alike.
    for observation in [Observation::Radius, Observation::Coordinates] {
        let options = MechanismOptions::default().with_observation(observation);
        blunder_is_named_and_removed(&dataset, touch, &options, &mut |_| {});
    }
    // A run stopped at its iteration limit is not judged (no checks'
    // pass): its balls' sigmas come from a pass of their own.
    let stopped = calibrate(
        &dataset,
        &MechanismOptions::default().with_max_iterations(Some(1)),
    );
    assert_eq!(stopped.status, Status::IterationLimit);
    assert!(stopped.observations.is_empty());
    for ball in &stopped.balls {
        let sigma = ball.centre_sigma.expect("a centre sigma");
        assert!(sigma.iter().all(|s| s.is_finite() && *s > 0.0), "{sigma:?}");
    }
}

/// The rods' common length, their mean: its posterior sigma over its
/// prior's (σ/√3 for three rods of prior σ).
fn common_rod_length_ratio(run: &MechanismCalibration) -> f64 {
    let at: Vec<usize> = ["diagonal_a", "diagonal_b", "diagonal_c"]
        .iter()
        .map(|name| run.parameters.iter().position(|p| p.name == *name).unwrap())
        .collect();
    let covariance = run.covariance.as_ref().unwrap();
    let variance: f64 = at
        .iter()
        .flat_map(|&i| at.iter().map(move |&j| covariance[(i, j)] / 9.0))
        .sum();
    let prior = run.parameters[at[0]].prior.sigma.unwrap() / 3f64.sqrt();
    variance.sqrt() / prior
}

/// `touched(seed, balls)` with a ball plate's certificate: the distance
/// between every pair of balls, each to `sigma` mm.
fn plated(seed: u64, balls: usize, sigma: f64) -> MechanismDataset {
    let scenario = DeltaScenario {
        balls,
        plate: Some(Plate {
            pairs: PlatePairs::All,
            sigma,
        }),
        ..scenario(seed, 0)
    };
    simulate_delta(&scenario, seed).unwrap()
}

#[test]
fn a_ball_plate_ties_the_balls_and_measures_the_rods_common_length() {
    // Three balls and their three distances, calibrated to 2 um: the
    // same touches as the balls alone, the balls' centres now global
    // unknowns tied by the distances, which measure lengths of about
    // 140 mm where a ball's radius measures 12.7 mm. The estimate stays
    // consistent with its covariance (NEES below the 99.9 % quantile of
    // chi-square(12), 32.91), and the rods' common length is known better.
    let (seed, balls) = (3, 3);
    let alone = touched(seed, balls);
    let dataset = plated(seed, balls, 0.002);
    assert_eq!(dataset.touches, alone.touches);
    assert_eq!(dataset.ball_distances.len(), 3);
    let run = calibrate(&dataset, &MechanismOptions::default());
    assert!(run.verdict.accepted, "{:?}", run.reasons);
    let (value, rank) = nees_of(&dataset, &run);
    eprintln!("probes, 3 balls and their plate: NEES {value:.2} over {rank}");
    assert_eq!(rank, 12);
    assert!(value < 32.91, "NEES {value:.2}");
    let checked = |kind| {
        run.observations
            .iter()
            .filter(|c| c.observation.kind == kind)
            .count()
    };
    assert_eq!(checked(ObservationKind::BallDistance), 3);
    assert_eq!(checked(ObservationKind::Touch), 21);
    for ball in &run.balls {
        let sigma = ball.centre_sigma.expect("centre sigmas");
        assert!(sigma.iter().all(|&s| s.is_finite() && s > 0.0), "{ball:?}");
        assert!(ball.radius_sigma.is_some_and(|s| s > 0.0 && s <= 0.001));
    }
    let without = calibrate(&alone, &MechanismOptions::default());
    let (before, after) = (
        common_rod_length_ratio(&without),
        common_rod_length_ratio(&run),
    );
    eprintln!(
        "the rods' common length: posterior/prior sigma {before:.4} with 3 balls, {after:.4} with their plate"
    );
    assert!(after < before, "{after} with the plate, {before} without");
}

#[test]
fn a_ball_distance_blunder_of_0_1_mm_is_named_and_removed_by_snooping() {
    // Four balls, six distances of 2 um: the third distance 0.1 mm long.
    let mut dataset = plated(5, 4, 0.002);
    let blunder = 2;
    dataset.ball_distances[blunder].length += 0.1;
    let distance = ObservationRef {
        kind: ObservationKind::BallDistance,
        index: blunder,
    };
    let default = MechanismOptions::default();
    blunder_is_named_and_removed(&dataset, distance, &default, &mut |_| {});
}

#[test]
fn probe_heights_and_three_balls_determine_the_rods_common_length() {
    // Probe heights alone leave the rods' common length (the XY scale)
    // to its prior; three balls of known radius measure lengths and
    // determine it.
    let ratio = |run: &MechanismCalibration, name: &str| {
        let k = run.parameters.iter().position(|p| p.name == name).unwrap();
        run.identifiability.as_ref().unwrap().sigma_ratio[k].unwrap()
    };
    let common = common_rod_length_ratio;
    let probes_only = calibrate(&touched(3, 0), &MechanismOptions::default());
    let with_balls = calibrate(&touched(3, 3), &MechanismOptions::default());
    let (before, after) = (common(&probes_only), common(&with_balls));
    eprintln!(
        "the rods' common length: posterior/prior sigma {before:.3} probes alone, {after:.3} with 3 balls"
    );
    assert!(after < before, "{after} with balls, {before} without");
    assert!(with_balls.verdict.accepted, "{:?}", with_balls.reasons);
    assert_eq!(rod_scale_directions(&probes_only), 1);
    eprintln!(
        "probes alone: {:#?}",
        probes_only.identifiability.as_ref().unwrap().statements
    );
    assert_eq!(rod_scale_directions(&with_balls), 0);
    for name in ["diagonal_a", "diagonal_b", "diagonal_c", "radius"] {
        let (before, after) = (ratio(&probes_only, name), ratio(&with_balls, name));
        eprintln!(
            "{name}: posterior/prior sigma {before:.3} probes alone, {after:.3} with 3 balls"
        );
        assert!(
            after < before,
            "{name}: {after} with balls, {before} without"
        );
    }
    eprintln!(
        "with 3 balls: {:#?}",
        with_balls.identifiability.as_ref().unwrap().statements
    );
}

#[test]
fn balls_touched_too_few_times_are_refused_by_name() {
    let data = MechanismData::from_dataset(&touched(4, 2)).unwrap();
    let error_of = |observations: Observations| match calibrate_mechanism(
        &data.with_observations(observations),
        &MechanismOptions::default(),
        &mut |_| {},
    ) {
        Err(MechanismCalibrationError::InvalidData { what, reason }) => {
            format!("{what}: {reason}")
        }
        other => panic!("{other:?}"),
    };
    let mut three = data.observations.clone();
    three.touches.retain(|t| t.ball == 0);
    three.touches.extend(
        data.observations
            .touches
            .iter()
            .filter(|t| t.ball == 1)
            .take(3)
            .cloned(),
    );
    let error = error_of(three);
    assert!(error.starts_with("ball 1: it has 3 touches"), "{error}");
    let mut untouched = data.observations.clone();
    untouched.balls.push(Ball::new(5.0, None));
    let error = error_of(untouched);
    assert!(error.starts_with("ball 2: it has 0 touches"), "{error}");
}

#[test]
fn rods_cut_as_a_matched_set_keep_their_differences_within_the_set() {
    // Probe heights see the rods' differences poorly; rods cut as a set,
    // each within 0.02 mm of the set's length (machine.json's "matched"),
    // bound each difference to √2 × 0.02 mm a priori, and the posterior
    // can only be tighter. The set's common length keeps its tolerance.
    let mut dataset = simulate_delta(&scenario(5, 0), 5).unwrap();
    let free = calibrate(&dataset, &MechanismOptions::default());
    dataset.machine.matched = vec![("diagonal rods".to_string(), 0.02)];
    let matched = calibrate(&dataset, &MechanismOptions::default());
    let at = |run: &MechanismCalibration, name: &str| {
        run.parameters.iter().position(|p| p.name == name).unwrap()
    };
    let difference_sigma = |run: &MechanismCalibration, a: &str, b: &str| {
        let c = run.covariance.as_ref().unwrap();
        let (a, b) = (at(run, a), at(run, b));
        (c[(a, a)] + c[(b, b)] - 2.0 * c[(a, b)]).sqrt()
    };
    let bound = 2f64.sqrt() * 0.02;
    for (a, b) in [("diagonal_a", "diagonal_b"), ("diagonal_b", "diagonal_c")] {
        let (before, after) = (
            difference_sigma(&free, a, b),
            difference_sigma(&matched, a, b),
        );
        eprintln!("{a} - {b}: sigma {before:.4} mm free, {after:.4} mm matched");
        assert!(after <= bound * (1.0 + 1e-9), "{after}");
        assert!(
            before > 2.0 * bound,
            "{before}: the probes alone see it well"
        );
    }
    // Each rod's own prior sigma is unchanged.
    let k = at(&matched, "diagonal_a");
    assert_eq!(
        matched.parameters[k].prior.sigma,
        free.parameters[k].prior.sigma
    );
    // A set matched more loosely than its tolerance is refused by name.
    dataset.machine.matched = vec![("diagonal rods".to_string(), 5.0)];
    let error = MechanismData::from_dataset(&dataset)
        .unwrap_err()
        .to_string();
    assert!(
        error.contains("diagonal rods") && error.contains("exceeds"),
        "{error}"
    );
}

#[test]
fn a_ball_placed_where_known_has_its_centre_held_by_the_placement() {
    // balls.csv's x,y,z,centre_sigma: where the first ball was placed,
    // within 0.01 mm (here, where a calibration without it put it). Its
    // centre's posterior sigmas can only shrink, and stay within the
    // placement's (a block's marginal variance is at most the inverse of
    // its information, which holds the prior's).
    let mut dataset = touched(3, 3);
    let free = calibrate(&dataset, &MechanismOptions::default());
    let centre = free.balls[0].centre;
    dataset.balls[0].placement = Some(BallPlacement {
        centre,
        sigma: 0.01,
    });
    let data = MechanismData::from_dataset(&dataset).unwrap();
    let expected = CentrePrior {
        centre,
        sigma: 0.01,
    };
    assert_eq!(data.observations.balls[0].centre_prior, Some(expected));
    assert_eq!(data.observations.balls[1].centre_prior, None);
    let placed = calibrate(&dataset, &MechanismOptions::default());
    let (before, after) = (
        free.balls[0].centre_sigma.unwrap(),
        placed.balls[0].centre_sigma.unwrap(),
    );
    eprintln!("ball 0's centre sigmas: {before:?} free, {after:?} placed within 0.01 mm");
    for k in 0..3 {
        assert!(
            after[k] < before[k] && after[k] <= 0.01 * (1.0 + 1e-9),
            "{k}"
        );
    }
    // More information shrinks every marginal variance; the estimate is
    // the same minimum (the placement's mean is the free estimate), to
    // the stopping rule's 1e-6 relative.
    for b in 1..3 {
        let (free, placed) = (
            free.balls[b].centre_sigma.unwrap(),
            placed.balls[b].centre_sigma.unwrap(),
        );
        for k in 0..3 {
            assert!(placed[k] <= free[k] * (1.0 + 1e-6), "ball {b}, {k}");
        }
    }
}
