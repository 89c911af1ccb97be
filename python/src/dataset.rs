//! `parcal.Dataset`: a dataset read from files (a directory or a
//! snapshot), or built in memory from what machine.json and artefacts.json
//! hold (dicts) and the measurements as arrays.

use std::collections::HashMap;
use std::path::PathBuf;

use numpy::{PyArray1, PyArray2};
use parcal::command::read_dataset;
use parcal::dataset::IN_MEMORY;
use parcal::dataset::{ARTEFACTS_FILE, MACHINE_FILE};
use parcal::workflows::evaluate::TrueMachine;
use parcal::{Artefacts, Machine, Measurements, PARAM_NAMES, Points, Poses, Tracker};
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::convert::{array2, known_keys, rows, through_file, to_python};
use crate::error::to_py;

/// A calibration dataset: the machine, the artefacts (balls and calibrated
/// distances) and the measurements (ball touches; poses and points of an
/// instrument).
///
/// `Dataset.read(path)` reads a directory of files or a snapshot
/// (dataset.bin); `Dataset(machine, artefacts, ball, q)` builds one in
/// memory: `machine` and `artefacts` hold what machine.json and
/// artefacts.json hold, `ball` the touched ball's id of each contact and
/// `q` its six actuator readings (n x 6). `poses` (a dict of `session`,
/// `q` n x 6, `position` n x 3, `orientation` n x 4 quaternions x, y, z,
/// w) and `points` (`session`, `q`, `position`) add instrument
/// measurements; sessions are labels, numbered in order of first
/// appearance.
#[pyclass(module = "parcal", frozen)]
pub struct Dataset {
    /// The dataset.
    pub inner: parcal::Dataset,
    /// The dataset as it was given (its path, or [`IN_MEMORY`]), for
    /// calibration.json's provenance.
    pub given: String,
}

impl Dataset {
    /// `inner`, made in memory.
    pub fn in_memory(inner: parcal::Dataset) -> Self {
        Self {
            inner,
            given: IN_MEMORY.to_string(),
        }
    }
}

impl Dataset {
    /// Reads the dataset at `path`: a directory of files, or a binary
    /// snapshot.
    pub fn read_from(py: Python<'_>, path: PathBuf) -> PyResult<Self> {
        let inner = py.detach(|| read_dataset(&path)).map_err(to_py)?;
        Ok(Self {
            inner,
            given: path.display().to_string(),
        })
    }
}

#[pymethods]
impl Dataset {
    #[new]
    #[pyo3(signature = (machine, artefacts=None, ball=None, q=None, direction=None, poses=None, points=None))]
    fn new(
        machine: &Bound<'_, PyAny>,
        artefacts: Option<&Bound<'_, PyAny>>,
        ball: Option<Vec<String>>,
        q: Option<&Bound<'_, PyAny>>,
        direction: Option<&Bound<'_, PyAny>>,
        poses: Option<&Bound<'_, PyDict>>,
        points: Option<&Bound<'_, PyDict>>,
    ) -> PyResult<Self> {
        let (machine, artefacts) = read_json_files(machine, artefacts)?;
        let measurements = measurements(&artefacts, ball, q, direction)?;
        let mut tracker = Tracker::default();
        if let Some(poses) = poses {
            known_keys(poses, "poses", &["session", "q", "position", "orientation"])?;
            let Points {
                session,
                q,
                position,
            } = instrument_rows(poses, "poses", &mut tracker.sessions)?;
            let orientation = rows::<4>(
                &required(poses, "poses", "orientation")?,
                "poses[\"orientation\"]",
            )?;
            if orientation.len() != q.len() {
                return Err(to_py(format!(
                    "poses: orientation has {} rows and q {}: one of each per row",
                    orientation.len(),
                    q.len()
                )));
            }
            tracker.poses = Poses {
                session,
                q,
                position,
                orientation,
            };
        }
        if let Some(points) = points {
            known_keys(points, "points", &["session", "q", "position"])?;
            tracker.points = instrument_rows(points, "points", &mut tracker.sessions)?;
        }
        let dataset = parcal::Dataset {
            machine,
            artefacts,
            measurements,
            tracker,
            truth: None,
        };
        // Checked as a calibration checks it first, so that a bad value is
        // refused here, by its 0-based row and its field.
        parcal::calibration::validate(&dataset).map_err(to_py)?;
        Ok(Self::in_memory(dataset))
    }

    /// Reads the dataset at `path`: a directory of files, or a binary
    /// snapshot (dataset.bin).
    #[staticmethod]
    fn read(py: Python<'_>, path: PathBuf) -> PyResult<Self> {
        Self::read_from(py, path)
    }

    /// Writes the dataset: a directory of files at `path` (which must not
    /// exist, or be empty), or with `snapshot=True` one binary snapshot
    /// file.
    #[pyo3(signature = (path, snapshot=false))]
    fn write(&self, py: Python<'_>, path: PathBuf, snapshot: bool) -> PyResult<()> {
        py.detach(|| {
            if snapshot {
                self.inner.write_snapshot(&path)
            } else {
                self.inner.write(&path)
            }
        })
        .map_err(to_py)
    }

    /// machine.json's content, as the dataset writes it (what
    /// `Dataset(machine, ...)` takes).
    #[getter]
    fn machine<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let text = self.inner.machine.to_json().map_err(to_py)?;
        py.import("json")?.call_method1("loads", (text,))
    }

    /// The balls' ids, in artefacts.json's order.
    #[getter]
    fn ball_ids(&self) -> Vec<String> {
        self.inner
            .artefacts
            .balls
            .iter()
            .map(|b| b.id.clone())
            .collect()
    }

    /// The touched ball's id of each contact.
    #[getter]
    fn ball(&self) -> Vec<String> {
        let balls = &self.inner.artefacts.balls;
        self.inner
            .measurements
            .ball
            .iter()
            .map(|&b| balls[b as usize].id.clone())
            .collect()
    }

    /// The actuator readings of each contact (n x 6).
    #[getter]
    fn q<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        array2(py, &self.inner.measurements.q)
    }

    /// The number of ball touches.
    #[getter]
    fn contacts(&self) -> usize {
        self.inner.measurements.len()
    }

    /// The instrument sessions' labels.
    #[getter]
    fn sessions(&self) -> Vec<String> {
        self.inner.tracker.sessions.clone()
    }

    /// The measured poses: `session` (labels), `q` (n x 6), `position`
    /// (n x 3), `orientation` (n x 4).
    #[getter]
    fn poses<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let poses = &self.inner.tracker.poses;
        let dict = instrument_dict(
            py,
            &self.inner.tracker.sessions,
            &poses.session,
            &poses.q,
            &poses.position,
        )?;
        dict.set_item("orientation", array2(py, &poses.orientation))?;
        Ok(dict)
    }

    /// The measured tool points: `session` (labels), `q` (n x 6),
    /// `position` (n x 3).
    #[getter]
    fn points<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let points = &self.inner.tracker.points;
        instrument_dict(
            py,
            &self.inner.tracker.sessions,
            &points.session,
            &points.q,
            &points.position,
        )
    }

    /// A simulated dataset's truth (truth.json) in the terms of its
    /// calibration's values: `names` and `canonical` (the true machine's
    /// 33 parameters in its canonical frames, in the order of a
    /// `Calibration`'s first 33 `names`), `ball_centres` (n x 3, mm, in
    /// the true canonical base frame, where a calibration's centres are) and
    /// `ball_radii` (n), both in the order of `ball_ids`, `actuator_scale`
    /// (the legs' true scales, or `None` when machine.json has no
    /// `actuator`) and `geometry` (truth.json's geometry as written, in
    /// machine.json's frames); `None` for measured data.
    #[getter]
    fn truth<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyDict>>> {
        let (Some(record), Some(truth)) = (&self.inner.truth, TrueMachine::of(&self.inner)) else {
            return Ok(None);
        };
        let truth = truth.map_err(|e| {
            to_py(format!(
                "{}: truth.json: the true geometry is degenerate: {e}",
                self.given
            ))
        })?;
        let centres: Vec<[f64; 3]> = truth.centres.iter().map(|c| [c.x, c.y, c.z]).collect();
        let dict = PyDict::new(py);
        dict.set_item("names", PARAM_NAMES.to_vec())?;
        dict.set_item(
            "canonical",
            PyArray1::from_slice(py, truth.params.as_slice()),
        )?;
        dict.set_item("ball_centres", array2(py, &centres))?;
        dict.set_item("ball_radii", PyArray1::from_slice(py, &record.ball_radii))?;
        dict.set_item(
            "actuator_scale",
            (record.actuator_scale).map(|scale| PyArray1::from_slice(py, &scale)),
        )?;
        dict.set_item("geometry", to_python(py, &record.geometry)?)?;
        Ok(Some(dict))
    }

    /// What was measured, as a checksum (calibration.json's provenance).
    #[getter]
    fn checksum(&self) -> String {
        self.inner.checksum()
    }

    fn __repr__(&self) -> String {
        let d = &self.inner;
        format!(
            "parcal.Dataset({}: {} balls, {} contacts, {} poses, {} points)",
            self.given,
            d.artefacts.balls.len(),
            d.measurements.len(),
            d.tracker.poses.len(),
            d.tracker.points.len()
        )
    }
}

/// machine.json's and artefacts.json's content (`artefacts` absent: no
/// balls), read by the files' own readers, which check them and name the
/// field (`machine.json: prior_sigma.base: ...`).
fn read_json_files(
    machine: &Bound<'_, PyAny>,
    artefacts: Option<&Bound<'_, PyAny>>,
) -> PyResult<(Machine, Artefacts)> {
    let machine = through_file(machine, "parcal-machine/1", MACHINE_FILE, Machine::read)?;
    let artefacts = match artefacts {
        Some(artefacts) => through_file(
            artefacts,
            "parcal-artefacts/1",
            ARTEFACTS_FILE,
            Artefacts::read,
        )?,
        None => Artefacts::default(),
    };
    Ok((machine, artefacts))
}

/// The touches: each contact's ball (by id, resolved against
/// `artefacts`), its readings and, if given, its approach direction.
fn measurements(
    artefacts: &Artefacts,
    ball: Option<Vec<String>>,
    q: Option<&Bound<'_, PyAny>>,
    direction: Option<&Bound<'_, PyAny>>,
) -> PyResult<Measurements> {
    let (ball, q) = match (ball, q) {
        (Some(ball), Some(q)) => (ball, rows::<6>(q, "q")?),
        (None, None) => return Ok(Measurements::default()),
        _ => {
            return Err(to_py(
                "ball and q: give both (the touched ball's id and the readings of each contact), or neither",
            ));
        }
    };
    if ball.len() != q.len() {
        return Err(to_py(format!(
            "ball has {} rows and q {}: one of each per contact",
            ball.len(),
            q.len()
        )));
    }
    let index: HashMap<&str, u32> = artefacts
        .balls
        .iter()
        .zip(0..)
        .map(|(b, i)| (b.id.as_str(), i))
        .collect();
    let ball = ball
        .iter()
        .enumerate()
        .map(|(row, id)| {
            index.get(id.as_str()).copied().ok_or_else(|| {
                to_py(format!(
                    "measurement row {row}, field ball: unknown ball id {id:?} (not in artefacts)"
                ))
            })
        })
        .collect::<PyResult<Vec<u32>>>()?;
    let direction = direction.map(|d| rows::<3>(d, "direction")).transpose()?;
    if let Some(direction) = &direction
        && direction.len() != q.len()
    {
        return Err(to_py(format!(
            "direction has {} rows and q {}: one of each per contact",
            direction.len(),
            q.len()
        )));
    }
    Ok(Measurements { ball, q, direction })
}

/// A dict's entry `key`, required.
fn required<'py>(dict: &Bound<'py, PyDict>, what: &str, key: &str) -> PyResult<Bound<'py, PyAny>> {
    dict.get_item(key)?
        .ok_or_else(|| to_py(format!("{what}: missing {key:?}")))
}

/// The rows of poses or points (`what`): each row's session (its label
/// numbered in `sessions`, in order of first appearance), readings and
/// position (the poses' orientations apart).
fn instrument_rows(
    dict: &Bound<'_, PyDict>,
    what: &str,
    sessions: &mut Vec<String>,
) -> PyResult<Points> {
    let q = rows::<6>(&required(dict, what, "q")?, &format!("{what}[\"q\"]"))?;
    let position = rows::<3>(
        &required(dict, what, "position")?,
        &format!("{what}[\"position\"]"),
    )?;
    let labels: Vec<String> = match dict.get_item("session")? {
        Some(labels) => labels
            .try_iter()?
            .map(|label| label.and_then(|l| l.str()).map(|l| l.to_string()))
            .collect::<PyResult<_>>()?,
        None => vec![parcal::dataset::DEFAULT_SESSION.to_string(); q.len()],
    };
    if labels.len() != q.len() || position.len() != q.len() {
        return Err(to_py(format!(
            "{what}: session, q and position have {}, {} and {} rows: one of each per row",
            labels.len(),
            q.len(),
            position.len()
        )));
    }
    let session = labels
        .into_iter()
        .map(|label| {
            let k = sessions
                .iter()
                .position(|s| *s == label)
                .unwrap_or_else(|| {
                    sessions.push(label);
                    sessions.len() - 1
                });
            u32::try_from(k).map_err(to_py)
        })
        .collect::<PyResult<_>>()?;
    Ok(Points {
        session,
        q,
        position,
    })
}

/// Rows of poses or points as a dict of their session labels and arrays.
fn instrument_dict<'py>(
    py: Python<'py>,
    sessions: &[String],
    session: &[u32],
    q: &[[f64; 6]],
    position: &[[f64; 3]],
) -> PyResult<Bound<'py, PyDict>> {
    let dict = PyDict::new(py);
    let labels: Vec<&str> = session
        .iter()
        .map(|&s| sessions[s as usize].as_str())
        .collect();
    dict.set_item("session", labels)?;
    dict.set_item("q", array2(py, q))?;
    dict.set_item("position", array2(py, position))?;
    Ok(dict)
}
