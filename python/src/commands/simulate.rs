//! `parcal.simulate`: a simulated dataset with its truth, as `parcal
//! simulate` makes it: the hexapod's campaign of ball touches (the paper's
//! scenario, or a scaled one), or with `mechanism` a linear delta's or a
//! cable robot's dataset ([`parcal::simulation::mechanism`]), held-out
//! data of a simulated one's true machine included.

use parcal::dataset::HEXAPOD;
use parcal::simulation::mechanism::{
    MechanismOptions, MechanismRequest, Spelling, TrueMachine, mechanism_name, simulate_mechanism,
};
use parcal::simulation::{COUNT, Plate, PlatePairs};
use parcal::{Scenario, simulate as simulate_campaign};
use pyo3::prelude::*;
use pyo3::{IntoPyObjectExt, Py, PyAny};

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
/// `tilt` degrees (default 10); `design_drawn` draws the design about the
/// truth by its tolerance.
///
/// With `mechanism` `"delta"` (`"linear delta"`) or `"cable"` (`"cable
/// robot"`), a `parcal.MechanismDataset`: a delta's `probe_rings`,
/// `probes_per_ring`, `part_distances`, `probe_sigma`, `distance_sigma`,
/// `manual_heights`, `height_sigma`, `balls`, `points_per_ball`, `plate`,
/// `trackers`, `points_per_tracker` and `tracker_sigma`, or a cable robot's `samples`,
/// `known_positions`, `reading_sigma` and `measured_sigma`; `truth` (a
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
/// An option of another mechanism than the one simulated is refused,
/// naming it; every count is bounded as the command bounds it.
#[pyfunction]
#[pyo3(signature = (
    seed=1,
    *,
    mechanism=None,
    balls=None,
    points_per_ball=None,
    tilt=None,
    design_drawn=false,
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
    plate: Option<&Bound<'_, PyAny>>,
    plate_sigma: Option<f64>,
    truth: Option<&Bound<'_, PyAny>>,
) -> PyResult<Py<PyAny>> {
    let plate = ball_plate(plate, plate_sigma)?;
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
        plate,
    };
    match mechanism.filter(|name| *name != HEXAPOD) {
        None => {
            let mut others: Vec<&str> = options
                .given()
                .into_iter()
                .filter(|name| !HEXAPOD_TOO.contains(name))
                .collect();
            others.extend(truth.map(|_| "truth"));
            refuse(
                &others,
                "apply to a mechanism other than the hexapod (give mechanism=\"delta\" or \"cable\")",
            )?;
            hexapod(py, seed, &options, tilt, design_drawn)?.into_py_any(py)
        }
        Some(name) => {
            let name = mechanism_name(name, Spelling::Keywords).map_err(to_py)?;
            let hexapod_only = [("tilt", tilt.is_some()), ("design_drawn", design_drawn)];
            let others: Vec<&str> = hexapod_only
                .iter()
                .filter(|(_, given)| *given)
                .map(|(name, _)| *name)
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
                spelling: Spelling::Keywords,
            };
            let dataset = py.detach(|| simulate_mechanism(&request)).map_err(to_py)?;
            MechanismDataset::in_memory(dataset)?.into_py_any(py)
        }
    }
}

/// The mechanism options a hexapod's campaign takes too.
const HEXAPOD_TOO: [&str; 3] = ["balls", "points_per_ball", "plate"];

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

/// The hexapod's campaign of ball touches (the paper's scenario, or
/// `balls` on a grid), as `parcal simulate` makes it.
fn hexapod(
    py: Python<'_>,
    seed: u64,
    options: &MechanismOptions,
    tilt: Option<f64>,
    design_drawn: bool,
) -> PyResult<Dataset> {
    let tilt = tilt.unwrap_or(10.0);
    if !(tilt.is_finite() && (0.0..90.0).contains(&tilt)) {
        return Err(to_py(format!(
            "tilt must be in [0, 90) degrees, got {tilt}"
        )));
    }
    let paper = Scenario::paper();
    let points_per_ball = COUNT
        .check(
            "points_per_ball",
            options.points_per_ball.unwrap_or(paper.points_per_ball),
        )
        .map_err(to_py)?;
    let mut scenario = match options.balls {
        None => Scenario {
            points_per_ball,
            max_tilt: tilt.to_radians(),
            ..paper
        },
        Some(balls) => {
            COUNT.check("balls", balls).map_err(to_py)?;
            Scenario::scaled(balls, points_per_ball, tilt.to_radians())
        }
    };
    if design_drawn {
        scenario = scenario.design_drawn(seed);
    }
    scenario.plate = options.plate;
    let simulation = py
        .detach(|| simulate_campaign(&scenario, seed))
        .map_err(to_py)?;
    Ok(Dataset::in_memory(simulation.dataset))
}
