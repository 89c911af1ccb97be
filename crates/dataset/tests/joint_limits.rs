//! machine.json's optional `joint_limits`: read and written back, absent in
//! v1 files, and bad values refused naming the field.

use crate::common;

use common::*;
use parcal_dataset::*;

fn limits() -> JointLimitsRecord {
    JointLimitsRecord {
        base_deg: Some(40.0),
        platform_deg: Some(35.0),
        base_axes: None,
        platform_axes: Some([[0.0, 0.0, 2.0]; 6]),
    }
}

#[test]
fn joint_limits_round_trip_and_are_absent_by_default() {
    let files = written(NONE);
    let read = Dataset::read(files.path()).unwrap();
    assert_eq!(read.machine.joint_limits, None);
    let text = std::fs::read_to_string(files.path().join(MACHINE_FILE)).unwrap();
    assert!(!text.contains("joint_limits"), "{text}");

    let mut d = dataset(NONE);
    d.machine.joint_limits = Some(limits());
    let dir = tempfile::tempdir().unwrap();
    d.write(dir.path()).unwrap();
    let read = Dataset::read(dir.path()).unwrap();
    assert_eq!(read.machine.joint_limits, Some(limits()));
    let text = std::fs::read_to_string(dir.path().join(MACHINE_FILE)).unwrap();
    assert!(!text.contains("base_axes"), "absent fields are left out");
    // A binary snapshot holds every field.
    let snapshot = dir.path().join("d.parcal");
    d.write_snapshot(&snapshot).unwrap();
    let back = Dataset::read_snapshot(&snapshot).unwrap();
    assert_eq!(back.machine.joint_limits, Some(limits()));
    // Axes are normalised, absent ones +z, degrees become radians.
    let l = limits().limits();
    assert_eq!(l.platform_axes[3], parcal_kinematics::Vec3::z());
    assert_eq!(l.base_axes[0], parcal_kinematics::Vec3::z());
    assert!((l.base.unwrap() - 40f64.to_radians()).abs() < 1e-15);
}

/// A damage to the limits and the message it gets.
type Case = (fn(&mut JointLimitsRecord), &'static str);

#[test]
fn bad_joint_limits_are_refused_naming_the_field() {
    let cases: [Case; 5] = [
        (
            |l| l.base_deg = Some(0.0),
            "field joint_limits.base_deg: must be an angle in (0, 180] degrees, found 0",
        ),
        (
            |l| l.platform_deg = Some(200.0),
            "field joint_limits.platform_deg: must be an angle in (0, 180] degrees, found 200",
        ),
        (
            |l| {
                l.base_deg = None;
                l.platform_deg = None;
                l.platform_axes = None;
            },
            "field joint_limits.base_deg: joint_limits needs base_deg, platform_deg or both",
        ),
        (
            |l| l.platform_axes.as_mut().unwrap()[2] = [0.0; 3],
            "field joint_limits.platform_axes[2]: an axis must not be zero",
        ),
        (
            |l| {
                l.base_deg = None;
                l.base_axes = Some([[0.0, 0.0, 1.0]; 6]);
            },
            "field joint_limits.base_axes: given without base_deg",
        ),
    ];
    for (damage, message) in cases {
        let mut d = dataset(NONE);
        let mut record = limits();
        damage(&mut record);
        d.machine.joint_limits = Some(record);
        assert_eq!(
            d.validate().unwrap_err().to_string(),
            format!("{MACHINE_FILE}: {message}")
        );
        // The reader says the same of the file.
        let files = written(NONE);
        edit_json(files.path(), MACHINE_FILE, |v| {
            v["joint_limits"] = serde_json::to_value(record).unwrap();
        });
        assert_eq!(
            read_error(files.path()),
            format!("{}: {message}", files.path().join(MACHINE_FILE).display())
        );
    }
}
