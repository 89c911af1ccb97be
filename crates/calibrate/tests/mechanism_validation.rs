//! A delta calibration validated on held-out data
//! (`parcal_calibrate::mechanism::validate_mechanism`) and applied to
//! target positions (`compensate_mechanism`), on printers simulated by
//! `parcal_simulate::delta`: the false-alarm rate on data of the same
//! printer, the rejection of a printer whose rod changed (and the change
//! named), and the compensated commands' error against the calibration's
//! predicted uncertainty.

use nalgebra::{DVector, Matrix3, Vector3};
use parcal_calibrate::mechanism::{
    CalibratedMechanism, MechanismData, MechanismOptions, MechanismValidation, calibrate_mechanism,
    compensate_mechanism, validate_mechanism,
};
use parcal_dataset::mechanism::{MechanismDataset, MechanismTruth};
use parcal_kinematics::delta::{DeltaParams, LinearDelta};
use parcal_kinematics::mechanism::Mechanism;
use parcal_simulate::Rng;
use parcal_simulate::delta::{DeltaScenario, measure_delta, simulate_delta};

use crate::mean;

use mean::mean_and_standard_error;

/// The w-tests' level, the calibration's.
const ALPHA: f64 = 0.05;
/// The seed offset of the held-out measurements.
const HELD_OUT: u64 = 10_000;

/// A printer of the range (rods 250-300 mm, radius 120-150 mm),
/// probed on 3 rings of 8 and measured by 4 part distances.
fn scenario(seed: u64) -> DeltaScenario {
    let mut rng = Rng::new(seed, 1000);
    DeltaScenario {
        design: DeltaParams::symmetric(
            rng.uniform(250.0, 300.0),
            rng.uniform(120.0, 150.0),
            rng.uniform(280.0, 350.0),
        ),
        distances: 4,
        ..DeltaScenario::typical()
    }
}

fn data(dataset: &MechanismDataset) -> MechanismData {
    MechanismData::from_dataset(dataset).expect("a simulated dataset converts")
}

/// Printer `seed` calibrated, and its truth.
fn calibrated(seed: u64) -> (DeltaScenario, CalibratedMechanism, MechanismTruth) {
    let scenario = scenario(seed);
    let dataset = simulate_delta(&scenario, seed).unwrap();
    let run =
        calibrate_mechanism(&data(&dataset), &MechanismOptions::default(), &mut |_| {}).unwrap();
    assert!(run.converged(), "seed {seed}: {:?}", run.reasons);
    let calibrated = CalibratedMechanism::of_calibration(&run).unwrap();
    (scenario, calibrated, dataset.truth.unwrap())
}

/// Held-out measurements of `truth` with noise of seed `seed + HELD_OUT`.
fn validated(
    scenario: &DeltaScenario,
    calibrated: &CalibratedMechanism,
    truth: &MechanismTruth,
    seed: u64,
) -> MechanismValidation {
    let held_out = measure_delta(scenario, truth, seed + HELD_OUT).unwrap();
    validate_mechanism(calibrated, &data(&held_out), ALPHA, None).unwrap()
}

/// Over `draws` printers, each calibrated and validated on held-out data
/// of the same printer: the mean `T / n` with its standard error, and the
/// fractions rejected by the global test and by a w-test.
fn false_alarms(draws: u64) -> (f64, f64, f64, f64) {
    let mut ratios = Vec::new();
    let (mut global, mut w) = (0, 0);
    for seed in 0..draws {
        let (scenario, calibrated, truth) = calibrated(seed);
        let validation = validated(&scenario, &calibrated, &truth, seed);
        ratios.push(validation.statistic / validation.rows.len() as f64);
        global += usize::from(!validation.global_test_passes());
        w += usize::from(validation.failing_rows().next().is_some());
    }
    let (mean, standard_error) = mean_and_standard_error(&ratios);
    let rate = |k: usize| k as f64 / draws as f64;
    (mean, standard_error, rate(global), rate(w))
}

#[test]
fn held_out_data_of_the_same_printer_fit_their_predicted_covariance() {
    // T = rᵀ C⁻¹ r is χ²(n) under the model: E[T / n] = 1.
    let (mean, standard_error, global, w) = false_alarms(30);
    eprintln!(
        "30 printers: mean T/n {mean:.4} +- {standard_error:.4}; rejected by the global test {:.1} %, by a w-test {:.1} %",
        100.0 * global,
        100.0 * w
    );
    assert!(
        (mean - 1.0).abs() < 4.0 * standard_error,
        "mean T/n {mean:.4} +- {standard_error:.4}"
    );
}

#[test]
fn held_out_heights_measured_by_hand_fit_their_predicted_covariance() {
    // Heights measured by hand (manual heights, σ 50 µm) on the centre and a
    // ring of 8 at 60 mm, 5 mm up, of each calibrated printer: their rows
    // are predicted without the trigger height, T/n of mean 1.
    const SIGMA: f64 = 0.05;
    let commanded: Vec<[f64; 3]> = std::iter::once([0.0, 0.0, 5.0])
        .chain((0..8).map(|k| {
            let (sin, cos) = (k as f64 * std::f64::consts::FRAC_PI_4).sin_cos();
            [60.0 * cos, 60.0 * sin, 5.0]
        }))
        .collect();
    let mut ratios = Vec::new();
    for seed in 0..30 {
        let (scenario, calibrated, truth) = calibrated(seed);
        let mut held_out = measure_delta(&scenario, &truth, seed + HELD_OUT).unwrap();
        let delta: LinearDelta = scenario.delta();
        let mut noise = Rng::new(seed + HELD_OUT, 77);
        let configured = held_out.machine.configured.clone();
        held_out.heights = (commanded.iter())
            .map(|&[x, y, z]| {
                let q = delta.inverse(&configured, &[x, y, z]).unwrap();
                let reached = delta
                    .forward(&truth.parameters, q.as_slice(), &[x, y, z])
                    .unwrap();
                [x, y, z, reached[2] + noise.normal(SIGMA)]
            })
            .collect();
        held_out.probes.clear();
        held_out.distances.clear();
        held_out.machine.noise.height = Some(SIGMA);
        let validation = validate_mechanism(&calibrated, &data(&held_out), ALPHA, None).unwrap();
        assert_eq!(validation.rows.len(), commanded.len());
        ratios.push(validation.statistic / validation.rows.len() as f64);
    }
    let (mean, standard_error) = mean_and_standard_error(&ratios);
    eprintln!("manual heights, 30 printers x 9: mean T/n {mean:.4} +- {standard_error:.4}");
    assert!(
        (mean - 1.0).abs() < 4.0 * standard_error,
        "mean T/n {mean:.4} +- {standard_error:.4}"
    );
}

#[test]
#[ignore = "400 printers: cargo test -p parcal-calibrate --test integration mechanism_validation:: -- --ignored --nocapture"]
fn false_alarm_rates_over_400_printers() {
    let (mean, standard_error, global, w) = false_alarms(400);
    let se = |p: f64| (p * (1.0 - p) / 400.0).sqrt();
    eprintln!(
        "400 printers: mean T/n {mean:.4} +- {standard_error:.4}; rejected by the global test {:.2} % (nominal 2.5 +- {:.2} %), by a w-test {:.2} % (nominal at most 5 +- {:.2} %)",
        100.0 * global,
        100.0 * se(0.025),
        100.0 * w,
        100.0 * se(0.05)
    );
    assert!((mean - 1.0).abs() < 4.0 * standard_error);
    assert!((global - 0.025).abs() < 4.0 * se(0.025));
}

#[test]
fn a_rod_0_3_mm_longer_is_rejected_and_named() {
    let seed = 7;
    let (scenario, calibrated, truth) = calibrated(seed);
    let same = validated(&scenario, &calibrated, &truth, seed);
    let mut changed = truth.clone();
    changed.parameters[11] += 0.3; // diagonal_a
    let validation = validated(&scenario, &calibrated, &changed, seed);
    let test = validation.test.unwrap();
    eprintln!(
        "same printer: T/n {:.3}, accepted {}; rod A 0.3 mm longer: T/n {:.3} (F {:.3}, interval {:.3}-{:.3}), accepted {}; shifts {:#?}",
        same.statistic / same.rows.len() as f64,
        same.accepted(),
        validation.statistic / validation.rows.len() as f64,
        test.ratio,
        test.interval.0,
        test.interval.1,
        validation.accepted(),
        validation.shifts
    );
    assert!(same.accepted());
    assert!(!validation.accepted() && test.rejects());
    let best = &validation.shifts[0];
    assert_eq!(best.name, "diagonal_a");
    assert!(
        (best.shift - 0.3).abs() < 4.0 * best.sigma,
        "{} +- {}",
        best.shift,
        best.sigma
    );
    assert!(!best.test.unwrap().rejects());
}

#[test]
fn compensated_commands_reach_the_targets_within_the_predicted_uncertainty() {
    // The true printer (canonical frame, as the calibration's) driven by
    // the compensated commands: its error eᵀ Cov(x)⁻¹ e over the 3
    // coordinates has mean 3 (per draw, the mean over the targets, which
    // share the calibration's error).
    let targets: Vec<[f64; 3]> = (0..12)
        .map(|k| {
            let angle = k as f64 * 0.9;
            let r = 15.0 + 7.0 * k as f64;
            [r * angle.cos(), r * angle.sin(), 5.0 + 12.0 * k as f64]
        })
        .collect();
    let mut nees = Vec::new();
    let mut nominal_error: f64 = 0.0;
    let mut calibrated_error: f64 = 0.0;
    for seed in 0..30 {
        let (scenario, calibrated, truth) = calibrated(seed);
        let delta: LinearDelta = scenario.delta();
        let true_params = delta.canonicalize(&truth.parameters).unwrap();
        let mut sum = 0.0;
        for (target, compensation) in
            targets
                .iter()
                .zip(compensate_mechanism(&calibrated, &targets, &[]))
        {
            let compensation = compensation.unwrap();
            let reached = |q: &DVector<f64>| {
                let x = delta
                    .forward(true_params.as_slice(), q.as_slice(), target)
                    .unwrap();
                Vector3::new(x[0], x[1], x[2]) - Vector3::from(*target)
            };
            let error = reached(&compensation.readings);
            let covariance: Matrix3<f64> = compensation.covariance.fixed_view::<3, 3>(0, 0).into();
            sum += error.dot(&(covariance.try_inverse().unwrap() * error));
            calibrated_error = calibrated_error.max(error.norm());
            nominal_error = nominal_error.max(reached(&compensation.nominal).norm());
        }
        nees.push(sum / targets.len() as f64);
    }
    let (mean, standard_error) = mean_and_standard_error(&nees);
    eprintln!(
        "compensation over 30 printers x 12 targets: mean eᵀC⁻¹e {mean:.3} +- {standard_error:.3} (expected 3); largest error {calibrated_error:.4} mm compensated, {nominal_error:.4} mm nominal"
    );
    assert!((mean - 3.0).abs() < 4.0 * standard_error);
    assert!(calibrated_error < nominal_error);
}

#[test]
fn an_unreachable_target_is_named() {
    let (_, calibrated, _) = calibrated(1);
    let results = compensate_mechanism(&calibrated, &[[0.0, 0.0, 10.0], [400.0, 0.0, 10.0]], &[]);
    assert!(results[0].is_ok());
    let error = results[1].as_ref().unwrap_err().to_string();
    assert!(
        error.contains("unreachable") || error.contains("radius"),
        "{error}"
    );
}

/// A validation of more observations than the threads whiten at a time
/// (1 + 12 x 100 probe heights) and of balls predicted on the threads (40,
/// 7 touches each) is the same, bit for bit, on 1, 2 and 3 threads.
#[test]
fn a_validation_is_the_same_on_any_number_of_threads() {
    let (scenario, calibrated, truth) = calibrated(3);
    let many = DeltaScenario {
        rings: 12,
        per_ring: 100,
        balls: 40,
        ..scenario
    };
    let held_out = data(&measure_delta(&many, &truth, 3 + HELD_OUT).unwrap());
    assert!(held_out.observations.probes.len() > 1200);
    assert_eq!(held_out.observations.touches.len(), 40 * 7);
    let on = |threads| {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        pool.install(|| validate_mechanism(&calibrated, &held_out, ALPHA, None).unwrap())
    };
    let one = on(1);
    // Each ball's seven touches less its centre's three unknowns.
    let o = &held_out.observations;
    assert_eq!(one.rows.len(), o.probes.len() + o.distances.len() + 40 * 4);
    for threads in [2, 3] {
        assert_eq!(on(threads), one, "{threads} threads");
    }
}
