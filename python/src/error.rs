//! `parcal.Error`: every failure of the library, a `ValueError` carrying
//! the library's message (it names the row, ball, field or file).

use pyo3::PyErr;
use pyo3::create_exception;
use pyo3::exceptions::PyValueError;

create_exception!(
    parcal,
    Error,
    PyValueError,
    "A failure of parcal: bad input (the message names the row, ball, field or file), or a computation that could not be made."
);

/// `error` as a `parcal.Error` with its message.
pub fn to_py(error: impl std::fmt::Display) -> PyErr {
    Error::new_err(error.to_string())
}
