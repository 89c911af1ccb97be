//! Numerical checks of the kinematics: inverse then forward kinematics over
//! the workspace, analytic derivatives against central differences, and the
//! canonical frames' invariance to rigid motions of the input frame.

use nalgebra::{Isometry3, Translation3, UnitQuaternion, Vector3, Vector6};
use parcal_kinematics::lanes::forward_batch;
use parcal_kinematics::{
    ForwardOptions, ForwardSolution, Geometry, KinematicsError, Params, Pose, TipDerivatives, Vec3,
    actuators, forward, forward_from_home, paper, params, rotation_zyx, tip_jacobians,
};

/// SplitMix64: a tiny deterministic generator for test poses.
struct Rng(u64);

impl Rng {
    fn uniform(&mut self, low: f64, high: f64) -> f64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^= z >> 31;
        low + (high - low) * (z >> 11) as f64 / (1u64 << 53) as f64
    }
}

/// A random pose of the design-frame workspace: tilt angles up to
/// `max_tilt` degrees, the tool tip in x, y in [-80, 80], z in [340, 460].
fn workspace_pose(rng: &mut Rng, geometry: &Geometry, max_tilt: f64) -> Pose {
    let tilt = max_tilt.to_radians();
    let rotation = rotation_zyx(
        rng.uniform(-tilt, tilt),
        rng.uniform(-tilt, tilt),
        rng.uniform(-tilt, tilt),
    );
    let tip = Vec3::new(
        rng.uniform(-80.0, 80.0),
        rng.uniform(-80.0, 80.0),
        rng.uniform(340.0, 460.0),
    );
    Pose::from_parts(Translation3::from(tip - rotation * geometry.tool), rotation)
}

#[test]
fn inverse_then_forward_returns_the_pose_over_the_workspace() {
    let mut rng = Rng(2004);
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
    let mut rng = Rng(7);
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
    let mut rng = Rng(11);
    let truth = paper::truth();
    let reference = truth.canonicalize().unwrap();
    for _ in 0..50 {
        let mut random_motion = || {
            let axis = Vector3::new(
                rng.uniform(-1.0, 1.0),
                rng.uniform(-1.0, 1.0),
                rng.uniform(-1.0, 1.0),
            );
            // Keep +z on the same side: tilts below 60 degrees.
            let rotation =
                UnitQuaternion::from_scaled_axis(axis.normalize() * rng.uniform(-1.0, 1.0));
            let shift = Translation3::new(
                rng.uniform(-500.0, 500.0),
                rng.uniform(-500.0, 500.0),
                rng.uniform(-500.0, 500.0),
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
    let mut rng = Rng(23);
    let design = paper::design();
    let canonical = paper::truth().canonicalize().unwrap();
    for _ in 0..50 {
        let pose = canonical.pose_from_input(&workspace_pose(&mut rng, &design, 15.0));
        let q = actuators(&canonical.geometry, &pose);
        let solution = forward(&canonical.geometry, &q, &pose, &ForwardOptions::default()).unwrap();
        let dp = Params::from_fn(|_, _| rng.uniform(-1.0, 1.0));
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
    let mut rng = Rng(31);
    let geometry = paper::truth();
    let options = ForwardOptions::default();
    for _ in 0..50 {
        let pose = workspace_pose(&mut rng, &geometry, 15.0);
        let q = actuators(&geometry, &pose);
        let mut derivatives = TipDerivatives::default();
        derivatives.forward(&geometry, &q, &pose, &options).unwrap();
        let direction = nalgebra::Vector6::from_fn(|_, _| rng.uniform(-1.0, 1.0));
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
    let shift = (lanes.pose.translation.vector - scalar.pose.translation.vector).amax();
    let turn = lanes.pose.rotation.angle_to(&scalar.pose.rotation);
    assert!(
        shift < 1e-10 && turn < 1e-12,
        "pose differs by {shift:e} mm, {turn:e} rad"
    );
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

#[test]
fn forward_kinematics_in_lanes_is_the_scalar_iteration() {
    let mut rng = Rng(1158);
    let options = ForwardOptions::default();
    let geometry = paper::truth();
    let mut histogram = [0; 8];
    for round in 0..400 {
        // Batches of 1 to 4 contacts, started one iteration away (a small
        // pose error, two Newton steps), from the home pose (four steps), or
        // turned by up to 80 degrees (five steps and more; the scalar
        // iteration halves some of them, and the lanes hand those contacts
        // over to it).
        let contacts: Vec<([f64; 6], Pose)> = (0..round % 4 + 1)
            .map(|_| {
                let pose = workspace_pose(&mut rng, &geometry, 10.0);
                let q = actuators(&geometry, &pose);
                let start = if round % 5 == 0 {
                    let turn = UnitQuaternion::from_scaled_axis(Vector3::new(
                        rng.uniform(-0.8, 0.8),
                        rng.uniform(-0.8, 0.8),
                        rng.uniform(-0.8, 0.8),
                    ));
                    Pose::from_parts(pose.translation, turn * pose.rotation)
                } else if round % 3 == 0 {
                    geometry.home_pose(&q)
                } else {
                    let shift = Translation3::new(
                        rng.uniform(-1e-3, 1e-3),
                        rng.uniform(-1e-3, 1e-3),
                        rng.uniform(-1e-3, 1e-3),
                    );
                    shift * pose
                };
                (q, start)
            })
            .collect();
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

#[test]
fn forward_kinematics_in_lanes_reports_the_first_failing_contact() {
    let geometry = paper::design();
    let options = ForwardOptions::default();
    let home = geometry.home_pose(&[0.0; 6]);
    let mut infeasible = [100.0; 6];
    infeasible[2] = -300.0;
    let mut nan = [100.0; 6];
    nan[4] = f64::NAN;
    let good = [120.0; 6];
    // Legs too long to close: the scalar iteration's error, in lane 1.
    let far = [1.0e4, 0.0, 0.0, 0.0, 0.0, 0.0];
    let cases: [(&[[f64; 6]], usize); 4] = [
        (&[good, infeasible, nan], 1),
        (&[good, good, nan, infeasible], 2),
        (&[good, far, infeasible], 1),
        (&[infeasible], 0),
    ];
    for (batch, first) in cases {
        let contacts: Vec<_> = batch.iter().map(|q| (*q, home)).collect();
        let (lanes, scalar) = lanes_and_scalar(&geometry, &contacts, &options);
        let (lane, error) = lanes.expect_err("a failing contact");
        assert_eq!(lane, first);
        assert_eq!(
            Err(error),
            scalar[first].as_ref().map(|_| ()).map_err(Clone::clone)
        );
    }
    // The iteration limit and a singular configuration, as in the scalar
    // iteration.
    let few = ForwardOptions {
        max_iterations: 1,
        ..options
    };
    let (lanes, _) = lanes_and_scalar(&geometry, &[(good, home), (good, home)], &few);
    let (_, error) = lanes.expect_err("not converged in one step");
    assert!(
        matches!(error, KinematicsError::NotConverged { iterations: 1, .. }),
        "{error}"
    );
    let (singular, upright) = singular_configuration(&geometry);
    let (lanes, _) = lanes_and_scalar(&singular, &[(good, home), ([-30.0; 6], upright)], &options);
    assert_eq!(
        lanes.expect_err("singular").1,
        KinematicsError::SingularJacobian
    );
}
