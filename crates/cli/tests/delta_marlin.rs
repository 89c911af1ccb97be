//! Marlin's linear delta end to end: what `M503` reported and the heights
//! `G30` reported imported, calibrated to the printer's truth within the
//! sigmas the calibration states, exported as Marlin's lines and read
//! back; bad files named with their line.

use crate::common;

use std::fs;
use std::path::{Path, PathBuf};

use common::{fails, ok, parcal, s};
use parcal::firmware::marlin::read_config;
use parcal::kinematics::delta::{DeltaParams, LinearDelta, probe_rings};
use parcal::kinematics::mechanism::Mechanism;

/// The printer's settings as `M503` reports them: a probe 5 mm right of
/// and 18 mm in front of the nozzle, triggering with the nozzle 0.75 mm
/// above the bed.
const M503: &str = "\
echo:; Endstop adjustment:
echo:  M666 X0.00 Y0.00 Z0.00
echo:; Delta (L<diagonal rod> R<radius> H<height> S<segments per second> XYZ<tower angle trim> ABC<rod trim>):
echo:  M665 L218.00 R97.50 H300.00 S200.00 X0.00 Y0.00 Z0.00 A0.00 B0.00 C0.00
echo:; Z-Probe Offset:
echo:  M851 X5.00 Y-18.00 Z-0.75 ; (mm)
ok
";
const PROBE_XY: [f64; 2] = [5.0, -18.0];
const TRIGGER: f64 = 0.75;

/// A printer off its settings by a few tenths, its bed tilted.
fn truth() -> DeltaParams {
    let mut p = DeltaParams::symmetric(218.0, 97.5, 300.0 + TRIGGER);
    p.endstop = [0.25, -0.1, -0.15];
    p.angle = [0.2, -0.15, 0.0];
    p.diagonal = [218.2, 217.9, 218.1];
    p.radius = 97.2;
    p.tilt = [0.04, -0.03];
    p
}

/// The firmware's `z` (parameters `firmware`) when the nozzle, sent to
/// `(x, y)`, is `trigger` above the bed of the machine `truth`: where the
/// probe triggers (Newton's method, as `probe_height`).
fn triggered(truth: &[f64], firmware: &[f64], [x, y]: [f64; 2], trigger: f64) -> f64 {
    let delta = LinearDelta::typical();
    let mut z = trigger;
    for _ in 0..50 {
        let q = delta.inverse(firmware, &[x, y, z]).unwrap();
        let above = delta.forward(truth, q.as_slice(), &[x, y, z]).unwrap()[2] - trigger;
        z -= above;
        if above.abs() < 1e-12 {
            break;
        }
    }
    z
}

/// Writes m503.txt and probes.csv into `dir`: `G30` at 37 probe positions
/// (the centre and 3 rings of 12 out to 75 mm, as `Bed X: Y:` prints them,
/// to 0.01), the nozzle there less the probe's offsets, the height
/// reported the nozzle's at the trigger plus `M851 Z`, to 0.001.
fn printer(dir: &Path) {
    fs::write(dir.join("m503.txt"), M503).unwrap();
    let firmware = read_config(&dir.join("m503.txt")).unwrap().to_params();
    let (t, f) = (truth().to_vector(), firmware.to_vector());
    let mut csv = String::from("x,y,z\n");
    for [x, y] in probe_rings(75.0, 3, 12) {
        let probe = [(x * 100.0).round() / 100.0, (y * 100.0).round() / 100.0];
        let nozzle = [probe[0] - PROBE_XY[0], probe[1] - PROBE_XY[1]];
        let z = triggered(t.as_slice(), f.as_slice(), nozzle, TRIGGER) - TRIGGER;
        csv.push_str(&format!("{:.2},{:.2},{z:.3}\n", probe[0], probe[1]));
    }
    fs::write(dir.join("probes.csv"), csv).unwrap();
}

/// `parcal import marlin` of the printer in `d` into `d/data`.
fn import_printer(d: &Path) -> (PathBuf, String) {
    let data = d.join("data");
    let said = ok(&[
        "import",
        "marlin",
        "--config",
        s(&d.join("m503.txt")),
        "--probes",
        s(&d.join("probes.csv")),
        "--print-radius",
        "85",
        "--out",
        s(&data),
    ]);
    (data, said)
}

/// The calibration's parameters: name, value and sigma.
fn parameters(calibration: &Path) -> Vec<(String, f64, Option<f64>)> {
    let record: serde_json::Value =
        serde_json::from_str(&fs::read_to_string(calibration).unwrap()).unwrap();
    (record["parameters"].as_array().unwrap().iter())
        .map(|p| {
            (
                p["name"].as_str().unwrap().to_string(),
                p["value"].as_f64().unwrap(),
                p["sigma"].as_f64(),
            )
        })
        .collect()
}

/// The truth in the calibration's frame (the canonical one): each
/// estimate of `calibration` within 3 of its sigmas of `truth`'s (the
/// gauge's zeros have none), the trigger height of [`TRIGGER`]; the
/// largest error over its sigma, by name.
fn within_three_sigmas(calibration: &Path, truth: &DeltaParams) -> (String, f64) {
    let delta = LinearDelta::typical();
    let canonical = delta.canonicalize(truth.to_vector().as_slice()).unwrap();
    let names: Vec<String> = delta.parameters().iter().map(|p| p.name.clone()).collect();
    let mut largest = (String::new(), 0.0f64);
    for (name, value, sigma) in parameters(calibration) {
        let Some(sigma) = sigma.filter(|s| *s > 0.0) else {
            continue;
        };
        let true_value = match names.iter().position(|n| *n == name) {
            Some(k) => canonical[k],
            None if name == "trigger_height" => TRIGGER,
            None => continue,
        };
        let error = (value - true_value) / sigma;
        assert!(
            error.abs() < 3.0,
            "{name}: {value} ± {sigma} for {true_value}"
        );
        if error.abs() > largest.1.abs() {
            largest = (name, error);
        }
    }
    largest
}

/// `parcal export`'s arguments writing `calibration` as Marlin's lines to
/// `out`.
fn export_marlin<'a>(calibration: &'a Path, out: &'a Path) -> [&'a str; 7] {
    [
        "export",
        "--calibration",
        s(calibration),
        "--format",
        "marlin",
        "--out",
        s(out),
    ]
}

#[test]
fn marlin_import_calibrates_to_the_truth_and_exports_lines_marlin_reads() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    printer(d);
    let (data, said) = import_printer(d);
    assert!(said.contains("Marlin's configuration"), "{said}");
    assert!(said.contains("37 probe heights"), "{said}");
    // Each probe at the nozzle's commanded position: G30's less M851 X Y.
    let probes = fs::read_to_string(data.join("probes.csv")).unwrap();
    let first: Vec<f64> = (probes.lines().nth(1).unwrap().split(','))
        .map(|v| v.parse().unwrap())
        .collect();
    assert_eq!(first[..2], [-PROBE_XY[0], -PROBE_XY[1]], "{probes}");
    let summary = ok(&["calibrate", s(&data)]);
    assert!(summary.contains("accepted"), "{summary}");
    let calibration = data.join("calibration.json");
    let largest = within_three_sigmas(&calibration, &truth());
    eprintln!("largest error: {} {:.2} sigma", largest.0, largest.1);

    let out = d.join("new.gcode");
    let said = ok(&export_marlin(&calibration, &out));
    assert!(said.contains("printable radius: 85 mm"), "{said}");
    assert!(said.contains("lost: the bed tilt"), "{said}");
    assert!(
        said.contains("kept: the probe's trigger height as configured (M851 Z)"),
        "{said}"
    );
    let written = fs::read_to_string(&out).unwrap();
    assert!(written.starts_with("; parcal: the calibrated linear delta for Marlin\n"));
    assert!(
        written.ends_with("M500\n") && !written.contains("\nM851"),
        "{written}"
    );
    // Read back with the configured probe: the calibrated machine, written
    // to 0.001, within half a step (the rod three of them: L and a trim).
    let back = read_config(&out).unwrap();
    assert_eq!(back.probe_offset, None);
    let configured = format!("{}{written}", "M851 Z-0.75\n");
    fs::write(&out, configured).unwrap();
    let back = read_config(&out).unwrap().to_params();
    let value = |name: &str| {
        (parameters(&calibration).into_iter())
            .find(|(n, _, _)| n == name)
            .unwrap()
            .1
    };
    let half = 0.0005 + 1e-9;
    let pairs = [
        ("diagonal_a", back.diagonal[0], 2.0 * half),
        ("diagonal_b", back.diagonal[1], 2.0 * half),
        ("diagonal_c", back.diagonal[2], 2.0 * half),
        ("radius", back.radius, half),
        ("angle_a", back.angle[0], half),
        ("angle_b", back.angle[1], half),
        ("angle_c", back.angle[2], half),
    ];
    for (name, read, step) in pairs {
        assert!(
            (value(name) - read).abs() <= step,
            "{name}: calibrated {}, read back {read}",
            value(name)
        );
    }
    // Each carriage's endstop height H + e_i: M665 H and M666 each to 0.001.
    for (i, tower) in ["a", "b", "c"].into_iter().enumerate() {
        let calibrated = value("homed_height") + value(&format!("endstop_{tower}"));
        let read = back.homed_height + back.endstop[i];
        assert!(
            (calibrated - read).abs() <= 2.0 * half,
            "{tower}: {calibrated} against {read}"
        );
    }
}

#[test]
fn bad_marlin_files_are_named_with_their_line() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    printer(d);
    let import = |config: &Path, radius: &str| {
        fails(&[
            "import",
            "marlin",
            "--config",
            s(config),
            "--probes",
            s(&d.join("probes.csv")),
            &format!("--print-radius={radius}"),
            "--out",
            s(&d.join("data")),
        ])
    };
    fs::write(
        d.join("bad.txt"),
        M503.replace("M666 X0.00 Y0.00 Z0.00", "M666 X0.00 Y0.30 Z0.00"),
    )
    .unwrap();
    let err = import(&d.join("bad.txt"), "85");
    assert!(
        err.contains("bad.txt: line 2: M666 parameter Y: 0.3 is positive; Marlin refuses it"),
        "{err}"
    );
    fs::write(d.join("short.txt"), M503.replace(" H300.00", "")).unwrap();
    let err = import(&d.join("short.txt"), "85");
    assert!(
        err.contains("short.txt: line 4: no M665 H (delta height) given"),
        "{err}"
    );
    for (radius, shown) in [("-5", "-5"), ("1e300", "1e300"), ("nan", "NaN")] {
        let err = import(&d.join("m503.txt"), radius);
        assert!(
            err.contains(&format!(
                "--print-radius: {shown} is not a positive number of mm up to 1e6 (1 km)"
            )),
            "{err}"
        );
    }
    assert!(!d.join("data").exists());
    let err = fails(&[
        "import",
        "marlin",
        "--config",
        s(&d.join("m503.txt")),
        "--probes",
        s(&d.join("probes.csv")),
        "--out",
        s(&d.join("data")),
    ]);
    assert!(err.contains("--print-radius"), "{err}");
    assert!(!d.join("data").exists());
}

/// Simulated printers (`parcal simulate --mechanism delta`, each its truth
/// a draw of the prior) probed as Marlin probes: their M503 (the simulated
/// configuration, the probe 5 mm right of and 18 mm in front of the nozzle
/// at the configured 0.7 mm) and G30's log (each probe at the nozzle's
/// position plus the offsets, the height less the trigger height). Imported,
/// each gives the simulated probe heights back; calibrated, the errors
/// against the truth (in the calibration's canonical frame) over their
/// sigmas have a mean square within 4 standard errors of 1, and none is
/// beyond 4.5.
#[test]
fn simulated_printers_probed_by_marlin_calibrate_to_their_truth() {
    const DRAWS: u64 = 40;
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let m503 = d.join("m503.txt");
    fs::write(
        &m503,
        "echo:  M665 L270.00 R135.00 H299.30 S200.00 X0.00 Y0.00 Z0.00 A0.00 B0.00 C0.00\n\
         echo:  M666 X0.00 Y0.00 Z0.00\n\
         echo:  M851 X5.00 Y-18.00 Z-0.70 ; (mm)\n",
    )
    .unwrap();
    let rows = |path: &Path| -> Vec<Vec<f64>> {
        (fs::read_to_string(path).unwrap().lines().skip(1))
            .map(|l| l.split(',').map(|v| v.parse().unwrap()).collect())
            .collect()
    };
    let delta = LinearDelta::typical();
    let names: Vec<String> = delta.parameters().iter().map(|p| p.name.clone()).collect();
    let (mut draw_means, mut largest) = (Vec::new(), 0.0f64);
    for seed in 1..=DRAWS {
        let sim = d.join(format!("sim{seed}"));
        ok(&[
            "simulate",
            "--mechanism",
            "delta",
            "--seed",
            &seed.to_string(),
            "--out",
            s(&sim),
        ]);
        let mut log = String::from("x,y,z\n");
        for row in rows(&sim.join("probes.csv")) {
            let (x, y, z) = (row[0] + 5.0, row[1] - 18.0, row[2] - 0.7);
            log.push_str(&format!("{x},{y},{z}\n"));
        }
        let probes = d.join(format!("probes{seed}.csv"));
        fs::write(&probes, log).unwrap();
        let data = d.join(format!("data{seed}"));
        ok(&[
            "import",
            "marlin",
            "--config",
            s(&m503),
            "--probes",
            s(&probes),
            "--print-radius",
            "100",
            "--out",
            s(&data),
        ]);
        let (imported, simulated) = (
            rows(&data.join("probes.csv")),
            rows(&sim.join("probes.csv")),
        );
        assert_eq!(imported.len(), simulated.len());
        for (a, b) in imported.iter().zip(&simulated) {
            assert!(
                a.iter().zip(b).all(|(a, b)| (a - b).abs() < 1e-9),
                "{a:?} against {b:?}"
            );
        }
        // A false alarm of the tests (a w-test at the family-wise 0.05
        // level, about one printer in twenty) rejects a calibration, which
        // estimates all the same.
        let calibrated = parcal(&["calibrate", s(&data)]);
        assert!(
            matches!(calibrated.status.code(), Some(0 | 3)),
            "{calibrated:?}"
        );
        let record = ["calibration.json", "calibration.rejected.json"]
            .map(|name| data.join(name))
            .into_iter()
            .find(|path| path.exists())
            .unwrap();
        let truth: serde_json::Value =
            serde_json::from_str(&fs::read_to_string(sim.join("truth.json")).unwrap()).unwrap();
        let raw: Vec<f64> = (names.iter())
            .map(|n| truth["parameters"][n].as_f64().unwrap())
            .collect();
        let canonical = delta.canonicalize(&raw).unwrap();
        let mut squares = Vec::new();
        for (name, value, sigma) in parameters(&record) {
            let Some(sigma) = sigma.filter(|s| *s > 0.0) else {
                continue;
            };
            let true_value = match names.iter().position(|n| *n == name) {
                Some(k) => canonical[k],
                None => truth["trigger_height"].as_f64().unwrap(),
            };
            let z = (value - true_value) / sigma;
            largest = largest.max(z.abs());
            squares.push(z * z);
        }
        draw_means.push(squares.iter().sum::<f64>() / squares.len() as f64);
    }
    let n = draw_means.len() as f64;
    let mean = draw_means.iter().sum::<f64>() / n;
    let variance = draw_means.iter().map(|m| (m - mean).powi(2)).sum::<f64>() / (n - 1.0);
    let standard_error = (variance / n).sqrt();
    eprintln!(
        "{DRAWS} printers: mean (error / sigma)^2 {mean:.3} +- {standard_error:.3}, largest |error / sigma| {largest:.2}"
    );
    assert!(
        (mean - 1.0).abs() < 4.0 * standard_error,
        "{mean} +- {standard_error}"
    );
    assert!(largest < 4.5, "{largest}");
}

/// A Marlin compiled with radius trims (`DELTA_RADIUS_TRIM_TOWER`, which
/// `M503` does not report): imported with `--radius-trims`, the configured
/// towers stand at the delta radius plus their trims and the calibration
/// reaches the truth within its sigmas; exported, the lines are written
/// for those trims (the calibration's prior states them) and, read back
/// with them, are the calibrated machine to the lines' rounding. Trims for
/// another firmware, or that no tower can have, are refused by name.
#[test]
fn radius_trims_compiled_into_marlin_are_imported_and_exported() {
    const TRIMS: [f64; 3] = [0.6, -0.4, 0.2];
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    fs::write(d.join("m503.txt"), M503).unwrap();
    let firmware = read_config(&d.join("m503.txt"))
        .unwrap()
        .with_radius_trims(TRIMS)
        .unwrap()
        .to_params();
    let mut truth = truth();
    truth.tower_radius = [0.7, -0.5, 0.2];
    let (t, f) = (truth.to_vector(), firmware.to_vector());
    let mut csv = String::from("x,y,z\n");
    for [x, y] in probe_rings(75.0, 3, 12) {
        let nozzle = [x - PROBE_XY[0], y - PROBE_XY[1]];
        let z = triggered(t.as_slice(), f.as_slice(), nozzle, TRIGGER) - TRIGGER;
        csv.push_str(&format!("{x:.2},{y:.2},{z:.3}\n"));
    }
    fs::write(d.join("probes.csv"), csv).unwrap();
    let import = |trims: &str, out: &Path| {
        vec![
            "import".to_string(),
            "marlin".into(),
            "--config".into(),
            s(&d.join("m503.txt")).into(),
            "--probes".into(),
            s(&d.join("probes.csv")).into(),
            "--print-radius".into(),
            "85".into(),
            format!("--radius-trims={trims}"),
            "--out".into(),
            s(out).into(),
        ]
    };
    fn args(v: &[String]) -> Vec<&str> {
        v.iter().map(String::as_str).collect()
    }
    let data = d.join("data");
    ok(&args(&import("0.6,-0.4,0.2", &data)));
    let machine: serde_json::Value =
        serde_json::from_str(&fs::read_to_string(data.join("machine.json")).unwrap()).unwrap();
    let design = |name: &str| machine["configured"][name].as_f64().unwrap();
    assert_eq!(["radius_a", "radius_b", "radius_c"].map(design), TRIMS);
    let summary = ok(&["calibrate", s(&data)]);
    assert!(summary.contains("accepted"), "{summary}");
    let calibration = data.join("calibration.json");
    within_three_sigmas(&calibration, &truth);
    let delta = LinearDelta::typical();
    let names: Vec<String> = delta.parameters().iter().map(|p| p.name.clone()).collect();

    let out = d.join("new.gcode");
    let export = export_marlin(&calibration, &out);
    let said = ok(&export);
    assert!(
        said.contains(
            "radius trims: 0.6, -0.4, 0.2 mm (DELTA_RADIUS_TRIM_TOWER, the calibration's prior's"
        ),
        "{said}"
    );
    let written = fs::read_to_string(&out).unwrap();
    assert!(
        written
            .contains("; for a Marlin compiled with DELTA_RADIUS_TRIM_TOWER { 0.6, -0.4, 0.2 }\n"),
        "{written}"
    );
    fs::write(&out, format!("M851 Z-0.75\n{written}")).unwrap();
    let back = read_config(&out)
        .unwrap()
        .with_radius_trims(TRIMS)
        .unwrap()
        .to_params();
    let back = delta.canonicalize(back.to_vector().as_slice()).unwrap();
    let calibrated: Vec<f64> = (names.iter())
        .map(|n| {
            (parameters(&calibration).into_iter())
                .find(|(name, _, _)| name == n)
                .unwrap()
                .1
        })
        .collect();
    let tilt = names.iter().position(|n| n == "tilt_x").unwrap();
    for (k, name) in names
        .iter()
        .enumerate()
        .filter(|(k, _)| *k < tilt || *k > tilt + 1)
    {
        assert!(
            (back[k] - calibrated[k]).abs() < 3e-3,
            "{name}: calibrated {}, read back {}",
            calibrated[k],
            back[k]
        );
    }

    // Refused by name: trims for Klipper, two trims, a tower at no radius.
    let err = fails(&[
        "export",
        "--calibration",
        s(&calibration),
        "--format",
        "klipper",
        "--radius-trims",
        "1,2,3",
        "--out",
        s(&d.join("printer.cfg")),
    ]);
    assert!(
        err.contains("--radius-trims: radius trims are Marlin's"),
        "{err}"
    );
    let err = fails(&[&export[..], &["--radius-trims", "1,2"]].concat());
    assert!(err.contains("is not three radius trims X,Y,Z"), "{err}");
    let err = fails(&args(&import("0,0,-98", &d.join("refused"))));
    assert!(
        err.contains("--radius-trims: tower Z's radius trim -98 mm puts it at radius -0.5 mm"),
        "{err}"
    );
    assert!(!d.join("refused").exists());
}
