//! K-fold cross-validation of a mechanism's calibration: observation `j`
//! of each kind in fold `j mod K`, each fold's observations predicted
//! ([`validate_mechanism`]) by the calibration ([`calibrate_mechanism`])
//! of the others, the folds pooled as the hexapod's cross-validation pools
//! them ([`crate::cross_validation`]): the statistics and their degrees of
//! freedom summed, the folds' global tests as one pass over the data, a
//! w-test per row over all the rows.
//!
//! Observations that need others of their fold to be predicted (a ball's
//! touches, the distances between balls, a tracker's points and poses,
//! which share the ball's centre or the tracker's frame) are not folded:
//! their data are refused here, and held-out campaigns judge them
//! ([`validate_mechanism`] with reference observations).

use crate::cross_validation::pooled_global_test;
use crate::hypothesis::critical_value;
use crate::prediction::PredictionTest;

use super::calibrate::calibrate_mechanism;
use super::calibrated::CalibratedMechanism;
use super::data::{MechanismData, Observations};
use super::error::MechanismCalibrationError;
use super::observation::{HeldOut, ObservationKind};
use super::options::MechanismOptions;
use super::validation::{MechanismValidation, validate_mechanism};

/// Cross-validates the calibration of `data` under `options` with `folds`
/// folds (module doc); `fold_done` is told of each fold as it ends. Each
/// row is named by its observation's index in `data`. Errors: fewer than
/// two folds, more folds than any kind has observations (a fold would hold
/// none), data with balls or trackers, a fold whose calibration does not
/// converge or cannot predict its observations.
pub fn cross_validate_mechanism(
    data: &MechanismData,
    options: &MechanismOptions,
    folds: usize,
    fold_done: &mut dyn FnMut(usize),
) -> Result<MechanismValidation, MechanismCalibrationError> {
    let refuse = |reason: String| MechanismCalibrationError::InvalidData {
        what: "the folds".to_string(),
        reason,
    };
    let o = &data.observations;
    if !(o.touches.is_empty() && o.ball_distances.is_empty() && o.trackers.is_empty()) {
        return Err(refuse(
            "balls' touches and trackers' points and poses are predicted together (a ball's centre, a tracker's frame): judge them with held-out data and reference observations".to_string(),
        ));
    }
    let most = ObservationKind::ALL
        .iter()
        .map(|&kind| o.count(kind))
        .max()
        .unwrap_or(0);
    if folds < 2 || folds > most {
        return Err(refuse(format!(
            "{folds} folds of data whose most numerous kind has {most} observations: give from 2 to {most}"
        )));
    }
    let mut pooled = Vec::with_capacity(folds);
    for r in 0..folds {
        let fit = data.with_observations(fold(o, |j| j % folds != r));
        let calibration = calibrate_mechanism(&fit, options, &mut |_| {})?;
        if !calibration.converged() {
            return Err(refuse(format!(
                "the calibration without fold {r} did not converge ({:?})",
                calibration.status
            )));
        }
        let calibrated = CalibratedMechanism::of_calibration(&calibration)?;
        let held_out = data.with_observations(fold(o, |j| j % folds == r));
        let mut validation = validate_mechanism(&calibrated, &held_out, options.alpha, None)?;
        // Each row named by its observation's index in `data`.
        for row in &mut validation.rows {
            if let HeldOut::Observation(observation) = &mut row.observation {
                observation.index = observation.index * folds + r;
            }
        }
        pooled.push((validation, calibrated.global_test));
        fold_done(r);
    }
    let tests: Option<Vec<(f64, usize)>> = pooled.iter().map(|(_, test)| *test).collect();
    let calibration_test = tests.map(|tests| pooled_global_test(&tests));
    let statistic = pooled.iter().map(|(v, _)| v.statistic).sum();
    let (first, _) = &pooled[0];
    let mechanism = first.mechanism.clone();
    let untested = pooled.iter().map(|(v, _)| v.untested).sum();
    let rows: Vec<_> = pooled.into_iter().flat_map(|(v, _)| v.rows).collect();
    let n = rows.len();
    Ok(MechanismValidation {
        mechanism,
        rows,
        untested,
        reference: None,
        statistic,
        test: PredictionTest::new(statistic, n, calibration_test),
        alpha: options.alpha,
        critical_value: critical_value(options.alpha, n),
        shifts: Vec::new(),
        mirrored_balls: Vec::new(),
    })
}

/// The observations of `o` whose index within their kind `keep` takes,
/// of the kinds that are folded (module doc).
fn fold(o: &Observations, keep: impl Fn(usize) -> bool) -> Observations {
    fn kept<T: Clone>(all: &[T], keep: &impl Fn(usize) -> bool) -> Vec<T> {
        (all.iter().enumerate())
            .filter(|(j, _)| keep(*j))
            .map(|(_, item)| item.clone())
            .collect()
    }
    Observations {
        probes: kept(&o.probes, &keep),
        manual_heights: kept(&o.manual_heights, &keep),
        distances: kept(&o.distances, &keep),
        points: kept(&o.points, &keep),
        samples: kept(&o.samples, &keep),
        quantities: kept(&o.quantities, &keep),
        ..o.clone()
    }
}
