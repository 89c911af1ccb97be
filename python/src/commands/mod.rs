//! The commands besides `calibrate`, each calling what `parcal COMMAND`
//! calls.

mod simulate;
mod validate;

use pyo3::prelude::*;

/// Adds the commands' functions to module `m`.
pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(simulate::simulate, m)?)?;
    m.add_function(wrap_pyfunction!(validate::validate, m)?)?;
    Ok(())
}
