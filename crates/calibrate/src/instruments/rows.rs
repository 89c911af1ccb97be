//! Every row of poses.csv and points.csv as residual rows on the global
//! block: the pose block (6 rows) and the point block (3 rows) of
//! `parcal_observe`, their Jacobians placed in the layout's columns, and
//! whitened by the covariance of the row formed once at the initial
//! estimate (as the ball touches' weights are).

use nalgebra::{DMatrix, Matrix3, Matrix6, SMatrix};
use parcal_dataset::{Repeatability, Tracker};
use parcal_kinematics::params::{BASE_INDEX, PLATFORM_INDEX, leg_index};
use parcal_kinematics::{
    ForwardOptions, N_PARAMS, Pose, TipJacobians, Vec3, forward, tip_jacobians,
};
use parcal_observe::{PointBlock, PoseBlock, PoseJacobians, point_covariance, pose_covariance};
use parcal_solver::GlobalObservations;

use crate::CalibrateError;
use crate::instruments::InstrumentTable;
use crate::instruments::model::{InstrumentModel, ModelValues};
use crate::layout::ParameterGroup;

/// The measured rows and their whitening.
#[derive(Debug, Clone)]
pub struct InstrumentRows<'a> {
    /// The measurements.
    pub tracker: &'a Tracker,
    /// poses.csv's `M_j`.
    pub measured: Vec<Pose>,
    /// The whitening `L⁻¹` of each pose's six rows.
    pub pose_whitening: Vec<Matrix6<f64>>,
    /// The whitening `L⁻¹` of each point's three rows.
    pub point_whitening: Vec<Matrix3<f64>>,
    /// The variance of every row (mm², the diagonal of each row's
    /// covariance): each pose's six, then each point's three.
    pub variances: Vec<f64>,
    /// Where each point's forward kinematics starts.
    pub point_starts: Vec<Pose>,
    /// Forward kinematics' tolerance and iteration limit.
    pub forward: ForwardOptions,
}

/// A point's block with the tool tip's derivatives.
pub struct PointRow {
    /// `c = F(T) − P` and its derivatives.
    pub block: parcal_observe::PointJacobians,
    /// `∂T/∂p` and `∂T/∂L`.
    pub tip: TipJacobians,
}

impl<'a> InstrumentRows<'a> {
    /// The rows of `tracker`, not yet weighed ([`InstrumentRows::whiten`]),
    /// each point's forward kinematics starting at `point_starts`.
    pub fn new(tracker: &'a Tracker, point_starts: Vec<Pose>, forward: ForwardOptions) -> Self {
        Self {
            tracker,
            measured: crate::instruments::start::measured_poses(tracker),
            pose_whitening: Vec::new(),
            point_whitening: Vec::new(),
            variances: Vec::new(),
            point_starts,
            forward,
        }
    }

    /// Number of residual rows: 6 per pose, 3 per point.
    pub fn len(&self) -> usize {
        6 * self.tracker.poses.len() + 3 * self.tracker.points.len()
    }

    /// Whether there is no row.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    fn session_of_pose(&self, j: usize) -> usize {
        self.tracker.poses.session[j] as usize
    }

    fn session_of_point(&self, j: usize) -> usize {
        self.tracker.points.session[j] as usize
    }

    /// Pose `j`'s raw block at `values`.
    pub fn pose(
        &self,
        model: &InstrumentModel,
        values: &ModelValues,
        j: usize,
    ) -> Result<PoseJacobians, CalibrateError> {
        let session = self.session_of_pose(j);
        let block = PoseBlock {
            measured: &self.measured[j],
            tracker_reference: &model.tracker_references[session],
            tracker: values.trackers[session],
            body_reference: &model.body_reference,
            body: values.bodies[session],
        };
        let lengths = values.lengths(session, &self.tracker.poses.q[j]);
        block
            .evaluate(&values.geometry, &lengths)
            .map_err(|e| CalibrateError::InstrumentRow {
                table: InstrumentTable::Poses,
                row: j,
                reason: e.to_string(),
            })
    }

    /// Point `j`'s raw block at `values`, by forward kinematics from its
    /// start.
    pub fn point(
        &self,
        model: &InstrumentModel,
        values: &ModelValues,
        j: usize,
    ) -> Result<PointRow, CalibrateError> {
        let session = self.session_of_point(j);
        let extensions = values.extensions(session, &self.tracker.points.q[j]);
        let solution = forward(
            &values.geometry,
            &extensions,
            &self.point_starts[j],
            &self.forward,
        )
        .map_err(|e| CalibrateError::InstrumentRow {
            table: InstrumentTable::Points,
            row: j,
            reason: format!("forward kinematics failed: {e}"),
        })?;
        let tip = values.geometry.tool_tip(&solution.pose);
        let measured = Vec3::from(self.tracker.points.position[j]);
        let block = PointBlock {
            measured: &measured,
            tracker_reference: &model.tracker_references[session],
            tracker: values.trackers[session],
        }
        .evaluate(&tip);
        Ok(PointRow {
            block,
            tip: tip_jacobians(&values.geometry, &solution),
        })
    }

    /// Forms the rows' whitening at `values` from the repeatabilities
    /// (actuators in their unit, times the scale; the instrument's
    /// position and orientation sigmas).
    pub fn whiten(
        &mut self,
        model: &InstrumentModel,
        values: &ModelValues,
        repeatability: &Repeatability,
    ) -> Result<(), CalibrateError> {
        let actuator: [f64; 6] = std::array::from_fn(|i| repeatability.actuator * values.scales[i]);
        let position = repeatability.position.unwrap_or(0.0);
        let orientation = repeatability.orientation.unwrap_or(0.0);
        let refuse = |table, row| CalibrateError::InstrumentRow {
            table,
            row,
            reason: "its covariance is not positive definite".into(),
        };
        let mut variances = Vec::with_capacity(self.len());
        self.pose_whitening = (0..self.tracker.poses.len())
            .map(|j| {
                let block = self.pose(model, values, j)?;
                let w = pose_covariance(&block.d_measurement, &actuator, position, orientation);
                variances.extend(w.diagonal().iter());
                inverse_factor(&w).ok_or_else(|| refuse(InstrumentTable::Poses, j))
            })
            .collect::<Result<_, _>>()?;
        self.point_whitening = (0..self.tracker.points.len())
            .map(|j| {
                let row = self.point(model, values, j)?;
                let d_lengths = row.block.d_tip * row.tip.d_q;
                let w = point_covariance(&d_lengths, &actuator, position);
                variances.extend(w.diagonal().iter());
                inverse_factor(&w).ok_or_else(|| refuse(InstrumentTable::Points, j))
            })
            .collect::<Result<_, _>>()?;
        self.variances = variances;
        Ok(())
    }

    /// The whitened rows and their Jacobian on the global block at
    /// `values`: every pose's six rows, then every point's three.
    pub fn evaluate(
        &self,
        model: &InstrumentModel,
        values: &ModelValues,
        out: &mut GlobalObservations,
    ) -> Result<(), CalibrateError> {
        self.fill(model, values, true, out)
    }

    /// The rows as [`InstrumentRows::evaluate`] gives them, not whitened
    /// (mm, per unit of each parameter).
    pub fn raw(
        &self,
        model: &InstrumentModel,
        values: &ModelValues,
    ) -> Result<GlobalObservations, CalibrateError> {
        let mut out = GlobalObservations::zeros(0, 0);
        self.fill(model, values, false, &mut out)?;
        Ok(out)
    }

    fn fill(
        &self,
        model: &InstrumentModel,
        values: &ModelValues,
        whiten: bool,
        out: &mut GlobalObservations,
    ) -> Result<(), CalibrateError> {
        let g = model.layout.size();
        *out = GlobalObservations::zeros(self.len(), g);
        let poses = self.tracker.poses.len();
        for j in 0..poses {
            let block = self.pose(model, values, j)?;
            let mut raw = DMatrix::zeros(6, g);
            self.pose_columns(model, j, &block, &mut raw);
            let w = if whiten {
                self.pose_whitening[j]
            } else {
                Matrix6::identity()
            };
            out.residual
                .rows_mut(6 * j, 6)
                .copy_from(&(w * block.residual));
            out.jacobian.rows_mut(6 * j, 6).copy_from(&(w * raw));
        }
        for j in 0..self.tracker.points.len() {
            let row = self.point(model, values, j)?;
            let mut raw = DMatrix::zeros(3, g);
            self.point_columns(model, j, &row, &mut raw);
            let w = if whiten {
                self.point_whitening[j]
            } else {
                Matrix3::identity()
            };
            let first = 6 * poses + 3 * j;
            out.residual
                .rows_mut(first, 3)
                .copy_from(&(w * row.block.residual));
            out.jacobian.rows_mut(first, 3).copy_from(&(w * raw));
        }
        Ok(())
    }

    /// Pose `j`'s raw Jacobian in the layout's columns (6 x G).
    fn pose_columns(
        &self,
        model: &InstrumentModel,
        j: usize,
        block: &PoseJacobians,
        out: &mut DMatrix<f64>,
    ) {
        let layout = &model.layout;
        let session = self.session_of_pose(j);
        let q = &self.tracker.poses.q[j];
        for i in 0..6 {
            for c in 0..3 {
                if let Some(k) = BASE_INDEX[i][c] {
                    out[(i, k)] = block.d_base[i][c];
                }
                if let Some(k) = PLATFORM_INDEX[i][c] {
                    out[(i, k)] = block.d_platform[i][c];
                }
            }
            out[(i, leg_index(i))] = -1.0;
        }
        length_columns(model, session, q, &SMatrix::<f64, 6, 6>::identity(), out);
        if let Some(r) = layout.range(ParameterGroup::TrackerFrame { session }) {
            out.view_mut((0, r.start), (6, 6))
                .copy_from(&block.d_tracker);
        }
        if let Some(r) = layout.range(ParameterGroup::BodyFrame) {
            out.view_mut((0, r.start), (6, 6)).copy_from(&block.d_body);
        }
        if let Some(r) = layout.range(ParameterGroup::BodyOrigin { session }) {
            out.view_mut((0, r.start), (6, 3))
                .copy_from(&block.d_body.fixed_columns::<3>(3));
        }
        if let Some(r) = layout.range(ParameterGroup::BodyRotation { session }) {
            out.view_mut((0, r.start), (6, 3))
                .copy_from(&block.d_body.fixed_columns::<3>(0));
        }
    }

    /// Point `j`'s raw Jacobian in the layout's columns (3 x G).
    fn point_columns(
        &self,
        model: &InstrumentModel,
        j: usize,
        row: &PointRow,
        out: &mut DMatrix<f64>,
    ) {
        let session = self.session_of_point(j);
        let d_params = row.block.d_tip * row.tip.d_params;
        out.view_mut((0, 0), (3, N_PARAMS)).copy_from(&d_params);
        // ∂c/∂L: the tip's J_q (L = l + o + s q enters as q = o + s q).
        let d_lengths = -(row.block.d_tip * row.tip.d_q);
        length_columns(model, session, &self.tracker.points.q[j], &d_lengths, out);
        if let Some(r) = model.layout.range(ParameterGroup::TrackerFrame { session }) {
            out.view_mut((0, r.start), (3, 6))
                .copy_from(&row.block.d_tracker);
        }
    }
}

/// The columns of the scales and the session's leg offsets, given
/// `−∂c/∂L` (`R` x 6): `∂c/∂o_i = ∂c/∂L_i`, `∂c/∂s_i = q_i ∂c/∂L_i`.
fn length_columns<const R: usize>(
    model: &InstrumentModel,
    session: usize,
    q: &[f64; 6],
    minus_d_lengths: &SMatrix<f64, R, 6>,
    out: &mut DMatrix<f64>,
) {
    let layout = &model.layout;
    for (i, &qi) in q.iter().enumerate() {
        let column = -minus_d_lengths.column(i);
        if let Some(r) = layout.range(ParameterGroup::ActuatorScales) {
            out.view_mut((0, r.start + i), (R, 1))
                .copy_from(&(column * qi));
        }
        if let Some(r) = layout.range(ParameterGroup::LegOffsets { session }) {
            out.view_mut((0, r.start + i), (R, 1)).copy_from(&column);
        }
    }
}

/// `L⁻¹` of `W = L Lᵀ`, if `W` is positive definite.
fn inverse_factor<const N: usize>(w: &SMatrix<f64, N, N>) -> Option<SMatrix<f64, N, N>> {
    if !w.iter().all(|v| v.is_finite()) {
        return None;
    }
    let factor = w.cholesky()?.unpack();
    factor.solve_lower_triangular(&SMatrix::identity())
}
