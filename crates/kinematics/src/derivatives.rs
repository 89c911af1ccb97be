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

use nalgebra::{Matrix3x6, Matrix6x3, SMatrix, Vector6};

use crate::params::{BASE_INDEX, N_PARAMS, PLATFORM_INDEX, TOOL_OFFSET, leg_index};
use crate::{Geometry, KinematicsError, Params, Pose, Vec3, closure::Legs, lu6::Lu6};

/// Tool-tip derivatives at one forward-kinematics solution.
#[derive(Debug, Clone, PartialEq)]
pub struct TipJacobians {
    /// `J_f = dT/dp` at fixed `q` (3 x 33), in the canonical base frame.
    pub d_params: SMatrix<f64, 3, N_PARAMS>,
    /// `dT/dq` at fixed parameters (3 x 6).
    pub d_q: Matrix3x6<f64>,
}

/// Derivatives of the tip of a canonical `geometry` at the pose where its legs
/// are `legs` (a forward-kinematics solution; [`crate::ForwardSolution::legs`]).
pub fn tip_jacobians(geometry: &Geometry, legs: &Legs) -> Result<TipJacobians, KinematicsError> {
    let rotation = legs.rotation;
    let tool = rotation * geometry.tool;
    // P^T = [I; [R E_T]x] (6 x 3); K^T = A^-T P^T.
    let mut p_transpose = Matrix6x3::zeros();
    p_transpose
        .fixed_view_mut::<3, 3>(0, 0)
        .fill_with_identity();
    p_transpose
        .fixed_view_mut::<3, 3>(3, 0)
        .copy_from(&tool.cross_matrix());
    let lu = Lu6::factor(&legs.pose_jacobian())?;
    let mut k = Matrix3x6::zeros();
    for c in 0..3 {
        let row = lu.solve_transpose(&p_transpose.column(c).into_owned());
        k.row_mut(c).copy_from(&row.transpose());
    }
    let mut d_params = SMatrix::<f64, 3, N_PARAMS>::zeros();
    for i in 0..6 {
        let k_i = k.column(i);
        let n = legs.direction[i];
        let n_platform = rotation.transpose() * n;
        for (c, slot) in BASE_INDEX[i].iter().enumerate() {
            if let Some(index) = slot {
                d_params.column_mut(*index).copy_from(&(k_i * n[c]));
            }
        }
        for (c, slot) in PLATFORM_INDEX[i].iter().enumerate() {
            if let Some(index) = slot {
                d_params
                    .column_mut(*index)
                    .copy_from(&(-k_i * n_platform[c]));
            }
        }
        d_params.column_mut(leg_index(i)).copy_from(&k_i);
    }
    d_params
        .fixed_view_mut::<3, 3>(0, TOOL_OFFSET)
        .copy_from(&rotation);
    Ok(TipJacobians { d_params, d_q: k })
}

/// The pose's and the tip's derivatives along a parameter direction `dp` at
/// fixed `q`, without forming `J_f`. With `v = (d phi / dp) dp` (leg `i`:
/// `-n_i . dB_i + (R^T n_i) . dE_i - dl_i`), the pose moves by
/// `(dt, w) = -A^-1 v` and the tip by `J_f dp = dt + w x R E_T + R dE_T`:
/// one LU solve instead of three.
#[derive(Debug, Clone, PartialEq)]
pub struct DerivativeAlong {
    /// `(dt, w)`: the pose increment (`t <- t + dt`, `R <- exp([w]x) R`) per
    /// unit of `dp`, to first order.
    pub pose: Vector6<f64>,
    /// `J_f dp` (mm).
    pub tip: Vec3,
}

/// [`DerivativeAlong`] of a canonical `geometry` at a forward-kinematics
/// solution's `legs`.
pub fn derivative_along(
    geometry: &Geometry,
    legs: &Legs,
    dp: &Params,
) -> Result<DerivativeAlong, KinematicsError> {
    let rotation = legs.rotation;
    let mut v = Vector6::zeros();
    for i in 0..6 {
        let n = legs.direction[i];
        let n_platform = rotation.transpose() * n;
        let mut change = -dp[leg_index(i)];
        for c in 0..3 {
            if let Some(k) = BASE_INDEX[i][c] {
                change -= n[c] * dp[k];
            }
            if let Some(k) = PLATFORM_INDEX[i][c] {
                change += n_platform[c] * dp[k];
            }
        }
        v[i] = change;
    }
    let pose = -Lu6::factor(&legs.pose_jacobian())?.solve(&v);
    let (dt, w) = (
        Vec3::from(pose.fixed_rows::<3>(0)),
        Vec3::from(pose.fixed_rows::<3>(3)),
    );
    let tool_step = Vec3::from(dp.fixed_rows::<3>(TOOL_OFFSET));
    let tip = dt + w.cross(&(rotation * geometry.tool)) + rotation * tool_step;
    Ok(DerivativeAlong { pose, tip })
}

/// [`tip_jacobians`] at a pose (evaluates the legs first).
pub fn tip_jacobians_at(geometry: &Geometry, pose: &Pose) -> Result<TipJacobians, KinematicsError> {
    tip_jacobians(geometry, &Legs::at(geometry, pose))
}
