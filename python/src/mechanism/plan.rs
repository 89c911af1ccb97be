//! `parcal.plan` on a mechanism dataset: the probe heights or encoder
//! samples to measure next, and a delta's heights measured by hand and
//! part distances, as `parcal plan` chooses them
//! (docs/delta-measurements.md, docs/cable-robots.md), with each unknown's
//! predicted sigma before and after.

use numpy::PyArray1;
use parcal::kinematics::delta::GAUGE_BLOCK;
use parcal::plan::bounds::{GRID, MEASUREMENTS};
use parcal::plan::mechanism::workspace::{DEFAULT_GRID, Grid, checked_gauge, plan_candidates};
use parcal::plan::mechanism::{
    Candidate, Counts, PlanRequest, Start, default_group, linearisation_point,
    plan_mechanism as plan, with_sigmas,
};
use parcal::{MechanismData, MechanismDataset as Inner};
use pyo3::prelude::*;
use pyo3::types::PyDict;

use super::calibration_record;
use super::dataset::MechanismDataset;
use crate::convert::array2;
use crate::error::to_py;

/// The `measurements` measurements of the mechanism of `dataset` (its
/// machine.json; its observations are not used), then a delta's `heights`
/// heights measured by hand (the nozzle `gauge` mm up) and `distances`
/// part distances, that minimise the trace of the predicted covariance of
/// the parameter group `group` (default: a delta's "diagonal rods", or
/// its "trigger height" for heights alone after a calibration; a cable
/// robot's "anchors"), chosen
/// from a grid of `grid` candidates per axis over its workspace, as
/// `parcal plan` chooses them for the same options. `height_sigma` and
/// `distance_sigma` (mm) stand for machine.json's noise of those kinds.
/// `after` (an accepted `parcal.MechanismCalibration` or a
/// calibration.json's path) starts from that calibration rather than the
/// prior; `measured_positions` plans a cable robot's samples with their
/// position measured too.
///
/// Returns a dict: `kind` (each pick's observation kind), `position`
/// (n x 3, where the effector goes, mm; a part distance's first end),
/// `end` (n x 3, a part distance's second end, NaN for the other kinds),
/// `trace` (the group's trace after each pick), `trace_before`, `group`,
/// `feasible` (the feasible candidates), `from_calibration`, `parameters`
/// (`name`, `unit`, `prior_sigma`, `before`, `after`: each unknown's sigma
/// before and after the plan) and `statements` (what the plan leaves to
/// the prior).
#[pyfunction]
#[pyo3(signature = (dataset, measurements=0, *, heights=0, distances=0, height_sigma=None, distance_sigma=None, gauge=GAUGE_BLOCK, group=None, grid=DEFAULT_GRID, measured_positions=false, after=None))]
#[allow(clippy::too_many_arguments)]
pub fn plan_mechanism<'py>(
    py: Python<'py>,
    dataset: &Bound<'py, MechanismDataset>,
    measurements: usize,
    heights: usize,
    distances: usize,
    height_sigma: Option<f64>,
    distance_sigma: Option<f64>,
    gauge: f64,
    group: Option<String>,
    grid: usize,
    measured_positions: bool,
    after: Option<&Bound<'py, PyAny>>,
) -> PyResult<Bound<'py, PyDict>> {
    let count = |name, value: usize| match value {
        0 => Ok(0),
        _ => MEASUREMENTS.check(name, value).map_err(to_py),
    };
    let counts = Counts {
        measurements: count("measurements", measurements)?,
        heights: count("heights", heights)?,
        distances: count("distances", distances)?,
    };
    if counts.total() == 0 {
        return Err(to_py(
            "measurements is needed for a mechanism's plan (or a delta's heights or distances)",
        ));
    }
    let grid = GRID.check("grid", grid).map_err(to_py)?;
    let dataset = dataset.get();
    let machine = dataset.inner.machine.clone();
    let noise = with_sigmas(
        machine.noise,
        [height_sigma, distance_sigma],
        ["height_sigma", "distance_sigma"],
    )
    .map_err(to_py)?;
    let grid = Grid {
        per_axis: grid,
        print_radius: machine.print_radius,
        gauge: checked_gauge(gauge, "gauge").map_err(to_py)?,
    };
    let machine_only = Inner {
        machine,
        ..Inner::default()
    };
    let data = MechanismData::from_dataset(&machine_only)
        .map_err(|e| super::data_error(&dataset.path, &machine_only.machine.mechanism, e))?;
    let mechanism = data.mechanism.as_ref();
    if measured_positions && mechanism.name() != "cable robot" {
        return Err(to_py(
            "measured_positions applies to a cable robot's samples",
        ));
    }
    let start = match after {
        Some(after) => {
            let (record, name) = calibration_record(after, true)?;
            if !record.accepted {
                return Err(to_py(format!(
                    "{name}: the calibration was rejected ({}); plan after an accepted one",
                    record.reasons.join("; ")
                )));
            }
            let start = Start::from_record(&record, mechanism)
                .map_err(|e| to_py(format!("{name}: {e}")))?;
            Some(start)
        }
        None => None,
    };
    let params = linearisation_point(&data, start.as_ref());
    let group =
        group.unwrap_or_else(|| default_group(mechanism, counts, start.as_ref()).to_string());
    let planned = py
        .detach(|| {
            let candidates = plan_candidates(mechanism, &params, grid, measured_positions, counts)?;
            plan(&PlanRequest {
                data: &data,
                noise,
                start,
                candidates: &candidates,
                group: &group,
                counts,
            })
        })
        .map_err(|e| to_py(format!("{}: {e}", dataset.path.display())))?;
    let dict = PyDict::new(py);
    let kind: Vec<&str> = planned.picks.iter().map(|(c, _)| c.kind()).collect();
    let (position, end): (Vec<[f64; 3]>, Vec<[f64; 3]>) = planned
        .picks
        .iter()
        .map(|(c, _)| match *c {
            Candidate::Distance([first, second]) => (first, second),
            _ => (c.positions(planned.trigger_height)[0], [f64::NAN; 3]),
        })
        .unzip();
    let trace: Vec<f64> = planned.picks.iter().map(|(_, t)| *t).collect();
    dict.set_item("kind", kind)?;
    dict.set_item("position", array2(py, &position))?;
    dict.set_item("end", array2(py, &end))?;
    dict.set_item("trace", PyArray1::from_vec(py, trace))?;
    dict.set_item("trace_before", planned.trace_before)?;
    dict.set_item("group", &planned.group)?;
    dict.set_item("feasible", planned.feasible)?;
    dict.set_item("from_calibration", planned.from_calibration)?;
    let parameters = PyDict::new(py);
    let p = &planned.parameters;
    parameters.set_item("name", p.iter().map(|p| &p.name).collect::<Vec<_>>())?;
    parameters.set_item("unit", p.iter().map(|p| &p.unit).collect::<Vec<_>>())?;
    let column = |of: fn(&parcal::plan::mechanism::PlannedParameter) -> f64| {
        PyArray1::from_vec(py, p.iter().map(of).collect())
    };
    parameters.set_item("prior_sigma", column(|p| p.prior_sigma.unwrap_or(f64::NAN)))?;
    parameters.set_item("before", column(|p| p.before))?;
    parameters.set_item("after", column(|p| p.after))?;
    dict.set_item("parameters", parameters)?;
    dict.set_item("statements", planned.statements.clone())?;
    Ok(dict)
}
