//! parcal against the independent implementation's calibrations of the same
//! dataset (fixtures/reference-paper-seed1, its README says where it
//! comes from): same method and modelling choices, so the
//! identified values, sigmas and iteration counts must agree.

use std::path::{Path, PathBuf};

use parcal_calibrate::{CalibrationOptions, PriorMode, Simulation, calibrate};
use parcal_dataset::{Calibration, Dataset};
use parcal_solver::SIGMA_TOLERANCE;

fn fixture() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../fixtures/reference-paper-seed1")
}

/// Calibrates the reference dataset and compares with `reference_file`:
/// every value within 1e-4 of the reference sigma (the reference prints 16
/// digits; both solve the same equations to a step tolerance of 1e-10,
/// parcal's sigma rule off), every sigma within 1e-6 relative, the same
/// number of iterations. With the default stopping rule, which ends a
/// run whose step is below `SIGMA_TOLERANCE` standard deviations, every
/// value is within that many of the reference sigma.
fn compare(sim: Simulation, prior: PriorMode, reference_file: &str) {
    let dataset = Dataset::read(&fixture()).unwrap();
    let options = CalibrationOptions {
        prior,
        ..CalibrationOptions::simulation(sim)
    };
    let reference = Calibration::read(&fixture().join(reference_file)).unwrap();
    let default = calibrate(&dataset, &options, &mut |_| {}).unwrap();
    assert!(default.converged());
    let worst = (0..33)
        .map(|k| {
            ((default.params[k] - reference.parameters.values[k]) / reference.parameters.sigma[k])
                .abs()
        })
        .fold(0.0, f64::max);
    println!(
        "the sigma rule: {} iterations, worst |value - reference| {worst:.2e} sigma",
        default.iterations()
    );
    assert!(worst < SIGMA_TOLERANCE, "{worst:e} sigma");
    let options = CalibrationOptions {
        sigma_tolerance: 0.0,
        ..options
    };
    let run = calibrate(&dataset, &options, &mut |_| {}).unwrap();
    assert!(run.converged() && reference.converged);
    // The reference records the initial iterate and one per step, the
    // converged one included; parcal ends at the iterate whose step
    // certified convergence (`CalibrationRun::iterations`).
    assert_eq!(
        run.iterations(),
        reference.iterations.len() - 1,
        "Gauss-Newton iterations (linear solves)"
    );
    let sigmas = run.sigmas().unwrap();
    for k in 0..33 {
        let (name, theirs, their_sigma) = (
            &reference.parameters.names[k],
            reference.parameters.values[k],
            reference.parameters.sigma[k],
        );
        let normalised = (run.params[k] - theirs) / their_sigma;
        assert!(
            normalised.abs() < 1e-4,
            "{name}: ours {} theirs {theirs} ({normalised:+e} sigma)",
            run.params[k]
        );
        let ratio = sigmas[k] / their_sigma - 1.0;
        assert!(
            ratio.abs() < 1e-6,
            "{name}: sigma ours {} theirs {their_sigma}",
            sigmas[k]
        );
    }
    // The same weights: parcal keeps them in single precision, which moves
    // a whitened row by about 3 · 2⁻²⁴ relative at most (three rounded
    // terms), and |O| by no more; another weight model would move it by
    // orders of magnitude more.
    let first = run.history[0].cost.sqrt();
    let their_first = reference.iterations[0].cost.sqrt();
    assert!(
        (first / their_first - 1.0).abs() < 1.5 * f64::from(f32::EPSILON),
        "initial |O|: ours {first} theirs {their_first}"
    );
}

#[test]
fn simulation_iv_propagated_matches_the_reference() {
    compare(
        Simulation::IV,
        PriorMode::Propagated,
        "reference-IV-propagated.json",
    );
}

#[test]
fn simulation_iii_paper_matches_the_reference() {
    compare(
        Simulation::III,
        PriorMode::Paper,
        "reference-III-paper.json",
    );
}

/// Levenberg-Marquardt reaches the Gauss-Newton solution of the paper case
/// (the same minimum: within 1e-3 of every sigma).
#[test]
fn levenberg_marquardt_reaches_the_gauss_newton_solution() {
    let dataset = Dataset::read(&fixture()).unwrap();
    let gn_options = CalibrationOptions {
        prior: PriorMode::Propagated,
        ..CalibrationOptions::simulation(Simulation::IV)
    };
    let gn = calibrate(&dataset, &gn_options, &mut |_| {}).unwrap();
    let lm = calibrate(
        &dataset,
        &gn_options.clone().levenberg_marquardt(),
        &mut |_| {},
    )
    .unwrap();
    assert!(
        gn.converged() && lm.converged(),
        "{:?} / {:?}",
        gn.status,
        lm.status
    );
    let sigmas = gn.sigmas().unwrap();
    for k in 0..33 {
        assert!(
            ((lm.params[k] - gn.params[k]) / sigmas[k]).abs() < 1e-3,
            "parameter {k}"
        );
    }
    assert!(lm.history.iter().any(|r| r.lambda > 0.0));
}
