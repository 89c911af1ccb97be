//! Results do not depend on the number of threads (bit for bit) nor on the
//! order of the rows of measurements.csv (to rounding).

use parcal_calibrate::{CalibrationOptions, CalibrationRun, PriorMode, Simulation, calibrate};
use parcal_dataset::Dataset;
use parcal_simulate::{Scenario, simulate};

fn run(dataset: &Dataset, threads: usize) -> CalibrationRun {
    let options = CalibrationOptions {
        prior: PriorMode::Propagated,
        ..CalibrationOptions::simulation(Simulation::IV)
    };
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap();
    pool.install(|| calibrate(dataset, &options, &mut |_| {}).unwrap())
}

#[test]
fn one_and_two_threads_give_identical_bits() {
    // 300 balls: several chunks of groups, so that the threads share work.
    let dataset = simulate(&Scenario::scaled(300, 7, 10f64.to_radians()), 4)
        .unwrap()
        .dataset;
    let (one, two) = (run(&dataset, 1), run(&dataset, 2));
    assert!(one.converged());
    assert_eq!(one.params, two.params);
    assert_eq!(one.covariance, two.covariance);
    assert_eq!(one.centres, two.centres);
    let costs = |r: &CalibrationRun| {
        r.history
            .iter()
            .map(|h| h.cost.to_bits())
            .collect::<Vec<_>>()
    };
    assert_eq!(costs(&one), costs(&two));
    // And run to run.
    assert_eq!(run(&dataset, 2).params, two.params);
}

#[test]
fn shuffled_rows_give_the_same_calibration() {
    let dataset = simulate(&Scenario::scaled(300, 7, 10f64.to_radians()), 5)
        .unwrap()
        .dataset;
    let reference = run(&dataset, 2);
    // A fixed permutation of the rows (truth contacts follow their rows).
    let n = dataset.measurements.q.len();
    let permutation: Vec<usize> = (0..n).map(|k| (k * 7919 + 13) % n).collect();
    let mut sorted = permutation.clone();
    sorted.sort_unstable();
    assert!(
        sorted.iter().enumerate().all(|(k, &p)| k == p),
        "not a permutation"
    );
    let mut shuffled = dataset.clone();
    shuffled.measurements.q = permutation
        .iter()
        .map(|&k| dataset.measurements.q[k])
        .collect();
    shuffled.measurements.ball = permutation
        .iter()
        .map(|&k| dataset.measurements.ball[k])
        .collect();
    let result = run(&shuffled, 2);
    let scale = reference.params.norm();
    let difference = (result.params - reference.params).norm() / scale;
    assert!(difference < 1e-9, "relative difference {difference:e}");
    let sigmas = (reference.sigmas().unwrap() - result.sigmas().unwrap()).amax()
        / reference.sigmas().unwrap().amax();
    assert!(sigmas < 1e-9, "sigma difference {sigmas:e}");
}
