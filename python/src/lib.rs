//! parcal in Python: the extension module `parcal._parcal`, which the
//! package `parcal` (python/parcal) re-exports. Datasets read from files
//! or built from dicts and numpy arrays (`dataset`), their calibration as
//! `parcal calibrate` makes it (`calibrate`, `run`), and the other
//! commands with numpy arrays where the command writes CSV (`commands`);
//! the same for a linear delta or a cable robot (`mechanism`), the
//! dataset's kind read from its machine.json (`read`); a calibration of
//! either kind (`recorded`) reported (`report`) and exported (`export`).
//! Every error is `parcal.Error`, a `ValueError` (`error`).

mod calibrate;
mod commands;
mod convert;
mod dataset;
mod error;
mod export;
mod mechanism;
mod options;
mod read;
mod recorded;
mod report;
mod run;

use pyo3::prelude::*;

/// The extension module: its classes, functions and exception.
#[pymodule]
fn _parcal(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("Error", m.py().get_type::<error::Error>())?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add_class::<dataset::Dataset>()?;
    m.add_class::<run::Calibration>()?;
    m.add_function(wrap_pyfunction!(calibrate::calibrate, m)?)?;
    m.add_function(wrap_pyfunction!(read::read_dataset, m)?)?;
    m.add_function(wrap_pyfunction!(report::report, m)?)?;
    m.add_function(wrap_pyfunction!(export::export, m)?)?;
    mechanism::register(m)?;
    commands::register(m)
}
