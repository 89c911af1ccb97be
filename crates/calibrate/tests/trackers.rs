//! Trackers in the common calibration: simulated delta printers probed on
//! the bed and measured by two trackers placed anywhere (their frames
//! unknown), the estimate's consistency with its covariance (NEES) for
//! the parameters and for the trackers' frames, which follow the delta's
//! canonical frame; held-out points of trackers placed anew judged against
//! their predicted covariance; and errors that name the tracker or its
//! point.

use nalgebra::{DMatrix, DVector, Isometry3, Vector3, Vector6};
use parcal_calibrate::mechanism::{
    CalibratedMechanism, MechanismCalibration, MechanismData, MechanismOptions, Tracker,
    calibrate_mechanism, validate_mechanism,
};
use parcal_dataset::FrameRecord;
use parcal_dataset::mechanism::{MechanismDataset, MechanismTruth};
use parcal_kinematics::delta::LinearDelta;
use parcal_kinematics::mechanism::Mechanism;
use parcal_observe::CoordinateWhitening;
use parcal_observe::mechanism::{Actuation, TrackerPoint};
use parcal_simulate::Rng;
use parcal_simulate::delta::{DeltaScenario, measure_delta, simulate_delta};

use crate::mean;
use crate::nees;

use mean::mean_and_standard_error;
use nees::nees;

/// The trackers' true frames (the true printer's frame → each tracker's).
fn true_frames() -> [Isometry3<f64>; 2] {
    [
        Isometry3::new(
            Vector3::new(1200.0, -300.0, 150.0),
            Vector3::new(0.1, -0.2, 2.5),
        ),
        Isometry3::new(
            Vector3::new(-800.0, 900.0, -40.0),
            Vector3::new(-0.05, 0.3, -1.0),
        ),
    ]
}

/// The trackers' noise per coordinate (mm).
const TRACKER_SIGMA: f64 = 0.01;

/// A commanded position of point `j` of 24: on two rings at two heights.
fn commanded(j: usize) -> [f64; 3] {
    let angle = 0.6 * j as f64;
    let radius = if j.is_multiple_of(2) { 60.0 } else { 100.0 };
    [
        radius * angle.cos(),
        radius * angle.sin(),
        20.0 + 5.0 * (j % 7) as f64,
    ]
}

/// `dataset`'s printer probed as simulated, and measured by two trackers
/// at 12 commanded positions each, every coordinate with Gaussian noise
/// of [`TRACKER_SIGMA`] (stream `seed`).
fn tracked(dataset: &MechanismDataset, seed: u64) -> MechanismData {
    let mut data = MechanismData::from_dataset(dataset).expect("a simulated dataset converts");
    let truth = &dataset.truth.as_ref().expect("simulated").parameters;
    let mut noise = Rng::new(seed, 7007);
    let frames = true_frames();
    let o = &mut data.observations;
    o.trackers = vec![Tracker::new("left"), Tracker::new("right")];
    o.tracker_points = (0..24)
        .map(|j| {
            let at = Actuation::Commanded(commanded(j));
            let reached = at
                .tool_point(data.mechanism.as_ref(), truth, &data.configured, None)
                .unwrap();
            let seen = frames[j % 2].transform_point(&reached.point.into()).coords;
            TrackerPoint {
                tracker: j % 2,
                at,
                measured: std::array::from_fn(|k| seen[k] + noise.normal(TRACKER_SIGMA)),
                weight: CoordinateWhitening::isotropic(TRACKER_SIGMA).unwrap(),
            }
        })
        .collect();
    data
}

/// Each tracker's error `F_true⁻¹ ∘ F` (rotation vector, translation)
/// against its covariance, the true frame carried to the canonical frame
/// of the truth as a report sets it beside the estimate
/// ([`MechanismData::true_tracker_frames`]): the sum over the trackers.
fn frames_nees(run: &MechanismCalibration, data: &MechanismData, truth: &MechanismTruth) -> f64 {
    let mut truth = truth.clone();
    truth.trackers = (data.observations.trackers.iter())
        .zip(true_frames())
        .map(|(tracker, frame)| (tracker.label.clone(), FrameRecord::of(&frame)))
        .collect();
    let frames = data.true_tracker_frames(&truth).unwrap();
    run.trackers
        .iter()
        .zip(frames)
        .map(|(tracker, frame)| {
            let error = frame.expect("every tracker's truth").inverse() * tracker.frame;
            let e = Vector6::from_iterator(
                error
                    .rotation
                    .scaled_axis()
                    .iter()
                    .chain(error.translation.vector.iter())
                    .copied(),
            );
            let covariance = tracker.covariance.expect("a covariance");
            let (value, rank) = nees(
                &DVector::from_column_slice(e.as_slice()),
                &DMatrix::from_column_slice(6, 6, covariance.as_slice()),
            );
            assert_eq!(rank, 6);
            value
        })
        .sum()
}

#[test]
fn parameters_and_tracker_frames_are_within_their_covariance() {
    // 30 printers: NEES of the canonical parameters and trigger height
    // (the identifiable count), and of the two trackers' frames (12),
    // each mean within 4 standard errors.
    let (mut parameters, mut frames, mut ranks) = (Vec::new(), Vec::new(), Vec::new());
    for seed in 0..30 {
        let dataset = simulate_delta(&DeltaScenario::typical(), seed).unwrap();
        let data = tracked(&dataset, seed);
        let run = calibrate_mechanism(&data, &MechanismOptions::default(), &mut |_| {}).unwrap();
        assert!(run.converged(), "seed {seed}: {:?}", run.reasons);
        let truth = dataset.truth.as_ref().unwrap();
        let delta = LinearDelta::typical();
        let mut expected: Vec<f64> = delta
            .canonicalize(&truth.parameters)
            .unwrap()
            .iter()
            .copied()
            .collect();
        expected.push(truth.trigger_height.unwrap());
        let error = run.values() - DVector::from_vec(expected);
        let (value, rank) = nees(&error, run.covariance.as_ref().unwrap());
        parameters.push(value);
        ranks.push(rank);
        frames.push(frames_nees(&run, &data, truth));
    }
    assert!(ranks.iter().all(|&r| r == ranks[0]), "{ranks:?}");
    let rank = ranks[0] as f64;
    let (mean, error) = mean_and_standard_error(&parameters);
    println!("NEES of the parameters: mean {mean:.2}, standard error {error:.2}, rank {rank}");
    assert!((mean - rank).abs() < 4.0 * error);
    let (mean, error) = mean_and_standard_error(&frames);
    println!("NEES of the frames: mean {mean:.2}, standard error {error:.2}, 12 unknowns");
    assert!((mean - 12.0).abs() < 4.0 * error);
}

#[test]
fn held_out_trackers_placed_anew_fit_their_predicted_covariance() {
    // 30 printers probed and tracked (two trackers of 12 points),
    // calibrated, then measured again with the trackers placed anew: each
    // tracker's frame fitted to its held-out points (3K - 6 rows), T = rᵀ
    // C⁻¹ r over all rows is χ²(n), E[T / n] = 1. The same printer with a
    // rod 0.2 mm longer is rejected.
    let scenario = DeltaScenario {
        trackers: 2,
        ..DeltaScenario::typical()
    };
    let mut ratios = Vec::new();
    for seed in 0..30 {
        let dataset = simulate_delta(&scenario, seed).unwrap();
        let data = MechanismData::from_dataset(&dataset).unwrap();
        let run = calibrate_mechanism(&data, &MechanismOptions::default(), &mut |_| {}).unwrap();
        let calibrated = CalibratedMechanism::of_calibration(&run).unwrap();
        let truth = dataset.truth.unwrap();
        let held_out = measure_delta(&scenario, &truth, seed + 10_000).unwrap();
        let held_out = MechanismData::from_dataset(&held_out).unwrap();
        let validation = validate_mechanism(&calibrated, &held_out, 0.05, None).unwrap();
        let tracker_rows = validation
            .rows
            .iter()
            .filter(|r| r.observation.name() == "tracker");
        assert_eq!(tracker_rows.count(), 2 * (3 * 12 - 6));
        ratios.push(validation.statistic / validation.rows.len() as f64);
        if seed == 0 {
            let mut changed = truth.clone();
            changed.parameters[11] += 0.2;
            let measured = measure_delta(&scenario, &changed, seed + 10_000).unwrap();
            let measured = MechanismData::from_dataset(&measured).unwrap();
            let validation = validate_mechanism(&calibrated, &measured, 0.05, None).unwrap();
            println!(
                "a rod 0.2 mm longer: T/n {:.2} over {} rows",
                validation.statistic / validation.rows.len() as f64,
                validation.rows.len()
            );
            assert!(!validation.global_test_passes());
        }
    }
    let (mean, error) = mean_and_standard_error(&ratios);
    println!("held-out T/n over 30 printers: mean {mean:.4}, standard error {error:.4}");
    assert!((mean - 1.0).abs() < 4.0 * error);
}

#[test]
fn errors_name_the_tracker_or_its_point() {
    let dataset = simulate_delta(&DeltaScenario::typical(), 1).unwrap();
    let error_of = |data: &MechanismData| {
        calibrate_mechanism(data, &MechanismOptions::default(), &mut |_| {})
            .unwrap_err()
            .to_string()
    };
    let mut data = tracked(&dataset, 1);
    data.observations.tracker_points[5].tracker = 2;
    assert_eq!(
        error_of(&data),
        "tracker point 5: it is of tracker 2, and there are 2 trackers"
    );
    let mut data = tracked(&dataset, 1);
    data.observations.tracker_points[3].measured[1] = f64::NAN;
    assert!(
        error_of(&data).starts_with("tracker point 3: "),
        "{}",
        error_of(&data)
    );
    // The right tracker keeps two points.
    let mut data = tracked(&dataset, 1);
    data.observations.tracker_points.retain(|p| {
        p.tracker == 0
            || p.at == Actuation::Commanded(commanded(1))
            || p.at == Actuation::Commanded(commanded(3))
    });
    assert_eq!(
        error_of(&data),
        "tracker \"right\": it has 2 points; its frame needs at least 3 not on a line"
    );
    // Three points on a line.
    let mut data = tracked(&dataset, 1);
    data.observations.tracker_points.retain(|p| p.tracker == 0);
    for (k, point) in data
        .observations
        .tracker_points
        .iter_mut()
        .enumerate()
        .take(3)
    {
        let t = k as f64;
        point.tracker = 1;
        point.at = Actuation::Commanded([10.0 * t, 5.0 * t, 30.0]);
        point.measured = [500.0 + 10.0 * t, 5.0 * t, 30.0];
    }
    let error = error_of(&data);
    assert!(
        error.contains("tracker \"right\"") && error.contains("they lie on a line"),
        "{error}"
    );
    // Offsets' sigmas: only for a re-homed tracker, positive.
    let mut data = tracked(&dataset, 1);
    data.observations.trackers[1].offset_sigmas = Some(vec![0.1]);
    assert_eq!(
        error_of(&data),
        "tracker \"right\": it has an offsets' sigma but was not re-homed: it has no offsets"
    );
    data.observations.trackers[1] = Tracker::rehomed("right", Some(-0.1));
    assert_eq!(
        error_of(&data),
        "tracker \"right\": its offsets' sigma -0.1 is not finite and positive"
    );
    data.observations.trackers[1] = Tracker::rehomed_each("right", vec![0.1, 0.2]);
    assert_eq!(
        error_of(&data),
        "tracker \"right\": it has 2 offsets' sigmas: one for every actuator, or one for each of the 3"
    );
    // A point the machine cannot reach.
    let mut data = tracked(&dataset, 1);
    data.observations.tracker_points[7].at = Actuation::Commanded([1000.0, 0.0, 30.0]);
    let error = error_of(&data);
    assert!(error.starts_with("tracker point 7: "), "{error}");
}
