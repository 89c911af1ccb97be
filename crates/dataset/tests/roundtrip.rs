//! Writing then reading gives back the same values, bit for bit; the
//! reference dataset of an independent tool reads.

use crate::common;

use std::fs;

use common::*;
use parcal_dataset::*;

fn all_combinations() -> Vec<Parts> {
    let mut out = Vec::new();
    for truth in [false, true] {
        for directions in [false, true] {
            for distances in [false, true] {
                out.push(Parts {
                    truth,
                    directions,
                    distances,
                });
            }
        }
    }
    out
}

#[test]
fn a_machines_text_is_the_file_written() {
    let machine = dataset(Parts {
        truth: false,
        directions: false,
        distances: false,
    })
    .machine;
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join(MACHINE_FILE);
    machine.write(&path).unwrap();
    assert_eq!(
        machine.to_json().unwrap(),
        fs::read_to_string(&path).unwrap()
    );
    let mut bad = machine;
    bad.geometry.leg_lengths[2] = f64::NAN;
    let error = bad.to_json().unwrap_err().to_string();
    assert!(error.starts_with("machine.json"), "{error}");
}

#[test]
fn write_then_read_is_bitwise_identical() {
    for parts in all_combinations() {
        let original = dataset(parts);
        let dir = tempfile::tempdir().unwrap();
        original.write(dir.path()).unwrap();
        let read = Dataset::read(dir.path()).unwrap_or_else(|e| panic!("{parts:?}: {e}"));
        assert_bitwise_eq(&read, &original);
        assert_eq!(read.truth.is_some(), parts.truth);
        assert_eq!(read.measurements.direction.is_some(), parts.directions);
        assert_eq!(read.artefacts.distances.is_empty(), !parts.distances);
    }
}

#[test]
fn negative_zero_and_tiny_values_survive_the_text_files() {
    let dir = written(ALL);
    let read = Dataset::read(dir.path()).unwrap();
    assert!(
        read.machine.geometry.tool[1].is_sign_negative() && read.machine.geometry.tool[1] == 0.0
    );
    assert_eq!(read.measurements.q[0][5].to_bits(), 5e-324f64.to_bits());
    let csv = fs::read_to_string(dir.path().join(MEASUREMENTS_FILE)).unwrap();
    assert!(
        csv.starts_with("ball,q1,q2,q3,q4,q5,q6,dir_x,dir_y,dir_z\n"),
        "{csv}"
    );
    assert!(csv.contains(",-0,"), "-0.0 is written as -0: {csv}");
}

#[test]
fn writing_is_deterministic() {
    let a = written(ALL);
    let b = written(ALL);
    for file in [MACHINE_FILE, ARTEFACTS_FILE, MEASUREMENTS_FILE, TRUTH_FILE] {
        let bytes_a = fs::read(a.path().join(file)).unwrap();
        let bytes_b = fs::read(b.path().join(file)).unwrap();
        assert!(bytes_a == bytes_b, "{file} differs between two writes");
    }
    // Rewriting what was read gives the same bytes again.
    let read = Dataset::read(a.path()).unwrap();
    let c = tempfile::tempdir().unwrap();
    read.write(c.path()).unwrap();
    for file in [MACHINE_FILE, ARTEFACTS_FILE, MEASUREMENTS_FILE, TRUTH_FILE] {
        assert_eq!(
            fs::read(a.path().join(file)).unwrap(),
            fs::read(c.path().join(file)).unwrap(),
            "{file}"
        );
    }
}

#[test]
fn json_files_are_pretty_and_start_with_their_format() {
    let dir = written(ALL);
    for (file, format) in [
        (MACHINE_FILE, "parcal-machine/1"),
        (ARTEFACTS_FILE, "parcal-artefacts/1"),
        (TRUTH_FILE, "parcal-truth/1"),
    ] {
        let text = fs::read_to_string(dir.path().join(file)).unwrap();
        assert!(
            text.starts_with(&format!("{{\n \"format\": \"{format}\",\n")),
            "{file}: {}",
            &text[..60]
        );
    }
    let truth = fs::read_to_string(dir.path().join(TRUTH_FILE)).unwrap();
    let ids = ["\"b01\": [", "\"b02\": [", "\"plate-3\": ["];
    let positions: Vec<usize> = ids.iter().map(|id| truth.find(id).unwrap()).collect();
    assert!(
        positions.is_sorted(),
        "ball_centres keyed by id in artefacts order"
    );
    let artefacts = fs::read_to_string(dir.path().join(ARTEFACTS_FILE)).unwrap();
    assert!(
        artefacts.contains("\"a\": \"b01\""),
        "distances name balls by id"
    );
    assert!(artefacts.contains("\"frame\": \"canonical\""));
}

#[test]
fn writing_creates_the_directory() {
    let root = tempfile::tempdir().unwrap();
    let dir = root.path().join("a/b/dataset");
    dataset(NONE).write(&dir).unwrap();
    assert_eq!(Dataset::read(&dir).unwrap(), dataset(NONE));
}

#[test]
fn a_dataset_is_replaced_only_when_asked_and_then_as_a_whole() {
    let dir = written(ALL);
    let error = dataset(NONE).write(dir.path()).unwrap_err().to_string();
    assert!(error.contains("exists and is not empty"), "{error}");
    assert!(dir.path().join(TRUTH_FILE).exists());
    let replace = WriteOptions {
        replace: true,
        ..Default::default()
    };
    dataset(NONE).write_with(dir.path(), &replace).unwrap();
    assert!(!dir.path().join(TRUTH_FILE).exists(), "no stale truth.json");
    assert_eq!(Dataset::read(dir.path()).unwrap().truth, None);
    // Only a dataset is replaced.
    let other = tempfile::tempdir().unwrap();
    fs::write(other.path().join("notes.txt"), "mine").unwrap();
    let error = dataset(NONE)
        .write_with(other.path(), &replace)
        .unwrap_err()
        .to_string();
    assert!(error.contains("not a dataset"), "{error}");
    assert!(other.path().join("notes.txt").exists());
}

#[test]
fn writing_leaves_no_temporary_files() {
    let dir = written(ALL);
    let mut names: Vec<String> = fs::read_dir(dir.path())
        .unwrap()
        .map(|e| e.unwrap().file_name().into_string().unwrap())
        .collect();
    names.sort();
    assert_eq!(
        names,
        [ARTEFACTS_FILE, MACHINE_FILE, MEASUREMENTS_FILE, TRUTH_FILE]
    );
}

#[test]
fn an_invalid_dataset_is_not_written_at_all() {
    let root = tempfile::tempdir().unwrap();
    let dir = root.path().join("out");
    let mut bad = dataset(ALL);
    bad.truth.as_mut().unwrap().contacts[7][2] = f64::NAN;
    let err = bad.write(&dir).unwrap_err().to_string();
    assert_error(
        &err,
        &dir,
        TRUTH_FILE,
        "field contacts[7][2]: value NaN is not a finite number",
    );
    assert!(!dir.exists(), "nothing is created");

    // Over an existing dataset, the old files stay as they were.
    let dir = written(NONE);
    let before = fs::read(dir.path().join(MEASUREMENTS_FILE)).unwrap();
    let mut bad = dataset(NONE);
    bad.measurements.q[4][2] = f64::INFINITY;
    let err = bad.write(dir.path()).unwrap_err().to_string();
    assert_error(
        &err,
        dir.path(),
        MEASUREMENTS_FILE,
        "line 6, column q3: value inf is not a finite number",
    );
    assert_eq!(
        fs::read(dir.path().join(MEASUREMENTS_FILE)).unwrap(),
        before
    );
}

#[test]
fn validate_names_the_file_and_field() {
    let mut bad = dataset(NONE);
    bad.artefacts.balls[1].radius = -5.0;
    assert_eq!(
        bad.validate().unwrap_err().to_string(),
        "artefacts.json: field balls[1].radius: must be positive, found -5"
    );
    let mut bad = dataset(NONE);
    bad.measurements.ball[3] = 3;
    assert_eq!(
        bad.validate().unwrap_err().to_string(),
        "measurements.csv: line 5, column ball: ball index 3 is out of range (3 balls)"
    );
    assert_eq!(
        bad.contacts_per_ball(),
        [4, 5, 5],
        "no panic on a bad index"
    );
}

#[test]
fn contacts_per_ball_counts_rows() {
    let mut d = dataset(NONE);
    assert_eq!(d.contacts_per_ball(), [5, 5, 5]);
    d.measurements.ball[0] = 2;
    assert_eq!(d.contacts_per_ball(), [4, 5, 6]);
}

/// The test dataset with `csv` as its measurements.csv, read allowing a
/// single contact per ball.
fn read_with_csv(csv: &str) -> Dataset {
    let dir = written(NONE);
    write_csv(dir.path(), csv);
    Dataset::read_with(
        dir.path(),
        &ReadOptions {
            min_contacts_per_ball: 1,
            ..ReadOptions::default()
        },
    )
    .unwrap()
}

#[test]
fn columns_may_come_in_any_order_and_extra_columns_are_ignored() {
    let csv = "q6, note ,q5,q4,q3,q2,q1,ball\n\
         6,x,5,4,3,2,1,b01\n\
         \n\
         6,\"a, b\",5,4,3,2,1.5e2,b02\n\
         6,,5,4,3,2,1,plate-3\n";
    let d = read_with_csv(csv);
    assert_eq!(d.measurements.ball, [0, 1, 2]);
    assert_eq!(d.measurements.q[0], [1.0, 2.0, 3.0, 4.0, 5.0, 6.0]);
    assert_eq!(d.measurements.q[1][0], 150.0);
    assert_eq!(d.measurements.direction, None);
}

#[test]
fn header_names_and_fields_are_trimmed_of_whitespace() {
    let csv = " ball ,q1,\tq2, q3 ,q4,q5,q6\r\n\
         \tb01 , 1 ,2,3,4,5, 6.5\t\r\n\
         b02,1,2,3,4,5,6\r\n\
         plate-3 ,1,2,3,4,5,6\r\n";
    let d = read_with_csv(csv);
    assert_eq!(d.measurements.ball, [0, 1, 2]);
    assert_eq!(d.measurements.q[0], [1.0, 2.0, 3.0, 4.0, 5.0, 6.5]);
}

#[test]
fn extra_json_fields_are_ignored() {
    let dir = written(ALL);
    for file in [MACHINE_FILE, ARTEFACTS_FILE, TRUTH_FILE] {
        edit_json(dir.path(), file, |v| {
            v["comment"] = "written by hand".into();
            v["nested"] = serde_json::json!({"a": [1, 2, {"b": null}]});
        });
    }
    edit_json(dir.path(), ARTEFACTS_FILE, |v| {
        v["balls"][0]["material"] = "ruby".into();
        v["distances"][0]["certificate"] = 17.into();
    });
    edit_json(dir.path(), MACHINE_FILE, |v| {
        v["prior_sigma"]["extra"] = 1.into();
        v["format"] = "parcal-machine/1.4".into();
    });
    assert_bitwise_eq(&Dataset::read(dir.path()).unwrap(), &dataset(ALL));
}

#[test]
fn the_reference_dataset_reads() {
    let dir = reference_dir();
    let d = Dataset::read(&dir).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(d.artefacts.balls.len(), 27);
    assert_eq!(d.measurements.len(), 189);
    assert_eq!(d.contacts_per_ball(), vec![7; 27]);
    assert_eq!(d.artefacts.frame, ArtefactFrame::Design);
    assert!(d.artefacts.distances.is_empty());
    assert_eq!(d.measurements.direction, None);
    assert_eq!(d.machine.geometry.base_joints[2], [-42.262, 90.631, 0.0]);
    assert_eq!(d.machine.geometry.leg_lengths, [235.0; 6]);
    assert_eq!(d.machine.repeatability.actuator, 0.001);
    assert_eq!(d.artefacts.balls[0].id, "b01");
    assert_eq!(d.artefacts.balls[0].radius, 4.999856933619536);
    assert_eq!(d.measurements.q[0][0], 98.8199849693);
    let truth = d.truth.as_ref().expect("truth.json is present");
    assert_eq!(truth.geometry.tool, [0.099, 0.053, 60.411]);
    assert_eq!(truth.geometry.leg_lengths[0], 234.934);
    assert_eq!(truth.contacts.len(), 189);
    assert_eq!(truth.ball_centres.len(), 27);
    assert!(truth.ball_radii.iter().all(|&r| r == 5.0));

    // And survives a round trip through parcal's own writer and a snapshot.
    let out = tempfile::tempdir().unwrap();
    d.write(out.path()).unwrap();
    assert_bitwise_eq(&Dataset::read(out.path()).unwrap(), &d);
    let snap = out.path().join("seed1.parcal");
    d.write_snapshot(&snap).unwrap();
    assert_bitwise_eq(&Dataset::read_snapshot(&snap).unwrap(), &d);
}

#[test]
fn parcal_s_own_fixture_is_rewritten_byte_for_byte() {
    // fixtures/paper-seed1 was written by parcal: reading and writing it
    // again gives the same files (field names, order, number forms).
    let fixture = reference_dir().with_file_name("paper-seed1");
    let d = Dataset::read(&fixture).unwrap_or_else(|e| panic!("{e}"));
    let out = tempfile::tempdir().unwrap();
    d.write(out.path()).unwrap();
    for file in [MACHINE_FILE, ARTEFACTS_FILE, MEASUREMENTS_FILE, TRUTH_FILE] {
        assert!(
            fs::read(fixture.join(file)).unwrap() == fs::read(out.path().join(file)).unwrap(),
            "{file} differs"
        );
    }
}

#[test]
fn the_reference_calibrations_read() {
    for (file, prior, iterations) in [
        ("reference-III-paper.json", "paper", 5),
        ("reference-IV-propagated.json", "propagated", 9),
    ] {
        let c = Calibration::read(&reference_dir().join(file)).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(c.prior, prior, "{file}");
        assert_eq!(c.parameters.names.len(), 33);
        assert_eq!(c.parameters.names[0], "y_b2");
        assert_eq!(c.parameters.values.len(), 33);
        assert_eq!(c.covariance.len(), 33);
        assert!(c.covariance.iter().all(|row| row.len() == 33));
        assert_eq!(c.ball_centres.len(), 27);
        assert_eq!(c.iterations.len(), iterations);
        assert!(c.converged);
        assert_eq!(c.status, "converged");
        assert_eq!(c.options["weights"], "prop");
        assert!(c.options.contains_key("centre_sigma"));
        assert_eq!(c.canonical.base_joints[0], [0.0; 3]);

        let out = tempfile::tempdir().unwrap();
        let path = out.path().join(CALIBRATION_FILE);
        c.write(&path).unwrap();
        assert_bitwise_eq(&Calibration::read(&path).unwrap(), &c);
    }
}

#[test]
fn calibration_round_trips_and_defaults_status_and_options() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join(CALIBRATION_FILE);
    let c = calibration();
    c.write(&path).unwrap();
    assert_bitwise_eq(&Calibration::read(&path).unwrap(), &c);
    let text = fs::read_to_string(&path).unwrap();
    assert!(text.starts_with("{\n \"format\": \"parcal-calibration/1\",\n \"canonical\""));

    // The design is machine.json's object, without its format.
    let design: serde_json::Value = serde_json::from_str(&text).unwrap();
    let design = &design["design"];
    assert_eq!(design["stroke"], serde_json::json!([-5.0, 105.0]));
    assert!(design["base_joints"].is_array() && design.get("format").is_none());

    edit_json(dir.path(), CALIBRATION_FILE, |v| {
        let object = v.as_object_mut().unwrap();
        object.remove("status");
        object.remove("options");
        object.remove("design");
    });
    let read = Calibration::read(&path).unwrap();
    assert_eq!(read.status, "");
    assert!(read.options.is_empty());
    assert_eq!((&read.design, read.actuator()), (&None, None));
}

#[test]
fn the_design_of_a_calibration_is_checked_and_named() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join(CALIBRATION_FILE);
    let mut c = calibration();
    c.design.as_mut().unwrap().stroke = Some([3.0, 1.0]);
    assert_error(
        &c.write(&path).unwrap_err().to_string(),
        dir.path(),
        CALIBRATION_FILE,
        "field design.stroke: must be [min, max] with min < max, found [3, 1]",
    );
    calibration().write(&path).unwrap();
    edit_json(dir.path(), CALIBRATION_FILE, |v| {
        v["design"]["prior_sigma"]["leg"] = serde_json::json!(0.0);
    });
    assert_error(
        &Calibration::read(&path).unwrap_err().to_string(),
        dir.path(),
        CALIBRATION_FILE,
        "field design.prior_sigma.leg: must be positive, found 0",
    );
    // Without a calibrated machine, the design's actuator applies.
    assert_eq!(calibration().actuator(), Some(&Actuator::default()));
}

#[test]
fn calibration_errors_name_the_file_and_field() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join(CALIBRATION_FILE);

    let mut c = calibration();
    c.canonical.tool[1] = f64::INFINITY;
    assert_error(
        &c.write(&path).unwrap_err().to_string(),
        dir.path(),
        CALIBRATION_FILE,
        "field canonical.tool[1]: value inf is not a finite number",
    );

    let mut c = calibration();
    c.diagnostics.as_mut().unwrap().systematic_tests[0].sigma = f64::NAN;
    assert_error(
        &c.write(&path).unwrap_err().to_string(),
        dir.path(),
        CALIBRATION_FILE,
        "field diagnostics.systematic_tests[0].sigma: value NaN",
    );

    let mut c = calibration();
    c.iterations[0].cost = f64::NAN;
    let err = c.write(&path).unwrap_err().to_string();
    assert_error(
        &err,
        dir.path(),
        CALIBRATION_FILE,
        "field iterations[0].cost: value NaN",
    );
    assert!(!path.exists());

    calibration().write(&path).unwrap();
    edit_json(dir.path(), CALIBRATION_FILE, |v| {
        v["covariance"][1] = serde_json::json!([1.0, 2.0]);
    });
    let err = Calibration::read(&path).unwrap_err().to_string();
    assert_error(
        &err,
        dir.path(),
        CALIBRATION_FILE,
        "field covariance[1]: expected 3 columns, found 2",
    );

    calibration().write(&path).unwrap();
    edit_json(dir.path(), CALIBRATION_FILE, |v| {
        v["parameters"]["sigma"] = serde_json::json!([1.0]);
    });
    let err = Calibration::read(&path).unwrap_err().to_string();
    assert_error(
        &err,
        dir.path(),
        CALIBRATION_FILE,
        "field parameters.sigma: expected 3 values (one per name), found 1",
    );

    calibration().write(&path).unwrap();
    edit_json(dir.path(), CALIBRATION_FILE, |v| {
        v.as_object_mut().unwrap().remove("converged");
    });
    let err = Calibration::read(&path).unwrap_err().to_string();
    assert_error(
        &err,
        dir.path(),
        CALIBRATION_FILE,
        "field converged: required field is missing",
    );

    calibration().write(&path).unwrap();
    edit_json(dir.path(), CALIBRATION_FILE, |v| {
        v["format"] = "parcal-calibration/3.1".into();
    });
    let err = Calibration::read(&path).unwrap_err().to_string();
    assert_error(
        &err,
        dir.path(),
        CALIBRATION_FILE,
        "has unknown major version 3",
    );

    let err = Calibration::read(&dir.path().join("absent.json"))
        .unwrap_err()
        .to_string();
    assert_error(&err, dir.path(), "absent.json", "required file not found");
}

#[test]
fn a_key_given_twice_in_calibration_json_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join(CALIBRATION_FILE);
    calibration().write(&path).unwrap();
    let text = fs::read_to_string(&path).unwrap();
    let entry = "\"ball_centres\": {";
    assert!(text.contains(entry), "{text}");
    let twice = text.replacen(
        entry,
        &format!("{entry} \"b01\": {{\"centre\": [0, 0, 0], \"sigma\": [1, 1, 1]}},"),
        1,
    );
    fs::write(&path, twice).unwrap();
    let err = Calibration::read(&path).unwrap_err().to_string();
    assert_error(
        &err,
        dir.path(),
        CALIBRATION_FILE,
        "field ball_centres: key \"b01\" is given twice",
    );
}

/// Balls keyed in another order than the artefacts' are read by their
/// ids, as in order.
#[test]
fn the_truths_balls_read_in_any_order() {
    let original = dataset(ALL);
    let dir = tempfile::tempdir().unwrap();
    original.write(dir.path()).unwrap();
    let path = dir.path().join(TRUTH_FILE);
    let mut truth: serde_json::Value =
        serde_json::from_str(&fs::read_to_string(&path).unwrap()).unwrap();
    let mut reversed = Vec::new();
    for key in ["ball_centres", "ball_radii"] {
        let entries: Vec<String> = (truth[key].as_object().unwrap().iter().rev())
            .map(|(id, value)| format!("{}: {value}", serde_json::Value::from(id.as_str())))
            .collect();
        reversed.push((format!("\"@{key}\""), format!("{{{}}}", entries.join(", "))));
        truth[key] = serde_json::Value::from(format!("@{key}"));
    }
    let mut text = truth.to_string();
    for (placeholder, object) in &reversed {
        text = text.replace(placeholder, object);
    }
    assert!(text.find("\"plate-3\"").unwrap() < text.find("\"b01\"").unwrap());
    fs::write(&path, text).unwrap();
    let read = Dataset::read(dir.path()).unwrap();
    assert_eq!(read.truth, original.truth);
}

#[test]
fn the_truth_reads_without_its_contact_points() {
    let original = dataset(ALL);
    let dir = tempfile::tempdir().unwrap();
    original.write(dir.path()).unwrap();
    let options = ReadOptions {
        true_contacts: false,
        ..ReadOptions::default()
    };
    let read = Dataset::read_with(dir.path(), &options).unwrap();
    let (truth, expected) = (
        read.truth.as_ref().unwrap(),
        original.truth.as_ref().unwrap(),
    );
    assert!(truth.contacts.is_empty() && !expected.contacts.is_empty());
    let mut without = expected.clone();
    without.contacts.clear();
    assert_eq!(truth, &without);
    assert_bitwise_eq(
        &Dataset {
            truth: original.truth.clone(),
            ..read.clone()
        },
        &original,
    );
    // Such a truth is not written as a dataset's.
    let error = read.write(tempfile::tempdir().unwrap().path()).unwrap_err();
    assert!(error.to_string().contains("contact points"), "{error}");
}
