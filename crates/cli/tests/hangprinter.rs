//! The Hangprinter end to end: its real data (`fixtures/hangprinter`)
//! calibrated, exported as the firmware's `M669`/`M666 R` lines and read
//! back; a cable robot's calibration refused by a delta's format.

use crate::common;

use std::fs;
use std::path::Path;

use common::{copy_fixture, fails, ok, s};
use parcal::firmware::hangprinter::read_config;

/// `parcal export` of `calibration` as the Hangprinter's lines into
/// `out`; what it said.
fn export_hangprinter(calibration: &std::path::Path, out: &std::path::Path) -> String {
    ok(&[
        "export",
        "--calibration",
        s(calibration),
        "--format",
        "hangprinter",
        "--out",
        s(out),
    ])
}

#[test]
fn calibrate_export_reads_back_the_anchors_and_radii() {
    let dir = tempfile::tempdir().unwrap();
    let data = copy_fixture("hangprinter", dir.path(), &["machine.json", "points.csv"]);
    let summary = ok(&["calibrate", s(&data)]);
    assert!(summary.contains("accepted"), "{summary}");
    let calibration = data.join("calibration.json");
    let out = dir.path().join("anchors.g");
    export_hangprinter(&calibration, &out);
    let back = read_config(&out).unwrap();
    let record: serde_json::Value =
        serde_json::from_str(&fs::read_to_string(&calibration).unwrap()).unwrap();
    let value = |name: &str| -> f64 {
        record["parameters"]
            .as_array()
            .unwrap()
            .iter()
            .find(|p| p["name"] == name)
            .unwrap_or_else(|| panic!("{name} in {record}"))["value"]
            .as_f64()
            .unwrap()
    };
    // Anchors relative to the encoder zero, written to 0.01 mm; radii to
    // 0.001 mm: read back within half a step.
    for (j, letter) in ["a", "b", "c", "d"].iter().enumerate() {
        for (k, axis) in ["x", "y", "z"].iter().enumerate() {
            let calibrated =
                value(&format!("anchor_{letter}_{axis}")) - value(&format!("zero_{axis}"));
            let read = back.anchors[j][k];
            assert!(
                (calibrated - read).abs() <= 0.005 + 1e-9,
                "{letter} {axis}: {calibrated} vs {read}"
            );
        }
        let radius = value(&format!("radius_{letter}"));
        assert!((radius - back.spool_radii[j]).abs() <= 0.0005 + 1e-9);
    }
    let error = fails(&[
        "export",
        "--calibration",
        s(&calibration),
        "--format",
        "klipper",
        "--print-radius",
        "100",
        "--out",
        s(&dir.path().join("printer.cfg")),
    ]);
    assert!(error.contains("a cable robot calibration"), "{error}");
}

/// The discarded hp-mark positions as a held-out dataset: the fixture's
/// machine.json, and points.csv with the readings of each sample of
/// untrusted.csv and hp-mark's position.
fn untrusted_dataset(dir: &std::path::Path) -> std::path::PathBuf {
    let fixture = copy_fixture(
        "hangprinter",
        &dir.join("fixture"),
        &["points.csv", "untrusted.csv"],
    );
    let held_out = copy_fixture("hangprinter", &dir.join("untrusted"), &["machine.json"]);
    let points = fs::read_to_string(fixture.join("points.csv")).unwrap();
    // The first four columns: q1..q4 (then x,y,z and the loads).
    let readings: Vec<String> = points
        .lines()
        .skip(1)
        .map(|line| line.split(',').take(4).collect::<Vec<_>>().join(","))
        .collect();
    let untrusted = fs::read_to_string(fixture.join("untrusted.csv")).unwrap();
    let mut rows = vec!["q1,q2,q3,q4,x,y,z".to_string()];
    for line in untrusted.lines().skip(1) {
        let (sample, position) = line.split_once(',').unwrap();
        rows.push(format!(
            "{},{position}",
            readings[sample.parse::<usize>().unwrap()]
        ));
    }
    fs::write(held_out.join("points.csv"), rows.join("\n") + "\n").unwrap();
    held_out
}

#[test]
fn validate_names_the_discarded_positions_and_compensate_reaches_targets() {
    let dir = tempfile::tempdir().unwrap();
    let data = copy_fixture("hangprinter", dir.path(), &["machine.json", "points.csv"]);
    ok(&["calibrate", s(&data)]);
    let calibration = data.join("calibration.json");
    let held_out = untrusted_dataset(dir.path());
    let out = common::parcal(&["validate", s(&held_out), "--calibration", s(&calibration)]);
    assert_eq!(out.status.code(), Some(3), "{}", common::text(&out.stderr));
    let summary = common::text(&out.stdout);
    assert!(summary.contains("verdict: rejected"), "{summary}");
    assert!(
        summary.contains("points.csv line 8 (point sample 6, row 2) fails its w-test"),
        "{summary}"
    );
    let record: serde_json::Value =
        serde_json::from_str(&fs::read_to_string(held_out.join("validation.json")).unwrap())
            .unwrap();
    assert_eq!(record["format"], "parcal-mechanism-validation/1");
    assert_eq!(record["rows"].as_array().unwrap().len(), 96);

    let targets = dir.path().join("targets.csv");
    fs::write(&targets, "x,y,z\n0,0,100\n-200,150,600\n0,0,5000\n").unwrap();
    let commands = dir.path().join("commands.csv");
    let error = fails(&compensate(&calibration, &targets, &commands));
    assert!(
        error.contains("line 4:") && error.contains("1 of 3 targets"),
        "{error}"
    );
    assert!(!commands.exists());
    fs::write(&targets, "x,y,z\n0,0,100\n-200,150,600\n").unwrap();
    ok(&[
        "compensate",
        "--calibration",
        s(&calibration),
        "--targets",
        s(&targets),
        "--out",
        s(&commands),
    ]);
    let written = fs::read_to_string(&commands).unwrap();
    assert!(
        written.starts_with("x,y,z,q1,q2,q3,q4,nominal_q1,nominal_q2,nominal_q3,nominal_q4\n"),
        "{written}"
    );
    assert_eq!(written.lines().count(), 3);
}

/// `parcal compensate` of `calibration` at the targets of `targets`,
/// written to `out`.
fn compensate<'a>(calibration: &'a Path, targets: &'a Path, out: &'a Path) -> [&'a str; 7] {
    [
        "compensate",
        "--calibration",
        s(calibration),
        "--targets",
        s(targets),
        "--out",
        s(out),
    ]
}

/// Sample 0's loads, those of the encoder zero (`points.csv`'s `f1..f4`).
fn zero_loads(data: &Path) -> Vec<f64> {
    let points = fs::read_to_string(data.join("points.csv")).unwrap();
    let first = points.lines().nth(1).unwrap();
    (first.split(',').skip(7))
        .map(|f| f.parse().unwrap())
        .collect()
}

/// The fixture's machine.json with its lines made elastic: one compliance,
/// named in `configured` at its typical value, the encoders zeroed under
/// sample 0's loads (`points.csv`'s `f1..f4`).
fn elastic_machine(data: &std::path::Path) {
    let zero_loads = zero_loads(data);
    let path = data.join("machine.json");
    let mut machine: serde_json::Value =
        serde_json::from_str(&fs::read_to_string(&path).unwrap()).unwrap();
    machine["configured"]["compliance_abcd"] = serde_json::json!(50.0);
    machine["elasticity"] = serde_json::json!({
        "compliance_of_line": [0, 0, 0, 0],
        "zero_loads": zero_loads,
    });
    fs::write(&path, machine.to_string()).unwrap();
}

#[test]
fn elastic_lines_from_machine_json_are_calibrated_validated_and_said_lost_by_export() {
    let dir = tempfile::tempdir().unwrap();
    let data = copy_fixture("hangprinter", dir.path(), &["machine.json", "points.csv"]);
    elastic_machine(&data);
    let summary = ok(&["calibrate", s(&data)]);
    assert!(summary.contains("compliance_abcd"), "{summary}");
    let calibration = data.join("calibration.json");
    let record: serde_json::Value =
        serde_json::from_str(&fs::read_to_string(&calibration).unwrap()).unwrap();
    assert_eq!(record["format"], "parcal-mechanism-calibration/1.6");
    assert_eq!(
        record["elasticity"]["compliance_of_line"],
        serde_json::json!([0, 0, 0, 0])
    );
    // The discarded positions with their loads, judged by the elastic
    // robot: every row predicted.
    let held_out = untrusted_dataset(dir.path());
    let loads: Vec<String> = (fs::read_to_string(data.join("points.csv")).unwrap())
        .lines()
        .skip(1)
        .map(|line| line.split(',').skip(7).collect::<Vec<_>>().join(","))
        .collect();
    let untrusted = fs::read_to_string(dir.path().join("fixture/data/untrusted.csv")).unwrap();
    let rows: Vec<String> = fs::read_to_string(held_out.join("points.csv"))
        .unwrap()
        .lines()
        .zip(untrusted.lines())
        .map(|(row, sample)| match sample.split_once(',') {
            Some((k, _)) if k != "sample" => {
                format!("{row},{}", loads[k.parse::<usize>().unwrap()])
            }
            _ => format!("{row},f1,f2,f3,f4"),
        })
        .collect();
    fs::write(held_out.join("points.csv"), rows.join("\n") + "\n").unwrap();
    fs::copy(data.join("machine.json"), held_out.join("machine.json")).unwrap();
    let out = common::parcal(&["validate", s(&held_out), "--calibration", s(&calibration)]);
    assert_eq!(out.status.code(), Some(3), "{}", common::text(&out.stderr));
    let validation: serde_json::Value =
        serde_json::from_str(&fs::read_to_string(held_out.join("validation.json")).unwrap())
            .unwrap();
    assert_eq!(validation["rows"].as_array().unwrap().len(), 96);
    // The Hangprinter's lines hold no compliance: export says so.
    let out = dir.path().join("anchors.g");
    let said = export_hangprinter(&calibration, &out);
    assert!(
        said.contains("lost: compliance_abcd =")
            && said.contains("hold the anchors and spool radii alone"),
        "{said}"
    );
    let lines = fs::read_to_string(&out).unwrap();
    assert!(
        lines.starts_with("; parcal: lost: compliance_abcd"),
        "{lines}"
    );
    read_config(&out).unwrap();

    // Targets under loads: the commands under them, the loads written
    // beside each target, so that the commands read back as targets give
    // the same commands. A row without loads is under the encoder zero's,
    // as a file without the columns; some of the columns are refused.
    let targets = dir.path().join("targets.csv");
    let commands = dir.path().join("commands.csv");
    let numbers = |path: &Path| -> Vec<Vec<f64>> {
        (fs::read_to_string(path).unwrap().lines().skip(1))
            .map(|line| line.split(',').map(|v| v.parse().unwrap()).collect())
            .collect()
    };
    fs::write(&targets, "x,y,z\n0,0,100\n").unwrap();
    ok(&compensate(&calibration, &targets, &commands));
    let unloaded = numbers(&commands);
    fs::write(
        &targets,
        "x,y,z,f1,f2,f3,f4\n0,0,100,,,,\n0,0,100,30,30,30,30\n",
    )
    .unwrap();
    ok(&compensate(&calibration, &targets, &commands));
    let text = fs::read_to_string(&commands).unwrap();
    assert!(
        text.starts_with("x,y,z,f1,f2,f3,f4,q1,q2,q3,q4,nominal_q1,"),
        "{text}"
    );
    let loaded = numbers(&commands);
    let (zero, pulled) = (&loaded[0], &loaded[1]);
    assert_eq!(zero[3..7], *zero_loads(&data));
    for (k, (a, b)) in zero[7..].iter().zip(&unloaded[0][3..]).enumerate() {
        assert!(
            (a - b).abs() <= 1e-9 * b.abs().max(1.0),
            "column {k}: {a} vs {b}"
        );
    }
    assert!(
        pulled[7..11].iter().zip(&zero[7..11]).all(|(a, b)| a != b),
        "{text}"
    );
    let again = dir.path().join("again.csv");
    ok(&compensate(&calibration, &commands, &again));
    assert_eq!(fs::read_to_string(&again).unwrap(), text);
    fs::write(&targets, "x,y,z,f1,f2\n0,0,100,20,20\n").unwrap();
    let said = fails(&compensate(&calibration, &targets, &commands));
    assert!(
        said.contains("the header names some of the load columns f1,f2,f3,f4 but not all"),
        "{said}"
    );

    // A load column misspelt in points.csv is refused by its name, not
    // read as no loads.
    let points = fs::read_to_string(data.join("points.csv")).unwrap();
    fs::write(
        data.join("points.csv"),
        points.replacen(",f1,", ",load1,", 1),
    )
    .unwrap();
    let said = fails(&["calibrate", s(&data)]);
    assert!(
        said.contains("points.csv")
            && said.contains("column \"load1\", which is not one of this file's"),
        "{said}"
    );
}

/// The fixture with its anchors' prior dropped and every position but the
/// encoder zero's blanked: rotations about that point move no reading, so
/// the calibration is refused, the combination named by its parameters.
#[test]
fn anchors_no_data_nor_prior_determine_are_named() {
    let dir = tempfile::tempdir().unwrap();
    let data = copy_fixture("hangprinter", dir.path(), &["machine.json", "points.csv"]);
    let path = data.join("machine.json");
    let mut machine: serde_json::Value =
        serde_json::from_str(&fs::read_to_string(&path).unwrap()).unwrap();
    machine["tolerances"]["anchors"] = serde_json::Value::Null;
    fs::write(&path, machine.to_string()).unwrap();
    let points = fs::read_to_string(data.join("points.csv")).unwrap();
    let blanked: Vec<String> = (points.lines().enumerate())
        .map(|(k, line)| match k {
            0 | 1 => line.to_string(),
            _ => {
                let mut fields: Vec<&str> = line.split(',').collect();
                fields[4..7].fill("");
                fields.join(",")
            }
        })
        .collect();
    fs::write(data.join("points.csv"), blanked.join("\n") + "\n").unwrap();
    let said = fails(&["calibrate", s(&data)]);
    assert!(said.contains("not determined"), "{said}");
    assert!(said.contains(" anchor_"), "{said}");
}

/// A sample copied to the end of points.csv is named by `inspect` and by
/// `calibrate` (its summary and calibration.json's warnings), with the line
/// it copies; the fixture as it is has no warning.
#[test]
fn a_sample_given_twice_is_warned_of_by_its_lines() {
    let dir = tempfile::tempdir().unwrap();
    let data = copy_fixture("hangprinter", dir.path(), &["machine.json", "points.csv"]);
    let points = fs::read_to_string(data.join("points.csv")).unwrap();
    assert!(!ok(&["inspect", s(&data)]).contains("warning"));
    let line_7 = points.lines().nth(6).unwrap();
    let rows = points.lines().count();
    fs::write(data.join("points.csv"), format!("{points}{line_7}\n")).unwrap();
    let warning = format!(
        "points.csv line {} (point sample {}) repeats points.csv line 7 (point sample 5) in every number",
        rows + 1,
        rows - 1
    );
    let inspected = ok(&["inspect", s(&data)]);
    assert!(
        inspected.contains(&format!("warning: {warning}")),
        "{inspected}"
    );
    let summary = ok(&["calibrate", s(&data)]);
    assert!(
        summary.contains(&format!("warning: {warning}")),
        "{summary}"
    );
    let record: serde_json::Value =
        serde_json::from_str(&fs::read_to_string(data.join("calibration.json")).unwrap()).unwrap();
    let warnings = record["warnings"].as_array().unwrap();
    assert_eq!(warnings.len(), 1);
    assert!(
        warnings[0].as_str().unwrap().starts_with(&warning),
        "{record}"
    );
    // The whole file given twice: one warning counts the 44 copies and
    // names the first ten, by their lines.
    let header_and_rows: Vec<&str> = points.lines().collect();
    let twice = [&header_and_rows[..], &header_and_rows[1..]]
        .concat()
        .join("\n")
        + "\n";
    fs::write(data.join("points.csv"), twice).unwrap();
    let copies = rows - 1;
    let counted = format!("warning: {copies} observations repeat an earlier one in every number");
    let first = format!(
        "(the first 10: points.csv line {} (point sample {}) repeats points.csv line 2 (point sample 0); ",
        rows + 1,
        rows - 1
    );
    for said in [ok(&["inspect", s(&data)]), ok(&["calibrate", s(&data)])] {
        assert_eq!(said.matches("warning:").count(), 1, "{said}");
        assert!(said.contains(&counted), "{said}");
        assert!(said.contains(&first), "{said}");
    }
}

/// `compensate --poses` (or `--table`), a hexapod's, given a cable robot's
/// calibration says what compensates it: `--targets`.
#[test]
fn compensate_of_a_hexapods_poses_names_the_targets_a_cable_robot_takes() {
    let dir = tempfile::tempdir().unwrap();
    let data = copy_fixture("hangprinter", dir.path(), &["machine.json", "points.csv"]);
    ok(&["calibrate", s(&data)]);
    let poses = dir.path().join("poses.csv");
    fs::write(&poses, "x,y,z,roll,pitch,yaw\n0,0,500,0,0,0\n").unwrap();
    let calibration = data.join("calibration.json");
    let said = fails(&[
        "compensate",
        "--calibration",
        s(&calibration),
        "--poses",
        s(&poses),
        "--out",
        s(&dir.path().join("commands.csv")),
    ]);
    assert!(
        said.contains("a cable robot's calibration: compensate it at positions with --targets"),
        "{said}"
    );
}

/// The fixture's own samples and line lengths judged by 4-fold
/// cross-validation: each fold predicted by the calibration of the other
/// three, accepted, every row named by its line; --reference is refused.
#[test]
fn validate_folds_judges_each_fold_by_the_others_calibration() {
    let dir = tempfile::tempdir().unwrap();
    let data = copy_fixture(
        "hangprinter",
        dir.path(),
        &["machine.json", "points.csv", "quantities.csv"],
    );
    let out = dir.path().join("cv.json");
    let said = ok(&["validate", s(&data), "--folds", "4", "--out", s(&out)]);
    assert!(said.starts_with("verdict: accepted"), "{said}");
    assert!(said.contains("applied: 4-fold cross-validation"), "{said}");
    let record: serde_json::Value =
        serde_json::from_str(&fs::read_to_string(&out).unwrap()).unwrap();
    let rows = record["rows"].as_array().unwrap();
    let lines: Vec<u64> = (rows.iter())
        .filter(|row| row["file"] == "points.csv")
        .map(|row| row["line"].as_u64().unwrap())
        .collect();
    // Every sample is predicted, named by its line.
    let samples = fs::read_to_string(data.join("points.csv"))
        .unwrap()
        .lines()
        .count()
        - 1;
    let mut distinct = lines.clone();
    distinct.sort_unstable();
    distinct.dedup();
    let every: Vec<u64> = (2..samples as u64 + 2).collect();
    assert_eq!(distinct, every, "{lines:?}");
    let error = fails(&["validate", s(&data), "--folds", "4", "--reference", "3"]);
    assert!(
        error.contains("a cross-validation fits each held-out ball's centre and tracker's frame"),
        "{error}"
    );
}
