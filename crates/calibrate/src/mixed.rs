//! Ball touches with instrument measurements in one calibration: the
//! poses and points of poses.csv and points.csv become global observations
//! of the ball-touch problem ([`crate::problem::CalibrationProblem`]),
//! beside the calibrated distances.
//!
//! ```text
//! g = [ p (33) | C_a (3) … | s (6) | F_1 (6) … | B (6) | B_k (3) | o_k (6) … ]
//!       touches  tied balls  the instrument groups (crate::instruments::observations::groups)
//! ```
//!
//! The touches and the instruments see the same kinematic parameters in
//! the same canonical frames: the balls' centres are in the canonical base
//! frame, an instrument sees that frame through its session's frame `F_k`,
//! poses see the canonical platform frame through the body frame `B`. The
//! gauge is therefore the canonical frames' as for touches alone, and the
//! tool, which touches observe, is determined by the data even with poses.
//! Each pose's six rows and each point's three are weighed once at the
//! initial estimate ([`InstrumentRows::whiten`]), as the contacts are, and
//! the instrument groups have the priors of an instrument calibration
//! (`instruments::observations::group_priors`).
//!
//! The touches and the instrument rows read the same actuators: leg `i` is
//! `l_i + s_i q_i` long for both, and with unknown scales (machine.json's
//! `actuator.scale_sigma`) both see the one group `s` of the layout.

use nalgebra::{DMatrix, DVector};
use parcal_dataset::Dataset;
use parcal_kinematics::Geometry;
use parcal_solver::GlobalObservations;

use crate::CalibrateError;
use crate::instruments::model::InstrumentModel;
use crate::instruments::observations::{model_and_rows, residuals};
use crate::instruments::result::InstrumentResult;
use crate::instruments::rows::InstrumentRows;
use crate::layout::ParameterLayout;

/// The poses and points of a calibration with ball touches.
pub struct InstrumentObservations<'a> {
    /// The global block's meaning for the instrument rows (the touch
    /// problem's layout).
    pub model: InstrumentModel,
    /// The measured rows and their weights.
    pub rows: InstrumentRows<'a>,
    /// The initial global block, at which the rows are weighed.
    pub initial: DVector<f64>,
}

impl<'a> InstrumentObservations<'a> {
    /// The poses and points of `dataset` on the global block `layout`,
    /// weighed at the initial block `initial`; `None` without poses and
    /// points. `canonical`: the design in its canonical frames.
    pub fn new(
        dataset: &'a Dataset,
        canonical: &Geometry,
        layout: &ParameterLayout,
        initial: &DVector<f64>,
    ) -> Result<Option<Self>, CalibrateError> {
        if dataset.tracker.is_empty() {
            return Ok(None);
        }
        let (model, rows) = model_and_rows(dataset, canonical, layout.clone(), initial)?;
        Ok(Some(Self {
            model,
            rows,
            initial: initial.clone(),
        }))
    }

    /// The whitened rows at the global block `global` appended to `out`
    /// (below its rows; same columns).
    pub fn append(
        &self,
        global: &DVector<f64>,
        out: &mut GlobalObservations,
    ) -> Result<(), CalibrateError> {
        let mut rows = GlobalObservations::zeros(0, 0);
        self.rows
            .evaluate(&self.model, &self.model.values(global), &mut rows)?;
        let (above, n) = (out.residual.len(), global.len());
        let total = above + rows.residual.len();
        let mut residual = DVector::zeros(total);
        residual.rows_mut(0, above).copy_from(&out.residual);
        residual
            .rows_mut(above, rows.residual.len())
            .copy_from(&rows.residual);
        let mut jacobian = DMatrix::zeros(total, n);
        jacobian.rows_mut(0, above).copy_from(&out.jacobian);
        jacobian
            .rows_mut(above, rows.residual.len())
            .copy_from(&rows.jacobian);
        *out = GlobalObservations { residual, jacobian };
        Ok(())
    }

    /// The poses and points of a solution at the global block `global`.
    pub fn result(&self, global: &DVector<f64>) -> Result<InstrumentResult, CalibrateError> {
        let values = self.model.values(global);
        let (leg_residuals, point_residuals) = residuals(&self.rows, &self.model, &values)?;
        Ok(InstrumentResult {
            model: self.model.clone(),
            initial: self.initial.clone(),
            leg_residuals,
            point_residuals,
            information: None,
        })
    }
}
