//! The instrument calibration as the solver sees it: a global block only
//! (no group, no point), every measured row a global observation, and the
//! prior on the global block.

use std::ops::Range;

use nalgebra::{DVector, Dyn, OMatrix, SVector, U1};
use parcal_solver::{GaussianPrior, GlobalObservations, Linearization, Problem};

use crate::CalibrateError;
use crate::instruments::model::InstrumentModel;
use crate::instruments::rows::InstrumentRows;

/// The least-squares problem of an instrument calibration.
pub struct InstrumentProblem<'a> {
    /// The global block's meaning.
    pub model: InstrumentModel,
    /// The measured rows.
    pub rows: InstrumentRows<'a>,
    /// The prior on the global block.
    pub prior: Option<GaussianPrior<Dyn>>,
}

/// No group and no point: the three block sizes are placeholders.
impl Problem<1, 0, 1> for InstrumentProblem<'_> {
    type PointCache = ();
    type Workspace = ();
    type Anchor = ();
    type Error = CalibrateError;
    type Jacobian = OMatrix<f64, U1, Dyn>;
    type Global = ();

    fn global_size(&self) -> usize {
        self.model.layout.size()
    }

    fn prepare_global(&self, _global: &DVector<f64>) {}

    fn n_groups(&self) -> usize {
        0
    }

    fn group_points(&self, _k: usize) -> Range<usize> {
        0..0
    }

    fn initial_cache(&self, _i: usize) {}

    /// There are no points: never called.
    fn linearize(
        &self,
        _i: usize,
        _global: &(),
        _group: &SVector<f64, 1>,
        _point: &SVector<f64, 0>,
        _cache: &mut (),
        _out: &mut Linearization<1, 0, 1, Self::Jacobian>,
    ) -> Result<(), CalibrateError> {
        Ok(())
    }

    /// Every pose's six rows and every point's three
    /// ([`InstrumentRows::evaluate`]).
    fn global_observations(
        &self,
        global: &DVector<f64>,
        out: &mut GlobalObservations,
    ) -> Result<(), CalibrateError> {
        let values = self.model.values(global);
        self.rows.evaluate(&self.model, &values, out)
    }

    fn global_prior(&self) -> Option<&GaussianPrior<Dyn>> {
        self.prior.as_ref()
    }
}
