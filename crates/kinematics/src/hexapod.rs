//! The 6-6 Stewart platform as a [`Mechanism`]: a thin adapter over the
//! crate's geometry, inverse and forward kinematics and closure Jacobian.
//!
//! - Parameters: the 33 of [`crate::params`], canonical by construction
//!   (the 45 input coordinates less the 12 of the two frames' rigid
//!   motions, [`crate::frames`]), so no gauge freedom is left.
//! - Pose: `(t_x, t_y, t_z, r_x, r_y, r_z)`, the platform's translation
//!   (mm) and rotation vector (rad, `R = exp([r]x)`); increments are
//!   `(dt, w)` with `R <- rot(w) R` ([`crate::forward::step`]).
//! - Readings: the actuator values `q_i = L_i - l_i` (mm).
//! - `dq/dx` are the closure rows `[n_i^T, (R E_i x n_i)^T]`
//!   ([`crate::closure`]); `dq_i/dp` is `-n_i` at the base joint
//!   `B_i`, `R^T n_i` at the platform joint `E_i`, `-1` at `l_i`.

use nalgebra::{DMatrix, DVector, Isometry3, Vector3, Vector6};

use crate::closure::Legs;
use crate::forward::step;
use crate::mechanism::{
    Actuator, Mechanism, MechanismError, Parameter, PoseCoordinate, ReadingJacobians, check_params,
    check_vector,
};
use crate::params::{
    BASE_INDEX, LEG_OFFSET, N_PARAMS, PARAM_NAMES, PLATFORM_INDEX, TOOL_OFFSET, from_params,
    leg_index, to_params,
};
use crate::{ForwardOptions, Geometry, KinematicsError, Params, Pose, PriorSigma, actuators};

/// The pose coordinates of a hexapod.
const POSE: [PoseCoordinate; 6] = [
    PoseCoordinate {
        name: "t_x",
        unit: "mm",
    },
    PoseCoordinate {
        name: "t_y",
        unit: "mm",
    },
    PoseCoordinate {
        name: "t_z",
        unit: "mm",
    },
    PoseCoordinate {
        name: "r_x",
        unit: "rad",
    },
    PoseCoordinate {
        name: "r_y",
        unit: "rad",
    },
    PoseCoordinate {
        name: "r_z",
        unit: "rad",
    },
];

/// A hexapod design with its tolerances.
#[derive(Debug, Clone)]
pub struct Hexapod {
    parameters: Vec<Parameter>,
    actuators: Vec<Actuator>,
    options: ForwardOptions,
}

impl Hexapod {
    /// The hexapod of a design geometry (any frames: it is canonicalised)
    /// with the tolerances of its input coordinates, each taken as the
    /// prior of the canonical parameters of its group (the propagated
    /// prior, [`crate::frames::parameter_jacobian`], couples them).
    pub fn new(design: &Geometry, prior: &PriorSigma) -> Result<Self, KinematicsError> {
        let canonical = design.canonicalize()?.geometry;
        let values = to_params(&canonical);
        let parameters = PARAM_NAMES
            .iter()
            .enumerate()
            .map(|(k, name)| {
                let (group, prior_sigma) = match k {
                    _ if k < LEG_OFFSET => ("base joints", prior.base),
                    _ if k < LEG_OFFSET + 6 => ("leg lengths", prior.leg),
                    _ if k < TOOL_OFFSET => ("platform joints", prior.platform),
                    _ => ("tool", prior.tool),
                };
                Parameter {
                    name: (*name).to_string(),
                    unit: "mm",
                    group,
                    design: values[k],
                    prior_sigma,
                }
            })
            .collect();
        let actuators = (1..=6)
            .map(|leg| Actuator::direct(format!("leg {leg}"), "mm"))
            .collect();
        Ok(Self {
            parameters,
            actuators,
            options: ForwardOptions::default(),
        })
    }

    /// The canonical geometry of a parameter vector (checked).
    fn geometry(&self, params: &[f64]) -> Result<Geometry, MechanismError> {
        check_params(self, params)?;
        Ok(from_params(&Params::from_column_slice(params)))
    }

    /// The pose of a pose vector (checked).
    fn pose(&self, pose: &[f64]) -> Result<Pose, MechanismError> {
        check_vector(self, "pose coordinates", pose, 6)?;
        Ok(pose_of(pose))
    }
}

/// The isometry of a pose vector `(t, r)`.
pub fn pose_of(x: &[f64]) -> Pose {
    Isometry3::new(
        Vector3::new(x[0], x[1], x[2]),
        Vector3::new(x[3], x[4], x[5]),
    )
}

/// The pose vector `(t, r)` of an isometry.
pub fn pose_vector(pose: &Pose) -> DVector<f64> {
    let (t, r) = (pose.translation.vector, pose.rotation.scaled_axis());
    DVector::from_column_slice(&[t.x, t.y, t.z, r.x, r.y, r.z])
}

impl Mechanism for Hexapod {
    fn name(&self) -> &str {
        "hexapod"
    }

    fn parameters(&self) -> &[Parameter] {
        &self.parameters
    }

    fn pose_coordinates(&self) -> &[PoseCoordinate] {
        &POSE
    }

    fn actuators(&self) -> &[Actuator] {
        &self.actuators
    }

    fn inverse(&self, params: &[f64], pose: &[f64]) -> Result<DVector<f64>, MechanismError> {
        let geometry = self.geometry(params)?;
        Ok(DVector::from_column_slice(&actuators(
            &geometry,
            &self.pose(pose)?,
        )))
    }

    fn forward(
        &self,
        params: &[f64],
        readings: &[f64],
        start: &[f64],
    ) -> Result<DVector<f64>, MechanismError> {
        let geometry = self.geometry(params)?;
        check_vector(self, "readings", readings, 6)?;
        let q: [f64; 6] = std::array::from_fn(|i| readings[i]);
        let solution = crate::forward(&geometry, &q, &self.pose(start)?, &self.options)?;
        Ok(pose_vector(&solution.pose))
    }

    fn reading_jacobians(
        &self,
        params: &[f64],
        pose: &[f64],
    ) -> Result<ReadingJacobians, MechanismError> {
        let geometry = self.geometry(params)?;
        let legs = Legs::at(&geometry, &self.pose(pose)?);
        let rows = legs.closure_rows();
        let d_pose = DMatrix::from_fn(6, 6, |i, c| rows[i][c]);
        let mut d_params = DMatrix::zeros(6, N_PARAMS);
        for i in 0..6 {
            let n = legs.direction[i];
            let n_platform = legs.rotation.tr_mul(&n);
            for c in 0..3 {
                if let Some(k) = BASE_INDEX[i][c] {
                    d_params[(i, k)] = -n[c];
                }
                if let Some(k) = PLATFORM_INDEX[i][c] {
                    d_params[(i, k)] = n_platform[c];
                }
            }
            d_params[(i, leg_index(i))] = -1.0;
        }
        Ok(ReadingJacobians { d_params, d_pose })
    }

    fn retract(&self, pose: &[f64], increment: &[f64]) -> DVector<f64> {
        pose_vector(&step(
            &pose_of(pose),
            &Vector6::from_column_slice(increment),
            1.0,
        ))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mechanism::{
        design, pose_jacobian_at_fixed_readings, reading_jacobians_by_differences,
    };
    use crate::{paper, rotation_zyx, tip_jacobians_at};
    use nalgebra::Translation3;

    fn hexapod() -> Hexapod {
        let prior = PriorSigma {
            base: 0.1,
            platform: 0.1,
            tool: 0.1,
            leg: 0.1,
        };
        Hexapod::new(&paper::design(), &prior).unwrap()
    }

    fn sample_pose() -> Pose {
        Pose::from_parts(
            Translation3::new(-30.0, 20.0, 240.0),
            rotation_zyx(0.1, -0.05, 0.08),
        )
    }

    #[test]
    fn the_adapter_gives_the_crates_kinematics() {
        let hexapod = hexapod();
        let p = to_params(&paper::truth().canonicalize().unwrap().geometry);
        let geometry = from_params(&p);
        let pose = sample_pose();
        let x = pose_vector(&pose);
        let q = hexapod.inverse(p.as_slice(), x.as_slice()).unwrap();
        assert_eq!(q.as_slice(), &actuators(&geometry, &pose));
        let start = pose_vector(&geometry.home_pose(&[0.0; 6]));
        let back = hexapod
            .forward(p.as_slice(), q.as_slice(), start.as_slice())
            .unwrap();
        assert!((back - &x).amax() < 1e-10, "forward kinematics");
        assert_eq!(design(&hexapod).len(), N_PARAMS);
        // Canonical by construction: no gauge freedom left.
        assert!(hexapod.gauge_freedoms(p.as_slice()).unwrap().is_empty());
        assert_eq!(hexapod.parameters()[LEG_OFFSET].group, "leg lengths");
    }

    #[test]
    fn reading_derivatives_match_central_differences() {
        let hexapod = hexapod();
        let p = design(&hexapod);
        let x = pose_vector(&sample_pose());
        let analytic = hexapod
            .reading_jacobians(p.as_slice(), x.as_slice())
            .unwrap();
        let numeric = reading_jacobians_by_differences(
            &hexapod,
            p.as_slice(),
            x.as_slice(),
            &[1e-4; N_PARAMS],
            1e-5,
        )
        .unwrap();
        // Central differences of O(1) derivatives with steps 1e-4 / 1e-5:
        // truncation ~h^2 |q'''| ~1e-9, rounding ~1e-16 * 250 / 1e-5.
        assert!((&analytic.d_params - &numeric.d_params).amax() < 1e-7);
        assert!((&analytic.d_pose - &numeric.d_pose).amax() < 1e-6);
    }

    #[test]
    fn implicit_pose_derivative_reproduces_the_tool_tip_jacobian() {
        // dT/dp = [I, -[R E_T]x] dx/dp + R dE_T/dp: the generic implicit
        // differentiation through the trait against the crate's own J_f.
        let hexapod = hexapod();
        let p = design(&hexapod);
        let geometry = from_params(&Params::from_column_slice(p.as_slice()));
        let pose = sample_pose();
        let x = pose_vector(&pose);
        let dx = pose_jacobian_at_fixed_readings(&hexapod, p.as_slice(), x.as_slice()).unwrap();
        let tool = pose.rotation * geometry.tool;
        let rotation = pose.rotation.to_rotation_matrix();
        let mut tip = DMatrix::zeros(3, N_PARAMS);
        for k in 0..N_PARAMS {
            let (dt, w) = (
                Vector3::new(dx[(0, k)], dx[(1, k)], dx[(2, k)]),
                Vector3::new(dx[(3, k)], dx[(4, k)], dx[(5, k)]),
            );
            let mut column = dt + w.cross(&tool);
            if k >= TOOL_OFFSET {
                column += rotation.matrix().column(k - TOOL_OFFSET);
            }
            tip.set_column(k, &column);
        }
        let reference = tip_jacobians_at(&geometry, &pose).unwrap().d_params;
        let difference =
            (tip - DMatrix::from_column_slice(3, N_PARAMS, reference.as_slice())).amax();
        assert!(difference < 1e-10, "{difference:e}");
    }

    #[test]
    fn wrong_lengths_and_non_finite_values_are_named() {
        let hexapod = hexapod();
        let p = design(&hexapod);
        let err = hexapod.inverse(&p.as_slice()[..5], &[0.0; 6]).unwrap_err();
        assert_eq!(err.to_string(), "hexapod has 33 parameters, got 5");
        let mut bad = p.clone();
        bad[13] = f64::NAN;
        let err = hexapod.inverse(bad.as_slice(), &[0.0; 6]).unwrap_err();
        assert_eq!(err.to_string(), "parameter l_2 is not a finite number");
        let err = hexapod.inverse(p.as_slice(), &[0.0; 5]).unwrap_err();
        assert_eq!(err.to_string(), "hexapod needs 6 pose coordinates, got 5");
    }
}
