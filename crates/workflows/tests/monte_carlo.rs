//! Is the posterior covariance honest? Simulation IV with the propagated
//! prior over many noise seeds of ONE truth (the paper's: `Scenario::paper()`
//! fixes the true geometry; the seed draws the noise, the calibrated radii,
//! the contact directions and the tilts). The NEES of the 33,
//! `(p^ - p)^T Sigma^-1 (p^ - p)`, is chi-square(33) when the covariance is
//! honest: its mean over the seeds must lie within 4 standard errors of 33
//! (the standard error from the seeds' own spread). The radius error is
//! taken per contact, as the paper's simulations do; `radius_model.rs`
//! tests the per-ball radius.

// Index loops over several arrays read best.
#![allow(clippy::needless_range_loop)]

use std::time::Instant;

use parcal_calibrate::{CalibrationOptions, PriorMode, Simulation, calibrate};
use parcal_kinematics::{N_PARAMS, PARAM_NAMES};
use parcal_simulate::{Scenario, simulate};
use parcal_workflows::evaluate::TrueMachine;

/// Noise seeds (the brief asks for at least 50; the paper scenario's
/// calibrations are small, so more are affordable).
const SEEDS: u64 = 200;
/// The mean NEES must lie within this many of its standard errors of 33
/// (the number of parameters). An honest covariance fails this with
/// probability about 6e-5.
const STANDARD_ERRORS: f64 = 4.0;

#[test]
fn mean_nees_of_simulation_iv_propagated_is_chi_square_33() {
    let start = Instant::now();
    let scenario = Scenario::paper();
    let options = CalibrationOptions {
        prior: PriorMode::Propagated,
        ..CalibrationOptions::simulation(Simulation::IV)
    };
    let mut nees = Vec::new();
    let mut failures = Vec::new();
    // Per-parameter sums of (error / sigma)^2 (1 each when honest).
    let mut z2 = [0.0; N_PARAMS];
    let mut truth_params = None;
    for seed in 1..=SEEDS {
        let dataset = simulate(&scenario, seed).expect("simulation").dataset;
        let truth = TrueMachine::of(&dataset)
            .expect("simulated truth")
            .expect("canonical truth");
        // One truth for every seed.
        match &truth_params {
            None => truth_params = Some(truth.params),
            Some(p) => assert_eq!(*p, truth.params, "seed {seed}: the truth changed"),
        }
        let run = calibrate(&dataset, &options, &mut |_| {}).expect("calibration");
        if !run.converged() {
            failures.push(format!("seed {seed}: {:?}", run.status));
            continue;
        }
        let covariance = run.covariance.expect("covariance of a converged run");
        match truth.nees(&run.params, &covariance) {
            Some(v) if v.is_finite() => nees.push(v),
            other => failures.push(format!("seed {seed}: NEES {other:?}")),
        }
        let sigmas = run.sigmas().expect("sigmas");
        for k in 0..N_PARAMS {
            z2[k] += ((run.params[k] - truth.params[k]) / sigmas[k]).powi(2);
        }
    }
    let n = nees.len() as f64;
    let mean = nees.iter().sum::<f64>() / n;
    let sd = (nees.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1.0)).sqrt();
    let mut sorted = nees.clone();
    sorted.sort_by(f64::total_cmp);
    let quantile = |q: f64| sorted[((q * (n - 1.0)).round() as usize).min(sorted.len() - 1)];
    // 95 % quantile of chi-square(33).
    let beyond = nees.iter().filter(|&&v| v > 47.40).count();
    println!(
        "IV propagated, {} seeds: mean NEES {mean:.2} (expected 33, standard error {:.2}), \
         sd {sd:.2} (chi-square(33): {:.2}), min {:.1}, 5% {:.1}, median {:.1}, 95% {:.1}, max {:.1}; \
         {beyond} above the chi-square(33) 95% quantile 47.4 (expected {:.0}); {:.1} s",
        nees.len(),
        sd / n.sqrt(),
        66f64.sqrt(),
        sorted[0],
        quantile(0.05),
        quantile(0.5),
        quantile(0.95),
        sorted[sorted.len() - 1],
        0.05 * n,
        start.elapsed().as_secs_f64(),
    );
    let per_parameter: Vec<String> = PARAM_NAMES
        .iter()
        .zip(z2)
        .map(|(name, s)| format!("{name} {:.2}", s / n))
        .collect();
    println!(
        "mean (error/sigma)^2 per parameter: {}",
        per_parameter.join(", ")
    );
    assert!(failures.is_empty(), "{}", failures.join("\n"));
    let standard_error = sd / n.sqrt();
    assert!(
        (mean - N_PARAMS as f64).abs() <= STANDARD_ERRORS * standard_error,
        "mean NEES {mean:.2} over {} seeds is more than {STANDARD_ERRORS} standard errors \
         ({standard_error:.2}) from {N_PARAMS}",
        nees.len(),
    );
}
