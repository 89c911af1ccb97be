//! RepRapFirmware's auto-calibration on simulated printers: noiseless probe
//! heights of a printer whose errors lie within the factor set are
//! recovered; errors outside it are reduced as far as the factors can.

use nalgebra::DVector;
use parcal_firmware::autocal::auto_calibrate;
use parcal_firmware::probes::ProbePoint;
use parcal_firmware::rrf::RrfDelta;
use parcal_kinematics::delta::{LinearDelta, probe_height, probe_rings};
use rand::rngs::StdRng;
use rand::{RngExt, SeedableRng};

/// A kit printer as its firmware knows it.
fn nominal() -> RrfDelta {
    RrfDelta {
        diagonals: [270.0; 3],
        radius: 135.0,
        homed_height: 300.0,
        print_radius: 110.0,
        ..RrfDelta::default()
    }
}

/// The heights `G30 S-1` reports on `truth` when the firmware holds
/// `firmware`, at 1 + 6 + 6 + 12 points out to 100 mm, plus `noise`.
fn probe(truth: &RrfDelta, firmware: &RrfDelta) -> Vec<ProbePoint> {
    let delta = LinearDelta::typical();
    let (t, f) = (
        truth.to_params().to_vector(),
        firmware.to_params().to_vector(),
    );
    let mut points = probe_rings(100.0, 2, 6);
    points.extend(
        probe_rings(100.0, 1, 12)
            .into_iter()
            .skip(1)
            .map(|[x, y]| [0.95 * x, 0.95 * y]),
    );
    points
        .into_iter()
        .map(|[x, y]| ProbePoint {
            x,
            y,
            z: probe_height(&delta, t.as_slice(), f.as_slice(), x, y).unwrap(),
        })
        .collect()
}

/// The parameters as one vector, endstops normalised to mean zero (the
/// firmware's gauge), for comparing.
fn normalised(rrf: &RrfDelta) -> DVector<f64> {
    let mean = rrf.endstop_adjustments.iter().sum::<f64>() / 3.0;
    let mut v = rrf.to_params();
    v.endstop = v.endstop.map(|e| e - mean);
    v.homed_height += mean;
    v.to_vector()
}

/// A true printer off `nominal` in the factors of an `n`-factor
/// calibration only, by a few tenths.
fn perturbed(rng: &mut StdRng, factors: usize) -> RrfDelta {
    let mut small = |scale: f64| rng.random_range(-scale..scale);
    let mut truth = nominal();
    truth.endstop_adjustments = [small(0.8), small(0.8), small(0.8)];
    truth.homed_height += small(1.0);
    if factors >= 4 {
        truth.radius += small(0.8);
    }
    if factors >= 6 {
        truth.angle_corrections[0] = small(0.4);
        truth.angle_corrections[1] = small(0.4);
    }
    if factors == 7 || factors == 9 {
        let dl = small(0.4);
        truth.diagonals = truth.diagonals.map(|l| l + dl);
    }
    if factors >= 8 {
        truth.tilt = [small(0.2), small(0.2)];
    }
    truth
}

#[test]
fn every_factor_set_recovers_a_printer_off_in_those_factors() {
    let mut rng = StdRng::seed_from_u64(36);
    for factors in [3, 4, 6, 7, 8, 9] {
        for _ in 0..3 {
            let truth = perturbed(&mut rng, factors);
            let result = auto_calibrate(&nominal(), &probe(&truth, &nominal()), factors).unwrap();
            let error = (normalised(&result.delta) - normalised(&truth)).amax();
            // Two Gauss-Newton steps from errors of a few tenths: the first
            // leaves errors of second order (~(0.5 mm)^2 / 270 mm ~ 1e-3),
            // the second of fourth order (~1e-6), well below the 1e-4 the
            // calibration lines are written to.
            assert!(error < 1e-4, "{factors} factors: parameter error {error:e}");
            assert!(
                result.deviation_after < 1e-5,
                "{factors} factors: {result:?}"
            );
            assert!(
                result.deviation_before > 0.01,
                "{factors} factors: {result:?}"
            );
        }
    }
}

#[test]
fn fewer_factors_than_errors_leave_a_deviation_the_full_set_removes() {
    // A rod error that 6 factors cannot see as such: they absorb what they
    // can into radius and endstops and leave a deviation; 7 factors remove it.
    let mut truth = nominal();
    truth.diagonals = truth.diagonals.map(|l| l + 0.4);
    truth.endstop_adjustments = [0.3, -0.2, 0.1];
    let probes = probe(&truth, &nominal());
    let six = auto_calibrate(&nominal(), &probes, 6).unwrap();
    let seven = auto_calibrate(&nominal(), &probes, 7).unwrap();
    assert!(six.deviation_after < six.deviation_before, "{six:?}");
    assert!(six.deviation_after > 1e-4, "{six:?}");
    assert!(seven.deviation_after < 1e-5, "{seven:?}");
    assert!(
        (seven.delta.diagonals[0] - truth.diagonals[0]).abs() < 1e-4,
        "{seven:?}"
    );
}

#[test]
fn refuses_what_the_firmware_refuses() {
    let probes = probe(&nominal(), &nominal());
    let err = auto_calibrate(&nominal(), &probes, 5).unwrap_err();
    assert_eq!(
        err.to_string(),
        "auto-calibration: 5 factors requested; RepRapFirmware calibrates 3, 4, 6, 7, 8 or 9"
    );
    let err = auto_calibrate(&nominal(), &probes[..5], 6).unwrap_err();
    assert_eq!(
        err.to_string(),
        "auto-calibration: 5 probe points cannot determine 6 factors"
    );
    let mut far = probes.clone();
    far[2].x = 400.0;
    let err = auto_calibrate(&nominal(), &far, 3).unwrap_err();
    assert!(err.to_string().contains("probe point 3 at (400"), "{err}");
    // All points at the centre: the endstops cannot be told apart.
    let centre = vec![
        ProbePoint {
            x: 0.0,
            y: 0.0,
            z: 0.1
        };
        5
    ];
    let err = auto_calibrate(&nominal(), &centre, 3).unwrap_err();
    assert!(err.to_string().contains("singular"), "{err}");
}
