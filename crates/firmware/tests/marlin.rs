//! Reading Marlin's delta settings as `M503` reports them and writing the
//! calibration lines back.

use std::path::Path;

use parcal_firmware::accuracy::Workspace;
use parcal_firmware::export::{Firmware, TriggerHeight, export};
use parcal_firmware::marlin::{MarlinDelta, parse_config, read_config};
use parcal_kinematics::delta::DeltaParams;

/// `M503` of a kit delta on Marlin 2.1, as a host's terminal shows it.
const M503: &str = "\
Send: M503
Recv: echo:; Linear Units:
Recv: echo:  G21 ; (mm)
Recv: echo:; Steps per unit:
Recv: echo:  M92 X100.00 Y100.00 Z100.00 E415.00
Recv: echo:; Max feedrates (units/s):
Recv: echo:  M203 X200.00 Y200.00 Z200.00 E25.00
Recv: echo:; Home offset:
Recv: echo:  M206 X0.00 Y0.00 Z0.00
Recv: echo:; Auto Bed Leveling:
Recv: echo:  M420 S0 Z0.00 ; Leveling OFF
Recv: echo:; Endstop adjustment:
Recv: echo:  M666 X-0.42 Y0.00 Z-0.17
Recv: echo:; Delta (L<diagonal rod> R<radius> H<height> S<segments per second> XYZ<tower angle trim> ABC<rod trim>):
Recv: echo:  M665 L218.00 R97.52 H301.47 S200.00 X0.18 Y-0.07 Z0.00 A0.12 B-0.05 C0.00
Recv: echo:; Material heatup parameters:
Recv: echo:  M145 S0 H200.00 B60.00 F0
Recv: echo:; Hotend PID:
Recv: echo:  M301 P22.20 I1.08 D114.00
Recv: echo:; Z-Probe Offset:
Recv: echo:  M851 X0.00 Y-18.50 Z-0.75 ; (mm)
Recv: ok
";

#[test]
fn reads_what_m503_reports() {
    let config = parse_config(M503, Path::new("m503.txt")).unwrap();
    let delta = &config.delta;
    assert_eq!(
        (delta.diagonal_rod, delta.radius, delta.height),
        (218.0, 97.52, 301.47)
    );
    assert_eq!(delta.rod_trims, [0.12, -0.05, 0.0]);
    assert_eq!(delta.angle_trims, [0.18, -0.07, 0.0]);
    assert_eq!(delta.endstop_adjustments, [-0.42, 0.0, -0.17]);
    assert_eq!(config.probe_offset, Some([0.0, -18.5, -0.75]));
    assert_eq!(config.trigger_height(), 0.75);
    assert_eq!(config.probe_xy(), [0.0, -18.5]);
    // In parcal's terms: rods L + A, B, C; endstop corrections the
    // adjustments' negatives; the homed height H less M851 Z.
    let params = config.to_params();
    assert_eq!(params.diagonal, [218.12, 217.95, 218.0]);
    assert_eq!(params.endstop, [0.42, 0.0, 0.17]);
    assert!((params.homed_height - 302.22).abs() < 1e-12);
    assert_eq!((params.radius, params.angle), (97.52, [0.18, -0.07, 0.0]));
    assert_eq!((params.tower_radius, params.tilt), ([0.0; 3], [0.0; 2]));
    // An older Marlin: echo: only, M665 B (its calibration radius) and no
    // rod trims, no probe.
    let older = "echo:  M665 L218.00 R97.50 H302.00 S200.00 B85.00 X0.00 Y0.00 Z0.00\n\
                 echo:  M666 X0.00 Y-0.10 Z-0.20\n";
    let config = parse_config(older, Path::new("old.txt")).unwrap();
    assert_eq!(config.delta.rod_trims, [0.0; 3]);
    assert_eq!(config.probe_offset, None);
    assert_eq!(config.trigger_height(), 0.0);
    assert_eq!(config.to_params().homed_height, 302.0);
}

#[test]
fn errors_name_the_file_and_line() {
    let path = Path::new("m503.txt");
    let error = |text: &str| parse_config(text, path).unwrap_err().to_string();
    assert_eq!(
        error("echo:  M666 X0 Y0 Z0\necho:  M665 L218 R9.7.5 H300 X0 Y0 Z0\n"),
        "m503.txt: line 2: M665 parameter R: '9.7.5' is not a number"
    );
    assert_eq!(
        error("M665 L218 R97.5 X0 Y0 Z0\nM666 X0 Y0 Z0\n"),
        "m503.txt: line 1: no M665 H (delta height) given: M503 reports it, and parcal cannot know the value compiled into the firmware"
    );
    assert_eq!(
        error("M665 L218 R97.5 H300 X0 Y0 Z0\nM666 X0 Z0\n"),
        "m503.txt: line 2: no M666 Y (endstop adjustment) given: M503 reports it, and parcal cannot know the value compiled into the firmware"
    );
    assert_eq!(
        error("M665 L218 R97.5 H300 X0 Y0\nM666 X0 Y0 Z0\n"),
        "m503.txt: line 1: no M665 Z (tower angle trim) given: M503 reports it, and parcal cannot know the value compiled into the firmware"
    );
    assert!(
        error("M665 L218 R97.5 H300 X0 Y0 Z0\n")
            .starts_with("m503.txt: no M666 line: no M666 X (endstop adjustment) given"),
    );
    assert_eq!(
        error("M665 L218 R97.5 H300 X0 Y0 Z0\nM666 X-0.1 Y0.2 Z0\n"),
        "m503.txt: line 2: M666 parameter Y: 0.2 is positive; Marlin refuses it (M666 offsets must be <= 0)"
    );
    assert_eq!(
        error("echo:  G20 ; (in)\necho:  M665 L8.6 R3.8 H11.8 X0 Y0 Z0\n"),
        "m503.txt: line 2: M665 in inches (G20 before it): parcal reads Marlin's settings in mm; send G21, then M503"
    );
    assert_eq!(
        error("echo:  M92 X100\nok\n"),
        "m503.txt: no M665 line: not a linear delta's settings (M503 of a delta reports M665)"
    );
    assert!(
        error("M665 L90 R97.5 H300 X0 Y0 Z0 A0 B10\nM666 X0 Y0 Z0\n")
            .starts_with("m503.txt: line 1: the diagonal rod of tower X (90 mm) is not longer"),
    );
    assert!(
        error("M665 L218 R-97.5 H300 X0 Y0 Z0\nM666 X0 Y0 Z0\n")
            .starts_with("m503.txt: line 1: delta radius -97.5 must be positive"),
    );
    assert_eq!(
        error("M665 L218 R97.5 H0 X0 Y0 Z0\nM666 X0 Y0 Z0\n"),
        "m503.txt: line 1: delta height 0 mm must be positive: the nozzle homes above the bed"
    );
    let err = read_config(Path::new("/nonexistent/m503.txt")).unwrap_err();
    assert!(
        err.to_string()
            .starts_with("/nonexistent/m503.txt: cannot read"),
        "{err}"
    );
}

/// A machine Marlin holds (no tower radius of its own, no tilt, values
/// on its 0.001 grid), written as Marlin's lines and read back: the same
/// machine, every carriage's endstop height `H + e_i` included, within
/// 1e-9 mm.
#[test]
fn calibration_lines_read_back_the_machine_written() {
    let mut params = DeltaParams::symmetric(218.0, 97.512, 301.234);
    params.diagonal = [218.123, 217.877, 218.006];
    params.angle = [0.234, -0.123, 0.0];
    params.endstop = [0.123, -0.346, 0.222];
    for trigger in [0.0, 0.75] {
        let delta = MarlinDelta::from_params(&params, trigger, [0.0; 3]).unwrap();
        // Marlin's M666 is at most zero: the highest carriage's is zero.
        assert!(delta.endstop_adjustments.iter().all(|a| *a <= 0.0));
        assert_eq!(delta.endstop_adjustments[1], 0.0);
        let text = format!("M851 Z{}\n{}", -trigger, delta.calibration_lines());
        let back = parse_config(&text, Path::new("lines")).unwrap();
        let read = back.to_params();
        let close = |a: &[f64], b: &[f64]| a.iter().zip(b).all(|(x, y)| (x - y).abs() < 1e-9);
        let endstop_heights = |p: &DeltaParams| p.endstop.map(|e| p.homed_height + e);
        assert!(close(&read.diagonal, &params.diagonal), "{read:?}");
        assert!(close(&read.angle, &params.angle), "{read:?}");
        assert!((read.radius - params.radius).abs() < 1e-9);
        assert!(close(&endstop_heights(&read), &endstop_heights(&params)));
        // And written again, identical.
        assert_eq!(back.delta.calibration_lines(), delta.calibration_lines());
    }
    let mut tilted = params;
    tilted.tilt = [0.05, 0.0];
    let error = MarlinDelta::from_params(&tilted, 0.0, [0.0; 3]).unwrap_err();
    assert!(
        error.to_string().contains("Marlin's delta cannot hold"),
        "{error}"
    );
    // A tower radius of its own is the trim of a Marlin compiled with it,
    // the rest unchanged; on a Marlin without trims, the same machine in
    // another frame.
    let mut own = params;
    own.tower_radius = [0.1, 0.0, 0.0];
    let trimmed = MarlinDelta::from_params(&own, 0.0, own.tower_radius).unwrap();
    let plain = MarlinDelta::from_params(&params, 0.0, [0.0; 3]).unwrap();
    assert_eq!(
        trimmed,
        MarlinDelta {
            radius_trims: own.tower_radius,
            ..plain
        }
    );
    let moved = MarlinDelta::from_params(&own, 0.0, [0.0; 3]).unwrap();
    assert_eq!(moved.radius_trims, [0.0; 3]);
    assert!((moved.radius - 97.512).abs() > 0.01, "{moved:?}");
}

/// A simulated printer's calibration exported for Marlin: the lines
/// Marlin reads give the canonical machine to the rounding, the tilt
/// said lost with its cost, and `M500` saves them.
#[test]
fn a_calibrated_printer_is_exported_with_what_marlin_loses() {
    let mut calibrated = DeltaParams::symmetric(218.0, 97.5, 301.0);
    calibrated.endstop = [0.21, -0.13, -0.08];
    calibrated.angle = [0.23, -0.11, 0.05];
    calibrated.tower_radius = [0.1, -0.05, 0.02];
    calibrated.diagonal = [218.12, 217.91, 218.04];
    calibrated.tilt = [0.05, -0.02];
    let workspace = Workspace::of_printer(85.0, 301.0);
    let exported = |trigger| {
        export(
            &calibrated,
            trigger,
            85.0,
            Firmware::Marlin {
                radius_trims: [0.0; 3],
            },
            None,
            &workspace,
        )
        .unwrap()
    };
    let determined = exported(TriggerHeight::Determined(0.7468));
    assert!(
        determined.text.ends_with("M851 Z-0.747\nM500\n"),
        "{}",
        determined.text
    );
    assert_eq!(determined.trigger_height, Some(0.747));
    assert!(determined.text.contains(
        "; parcal: lost: the bed tilt (x 0.0500 %, y -0.0200 %): Marlin's delta has none"
    ));
    assert!(determined.text.contains(
        "; parcal: written: the probe's trigger height, 0.747 mm, which the data determine (M851 Z)"
    ));
    assert_eq!(determined.written.tilt, [0.0; 2]);
    // The tilt costs its height at the edge of the printable disc.
    let edge = 0.05e-2 * 85.0;
    assert!(
        determined.cost.flatness_max > 0.8 * edge
            && determined.cost.flatness_max < 1.2 * edge.hypot(0.02e-2 * 85.0),
        "{:?}",
        determined.cost
    );
    // The configured trigger height kept: M665 H counts its M851 Z, and the
    // machine Marlin then believes in is the same.
    let kept = exported(TriggerHeight::AtPrior {
        ratio: 0.99,
        configured: 0.5,
    });
    assert!(!kept.text.contains("\nM851"), "{}", kept.text);
    assert_eq!(kept.trigger_height, None);
    let close = |a: f64, b: f64| (a - b).abs() < 1e-9;
    assert!(close(
        kept.written.homed_height,
        determined.written.homed_height
    ));
    let height = |export: &parcal_firmware::export::Export| {
        let line = export
            .text
            .lines()
            .find(|l| l.starts_with("M665 "))
            .unwrap();
        let h = line.split(' ').find(|w| w.starts_with('H')).unwrap();
        h[1..].parse::<f64>().unwrap()
    };
    assert!(close(height(&determined) - height(&kept), 0.5 - 0.747));
    // No trigger height among the unknowns: H for no probe offset, said.
    let absent = exported(TriggerHeight::Absent);
    assert!(
        absent
            .lost
            .iter()
            .any(|s| s.contains("add its M851 Z to H"))
    );
    assert!(close(
        absent.written.homed_height,
        determined.written.homed_height
    ));
    // The lines are written alone.
    let refused = export(
        &calibrated,
        TriggerHeight::Absent,
        85.0,
        Firmware::Marlin {
            radius_trims: [0.0; 3],
        },
        Some(Path::new("m503.txt")),
        &workspace,
    )
    .unwrap_err();
    assert!(refused.to_string().contains("written alone"), "{refused}");
}

/// A Marlin compiled with radius trims (`DELTA_RADIUS_TRIM_TOWER`, which
/// `M503` does not report): its settings read with them put each tower at
/// the delta radius plus its trim, and the calibrated machine is written
/// in the frame of those trims, so that the lines read back with them are
/// the calibrated machine, and read without them another.
#[test]
fn radius_trims_compiled_in_are_read_and_written() {
    let trims = [0.8, -0.5, 0.3];
    let config = parse_config(M503, Path::new("m503.txt")).unwrap();
    let trimmed = config.with_radius_trims(trims).unwrap().to_params();
    assert_eq!(trimmed.tower_radius, trims);
    assert_eq!(
        DeltaParams {
            tower_radius: [0.0; 3],
            ..trimmed
        },
        config.to_params()
    );
    let refused = config.with_radius_trims([0.0, f64::NAN, 0.0]).unwrap_err();
    assert!(
        refused.contains("tower Y's radius trim NaN mm"),
        "{refused}"
    );
    let refused = config.with_radius_trims([0.0, 0.0, -98.0]).unwrap_err();
    assert!(
        refused.contains("tower Z's radius trim -98 mm"),
        "{refused}"
    );

    let mut calibrated = DeltaParams::symmetric(218.0, 97.5, 301.0);
    calibrated.endstop = [0.21, -0.13, -0.08];
    calibrated.angle = [0.23, -0.11, 0.05];
    calibrated.tower_radius = [0.1, -0.05, 0.02];
    calibrated.diagonal = [218.12, 217.91, 218.04];
    let workspace = Workspace::of_printer(85.0, 301.0);
    let exported = |radius_trims| {
        export(
            &calibrated,
            TriggerHeight::Determined(0.7468),
            85.0,
            Firmware::Marlin { radius_trims },
            None,
            &workspace,
        )
        .unwrap()
    };
    let (plain, with_trims) = (exported([0.0; 3]), exported(trims));
    assert!(
        with_trims
            .text
            .contains("; for a Marlin compiled with DELTA_RADIUS_TRIM_TOWER { 0.8, -0.5, 0.3 }\n"),
        "{}",
        with_trims.text
    );
    assert!(
        !plain.text.contains("DELTA_RADIUS_TRIM_TOWER"),
        "{}",
        plain.text
    );
    assert_eq!(with_trims.written.tower_radius, trims);
    // Both cost the rounding of their lines alone: 0.001 mm and 0.001
    // degree move a point of the printable disc by a few um.
    for export in [&plain, &with_trims] {
        assert!(export.cost.volume_max < 5e-3, "{:?}", export.cost);
    }
    // The trims' lines on a Marlin compiled without them: another machine.
    let lines: String = (with_trims.text.lines())
        .filter(|l| !l.starts_with(';'))
        .map(|l| format!("{l}\n"))
        .collect();
    let untrimmed = parse_config(&lines, Path::new("exported"))
        .unwrap()
        .to_params();
    let cost =
        parcal_firmware::accuracy::position_errors(&calibrated, &untrimmed, &workspace).unwrap();
    assert!(cost.volume_max > 0.1, "{cost:?}");
}

proptest::proptest! {
    #![proptest_config(proptest::prelude::ProptestConfig::with_cases(64))]

    /// Any printer of the usual sizes, off its design by up to a few
    /// tenths, exported for a Marlin compiled with radius trims of up to 3
    /// mm: the lines read back with the trims are the calibrated machine to
    /// their rounding (0.001 mm and degree: a few um over the build
    /// volume).
    #[test]
    fn lines_for_any_radius_trims_read_back_the_machine(
        rod in 250.0..300.0f64,
        radius in 120.0..150.0f64,
        small in proptest::collection::vec(-0.3..0.3f64, 12),
        trims in proptest::array::uniform3(-3.0..3.0f64),
    ) {
        let mut calibrated = DeltaParams::symmetric(rod, radius, 300.0);
        calibrated.endstop = [small[0], small[1], small[2]];
        calibrated.tower_radius = [small[3], small[4], small[5]];
        calibrated.angle = [small[6], small[7], small[8]];
        calibrated.diagonal = [rod + small[9], rod + small[10], rod + small[11]];
        let workspace = Workspace::of_printer(100.0, 300.0);
        let exported = export(
            &calibrated,
            TriggerHeight::Absent,
            100.0,
            Firmware::Marlin { radius_trims: trims },
            None,
            &workspace,
        )
        .unwrap();
        proptest::prop_assert_eq!(exported.written.tower_radius, trims);
        proptest::prop_assert!(exported.cost.volume_max < 5e-3, "{:?}", exported.cost);
    }
}
