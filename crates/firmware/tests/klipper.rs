//! Reading Klipper's delta settings and writing its SAVE_CONFIG block.

use std::path::Path;

use parcal_firmware::klipper::{KlipperDelta, parse_printer, read_printer};

const PRINTER_CFG: &str = "\
# A kit delta
[stepper_a]
step_pin: PF0
arm_length: 269.8   # measured
position_endstop: 301.2
homing_speed: 60

[stepper_b]
step_pin: PF6
angle = 329.8

[stepper_c]
position_endstop: 300.9

[printer]
kinematics: delta
max_velocity: 300
delta_radius: 134.5
print_radius: 110

[gcode_macro PARK]
gcode:
    G1 X0 Y0 Z50 ; not a key: value of ours
    M400
";

#[test]
fn reads_the_settings_with_klippers_defaults() {
    let delta = parse_printer(PRINTER_CFG, Path::new("printer.cfg"))
        .unwrap()
        .delta;
    assert_eq!(delta.delta_radius, 134.5);
    assert_eq!(delta.print_radius, 110.0);
    assert_eq!(delta.angles, [210.0, 329.8, 90.0]);
    assert_eq!(delta.arm_lengths, [269.8; 3]);
    assert_eq!(delta.position_endstops, [301.2, 301.2, 300.9]);
    let params = delta.to_params();
    assert!((params.homed_height - 301.1).abs() < 1e-12);
    assert!((params.endstop[2] + 0.2).abs() < 1e-12);
    assert!((params.angle[1] + 0.2).abs() < 1e-12);
}

#[test]
fn the_save_config_block_overrides_and_reads_back() {
    let calibrated = KlipperDelta {
        delta_radius: 134.987654,
        print_radius: 110.0,
        angles: [210.123456, 329.876543, 90.0],
        arm_lengths: [270.111111, 269.888888, 270.0],
        position_endstops: [301.234567, 300.765432, 301.0],
    };
    let text = format!("{PRINTER_CFG}\n{}", calibrated.save_config_block(None));
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("printer.cfg");
    std::fs::write(&path, &text).unwrap();
    let back = read_printer(&path).unwrap().delta;
    // Written to 1e-6: equal to the values, which have six decimals.
    assert_eq!(back, calibrated);
    let params = back.to_params();
    assert_eq!(
        KlipperDelta::from_params(&params, 110.0)
            .unwrap()
            .save_config_block(None),
        calibrated.save_config_block(None)
    );
}

#[test]
fn the_probe_s_z_offset_is_read_and_saved_as_probe_calibrate_saves_it() {
    let path = Path::new("printer.cfg");
    assert_eq!(parse_printer(PRINTER_CFG, path).unwrap().z_offset, None);
    let with = |section: &str, value: &str| {
        format!("{PRINTER_CFG}\n[{section}]\nsensor_pin: ^PA1\nz_offset: {value}\n")
    };
    for section in ["probe", "bltouch", "smart_effector"] {
        let text = with(section, "1.25");
        assert_eq!(parse_printer(&text, path).unwrap().z_offset, Some(1.25));
        // SAVE_CONFIG's value overrides the main part's, to 1e-3.
        let delta = parse_printer(&text, path).unwrap().delta;
        let (main, block) = delta.saved_into(&text, Some(0.8126));
        let saved = format!("{main}{block}");
        assert!(
            saved.contains(&format!("#*# [{section}]\n#*# z_offset = 0.813\n")),
            "{saved}"
        );
        assert_eq!(parse_printer(&saved, path).unwrap().z_offset, Some(0.813));
    }
    let err = parse_printer(&with("probe", "high"), path)
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("[probe] z_offset: 'high' is not a number"),
        "{err}"
    );
    let err = parse_printer(&with("probe", "1e300"), path)
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("[probe] z_offset: '1e300' is beyond the 1e6 a firmware's number may be"),
        "{err}"
    );
    // Klipper runs one probe: a z_offset in both sections is refused at
    // the second.
    let both = format!("{}[bltouch]\nz_offset: 0.9\n", with("probe", "1.25"));
    let line = both.lines().count();
    let err = parse_printer(&both, path).unwrap_err().to_string();
    assert_eq!(
        err,
        format!(
            "printer.cfg: line {line}: [bltouch] z_offset: the file gives [probe] a z_offset too; Klipper runs one probe"
        )
    );
}

#[test]
fn errors_name_the_file_and_line() {
    let path = Path::new("printer.cfg");
    let error = |text: &str| parse_printer(text, path).unwrap_err().to_string();
    let edited = |from: &str, to: &str| error(&PRINTER_CFG.replace(from, to));
    for (from, to, expected) in [
        (
            "134.5",
            "13x",
            "printer.cfg: line 18: [printer] delta_radius: '13x' is not a number",
        ),
        (
            "kinematics: delta",
            "kinematics: corexy",
            "printer.cfg: line 16: kinematics 'corexy': not a linear delta",
        ),
        (
            "delta_radius: 134.5",
            "",
            "printer.cfg: no delta_radius in [printer] (includes are not followed)",
        ),
        // What Klipper refuses (`above=0.`), and a nozzle homed below the
        // bed.
        (
            "134.5",
            "-134.5",
            "printer.cfg: line 18: [printer] delta_radius: -134.5 must be positive",
        ),
        (
            "print_radius: 110",
            "print_radius: 0",
            "printer.cfg: line 19: [printer] print_radius: 0 must be positive",
        ),
        (
            "300.9",
            "-5",
            "printer.cfg: line 13: [stepper_c] position_endstop: -5 must be positive",
        ),
    ] {
        assert_eq!(edited(from, to), expected);
    }
    assert_eq!(
        error("orphan: 1\n"),
        "printer.cfg: line 1: 'orphan: 1' comes before any section"
    );
    let mut tilted = parse_printer(PRINTER_CFG, path).unwrap().delta.to_params();
    tilted.tilt = [0.1, 0.0];
    assert!(KlipperDelta::from_params(&tilted, 110.0).is_err());
}
