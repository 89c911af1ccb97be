//! `parcal.Calibration`: a calibration's result, as calibration.json
//! holds it (`to_json`), with its numbers as numpy arrays.

use std::path::PathBuf;

use numpy::{PyArray1, PyArray2};
use parcal::calibration::observation::ObservationId;
use parcal::command::RecordedRun;
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::convert::{array2, to_python};
use crate::error::to_py;

/// Every observation's test at the final state: the columns of
/// `Calibration.observations`.
#[derive(Default)]
struct ObservationTests {
    /// `contact`, `distance`, `pose` or `point`.
    kind: Vec<&'static str>,
    /// Its row (0-based) in the dataset given: measurements, distances,
    /// poses or points.
    index: Vec<usize>,
    /// Its redundancy number (the sum over its rows).
    redundancy: Vec<f64>,
    /// The normalised residual `w = e / √r` of its row of largest `|w|`
    /// (NaN when no other observation checks it).
    normalised: Vec<f64>,
    /// That row's whitened residual `e` (in units of its sigma).
    residual: Vec<f64>,
    /// Its estimated gross error `w / √r` (in sigmas of what its test
    /// sees: a contact's over its redundancy, a pose's or a point's row
    /// over that row's).
    gross_error: Vec<f64>,
}

impl ObservationTests {
    /// The tests of `recorded`'s run, by the observations' places in the
    /// dataset given; empty when the run has none (it did not converge).
    fn of(recorded: &RecordedRun) -> Self {
        let mut tests = Self::default();
        let Some(reliability) = &recorded.run.reliability else {
            return tests;
        };
        for check in reliability.observations() {
            let (kind, index) = match recorded.original(check.observation()) {
                ObservationId::Contact(k) => ("contact", k),
                ObservationId::Distance(k) => ("distance", k),
                ObservationId::Pose(k) => ("pose", k),
                ObservationId::Point(k) => ("point", k),
            };
            tests.kind.push(kind);
            tests.index.push(index);
            tests.redundancy.push(check.redundancy());
            tests
                .normalised
                .push(check.normalised().unwrap_or(f64::NAN));
            tests.residual.push(check.residual().unwrap_or(f64::NAN));
            tests
                .gross_error
                .push(check.gross_error().unwrap_or(f64::NAN));
        }
        tests
    }
}

/// A calibration: its verdict and reasons, the identified parameters with
/// their sigmas and covariance, the ball centres, every observation's
/// test, and calibration.json (`to_json`, `write`) exactly as `parcal
/// calibrate` writes it for the same data and options.
#[pyclass(module = "parcal", frozen)]
pub struct Calibration {
    /// calibration.json's content, provenance included.
    record: parcal::Calibration,
    /// Every observation's test; `None` for a calibration read back
    /// (calibration.json keeps their summary, not each test).
    tests: Option<ObservationTests>,
    /// A calibration with poses or points: their residuals.
    instrument_residuals: Option<InstrumentResiduals>,
}

/// The residuals of the poses and points of a calibration at the
/// identified state (mm).
struct InstrumentResiduals {
    /// Each pose's leg-length residuals.
    legs: Vec<[f64; 6]>,
    /// Each point's residual.
    points: Vec<[f64; 3]>,
}

impl Calibration {
    /// The result of `recorded`, its record stamped with `provenance`.
    pub fn new(recorded: RecordedRun, provenance: parcal::dataset::Provenance) -> Self {
        let tests = ObservationTests::of(&recorded);
        let RecordedRun {
            run, mut record, ..
        } = recorded;
        record.provenance = Some(provenance);
        let instrument_residuals = run.instruments.map(|instruments| InstrumentResiduals {
            legs: instruments.leg_residuals,
            points: instruments
                .point_residuals
                .iter()
                .map(|r| [r.x, r.y, r.z])
                .collect(),
        });
        Self {
            record,
            tests: Some(tests),
            instrument_residuals,
        }
    }
}

impl Calibration {
    /// calibration.json's content.
    pub fn record(&self) -> &parcal::Calibration {
        &self.record
    }
}

#[pymethods]
impl Calibration {
    /// Reads a hexapod's calibration.json at `path`: its verdict, reasons,
    /// parameters, covariance and ball centres; `observations`,
    /// `normalised_residuals`, `leg_residuals` and `point_residuals` are
    /// `None`, since the file keeps a summary of the tests and residuals
    /// rather than each.
    #[staticmethod]
    fn read(path: PathBuf) -> PyResult<Self> {
        let record = parcal::Calibration::read(&path).map_err(to_py)?;
        Ok(Self {
            record,
            tests: None,
            instrument_residuals: None,
        })
    }

    /// `"accepted"` or `"rejected"`.
    #[getter]
    fn verdict(&self) -> &str {
        &self.record.verdict
    }

    /// Why the verdict, one sentence each.
    #[getter]
    fn reasons(&self) -> Vec<String> {
        self.record.reasons.clone()
    }

    /// Every warning of the run, one sentence each.
    #[getter]
    fn warnings(&self) -> Vec<String> {
        self.record.warnings.clone()
    }

    /// The solver's iterations (linear solves).
    #[getter]
    fn iterations(&self) -> usize {
        self.record.iterations.len()
    }

    /// The parameters' prior standard deviations, in the order of `names`
    /// (NaN: no prior on it); `None` when calibration.json does not state
    /// them.
    #[getter]
    fn prior_sigmas<'py>(&self, py: Python<'py>) -> Option<Bound<'py, PyArray1<f64>>> {
        let sigmas = &self.record.diagnostics.as_ref()?.prior_sigma;
        (!sigmas.is_empty())
            .then(|| PyArray1::from_vec(py, sigmas.iter().map(|s| s.unwrap_or(f64::NAN)).collect()))
    }

    /// The global test of the variance factor (a dict as calibration.json
    /// holds it), or `None` when it was not made.
    #[getter]
    fn global_test<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        to_python(py, &self.record.global_test)
    }

    /// The observations data snooping removed, in order (dicts as
    /// calibration.json holds them: `file`, `line`, `normalised_residual`,
    /// `gross_error_sigmas`, the variance factor before and after).
    #[getter]
    fn removed<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        to_python(py, &self.record.removed_observations)
    }

    /// Whether the solver converged.
    #[getter]
    fn converged(&self) -> bool {
        self.record.converged
    }

    /// How the solver's run ended.
    #[getter]
    fn status(&self) -> &str {
        &self.record.status
    }

    /// The identified parameters' names (`x_b1` .. `z_t`, then any
    /// actuator scales and instrument parameters).
    #[getter]
    fn names(&self) -> Vec<String> {
        self.record.parameters.names.clone()
    }

    /// The identified parameters' values (mm, rad), in the order of `names`.
    #[getter]
    fn values<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        PyArray1::from_slice(py, &self.record.parameters.values)
    }

    /// Their posterior standard deviations.
    #[getter]
    fn sigmas<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        PyArray1::from_slice(py, &self.record.parameters.sigma)
    }

    /// Their posterior covariance (n x n; 0 x 0 when it could not be
    /// computed).
    #[getter]
    fn covariance<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let n = self.record.covariance.len();
        PyArray2::from_vec2(py, &self.record.covariance)
            .map_err(to_py)
            .map(|a| {
                if n == 0 {
                    PyArray2::zeros(py, [0, 0], false)
                } else {
                    a
                }
            })
    }

    /// The identified ball centres (canonical base frame, mm), by ball id.
    #[getter]
    fn ball_ids(&self) -> Vec<String> {
        self.record.ball_centres.keys().cloned().collect()
    }

    /// The identified ball centres (n x 3, mm), in the order of `ball_ids`.
    #[getter]
    fn ball_centres<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        let centres: Vec<[f64; 3]> = self
            .record
            .ball_centres
            .values()
            .map(|c| c.centre)
            .collect();
        array2(py, &centres)
    }

    /// Their posterior standard deviations (n x 3, mm).
    #[getter]
    fn ball_centre_sigmas<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        let sigmas: Vec<[f64; 3]> = self.record.ball_centres.values().map(|c| c.sigma).collect();
        array2(py, &sigmas)
    }

    /// Every observation's test at the final state (empty when the run did
    /// not converge), as arrays of one entry per observation: `kind`
    /// (`contact`, `distance`, `pose`, `point`), `index` (its row in the
    /// dataset given: measurements, distances, poses, points; 0-based),
    /// `redundancy` (its redundancy number), `normalised_residual` (`w`
    /// of its row of largest `|w|`; NaN when nothing checks it),
    /// `residual` (that row's whitened residual, in sigmas) and
    /// `gross_error` (its estimated gross error `w / √r`, in sigmas of what
    /// its test sees: a contact's over its redundancy, tested as one; a
    /// pose's or a point's row over that row's, `e / r`).
    /// `None` for a calibration read back.
    #[getter]
    fn observations<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyDict>>> {
        let Some(t) = &self.tests else {
            return Ok(None);
        };
        let dict = PyDict::new(py);
        dict.set_item("kind", t.kind.clone())?;
        dict.set_item(
            "index",
            PyArray1::from_vec(py, t.index.iter().map(|&k| k as i64).collect()),
        )?;
        dict.set_item("redundancy", PyArray1::from_slice(py, &t.redundancy))?;
        dict.set_item(
            "normalised_residual",
            PyArray1::from_slice(py, &t.normalised),
        )?;
        dict.set_item("residual", PyArray1::from_slice(py, &t.residual))?;
        dict.set_item("gross_error", PyArray1::from_slice(py, &t.gross_error))?;
        Ok(Some(dict))
    }

    /// The normalised residual of every observation (`observations`'
    /// `normalised_residual`); `None` for a calibration read back.
    #[getter]
    fn normalised_residuals<'py>(&self, py: Python<'py>) -> Option<Bound<'py, PyArray1<f64>>> {
        (self.tests.as_ref()).map(|t| PyArray1::from_slice(py, &t.normalised))
    }

    /// Each pose's leg-length residuals `|T E_i - B_i| - L_i` at the
    /// identified state (n x 6, mm); `None` for a calibration without
    /// poses or points, or read back.
    #[getter]
    fn leg_residuals<'py>(&self, py: Python<'py>) -> Option<Bound<'py, PyArray2<f64>>> {
        self.instrument_residuals
            .as_ref()
            .map(|r| array2(py, &r.legs))
    }

    /// Each point's residual (n x 3, mm); `None` for a calibration
    /// without poses or points, or read back.
    #[getter]
    fn point_residuals<'py>(&self, py: Python<'py>) -> Option<Bound<'py, PyArray2<f64>>> {
        self.instrument_residuals
            .as_ref()
            .map(|r| array2(py, &r.points))
    }

    /// calibration.json's content as a dict (`json.loads(to_json())`).
    fn to_dict<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        py.import("json")?.call_method1("loads", (self.to_json()?,))
    }

    /// calibration.json's text: the bytes `parcal calibrate` writes for
    /// the same data (given by the same path) and options.
    fn to_json(&self) -> PyResult<String> {
        crate::convert::written_text(parcal::dataset::CALIBRATION_FILE, |path| {
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
            "parcal.Calibration({}, {} parameters, {})",
            self.record.verdict,
            self.record.parameters.names.len(),
            self.record.status
        )
    }
}
