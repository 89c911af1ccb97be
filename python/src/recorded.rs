//! A calibration given to a function of either kind: a
//! `parcal.Calibration` (the hexapod's own), a `parcal.MechanismCalibration`
//! or a calibration.json's path (read as the hexapod's own, else as a
//! mechanism's).

use std::path::PathBuf;

use parcal::command::{Recorded, read_either};
use pyo3::prelude::*;

use crate::error::to_py;
use crate::mechanism::calibration::MechanismCalibration;
use crate::run::Calibration;

/// The calibration `calibration` and its file's path (`None` in memory).
pub fn recorded(calibration: &Bound<'_, PyAny>) -> PyResult<(Recorded, Option<PathBuf>)> {
    if let Ok(run) = calibration.cast::<Calibration>() {
        return Ok((Recorded::Own(Box::new(run.get().record().clone())), None));
    }
    if let Ok(run) = calibration.cast::<MechanismCalibration>() {
        return Ok((
            Recorded::Mechanism(Box::new(run.get().record.clone())),
            None,
        ));
    }
    let path: PathBuf = calibration.extract().map_err(|_| {
        to_py(format!(
            "calibration: expected a parcal.Calibration, a parcal.MechanismCalibration or a calibration.json's path, got {calibration}"
        ))
    })?;
    let recorded = read_either(&path).map_err(to_py)?;
    Ok((recorded, Some(path)))
}
