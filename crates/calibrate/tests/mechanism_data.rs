//! A mechanism calibration's data: errors that name the observation or
//! the parameter, the options' checks, and the dataset and calibration
//! record through their files.

use std::sync::Arc;

use parcal_calibrate::mechanism::{
    Ball, MAX_TIED_BALLS, MechanismCalibrationError, MechanismData, MechanismOptions, Observations,
    calibrate_mechanism,
};
use parcal_calibrate::{HUBER_K, Loss, Method};
use parcal_dataset::mechanism::{MechanismCalibrationRecord, MechanismDataset};
use parcal_dataset::{Calibration, Dataset};
use parcal_kinematics::delta::{LinearDelta, probe_rings};
use parcal_kinematics::mechanism::design;
use parcal_observe::mechanism::{Actuation, BallDistance, BallTouch, PointSample, ProbeHeight};
use parcal_simulate::delta::{DeltaScenario, simulate_delta};

/// A typical delta probed on two rings, as configured.
fn probed() -> MechanismData {
    let delta = LinearDelta::typical();
    let configured: Vec<f64> = design(&delta).iter().copied().collect();
    let probes = probe_rings(100.0, 2, 6)
        .into_iter()
        .map(|[x, y]| ProbeHeight {
            commanded: [x, y, 0.7],
            sigma: 0.01,
        })
        .collect();
    let observations = Observations {
        probes,
        ..Observations::default()
    };
    MechanismData::new(Arc::new(delta), configured, observations)
        .with_trigger_height(0.7, Some(0.05))
}

fn error_of(data: &MechanismData) -> String {
    calibrate_mechanism(data, &MechanismOptions::default(), &mut |_| {})
        .unwrap_err()
        .to_string()
}

#[test]
fn errors_name_the_observation_or_the_parameter() {
    let mut data = probed();
    data.observations.probes[2].commanded[1] = f64::NAN;
    let error = error_of(&data);
    assert!(error.starts_with("probe height 2: "), "{error}");

    let mut data = probed();
    data.observations.probes[4].commanded = [1000.0, 0.0, 0.7];
    let error = error_of(&data);
    assert!(error.starts_with("probe height 4: unreachable"), "{error}");

    let mut data = probed();
    data.observations.samples.push(PointSample {
        readings: vec![-100.0, -100.0],
        sigma: 0.005,
        known_pose: None,
        loads: None,
    });
    let error = error_of(&data);
    assert!(
        error.starts_with("point sample 0: 2 readings for the 3 actuators"),
        "{error}"
    );

    let mut data = probed();
    data.configured[11] = f64::INFINITY;
    assert!(
        error_of(&data).starts_with("parameter diagonal_a: "),
        "{}",
        error_of(&data)
    );

    let mut data = probed();
    data.configured.pop();
    assert!(error_of(&data).starts_with("configured parameters: 15 values"));

    let error = probed()
        .with_group_sigma("rods", Some(0.1))
        .unwrap_err()
        .to_string();
    assert!(error.contains("diagonal rods"), "{error}");

    // No prior on any parameter: the gauge is determined by nothing.
    let error = error_of(&probed().without_priors());
    assert!(
        error.starts_with("not determined: no measurement sees the homed height"),
        "{error}"
    );

    let empty = probed().with_observations(Observations::default());
    assert!(error_of(&empty).contains("there is none"));
}

#[test]
fn options_are_checked_and_a_robust_loss_calibrates() {
    let data = probed();
    let refuse = |options: MechanismOptions| {
        calibrate_mechanism(&data, &options, &mut |_| {})
            .unwrap_err()
            .to_string()
    };
    let huber = Loss::Huber { k: HUBER_K };
    assert!(refuse(MechanismOptions::default().with_alpha(0.0)).contains("options.alpha"));
    let mut damped = MechanismOptions::default();
    damped.method = Method::LevenbergMarquardt {
        initial_lambda: f64::NAN,
    };
    assert!(refuse(damped).contains("options.method: a Levenberg-Marquardt lambda of NaN"));
    assert!(
        refuse(
            MechanismOptions::default()
                .with_loss(huber)
                .with_snooping(true)
        )
        .contains("the loss replaces it")
    );
    let run = calibrate_mechanism(
        &data,
        &MechanismOptions::default().with_loss(huber),
        &mut |_| {},
    )
    .unwrap();
    assert!(run.converged(), "{:?}", run.reasons);
    assert!(matches!(
        calibrate_mechanism(
            &data.clone().without_priors(),
            &MechanismOptions::default(),
            &mut |_| {}
        ),
        Err(MechanismCalibrationError::NotDetermined { .. })
    ));
}

#[test]
fn a_dataset_calibrates_from_its_files_and_its_record_reads_back() {
    let scenario = DeltaScenario {
        distances: 2,
        unknown_samples: 2,
        known_samples: 2,
        ..DeltaScenario::typical()
    };
    let dataset = simulate_delta(&scenario, 4).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("delta");
    dataset.write(&path).unwrap();
    let read = MechanismDataset::read(&path).unwrap();
    assert_eq!(read, dataset);
    let data = MechanismData::from_dataset(&read).unwrap();
    assert_eq!(
        (
            data.observations.probes.len(),
            data.observations.distances.len(),
            data.observations.samples.len()
        ),
        (25, 2, 4)
    );
    let run = calibrate_mechanism(&data, &MechanismOptions::default(), &mut |_| {}).unwrap();
    assert!(run.converged(), "{:?}", run.reasons);
    let record = run.record();
    let file = path.join("calibration.json");
    record.write(&file).unwrap();
    let back = MechanismCalibrationRecord::read(&file).unwrap();
    assert_eq!(back, record);
    assert_eq!(back.mechanism, "linear delta");
    assert_eq!(back.parameters.len(), 17);
    // The printer's printable radius travels from machine.json to the
    // record, which refuses one that is not a positive length.
    assert_eq!(data.print_radius, Some(scenario.print_radius));
    assert_eq!(back.print_radius, Some(scenario.print_radius));
    let negative = path.join("negative.json");
    let error = MechanismCalibrationRecord {
        print_radius: Some(-5.0),
        ..back.clone()
    }
    .write(&negative)
    .unwrap_err()
    .to_string();
    assert!(
        error.contains("negative.json") && error.contains("print_radius"),
        "{error}"
    );
    assert!(!negative.exists());
    assert_eq!(
        back.parameter("radius").unwrap().value,
        run.parameter("radius").unwrap().value
    );
    // The hexapod's readers refuse the mechanism's files, and the other
    // way round, each naming the right reader or kind.
    let error = Dataset::read(&path).unwrap_err().to_string();
    assert!(error.contains("mechanism reader"), "{error}");
    let error = Calibration::read(&file).unwrap_err().to_string();
    assert!(error.contains("parcal-mechanism-calibration"), "{error}");
    let hexapod = parcal_simulate::simulate(&parcal_simulate::Scenario::paper(), 1)
        .unwrap()
        .dataset;
    let hexapod_dir = dir.path().join("hexapod");
    hexapod.write(&hexapod_dir).unwrap();
    let error = MechanismDataset::read(&hexapod_dir)
        .unwrap_err()
        .to_string();
    assert!(error.contains("hexapod reader"), "{error}");
    // A dataset file names its file and line.
    std::fs::write(path.join("probes.csv"), "x,y,z\n1,2,3\n4,five,6\n").unwrap();
    let error = MechanismDataset::read(&path).unwrap_err().to_string();
    assert!(
        error.ends_with("probes.csv: line 3, column y: expected a number, found \"five\""),
        "{error}"
    );
}

#[test]
fn measured_quantities_and_loads_are_checked_naming_the_observation() {
    use parcal_observe::mechanism::MeasuredQuantity;
    // The delta has no measurable quantity and no load model.
    let mut data = probed();
    data.observations.quantities.push(MeasuredQuantity {
        quantity: 0,
        value: 1.0,
        sigma: 1.0,
    });
    let error = error_of(&data);
    assert!(
        error.starts_with("measured quantity 0: ") && error.contains("0 measurable quantities"),
        "{error}"
    );
    let mut data = probed();
    let pose = [10.0, 20.0, 50.0];
    let readings = data
        .mechanism
        .inverse(&data.configured, &pose)
        .unwrap()
        .iter()
        .copied()
        .collect();
    data.observations.samples.push(PointSample {
        readings,
        sigma: 0.005,
        known_pose: None,
        loads: Some(vec![1.0; 2]),
    });
    let error = error_of(&data);
    assert!(
        error.starts_with("point sample 0: ") && error.contains("2 loads"),
        "{error}"
    );
    data.observations.samples[0].loads = Some(vec![1.0; 3]);
    let error = error_of(&data);
    assert!(
        error.contains("point sample 0: the linear delta has no load model"),
        "{error}"
    );
    // A cable robot's line length with a sigma that is not positive.
    let robot = parcal_kinematics::cable::CableRobot::typical();
    let configured: Vec<f64> = design(&robot).iter().copied().collect();
    let observations = Observations {
        quantities: vec![MeasuredQuantity {
            quantity: 3,
            value: 2355.0,
            sigma: 0.0,
        }],
        ..Observations::default()
    };
    let data = MechanismData::new(Arc::new(robot), configured, observations);
    let error = error_of(&data);
    assert!(error.starts_with("measured quantity 0: "), "{error}");
}

#[test]
fn ball_distances_are_checked_naming_the_distance() {
    // Balls touched four times each (validation looks at the distances
    // before any ball is located).
    let with_balls = |count: usize| {
        let mut data = probed();
        data.observations.balls = vec![Ball::new(12.7, None); count];
        data.observations.touches = (0..4 * count)
            .map(|k| BallTouch::new(k / 4, Actuation::Commanded([0.0, 0.0, 20.0]), 0.005))
            .collect();
        data
    };
    let data = with_balls(3);
    let distance = |first, second| BallDistance {
        first,
        second,
        distance: 100.0,
        sigma: 0.002,
    };
    let refused = |data: &MechanismData, distances: Vec<BallDistance>| {
        let mut tied = data.clone();
        tied.observations.ball_distances = distances;
        tied.validate().unwrap_err().to_string()
    };
    let error = refused(&data, vec![distance(0, 1), distance(1, 3)]);
    assert!(
        error.starts_with("ball distance 1: it ties ball 3, and there are 3 balls"),
        "{error}"
    );
    let error = refused(&data, vec![distance(2, 2)]);
    assert!(
        error.starts_with("ball distance 0: it ties ball 2 to itself"),
        "{error}"
    );
    let error = refused(
        &data,
        vec![BallDistance {
            distance: -1.0,
            ..distance(0, 1)
        }],
    );
    assert!(
        error.contains("its distance -1 is not finite and positive"),
        "{error}"
    );
    let error = refused(
        &data,
        vec![BallDistance {
            sigma: 0.0,
            ..distance(0, 1)
        }],
    );
    assert!(
        error.starts_with("ball distance 0: its standard deviation 0"),
        "{error}"
    );
    let error = refused(&data, vec![distance(0, 1), distance(2, 0), distance(1, 0)]);
    assert!(
        error.starts_with("ball distance 2: balls 0 and 1 already have ball distance 0"),
        "{error}"
    );
    // More balls tied than the dense global block takes.
    let balls = MAX_TIED_BALLS + 1;
    let chain = (1..balls).map(|b| distance(b - 1, b)).collect();
    let error = refused(&with_balls(balls), chain);
    assert!(
        error.contains(&format!(
            "they tie {balls} balls together, more than the {MAX_TIED_BALLS} accepted"
        )),
        "{error}"
    );
}
