//! Analytic derivatives of the tool tip at fixed actuator values, by implicit
//! differentiation of the closure equations (paper eqs. 1-2).
//!
//! With the closure `phi(pose, p, q) = 0` ([`crate::closure`]), its pose
//! Jacobian `A = d phi / d pose` and the tip `T = R E_T + t`, whose pose
//! derivative is `P = [I, -[R E_T]x]`, let `K = P A^-1` (3 x 6). Then
//!
//! ```text
//! dT/dq = -K d phi/dq = K                      (d phi_i / d q_i = -1)
//! dT/dp = -K d phi/dp + dT/dp|pose
//! ```
//!
//! where leg `i` contributes only through its own joints and length:
//! `d phi_i / d B_i = -n_i^T`, `d phi_i / d E_i = n_i^T R`,
//! `d phi_i / d l_i = -1`, and the tool enters directly, `dT / d E_T = R`.
//! `K` comes from one LU of `A` solved transposed ([`crate::lu6`]).
//!
//! A calibration needs `J_f` only through products: a combination of its
//! rows `h^T J_f` (`y = A^-T P^T h`, then leg `i` contributes `y_i` times its
//! sparse row of `d phi / dp`: one transposed solve, no 3 x 33 matrix) and a
//! directional derivative `J_f dp` (one solve). [`TipDerivatives`] keeps
//! what both need; [`TipDerivatives::jacobians`] forms the full matrices.

use nalgebra::{Matrix3x6, SMatrix, Vector3, Vector6};

use crate::forward::step;
use crate::lanes::forward_batch;
use crate::params::{BASE_INDEX, N_PARAMS, PLATFORM_INDEX, TOOL_OFFSET, leg_index};
use crate::{
    ForwardOptions, ForwardSolution, Geometry, KinematicsError, Params, Pose, Vec3, closure::Legs,
};

/// Tool-tip derivatives at one forward-kinematics solution.
#[derive(Debug, Clone, PartialEq)]
pub struct TipJacobians {
    /// `J_f = dT/dp` at fixed `q` (3 x 33), in the canonical base frame.
    pub d_params: SMatrix<f64, 3, N_PARAMS>,
    /// `dT/dq` at fixed parameters (3 x 6).
    pub d_q: Matrix3x6<f64>,
}

/// The derivatives of the tool tip of a canonical geometry at one
/// forward-kinematics solution, as linear maps (module documentation). The
/// default is a placeholder (the derivatives of a zero-length mechanism at
/// the identity pose), to be overwritten.
#[derive(Debug, Clone, Default)]
pub struct TipDerivatives {
    /// The forward kinematics: the legs (`R`, `n_i`) and the LU of the
    /// closure Jacobian `A` where they are.
    solution: ForwardSolution,
    /// `R E_T`: the tool offset rotated into the base frame.
    tool: Vec3,
}

/// The pose's and the tip's derivatives along a parameter direction `dp` at
/// fixed `q`, without forming `J_f`. With `v = (d phi / dp) dp` (leg `i`:
/// `-n_i . dB_i + (R^T n_i) . dE_i - dl_i`), the pose moves by
/// `(dt, w) = -A^-1 v` and the tip by `J_f dp = dt + w x R E_T + R dE_T`.
#[derive(Debug, Clone, PartialEq)]
pub struct DerivativeAlong {
    /// `(dt, w)`: the pose increment (`t <- t + dt`, `R <- exp([w]x) R`) per
    /// unit of `dp`, to first order.
    pub pose: Vector6<f64>,
    /// `J_f dp` (mm).
    pub tip: Vec3,
}

impl TipDerivatives {
    /// The derivatives of `geometry`'s tip at its forward-kinematics
    /// `solution`.
    pub fn new(geometry: &Geometry, solution: &ForwardSolution) -> Self {
        Self {
            tool: solution.legs.rotation * geometry.tool,
            solution: solution.clone(),
        }
    }

    /// The derivatives at `pose` (evaluates and factorises the legs).
    pub fn at(geometry: &Geometry, pose: &Pose) -> Result<Self, KinematicsError> {
        let legs = Legs::at(geometry, pose);
        let solution = ForwardSolution {
            pose: *pose,
            factor: legs.factor()?,
            legs,
            iterations: 0,
        };
        Ok(Self::new(geometry, &solution))
    }

    /// Forward kinematics of `geometry` at `q` from `start`
    /// ([`crate::forward()`]),
    /// in place, leaving these derivatives at its solution.
    pub fn forward(
        &mut self,
        geometry: &Geometry,
        q: &[f64; 6],
        start: &Pose,
        options: &ForwardOptions,
    ) -> Result<(), KinematicsError> {
        let items = std::slice::from_mut(self);
        Self::forward_batch(geometry, &[q], &[*start], options, items, |d| d).map_err(|(_, e)| e)
    }

    /// [`TipDerivatives::forward`] of up to [`crate::lanes::LANES`]
    /// contacts at once (in SIMD lanes where the machine has AVX2,
    /// [`crate::lanes::forward_batch`]): the derivatives of item `l`
    /// (`derivatives(&mut items[l])`) are left at the solution for `q[l]`
    /// from `starts[l]`. An error is that of the first failing contact, with
    /// its index (the other derivatives are then unspecified).
    pub fn forward_batch<T>(
        geometry: &Geometry,
        q: &[&[f64; 6]],
        starts: &[Pose],
        options: &ForwardOptions,
        items: &mut [T],
        derivatives: impl Fn(&mut T) -> &mut Self,
    ) -> Result<(), (usize, KinematicsError)> {
        for (item, start) in items.iter_mut().zip(starts) {
            derivatives(item).solution.pose = *start;
        }
        forward_batch(geometry, q, options, items, |item| {
            &mut derivatives(item).solution
        })?;
        for item in items.iter_mut() {
            let derivatives = derivatives(item);
            derivatives.tool = derivatives.solution.legs.rotation * geometry.tool;
        }
        Ok(())
    }

    /// The forward-kinematics solution these derivatives are taken at.
    pub fn solution(&self) -> &ForwardSolution {
        &self.solution
    }

    /// `y = K^T h = A^-T P^T h`, `P^T h = (h, R E_T x h)`: the weights of the
    /// closure rows in `h^T J_f`; also `h^T dT/dq = y^T`.
    pub fn closure_weights(&self, h: &Vec3) -> Vector6<f64> {
        let m = self.tool.cross(h);
        self.solution
            .factor
            .solve_transpose(&Vector6::new(h.x, h.y, h.z, m.x, m.y, m.z))
    }

    /// `h^T J_f`, written into `out` (33 values): leg `i` adds `y_i` times
    /// its row `(n_i; -R^T n_i; 1)` at its base joint, platform joint and
    /// length, and the tool columns are `h^T R`.
    pub fn params_row(&self, h: &Vec3, out: &mut [f64]) {
        let y = self.closure_weights(h);
        let legs = &self.solution.legs;
        let rotation = &legs.rotation;
        for i in 0..6 {
            let n = &legs.direction[i];
            let n_platform = rotation.tr_mul(n);
            for c in 0..3 {
                if let Some(k) = BASE_INDEX[i][c] {
                    out[k] = y[i] * n[c];
                }
                if let Some(k) = PLATFORM_INDEX[i][c] {
                    out[k] = -y[i] * n_platform[c];
                }
            }
            out[leg_index(i)] = y[i];
        }
        let tool = rotation.tr_mul(h);
        out[TOOL_OFFSET..TOOL_OFFSET + 3].copy_from_slice(tool.as_slice());
    }

    /// `J_f dp` and the pose's first-order change along `dp`
    /// ([`DerivativeAlong`]): one LU solve.
    pub fn along(&self, dp: &Params) -> DerivativeAlong {
        let legs = &self.solution.legs;
        let v = Vector6::from_fn(|i, _| {
            let n = &legs.direction[i];
            let n_platform = legs.rotation.tr_mul(n);
            let mut change = -dp[leg_index(i)];
            for c in 0..3 {
                if let Some(k) = BASE_INDEX[i][c] {
                    change -= n[c] * dp[k];
                }
                if let Some(k) = PLATFORM_INDEX[i][c] {
                    change += n_platform[c] * dp[k];
                }
            }
            change
        });
        let pose = -self.solution.factor.solve(&v);
        let (dt, w) = (
            Vec3::from(pose.fixed_rows::<3>(0)),
            Vec3::from(pose.fixed_rows::<3>(3)),
        );
        let tool_step = Vec3::from(dp.fixed_rows::<3>(TOOL_OFFSET));
        let tip = dt + w.cross(&self.tool) + legs.rotation * tool_step;
        DerivativeAlong { pose, tip }
    }

    /// The first-order prediction of the pose at actuator values changed by
    /// `dq` (same parameters): `A dpose = dq` (the closure's
    /// `d phi_i / d q_i = -1`), one solve, applied as a Newton step is. A
    /// warm start for the forward kinematics of a nearby contact.
    pub fn predicted_pose(&self, dq: &Vector6<f64>) -> Pose {
        step(&self.solution.pose, &self.solution.factor.solve(dq), 1.0)
    }

    /// `dT/dq` (3 x 6): row `a` is [`TipDerivatives::closure_weights`] of
    /// the base-frame axis `a`.
    pub fn d_q(&self) -> Matrix3x6<f64> {
        let mut d_q = Matrix3x6::zeros();
        for axis in 0..3 {
            let y = self.closure_weights(&Vector3::ith(axis, 1.0));
            d_q.row_mut(axis).copy_from(&y.transpose());
        }
        d_q
    }

    /// The full `J_f` (3 x 33) and `dT/dq` (3 x 6): one row per base-frame
    /// axis.
    pub fn jacobians(&self) -> TipJacobians {
        let mut d_params = SMatrix::<f64, 3, N_PARAMS>::zeros();
        let mut row = [0.0; N_PARAMS];
        for axis in 0..3 {
            self.params_row(&Vector3::ith(axis, 1.0), &mut row);
            d_params.row_mut(axis).copy_from_slice(&row);
        }
        TipJacobians {
            d_params,
            d_q: self.d_q(),
        }
    }
}

/// Derivatives of the tip of a canonical `geometry` at its forward-kinematics
/// `solution`, as full matrices ([`TipDerivatives::jacobians`]).
pub fn tip_jacobians(geometry: &Geometry, solution: &ForwardSolution) -> TipJacobians {
    TipDerivatives::new(geometry, solution).jacobians()
}

/// [`tip_jacobians`] at a pose (evaluates and factorises the legs first).
pub fn tip_jacobians_at(geometry: &Geometry, pose: &Pose) -> Result<TipJacobians, KinematicsError> {
    Ok(TipDerivatives::at(geometry, pose)?.jacobians())
}
