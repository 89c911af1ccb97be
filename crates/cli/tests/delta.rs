//! The linear delta end to end: a printer's config.g and probe log
//! imported, calibrated, exported for its firmware and read back; bad
//! files named with their line; a calibration exported in a format of
//! another mechanism refused.

use crate::common;

use std::fs;
use std::path::{Path, PathBuf};

use common::{fails, ok, parcal, s, text, tracker_errors};
use parcal::firmware::rrf::read_config;
use parcal::kinematics::delta::{DeltaParams, LinearDelta, probe_height, probe_rings};
use parcal::kinematics::mechanism::Mechanism;

/// The printer's configuration as its firmware holds it.
const CONFIG: &str = "; config.g of a kit delta\n\
M550 P\"delta\"\n\
M665 L270 R135 H300 B100\n\
M666 X0 Y0 Z0\n\
G31 P500 X0 Y0 Z0.7\n\
M208 Z0 S1\n";

/// A printer off its configuration by a few tenths.
fn truth() -> DeltaParams {
    let mut p = DeltaParams::symmetric(270.0, 135.0, 300.0);
    p.endstop = [0.25, -0.1, -0.15];
    p.angle = [0.2, -0.15, 0.0];
    p.diagonal = [270.2, 269.9, 270.1];
    p.radius = 134.7;
    p.tilt = [0.04, -0.03];
    p
}

/// Writes config.g, the noiseless probe heights of [`truth`] at 37
/// points (the centre and 3 rings of 12 out to 95 mm) and 3 part
/// distances (distances.csv) into `dir`.
fn printer(dir: &Path) {
    fs::write(dir.join("config.g"), CONFIG).unwrap();
    let configured = read_config(&dir.join("config.g")).unwrap().delta;
    let delta = LinearDelta::typical();
    let (t, c) = (truth().to_vector(), configured.to_params().to_vector());
    let mut csv = String::from("x,y,z\n");
    for [x, y] in probe_rings(95.0, 3, 12) {
        let z = probe_height(&delta, t.as_slice(), c.as_slice(), x, y).unwrap();
        csv.push_str(&format!("{x:.3},{y:.3},{z:.4}\n"));
    }
    fs::write(dir.join("probes.csv"), csv).unwrap();
    // Three diameters of a printed disc on the first layer, measured.
    let mut csv = String::from("x1,y1,z1,x2,y2,z2,distance\n");
    for angle in [0.0f64, 60.0, 120.0] {
        let (sin, cos) = angle.to_radians().sin_cos();
        let ends = [
            [90.0 * cos, 90.0 * sin, 0.2],
            [-90.0 * cos, -90.0 * sin, 0.2],
        ];
        let reached = ends.map(|end| {
            let q = delta.inverse(c.as_slice(), &end).unwrap();
            delta.forward(t.as_slice(), q.as_slice(), &end).unwrap()
        });
        let [a, b] = ends;
        let d = (&reached[0] - &reached[1]).norm();
        csv.push_str(&format!(
            "{},{},{},{},{},{},{d:.4}\n",
            a[0], a[1], a[2], b[0], b[1], b[2]
        ));
    }
    fs::write(dir.join("distances.csv"), csv).unwrap();
    assert_eq!(delta.name(), "linear delta");
}

/// `parcal import reprapfirmware` of the printer in `d` (config.g,
/// probes.csv and, `with_distances`, distances.csv) into `d/data`.
fn import_printer(d: &Path, with_distances: bool) -> PathBuf {
    let data = d.join("data");
    let (config, probes, distances) = (
        d.join("config.g"),
        d.join("probes.csv"),
        d.join("distances.csv"),
    );
    let mut args = vec![
        "import",
        "reprapfirmware",
        "--config",
        s(&config),
        "--probes",
        s(&probes),
    ];
    if with_distances {
        args.extend(["--distances", s(&distances)]);
    }
    args.extend(["--out", s(&data)]);
    ok(&args);
    data
}

#[test]
fn import_calibrate_export_reads_back_the_calibrated_parameters() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    printer(d);
    let data = import_printer(d, true);
    let summary = ok(&["calibrate", s(&data)]);
    assert!(summary.contains("accepted"), "{summary}");
    assert!(summary.contains("3 part distances"), "{summary}");
    assert!(summary.contains("diagonal_a"), "{summary}");
    let calibration = data.join("calibration.json");
    let out = d.join("new.g");
    // The printable radius is config.g's (M665 B100), which the
    // calibration carries from its dataset.
    let said = ok(&export_args(&calibration, "reprapfirmware", &out, &[]));
    assert!(said.contains("cost"), "{said}");
    assert!(said.contains("printable radius: 100 mm"), "{said}");
    let written = fs::read_to_string(&out).unwrap();
    assert!(written.contains("; parcal: cost: "), "{written}");
    let exported = read_config(&out).unwrap().delta;
    assert_eq!(exported.print_radius, 100.0);
    let back = exported.to_params();
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
    // Written to 0.001 (mm, degrees, %): read back within half a step.
    let half = 0.0005 + 1e-9;
    let pairs = [
        ("diagonal_a", back.diagonal[0]),
        ("diagonal_b", back.diagonal[1]),
        ("diagonal_c", back.diagonal[2]),
        ("radius", back.radius),
        ("homed_height", back.homed_height),
        ("angle_a", back.angle[0]),
        ("angle_b", back.angle[1]),
        ("angle_c", back.angle[2]),
        ("endstop_a", back.endstop[0]),
        ("endstop_b", back.endstop[1]),
        ("endstop_c", back.endstop[2]),
        ("tilt_x", back.tilt[0]),
        ("tilt_y", back.tilt[1]),
    ];
    for (name, read) in pairs {
        assert!(
            (value(name) - read).abs() <= half,
            "{name}: calibrated {}, read back {read}",
            value(name)
        );
    }
}

/// The printer of [`printer`] in `dir`, imported (with its part
/// distances if `with_distances`) and calibrated: its dataset, and a copy
/// of its calibration.json in `dir`, away from the dataset it names.
fn calibrated_away(dir: &Path, with_distances: bool) -> (PathBuf, PathBuf) {
    printer(dir);
    let data = import_printer(dir, with_distances);
    ok(&["calibrate", s(&data)]);
    let away = dir.join("calibration.json");
    fs::copy(data.join("calibration.json"), &away).unwrap();
    (data, away)
}

/// `parcal export` of `calibration` as `format` to `out`, with `extra`
/// arguments before `--out`.
fn export_args<'a>(
    calibration: &'a Path,
    format: &'a str,
    out: &'a Path,
    extra: &[&'a str],
) -> Vec<&'a str> {
    let mut args = vec![
        "export",
        "--calibration",
        s(calibration),
        "--format",
        format,
    ];
    args.extend(extra);
    args.extend(["--out", s(out)]);
    args
}

/// `export --format machine-json` of a delta's calibration: the
/// machine.json of its dataset (found by the calibration's provenance, or
/// --machine) with the estimates as its design and the calibrated
/// trigger height; the next calibration from it has its priors about
/// those. Without the dataset, or with a firmware's format, --machine is
/// asked for or refused by name.
#[test]
fn a_delta_exports_its_calibrated_machine_json() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let (data, calibration) = calibrated_away(d, true);
    let out = d.join("calibrated-machine.json");
    // `export` of `calibration` as `format` to `out`, with `extra`
    // arguments; its output, or its error when it is to fail.
    let run = |calibration: &Path, format: &str, out: &Path, extra: &[&str], succeeds: bool| {
        let args = export_args(calibration, format, out, extra);
        if succeeds { ok(&args) } else { fails(&args) }
    };
    let said = run(&calibration, "machine-json", &out, &[], true);
    let found = format!("machine: {}\n", s(&data.join("machine.json")));
    assert!(said.contains(&found), "{said}");
    let json = |path: &Path| -> serde_json::Value {
        serde_json::from_str(&fs::read_to_string(path).unwrap()).unwrap()
    };
    let (record, machine, given) = (
        json(&calibration),
        json(&out),
        json(&data.join("machine.json")),
    );
    for p in record["parameters"].as_array().unwrap() {
        let name = p["name"].as_str().unwrap();
        let written = match name {
            "trigger_height" => &machine["trigger_height"]["value"],
            _ => &machine["design"][name],
        };
        assert_eq!(written, &p["value"], "{name}");
    }
    assert_eq!(machine["configured"], given["configured"]);
    assert_eq!(machine["tolerances"], given["tolerances"]);
    assert_eq!(machine["noise"], given["noise"]);

    let next = d.join("next");
    fs::create_dir(&next).unwrap();
    for file in ["probes.csv", "distances.csv"] {
        fs::copy(data.join(file), next.join(file)).unwrap();
    }
    fs::copy(&out, next.join("machine.json")).unwrap();
    ok(&["calibrate", s(&next)]);
    let second = json(&next.join("calibration.json"));
    for (p, q) in (record["parameters"].as_array().unwrap().iter())
        .zip(second["parameters"].as_array().unwrap())
    {
        assert_eq!(q["prior_mean"], p["value"], "{}", p["name"]);
    }

    // A machine.json the calibration was not made from: the next one's,
    // a hexapod's.
    let hexapod =
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../../fixtures/paper-seed1/machine.json");
    for (machine, refusal) in [
        (
            next.join("machine.json"),
            "the calibration's prior mean is 0, machine.json's design",
        ),
        (
            hexapod,
            "mechanism: the calibration is a linear delta's, machine.json a hexapod's: the calibration was not made from this machine.json",
        ),
    ] {
        let err = run(
            &calibration,
            "machine-json",
            &out,
            &["--machine", s(&machine)],
            false,
        );
        assert!(err.contains(refusal), "{err}");
    }
    // Its dataset moved: none to be found by its provenance, nor beside
    // the copy; the one beside the record in the moved dataset.
    let moved = d.join("moved");
    fs::rename(&data, &moved).unwrap();
    let err = run(&calibration, "machine-json", &out, &[], false);
    let missing = format!(
        "a linear delta's calibration does not carry its machine's noise and tolerances, and none is at {} or {}: give the machine.json it was calibrated from (--machine)",
        s(&data.join("machine.json")),
        s(&d.join("machine.json"))
    );
    assert!(err.contains(&missing), "{err}");
    let beside = moved.join("calibration.json");
    let said = run(&beside, "machine-json", &out, &[], true);
    assert!(
        said.contains(&format!("machine: {}\n", s(&moved.join("machine.json")))),
        "{said}"
    );
    let err = run(
        &beside,
        "machine-json",
        &moved.join("machine.json"),
        &[],
        false,
    );
    assert!(err.contains("which this run reads"), "{err}");
    let err = run(
        &calibration,
        "reprapfirmware",
        &d.join("new.g"),
        &["--machine", s(&out)],
        false,
    );
    assert!(
        err.contains("--machine: a mechanism's machine.json is what --format machine-json starts from; --format reprapfirmware does not read one"),
        "{err}"
    );
}

#[test]
fn a_calibration_carries_its_printers_printable_radius() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // Moved away from its dataset, the calibration still knows config.g's
    // M665 B100: export writes it back, --print-radius overrides it.
    let (data, away) = calibrated_away(d, false);
    let out = d.join("new.g");
    let said = ok(&export_args(&away, "reprapfirmware", &out, &[]));
    assert!(said.contains("printable radius: 100 mm"), "{said}");
    assert_eq!(read_config(&out).unwrap().delta.print_radius, 100.0);
    ok(&export_args(
        &away,
        "reprapfirmware",
        &out,
        &["--print-radius", "90"],
    ));
    assert_eq!(read_config(&out).unwrap().delta.print_radius, 90.0);

    // Compensation keeps the nozzle within 100 mm, not the typical
    // printer's 110 mm: a target at 105 mm is refused, by its line.
    let targets = d.join("targets.csv");
    let commands = d.join("commands.csv");
    let compensate = [
        "compensate",
        "--calibration",
        s(&away),
        "--targets",
        s(&targets),
        "--out",
        s(&commands),
    ];
    fs::write(&targets, "x,y,z\n0,0,5\n0,95,5\n105,0,5\n").unwrap();
    let err = fails(&compensate);
    assert!(
        err.contains("line 4:") && err.contains("beyond the print radius 100"),
        "{err}"
    );
    assert!(!commands.exists());
    fs::write(&targets, "x,y,z\n0,0,5\n0,95,5\n").unwrap();
    ok(&compensate);
    assert_eq!(fs::read_to_string(&commands).unwrap().lines().count(), 3);

    // A dataset that states no printable radius gives a calibration that
    // needs --print-radius to be exported.
    let machine = data.join("machine.json");
    let mut stated: serde_json::Value =
        serde_json::from_str(&fs::read_to_string(&machine).unwrap()).unwrap();
    assert_eq!(stated["print_radius"], 100.0);
    stated.as_object_mut().unwrap().remove("print_radius");
    fs::write(&machine, serde_json::to_string(&stated).unwrap()).unwrap();
    ok(&["calibrate", s(&data)]);
    let unstated = data.join("calibration.json");
    let err = fails(&export_args(&unstated, "reprapfirmware", &out, &[]));
    assert!(err.contains("states no printable radius"), "{err}");
    assert!(err.contains("--print-radius"), "{err}");
    fs::remove_file(&out).unwrap();
    ok(&export_args(
        &unstated,
        "reprapfirmware",
        &out,
        &["--print-radius", "90"],
    ));
    assert_eq!(read_config(&out).unwrap().delta.print_radius, 90.0);
}

#[test]
fn a_plan_probes_within_the_printers_own_printable_radius() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    printer(d);
    // A printer whose printable disc (M665 B85) is smaller than the
    // typical 110 mm: its probes are planned on it, out to its edge.
    fs::write(d.join("config.g"), CONFIG.replace("B100", "B85")).unwrap();
    let data = import_printer(d, false);
    let next = d.join("next.csv");
    ok(&["plan", s(&data), "--measurements", "12", "--out", s(&next)]);
    let radii: Vec<f64> = (fs::read_to_string(&next).unwrap().lines().skip(1))
        .map(|line| {
            let xy: Vec<f64> = (line.split(',').take(2))
                .map(|v| v.parse().unwrap())
                .collect();
            xy[0].hypot(xy[1])
        })
        .collect();
    assert_eq!(radii.len(), 12);
    assert!(radii.iter().all(|&r| r <= 85.0 + 1e-9), "{radii:?}");
    assert!(radii.iter().any(|&r| r > 75.0), "{radii:?}");
}

#[test]
fn bad_files_are_named_with_their_line() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    printer(d);
    let mut probes = fs::read_to_string(d.join("probes.csv")).unwrap();
    probes.push_str("10,20,oops\n");
    fs::write(d.join("bad.csv"), probes).unwrap();
    let import = |config: &Path, probes: &Path| {
        fails(&[
            "import",
            "reprapfirmware",
            "--config",
            s(config),
            "--probes",
            s(probes),
            "--out",
            s(&d.join("data")),
        ])
    };
    let err = import(&d.join("config.g"), &d.join("bad.csv"));
    assert!(
        err.contains("bad.csv: line 39: z: 'oops' is not a number"),
        "{err}"
    );
    fs::write(d.join("cartesian.g"), "M550 P\"box\"\nG31 Z1\n").unwrap();
    let err = import(&d.join("cartesian.g"), &d.join("probes.csv"));
    assert!(
        err.contains("cartesian.g: no M665 line: not a linear delta's configuration"),
        "{err}"
    );
    assert!(!d.join("data").exists());
}

#[test]
fn a_format_of_another_mechanism_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    printer(d);
    let data = import_printer(d, false);
    ok(&["calibrate", s(&data)]);
    let calibration = data.join("calibration.json");
    let err = fails(&export_args(
        &calibration,
        "genhexkins",
        &d.join("hal"),
        &[],
    ));
    assert!(err.contains("linear delta"), "{err}");
    assert!(!d.join("hal").exists());
}

#[test]
fn a_hexapod_calibration_is_not_exported_for_a_printer() {
    let dir = tempfile::tempdir().unwrap();
    let data = common::copy_fixture("paper-seed1", dir.path(), &common::PAPER_FILES);
    ok(&["calibrate", s(&data)]);
    let out = dir.path().join("new.g");
    let calibration = data.join("calibration.json");
    let err = fails(&export_args(
        &calibration,
        "reprapfirmware",
        &out,
        &["--print-radius", "100"],
    ));
    assert!(
        err.contains("a hexapod calibration; --format reprapfirmware exports a linear delta's"),
        "{err}"
    );
    assert!(!out.exists());
}

#[test]
fn a_blunder_is_named_and_removed_by_snooping() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    printer(d);
    // Probe 10 (line 12) reads 0.3 mm off.
    let probes = fs::read_to_string(d.join("probes.csv")).unwrap();
    let mut lines: Vec<String> = probes.lines().map(String::from).collect();
    let fields: Vec<f64> = lines[11].split(',').map(|v| v.parse().unwrap()).collect();
    lines[11] = format!("{},{},{}", fields[0], fields[1], fields[2] + 0.3);
    fs::write(d.join("probes.csv"), lines.join("\n") + "\n").unwrap();
    let data = import_printer(d, false);
    // Without snooping the blunder fails the tests, named by its line;
    // with it, probe height 10 (0-based, line 12) is removed and the rest
    // pass.
    let err = fails(&["calibrate", s(&data)]);
    assert!(
        err.contains("rejected")
            && err.contains("probes.csv line 12 (probe height 10, row 0) fails its w-test"),
        "{err}"
    );
    let summary = ok(&["calibrate", s(&data), "--snoop"]);
    assert!(
        summary.contains("removed by data snooping: probes.csv line 12 (probe height 10, row 0)"),
        "{summary}"
    );
    assert!(summary.contains("Verdict: accepted"), "{summary}");
    // An option of the hexapod's calibration is refused by name.
    let err = fails(&["calibrate", s(&data), "--sim", "III"]);
    assert!(
        err.contains("--sim applies to a hexapod's calibration"),
        "{err}"
    );
}

/// `parcal simulate --mechanism delta` with `flags`, written into
/// `dir/name`.
fn simulated_printer(dir: &Path, name: &str, flags: &[&str]) -> PathBuf {
    let sim = dir.join(name);
    let simulate = ["simulate", "--mechanism", "delta"];
    ok(&[&simulate[..], flags, &["--out", s(&sim)]].concat());
    sim
}

/// `parcal simulate --mechanism delta --seed 3 --balls 3` and `flags`,
/// written into `dir/sim`.
fn printer_touching_balls(dir: &Path, flags: &[&str]) -> PathBuf {
    simulated_printer(
        dir,
        "sim",
        &[&["--seed", "3", "--balls", "3"], flags].concat(),
    )
}

#[test]
fn a_printers_dataset_is_inspected_and_an_unreachable_probe_named_by_its_line() {
    let dir = tempfile::tempdir().unwrap();
    let sim = printer_touching_balls(dir.path(), &["--plate", "all"]);
    let summary = ok(&["inspect", s(&sim)]);
    for line in [
        "  mechanism          linear delta: 3 actuators, 16 parameters (16 with a prior)\n",
        "  observations       25 probe heights, 21 ball touches, 3 ball distances\n",
        "  balls              3 (7 .. 7 touches a ball; 3 tied by distances)\n",
        "  trigger height     0.7 mm (prior sigma 0.05 mm)\n",
        "  truth              yes\n",
    ] {
        assert!(summary.contains(line), "{line:?} in {summary}");
    }
    // A probe point no tower's rod reaches: named by its line, by
    // inspect as by calibrate, before any step.
    let probes = fs::read_to_string(sim.join("probes.csv")).unwrap();
    let mut lines: Vec<&str> = probes.lines().collect();
    lines[4] = "900,0,0.7";
    fs::write(sim.join("probes.csv"), lines.join("\n") + "\n").unwrap();
    for command in ["inspect", "calibrate"] {
        let err = fails(&[command, s(&sim)]);
        assert!(
            err.contains("the linear delta: probes.csv line 5 (probe height 3): unreachable"),
            "{command}: {err}"
        );
    }
}

#[test]
fn a_printers_calibration_shows_its_iterations_and_takes_the_run_controls() {
    let dir = tempfile::tempdir().unwrap();
    let sim = printer_touching_balls(dir.path(), &[]);
    let calibrate = |flags: &[&str], name: &str| {
        let out = dir.path().join(name);
        let output = parcal(&[&["calibrate", s(&sim), "--out", s(&out)], flags].concat());
        let file = if output.status.success() {
            out
        } else {
            out.with_extension("rejected.json")
        };
        let record: serde_json::Value =
            serde_json::from_str(&fs::read_to_string(file).unwrap()).unwrap();
        (text(&output.stderr), record)
    };
    // Gauss-Newton: a line per iteration on stderr.
    let (progress, gauss_newton) = calibrate(&[], "gn.json");
    assert!(progress.contains("read 46 observations in "), "{progress}");
    assert!(
        progress.contains(
            "calibrating the linear delta: Gauss-Newton, squared loss, ball touches by their radius (eq. 9)\n"
        ),
        "{progress}"
    );
    let iterations = progress.matches("  iteration: cost ").count();
    assert_eq!(
        iterations as u64,
        gauss_newton["iterations"].as_u64().unwrap()
    );
    // Levenberg-Marquardt reaches the same minimum: each run stops within
    // 1e-3 of its sigmas of it (the canonical frame's zeros exactly).
    let (progress, levenberg) = calibrate(&["--lm"], "lm.json");
    assert!(progress.contains("Levenberg-Marquardt"), "{progress}");
    assert_eq!(levenberg["accepted"], true);
    let parameters = |record: &serde_json::Value| record["parameters"].as_array().unwrap().clone();
    for (a, b) in parameters(&gauss_newton).iter().zip(parameters(&levenberg)) {
        let (value, sigma) = (a["value"].as_f64().unwrap(), a["sigma"].as_f64().unwrap());
        let shift = (value - b["value"].as_f64().unwrap()).abs();
        assert!(
            shift <= 2e-3 * sigma,
            "{}: {shift} for a sigma of {sigma}",
            a["name"]
        );
    }
    // The touches by their coordinates (eq. 10), weighted σ⁻¹ I without
    // an angle prior: the angles take up the tangential rows, so the same
    // minimum as by their radius rows (eq. 9), the default.
    let (_, coordinates) = calibrate(&["--observation", "coordinates"], "eq10.json");
    for (a, b) in parameters(&gauss_newton)
        .iter()
        .zip(parameters(&coordinates))
    {
        let (value, sigma) = (a["value"].as_f64().unwrap(), a["sigma"].as_f64().unwrap());
        let shift = (value - b["value"].as_f64().unwrap()).abs();
        assert!(shift <= 2e-3 * sigma, "{}: {shift} for {sigma}", a["name"]);
    }
    let rows = |record: &serde_json::Value| record["tests"]["data_rows"].as_u64().unwrap();
    assert_eq!(rows(&coordinates), rows(&gauss_newton) + 2 * 21);
    // A spent time budget stops the first iterate: rejected, and said.
    let (_, stopped) = calibrate(&["--time-limit", "0"], "stopped.json");
    assert_eq!(stopped["status"], "TimeLimit");
    assert_eq!(stopped["accepted"], false);
    let reason = stopped["reasons"][0].as_str().unwrap();
    assert!(reason.contains("(it reached the time limit)"), "{reason}");
}

#[test]
fn a_simulated_printer_is_written_with_its_truth_and_calibrates() {
    let dir = tempfile::tempdir().unwrap();
    let sim = dir.path().join("sim");
    ok(&[
        "simulate",
        "--mechanism",
        "delta",
        "--seed",
        "5",
        "--part-distances",
        "3",
        "--out",
        s(&sim),
    ]);
    for file in ["machine.json", "probes.csv", "distances.csv", "truth.json"] {
        assert!(sim.join(file).exists(), "{file}");
    }
    let summary = ok(&["calibrate", s(&sim)]);
    assert!(summary.contains("3 part distances"), "{summary}");
    // The truth beside each estimate: a rod's length (no frame moves
    // it) as truth.json has it, and the error in the estimate's sigmas.
    assert!(summary.contains("true  error / sigma"), "{summary}");
    let read = |path: PathBuf| -> serde_json::Value {
        serde_json::from_str(&fs::read_to_string(path).unwrap()).unwrap()
    };
    let (calibration, truth) = (
        read(sim.join("calibration.json")),
        read(sim.join("truth.json")),
    );
    let rod = (calibration["parameters"].as_array().unwrap().iter())
        .find(|p| p["name"] == "diagonal_a")
        .unwrap();
    let true_rod = truth["parameters"]["diagonal_a"].as_f64().unwrap();
    let error = (rod["value"].as_f64().unwrap() - true_rod) / rod["sigma"].as_f64().unwrap();
    let line = summary
        .lines()
        .find(|l| l.starts_with("diagonal_a "))
        .unwrap();
    let cells: Vec<&str> = line.split_whitespace().collect();
    assert_eq!(
        cells[7..],
        [format!("{true_rod:.4}"), format!("{error:.2}")],
        "{line}"
    );
    // And in the report, from the dataset given.
    let markdown = reported(&sim, dir.path());
    assert!(markdown.contains("| true | error / sigma |"), "{markdown}");
    // Its own probe heights and part distances, 3-fold cross-validated:
    // every probe height and distance predicted once, each by its line.
    let said = ok(&["validate", s(&sim), "--folds", "3"]);
    assert!(said.contains("applied: 3-fold cross-validation"), "{said}");
    let record = read(sim.join("validation.json"));
    let rows = record["rows"].as_array().unwrap();
    let probes = fs::read_to_string(sim.join("probes.csv"))
        .unwrap()
        .lines()
        .count()
        - 1;
    assert_eq!(rows.len(), probes + 3);
    // A printer's ball touches: each ball held out with its touches, its
    // centre fitted to them, its rows named by balls.csv's line.
    let touched = simulated_printer(dir.path(), "touched", &["--seed", "4", "--balls", "6"]);
    let said = ok(&["validate", s(&touched), "--folds", "3"]);
    assert!(said.contains("predicted 24 ball rows"), "{said}");
    let record = read(touched.join("validation.json"));
    let lines: std::collections::BTreeSet<u64> = (record["rows"].as_array().unwrap().iter())
        .filter(|row| row["file"] == "balls.csv")
        .map(|row| row["line"].as_u64().unwrap())
        .collect();
    assert_eq!(lines, (2..8).collect(), "{record}");
    // Two trackers of 12 points, each in every fold: 4 points (12 rows) a
    // fold, its frame fitted to them (6 rows less).
    let tracked = simulated_printer(dir.path(), "tracked", &["--seed", "4", "--trackers", "2"]);
    let said = ok(&["validate", s(&tracked), "--folds", "3"]);
    assert!(said.contains("predicted 36 tracker rows"), "{said}");
    let err = fails(&[
        "simulate",
        "--mechanism",
        "scara",
        "--out",
        s(&dir.path().join("other")),
    ]);
    assert!(err.contains("unknown"), "{err}");
    let err = fails(&[
        "simulate",
        "--mechanism",
        "delta",
        "--probe-rings",
        "50",
        "--out",
        s(&dir.path().join("other")),
    ]);
    assert!(err.contains("--probe-rings"), "{err}");
}

/// `parcal report` of `sim`'s calibration.json with the dataset `sim`,
/// into `dir/report`: its report.md.
fn reported(sim: &Path, dir: &Path) -> String {
    let report = dir.join("report");
    ok(&[
        "report",
        s(&sim.join("calibration.json")),
        "--dataset",
        s(sim),
        "--out",
        s(&report),
    ]);
    fs::read_to_string(report.join("report.md")).unwrap()
}

#[test]
fn a_simulated_printers_trackers_are_judged_against_their_truth() {
    // Two trackers of 12 points: truth.json holds their frames, and the
    // report (of the calibration, and `parcal report --dataset`) gives
    // each one's error in its sigmas, every one of the 12 within 5.
    let dir = tempfile::tempdir().unwrap();
    let sim = dir.path().join("sim");
    let said = ok(&[
        "simulate",
        "--mechanism",
        "delta",
        "--seed",
        "3",
        "--trackers",
        "2",
        "--points-per-tracker",
        "12",
        "--out",
        s(&sim),
    ]);
    assert!(
        said.contains("24 points of 2 trackers") && said.contains("and the trackers' frames"),
        "{said}"
    );
    ok(&["calibrate", s(&sim), "--report"]);
    let calibrated = fs::read_to_string(sim.join("report.md")).unwrap();
    for markdown in [calibrated, reported(&sim, dir.path())] {
        assert!(
            markdown.contains("| error / sigma (rotations; translations) |"),
            "{markdown}"
        );
        for label in ["T1", "T2"] {
            let errors = tracker_errors(&markdown, label);
            assert!(errors.iter().all(|e| e.abs() < 5.0), "{label}: {errors:?}");
        }
    }
}

#[test]
fn the_report_draws_a_simulated_printers_manual_heights_over_the_bed() {
    // 25 probes and 5 heights measured by hand: one figure, a circle per
    // probe and a square per height, titled with each kind's largest
    // |e / sigma| as calibration.json holds it.
    let dir = tempfile::tempdir().unwrap();
    let sim = dir.path().join("sim");
    let simulate = ["simulate", "--mechanism", "delta", "--seed", "2"];
    ok(&[&simulate[..], &["--manual-heights", "5", "--out", s(&sim)]].concat());
    ok(&["calibrate", s(&sim)]);
    let markdown = reported(&sim, dir.path());
    let html = fs::read_to_string(dir.path().join("report/report.html")).unwrap();
    let record: serde_json::Value =
        serde_json::from_str(&fs::read_to_string(sim.join("calibration.json")).unwrap()).unwrap();
    let largest = |kind: &str| {
        (record["tests"]["observations"].as_array().unwrap().iter())
            .filter(|run| run["kind"] == kind)
            .flat_map(|run| run["residuals"].as_array().unwrap())
            .map(|e| e.as_f64().unwrap().abs())
            .fold(0.0, f64::max)
    };
    let (probes, heights) = (largest("probe height"), largest("manual height"));
    assert!(heights > 0.0, "no manual height tested");
    let title = format!(
        "e / sigma: probe heights (largest {probes:.2}), manual heights (largest {heights:.2})"
    );
    assert!(html.contains(&title), "{html}");
    // The residuals' markers in the bed's figure: filled red or open
    // blue.
    let bed = &html[html.find(">Residuals over the bed</h2>").unwrap()..];
    let bed = bed.find("<h2").map_or(bed, |end| &bed[..end]);
    let markers = |element: &str| {
        (bed.lines())
            .filter(|line| line.starts_with(element))
            .filter(|line| line.contains("#D62728") || line.contains("#1F77B4"))
            .count()
    };
    assert_eq!((markers("<circle"), markers("<rect")), (25, 5), "{html}");
    assert_eq!(markdown.matches("## Residuals over the bed").count(), 1);
    assert!(
        markdown.contains("Each probe height (circle) and each manual height (square)"),
        "{markdown}"
    );
    // The probes alone: no square, and a caption of probes only.
    let probed = dir.path().join("probed");
    ok(&[&simulate[..], &["--out", s(&probed)]].concat());
    ok(&["calibrate", s(&probed)]);
    let markdown = reported(&probed, dir.path());
    assert!(
        markdown.contains("Each probe height (circle) at its commanded XY")
            && !markdown.contains("manual height"),
        "{markdown}"
    );
}

#[test]
fn a_simulated_printer_touches_calibrated_balls() {
    let dir = tempfile::tempdir().unwrap();
    let sim = dir.path().join("sim");
    let simulate = ["simulate", "--mechanism", "delta", "--points-per-ball", "5"];
    ok(&[&simulate[..], &["--balls", "3", "--out", s(&sim)]].concat());
    for file in ["balls.csv", "touches.csv"] {
        assert!(sim.join(file).exists(), "{file}");
    }
    let summary = ok(&["calibrate", s(&sim)]);
    assert!(summary.contains("15 ball touches"), "{summary}");
    let many = dir.path().join("many");
    // touches.csv holds at most 10^6 rows, a ball takes at least 4.
    let too_many = (1_000_000 / 4 + 1).to_string();
    let err = fails(&[&simulate[..], &["--balls", &too_many, "--out", s(&many)]].concat());
    assert!(err.contains(&format!("balls {too_many}")), "{err}");
    let err = fails(&[
        "simulate",
        "--mechanism",
        "cable",
        "--balls",
        "3",
        "--out",
        s(&dir.path().join("cable")),
    ]);
    assert!(
        err.contains("--balls do not apply to a cable robot"),
        "{err}"
    );
}

#[test]
fn a_simulated_printers_balls_come_with_a_ball_plate() {
    let dir = tempfile::tempdir().unwrap();
    let (plain, plated) = (dir.path().join("plain"), dir.path().join("plated"));
    let simulate = ["simulate", "--mechanism", "delta", "--seed", "7"];
    let balls = ["--balls", "4", "--points-per-ball", "5"];
    ok(&[&simulate[..], &balls, &["--out", s(&plain)]].concat());
    let said = ok(&[
        &simulate[..],
        &balls,
        &["--plate", "all", "--plate-sigma", "2", "--out", s(&plated)],
    ]
    .concat());
    assert!(
        said.contains("20 touches of 4 balls (6 distances between them)"),
        "{said}"
    );
    // The plate draws from its own stream: every other file is the same.
    assert!(!plain.join("ball_distances.csv").exists());
    let mut files: Vec<_> = fs::read_dir(&plain)
        .unwrap()
        .map(|entry| entry.unwrap().file_name())
        .collect();
    files.sort();
    assert_eq!(
        files,
        [
            "balls.csv",
            "machine.json",
            "probes.csv",
            "touches.csv",
            "truth.json"
        ]
    );
    for file in &files {
        assert_eq!(
            fs::read(plain.join(file)).unwrap(),
            fs::read(plated.join(file)).unwrap(),
            "{file:?}"
        );
    }
    // All 6 pairs of the 4 balls, whose true centres are on a ring of
    // 0.6 of the 100 mm print radius, 90 degrees apart, at the height of
    // their radii (equal within micrometres, which change a distance by
    // far less than its sigma): each distance within 5 sigmas of 2 mm.
    let text = fs::read_to_string(plated.join("ball_distances.csv")).unwrap();
    let mut lines = text.lines();
    assert_eq!(lines.next(), Some("first,second,distance,sigma"));
    let rows: Vec<Vec<f64>> = lines
        .map(|line| line.split(',').map(|f| f.parse().unwrap()).collect())
        .collect();
    assert_eq!(rows.len(), 4 * 3 / 2);
    for row in &rows {
        let [a, b, distance, sigma] = row[..] else {
            panic!("{row:?}")
        };
        assert_eq!(sigma, 0.002);
        let apart = (b - a) * std::f64::consts::FRAC_PI_2;
        let chord = 2.0 * 60.0 * (apart / 2.0).sin();
        assert!((distance - chord).abs() < 5.0 * sigma, "{row:?}: {chord}");
    }
    // Without balls, or of a cable robot, there is nothing to measure.
    let err = fails(
        &[
            &simulate[..],
            &["--plate", "all", "--out", s(&dir.path().join("none"))],
        ]
        .concat(),
    );
    assert!(err.contains("--plate needs --balls"), "{err}");
    let err = fails(&[
        "simulate",
        "--mechanism",
        "cable",
        "--plate",
        "all",
        "--out",
        s(&dir.path().join("cable")),
    ]);
    assert!(
        err.contains("--plate do not apply to a cable robot"),
        "{err}"
    );
}

#[test]
fn klipper_import_and_export_round_trip() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    printer(d);
    fs::write(
        d.join("printer.cfg"),
        "[printer]\nkinematics: delta\ndelta_radius: 135\nprint_radius: 100\n\n\
         [stepper_a]\narm_length: 270\nposition_endstop: 300\n\n[stepper_b]\n\n[stepper_c]\n",
    )
    .unwrap();
    // The same printer's probe heights, less Klipper's z_offset (0 here).
    let data = d.join("data");
    ok(&[
        "import",
        "klipper",
        "--config",
        s(&d.join("printer.cfg")),
        "--probes",
        s(&d.join("probes.csv")),
        "--out",
        s(&data),
    ]);
    ok(&["calibrate", s(&data)]);
    let out = d.join("save_config.cfg");
    let calibration = data.join("calibration.json");
    let said = ok(&export_args(
        &calibration,
        "klipper",
        &out,
        &["--print-radius", "100"],
    ));
    // Klipper holds no bed tilt: export says so and what it costs.
    assert!(said.contains("lost: the bed tilt"), "{said}");
    let block = fs::read_to_string(&out).unwrap();
    let back = parcal::firmware::klipper::parse_printer(
        &format!("[printer]\nkinematics: delta\n{block}"),
        &out,
    )
    .unwrap()
    .delta
    .to_params();
    let record: serde_json::Value =
        serde_json::from_str(&fs::read_to_string(data.join("calibration.json")).unwrap()).unwrap();
    let value = |name: &str| {
        record["parameters"]
            .as_array()
            .unwrap()
            .iter()
            .find(|p| p["name"] == name)
            .unwrap()["value"]
            .as_f64()
            .unwrap()
    };
    // Written to 1e-6: read back within half a step (and the mean of
    // three such for the homed height).
    for (name, read) in [
        ("diagonal_a", back.diagonal[0]),
        ("radius", back.radius),
        ("angle_b", back.angle[1]),
        ("endstop_c", back.endstop[2]),
        ("homed_height", back.homed_height),
    ] {
        assert!(
            (value(name) - read).abs() < 1e-6,
            "{name}: {} vs {read}",
            value(name)
        );
    }
    // The probe's z_offset configured (a BLTouch's): the same log's
    // commanded heights are PROBE's, the trigger height's prior that
    // z_offset. Moving the carriages together moves the nozzle straight
    // up, so every parameter is the same and the trigger height moves by
    // the z_offset.
    let bltouch = d.join("bltouch.cfg");
    let text = fs::read_to_string(d.join("printer.cfg")).unwrap();
    fs::write(&bltouch, format!("{text}\n[bltouch]\nz_offset: 1.5\n")).unwrap();
    let offset = d.join("offset");
    ok(&[
        "import",
        "klipper",
        "--config",
        s(&bltouch),
        "--probes",
        s(&d.join("probes.csv")),
        "--out",
        s(&offset),
    ]);
    let machine: serde_json::Value =
        serde_json::from_str(&fs::read_to_string(offset.join("machine.json")).unwrap()).unwrap();
    assert_eq!(machine["trigger_height"]["value"], 1.5);
    ok(&["calibrate", s(&offset)]);
    let shifted: serde_json::Value =
        serde_json::from_str(&fs::read_to_string(offset.join("calibration.json")).unwrap())
            .unwrap();
    for parameter in shifted["parameters"].as_array().unwrap() {
        let name = parameter["name"].as_str().unwrap();
        let shift = if name == "trigger_height" { 1.5 } else { 0.0 };
        let sigma = parameter["sigma"].as_f64().unwrap_or(0.0);
        let moved = parameter["value"].as_f64().unwrap() - value(name) - shift;
        // The carriages' common move is exact: what differs is rounding,
        // some 1e-13 mm.
        assert!(
            moved.abs() <= 1e-9 * sigma.max(1e-3),
            "{name}: {moved:e} (sigma {sigma})"
        );
    }
}

#[test]
fn rods_cut_as_a_matched_set_are_imported_as_one() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    printer(d);
    let (config, probes) = (d.join("config.g"), d.join("probes.csv"));
    let import = |out: &Path, matched: &str| {
        vec![
            "import".to_string(),
            "reprapfirmware".to_string(),
            "--config".to_string(),
            s(&config).to_string(),
            "--probes".to_string(),
            s(&probes).to_string(),
            "--matched-rods".to_string(),
            matched.to_string(),
            "--out".to_string(),
            s(out).to_string(),
        ]
    };
    let args = import(&d.join("data"), "0.02");
    ok(&args.iter().map(String::as_str).collect::<Vec<_>>());
    let machine: serde_json::Value =
        serde_json::from_str(&fs::read_to_string(d.join("data/machine.json")).unwrap()).unwrap();
    assert_eq!(machine["matched"]["diagonal rods"], 0.02);
    let summary = ok(&["calibrate", s(&d.join("data"))]);
    // 1 - 0.02² / 0.5² between two rods of the default 0.5 mm tolerance.
    assert!(
        summary.contains(
            "The priors of 3 of the 16 parameters are correlated (diagonal_a, diagonal_b, diagonal_c); the strongest, diagonal_a and diagonal_b, by 0.9984."
        ),
        "{summary}"
    );
    let record: serde_json::Value =
        serde_json::from_str(&fs::read_to_string(d.join("data/calibration.json")).unwrap())
            .unwrap();
    let correlation = &record["prior_correlation"];
    assert_eq!(correlation.as_array().unwrap().len(), 16);
    let rho = correlation[11][12].as_f64().unwrap();
    assert!((rho - (1.0 - 0.0004 / 0.25)).abs() < 1e-12, "{rho}");
    // Looser than the rods' tolerance (0.5 mm by default): refused, named.
    let args = import(&d.join("loose"), "0.9");
    let error = fails(&args.iter().map(String::as_str).collect::<Vec<_>>());
    assert!(
        error.contains("matched_rods: 0.9 is more than diagonal_tolerance 0.5"),
        "{error}"
    );
    assert!(!d.join("loose").exists(), "nothing is left half-written");
}

/// A Klipper printer configured as [`CONFIG`]'s (radius 135, rods 270,
/// endstops at 300, 0.0125 mm a step) whose true geometry is [`truth`]'s.
const KLIPPER_SETTINGS: &str = "[printer]\nkinematics: delta\ndelta_radius: 135\nprint_radius: 100\n\n\
     [stepper_a]\nrotation_distance: 40\nmicrosteps: 16\narm_length: 270\nposition_endstop: 300\n\n\
     [stepper_b]\nrotation_distance: 40\nmicrosteps: 16\n\n\
     [stepper_c]\nrotation_distance: 40\nmicrosteps: 16\n";

/// The `[delta_calibrate]` block Klipper saves for the printer [`truth`]
/// run with [`KLIPPER_SETTINGS`], written entry by entry: readings as
/// Klipper saves them (steps down from the endstops, to 0.001 step).
struct SavedBlock {
    delta: LinearDelta,
    truth: nalgebra::DVector<f64>,
    configured: nalgebra::DVector<f64>,
    text: String,
}

impl SavedBlock {
    /// The steppers' step distance in [`KLIPPER_SETTINGS`] (mm).
    const STEP: f64 = 0.0125;

    fn new() -> Self {
        Self {
            delta: LinearDelta::typical(),
            truth: truth().to_vector(),
            configured: DeltaParams::symmetric(270.0, 135.0, 300.0).to_vector(),
            text: String::from(
                "#*# <---------------------- SAVE_CONFIG ---------------------->\n\
                 #*# DO NOT EDIT THIS BLOCK OR BELOW. The contents are auto-generated.\n#*#\n\
                 #*# [delta_calibrate]\n",
            ),
        }
    }

    /// The stable position of readings `q`, as Klipper saves it.
    fn stable(q: &[f64]) -> String {
        let steps: Vec<String> = (q.iter())
            .map(|q| format!("{:.3}", -q / Self::STEP))
            .collect();
        steps.join(",")
    }

    /// The commanded position at readings `q`.
    fn commanded(&self, q: &[f64]) -> nalgebra::DVector<f64> {
        (self.delta)
            .forward(self.configured.as_slice(), q, &[0.0; 3])
            .unwrap()
    }

    /// DELTA_CALIBRATE's probe `i` at `(x, y)`, triggered with the true
    /// nozzle `trigger` above the bed and saved with the probe's
    /// `z_offset`; the commanded position at the trigger.
    fn probe(&mut self, i: usize, [x, y]: [f64; 2], trigger: f64, z_offset: f64) -> [f64; 3] {
        let q = (self.delta)
            .inverse(self.truth.as_slice(), &[x, y, trigger])
            .unwrap();
        self.text.push_str(&format!(
            "#*# height{i} = {z_offset}\n#*# height{i}_pos = {}\n",
            Self::stable(q.as_slice())
        ));
        let p = self.commanded(q.as_slice());
        [p[0], p[1], p[2]]
    }

    /// DELTA_ANALYZE MANUAL_HEIGHT's height `i`, measured exactly with
    /// the nozzle sent to `commanded`; the height.
    fn manual_height(&mut self, i: usize, commanded: [f64; 3]) -> f64 {
        let q = (self.delta)
            .inverse(self.configured.as_slice(), &commanded)
            .unwrap();
        let reached = (self.delta)
            .forward(self.truth.as_slice(), q.as_slice(), &[0.0; 3])
            .unwrap();
        self.text.push_str(&format!(
            "#*# manual_height{i} = {:.4}\n#*# manual_height{i}_pos = {}\n",
            reached[2],
            Self::stable(q.as_slice())
        ));
        reached[2]
    }
}

#[test]
fn klippers_manual_heights_find_a_probe_triggering_off_its_z_offset() {
    // The probe triggers with the nozzle 0.9 mm above the bed while
    // printer.cfg says 0.7: probe heights alone cannot tell that from the
    // printer's height, and the prior about 0.7 holds the trigger height
    // there. Three heights measured by hand (a gauge block, 10 µm) can.
    const Z_OFFSET: f64 = 0.7;
    const TRIGGER: f64 = 0.9;
    const GAUGE: f64 = 0.01;
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let mut block = SavedBlock::new();
    for (i, xy) in probe_rings(95.0, 3, 12).into_iter().enumerate() {
        block.probe(i, xy, TRIGGER, Z_OFFSET);
    }
    let probes_only = format!("{KLIPPER_SETTINGS}\n{}", block.text);
    for (i, commanded) in [[0.0, 0.0, 5.0], [60.0, -30.0, 5.0], [-40.0, 70.0, 5.0]]
        .into_iter()
        .enumerate()
    {
        let height = block.manual_height(i, commanded);
        assert!((height - 5.0).abs() < 1.0, "{height}");
    }
    let trigger_height = |text: &str, name: &str| -> (f64, f64, String) {
        let config = d.join(format!("{name}.cfg"));
        fs::write(&config, text).unwrap();
        let data = d.join(name);
        let said = ok(&[
            "import",
            "klipper",
            "--config",
            s(&config),
            "--height-sigma",
            &GAUGE.to_string(),
            "--out",
            s(&data),
        ]);
        ok(&["calibrate", s(&data)]);
        let record: serde_json::Value =
            serde_json::from_str(&fs::read_to_string(data.join("calibration.json")).unwrap())
                .unwrap();
        let trigger = (record["parameters"].as_array().unwrap().iter())
            .find(|p| p["name"] == "trigger_height")
            .unwrap()
            .clone();
        let number = |key: &str| trigger[key].as_f64().unwrap();
        (number("value"), number("sigma"), said)
    };
    let (alone, alone_sigma, said) = trigger_height(&probes_only, "probes");
    assert!(!said.contains("measured by hand"), "{said}");
    // Held at its prior: within a sigma of 0.7, four of them from 0.9.
    assert!(
        (alone - Z_OFFSET).abs() < alone_sigma,
        "{alone} ± {alone_sigma}"
    );
    let (found, sigma, said) =
        trigger_height(&format!("{KLIPPER_SETTINGS}\n{}", block.text), "manual");
    assert!(
        said.contains("3 heights measured by hand (saved in"),
        "{said}"
    );
    // Noiseless heights: the estimate is the truth but for the prior's
    // pull, a few thousandths of the 0.2 mm; its sigma about the gauge's
    // over the three.
    eprintln!(
        "trigger height: probes alone {alone:.4} ± {alone_sigma:.4}, with manual heights {found:.4} ± {sigma:.4} (true {TRIGGER})"
    );
    assert!(sigma < 0.5 * alone_sigma, "{sigma} against {alone_sigma}");
    assert!((found - TRIGGER).abs() < 4.0 * sigma, "{found} ± {sigma}");
    // Exported into the printer.cfg: the z_offset the manual heights found,
    // as PROBE_CALIBRATE saves it; from the probes alone it is left as
    // configured, and the file says why.
    let exported = |name: &str| {
        let out = d.join(format!("{name}-new.cfg"));
        let (calibration, config) = (
            d.join(name).join("calibration.json"),
            d.join(format!("{name}.cfg")),
        );
        ok(&export_args(
            &calibration,
            "klipper",
            &out,
            &["--config", s(&config)],
        ));
        fs::read_to_string(out).unwrap()
    };
    let text = exported("manual");
    assert!(
        text.contains(&format!("#*# [probe]\n#*# z_offset = {found:.3}\n")),
        "{text}"
    );
    let text = exported("probes");
    assert!(!text.contains("z_offset = "), "{text}");
    assert!(
        text.contains("# parcal: kept: the probe's trigger height as configured"),
        "{text}"
    );
    // The same heights held out, the second measured 1 mm high: named by
    // its line.
    let held = d.join("held");
    fs::create_dir(&held).unwrap();
    fs::copy(d.join("manual/machine.json"), held.join("machine.json")).unwrap();
    let heights = fs::read_to_string(d.join("manual/heights.csv")).unwrap();
    let mut rows: Vec<String> = heights.lines().map(str::to_string).collect();
    let mut fields: Vec<f64> = (rows[2].split(',')).map(|v| v.parse().unwrap()).collect();
    fields[3] += 1.0;
    rows[2] = (fields.iter().map(f64::to_string))
        .collect::<Vec<_>>()
        .join(",");
    fs::write(held.join("heights.csv"), rows.join("\n") + "\n").unwrap();
    let calibration = d.join("manual/calibration.json");
    let error = fails(&["validate", s(&held), "--calibration", s(&calibration)]);
    assert!(
        error.contains("heights.csv line 3 (manual height 1, row 0)"),
        "{error}"
    );
}

#[test]
fn klippers_saved_probes_and_distances_are_those_of_a_probe_log() {
    const Z_OFFSET: f64 = 0.7;
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let mut block = SavedBlock::new();
    // DELTA_CALIBRATE: the probe triggers with the true nozzle Z_OFFSET
    // above the bed.
    let mut probes = String::from("x,y,z\n");
    for (i, xy) in probe_rings(95.0, 3, 12).into_iter().enumerate() {
        let p = block.probe(i, xy, Z_OFFSET, Z_OFFSET);
        probes.push_str(&format!("{},{},{}\n", p[0], p[1], p[2] - Z_OFFSET));
    }
    // DELTA_ANALYZE: three diameters of a printed disc at 0.2 mm.
    let mut distances = String::from("x1,y1,z1,x2,y2,z2,distance\n");
    for (i, angle) in [0.0f64, 60.0, 120.0].into_iter().enumerate() {
        let (sin, cos) = angle.to_radians().sin_cos();
        let ends = [
            [90.0 * cos, 90.0 * sin, 0.2],
            [-90.0 * cos, -90.0 * sin, 0.2],
        ]
        .map(|end| {
            (block.delta)
                .inverse(block.configured.as_slice(), &end)
                .unwrap()
        });
        let printed = ends.clone().map(|q| {
            (block.delta)
                .forward(block.truth.as_slice(), q.as_slice(), &[0.0; 3])
                .unwrap()
        });
        let distance = (&printed[0] - &printed[1]).norm();
        block.text.push_str(&format!(
            "#*# distance{i} = {distance:.4}\n#*# distance{i}_pos1 = {}\n#*# distance{i}_pos2 = {}\n",
            SavedBlock::stable(ends[0].as_slice()),
            SavedBlock::stable(ends[1].as_slice())
        ));
        let [a, b] = ends.map(|q| block.commanded(q.as_slice()));
        distances.push_str(&format!(
            "{},{},{},{},{},{},{distance:.4}\n",
            a[0], a[1], a[2], b[0], b[1], b[2]
        ));
    }
    fs::write(
        d.join("printer.cfg"),
        format!("{KLIPPER_SETTINGS}\n{}", block.text),
    )
    .unwrap();
    fs::write(d.join("probes.csv"), probes).unwrap();
    fs::write(d.join("distances.csv"), distances).unwrap();
    let config = d.join("printer.cfg");
    let said = ok(&[
        "import",
        "klipper",
        "--config",
        s(&config),
        "--out",
        s(&d.join("saved")),
    ]);
    assert!(
        said.contains("37 probe heights (saved in") && said.contains("3 part distances (saved in"),
        "{said}"
    );
    ok(&[
        "import",
        "klipper",
        "--config",
        s(&config),
        "--probes",
        s(&d.join("probes.csv")),
        "--distances",
        s(&d.join("distances.csv")),
        "--out",
        s(&d.join("logged")),
    ]);
    let parameters = |data: &str| -> Vec<(String, f64, f64)> {
        let path = d.join(data);
        let summary = ok(&["calibrate", s(&path)]);
        assert!(summary.contains("accepted"), "{summary}");
        let record: serde_json::Value =
            serde_json::from_str(&fs::read_to_string(path.join("calibration.json")).unwrap())
                .unwrap();
        (record["parameters"].as_array().unwrap().iter())
            .map(|p| {
                let number = |key: &str| p[key].as_f64().unwrap_or(0.0);
                (
                    p["name"].as_str().unwrap().to_string(),
                    number("value"),
                    number("sigma"),
                )
            })
            .collect()
    };
    // The saved probes' commanded heights are the log's plus the z_offset,
    // and so is their trigger height; the parameters are the same but for
    // the saved steps' rounding: half a step, 6e-6 mm, is 6e-4 of the
    // probes' 10 µm sigma, and moves an estimate by about that fraction of
    // its sigma (a gauge-fixed parameter, of sigma 0, is 0 in both).
    let (saved, logged) = (parameters("saved"), parameters("logged"));
    assert_eq!(saved.len(), logged.len());
    for ((name, value, sigma), (_, logged, _)) in saved.iter().zip(&logged) {
        let shift = if name == "trigger_height" {
            Z_OFFSET
        } else {
            0.0
        };
        assert!(
            (value - logged - shift).abs() <= 0.002 * sigma,
            "{name}: {value} from the saved probes, {logged} from the log (sigma {sigma})"
        );
    }
    // Exported into the printer's printer.cfg: its main part and what
    // DELTA_CALIBRATE saved kept, the calibrated settings in its block.
    let new = d.join("new.cfg");
    let saved_record = d.join("saved/calibration.json");
    let with_config = ["--config", s(&config)];
    let said = ok(&export_args(&saved_record, "klipper", &new, &with_config));
    assert!(
        said.contains("lost: the bed tilt") && said.contains("cost: "),
        "{said}"
    );
    let written = fs::read_to_string(&new).unwrap();
    let main = format!("{KLIPPER_SETTINGS}\n");
    assert!(
        written.starts_with(&format!("{main}# parcal: the calibrated")),
        "{written}"
    );
    let kept = &block.text[block.text.find("#*# [delta_calibrate]").unwrap()..];
    assert!(written.contains(kept), "{written}");
    let back = parcal::firmware::klipper::parse_printer(&written, &new).unwrap();
    assert_eq!(back.saved.probes.len(), 37);
    assert_eq!(back.saved.distances.len(), 3);
    // Written to 1e-6, the endstop corrections as differences of two such.
    let endstops = back.delta.to_params().endstop;
    for ((name, value, _), read) in saved.iter().zip(endstops) {
        assert!((value - read).abs() < 2e-6, "{name}: {value} vs {read}");
    }
    let error = fails(&export_args(
        &saved_record,
        "reprapfirmware",
        &d.join("x.g"),
        &with_config,
    ));
    assert!(
        error.contains("--config: reprapfirmware's lines are written alone"),
        "{error}"
    );
    let error = fails(&export_args(
        &saved_record,
        "klipper",
        &config,
        &with_config,
    ));
    assert!(error.contains("which this run reads"), "{error}");
    // Nothing saved and no log: refused, saying what to give.
    fs::write(&config, KLIPPER_SETTINGS).unwrap();
    let error = fails(&[
        "import",
        "klipper",
        "--config",
        s(&config),
        "--out",
        s(&d.join("none")),
    ]);
    assert!(
        error.contains(
            "printer.cfg: no probe log given, and no probes saved (run DELTA_CALIBRATE and SAVE_CONFIG): give --probes (header x,y,z)"
        ),
        "{error}"
    );
}
