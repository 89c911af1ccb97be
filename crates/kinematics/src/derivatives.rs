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
//! [`FactoredTipJacobian`] keeps `K^T` itself (three transposed solves,
//! once) instead of the LU: a combination of rows is then a 6 x 3 product,
//! and no factorisation need be kept per contact (what the SIMD lanes of
//! [`crate::forward_batch`] leave).

use bytemuck::{Pod, Zeroable};
use nalgebra::{Matrix, Matrix3, Matrix3x6, Matrix6x3, SMatrix, Storage, U3, Vector3, Vector6};

use crate::forward::{forward_in_place, step};
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
    pub(crate) solution: ForwardSolution,
    /// `R E_T`: the tool offset rotated into the base frame.
    pub(crate) tool: Vec3,
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

/// A contact's forward-kinematics solution and its first-order change along
/// a parameter direction `dp` ([`TipDerivatives::along`]), without the
/// derivatives themselves: what a back-substitution needs of a contact
/// ([`crate::forward_batch::forward_along_batch`] makes up to four at once).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct SolutionAlong {
    /// The solution's pose.
    pub pose: Pose,
    /// The first-order prediction of the pose at the parameters `p + dp`:
    /// `pose` stepped by [`DerivativeAlong::pose`] ([`step`]).
    pub predicted: Pose,
    /// The tool tip at `pose`, [`Geometry::tool_tip`] (paper eq. 2).
    pub tool_tip: Vec3,
    /// `J_f dp` (mm).
    pub tip: Vec3,
    /// Newton steps taken.
    pub iterations: usize,
}

impl SolutionAlong {
    /// Forward kinematics of `geometry` at `q` from `start`
    /// ([`TipDerivatives::forward`]), then [`TipDerivatives::along`] `dp`
    /// at the solution.
    pub fn solve(
        geometry: &Geometry,
        q: &[f64; 6],
        start: &Pose,
        dp: &Params,
        options: &ForwardOptions,
    ) -> Result<Self, KinematicsError> {
        let derivatives = TipDerivatives::solved(geometry, q, start, options)?;
        let along = derivatives.along(dp);
        let solution = derivatives.solution();
        Ok(Self {
            pose: solution.pose,
            predicted: step(&solution.pose, &along.pose, 1.0),
            tool_tip: geometry.tool_tip(&solution.pose),
            tip: along.tip,
            iterations: solution.iterations,
        })
    }
}

/// `J_f` in factored form, `J_f = -K d phi/dp + dT/dp|pose` with
/// `K = P A^-1` (module documentation), kept as `K^T` (6 x 3), `R` and the
/// leg directions `n_i` (and `R^T n_i`, formed once for all its rows)
/// instead of the closure LU: a combination of its rows `h^T J_f` costs the
/// product `y = K^T h` and a sparse row per leg, and `J_f dp = -K v + R dE_T`
/// (`v` as in [`DerivativeAlong`]).
///
/// Its 63 values are held in the order of its fields (`#[repr(C)]`, plain
/// data): a form's values are read and written in place
/// ([`FactoredTipJacobian::in_values`]).
#[derive(Debug, Clone, Copy, Default, PartialEq, Pod, Zeroable)]
#[repr(C)]
pub struct FactoredTipJacobian {
    /// `K^T = A^-T P^T`: column `a` is [`TipDerivatives::closure_weights`]
    /// of the base-frame axis `a` (and `dT/dq = K`).
    pub weights: Matrix6x3<f64>,
    /// The platform's rotation `R`.
    pub rotation: Matrix3<f64>,
    /// The leg directions `n_i`.
    pub directions: [Vec3; 6],
    /// The leg directions in the platform frame, `R^T n_i`: the platform
    /// joints' columns of every row (a contact under eq. 10 with an angle
    /// prior combines three).
    pub platform_directions: [Vec3; 6],
}

impl FactoredTipJacobian {
    /// `R^T n_i` of each leg direction `n_i` under `rotation`
    /// ([`FactoredTipJacobian::platform_directions`]).
    pub fn platform_directions(rotation: &Matrix3<f64>, directions: &[Vec3; 6]) -> [Vec3; 6] {
        directions.map(|n| rotation.tr_mul(&n))
    }

    /// `h^T J_f`, written into `out` (33 values), as
    /// [`TipDerivatives::params_row`] forms it.
    #[inline]
    pub fn params_row(&self, h: &Vec3, out: &mut [f64]) {
        leg_rows(
            &(self.weights * h),
            &self.rotation,
            |i| (self.directions[i], self.platform_directions[i]),
            h,
            out,
        );
    }

    /// The number of its values ([`FactoredTipJacobian::in_values`]).
    pub const VALUES: usize = size_of::<Self>() / size_of::<f64>();

    /// The one held in the first [`FactoredTipJacobian::VALUES`] of
    /// `values`, in the order of its fields: `K^T` (18, column-major), `R`
    /// (9, column-major), the six `n_i` (18) and the six `R^T n_i` (18).
    ///
    /// # Panics
    /// If `values` holds fewer than [`FactoredTipJacobian::VALUES`].
    pub fn in_values(values: &[f64]) -> &Self {
        let values: &[f64; Self::VALUES] = values.first_chunk().expect("a factored J_f's values");
        bytemuck::cast_ref(values)
    }

    /// [`FactoredTipJacobian::in_values`], to be written.
    ///
    /// # Panics
    /// If `values` holds fewer than [`FactoredTipJacobian::VALUES`].
    pub fn in_values_mut(values: &mut [f64]) -> &mut Self {
        let values: &mut [f64; Self::VALUES] =
            (values.first_chunk_mut()).expect("room for a factored J_f's values");
        bytemuck::cast_mut(values)
    }

    /// `J_f dp` (mm).
    pub fn along(&self, dp: &Params) -> Vec3 {
        let legs = |i: usize| (self.directions[i], self.platform_directions[i]);
        let v = closure_change(legs, dp);
        self.rotation * tool_step(dp) - self.weights.tr_mul(&v)
    }
}

/// A contact's forward-kinematics solution with its `J_f` in factored form:
/// what a linearisation needs of a contact ([`crate::forward_batch::forward_jacobian_batch`]
/// makes up to four at once).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct SolutionJacobian {
    /// The solution's pose.
    pub pose: Pose,
    /// The tool tip at `pose`, [`Geometry::tool_tip`] (paper eq. 2).
    pub tool_tip: Vec3,
    /// `J_f` at the solution.
    pub jacobian: FactoredTipJacobian,
    /// Newton steps taken.
    pub iterations: usize,
}

impl SolutionJacobian {
    /// Forward kinematics of `geometry` at `q` from `start`
    /// ([`TipDerivatives::forward`]), then [`TipDerivatives::factored`].
    pub fn solve(
        geometry: &Geometry,
        q: &[f64; 6],
        start: &Pose,
        options: &ForwardOptions,
    ) -> Result<Self, KinematicsError> {
        let derivatives = TipDerivatives::solved(geometry, q, start, options)?;
        let solution = derivatives.solution();
        Ok(Self {
            pose: solution.pose,
            tool_tip: geometry.tool_tip(&solution.pose),
            jacobian: derivatives.factored(),
            iterations: solution.iterations,
        })
    }
}

/// Where a contact's forward-kinematics solution with `J_f` is kept
/// ([`crate::forward_batch::forward_jacobian_batch`] writes into it): a
/// [`SolutionJacobian`], or a mechanism's own room for what it returns,
/// so that the SIMD lanes write `J_f` where it is read, not into a copy.
pub trait SolutionRoom {
    /// The solution at `pose`, its tool tip `tool_tip` after `iterations`
    /// Newton steps, kept; and the room of its `J_f`, which the caller
    /// writes whole.
    fn solved(
        &mut self,
        pose: &Pose,
        tool_tip: &Vec3,
        iterations: usize,
    ) -> &mut FactoredTipJacobian;
}

impl SolutionRoom for SolutionJacobian {
    fn solved(
        &mut self,
        pose: &Pose,
        tool_tip: &Vec3,
        iterations: usize,
    ) -> &mut FactoredTipJacobian {
        self.pose = *pose;
        self.tool_tip = *tool_tip;
        self.iterations = iterations;
        &mut self.jacobian
    }
}

/// `h^T J_f` from the closure weights `y = K^T h` (33 values into `out`):
/// leg `i` adds `y_i` times its row `(n_i; -R^T n_i; 1)` at its base joint,
/// platform joint and length, and the tool columns are `h^T R`; `legs(i)`
/// is `(n_i, R^T n_i)`.
fn leg_rows<S: Storage<f64, U3, U3>>(
    y: &Vector6<f64>,
    rotation: &Matrix<f64, U3, U3, S>,
    legs: impl Fn(usize) -> (Vec3, Vec3),
    h: &Vec3,
    out: &mut [f64],
) {
    // A fixed-size view: the indices are constants once the loops unroll.
    let out: &mut [f64; N_PARAMS] = out
        .first_chunk_mut()
        .expect("a parameter row holds the 33 parameters");
    for i in 0..6 {
        let (n, n_platform) = legs(i);
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

/// `v = (d phi / dp) dp`: leg `i` changes by
/// `-n_i . dB_i + (R^T n_i) . dE_i - dl_i`; `legs(i)` is `(n_i, R^T n_i)`.
fn closure_change(legs: impl Fn(usize) -> (Vec3, Vec3), dp: &Params) -> Vector6<f64> {
    Vector6::from_fn(|i, _| {
        let (n, n_platform) = legs(i);
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
    })
}

/// The tool offset's part `dE_T` of `dp`.
fn tool_step(dp: &Params) -> Vec3 {
    Vec3::from(dp.fixed_rows::<3>(TOOL_OFFSET))
}

impl TipDerivatives {
    /// The derivatives of `geometry`'s tip at its forward-kinematics
    /// `solution`.
    pub fn new(geometry: &Geometry, solution: &ForwardSolution) -> Self {
        Self {
            tool: Self::tool_at(geometry, solution),
            solution: solution.clone(),
        }
    }

    /// The tool offset in the base frame at `solution`, `R E_T`.
    pub(crate) fn tool_at(geometry: &Geometry, solution: &ForwardSolution) -> Vec3 {
        solution.legs.rotation * geometry.tool
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

    /// New derivatives at the forward kinematics of `geometry` at `q` from
    /// `start` ([`TipDerivatives::forward`]).
    fn solved(
        geometry: &Geometry,
        q: &[f64; 6],
        start: &Pose,
        options: &ForwardOptions,
    ) -> Result<Self, KinematicsError> {
        let mut derivatives = Self::default();
        derivatives.forward(geometry, q, start, options)?;
        Ok(derivatives)
    }

    /// Forward kinematics of `geometry` at `q` from `start`
    /// ([`crate::forward()`]), in place, leaving these derivatives at its
    /// solution. Several contacts at once, in SIMD lanes:
    /// [`crate::forward_batch::forward_derivatives_batch`].
    pub fn forward(
        &mut self,
        geometry: &Geometry,
        q: &[f64; 6],
        start: &Pose,
        options: &ForwardOptions,
    ) -> Result<(), KinematicsError> {
        self.solution.pose = *start;
        forward_in_place(geometry, q, options, &mut self.solution)?;
        self.tool = Self::tool_at(geometry, &self.solution);
        Ok(())
    }

    /// The forward-kinematics solution these derivatives are taken at.
    pub fn solution(&self) -> &ForwardSolution {
        &self.solution
    }

    /// `y = K^T h = A^-T P^T h`, `P^T h = (h, R E_T x h)`: the weights of the
    /// closure rows in `h^T J_f`; also `h^T dT/dq = y^T`.
    pub fn closure_weights(&self, h: &Vec3) -> Vector6<f64> {
        let [y] = self.closure_weights_each(&[*h]);
        y
    }

    /// [`TipDerivatives::closure_weights`] of each of `K` directions,
    /// side by side ([`Lu6::solve_transpose_each`]: the bits of each
    /// alone).
    ///
    /// [`Lu6::solve_transpose_each`]: crate::lu6::Lu6::solve_transpose_each
    fn closure_weights_each<const K: usize>(&self, h: &[Vec3; K]) -> [Vector6<f64>; K] {
        let b = h.map(|h| {
            let m = self.tool.cross(&h);
            Vector6::new(h.x, h.y, h.z, m.x, m.y, m.z)
        });
        self.solution.factor.solve_transpose_each(&b)
    }

    /// [`TipDerivatives::closure_weights`] of the three base-frame axes.
    fn axes_closure_weights(&self) -> [Vector6<f64>; 3] {
        self.closure_weights_each(&std::array::from_fn(|axis| Vector3::ith(axis, 1.0)))
    }

    /// `h^T J_f`, written into `out` (33 values): leg `i` adds `y_i` times
    /// its row `(n_i; -R^T n_i; 1)` at its base joint, platform joint and
    /// length, and the tool columns are `h^T R`.
    pub fn params_row(&self, h: &Vec3, out: &mut [f64]) {
        let legs = &self.solution.legs;
        let platform = FactoredTipJacobian::platform_directions(&legs.rotation, &legs.direction);
        leg_rows(
            &self.closure_weights(h),
            &legs.rotation,
            |i| (legs.direction[i], platform[i]),
            h,
            out,
        );
    }

    /// `J_f dp` and the pose's first-order change along `dp`
    /// ([`DerivativeAlong`]): one LU solve.
    pub fn along(&self, dp: &Params) -> DerivativeAlong {
        let legs = &self.solution.legs;
        let platform = FactoredTipJacobian::platform_directions(&legs.rotation, &legs.direction);
        let v = closure_change(|i| (legs.direction[i], platform[i]), dp);
        let pose = -self.solution.factor.solve(&v);
        let (dt, w) = (
            Vec3::from(pose.fixed_rows::<3>(0)),
            Vec3::from(pose.fixed_rows::<3>(3)),
        );
        let tip = dt + w.cross(&self.tool) + legs.rotation * tool_step(dp);
        DerivativeAlong { pose, tip }
    }

    /// `J_f` in factored form at these derivatives' solution (three
    /// transposed solves).
    pub fn factored(&self) -> FactoredTipJacobian {
        let legs = &self.solution.legs;
        FactoredTipJacobian {
            weights: self.d_q().transpose(),
            rotation: legs.rotation,
            directions: legs.direction,
            platform_directions: FactoredTipJacobian::platform_directions(
                &legs.rotation,
                &legs.direction,
            ),
        }
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
        for (axis, y) in self.axes_closure_weights().iter().enumerate() {
            d_q.row_mut(axis).copy_from(&y.transpose());
        }
        d_q
    }

    /// The full `J_f` (3 x 33) and `dT/dq` (3 x 6): one row per base-frame
    /// axis `h`, both from its closure weights `y = K^T h` (one transposed
    /// solve per axis: [`TipDerivatives::params_row`] and
    /// [`TipDerivatives::d_q`] share it).
    pub fn jacobians(&self) -> TipJacobians {
        let legs = &self.solution.legs;
        let mut d_params = SMatrix::<f64, 3, N_PARAMS>::zeros();
        let mut d_q = Matrix3x6::zeros();
        let mut row = [0.0; N_PARAMS];
        let platform = FactoredTipJacobian::platform_directions(&legs.rotation, &legs.direction);
        for (axis, y) in self.axes_closure_weights().iter().enumerate() {
            let h = Vector3::ith(axis, 1.0);
            let legs_of = |i: usize| (legs.direction[i], platform[i]);
            leg_rows(y, &legs.rotation, legs_of, &h, &mut row);
            d_params.row_mut(axis).copy_from_slice(&row);
            d_q.row_mut(axis).copy_from(&y.transpose());
        }
        TipJacobians { d_params, d_q }
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
