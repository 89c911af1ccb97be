//! parcal for a mechanism other than the hexapod (a linear delta, a cable
//! robot, docs/mechanisms.md): its dataset ([`dataset`]), its calibration
//! ([`calibration`]), and the commands on them as `parcal validate`,
//! `parcal compensate` and `parcal plan` make them ([`apply`], [`plan`]),
//! and a printer's firmware files as its dataset, as `parcal import`
//! makes it ([`firmware_import`]).
//! Errors name the file and line of an observation, as the commands do.

pub mod apply;
pub mod calibration;
pub mod dataset;
pub mod firmware_import;
pub mod plan;

use std::path::{Path, PathBuf};

use parcal::dataset::IN_MEMORY;
use parcal::report::mechanism_validation::placed_error;
use parcal::{MechanismCalibrationError, MechanismCalibrationRecord};
use pyo3::prelude::*;
use pyo3::types::PyModule;

use crate::error::to_py;
use calibration::MechanismCalibration;

/// Adds the mechanisms' classes and functions to module `m`.
pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<dataset::MechanismDataset>()?;
    m.add_class::<MechanismCalibration>()?;
    m.add_function(wrap_pyfunction!(calibration::calibrate_mechanism, m)?)?;
    m.add_function(wrap_pyfunction!(calibration::calibrate_common, m)?)?;
    m.add_function(wrap_pyfunction!(apply::validate_mechanism, m)?)?;
    m.add_function(wrap_pyfunction!(apply::validate_common, m)?)?;
    m.add_function(wrap_pyfunction!(apply::compensate_mechanism, m)?)?;
    m.add_function(wrap_pyfunction!(plan::plan_mechanism, m)?)?;
    m.add_function(wrap_pyfunction!(firmware_import::import_firmware, m)?)?;
    Ok(())
}

/// An error of the data of the dataset at `dataset`, an observation named
/// by its file and line (`probes.csv line 5 (probe height 3)`), as the
/// commands name it.
pub fn data_error(dataset: &Path, mechanism: &str, error: MechanismCalibrationError) -> PyErr {
    to_py(format!(
        "{}: {}",
        dataset.display(),
        placed_error(mechanism, &error)
    ))
}

/// The calibration to apply, given as a `parcal.MechanismCalibration` or
/// the path of its calibration.json, and its name in messages; a rejected
/// one only if `accept_rejected`.
fn calibration_record(
    calibration: &Bound<'_, PyAny>,
    accept_rejected: bool,
) -> PyResult<(MechanismCalibrationRecord, String)> {
    let (record, name) = match calibration.cast::<MechanismCalibration>() {
        Ok(run) => (run.get().record.clone(), IN_MEMORY.to_string()),
        Err(_) => {
            let path: PathBuf = calibration.extract().map_err(|_| {
                to_py(format!(
                    "calibration: expected a parcal.MechanismCalibration or a calibration.json's path, got {calibration}"
                ))
            })?;
            let record = MechanismCalibrationRecord::read(&path).map_err(to_py)?;
            (record, path.display().to_string())
        }
    };
    if !record.accepted && !accept_rejected {
        return Err(to_py(format!(
            "{name}: the calibration was rejected ({}); give accept_rejected=True to use it anyway",
            record.reasons.join("; ")
        )));
    }
    Ok((record, name))
}
