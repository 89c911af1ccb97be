//! `parcal.compensate`: targets to actuator commands with a calibration,
//! and the corrected poses for a controller that uses the nominal model,
//! as `parcal compensate --poses` makes them; `parcal.correction_table`:
//! a correction table over a grid of targets, as `parcal compensate
//! --table` makes it ([`parcal::correction_table`]; docs/apply.md).

use numpy::PyArray1;
use parcal::apply::{
    AppliedModel, ApplyError, CorrectionTable, Target, compensate as commands, corrected_poses,
};
use parcal::correction_table::{
    AxisRange, TableError, correction_table as correction_table_of, table_grid,
};
use parcal::dataset::mechanism::TARGETS;
use parcal::simulation::mechanism::Spelling;
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyTuple};

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
    TARGETS.check("targets", targets.len()).map_err(to_py)?;
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

/// The correction table of `calibration` (a `parcal.Calibration` or a
/// calibration.json's path) over the grid of `x`, `y`, `z` (mm), `roll`,
/// `pitch`, `yaw` (rad), each `(min, max, n)`: `n` values evenly from
/// `min` to `max` (`n = 1`: `min`), an axis not given at 0; as `parcal
/// compensate --table "x=MIN:MAX:N,..."` makes it. `nominal=True` makes it
/// with the design model; a rejected calibration only with
/// `accept_rejected`.
///
/// Returns a dict: the table's columns (table.csv's header: `x` .. `yaw`,
/// the node, then `dx` .. `dyaw`, its correction: the corrected pose less
/// the target, mm and rad), each a numpy array of one value per node,
/// row-major with `x` slowest; `shape` (the six axes' numbers of values);
/// and the multilinear interpolation error at the cell midpoints:
/// `points` (midpoints compared), `position_rms`, `position_max` (mm),
/// `angle_max` (rad). A node or midpoint the machine cannot reach raises
/// `parcal.Error` naming its row (0-based).
#[pyfunction]
#[pyo3(signature = (calibration, *, x=None, y=None, z=None, roll=None, pitch=None, yaw=None, nominal=false, accept_rejected=false))]
#[allow(clippy::too_many_arguments)]
pub fn correction_table<'py>(
    py: Python<'py>,
    calibration: &Bound<'py, PyAny>,
    x: Option<&Bound<'py, PyAny>>,
    y: Option<&Bound<'py, PyAny>>,
    z: Option<&Bound<'py, PyAny>>,
    roll: Option<&Bound<'py, PyAny>>,
    pitch: Option<&Bound<'py, PyAny>>,
    yaw: Option<&Bound<'py, PyAny>>,
    nominal: bool,
    accept_rejected: bool,
) -> PyResult<Bound<'py, PyDict>> {
    let given = [x, y, z, roll, pitch, yaw];
    let mut ranges = [None; 6];
    for ((range, axis), name) in ranges.iter_mut().zip(given).zip(Target::COLUMNS) {
        *range = axis.map(|axis| axis_range(name, axis)).transpose()?;
    }
    let grid = table_grid(&ranges, Spelling::Keywords).map_err(to_py)?;
    let (record, name) = calibration_record(calibration, accept_rejected)?;
    let (table, error) = py.detach(|| {
        let mut model =
            AppliedModel::from_record(&record).map_err(|e| to_py(format!("{name}: {e}")))?;
        if nominal {
            model = model.nominal().map_err(to_py)?;
        }
        correction_table_of(&model, &grid).map_err(|error| match error {
            TableError::Nodes(ApplyError::Refused { row, refusal }) => {
                to_py(format!("the correction table: row {}: {refusal}", row - 1))
            }
            TableError::Midpoints(ApplyError::Refused { row, refusal }) => to_py(format!(
                "the correction table's midpoints: midpoint {}: {refusal}",
                row - 1
            )),
            other => to_py(other),
        })
    })?;
    let dict = PyDict::new(py);
    let rows = table.rows();
    for (k, column) in CorrectionTable::HEADER.iter().enumerate() {
        let values: Vec<f64> = rows.iter().map(|row| row[k]).collect();
        dict.set_item(*column, PyArray1::from_vec(py, values))?;
    }
    let shape: Vec<usize> = grid.axes.iter().map(Vec::len).collect();
    dict.set_item("shape", PyTuple::new(py, shape)?)?;
    dict.set_item("points", error.points)?;
    dict.set_item("position_rms", error.position_rms)?;
    dict.set_item("position_max", error.position_max)?;
    dict.set_item("angle_max", error.angle_max)?;
    Ok(dict)
}

/// Axis `name`'s `(min, max, n)`.
fn axis_range(name: &str, axis: &Bound<'_, PyAny>) -> PyResult<AxisRange> {
    let (min, max, nodes): (f64, f64, usize) = axis.extract().map_err(|_| {
        to_py(format!(
            "{name}: expected (min, max, n) with n a whole number, got {}",
            axis.repr()
                .map_or_else(|_| "?".to_string(), |r| r.to_string())
        ))
    })?;
    Ok(AxisRange { min, max, nodes })
}
