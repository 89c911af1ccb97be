//! Results do not depend on the number of threads (bit for bit) nor on the
//! order of the rows of measurements.csv (to rounding).

mod common;

use common::{options, relative_differences, shuffled};
use parcal_calibrate::{CalibrationRun, calibrate};
use parcal_dataset::Dataset;
use parcal_simulate::{Scenario, simulate};

fn run(dataset: &Dataset, threads: usize) -> CalibrationRun {
    let options = options();
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
    let result = run(&shuffled(&dataset), 2);
    let (params, sigmas) = relative_differences(&reference, &result);
    assert!(params < 1e-9, "relative difference {params:e}");
    assert!(sigmas < 1e-9, "sigma difference {sigmas:e}");
}
