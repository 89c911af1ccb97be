//! `parcal.plan`: which ball touches to measure, as `parcal plan` chooses
//! them (docs/design.md), the plan as numpy arrays.

use numpy::PyArray1;
use parcal::plan::{Criterion, PlanOptions, bounds, plan as plan_touches, plan_next};
use pyo3::prelude::*;
use pyo3::types::PyDict;

use super::calibration_record;
use crate::convert::{array2, to_python};
use crate::dataset::Dataset;
use crate::error::to_py;
use crate::options::choice;

/// The criteria a plan minimises, as `parcal plan --criterion` names them.
const CRITERIA: [Criterion; 4] = [
    Criterion::Registered,
    Criterion::D,
    Criterion::A,
    Criterion::G,
];

/// The `contacts` ball touches of `dataset`'s balls (its machine.json and
/// artefacts.json; its measurements are not used) that minimise the
/// predicted criterion, the platform tilted by up to `tilt` degrees, as
/// `parcal plan` chooses them for the same options (`criterion`:
/// "registered", "d", "a", "g"; `after`: a calibration, or a
/// calibration.json's path, whose covariance the plan adds to; `radius`:
/// "ball" or "contact").
///
/// Returns a dict of the touches, one row each: `ball` (ids), `direction`
/// (n x 3, the outward normal of the approach), `angles` (n x 3: roll,
/// pitch, yaw, rad), `q` (n x 6, the planned readings); and `prior`,
/// `predicted` (the criterion's figures before and after), `pool_size`,
/// `stroke`.
#[pyfunction]
#[pyo3(signature = (dataset, contacts, tilt, *, criterion="registered", pool=20_000, seed=1, per_ball=None, min_balls=None, restarts=1, max_approach=None, radius=None, after=None))]
#[allow(clippy::too_many_arguments)]
pub fn plan<'py>(
    py: Python<'py>,
    dataset: &Bound<'py, Dataset>,
    contacts: usize,
    tilt: f64,
    criterion: &str,
    pool: usize,
    seed: u64,
    per_ball: Option<usize>,
    min_balls: Option<usize>,
    restarts: usize,
    max_approach: Option<f64>,
    radius: Option<&Bound<'py, PyAny>>,
    after: Option<&Bound<'py, PyAny>>,
) -> PyResult<Bound<'py, PyDict>> {
    if !(tilt.is_finite() && (0.0..90.0).contains(&tilt)) {
        return Err(to_py(format!(
            "tilt must be in [0, 90) degrees, got {tilt}"
        )));
    }
    let check = |name: &str, count: parcal::dataset::bounds::Count, n: usize| {
        count.check(name, n).map_err(to_py)
    };
    check("contacts", bounds::CONTACTS, contacts)?;
    check("pool", bounds::POOL, pool)?;
    check("restarts", bounds::RESTARTS, restarts)?;
    let criterion = CRITERIA
        .into_iter()
        .find(|c| {
            serde_json::to_value(c)
                .ok()
                .and_then(|v| v.as_str().map(|s| s == criterion))
                == Some(true)
        })
        .ok_or_else(|| {
            to_py(format!(
                "criterion: {criterion:?} is not one of registered, d, a, g"
            ))
        })?;
    let defaults = PlanOptions::new(contacts, tilt);
    let options = PlanOptions {
        criterion,
        pool,
        seed,
        per_ball: per_ball
            .map(|n| check("per_ball", bounds::PER_BALL, n))
            .transpose()?,
        min_balls: match min_balls {
            Some(n) => check("min_balls", bounds::MIN_BALLS, n)?,
            None => parcal::plan::select::default_min_balls(contacts),
        },
        restarts,
        max_approach_degrees: max_approach.unwrap_or(defaults.max_approach_degrees),
        radius: radius
            .map(|r| choice("radius", r))
            .transpose()?
            .unwrap_or(defaults.radius),
        ..defaults
    };
    let dataset = &dataset.get().inner;
    let calibration = after.map(|a| calibration_record(a, false)).transpose()?;
    let (machine, artefacts) = (&dataset.machine, &dataset.artefacts);
    let planned = py
        .detach(|| match &calibration {
            None => plan_touches(machine, artefacts, &options, &mut |_| {}),
            Some((record, _)) => plan_next(machine, artefacts, record, &options, &mut |_| {}),
        })
        .map_err(|e| to_py(format!("planning failed: {e}")))?;
    let touches = &planned.contacts;
    let dict = PyDict::new(py);
    let ball: Vec<&str> = touches
        .iter()
        .map(|c| artefacts.balls[c.ball].id.as_str())
        .collect();
    let direction: Vec<[f64; 3]> = touches.iter().map(|c| c.direction.into()).collect();
    let angles: Vec<[f64; 3]> = touches.iter().map(|c| c.angles).collect();
    let q: Vec<[f64; 6]> = touches.iter().map(|c| c.q).collect();
    dict.set_item("ball", ball)?;
    dict.set_item("direction", array2(py, &direction))?;
    dict.set_item("angles", array2(py, &angles))?;
    dict.set_item("q", array2(py, &q))?;
    dict.set_item("prior", to_python(py, &planned.prior)?)?;
    dict.set_item("predicted", to_python(py, &planned.predicted)?)?;
    dict.set_item("pool_size", planned.pool_size)?;
    dict.set_item("stroke", PyArray1::from_slice(py, &planned.stroke))?;
    Ok(dict)
}
