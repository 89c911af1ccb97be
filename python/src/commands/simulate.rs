//! `parcal.simulate`: a simulated dataset with its truth, as `parcal
//! simulate` makes it: the hexapod's campaign of ball touches or of
//! instrument measurements ([`parcal::hexapod_simulation`]), or with
//! `mechanism` a linear delta's or a cable robot's dataset
//! ([`parcal::simulation::mechanism`]), held-out data of a simulated one's
//! true machine included.

use std::path::PathBuf;

use parcal::dataset::HEXAPOD;
use parcal::hexapod_plan;
use parcal::hexapod_simulation::{self, HexapodOptions, PlanSource, hexapod_scenario};
use parcal::plan::plan_file::PlanRow;
use parcal::plan::tracker::plan_file::PosePlanRow;
use parcal::simulation::mechanism::{
    MechanismOptions, MechanismRequest, Spelling, TrueMachine, mechanism_name, simulate_mechanism,
};
use parcal::simulation::{Plate, PlatePairs};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use pyo3::{IntoPyObjectExt, Py, PyAny};

use crate::convert::rows;
use crate::dataset::Dataset;
use crate::error::to_py;
use crate::mechanism::dataset::MechanismDataset;

/// A simulated dataset with its truth, as `parcal simulate` makes it for
/// the same options (snake_case for its flags). The same seed gives the
/// same dataset.
///
/// Without `mechanism` (or with `"hexapod"`), a `parcal.Dataset` of ball
/// touches: the paper's 27 balls (or `balls` on a regular grid) touched
/// `points_per_ball` times each (default 7), the platform tilted by up to
/// `tilt` degrees (default 10), the legs read in `readings` (`"mm"`, or
/// `"rev"`: motor revolutions, scales unknown); `design_drawn` draws the
/// design about the truth by its tolerance. With `tracker` (`"poses"`,
/// `"points"`, `"both"`), an instrument campaign instead: `sessions`
/// (default 3) of `rows` rows each, of the `machine` `"paper"` (default)
/// or `"jugglebot"`, legs re-homed between sessions with sigma `rehome`
/// (mm, 0: none), the instrument's noise `position_sigma` (mm) and
/// `orientation_sigma` (rad); `touches` adds the paper's ball touches of
/// the same machine. `plan` (a plan.csv's path, or the dict `parcal.plan`
/// returns) simulates exactly its touches, or with `tracker` its poses'
/// readings in each session.
///
/// With `mechanism` `"delta"` (`"linear delta"`) or `"cable"` (`"cable
/// robot"`), a `parcal.MechanismDataset`: a delta's `probe_rings`,
/// `probes_per_ring`, `part_distances`, `probe_sigma`, `distance_sigma`,
/// `manual_heights`, `height_sigma`, `balls`, `points_per_ball`, `plate`,
/// `trackers`, `points_per_tracker` and `tracker_sigma`, or a cable robot's `samples`,
/// `known_positions`, `reading_sigma`, `measured_sigma` and, for elastic
/// lines, `zero_loads` (N, one per line), `compliance_of_line` and
/// `load_range` (N, `(low, high)`); `truth` (a
/// simulated `parcal.MechanismDataset`, with its truth) measures that true
/// machine again instead of drawing one: held-out data, refused if it is
/// the dataset's own measurements (the same seed and options).
///
/// `plate` (`"all"`, or a number of pairs) adds a calibrated ball plate
/// over the balls, for the hexapod (artefacts.json's distances) and the
/// delta (ball_distances.csv): each distance the true one plus an error
/// of `plate_sigma` micrometres (default 1); the touches are those of the
/// same seed without it.
///
/// An option of another mechanism than the one simulated, or one the
/// command refuses with another (`balls` with `tracker`, `sessions`
/// without it), is refused, naming it; every count is bounded as the
/// command bounds it.
#[pyfunction]
#[pyo3(signature = (
    seed=1,
    *,
    mechanism=None,
    balls=None,
    points_per_ball=None,
    tilt=None,
    design_drawn=false,
    readings=None,
    tracker=None,
    machine=None,
    touches=false,
    sessions=None,
    rows=None,
    rehome=None,
    position_sigma=None,
    orientation_sigma=None,
    plan=None,
    probe_rings=None,
    probes_per_ring=None,
    part_distances=None,
    manual_heights=None,
    probe_sigma=None,
    distance_sigma=None,
    height_sigma=None,
    trackers=None,
    points_per_tracker=None,
    tracker_sigma=None,
    samples=None,
    known_positions=None,
    reading_sigma=None,
    measured_sigma=None,
    zero_loads=None,
    compliance_of_line=None,
    load_range=None,
    plate=None,
    plate_sigma=None,
    truth=None,
))]
#[allow(clippy::too_many_arguments)]
pub fn simulate(
    py: Python<'_>,
    seed: u64,
    mechanism: Option<&str>,
    balls: Option<usize>,
    points_per_ball: Option<usize>,
    tilt: Option<f64>,
    design_drawn: bool,
    readings: Option<&str>,
    tracker: Option<&str>,
    machine: Option<&str>,
    touches: bool,
    sessions: Option<usize>,
    rows: Option<usize>,
    rehome: Option<f64>,
    position_sigma: Option<f64>,
    orientation_sigma: Option<f64>,
    plan: Option<&Bound<'_, PyAny>>,
    probe_rings: Option<usize>,
    probes_per_ring: Option<usize>,
    part_distances: Option<usize>,
    manual_heights: Option<usize>,
    probe_sigma: Option<f64>,
    distance_sigma: Option<f64>,
    height_sigma: Option<f64>,
    trackers: Option<usize>,
    points_per_tracker: Option<usize>,
    tracker_sigma: Option<f64>,
    samples: Option<usize>,
    known_positions: Option<usize>,
    reading_sigma: Option<f64>,
    measured_sigma: Option<f64>,
    zero_loads: Option<Vec<f64>>,
    compliance_of_line: Option<Vec<usize>>,
    load_range: Option<(f64, f64)>,
    plate: Option<&Bound<'_, PyAny>>,
    plate_sigma: Option<f64>,
    truth: Option<&Bound<'_, PyAny>>,
) -> PyResult<Py<PyAny>> {
    let plate = ball_plate(plate, plate_sigma)?;
    let spelling = Spelling::Keywords;
    let tracker = tracker
        .map(|name| hexapod_plan::tracker_kind(name, spelling))
        .transpose()
        .map_err(to_py)?;
    let hexapod = HexapodOptions {
        balls,
        points_per_ball,
        readings: readings
            .map(|name| hexapod_simulation::reading_unit(name, spelling))
            .transpose()
            .map_err(to_py)?,
        tilt,
        tracker,
        machine: machine
            .map(|name| hexapod_simulation::tracked_machine(name, spelling))
            .transpose()
            .map_err(to_py)?,
        touches,
        sessions,
        rows,
        rehome,
        position_sigma,
        orientation_sigma,
        plate,
        plan: plan
            .map(|plan| plan_source(plan, tracker.is_some()))
            .transpose()?,
        design_drawn,
    };
    let options = MechanismOptions {
        probe_rings,
        probes_per_ring,
        part_distances,
        manual_heights,
        probe_sigma,
        distance_sigma,
        height_sigma,
        balls,
        points_per_ball,
        trackers,
        points_per_tracker,
        tracker_sigma,
        samples,
        known_positions,
        reading_sigma,
        measured_sigma,
        zero_loads,
        compliance_of_line,
        load_range: load_range.map(|(low, high)| [low, high]),
        plate,
    };
    match mechanism.filter(|name| *name != HEXAPOD) {
        None => {
            let mut others: Vec<&str> = options
                .given()
                .into_iter()
                .filter(|name| !SHARED.contains(name))
                .collect();
            others.extend(truth.map(|_| "truth"));
            refuse(
                &others,
                "apply to a mechanism other than the hexapod (give mechanism=\"delta\" or \"cable\")",
            )?;
            hexapod.check_combinations(spelling).map_err(to_py)?;
            let simulation = py
                .detach(|| {
                    let scenario = hexapod_scenario(&hexapod, seed, spelling)
                        .map_err(|error| error.to_string())?;
                    scenario.simulate(seed).map_err(|error| error.to_string())
                })
                .map_err(to_py)?;
            Dataset::in_memory(simulation.dataset).into_py_any(py)
        }
        Some(name) => {
            let name = mechanism_name(name, spelling).map_err(to_py)?;
            let others: Vec<&str> = hexapod
                .given()
                .into_iter()
                .filter(|name| !SHARED.contains(name))
                .collect();
            refuse(&others, &format!("do not apply to a {name}"))?;
            let truth = truth
                .map(|truth| mechanism_dataset(truth, name))
                .transpose()?;
            let truth = truth.as_ref().map(|dataset| dataset.get());
            let truth_name = truth.map(|dataset| format!("truth {}", dataset.path.display()));
            let request = MechanismRequest {
                mechanism: name,
                seed,
                options: &options,
                truth: truth
                    .zip(truth_name.as_deref())
                    .map(|(dataset, name)| TrueMachine {
                        dataset: &dataset.inner,
                        name,
                    }),
                spelling,
            };
            let dataset = py.detach(|| simulate_mechanism(&request)).map_err(to_py)?;
            MechanismDataset::in_memory(dataset)?.into_py_any(py)
        }
    }
}

/// The options a hexapod's campaign and a mechanism's both take.
const SHARED: [&str; 3] = ["balls", "points_per_ball", "plate"];

/// The plan `plan` names: a plan.csv's path, or the dict `parcal.plan`
/// returns, of poses (`session`, `q`) if `poses`, else of ball touches
/// (`ball`, `direction`, `angles`); its values are checked by the
/// facade, as plan.csv's reader checks them.
fn plan_source(plan: &Bound<'_, PyAny>, poses: bool) -> PyResult<PlanSource> {
    let Ok(dict) = plan.cast::<PyDict>() else {
        return plan
            .extract::<PathBuf>()
            .map(PlanSource::File)
            .map_err(|_| {
                to_py(format!(
                    "plan: expected a plan.csv's path or the dict parcal.plan returns, got {plan}"
                ))
            });
    };
    let required = |key: &str, kind: &str| {
        dict.get_item(key)?.ok_or_else(|| {
            to_py(format!(
                "plan: missing {key:?} (a plan of {kind}, as parcal.plan returns it)"
            ))
        })
    };
    let labels = |key: &str, kind: &str| -> PyResult<Vec<String>> {
        required(key, kind)?
            .extract()
            .map_err(|_| to_py(format!("plan[{key:?}]: expected a sequence of strings")))
    };
    if poses {
        let kind = "poses (tracker=)";
        let session = labels("session", kind)?;
        let q = rows::<6>(&required("q", kind)?, "plan[\"q\"]")?;
        if session.len() != q.len() {
            return Err(to_py(format!(
                "plan: session and q have {} and {} rows: one of each per pose",
                session.len(),
                q.len()
            )));
        }
        // The angles and tips are not simulated (the readings are).
        Ok(PlanSource::Poses(
            session
                .into_iter()
                .zip(q)
                .map(|(session, q)| PosePlanRow {
                    session,
                    angles: [f64::NAN; 3],
                    tip: [f64::NAN; 3].into(),
                    q,
                })
                .collect(),
        ))
    } else {
        let kind = "ball touches";
        let ball = labels("ball", kind)?;
        let direction = rows::<3>(&required("direction", kind)?, "plan[\"direction\"]")?;
        let angles = rows::<3>(&required("angles", kind)?, "plan[\"angles\"]")?;
        if ball.len() != direction.len() || ball.len() != angles.len() {
            return Err(to_py(format!(
                "plan: ball, direction and angles have {}, {} and {} rows: one of each per touch",
                ball.len(),
                direction.len(),
                angles.len()
            )));
        }
        // The readings are not simulated (the touches are).
        Ok(PlanSource::Touches(
            ball.into_iter()
                .zip(direction)
                .zip(angles)
                .map(|((ball, direction), angles)| PlanRow {
                    ball,
                    direction: direction.into(),
                    angles,
                    q: [f64::NAN; 6],
                })
                .collect(),
        ))
    }
}

/// The ball plate of `plate` (`"all"` or a number of pairs) and
/// `plate_sigma` (micrometres, default 1), as `--plate` and
/// `--plate-sigma` give it; `plate_sigma` alone is refused.
fn ball_plate(plate: Option<&Bound<'_, PyAny>>, sigma: Option<f64>) -> PyResult<Option<Plate>> {
    let Some(plate) = plate else {
        return match sigma {
            Some(_) => Err(to_py("plate_sigma needs plate")),
            None => Ok(None),
        };
    };
    let pairs: PlatePairs = plate
        .str()?
        .to_string()
        .parse()
        .map_err(|e: String| to_py(format!("plate: {e}")))?;
    let sigma = sigma.unwrap_or(1.0);
    if !(sigma.is_finite() && sigma > 0.0) {
        return Err(to_py(format!("plate_sigma must be positive, got {sigma}")));
    }
    Ok(Some(Plate {
        pairs,
        sigma: sigma * 1e-3,
    }))
}

/// Refuses the options `others`, if any: they `what` (`"do not apply to a
/// cable robot"`).
fn refuse(others: &[&str], what: &str) -> PyResult<()> {
    if others.is_empty() {
        Ok(())
    } else {
        Err(to_py(format!("{} {what}", others.join(", "))))
    }
}

/// `truth` as a mechanism dataset, a hexapod's refused as the dataset of
/// another mechanism than `name`.
fn mechanism_dataset<'py>(
    truth: &Bound<'py, PyAny>,
    name: &str,
) -> PyResult<Bound<'py, MechanismDataset>> {
    if let Ok(dataset) = truth.cast::<MechanismDataset>() {
        return Ok(dataset.clone());
    }
    Err(to_py(if truth.cast::<Dataset>().is_ok() {
        format!("truth: a dataset of a hexapod, not of a {name}")
    } else {
        format!("truth: expected a simulated parcal.MechanismDataset, got {truth}")
    }))
}
