//! RepRapFirmware's auto-calibration on simulated printers: noiseless probe
//! heights of a printer whose errors lie within the factor set are
//! recovered; errors outside it are reduced as far as the factors can.

use nalgebra::DVector;
use parcal_firmware::autocal::auto_calibrate;
use parcal_firmware::probes::ProbePoint;
use parcal_firmware::rrf::RrfDelta;
use parcal_kinematics::delta::{
    ANGLE, DIAGONAL, ENDSTOP, LinearDelta, RADIUS, probe_height, probe_height_jacobian, probe_rings,
};
use rand::rngs::StdRng;
use rand::{RngExt, SeedableRng};
use rand_distr::StandardNormal;

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

/// The probe points: 1 + 6 + 6 on two rings out to 100 mm, and 12 on a
/// ring at 95 mm.
fn points() -> Vec<[f64; 2]> {
    let mut points = probe_rings(100.0, 2, 6);
    points.extend(
        probe_rings(100.0, 1, 12)
            .into_iter()
            .skip(1)
            .map(|[x, y]| [0.95 * x, 0.95 * y]),
    );
    points
}

/// The heights `G30 S-1` reports on `truth` when the firmware holds
/// `firmware`, at [`points`].
fn probe(truth: &RrfDelta, firmware: &RrfDelta) -> Vec<ProbePoint> {
    let delta = LinearDelta::typical();
    let (t, f) = (
        truth.to_params().to_vector(),
        firmware.to_params().to_vector(),
    );
    points()
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
    eprintln!(
        "a 0.4 mm rod error: deviation {:.4} mm before, {:.4} mm after 6 factors (radius {:.3} mm)",
        six.deviation_before, six.deviation_after, six.delta.radius
    );
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
    let mut bad = probes.clone();
    bad[3].z = f64::NAN;
    let err = auto_calibrate(&nominal(), &bad, 3).unwrap_err();
    assert_eq!(
        err.to_string(),
        "auto-calibration: probe point 4 has a value that is not a finite number"
    );
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

#[test]
fn probe_noise_scatters_the_rods_as_the_linear_theory_predicts() {
    // 10 um of probe noise on a printer the firmware knows exactly. The
    // 7-factor fit is linear least squares to first order, so (i) the
    // residual sum of squares over sigma^2 is chi-square with n - 7 degrees
    // of freedom, and (ii) the common rod length scatters with the standard
    // deviation sigma sqrt([(J^T J)^-1]_LL), J the probe heights' Jacobian
    // (parcal-kinematics) in the directions the 7 factors span: the
    // endstops, the radius, the angles of towers X and Y, the three rods
    // together. Both checked over 400 draws, within 4 standard errors.
    const SIGMA: f64 = 0.010;
    const DRAWS: usize = 400;
    let truth = nominal();
    let clean = probe(&truth, &truth);
    let n = clean.len();
    let delta = LinearDelta::typical();
    let p = truth.to_params().to_vector();
    let full = probe_height_jacobian(&delta, p.as_slice(), &points()).unwrap();
    let mut jacobian = nalgebra::DMatrix::zeros(n, 7);
    for (column, k) in [ENDSTOP, ENDSTOP + 1, ENDSTOP + 2, RADIUS, ANGLE, ANGLE + 1]
        .into_iter()
        .enumerate()
    {
        jacobian.set_column(column, &full.column(k));
    }
    let rods = full.column(DIAGONAL) + full.column(DIAGONAL + 1) + full.column(DIAGONAL + 2);
    jacobian.set_column(6, &rods);
    let covariance = (jacobian.transpose() * &jacobian).try_inverse().unwrap();
    let predicted_rod_sigma = SIGMA * covariance[(6, 6)].sqrt();
    eprintln!(
        "7 factors, {n} points, probe noise {SIGMA} mm: rod length sigma {predicted_rod_sigma:.4} mm"
    );
    let mut rng = StdRng::seed_from_u64(2026);
    let (mut chi_square_sum, mut rod_sum, mut rod_square_sum) = (0.0, 0.0, 0.0);
    for _ in 0..DRAWS {
        let noisy: Vec<ProbePoint> = clean
            .iter()
            .map(|point| ProbePoint {
                z: point.z + SIGMA * rng.sample::<f64, _>(StandardNormal),
                ..*point
            })
            .collect();
        let result = auto_calibrate(&truth, &noisy, 7).unwrap();
        chi_square_sum += n as f64 * (result.deviation_after / SIGMA).powi(2);
        let rod_error = result.delta.diagonals[0] - truth.diagonals[0];
        rod_sum += rod_error;
        rod_square_sum += rod_error * rod_error;
    }
    let draws = DRAWS as f64;
    let dof = (n - 7) as f64;
    let chi_square_mean = chi_square_sum / draws;
    let chi_square_se = (2.0 * dof / draws).sqrt();
    assert!(
        (chi_square_mean - dof).abs() < 4.0 * chi_square_se,
        "mean chi-square {chi_square_mean} for {dof} degrees of freedom"
    );
    let mean = rod_sum / draws;
    let variance = (rod_square_sum - draws * mean * mean) / (draws - 1.0);
    let ratio = variance / predicted_rod_sigma.powi(2);
    assert!(
        (ratio - 1.0).abs() < 4.0 * (2.0 / (draws - 1.0)).sqrt(),
        "rod variance {variance:e} against {:e} predicted",
        predicted_rod_sigma.powi(2)
    );
}
