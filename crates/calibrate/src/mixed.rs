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
use parcal_kinematics::{Geometry, Vec3};
use parcal_solver::GlobalObservations;

use crate::CalibrateError;
use crate::instruments::model::InstrumentModel;
use crate::instruments::observations::{model_and_rows, residuals, rms};
use crate::instruments::rows::InstrumentRows;
use crate::layout::ParameterLayout;

/// The poses and points of a calibration with ball touches.
pub struct InstrumentObservations<'a> {
    /// The global block's meaning for the instrument rows (the touch
    /// problem's layout).
    pub model: InstrumentModel,
    /// The measured rows and their weights.
    pub rows: InstrumentRows<'a>,
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
        Ok(Some(Self { model, rows }))
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

    /// The instrument part of a solution at the global block `global`, with
    /// the global covariance `covariance` of a converged run.
    pub fn result(
        &self,
        global: &DVector<f64>,
        covariance: Option<&DMatrix<f64>>,
    ) -> Result<InstrumentResult, CalibrateError> {
        let values = self.model.values(global);
        let (leg_residuals, point_residuals) = residuals(&self.rows, &self.model, &values)?;
        Ok(InstrumentResult {
            model: self.model.clone(),
            global: global.clone(),
            covariance: covariance.cloned(),
            leg_residuals,
            point_residuals,
        })
    }
}

/// The instrument part of a calibration with ball touches.
#[derive(Debug, Clone)]
pub struct InstrumentResult {
    /// The global block's meaning.
    pub model: InstrumentModel,
    /// The identified global block (kinematic parameters, tied centres,
    /// instrument groups).
    pub global: DVector<f64>,
    /// Its covariance, when the run converged.
    pub covariance: Option<DMatrix<f64>>,
    /// Each pose's leg-length residuals `|T E_i − B_i| − L_i` (mm).
    pub leg_residuals: Vec<[f64; 6]>,
    /// Each point's residual `F(T) − P` (mm).
    pub point_residuals: Vec<Vec3>,
}

impl InstrumentResult {
    /// RMS of the poses' leg-length residuals (mm), or `None` without
    /// poses.
    pub fn leg_rms(&self) -> Option<f64> {
        rms(self.leg_residuals.iter().flatten().copied())
    }

    /// RMS of the points' residual coordinates (mm), or `None` without
    /// points.
    pub fn point_rms(&self) -> Option<f64> {
        rms(self.point_residuals.iter().flat_map(|p| p.iter().copied()))
    }

    /// Marginal sigmas of the global block (zero without a covariance).
    pub fn sigmas(&self) -> DVector<f64> {
        self.covariance.as_ref().map_or_else(
            || DVector::zeros(self.global.len()),
            |c| c.diagonal().map(f64::sqrt),
        )
    }

    /// The instrument parameters with their values and sigmas, named by
    /// `names` (the whole global block's,
    /// [`crate::CalibrationRun::names`]); the kinematic parameters and the
    /// ball centres are reported with the touches'.
    pub fn parameters(&self, names: &[String]) -> Vec<(String, f64, f64)> {
        let sigmas = self.sigmas();
        (self.first_instrument_column()..self.global.len())
            .map(|k| (names[k].clone(), self.global[k], sigmas[k]))
            .collect()
    }

    /// The first column after the kinematic parameters and the tied
    /// centres.
    fn first_instrument_column(&self) -> usize {
        self.model
            .layout
            .groups()
            .iter()
            .find(|(group, _)| {
                !matches!(
                    group,
                    crate::layout::ParameterGroup::Kinematic
                        | crate::layout::ParameterGroup::BallCentre { .. }
                        | crate::layout::ParameterGroup::BallRadius { .. }
                )
            })
            .map_or(self.global.len(), |(_, range)| range.start)
    }
}
