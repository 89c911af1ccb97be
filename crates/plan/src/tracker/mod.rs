//! Measurement design for an instrument calibration: which platform poses
//! to measure with a laser tracker (points) or motion capture (poses) so
//! that the calibrated machine is most accurate for a given number of
//! poses (docs/plan-poses.md).
//!
//! - [`pool`]: the feasible candidate poses on the workspace and tilt box;
//! - [`information`]: each pose's whitened rows on the instrument
//!   calibration's global block and the prior, linearised at the design;
//! - [`select`]: greedy selection and Fedorov exchange of multi-row
//!   candidates with shared nuisances;
//! - [`plan_file`]: plan.csv and plan.json of poses.

pub mod information;
pub mod plan_file;
pub mod pool;
pub mod select;

use parcal_accuracy::{CanonicalTargets, MapGrid, registered_jacobians};
use parcal_dataset::Machine;
use parcal_kinematics::{Geometry, params};
use parcal_simulate::{TrackerKind, Workspace};

use crate::criterion::{Criterion, CriterionValues, MapWeights};
use crate::{DesignError, bounds};

pub use pool::CandidatePose;

/// Everything a pose plan is asked for.
#[derive(Debug, Clone, PartialEq)]
pub struct PosePlanOptions {
    /// The budget: number of poses.
    pub poses: usize,
    /// What the instrument measures at each pose.
    pub kind: TrackerKind,
    /// Where the platform origin may go (design base frame).
    pub workspace: Workspace,
    /// Largest |roll|, |pitch|, |yaw| (degrees).
    pub tilt_degrees: f64,
    /// What is minimised.
    pub criterion: Criterion,
    /// Largest number of exchange passes.
    pub passes: usize,
    /// Number of measuring sessions (re-homing, a re-placed instrument):
    /// the poses are split evenly between them, each session with its own
    /// nuisances (the instrument frame, and the leg offsets and body origin
    /// and turn when machine.json's `session_model` gives their sigmas).
    pub sessions: usize,
}

/// A pose plan and what it is predicted to give.
#[derive(Debug, Clone)]
pub struct PosePlan {
    /// The chosen poses, by session, in pool order within each.
    pub poses: Vec<CandidatePose>,
    /// The session (0-based) of each chosen pose.
    pub sessions: Vec<usize>,
    /// Predicted figures after calibrating the plan's poses.
    pub predicted: CriterionValues,
    /// The prior's figures.
    pub prior: CriterionValues,
    /// Number of feasible candidates the plan was chosen from.
    pub pool_size: usize,
}

/// Plans `options.poses` poses for the instrument calibration of
/// `machine` (module doc); `progress` hears one line per stage and pass.
pub fn plan_poses(
    machine: &Machine,
    options: &PosePlanOptions,
    progress: &mut dyn FnMut(&str),
) -> Result<PosePlan, DesignError> {
    let refuse = DesignError::Options;
    bounds::POSES
        .check("poses", options.poses)
        .map_err(refuse)?;
    bounds::SESSIONS
        .check("sessions", options.sessions)
        .map_err(refuse)?;
    let k = options.sessions;
    if !options.poses.is_multiple_of(k) {
        return Err(DesignError::Options(format!(
            "{} poses in {k} sessions: the sessions must share the poses evenly",
            options.poses
        )));
    }
    let m = &machine.geometry;
    let design = Geometry::from_arrays(&m.base_joints, &m.platform_joints, &m.tool, &m.leg_lengths);
    let canonical = design.canonicalize().map_err(DesignError::Design)?;
    let pool = pool::pose_pool(
        &design,
        &options.workspace,
        options.tilt_degrees.to_radians(),
        &machine.actuator.scale,
        machine.stroke,
        machine.joint_limits.map(|l| l.limits()).as_ref(),
    )?;
    progress(&format!("{} feasible candidate poses", pool.len()));
    let poses: Vec<_> = pool.iter().map(|c| c.pose).collect();
    let q: Vec<_> = pool.iter().map(|c| c.q).collect();
    let rows = information::pose_information(machine, &design.tool, options.kind, &poses, &q, k)?;
    let targets =
        CanonicalTargets::new(&design, &MapGrid::paper()).map_err(DesignError::Accuracy)?;
    let map = MapWeights::new(
        registered_jacobians(&targets, &params::to_params(&canonical.geometry))
            .map_err(DesignError::Accuracy)?,
    );
    let prior_covariance = select::params_block(
        &rows
            .prior
            .clone()
            .cholesky()
            .ok_or(DesignError::Singular)?
            .inverse(),
    );
    let prior = CriterionValues::of(&prior_covariance, &map).ok_or(DesignError::Singular)?;
    let group: Vec<usize> = (0..rows.blocks.len()).map(|c| c / pool.len()).collect();
    let quota = vec![options.poses / k; k];
    let selection = select::select_poses(
        &rows.blocks,
        select::Quotas {
            group: &group,
            quota: &quota,
        },
        &rows.prior,
        &map,
        options.criterion,
        options.passes,
        progress,
    )?;
    Ok(PosePlan {
        poses: selection
            .chosen
            .iter()
            .map(|&c| pool[c % pool.len()].clone())
            .collect(),
        sessions: selection.chosen.iter().map(|&c| group[c]).collect(),
        predicted: CriterionValues::of(&selection.covariance, &map).ok_or(DesignError::Singular)?,
        prior,
        pool_size: pool.len(),
    })
}
