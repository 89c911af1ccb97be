//! `parcal plan` on mechanism datasets: a delta's probe heights from its
//! prior, its heights measured by hand after a calibration, a cable
//! robot's encoder samples after a calibration, each
//! written as the dataset's own file to fill in with the predicted sigmas
//! beside it; the hexapod's options refused.

use crate::common;

use std::fs;

use common::{fails, ok, s, simulated};

#[test]
fn a_delta_s_plan_is_a_probes_csv_to_fill_in() {
    let dir = tempfile::tempdir().unwrap();
    let sim = simulated(dir.path(), "delta", 2);
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
fn a_delta_s_heights_by_hand_are_planned_into_a_heights_csv() {
    let dir = tempfile::tempdir().unwrap();
    let sim = simulated(dir.path(), "delta", 2);
    ok(&["calibrate", s(&sim)]);
    let calibration = sim.join("calibration.json");
    let out = dir.path().join("heights.csv");
    let run = |extra: &[&str], succeeds: bool| {
        let mut args = vec!["plan", s(&sim), "--out", s(&out)];
        args.extend(extra);
        if succeeds { ok(&args) } else { fails(&args) }
    };
    let after = ["--after", s(&calibration), "--heights", "3"];
    // The simulated printer has no heights yet: their sigma is asked for.
    let err = run(&after, false);
    assert!(err.contains("noise.height"), "{err}");
    let trigger = [
        &after[..],
        &["--height-sigma", "0.02", "--group", "trigger height"],
    ]
    .concat();
    let summary = run(&trigger, true);
    assert!(summary.contains("3 measurements from"), "{summary}");
    // Three commanded positions on the gauge block, the height to fill in.
    let text = fs::read_to_string(&out).unwrap();
    let lines: Vec<&str> = text.lines().collect();
    assert_eq!(lines[0], "x,y,z,height");
    assert_eq!(lines.len(), 4);
    assert!(lines[1..].iter().all(|l| {
        let fields: Vec<&str> = l.split(',').collect();
        fields.len() == 4 && fields[2] == "5" && fields[3].is_empty()
    }));
    let json: serde_json::Value =
        serde_json::from_str(&fs::read_to_string(dir.path().join("heights.json")).unwrap())
            .unwrap();
    assert_eq!(json["start"], "calibration");
    assert_eq!(json["group"], "trigger height");
    // Heights alone after a calibration minimise the trigger height's
    // variance unless asked another group: the same plan.
    let asked = fs::read_to_string(&out).unwrap();
    run(&[&after[..], &["--height-sigma", "0.02"]].concat(), true);
    assert_eq!(fs::read_to_string(&out).unwrap(), asked);
    assert_eq!(json["measurements"][0]["kind"], "manual height");
    let sigmas = json["parameters"]
        .as_array()
        .unwrap()
        .iter()
        .find(|p| p["name"] == "trigger_height")
        .unwrap();
    // Three heights of 20 um where the probes left the prior's 50 um.
    assert!(sigmas["after"].as_f64().unwrap() < 0.5 * sigmas["before"].as_f64().unwrap());
    // Another gauge; one out of bounds is refused with its bound.
    let gauge = [&trigger[..], &["--gauge", "10"]].concat();
    run(&gauge, true);
    let text = fs::read_to_string(&out).unwrap();
    assert!(
        text.lines()
            .skip(1)
            .all(|l| l.split(',').nth(2) == Some("10")),
        "{text}"
    );
    for (gauge, shown) in [("500", "500"), ("-1", "-1")] {
        let err = run(&[&trigger[..], &["--gauge", gauge]].concat(), false);
        assert!(
            err.contains(&format!("--gauge must be in (0, 100] mm, got {shown}")),
            "{err}"
        );
    }
    // Every stage at once, from the prior: the probes in the file itself,
    // the heights and the part distances beside it, in that order.
    let next = dir.path().join("next.csv");
    let summary = ok(&[
        "plan",
        s(&sim),
        "--measurements",
        "10",
        "--heights",
        "2",
        "--distances",
        "1",
        "--height-sigma",
        "0.02",
        "--distance-sigma",
        "0.02",
        "--out",
        s(&next),
    ]);
    assert!(
        summary.contains("next.csv, ")
            && summary.contains("next-heights.csv, ")
            && summary.contains("next-distances.csv and"),
        "{summary}"
    );
    let json: serde_json::Value =
        serde_json::from_str(&fs::read_to_string(dir.path().join("next.json")).unwrap()).unwrap();
    let kinds: Vec<&str> = (json["measurements"].as_array().unwrap().iter())
        .map(|m| m["kind"].as_str().unwrap())
        .collect();
    let expected = [
        vec!["probe height"; 10],
        vec!["manual height"; 2],
        vec!["part distance"],
    ]
    .concat();
    assert_eq!(kinds, expected);
    assert!(json["heights_csv_checksum"].is_string() && json["distances_csv_checksum"].is_string());
    let heights = fs::read_to_string(dir.path().join("next-heights.csv")).unwrap();
    assert_eq!(heights.lines().count(), 3);
    // A hexapod has no heights to plan.
    let paper = dir.path().join("paper");
    ok(&[
        "simulate",
        "--seed",
        "1",
        "--balls",
        "3",
        "--out",
        s(&paper),
    ]);
    let err = fails(&["plan", s(&paper), "--heights", "2", "--out", s(&out)]);
    assert!(err.contains("--heights"), "{err}");
}

#[test]
fn a_cable_robot_s_plan_after_its_calibration_is_a_points_csv_and_repeats() {
    let dir = tempfile::tempdir().unwrap();
    let sim = simulated(dir.path(), "cable", 4);
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
