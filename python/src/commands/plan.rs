//! `parcal.plan`: which ball touches, or which platform poses for an
//! instrument, to measure, as `parcal plan` chooses them (docs/plan.md,
//! docs/plan-poses.md; [`parcal::hexapod_plan`]), the plan as numpy arrays.

use numpy::PyArray1;
use parcal::Machine;
use parcal::hexapod_plan::{self, PosePlanRequest};
use parcal::plan::tracker::information::session_labels;
use parcal::plan::tracker::plan_poses;
use parcal::plan::{Criterion, PlanOptions, bounds, plan as plan_touches, plan_next};
use parcal::simulation::Workspace;
use parcal::simulation::mechanism::Spelling;
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

/// A hexapod's plan, as `parcal plan` makes it for the same options: the
/// `contacts` ball touches of `dataset`'s balls (its machine.json and
/// artefacts.json; its measurements are not used), or with `tracker`
/// ("poses", "points", "both"; "poses" for a dataset without balls) the
/// `poses` platform poses an instrument measures, in `sessions` sessions,
/// the platform origin within `workspace` (`(half_width, z_min, z_max)`,
/// mm, design base frame); either minimising the predicted `criterion`
/// ("registered", "d", "a", "g"), the platform tilted by up to `tilt`
/// degrees. A touch plan's options: `pool`, `seed`, `per_ball`,
/// `min_balls`, `restarts`, `max_approach` (degrees), `radius` ("ball" or
/// "contact") and `after` (a calibration, or a calibration.json's path,
/// whose covariance the plan adds to).
///
/// Returns a dict. Touches, one row each: `ball` (ids), `direction`
/// (n x 3, the outward normal of the approach), `angles` (n x 3: roll,
/// pitch, yaw, rad), `q` (n x 6, the planned readings), and `stroke`.
/// Poses, one row each as plan.csv's: `session` (labels), `angles` (n x
/// 3: roll, pitch, yaw, rad), `tip` (n x 3, the design's tool tip, mm),
/// `q` (n x 6, the design's readings). Both: `prior`, `predicted` (the
/// criterion's figures before and after, plan.json's) and `pool_size`.
#[pyfunction]
#[pyo3(signature = (dataset, contacts=None, tilt=None, *, poses=None, tracker=None, sessions=1, workspace=None, criterion="registered", pool=20_000, seed=1, per_ball=None, min_balls=None, restarts=1, max_approach=None, radius=None, after=None))]
#[allow(clippy::too_many_arguments)]
pub fn plan<'py>(
    py: Python<'py>,
    dataset: &Bound<'py, Dataset>,
    contacts: Option<usize>,
    tilt: Option<f64>,
    poses: Option<usize>,
    tracker: Option<&str>,
    sessions: usize,
    workspace: Option<&Bound<'py, PyAny>>,
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
    if contacts.is_some() && poses.is_some() {
        return Err(to_py(
            "contacts cannot be used with poses: a plan is of ball touches or of poses",
        ));
    }
    let tilt = hexapod_plan::tilt(tilt, Spelling::Keywords).map_err(to_py)?;
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
    let asked = tracker
        .map(|name| hexapod_plan::tracker_kind(name, Spelling::Keywords))
        .transpose()
        .map_err(to_py)?;
    let inner = &dataset.get().inner;
    if let Some(kind) = hexapod_plan::planned_tracker(asked, !inner.artefacts.balls.is_empty()) {
        let request = PosePlanRequest {
            poses,
            kind,
            workspace: workspace.map(workspace_box).transpose()?,
            tilt_degrees: tilt,
            criterion,
            sessions,
            touch_options: after.is_some()
                || per_ball.is_some()
                || min_balls.is_some()
                || radius.is_some(),
        };
        return pose_plan(py, &inner.machine, &request);
    }
    let contacts =
        hexapod_plan::touch_contacts(contacts, sessions, Spelling::Keywords).map_err(to_py)?;
    let check = |name: &str, count: parcal::dataset::bounds::Count, n: usize| {
        count.check(name, n).map_err(to_py)
    };
    check("contacts", bounds::CONTACTS, contacts)?;
    check("pool", bounds::POOL, pool)?;
    check("restarts", bounds::RESTARTS, restarts)?;
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
    let calibration = after.map(|a| calibration_record(a, false)).transpose()?;
    let (machine, artefacts) = (&inner.machine, &inner.artefacts);
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

/// `workspace` (a sequence of three numbers) as a pose plan's workspace,
/// checked as `--workspace` is.
fn workspace_box(workspace: &Bound<'_, PyAny>) -> PyResult<Workspace> {
    let given = workspace
        .repr()
        .map_or_else(|_| "?".to_string(), |r| r.to_string());
    let values: Vec<f64> = workspace.extract().map_err(|_| {
        to_py(format!(
            "workspace: expected (half_width, z_min, z_max), three numbers, got {given}"
        ))
    })?;
    hexapod_plan::workspace(&values, &given, Spelling::Keywords).map_err(to_py)
}

/// The pose plan `request` asks for on `machine`, as `parcal plan
/// --tracker` makes it: plan.csv's columns and plan.json's figures.
fn pose_plan<'py>(
    py: Python<'py>,
    machine: &Machine,
    request: &PosePlanRequest,
) -> PyResult<Bound<'py, PyDict>> {
    let options = hexapod_plan::pose_plan_options(request, Spelling::Keywords).map_err(to_py)?;
    let planned = py
        .detach(|| plan_poses(machine, &options, &mut |_| {}))
        .map_err(|e| to_py(format!("planning failed: {e}")))?;
    let labels = session_labels(options.sessions);
    let session: Vec<&str> = planned
        .sessions
        .iter()
        .map(|&s| labels[s].as_str())
        .collect();
    let angles: Vec<[f64; 3]> = planned.poses.iter().map(|c| c.angles).collect();
    let tip: Vec<[f64; 3]> = planned.poses.iter().map(|c| c.tip.into()).collect();
    let q: Vec<[f64; 6]> = planned.poses.iter().map(|c| c.q).collect();
    let dict = PyDict::new(py);
    dict.set_item("session", session)?;
    dict.set_item("angles", array2(py, &angles))?;
    dict.set_item("tip", array2(py, &tip))?;
    dict.set_item("q", array2(py, &q))?;
    dict.set_item("prior", to_python(py, &planned.prior)?)?;
    dict.set_item("predicted", to_python(py, &planned.predicted)?)?;
    dict.set_item("pool_size", planned.pool_size)?;
    Ok(dict)
}
