//! Held-out data of a simulated mechanism from the command line:
//! `parcal simulate --mechanism ... --truth DATASET` measures the true
//! machine of a simulated dataset again; `parcal validate` judges the
//! dataset's calibration on them (probe heights, part distances, samples,
//! touches of balls), accepted for the same machine and rejected, the
//! change named, for a machine changed on purpose.

use crate::common;

use std::fs;
use std::path::{Path, PathBuf};

use common::{fails, ok, parcal, s};
use parcal::dataset::mechanism::MechanismDataset;
use parcal::kinematics::delta::{DIAGONAL, RADIUS};

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
    validate_with(data, calibration, &[])
}

/// [`validate`] with the options `options` too.
fn validate_with(data: &Path, calibration: &Path, options: &[&str]) -> (Option<i32>, String) {
    let args = [
        &["validate", s(data), "--calibration", s(calibration)],
        options,
    ]
    .concat();
    let output = parcal(&args);
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
    assert!(!said.contains("in sample"), "{said}");

    // The calibration records the data it was fitted on: validated on
    // them, a note says the rows are predicted in sample; a report with
    // other data is refused unless asked for.
    let (_, said) = validate(&sim, &calibration);
    assert!(
        said.contains("the same checksum): its rows are predicted in sample"),
        "{said}"
    );
    let report_dir = d.join("report");
    let report = |dataset: &Path, other: &[&str]| {
        let args = [
            &["report", s(&calibration), "--dataset", s(dataset)],
            other,
            &["--out", s(&report_dir)],
        ]
        .concat();
        parcal(&args)
    };
    let refused = report(&held_out, &[]);
    assert_eq!(refused.status.code(), Some(1));
    let said = common::text(&refused.stderr);
    assert!(
        said.contains("the calibration is of another dataset") && said.contains("--other-data"),
        "{said}"
    );
    assert!(!report_dir.join("report.html").exists());
    let allowed = report(&held_out, &["--other-data"]);
    assert_eq!(
        allowed.status.code(),
        Some(0),
        "{}",
        common::text(&allowed.stderr)
    );

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

/// The held-out touches of `--balls` balls of `--points-per-ball` touches
/// each, of the true machine of `truth`, without the probe heights the
/// simulator always makes: a dataset of touches alone.
fn touches_only(truth: &Path, balls: &str, touches: &str, out: &Path) -> PathBuf {
    let pattern = ["--balls", balls, "--points-per-ball", touches];
    let said = simulate("delta", "5", Some(truth), &pattern, out);
    assert!(
        said.contains(&format!("touches of {balls} balls")),
        "{said}"
    );
    fs::remove_file(out.join("probes.csv")).unwrap();
    out.to_path_buf()
}

#[test]
fn a_delta_s_held_out_touches_accept_its_printer_and_name_a_larger_radius() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let sim = d.join("sim");
    simulate("delta", "3", None, &["--part-distances", "4"], &sim);
    let summary = ok(&["calibrate", s(&sim)]);
    assert!(summary.contains("accepted"), "{summary}");
    let calibration = sim.join("calibration.json");

    // Four balls touched ten times each: 4 × (10 − 3) rows, each ball's
    // centre fitted to its own touches.
    let held_out = touches_only(&sim, "4", "10", &d.join("held-out"));
    let (status, said) = validate(&held_out, &calibration);
    eprintln!("{said}");
    assert_eq!(status, Some(0), "{said}");
    assert!(said.contains("predicted 28 ball rows"), "{said}");
    // Each ball's centre located by its first 5 touches, its other 5
    // predicted: 4 × 5 rows, each a touch's, named by its line.
    let reference = ["--reference", "5"];
    let (status, said) = validate_with(&held_out, &calibration, &reference);
    eprintln!("{said}");
    assert_eq!(status, Some(0), "{said}");
    assert!(said.contains("predicted 20 ball touch rows"), "{said}");
    assert!(said.contains("the largest, touches.csv line "), "{said}");

    // The delta radius 0.5 mm larger (the printer's scale): rejected, the
    // balls' rows failing, by the ball's line and its touches' (from
    // reference touches, each touch by its line), and the radius named.
    let larger = changed(&sim, &d.join("larger"), RADIUS, 0.5);
    let held_out = touches_only(&larger, "4", "10", &d.join("held-out-larger"));
    let by_ball = |line: &str| {
        line.contains("balls.csv line")
            && line.contains("touched at touches.csv lines")
            && line.contains("fails its w-test")
    };
    let by_touch = |line: &str| {
        line.contains("touches.csv line")
            && line.contains("(ball touch ")
            && line.contains("fails its w-test")
    };
    for (options, named) in [
        (&[][..], &by_ball as &dyn Fn(&str) -> bool),
        (&reference, &by_touch),
    ] {
        let (status, said) = validate_with(&held_out, &calibration, options);
        eprintln!("{said}");
        assert_eq!(status, Some(3), "{said}");
        assert!(said.contains("prediction test failed"), "{said}");
        assert!(said.lines().any(named), "{said}");
        assert!(said.contains("a change of radius by"), "{said}");
    }

    // A ball touched 4 times gives one row; one touched 3 times is named.
    let four = touches_only(&sim, "2", "4", &d.join("four"));
    let (status, said) = validate(&four, &calibration);
    assert_eq!(status, Some(0), "{said}");
    assert!(said.contains("predicted 2 ball rows"), "{said}");
    let touches = four.join("touches.csv");
    let text = fs::read_to_string(&touches).unwrap();
    let without_first: Vec<&str> = text
        .lines()
        .enumerate()
        .filter(|&(k, _)| k != 1)
        .map(|(_, line)| line)
        .collect();
    fs::write(&touches, without_first.join("\n") + "\n").unwrap();
    let (status, said) = validate(&four, &calibration);
    assert_eq!(status, Some(1), "{said}");
    assert!(
        said.contains("ball 0: it has 3 touches; its centre needs at least 4"),
        "{said}"
    );
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
