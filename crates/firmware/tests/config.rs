//! Reading RepRapFirmware's delta configuration and writing it back.

use std::path::Path;

use parcal_firmware::rrf::{RrfDelta, parse_config, read_config};

const CONFIG: &str = "\
; config.g of a kit delta
M550 P\"Kossel\"            ; name
M665 L267.5 R134.2 H299.8 B110 ; geometry
M665 X0.21 Y-0.15          ; tower angles later, as M500 writes them
M666 X0.12 Y-0.31 Z0.19 A0.05 B-0.02
G31 P500 X0 Y-25.5 Z1.43   ; probe
G31 K1 Z9                  ; another probe: not ours
M208 Z-1 S1
";

#[test]
fn reads_the_lines_as_the_firmware_executes_them() {
    let config = parse_config(CONFIG, Path::new("config.g")).unwrap();
    let delta = &config.delta;
    assert_eq!(delta.diagonals, [267.5; 3]);
    assert_eq!(
        (delta.radius, delta.homed_height, delta.print_radius),
        (134.2, 299.8, 110.0)
    );
    assert_eq!(delta.angle_corrections, [0.21, -0.15, 0.0]);
    assert_eq!(delta.endstop_adjustments, [0.12, -0.31, 0.19]);
    assert_eq!(delta.tilt, [0.05, -0.02]);
    assert_eq!(config.probe.trigger_height, 1.43);
    assert_eq!(config.probe.offset, [0.0, -25.5]);
}

#[test]
fn per_tower_rods_fill_as_the_firmware_fills_them() {
    let three = parse_config("M665 L270.1:269.9:270.3 R135", Path::new("c.g")).unwrap();
    assert_eq!(three.delta.diagonals, [270.1, 269.9, 270.3]);
    let two = parse_config("M665 L270.1:269.9 R135", Path::new("c.g")).unwrap();
    assert_eq!(two.delta.diagonals, [270.1, 269.9, 270.1]);
}

#[test]
fn errors_name_the_file_and_line() {
    let path = Path::new("sys/config.g");
    let error = |text: &str| parse_config(text, path).unwrap_err().to_string();
    for (text, expected) in [
        (
            "G28\nM665 L270 R13.5.1\n",
            "sys/config.g: line 2: M665 parameter R: '13.5.1' is not a number",
        ),
        // A length no printer has, named where it stands, not in the
        // dataset an import would write.
        (
            "M665 L2000000 R135\n",
            "sys/config.g: line 1: M665 parameter L: '2000000' is beyond the 1e6 a firmware's number may be (1 km in mm: a unit error?)",
        ),
        // A letter with no number (`Rnan` reads as `R`, then `N`, `A`, `N`).
        (
            "M665 L270 Rnan\n",
            "sys/config.g: line 1: M665 parameter R: no number follows the letter",
        ),
        // The nozzle homed at or below the bed, where the probe points lie.
        (
            "M665 L270 R135 H-5\n",
            "sys/config.g: line 1: homed height -5 mm must be positive: the nozzle homes above the bed",
        ),
        (
            "M665 L270:270:270:270 R135\n",
            "sys/config.g: line 1: M665 L gives 4 diagonals: parcal reads deltas of three towers",
        ),
        (
            "M666 X0.1\n",
            "sys/config.g: no M665 line: not a linear delta's configuration",
        ),
    ] {
        assert_eq!(error(text), expected);
    }
    let err = error("; rods\nM665 L120 R135\n");
    assert!(
        err.starts_with("sys/config.g: line 2: the diagonal rod of tower X"),
        "{err}"
    );
    let err = read_config(Path::new("/nonexistent/config.g")).unwrap_err();
    assert!(
        err.to_string()
            .starts_with("/nonexistent/config.g: cannot read"),
        "{err}"
    );
}

#[test]
fn calibration_lines_read_back_to_the_values_written() {
    let delta = RrfDelta {
        diagonals: [270.1234, 269.8766, 270.0004],
        radius: 134.9876,
        homed_height: 301.2345,
        print_radius: 110.0,
        angle_corrections: [0.2345, -0.1234, 0.0],
        endstop_adjustments: [0.1234, -0.3456, 0.2222],
        tilt: [0.0523, -0.0217],
    };
    let text = delta.calibration_lines();
    assert!(
        text.starts_with("; Delta parameters\nM665 L270.123:269.877:270.000 R134.988 H301.23"),
        "{text}"
    );
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("config-override.g");
    std::fs::write(&path, &text).unwrap();
    let back = read_config(&path).unwrap().delta;
    let close = |a: &[f64], b: &[f64], half_step: f64| {
        a.iter().zip(b).all(|(x, y)| (x - y).abs() <= half_step)
    };
    // Written to 0.001: read back within half a step (and rounding).
    let half = 0.0005 + 1e-12;
    assert!(close(&back.diagonals, &delta.diagonals, half), "{back:?}");
    assert!(close(
        &[back.radius, back.homed_height],
        &[delta.radius, delta.homed_height],
        half
    ));
    assert!(close(
        &back.angle_corrections,
        &delta.angle_corrections,
        half
    ));
    assert!(close(
        &back.endstop_adjustments,
        &delta.endstop_adjustments,
        half
    ));
    assert!(close(&back.tilt, &delta.tilt, half));
    assert_eq!(back.print_radius, delta.print_radius);
    // And written again, identical.
    assert_eq!(back.calibration_lines(), text);
}

/// `M501` (or `M98 P"config-override.g"`) runs config-override.g's lines
/// where it stands, as the firmware does: its values replace config.g's
/// before it and those after it replace its; an override config.g loads
/// that is not beside it is refused by the line that loads it.
#[test]
fn the_override_runs_where_config_g_loads_it() {
    let dir = tempfile::tempdir().unwrap();
    let config = dir.path().join("config.g");
    std::fs::write(
        dir.path().join("config-override.g"),
        "; saved by M500\nM665 L270.3:270.4:270.2 R135.8 H298.5 X1.2\nM666 X0.6 Y0.3 Z-0.9\n",
    )
    .unwrap();
    for load in [
        "M501",
        "M98 P\"config-override.g\"",
        "M98 P\"0:/sys/config-override.g\"",
    ] {
        let text = format!("M665 L270 R135 H300 B100\nM666 X0 Y0 Z0\n{load}\nM666 Z-1.0\n");
        let read = parse_config(&text, &config).unwrap().delta;
        assert_eq!(read.diagonals, [270.3, 270.4, 270.2], "{load}");
        assert_eq!(
            (read.radius, read.homed_height, read.print_radius),
            (135.8, 298.5, 100.0)
        );
        assert_eq!(read.angle_corrections, [1.2, 0.0, 0.0]);
        assert_eq!(read.endstop_adjustments, [0.6, 0.3, -1.0], "{load}");
    }
    // Another macro is not the override.
    let other = parse_config("M665 L270 R135\nM98 P\"homedelta.g\"\n", &config).unwrap();
    assert_eq!(other.delta.diagonals, [270.0; 3]);
    // An override the printer runs but parcal cannot see.
    let alone = tempfile::tempdir().unwrap();
    let err = parse_config("M665 L270 R135\nM501\n", &alone.path().join("config.g"))
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("config.g: line 2: M501 loads config-override.g"),
        "{err}"
    );
    // An error in the override names its own file and line.
    std::fs::write(dir.path().join("config-override.g"), "M665 R13.5.1\n").unwrap();
    let err = parse_config("M665 L270 R135\nM501\n", &config)
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("config-override.g: line 1: M665 parameter R"),
        "{err}"
    );
}
