//! `parcal.MechanismDataset`: the dataset of a mechanism other than the
//! hexapod (a linear delta, a cable robot), read from its directory
//! (machine.json naming the mechanism, probes.csv, distances.csv,
//! points.csv, quantities.csv, balls.csv, touches.csv,
//! ball_distances.csv, tracker_points.csv, truth.json), its parameters and
//! observations as numpy arrays.

use std::path::{Path, PathBuf};

use numpy::{PyArray1, PyArray2};
use parcal::MechanismData;
use parcal::MechanismDataset as Inner;
use parcal::dataset::Distance;
use parcal::dataset::IN_MEMORY;
use parcal::dataset::mechanism::{
    BallPlacement, BallRow, MACHINE_FILE, MechanismMachine, QuantityRow, RowNames, SampleRow,
    TRIGGER_HEIGHT, TouchRow, TrackerPointRow,
};
use parcal::kinematics::mechanism::Mechanism;
use pyo3::prelude::*;
use pyo3::types::PyDict;

use super::data_error;
use crate::convert::{
    array2, known_keys, rows, table, table_rows, table_rows_of, through_file, to_python,
    written_text,
};
use crate::error::to_py;

/// A mechanism dataset: its machine (the mechanism by name, the
/// configured and design parameters, the tolerances as prior sigmas, the
/// noise) and its observations: probe heights, heights measured by hand,
/// part distances, encoder samples (readings, with the position where
/// measured and the loads where given) and quantities measured directly.
///
/// `MechanismDataset.read(path)` reads a directory whose machine.json
/// names its `"mechanism"`; `parcal.read_dataset(path)` reads either kind.
/// `MechanismDataset(machine, probes=, heights=, distances=, samples=,
/// quantities=)` builds one in memory: `machine` holds what machine.json
/// holds, `probes` n x 3, `heights` n x 4, `distances` n x 7, `samples` a dict of `readings` (n x A),
/// `position` (n x 3, a row of NaN where not measured; `measured`, n
/// booleans, optional, must agree) and `loads` (n x A), `quantities` a dict of `quantity`, `value`, `sigma`, `balls`
/// n x 2 (`radius`, `radius_sigma`, 0 for an exact radius), `touches`
/// n x 4 (`ball`, the commanded `x, y, z`), `ball_distances` n x 4
/// (`first, second, distance, sigma`: two balls' numbers and the
/// calibrated distance between their centres, mm), `tracker_points` a dict
/// of `tracker` (a label per row), `commanded` (n x 3) and `measured`
/// (n x 3, in the tracker's frame); they are checked as the files are, and
/// messages name the files they would be.
#[pyclass(module = "parcal", frozen)]
pub struct MechanismDataset {
    /// The dataset as read.
    pub inner: Inner,
    /// Its data as the calibration takes them (mechanism, priors,
    /// observations with their sigmas).
    pub data: MechanismData,
    /// The directory it was read from, for messages.
    pub path: PathBuf,
}

impl MechanismDataset {
    /// Whether the dataset was read from files (not made in memory): its
    /// observations are then named by their files' lines.
    pub fn read_from_files(&self) -> bool {
        self.path != Path::new(IN_MEMORY)
    }

    /// The mechanism of the dataset's data.
    fn model(&self) -> &dyn Mechanism {
        self.data.mechanism.as_ref()
    }

    /// Reads the dataset in directory `path`.
    pub fn read_from(py: Python<'_>, path: PathBuf) -> PyResult<Self> {
        let inner = py.detach(|| Inner::read(&path)).map_err(to_py)?;
        let data = MechanismData::from_dataset(&inner)
            .map_err(|e| data_error(&path, &inner.machine.mechanism, e))?;
        Ok(Self { inner, data, path })
    }

    /// The dataset `inner`, made in memory (built or simulated), checked
    /// as its files would be.
    pub fn in_memory(inner: Inner) -> PyResult<Self> {
        let path = PathBuf::from(IN_MEMORY);
        (inner.validate_named(&path, RowNames::Indices)).map_err(to_py)?;
        let data = MechanismData::from_dataset(&inner)
            .map_err(|e| data_error(&path, &inner.machine.mechanism, e))?;
        Ok(Self { inner, data, path })
    }
}

#[pymethods]
impl MechanismDataset {
    #[new]
    #[pyo3(signature = (machine, *, probes=None, heights=None, distances=None, samples=None, quantities=None, balls=None, touches=None, ball_distances=None, tracker_points=None))]
    #[allow(clippy::too_many_arguments)]
    fn new(
        machine: &Bound<'_, PyAny>,
        probes: Option<&Bound<'_, PyAny>>,
        heights: Option<&Bound<'_, PyAny>>,
        distances: Option<&Bound<'_, PyAny>>,
        samples: Option<&Bound<'_, PyDict>>,
        quantities: Option<&Bound<'_, PyDict>>,
        balls: Option<&Bound<'_, PyAny>>,
        touches: Option<&Bound<'_, PyAny>>,
        ball_distances: Option<&Bound<'_, PyAny>>,
        tracker_points: Option<&Bound<'_, PyDict>>,
    ) -> PyResult<Self> {
        let machine = through_file(
            machine,
            "parcal-machine/1",
            MACHINE_FILE,
            MechanismMachine::read,
        )?;
        let actuators = machine
            .mechanism()
            .expect("machine.json's reader knows the mechanism")
            .actuators()
            .len();
        let inner = Inner {
            probes: probes
                .map(|p| rows::<3>(p, "probes"))
                .transpose()?
                .unwrap_or_default(),
            heights: heights
                .map(|h| rows::<4>(h, "heights"))
                .transpose()?
                .unwrap_or_default(),
            distances: distances
                .map(|d| rows::<7>(d, "distances"))
                .transpose()?
                .unwrap_or_default(),
            samples: samples
                .map(|s| sample_rows(s, actuators))
                .transpose()?
                .unwrap_or_default(),
            quantities: quantities
                .map(quantity_rows)
                .transpose()?
                .unwrap_or_default(),
            balls: balls.map(ball_rows).transpose()?.unwrap_or_default(),
            touches: touches.map(touch_rows).transpose()?.unwrap_or_default(),
            ball_distances: ball_distances
                .map(ball_distance_rows)
                .transpose()?
                .unwrap_or_default(),
            tracker_points: tracker_points
                .map(tracker_point_rows)
                .transpose()?
                .unwrap_or_default(),
            truth: None,
            machine,
        };
        Self::in_memory(inner)
    }

    /// Reads the mechanism dataset in directory `path` (machine.json
    /// naming its mechanism); the messages of a bad file name the file,
    /// the line and the column or field.
    #[staticmethod]
    fn read(py: Python<'_>, path: PathBuf) -> PyResult<Self> {
        Self::read_from(py, path)
    }

    /// Writes the dataset as directory `path` (which must not exist, or be
    /// empty), as a set: the whole directory, or nothing.
    fn write(&self, py: Python<'_>, path: PathBuf) -> PyResult<()> {
        py.detach(|| self.inner.write(&path)).map_err(to_py)
    }

    /// The mechanism's name (`"linear delta"`, `"cable robot"`).
    #[getter]
    fn mechanism(&self) -> &str {
        &self.inner.machine.mechanism
    }

    /// machine.json's content, as the dataset writes it.
    #[getter]
    fn machine<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let text = written_text(MACHINE_FILE, |path| self.inner.machine.write(path))?;
        py.import("json")?.call_method1("loads", (text,))
    }

    /// The mechanism's parameters' names, in its order (the order of every
    /// array of parameters).
    #[getter]
    fn parameters(&self) -> Vec<String> {
        self.model()
            .parameters()
            .iter()
            .map(|p| p.name.clone())
            .collect()
    }

    /// Their units (`mm`, `rad`...).
    #[getter]
    fn units(&self) -> Vec<String> {
        self.model()
            .parameters()
            .iter()
            .map(|p| p.unit.to_string())
            .collect()
    }

    /// Their groups (`anchors`, `diagonal rods`...), which machine.json's
    /// tolerances name.
    #[getter]
    fn groups(&self) -> Vec<&'static str> {
        self.model().parameters().iter().map(|p| p.group).collect()
    }

    /// The values the controller ran with (machine.json's `configured`).
    #[getter]
    fn configured<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        PyArray1::from_slice(py, &self.inner.machine.configured)
    }

    /// The design: the priors' means (machine.json's `design`, else
    /// `configured`).
    #[getter]
    fn design<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        PyArray1::from_slice(py, &self.inner.machine.design)
    }

    /// The priors' standard deviations: the mechanism's, overridden per
    /// group by machine.json's tolerances (NaN: no prior).
    #[getter]
    fn prior_sigmas<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        let sigmas: Vec<f64> = self
            .data
            .priors
            .iter()
            .map(|p| p.sigma.unwrap_or(f64::NAN))
            .collect();
        PyArray1::from_vec(py, sigmas)
    }

    /// machine.json's noise: `probe`, `actuator`, `position`, `distance`
    /// (only those given).
    #[getter]
    fn noise<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        to_python(py, &self.inner.machine.noise)
    }

    /// The probe's trigger height: `{"value": mm, "sigma": mm}` (no
    /// `sigma`: no prior), or `None` for a machine without a probe.
    #[getter]
    fn trigger_height<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        to_python(py, &self.inner.machine.trigger_height)
    }

    /// A printer's printable radius (mm), as its firmware holds it, or
    /// `None` when machine.json states none.
    #[getter]
    fn print_radius(&self) -> Option<f64> {
        self.inner.machine.print_radius
    }

    /// The probe heights (n x 3, probes.csv's `x, y, z`: the commanded
    /// position and the height at which the probe triggered, mm).
    #[getter]
    fn probes<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        array2(py, &self.inner.probes)
    }

    /// The heights measured by hand (n x 4, heights.csv's `x, y, z,
    /// height`: the commanded position and the nozzle's height above the
    /// bed measured there, mm).
    #[getter]
    fn heights<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        array2(py, &self.inner.heights)
    }

    /// The part distances (n x 7, distances.csv's `x1, y1, z1, x2, y2,
    /// z2, distance`, mm).
    #[getter]
    fn distances<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        array2(py, &self.inner.distances)
    }

    /// The samples of points.csv: `readings` (n x A, the actuators'
    /// unit), `position` (n x 3 mm, NaN where not measured), `measured`
    /// (n booleans: the position was measured) and `loads` (n x A, NaN
    /// where not given; `None` when no row gives them).
    #[getter]
    fn samples<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let samples = &self.inner.samples;
        let actuators = self.model().actuators().len();
        let table = |row: &dyn Fn(&SampleRow) -> Option<&[f64]>, width: usize| {
            let flat: Vec<f64> = samples
                .iter()
                .flat_map(|sample| match row(sample) {
                    Some(values) => values.to_vec(),
                    None => vec![f64::NAN; width],
                })
                .collect();
            table(py, flat, width)
        };
        let dict = PyDict::new(py);
        dict.set_item(
            "readings",
            table(&|s| Some(s.readings.as_slice()), actuators),
        )?;
        dict.set_item(
            "position",
            table(&|s| s.position.as_ref().map(|p| p.as_slice()), 3),
        )?;
        let measured: Vec<bool> = samples.iter().map(|s| s.position.is_some()).collect();
        dict.set_item("measured", PyArray1::from_vec(py, measured))?;
        let loads = if samples.iter().any(|s| s.loads.is_some()) {
            Some(table(&|s| s.loads.as_deref(), actuators))
        } else {
            None
        };
        dict.set_item("loads", loads)?;
        Ok(dict)
    }

    /// The quantities measured directly (quantities.csv): `quantity`
    /// (names), `value` and `sigma` (arrays).
    #[getter]
    fn quantities<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let rows = &self.inner.quantities;
        let dict = PyDict::new(py);
        let names: Vec<&str> = rows.iter().map(|r| r.quantity.as_str()).collect();
        let values: Vec<f64> = rows.iter().map(|r| r.value).collect();
        let sigmas: Vec<f64> = rows.iter().map(|r| r.sigma).collect();
        dict.set_item("quantity", names)?;
        dict.set_item("value", PyArray1::from_vec(py, values))?;
        dict.set_item("sigma", PyArray1::from_vec(py, sigmas))?;
        Ok(dict)
    }

    /// The calibrated balls (n x 2, balls.csv's `radius, radius_sigma`,
    /// mm; a sigma of 0: an exact radius); n x 6 if a ball has a placement,
    /// with its `x, y, z, centre_sigma` (NaN for a ball without).
    #[getter]
    fn balls<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        let balls = &self.inner.balls;
        let radius = |b: &BallRow| [b.radius, b.radius_sigma.unwrap_or(0.0)];
        if balls.iter().all(|b| b.placement.is_none()) {
            let rows: Vec<[f64; 2]> = balls.iter().map(radius).collect();
            return array2(py, &rows);
        }
        let rows: Vec<[f64; BALL_COLUMNS]> = balls
            .iter()
            .map(|b| {
                let [r, s] = radius(b);
                match b.placement {
                    Some(BallPlacement {
                        centre: [x, y, z],
                        sigma,
                    }) => [r, s, x, y, z, sigma],
                    None => [r, s, f64::NAN, f64::NAN, f64::NAN, f64::NAN],
                }
            })
            .collect();
        array2(py, &rows)
    }

    /// The touches of the balls (n x 4, touches.csv's `ball, x, y, z`: the
    /// ball's number and the commanded position, mm).
    #[getter]
    fn touches<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        let rows: Vec<[f64; 4]> = self
            .inner
            .touches
            .iter()
            .map(|t| {
                [
                    t.ball as f64,
                    t.commanded[0],
                    t.commanded[1],
                    t.commanded[2],
                ]
            })
            .collect();
        array2(py, &rows)
    }

    /// The trackers' points (tracker_points.csv): a dict of `tracker` (a
    /// label per row), `commanded` (n x 3, mm) and `measured` (n x 3, mm,
    /// the tracker's frame).
    #[getter]
    fn tracker_points<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let rows = &self.inner.tracker_points;
        let dict = PyDict::new(py);
        let labels: Vec<&str> = rows.iter().map(|r| r.tracker.as_str()).collect();
        let commanded: Vec<[f64; 3]> = rows.iter().map(|r| r.commanded).collect();
        let measured: Vec<[f64; 3]> = rows.iter().map(|r| r.measured).collect();
        dict.set_item("tracker", labels)?;
        dict.set_item("commanded", array2(py, &commanded))?;
        dict.set_item("measured", array2(py, &measured))?;
        Ok(dict)
    }

    /// The calibrated distances between the balls (n x 4,
    /// ball_distances.csv's `first, second, distance, sigma`: the two
    /// balls' numbers, the distance between their centres and its sigma,
    /// mm).
    #[getter]
    fn ball_distances<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        let rows: Vec<[f64; 4]> = self
            .inner
            .ball_distances
            .iter()
            .map(|d| [d.a as f64, d.b as f64, d.length, d.sigma])
            .collect();
        array2(py, &rows)
    }

    /// A simulated dataset's truth (truth.json): `parameters` (an array in
    /// the order of `parameters`), `canonical` (the same machine in the
    /// canonical frame a calibration's values are in, its gauge freedoms
    /// fixed), `trigger_height` (mm, or `None`), and `names` and `values`:
    /// the truth in the terms of this dataset's calibration, in the order
    /// of its `names` (`canonical`, then the trigger height where probe
    /// heights make it an unknown); `None` for measured data.
    #[getter]
    fn truth<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyDict>>> {
        let Some(truth) = &self.inner.truth else {
            return Ok(None);
        };
        let failed =
            |e: &dyn std::fmt::Display| to_py(format!("{}: truth.json: {e}", self.path.display()));
        let canonical = self
            .model()
            .canonicalize(&truth.parameters)
            .map_err(|e| failed(&e))?;
        let values = self.data.true_values(truth).map_err(|e| failed(&e))?;
        let mut names: Vec<&str> = (self.model().parameters().iter())
            .map(|p| p.name.as_str())
            .collect();
        if self.data.has_trigger_height() {
            names.push(TRIGGER_HEIGHT);
        }
        let dict = PyDict::new(py);
        dict.set_item("parameters", PyArray1::from_slice(py, &truth.parameters))?;
        dict.set_item("canonical", PyArray1::from_slice(py, canonical.as_slice()))?;
        dict.set_item("trigger_height", truth.trigger_height)?;
        dict.set_item("names", names)?;
        dict.set_item("values", PyArray1::from_vec(py, values))?;
        Ok(Some(dict))
    }

    fn __repr__(&self) -> String {
        let d = &self.inner;
        format!(
            "parcal.MechanismDataset({}: a {}, {} probe heights, {} part distances, {} samples, {} quantities)",
            self.path.display(),
            d.machine.mechanism,
            d.probes.len(),
            d.distances.len(),
            d.samples.len(),
            d.quantities.len()
        )
    }
}

/// The samples of a dict: `readings` (n x A), `position` (n x 3, a row of
/// NaN where not measured) and `loads` (n x A, a row of NaN where not
/// given), the last two optional; `measured` (n booleans), optional too,
/// must say which positions were given, as the `samples` property writes
/// it.
fn sample_rows(dict: &Bound<'_, PyDict>, actuators: usize) -> PyResult<Vec<SampleRow>> {
    known_keys(
        dict,
        "samples",
        &["readings", "position", "measured", "loads"],
    )?;
    let column = |key: &str, width: usize| -> PyResult<Option<Vec<Vec<f64>>>> {
        dict.get_item(key)?
            .filter(|value| !value.is_none())
            .map(|value| table_rows(&value, width, &format!("samples[{key:?}]")))
            .transpose()
    };
    let readings =
        column("readings", actuators)?.ok_or_else(|| to_py("samples: missing \"readings\""))?;
    let positions = column("position", 3)?;
    let loads = column("loads", actuators)?;
    for (key, rows) in [("position", &positions), ("loads", &loads)] {
        if let Some(rows) = rows
            && rows.len() != readings.len()
        {
            return Err(to_py(format!(
                "samples: {key} has {} rows and readings {}: one of each per sample",
                rows.len(),
                readings.len()
            )));
        }
    }
    let given = |rows: &Option<Vec<Vec<f64>>>, k: usize| {
        rows.as_ref()
            .map(|rows| rows[k].clone())
            .filter(|row| !row.iter().all(|v| v.is_nan()))
    };
    if let Some(measured) = dict.get_item("measured")?.filter(|v| !v.is_none()) {
        let measured: Vec<bool> = measured
            .extract()
            .map_err(|_| to_py("samples[\"measured\"]: expected a sequence of booleans"))?;
        if measured.len() != readings.len() {
            return Err(to_py(format!(
                "samples: measured has {} rows and readings {}: one of each per sample",
                measured.len(),
                readings.len()
            )));
        }
        if let Some(k) =
            (0..readings.len()).find(|&k| measured[k] != given(&positions, k).is_some())
        {
            let said = if measured[k] {
                "a position"
            } else {
                "no position"
            };
            return Err(to_py(format!(
                "samples: row {k}: measured says {said} was measured, position says otherwise (a row of NaN where none was)"
            )));
        }
    }
    Ok(readings
        .into_iter()
        .enumerate()
        .map(|(k, readings)| SampleRow {
            readings,
            position: given(&positions, k).map(|p| [p[0], p[1], p[2]]),
            loads: given(&loads, k),
        })
        .collect())
}

/// The columns of `balls` with placements: radius, its sigma, x, y, z,
/// centre_sigma.
const BALL_COLUMNS: usize = 6;

/// `balls` (n x 2: radius, radius sigma, 0 for an exact radius; or n x 6
/// with where each ball was placed: x, y, z and each coordinate's sigma,
/// all four NaN for a ball not placed) as balls.csv's rows.
fn ball_rows(balls: &Bound<'_, PyAny>) -> PyResult<Vec<BallRow>> {
    table_rows_of(balls, &[2, BALL_COLUMNS], "balls")?
        .into_iter()
        .enumerate()
        .map(|(row, values)| {
            let placed = &values[2..];
            let placement = if placed.iter().all(|v| v.is_nan()) {
                None
            } else if placed.iter().any(|v| v.is_nan()) {
                return Err(to_py(format!(
                    "balls row {row}: a placement gives all of x, y, z and centre_sigma, or none (NaN)"
                )));
            } else {
                Some(BallPlacement {
                    centre: [placed[0], placed[1], placed[2]],
                    sigma: placed[3],
                })
            };
            Ok(BallRow {
                radius: values[0],
                radius_sigma: (values[1] != 0.0).then_some(values[1]),
                placement,
            })
        })
        .collect()
}

/// `touches` (n x 4: ball number, commanded x, y, z) as touches.csv's
/// rows; a ball number must be a whole number, at least 0.
fn touch_rows(touches: &Bound<'_, PyAny>) -> PyResult<Vec<TouchRow>> {
    rows::<4>(touches, "touches")?
        .into_iter()
        .enumerate()
        .map(|(row, [ball, x, y, z])| {
            Ok(TouchRow {
                ball: ball_number(ball, || format!("touches row {row}"))?,
                commanded: [x, y, z],
            })
        })
        .collect()
}

/// `tracker_points` (a dict of `tracker`, `commanded`, `measured`) as
/// tracker_points.csv's rows.
fn tracker_point_rows(dict: &Bound<'_, PyDict>) -> PyResult<Vec<TrackerPointRow>> {
    known_keys(
        dict,
        "tracker_points",
        &["tracker", "commanded", "measured"],
    )?;
    let entry = |key: &str| {
        dict.get_item(key)?
            .ok_or_else(|| to_py(format!("tracker_points: missing {key:?}")))
    };
    let labels: Vec<String> = entry("tracker")?
        .extract()
        .map_err(|_| to_py("tracker_points[\"tracker\"]: expected a list of labels"))?;
    let commanded = rows::<3>(&entry("commanded")?, "tracker_points[\"commanded\"]")?;
    let measured = rows::<3>(&entry("measured")?, "tracker_points[\"measured\"]")?;
    if commanded.len() != labels.len() || measured.len() != labels.len() {
        return Err(to_py(format!(
            "tracker_points: tracker, commanded and measured have {}, {} and {} rows: one of each per point",
            labels.len(),
            commanded.len(),
            measured.len()
        )));
    }
    Ok(labels
        .into_iter()
        .zip(commanded.into_iter().zip(measured))
        .map(|(tracker, (commanded, measured))| TrackerPointRow {
            tracker,
            commanded,
            measured,
        })
        .collect())
}

/// `ball_distances` (n x 4: the two balls' numbers, the distance and its
/// sigma) as ball_distances.csv's rows.
fn ball_distance_rows(distances: &Bound<'_, PyAny>) -> PyResult<Vec<Distance>> {
    rows::<4>(distances, "ball_distances")?
        .into_iter()
        .enumerate()
        .map(|(row, [a, b, length, sigma])| {
            let at = || format!("ball_distances row {row}");
            Ok(Distance {
                a: ball_number(a, at)?,
                b: ball_number(b, at)?,
                length,
                sigma,
            })
        })
        .collect()
}

/// `value` as a ball's number (0, 1, 2, ...), else an error at `at`.
fn ball_number(value: f64, at: impl Fn() -> String) -> PyResult<usize> {
    if value < 0.0 || value.fract() != 0.0 || value > u32::MAX as f64 {
        return Err(to_py(format!(
            "{}: ball {} is not a ball's number (0, 1, 2, ...)",
            at(),
            parcal::dataset::shown(value)
        )));
    }
    Ok(value as usize)
}

/// The quantities of a dict: `quantity` (names), `value` and `sigma`.
fn quantity_rows(dict: &Bound<'_, PyDict>) -> PyResult<Vec<QuantityRow>> {
    known_keys(dict, "quantities", &["quantity", "value", "sigma"])?;
    let entry = |key: &str| {
        dict.get_item(key)?
            .ok_or_else(|| to_py(format!("quantities: missing {key:?}")))
    };
    let names: Vec<String> = entry("quantity")?
        .extract()
        .map_err(|_| to_py("quantities[\"quantity\"]: expected a list of names"))?;
    let numbers = |key: &str| -> PyResult<Vec<f64>> {
        entry(key)?
            .extract()
            .map_err(|_| to_py(format!("quantities[{key:?}]: expected a list of numbers")))
    };
    let (values, sigmas) = (numbers("value")?, numbers("sigma")?);
    if values.len() != names.len() || sigmas.len() != names.len() {
        return Err(to_py(format!(
            "quantities: quantity, value and sigma have {}, {} and {} rows: one of each per quantity",
            names.len(),
            values.len(),
            sigmas.len()
        )));
    }
    Ok(names
        .into_iter()
        .zip(values.into_iter().zip(sigmas))
        .map(|(quantity, (value, sigma))| QuantityRow {
            quantity,
            value,
            sigma,
        })
        .collect())
}
