//! The Hangprinter's calibration (`fixtures/hangprinter`, its
//! machine.json's model) validated on the 32 positions the author
//! discarded (`untrusted.csv`): each a point sample whose readings are
//! those of its row of `points.csv` and whose measured position is
//! hp-mark's, as `parcal validate` reads them (docs/cable-robots.md).

use std::path::{Path, PathBuf};

use parcal_calibrate::mechanism::{
    CalibratedMechanism, MechanismData, MechanismOptions, MechanismValidation, calibrate_mechanism,
    validate_mechanism,
};
use parcal_dataset::mechanism::{MechanismDataset, SampleRow};

fn fixture(file: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../fixtures/hangprinter")
        .join(file)
}

/// The held-out dataset: the fixture's machine, and one sample per row of
/// untrusted.csv, its readings from points.csv.
fn held_out(dataset: &MechanismDataset, position_sigma: f64) -> MechanismDataset {
    let text = std::fs::read_to_string(fixture("untrusted.csv")).unwrap();
    let samples = text
        .lines()
        .skip(1)
        .map(|line| {
            let f: Vec<f64> = line.split(',').map(|v| v.parse().expect(line)).collect();
            SampleRow {
                readings: dataset.samples[f[0] as usize].readings.clone(),
                position: Some([f[1], f[2], f[3]]),
                loads: None,
            }
        })
        .collect();
    let mut machine = dataset.machine.clone();
    machine.noise.position = Some(position_sigma);
    MechanismDataset {
        machine,
        samples,
        ..MechanismDataset::default()
    }
}

fn validated(calibrated: &CalibratedMechanism, held_out: &MechanismDataset) -> MechanismValidation {
    let data = MechanismData::from_dataset(held_out).unwrap();
    validate_mechanism(calibrated, &data, 0.05, None).unwrap()
}

/// The RMS of the 3D distances between predicted and measured positions.
fn distance_rms(validation: &MechanismValidation) -> f64 {
    let squares: f64 = validation.rows.iter().map(|r| r.residual.powi(2)).sum();
    (squares / (validation.rows.len() / 3) as f64).sqrt()
}

#[test]
fn the_discarded_positions_are_five_millimetres_off_and_rejected() {
    let dataset = MechanismDataset::read(&fixture("")).unwrap();
    let data = MechanismData::from_dataset(&dataset).unwrap();
    let run = calibrate_mechanism(&data, &MechanismOptions::default(), &mut |_| {}).unwrap();
    assert!(run.verdict.accepted, "{:?}", run.reasons);
    let calibrated = CalibratedMechanism::of_calibration(&run).unwrap();
    // hp-mark's positions at the fixture's 0.1 mm.
    let stated = validated(&calibrated, &held_out(&dataset, 0.1));
    let rms = distance_rms(&stated);
    let worst = stated.worst().unwrap();
    eprintln!(
        "32 discarded positions at 0.1 mm: 3D RMS {rms:.3} mm, T/n {:.1}, accepted {}, {} rows fail their w-test, the worst {} row {} w = {:.1}",
        stated.statistic / stated.rows.len() as f64,
        stated.accepted(),
        stated.failing_rows().count(),
        worst.observation,
        worst.row,
        worst.w
    );
    assert_eq!(stated.rows.len(), 96);
    assert!(!stated.accepted() && stated.test.unwrap().rejects());
    // The forward kinematics of the calibration puts them 5.04 mm RMS
    // away (docs/cable-robots.md); the readings' least-squares pose as
    // far, within its difference from the line lengths' least squares.
    assert!((4.8..5.31).contains(&rms), "{rms}");
    // The noise hp-mark's positions would need for the calibration to
    // predict them: the smallest of a few that passes.
    let passing = [1.0, 2.0, 3.0, 4.0, 5.0]
        .into_iter()
        .map(|sigma| (sigma, validated(&calibrated, &held_out(&dataset, sigma))))
        .inspect(|(sigma, v)| {
            eprintln!(
                "at {sigma} mm: T/n {:.3}, F {:.3} in [{:.3}, {:.3}], accepted {}",
                v.statistic / v.rows.len() as f64,
                v.test.unwrap().ratio,
                v.test.unwrap().interval.0,
                v.test.unwrap().interval.1,
                v.accepted()
            )
        })
        .find(|(_, v)| v.accepted());
    assert!(passing.is_some());
}
