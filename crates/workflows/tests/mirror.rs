//! A ball whose contacts lie on a band of its sphere has two centre fits,
//! mirror images through the band's plane, and with the design geometry the
//! wrong one can fit best. The calibration finds such a ball on the wrong
//! side once Gauss-Newton has settled, re-seeds it at the mirror image and
//! resumes: the ball ends on the right side, fitting its contacts.

use nalgebra::Translation3;
use parcal_calibrate::mirror::SETTLED;
use parcal_calibrate::setup::{Observations, Setup};
use parcal_calibrate::{CalibrationOptions, PriorMode, Simulation, calibrate};
use parcal_dataset::Dataset;
use parcal_kinematics::{Pose, Vec3, inverse::actuators, rotation_zyx};
use parcal_simulate::{Scenario, simulate};
use parcal_workflows::evaluate::TrueMachine;

fn options() -> CalibrationOptions {
    CalibrationOptions {
        prior: PriorMode::Propagated,
        ..CalibrationOptions::simulation(Simulation::IV)
    }
}

/// The paper campaign (seed 1) with the contacts of ball `ball` replaced by
/// noise-free touches of the true machine on a band just below its equator
/// (heights -0.10, -0.11 and -0.12 radii), the platform tilted over the
/// scenario's range as in the campaign.
fn with_band(scenario: &Scenario, ball: usize) -> Dataset {
    with_touches(scenario, 1, ball, |j| {
        (-0.1 - 0.01 * (j % 3) as f64, 0.9 * j as f64, 0.0)
    })
}

/// The paper campaign of `seed` with the contacts of ball `ball` replaced
/// by noise-free touches of the true machine, touch `j` at the height
/// (in radii) and azimuth `at(j)` on the ball, the platform tilted over
/// the scenario's range as in the campaign.
fn with_touches(
    scenario: &Scenario,
    seed: u64,
    ball: usize,
    at: impl Fn(usize) -> (f64, f64, f64),
) -> Dataset {
    let mut dataset = simulate(scenario, seed).unwrap().dataset;
    let rows = (0..dataset.measurements.ball.len())
        .filter(|&row| dataset.measurements.ball[row] as usize == ball)
        .collect::<Vec<_>>();
    let truth = &scenario.truth;
    for (j, row) in rows.into_iter().enumerate() {
        let (height, azimuth, off) = at(j);
        let across = (1.0 - height * height).sqrt();
        let direction = Vec3::new(across * azimuth.cos(), across * azimuth.sin(), height);
        let tip = scenario.centres[ball] + (scenario.radius + off) * direction;
        let tilt = |phase: f64| scenario.max_tilt * (2.1 * j as f64 + phase).sin();
        let rotation = rotation_zyx(tilt(0.0), tilt(1.7), tilt(3.1));
        let pose = Pose::from_parts(Translation3::from(tip - rotation * truth.tool), rotation);
        dataset.measurements.q[row] = actuators(truth, &pose);
    }
    dataset
}

#[test]
fn a_ball_started_on_the_wrong_side_is_re_seeded_and_ends_right() {
    let scenario = Scenario::paper();
    let ball = 1;
    let dataset = with_band(&scenario, ball);

    // The set-up's best fit puts the centre below the band: the initial
    // directions point up, the true ones down.
    let (setup, observations) = Setup::new(&dataset, &options()).unwrap();
    let Observations::Coordinates(observations) = observations else {
        unreachable!("simulation IV uses the coordinate observation")
    };
    let contacts = setup.groups[ball].clone();
    let up = contacts
        .clone()
        .map(|i| observations.directions[i].z)
        .sum::<f64>();
    assert!(up > 0.0, "the start is on the right side already ({up})");

    let run = calibrate(&dataset, &options(), &mut |_| {}).unwrap();
    assert!(run.converged(), "{:?}", run.status);
    let mirrored: Vec<usize> = run.balls.mirrored.iter().map(|m| m.ball).collect();
    assert_eq!(mirrored, [ball]);
    let side = &run.balls.mirrored[0].side;
    // Ten times the mean of chi-square(4) and more; the mirror image fits
    // the calibrated contact points ten times better and more.
    assert!(side.chi_square > 40.0, "{side:?}");
    assert!(side.mirror.cost * 10.0 < side.side.cost, "{side:?}");
    assert!(run.balls.misfits.is_empty(), "{:?}", run.balls.misfits);
    // Found at the first settled iterate, long before the run converged:
    // the iterate before it still moved the cost by more than SETTLED.
    let at = run.balls.mirrored[0].iteration;
    let (before, last) = (&run.history[at - 2], &run.history[at - 1]);
    assert!(
        (before.cost - last.cost).abs() > SETTLED * last.cost,
        "{before:?} then {last:?}"
    );
    assert!(at + 3 < run.iterations(), "{at} of {}", run.iterations());

    // Its centre (canonical frames) within 4 sigma of the truth, on the
    // right side: the initial centre was about 1.1 mm below it.
    let truth = TrueMachine::of(&dataset).unwrap().unwrap();
    let sigmas = run.balls.centre_sigmas.as_ref().unwrap()[ball];
    let error = run.balls.centres[ball] - truth.centres[ball];
    for axis in 0..3 {
        assert!(
            error[axis].abs() < 4.0 * sigmas[axis],
            "axis {axis}: error {error:?} against sigmas {sigmas:?}"
        );
    }
    // The re-seeded initial centre is the one recorded.
    assert_ne!(
        run.balls.mirrored[0].initial_centre,
        setup.initial_centres[ball]
    );
}

#[test]
fn the_two_solves_share_the_iteration_limit() {
    let scenario = Scenario::paper();
    let dataset = with_band(&scenario, 1);
    let options = CalibrationOptions {
        max_iterations: 5,
        ..options()
    };
    let run = calibrate(&dataset, &options, &mut |_| {}).unwrap();
    assert_eq!(run.balls.mirrored.len(), 1);
    assert!(run.balls.mirrored[0].iteration < 5);
    assert_eq!(run.status, parcal_solver::Status::IterationLimit);
    assert_eq!(run.iterations(), 5);
}

/// A validation locates each ball's centre on its first 4 touches. Ball
/// 1's first 4 lie on one circle 0.2 radii below its equator, off the
/// sphere by 1 um (the first outwards, the others inwards): their best
/// fit is the centre's mirror image through their plane, 0.4 radii below
/// it. Its other 3 touches are high on the ball, which only the true side
/// fits. Through the hexapod's own validation and through the common
/// path's, the ball is located on the true side and named, and the
/// campaign is predicted as well as the calibration says.
#[test]
fn a_validation_locates_a_ball_whose_reference_touches_fit_its_mirror_image() {
    use parcal_calibrate::mechanism::{
        CalibratedMechanism, MechanismData, MechanismOptions, calibrate_mechanism,
        validate_mechanism,
    };
    use parcal_calibrate::sphere_fit::best_fit;
    use parcal_calibrate::validate_touches;
    use parcal_kinematics::forward_from_home;
    let scenario = Scenario::paper();
    let ball = 1;
    let fitted = simulate(&scenario, 1).unwrap().dataset;
    let other = with_touches(&scenario, 2, ball, |j| match j {
        0 => (-0.2, 0.0, 0.001),
        1..4 => (-0.2, 1.6 * j as f64, -0.001),
        _ => (0.6 + 0.1 * (j - 4) as f64, 2.0 * j as f64, 0.0),
    });
    // The reference touches' best fit, at the true geometry, is the
    // mirror image, 2 x 0.2 radii below the centre.
    let tips: Vec<Vec3> = (0..other.measurements.ball.len())
        .filter(|&row| other.measurements.ball[row] as usize == ball)
        .take(4)
        .map(|row| {
            let q = &other.measurements.q[row];
            let solution = forward_from_home(&scenario.truth, q, &Default::default()).unwrap();
            scenario.truth.tool_tip(&solution.pose)
        })
        .collect();
    let reference_fit = best_fit(&tips, scenario.radius).unwrap();
    let above = reference_fit.centre - scenario.centres[ball];
    assert!((above.z / scenario.radius + 0.4).abs() < 0.01, "{above:?}");

    let run = calibrate(&fitted, &options(), &mut |_| {}).unwrap();
    let validation = validate_touches(&other, &run.record(String::new()), Some(4)).unwrap();
    let id = &other.artefacts.balls[ball].id;
    assert_eq!(validation.mirrored_balls, std::slice::from_ref(id));
    assert!(validation.accepted(), "{:?}", validation.test());

    let data = MechanismData::from_hexapod_touches(&fitted, &options()).unwrap();
    let calibration =
        calibrate_mechanism(&data, &MechanismOptions::default(), &mut |_| {}).unwrap();
    let calibrated = CalibratedMechanism::of_calibration(&calibration).unwrap();
    let held_out = MechanismData::hexapod_held_out(&other).unwrap();
    let common = validate_mechanism(&calibrated, &held_out, 0.05, Some(4)).unwrap();
    assert_eq!(common.mirrored_balls, [ball]);
    assert!(common.accepted(), "{:?}", common.test);
}
