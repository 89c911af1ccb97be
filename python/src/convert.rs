//! Between Python and the library: dicts through JSON (what the files
//! hold), arrays of rows through numpy (float64, one row per
//! observation).

use std::path::Path;

use numpy::{PyArray1, PyArray2, PyArrayMethods, PyReadonlyArray2, PyUntypedArrayMethods};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use serde::Serialize;

use crate::error::to_py;

/// `object` (a dict, a list...) as JSON text, by Python's `json.dumps`:
/// numpy's numbers and arrays as Python's (their `tolist()`); a number
/// that is not finite, which JSON cannot hold, refused by its keys.
fn json_text(object: &Bound<'_, PyAny>, what: &str) -> PyResult<String> {
    let py = object.py();
    if let Some(place) = non_finite(object, String::new())? {
        return Err(to_py(format!(
            "{what}: {place}: not a finite number (NaN and infinities have no JSON form)"
        )));
    }
    let kwargs = PyDict::new(py);
    kwargs.set_item("allow_nan", false)?;
    let to_list = py
        .import("operator")?
        .call_method1("methodcaller", ("tolist",))?;
    kwargs.set_item("default", to_list)?;
    py.import("json")?
        .call_method("dumps", (object,), Some(&kwargs))
        .and_then(|text| text.extract())
        .map_err(|error| to_py(format!("{what}: not JSON: {error}")))
}

/// Where in `object` (a dict, a list, numbers, numpy's numbers and arrays)
/// a number is not finite: its keys and indices from `place`
/// (`noise.probe`, `design[2]`), or `None`.
fn non_finite(object: &Bound<'_, PyAny>, place: String) -> PyResult<Option<String>> {
    let at = |key: String| match place.is_empty() {
        true => key,
        false => format!("{place}.{key}"),
    };
    if let Ok(dict) = object.cast::<PyDict>() {
        for (key, value) in dict.iter() {
            if let Some(found) = non_finite(&value, at(key.str()?.to_string()))? {
                return Ok(Some(found));
            }
        }
        return Ok(None);
    }
    if object.hasattr("tolist")? && !object.is_instance_of::<pyo3::types::PyString>() {
        return non_finite(&object.call_method0("tolist")?, place);
    }
    if let Ok(list) = object.cast::<pyo3::types::PyList>() {
        for (k, value) in list.iter().enumerate() {
            if let Some(found) = non_finite(&value, format!("{place}[{k}]"))? {
                return Ok(Some(found));
            }
        }
        return Ok(None);
    }
    if let Ok(tuple) = object.cast::<pyo3::types::PyTuple>() {
        for (k, value) in tuple.iter().enumerate() {
            if let Some(found) = non_finite(&value, format!("{place}[{k}]"))? {
                return Ok(Some(found));
            }
        }
        return Ok(None);
    }
    if let Ok(number) = object.cast::<pyo3::types::PyFloat>() {
        return Ok((!number.value().is_finite()).then_some(place));
    }
    Ok(None)
}

/// Refuses a key of `dict` (`what`) that is none of `keys`: a misspelt
/// key would otherwise be passed over without a word.
pub fn known_keys(dict: &Bound<'_, PyDict>, what: &str, keys: &[&str]) -> PyResult<()> {
    for key in dict.keys() {
        let name = key.str()?.to_string();
        if !keys.contains(&name.as_str()) {
            return Err(to_py(format!(
                "{what}: unknown key {name:?} (its keys are {})",
                keys.join(", ")
            )));
        }
    }
    Ok(())
}

/// `value` as Python objects (dicts, lists, numbers), by its JSON form.
pub fn to_python<'py>(py: Python<'py>, value: &impl Serialize) -> PyResult<Bound<'py, PyAny>> {
    let text = serde_json::to_string(value).map_err(to_py)?;
    py.import("json")?.call_method1("loads", (text,))
}

/// `object` as float64 rows of `N` columns, named `what` in errors (with
/// the row of a value that is not finite).
pub fn rows<const N: usize>(object: &Bound<'_, PyAny>, what: &str) -> PyResult<Vec<[f64; N]>> {
    Ok(table_rows(object, N, what)?
        .into_iter()
        .map(|row| std::array::from_fn(|k| row[k]))
        .collect())
}

/// `object` as float64 rows of `width` columns (a mechanism's actuators),
/// named `what` in errors.
pub fn table_rows(object: &Bound<'_, PyAny>, width: usize, what: &str) -> PyResult<Vec<Vec<f64>>> {
    table_rows_of(object, &[width], what)
}

/// `object` as float64 rows of one of `widths` columns, named `what` in
/// errors.
pub fn table_rows_of(
    object: &Bound<'_, PyAny>,
    widths: &[usize],
    what: &str,
) -> PyResult<Vec<Vec<f64>>> {
    let names: Vec<String> = widths.iter().map(usize::to_string).collect();
    let expected = names.join(" or ");
    let array = float_array(object, what)?;
    let array: PyReadonlyArray2<f64> = array.extract().map_err(|_| {
        to_py(format!(
            "{what}: expected a 2-D array of {expected} columns, got {} dimension(s)",
            array.ndim()
        ))
    })?;
    let view = array.as_array();
    if !widths.contains(&view.ncols()) {
        return Err(to_py(format!(
            "{what}: expected {expected} columns, got {}",
            view.ncols()
        )));
    }
    Ok(view.rows().into_iter().map(|row| row.to_vec()).collect())
}

/// `content` (a dict) as the file `file` (its `format` field `format` if
/// it has none), read by the file's own reader `read`, which checks it and
/// names the field (`machine.json: noise.probe: ...`); the temporary
/// directory it went through is not named.
pub fn through_file<T>(
    content: &Bound<'_, PyAny>,
    format: &str,
    file: &str,
    read: impl FnOnce(&Path) -> Result<T, parcal::DatasetError>,
) -> PyResult<T> {
    let dict = content
        .cast::<PyDict>()
        .map_err(|_| to_py(format!("{file}: expected a dict of its content")))?
        .copy()?;
    if !dict.contains("format")? {
        dict.set_item("format", format)?;
    }
    let text = json_text(dict.as_any(), file)?;
    let directory = tempfile::tempdir().map_err(to_py)?;
    let path = directory.path().join(file);
    std::fs::write(&path, text).map_err(to_py)?;
    read(&path).map_err(|error| {
        let prefix = format!("{}/", directory.path().display());
        to_py(error.to_string().replace(&prefix, ""))
    })
}

/// The text a file writer `write` puts in the file `file`: the same bytes
/// as the file it writes for a command (written to a temporary directory,
/// then read back).
pub fn written_text<E: std::fmt::Display>(
    file: &str,
    write: impl FnOnce(&Path) -> Result<(), E>,
) -> PyResult<String> {
    let directory = tempfile::tempdir().map_err(to_py)?;
    let path = directory.path().join(file);
    write(&path).map_err(to_py)?;
    std::fs::read_to_string(&path).map_err(to_py)
}

/// `object` as a float64 numpy array (numpy's `asarray`); complex
/// numbers refused, which the cast would cut to their real parts.
fn float_array<'py>(
    object: &Bound<'py, PyAny>,
    what: &str,
) -> PyResult<Bound<'py, numpy::PyUntypedArray>> {
    let py = object.py();
    let numpy = py.import("numpy")?;
    if numpy
        .call_method1("iscomplexobj", (object,))
        .and_then(|complex| complex.is_truthy())
        .unwrap_or(false)
    {
        return Err(to_py(format!(
            "{what}: complex numbers, where real ones are expected"
        )));
    }
    let kwargs = PyDict::new(py);
    kwargs.set_item("dtype", "float64")?;
    let array = numpy
        .call_method("asarray", (object,), Some(&kwargs))
        .map_err(|error| to_py(format!("{what}: not an array of numbers: {error}")))?;
    Ok(array.cast_into::<numpy::PyUntypedArray>()?)
}

/// Rows of `N` numbers as an `n x N` array.
pub fn array2<'py, const N: usize>(
    py: Python<'py>,
    rows: &[[f64; N]],
) -> Bound<'py, PyArray2<f64>> {
    let flat: Vec<f64> = rows.iter().flatten().copied().collect();
    PyArray1::from_vec(py, flat)
        .reshape([rows.len(), N])
        .expect("n x N numbers reshape to n rows of N")
}

/// `flat`, `width` numbers a row (the actuators' readings of each row),
/// as an `n x width` array.
pub fn table(py: Python<'_>, flat: Vec<f64>, width: usize) -> Bound<'_, PyArray2<f64>> {
    let rows = flat.len() / width.max(1);
    PyArray1::from_vec(py, flat)
        .reshape([rows, width])
        .expect("whole rows of `width` numbers reshape to n rows")
}
