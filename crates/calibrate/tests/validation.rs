//! `calibrate` refuses a bad dataset built in memory with an error that
//! names the measurement row, the ball or the field: never a panic.

use parcal_calibrate::{CalibrateError, CalibrationOptions, calibrate};
use parcal_dataset::Dataset;
use parcal_simulate::{Scenario, simulate};

/// The paper's campaign (27 balls x 7 contacts), without its truth so that
/// rows can be removed freely.
fn campaign() -> Dataset {
    let mut dataset = simulate(&Scenario::paper(), 1).unwrap().dataset;
    dataset.truth = None;
    dataset
}

/// The error `calibrate` returns for `dataset`, and its message.
fn refused(dataset: &Dataset) -> (CalibrateError, String) {
    match calibrate(dataset, &CalibrationOptions::default(), &mut |_| {}) {
        Ok(_) => panic!("an invalid dataset was calibrated"),
        Err(error) => {
            let message = error.to_string();
            (error, message)
        }
    }
}

#[test]
fn a_ball_index_out_of_range_names_the_row() {
    let mut dataset = campaign();
    dataset.measurements.ball[5] = 99;
    let (error, message) = refused(&dataset);
    assert_eq!(error.row(), Some(5));
    assert_eq!(
        message,
        "invalid dataset: measurement row 5, field ball: ball index 99 is out of range (27 balls)"
    );
}

#[test]
fn a_non_finite_reading_names_the_row_and_the_actuator() {
    let mut dataset = campaign();
    dataset.measurements.q[7][2] = f64::NAN;
    let (error, message) = refused(&dataset);
    assert_eq!(error.row(), Some(7));
    assert_eq!(
        message,
        "invalid dataset: measurement row 7, field q3: value NaN is not a finite number"
    );
}

#[test]
fn arrays_of_another_length_name_the_field() {
    let mut dataset = campaign();
    dataset.measurements.q.pop();
    let (error, message) = refused(&dataset);
    assert_eq!(error.row(), None);
    assert_eq!(
        message,
        "invalid dataset: field measurements.q: has 188 rows, ball has 189"
    );

    let mut dataset = campaign();
    dataset.measurements.direction = Some(vec![[0.0, 0.0, -1.0]; 188]);
    let (_, message) = refused(&dataset);
    assert_eq!(
        message,
        "invalid dataset: field measurements.direction: has 188 rows, ball has 189"
    );
}

#[test]
fn a_bad_artefact_value_names_its_path_in_the_dataset() {
    let mut dataset = campaign();
    dataset.artefacts.balls[3].radius = -1.0;
    let (error, message) = refused(&dataset);
    assert_eq!(error.row(), None);
    assert_eq!(
        message,
        "invalid dataset: field artefacts.balls[3].radius: must be positive, found -1"
    );
}

#[test]
fn a_ball_with_two_contacts_is_named() {
    let mut dataset = campaign();
    let m = &mut dataset.measurements;
    // Ball b05 (index 4) keeps its first two contacts of seven.
    let dropped: Vec<usize> = (0..m.len()).filter(|&r| m.ball[r] == 4).skip(2).collect();
    for &r in dropped.iter().rev() {
        m.ball.remove(r);
        m.q.remove(r);
    }
    assert_eq!(dataset.contacts_per_ball()[4], 2);
    let (error, message) = refused(&dataset);
    assert!(matches!(
        error,
        CalibrateError::TooFewContacts {
            count: 2,
            min: 4,
            ..
        }
    ));
    assert_eq!(
        message,
        "ball \"b05\" has 2 contacts, fewer than the 4 its initial centre needs"
    );
}

#[test]
fn a_failure_states_its_cause_once() {
    let mut dataset = campaign();
    dataset.measurements.q[9] = [1000.0, 1000.0, 1000.0, 0.0, 0.0, 0.0];
    let (error, message) = refused(&dataset);
    assert_eq!(error.row(), Some(9));
    assert!(
        message.starts_with("measurement row 9: forward kinematics failed: "),
        "{message}"
    );
    // The message states the cause; no `source` repeats it in a chain.
    assert!(std::error::Error::source(&error).is_none());
}

/// What the dataset's reader refuses (a zero approach direction, a tool a
/// kilometre away, coincident joints, a repeatability whose weight
/// overflows), the calibration refuses with the reader's words, before it
/// starts: inspect and calibrate agree.
#[test]
fn what_the_reader_refuses_is_refused_before_the_calibration_starts() {
    let mut dataset = campaign();
    let mut directions = vec![[0.0, 0.0, -1.0]; dataset.measurements.len()];
    directions[3] = [0.0; 3];
    dataset.measurements.direction = Some(directions);
    let (error, message) = refused(&dataset);
    assert_eq!(error.row(), Some(3));
    assert!(
        message.ends_with("the approach direction (0, 0, 0) is zero, not a direction"),
        "{message}"
    );

    let mut dataset = campaign();
    dataset.machine.geometry.tool[2] = 1e12;
    assert_eq!(
        refused(&dataset).1,
        "invalid dataset: field machine.tool[2]: 1e12 mm is beyond the 1e6 mm (1 km) \
         a length may have (a unit error?)"
    );

    let mut dataset = campaign();
    dataset.machine.geometry.platform_joints[3] = dataset.machine.geometry.platform_joints[0];
    assert_eq!(
        refused(&dataset).1,
        "invalid dataset: field machine.platform_joints: degenerate geometry: \
         platform joints 1 and 4 coincide"
    );

    let mut dataset = campaign();
    dataset.machine.repeatability.actuator = 1e-300;
    assert!(
        refused(&dataset)
            .1
            .starts_with("invalid dataset: field machine.repeatability.actuator: a standard deviation of 1e-300 is too small"),
    );
}
