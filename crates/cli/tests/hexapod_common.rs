//! `parcal calibrate --common`: a hexapod's ball touches by the common
//! calibration of every mechanism, from the command line: the same
//! estimate as its own calibration, written as a mechanism's record with
//! its report, by Gauss-Newton or Levenberg-Marquardt; what the common
//! calibration does not model refused by name.

use crate::common;

use common::{PAPER_FILES, copy_fixture, fails, ok, parcal, s, text, tracker_errors};
use parcal::kinematics::params::PARAM_NAMES;
use parcal::workflows::evaluate::TrueMachine;
use serde_json::Value;

fn read(path: &std::path::Path) -> Value {
    serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap()
}

/// The own record's 33 parameters and the common record's, by name: each
/// run stops within 1e-3 of its sigmas from the same minimum.
fn assert_same_minimum(own: &Value, common: &Value) {
    let names = own["parameters"]["names"].as_array().unwrap();
    let values = own["parameters"]["values"].as_array().unwrap();
    let parameters = common["parameters"].as_array().unwrap();
    assert_eq!(parameters.len(), 33);
    for ((name, value), parameter) in names.iter().zip(values).zip(parameters) {
        assert_eq!(parameter["name"], *name);
        let (a, b) = (
            value.as_f64().unwrap(),
            parameter["value"].as_f64().unwrap(),
        );
        let sigma = parameter["sigma"].as_f64().unwrap();
        assert!(
            (a - b).abs() < 2e-3 * sigma,
            "{}: {a} against {b}",
            parameter["name"]
        );
    }
}

#[test]
fn a_hexapod_through_the_common_calibration_is_its_own() {
    let temp = tempfile::tempdir().unwrap();
    let data = copy_fixture("paper-seed1", temp.path(), &PAPER_FILES);
    let (own, shared) = (temp.path().join("own.json"), temp.path().join("shared"));
    std::fs::create_dir(&shared).unwrap();
    let common = shared.join("calibration.json");
    ok(&["calibrate", s(&data), "--sim", "III", "--out", s(&own)]);
    let printed = ok(&[
        "calibrate",
        s(&data),
        "--common",
        "--sim",
        "III",
        "--report",
        "--out",
        s(&common),
    ]);
    assert!(
        printed.contains("observations: 189 ball touches"),
        "{printed}"
    );
    assert!(shared.join("report.html").exists() && shared.join("report.md").exists());
    // The simulation's truth beside each estimate: the true machine's
    // canonical parameters; in the report too, and in one made from the
    // record with the dataset.
    let dataset = parcal::dataset::Dataset::read(&data).unwrap();
    let truth = TrueMachine::of(&dataset).unwrap().unwrap();
    for (name, value) in PARAM_NAMES.iter().zip(truth.params.iter()) {
        let line = printed.lines().find(|l| l.starts_with(&format!("{name} ")));
        let cells: Vec<&str> = line.unwrap().split_whitespace().collect();
        assert_eq!(cells[7], format!("{value:.4}"), "{name}");
    }
    let again = temp.path().join("again");
    let command = ["report", s(&common), "--dataset", s(&data)];
    ok(&[&command[..], &["--out", s(&again)]].concat());
    for report in [shared.join("report.md"), again.join("report.md")] {
        let markdown = std::fs::read_to_string(report).unwrap();
        assert!(markdown.contains("| true | error / sigma |"), "{markdown}");
    }
    let levenberg = temp.path().join("levenberg.json");
    let command = ["calibrate", s(&data), "--common", "--sim", "III", "--lm"];
    ok(&[&command[..], &["--out", s(&levenberg)]].concat());
    let own = read(&own);
    for common in [read(&common), read(&levenberg)] {
        assert_eq!(common["mechanism"], "hexapod");
        assert_same_minimum(&own, &common);
    }
}

#[test]
fn balls_tied_by_a_plate_through_the_common_calibration_are_its_own() {
    // The paper's campaign with a ball plate of 12 pairs: the tied balls'
    // centres are global unknowns in both paths.
    let temp = tempfile::tempdir().unwrap();
    let data = temp.path().join("plate");
    let simulated = [
        "simulate",
        "--seed",
        "3",
        "--plate",
        "12",
        "--out",
        s(&data),
    ];
    ok(&simulated);
    let (own, common) = (
        temp.path().join("own.json"),
        temp.path().join("common.json"),
    );
    let sim = ["--sim", "III", "--prior", "propagated"];
    ok(&[&["calibrate", s(&data)][..], &sim, &["--out", s(&own)]].concat());
    let printed = ok(&[
        &["calibrate", s(&data), "--common"][..],
        &sim,
        &["--out", s(&common)],
    ]
    .concat());
    assert!(
        printed.contains("observations: 12 ball distances, 189 ball touches"),
        "{printed}"
    );
    let (own, common) = (read(&own), read(&common));
    assert_same_minimum(&own, &common);
    let tested: Vec<u64> = common["tests"]["observations"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|run| run["kind"] == "ball distance")
        .flat_map(|run| {
            let first = run["index"].as_u64().unwrap();
            first..first + run.get("count").map_or(1, |c| c.as_u64().unwrap())
        })
        .collect();
    assert_eq!(tested, (0..12).collect::<Vec<u64>>());
}

/// fixtures/paper-seed1 calibrated through the common path, `--sim III`
/// with the propagated prior, its record in `directory`.
fn propagated_record(directory: &std::path::Path) -> std::path::PathBuf {
    let data = copy_fixture("paper-seed1", directory, &PAPER_FILES);
    let calibration = directory.join("calibration.json");
    let args = ["calibrate", s(&data), "--common", "--sim", "III"];
    ok(&[
        &args[..],
        &["--prior", "propagated", "--out", s(&calibration)],
    ]
    .concat());
    calibration
}

#[test]
fn a_hexapod_record_is_compensated_on_target_poses() {
    // Targets in the hexapod's pose coordinates; commands for six legs with
    // the nominal ones beside them.
    let temp = tempfile::tempdir().unwrap();
    let calibration = propagated_record(temp.path());
    let targets = temp.path().join("targets.csv");
    let out = temp.path().join("commands.csv");
    std::fs::write(&targets, "t_x,t_y,t_z,r_x,r_y,r_z\n-80,-30,330,0.05,0,0\n").unwrap();
    let compensate = ["compensate", "--calibration", s(&calibration)];
    let printed = ok(&[
        &compensate[..],
        &["--targets", s(&targets), "--out", s(&out)],
    ]
    .concat());
    assert!(printed.contains("1 targets"), "{printed}");
    let written = std::fs::read_to_string(&out).unwrap();
    let header = written.lines().next().unwrap();
    assert!(
        header.starts_with("t_x,t_y,t_z,r_x,r_y,r_z,q1,q2,q3,q4,q5,q6,nominal_q1"),
        "{header}"
    );
    // The hexapod's own export formats need its design's frames.
    let hal = temp.path().join("hal");
    let export = ["export", "--calibration", s(&calibration), "--format"];
    let error = fails(&[&export[..], &["genhexkins", "--out", s(&hal)]].concat());
    assert!(error.contains("through the common path"), "{error}");
    // Positions alone are refused, naming the hexapod's columns.
    std::fs::write(&targets, "x,y,z\n0,0,400\n").unwrap();
    let error = fails(
        &[
            &compensate[..],
            &["--targets", s(&targets), "--out", s(&out)],
        ]
        .concat(),
    );
    assert!(error.contains("t_x,t_y,t_z,r_x,r_y,r_z"), "{error}");
}

#[test]
fn a_hexapod_record_is_validated_on_held_out_touches() {
    // Fitted on fixtures/paper-seed1 (propagated prior), judged on another
    // campaign of the same machine (seed 7: other noise), each ball's
    // centre projected out of its touches or located by its first 4:
    // accepted; with leg 1 reading 0.1 mm long there, rejected, l_1 the
    // change that best explains it; each row placed in the hexapod
    // dataset's files.
    let temp = tempfile::tempdir().unwrap();
    let calibration = propagated_record(temp.path());
    let held_out = temp.path().join("seed7");
    ok(&["simulate", "--seed", "7", "--out", s(&held_out)]);
    let out = temp.path().join("validation.json");
    let validate = ["validate", s(&held_out), "--calibration", s(&calibration)];
    let printed = ok(&[&validate[..], &["--out", s(&out)]].concat());
    assert!(printed.contains("verdict: accepted"), "{printed}");
    let record = read(&out);
    assert_eq!(record["mechanism"], "hexapod");
    let rows = record["rows"].as_array().unwrap();
    assert_eq!(rows.len(), 27 * 4);
    assert!(rows.iter().all(|row| row["file"] == "artefacts.json"));
    // Each ball's centre located by its first 4 touches, its other 3
    // predicted: accepted too.
    let referenced = temp.path().join("referenced.json");
    let with_reference = [
        &validate[..],
        &["--reference", "4", "--out", s(&referenced)],
    ]
    .concat();
    let printed = ok(&with_reference);
    assert!(printed.contains("verdict: accepted"), "{printed}");
    let record = read(&referenced);
    assert_eq!(record["reference"], 4);
    let rows = record["rows"].as_array().unwrap();
    assert_eq!(rows.len(), 27 * 3);
    // Each row a touch's, by its line in measurements.csv: ball 0's
    // touches are its first 7 rows, so its fifth is line 6.
    assert!(rows.iter().all(|row| row["file"] == "measurements.csv"));
    assert_eq!(
        (&rows[0]["kind"], &rows[0]["line"]),
        (&"ball touch".into(), &6.into())
    );
    let said = record["reasons"].to_string();
    assert!(said.contains("its first 4 touches"), "{said}");
    // Leg 1 0.1 mm long: every q1 + 0.1 (the scale is 1).
    let measurements = held_out.join("measurements.csv");
    let text = std::fs::read_to_string(&measurements).unwrap();
    let mut lines = text.lines();
    let mut shifted = format!("{}\n", lines.next().unwrap());
    for line in lines {
        let mut fields: Vec<String> = line.split(',').map(str::to_string).collect();
        fields[1] = (fields[1].parse::<f64>().unwrap() + 0.1).to_string();
        shifted += &format!("{}\n", fields.join(","));
    }
    std::fs::write(&measurements, shifted).unwrap();
    let error = fails(&[&validate[..], &["--out", s(&out)]].concat());
    assert!(error.contains("rejected"), "{error}");
    let record = read(&out);
    assert_eq!(record["verdict"], "rejected");
    assert_eq!(record["shifts"][0]["name"], "l_1");
    let error = fails(&with_reference);
    assert!(error.contains("rejected"), "{error}");
    assert_eq!(read(&referenced)["shifts"][0]["name"], "l_1");
}

#[test]
fn unknown_scales_through_the_common_calibration_are_its_own() {
    // Touches read in motor revolutions, the scales unknowns with a 2 %
    // prior: the record holds them after the 33 (their prior's
    // correlation 39 x 39), within 2e-3 of their sigma of the own
    // calibration's calibrated scales.
    let temp = tempfile::tempdir().unwrap();
    let data = temp.path().join("rev");
    ok(&[
        "simulate",
        "--seed",
        "3",
        "--readings",
        "rev",
        "--out",
        s(&data),
    ]);
    let (own, common) = (
        temp.path().join("own.json"),
        temp.path().join("common.json"),
    );
    let flags = ["--sim", "III", "--prior", "propagated"];
    ok(&[&["calibrate", s(&data), "--out", s(&own)], &flags[..]].concat());
    let common_args = [
        &["calibrate", s(&data), "--common", "--out", s(&common)],
        &flags[..],
    ];
    ok(&common_args.concat());
    let (own, common) = (read(&own), read(&common));
    let parameters = common["parameters"].as_array().unwrap();
    assert_eq!(parameters.len(), 39);
    assert_eq!(common["prior_correlation"].as_array().unwrap().len(), 39);
    let scales = own["machine"]["actuator"]["scale"].as_array().unwrap();
    for (i, (parameter, own_scale)) in parameters[33..].iter().zip(scales).enumerate() {
        assert_eq!(parameter["name"], format!("s_{}", i + 1));
        assert_eq!(parameter["unit"], "mm/rev");
        let (a, b) = (
            own_scale.as_f64().unwrap(),
            parameter["value"].as_f64().unwrap(),
        );
        let sigma = parameter["sigma"].as_f64().unwrap();
        assert!((a - b).abs() < 2e-3 * sigma, "s_{}: {a} against {b}", i + 1);
    }
    // Applied with its scales: commands in revolutions.
    let targets = temp.path().join("targets.csv");
    std::fs::write(&targets, "t_x,t_y,t_z,r_x,r_y,r_z\n-80,-30,330,0.05,0,0\n").unwrap();
    let out = temp.path().join("commands.csv");
    let record = temp.path().join("common.json");
    let compensate = [
        "compensate",
        "--calibration",
        s(&record),
        "--targets",
        s(&targets),
    ];
    let printed = ok(&[&compensate[..], &["--out", s(&out)]].concat());
    assert!(printed.contains("readings q1..q6 in rev"), "{printed}");
}

#[test]
fn the_default_options_through_the_common_calibration_are_the_own() {
    // The default observation is the coordinates' (eq. 10): three rows and
    // two contact angles a touch, through the interface as in the own
    // calibration.
    let temp = tempfile::tempdir().unwrap();
    let data = copy_fixture("paper-seed1", temp.path(), &PAPER_FILES);
    let (own, common) = (
        temp.path().join("own.json"),
        temp.path().join("common.json"),
    );
    ok(&["calibrate", s(&data), "--out", s(&own)]);
    let run = parcal(&["calibrate", s(&data), "--common", "--out", s(&common)]);
    assert!(run.status.success(), "{}", text(&run.stderr));
    let printed = text(&run.stdout);
    assert!(
        printed.contains("189 ball touches by their coordinates (eq. 10)"),
        "{printed}"
    );
    // The progress says what the reading took and what the conversion
    // (the hexapod calibration's start at the design) took.
    let progress = text(&run.stderr);
    assert!(
        progress.starts_with("read the dataset in ")
            && progress.contains(
                "\nmade 189 observations of it, with the hexapod calibration's start and weights, in "
            ),
        "{progress}"
    );
    let (own, common) = (read(&own), read(&common));
    assert_same_minimum(&own, &common);
    // The record names the touches' observation equation.
    assert_eq!(common["observation"], "coordinates");
    let touches = common["tests"]["observations"]
        .as_array()
        .unwrap()
        .iter()
        .find(|run| run["kind"] == "ball touch")
        .unwrap();
    let count = touches.get("count").map_or(1, |c| c.as_u64().unwrap());
    assert_eq!(
        touches["residuals"].as_array().unwrap().len() as u64,
        3 * count,
        "three rows a touch"
    );
}

#[test]
fn a_simulated_hexapods_trackers_are_judged_against_their_truth() {
    // Three sessions of tool points by a laser tracker: the report of the
    // common calibration gives each session's frame error in its sigmas
    // (its true frame from truth.json, carried to the canonical frame),
    // every one of the 18 within 5.
    let temp = tempfile::tempdir().unwrap();
    let data = temp.path().join("points");
    ok(&[
        "simulate",
        "--tracker",
        "points",
        "--seed",
        "2",
        "--out",
        s(&data),
    ]);
    let out = temp.path().join("common.json");
    ok(&[
        "calibrate",
        s(&data),
        "--common",
        "--out",
        s(&out),
        "--report",
    ]);
    let markdown = std::fs::read_to_string(temp.path().join("report.md")).unwrap();
    for label in ["1", "2", "3"] {
        let errors = tracker_errors(&markdown, label);
        assert!(errors.iter().all(|e| e.abs() < 5.0), "{label}: {errors:?}");
    }
}

#[test]
fn motion_capture_poses_go_through_the_common_calibration() {
    // Jugglebot's poses: one tracker and the body frame, each located
    // with its sigmas (the library's test compares the estimate with the
    // own path's).
    let temp = tempfile::tempdir().unwrap();
    let files = ["machine.json", "poses.csv"];
    let data = copy_fixture("jugglebot", temp.path(), &files);
    let out = temp.path().join("common.json");
    ok(&["calibrate", s(&data), "--common", "--out", s(&out)]);
    let common = read(&out);
    assert_eq!(common["trackers"].as_array().unwrap().len(), 1);
    let sigma = common["body"]["sigma"].as_array().unwrap();
    assert!(sigma.iter().all(|s| s.as_f64().unwrap() > 0.0));
    // Its report; these real data add no truth to it.
    let report = temp.path().join("report");
    ok(&["report", s(&out), "--out", s(&report)]);
    assert!(report.join("report.md").exists());
    let with_data = temp.path().join("with-data");
    let command = ["report", s(&out), "--dataset", s(&data)];
    ok(&[&command[..], &["--out", s(&with_data)]].concat());
    let markdown = std::fs::read_to_string(with_data.join("report.md")).unwrap();
    assert!(!markdown.contains("error / sigma"), "{markdown}");
    // Judged as another day's session: the frame and the body located by
    // the first 12 poses, the other 96 poses' readings predicted.
    let validation = temp.path().join("validation.json");
    let validate = ["validate", s(&data), "--calibration", s(&out)];
    ok(&[
        &validate[..],
        &["--reference", "12", "--out", s(&validation)],
    ]
    .concat());
    let record = read(&validation);
    assert_eq!(record["verdict"], "accepted");
    assert_eq!(record["kinds"][0]["rows"], 6 * 96);
    assert_eq!(record["kinds"][0]["unit"], "rev");
    // Without a prior the tool keeps its tolerance, which holds it at the
    // design: the data do not see it, and the record and the printout say
    // so. (These real data fail the global test under simulation I's
    // model, as the own path's do: the record is written as rejected.)
    let bare = temp.path().join("bare.json");
    let run = parcal(&[
        "calibrate",
        s(&data),
        "--common",
        "--sim",
        "I",
        "--out",
        s(&bare),
    ]);
    let printed = text(&run.stdout) + &text(&run.stderr);
    assert!(
        printed.contains("x_eT (in prior sigmas): the data do not see it at all"),
        "{printed}"
    );
    let record = read(&temp.path().join("bare.rejected.json"));
    let tool = record["parameters"].as_array().unwrap().iter();
    let tool: Vec<&Value> = tool.filter(|p| p["group"] == "tool").collect();
    assert_eq!(tool.len(), 3);
    for parameter in tool {
        assert_eq!(parameter["value"], parameter["prior_mean"]);
        let ratio =
            parameter["sigma"].as_f64().unwrap() / parameter["prior_sigma"].as_f64().unwrap();
        assert!((ratio - 1.0).abs() < 1e-9, "{parameter}");
    }
}

#[test]
fn a_campaign_of_poses_through_the_common_calibration_is_validated_on_another() {
    // Two Jugglebot-like campaigns (three sessions of poses each, the legs
    // re-homed between them, the scales unknown): the first calibrated
    // through the common path, the second judged by it, each of its
    // trackers placed anew with the body (12 unknowns and 6 offsets of a
    // re-homed one projected out).
    let temp = tempfile::tempdir().unwrap();
    let campaign = |seed: &str| {
        let data = temp.path().join(format!("seed{seed}"));
        let args = [
            "--tracker",
            "poses",
            "--machine",
            "jugglebot",
            "--rehome",
            "2",
        ];
        let mut all = vec!["simulate", "--seed", seed];
        all.extend(args);
        all.extend(["--out", s(&data)]);
        ok(&all);
        data
    };
    let (first, second) = (campaign("1"), campaign("2"));
    let calibration = temp.path().join("common.json");
    ok(&["calibrate", s(&first), "--common", "--out", s(&calibration)]);
    let out = temp.path().join("validation.json");
    let validation_args = ["validate", s(&second), "--calibration", s(&calibration)];
    let mut args = validation_args.to_vec();
    args.extend(["--out", s(&out)]);
    ok(&args);
    let validation = read(&out);
    let rows = validation["rows"].as_array().unwrap();
    let poses = read_poses(&second);
    assert_eq!(rows.len(), 6 * poses - 3 * 12 - 2 * 6);
    assert_eq!(rows[0]["unit"], "rev");
    assert_eq!(rows[0]["file"], "poses.csv");
    // Each session's frames (and a re-homed one's offsets) located by its
    // first 4 poses, its other poses predicted: a row of each pose's each
    // reading, named by its line (the first session's fifth pose, line 6).
    args.extend(["--reference", "4"]);
    let printed = ok(&args);
    assert!(
        printed.contains("each tracker's frame located by its first 4 points and poses"),
        "{printed}"
    );
    let validation = read(&out);
    let rows = validation["rows"].as_array().unwrap();
    assert_eq!(rows.len(), 6 * (poses - 3 * 4));
    assert_eq!(
        (&rows[0]["kind"], &rows[0]["line"]),
        (&"tracker pose".into(), &6.into())
    );
    assert_eq!(
        (&rows[0]["unit"], &rows[5]["row"]),
        (&"rev".into(), &5.into())
    );
}

/// The number of rows of a dataset's poses.csv.
fn read_poses(data: &std::path::Path) -> usize {
    std::fs::read_to_string(data.join("poses.csv"))
        .unwrap()
        .lines()
        .count()
        - 1
}
