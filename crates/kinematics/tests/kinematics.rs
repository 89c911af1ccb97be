//! Numerical checks of the kinematics: inverse then forward kinematics over
//! the workspace, analytic derivatives against central differences, and the
//! canonical frames' invariance to rigid motions of the input frame.

use nalgebra::{Isometry3, Translation3, UnitQuaternion, Vector3, Vector6};
use parcal_kinematics::forward_batch::{
    LANES, PivotOrder, forward_along_batch, forward_batch, forward_jacobian_batch,
};
use parcal_kinematics::{
    FactoredTipJacobian, ForwardOptions, ForwardSolution, Geometry, KinematicsError, N_PARAMS,
    Params, Pose, SolutionAlong, SolutionJacobian, TipDerivatives, Vec3, actuators, forward,
    forward_from_home, paper, params, rotation_zyx, tip_jacobians,
};
use rand::rngs::StdRng;
use rand::{RngExt, SeedableRng};

/// A random pose of the design-frame workspace: tilt angles up to
/// `max_tilt` degrees, the tool tip in x, y in [-80, 80], z in [340, 460].
fn workspace_pose(rng: &mut StdRng, geometry: &Geometry, max_tilt: f64) -> Pose {
    let tilt = max_tilt.to_radians();
    let rotation = rotation_zyx(
        rng.random_range(-tilt..tilt),
        rng.random_range(-tilt..tilt),
        rng.random_range(-tilt..tilt),
    );
    let tip = Vec3::new(
        rng.random_range(-80.0..80.0),
        rng.random_range(-80.0..80.0),
        rng.random_range(340.0..460.0),
    );
    Pose::from_parts(Translation3::from(tip - rotation * geometry.tool), rotation)
}

#[test]
fn inverse_then_forward_returns_the_pose_over_the_workspace() {
    let mut rng = StdRng::seed_from_u64(2004);
    let options = ForwardOptions::default();
    for geometry in [paper::design(), paper::truth()] {
        let mut worst: f64 = 0.0;
        for _ in 0..10_000 {
            let pose = workspace_pose(&mut rng, &geometry, 15.0);
            let q = actuators(&geometry, &pose);
            let solution = forward_from_home(&geometry, &q, &options).expect("forward kinematics");
            let error = (geometry.tool_tip(&solution.pose) - geometry.tool_tip(&pose)).norm();
            worst = worst.max(error);
        }
        assert!(worst < 1e-9, "largest tool-tip error {worst:e} mm");
    }
}

#[test]
fn rotation_is_yaw_pitch_roll_about_fixed_axes() {
    let (yaw, pitch, roll) = (0.3, -0.2, 0.1);
    let rz = UnitQuaternion::from_axis_angle(&Vector3::z_axis(), yaw);
    let ry = UnitQuaternion::from_axis_angle(&Vector3::y_axis(), pitch);
    let rx = UnitQuaternion::from_axis_angle(&Vector3::x_axis(), roll);
    assert!(rotation_zyx(yaw, pitch, roll).angle_to(&(rz * ry * rx)) < 1e-14);
}

/// Tip of the canonical geometry of `p` at fixed `q`, by forward kinematics
/// from `start`.
fn tip(p: &Params, q: &[f64; 6], start: &Pose) -> Vec3 {
    let geometry = params::from_params(p);
    let solution = forward(&geometry, q, start, &ForwardOptions::default()).unwrap();
    geometry.tool_tip(&solution.pose)
}

fn assert_columns_agree(name: &str, analytic: &[Vec3], numeric: &[Vec3]) {
    let scale = analytic.iter().map(|c| c.norm()).fold(0.0, f64::max);
    for (k, (a, n)) in analytic.iter().zip(numeric).enumerate() {
        let error = (a - n).norm();
        assert!(
            error <= 1e-6 * a.norm().max(1e-3 * scale),
            "{name} column {k}: analytic {a:?} numeric {n:?}"
        );
    }
}

#[test]
fn tip_derivatives_agree_with_central_differences() {
    let mut rng = StdRng::seed_from_u64(7);
    let design = paper::design();
    let canonical = paper::truth().canonicalize().unwrap();
    let p = params::to_params(&canonical.geometry);
    for _ in 0..20 {
        let pose = canonical.pose_from_input(&workspace_pose(&mut rng, &design, 15.0));
        let q = actuators(&canonical.geometry, &pose);
        let solution = forward(&canonical.geometry, &q, &pose, &ForwardOptions::default()).unwrap();
        let jacobians = tip_jacobians(&canonical.geometry, &solution);

        // From a start 1e-9 mm away, one short Newton step lands on the
        // solution (not evaluated again) and keeps the legs and the
        // factorisation of its start: the Jacobians hardly change.
        let nearby = Pose::from_parts(
            Translation3::from(pose.translation.vector + Vec3::new(1e-9, -2e-9, 1e-9)),
            pose.rotation,
        );
        let reused = forward(&canonical.geometry, &q, &nearby, &ForwardOptions::default()).unwrap();
        assert_eq!(reused.iterations, 1);
        let closure = parcal_kinematics::closure::Legs::at(&canonical.geometry, &reused.pose)
            .residual(&canonical.geometry, &q)
            .amax();
        assert!(
            closure < 1e-12,
            "closure residual {closure:e} after the short step"
        );
        let reused = tip_jacobians(&canonical.geometry, &reused);
        assert!(
            (reused.d_params - jacobians.d_params).amax() < 1e-8 * jacobians.d_params.amax(),
            "Jacobian from the reused factorisation"
        );

        let h = 1e-4;
        let analytic: Vec<Vec3> = (0..params::N_PARAMS)
            .map(|k| jacobians.d_params.column(k).into())
            .collect();
        let numeric: Vec<Vec3> = (0..params::N_PARAMS)
            .map(|k| {
                let (mut plus, mut minus) = (p, p);
                plus[k] += h;
                minus[k] -= h;
                (tip(&plus, &q, &pose) - tip(&minus, &q, &pose)) / (2.0 * h)
            })
            .collect();
        assert_columns_agree("d tip / d p", &analytic, &numeric);

        let analytic: Vec<Vec3> = (0..6).map(|i| jacobians.d_q.column(i).into()).collect();
        let numeric: Vec<Vec3> = (0..6)
            .map(|i| {
                let (mut plus, mut minus) = (q, q);
                plus[i] += h;
                minus[i] -= h;
                (tip(&p, &plus, &pose) - tip(&p, &minus, &pose)) / (2.0 * h)
            })
            .collect();
        assert_columns_agree("d tip / d q", &analytic, &numeric);
    }
}

#[test]
fn canonical_geometry_is_invariant_to_rigid_motions_of_the_input_frames() {
    let mut rng = StdRng::seed_from_u64(11);
    let truth = paper::truth();
    let reference = truth.canonicalize().unwrap();
    for _ in 0..50 {
        let mut random_motion = || {
            let axis = Vector3::new(
                rng.random_range(-1.0..1.0),
                rng.random_range(-1.0..1.0),
                rng.random_range(-1.0..1.0),
            );
            // Keep +z on the same side: tilts below 60 degrees.
            let rotation =
                UnitQuaternion::from_scaled_axis(axis.normalize() * rng.random_range(-1.0..1.0));
            let shift = Translation3::new(
                rng.random_range(-500.0..500.0),
                rng.random_range(-500.0..500.0),
                rng.random_range(-500.0..500.0),
            );
            Isometry3::from_parts(shift, rotation)
        };
        let (base_motion, platform_motion) = (random_motion(), random_motion());
        let moved = Geometry {
            base: truth
                .base
                .map(|b| base_motion.transform_point(&b.into()).coords),
            platform: truth
                .platform
                .map(|e| platform_motion.transform_point(&e.into()).coords),
            tool: platform_motion.transform_point(&truth.tool.into()).coords,
            legs: truth.legs,
        };
        let canonical = moved.canonicalize().unwrap();
        let difference =
            params::to_params(&canonical.geometry) - params::to_params(&reference.geometry);
        assert!(
            difference.amax() < 1e-9,
            "largest parameter change {:e}",
            difference.amax()
        );
    }
}

#[test]
fn forward_kinematics_failures_are_error_values() {
    let geometry = paper::design();
    let options = ForwardOptions::default();
    let home = geometry.home_pose(&[0.0; 6]);

    let mut q = [100.0; 6];
    q[2] = -300.0;
    assert_eq!(
        forward(&geometry, &q, &home, &options).unwrap_err(),
        KinematicsError::InfeasibleLeg {
            leg: 3,
            length: -65.0
        }
    );

    q[2] = f64::NAN;
    let error = forward(&geometry, &q, &home, &options).unwrap_err();
    assert_eq!(
        error.to_string(),
        "actuator value q3 is not a finite number"
    );

    // Legs longer than the joints can ever be apart: no pose closes.
    let error = forward(
        &geometry,
        &[1.0e4, 0.0, 0.0, 0.0, 0.0, 0.0],
        &home,
        &options,
    )
    .unwrap_err();
    assert!(
        matches!(error, KinematicsError::NotConverged { .. }),
        "{error}"
    );

    let few = ForwardOptions {
        max_iterations: 1,
        ..options
    };
    let error = forward(&geometry, &[120.0; 6], &home, &few).unwrap_err();
    assert!(
        matches!(error, KinematicsError::NotConverged { iterations: 1, .. }),
        "{error}"
    );

    let (singular, upright) = singular_configuration(&geometry);
    let error = forward(&singular, &[-30.0; 6], &upright, &options).unwrap_err();
    assert_eq!(error, KinematicsError::SingularJacobian);
}

#[test]
fn derivative_along_a_direction_equals_the_jacobian_times_it() {
    let mut rng = StdRng::seed_from_u64(23);
    let design = paper::design();
    let canonical = paper::truth().canonicalize().unwrap();
    for _ in 0..50 {
        let pose = canonical.pose_from_input(&workspace_pose(&mut rng, &design, 15.0));
        let q = actuators(&canonical.geometry, &pose);
        let solution = forward(&canonical.geometry, &q, &pose, &ForwardOptions::default()).unwrap();
        let dp = Params::from_fn(|_, _| rng.random_range(-1.0..1.0));
        let full = tip_jacobians(&canonical.geometry, &solution).d_params * dp;
        let derivatives = TipDerivatives::new(&canonical.geometry, &solution);
        let along = derivatives.along(&dp);
        // A combination of the rows, as the calibration's elimination uses.
        let weights = Vec3::new(0.3, -1.2, 0.7);
        let mut row = [0.0; params::N_PARAMS];
        derivatives.params_row(&weights, &mut row);
        let dense = tip_jacobians(&canonical.geometry, &solution)
            .d_params
            .tr_mul(&weights);
        assert!((Params::from(row) - dense).amax() <= 1e-12 * dense.amax());
        assert!(
            (full - along.tip).norm() <= 1e-12 * full.norm(),
            "{full:?} vs {:?}",
            along.tip
        );
        // The pose prediction is first order: forward kinematics at p + h dp
        // lands within O(h^2) of the predicted pose.
        let h = 1e-3;
        let moved = params::from_params(&(params::to_params(&canonical.geometry) + h * dp));
        let predicted = parcal_kinematics::forward::step(&solution.pose, &along.pose, h);
        let exact = forward(&moved, &q, &solution.pose, &ForwardOptions::default())
            .unwrap()
            .pose;
        let miss = (predicted.translation.vector - exact.translation.vector).norm()
            + predicted.rotation.angle_to(&exact.rotation) * 100.0;
        let first_order = (h * along.pose).norm();
        assert!(
            miss < 1e-2 * first_order,
            "prediction misses by {miss:e} (step {first_order:e})"
        );
    }
}

#[test]
fn predicted_pose_is_first_order_in_the_actuators() {
    let mut rng = StdRng::seed_from_u64(31);
    let geometry = paper::truth();
    let options = ForwardOptions::default();
    for _ in 0..50 {
        let pose = workspace_pose(&mut rng, &geometry, 15.0);
        let q = actuators(&geometry, &pose);
        let mut derivatives = TipDerivatives::default();
        derivatives.forward(&geometry, &q, &pose, &options).unwrap();
        let direction = nalgebra::Vector6::from_fn(|_, _| rng.random_range(-1.0..1.0));
        // The miss of the prediction against forward kinematics at q + h dq
        // shrinks as h^2: by 4 when h halves.
        let miss = |h: f64| {
            let moved: [f64; 6] = std::array::from_fn(|i| q[i] + h * direction[i]);
            let exact = forward(&geometry, &moved, &pose, &options).unwrap().pose;
            let predicted = derivatives.predicted_pose(&(h * direction));
            (predicted.translation.vector - exact.translation.vector).norm()
                + predicted.rotation.angle_to(&exact.rotation) * 100.0
        };
        let (coarse, fine) = (miss(1e-1), miss(5e-2));
        assert!(coarse < 1e-2, "miss {coarse:e} for a 0.1 mm change");
        let ratio = coarse / fine;
        assert!(
            (3.5..4.5).contains(&ratio),
            "miss ratio {ratio} (4 expected)"
        );
    }
}

/// Platform joints over the base joints of `geometry` with vertical legs,
/// and a pose of it: the closure Jacobian loses rank there (no control of
/// x, y and the yaw).
fn singular_configuration(geometry: &Geometry) -> (Geometry, Pose) {
    let singular = Geometry {
        platform: geometry.base,
        ..geometry.clone()
    };
    let upright = Pose::from_parts(
        Translation3::new(0.0, 0.0, 200.0),
        UnitQuaternion::identity(),
    );
    (singular, upright)
}

/// Contacts of the workspace for batch `round` of a test: 1 to [`LANES`] of them,
/// started one iteration away (a small pose error, two Newton steps), from
/// the home pose (four steps), or turned by up to 80 degrees (five steps and
/// more; the scalar iteration halves some of them, and the lanes hand those
/// contacts over to it).
fn random_batch(rng: &mut StdRng, geometry: &Geometry, round: usize) -> Vec<([f64; 6], Pose)> {
    (0..round % LANES + 1)
        .map(|_| {
            let pose = workspace_pose(rng, geometry, 10.0);
            let q = actuators(geometry, &pose);
            let start = if round.is_multiple_of(5) {
                let turn = UnitQuaternion::from_scaled_axis(Vector3::new(
                    rng.random_range(-0.8..0.8),
                    rng.random_range(-0.8..0.8),
                    rng.random_range(-0.8..0.8),
                ));
                Pose::from_parts(pose.translation, turn * pose.rotation)
            } else if round.is_multiple_of(3) {
                geometry.home_pose(&q)
            } else {
                let shift = Translation3::new(
                    rng.random_range(-1e-3..1e-3),
                    rng.random_range(-1e-3..1e-3),
                    rng.random_range(-1e-3..1e-3),
                );
                shift * pose
            };
            (q, start)
        })
        .collect()
}

/// What `forward_batch` gives a batch: every solution, or the first error
/// with its contact's index.
type LanesOutcome = Result<Vec<ForwardSolution>, (usize, KinematicsError)>;

/// Runs `forward_batch` on the contacts `(q, start)` (in SIMD lanes on a
/// machine with AVX2, for two contacts and more) and the scalar forward
/// kinematics on each; returns both solutions (or errors).
fn lanes_and_scalar(
    geometry: &Geometry,
    contacts: &[([f64; 6], Pose)],
    options: &ForwardOptions,
) -> (LanesOutcome, Vec<Result<ForwardSolution, KinematicsError>>) {
    let mut solutions: Vec<ForwardSolution> = contacts
        .iter()
        .map(|(_, start)| ForwardSolution {
            pose: *start,
            ..ForwardSolution::default()
        })
        .collect();
    let q: Vec<&[f64; 6]> = contacts.iter().map(|(q, _)| q).collect();
    let lanes = forward_batch(geometry, &q, options, &mut solutions, |s| s).map(|()| solutions);
    let scalar = contacts
        .iter()
        .map(|(q, start)| forward(geometry, q, start, options))
        .collect();
    (lanes, scalar)
}

/// The lanes' solution is the scalar one up to rounding: the pose, the
/// legs, the step count, and a factorisation that solves by the same
/// closure Jacobian.
fn assert_same_solution(lanes: &ForwardSolution, scalar: &ForwardSolution) {
    assert_eq!(lanes.iterations, scalar.iterations);
    assert_same_pose(&lanes.pose, &scalar.pose, "pose");
    for i in 0..6 {
        assert!((lanes.legs.length[i] - scalar.legs.length[i]).abs() < 1e-10);
        assert!((lanes.legs.direction[i] - scalar.legs.direction[i]).amax() < 1e-12);
        assert!((lanes.legs.rotated[i] - scalar.legs.rotated[i]).amax() < 1e-10);
    }
    let b = Vector6::new(1.0, -2.0, 0.5, 3.0, -0.25, 1.5);
    let x = scalar.factor.solve(&b);
    let y = scalar.factor.solve_transpose(&b);
    assert!((lanes.factor.solve(&b) - x).amax() < 1e-9 * x.amax());
    assert!((lanes.factor.solve_transpose(&b) - y).amax() < 1e-9 * y.amax());
}

/// What `forward_along_batch` gives a batch: every solution, or the first
/// error with its contact's index.
type AlongOutcome = Result<Vec<SolutionAlong>, (usize, KinematicsError)>;

/// Runs `forward_along_batch` on the contacts `(q, start)` along `dp`, the
/// rows first tried in the order `trial`, and `SolutionAlong::solve` on
/// each; returns both.
fn along_in_lanes_and_scalar(
    geometry: &Geometry,
    contacts: &[([f64; 6], Pose)],
    dp: &Params,
    options: &ForwardOptions,
    trial: &mut PivotOrder,
) -> (AlongOutcome, Vec<Result<SolutionAlong, KinematicsError>>) {
    let q: Vec<&[f64; 6]> = contacts.iter().map(|(q, _)| q).collect();
    let starts: Vec<Pose> = contacts.iter().map(|(_, start)| *start).collect();
    let mut out = vec![SolutionAlong::default(); contacts.len()];
    let lanes =
        forward_along_batch(geometry, &q, &starts, dp, options, trial, &mut out).map(|()| out);
    let scalar = contacts
        .iter()
        .map(|(q, start)| SolutionAlong::solve(geometry, q, start, dp, options))
        .collect();
    (lanes, scalar)
}

/// What `forward_jacobian_batch` gives a batch: every solution, or the first
/// error with its contact's index.
type JacobianOutcome = Result<Vec<SolutionJacobian>, (usize, KinematicsError)>;

/// Runs `forward_jacobian_batch` on the contacts `(q, start)`, the rows
/// first tried in the order `trial`, and `SolutionJacobian::solve` on each;
/// returns both.
fn jacobian_in_lanes_and_scalar(
    geometry: &Geometry,
    contacts: &[([f64; 6], Pose)],
    options: &ForwardOptions,
    trial: &mut PivotOrder,
) -> (
    JacobianOutcome,
    Vec<Result<SolutionJacobian, KinematicsError>>,
) {
    let q: Vec<&[f64; 6]> = contacts.iter().map(|(q, _)| q).collect();
    let starts: Vec<Pose> = contacts.iter().map(|(_, start)| *start).collect();
    let mut out = vec![SolutionJacobian::default(); contacts.len()];
    let lanes = forward_jacobian_batch(geometry, &q, &starts, options, trial, &mut out, |s| s)
        .map(|()| out);
    let scalar = contacts
        .iter()
        .map(|(q, start)| SolutionJacobian::solve(geometry, q, start, options))
        .collect();
    (lanes, scalar)
}

/// `|a - b| <= tolerance max |b|`, entry by entry.
fn assert_close(a: &[f64], b: &[f64], tolerance: f64, what: &str) {
    let scale = b.iter().fold(0.0_f64, |m, x| m.max(x.abs()));
    for (x, y) in a.iter().zip(b) {
        assert!(
            (x - y).abs() <= tolerance * scale,
            "{what}: {a:?} against {b:?}"
        );
    }
}

/// Two poses agree to rounding.
fn assert_same_pose(a: &Pose, b: &Pose, what: &str) {
    let shift = (a.translation.vector - b.translation.vector).amax();
    let turn = a.rotation.angle_to(&b.rotation);
    assert!(
        shift < 1e-10 && turn < 1e-12,
        "{what} differs by {shift:e} mm, {turn:e} rad"
    );
}

#[test]
fn forward_kinematics_in_lanes_is_the_scalar_iteration() {
    let mut rng = StdRng::seed_from_u64(1158);
    let options = ForwardOptions::default();
    let geometry = paper::truth();
    let mut histogram = [0; 8];
    for round in 0..400 {
        let contacts = random_batch(&mut rng, &geometry, round);
        let (lanes, scalar) = lanes_and_scalar(&geometry, &contacts, &options);
        for (lanes, scalar) in lanes
            .expect("forward kinematics in lanes")
            .iter()
            .zip(scalar)
        {
            let scalar = scalar.expect("scalar forward kinematics");
            histogram[scalar.iterations.min(7)] += 1;
            assert_same_solution(lanes, &scalar);
        }
    }
    // Every regime was exercised.
    assert!(
        histogram[2] > 100 && histogram[4] > 100 && histogram[5..].iter().sum::<usize>() > 10,
        "step counts {histogram:?}"
    );
}

/// Runs `check` on 400 random batches (`random_batch`) of the true
/// geometry, with one row order carried from batch to batch, and checks
/// that most of them ran in lanes (several contacts).
fn over_random_batches(
    seed: u64,
    mut check: impl FnMut(&mut StdRng, &Geometry, &[([f64; 6], Pose)], &mut PivotOrder),
) {
    let mut rng = StdRng::seed_from_u64(seed);
    let geometry = paper::truth();
    let mut trial = PivotOrder::default();
    let mut several = 0;
    for round in 0..400 {
        let contacts = random_batch(&mut rng, &geometry, round);
        check(&mut rng, &geometry, &contacts, &mut trial);
        several += usize::from(contacts.len() > 1);
    }
    assert!(several >= 300, "{several} batches in lanes");
}

#[test]
fn change_along_parameters_in_lanes_is_the_scalar_one() {
    let options = ForwardOptions::default();
    over_random_batches(2004, |rng, geometry, contacts, trial| {
        let dp = Params::from_fn(|_, _| rng.random_range(-1e-2..1e-2));
        let (lanes, scalar) = along_in_lanes_and_scalar(geometry, contacts, &dp, &options, trial);
        for (lanes, scalar) in lanes.expect("lanes").iter().zip(scalar) {
            let scalar = scalar.expect("scalar");
            assert_eq!(lanes.iterations, scalar.iterations);
            assert_same_pose(&lanes.pose, &scalar.pose, "pose");
            assert_same_pose(&lanes.predicted, &scalar.predicted, "predicted pose");
            // The lanes rotate the tool as nalgebra does: the same bits.
            assert_eq!(lanes.tool_tip, geometry.tool_tip(&lanes.pose));
            assert_eq!(scalar.tool_tip, geometry.tool_tip(&scalar.pose));
            let miss = (lanes.tip - scalar.tip).amax();
            assert!(
                miss <= 1e-9 * scalar.tip.amax(),
                "J_f dp {} against {}",
                lanes.tip,
                scalar.tip
            );
            // The change is not trivial: a step of 1e-2 moves the tip.
            assert!(scalar.tip.amax() > 1e-4, "{}", scalar.tip);
        }
    });
}

#[test]
fn factored_tip_jacobian_in_lanes_is_the_scalar_one() {
    let options = ForwardOptions::default();
    over_random_batches(1158_2004, |_, geometry, contacts, trial| {
        let (lanes, scalar) = jacobian_in_lanes_and_scalar(geometry, contacts, &options, trial);
        for (lanes, scalar) in lanes.expect("lanes").iter().zip(scalar) {
            let scalar = scalar.expect("scalar");
            assert_eq!(lanes.iterations, scalar.iterations);
            assert_same_pose(&lanes.pose, &scalar.pose, "pose");
            assert_eq!(lanes.tool_tip, geometry.tool_tip(&lanes.pose));
            assert_eq!(scalar.tool_tip, geometry.tool_tip(&scalar.pose));
            let (a, b) = (&lanes.jacobian, &scalar.jacobian);
            assert_close(a.weights.as_slice(), b.weights.as_slice(), 1e-9, "K^T");
            assert_close(a.rotation.as_slice(), b.rotation.as_slice(), 1e-12, "R");
            for (n, m) in a.directions.iter().zip(&b.directions) {
                assert_close(n.as_slice(), m.as_slice(), 1e-12, "n_i");
            }
            // `R^T n_i` made in the lanes as the scalar code makes it, to
            // the bit.
            for jacobian in [a, b] {
                let platform = FactoredTipJacobian::platform_directions(
                    &jacobian.rotation,
                    &jacobian.directions,
                );
                assert_eq!(jacobian.platform_directions, platform, "R^T n_i");
            }
        }
    });
}

/// The factored `J_f` combines rows and takes products as the
/// derivatives with their LU do.
#[test]
fn factored_tip_jacobian_is_the_tip_derivatives() {
    let mut rng = StdRng::seed_from_u64(33);
    let options = ForwardOptions::default();
    let geometry = paper::truth();
    for _ in 0..50 {
        let pose = workspace_pose(&mut rng, &geometry, 10.0);
        let q = actuators(&geometry, &pose);
        let mut derivatives = TipDerivatives::default();
        derivatives
            .forward(&geometry, &q, &geometry.home_pose(&q), &options)
            .unwrap();
        let factored = derivatives.factored();
        let h = Vec3::new(
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
        );
        let (mut a, mut b) = ([0.0; N_PARAMS], [0.0; N_PARAMS]);
        factored.params_row(&h, &mut a);
        derivatives.params_row(&h, &mut b);
        assert_close(&a, &b, 1e-12, "h^T J_f");
        // Held in values in the order of its fields, as its doc says.
        let mut values = [0.0; FactoredTipJacobian::VALUES];
        *FactoredTipJacobian::in_values_mut(&mut values) = factored;
        assert_eq!(&values[..18], factored.weights.as_slice(), "K^T first");
        assert_eq!(&values[18..27], factored.rotation.as_slice(), "then R");
        assert_eq!(
            &values[27..30],
            factored.directions[0].as_slice(),
            "then n_1"
        );
        let last = factored.platform_directions[5];
        assert_eq!(&values[60..], last.as_slice(), "R^T n_6 last");
        assert_eq!(FactoredTipJacobian::in_values(&values), &factored);
        let dp = Params::from_fn(|_, _| rng.random_range(-1.0..1.0));
        let along = derivatives.along(&dp).tip;
        assert_close(
            factored.along(&dp).as_slice(),
            along.as_slice(),
            1e-12,
            "J_f dp",
        );
        // `K^T` is `dT/dq` transposed.
        let d_q = derivatives.d_q();
        assert_close(
            factored.weights.transpose().as_slice(),
            d_q.as_slice(),
            1e-12,
            "K",
        );
    }
}

#[test]
fn forward_kinematics_in_lanes_reports_the_first_failing_contact() {
    let geometry = paper::design();
    let options = ForwardOptions::default();
    let home = geometry.home_pose(&[0.0; 6]);
    let mut infeasible = [100.0; 6];
    infeasible[2] = -300.0;
    let mut nan = [100.0; 6];
    nan[4] = f64::NAN;
    let mut infinite = [100.0; 6];
    infinite[0] = f64::INFINITY;
    let good = [120.0; 6];
    // Legs too long to close: the scalar iteration's error, in lane 1.
    let far = [1.0e4, 0.0, 0.0, 0.0, 0.0, 0.0];
    // Up to four contacts in the lanes of one AVX2 kernel, five to eight in
    // an AVX-512 kernel's (or two AVX2 kernels').
    let cases: [(&[[f64; 6]], usize); 8] = [
        (&[good, infeasible, nan], 1),
        (&[good, good, nan, infeasible], 2),
        (&[good, far, infeasible], 1),
        (&[good, good, good, infinite], 3),
        (&[infeasible], 0),
        (&[good, good, good, good, good, nan, infeasible], 5),
        (&[good, good, good, good, far, good, good, good], 4),
        (
            &[good, good, infinite, good, good, good, good, infeasible],
            2,
        ),
    ];
    let dp = Params::repeat(1e-3);
    let mut trial = PivotOrder::default();
    for (batch, first) in cases {
        let contacts: Vec<_> = batch.iter().map(|q| (*q, home)).collect();
        let (lanes, scalar) = lanes_and_scalar(&geometry, &contacts, &options);
        let (lane, error) = lanes.expect_err("a failing contact");
        assert_eq!(lane, first);
        assert_eq!(
            Err(error.clone()),
            scalar[first].as_ref().map(|_| ()).map_err(Clone::clone)
        );
        // The same contact and error with the change along parameters.
        let (along, _) = along_in_lanes_and_scalar(&geometry, &contacts, &dp, &options, &mut trial);
        assert_eq!(along.expect_err("a failing contact"), (first, error));
    }
    // The iteration limit and a singular configuration, as in the scalar
    // iteration.
    let few = ForwardOptions {
        max_iterations: 1,
        ..options
    };
    let two = [(good, home), (good, home)];
    let (lanes, _) = lanes_and_scalar(&geometry, &two, &few);
    let (_, error) = lanes.expect_err("not converged in one step");
    assert!(
        matches!(error, KinematicsError::NotConverged { iterations: 1, .. }),
        "{error}"
    );
    let (along, _) = along_in_lanes_and_scalar(&geometry, &two, &dp, &few, &mut trial);
    assert_eq!(along.expect_err("not converged in one step").1, error);
    let (jacobian, _) = jacobian_in_lanes_and_scalar(&geometry, &two, &few, &mut trial);
    assert_eq!(jacobian.expect_err("not converged in one step").1, error);
    let (singular, upright) = singular_configuration(&geometry);
    let contacts = [(good, home), ([-30.0; 6], upright)];
    let (lanes, _) = lanes_and_scalar(&singular, &contacts, &options);
    assert_eq!(
        lanes.expect_err("singular").1,
        KinematicsError::SingularJacobian
    );
    let (along, _) = along_in_lanes_and_scalar(&singular, &contacts, &dp, &options, &mut trial);
    assert_eq!(
        along.expect_err("singular").1,
        KinematicsError::SingularJacobian
    );
    let (jacobian, _) = jacobian_in_lanes_and_scalar(&singular, &contacts, &options, &mut trial);
    assert_eq!(
        jacobian.expect_err("singular").1,
        KinematicsError::SingularJacobian
    );
}
