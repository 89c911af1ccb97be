//! Simulated cable robots (`parcal_simulate::simulate_cable`): the truth,
//! drawn from the design's priors, recovered within the sigmas the
//! mechanism calibration reports. The normalised estimation error
//! `NEES = (p̂ − p)ᵀ C⁻¹ (p̂ − p)` over the parameters has mean equal to
//! their number when the covariance `C` is right; its mean over the draws
//! must be within 4 standard errors of it (the standard error from the
//! draws' own scatter). With the line lengths at the encoder zero
//! measured (the true lengths with Gaussian noise, as by hand) as
//! observations of their own, the same must hold: their sigma is
//! honoured. So must it for elastic lines under loads that vary from
//! sample to sample, the compliance one more parameter; a held-out
//! campaign of the same machine, under its own loads, must fit the
//! covariance its validation predicts (`T / n` of mean 1); and the
//! commands compensated under loads must put the true machine on its
//! targets within the covariance compensation predicts (`eᵀ C⁻¹ e` of
//! mean 3).

use std::sync::Arc;

use nalgebra::{DVector, Matrix3, Vector3};
use parcal_calibrate::mechanism::{
    CalibratedMechanism, MechanismCalibration, MechanismData, MechanismOptions, Observations,
    calibrate_mechanism, compensate_mechanism, validate_mechanism,
};
use parcal_kinematics::cable::{CableRobot, Elasticity};
use parcal_kinematics::mechanism::{Mechanism, design, forward_under_loads};
use parcal_observe::mechanism::{MeasuredQuantity, PointSample};
use parcal_simulate::{CableScenario, CableSimulation, Rng, measure_cable, simulate_cable};

use crate::mean::mean_and_standard_error;

/// The stream of the line lengths' noise (the simulation's own streams
/// are below it).
const LINE_LENGTH_STREAM: u64 = 1000;
/// The seed offset of the held-out campaigns.
const HELD_OUT: u64 = 10_000;
/// The stream of the compensated targets' loads.
const TARGET_LOAD_STREAM: u64 = 1001;
/// The targets compensated under loads (mm, within the anchors' hull).
const TARGETS: [[f64; 3]; 6] = [
    [0.0, 0.0, 0.0],
    [300.0, -200.0, 400.0],
    [-250.0, 150.0, 800.0],
    [100.0, 300.0, 1200.0],
    [-100.0, -100.0, 200.0],
    [200.0, 100.0, 1500.0],
];

/// The NEES of the calibration of the campaign of `seed`, with the line
/// lengths at the encoder zero measured to `line_length_sigma` (mm) if
/// given.
fn nees(
    robot: &CableRobot,
    scenario: &CableScenario,
    seed: u64,
    line_length_sigma: Option<f64>,
) -> f64 {
    let simulation = simulate_cable(robot, scenario, seed).unwrap();
    let samples = point_samples(&simulation, scenario);
    let mut rng = Rng::new(seed, LINE_LENGTH_STREAM);
    let quantities = match line_length_sigma {
        Some(sigma) => (0..robot.quantities().len())
            .map(|quantity| MeasuredQuantity {
                quantity,
                value: robot
                    .quantity(quantity, simulation.truth.as_slice())
                    .unwrap()
                    .value
                    + rng.normal(sigma),
                sigma,
            })
            .collect(),
        None => Vec::new(),
    };
    let observations = Observations {
        samples,
        quantities,
        ..Default::default()
    };
    nees_of(robot, &simulation.truth, observations, seed)
}

/// The NEES of the calibration of `observations` of `robot`, started at
/// its design, against the true parameters `truth` (the campaign of
/// `seed`).
fn nees_of(robot: &CableRobot, truth: &DVector<f64>, observations: Observations, seed: u64) -> f64 {
    nees_against(&calibrated(robot, observations, seed), truth)
}

/// The calibration of `observations` of `robot` (its lines elastic or
/// not), started at its design; converged (the campaign of `seed`).
fn calibrated(robot: &CableRobot, observations: Observations, seed: u64) -> MechanismCalibration {
    let configured: Vec<f64> = design(robot).iter().copied().collect();
    let data = MechanismData::new(Arc::new(robot.clone()), configured, observations);
    let calibration =
        calibrate_mechanism(&data, &MechanismOptions::default(), &mut |_| {}).unwrap();
    assert!(
        calibration.converged(),
        "seed {seed}: {:?}",
        calibration.status
    );
    calibration
}

/// `(p̂ − p)ᵀ C⁻¹ (p̂ − p)` of `calibration` against the true parameters
/// `truth`.
fn nees_against(calibration: &MechanismCalibration, truth: &DVector<f64>) -> f64 {
    let n = truth.len();
    let error = calibration.values().rows(0, n) - truth;
    let covariance = calibration
        .covariance
        .as_ref()
        .unwrap()
        .view((0, 0), (n, n))
        .clone_owned();
    let solved = covariance.cholesky().unwrap().solve(&error);
    error.dot(&solved)
}

/// The samples of `simulation`, a campaign of `scenario`, as the
/// calibration observes them (with their loads, if any).
fn point_samples(simulation: &CableSimulation, scenario: &CableScenario) -> Vec<PointSample> {
    (simulation.samples.iter())
        .map(|sample| PointSample {
            readings: sample.readings.clone(),
            sigma: scenario.reading_sigma,
            known_pose: sample.known.map(|p| (p, scenario.position_sigma)),
            loads: sample.loads.clone(),
        })
        .collect()
}

/// For the campaign of `seed` on `robot`, whose lines are elastic, every
/// sample but the encoder zero under drawn loads ([`simulate_cable`]): the
/// NEES of its calibration, `T / n` of that calibration validated on a
/// held-out campaign of the same machine (other positions, loads and
/// noise), and its compensation's `eᵀ C⁻¹ e` ([`compensation_error`]).
fn elastic_draw(robot: &CableRobot, seed: u64) -> (f64, f64, f64) {
    let scenario = CableScenario::hangprinter();
    let simulation = simulate_cable(robot, &scenario, seed).unwrap();
    let observations = Observations {
        samples: point_samples(&simulation, &scenario),
        ..Default::default()
    };
    let calibration = calibrated(robot, observations, seed);
    let truth = simulation.truth;
    let held_out = measure_cable(robot, &scenario, truth.clone(), seed + HELD_OUT).unwrap();
    let configured: Vec<f64> = design(robot).iter().copied().collect();
    let observations = Observations {
        samples: point_samples(&held_out, &scenario),
        ..Default::default()
    };
    let held_out = MechanismData::new(Arc::new(robot.clone()), configured, observations);
    let applied = CalibratedMechanism::of_calibration(&calibration).unwrap();
    let validation = validate_mechanism(&applied, &held_out, 0.05, None).unwrap();
    (
        nees_against(&calibration, &truth),
        validation.statistic / validation.rows.len() as f64,
        compensation_error(robot, &applied, &truth, seed),
    )
}

/// The commands `applied` compensates for [`TARGETS`] under loads drawn
/// from 5 to 35 N (the campaign of `seed`), run on the true machine
/// (parameters `truth`) under those loads: the error `e` of the pose each
/// reaches, `eᵀ C⁻¹ e` with `C` the covariance compensation predicts,
/// averaged over the targets (they share the calibration's error). The
/// calibrated machine itself reaches each target under its loads, to 1e-6
/// mm; the commands under the loads of the encoder zero are those without
/// loads.
fn compensation_error(
    robot: &CableRobot,
    applied: &CalibratedMechanism,
    truth: &DVector<f64>,
    seed: u64,
) -> f64 {
    let mut rng = Rng::new(seed, TARGET_LOAD_STREAM);
    let loads: Vec<Vec<f64>> = (TARGETS.iter())
        .map(|_| (0..4).map(|_| rng.uniform(5.0, 35.0)).collect())
        .collect();
    let (_, zero_loads) = robot.line_compliances().unwrap();
    let unloaded = compensate_mechanism(applied, &TARGETS, &[]);
    let at_zero = compensate_mechanism(applied, &TARGETS, &vec![zero_loads.to_vec(); 6]);
    for (a, b) in unloaded.iter().zip(&at_zero) {
        let (a, b) = (&a.as_ref().unwrap().readings, &b.as_ref().unwrap().readings);
        assert!((a - b).amax() <= 1e-9 * a.amax(), "{a} vs {b}");
    }
    let compensations = compensate_mechanism(applied, &TARGETS, &loads);
    let mut sum = 0.0;
    for ((target, loads), compensation) in TARGETS.iter().zip(&loads).zip(compensations) {
        let compensation = compensation.unwrap();
        let readings = compensation.readings.as_slice();
        let calibrated = applied.params();
        let own = forward_under_loads(robot, calibrated, readings, loads, target, 1e-9).unwrap();
        let miss = (Vector3::new(own[0], own[1], own[2]) - Vector3::from(*target)).norm();
        assert!(
            miss <= 1e-6,
            "{target:?} under {loads:?}: missed by {miss} mm"
        );
        let reached =
            forward_under_loads(robot, truth.as_slice(), readings, loads, target, 1e-9).unwrap();
        let error = Vector3::new(reached[0], reached[1], reached[2]) - Vector3::from(*target);
        let covariance: Matrix3<f64> = compensation.covariance.fixed_view::<3, 3>(0, 0).into();
        sum += error.dot(&(covariance.try_inverse().unwrap() * error));
    }
    sum / TARGETS.len() as f64
}

/// Mean NEES over `draws` seeds, its standard error, and the number of
/// parameters.
fn mean_nees(draws: u64, line_length_sigma: Option<f64>) -> (f64, f64, f64) {
    let robot = CableRobot::typical();
    let scenario = CableScenario::hangprinter();
    let values: Vec<f64> = (0..draws)
        .map(|seed| nees(&robot, &scenario, seed, line_length_sigma))
        .collect();
    let count = values.len() as f64;
    let mean = values.iter().sum::<f64>() / count;
    let variance = values.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (count - 1.0);
    (
        mean,
        (variance / count).sqrt(),
        robot.parameters().len() as f64,
    )
}

#[test]
fn the_truth_is_recovered_within_the_reported_sigmas() {
    let (mean, standard_error, parameters) = mean_nees(40, None);
    eprintln!("mean NEES {mean:.2} +- {standard_error:.2} over 40 draws, {parameters} parameters");
    assert!(
        (mean - parameters).abs() <= 4.0 * standard_error,
        "mean NEES {mean} vs {parameters} (standard error {standard_error})"
    );
}

#[test]
#[ignore = "400 draws: cargo test -p parcal-calibrate --test integration cable_simulation:: -- --ignored --nocapture"]
fn the_truth_is_recovered_within_the_reported_sigmas_over_400_draws() {
    let (mean, standard_error, parameters) = mean_nees(400, None);
    eprintln!("mean NEES {mean:.2} +- {standard_error:.2} over 400 draws, {parameters} parameters");
    assert!((mean - parameters).abs() <= 4.0 * standard_error);
}

#[test]
fn measured_line_lengths_are_honoured() {
    // 10 mm, the hand-measured lengths' sigma (docs/cable-robots.md).
    let (mean, standard_error, parameters) = mean_nees(40, Some(10.0));
    eprintln!(
        "with line lengths: mean NEES {mean:.2} +- {standard_error:.2} over 40 draws, {parameters} parameters"
    );
    assert!(
        (mean - parameters).abs() <= 4.0 * standard_error,
        "mean NEES {mean} vs {parameters} (standard error {standard_error})"
    );
}

#[test]
#[ignore = "400 draws: cargo test -p parcal-calibrate --test integration cable_simulation:: -- --ignored --nocapture"]
fn measured_line_lengths_are_honoured_over_400_draws() {
    let (mean, standard_error, parameters) = mean_nees(400, Some(10.0));
    eprintln!(
        "with line lengths: mean NEES {mean:.2} +- {standard_error:.2} over 400 draws, {parameters} parameters"
    );
    assert!((mean - parameters).abs() <= 4.0 * standard_error);
}

#[test]
fn elastic_lines_under_loads_are_recovered_predicted_and_compensated_within_the_reported_sigmas() {
    let robot = CableRobot::typical()
        .with_elasticity(Elasticity::typical(
            vec![0; 4],
            vec![15.0, 15.0, 15.0, 30.0],
        ))
        .unwrap();
    let draws = 40;
    let draws_made: Vec<(f64, f64, f64)> =
        (0..draws).map(|seed| elastic_draw(&robot, seed)).collect();
    let nees: Vec<f64> = draws_made.iter().map(|d| d.0).collect();
    let ratios: Vec<f64> = draws_made.iter().map(|d| d.1).collect();
    let compensated: Vec<f64> = draws_made.iter().map(|d| d.2).collect();
    let parameters = robot.parameters().len() as f64;
    let (mean, standard_error) = mean_and_standard_error(&nees);
    eprintln!(
        "elastic lines: mean NEES {mean:.2} +- {standard_error:.2} over {draws} draws, {parameters} parameters"
    );
    assert!(
        (mean - parameters).abs() <= 4.0 * standard_error,
        "mean NEES {mean} vs {parameters} (standard error {standard_error})"
    );
    // Held out: T = rᵀ C⁻¹ r is χ²(n) under the model, E[T / n] = 1.
    let (mean, standard_error) = mean_and_standard_error(&ratios);
    eprintln!("elastic lines held out: mean T/n {mean:.4} +- {standard_error:.4}");
    assert!(
        (mean - 1.0).abs() <= 4.0 * standard_error,
        "mean T/n {mean:.4} +- {standard_error:.4}"
    );
    // Compensated under loads: e ~ N(0, C) over 3 coordinates.
    let (mean, standard_error) = mean_and_standard_error(&compensated);
    eprintln!(
        "elastic lines compensated under loads: mean eᵀC⁻¹e {mean:.3} +- {standard_error:.3} (expected 3)"
    );
    assert!(
        (mean - 3.0).abs() <= 4.0 * standard_error,
        "mean eᵀC⁻¹e {mean:.3} +- {standard_error:.3}"
    );
}
