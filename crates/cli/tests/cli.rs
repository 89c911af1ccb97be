//! End-to-end tests of the `parcal` binary.

use std::path::Path;
use std::process::{Command, Output, Stdio};

use crate::common;
use common::{copy_fixture, ok, parcal, s, text};

fn simulate(dir: &Path, extra: &[&str]) -> Output {
    let mut args = vec!["simulate", "--seed", "7", "--out", dir.to_str().unwrap()];
    args.extend_from_slice(extra);
    let output = parcal(&args);
    assert!(output.status.success(), "{}", text(&output.stderr));
    output
}

#[test]
fn the_same_seed_gives_byte_identical_files() {
    let temp = tempfile::tempdir().unwrap();
    let (a, b) = (temp.path().join("a"), temp.path().join("b"));
    simulate(&a, &[]);
    simulate(&b, &[]);
    for file in [
        "machine.json",
        "artefacts.json",
        "measurements.csv",
        "truth.json",
    ] {
        let (x, y) = (
            std::fs::read(a.join(file)).unwrap(),
            std::fs::read(b.join(file)).unwrap(),
        );
        assert!(
            !x.is_empty() && x == y,
            "{file} differs between two runs with the same seed"
        );
    }
    let c = temp.path().join("c");
    let output = parcal(&["simulate", "--seed", "8", "--out", c.to_str().unwrap()]);
    assert!(output.status.success());
    assert_ne!(
        std::fs::read(a.join("measurements.csv")).unwrap(),
        std::fs::read(c.join("measurements.csv")).unwrap()
    );
}

#[test]
fn simulate_prints_a_summary_and_scales() {
    let temp = tempfile::tempdir().unwrap();
    let output = simulate(
        temp.path(),
        &["--balls", "40", "--points-per-ball", "5", "--tilt", "20"],
    );
    let stdout = text(&output.stdout);
    assert!(
        stdout.contains("contacts           200 (5 per ball)"),
        "{stdout}"
    );
    assert!(stdout.contains("platform tilt"), "{stdout}");
    let inspect = parcal(&["inspect", temp.path().to_str().unwrap()]);
    assert!(inspect.status.success(), "{}", text(&inspect.stderr));
    let stdout = text(&inspect.stdout);
    assert!(stdout.contains("balls              40"), "{stdout}");
    assert!(stdout.contains("succeeds on every row"), "{stdout}");
}

#[test]
fn simulate_writes_a_ball_plate_and_inspect_counts_it() {
    let temp = tempfile::tempdir().unwrap();
    let (plain, plated) = (temp.path().join("plain"), temp.path().join("plated"));
    simulate(&plain, &[]);
    let output = simulate(&plated, &["--plate", "all", "--plate-sigma", "2"]);
    let stdout = text(&output.stdout);
    assert!(
        stdout.contains("ball distances     351 (sigma 2 um)"),
        "{stdout}"
    );
    // The plate has its own random stream: the contacts and the truth are
    // those of the same seed without it.
    for file in ["machine.json", "measurements.csv", "truth.json"] {
        assert!(
            std::fs::read(plain.join(file)).unwrap() == std::fs::read(plated.join(file)).unwrap(),
            "{file} changed with the plate"
        );
    }
    let artefacts = std::fs::read_to_string(plated.join("artefacts.json")).unwrap();
    assert_eq!(artefacts.matches("\"sigma\": 0.002").count(), 351);

    let inspect = parcal(&["inspect", plated.to_str().unwrap()]);
    assert!(inspect.status.success(), "{}", text(&inspect.stderr));
    let stdout = text(&inspect.stdout);
    assert!(
        stdout.contains("ball distances     351 (tying 27 balls)"),
        "{stdout}"
    );
    let inspect = parcal(&["inspect", plain.to_str().unwrap()]);
    assert!(text(&inspect.stdout).contains("ball distances     0\n"));

    let some = temp.path().join("some");
    simulate(&some, &["--plate", "5"]);
    let inspect = parcal(&["inspect", some.to_str().unwrap()]);
    let stdout = text(&inspect.stdout);
    assert!(stdout.contains("ball distances     5 (tying "), "{stdout}");
}

/// `--design-drawn`: the same true machine, and machine.json's design a
/// draw about it by the design tolerance: the 45 deviations of the design
/// from the truth (joints, tool, legs), in tolerances, have a sum of
/// squares inside chi-square(45)'s central 99.98 % (17.8 to 89.2, a
/// single draw fails with probability 2e-4); the same seed draws the same
/// design.
#[test]
fn simulate_draws_the_design_about_the_truth() {
    let temp = tempfile::tempdir().unwrap();
    let (paper, drawn, again) = (
        temp.path().join("paper"),
        temp.path().join("drawn"),
        temp.path().join("again"),
    );
    simulate(&paper, &[]);
    simulate(&drawn, &["--design-drawn"]);
    simulate(&again, &["--design-drawn"]);
    let json = |dir: &Path, file: &str| -> serde_json::Value {
        serde_json::from_str(&std::fs::read_to_string(dir.join(file)).unwrap()).unwrap()
    };
    let (truth, design) = (json(&drawn, "truth.json"), json(&drawn, "machine.json"));
    for key in ["base_joints", "platform_joints", "tool", "leg_lengths"] {
        assert_eq!(
            truth[key],
            json(&paper, "truth.json")[key],
            "the truth's {key}"
        );
    }
    assert_ne!(
        design["base_joints"],
        json(&paper, "machine.json")["base_joints"]
    );
    assert_eq!(design, json(&again, "machine.json"));
    fn numbers(v: &serde_json::Value) -> Vec<f64> {
        match v {
            serde_json::Value::Array(items) => items.iter().flat_map(numbers).collect(),
            other => vec![other.as_f64().unwrap()],
        }
    }
    let mut sum = 0.0;
    let mut count = 0;
    for (key, sigma) in [
        ("base_joints", "base"),
        ("platform_joints", "platform"),
        ("tool", "tool"),
        ("leg_lengths", "leg"),
    ] {
        let tolerance = design["prior_sigma"][sigma].as_f64().unwrap();
        for (d, t) in numbers(&design[key]).iter().zip(numbers(&truth[key])) {
            sum += ((d - t) / tolerance).powi(2);
            count += 1;
        }
    }
    assert_eq!(count, 45);
    assert!((17.8..89.2).contains(&sum), "sum of squares {sum}");
}

#[test]
fn simulate_refuses_a_bad_plate() {
    let temp = tempfile::tempdir().unwrap();
    let out = temp.path().join("x");
    let out = out.to_str().unwrap();
    for (args, expected) in [
        (&["--plate", "0"][..], "a plate needs at least 1 pair"),
        (
            &["--plate", "some"][..],
            "expected `all` or a number of pairs",
        ),
        (&["--plate-sigma", "2"][..], "--plate"),
        (
            &["--plate", "all", "--plate-sigma", "0"][..],
            "--plate-sigma must be positive",
        ),
        (
            &["--plate", "352"][..],
            "ball plate: 352 pairs asked for, but 27 balls have 351",
        ),
    ] {
        let mut all = vec!["simulate", "--out", out];
        all.extend_from_slice(args);
        let output = parcal(&all);
        assert!(!output.status.success(), "{args:?}");
        let stderr = text(&output.stderr);
        assert!(stderr.contains(expected), "{args:?}: {stderr}");
    }
}

#[test]
fn simulate_writes_instrument_sessions() {
    let temp = tempfile::tempdir().unwrap();
    let output = simulate(
        temp.path(),
        &[
            "--tracker",
            "poses",
            "--sessions",
            "2",
            "--rows",
            "12",
            "--rehome",
            "0.5",
            "--position-sigma",
            "0.02",
            "--orientation-sigma",
            "0.0002",
        ],
    );
    let stdout = text(&output.stdout);
    assert!(stdout.contains("sessions           2"), "{stdout}");
    assert!(
        stdout.contains("poses              24 (12 per session)"),
        "{stdout}"
    );
    assert!(!stdout.contains("points "), "{stdout}");
    assert!(!temp.path().join("points.csv").exists());
    let dataset = parcal::dataset::Dataset::read(temp.path()).unwrap();
    assert_eq!(dataset.tracker.sessions, ["1", "2"]);
    assert_eq!(dataset.tracker.poses.len(), 24);
    assert_eq!(dataset.machine.session_model.leg_offset_sigma, Some(0.5));
    let r = dataset.machine.repeatability;
    assert_eq!((r.position, r.orientation), (Some(0.02), Some(0.0002)));
    assert_eq!(dataset.truth.unwrap().sessions.len(), 2);

    let out = temp.path().join("x");
    let out = out.to_str().unwrap();
    for (args, expected) in [
        (
            &["--tracker", "both", "--balls", "3"][..],
            "cannot be used with",
        ),
        (&["--sessions", "2"][..], "--tracker"),
        (
            &["--tracker", "points", "--rows", "0"][..],
            "--rows 0: must be a whole number from 1 to",
        ),
        (
            &["--tracker", "poses", "--position-sigma", "0"][..],
            "--position-sigma must be positive",
        ),
    ] {
        let mut all = vec!["simulate", "--out", out];
        all.extend_from_slice(args);
        let output = parcal(&all);
        assert!(!output.status.success(), "{args:?}");
        let stderr = text(&output.stderr);
        assert!(stderr.contains(expected), "{args:?}: {stderr}");
    }
}

#[test]
fn touches_and_tracker_data_are_simulated_inspected_and_calibrated_together() {
    let temp = tempfile::tempdir().unwrap();
    let output = simulate(
        temp.path(),
        &[
            "--tracker",
            "both",
            "--touches",
            "--sessions",
            "2",
            "--rows",
            "10",
            "--rehome",
            "0.5",
        ],
    );
    let stdout = text(&output.stdout);
    assert!(stdout.contains("contacts           189"), "{stdout}");
    assert!(stdout.contains("poses              20"), "{stdout}");
    let dir = temp.path().to_str().unwrap();
    let output = parcal(&["inspect", dir]);
    assert!(output.status.success());
    let stdout = text(&output.stdout);
    for kind in [
        "poses              20",
        "points             20",
        "contacts           189",
    ] {
        assert!(stdout.contains(kind), "{kind}: {stdout}");
    }
    let output = parcal(&["calibrate", dir]);
    assert!(output.status.success(), "{}", text(&output.stderr));
    let stdout = text(&output.stdout);
    assert!(
        stdout.contains("with 2 sessions, 20 poses, 20 points"),
        "{stdout}"
    );
    assert!(stdout.contains("| o_1 2 |"), "{stdout}");
    assert!(stdout.contains("verdict: accepted"), "{stdout}");
    let record = parcal::dataset::Calibration::read(&temp.path().join("calibration.json")).unwrap();
    assert_eq!(record.sessions.len(), 2);
    assert_eq!(record.ball_centres.len(), 27);

    let out = temp.path().join("jugglebot");
    let output = parcal(&[
        "simulate",
        "--out",
        out.to_str().unwrap(),
        "--tracker",
        "poses",
        "--touches",
        "--machine",
        "jugglebot",
    ]);
    assert!(!output.status.success());
    assert!(
        text(&output.stderr).contains("--machine paper"),
        "{}",
        text(&output.stderr)
    );
}

/// Touches read in motor revolutions with unknown scales: simulated,
/// calibrated (the scales after the 33 in calibration.json, the
/// calibrated actuator block in rev) and validated on another campaign.
#[test]
fn touches_in_revolutions_calibrate_their_scales() {
    let temp = tempfile::tempdir().unwrap();
    let output = simulate(temp.path(), &["--readings", "rev"]);
    let stdout = text(&output.stdout);
    assert!(stdout.contains("readings           unit rev"), "{stdout}");
    let dir = temp.path().to_str().unwrap();
    let output = parcal(&["calibrate", dir]);
    let stdout = text(&output.stdout);
    assert!(output.status.success(), "{}{stdout}", text(&output.stderr));
    assert!(stdout.contains("verdict: accepted"), "{stdout}");
    let calibration = temp.path().join("calibration.json");
    let record = parcal::dataset::Calibration::read(&calibration).unwrap();
    assert_eq!(
        record.parameters.names[33..],
        ["s_1", "s_2", "s_3", "s_4", "s_5", "s_6"]
    );
    let actuator = &record
        .machine
        .as_ref()
        .expect("calibrated actuators")
        .actuator;
    assert_eq!(actuator.unit, "rev");
    let truth = parcal::dataset::Dataset::read(temp.path())
        .unwrap()
        .truth
        .unwrap()
        .actuator_scale
        .expect("true scales");
    let sigma = actuator.scale_sigma.expect("their sigmas");
    for i in 0..6 {
        let z = (actuator.scale[i] - truth[i]) / sigma[i];
        assert!(z.abs() < 4.5, "s_{}: {z:.2} sigma off", i + 1);
    }

    let other = temp.path().join("other");
    let output = parcal(&[
        "simulate",
        "--seed",
        "8",
        "--readings",
        "rev",
        "--out",
        s(&other),
    ]);
    assert!(output.status.success(), "{}", text(&output.stderr));
    let output = parcal(&[
        "validate",
        s(&other),
        "--calibration",
        s(&calibration),
        "--reference",
        "5",
    ]);
    assert!(output.status.success(), "{}", text(&output.stderr));
}

/// Poses alone (fixtures/jugglebot) do not observe the tool:
/// calibration.json holds no tool parameter, keeps the design's tool, and
/// `parcal accuracy` (maps of the tool tip) says the tool was not
/// calibrated.
#[test]
fn a_calibration_of_poses_alone_leaves_the_tool_out_and_accuracy_says_so() {
    let temp = tempfile::tempdir().unwrap();
    let data = copy_fixture("jugglebot", temp.path(), &["machine.json", "poses.csv"]);
    let calibration = temp.path().join("calibration.json");
    let output = parcal(&["calibrate", s(&data), "--out", s(&calibration)]);
    assert!(output.status.success(), "{}", text(&output.stderr));
    let record = parcal::dataset::Calibration::read(&calibration).unwrap();
    let names = &record.parameters.names;
    assert_eq!(names.len(), 30 + 6 + 6 + 6, "{names:?}");
    assert!(!names.iter().any(|n| n.ends_with("_eT")), "{names:?}");
    let output = parcal(&[
        "accuracy",
        s(&data),
        "--calibration",
        s(&calibration),
        "--out",
        s(&temp.path().join("maps")),
    ]);
    assert!(!output.status.success());
    let stderr = text(&output.stderr);
    assert!(stderr.contains("did not calibrate the tool"), "{stderr}");
    // The calibrated scales are held twice, as parameters and in the
    // calibrated machine: a copy edited apart is refused by name.
    let mut json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&calibration).unwrap()).unwrap();
    let scale = &mut json["machine"]["actuator"]["scale"][0];
    *scale = (scale.as_f64().unwrap() * 1.1).into();
    std::fs::write(&calibration, json.to_string()).unwrap();
    let error = parcal::dataset::Calibration::read(&calibration)
        .unwrap_err()
        .to_string();
    assert!(
        error.contains("field machine.actuator.scale[0]") && error.contains("s_1 = "),
        "{error}"
    );
}

#[test]
fn inspect_reads_the_reference_dataset() {
    let reference =
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../../fixtures/reference-paper-seed1");
    let output = parcal(&["inspect", reference.to_str().unwrap()]);
    assert!(output.status.success(), "{}", text(&output.stderr));
    assert!(text(&output.stdout).contains("contacts           189 (7 .. 7 per ball)"));
}

/// A malformed dataset: exit code non-zero and a message naming the file.
fn assert_inspect_fails(dir: &Path, expected: &[&str]) {
    let output = parcal(&["inspect", dir.to_str().unwrap()]);
    assert!(!output.status.success());
    let stderr = text(&output.stderr);
    for part in expected {
        assert!(stderr.contains(part), "expected {part:?} in: {stderr}");
    }
}

#[test]
fn inspect_reports_malformed_datasets() {
    let temp = tempfile::tempdir().unwrap();
    simulate(temp.path(), &[]);
    let csv = temp.path().join("measurements.csv");
    let original = std::fs::read_to_string(&csv).unwrap();

    std::fs::write(&csv, original.replacen("b01,", "b99,", 1)).unwrap();
    assert_inspect_fails(temp.path(), &["measurements.csv", "line 2", "b99"]);

    let mut lines: Vec<String> = original.lines().map(String::from).collect();
    // A NaN reading, same number of columns.
    let (ball, rest) = lines[3].split_once(',').unwrap();
    let (_, others) = rest.split_once(',').unwrap();
    lines[3] = format!("{ball},NaN,{others}");
    std::fs::write(&csv, lines.join("\n")).unwrap();
    assert_inspect_fails(temp.path(), &["measurements.csv", "line 4"]);

    // A contact the design machine cannot reach.
    let mut lines: Vec<String> = original.lines().map(String::from).collect();
    lines[5] = "b01,1000,1000,1000,0,0,0".to_string();
    std::fs::write(&csv, lines.join("\n")).unwrap();
    assert_inspect_fails(
        temp.path(),
        &["measurements.csv line 6", "fails on 1 of 189 rows"],
    );

    std::fs::remove_file(&csv).unwrap();
    assert_inspect_fails(temp.path(), &["measurements.csv"]);

    let missing = temp.path().join("nowhere");
    assert_inspect_fails(&missing, &["machine.json"]);
}

#[test]
fn calibrate_writes_calibration_json_and_compares_with_the_truth() {
    let temp = tempfile::tempdir().unwrap();
    simulate(temp.path(), &[]);
    let dir = temp.path().to_str().unwrap();
    let output = parcal(&["calibrate", dir, "--sim", "IV", "--prior", "propagated"]);
    let stdout = text(&output.stdout);
    assert!(output.status.success(), "{}{stdout}", text(&output.stderr));
    assert!(stdout.contains("status: converged"), "{stdout}");
    assert!(stdout.contains("| z_eT |"), "{stdout}");
    assert!(stdout.contains("error/sigma"), "{stdout}");
    assert!(stdout.contains("NEES against the truth"), "{stdout}");
    let calibration = parcal_dataset_calibration(&temp.path().join("calibration.json"));
    assert!(
        calibration.contains("\"prior\": \"propagated\"")
            && calibration.contains("\"converged\": true")
    );
    // --sim takes the radius error per contact: no radius estimates.
    assert!(calibration.contains("\"radius\": \"contact\""));
    assert!(!calibration.contains("\"radius_sigma\""));

    // The default: each ball's radius an unknown, written with its sigma.
    let out = temp.path().join("per-ball.json");
    let output = parcal(&["calibrate", dir, "--out", out.to_str().unwrap()]);
    assert!(output.status.success(), "{}", text(&output.stderr));
    let per_ball = parcal_dataset_calibration(&out);
    assert!(per_ball.contains("\"radius\": \"ball\""), "{per_ball}");
    let read: serde_json::Value = serde_json::from_str(&per_ball).unwrap();
    let centres = read["ball_centres"].as_object().unwrap();
    assert!(!centres.is_empty());
    assert!(
        centres
            .values()
            .all(|c| c["radius_sigma"].as_f64() > Some(0.0))
    );

    // Paper mode: the prior warning fires.
    let out = temp.path().join("paper.json");
    let output = parcal(&[
        "calibrate",
        dir,
        "--sim",
        "III",
        "--out",
        out.to_str().unwrap(),
    ]);
    let stdout = text(&output.stdout);
    // The over-confident prior leaves a contact of this dataset (seed 7)
    // failing the data-snooping test, which rejects the run.
    assert_eq!(output.status.code(), Some(3), "{}", text(&output.stderr));
    assert!(stdout.contains("data-snooping test failed"), "{stdout}");
    assert!(
        stdout.contains("WARNING: the paper-form prior is over-confident"),
        "{stdout}"
    );

    // Maps from the calibration.
    let maps = temp.path().join("maps");
    let output = parcal(&[
        "accuracy",
        dir,
        "--calibration",
        temp.path().join("calibration.json").to_str().unwrap(),
        "--out",
        maps.to_str().unwrap(),
    ]);
    assert!(output.status.success(), "{}", text(&output.stderr));
    assert!(maps.join("accuracy.csv").exists());
    assert!(maps.join("after_true_registered.svg").exists());
    assert!(maps.join("before_predicted_absolute.svg").exists());
}

fn parcal_dataset_calibration(path: &Path) -> String {
    std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

#[test]
fn paper_writes_the_report() {
    let temp = tempfile::tempdir().unwrap();
    let output = parcal(&[
        "paper",
        "--seed",
        "2",
        "--out",
        temp.path().to_str().unwrap(),
    ]);
    assert!(output.status.success(), "{}", text(&output.stderr));
    let report = std::fs::read_to_string(temp.path().join("report.md")).unwrap();
    for part in [
        "## Convergence",
        "| IV (propagated prior) | converged",
        "## The paper's figures beside ours",
        "### Where and why they differ",
        "| z_b5 |",
    ] {
        assert!(report.contains(part), "report.md lacks {part:?}");
    }
    for file in [
        "residuals-fig5.svg",
        "residuals-fig8.svg",
        "residuals.csv",
        "calibration-IV-propagated.json",
        "map-IV-propagated-after_true_registered.svg",
    ] {
        assert!(temp.path().join(file).exists(), "{file} missing");
    }
}

#[test]
fn an_underdetermined_calibration_names_the_weak_parameters_and_still_writes_its_file() {
    // 4 balls x 4 contacts without a prior: 16 radius rows for 45 unknowns.
    let temp = tempfile::tempdir().unwrap();
    simulate(temp.path(), &["--balls", "4", "--points-per-ball", "4"]);
    let dir = temp.path().to_str().unwrap();
    let output = parcal(&["calibrate", dir, "--sim", "I"]);
    // Rejected: computed and written, but not to be used.
    assert_eq!(output.status.code(), Some(3));
    let stderr = text(&output.stderr);
    assert!(
        stderr.contains("rejected: the solver stopped: the reduced system is singular"),
        "{stderr}"
    );
    assert!(
        stderr.contains("smallest eigenvalues: eigenvalue") && stderr.contains(" along "),
        "{stderr}"
    );
    // 45 - 16 directions have no information at all: said so, with no
    // infinite sigma and no (negative) condition number.
    let stdout = text(&output.stdout);
    assert!(
        stdout.contains(
            "the data and the prior cannot identify the parameters: 29 directions of them have no information"
        ),
        "{stdout}"
    );
    for misleading in ["sigma inf", "condition number"] {
        assert!(!stdout.contains(misleading), "{misleading}: {stdout}");
    }
    // Beside calibration.json, which a rejected run never replaces.
    assert!(stderr.contains("calibration.rejected.json"), "{stderr}");
    assert!(!temp.path().join("calibration.json").exists());
    let calibration =
        std::fs::read_to_string(temp.path().join("calibration.rejected.json")).unwrap();
    assert!(
        calibration.contains("\"converged\": false"),
        "{calibration}"
    );
    assert!(calibration.contains("\"status\": \"the reduced system is singular at iteration 0"));
    assert!(!calibration.contains("NaN"));
}

#[test]
fn a_calibration_that_cannot_start_says_where() {
    let temp = tempfile::tempdir().unwrap();
    simulate(temp.path(), &[]);
    let csv = temp.path().join("measurements.csv");
    let mut lines: Vec<String> = std::fs::read_to_string(&csv)
        .unwrap()
        .lines()
        .map(String::from)
        .collect();
    lines[9] = "b02,1000,1000,1000,0,0,0".to_string();
    std::fs::write(&csv, lines.join("\n")).unwrap();
    let output = parcal(&["calibrate", temp.path().to_str().unwrap()]);
    assert!(!output.status.success());
    let stderr = text(&output.stderr);
    assert!(
        stderr.contains("measurements.csv line 10: measurement row 8: forward kinematics failed"),
        "{stderr}"
    );
    assert_eq!(stderr.matches("did not converge").count(), 1, "{stderr}");

    // A zero commanded approach direction is refused as the dataset is
    // read, by inspect as by calibrate.
    let mut with_directions = vec![format!("{},dir_x,dir_y,dir_z", lines[0])];
    with_directions.extend(lines[1..].iter().map(|line| format!("{line},0,0,-1")));
    with_directions[1] = format!("{},0,0,0", lines[1]);
    std::fs::write(&csv, with_directions.join("\n")).unwrap();
    for command in ["calibrate", "inspect"] {
        let output = parcal(&[command, temp.path().to_str().unwrap()]);
        assert!(!output.status.success());
        let stderr = text(&output.stderr);
        assert!(
            stderr.contains(
                "measurements.csv: line 2: the approach direction (0, 0, 0) is zero, not a direction"
            ),
            "{command}: {stderr}"
        );
    }
}

#[test]
fn a_dataset_with_too_few_contacts_per_ball_is_not_written() {
    // The reader would refuse it, as text files or as a snapshot: the
    // writer refuses it with the reader's message.
    for binary in [false, true] {
        let temp = tempfile::tempdir().unwrap();
        let dir = temp.path().join("d");
        let mut args = vec!["simulate", "--points-per-ball", "3", "--out"];
        args.push(dir.to_str().unwrap());
        if binary {
            args.push("--binary");
        }
        let output = parcal(&args);
        assert!(!output.status.success());
        let stderr = text(&output.stderr);
        assert!(
            stderr.contains("ball \"b01\" has 3 contacts, fewer than the minimum of 4"),
            "{stderr}"
        );
        assert!(!dir.join("measurements.csv").exists() && !dir.join("dataset.bin").exists());
    }
}

#[test]
fn a_binary_snapshot_calibrates_like_the_text_files() {
    let temp = tempfile::tempdir().unwrap();
    simulate(temp.path(), &["--binary"]);
    let snapshot = temp.path().join("dataset.bin");
    let output = parcal(&["calibrate", snapshot.to_str().unwrap()]);
    assert!(output.status.success(), "{}", text(&output.stderr));
    let from_snapshot = std::fs::read_to_string(temp.path().join("calibration.json")).unwrap();
    let text_out = temp.path().join("from-text.json");
    let output = parcal(&[
        "calibrate",
        temp.path().to_str().unwrap(),
        "--out",
        text_out.to_str().unwrap(),
    ]);
    assert!(output.status.success());
    // The same result; the provenance names each its own input.
    let without_provenance = |json: &str| -> serde_json::Value {
        let mut value: serde_json::Value = serde_json::from_str(json).unwrap();
        let provenance = value.as_object_mut().unwrap().remove("provenance").unwrap();
        assert!(
            provenance["dataset_checksum"]
                .as_str()
                .unwrap()
                .starts_with("crc32:")
        );
        value
    };
    let from_text = std::fs::read_to_string(text_out).unwrap();
    assert_eq!(
        without_provenance(&from_snapshot),
        without_provenance(&from_text)
    );
    let checksum = |json: &str| -> serde_json::Value {
        serde_json::from_str::<serde_json::Value>(json).unwrap()["provenance"]["dataset_checksum"]
            .clone()
    };
    assert_eq!(checksum(&from_snapshot), checksum(&from_text));
}

/// Runs parcal with its stdout (and, if `close_stderr`, its stderr) a pipe
/// whose reader is gone before parcal writes, as in `parcal inspect d | head
/// -0`; returns the exit status and what reached stderr.
fn with_closed_output(args: &[&str], close_stderr: bool) -> (std::process::ExitStatus, String) {
    let mut child = Command::new(env!("CARGO_BIN_EXE_parcal"))
        .args(args)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("the parcal binary runs");
    drop(child.stdout.take());
    if close_stderr {
        drop(child.stderr.take());
    }
    let output = child.wait_with_output().expect("parcal ends");
    (output.status, text(&output.stderr))
}

#[test]
fn a_closed_output_pipe_ends_the_run_quietly_and_keeps_its_files() {
    let reference =
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../../fixtures/reference-paper-seed1");
    let reference = reference.to_str().unwrap();
    let (status, stderr) = with_closed_output(&["inspect", reference], false);
    assert!(status.success() && stderr.is_empty(), "{status}: {stderr}");

    let temp = tempfile::tempdir().unwrap();
    for close_stderr in [false, true] {
        let out = temp.path().join(format!("calibration-{close_stderr}.json"));
        let args = ["calibrate", reference, "--out", out.to_str().unwrap()];
        let (status, stderr) = with_closed_output(&args, close_stderr);
        assert!(status.success(), "{status}: {stderr}");
        assert!(!stderr.contains("panicked"), "{stderr}");
        let calibration = parcal_dataset_calibration(&out);
        assert!(calibration.contains("\"converged\": true"), "{calibration}");
    }

    // A calibration that fails still says so.
    let out = temp.path().join("unfinished.json");
    let args = [
        "calibrate",
        reference,
        "--max-iterations",
        "1",
        "--out",
        out.to_str().unwrap(),
    ];
    let (status, stderr) = with_closed_output(&args, false);
    assert_eq!(status.code(), Some(3), "{stderr}");
    assert!(
        stderr.contains("rejected: the solver stopped: iteration limit"),
        "{stderr}"
    );
}

#[test]
fn plan_writes_a_plan_that_simulate_measures() {
    let temp = tempfile::tempdir().unwrap();
    let (template, data) = (temp.path().join("template"), temp.path().join("data"));
    simulate(&template, &["--balls", "8", "--points-per-ball", "5"]);
    // A plan of 40 touches at +-20 degrees from 2000 candidates.
    let plan_into = |out: &std::path::Path, options: &[&str]| {
        let mut args = vec![
            "plan",
            template.to_str().unwrap(),
            "--contacts",
            "40",
            "--tilt",
            "20",
            "--pool",
            "2000",
            "--out",
            out.to_str().unwrap(),
        ];
        args.extend_from_slice(options);
        let output = parcal(&args);
        assert!(output.status.success(), "{}", text(&output.stderr));
        output
    };
    let plan = temp.path().join("plan.csv");
    let output = plan_into(&plan, &[]);
    let stdout = text(&output.stdout);
    assert!(stdout.contains("touches            40 from"), "{stdout}");
    assert!(
        stdout.contains("predicted          registered RMS"),
        "{stdout}"
    );
    let csv = std::fs::read_to_string(&plan).unwrap();
    let mut lines = csv.lines();
    assert_eq!(
        lines.next(),
        Some("ball,u_x,u_y,u_z,roll,pitch,yaw,q1,q2,q3,q4,q5,q6")
    );
    assert_eq!(lines.count(), 40);
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(temp.path().join("plan.json")).unwrap())
            .unwrap();
    let rms = summary["predicted"]["registered_rms_um"].as_f64().unwrap();
    let prior = summary["prior"]["registered_rms_um"].as_f64().unwrap();
    assert!(rms > 0.0 && rms < prior / 2.0, "{rms} {prior}");
    assert_eq!(summary["options"]["contacts"], 40);
    // The radius model is calibrate's default; --radius takes calibrate's
    // values.
    assert_eq!(summary["options"]["radius"], "ball");
    let contact = temp.path().join("contact.csv");
    plan_into(&contact, &["--radius", "contact"]);
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(temp.path().join("contact.json")).unwrap())
            .unwrap();
    assert_eq!(summary["options"]["radius"], "contact");

    // Noise seed 2: 40 touches of 8 balls, each with its centre and radius
    // unknown, leave every observation a redundancy under 0.1, where the
    // data-snooping test rejects clean draws often (seeds 1, 4, 7 and 8 of
    // 1-8); the sequential step below needs an accepted calibration.
    let output = parcal(&[
        "simulate",
        "--seed",
        "2",
        "--balls",
        "8",
        "--plan",
        plan.to_str().unwrap(),
        "--out",
        data.to_str().unwrap(),
    ]);
    assert!(output.status.success(), "{}", text(&output.stderr));
    assert!(text(&output.stdout).contains("contacts           40 (planned:"));
    let inspect = parcal(&["inspect", data.to_str().unwrap()]);
    assert!(inspect.status.success(), "{}", text(&inspect.stderr));

    // Sequential mode: the next touches after calibrating the planned data.
    let calibrate = parcal(&["calibrate", data.to_str().unwrap()]);
    assert!(calibrate.status.success(), "{}", text(&calibrate.stderr));
    let next = temp.path().join("next.csv");
    let output = parcal(&[
        "plan",
        data.to_str().unwrap(),
        "--after",
        data.join("calibration.json").to_str().unwrap(),
        "--contacts",
        "8",
        "--tilt",
        "20",
        "--pool",
        "2000",
        "--out",
        next.to_str().unwrap(),
    ]);
    assert!(output.status.success(), "{}", text(&output.stderr));
    assert!(text(&output.stdout).contains("  calibration        registered RMS"));
    assert_eq!(std::fs::read_to_string(&next).unwrap().lines().count(), 9);

    // A plan naming a ball the simulation does not have is refused, naming
    // the line.
    let output = parcal(&[
        "simulate",
        "--balls",
        "4",
        "--plan",
        plan.to_str().unwrap(),
        "--out",
        temp.path().join("small").to_str().unwrap(),
    ]);
    assert!(!output.status.success());
    let stderr = text(&output.stderr);
    assert!(
        stderr.contains("plan.csv: line") && stderr.contains("is not one of the simulated balls"),
        "{stderr}"
    );
}

#[test]
fn plan_chooses_tracker_poses_that_simulate_measures() {
    let temp = tempfile::tempdir().unwrap();
    let template = temp.path().join("template");
    simulate(
        &template,
        &["--tracker", "poses", "--sessions", "1", "--rows", "8"],
    );
    let plan = temp.path().join("plan.csv");
    let args = |extra: &[&str]| {
        let mut args = vec![
            "plan",
            template.to_str().unwrap(),
            "--poses",
            "8",
            "--tilt",
            "10",
            "--out",
            plan.to_str().unwrap(),
        ];
        args.extend_from_slice(extra);
        parcal(&args)
    };
    // Without a workspace the pose plan is refused, saying what it needs.
    let output = args(&[]);
    assert!(!output.status.success());
    assert!(
        text(&output.stderr).contains("--workspace"),
        "{}",
        text(&output.stderr)
    );
    let output = args(&["--workspace", "60,300,380"]);
    assert!(output.status.success(), "{}", text(&output.stderr));
    assert!(text(&output.stdout).contains("poses              8 from"));
    let csv = std::fs::read_to_string(&plan).unwrap();
    let mut lines = csv.lines();
    assert_eq!(
        lines.next(),
        Some("session,roll,pitch,yaw,x,y,z,q1,q2,q3,q4,q5,q6")
    );
    let planned: Vec<Vec<f64>> = lines
        .map(|l| l.split(',').skip(1).map(|v| v.parse().unwrap()).collect())
        .collect();
    assert_eq!(planned.len(), 8);
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(temp.path().join("plan.json")).unwrap())
            .unwrap();
    assert_eq!(summary["options"]["tracker"], "poses");
    // Every session measures the planned readings (plus 1 um of noise).
    let data = temp.path().join("planned");
    simulate(
        &data,
        &[
            "--tracker",
            "poses",
            "--sessions",
            "2",
            "--plan",
            plan.to_str().unwrap(),
        ],
    );
    let poses = std::fs::read_to_string(data.join("poses.csv")).unwrap();
    let mut lines = poses.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let q1 = header.iter().position(|h| *h == "q1").unwrap();
    let rows: Vec<Vec<f64>> = lines
        .map(|l| {
            l.split(',')
                .skip(q1)
                .take(6)
                .map(|v| v.parse().unwrap())
                .collect()
        })
        .collect();
    assert_eq!(rows.len(), 16);
    for (k, row) in rows.iter().enumerate() {
        let plan_row = &planned[k % 8];
        for i in 0..6 {
            assert!(
                (row[i] - plan_row[6 + i]).abs() < 0.01,
                "row {k}: {row:?} vs {plan_row:?}"
            );
        }
    }
    // A plan over two sessions, 4 poses each: the simulation has the
    // plan's sessions, each measuring its own poses.
    let output = args(&["--workspace", "60,300,380", "--sessions", "2"]);
    assert!(output.status.success(), "{}", text(&output.stderr));
    let csv = std::fs::read_to_string(&plan).unwrap();
    let planned: Vec<(String, Vec<f64>)> = csv
        .lines()
        .skip(1)
        .map(|l| {
            let mut fields = l.split(',');
            let session = fields.next().unwrap().to_owned();
            (
                session,
                fields.skip(6).map(|v| v.parse().unwrap()).collect(),
            )
        })
        .collect();
    let sessions: Vec<&str> = planned.iter().map(|(s, _)| s.as_str()).collect();
    assert_eq!(sessions, ["1", "1", "1", "1", "2", "2", "2", "2"]);
    let data = temp.path().join("two-sessions");
    simulate(
        &data,
        &["--tracker", "poses", "--plan", plan.to_str().unwrap()],
    );
    let poses = std::fs::read_to_string(data.join("poses.csv")).unwrap();
    let mut lines = poses.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let (at_session, q1) = (
        header.iter().position(|h| *h == "session").unwrap(),
        header.iter().position(|h| *h == "q1").unwrap(),
    );
    let rows: Vec<Vec<&str>> = lines.map(|l| l.split(',').collect()).collect();
    assert_eq!(rows.len(), 8);
    for (row, (session, q)) in rows.iter().zip(&planned) {
        assert_eq!(row[at_session], session);
        for i in 0..6 {
            let measured: f64 = row[q1 + i].parse().unwrap();
            assert!((measured - q[i]).abs() < 0.01, "{row:?} vs {q:?}");
        }
    }
}

#[test]
fn a_budget_below_four_touches_per_ball_plans_fewer_balls() {
    // 95 touches of the paper's 27 balls: fewer than the reader's 4 per
    // ball, so the plan touches some balls and the simulation writes only
    // those, which calibrate accepts.
    let temp = tempfile::tempdir().unwrap();
    let (template, data) = (temp.path().join("template"), temp.path().join("data"));
    simulate(&template, &["--points-per-ball", "4"]);
    let plan = temp.path().join("plan.csv");
    let output = parcal(&[
        "plan",
        template.to_str().unwrap(),
        "--contacts",
        "95",
        "--tilt",
        "20",
        "--pool",
        "3000",
        "--out",
        plan.to_str().unwrap(),
    ]);
    assert!(output.status.success(), "{}", text(&output.stderr));
    let csv = std::fs::read_to_string(&plan).unwrap();
    let mut per_ball = std::collections::BTreeMap::new();
    for line in csv.lines().skip(1) {
        *per_ball.entry(line.split(',').next().unwrap()).or_insert(0) += 1;
    }
    assert_eq!(per_ball.values().sum::<usize>(), 95);
    // The default floor: at least 95 / 8 = 11 balls.
    assert!((11..27).contains(&per_ball.len()), "{per_ball:?}");
    assert!(per_ball.values().all(|&n| n >= 4), "{per_ball:?}");

    let output = simulate(&data, &["--plan", plan.to_str().unwrap()]);
    let stdout = text(&output.stdout);
    assert!(
        stdout.contains(&format!("  balls              {}\n", per_ball.len())),
        "{stdout}"
    );
    let artefacts: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(data.join("artefacts.json")).unwrap())
            .unwrap();
    let ids: Vec<&str> = artefacts["balls"]
        .as_array()
        .unwrap()
        .iter()
        .map(|b| b["id"].as_str().unwrap())
        .collect();
    assert_eq!(ids, per_ball.keys().copied().collect::<Vec<_>>());
    let calibrate = parcal(&["calibrate", data.to_str().unwrap()]);
    assert!(calibrate.status.success(), "{}", text(&calibrate.stderr));
}

/// `--loss`: a reading 5 mm off (measurements.csv line 40) is down-weighted
/// by the Cauchy loss, listed in calibration.json with its line and in the
/// verdict's reasons, and the loss recorded in the options; a bad loss, and
/// a robust loss with --snoop (which it replaces), fail with a message.
#[test]
fn calibrate_with_a_robust_loss_lists_the_down_weighted_reading() {
    let temp = tempfile::tempdir().unwrap();
    let data = common::copy_fixture("paper-seed1", temp.path(), &common::PAPER_FILES);
    let csv = data.join("measurements.csv");
    let text_csv = std::fs::read_to_string(&csv).unwrap();
    let mut lines: Vec<String> = text_csv.lines().map(String::from).collect();
    let mut fields: Vec<String> = lines[39].split(',').map(String::from).collect();
    fields[3] = (fields[3].parse::<f64>().unwrap() + 5.0).to_string();
    lines[39] = fields.join(",");
    std::fs::write(&csv, lines.join("\n") + "\n").unwrap();
    let out = temp.path().join("cauchy.json");
    let stdout = common::ok(&[
        "calibrate",
        common::s(&data),
        "--loss",
        "cauchy",
        "--out",
        common::s(&out),
    ]);
    assert!(stdout.contains("verdict: accepted"), "{stdout}");
    assert!(
        stdout.contains("down-weighted 1 observation")
            && stdout.contains("measurements.csv line 40"),
        "{stdout}"
    );
    let json = parcal_dataset_calibration(&out);
    assert!(json.contains("\"loss\": \"cauchy:2.385\""), "{json}");
    assert!(json.contains("\"down_weighted_observations\""), "{json}");
    let record = parcal::dataset::Calibration::read(&out).unwrap();
    let listed = &record.down_weighted_observations;
    assert_eq!(listed.len(), 1);
    assert_eq!(
        (listed[0].file.as_str(), listed[0].line),
        ("measurements.csv", Some(40))
    );
    assert!(listed[0].weight < 0.1 && listed[0].residual_sigmas > 7.0);

    let error = common::fails(&["calibrate", common::s(&data), "--loss", "huber:0"]);
    assert!(error.contains("k must be positive"), "{error}");
    let error = common::fails(&["calibrate", common::s(&data), "--loss", "huber", "--snoop"]);
    assert!(error.contains("data snooping"), "{error}");
}

/// The re-mounted session of the issue (fixtures/jugglebot's poses with
/// the marker body moved 7.1 mm, machine.json without a session model),
/// validated on 12 reference poses against the fixture's calibration:
/// exit status 3, validation.json written with the verdict "rejected" and
/// its test, and the message names the body origin and the setting that
/// declares it.
#[test]
fn a_re_mounted_marker_body_fails_validation_with_status_3_naming_the_body_origin() {
    let temp = tempfile::tempdir().unwrap();
    let data = copy_fixture("jugglebot", temp.path(), &["machine.json", "poses.csv"]);
    let calibration = temp.path().join("calibration.json");
    ok(&["calibrate", s(&data), "--out", s(&calibration)]);
    let mut day2 = parcal::dataset::Dataset::read(&data).unwrap();
    day2.tracker = parcal::simulation::re_mounted(
        &day2.tracker,
        parcal::kinematics::Vec3::new(5.0, -3.0, 4.0),
    );
    day2.machine.session_model = parcal::dataset::SessionModel::default();
    let day2_dir = temp.path().join("day2");
    day2.write(&day2_dir).unwrap();
    let args = [
        "validate",
        s(&day2_dir),
        "--calibration",
        s(&calibration),
        "--reference",
        "12",
    ];
    let output = parcal(&args);
    let stderr = text(&output.stderr);
    assert_eq!(output.status.code(), Some(3), "{stderr}");
    assert!(
        stderr.starts_with("rejected: prediction test failed"),
        "{stderr}"
    );
    assert!(
        stderr.contains("re-fitting the body origin would explain them")
            && stderr.contains("declare session_model.body_origin_sigma in machine.json"),
        "{stderr}"
    );
    let record =
        parcal::dataset::ValidationRecord::read(&day2_dir.join("validation.json")).unwrap();
    assert_eq!(record.verdict, "rejected");
    let test = record.test.expect("the test");
    assert_eq!(test.outcome, "too large");
    assert_eq!(test.degrees_of_freedom, 6 * 96);
    assert!(test.ratio > test.interval[1]);
    // Without reference rows, its session (labelled as the calibration's)
    // is predicted in the calibration's frames: the message says that the
    // instrument or the body may have moved, which reference rows re-fit.
    let output = parcal(&args[..4]);
    let stderr = text(&output.stderr);
    assert_eq!(output.status.code(), Some(3), "{stderr}");
    assert!(
        stderr.contains(
            "the instrument or the marker body may have moved since, which reference rows re-fit"
        ),
        "{stderr}"
    );
    // The fixture itself as another day's session is accepted, and said
    // to be predicted in sample.
    let output = parcal(&[
        "validate",
        s(&data),
        "--calibration",
        s(&calibration),
        "--reference",
        "12",
    ]);
    let stdout = text(&output.stdout);
    assert!(stdout.starts_with("verdict: accepted\n"), "{stdout}");
    let stderr = text(&output.stderr);
    assert!(
        stderr.contains("its rows are predicted in sample"),
        "{stderr}"
    );
}
