//! The report of a hexapod calibrated through the common mechanism
//! interface: its record, rendered as any mechanism's, names the hexapod,
//! its 33 parameters, its balls and its verdict.

use std::path::Path;

use parcal_calibrate::mechanism::{MechanismData, MechanismOptions, calibrate_mechanism};
use parcal_calibrate::{CalibrationOptions, Simulation};
use parcal_dataset::Dataset;
use parcal_report::calibration_report::Format;
use parcal_report::mechanism::render;

#[test]
fn a_hexapods_common_calibration_is_reported_as_any_mechanisms() {
    let fixture = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../fixtures/paper-seed1");
    let dataset = Dataset::read(&fixture).unwrap();
    let options = CalibrationOptions::simulation(Simulation::III);
    let data = MechanismData::from_hexapod_touches(&dataset, &options).unwrap();
    let calibration =
        calibrate_mechanism(&data, &MechanismOptions::default(), &mut |_| {}).unwrap();
    let record = calibration.record();
    assert_eq!(record.mechanism, "hexapod");
    for format in [Format::Html, Format::Markdown] {
        let text = render(&record, "calibration.json", Default::default(), format).unwrap();
        assert!(text.contains("Calibration of a hexapod"), "{format:?}");
        // The parameters, by the mechanism's names (Markdown escapes `_`).
        for name in ["y_b2", "l_1", "z_e6", "z_eT"] {
            let written = match format {
                Format::Html => name.to_string(),
                Format::Markdown => name.replace('_', "\\_"),
            };
            assert!(text.contains(&written), "{format:?}: {name}");
        }
        let verdict = if calibration.verdict.accepted {
            "accepted"
        } else {
            "rejected"
        };
        assert!(
            text.to_lowercase().contains(verdict),
            "{format:?}: {verdict}"
        );
    }
}
