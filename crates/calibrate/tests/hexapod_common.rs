//! The hexapod through the common interface: the ball touches of
//! fixtures/paper-seed1 calibrated as a [`Mechanism`] plug-in by the path
//! of every mechanism (`calibrate_mechanism`), against the hexapod's own
//! calibration under the same model (the radius observation, eq. 9, and
//! the coordinate observation, eq. 10, with each of its weight and radius
//! models, and each of its priors).
//! Both minimise the same cost, so they must reach the same estimate and
//! the same covariance.
//!
//! [`Mechanism`]: parcal_kinematics::mechanism::Mechanism

use std::path::{Path, PathBuf};

use nalgebra::Isometry3;
use parcal_calibrate::mechanism::{
    CalibratedMechanism, MechanismData, MechanismOptions, ObservationKind, Observations,
    calibrate_mechanism, compensate_mechanism, validate_mechanism,
};
use parcal_calibrate::observation::ObservationId;
use parcal_calibrate::{
    CalibrationOptions, Observation, PriorMode, RadiusModel, Simulation, calibrate,
};
use parcal_dataset::{ArtefactFrame, Dataset, Distance, SessionModel};
use parcal_kinematics::Geometry;
use parcal_kinematics::params::to_params;
use parcal_observe::WeightModel;
use parcal_observe::mechanism::Actuation;
use parcal_simulate::{
    Readings, Scenario, TrackerKind, TrackerScenario, simulate_mixed, simulate_tracker,
};
use parcal_solver::SIGMA_TOLERANCE;

fn fixture() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../fixtures/paper-seed1")
}

#[test]
fn the_common_calibration_of_a_hexapod_is_its_own() {
    for weighting in [WeightModel::Propagated, WeightModel::Diagonal] {
        for radius in [RadiusModel::PerBall, RadiusModel::PerContact] {
            println!("{weighting:?} weights, {radius:?} radius:");
            let options = CalibrationOptions {
                weighting,
                radius,
                ..CalibrationOptions::simulation(Simulation::I)
            };
            compare(&options);
        }
    }
}

/// The common calibration starts where the own one does (the own
/// set-up's ball centres and design poses as warm starts, `TouchStart`): the same cost at
/// the start, to rounding; the same number of iterations; the same cost at
/// the end, to the stopping rule's level. A start of the wrong size is
/// refused by name.
#[test]
fn the_common_hexapod_starts_where_the_own_does() {
    let dataset = Dataset::read(&fixture()).unwrap();
    for simulation in [Simulation::I, Simulation::IV] {
        let options = CalibrationOptions::simulation(simulation);
        let mut own_costs = Vec::new();
        calibrate(&dataset, &options, &mut |r| own_costs.push(r.cost)).unwrap();
        let data = MechanismData::from_hexapod_touches(&dataset, &options).unwrap();
        let common_options = MechanismOptions::default().with_observation(options.observation);
        let mut costs = Vec::new();
        calibrate_mechanism(&data, &common_options, &mut |r| costs.push(r.cost)).unwrap();
        println!("{simulation:?}: own {own_costs:?}\n  common {costs:?}");
        // The same start, to rounding; the same iterations; and ends each
        // within SIGMA_TOLERANCE of its sigmas from the minimum, so within
        // about that squared of its cost.
        assert!((costs[0] / own_costs[0] - 1.0).abs() < 1e-12);
        assert_eq!(costs.len(), own_costs.len());
        let last = (costs.last().unwrap() - own_costs.last().unwrap()).abs();
        assert!(last < 2.0 * SIGMA_TOLERANCE.powi(2), "{last:e}");
        let mut wrong = data.clone();
        let mut start = data.touch_start.clone().unwrap();
        start.warm_starts.pop();
        wrong.touch_start = Some(start);
        let error = calibrate_mechanism(&wrong, &common_options, &mut |_| {})
            .unwrap_err()
            .to_string();
        assert!(
            error.contains("touches' start") && error.contains("189 touches of 7 each"),
            "{error}"
        );
    }
}

#[test]
fn the_coordinate_observation_through_the_interface_is_the_own_paths() {
    // Eq. 10: three rows and two contact angles a touch, the own set-up's
    // weights W and, under the paper's prior, every contact's angles about
    // its direction at the design.
    for prior in [PriorMode::None, PriorMode::Paper, PriorMode::Propagated] {
        for radius in [RadiusModel::PerBall, RadiusModel::PerContact] {
            println!("coordinates, {prior:?} prior, {radius:?} radius:");
            let options = CalibrationOptions {
                prior,
                radius,
                ..CalibrationOptions::simulation(Simulation::IV)
            };
            compare(&options);
        }
    }
    let dataset = Dataset::read(&fixture()).unwrap();
    let paper = CalibrationOptions::simulation(Simulation::IV);
    let data = MechanismData::from_hexapod_touches(&dataset, &paper).unwrap();
    let approaches = data.observations.touches.iter().filter_map(|t| t.approach);
    assert_eq!(approaches.count(), dataset.measurements.len());
    let diagonal = CalibrationOptions {
        weighting: WeightModel::Diagonal,
        ..CalibrationOptions::simulation(Simulation::II)
    };
    println!("coordinates, diagonal weights:");
    compare(&diagonal);
    // Two touches whose contact directions cannot be charted (an approach
    // of zero length): the first of them is named.
    let mut broken = data.clone();
    for t in [150, 40] {
        let approach = broken.observations.touches[t].approach.as_mut().unwrap();
        approach.direction = [0.0; 3];
    }
    let common_options = MechanismOptions::default().with_observation(paper.observation);
    let error = calibrate_mechanism(&broken, &common_options, &mut |_| {}).unwrap_err();
    assert!(
        error.to_string().starts_with("ball touch 40: on ball 5:"),
        "{error}"
    );
}

#[test]
fn legs_read_with_known_scales_are_the_own_paths() {
    // The same legs read in another unit: each reading divided by its
    // leg's scale, the scales stated in machine.json (known). Both paths
    // take the extensions s_i q_i, and reach the same minimum.
    let mut dataset = Dataset::read(&fixture()).unwrap();
    let scale = [1.25, 0.8, 2.0, 0.5, 1.6, 0.625];
    dataset.machine.actuator.scale = scale;
    for q in &mut dataset.measurements.q {
        for (q, s) in q.iter_mut().zip(scale) {
            *q /= s;
        }
    }
    compare_on(&dataset, &CalibrationOptions::simulation(Simulation::I));
}

#[test]
fn unknown_scales_are_the_own_paths() {
    // The legs read in another unit with the scales unknowns of 1 %
    // sigma about the stated ones: six parameters s_1..s_6 after the 33 in
    // both paths (the own layout's actuator scales), with no prior, the
    // paper's and the propagated one.
    let mut dataset = Dataset::read(&fixture()).unwrap();
    let scale = [1.25, 0.8, 2.0, 0.5, 1.6, 0.625];
    dataset.machine.actuator.scale = scale;
    dataset.machine.actuator.scale_sigma = Some(scale.map(|s| 0.01 * s));
    for q in &mut dataset.measurements.q {
        for (q, s) in q.iter_mut().zip(scale) {
            *q /= s;
        }
    }
    for prior in [PriorMode::None, PriorMode::Paper, PriorMode::Propagated] {
        println!("{prior:?} prior, unknown scales:");
        let options = CalibrationOptions {
            prior,
            ..CalibrationOptions::simulation(Simulation::I)
        };
        compare_on(&dataset, &options);
        let data = MechanismData::from_hexapod_touches(&dataset, &options).unwrap();
        let scales = &data.priors[33..];
        for (prior_of, (s, sigma)) in scales.iter().zip(scale.iter().zip(scale.map(|s| 0.01 * s))) {
            assert_eq!(prior_of.mean, *s);
            let expected = (prior != PriorMode::None).then_some(sigma);
            assert_eq!(prior_of.sigma, expected);
        }
    }
}

#[test]
fn the_priors_through_the_interface_are_the_own_paths() {
    // The paper's prior: each parameter about its design with its
    // group's tolerance, each ball's centre about its centre at the design
    // with its centre_sigma. The propagated prior: the input coordinates'
    // tolerances propagated through the canonical frame, 33 correlated
    // priors (the balls of fixtures/paper-seed1 are in the design's frame,
    // so their centres have none).
    let dataset = Dataset::read(&fixture()).unwrap();
    for prior in [PriorMode::Paper, PriorMode::Propagated] {
        for radius in [RadiusModel::PerBall, RadiusModel::PerContact] {
            println!("{prior:?} prior, {radius:?} radius:");
            let options = CalibrationOptions {
                prior,
                radius,
                ..CalibrationOptions::simulation(Simulation::I)
            };
            compare(&options);
            let data = MechanismData::from_hexapod_touches(&dataset, &options).unwrap();
            let centre_priors = data
                .observations
                .balls
                .iter()
                .filter(|ball| ball.centre_prior.is_some())
                .count();
            let correlation = data.prior_correlation.as_ref();
            match prior {
                PriorMode::Paper => {
                    assert_eq!(centre_priors, 27);
                    assert!(correlation.is_none());
                }
                _ => {
                    assert_eq!(centre_priors, 0);
                    // Far from independent.
                    let correlation = correlation.unwrap();
                    let largest = (0..33)
                        .flat_map(|j| (0..33).filter(move |&k| k != j).map(move |k| (j, k)))
                        .map(|(j, k)| correlation[(j, k)].abs())
                        .fold(0.0, f64::max);
                    assert!(largest > 0.5, "{largest}");
                }
            }
        }
    }
}

#[test]
fn tracker_points_through_the_interface_are_the_own_paths() {
    // The paper's touches with a tracker's points in two sessions (two
    // placements of the instrument): each session a tracker of the common
    // calibration, its frame six unknowns; its points weighted as the own
    // path weighs them. Then the legs re-homed between the sessions: the
    // second tracker's six leg offsets, with the session model's prior.
    // Then poses beside the points (the body frame), the body re-mounted
    // between the sessions too; the legs re-homed at unknown scales.
    let tracker = TrackerScenario {
        kind: TrackerKind::Points,
        true_scale: [1.0; 6],
        scale_sigma: None,
        sessions: 2,
        rows_per_session: 15,
        session_model: SessionModel::default(),
        ..TrackerScenario::paper_like()
    };
    let dataset = simulate_mixed(&Scenario::paper(), &tracker, 3)
        .unwrap()
        .dataset;
    assert_eq!(dataset.tracker.points.len(), 30);
    compare_under_both("with tracker points", &dataset);
    let rehomed_scenario = TrackerScenario {
        session_model: SessionModel {
            leg_offset_sigma: Some(0.5),
            body_origin_sigma: None,
            body_rotation_sigma: None,
        },
        ..tracker.clone()
    };
    let rehomed = simulate_mixed(&Scenario::paper(), &rehomed_scenario, 3)
        .unwrap()
        .dataset;
    compare_under_both("with tracker points, the legs re-homed", &rehomed);
    // Tracker poses beside the points: the body frame six unknowns of the
    // global block, one row per leg; with the legs re-homed too.
    for scenario in [&tracker, &rehomed_scenario] {
        let both = TrackerScenario {
            kind: TrackerKind::Both,
            ..scenario.clone()
        };
        let with_poses = simulate_mixed(&Scenario::paper(), &both, 3)
            .unwrap()
            .dataset;
        assert_eq!(with_poses.tracker.poses.len(), 30);
        let with = format!(
            "with tracker poses and points, leg offsets {:?}",
            scenario.session_model.leg_offset_sigma
        );
        compare_under_both(&with, &with_poses);
    }
    // The legs re-homed with the scales unknown and about 0.1 % off their
    // design values, poses beside the points: the offsets in mm, as
    // the own path's, the poses' rows in leg length.
    let (true_scale, scale_sigma) = (
        [1.0012, 0.9991, 1.0004, 0.9987, 1.0009, 0.9996],
        Some([2e-3; 6]),
    );
    let scaled = TrackerScenario {
        kind: TrackerKind::Both,
        true_scale,
        scale_sigma,
        ..rehomed_scenario.clone()
    };
    let paper = Scenario::paper();
    let touches = Scenario {
        readings: Readings {
            true_scale,
            scale_sigma,
            ..paper.readings.clone()
        },
        ..paper
    };
    let scaled = simulate_mixed(&touches, &scaled, 3).unwrap().dataset;
    compare_under_both(
        "with tracker poses and points, the legs re-homed, the scales unknown",
        &scaled,
    );
    // The body re-mounted between the sessions of poses: the second
    // session's body rotation and origin shift, with the session model's
    // priors, and the legs re-homed.
    let remounted = TrackerScenario {
        kind: TrackerKind::Both,
        session_model: SessionModel {
            body_origin_sigma: Some(1.0),
            body_rotation_sigma: Some(0.01),
            ..rehomed_scenario.session_model
        },
        ..tracker.clone()
    };
    let remounted = simulate_mixed(&Scenario::paper(), &remounted, 3)
        .unwrap()
        .dataset;
    compare_under_both(
        "with tracker poses and points, the body re-mounted",
        &remounted,
    );
}

#[test]
fn motion_capture_poses_at_unknown_scales_are_the_own_paths() {
    // fixtures/jugglebot: 108 poses by motion capture, the actuators'
    // scales unknown, 6 % off their design values. The common
    // calibration's rows are the residuals in revolutions times the
    // scales' estimates, the own path's in leg length, both whitened
    // alike: the same cost, so that each run stops within SIGMA_TOLERANCE
    // of its sigmas from the same minimum.
    let jugglebot = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../fixtures/jugglebot");
    let dataset = Dataset::read(&jugglebot).unwrap();
    let options = CalibrationOptions::default();
    let own = calibrate(&dataset, &options, &mut |_| {}).unwrap();
    assert!(own.converged());
    let data = MechanismData::from_hexapod_touches(&dataset, &options).unwrap();
    let common = calibrate_mechanism(&data, &MechanismOptions::default(), &mut |_| {}).unwrap();
    assert!(common.converged());
    let names = own.names();
    let sigmas = own.global_sigmas().unwrap();
    let design = dataset.machine.actuator.scale;
    let mut delta = 0.0f64;
    let mut worst = 0.0f64;
    let mut worst_sigma = 0.0f64;
    for parameter in &common.parameters {
        // The tool is not in the own path's layout: no pose sees it.
        let Some(k) = names.iter().position(|name| *name == parameter.name) else {
            assert!(parameter.name.ends_with("_eT"), "{}", parameter.name);
            continue;
        };
        worst = worst.max(((parameter.value - own.global[k]) / sigmas[k]).abs());
        worst_sigma = worst_sigma.max((parameter.sigma.unwrap() / sigmas[k] - 1.0).abs());
        if let Some(leg) = parameter.name.strip_prefix("s_") {
            let i: usize = leg.parse::<usize>().unwrap() - 1;
            delta = delta.max((own.global[k] / design[i] - 1.0).abs());
        }
    }
    let body = common.body.as_ref().unwrap();
    let instruments = own.instruments.as_ref().unwrap();
    let values = instruments.model.values(&own.global);
    let own_body = instruments.model.body_frame(&values, 0);
    let own_frame = instruments.model.tracker_frame(&values, 0);
    worst = worst.max(frame_difference(&own_body, &body.frame, body.sigma()));
    let tracker = &common.trackers[0];
    worst = worst.max(frame_difference(
        &own_frame,
        &tracker.frame,
        tracker.sigma(),
    ));
    let test = common.global_test.unwrap();
    let own_test = own.global_test.unwrap();
    let factors = test.variance_factor / own_test.variance_factor - 1.0;
    println!(
        "{} and {} iterations; worst |difference| {worst:.2e} sigma, worst sigma ratio - 1 {worst_sigma:.2e}; scales within {delta:.4} of the design; variance factors {:.6} (own) and {:.6}",
        own.iterations(),
        common.iterations,
        own_test.variance_factor,
        test.variance_factor
    );
    assert!(delta > 0.05, "the scales are {delta} off their design");
    assert!(worst < 2.0 * SIGMA_TOLERANCE, "{worst:e}");
    // The covariances are taken at estimates up to 2e-3 sigma apart: a
    // sigma moves to first order with them, on these poses' rotations by
    // less than a tenth of their difference in sigmas (0.04 to 0.07 of it
    // with and without the prior).
    assert!(worst_sigma < 0.1 * 2.0 * SIGMA_TOLERANCE, "{worst_sigma:e}");
    // The cost is flat at the minimum: second order in 2e-3 sigma.
    assert!(factors.abs() < 1e-6, "{factors:e}");
}

#[test]
fn motion_capture_poses_held_out_are_judged() {
    // fixtures/jugglebot's 108 poses in 6 interleaved folds (pose j in fold
    // j mod 6): each fold's 18 poses judged by the calibration of the
    // other 90 as a tracker placed anew and a body mounted anew (their 12
    // unknowns projected out), 18 x 6 - 12 rows, one observation named by
    // the tracker, tested against the covariance the calibration predicts.
    let jugglebot = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../fixtures/jugglebot");
    let dataset = Dataset::read(&jugglebot).unwrap();
    let data =
        MechanismData::from_hexapod_touches(&dataset, &CalibrationOptions::default()).unwrap();
    let held_out = MechanismData::hexapod_held_out(&dataset).unwrap();
    let folds = 6;
    let fold = |observations: &Observations, r: usize, inside: bool| Observations {
        tracker_poses: (observations.tracker_poses.iter().enumerate())
            .filter(|(j, _)| (j % folds == r) == inside)
            .map(|(_, pose)| pose.clone())
            .collect(),
        ..observations.clone()
    };
    let (mut squares, mut predicted, mut rows) = (0.0, 0.0, 0);
    for r in 0..folds {
        let fit = data.with_observations(fold(&data.observations, r, false));
        let calibration =
            calibrate_mechanism(&fit, &MechanismOptions::default(), &mut |_| {}).unwrap();
        assert!(calibration.converged());
        let calibrated = CalibratedMechanism::of_calibration(&calibration).unwrap();
        let judged = held_out.with_observations(fold(&held_out.observations, r, true));
        let validation = validate_mechanism(&calibrated, &judged, 0.05, None).unwrap();
        assert_eq!(validation.rows.len(), 18 * 6 - 12);
        assert!(
            (validation.rows.iter())
                .all(|row| row.observation.to_string() == "tracker 0 (tracker poses 0-17)")
        );
        let test = validation.test.as_ref().unwrap();
        println!(
            "fold {r}: ratio {:.3} within [{:.3}, {:.3}] ({:?})",
            test.ratio, test.interval.0, test.interval.1, test.outcome
        );
        // Each leg's row in mm: its readings' unit times its calibrated
        // scale.
        let scale: Vec<f64> = (1..=6)
            .map(|i| {
                let name = format!("s_{i}");
                let s = calibration.parameters.iter().find(|p| p.name == name);
                s.unwrap().value
            })
            .collect();
        for row in &validation.rows {
            let leg = scale[row.row % 6];
            squares += (row.residual * leg).powi(2);
            predicted += (row.sigma * leg).powi(2);
            rows += 1;
        }
    }
    println!(
        "cross-validated leg-length RMS {:.4} mm against the predicted {:.4} mm over {rows} rows",
        (squares / rows as f64).sqrt(),
        (predicted / rows as f64).sqrt()
    );
}

/// Calibrates `dataset` both ways under simulations I and IV (the radius
/// and the coordinate observation) and compares, each run announced as
/// `with`.
fn compare_under_both(with: &str, dataset: &Dataset) {
    for simulation in [Simulation::I, Simulation::IV] {
        println!("{simulation:?} {with}:");
        compare_on(dataset, &CalibrationOptions::simulation(simulation));
    }
}

/// Calibrates fixtures/paper-seed1 both ways under `options` and compares.
fn compare(options: &CalibrationOptions) {
    compare_on(&Dataset::read(&fixture()).unwrap(), options);
}

/// Calibrates `dataset` both ways under `options` and compares.
fn compare_on(dataset: &Dataset, options: &CalibrationOptions) {
    let own = calibrate(dataset, options, &mut |_| {}).unwrap();
    assert!(own.converged());
    // The 33, then the actuators' scales when they are unknowns (the own
    // global block then holds the tied balls' centres, which the common
    // result gives with the balls).
    let sigmas = own.global_sigmas().unwrap();
    let data = MechanismData::from_hexapod_touches(dataset, options).unwrap();
    let common_options = MechanismOptions::default().with_observation(options.observation);
    let common = calibrate_mechanism(&data, &common_options, &mut |_| {}).unwrap();
    let tied = own
        .names()
        .iter()
        .filter(|name| name.starts_with("centre "))
        .count();
    let per_ball_radius = usize::from(options.radius == RadiusModel::PerBall);
    let tied_unknowns = tied / 3 * (3 + per_ball_radius);
    let frames = 6 * (common.trackers.len() + usize::from(common.body.is_some()));
    let offsets: usize = common.trackers.iter().map(|t| t.offsets.len()).sum();
    let shifts: usize = (data.observations.trackers.iter())
        .map(|t| 3 * (usize::from(t.body_turned) + usize::from(t.body_moved)))
        .sum();
    assert_eq!(
        common.parameters.len() + tied_unknowns + frames + offsets + shifts,
        own.global.len()
    );
    let common_test = common.global_test.unwrap();
    let value_tolerance = 2.0 * SIGMA_TOLERANCE;
    let names = own.names();
    let (mut worst_value, mut worst_sigma) = (0.0f64, 0.0f64);
    for (k, parameter) in common.parameters.iter().enumerate() {
        assert_eq!(parameter.name, names[k]);
        let sigma = parameter.sigma.unwrap();
        worst_value = worst_value.max(((parameter.value - own.global[k]) / sigmas[k]).abs());
        worst_sigma = worst_sigma.max((sigma / sigmas[k] - 1.0).abs());
    }
    println!(
        "{} and {} iterations; worst |difference| {worst_value:.2e} sigma, worst sigma ratio - 1 {worst_sigma:.2e}",
        own.iterations(),
        common.iterations
    );
    // Each run stops within SIGMA_TOLERANCE of its sigmas from the minimum.
    assert!(worst_value < value_tolerance, "{worst_value:e}");
    // The covariances are taken at estimates at most 2e-3 sigma apart
    // (the runs may stop at different iterates: each takes local steps
    // where its problem has them): the Jacobians differ by 2e-3 of their
    // change over one sigma, which the covariance's linearisation needs
    // small (under 5 %: the fit is linear over its uncertainty); a sigma,
    // the root of a quadratic form in them, by at most 2 x 2e-3 x 5 %.
    assert!(worst_sigma < 2e-4, "{worst_sigma:e}");
    // The balls: centres (the same canonical frame) and radii, when they
    // are unknowns.
    let centre_sigmas = own.balls.centre_sigmas.as_ref().unwrap();
    assert_eq!(common.balls.len(), own.balls.centres.len());
    let mut worst_ball = 0.0f64;
    for (b, ball) in common.balls.iter().enumerate() {
        for ((estimate, own_estimate), sigma) in ball
            .centre
            .iter()
            .zip(&own.balls.centres[b])
            .zip(&centre_sigmas[b])
        {
            worst_ball = worst_ball.max(((estimate - own_estimate) / sigma).abs());
        }
        if let (Some(radii), Some(radius_sigmas)) = (&own.balls.radii, &own.balls.radius_sigmas) {
            let difference = (ball.radius - radii[b]) / radius_sigmas[b];
            worst_ball = worst_ball.max(difference.abs());
        }
    }
    println!("balls: worst |difference| {worst_ball:.2e} sigma");
    assert!(worst_ball < value_tolerance, "{worst_ball:e}");
    // The trackers' frames: F_own⁻¹ ∘ F in units of the common sigmas.
    if let Some(instruments) = &own.instruments {
        let values = instruments.model.values(&own.global);
        let mut worst_frame = 0.0f64;
        for (session, tracker) in common.trackers.iter().enumerate() {
            let own_frame = instruments.model.tracker_frame(&values, session);
            worst_frame = worst_frame.max(frame_difference(
                &own_frame,
                &tracker.frame,
                tracker.sigma(),
            ));
            // In mm, as the own path's.
            for (&(offset, sigma), own) in tracker.offsets.iter().zip(values.offsets[session]) {
                worst_frame = worst_frame.max(((offset - own) / sigma.unwrap()).abs());
            }
        }
        if let Some(body) = &common.body {
            // The body as each session's poses saw it (re-mounted or not).
            for (session, tracker) in common.trackers.iter().enumerate() {
                let own_body = instruments.model.body_frame(&values, session);
                let seen = tracker.body.as_ref().unwrap_or(body);
                worst_frame =
                    worst_frame.max(frame_difference(&own_body, &seen.frame, seen.sigma()));
            }
        }
        println!("trackers' and body frames: worst |difference| {worst_frame:.2e} sigma");
        assert!(worst_frame < value_tolerance, "{worst_frame:e}");
    }
    // The checks: one row per contact (three under eq. 10); the same
    // global test and the same largest normalised residual, of the same
    // contact.
    let distances = dataset.artefacts.distances.len();
    let rows = match options.observation {
        Observation::Radius => 1,
        Observation::Coordinates => 3,
    };
    assert_eq!(
        common.data_rows,
        rows * dataset.measurements.len()
            + distances
            + 3 * dataset.tracker.points.len()
            + 6 * dataset.tracker.poses.len()
    );
    // One w-test a contact, under either observation, as the own path
    // counts them: the same critical value.
    let own_reliability = own.reliability.as_ref().unwrap();
    assert_eq!(common.tests, own_reliability.tests());
    let own_test = own.global_test.unwrap();
    assert_eq!(own_test.redundancy, common_test.redundancy);
    let factors = common_test.variance_factor / own_test.variance_factor - 1.0;
    // The cost is flat at the minimum: second order in 2e-3 sigma.
    assert!(factors.abs() < 1e-6, "{factors:e}");
    let own_worst = own_reliability.worst().unwrap();
    let worst = common.worst().unwrap();
    let (observation, w) = (worst.observation, worst.normalised);
    println!(
        "variance factor {:.4}; largest |w| {:.4} at {observation}",
        common_test.variance_factor,
        w.abs()
    );
    let index = observation.index;
    let expected = match observation.kind {
        ObservationKind::Touch => ObservationId::Contact(index),
        ObservationKind::BallDistance => ObservationId::Distance(index),
        ObservationKind::TrackerPoint => ObservationId::Point(index),
        ObservationKind::TrackerPose => ObservationId::Pose(index),
        other => panic!("a hexapod has no {}", other.name()),
    };
    assert_eq!(own_worst.observation(), expected);
    // Each run stops within SIGMA_TOLERANCE of the minimum in the norm of
    // H: the row's residual moves by at most 2 SIGMA_TOLERANCE √h, `w =
    // e / √r` by that over √r (`h = 1 − r` its leverage, `r` the row's
    // redundancy), beside the rounding.
    let r = f64::from(
        (common.observations.iter())
            .find(|c| c.observation == observation)
            .expect("the worst observation is checked")
            .rows[worst.row]
            .redundancy,
    );
    let bound = 1e-6 * w.abs() + 2.0 * SIGMA_TOLERANCE * ((1.0 - r) / r).sqrt();
    let difference = w.abs() - own_worst.normalised().unwrap().abs();
    assert!(difference.abs() < bound, "{difference:e} against {bound:e}");
}

#[test]
fn balls_located_in_the_canonical_frame_are_held_there_by_both_paths() {
    // artefacts.json locating the balls in the canonical base frame (here
    // where a calibration without priors puts them): under the propagated
    // prior each centre has that location as its prior, in both paths.
    let mut dataset = Dataset::read(&fixture()).unwrap();
    let free = calibrate(
        &dataset,
        &CalibrationOptions::simulation(Simulation::I),
        &mut |_| {},
    )
    .unwrap();
    dataset.artefacts.frame = ArtefactFrame::Canonical;
    for (ball, centre) in dataset.artefacts.balls.iter_mut().zip(&free.balls.centres) {
        ball.centre = (*centre).into();
    }
    let options = CalibrationOptions {
        prior: PriorMode::Propagated,
        ..CalibrationOptions::simulation(Simulation::I)
    };
    let data = MechanismData::from_hexapod_touches(&dataset, &options).unwrap();
    let placed = data.observations.balls.iter().zip(&dataset.artefacts.balls);
    for (ball, stated) in placed {
        let prior = ball.centre_prior.unwrap();
        assert_eq!(
            (prior.centre, prior.sigma),
            (stated.centre, stated.centre_sigma)
        );
    }
    println!("propagated prior, balls in the canonical frame:");
    compare_on(&dataset, &options);
}

#[test]
fn balls_tied_by_calibrated_distances_are_the_own_paths() {
    // A ball plate's certificate over fixtures/paper-seed1's balls: 17
    // pairs (a, a + 1) tying 26 of the 27 balls in chains of three, at
    // their true distances to within a few tenths of their 1 um sigma.
    // Both paths put the tied balls' centres (and uncertain radii) in the
    // global block.
    let mut dataset = Dataset::read(&fixture()).unwrap();
    let truth = dataset.truth.clone().unwrap();
    let centre = |b: usize| {
        let c = &truth.ball_centres[b];
        nalgebra::Vector3::from(*c)
    };
    dataset.artefacts.distances = (0..27)
        .filter(|b| b % 3 != 2)
        .map(|a| (a, a + 1))
        .take(17)
        .enumerate()
        .map(|(k, (a, b))| Distance {
            a,
            b,
            length: (centre(a) - centre(b)).norm() + 3e-4 * (k as f64).sin(),
            sigma: 1e-3,
        })
        .collect();
    for prior in [PriorMode::Paper, PriorMode::Propagated] {
        for radius in [RadiusModel::PerBall, RadiusModel::PerContact] {
            println!("{prior:?} prior, {radius:?} radius, 17 ball distances:");
            let options = CalibrationOptions {
                prior,
                radius,
                ..CalibrationOptions::simulation(Simulation::I)
            };
            compare_on(&dataset, &options);
        }
    }
    println!("the default options (coordinates), 17 ball distances:");
    compare_on(&dataset, &CalibrationOptions::default());
}

/// The largest component of `own⁻¹ ∘ common` (rotation vector, then
/// translation) in units of `sigma`.
fn frame_difference(own: &Isometry3<f64>, common: &Isometry3<f64>, sigma: Option<[f64; 6]>) -> f64 {
    let error = own.inverse() * common;
    let sigma = sigma.unwrap();
    (error.rotation.scaled_axis().iter())
        .chain(error.translation.vector.iter())
        .zip(sigma)
        .map(|(e, s)| (e / s).abs())
        .fold(0.0, f64::max)
}

#[test]
fn poses_alone_without_a_prior_hold_the_tool_by_its_tolerance() {
    // Poses in two sessions at known scales, no touch, no point, no prior:
    // the own path leaves the tool out of its layout; the common path
    // keeps the tool's tolerance as its prior, which no row sees. Every
    // other unknown, the cost and the redundancy are the own path's.
    let scenario = TrackerScenario {
        kind: TrackerKind::Poses,
        true_scale: [1.0; 6],
        scale_sigma: None,
        sessions: 2,
        rows_per_session: 30,
        session_model: SessionModel::default(),
        ..TrackerScenario::paper_like()
    };
    let dataset = simulate_tracker(&scenario, 5).unwrap().dataset;
    let options = CalibrationOptions {
        prior: PriorMode::None,
        ..CalibrationOptions::simulation(Simulation::I)
    };
    let own = calibrate(&dataset, &options, &mut |_| {}).unwrap();
    assert!(own.converged());
    let data = MechanismData::from_hexapod_touches(&dataset, &options).unwrap();
    let common = calibrate_mechanism(&data, &MechanismOptions::default(), &mut |_| {}).unwrap();
    assert!(common.converged());
    let (names, sigmas) = (own.names(), own.global_sigmas().unwrap());
    let tolerance = dataset.machine.prior_sigma.tool;
    let (mut worst_value, mut worst_sigma, mut tool) = (0.0f64, 0.0f64, 0);
    for parameter in &common.parameters {
        let sigma = parameter.sigma.unwrap();
        let Some(k) = names.iter().position(|name| *name == parameter.name) else {
            // The tool, at its design with its tolerance: its block of the
            // normal equations is the prior's alone.
            assert_eq!(parameter.group, "tool", "{}", parameter.name);
            assert!((parameter.value - parameter.prior.mean).abs() < 1e-9 * tolerance);
            assert!((sigma / tolerance - 1.0).abs() < 1e-9, "{sigma}");
            tool += 1;
            continue;
        };
        worst_value = worst_value.max(((parameter.value - own.global[k]) / sigmas[k]).abs());
        worst_sigma = worst_sigma.max((sigma / sigmas[k] - 1.0).abs());
    }
    assert_eq!(tool, 3);
    let instruments = own.instruments.as_ref().unwrap();
    let values = instruments.model.values(&own.global);
    let body = common.body.as_ref().unwrap();
    for (session, tracker) in common.trackers.iter().enumerate() {
        let own_frame = instruments.model.tracker_frame(&values, session);
        let own_body = instruments.model.body_frame(&values, session);
        worst_value = worst_value
            .max(frame_difference(
                &own_frame,
                &tracker.frame,
                tracker.sigma(),
            ))
            .max(frame_difference(&own_body, &body.frame, body.sigma()));
    }
    let (own_test, test) = (own.global_test.unwrap(), common.global_test.unwrap());
    let factors = test.variance_factor / own_test.variance_factor - 1.0;
    println!(
        "{} and {} iterations; worst |difference| {worst_value:.2e} sigma, worst sigma ratio - 1 {worst_sigma:.2e}, variance factors' ratio - 1 {factors:.2e}",
        own.iterations(),
        common.iterations
    );
    // Each run stops within SIGMA_TOLERANCE of its sigmas from the
    // minimum; the covariances and the flat cost differ at second order.
    assert!(worst_value < 2.0 * SIGMA_TOLERANCE, "{worst_value:e}");
    assert!(worst_sigma < 1e-6, "{worst_sigma:e}");
    assert_eq!(own_test.redundancy, test.redundancy);
    assert!(factors.abs() < 1e-6, "{factors:e}");
}

#[test]
fn what_the_common_calibration_does_not_model_is_refused_by_name() {
    let eq9 = CalibrationOptions::simulation(Simulation::I);
    let refusal = |dataset: &Dataset, options: &CalibrationOptions| {
        MechanismData::from_hexapod_touches(dataset, options)
            .unwrap_err()
            .to_string()
    };
    let dataset = Dataset::read(&fixture()).unwrap();
    // Readings no pose reaches (legs 0 and 1000 mm out in turn), at two
    // contacts: the first in the file is named, whichever thread met it.
    let mut unreachable = dataset.clone();
    for row in [150, 20] {
        unreachable.measurements.q[row] = [0.0, 1000.0, 0.0, 1000.0, 0.0, 1000.0];
    }
    let error = refusal(&unreachable, &eq9);
    assert!(
        error.starts_with("the design's start: measurement row 20: "),
        "{error}"
    );
    // A hexapod touch at a commanded position (x, y, z): its pose has six
    // coordinates.
    let mut data = MechanismData::from_hexapod_touches(&dataset, &eq9).unwrap();
    data.observations.touches[7].at = Actuation::Commanded([0.0, 0.0, 400.0]);
    let error = calibrate_mechanism(&data, &MechanismOptions::default(), &mut |_| {}).unwrap_err();
    let message = error.to_string();
    assert!(message.contains("touch 7"), "{message}");
    assert!(message.contains("6 coordinates"), "{message}");
    // Readings of the wrong length.
    data.observations.touches[7].at = Actuation::Readings(vec![0.0; 5].into());
    let error = calibrate_mechanism(&data, &MechanismOptions::default(), &mut |_| {}).unwrap_err();
    let message = error.to_string();
    assert!(
        message.contains("5 readings for the 6 actuators"),
        "{message}"
    );
}

/// The observations of the balls `keep` (numbered again from 0) and their
/// touches.
fn balls(observations: &Observations, keep: std::ops::Range<usize>) -> Observations {
    Observations {
        balls: observations.balls[keep.clone()].to_vec(),
        touches: observations
            .touches
            .iter()
            .filter(|t| keep.contains(&t.ball))
            .map(|t| {
                let mut touch = t.clone();
                touch.ball -= keep.start;
                touch
            })
            .collect(),
        ..Observations::default()
    }
}

#[test]
fn a_hexapod_calibrated_through_the_interface_is_judged_on_held_out_balls() {
    // Fitted on 20 of the 27 balls (simulation III's model: eq. 9, the
    // propagated weights, the design tolerances as priors), through its
    // record, judged on the touches of the other 7: each
    // ball's centre located from its 7 touches leaves 4 rows.
    let dataset = Dataset::read(&fixture()).unwrap();
    let options = CalibrationOptions::simulation(Simulation::III);
    let all = MechanismData::from_hexapod_touches(&dataset, &options).unwrap();
    let fit = all.with_observations(balls(&all.observations, 0..20));
    let calibration = calibrate_mechanism(&fit, &MechanismOptions::default(), &mut |_| {}).unwrap();
    assert!(calibration.converged());
    let calibrated = CalibratedMechanism::of_calibration(&calibration).unwrap();
    let mut held_out = all.with_observations(balls(&all.observations, 20..27));
    let validation = validate_mechanism(&calibrated, &held_out, 0.05, None).unwrap();
    let test = validation.test.as_ref().unwrap();
    println!(
        "held out: {} rows, ratio {:.3} within [{:.3}, {:.3}]",
        validation.rows.len(),
        test.ratio,
        test.interval.0,
        test.interval.1
    );
    assert_eq!(validation.rows.len(), 7 * 4);
    assert!(validation.accepted(), "{validation:?}");
    // The same touches with leg 1 reading 0.1 mm long (a re-homed
    // actuator): rejected, and the change that explains it is leg 1's
    // length. (An offset of 20 µm is not seen: it moves a ball's touches
    // nearly alike, as a shift of its centre.)
    for touch in &mut held_out.observations.touches {
        if let Actuation::Readings(q) = &mut touch.at {
            q[0] += 0.1;
        }
    }
    let validation = validate_mechanism(&calibrated, &held_out, 0.05, None).unwrap();
    let test = validation.test.as_ref().unwrap();
    let best = &validation.shifts[0];
    println!(
        "leg 1 + 0.1 mm: ratio {:.3}; best explained by {} {:+.4} ± {:.4} mm",
        test.ratio, best.name, best.shift, best.sigma
    );
    assert!(!validation.accepted());
    assert_eq!(best.name, "l_1");
}

#[test]
fn a_hexapod_calibrated_through_the_interface_is_compensated_on_target_poses() {
    // The platform poses of eight contacts of fixtures/paper-seed1 (as the
    // calibrated machine reaches them) as targets, calibrated with the
    // propagated prior (the one the truth is a plausible draw of): the
    // commands the calibration gives put the true machine (truth.json,
    // canonical frame) nearer each than the design's commands do, and its
    // platform origin within 5 of its predicted sigmas of each (one
    // calibration: the eight errors share its error, so no mean is
    // tested).
    let dataset = Dataset::read(&fixture()).unwrap();
    let options = CalibrationOptions {
        prior: PriorMode::Propagated,
        ..CalibrationOptions::simulation(Simulation::III)
    };
    let data = MechanismData::from_hexapod_touches(&dataset, &options).unwrap();
    let run = calibrate_mechanism(&data, &MechanismOptions::default(), &mut |_| {}).unwrap();
    let calibrated = CalibratedMechanism::of_calibration(&run).unwrap();
    let hexapod = calibrated.mechanism.as_ref();
    let g = &dataset.truth.as_ref().unwrap().geometry;
    let truth = Geometry::from_arrays(&g.base_joints, &g.platform_joints, &g.tool, &g.leg_lengths);
    let truth = to_params(&truth.canonicalize().unwrap().geometry);
    let truth = truth.as_slice();
    let params = calibrated.params();
    let targets: Vec<Vec<f64>> = (0..8)
        .map(|k| {
            let q = &dataset.measurements.q[23 * k];
            let start = hexapod.start_pose(params, q).unwrap();
            hexapod
                .forward(params, q, start.as_slice())
                .unwrap()
                .as_slice()
                .to_vec()
        })
        .collect();
    for (target, compensation) in
        targets
            .iter()
            .zip(compensate_mechanism(&calibrated, &targets, &[]))
    {
        let compensation = compensation.unwrap();
        let error = |q: &nalgebra::DVector<f64>| {
            let reached = hexapod.forward(truth, q.as_slice(), target).unwrap();
            [0, 1, 2].map(|k| reached[k] - target[k])
        };
        let (calibrated_error, nominal_error) =
            (error(&compensation.readings), error(&compensation.nominal));
        let norm = |e: [f64; 3]| e.iter().map(|v| v * v).sum::<f64>().sqrt();
        let sigmas = compensation.sigmas();
        println!(
            "target {:?}: {:.4} mm calibrated (sigmas {:.4?} mm), {:.4} mm nominal",
            &target[..3],
            norm(calibrated_error),
            &sigmas[..3],
            norm(nominal_error)
        );
        assert!(norm(calibrated_error) < norm(nominal_error));
        assert_eq!(sigmas.len(), 6);
        for (e, sigma) in calibrated_error.iter().zip(&sigmas) {
            assert!(e.abs() < 5.0 * sigma, "{e} against sigma {sigma}");
        }
    }
}
