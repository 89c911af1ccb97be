//! Correctness at scale: 10^5 contacts (14 286 balls, 7 contacts each, tilts
//! up to 10 degrees, seed 1; simulation IV with the propagated prior, the
//! benches' case). The calibration converges, does not depend on the order
//! of the measurement rows, and recovers each of the 33 true canonical
//! parameters within 3 sigma of its reported uncertainty.

use crate::common;

use std::sync::OnceLock;
use std::time::Instant;

use common::{options, relative_differences, shuffled};
use parcal_calibrate::{CalibrationRun, calibrate};
use parcal_dataset::Dataset;
use parcal_kinematics::PARAM_NAMES;
use parcal_simulate::{Scenario, simulate};
use parcal_workflows::evaluate::TrueMachine;

/// The simulated campaign and its calibration, shared by the tests.
fn case() -> &'static (Dataset, CalibrationRun) {
    static CASE: OnceLock<(Dataset, CalibrationRun)> = OnceLock::new();
    CASE.get_or_init(|| {
        let start = Instant::now();
        let scenario = Scenario::scaled(14_286, 7, 10f64.to_radians());
        let dataset = simulate(&scenario, 1).expect("simulation").dataset;
        assert_eq!(dataset.measurements.len(), 100_002);
        let simulated = start.elapsed().as_secs_f64();
        let run = calibrate(&dataset, &options(), &mut |_| {}).expect("calibration");
        println!(
            "10^5 contacts: simulated in {simulated:.2} s, calibrated in {:.2} s \
             ({} records, condition number {:.2e})",
            start.elapsed().as_secs_f64() - simulated,
            run.history.len(),
            run.condition_number().unwrap_or(f64::NAN)
        );
        (dataset, run)
    })
}

#[test]
fn a_hundred_thousand_contacts_converge() {
    let (_, run) = case();
    assert!(run.converged(), "{:?}", run.status);
}

#[test]
fn a_hundred_thousand_shuffled_rows_give_the_same_calibration() {
    let (dataset, reference) = case();
    let start = Instant::now();
    let result = calibrate(&shuffled(dataset), &options(), &mut |_| {}).expect("calibration");
    println!(
        "shuffled rows calibrated in {:.2} s",
        start.elapsed().as_secs_f64()
    );
    assert!(result.converged(), "{:?}", result.status);
    let (params, sigmas) = relative_differences(reference, &result);
    println!("relative difference: parameters {params:.2e}, sigmas {sigmas:.2e}");
    assert!(params < 1e-9, "relative difference {params:e}");
    // The sigmas come from the inverse of the reduced 33 x 33 matrix, whose
    // condition number (~1e7 here) amplifies the rounding of sums taken in
    // another order: eps x 1e7 ~ 2e-9. The parameters are a fixed point of
    // the iteration and do not inherit it (the test prints both).
    assert!(sigmas < 1e-7, "sigma difference {sigmas:e}");
}

#[test]
fn a_hundred_thousand_contacts_recover_the_truth_within_3_sigma() {
    let (dataset, run) = case();
    assert!(run.converged(), "{:?}", run.status);
    let truth = TrueMachine::of(dataset)
        .expect("simulated truth")
        .expect("canonical truth");
    let sigmas = run.sigmas().expect("sigmas of a converged run");
    let mut outside = Vec::new();
    for (k, name) in PARAM_NAMES.iter().enumerate() {
        let error = run.params[k] - truth.params[k];
        let z = error / sigmas[k];
        println!(
            "{name:>6}: estimate {:14.6}, truth {:14.6}, error {error:+.3e}, sigma {:.3e}, error/sigma {z:+.2}",
            run.params[k], truth.params[k], sigmas[k]
        );
        if z.is_nan() || z.abs() > 3.0 {
            outside.push(format!(
                "{name}: error {error:+.3e} mm, sigma {:.3e} mm, {z:+.2} sigma",
                sigmas[k]
            ));
        }
    }
    assert!(
        outside.is_empty(),
        "beyond 3 sigma of the truth:\n{}",
        outside.join("\n")
    );
}
