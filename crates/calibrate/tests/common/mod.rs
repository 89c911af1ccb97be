//! Helpers shared by the integration tests: the calibration case
//! and a dataset with its measurement rows shuffled.

#![allow(dead_code)] // each test binary uses a different subset

use parcal_calibrate::{CalibrationOptions, CalibrationRun, PriorMode, Simulation};
use parcal_dataset::Dataset;

/// Simulation IV with the propagated prior (the case, as in the
/// benches).
pub fn options() -> CalibrationOptions {
    CalibrationOptions {
        prior: PriorMode::Propagated,
        ..CalibrationOptions::simulation(Simulation::IV)
    }
}

/// `dataset` with its measurement rows in a fixed scrambled order, row `k`
/// taken from row `(7919 k + 13) mod n`: every per-row column moves (ball,
/// q, the directions if any, and the truth's contacts if any).
pub fn shuffled(dataset: &Dataset) -> Dataset {
    let n = dataset.measurements.len();
    let permutation: Vec<usize> = (0..n).map(|k| (k * 7919 + 13) % n).collect();
    let mut seen = vec![false; n];
    for &k in &permutation {
        seen[k] = true;
    }
    assert!(seen.iter().all(|&s| s), "not a permutation of {n} rows");
    fn permute<T: Clone>(column: &[T], permutation: &[usize]) -> Vec<T> {
        permutation.iter().map(|&k| column[k].clone()).collect()
    }
    let mut shuffled = dataset.clone();
    let (from, to) = (&dataset.measurements, &mut shuffled.measurements);
    to.ball = permute(&from.ball, &permutation);
    to.q = permute(&from.q, &permutation);
    to.direction = from.direction.as_deref().map(|d| permute(d, &permutation));
    if let (Some(from), Some(to)) = (&dataset.truth, &mut shuffled.truth) {
        to.contacts = permute(&from.contacts, &permutation);
    }
    shuffled
}

/// How far `result` is from `reference`, relatively: of the 33 parameters
/// `|p - p_ref| / |p_ref|` (Euclidean norms), of their sigmas
/// `max |s - s_ref| / max s_ref`.
pub fn relative_differences(reference: &CalibrationRun, result: &CalibrationRun) -> (f64, f64) {
    let params = (result.params - reference.params).norm() / reference.params.norm();
    let (s, s_ref) = (
        result.sigmas().expect("sigmas"),
        reference.sigmas().expect("sigmas"),
    );
    (params, (s - s_ref).amax() / s_ref.amax())
}
