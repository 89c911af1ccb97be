//! `parcal.calibrate`: a dataset calibrated as `parcal calibrate` does it,
//! the GIL released while it runs; a progress callback is called at each
//! iteration with the GIL held again, and an exception it raises (or a
//! signal, Ctrl-C) stops the run.

use std::panic::{AssertUnwindSafe, catch_unwind, resume_unwind};

use parcal::calibration::IterationRecord;
use parcal::command::{calibrate_recorded, provenance};
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::dataset::Dataset;
use crate::error::to_py;
use crate::options::flags;
use crate::run::Calibration;

/// What unwinds a calibration out of its observer when the progress
/// callback raised or a signal arrived: the library has no other way to
/// stop a run between iterations, and unwinding drops everything the run
/// holds. `resume_unwind` does not run the panic hook: nothing is printed.
struct Stopped;

/// Calibrates `dataset` as `parcal calibrate` with the same options does.
///
/// `options` are the command's long flags with `_` for `-`:
/// `sim` ("I".."IV"), `observation` ("radius", "coordinates"), `prior`
/// ("paper", "propagated", "none"), `weights` ("propagated", "diagonal"),
/// `radius` ("ball", "contact"), `lm` (bool), `max_iterations` (int),
/// `time_limit` (seconds), `snoop` (bool), `loss` ("squared",
/// "huber[:K]", "cauchy[:K]"). `progress`, if given, is called after
/// each iteration with a dict (`iteration`, `cost`, `step_norm`,
/// `lambda`, `accepted`); an exception it raises stops the calibration
/// and is raised here. The GIL is released while the calibration runs.
///
/// Returns a `Calibration`, accepted or rejected (its `verdict`); raises
/// `parcal.Error` when the dataset or an option is invalid.
#[pyfunction]
#[pyo3(signature = (dataset, *, progress=None, **options))]
pub fn calibrate(
    py: Python<'_>,
    dataset: &Bound<'_, Dataset>,
    progress: Option<Py<PyAny>>,
    options: Option<&Bound<'_, PyDict>>,
) -> PyResult<Calibration> {
    let flags = flags(options)?;
    let dataset = dataset.get();
    let recorded = observed(py, progress.as_ref(), |observer| {
        calibrate_recorded(&dataset.inner, &flags, observer)
    })?
    .map_err(to_py)?;
    Ok(Calibration::new(
        recorded,
        provenance(dataset.inner.checksum(), &dataset.given),
    ))
}

/// Runs `work` with the GIL released, handing it an observer that calls
/// `progress` (if any) after each iteration with the GIL held again: an
/// exception the callback raises, or a signal (Ctrl-C), stops the work
/// and is returned here; otherwise `work`'s own result.
pub(crate) fn observed<T, E>(
    py: Python<'_>,
    progress: Option<&Py<PyAny>>,
    work: impl FnOnce(&mut dyn FnMut(&IterationRecord)) -> Result<T, E> + Send,
) -> PyResult<Result<T, E>>
where
    T: Send,
    E: Send,
{
    let mut raised: Option<PyErr> = None;
    let mut iteration = 0usize;
    let mut observer = |record: &IterationRecord| {
        iteration += 1;
        let outcome = Python::attach(|py| {
            py.check_signals()?;
            match progress {
                Some(callback) => report(py, callback, iteration, record),
                None => Ok(()),
            }
        });
        if let Err(error) = outcome {
            raised = Some(error);
            resume_unwind(Box::new(Stopped));
        }
    };
    let outcome = py.detach(|| catch_unwind(AssertUnwindSafe(|| work(&mut observer))));
    match outcome {
        Ok(result) => Ok(result),
        Err(payload) if payload.is::<Stopped>() => {
            Err(raised.expect("the observer stops the run after an exception only"))
        }
        Err(payload) => resume_unwind(payload),
    }
}

/// Calls `callback` with iteration `iteration`'s `record`.
fn report(
    py: Python<'_>,
    callback: &Py<PyAny>,
    iteration: usize,
    record: &IterationRecord,
) -> PyResult<()> {
    let dict = PyDict::new(py);
    dict.set_item("iteration", iteration)?;
    dict.set_item("cost", record.cost)?;
    dict.set_item("step_norm", record.step_norm)?;
    dict.set_item("lambda", record.lambda)?;
    dict.set_item("accepted", record.accepted)?;
    callback.call1(py, (dict,))?;
    Ok(())
}
