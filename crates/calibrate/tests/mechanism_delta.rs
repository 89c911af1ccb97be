//! The calibration of a linear delta through the `Mechanism` trait
//! (`parcal_calibrate::mechanism`), on printers simulated by
//! `parcal_simulate::delta`: the estimate's consistency with its
//! covariance (NEES), a probe blunder found by snooping, what probe
//! heights alone cannot determine and what a part distance adds, and
//! readings at unknown poses.

use nalgebra::{DMatrix, DVector};
use parcal_calibrate::mechanism::{
    MechanismCalibration, MechanismData, MechanismOptions, ObservationKind, ObservationRef,
    TRIGGER_HEIGHT, calibrate_mechanism,
};
use parcal_dataset::mechanism::MechanismDataset;
use parcal_kinematics::delta::DeltaParams;
use parcal_kinematics::mechanism::Mechanism;
use parcal_simulate::Rng;
use parcal_simulate::delta::{DeltaScenario, simulate_delta};

/// A printer of the range: rods 250-300 mm, radius 120-150 mm,
/// drawn from stream `seed`.
fn scenario(seed: u64, distances: usize) -> DeltaScenario {
    let mut rng = Rng::new(seed, 1000);
    DeltaScenario {
        design: DeltaParams::symmetric(
            rng.uniform(250.0, 300.0),
            rng.uniform(120.0, 150.0),
            rng.uniform(280.0, 350.0),
        ),
        distances,
        ..DeltaScenario::typical()
    }
}

fn calibrate(dataset: &MechanismDataset, options: &MechanismOptions) -> MechanismCalibration {
    let data = MechanismData::from_dataset(dataset).expect("a simulated dataset converts");
    calibrate_mechanism(&data, options).expect("a simulated printer calibrates")
}

/// The true unknowns in the canonical frame: the parameters
/// canonicalised, then the trigger height.
fn canonical_truth(dataset: &MechanismDataset) -> DVector<f64> {
    let truth = dataset.truth.as_ref().expect("simulated");
    let delta = parcal_kinematics::delta::LinearDelta::typical();
    let canonical = delta.canonicalize(&truth.parameters).unwrap();
    let mut values: Vec<f64> = canonical.iter().copied().collect();
    values.push(truth.trigger_height);
    DVector::from_vec(values)
}

/// `eᵀ Cov⁺ e` over the covariance's range, and its rank (eigenvalues
/// above 1e-9 of the largest: the gauge directions' are rounding noise).
fn nees(error: &DVector<f64>, covariance: &DMatrix<f64>) -> (f64, usize) {
    let eigen = covariance.clone().symmetric_eigen();
    let largest = eigen.eigenvalues.max();
    let mut nees = 0.0;
    let mut rank = 0;
    for (k, &lambda) in eigen.eigenvalues.iter().enumerate() {
        if lambda > 1e-9 * largest {
            rank += 1;
            nees += eigen.eigenvectors.column(k).dot(error).powi(2) / lambda;
        }
    }
    (nees, rank)
}

/// NEES over `draws` printers, with `distances` part distances each: the
/// mean, its standard error from the draws, and the identifiable count.
fn nees_over(draws: u64, distances: usize) -> (f64, f64, usize) {
    let mut values = Vec::new();
    let mut ranks = Vec::new();
    for seed in 0..draws {
        let dataset = simulate_delta(&scenario(seed, distances), seed).unwrap();
        let run = calibrate(&dataset, &MechanismOptions::default());
        assert!(run.converged(), "seed {seed}: {:?}", run.reasons);
        let error = run.values() - canonical_truth(&dataset);
        let (value, rank) = nees(&error, run.covariance.as_ref().unwrap());
        values.push(value);
        ranks.push(rank);
    }
    let n = values.len() as f64;
    let mean = values.iter().sum::<f64>() / n;
    let variance = values.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1.0);
    ranks.dedup();
    assert_eq!(ranks.len(), 1, "the identifiable count varies: {ranks:?}");
    (mean, (variance / n).sqrt(), ranks[0])
}

#[test]
fn nees_over_simulated_printers_matches_the_identifiable_count() {
    // 16 parameters and the trigger height, less the delta's 5 gauge
    // freedoms (its `gauge_freedoms`): 12 identifiable unknowns, the rank
    // of the canonical covariance (checked draw by draw). The true
    // printers are drawn from the priors, so the posterior covariance is
    // the error's: E[NEES] = 12.
    let delta = parcal_kinematics::delta::LinearDelta::typical();
    let gauge = delta.gauge_freedoms(&vec![0.0; 16]).map_or(5, |g| g.len());
    let expected = delta.parameters().len() + 1 - gauge;
    let (mean, standard_error, rank) = nees_over(30, 4);
    eprintln!("NEES over 30 printers: {mean:.3} +- {standard_error:.3} (rank {rank})");
    assert_eq!(rank, expected);
    assert!(
        (mean - expected as f64).abs() < 4.0 * standard_error,
        "mean NEES {mean:.3} +- {standard_error:.3}, expected {expected}"
    );
}

#[test]
fn explore() {
    for distances in [0, 4] {
        let dataset = simulate_delta(&scenario(3, distances), 3).unwrap();
        let run = calibrate(&dataset, &MechanismOptions::default());
        eprintln!("{:?}", run.reasons);
        for p in &run.parameters {
            eprintln!("{} {:.4} +- {:?}", p.name, p.value, p.sigma);
        }
        eprintln!("{:#?}", run.identifiability);
    }
}
