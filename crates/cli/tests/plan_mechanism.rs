//! `parcal plan` on mechanism datasets: a delta's probe heights from its
//! prior, a cable robot's encoder samples after a calibration, each
//! written as the dataset's own file to fill in with the predicted sigmas
//! beside it; the hexapod's options refused.

use crate::common;

use std::fs;

use common::{fails, ok, s};

#[test]
fn a_delta_s_plan_is_a_probes_csv_to_fill_in() {
    let dir = tempfile::tempdir().unwrap();
    let sim = dir.path().join("sim");
    ok(&[
        "simulate",
        "--mechanism",
        "delta",
        "--seed",
        "2",
        "--out",
        s(&sim),
    ]);
    let out = dir.path().join("probes.csv");
    let summary = ok(&["plan", s(&sim), "--measurements", "10", "--out", s(&out)]);
    assert!(summary.contains("10 measurements from"), "{summary}");
    // Ten probe heights at commanded (x, y), the height left to fill in.
    let text = fs::read_to_string(&out).unwrap();
    let lines: Vec<&str> = text.lines().collect();
    assert_eq!(lines[0], "x,y,z");
    assert_eq!(lines.len(), 11);
    assert!(
        lines[1..]
            .iter()
            .all(|l| l.ends_with(',') && l.split(',').count() == 3)
    );
    // What probe heights leave to the prior: the rods, said so.
    assert!(summary.contains("determined by their prior"), "{summary}");
    assert!(summary.contains("diagonal_"), "{summary}");
    let json: serde_json::Value =
        serde_json::from_str(&fs::read_to_string(dir.path().join("probes.json")).unwrap()).unwrap();
    assert_eq!(json["start"], "prior");
    assert_eq!(json["measurements"].as_array().unwrap().len(), 10);
    let rods = json["parameters"]
        .as_array()
        .unwrap()
        .iter()
        .find(|p| p["name"] == "diagonal_a")
        .unwrap();
    assert!(rods["after"].as_f64().unwrap() < rods["before"].as_f64().unwrap());
    // A hexapod's options are refused, and a mechanism's for a hexapod.
    let err = fails(&[
        "plan",
        s(&sim),
        "--measurements",
        "3",
        "--tilt",
        "10",
        "--out",
        s(&out),
    ]);
    assert!(err.contains("apply to a hexapod's plans"), "{err}");
    let err = fails(&["plan", s(&sim), "--out", s(&out)]);
    assert!(err.contains("--measurements is needed"), "{err}");
    let err = fails(&[
        "plan",
        s(&sim),
        "--measurements",
        "3",
        "--group",
        "legs",
        "--out",
        s(&out),
    ]);
    assert!(err.contains("no parameter group \"legs\""), "{err}");
    // Part distances after the probes: a distances.csv to fill in beside,
    // each pick with the rods' RMS sigma it leaves.
    let next = dir.path().join("next.csv");
    let plan = |extra: &[&str]| {
        let mut args = vec!["plan", s(&sim), "--measurements", "10", "--distances", "2"];
        args.extend(extra);
        args.extend(["--out", s(&next)]);
        args.into_iter().map(String::from).collect::<Vec<String>>()
    };
    let run = |args: Vec<String>, succeeds: bool| {
        let args: Vec<&str> = args.iter().map(String::as_str).collect();
        if succeeds { ok(&args) } else { fails(&args) }
    };
    let err = run(plan(&[]), false);
    assert!(err.contains("noise.distance"), "{err}");
    let summary = run(plan(&["--distance-sigma", "0.02"]), true);
    assert!(summary.contains("next-distances.csv"), "{summary}");
    let distances: Vec<&str> = summary
        .lines()
        .filter(|l| l.contains("part distance at"))
        .collect();
    assert_eq!(distances.len(), 2, "{summary}");
    assert!(
        distances[0].contains("diagonal rods RMS sigma"),
        "{summary}"
    );
    let text = fs::read_to_string(dir.path().join("next-distances.csv")).unwrap();
    let lines: Vec<&str> = text.lines().collect();
    assert_eq!(lines[0], "x1,y1,z1,x2,y2,z2,distance");
    assert_eq!(lines.len(), 3);
    assert!(lines[1..].iter().all(|l| {
        let fields: Vec<&str> = l.split(',').collect();
        fields.len() == 7 && fields[6].is_empty() && fields[2] == "0.2" && fields[5] == "0.2"
    }));
    assert_eq!(fs::read_to_string(&next).unwrap().lines().count(), 11);
    let json: serde_json::Value =
        serde_json::from_str(&fs::read_to_string(dir.path().join("next.json")).unwrap()).unwrap();
    assert!(json["distances_csv_checksum"].is_string());
    assert_eq!(json["measurements"][10]["kind"], "part distance");
}

#[test]
fn a_cable_robot_s_plan_after_its_calibration_is_a_points_csv_and_repeats() {
    let dir = tempfile::tempdir().unwrap();
    let sim = dir.path().join("sim");
    ok(&[
        "simulate",
        "--mechanism",
        "cable",
        "--seed",
        "4",
        "--out",
        s(&sim),
    ]);
    // Seed 4's calibration is accepted (a plan refuses a rejected one).
    ok(&["calibrate", s(&sim)]);
    let calibration = sim.join("calibration.json");
    let plan = |name: &str, extra: &[&str]| {
        let out = dir.path().join(name);
        let mut args = vec![
            "plan",
            s(&sim),
            "--measurements",
            "5",
            "--grid",
            "8",
            "--after",
            s(&calibration),
            "--out",
            s(&out),
        ];
        args.extend_from_slice(extra);
        (common::parcal(&args), out)
    };
    let (output, out) = plan("a.csv", &[]);
    assert!(output.status.success(), "{}", common::text(&output.stderr));
    let text = fs::read_to_string(&out).unwrap();
    assert_eq!(text.lines().next().unwrap(), "q1,q2,q3,q4,x,y,z");
    assert_eq!(text.lines().skip(1).filter(|l| *l == ",,,,,,").count(), 5);
    let (_, again) = plan("b.csv", &[]);
    assert_eq!(fs::read(&out).unwrap(), fs::read(&again).unwrap());
    assert_eq!(
        fs::read(dir.path().join("a.json")).unwrap(),
        fs::read(dir.path().join("b.json")).unwrap()
    );
    // Samples whose position is measured carry their target.
    let (output, measured) = plan("m.csv", &["--measured-positions"]);
    assert!(output.status.success());
    let text = fs::read_to_string(&measured).unwrap();
    assert!(
        text.lines()
            .skip(1)
            .all(|l| l.starts_with(",,,,") && l.len() > 7),
        "{text}"
    );
}
