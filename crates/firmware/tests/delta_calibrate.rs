//! Reading what Klipper's `DELTA_CALIBRATE` saved: probes and part
//! distances at stable positions, made here by Klipper's own formula
//! (`calc_stable_position`: each tower's steps down from its endstop),
//! read back as the nozzle's positions under the configured parameters.

use std::path::Path;

use parcal_firmware::klipper::{ReadHeight, fit, parse_printer};
use parcal_kinematics::delta::{LinearDelta, probe_rings};
use parcal_kinematics::mechanism::Mechanism;

/// A printer whose steppers have 40 mm a turn at 16 microsteps (tower B
/// through a 2:1 reduction of an 80 mm pulley, tower C in the older
/// `step_distance` form): 0.0125 mm a step each.
const SETTINGS: &str = "\
[printer]
kinematics: delta
delta_radius: 134.5
print_radius: 110

[stepper_a]
rotation_distance: 40
microsteps: 16
arm_length: 269.8
position_endstop: 301.2

[stepper_b]
rotation_distance: 80
gear_ratio: 2:1
microsteps: 16
angle: 329.8

[stepper_c]
step_distance: 0.0125
position_endstop: 300.9
";

const STEP: f64 = 0.0125;
const RADIUS: f64 = 134.5;
const ANGLES: [f64; 3] = [210.0, 329.8, 90.0];
const ARM: f64 = 269.8;
const ENDSTOPS: [f64; 3] = [301.2, 301.2, 300.9];

/// Klipper's stable position of the nozzle at `p`, written as it saves
/// one (`%.3f` steps).
fn stable(p: [f64; 3]) -> String {
    let steps: Vec<String> = (0..3)
        .map(|i| {
            let (s, c) = ANGLES[i].to_radians().sin_cos();
            let (tx, ty) = (c * RADIUS, s * RADIUS);
            let home = ENDSTOPS[i] + (ARM * ARM - RADIUS * RADIUS).sqrt();
            let carriage = (ARM * ARM - (tx - p[0]).powi(2) - (ty - p[1]).powi(2)).sqrt() + p[2];
            format!("{:.3}", (home - carriage) / STEP)
        })
        .collect();
    steps.join(",")
}

/// Half a saved step (0.0005 of 0.0125 mm) moves a carriage by 6.3e-6 mm,
/// and the nozzle by at most a few times that within the printable area.
const SAVED_TO: f64 = 5e-5;

const PROBES: [[f64; 2]; 4] = [[0.0, 0.0], [0.0, 95.0], [-82.3, -47.5], [60.0, -30.0]];
const Z_OFFSET: f64 = 1.25;

fn printer_cfg(extra: &str) -> String {
    let mut text = format!(
        "{SETTINGS}\n#*# <---------------------- SAVE_CONFIG ---------------------->\n\
         #*# DO NOT EDIT THIS BLOCK OR BELOW. The contents are auto-generated.\n#*#\n\
         #*# [delta_calibrate]\n"
    );
    for (i, [x, y]) in PROBES.iter().enumerate() {
        text.push_str(&format!(
            "#*# height{i} = {Z_OFFSET}\n#*# height{i}_pos = {}\n",
            stable([*x, *y, Z_OFFSET])
        ));
    }
    text.push_str(&format!(
        "#*# distance0 = 130.05\n#*# distance0_pos1 = {}\n#*# distance0_pos2 = {}\n",
        stable([-65.0, 0.0, 0.0]),
        stable([65.0, 0.0, 0.0])
    ));
    text.push_str(extra);
    text
}

#[test]
fn saved_probes_and_distances_are_the_nozzles_positions() {
    let printer = parse_printer(&printer_cfg(""), Path::new("printer.cfg")).unwrap();
    let saved = printer.saved;
    assert_eq!(saved.z_offset, Some(Z_OFFSET));
    assert_eq!(saved.probes.len(), PROBES.len());
    for (probe, [x, y]) in saved.probes.iter().zip(PROBES) {
        for (got, want) in probe.iter().zip([x, y, Z_OFFSET]) {
            assert!((got - want).abs() < SAVED_TO, "{probe:?} vs {x}, {y}");
        }
    }
    let [d] = saved.distances[..] else {
        panic!("{:?}", saved.distances)
    };
    for (got, want) in d.iter().zip([-65.0, 0.0, 0.0, 65.0, 0.0, 0.0, 130.05]) {
        assert!((got - want).abs() < SAVED_TO, "{d:?}");
    }
}

#[test]
fn manual_heights_are_read_at_their_positions() {
    // DELTA_ANALYZE MANUAL_HEIGHT: the nozzle measured 5.2 mm and 0.8 mm
    // above the bed where the configured printer puts it at 5 and 1.
    let manual = format!(
        "#*# manual_height0 = 5.2\n#*# manual_height0_pos = {}\n\
         #*# manual_height1 = 0.8\n#*# manual_height1_pos = {}\n",
        stable([10.0, 20.0, 5.0]),
        stable([-40.0, 70.0, 1.0])
    );
    let saved = parse_printer(&printer_cfg(&manual), Path::new("printer.cfg"))
        .unwrap()
        .saved;
    assert_eq!(saved.probes.len(), PROBES.len());
    assert_eq!(saved.manual_heights.len(), 2);
    let wanted = [[10.0, 20.0, 5.0, 5.2], [-40.0, 70.0, 1.0, 0.8]];
    for (got, want) in saved.manual_heights.iter().zip(wanted) {
        for (g, w) in got.iter().zip(want) {
            assert!((g - w).abs() < SAVED_TO, "{got:?} vs {want:?}");
        }
    }
}

#[test]
fn saved_manual_heights_reach_klippers_fit() {
    // Six probes more, on a ring, so that the points outnumber Klipper's
    // six settings; the nozzle measured by hand 0.1 mm higher than the
    // settings put it, 5 mm up at each probe's point, where the saved
    // probes agree with the settings.
    let ring = &probe_rings(80.0, 1, 6)[1..];
    let raised = 0.1;
    let mut extra = String::new();
    for (i, [x, y]) in ring.iter().enumerate() {
        let i = PROBES.len() + i;
        extra.push_str(&format!(
            "#*# height{i} = {Z_OFFSET}\n#*# height{i}_pos = {}\n",
            stable([*x, *y, Z_OFFSET])
        ));
    }
    for (i, [x, y]) in PROBES.iter().chain(ring).enumerate() {
        extra.push_str(&format!(
            "#*# manual_height{i} = {}\n#*# manual_height{i}_pos = {}\n",
            5.0 + raised,
            stable([*x, *y, 5.0])
        ));
    }
    let printer = parse_printer(&printer_cfg(&extra), Path::new("printer.cfg")).unwrap();
    let configured = printer.delta.to_params().to_vector();
    let delta = LinearDelta::typical();
    let readings = |x: &[f64]| {
        let q = delta.inverse(configured.as_slice(), x).unwrap();
        [q[0], q[1], q[2]]
    };
    let probes: Vec<[f64; 3]> = printer.saved.probes.iter().map(|x| readings(x)).collect();
    let manual_heights: Vec<ReadHeight> = (printer.saved.manual_heights.iter())
        .map(|m| ReadHeight {
            readings: readings(&m[..3]),
            height: m[3],
        })
        .collect();
    assert_eq!((probes.len(), manual_heights.len()), (10, 10));
    // DELTA_CALIBRATE on the probes and the manual heights, the saved
    // distance aside, each height weighing as a probe (klipper::fit): the
    // settings but for a common height s leave E = K s² + M (s − 0.1)²,
    // least at s = 0.1 M / (K + M), 0.05 mm for as many manual heights as
    // probes at the same points (where no other setting's pattern of
    // heights does better, its product with the residuals being zero).
    let z_offset = printer.saved.z_offset.unwrap();
    let fitted = fit(&printer.delta, &probes, z_offset, &manual_heights, &[]).unwrap();
    let sent = fitted.to_params().to_vector();
    let q = delta.inverse(sent.as_slice(), &[0.0; 3]).unwrap();
    let height = delta
        .forward(configured.as_slice(), q.as_slice(), &[0.0; 3])
        .unwrap()[2];
    // Within the saved positions' rounding and the descent's stop (its
    // steps summing to 1e-5).
    assert!((height + raised / 2.0).abs() < SAVED_TO + 1e-5, "{height}");
}

#[test]
fn a_configuration_without_saved_measurements_has_none() {
    let printer = parse_printer(SETTINGS, Path::new("printer.cfg")).unwrap();
    assert_eq!(printer.saved.z_offset, None);
    assert!(printer.saved.probes.is_empty() && printer.saved.distances.is_empty());
}

#[test]
fn what_cannot_be_read_is_refused_naming_the_line() {
    let path = Path::new("printer.cfg");
    let error = |text: &str| parse_printer(text, path).unwrap_err().to_string();
    // The block's height0 is line 26 (SETTINGS has 20 lines, then a blank,
    // the marker, the notice, "#*#" and the section), each entry two lines
    // (a distance three), the extra lines from 37 on.
    let manual = error(&printer_cfg("#*# manual_height0 = 0.5\n"));
    assert!(
        manual.starts_with("printer.cfg: line 37: [delta_calibrate] manual_height0_pos: missing"),
        "{manual}"
    );
    let differs = error(&printer_cfg("").replace("height2 = 1.25", "height2 = 1.3"));
    assert!(
        differs.starts_with("printer.cfg: line 30: [delta_calibrate] height2: z_offset 1.3"),
        "{differs}"
    );
    let unpositioned = error(&printer_cfg("").replace("height1_pos", "height1_place"));
    assert!(
        unpositioned.starts_with("printer.cfg: line 28: [delta_calibrate] height1_pos: missing"),
        "{unpositioned}"
    );
    let malformed = error(&printer_cfg("").replacen("height0_pos = ", "height0_pos = 1,x,", 1));
    assert!(
        malformed.contains("line 27: [delta_calibrate] height0_pos: '1,x,"),
        "{malformed}"
    );
    let no_steps = error(&printer_cfg("").replace("rotation_distance: 40\n", ""));
    assert!(
        no_steps.contains("no rotation_distance in [stepper_a]"),
        "{no_steps}"
    );
    let microsteps = error(&printer_cfg("").replacen("microsteps: 16", "microsteps: 0", 1));
    assert!(
        microsteps.starts_with(
            "printer.cfg: line 8: [stepper_a] microsteps: 0 is not a positive integer"
        ),
        "{microsteps}"
    );
    let gears = error(&printer_cfg("").replace("2:1", "2:0"));
    assert!(gears.contains("[stepper_b] gear_ratio: '2:0'"), "{gears}");
    let far = error(&printer_cfg("").replace("distance0_pos2 = ", "distance0_pos2 = 90000"));
    assert!(
        far.contains("line 34: [delta_calibrate] stable position"),
        "{far}"
    );
}
