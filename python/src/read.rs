//! `parcal.read_dataset`: a dataset directory read as the kind its
//! machine.json declares, as every `parcal` command reads it: a hexapod's
//! (no `"mechanism"`, or `"hexapod"`; or a snapshot file) as
//! `parcal.Dataset`, any other mechanism's as `parcal.MechanismDataset`.

use std::path::PathBuf;

use parcal::dataset::mechanism::MACHINE_FILE;
use parcal::dataset::{HEXAPOD, declared_mechanism};
use pyo3::prelude::*;
use pyo3::{IntoPyObjectExt, Py, PyAny};

use crate::dataset::Dataset;
use crate::error::to_py;
use crate::mechanism::dataset::MechanismDataset;

/// Reads the dataset at `path` (a directory, or a hexapod's snapshot
/// file): a `parcal.MechanismDataset` when its machine.json names a
/// mechanism other than the hexapod, else a `parcal.Dataset`.
#[pyfunction]
pub fn read_dataset(py: Python<'_>, path: PathBuf) -> PyResult<Py<PyAny>> {
    let machine = path.join(MACHINE_FILE);
    let mechanism = if path.is_dir() && machine.exists() {
        declared_mechanism(&machine)
            .map_err(to_py)?
            .filter(|name| name != HEXAPOD)
    } else {
        None
    };
    match mechanism {
        Some(_) => MechanismDataset::read_from(py, path)?.into_py_any(py),
        None => Dataset::read_from(py, path)?.into_py_any(py),
    }
}
