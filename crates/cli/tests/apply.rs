//! End-to-end tests of applying a calibration: `parcal compensate`,
//! `parcal export`, `parcal simulate --run` (docs/apply.md).

use std::fs;
use std::path::{Path, PathBuf};

use crate::common;
use common::{PAPER_FILES, compensate_poses, copy_fixture, fails, ok, s};

/// fixtures/paper-seed1 calibrated in `dir`; returns the dataset directory.
fn calibrated(dir: &Path) -> PathBuf {
    let data = copy_fixture("paper-seed1", dir, &PAPER_FILES);
    ok(&["calibrate", s(&data)]);
    data
}

/// A 5 x 5 grid on z = 400, every tenth target tilted.
fn write_targets(path: &Path) {
    let mut text = String::from("x,y,z,roll,pitch,yaw\n");
    for i in 0..5 {
        for j in 0..5 {
            let tilt = if (i + j) % 3 == 0 { 0.05 } else { 0.0 };
            text += &format!("{},{},400,{tilt},0,{}\n", -80 + 40 * i, -80 + 40 * j, -tilt);
        }
    }
    fs::write(path, text).unwrap();
}

#[test]
fn compensated_commands_run_on_the_true_machine_reach_the_targets() {
    let dir = tempfile::tempdir().unwrap();
    let data = calibrated(dir.path());
    let calibration = data.join("calibration.json");
    let (targets, commands, corrected, reached) = (
        dir.path().join("targets.csv"),
        dir.path().join("commands.csv"),
        dir.path().join("corrected.csv"),
        dir.path().join("reached.csv"),
    );
    write_targets(&targets);
    let out = ok(&[
        "compensate",
        "--calibration",
        s(&calibration),
        "--poses",
        s(&targets),
        "--out",
        s(&commands),
        "--corrected-poses",
        s(&corrected),
    ]);
    assert!(out.contains("25 targets"), "{out}");
    assert!(
        out.contains("predicted tip error after registration"),
        "{out}"
    );
    let text = fs::read_to_string(&commands).unwrap();
    assert!(text.starts_with("q1,q2,q3,q4,q5,q6\n") && text.lines().count() == 26);
    assert_eq!(fs::read_to_string(&corrected).unwrap().lines().count(), 26);

    let rms = |out: &str| -> f64 {
        let at = out.find("RMS ").unwrap() + 4;
        out[at..]
            .split_whitespace()
            .next()
            .unwrap()
            .parse()
            .unwrap()
    };
    let run = |commands: &Path| {
        ok(&[
            "simulate",
            "--run",
            s(commands),
            "--truth",
            s(&data),
            "--targets",
            s(&targets),
            "--out",
            s(&reached),
        ])
    };
    let compensated = rms(&run(&commands));
    let nominal_commands = dir.path().join("nominal.csv");
    ok(&[
        "compensate",
        "--nominal",
        "--calibration",
        s(&calibration),
        "--poses",
        s(&targets),
        "--out",
        s(&nominal_commands),
    ]);
    let nominal = rms(&run(&nominal_commands));
    // Micrometres: the calibrated model several times better than the
    // design's (crates/apply/tests/closed_loop.rs has the statistics).
    assert!(compensated < nominal / 3.0, "{compensated} vs {nominal}");
}

#[test]
fn exports_are_written_and_the_machine_reads_as_a_design() {
    let dir = tempfile::tempdir().unwrap();
    let data = calibrated(dir.path());
    let calibration = data.join("calibration.json");
    for format in ["machine-json", "genhexkins", "summary"] {
        let out = dir.path().join(format);
        ok(&[
            "export",
            "--calibration",
            s(&calibration),
            "--format",
            format,
            "--out",
            s(&out),
        ]);
        assert!(fs::metadata(&out).unwrap().len() > 0);
    }
    let hal = fs::read_to_string(dir.path().join("genhexkins")).unwrap();
    assert_eq!(
        hal.lines()
            .filter(|l| l.starts_with("setp genhexkins."))
            .count(),
        36
    );
    let summary = fs::read_to_string(dir.path().join("summary")).unwrap();
    assert!(
        summary.contains("posterior covariance as correlations"),
        "{summary}"
    );
    // Touches see the tool: nothing is said of it.
    assert!(
        !summary.contains(UNSEEN) && !hal.contains(UNSEEN),
        "{summary}"
    );
    // The exported machine is the design of a next calibration.
    fs::copy(dir.path().join("machine-json"), data.join("machine.json")).unwrap();
    ok(&["inspect", s(&data)]);

    // Poses of the platform do not see the tool: both exports say that
    // theirs is not calibrated.
    let jugglebot = copy_fixture(
        "jugglebot",
        &dir.path().join("jb"),
        &["machine.json", "poses.csv"],
    );
    let calibration = dir.path().join("jb.json");
    ok(&["calibrate", s(&jugglebot), "--out", s(&calibration)]);
    for format in ["genhexkins", "summary"] {
        let out = dir.path().join(format!("jb-{format}"));
        let export = [
            "export",
            "--calibration",
            s(&calibration),
            "--format",
            format,
        ];
        ok(&[&export[..], &["--out", s(&out)]].concat());
        let text = fs::read_to_string(&out).unwrap();
        assert!(text.contains(UNSEEN), "{format}: {text}");
    }
}

/// What the exports say of a tool the data do not see.
const UNSEEN: &str = "the tool tip E_T is not calibrated";

#[test]
fn a_run_that_did_not_converge_quotes_no_posterior_accuracy() {
    // Two iterations: the iteration limit, a rejected calibration.
    let dir = tempfile::tempdir().unwrap();
    let data = copy_fixture("paper-seed1", dir.path(), &PAPER_FILES);
    let error = fails(&["calibrate", s(&data), "--max-iterations", "2"]);
    assert!(error.contains("iteration limit"), "{error}");
    let calibration = data.join("calibration.rejected.json");
    let record = parcal::dataset::Calibration::read(&calibration).unwrap();
    assert!(!record.converged && record.covariance.is_empty());
    assert!(record.parameters.sigma.iter().all(|&s| s == 0.0));
    let (targets, commands) = (
        dir.path().join("targets.csv"),
        dir.path().join("commands.csv"),
    );
    write_targets(&targets);
    let out = ok(&[
        "compensate",
        "--calibration",
        s(&calibration),
        "--accept-rejected",
        "--poses",
        s(&targets),
        "--out",
        s(&commands),
    ]);
    assert!(
        out.contains("predicted tip error after registration: none (calibration.json gives no posterior covariance"),
        "{out}"
    );
    assert!(!out.contains(" um"), "{out}");
    // Its report reads it too, and quotes no accuracy map.
    ok(&[
        "report",
        s(&calibration),
        "--out",
        s(&dir.path().join("report")),
    ]);
}

#[test]
fn refusals_name_the_file_and_the_row_and_write_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let data = calibrated(dir.path());
    let calibration = data.join("calibration.json");
    let targets = dir.path().join("targets.csv");
    let commands = dir.path().join("commands.csv");
    let compensate =
        |calibration: &Path| fails(&compensate_poses(calibration, &targets, &commands));
    fs::write(
        &targets,
        "x,y,z,roll,pitch,yaw\n0,0,400,0,0,0\n0,x,400,0,0,0\n",
    )
    .unwrap();
    let error = compensate(&calibration);
    assert!(
        error.contains("targets.csv: line 3, column y: expected a number"),
        "{error}"
    );

    // A stroke that the second target leaves.
    let mut record: serde_json::Value =
        serde_json::from_str(&fs::read_to_string(&calibration).unwrap()).unwrap();
    record["design"]["stroke"] = serde_json::json!([100.0, 160.0]);
    let narrow = dir.path().join("narrow.json");
    fs::write(&narrow, serde_json::to_string(&record).unwrap()).unwrap();
    fs::write(
        &targets,
        "x,y,z,roll,pitch,yaw\n0,0,400,0,0,0\n0,0,480,0,0,0\n",
    )
    .unwrap();
    let error = compensate(&narrow);
    assert!(error.contains("targets.csv: line 3: q"), "{error}");
    assert!(error.contains("outside the stroke [100, 160]"), "{error}");

    // A calibration written before the design was recorded.
    record.as_object_mut().unwrap().remove("design");
    let old = dir.path().join("old.json");
    fs::write(&old, serde_json::to_string(&record).unwrap()).unwrap();
    let error = compensate(&old);
    assert!(error.contains("has no `design`"), "{error}");
    assert!(!commands.exists());

    // The output is one of the inputs.
    let error = fails(&compensate_poses(&calibration, &targets, &targets));
    assert!(error.contains("which this run reads"), "{error}");
    assert!(
        fs::read_to_string(&targets)
            .unwrap()
            .starts_with("x,y,z,roll,pitch,yaw")
    );
}

/// A calibration.json whose `machine` was left out (Jugglebot's, read in
/// revolutions, its scales identified): the scales are its parameters
/// `s_1..s_6`, so that validating held-out poses and compensating give
/// what the whole record gives. The scales used to be taken as 1 mm per
/// revolution, and `validate --reference` failed to locate the instrument
/// from the poses those made.
#[test]
fn a_calibration_without_its_machine_applies_its_identified_scales() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let jugglebot = copy_fixture("jugglebot", &d.join("jb"), &["machine.json", "poses.csv"]);
    let whole = d.join("whole.json");
    ok(&["calibrate", s(&jugglebot), "--out", s(&whole)]);
    let mut record: serde_json::Value =
        serde_json::from_str(&fs::read_to_string(&whole).unwrap()).unwrap();
    assert!(record.as_object_mut().unwrap().remove("machine").is_some());
    let without = d.join("without.json");
    fs::write(&without, record.to_string()).unwrap();
    let run = |calibration: &Path, what: &str| {
        let validation = d.join(format!("validation-{what}.json"));
        let said = common::parcal(&[
            "validate",
            s(&jugglebot),
            "--calibration",
            s(calibration),
            "--reference",
            "40",
            "--out",
            s(&validation),
        ]);
        let said = common::text(&said.stderr);
        let (targets, commands) = (
            d.join("targets.csv"),
            d.join(format!("commands-{what}.csv")),
        );
        fs::write(
            &targets,
            "x,y,z,roll,pitch,yaw\n0,0,760,0,0,0\n10,-5,770,0.02,0,0.01\n",
        )
        .unwrap();
        ok(&compensate_poses(calibration, &targets, &commands));
        let mut validation: serde_json::Value = serde_json::from_str(
            &fs::read_to_string(&validation).unwrap_or_else(|_| panic!("{what}: {said}")),
        )
        .unwrap();
        validation["calibration"] = serde_json::Value::Null;
        (validation, fs::read_to_string(&commands).unwrap())
    };
    assert_eq!(run(&without, "without"), run(&whole, "whole"));
}
