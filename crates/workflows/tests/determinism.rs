//! Results do not depend on the number of threads (bit for bit) nor on the
//! order of the rows of measurements.csv (to rounding).

use crate::common;

use common::{cost_bits, options, permutation, relative_differences, shuffled};
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
    assert_eq!(one.balls.centres, two.balls.centres);
    assert_eq!(cost_bits(&one), cost_bits(&two));
    // The checks of every observation too.
    assert!(one.reliability.is_some());
    assert_eq!(one.reliability, two.reliability);
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
    // Each contact's check is kept at its own row: row k of the shuffled
    // rows is row `permutation[k]` of the dataset.
    // Its redundancy depends on the geometry alone (rounding: 1e-9
    // allowed); its normalised residual on the residual too, which moves
    // with the parameters: their difference (1e-9 relative, about 4e-7 mm
    // on 400 mm) over a noise of some 10 um moves a whitened residual by
    // up to 4e-5 (1e-4 allowed).
    let (a, b) = (
        reference.reliability.as_ref().unwrap(),
        result.reliability.as_ref().unwrap(),
    );
    let n = dataset.measurements.len();
    assert_eq!((a.len(), b.len()), (n, n));
    let permutation = permutation(n);
    let (mut redundancy, mut normalised): (f64, f64) = (0.0, 0.0);
    for (k, &from) in permutation.iter().enumerate() {
        let (ours, theirs) = (b.observation(k), a.observation(from));
        assert_eq!(
            ours.observation(),
            parcal_calibrate::observation::ObservationId::Contact(k)
        );
        redundancy = redundancy.max((ours.redundancy() - theirs.redundancy()).abs());
        let w = |c: &parcal_calibrate::reliability::ObservationCheck| c.normalised().unwrap().abs();
        normalised = normalised.max((w(&ours) - w(&theirs)).abs());
    }
    println!("largest difference: redundancy {redundancy:.1e}, |w| {normalised:.1e}");
    assert!(redundancy < 1e-9 && normalised < 1e-4);
}
