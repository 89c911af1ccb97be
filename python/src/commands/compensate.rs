//! `parcal.compensate`: targets to actuator commands with a calibration,
//! and the corrected poses for a controller that uses the nominal model,
//! as `parcal compensate --poses` makes them (docs/apply.md).

use numpy::PyArray1;
use parcal::apply::{AppliedModel, ApplyError, Target, compensate as commands, corrected_poses};
use pyo3::prelude::*;
use pyo3::types::PyDict;

use super::calibration_record;
use crate::convert::{array2, rows};
use crate::error::to_py;

/// The actuator commands that bring the tool tip to each of `targets`
/// (n x 6: x, y, z in mm and roll, pitch, yaw in rad, R = Rz(yaw) Ry(pitch)
/// Rx(roll), design frame) with `calibration` (a `parcal.Calibration` or a
/// calibration.json's path), as `parcal compensate` computes them.
///
/// Returns a dict: `q` (n x 6 commands, in the actuators' unit),
/// `conditioning` (each pose's Jacobian singular-value ratio) and
/// `corrected_poses` (n x 6: the poses to send to a controller that uses
/// the nominal model). `nominal=True` commands with the design model
/// instead; a rejected calibration only with `accept_rejected`. A target
/// the machine cannot reach raises `parcal.Error` naming its row
/// (0-based).
#[pyfunction]
#[pyo3(signature = (calibration, targets, *, nominal=false, accept_rejected=false))]
pub fn compensate<'py>(
    py: Python<'py>,
    calibration: &Bound<'py, PyAny>,
    targets: &Bound<'py, PyAny>,
    nominal: bool,
    accept_rejected: bool,
) -> PyResult<Bound<'py, PyDict>> {
    let (record, name) = calibration_record(calibration, accept_rejected)?;
    let targets: Vec<Target> = rows::<6>(targets, "targets")?
        .iter()
        .map(Target::from_row)
        .collect();
    let named = |error: ApplyError| match error {
        ApplyError::Refused { row, refusal } => to_py(format!("target row {}: {refusal}", row - 1)),
        other => to_py(other),
    };
    let (commands, corrected) = py.detach(|| {
        let mut model =
            AppliedModel::from_record(&record).map_err(|e| to_py(format!("{name}: {e}")))?;
        if nominal {
            model = model.nominal().map_err(to_py)?;
        }
        let commands = commands(&model, &targets).map_err(named)?;
        let corrected = corrected_poses(&model, &commands).map_err(named)?;
        Ok::<_, PyErr>((commands, corrected))
    })?;
    let dict = PyDict::new(py);
    let q: Vec<[f64; 6]> = commands.iter().map(|c| c.q).collect();
    let conditioning: Vec<f64> = commands.iter().map(|c| c.conditioning).collect();
    let corrected: Vec<[f64; 6]> = corrected.iter().map(Target::row).collect();
    dict.set_item("q", array2(py, &q))?;
    dict.set_item("conditioning", PyArray1::from_vec(py, conditioning))?;
    dict.set_item("corrected_poses", array2::<6>(py, &corrected))?;
    Ok(dict)
}
