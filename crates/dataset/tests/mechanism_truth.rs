//! A mechanism dataset's truth.json: the trigger height required where the
//! machine has a probe (a delta's probe heights), optional otherwise (a
//! cable robot's encoder samples); the trackers' true frames, each of a
//! tracker measured.

use std::collections::BTreeMap;
use std::fs;

use parcal_dataset::FrameRecord;
use parcal_dataset::mechanism::{
    MechanismDataset, MechanismMachine, MechanismTruth, Noise, SampleRow, TrackerPointRow,
};
use parcal_kinematics::cable::CableRobot;
use parcal_kinematics::mechanism::{Mechanism, design};

#[test]
fn a_probed_machine_s_truth_needs_its_trigger_height() {
    let mut dataset = MechanismDataset {
        probes: vec![[0.0, 0.0, 0.7], [40.0, 10.0, 0.71]],
        ..MechanismDataset::default()
    };
    dataset.machine.noise.probe = Some(0.01);
    let parameters: Vec<f64> = dataset.machine.configured.clone();
    dataset.truth = Some(MechanismTruth {
        parameters,
        trigger_height: Some(0.69),
        trackers: BTreeMap::new(),
    });
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("delta");
    dataset.write(&path).unwrap();
    assert_eq!(MechanismDataset::read(&path).unwrap(), dataset);
    // The same file without its trigger height: refused, naming it.
    let file = path.join("truth.json");
    let mut json: serde_json::Value =
        serde_json::from_str(&fs::read_to_string(&file).unwrap()).unwrap();
    json.as_object_mut().unwrap().remove("trigger_height");
    fs::write(&file, json.to_string()).unwrap();
    let error = MechanismDataset::read(&path).unwrap_err().to_string();
    assert!(
        error.contains("truth.json") && error.contains("trigger_height"),
        "{error}"
    );
    // And a truth without it is not written for a probed machine.
    dataset.truth.as_mut().unwrap().trigger_height = None;
    let error = dataset
        .write(&dir.path().join("other"))
        .unwrap_err()
        .to_string();
    assert!(error.contains("trigger_height"), "{error}");
}

#[test]
fn a_cable_robot_s_truth_has_no_trigger_height() {
    let robot = CableRobot::typical();
    let p = design(&robot);
    let readings = robot.inverse(p.as_slice(), &[0.0, 0.0, 0.0]).unwrap();
    let dataset = MechanismDataset {
        machine: MechanismMachine {
            noise: Noise {
                actuator: Some(1.0),
                ..Noise::default()
            },
            ..MechanismMachine::of(&robot)
        },
        samples: vec![SampleRow {
            readings: readings.iter().copied().collect(),
            position: None,
            loads: None,
        }],
        truth: Some(MechanismTruth {
            parameters: p.iter().copied().collect(),
            trigger_height: None,
            trackers: BTreeMap::new(),
        }),
        ..MechanismDataset::default()
    };
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("cable");
    dataset.write(&path).unwrap();
    let truth = fs::read_to_string(path.join("truth.json")).unwrap();
    assert!(!truth.contains("trigger_height"), "{truth}");
    assert_eq!(MechanismDataset::read(&path).unwrap(), dataset);
}

#[test]
fn the_trackers_true_frames_are_kept_and_checked() {
    // A printer probed and measured by one tracker "left", its true frame
    // a quarter turn about z: written and read back to the bit.
    let mut dataset = MechanismDataset {
        probes: vec![[0.0, 0.0, 0.7], [40.0, 10.0, 0.71]],
        tracker_points: (0..3)
            .map(|k| TrackerPointRow {
                tracker: "left".to_string(),
                commanded: [10.0 * k as f64, 0.0, 5.0],
                measured: [1500.0, 10.0 * k as f64, 5.0],
            })
            .collect(),
        ..MechanismDataset::default()
    };
    dataset.machine.noise.probe = Some(0.01);
    dataset.machine.noise.tracker = Some(0.01);
    let half = std::f64::consts::FRAC_1_SQRT_2;
    let frame = FrameRecord {
        translation: [1500.0, 0.0, 0.0],
        rotation: [0.0, 0.0, half, half],
    };
    dataset.truth = Some(MechanismTruth {
        parameters: dataset.machine.configured.clone(),
        trigger_height: Some(0.69),
        trackers: BTreeMap::from([("left".to_string(), frame)]),
    });
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("tracked");
    dataset.write(&path).unwrap();
    assert_eq!(MechanismDataset::read(&path).unwrap(), dataset);
    // Refused, naming the file and the tracker: a frame of a tracker that
    // measured nothing, and a rotation that is not a unit quaternion.
    let file = path.join("truth.json");
    let text = fs::read_to_string(&file).unwrap();
    fs::write(&file, text.replace("\"left\"", "\"right\"")).unwrap();
    let error = MechanismDataset::read(&path).unwrap_err().to_string();
    assert!(
        error.contains("truth.json") && error.contains("trackers.right"),
        "{error}"
    );
    let truth = dataset.truth.as_mut().unwrap();
    truth.trackers.get_mut("left").unwrap().rotation = [0.0, 0.0, 1.0, 1.0];
    let error = dataset
        .write(&dir.path().join("other"))
        .unwrap_err()
        .to_string();
    assert!(error.contains("trackers.left.rotation"), "{error}");
}
