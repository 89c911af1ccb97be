//! `parcal.validate` and `parcal.compensate` for a mechanism's calibration,
//! as `parcal validate` and `parcal compensate` make them (docs/delta.md,
//! docs/cable-robots.md): the held-out data judged against a calibration,
//! and the actuator commands that reach target positions.

use std::path::Path;

use parcal::calibration::bounds::{FOLDS, REFERENCE};
use parcal::calibration::hypothesis::SNOOPING_LEVEL;
use parcal::calibration::mechanism::{MechanismCalibrationError, MechanismValidation};
use parcal::calibration::mechanism::{
    MechanismOptions, compensate_targets, cross_validate_mechanism,
};
use parcal::dataset::mechanism::TARGETS;
use parcal::report::mechanism_validation::validation_record;
use parcal::{
    CalibratedMechanism, Compensation, MechanismCalibrationRecord, MechanismData,
    validate_mechanism as validate,
};
use pyo3::prelude::*;
use pyo3::types::PyDict;

use super::dataset::MechanismDataset;
use super::{calibration_record, data_error};
use crate::convert::{table, table_rows, to_python};
use crate::dataset::Dataset;
use crate::error::to_py;

/// The numbers that apply `record`, named `name` in messages.
fn calibrated(record: &MechanismCalibrationRecord, name: &str) -> PyResult<CalibratedMechanism> {
    CalibratedMechanism::from_record(record).map_err(|e| to_py(format!("{name}: {e}")))
}

/// Validates `calibration` (a `parcal.MechanismCalibration`, or the path
/// of a mechanism's calibration.json) on the held-out mechanism dataset
/// `dataset`, as `parcal validate` does (each held-out ball's centre and
/// tracker's frame located by its first `reference` touches, points and
/// poses if given), and returns what
/// it writes to validation.json: a dict with its `verdict`, `reasons`, the
/// `test` of the held-out residuals, each kind's RMS, the worst rows named
/// by file and line. A rejected calibration only with `accept_rejected`.
/// With `folds` instead of `calibration`: the K-fold cross-validation of
/// the dataset's own calibration under the default options (observation
/// `j` of each kind in fold `j mod K`, a ball with its touches, or the
/// balls a plate ties, as one, a tracker's `k`-th point and pose in fold
/// `k mod K`), as `parcal validate --folds`.
#[pyfunction]
#[pyo3(signature = (dataset, *, calibration=None, reference=None, folds=None, accept_rejected=false))]
pub fn validate_mechanism<'py>(
    py: Python<'py>,
    dataset: &Bound<'py, MechanismDataset>,
    calibration: Option<&Bound<'py, PyAny>>,
    reference: Option<usize>,
    folds: Option<usize>,
    accept_rejected: bool,
) -> PyResult<Bound<'py, PyAny>> {
    let dataset = dataset.get();
    checked_reference(reference)?;
    let calibration = match (calibration, folds) {
        (Some(calibration), None) => calibration,
        (None, Some(folds)) => {
            FOLDS.check("folds", folds).map_err(to_py)?;
            if reference.is_some() {
                return Err(to_py(
                    "reference: a cross-validation fits each held-out ball's centre and tracker's frame to all its fold's touches, points and poses",
                ));
            }
            let data = &dataset.data;
            let validation = py
                .detach(|| {
                    cross_validate_mechanism(data, &MechanismOptions::default(), folds, &mut |_| {})
                })
                .map_err(|e| data_error(&dataset.path, data.mechanism.name(), e))?;
            let name = format!("{folds}-fold cross-validation");
            return to_python(py, &validation_record(&validation, name));
        }
        _ => return Err(to_py("give calibration or folds (one of them)")),
    };
    judged(
        py,
        calibration,
        accept_rejected,
        &dataset.path,
        |calibrated| validate(calibrated, &dataset.data, SNOOPING_LEVEL, reference),
    )
}

/// Validates `calibration` (a `parcal.MechanismCalibration` of a hexapod
/// through the common path, or its calibration.json's path) on the ball
/// touches of the hexapod `dataset` (a `Dataset`), as `parcal validate`
/// does (each held-out ball's centre and tracker's frame located by its
/// first `reference` touches, points and poses if given, else projected
/// out of all of them), and returns what
/// it writes to validation.json. A rejected calibration only with
/// `accept_rejected`.
#[pyfunction]
#[pyo3(signature = (dataset, *, calibration, reference=None, accept_rejected=false))]
pub fn validate_common<'py>(
    py: Python<'py>,
    dataset: &Bound<'py, Dataset>,
    calibration: &Bound<'py, PyAny>,
    reference: Option<usize>,
    accept_rejected: bool,
) -> PyResult<Bound<'py, PyAny>> {
    let dataset = dataset.get();
    checked_reference(reference)?;
    let given = Path::new(&dataset.given);
    judged(py, calibration, accept_rejected, given, |calibrated| {
        let data = MechanismData::hexapod_held_out(&dataset.inner)?;
        validate(calibrated, &data, SNOOPING_LEVEL, reference)
    })
}

/// `reference` within its bounds ([`REFERENCE`]), if given.
fn checked_reference(reference: Option<usize>) -> PyResult<()> {
    if let Some(n) = reference {
        REFERENCE.check("reference", n).map_err(to_py)?;
    }
    Ok(())
}

/// `calibration` (accepted, or `accept_rejected`) judged by `validate_on`
/// with the GIL released, as validation.json holds it; an observation of
/// the held-out data named in the files of `dataset`.
fn judged<'py>(
    py: Python<'py>,
    calibration: &Bound<'py, PyAny>,
    accept_rejected: bool,
    dataset: &Path,
    validate_on: impl FnOnce(
        &CalibratedMechanism,
    ) -> Result<MechanismValidation, MechanismCalibrationError>
    + Send,
) -> PyResult<Bound<'py, PyAny>> {
    let (record, name) = calibration_record(calibration, accept_rejected)?;
    let calibrated = calibrated(&record, &name)?;
    let validation = py
        .detach(|| validate_on(&calibrated))
        .map_err(|e| data_error(dataset, calibrated.mechanism.name(), e))?;
    to_python(py, &validation_record(&validation, name))
}

/// The actuator commands that put the calibrated machine on each of
/// `targets` (n x P, P its pose coordinates: a delta's or a cable robot's
/// effector position in mm, the controller's coordinates; a hexapod's
/// t_x, t_y, t_z in mm and rotation vector in rad), as `parcal
/// compensate` computes them with `calibration` (a
/// `parcal.MechanismCalibration`, or a calibration.json's path).
///
/// Returns a dict: `target` (n x P), `q` (n x A, the calibrated machine's
/// readings, in the actuators' unit), `nominal` (n x A, what the design
/// the calibration started from commands) and `sigma` (n x P, the
/// predicted standard deviation of each coordinate of the pose increment
/// reached, from the calibration's covariance, mm and rad). `loads` (n x
/// A, N), an elastic cable robot's line loads at each target, gives the
/// commands under them (none: under the loads of the encoder zero). A
/// target the machine cannot reach raises `parcal.Error` naming its row
/// (0-based); a rejected calibration is used only with `accept_rejected`.
#[pyfunction]
#[pyo3(signature = (calibration, targets, *, loads=None, accept_rejected=false))]
pub fn compensate_mechanism<'py>(
    py: Python<'py>,
    calibration: &Bound<'py, PyAny>,
    targets: &Bound<'py, PyAny>,
    loads: Option<&Bound<'py, PyAny>>,
    accept_rejected: bool,
) -> PyResult<Bound<'py, PyDict>> {
    let (record, name) = calibration_record(calibration, accept_rejected)?;
    let calibrated = calibrated(&record, &name)?;
    let pose = calibrated.mechanism.pose_coordinates().len();
    let targets = table_rows(targets, pose, "targets")?;
    TARGETS.check("targets", targets.len()).map_err(to_py)?;
    let actuators = calibrated.mechanism.actuators().len();
    let loads = match loads {
        None => Vec::new(),
        Some(_) if calibrated.mechanism.line_compliances().is_none() => {
            return Err(to_py(format!(
                "loads: the {}'s readings do not depend on its actuators' loads (machine.json's elasticity makes a cable robot's lines elastic)",
                calibrated.mechanism.name()
            )));
        }
        Some(loads) => table_rows(loads, actuators, "loads")?,
    };
    if !loads.is_empty() && loads.len() != targets.len() {
        return Err(to_py(format!(
            "loads has {} rows and targets {}",
            loads.len(),
            targets.len()
        )));
    }
    let compensations = py
        .detach(|| compensate_targets(&calibrated, &targets, &loads))
        .map_err(|unreachable| to_py(unreachable.message(|k| format!("target row {k}"))))?;
    let table = |of: &dyn Fn(&Compensation) -> &[f64]| {
        let flat: Vec<f64> = compensations.iter().flat_map(|c| of(c).to_vec()).collect();
        table(py, flat, actuators)
    };
    let dict = PyDict::new(py);
    let of_pose = |of: &dyn Fn(&Compensation) -> Vec<f64>| {
        let flat: Vec<f64> = compensations.iter().flat_map(of).collect();
        crate::convert::table(py, flat, pose)
    };
    dict.set_item("target", of_pose(&|c| c.target.as_slice().to_vec()))?;
    dict.set_item("q", table(&|c| c.readings.as_slice()))?;
    dict.set_item("nominal", table(&|c| c.nominal.as_slice()))?;
    dict.set_item("sigma", of_pose(&Compensation::sigmas))?;
    Ok(dict)
}
