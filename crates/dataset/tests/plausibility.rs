//! One validation for reading, reading a snapshot and writing: what a
//! calibration would refuse (a zero approach direction, a degenerate
//! geometry, a ball with too few contacts) and what is implausible (a
//! tool 1 km away, a sigma whose weight overflows) is refused at reading,
//! naming the file and the field or line, and is not written.

use crate::common;

use std::fs;
use std::path::Path;

use common::*;
use parcal_dataset::*;

/// `damaged` is refused by `validate` and by `write` with `message` about
/// `file`, and so is the dataset of `dir` (valid files damaged the same
/// way by `damage_files`) when read.
fn refused_everywhere(
    damaged: &Dataset,
    damage_files: impl FnOnce(&Path),
    file: &str,
    message: &str,
) {
    let validated = damaged.validate().unwrap_err().to_string();
    assert_eq!(validated, format!("{file}: {message}"));
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    let written = damaged.write(&out).unwrap_err().to_string();
    assert_eq!(written, format!("{}: {message}", out.join(file).display()));
    assert!(!out.join(MACHINE_FILE).exists(), "nothing is written");
    let snapshot = dir.path().join("d.parcal");
    let err = damaged.write_snapshot(&snapshot).unwrap_err().to_string();
    assert_eq!(err, format!("{}: {message}", snapshot.display()));

    let files = common::written(damaged_parts(damaged));
    damage_files(files.path());
    let read = read_error(files.path());
    assert_eq!(
        read,
        format!("{}: {message}", files.path().join(file).display())
    );
}

fn damaged_parts(d: &Dataset) -> Parts {
    Parts {
        truth: d.truth.is_some(),
        directions: d.measurements.direction.is_some(),
        distances: !d.artefacts.distances.is_empty(),
    }
}

/// Replaces row `row` (0-based) of measurements.csv by `line`.
fn replace_row(dir: &Path, row: usize, line: &str) {
    let path = dir.join(MEASUREMENTS_FILE);
    let text = fs::read_to_string(&path).unwrap();
    let mut lines: Vec<&str> = text.lines().collect();
    lines[row + 1] = line;
    fs::write(&path, lines.join("\n") + "\n").unwrap();
}

#[test]
fn the_valid_dataset_passes_every_check() {
    dataset(ALL).validate().unwrap();
}

#[test]
fn an_approach_direction_that_does_not_normalise_is_refused_with_its_line() {
    for (direction, text, why) in [
        (
            [0.0, 0.0, 0.0],
            "0,0,0",
            "(0, 0, 0) is zero, not a direction",
        ),
        (
            [0.0, 0.0, 1e300],
            "0,0,1e300",
            "(0, 0, 1e300) is too large to normalise (its length overflows); give a unit vector",
        ),
        (
            [1e-200, 0.0, 0.0],
            "1e-200,0,0",
            "(1e-200, 0, 0) is too small to normalise (its length underflows to 0); give a unit vector",
        ),
    ] {
        let mut d = dataset(ALL);
        d.measurements.direction.as_mut().unwrap()[3] = direction;
        let q = d.measurements.q[3].map(|v| v.to_string()).join(",");
        refused_everywhere(
            &d,
            |dir| replace_row(dir, 3, &format!("b01,{q},{text}")),
            MEASUREMENTS_FILE,
            &format!("line 5: the approach direction {why}"),
        );
    }
}

#[test]
fn a_tool_a_kilometre_away_is_refused_naming_the_field() {
    let mut d = dataset(NONE);
    d.machine.geometry.tool[2] = 1e12;
    refused_everywhere(
        &d,
        |dir| edit_json(dir, MACHINE_FILE, |v| v["tool"][2] = 1e12.into()),
        MACHINE_FILE,
        "field tool[2]: 1e12 mm is beyond the 1e6 mm (1 km) a length may have (a unit error?)",
    );
    let mut d = dataset(NONE);
    d.artefacts.balls[1].radius = 2e6;
    refused_everywhere(
        &d,
        |dir| {
            edit_json(dir, ARTEFACTS_FILE, |v| {
                v["balls"][1]["radius"] = 2e6.into()
            })
        },
        ARTEFACTS_FILE,
        "field balls[1].radius: 2e6 mm is beyond the 1e6 mm (1 km) a length may have (a unit error?)",
    );
}

#[test]
fn a_reading_that_extends_its_leg_beyond_a_kilometre_is_refused() {
    let mut d = dataset(NONE);
    d.measurements.q[0][2] = -3e6;
    let mut q = d.measurements.q[0].map(|v| v.to_string());
    q[2] = "-3e6".into();
    refused_everywhere(
        &d,
        |dir| replace_row(dir, 0, &format!("b01,{}", q.join(","))),
        MEASUREMENTS_FILE,
        "line 2, column q3: the reading -3e6 extends its leg by -3e6 mm, beyond \
         the 1e6 mm (1 km) a length may have (a unit error?)",
    );
}

#[test]
fn a_sigma_whose_weight_overflows_is_refused_naming_the_field() {
    let mut d = dataset(NONE);
    d.machine.repeatability.actuator = 1e-300;
    refused_everywhere(
        &d,
        |dir| {
            edit_json(dir, MACHINE_FILE, |v| {
                v["repeatability"]["actuator"] = 1e-300.into()
            })
        },
        MACHINE_FILE,
        "field repeatability.actuator: a standard deviation of 1e-300 is too small: it must be \
         at least 1e-12 (its weight 1/sigma^2 is used in the fit)",
    );
}

#[test]
fn a_degenerate_machine_or_truth_geometry_is_refused() {
    let mut d = dataset(ALL);
    let collinear = [[0.0, 0.0, 0.0], [10.0, 0.0, 0.0], [20.0, 0.0, 0.0]];
    d.truth.as_mut().unwrap().geometry.base_joints[..3].copy_from_slice(&collinear);
    refused_everywhere(
        &d,
        |dir| {
            edit_json(dir, TRUTH_FILE, |v| {
                for (i, p) in collinear.iter().enumerate() {
                    v["base_joints"][i] = serde_json::json!(p);
                }
            })
        },
        TRUTH_FILE,
        "field base_joints: degenerate geometry: base joints 1, 2 and 3 are collinear \
         (sine of their angle 0.000e0): they cannot define the canonical frame",
    );
    let mut d = dataset(NONE);
    d.machine.geometry.platform_joints[3] = d.machine.geometry.platform_joints[0];
    let first = d.machine.geometry.platform_joints[0];
    refused_everywhere(
        &d,
        |dir| {
            edit_json(dir, MACHINE_FILE, |v| {
                v["platform_joints"][3] = serde_json::json!(first);
            })
        },
        MACHINE_FILE,
        "field platform_joints: degenerate geometry: platform joints 1 and 4 coincide",
    );
}

#[test]
fn a_ball_with_too_few_contacts_is_not_written() {
    let mut d = dataset(NONE);
    // Ball 0 ("b01") loses two of its five contacts.
    let keep: Vec<usize> = (0..d.measurements.len())
        .filter(|&r| r != 0 && r != 3)
        .collect();
    d.measurements.ball = keep.iter().map(|&r| d.measurements.ball[r]).collect();
    d.measurements.q = keep.iter().map(|&r| d.measurements.q[r]).collect();
    let message = "ball \"b01\" has 3 contacts, fewer than the minimum of 4";
    let dir = tempfile::tempdir().unwrap();
    assert_eq!(
        d.write(dir.path()).unwrap_err().to_string(),
        format!(
            "{}: {message}",
            dir.path().join(MEASUREMENTS_FILE).display()
        )
    );
    assert_eq!(
        d.validate().unwrap_err().to_string(),
        format!("{MEASUREMENTS_FILE}: {message}")
    );
    // The reader says the same of such files.
    let files = written(NONE);
    let text = fs::read_to_string(files.path().join(MEASUREMENTS_FILE)).unwrap();
    let lines: Vec<&str> = text.lines().collect();
    let kept: Vec<&str> = std::iter::once(lines[0])
        .chain(keep.iter().map(|&r| lines[r + 1]))
        .collect();
    write_csv(files.path(), &(kept.join("\n") + "\n"));
    assert_error(
        &read_error(files.path()),
        files.path(),
        MEASUREMENTS_FILE,
        message,
    );
}
