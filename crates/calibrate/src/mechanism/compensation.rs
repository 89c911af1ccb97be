//! The actuator commands that put the calibrated machine's effector on
//! target positions: `q = g(p̂, x)` (the inverse kinematics at the
//! calibrated parameters, after [`Mechanism::check_feasible`]), beside
//! the nominal `q_0 = g(p_0, x)` of the design the calibration started
//! from (what a controller configured from the design commands).
//!
//! Where the machine truly is at `q` differs from `x` by the calibration's
//! error: to first order `δx = (dx/dp|_q) δp`, so its covariance is
//!
//! ```text
//! Cov(x) = J Σ_p Jᵀ,   J = dx/dp|_q = −G_x⁺ G_p,
//! ```
//!
//! `Σ_p` the calibration's covariance of the parameters
//! ([`super::predicted::pose_derivative`]).

use nalgebra::{DMatrix, DVector, Matrix3};
use parcal_kinematics::mechanism::{Mechanism, MechanismError};

use super::calibrated::CalibratedMechanism;
use super::predicted::pose_derivative;

/// The commands of one target (module doc).
#[derive(Debug, Clone, PartialEq)]
#[non_exhaustive]
pub struct Compensation {
    /// The target position `x` (mm).
    pub target: [f64; 3],
    /// `q = g(p̂, x)`, the calibrated machine's readings there.
    pub readings: DVector<f64>,
    /// `q_0 = g(p_0, x)`, the nominal machine's.
    pub nominal: DVector<f64>,
    /// `Cov(x)` of the position the machine reaches at `q` (mm²).
    pub covariance: Matrix3<f64>,
}

impl Compensation {
    /// The predicted standard deviation of each coordinate reached (mm).
    pub fn sigmas(&self) -> [f64; 3] {
        std::array::from_fn(|k| self.covariance[(k, k)].max(0.0).sqrt())
    }
}

/// Each target's commands with `calibrated`, or why the calibrated (or
/// the nominal) machine cannot reach it, in the order of `targets`.
pub fn compensate_mechanism(
    calibrated: &CalibratedMechanism,
    targets: &[[f64; 3]],
) -> Vec<Result<Compensation, MechanismError>> {
    let mechanism = calibrated.mechanism.as_ref();
    let n = calibrated.n_params();
    let sigma_p = calibrated.covariance.view((0, 0), (n, n)).into_owned();
    targets
        .iter()
        .map(|target| compensate_one(mechanism, calibrated, &sigma_p, target))
        .collect()
}

fn compensate_one(
    mechanism: &dyn Mechanism,
    calibrated: &CalibratedMechanism,
    sigma_p: &DMatrix<f64>,
    target: &[f64; 3],
) -> Result<Compensation, MechanismError> {
    let params = calibrated.params();
    mechanism.check_feasible(params, target)?;
    let readings = mechanism.inverse(params, target)?;
    let nominal = mechanism
        .inverse(&calibrated.nominal, target)
        .map_err(|error| MechanismError::Unreachable {
            reason: format!("the nominal machine cannot reach it: {error}"),
        })?;
    let jacobians = mechanism.reading_jacobians(params, target)?;
    let (j, _) = pose_derivative(&jacobians.d_pose, &jacobians.d_params)?;
    let covariance = &j * sigma_p * j.transpose();
    Ok(Compensation {
        target: *target,
        readings,
        nominal,
        covariance: covariance.fixed_view::<3, 3>(0, 0).into_owned(),
    })
}
