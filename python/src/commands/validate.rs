//! `parcal.validate`: a calibration applied to data it was not fitted on,
//! or a dataset's cross-validation, as `parcal validate` makes them.

use parcal::calibration::bounds::{FOLDS, REFERENCE};
use parcal::calibration::validate_touches;
use parcal::{Calibrated, CalibrationOptions, cross_validate, validate_calibration};
use pyo3::prelude::*;

use super::calibration_record;
use crate::convert::to_python;
use crate::dataset::Dataset;
use crate::error::to_py;

/// Validates `dataset` as `parcal validate` does, and returns what it
/// writes to validation.json (a dict with its `verdict` and `reasons`).
///
/// With `calibration` (a `parcal.Calibration`, or the path of a
/// calibration.json): that calibration applied to the dataset, each
/// session's nuisance (each ball's centre) re-fitted on its first
/// `reference` rows (touches) if given; a rejected calibration only with
/// `accept_rejected`. With `folds` instead: the K-fold cross-validation of
/// the dataset's own calibration.
#[pyfunction]
#[pyo3(signature = (dataset, *, calibration=None, reference=None, folds=None, accept_rejected=false))]
pub fn validate<'py>(
    py: Python<'py>,
    dataset: &Bound<'py, Dataset>,
    calibration: Option<&Bound<'py, PyAny>>,
    reference: Option<usize>,
    folds: Option<usize>,
    accept_rejected: bool,
) -> PyResult<Bound<'py, PyAny>> {
    let dataset = &dataset.get().inner;
    if let Some(reference) = reference {
        REFERENCE.check("reference", reference).map_err(to_py)?;
    }
    let (validation, name) = match (calibration, folds) {
        (Some(calibration), None) => {
            let (record, name) = calibration_record(calibration, accept_rejected)?;
            let validation = py.detach(|| {
                if dataset.tracker.is_empty() {
                    validate_touches(dataset, &record, reference)
                } else {
                    Calibrated::from_record(&record).and_then(|calibrated| {
                        validate_calibration(dataset, &calibrated, reference)
                    })
                }
            });
            (validation.map_err(|e| to_py(format!("{name}: {e}")))?, name)
        }
        (None, Some(folds)) => {
            FOLDS.check("folds", folds).map_err(to_py)?;
            let cross = py
                .detach(|| cross_validate(dataset, &CalibrationOptions::default(), folds))
                .map_err(to_py)?;
            (cross.pooled(), format!("{folds}-fold cross-validation"))
        }
        _ => return Err(to_py("give calibration or folds (one of them)")),
    };
    let record = parcal::report::instruments::validation_record(&validation, name);
    to_python(py, &record)
}
