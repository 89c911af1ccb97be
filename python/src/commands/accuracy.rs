//! `parcal.accuracy`: the accuracy maps `parcal accuracy` writes to
//! accuracy.csv, as numpy grids.

use numpy::{PyArray1, PyArray2, PyArrayMethods};
use parcal::maps::{MapsError, accuracy_maps, calibrated_params};
use parcal::{Accuracy, AccuracyMap};
use pyo3::prelude::*;
use pyo3::types::PyDict;

use super::calibration_record;
use crate::dataset::Dataset;
use crate::error::to_py;

/// The accuracy maps of `dataset` on the paper's grid (x and y from -100
/// to 100 mm by 10 on the plane z = 400 of the design frame), as `parcal
/// accuracy` computes them: before calibration (the design with its
/// propagated prior) and, with `calibration` (a `parcal.Calibration` or a
/// calibration.json's path), after it.
///
/// Returns a dict: `x` and `y` (the grid's columns and rows, mm), `z`,
/// and each map as a `len(y) x len(x)` array (mm) under accuracy.csv's
/// column name: `before_predicted_absolute`, `before_predicted_registered`,
/// `after_...`, and with a simulation's truth `before_true_absolute` ...
/// A rejected calibration only with `accept_rejected`; one of another
/// dataset only with `other_data`.
#[pyfunction]
#[pyo3(signature = (dataset, calibration=None, *, accept_rejected=false, other_data=false))]
pub fn accuracy<'py>(
    py: Python<'py>,
    dataset: &Bound<'py, Dataset>,
    calibration: Option<&Bound<'py, PyAny>>,
    accept_rejected: bool,
    other_data: bool,
) -> PyResult<Bound<'py, PyDict>> {
    let dataset = &dataset.get().inner;
    let calibrated = calibration
        .map(|calibration| {
            let (record, name) = calibration_record(calibration, accept_rejected)?;
            calibrated_params(&record, dataset, other_data).map_err(|e| match e {
                MapsError::OtherData(_) => to_py(format!(
                    "{name}: {e}; give other_data=True to map it here anyway"
                )),
                e => to_py(format!("{name}: {e}")),
            })
        })
        .transpose()?;
    let maps = py
        .detach(|| accuracy_maps(dataset, calibrated.as_ref()))
        .map_err(|e: MapsError| to_py(e))?;
    let dict = PyDict::new(py);
    let grid = &maps
        .before
        .as_ref()
        .expect("the maps before calibration are always made")
        .predicted
        .grid;
    dict.set_item("x", PyArray1::from_slice(py, &grid.xs))?;
    dict.set_item("y", PyArray1::from_slice(py, &grid.ys))?;
    dict.set_item("z", grid.z)?;
    for (stage, accuracy) in [("before", &maps.before), ("after", &maps.after)] {
        if let Some(Accuracy {
            predicted,
            true_error,
        }) = accuracy
        {
            add(&dict, &format!("{stage}_predicted"), predicted)?;
            if let Some(true_error) = true_error {
                add(&dict, &format!("{stage}_true"), true_error)?;
            }
        }
    }
    Ok(dict)
}

/// `map`'s absolute and registered errors in `dict` as `NAME_absolute`
/// and `NAME_registered`, rows by y.
fn add(dict: &Bound<'_, PyDict>, name: &str, map: &AccuracyMap) -> PyResult<()> {
    let py = dict.py();
    let shape = [map.grid.ys.len(), map.grid.xs.len()];
    for (kind, values) in [("absolute", &map.absolute), ("registered", &map.registered)] {
        let grid: Bound<'_, PyArray2<f64>> = PyArray1::from_slice(py, values).reshape(shape)?;
        dict.set_item(format!("{name}_{kind}"), grid)?;
    }
    Ok(())
}
