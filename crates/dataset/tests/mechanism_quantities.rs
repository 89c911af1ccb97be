//! A mechanism dataset's measured quantities (`quantities.csv`) and the
//! samples' loads (`f1..fA` in `points.csv`): written and read back, and
//! bad files refused naming the file, the line and the column.

use std::fs;
use std::path::Path;

use parcal_dataset::mechanism::{
    MechanismDataset, MechanismMachine, Noise, QuantityRow, RowNames, SampleRow,
};
use parcal_kinematics::cable::CableRobot;

/// A cable robot's dataset: three samples, two with loads, and the four
/// line lengths at the encoder zero.
fn cable_dataset() -> MechanismDataset {
    let mut machine = MechanismMachine::of(&CableRobot::typical());
    machine.noise = Noise {
        actuator: Some(18.0),
        position: Some(0.1),
        ..Noise::default()
    };
    let samples = vec![
        SampleRow {
            readings: vec![0.0, -0.07, 0.0, 0.0],
            position: Some([-0.5, -0.6, 0.0]),
            loads: Some(vec![13.72, 14.54, 14.07, 12.49]),
        },
        SampleRow {
            readings: vec![-4834.89, 7431.31, -1079.36, 1309.72],
            position: None,
            loads: Some(vec![7.7, 13.37, 12.66, 17.58]),
        },
        SampleRow {
            readings: vec![4036.97, 3243.27, 10617.52, -32192.57],
            position: None,
            loads: None,
        },
    ];
    let quantities = [("a", 1597.0), ("b", 1795.0), ("c", 1582.5), ("d", 2355.0)]
        .iter()
        .map(|(line, value)| QuantityRow {
            quantity: format!("line_length_{line}"),
            value: *value,
            sigma: 10.0,
        })
        .collect();
    MechanismDataset {
        machine,
        samples,
        quantities,
        ..MechanismDataset::default()
    }
}

fn written(dataset: &MechanismDataset) -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    dataset.write(&dir.path().join("cable")).unwrap();
    dir
}

fn read_error(dir: &Path) -> String {
    MechanismDataset::read(dir).unwrap_err().to_string()
}

#[test]
fn quantities_and_loads_are_written_and_read_back() {
    let dataset = cable_dataset();
    let dir = written(&dataset);
    let path = dir.path().join("cable");
    assert_eq!(MechanismDataset::read(&path).unwrap(), dataset);
    let points = fs::read_to_string(path.join("points.csv")).unwrap();
    assert!(
        points.starts_with("q1,q2,q3,q4,x,y,z,f1,f2,f3,f4\n"),
        "{points}"
    );
    // Without loads, no load columns.
    let mut rigid = dataset.clone();
    for sample in &mut rigid.samples {
        sample.loads = None;
    }
    let dir = written(&rigid);
    let points = fs::read_to_string(dir.path().join("cable/points.csv")).unwrap();
    assert!(points.starts_with("q1,q2,q3,q4,x,y,z\n"), "{points}");
    assert_eq!(
        MechanismDataset::read(&dir.path().join("cable")).unwrap(),
        rigid
    );
}

#[test]
fn bad_quantities_and_loads_are_named() {
    let dir = written(&cable_dataset());
    let path = dir.path().join("cable");
    let quantities = path.join("quantities.csv");
    let cases = [
        (
            "quantity,value,sigma\nline_length_a,1597,10\nline_length_e,1600,10\n",
            &[
                "quantities.csv",
                "line 3",
                "quantity",
                "line_length_e",
                "line_length_d",
            ][..],
        ),
        (
            "quantity,value,sigma\nline_length_a,1597,0\n",
            &["quantities.csv", "line 2", "sigma", "positive"][..],
        ),
        (
            "quantity,value,sigma\nline_length_a,long,10\n",
            &["quantities.csv", "line 2", "value"][..],
        ),
        (
            "quantity,value\nline_length_a,1597\n",
            &["quantities.csv", "sigma"][..],
        ),
        (
            "quantity,value,sigma,unit\nline_length_a,1597,10,mm\n",
            &[
                "quantities.csv",
                "column \"unit\", which is not one of this file's",
            ][..],
        ),
    ];
    for (text, expected) in cases {
        fs::write(&quantities, text).unwrap();
        let error = read_error(&path);
        for part in expected {
            assert!(error.contains(part), "{part:?} not in {error}");
        }
    }
    fs::remove_file(&quantities).unwrap();
    let points = path.join("points.csv");
    let cases = [
        (
            "q1,q2,q3,q4,x,y,z,f1,f2\n0,0,0,0,,,,1,2\n",
            &["points.csv", "line 1", "load columns"][..],
        ),
        (
            "q1,q2,q3,q4,x,y,z,f1,f2,f3,f4\n0,0,0,0,,,,1,2,,4\n",
            &["points.csv", "line 2", "loads f1,f2,f3,f4"][..],
        ),
        (
            "q1,q2,q3,q4,x,y,z,f1,f2,f3,f4\n0,0,0,0,,,,1,2,x,4\n",
            &["points.csv", "line 2", "f3"][..],
        ),
        (
            "q1,q2,q3,q4,x,y,z,load1\n0,0,0,0,,,,1\n",
            &[
                "points.csv",
                "line 1",
                "column \"load1\", which is not one of this file's",
            ][..],
        ),
    ];
    for (text, expected) in cases {
        fs::write(&points, text).unwrap();
        let error = read_error(&path);
        for part in expected {
            assert!(error.contains(part), "{part:?} not in {error}");
        }
    }
}

/// A dataset is checked before it is written: a value that is not a number
/// is named by the line its row would have and its column's name; built in
/// memory (Python's), by its row's 0-based index.
#[test]
fn a_bad_value_is_named_by_its_line_or_in_memory_its_row_and_column() {
    let dir = tempfile::tempdir().unwrap();
    let error = |change: &dyn Fn(&mut MechanismDataset)| {
        let mut dataset = cable_dataset();
        change(&mut dataset);
        dataset
            .write(&dir.path().join("cable"))
            .unwrap_err()
            .to_string()
    };
    let mut in_memory = cable_dataset();
    in_memory.samples[1].loads.as_mut().unwrap()[2] = f64::NAN;
    let indexed = in_memory.validate_named(Path::new("(in memory)"), RowNames::Indices);
    assert_eq!(
        indexed.unwrap_err().to_string(),
        "(in memory)/points.csv: field row 1, column f3: value NaN is not a finite number"
    );
    let load = error(&|d| d.samples[1].loads.as_mut().unwrap()[2] = f64::NAN);
    assert!(
        load.ends_with("points.csv: field line 3, column f3: value NaN is not a finite number"),
        "{load}"
    );
    let position = error(&|d| d.samples[0].position.as_mut().unwrap()[1] = f64::INFINITY);
    assert!(
        position.ends_with("points.csv: field line 2, column y: value inf is not a finite number"),
        "{position}"
    );
    let value = error(&|d| d.quantities[3].value = f64::NAN);
    assert!(
        value.ends_with(
            "quantities.csv: field line 5, column value: value NaN is not a finite number"
        ),
        "{value}"
    );
}
