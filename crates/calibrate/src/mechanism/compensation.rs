//! The actuator commands that put the calibrated machine on target poses
//! `x` (in the mechanism's pose coordinates: a delta's or a cable robot's
//! effector position, a hexapod's platform translation and rotation
//! vector): `q = g(p̂, x)` (the inverse kinematics at the calibrated
//! parameters, after [`Mechanism::check_feasible`]), beside the nominal
//! `q_0 = g(p_0, x)` of the design the calibration started from (what a
//! controller configured from the design commands). A mechanism whose
//! readings depend on its actuators' loads `F` (a cable robot's elastic
//! lines) is commanded under the loads it holds at the target, `q =
//! g_F(p̂, x)` ([`Mechanism::loaded_readings`]), when they are given; `g`
//! is the readings under the loads held when the actuators were zeroed.
//!
//! Where the machine truly is at `q` differs from `x` by the calibration's
//! error: to first order `δx = (dx/dp|_q) δp` (`δx` the pose increment
//! [`Mechanism::retract`] takes), so its covariance is
//!
//! ```text
//! Cov(x) = J Σ_p Jᵀ,   J = dx/dp|_q = −G_x⁺ G_p,
//! ```
//!
//! `Σ_p` the calibration's covariance of the parameters
//! ([`super::predicted::pose_derivative`]).

use nalgebra::{DMatrix, DVector};
use parcal_kinematics::mechanism::{Mechanism, MechanismError};
use rayon::prelude::*;

use super::calibrated::CalibratedMechanism;
use super::predicted::pose_derivative;

/// The commands of one target (module doc).
#[derive(Debug, Clone, PartialEq)]
#[non_exhaustive]
pub struct Compensation {
    /// The target pose `x` (the mechanism's pose coordinates).
    pub target: DVector<f64>,
    /// `q = g(p̂, x)`, the calibrated machine's readings there.
    pub readings: DVector<f64>,
    /// `q_0 = g(p_0, x)`, the nominal machine's.
    pub nominal: DVector<f64>,
    /// `Cov(x)` of the pose the machine reaches at `q`, over the pose
    /// increment's coordinates (mm², rad²).
    pub covariance: DMatrix<f64>,
}

impl Compensation {
    /// The predicted standard deviation of each coordinate of the pose
    /// increment reached (mm, rad).
    pub fn sigmas(&self) -> Vec<f64> {
        self.covariance
            .diagonal()
            .iter()
            .map(|v| v.max(0.0).sqrt())
            .collect()
    }
}

/// Each target pose's commands with `calibrated`, under the loads
/// `loads[k]` of target `k` (`loads` empty: those held when the actuators
/// were zeroed), or why the calibrated (or the nominal) machine cannot
/// reach it, in the order of `targets` (each solved on its own, on the
/// threads).
pub fn compensate_mechanism<T: AsRef<[f64]> + Sync>(
    calibrated: &CalibratedMechanism,
    targets: &[T],
    loads: &[Vec<f64>],
) -> Vec<Result<Compensation, MechanismError>> {
    let mechanism = calibrated.mechanism.as_ref();
    let n = calibrated.n_params();
    let sigma_p = calibrated.covariance.view((0, 0), (n, n)).into_owned();
    targets
        .par_iter()
        .enumerate()
        .map(|(k, target)| {
            let loads = loads.get(k).map(Vec::as_slice);
            compensate_one(mechanism, calibrated, &sigma_p, target.as_ref(), loads)
        })
        .collect()
}

fn compensate_one(
    mechanism: &dyn Mechanism,
    calibrated: &CalibratedMechanism,
    sigma_p: &DMatrix<f64>,
    target: &[f64],
    loads: Option<&[f64]>,
) -> Result<Compensation, MechanismError> {
    let params = calibrated.params();
    mechanism.check_feasible(params, target)?;
    let (readings, jacobians) = match loads {
        Some(loads) => mechanism.loaded_readings(params, target, loads)?,
        None => (
            mechanism.inverse(params, target)?,
            mechanism.reading_jacobians(params, target)?,
        ),
    };
    // Of the nominal machine, its readings alone.
    let nominal = match loads {
        Some(loads) => mechanism
            .loaded_readings(&calibrated.nominal, target, loads)
            .map(|(readings, _)| readings),
        None => mechanism.inverse(&calibrated.nominal, target),
    }
    .map_err(|error| MechanismError::Unreachable {
        reason: format!("the nominal machine cannot reach it: {error}"),
    })?;
    let (j, _) = pose_derivative(&jacobians.d_pose, &jacobians.d_params)?;
    Ok(Compensation {
        target: DVector::from_column_slice(target),
        readings,
        nominal,
        covariance: &j * sigma_p * j.transpose(),
    })
}

/// The most unreachable targets [`UnreachableTargets::message`] names one
/// by one.
pub const NAMED_TARGETS: usize = 10;

/// The targets a calibrated machine cannot reach, each with why.
#[derive(Debug, Clone, PartialEq)]
#[non_exhaustive]
pub struct UnreachableTargets {
    /// The mechanism's name.
    pub mechanism: String,
    /// How many targets were given.
    pub targets: usize,
    /// Each unreachable target's index (in the order given) and why.
    pub unreachable: Vec<(usize, MechanismError)>,
}

impl UnreachableTargets {
    /// How many of how many targets the machine cannot reach, then the
    /// first [`NAMED_TARGETS`] of them, each named by `name(index)` (a
    /// file's line, an array's row), with why, and how many more.
    pub fn message(&self, name: impl Fn(usize) -> String) -> String {
        let named: Vec<String> = self
            .unreachable
            .iter()
            .take(NAMED_TARGETS)
            .map(|(k, error)| format!("{}: {error}", name(*k)))
            .collect();
        let more = self.unreachable.len().saturating_sub(NAMED_TARGETS);
        let more = if more > 0 {
            format!("\n  and {more} more")
        } else {
            String::new()
        };
        format!(
            "{} of {} targets cannot be reached by the calibrated {}:\n  {}{more}",
            self.unreachable.len(),
            self.targets,
            self.mechanism,
            named.join("\n  ")
        )
    }
}

/// Every target's commands with `calibrated` under `loads`
/// ([`compensate_mechanism`]), or every target it cannot reach.
pub fn compensate_targets<T: AsRef<[f64]> + Sync>(
    calibrated: &CalibratedMechanism,
    targets: &[T],
    loads: &[Vec<f64>],
) -> Result<Vec<Compensation>, UnreachableTargets> {
    let results = compensate_mechanism(calibrated, targets, loads);
    let unreachable: Vec<(usize, MechanismError)> = results
        .iter()
        .enumerate()
        .filter_map(|(k, result)| result.as_ref().err().map(|e| (k, e.clone())))
        .collect();
    if unreachable.is_empty() {
        Ok(results.into_iter().flatten().collect())
    } else {
        Err(UnreachableTargets {
            mechanism: calibrated.mechanism.name().to_string(),
            targets: targets.len(),
            unreachable,
        })
    }
}
