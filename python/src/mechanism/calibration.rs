//! `parcal.calibrate` on a mechanism dataset: the calibration `parcal
//! calibrate` makes of it (the generic engine, docs/mechanisms.md), the
//! result as `parcal.MechanismCalibration` with its numbers as numpy
//! arrays and its calibration.json byte for byte.

use std::path::{Path, PathBuf};

use numpy::{PyArray1, PyArray2};
use parcal::calibration::Observation;
use parcal::calibration::bounds::MAX_ITERATIONS;
use parcal::calibration::mechanism::{ObservationKind, ObservationRef};
use parcal::command::{CalibrateFlags, common_calibration, provenance};
use parcal::dataset::mechanism::ObservationRecord;
use parcal::dataset::{HEXAPOD, IN_MEMORY};
use parcal::report::mechanism::identifiability_statements;
use parcal::report::mechanism_validation::{observation_place, observation_row_place};
use parcal::{MechanismCalibrationRecord, calibrate_mechanism as calibrate};
use pyo3::prelude::*;
use pyo3::types::PyDict;

use super::data_error;
use super::dataset::MechanismDataset;
use crate::calibrate::observed;
use crate::convert::to_python;
use crate::dataset::Dataset;
use crate::error::to_py;
use crate::options::{choice, flags, seconds};

/// Calibrates the mechanism dataset `dataset` as `parcal calibrate` does
/// with the same options: `observation` (the ball touches' equation,
/// "radius" or "coordinates"; default "radius"), `snoop` (data
/// snooping), `loss` ("squared",
/// "huber[:K]", "cauchy[:K]"), `lm` (Levenberg-Marquardt),
/// `max_iterations` and `time_limit` (seconds). `progress`, if given, is
/// called after each iteration as `parcal.calibrate`'s is, and an
/// exception it raises stops the calibration and is raised here. The GIL
/// is released while it runs.
///
/// Returns a `MechanismCalibration`, accepted or rejected (its
/// `verdict`); raises `parcal.Error` when the data or an option is
/// invalid, naming the observation by its file and line.
#[pyfunction]
#[pyo3(signature = (
    dataset, *, progress=None, observation=None, snoop=false, loss="squared", lm=false,
    max_iterations=None, time_limit=None
))]
#[allow(
    clippy::too_many_arguments,
    reason = "the command's flags, each a keyword"
)]
pub fn calibrate_mechanism(
    py: Python<'_>,
    dataset: &Bound<'_, MechanismDataset>,
    progress: Option<Py<PyAny>>,
    observation: Option<Bound<'_, PyAny>>,
    snoop: bool,
    loss: &str,
    lm: bool,
    max_iterations: Option<usize>,
    time_limit: Option<f64>,
) -> PyResult<MechanismCalibration> {
    let flags = CalibrateFlags {
        snoop,
        loss: loss.parse().map_err(|e| to_py(format!("loss: {e}")))?,
        lm,
        max_iterations: max_iterations
            .map(|limit| MAX_ITERATIONS.check("max_iterations", limit))
            .transpose()
            .map_err(to_py)?,
        time_limit: time_limit.map(seconds).transpose()?,
        ..CalibrateFlags::default()
    };
    let observation = match observation {
        Some(value) => choice("observation", &value)?,
        None => Observation::Radius,
    };
    let options = flags.mechanism_options().with_observation(observation);
    let dataset = dataset.get();
    let mut calibration = observed(py, progress.as_ref(), |observer| {
        calibrate(&dataset.data, &options, observer)
    })?
    .map_err(|error| data_error(&dataset.path, dataset.data.mechanism.name(), error))?;
    if dataset.read_from_files() {
        let mechanism = dataset.data.mechanism.name();
        calibration.place_observations(&|observation, row| {
            observation_row_place(mechanism, observation, row)
        });
    }
    let mut record = calibration.into_record();
    record.provenance = Some(provenance(
        dataset.inner.checksum(),
        &dataset.path.display().to_string(),
    ));
    Ok(MechanismCalibration { record })
}

/// Calibrates a hexapod's ball touches (`dataset`, a `Dataset`) by the
/// common calibration of every mechanism, as `parcal calibrate --common`
/// does with the same options: those of `parcal.calibrate`, and
/// `progress` as there. The GIL is released while it runs.
///
/// Returns a `MechanismCalibration` of the mechanism `"hexapod"`; raises
/// `parcal.Error` naming what the common calibration does not model.
#[pyfunction]
#[pyo3(signature = (dataset, *, progress=None, **options))]
pub fn calibrate_common(
    py: Python<'_>,
    dataset: &Bound<'_, Dataset>,
    progress: Option<Py<PyAny>>,
    options: Option<&Bound<'_, PyDict>>,
) -> PyResult<MechanismCalibration> {
    let flags = flags(options)?;
    let dataset = dataset.get();
    let given = Path::new(&dataset.given);
    let (data, options) = common_calibration(&dataset.inner, &flags)
        .map_err(|error| data_error(given, HEXAPOD, error))?;
    let mut calibration = observed(py, progress.as_ref(), |observer| {
        calibrate(&data, &options, observer)
    })?
    .map_err(|error| data_error(given, HEXAPOD, error))?;
    if dataset.given != IN_MEMORY {
        calibration.place_observations(&|observation, row| {
            observation_row_place(HEXAPOD, observation, row)
        });
    }
    let mut record = calibration.into_record();
    record.provenance = Some(provenance(dataset.inner.checksum(), &dataset.given));
    Ok(MechanismCalibration { record })
}

/// A mechanism's calibration: its verdict and reasons, the parameters
/// (the mechanism's, then the trigger height if estimated) with their
/// sigmas, priors and covariance in the canonical frame, every
/// observation's test, what the data leave to the priors, and
/// calibration.json (`to_json`, `write`) exactly as `parcal calibrate`
/// writes it for the same data and options.
#[pyclass(module = "parcal", frozen)]
pub struct MechanismCalibration {
    /// calibration.json's content.
    pub record: MechanismCalibrationRecord,
}

/// The observation of `observation`'s kind and index.
fn observation_ref(observation: ObservationRecord) -> Option<ObservationRef> {
    ObservationKind::named(observation.kind).map(|kind| ObservationRef {
        kind,
        index: observation.index,
    })
}

#[pymethods]
impl MechanismCalibration {
    /// Reads a mechanism's calibration.json at `path`.
    #[staticmethod]
    fn read(path: PathBuf) -> PyResult<Self> {
        let record = MechanismCalibrationRecord::read(&path).map_err(to_py)?;
        Ok(Self { record })
    }

    /// The mechanism's name.
    #[getter]
    fn mechanism(&self) -> &str {
        &self.record.mechanism
    }

    /// A printer's printable radius (mm), its dataset's, which
    /// `compensate` keeps targets within; `None` when the dataset stated
    /// none.
    #[getter]
    fn print_radius(&self) -> Option<f64> {
        self.record.print_radius
    }

    /// `"accepted"` or `"rejected"`.
    #[getter]
    fn verdict(&self) -> &str {
        if self.record.accepted {
            "accepted"
        } else {
            "rejected"
        }
    }

    /// Why the verdict, one sentence each.
    #[getter]
    fn reasons(&self) -> Vec<String> {
        self.record.reasons.clone()
    }

    /// Why data snooping stopped early, if it did, then the observations
    /// given twice (the warnings besides the verdict's reasons).
    #[getter]
    fn warnings(&self) -> Vec<String> {
        let stopped = self.record.tests.snooping_stopped.iter();
        stopped.chain(&self.record.warnings).cloned().collect()
    }

    /// How the solver's run ended.
    #[getter]
    fn status(&self) -> &str {
        &self.record.status
    }

    /// The solver's linear solves.
    #[getter]
    fn iterations(&self) -> usize {
        self.record.iterations
    }

    /// The parameters' names: the mechanism's, then `trigger_height` if
    /// the data estimate it.
    #[getter]
    fn names(&self) -> Vec<String> {
        self.record
            .parameters
            .iter()
            .map(|p| p.name.clone())
            .collect()
    }

    /// Their units.
    #[getter]
    fn units(&self) -> Vec<String> {
        self.record
            .parameters
            .iter()
            .map(|p| p.unit.clone())
            .collect()
    }

    /// Their groups.
    #[getter]
    fn groups(&self) -> Vec<String> {
        self.record
            .parameters
            .iter()
            .map(|p| p.group.clone())
            .collect()
    }

    /// Their estimates (canonical frame), in the order of `names`.
    #[getter]
    fn values<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        self.column(py, |p| Some(p.value))
    }

    /// Their posterior standard deviations (NaN: not computed).
    #[getter]
    fn sigmas<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        self.column(py, |p| p.sigma)
    }

    /// Their prior means (the design).
    #[getter]
    fn prior_means<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        self.column(py, |p| Some(p.prior_mean))
    }

    /// Their prior standard deviations (NaN: no prior).
    #[getter]
    fn prior_sigmas<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        self.column(py, |p| p.prior_sigma)
    }

    /// Each posterior sigma over its prior sigma (canonical frame; near 1:
    /// the data say little of it; NaN: no prior or not computed).
    #[getter]
    fn sigma_ratios<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        self.column(py, |p| p.sigma_ratio)
    }

    /// Their posterior covariance (n x n, canonical frame; 0 x 0 when it
    /// could not be computed).
    #[getter]
    fn covariance<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        match &self.record.covariance {
            Some(rows) if !rows.is_empty() => PyArray2::from_vec2(py, rows).map_err(to_py),
            _ => Ok(PyArray2::zeros(py, [0, 0], false)),
        }
    }

    /// The correlation of the mechanism's parameters' priors (n x n over
    /// its parameters, machine.json's `matched` sets), or `None` when the
    /// priors were independent.
    #[getter]
    fn prior_correlation<'py>(
        &self,
        py: Python<'py>,
    ) -> PyResult<Option<Bound<'py, PyArray2<f64>>>> {
        self.record
            .prior_correlation
            .as_ref()
            .map(|rows| PyArray2::from_vec2(py, rows).map_err(to_py))
            .transpose()
    }

    /// The global test of the variance factor (a dict as calibration.json
    /// holds it), or `None` when it was not made.
    #[getter]
    fn global_test<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        to_python(py, &self.record.global_test)
    }

    /// Every observation's test, as arrays of one entry per observation:
    /// `kind` (`probe height`, `part distance`, `measured point`, `point
    /// sample`, `measured quantity`), `index` (0-based among its kind),
    /// `place` (its file and line: `probes.csv line 5 (probe height 3)`),
    /// `redundancy` (the sum over its rows), `normalised_residual` (`w`
    /// of its row of largest `|w|`; NaN when nothing checks it) and
    /// `residual` (that row's whitened residual, in sigmas; NaN likewise).
    /// The w-tests' critical value is `critical_value`.
    #[getter]
    fn observations<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let observations = &self.record.tests.observations;
        let (mut w, mut e) = (Vec::new(), Vec::new());
        for observation in observations.iter() {
            let worst = observation.worst();
            w.push(worst.map_or(f64::NAN, |(_, w)| w));
            e.push(worst.map_or(f64::NAN, |(row, _)| {
                f64::from(observation.rows[row].residual)
            }));
        }
        let dict = PyDict::new(py);
        let kinds: Vec<&str> = observations.iter().map(|o| o.kind).collect();
        let index: Vec<i64> = observations.iter().map(|o| o.index as i64).collect();
        let place: Vec<String> = observations
            .iter()
            .map(|o| {
                observation_ref(o).map_or_else(
                    || o.kind.to_string(),
                    |observation| observation_place(&self.record.mechanism, observation),
                )
            })
            .collect();
        let redundancy: Vec<f64> = observations
            .iter()
            .map(|o| o.rows.iter().map(|r| f64::from(r.redundancy)).sum())
            .collect();
        dict.set_item("kind", kinds)?;
        dict.set_item("index", PyArray1::from_vec(py, index))?;
        dict.set_item("place", place)?;
        dict.set_item("redundancy", PyArray1::from_vec(py, redundancy))?;
        dict.set_item("normalised_residual", PyArray1::from_vec(py, w))?;
        dict.set_item("residual", PyArray1::from_vec(py, e))?;
        Ok(dict)
    }

    /// The critical value of `|w|` of the w-tests.
    #[getter]
    fn critical_value(&self) -> f64 {
        self.record.tests.critical_value
    }

    /// The observations data snooping removed, in order (dicts as
    /// calibration.json holds them: `kind`, `index`, `row`, `normalised`,
    /// the variance factor before and after).
    #[getter]
    fn removed<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        to_python(py, &self.record.tests.removed)
    }

    /// The trackers' frames (dicts as calibration.json holds them:
    /// `label`, `frame` with its `translation` (mm) and `rotation` (a unit
    /// quaternion `[x, y, z, w]`), mapping the mechanism's canonical frame
    /// to the tracker's, and `sigma`: rotations about the mechanism's axes
    /// (rad), then translations (mm)); empty without tracker points.
    #[getter]
    fn trackers<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        to_python(py, &self.record.trackers)
    }

    /// The body frame the tracker poses saw (a dict as calibration.json
    /// holds it: `frame`, mapping the body's frame to the platform's, and
    /// `sigma`, rad then mm); `None` without tracker poses. A tracker after
    /// which the body was re-mounted has its own in `trackers`.
    #[getter]
    fn body<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        to_python(py, &self.record.body)
    }

    /// What the data determine: `gauge` (the freedoms the canonical frame
    /// fixes), `undetermined` (each combination of parameters the data
    /// leave to the priors: its `components` as (name, weight) pairs in
    /// units of the prior sigmas, and `data_to_prior`, its data-only sigma
    /// over the prior's) and `statements` (in words, as `parcal calibrate`
    /// prints them); `None` when not computed.
    #[getter]
    fn identifiability<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyAny>>> {
        if self.record.identifiability.is_none() {
            return Ok(None);
        }
        let dict = to_python(py, &self.record.identifiability)?;
        dict.set_item("statements", identifiability_statements(&self.record))?;
        Ok(Some(dict))
    }

    /// calibration.json's content as a dict (its `format` included).
    fn to_dict<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        py.import("json")?.call_method1("loads", (self.to_json()?,))
    }

    /// calibration.json's text: the bytes `parcal calibrate` writes for
    /// the same data and options.
    fn to_json(&self) -> PyResult<String> {
        crate::convert::written_text(parcal::dataset::mechanism::CALIBRATION_FILE, |path| {
            self.record.write(path)
        })
    }

    /// Writes calibration.json to `path` (atomically: the whole file, or
    /// the file as it was).
    fn write(&self, path: PathBuf) -> PyResult<()> {
        self.record.write(&path).map_err(to_py)
    }

    fn __repr__(&self) -> String {
        format!(
            "parcal.MechanismCalibration({}: {}, {} parameters, {})",
            self.record.mechanism,
            self.verdict(),
            self.record.parameters.len(),
            self.record.status
        )
    }
}

impl MechanismCalibration {
    /// One number of every parameter, NaN where it has none.
    fn column<'py>(
        &self,
        py: Python<'py>,
        of: impl Fn(&parcal::dataset::mechanism::ParameterRecord) -> Option<f64>,
    ) -> Bound<'py, PyArray1<f64>> {
        let values: Vec<f64> = self
            .record
            .parameters
            .iter()
            .map(|p| of(p).unwrap_or(f64::NAN))
            .collect();
        PyArray1::from_vec(py, values)
    }
}
