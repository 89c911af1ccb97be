//! The cable robot's quantities (the line lengths at the encoder zero) and
//! its elastic lines (`parcal_kinematics::cable::elasticity`): analytic
//! derivatives against central differences, the rigid model under the
//! encoder zero's loads, the forward kinematics under loads.

use nalgebra::DVector;
use parcal_kinematics::cable::{CableDesignError, CableRobot, Elasticity};
use parcal_kinematics::mechanism::{Mechanism, design, forward_under_loads};
use rand::rngs::StdRng;
use rand::{RngExt, SeedableRng};

/// The Hangprinter with elastic lines, one compliance per line or one
/// shared, about the source's 20000 N stiffness (50 um/m/N).
fn elastic(compliance_of_line: Vec<usize>) -> CableRobot {
    CableRobot::typical()
        .with_elasticity(Elasticity {
            compliance_of_line,
            zero_loads: vec![13.7, 14.5, 14.1, 12.5],
            compliance: 50.0,
            compliance_sigma: 50.0,
        })
        .unwrap()
}

/// A machine off its design by up to 80 mm in the anchors, 1 mm in the
/// radii, 2 mm in the encoder zero and 20 um/m/N in the compliances.
fn perturbed(robot: &CableRobot, rng: &mut StdRng) -> DVector<f64> {
    let mut p = design(robot);
    for (value, parameter) in p.iter_mut().zip(robot.parameters()) {
        let scale = match parameter.group {
            "anchors" => 80.0,
            "spool radii" => 1.0,
            "line compliance" => 20.0,
            _ => 2.0,
        };
        *value += rng.random_range(-scale..scale);
    }
    p
}

fn random_pose(rng: &mut StdRng) -> [f64; 3] {
    [
        rng.random_range(-500.0..500.0),
        rng.random_range(-500.0..500.0),
        rng.random_range(0.0..1500.0),
    ]
}

fn random_loads(rng: &mut StdRng) -> [f64; 4] {
    [(); 4].map(|_| rng.random_range(5.0..40.0))
}

#[test]
fn line_length_derivatives_match_central_differences() {
    let robot = CableRobot::typical();
    let names: Vec<&str> = robot.quantities().iter().map(|q| q.name.as_str()).collect();
    assert_eq!(
        names,
        [
            "line_length_a",
            "line_length_b",
            "line_length_c",
            "line_length_d"
        ]
    );
    let mut rng = StdRng::seed_from_u64(3);
    for _ in 0..20 {
        let p = perturbed(&robot, &mut rng);
        for j in 0..4 {
            let value = robot.quantity(j, p.as_slice()).unwrap();
            let anchor = robot.anchor(p.as_slice(), j);
            let zero = robot.encoder_zero(p.as_slice());
            assert!((value.value - (anchor - zero).norm()).abs() < 1e-9);
            // Steps of 0.01 mm on a length of ~2000 mm: truncation
            // h^2/6 / L^2 ~ 1e-11, rounding 1e-16 * 2000 / h ~ 2e-11.
            let numeric = DVector::from_fn(p.len(), |k, _| {
                let (mut plus, mut minus) = (p.clone(), p.clone());
                plus[k] += 1e-2;
                minus[k] -= 1e-2;
                (robot.quantity(j, plus.as_slice()).unwrap().value
                    - robot.quantity(j, minus.as_slice()).unwrap().value)
                    / 2e-2
            });
            let error = (&value.gradient - &numeric).amax();
            assert!(error < 1e-8, "line {j}: {error:e}");
        }
    }
    let error = robot.quantity(4, design(&robot).as_slice()).unwrap_err();
    assert!(error.to_string().contains("quantity 4"), "{error}");
}

#[test]
fn loaded_reading_derivatives_match_central_differences() {
    for lines in [vec![0, 1, 2, 3], vec![0; 4]] {
        let robot = elastic(lines);
        let mut rng = StdRng::seed_from_u64(11);
        for _ in 0..30 {
            let p = perturbed(&robot, &mut rng);
            let pose = random_pose(&mut rng);
            let loads = random_loads(&mut rng);
            let at = |p: &[f64], x: &[f64]| robot.loaded_readings(p, x, &loads).unwrap();
            let (_, analytic) = at(p.as_slice(), &pose);
            // Steps as the rigid model's test (cable.rs): 0.01 mm, 1e-3 mm
            // on the radii; the readings are linear in a compliance.
            for k in 0..p.len() {
                let h = if robot.parameters()[k].group == "spool radii" {
                    1e-3
                } else {
                    1e-2
                };
                let (mut plus, mut minus) = (p.clone(), p.clone());
                plus[k] += h;
                minus[k] -= h;
                let column =
                    (at(plus.as_slice(), &pose).0 - at(minus.as_slice(), &pose).0) / (2.0 * h);
                let error = (analytic.d_params.column(k) - column).amax();
                assert!(error < 1e-6, "{}: {error:e}", robot.parameters()[k].name);
            }
            for axis in 0..3 {
                let (mut plus, mut minus) = (pose, pose);
                plus[axis] += 1e-2;
                minus[axis] -= 1e-2;
                let column = (at(p.as_slice(), &plus).0 - at(p.as_slice(), &minus).0) / 2e-2;
                let error = (analytic.d_pose.column(axis) - column).amax();
                assert!(error < 1e-8, "pose {axis}: {error:e}");
            }
        }
    }
}

#[test]
fn loads_change_the_readings_by_the_stretch_beyond_the_encoder_zero() {
    let robot = elastic(vec![0, 0, 0, 0]);
    let rigid = CableRobot::typical();
    let p = design(&robot);
    let n = rigid.parameters().len();
    let pose = [200.0, -100.0, 600.0];
    // Under the encoder zero's loads: the rigid model's readings and
    // derivatives, and no derivative by the compliance.
    let zero_loads = robot.elasticity().unwrap().zero_loads.clone();
    let (q, jacobians) = robot
        .loaded_readings(p.as_slice(), &pose, &zero_loads)
        .unwrap();
    let q_rigid = rigid.inverse(&p.as_slice()[..n], &pose).unwrap();
    assert!((&q - &q_rigid).amax() < 1e-9, "{q} vs {q_rigid}");
    assert!(jacobians.d_params.column(n).amax() == 0.0);
    // 10 N more on line A only: the encoder sees A shorter by
    // c dF L = 50e-6 * 10 * L, converted by the paid-out formula.
    let mut loads = zero_loads.clone();
    loads[0] += 10.0;
    let (q, _) = robot.loaded_readings(p.as_slice(), &pose, &loads).unwrap();
    let paid = robot.paid_out(p.as_slice(), q.as_slice()).unwrap();
    let rigid_paid = rigid.line_changes(&p.as_slice()[..n], &pose).unwrap();
    let length = (robot.anchor(p.as_slice(), 0) - nalgebra::Vector3::from(pose)).norm();
    assert!((rigid_paid[0] - paid[0] - 50e-6 * 10.0 * length).abs() < 1e-9);
    assert!((1..4).all(|j| (paid[j] - rigid_paid[j]).abs() < 1e-9));
}

#[test]
fn forward_under_loads_inverts_the_loaded_readings() {
    let robot = elastic(vec![0, 1, 2, 3]);
    let mut rng = StdRng::seed_from_u64(5);
    for _ in 0..20 {
        let p = perturbed(&robot, &mut rng);
        let pose = random_pose(&mut rng);
        let loads = random_loads(&mut rng);
        let (q, _) = robot.loaded_readings(p.as_slice(), &pose, &loads).unwrap();
        let back = forward_under_loads(&robot, p.as_slice(), q.as_slice(), &loads, &[0.0; 3], 1e-9)
            .unwrap();
        let error = (back - DVector::from_column_slice(&pose)).amax();
        assert!(error < 1e-7, "{error:e}");
    }
    // A line's load that is not positive is a slack line's: refused, by
    // its line.
    let p = design(&robot);
    let error = robot
        .loaded_readings(p.as_slice(), &[0.0, 0.0, 300.0], &[10.0, 10.0, 0.0, 10.0])
        .unwrap_err();
    assert!(error.to_string().contains("line C's load, 0 N"), "{error}");
    // A mechanism without a load model says so.
    let delta = parcal_kinematics::delta::LinearDelta::typical();
    let p = design(&delta);
    let error = delta
        .loaded_readings(p.as_slice(), &[0.0, 0.0, 50.0], &[1.0; 3])
        .unwrap_err();
    assert!(error.to_string().contains("no load model"), "{error}");
}

#[test]
fn elasticity_options_that_do_not_fit_are_named() {
    let option = |compliance_of_line: Vec<usize>, zero_loads: Vec<f64>, sigma: f64| Elasticity {
        compliance_of_line,
        zero_loads,
        compliance: 50.0,
        compliance_sigma: sigma,
    };
    let refused = |elasticity: Elasticity| match CableRobot::typical().with_elasticity(elasticity) {
        Err(CableDesignError::Elasticity(message)) => message,
        other => panic!("{other:?}"),
    };
    assert!(refused(option(vec![0; 3], vec![1.0; 4], 1.0)).contains("3 values for 4 lines"));
    // The index left out, as the option counts them (from 0).
    let gap = refused(option(vec![0, 2, 2, 2], vec![1.0; 4], 1.0));
    assert!(gap.contains("no line has compliance index 1"), "{gap}");
    assert!(refused(option(vec![0; 4], vec![1.0, f64::NAN, 1.0, 1.0], 1.0)).contains("NaN"));
    let slack = refused(option(vec![0; 4], vec![1.0, -2.0, 1.0, 1.0], 1.0));
    assert!(slack.contains("-2 N, is not positive"), "{slack}");
    assert!(refused(option(vec![0; 4], vec![1.0; 4], 0.0)).contains("sigma"));
    let twice = elastic(vec![0; 4]).with_elasticity(option(vec![0; 4], vec![1.0; 4], 1.0));
    assert!(matches!(twice, Err(CableDesignError::Elasticity(_))));
    let names: Vec<String> = elastic(vec![0, 0, 0, 1]).parameters()[19..]
        .iter()
        .map(|p| p.name.clone())
        .collect();
    assert_eq!(names, ["compliance_abc", "compliance_d"]);
}
