//! k-fold cross-validation of a calibration of poses and points: every
//! row predicted ([`validate_calibration`]) by a calibration
//! ([`crate::calibrate`]) fitted on the other folds.

use parcal_dataset::Dataset;

use crate::instruments::validate::{Calibrated, Validation, subset, validate_calibration};
use crate::{CalibrateError, CalibrationOptions, calibrate};

/// A k-fold cross-validation: every row predicted by a calibration fitted
/// on the other folds.
#[derive(Debug, Clone, PartialEq)]
#[non_exhaustive]
pub struct CrossValidation {
    /// Number of folds.
    pub folds: usize,
    /// Each fold's validation (its rows predicted by the other folds'
    /// calibration, through the calibration's own session frames).
    pub validations: Vec<Validation>,
}

impl CrossValidation {
    /// RMS of every held-out residual (mm).
    pub fn rms(&self) -> f64 {
        self.pooled().rms()
    }

    /// The RMS the folds' calibrations predict (mm).
    pub fn predicted_rms(&self) -> f64 {
        self.pooled().predicted_rms()
    }

    /// The folds as one validation: their rows in fold order, each fold's
    /// residuals tested against its own calibration's predicted covariance,
    /// the statistics and their degrees of freedom summed; the folds'
    /// global tests pooled as one pass over the data (each row is in
    /// `K − 1` of the folds' calibrations): `(Σ Ω_k, Σ r_k) / (K − 1)`.
    pub fn pooled(&self) -> Validation {
        let tests: Option<Vec<(f64, usize)>> = self
            .validations
            .iter()
            .map(|v| v.calibration_test)
            .collect();
        let all = |part: fn(&Validation) -> &Vec<f64>| -> Vec<f64> {
            self.validations
                .iter()
                .flat_map(|v| part(v).iter().copied())
                .collect()
        };
        Validation {
            poses: self.validations.iter().map(|v| v.poses).sum(),
            points: self.validations.iter().map(|v| v.points).sum(),
            contacts: 0,
            reference: 0,
            refitted: Vec::new(),
            selection: Vec::new(),
            residuals: all(|v| &v.residuals),
            predicted_sigmas: all(|v| &v.predicted_sigmas),
            statistic: self.validations.iter().map(|v| v.statistic).sum(),
            calibration_test: tests.map(|tests| pooled_global_test(&tests)),
            explanations: Vec::new(),
            mirrored_balls: Vec::new(),
        }
    }
}

/// The global tests `(Ω_k, r_k)` of the `K` folds' calibrations as one
/// pass over the data (each row is in `K − 1` of them):
/// `(Σ Ω_k, Σ r_k) / (K − 1)`.
pub(crate) fn pooled_global_test(tests: &[(f64, usize)]) -> (f64, usize) {
    let passes = tests.len().saturating_sub(1).max(1);
    let cost: f64 = tests.iter().map(|t| t.0).sum();
    let redundancy: usize = tests.iter().map(|t| t.1).sum();
    (cost / passes as f64, redundancy / passes)
}

/// Cross-validates the instrument calibration of `dataset` with `folds`
/// folds: row `j` of each file is in fold `j mod folds`; each fold is
/// predicted ([`validate_calibration`], no re-fit) by the calibration of the others.
pub fn cross_validate(
    dataset: &Dataset,
    options: &CalibrationOptions,
    folds: usize,
) -> Result<CrossValidation, CalibrateError> {
    let tracker = &dataset.tracker;
    // Each fold holds at least one row of the longer file.
    let rows = tracker.poses.len().max(tracker.points.len());
    crate::bounds::FOLDS
        .check("folds", folds)
        .and_then(|folds| {
            if folds <= rows {
                Ok(folds)
            } else {
                Err(format!(
                    "{folds} folds of {rows} rows (poses or points): a fold would hold none"
                ))
            }
        })
        .map_err(|reason| CalibrateError::Calibration { reason })?;
    let mut validations = Vec::with_capacity(folds);
    for fold in 0..folds {
        let split = |n: usize, held: bool| -> Vec<usize> {
            (0..n).filter(|j| (j % folds == fold) == held).collect()
        };
        let part = |held: bool| Dataset {
            tracker: subset(
                tracker,
                &split(tracker.poses.len(), held),
                &split(tracker.points.len(), held),
            ),
            ..dataset.clone()
        };
        let run = calibrate(&part(false), options, &mut |_| {})?;
        let calibrated = Calibrated::of_run(&run)?;
        validations.push(validate_calibration(&part(true), &calibrated, None)?);
    }
    Ok(CrossValidation { folds, validations })
}
