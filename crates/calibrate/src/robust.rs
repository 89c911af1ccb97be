//! A robust loss on the observations ([`crate::CalibrationOptions::loss`]):
//! Huber's or Cauchy's instead of least squares, solved by iteratively
//! reweighted least squares inside the solver's iteration
//! ([`parcal_solver::Loss`]: at every iterate each observation's whitened
//! rows are scaled by `√w(u)`, `u` its scaled residual there).
//!
//! **Observations.** The loss acts on whole observations, `u = |e| / √d`
//! with `e` its whitened rows and `d` its degrees of freedom: a contact is
//! one (`d = 1`: the radius observation has one row, and the coordinate
//! observation's two angles absorb two of its three rows, leaving the
//! distance normal to the ball, [`parcal_solver::point_degrees_of_freedom`]);
//! a distance has one row, a pose six, a point three (`d` = its rows, so
//! that `u` is their RMS, about 1 at the noise level whatever their
//! number). The priors are never down-weighted.
//!
//! **Checks.** The covariance, the global test and the reliability numbers
//! (redundancy numbers, normalised residuals, minimal detectable biases,
//! variance components) are those of the final reweighted problem: the
//! rows scaled by their weights at the solution. With Huber's loss the
//! weighted sum of squares of clean Gaussian data is below least
//! squares' (`E[w(u) u²] = 2Φ(k) − 1`, 0.82 at `k` = 1.345, for one
//! degree of freedom), so the global test is conservative there; a gross
//! error still adds `k u` to it. Cauchy's adds at most `k²`.
//!
//! **Blunders.** An observation whose final weight is under
//! [`DOWN_WEIGHTED`] (`u > 10 k` for Huber, `u > 3 k` for Cauchy: beyond
//! 13 and 7 standard deviations at the default thresholds, which Gaussian
//! noise does not reach) is listed as down-weighted
//! ([`down_weighted`]), with its place in the dataset, in calibration.json
//! and the verdict's reasons. A robust loss replaces data snooping: the
//! normalised residuals of the reweighted problem no longer show a
//! down-weighted blunder, so the snooping test is not part of the verdict
//! and [`crate::snooping`] refuses a robust loss; instead a run that
//! down-weights more observations than snooping would remove
//! ([`crate::hypothesis::MAX_REMOVALS`]) is rejected, its model rather than a
//! few blunders being wrong.

use parcal_solver::{HUBER_K, Loss};

use crate::hypothesis::MAX_REMOVALS;
use crate::observation::ObservationId;

/// The loss a calibration with `loss` starts with, if not `loss` itself:
/// Huber's (at [`HUBER_K`]) for Cauchy's, whose `ψ` redescends and whose
/// cost has local minima: from the design, where every residual is large
/// and every weight small, the iteration can settle where a blunder fits
/// and its neighbours do not. Huber's cost is convex in the residuals, and
/// its estimate, solved to [`START_TOLERANCE`], is the start of Cauchy's
/// (the usual robust start of a redescending M-estimator).
pub fn start(loss: Loss) -> Option<Loss> {
    matches!(loss, Loss::Cauchy { .. }).then_some(Loss::Huber { k: HUBER_K })
}

/// The step tolerance of the Huber start of a redescending loss
/// ([`start`]): a start, not a result.
pub const START_TOLERANCE: f64 = 1e-6;

/// The final weight under which an observation is listed as
/// down-weighted.
pub const DOWN_WEIGHTED: f64 = 0.1;

/// An observation a robust loss down-weighted.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DownWeighted {
    /// The observation.
    pub observation: ObservationId,
    /// Its final weight `w(u)`.
    pub weight: f64,
    /// Its scaled residual `u = |e| / √d` at the solution (its unweighted
    /// whitened rows), in units of its standard deviation.
    pub residual: f64,
}

/// `observation` as down-weighted, if its final weight `weight` is under
/// [`DOWN_WEIGHTED`]: its whitened rows weighted by `√w` are `weighted`,
/// and it has `dof` degrees of freedom (a contact's
/// [`parcal_solver::point_degrees_of_freedom`], a global observation's rows), whence `u`
/// is recovered. The checks gather them as the redundancy pass hands over
/// the observations: the contacts in the solver's order, then the global
/// observations.
pub fn down_weighted(
    observation: ObservationId,
    weight: f64,
    weighted: &[f64],
    dof: usize,
) -> Option<DownWeighted> {
    (weight < DOWN_WEIGHTED).then(|| {
        let norm2: f64 = weighted.iter().map(|v| v * v).sum();
        DownWeighted {
            observation,
            weight,
            residual: (norm2 / (weight * dof as f64)).sqrt(),
        }
    })
}

/// Whether a robust run down-weighted more observations than data snooping
/// would remove ([`MAX_REMOVALS`]): its model, not a few blunders, is
/// wrong.
pub fn too_many(down_weighted: &[DownWeighted]) -> bool {
    down_weighted.len() > MAX_REMOVALS
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_down_weighted_observation_keeps_its_unweighted_residual() {
        // Rows e = (3, 4) weighted by √w: u = |e| / √2 = 5 / √2.
        let w: f64 = 0.05;
        let weighted = [3.0 * w.sqrt(), 4.0 * w.sqrt()];
        let listed = down_weighted(ObservationId::Point(4), w, &weighted, 2).unwrap();
        assert_eq!(listed.observation, ObservationId::Point(4));
        assert_eq!(listed.weight, w);
        assert!((listed.residual - 5.0 / 2f64.sqrt()).abs() < 1e-12);
        assert_eq!(
            down_weighted(ObservationId::Contact(0), DOWN_WEIGHTED, &[1.0], 1),
            None
        );
    }
}
