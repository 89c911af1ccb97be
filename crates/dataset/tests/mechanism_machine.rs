//! A mechanism dataset's machine.json: a group made as a matched set
//! (`"matched"`) written and read back, and refused, naming the field,
//! when it has no tolerance or is looser than it; a printer's printable
//! radius (`"print_radius"`) written and read back, and refused when it
//! is not a positive length; a cable robot's elastic lines
//! (`"elasticity"`) written and read back, their compliances among the
//! parameters, and refused, naming the field, for another mechanism or
//! when they do not fit the robot's lines; a parameter value no machine
//! of its kind has refused, naming the field; a part distance that is
//! not positive refused at its line.

use std::fs;

use parcal_dataset::mechanism::{
    LineElasticity, MechanismDataset, MechanismMachine, MechanismTruth, Noise, SampleRow,
};
use parcal_kinematics::cable::{CableRobot, Elasticity, TYPICAL_COMPLIANCE};
use parcal_kinematics::delta::LinearDelta;
use parcal_kinematics::mechanism::Mechanism;

/// A delta probed twice, its rods cut as a set within `matched` mm, its
/// rods' tolerance `tolerance`.
fn with_rods(matched: f64, tolerance: Option<f64>) -> MechanismDataset {
    let mut machine = MechanismMachine::of(&LinearDelta::typical());
    machine.noise = Noise {
        probe: Some(0.01),
        ..Noise::default()
    };
    machine.tolerances = vec![("diagonal rods".to_string(), tolerance)];
    machine.matched = vec![("diagonal rods".to_string(), matched)];
    MechanismDataset {
        machine,
        probes: vec![[0.0, 0.0, 0.71], [50.0, 20.0, 0.69]],
        ..MechanismDataset::default()
    }
}

#[test]
fn a_matched_group_is_written_and_read_back() {
    let dataset = with_rods(0.02, Some(0.5));
    let dir = tempfile::tempdir().unwrap();
    dataset.write(dir.path()).unwrap();
    let text = fs::read_to_string(dir.path().join("machine.json")).unwrap();
    assert!(text.contains("\"matched\""), "{text}");
    let read = MechanismDataset::read(dir.path()).unwrap();
    assert_eq!(read.machine.matched, dataset.machine.matched);
    // Without one, the file has no "matched" field.
    let mut plain = dataset.clone();
    plain.machine.matched.clear();
    let dir = tempfile::tempdir().unwrap();
    plain.write(dir.path()).unwrap();
    let text = fs::read_to_string(dir.path().join("machine.json")).unwrap();
    assert!(!text.contains("matched"), "{text}");
}

#[test]
fn a_matched_group_without_a_tolerance_or_looser_than_it_is_refused() {
    for (dataset, expected) in [
        (with_rods(0.02, None), "has no prior"),
        (with_rods(0.6, Some(0.5)), "more than the group's tolerance"),
        (with_rods(-0.1, Some(0.5)), "matched.diagonal rods"),
    ] {
        let dir = tempfile::tempdir().unwrap();
        let error = dataset.write(dir.path()).unwrap_err().to_string();
        assert!(error.contains("matched.diagonal rods"), "{error}");
        assert!(error.contains(expected), "{error}");
    }
    // And on reading a file written by hand.
    let dir = tempfile::tempdir().unwrap();
    with_rods(0.02, Some(0.5)).write(dir.path()).unwrap();
    let path = dir.path().join("machine.json");
    let text = fs::read_to_string(&path).unwrap().replace("0.02", "0.9");
    fs::write(&path, text).unwrap();
    let error = MechanismDataset::read(dir.path()).unwrap_err().to_string();
    assert!(error.contains("machine.json"), "{error}");
    assert!(error.contains("matched.diagonal rods"), "{error}");
}

#[test]
fn a_printable_radius_is_written_read_back_and_refused_when_not_positive() {
    let mut dataset = with_rods(0.02, Some(0.5));
    dataset.machine.print_radius = Some(95.5);
    let dir = tempfile::tempdir().unwrap();
    dataset.write(dir.path()).unwrap();
    let read = MechanismDataset::read(dir.path()).unwrap();
    assert_eq!(read.machine.print_radius, Some(95.5));
    let path = dir.path().join("machine.json");
    let text = fs::read_to_string(&path).unwrap();
    let start = text.find("\"print_radius\"").unwrap();
    let end = start + text[start..].find([',', '}']).unwrap();
    for bad in ["0", "-95.5", "1e300"] {
        let field = format!("\"print_radius\": {bad}");
        fs::write(&path, format!("{}{field}{}", &text[..start], &text[end..])).unwrap();
        let error = MechanismDataset::read(dir.path()).unwrap_err().to_string();
        assert!(error.contains("print_radius"), "{bad}: {error}");
    }
    // Only a printer has one.
    let mut cable = MechanismDataset {
        machine: MechanismMachine::of(&CableRobot::typical()),
        ..MechanismDataset::default()
    };
    cable.machine.print_radius = Some(95.5);
    let dir = tempfile::tempdir().unwrap();
    let error = cable.write(dir.path()).unwrap_err().to_string();
    assert!(error.contains("print_radius"), "{error}");
    assert!(error.contains("no printable radius"), "{error}");
}

/// A cable robot whose lines share one compliance, zeroed under the
/// loads `zero_loads`.
fn elastic_robot(zero_loads: Vec<f64>) -> (CableRobot, LineElasticity) {
    let lines = LineElasticity {
        compliance_of_line: vec![0; 4],
        zero_loads,
    };
    let elasticity =
        Elasticity::typical(lines.compliance_of_line.clone(), lines.zero_loads.clone());
    let robot = CableRobot::typical().with_elasticity(elasticity).unwrap();
    (robot, lines)
}

#[test]
fn elastic_lines_are_written_read_back_and_refused_when_they_do_not_fit() {
    let (robot, lines) = elastic_robot(vec![13.7, 14.5, 14.1, 12.5]);
    // One sample of its readings at the design, under other loads.
    let design: Vec<f64> = robot.parameters().iter().map(|p| p.design).collect();
    let readings = robot.inverse(&design, &[0.0, 0.0, 100.0]).unwrap();
    let mut dataset = MechanismDataset {
        machine: MechanismMachine::of(&robot),
        samples: vec![SampleRow {
            readings: readings.iter().copied().collect(),
            position: None,
            loads: Some(vec![12.0, 15.0, 13.0, 30.0]),
        }],
        ..MechanismDataset::default()
    };
    dataset.machine.noise.actuator = Some(1.0);
    // The machine of the robot has its lines.
    assert_eq!(dataset.machine.elasticity, Some(lines.clone()));
    // Its truth names the compliance too.
    let mut truth = design.clone();
    *truth.last_mut().unwrap() = 61.5;
    dataset.truth = Some(MechanismTruth {
        parameters: truth,
        trigger_height: None,
        trackers: Default::default(),
    });
    let dir = tempfile::tempdir().unwrap();
    dataset.write(dir.path()).unwrap();
    let truth_text = fs::read_to_string(dir.path().join("truth.json")).unwrap();
    assert!(
        truth_text.contains("\"compliance_abcd\": 61.5"),
        "{truth_text}"
    );
    let path = dir.path().join("machine.json");
    let text = fs::read_to_string(&path).unwrap();
    assert!(
        text.contains("\"elasticity\"") && text.contains("\"compliance_abcd\": 50.0"),
        "{text}"
    );
    let read = MechanismDataset::read(dir.path()).unwrap();
    assert_eq!(read.machine.elasticity, Some(lines.clone()));
    assert_eq!(read.truth, dataset.truth);
    // The machine's mechanism has the compliance among its parameters,
    // as the robot made elastic in code.
    let mechanism = read.machine.mechanism().unwrap();
    let names = |m: &dyn Mechanism| -> Vec<String> {
        m.parameters().iter().map(|p| p.name.clone()).collect()
    };
    assert_eq!(names(mechanism.as_ref()), names(&robot));
    let compliance = mechanism.parameters().last().unwrap();
    assert_eq!(
        (compliance.design, compliance.prior_sigma),
        (TYPICAL_COMPLIANCE, TYPICAL_COMPLIANCE)
    );
    // Loads for three of the four lines, a compliance no line uses, a
    // slack line at the encoder zero, the compliance left out of
    // "configured": refused by field.
    let json: serde_json::Value = serde_json::from_str(&text).unwrap();
    let edited = |edit: &dyn Fn(&mut serde_json::Value)| {
        let mut json = json.clone();
        edit(&mut json);
        json.to_string()
    };
    for (bad, expected) in [
        (
            edited(&|j| j["elasticity"]["zero_loads"] = serde_json::json!([13.7, 14.5, 14.1])),
            "the loads at the encoder zero lists 3 values for 4 lines",
        ),
        (
            edited(&|j| j["elasticity"]["compliance_of_line"] = serde_json::json!([1, 1, 1, 1])),
            "no line has compliance index 0: the indices run from 0 to 1 without a gap",
        ),
        (
            edited(&|j| {
                j["elasticity"]["zero_loads"] = serde_json::json!([13.7, -14.5, 14.1, 12.5])
            }),
            "a load at the encoder zero, -14.5 N, is not positive and finite",
        ),
        (
            edited(&|j| {
                drop(
                    j["configured"]
                        .as_object_mut()
                        .unwrap()
                        .remove("compliance_abcd"),
                )
            }),
            "configured.compliance_abcd",
        ),
    ] {
        fs::write(&path, bad).unwrap();
        let error = MechanismDataset::read(dir.path()).unwrap_err().to_string();
        assert!(error.contains("machine.json"), "{error}");
        assert!(error.contains(expected), "{error}");
    }
    // Only a cable robot has lines.
    let mut printer = with_rods(0.02, Some(0.5));
    printer.machine.elasticity = Some(lines);
    let error = printer
        .write(&dir.path().join("x"))
        .unwrap_err()
        .to_string();
    assert!(
        error.contains("elasticity") && error.contains("the linear delta has no lines"),
        "{error}"
    );
}

#[test]
fn heights_measured_by_hand_are_written_and_read_back_with_their_noise() {
    let mut dataset = with_rods(0.02, Some(0.5));
    dataset.heights = vec![[0.0, 0.0, 5.0, 5.12], [40.0, -20.0, 2.0, 1.97]];
    dataset.machine.noise.height = Some(0.05);
    let dir = tempfile::tempdir().unwrap();
    dataset.write(dir.path()).unwrap();
    let text = fs::read_to_string(dir.path().join("heights.csv")).unwrap();
    assert!(text.starts_with("x,y,z,height\n"), "{text}");
    assert_eq!(MechanismDataset::read(dir.path()).unwrap(), dataset);
    // Heights without their noise, and a row out of the length bound,
    // are refused naming the field and the row.
    let mut silent = dataset.clone();
    silent.machine.noise.height = None;
    let error = silent.write(&dir.path().join("x")).unwrap_err().to_string();
    assert!(error.contains("noise.height"), "{error}");
    let mut far = dataset;
    far.heights[1][3] = 1e9;
    let error = far.write(&dir.path().join("y")).unwrap_err().to_string();
    assert!(
        error.contains("heights.csv") && error.contains("line 3"),
        "{error}"
    );
}

#[test]
fn a_part_distance_that_is_not_positive_is_refused_at_its_line() {
    let mut dataset = with_rods(0.02, Some(0.5));
    dataset.distances = vec![[-40.0, 0.0, 0.2, 40.0, 0.0, 0.2, 80.01]];
    dataset.machine.noise.distance = Some(0.01);
    let dir = tempfile::tempdir().unwrap();
    dataset.write(dir.path()).unwrap();
    let path = dir.path().join("distances.csv");
    let text = fs::read_to_string(&path).unwrap();
    for (bad, shown) in [("-80.01", "-80.01"), ("0", "0")] {
        fs::write(&path, text.replace("80.01", bad)).unwrap();
        let error = MechanismDataset::read(dir.path()).unwrap_err().to_string();
        assert!(
            error.ends_with(&format!(
                "distances.csv: field line 2, column distance: must be positive, found {shown}"
            )),
            "{error}"
        );
    }
    // Refused before it is written, at the line it would have.
    dataset.distances[0][6] = -80.01;
    let target = dir.path().join("x");
    let error = dataset.write(&target).unwrap_err().to_string();
    assert!(
        error.ends_with("field line 2, column distance: must be positive, found -80.01"),
        "{error}"
    );
    assert!(!target.exists());
}

#[test]
fn a_parameter_no_machine_has_is_refused_naming_its_field() {
    let robot = CableRobot::typical();
    let k = (robot.parameters().iter())
        .position(|p| p.name == "radius_b")
        .unwrap();
    let mut machine = MechanismMachine::of(&robot);
    machine.noise.actuator = Some(1.0);
    let mut dataset = MechanismDataset {
        machine,
        samples: vec![SampleRow {
            readings: vec![0.0; 4],
            position: None,
            loads: None,
        }],
        ..MechanismDataset::default()
    };
    let dir = tempfile::tempdir().unwrap();
    dataset.write(dir.path()).unwrap();
    // Written: refused before a file is.
    dataset.machine.configured[k] = 0.0;
    let error = dataset
        .write(tempfile::tempdir().unwrap().path())
        .unwrap_err();
    assert!(
        error
            .to_string()
            .ends_with("field configured.radius_b: a spool radius must be positive, found 0"),
        "{error}"
    );
    // Read: the design's as well as the configured values.
    let path = dir.path().join("machine.json");
    let text = fs::read_to_string(&path).unwrap();
    for field in ["configured", "design"] {
        let mut json: serde_json::Value = serde_json::from_str(&text).unwrap();
        if json["design"].is_null() {
            json["design"] = json["configured"].clone();
        }
        json[field]["radius_b"] = serde_json::json!(-75.0);
        fs::write(&path, json.to_string()).unwrap();
        let error = MechanismDataset::read(dir.path()).unwrap_err().to_string();
        assert!(
            error.ends_with(&format!(
                "machine.json: field {field}.radius_b: a spool radius must be positive, found -75"
            )),
            "{error}"
        );
    }
}
