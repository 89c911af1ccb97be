//! What the machine can reach (docs/apply.md, docs/reliability.md): targets
//! in the other assembly mode refused by `parcal compensate`, commands
//! outside the stroke by `parcal simulate --run`, and readings outside the
//! stroke named by `parcal inspect` and `parcal calibrate`.

use std::fs;
use std::path::Path;

use crate::common;
use common::{PAPER_FILES, compensate_poses, copy_fixture, fails, ok, s};

/// The JSON file `from` edited by `edit`, written to `to`.
fn edit_json(from: &Path, to: &Path, edit: impl FnOnce(&mut serde_json::Value)) {
    let mut value: serde_json::Value =
        serde_json::from_str(&fs::read_to_string(from).unwrap()).unwrap();
    edit(&mut value);
    fs::write(to, serde_json::to_string_pretty(&value).unwrap()).unwrap();
}

#[test]
fn a_target_below_the_base_and_commands_outside_the_stroke_are_refused_naming_the_row() {
    let dir = tempfile::tempdir().unwrap();
    let data = copy_fixture("paper-seed1", dir.path(), &PAPER_FILES);
    ok(&["calibrate", s(&data)]);
    let calibration = data.join("calibration.json");
    let limited = dir.path().join("limited.json");
    edit_json(&calibration, &limited, |record| {
        record["design"]["joint_limits"] = serde_json::json!({"base_deg": 40, "platform_deg": 40});
    });
    let (targets, commands, reached) = (
        dir.path().join("targets.csv"),
        dir.path().join("commands.csv"),
        dir.path().join("reached.csv"),
    );
    fs::write(
        &targets,
        "x,y,z,roll,pitch,yaw\n0,0,400,0,0,0\n0,0,-400,0,0,0\n",
    )
    .unwrap();
    // Without and with joint limits: the second target's platform is
    // 400 + 60.4 mm (the tool) below the base.
    for calibration in [&calibration, &limited] {
        let error = fails(&compensate_poses(calibration, &targets, &commands));
        assert!(
            error.contains("targets.csv: line 3: the platform would be 460."),
            "{error}"
        );
        assert!(error.contains("other assembly mode"), "{error}");
        assert!(!commands.exists());
    }

    // The dataset's stroke is [20, 250]: the second row's q3 is beyond it.
    fs::write(
        &commands,
        "q1,q2,q3,q4,q5,q6\n100,100,100,100,100,100\n100,100,260,100,100,100\n",
    )
    .unwrap();
    let error = fails(&[
        "simulate",
        "--run",
        s(&commands),
        "--truth",
        s(&data),
        "--out",
        s(&reached),
    ]);
    assert!(
        error.contains("commands.csv: line 3: q3 = 260 is outside the stroke [20, 250]"),
        "{error}"
    );
    assert!(!reached.exists());
}

#[test]
fn inspect_and_calibrate_name_a_reading_outside_the_stroke() {
    let dir = tempfile::tempdir().unwrap();
    let data = copy_fixture("paper-seed1", dir.path(), &PAPER_FILES);
    let machine = data.join("machine.json");
    // The fixture's largest reading, q3 of line 146, is 185.97 mm; the
    // next, q6 of line 190, 185.44 mm.
    edit_json(&machine, &machine, |m| {
        m["stroke"] = serde_json::json!([20.0, 185.5]);
    });
    let expected = "measurements.csv line 146: q3 = 185.97163739104198 mm is outside machine.json's stroke [20, 185.5]";
    let out = ok(&["inspect", s(&data)]);
    assert!(out.contains(&format!("warning: {expected}")), "{out}");
    let out = ok(&["calibrate", s(&data)]);
    assert!(out.contains(expected), "{out}");
    let record: serde_json::Value =
        serde_json::from_str(&fs::read_to_string(data.join("calibration.json")).unwrap()).unwrap();
    let warnings = record["warnings"].as_array().unwrap();
    assert!(
        warnings
            .iter()
            .any(|w| w.as_str().unwrap().starts_with(expected)),
        "{warnings:?}"
    );
}
