//! A mechanism dataset's truth.json: the trigger height required where the
//! machine has a probe (a delta's probe heights), optional otherwise (a
//! cable robot's encoder samples).

use std::fs;

use parcal_dataset::mechanism::{
    MechanismDataset, MechanismMachine, MechanismTruth, Noise, SampleRow,
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
