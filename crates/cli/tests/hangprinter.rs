//! The Hangprinter end to end: its real data (`fixtures/hangprinter`)
//! calibrated, exported as the firmware's `M669`/`M666 R` lines and read
//! back; a cable robot's calibration refused by a delta's format.

mod common;

use std::fs;

use common::{copy_fixture, fails, ok, s};
use parcal_firmware::hangprinter::read_config;

#[test]
fn calibrate_export_reads_back_the_anchors_and_radii() {
    let dir = tempfile::tempdir().unwrap();
    let data = copy_fixture("hangprinter", dir.path(), &["machine.json", "points.csv"]);
    let summary = ok(&["calibrate", s(&data)]);
    assert!(summary.contains("accepted"), "{summary}");
    let calibration = data.join("calibration.json");
    let out = dir.path().join("anchors.g");
    ok(&[
        "export",
        "--calibration",
        s(&calibration),
        "--format",
        "hangprinter",
        "--out",
        s(&out),
    ]);
    let back = read_config(&out).unwrap();
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
    // Anchors relative to the encoder zero, written to 0.01 mm; radii to
    // 0.001 mm: read back within half a step.
    for (j, letter) in ["a", "b", "c", "d"].iter().enumerate() {
        for (k, axis) in ["x", "y", "z"].iter().enumerate() {
            let calibrated =
                value(&format!("anchor_{letter}_{axis}")) - value(&format!("zero_{axis}"));
            let read = back.anchors[j][k];
            assert!(
                (calibrated - read).abs() <= 0.005 + 1e-9,
                "{letter} {axis}: {calibrated} vs {read}"
            );
        }
        let radius = value(&format!("radius_{letter}"));
        assert!((radius - back.spool_radii[j]).abs() <= 0.0005 + 1e-9);
    }
    let error = fails(&[
        "export",
        "--calibration",
        s(&calibration),
        "--format",
        "klipper",
        "--print-radius",
        "100",
        "--out",
        s(&dir.path().join("printer.cfg")),
    ]);
    assert!(error.contains("a cable robot calibration"), "{error}");
}
