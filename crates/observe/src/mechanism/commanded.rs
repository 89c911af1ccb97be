//! What the machine reaches when its controller commands a position or its
//! actuators read given values, and the whitened rows every observation
//! kind returns.

use nalgebra::{DMatrix, DVector, Vector3};
use parcal_kinematics::mechanism::{Mechanism, MechanismError, Reached};

/// The number of pose coordinates these kinds need: a position `(x, y, z)`.
pub const POSE_COORDINATES: usize = 3;

/// Whitened residual rows and their Jacobian with respect to the
/// mechanism's parameters (and, for some kinds, other unknowns).
#[derive(Debug, Clone, PartialEq)]
pub struct Rows {
    /// Whitened residuals `e / σ`.
    pub residual: DVector<f64>,
    /// `d(e / σ)/dp` (rows × parameters).
    pub d_params: DMatrix<f64>,
}

/// Where the machine with true parameters `params` is when its controller,
/// configured with `configured`, commands `commanded`: the tool point
/// `T(p, f(p, g(p_c, x_c)))` and its `dT/dp` at fixed readings (3 x
/// parameters; module doc), the forward kinematics started at `x_c`.
pub fn reached(
    mechanism: &dyn Mechanism,
    params: &[f64],
    configured: &[f64],
    commanded: &[f64; 3],
) -> Result<(DVector<f64>, DMatrix<f64>), MechanismError> {
    let reached = reached_at_command(mechanism, params, configured, commanded)?;
    Ok((
        DVector::from_column_slice(reached.point.as_slice()),
        reached.d_params,
    ))
}

/// [`reached`] with the pose: the readings `g(p_c, x_c)` through
/// [`Mechanism::tool_point_at_readings`] from `x_c`.
fn reached_at_command(
    mechanism: &dyn Mechanism,
    params: &[f64],
    configured: &[f64],
    commanded: &[f64; 3],
) -> Result<Reached, MechanismError> {
    let readings = mechanism.inverse(configured, commanded)?;
    mechanism.tool_point_at_readings(params, readings.as_slice(), commanded)
}

/// How the machine was put where it observed: a position `x_c` its
/// controller commanded (the readings `g(p_c, x_c)` follow from the
/// configured parameters), or the readings `q` its actuators gave (a
/// hexapod's legs at a touch).
#[derive(Debug, Clone, PartialEq)]
pub enum Actuation {
    /// A commanded position `x_c` (mm, the controller's coordinates).
    Commanded([f64; 3]),
    /// The actuators' readings `q`, one per actuator.
    Readings(Vec<f64>),
}

impl Actuation {
    /// The pose and tool point the machine of true parameters `params`
    /// reaches and the tool point's `dT/dp` at fixed readings: [`reached`]
    /// for a commanded position; for readings, the forward kinematics from
    /// `start` (a pose near the one reached, such as the one a previous
    /// evaluation found), else from the mechanism's
    /// [`Mechanism::start_pose`].
    pub fn tool_point(
        &self,
        mechanism: &dyn Mechanism,
        params: &[f64],
        configured: &[f64],
        start: Option<&[f64]>,
    ) -> Result<Reached, MechanismError> {
        match self {
            Self::Commanded(commanded) => {
                reached_at_command(mechanism, params, configured, commanded)
            }
            Self::Readings(readings) => match start {
                Some(start) => mechanism.tool_point_at_readings(params, readings, start),
                None => {
                    let start = mechanism.start_pose(params, readings)?;
                    mechanism.tool_point_at_readings(params, readings, start.as_slice())
                }
            },
        }
    }

    /// The pose the machine of true parameters `params` reaches, `f(p, q)`,
    /// without derivatives: from the commanded position (the readings
    /// `g(p_c, x_c)`) or from the mechanism's [`Mechanism::start_pose`].
    pub fn pose(
        &self,
        mechanism: &dyn Mechanism,
        params: &[f64],
        configured: &[f64],
    ) -> Result<DVector<f64>, MechanismError> {
        match self {
            Self::Commanded(commanded) => {
                let readings = mechanism.inverse(configured, commanded)?;
                mechanism.forward(params, readings.as_slice(), commanded)
            }
            Self::Readings(readings) => {
                let start = mechanism.start_pose(params, readings)?;
                mechanism.forward(params, readings, start.as_slice())
            }
        }
    }

    /// The tool point at [`Actuation::pose`], without derivatives.
    pub fn point(
        &self,
        mechanism: &dyn Mechanism,
        params: &[f64],
        configured: &[f64],
    ) -> Result<Vector3<f64>, MechanismError> {
        let pose = self.pose(mechanism, params, configured)?;
        Ok(mechanism.tool_point(params, pose.as_slice())?.point)
    }
}

/// Refuses a standard deviation that is not finite and positive.
pub(crate) fn check_sigma(what: &'static str, sigma: f64) -> Result<(), MechanismError> {
    if sigma.is_finite() && sigma > 0.0 {
        Ok(())
    } else {
        Err(MechanismError::NonFinite {
            what: format!("{what} {sigma} (a standard deviation must be finite and positive)"),
        })
    }
}
