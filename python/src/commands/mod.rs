//! The commands besides `calibrate`, each calling what `parcal COMMAND`
//! calls.

mod accuracy;
mod compensate;
mod plan;
mod simulate;
mod validate;

use std::path::PathBuf;

use parcal::dataset::IN_MEMORY;
use pyo3::prelude::*;

use crate::error::to_py;
use crate::mechanism::calibration::MechanismCalibration;
use crate::run::Calibration;

/// Adds the commands' functions to module `m`.
pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(accuracy::accuracy, m)?)?;
    m.add_function(wrap_pyfunction!(compensate::compensate, m)?)?;
    m.add_function(wrap_pyfunction!(compensate::correction_table, m)?)?;
    m.add_function(wrap_pyfunction!(plan::plan, m)?)?;
    m.add_function(wrap_pyfunction!(simulate::simulate, m)?)?;
    m.add_function(wrap_pyfunction!(validate::validate, m)?)?;
    Ok(())
}

/// The calibration to apply, given as a `parcal.Calibration` or the path
/// of a calibration.json, and its name in messages; a rejected one only if
/// `accept_rejected`.
fn calibration_record(
    calibration: &Bound<'_, PyAny>,
    accept_rejected: bool,
) -> PyResult<(parcal::Calibration, String)> {
    let (record, name) = match calibration.cast::<Calibration>() {
        Ok(run) => (run.get().record().clone(), IN_MEMORY.to_string()),
        Err(_) if calibration.cast::<MechanismCalibration>().is_ok() => {
            return Err(to_py(
                "calibration: a parcal.MechanismCalibration (a mechanism's, or a hexapod's through common=True): this takes a hexapod's own calibration (parcal.calibrate without common=True) or its calibration.json's path",
            ));
        }
        Err(_) => {
            let path: PathBuf = calibration.extract().map_err(|_| {
                to_py(format!(
                    "calibration: expected a parcal.Calibration or a calibration.json's path, got {calibration}"
                ))
            })?;
            let record = parcal::Calibration::read(&path).map_err(to_py)?;
            (record, path.display().to_string())
        }
    };
    if record.is_rejected() && !accept_rejected {
        return Err(to_py(format!(
            "{name}: the calibration was rejected ({}); give accept_rejected=True to use it anyway",
            record.reasons.join("; ")
        )));
    }
    Ok((record, name))
}
