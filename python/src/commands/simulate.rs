//! `parcal.simulate`: a simulated campaign of ball touches, as `parcal
//! simulate` makes it (the paper's scenario, or a scaled one).

use parcal::simulation::COUNT;
use parcal::{Scenario, simulate as simulate_campaign};
use pyo3::prelude::*;

use crate::dataset::Dataset;
use crate::error::to_py;

/// A simulated campaign of ball touches, as `parcal simulate` makes it for
/// the same options: the paper's 27 balls (or `balls` on a regular grid)
/// touched `points_per_ball` times each, the platform tilted by up to
/// `tilt` degrees; `design_drawn` draws the design about the truth by its
/// tolerance. The same seed gives the same dataset (with its truth).
#[pyfunction]
#[pyo3(signature = (seed=1, *, balls=None, points_per_ball=7, tilt=10.0, design_drawn=false))]
pub fn simulate(
    py: Python<'_>,
    seed: u64,
    balls: Option<usize>,
    points_per_ball: usize,
    tilt: f64,
    design_drawn: bool,
) -> PyResult<Dataset> {
    if !(tilt.is_finite() && (0.0..90.0).contains(&tilt)) {
        return Err(to_py(format!(
            "tilt must be in [0, 90) degrees, got {tilt}"
        )));
    }
    COUNT
        .check("points_per_ball", points_per_ball)
        .map_err(to_py)?;
    let mut scenario = match balls {
        None => Scenario {
            points_per_ball,
            max_tilt: tilt.to_radians(),
            ..Scenario::paper()
        },
        Some(balls) => {
            COUNT.check("balls", balls).map_err(to_py)?;
            Scenario::scaled(balls, points_per_ball, tilt.to_radians())
        }
    };
    if design_drawn {
        scenario = scenario.design_drawn(seed);
    }
    let simulation = py
        .detach(|| simulate_campaign(&scenario, seed))
        .map_err(to_py)?;
    Ok(Dataset::in_memory(simulation.dataset))
}
