//! Held-out data of a simulated mechanism from the command line:
//! `parcal simulate --mechanism ... --truth DATASET` measures the true
//! machine of a simulated dataset again; `parcal validate` judges the
//! dataset's calibration on them, accepted for the same machine and
//! rejected, the change named, for a machine changed on purpose.

mod common;

use std::fs;
use std::path::{Path, PathBuf};

use common::{fails, ok, parcal, s};
use parcal::dataset::mechanism::MechanismDataset;
use parcal::kinematics::delta::DIAGONAL;

/// `parcal simulate --mechanism NAME --seed SEED` of `flags` into `out`,
/// measuring the truth of `truth` if given.
fn simulate(name: &str, seed: &str, truth: Option<&Path>, flags: &[&str], out: &Path) -> String {
    let mut args = vec!["simulate", "--mechanism", name, "--seed", seed];
    if let Some(truth) = truth {
        args.extend(["--truth", s(truth)]);
    }
    args.extend(flags);
    args.extend(["--out", s(out)]);
    ok(&args)
}

/// `parcal validate DATA --calibration CALIBRATION`: its exit status and
/// what it printed.
fn validate(data: &Path, calibration: &Path) -> (Option<i32>, String) {
    let output = parcal(&["validate", s(data), "--calibration", s(calibration)]);
    let said = format!(
        "{}{}",
        common::text(&output.stdout),
        common::text(&output.stderr)
    );
    (output.status.code(), said)
}

/// A copy of the dataset at `from` in `to` whose true parameter `k` is
/// `change` larger.
fn changed(from: &Path, to: &Path, k: usize, change: f64) -> PathBuf {
    let mut dataset = MechanismDataset::read(from).unwrap();
    dataset.truth.as_mut().unwrap().parameters[k] += change;
    dataset.write(to).unwrap();
    to.to_path_buf()
}

#[test]
fn a_delta_s_held_out_data_accept_its_printer_and_name_a_longer_rod() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let flags = ["--part-distances", "4"];
    let sim = d.join("sim");
    simulate("delta", "3", None, &flags, &sim);
    let summary = ok(&["calibrate", s(&sim)]);
    assert!(summary.contains("accepted"), "{summary}");
    let calibration = sim.join("calibration.json");

    // The same printer measured again, with new noise and another pattern.
    let held_out = d.join("held-out");
    let pattern = ["--part-distances", "6", "--probes-per-ring", "10"];
    let said = simulate("delta", "4", Some(&sim), &pattern, &held_out);
    assert!(
        said.contains("31 probe heights, 6 part distances"),
        "{said}"
    );
    assert!(said.contains("the true machine of"), "{said}");
    let again = d.join("again");
    simulate("delta", "4", Some(&sim), &pattern, &again);
    for file in ["machine.json", "probes.csv", "distances.csv", "truth.json"] {
        assert_eq!(
            fs::read(held_out.join(file)).unwrap(),
            fs::read(again.join(file)).unwrap(),
            "{file} differs between two runs of one seed"
        );
    }
    assert_eq!(
        fs::read(held_out.join("truth.json")).unwrap(),
        fs::read(sim.join("truth.json")).unwrap(),
        "the held-out data are of another printer"
    );
    let (status, said) = validate(&held_out, &calibration);
    assert_eq!(status, Some(0), "{said}");
    assert!(said.contains("accepted"), "{said}");

    // Rod A 0.3 mm longer: rejected, the rod named.
    let longer = changed(&sim, &d.join("longer"), DIAGONAL, 0.3);
    let held_out = d.join("held-out-longer");
    simulate("delta", "4", Some(&longer), &pattern, &held_out);
    let (status, said) = validate(&held_out, &calibration);
    assert_eq!(status, Some(3), "{said}");
    assert!(said.contains("rejected"), "{said}");
    assert!(said.contains("a change of diagonal_a by"), "{said}");

    // Refused: the dataset's own measurements (its seed and pattern), an
    // existing directory without --force, the truth's own directory, a
    // dataset without truth, one of another mechanism.
    let error = fails(&[
        "simulate",
        "--mechanism",
        "delta",
        "--seed",
        "3",
        "--part-distances",
        "4",
        "--truth",
        s(&sim),
        "--out",
        s(&d.join("same")),
    ]);
    assert!(error.contains("its own measurements"), "{error}");
    assert!(!d.join("same").exists());
    let mut args = vec!["simulate", "--mechanism", "delta", "--seed", "5"];
    args.extend(["--truth", s(&sim), "--out", s(&again)]);
    let error = fails(&args);
    assert!(error.contains("exists and is not empty"), "{error}");
    args.push("--force");
    ok(&args);
    let mut args = vec!["simulate", "--mechanism", "delta", "--seed", "5"];
    args.extend(["--truth", s(&sim), "--out", s(&sim), "--force"]);
    let error = fails(&args);
    assert!(error.contains("the dataset of --truth"), "{error}");
    fs::remove_file(longer.join("truth.json")).unwrap();
    let error = fails(&[
        "simulate",
        "--mechanism",
        "delta",
        "--truth",
        s(&longer),
        "--out",
        s(&d.join("none")),
    ]);
    assert!(error.contains("no truth.json"), "{error}");
    let error = fails(&[
        "simulate",
        "--mechanism",
        "cable",
        "--truth",
        s(&sim),
        "--out",
        s(&d.join("cable")),
    ]);
    assert!(error.contains("not of a cable robot"), "{error}");
    let error = fails(&["simulate", "--truth", s(&sim), "--out", s(&d.join("x"))]);
    assert!(error.contains("--truth needs --run"), "{error}");
}

#[test]
fn a_cable_robot_s_held_out_samples_accept_it_and_name_a_moved_anchor() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let sim = d.join("sim");
    simulate("cable", "2", None, &[], &sim);
    let summary = ok(&["calibrate", s(&sim)]);
    assert!(summary.contains("accepted"), "{summary}");
    let calibration = sim.join("calibration.json");
    let held_out = d.join("held-out");
    let pattern = ["--samples", "30", "--known-positions", "6"];
    let said = simulate("cable", "12", Some(&sim), &pattern, &held_out);
    assert!(said.contains("30 encoder samples (6 with"), "{said}");
    let (status, said) = validate(&held_out, &calibration);
    assert_eq!(status, Some(0), "{said}");

    // Anchor A 3 mm further along x: rejected, the change named.
    let moved = changed(&sim, &d.join("moved"), 0, 3.0);
    let held_out = d.join("held-out-moved");
    simulate("cable", "12", Some(&moved), &pattern, &held_out);
    let (status, said) = validate(&held_out, &calibration);
    assert_eq!(status, Some(3), "{said}");
    assert!(said.contains("a change of anchor_a_x by"), "{said}");
}
