//! A mechanism dataset's calibrated balls (`balls.csv`), their touches
//! (`touches.csv`) and the calibrated distances between them
//! (`ball_distances.csv`): written and read back, a dataset without them
//! read as before, and bad files refused naming the file, the line and the
//! column.

use std::fs;

use parcal_dataset::Distance;
use parcal_dataset::mechanism::{
    BALL_DISTANCES_FILE, BallPlacement, BallRow, MechanismDataset, MechanismMachine, Noise,
    TouchRow,
};
use parcal_kinematics::delta::LinearDelta;

/// A delta's dataset: two probes, two balls (the second exact), five
/// touches.
fn touched() -> MechanismDataset {
    let mut machine = MechanismMachine::of(&LinearDelta::typical());
    machine.noise = Noise {
        probe: Some(0.01),
        touch: Some(0.005),
        ..Noise::default()
    };
    let touch = |ball, x: f64| TouchRow {
        ball,
        commanded: [x, -20.0, 12.5],
    };
    MechanismDataset {
        machine,
        probes: vec![[0.0, 0.0, 0.71], [50.0, 20.0, 0.69]],
        balls: vec![
            BallRow {
                radius: 12.7,
                radius_sigma: Some(0.001),
                placement: None,
            },
            BallRow {
                radius: 6.35,
                radius_sigma: None,
                placement: None,
            },
        ],
        touches: vec![
            touch(0, 1.0),
            touch(1, 2.0),
            touch(0, 3.0),
            touch(1, 4.0),
            touch(0, 5.5),
        ],
        ..MechanismDataset::default()
    }
}

#[test]
fn balls_and_touches_are_written_and_read_back() {
    let dataset = touched();
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("delta");
    dataset.write(&path).unwrap();
    assert_eq!(MechanismDataset::read(&path).unwrap(), dataset);
    let balls = fs::read_to_string(path.join("balls.csv")).unwrap();
    assert!(
        balls.starts_with("ball,radius,radius_sigma\n0,12.7,0.001\n1,6.35,\n"),
        "{balls}"
    );
    // The second ball placed within 0.5 mm: the placement columns, empty
    // for the first.
    let mut placed = dataset.clone();
    placed.balls[1].placement = Some(BallPlacement {
        centre: [30.0, -20.0, 6.35],
        sigma: 0.5,
    });
    let path = dir.path().join("placed");
    placed.write(&path).unwrap();
    assert_eq!(MechanismDataset::read(&path).unwrap(), placed);
    let balls = fs::read_to_string(path.join("balls.csv")).unwrap();
    assert!(
        balls.starts_with(
            "ball,radius,radius_sigma,x,y,z,centre_sigma\n0,12.7,0.001,,,,\n1,6.35,,30,-20,6.35,0.5\n"
        ),
        "{balls}"
    );
    // Without them, no file, and the dataset reads as before.
    let plain = MechanismDataset {
        balls: Vec::new(),
        touches: Vec::new(),
        ..dataset
    };
    let path = dir.path().join("plain");
    plain.write(&path).unwrap();
    assert!(!path.join("balls.csv").exists() && !path.join("touches.csv").exists());
    assert_eq!(MechanismDataset::read(&path).unwrap(), plain);
}

#[test]
fn bad_balls_and_touches_are_named() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("delta");
    touched().write(&path).unwrap();
    let (balls, touches) = (path.join("balls.csv"), path.join("touches.csv"));
    let good_balls = fs::read_to_string(&balls).unwrap();
    let good_touches = fs::read_to_string(&touches).unwrap();
    let ball_cases = [
        (
            "ball,radius,radius_sigma\n0,12.7,\n2,5,\n",
            &["balls.csv", "line 3", "ball", "this row's number, 1"][..],
        ),
        (
            "ball,radius,radius_sigma\n0,-1,\n",
            &["balls.csv", "line 2", "radius", "not positive"][..],
        ),
        (
            "ball,radius,radius_sigma\n0,12.7,0\n",
            &[
                "balls.csv",
                "line 2",
                "radius_sigma",
                "exact: leave it empty",
            ][..],
        ),
        ("ball,radius\n0,12.7\n", &["balls.csv", "radius_sigma"][..]),
        (
            "ball,radius,radius_sigma,x,y,z\n0,12.7,,1,2,3\n",
            &["balls.csv", "placement columns x,y,z,centre_sigma"][..],
        ),
        (
            "ball,radius,radius_sigma,x,y,z,centre_sigma\n0,12.7,,1,,3,0.5\n",
            &["balls.csv", "line 2", "placement", "whole"][..],
        ),
        (
            "ball,radius,radius_sigma,x,y,z,centre_sigma\n0,12.7,,1,2,3,0\n",
            &["balls.csv", "line 2", "centre_sigma", "positive"][..],
        ),
    ];
    for (text, expected) in ball_cases {
        fs::write(&balls, text).unwrap();
        let error = MechanismDataset::read(&path).unwrap_err().to_string();
        for part in expected {
            assert!(error.contains(part), "{part:?} not in {error}");
        }
    }
    fs::write(&balls, &good_balls).unwrap();
    let touch_cases = [
        (
            "ball,x,y,z\n0,1,2,3\n2,1,2,3\n",
            &["touches.csv", "line 3", "ball", "which has 2"][..],
        ),
        (
            "ball,x,y,z\n0.5,1,2,3\n",
            &["touches.csv", "line 2", "ball"][..],
        ),
        (
            "ball,x,y,z\n0,1,two,3\n",
            &["touches.csv", "line 2", "y"][..],
        ),
    ];
    for (text, expected) in touch_cases {
        fs::write(&touches, text).unwrap();
        let error = MechanismDataset::read(&path).unwrap_err().to_string();
        for part in expected {
            assert!(error.contains(part), "{part:?} not in {error}");
        }
    }
    // Touches without balls, balls without touches.
    fs::remove_file(&balls).unwrap();
    fs::write(&touches, &good_touches).unwrap();
    let error = MechanismDataset::read(&path).unwrap_err().to_string();
    assert!(
        error.contains("touches.csv") && error.contains("balls.csv"),
        "{error}"
    );
    fs::write(&balls, &good_balls).unwrap();
    fs::remove_file(&touches).unwrap();
    let error = MechanismDataset::read(&path).unwrap_err().to_string();
    assert!(
        error.contains("balls.csv") && error.contains("touches.csv"),
        "{error}"
    );
    // The touches' noise is required.
    let mut silent = touched();
    silent.machine.noise.touch = None;
    let error = silent
        .write(&dir.path().join("silent"))
        .unwrap_err()
        .to_string();
    assert!(error.contains("noise.touch"), "{error}");
}

/// [`touched`] with a third ball and a ball plate's distances between
/// the three.
fn plated() -> MechanismDataset {
    let mut dataset = touched();
    dataset.balls.push(dataset.balls[0]);
    dataset.touches.push(TouchRow {
        ball: 2,
        commanded: [7.0, 20.0, 12.5],
    });
    let distance = |a, b, length| Distance {
        a,
        b,
        length,
        sigma: 0.0015,
    };
    dataset.ball_distances = vec![
        distance(0, 1, 60.25),
        distance(2, 0, 104.5),
        distance(1, 2, 60.125),
    ];
    dataset
}

#[test]
fn ball_distances_are_written_and_read_back() {
    let dataset = plated();
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("plated");
    dataset.write(&path).unwrap();
    assert_eq!(MechanismDataset::read(&path).unwrap(), dataset);
    let text = fs::read_to_string(path.join(BALL_DISTANCES_FILE)).unwrap();
    assert_eq!(
        text,
        "first,second,distance,sigma\n0,1,60.25,0.0015\n2,0,104.5,0.0015\n1,2,60.125,0.0015\n"
    );
    // Without them, no file.
    let path = dir.path().join("touched");
    touched().write(&path).unwrap();
    assert!(!path.join(BALL_DISTANCES_FILE).exists());
}

#[test]
fn bad_ball_distances_are_named() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("plated");
    plated().write(&path).unwrap();
    let file = path.join(BALL_DISTANCES_FILE);
    let header = "first,second,distance,sigma\n";
    let cases = [
        (
            "0,3,60,0.001\n",
            &["line 2", "column second", "which has 3"][..],
        ),
        (
            "0.5,1,60,0.001\n",
            &["line 2", "column first", "is not the number"][..],
        ),
        (
            "1,1,60,0.001\n",
            &["line 2", "column second", "two balls"][..],
        ),
        (
            "0,1,0,0.001\n",
            &["line 2", "column distance", "not positive"][..],
        ),
        (
            "0,1,60,-1\n",
            &["line 2", "column sigma", "not positive"][..],
        ),
        ("0,1,60,\n", &["line 2", "column sigma", "empty field"][..]),
        (
            "0,1,60,0.001\n0,2,90,0.001\n\n1,0,60,0.001\n",
            &["line 5", "balls 1 and 0 is given twice, first on line 2"][..],
        ),
    ];
    for (rows, expected) in cases {
        fs::write(&file, format!("{header}{rows}")).unwrap();
        let error = MechanismDataset::read(&path).unwrap_err().to_string();
        assert!(error.contains(BALL_DISTANCES_FILE), "{error}");
        for part in expected {
            assert!(error.contains(part), "{part:?} not in {error}");
        }
    }
    for (text, expected) in [
        ("first,second,distance\n0,1,60\n", "no column sigma"),
        (header, "no ball distance row"),
        ("", "empty"),
    ] {
        fs::write(&file, text).unwrap();
        let error = MechanismDataset::read(&path).unwrap_err().to_string();
        assert!(
            error.contains(BALL_DISTANCES_FILE)
                && error.contains("line 1")
                && error.contains(expected),
            "{error}"
        );
    }
    // Distances without balls: on file and in memory.
    fs::write(&file, format!("{header}0,1,60,0.001\n")).unwrap();
    fs::remove_file(path.join("balls.csv")).unwrap();
    fs::remove_file(path.join("touches.csv")).unwrap();
    let error = MechanismDataset::read(&path).unwrap_err().to_string();
    assert!(
        error.contains(BALL_DISTANCES_FILE) && error.contains("need balls.csv"),
        "{error}"
    );
    let unballed = MechanismDataset {
        balls: Vec::new(),
        touches: Vec::new(),
        ..plated()
    };
    let error = unballed
        .write(&dir.path().join("unballed"))
        .unwrap_err()
        .to_string();
    assert!(
        error.contains(BALL_DISTANCES_FILE) && error.contains("need balls.csv"),
        "{error}"
    );
    // Written from memory, the same checks name the line the row would
    // have.
    let mut twice = plated();
    twice.ball_distances[2] = Distance {
        a: 1,
        b: 0,
        ..twice.ball_distances[2]
    };
    let error = twice
        .write(&dir.path().join("twice"))
        .unwrap_err()
        .to_string();
    assert!(
        error.contains(BALL_DISTANCES_FILE)
            && error.contains("line 4")
            && error.contains("first in line 2"),
        "{error}"
    );
}
