//! The candidates of a mechanism plan: a grid over the mechanism's
//! workspace, of the kind of measurement its calibration takes there.
//!
//! - A linear delta: probe heights at commanded `(x, y)` on a square grid
//!   over the bed, those within its print radius (`M665 B`: machine.json's
//!   `print_radius`, else its typical design's); part
//!   distances between every two points of that grid at the first
//!   layer's height ([`distance_candidates`]); heights measured by hand at
//!   the points of that grid, the nozzle at the gauge block's height
//!   ([`height_candidates`]).
//! - A cable robot: encoder samples on a cubic grid over the box of its
//!   anchors from the bed (`z = 0`) up, the position unknown or measured.
//!
//! Each candidate is then kept only where the mechanism can take it
//! ([`Mechanism::check_feasible`]: a delta's arm angles and carriage
//! travel, a cable robot's lines all taut), which the plan checks.

use parcal_kinematics::cable::CableRobot;
use parcal_kinematics::delta::{FIRST_LAYER, GAUGE_BLOCK, LinearDelta};
use parcal_kinematics::mechanism::Mechanism;

use super::candidate::{Candidate, Counts, Stage};
use crate::DesignError;

/// The candidate grid's points per axis unless asked another.
pub const DEFAULT_GRID: usize = 12;

/// The highest gauge a height measured by hand is planned on (mm): a
/// stack of gauge blocks, far above any first layer.
pub const MAX_GAUGE: f64 = 100.0;

/// The grid candidates are taken on: `per_axis` points per axis over the
/// mechanism's workspace, a delta's bed within `print_radius` (mm,
/// machine.json's; its typical design's when `None`), its heights
/// measured by hand with the nozzle `gauge` above the bed.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Grid {
    /// Points per axis.
    pub per_axis: usize,
    /// A delta's printable radius.
    pub print_radius: Option<f64>,
    /// The height a delta's heights are measured at by hand (mm).
    pub gauge: f64,
}

impl Grid {
    /// `per_axis` points per axis, a delta's bed its typical design's, its
    /// heights measured on a [`GAUGE_BLOCK`].
    pub fn new(per_axis: usize) -> Self {
        Self {
            per_axis,
            print_radius: None,
            gauge: GAUGE_BLOCK,
        }
    }
}

/// `count` values evenly from `low` to `high`.
fn along(low: f64, high: f64, count: usize) -> impl Iterator<Item = f64> + Clone {
    (0..count).map(move |i| low + (high - low) * i as f64 / (count - 1).max(1) as f64)
}

/// The points of a square grid over a delta's bed within its print
/// radius ([`Grid`]).
fn bed_grid(grid: Grid) -> impl Iterator<Item = [f64; 2]> + Clone {
    let radius =
        (grid.print_radius).unwrap_or_else(|| LinearDelta::typical().limits().print_radius);
    let xs = along(-radius, radius, grid.per_axis);
    xs.clone()
        .flat_map(move |x| xs.clone().map(move |y| [x, y]))
        .filter(move |[x, y]| x.hypot(*y) <= radius)
}

/// An error unless `mechanism` is a linear delta: `what` is planned on a
/// printer's bed.
fn on_a_bed(mechanism: &dyn Mechanism, what: &str) -> Result<(), DesignError> {
    if mechanism.name() == "linear delta" {
        return Ok(());
    }
    Err(DesignError::Options(format!(
        "{what} are planned on a linear delta's bed, not a {}'s",
        mechanism.name()
    )))
}

/// `gauge` (mm), the height a plan's heights are measured at by hand, if
/// it lies in `(0, MAX_GAUGE]`; else an error naming it by `name` (the
/// front end's word for it).
pub fn checked_gauge(gauge: f64, name: &str) -> Result<f64, DesignError> {
    if gauge > 0.0 && gauge <= MAX_GAUGE {
        Ok(gauge)
    } else {
        Err(DesignError::Options(format!(
            "{name} must be in (0, {MAX_GAUGE}] mm, got {gauge}"
        )))
    }
}

/// A delta's heights measured by hand: at the points of the bed's `grid`,
/// the nozzle `grid.gauge` above the bed; an error for another mechanism
/// or a gauge outside `(0, MAX_GAUGE]` ([`checked_gauge`]).
pub fn height_candidates(
    mechanism: &dyn Mechanism,
    grid: Grid,
) -> Result<Vec<Candidate>, DesignError> {
    on_a_bed(mechanism, Stage::Heights.name())?;
    checked_gauge(grid.gauge, "the gauge of the heights measured by hand")?;
    Ok(bed_grid(grid)
        .map(|[x, y]| Candidate::Height([x, y, grid.gauge]))
        .collect())
}

/// A delta's part distances: between every two points of the bed's
/// `grid`, at the first layer's height (where a printed part's features
/// are measured); an error for another mechanism.
pub fn distance_candidates(
    mechanism: &dyn Mechanism,
    grid: Grid,
) -> Result<Vec<Candidate>, DesignError> {
    on_a_bed(mechanism, Stage::Distances.name())?;
    let points: Vec<[f64; 3]> = bed_grid(grid).map(|[x, y]| [x, y, FIRST_LAYER]).collect();
    Ok(points
        .iter()
        .enumerate()
        .flat_map(|(i, first)| {
            points[i + 1..]
                .iter()
                .map(|second| Candidate::Distance([*first, *second]))
        })
        .collect())
}

/// The candidates of a plan of `counts` on `grid`, each stage's where it
/// has a count: the grid's measurements ([`grid_candidates`], with
/// `measured`), a delta's heights measured by hand
/// ([`height_candidates`]) and part distances ([`distance_candidates`]).
pub fn plan_candidates(
    mechanism: &dyn Mechanism,
    params: &[f64],
    grid: Grid,
    measured: bool,
    counts: Counts,
) -> Result<Vec<Candidate>, DesignError> {
    let mut candidates = Vec::new();
    for stage in Stage::ALL.into_iter().filter(|&s| counts.of(s) > 0) {
        candidates.extend(match stage {
            Stage::Measurements => grid_candidates(mechanism, params, grid, measured)?,
            Stage::Heights => height_candidates(mechanism, grid)?,
            Stage::Distances => distance_candidates(mechanism, grid)?,
        });
    }
    Ok(candidates)
}

/// The candidates of `mechanism` at parameters `params` on `grid` (module
/// doc); a cable robot's samples with their position measured if
/// `measured`.
pub fn grid_candidates(
    mechanism: &dyn Mechanism,
    params: &[f64],
    grid: Grid,
    measured: bool,
) -> Result<Vec<Candidate>, DesignError> {
    let per_axis = grid.per_axis;
    match mechanism.name() {
        "linear delta" => Ok(bed_grid(grid).map(Candidate::Probe).collect()),
        "cable robot" => {
            let robot = CableRobot::typical();
            let anchors: Vec<_> = (0..mechanism.actuators().len())
                .map(|j| robot.anchor(params, j))
                .collect();
            let bound = |k: usize, max: bool| {
                anchors
                    .iter()
                    .map(|a| a[k])
                    .fold(if max { f64::MIN } else { f64::MAX }, |b, v| {
                        if max { b.max(v) } else { b.min(v) }
                    })
            };
            let (xs, ys) = (
                along(bound(0, false), bound(0, true), per_axis),
                along(bound(1, false), bound(1, true), per_axis),
            );
            let zs = along(0.0, bound(2, true), per_axis);
            let mut candidates = Vec::new();
            for x in xs {
                for y in ys.clone() {
                    for z in zs.clone() {
                        candidates.push(if measured {
                            Candidate::MeasuredSample([x, y, z])
                        } else {
                            Candidate::Sample([x, y, z])
                        });
                    }
                }
            }
            Ok(candidates)
        }
        other => Err(DesignError::Options(format!(
            "no candidate grid for a {other}: a plan of a linear delta or a cable robot"
        ))),
    }
}
