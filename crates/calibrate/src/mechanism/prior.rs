//! The prior on the global block (paper eq. 7): each parameter's mean and
//! sigma ([`ParameterPrior`]), correlated when the data give a correlation
//! matrix `R` ([`MechanismData::prior_correlation`]), and the trigger
//! height's, independent of them:
//!
//! ```text
//! Σ_prior = D R D,     D = diag(σ_k),     Λ = Σ_prior⁻¹,
//! ```
//!
//! over the unknowns that have a prior (the trackers' frames, which follow
//! the trigger height, and the body frame have none; the trackers'
//! actuators' offsets do); an unknown without one has no row
//! or column in `Σ_prior` (zero there) and no information. A correlated
//! prior states what tolerances on the parts imply for parameters that
//! share them: the hexapod's joint coordinates after its canonical frame
//! is fixed (the propagated prior), a delta's rods cut as a matched set
//! (their lengths uncertain together, their differences far less;
//! [`MechanismData::with_matched_group`]).

use nalgebra::{DMatrix, DVector, Dyn};
use parcal_solver::GaussianPrior;

use super::data::{MechanismData, ParameterPrior};
use super::error::MechanismCalibrationError;
use super::tied::TiedBalls;

/// The global block's priors: the parameters', then the trigger height's
/// when it is an unknown (there are probe heights), then each tracker's
/// frame correction's six, none, about the correction's start 0, then
/// each re-homed tracker's actuator offsets', about zero with its
/// offsets' sigmas if any, then with tracker poses the body frame's
/// correction's six, none, then each tracker's body rotation (three) and
/// origin shift (three), where the body was turned or moved, about zero
/// with its sigma if any.
pub(crate) fn global_priors(data: &MechanismData) -> Vec<ParameterPrior> {
    let mut priors = data.priors.clone();
    if data.has_trigger_height() {
        priors.push(data.trigger_height);
    }
    let trackers = &data.observations.trackers;
    let frames = FRAME_UNKNOWNS * trackers.len();
    let about_zero = |sigma| ParameterPrior { mean: 0.0, sigma };
    priors.extend(std::iter::repeat_n(about_zero(None), frames));
    let actuators = data.mechanism.actuators().len();
    for tracker in trackers.iter().filter(|tracker| tracker.rehomed) {
        priors.extend((0..actuators).map(|i| about_zero(tracker.offset_sigma(i))));
    }
    if !data.observations.tracker_poses.is_empty() {
        priors.extend(std::iter::repeat_n(about_zero(None), FRAME_UNKNOWNS));
    }
    for tracker in trackers {
        if tracker.body_turned {
            priors.extend([about_zero(tracker.body_rotation_sigma); 3]);
        }
        if tracker.body_moved {
            priors.extend([about_zero(tracker.body_origin_sigma); 3]);
        }
    }
    priors
}

/// The unknowns of a frame correction (a tracker's, the body's): `ω` and
/// `τ`.
pub(crate) const FRAME_UNKNOWNS: usize = 6;

/// `Σ_prior` over the global block (module doc): `σ_j σ_k R_jk` where both
/// have a prior (`R` the identity without a correlation), zero elsewhere.
pub fn prior_covariance(data: &MechanismData) -> DMatrix<f64> {
    let priors = global_priors(data);
    let n = data.priors.len();
    let correlation = |j: usize, k: usize| match &data.prior_correlation {
        Some(r) if j < n && k < n => r[(j, k)],
        _ if j == k => 1.0,
        _ => 0.0,
    };
    DMatrix::from_fn(priors.len(), priors.len(), |j, k| {
        match (priors[j].sigma, priors[k].sigma) {
            (Some(a), Some(b)) => a * b * correlation(j, k),
            _ => 0.0,
        }
    })
}

/// `Λ = Σ_prior⁻¹` over the unknowns with a prior, zero elsewhere (module
/// doc); `None` when no unknown has one or `Σ_prior` is not positive
/// definite there (refused by
/// [`check_correlation`](super::correlation::check_correlation)
/// beforehand).
pub(crate) fn prior_information(data: &MechanismData) -> Option<DMatrix<f64>> {
    let covariance = prior_covariance(data);
    let with: Vec<usize> = global_priors(data)
        .iter()
        .enumerate()
        .filter_map(|(k, p)| p.sigma.map(|_| k))
        .collect();
    if with.is_empty() {
        return None;
    }
    let inverse = covariance
        .select_rows(&with)
        .select_columns(&with)
        .cholesky()?
        .inverse();
    let g = covariance.nrows();
    let mut information = DMatrix::zeros(g, g);
    for (a, &j) in with.iter().enumerate() {
        for (b, &k) in with.iter().enumerate() {
            information[(j, k)] = inverse[(a, b)];
        }
    }
    Some(information)
}

impl MechanismData {
    /// These data with the parts of `group` made as a matched set: each
    /// part `l_i = L + d_i`, the set's common value `L` as uncertain as the
    /// parts' priors say and each part within `sigma` of it (`d_i ~ N(0,
    /// sigma²)`), so that two parts' priors have the covariance `σ_i σ_j −
    /// sigma²`, the correlation `1 − sigma² / (σ_i σ_j)`, and their
    /// difference the sigma `√2 sigma`. An error names a group the
    /// mechanism does not have, a part without a prior, or a `sigma` that
    /// is not positive or exceeds a part's prior sigma.
    pub fn with_matched_group(
        mut self,
        group: &str,
        sigma: f64,
    ) -> Result<Self, MechanismCalibrationError> {
        let invalid = |reason: String| {
            Err(MechanismCalibrationError::InvalidData {
                what: format!("matched group {group:?}"),
                reason,
            })
        };
        let parts: Vec<usize> = (0..self.priors.len())
            .filter(|&k| self.mechanism.parameters()[k].group == group)
            .collect();
        if parts.is_empty() {
            return invalid(format!("the {} has no such group", self.mechanism.name()));
        }
        if !(sigma.is_finite() && sigma > 0.0) {
            return invalid(format!("its sigma {sigma} is not finite and positive"));
        }
        let mut part_sigmas = Vec::with_capacity(parts.len());
        for &k in &parts {
            let name = &self.mechanism.parameters()[k].name;
            match self.priors[k].sigma {
                None => return invalid(format!("parameter {name} has no prior")),
                Some(s) if sigma > s => {
                    return invalid(format!(
                        "its sigma {sigma} exceeds the prior sigma {s} of parameter {name}"
                    ));
                }
                Some(s) => part_sigmas.push(s),
            }
        }
        let n = self.priors.len();
        let mut correlation = self
            .prior_correlation
            .take()
            .unwrap_or_else(|| DMatrix::identity(n, n));
        for (a, &j) in parts.iter().enumerate() {
            for (b, &k) in parts.iter().enumerate() {
                if j != k {
                    correlation[(j, k)] = 1.0 - sigma * sigma / (part_sigmas[a] * part_sigmas[b]);
                }
            }
        }
        Ok(self.with_prior_correlation(correlation))
    }
}

/// The mechanism's part of the global block's priors' means.
pub(super) fn prior_means(data: &MechanismData) -> DVector<f64> {
    let priors = global_priors(data);
    DVector::from_iterator(priors.len(), priors.iter().map(|p| p.mean))
}

/// The prior on the global block (module doc): the mechanism's part's
/// ([`prior_information`]), and each tied ball's centre prior and its
/// radius's calibration sigma, independent of it and of each other;
/// `None` when no unknown has one.
pub(super) fn global_prior(data: &MechanismData, tied: &TiedBalls) -> Option<GaussianPrior<Dyn>> {
    let m = global_priors(data).len();
    let g = m + tied.unknowns();
    let mut mean = prior_means(data).resize_vertically(g, 0.0);
    let mut information = DMatrix::zeros(g, g);
    let mechanism = prior_information(data);
    if let Some(mechanism) = &mechanism {
        information.view_mut((0, 0), (m, m)).copy_from(mechanism);
    }
    let mut any = mechanism.is_some();
    for (b, columns) in tied.iter() {
        let column = columns.start;
        let ball = &data.observations.balls[b];
        if let Some(prior) = ball.centre_prior {
            for k in 0..3 {
                mean[column + k] = prior.centre[k];
                information[(column + k, column + k)] = prior.sigma.powi(-2);
            }
            any = true;
        }
        if let Some(sigma) = ball.radius_sigma {
            mean[column + 3] = ball.radius;
            information[(column + 3, column + 3)] = sigma.powi(-2);
            any = true;
        }
    }
    any.then(|| GaussianPrior::new(mean, information))
}

#[cfg(test)]
mod tests {
    use std::sync::Arc;

    use nalgebra::DMatrix;
    use parcal_kinematics::delta::LinearDelta;
    use parcal_kinematics::mechanism::{Mechanism, design};

    use super::*;
    use crate::mechanism::data::Observations;
    use parcal_observe::mechanism::ProbeHeight;

    /// A typical delta probed once, its three diagonal rods a matched set:
    /// correlation `rho` between each pair.
    fn matched_rods(rho: f64) -> MechanismData {
        let delta = LinearDelta::typical();
        let n = delta.parameters().len();
        let rods: Vec<usize> = (0..n)
            .filter(|&k| delta.parameters()[k].group == "diagonal rods")
            .collect();
        assert_eq!(rods.len(), 3);
        let correlation = DMatrix::from_fn(n, n, |j, k| match () {
            _ if j == k => 1.0,
            _ if rods.contains(&j) && rods.contains(&k) => rho,
            _ => 0.0,
        });
        let configured: Vec<f64> = design(&delta).iter().copied().collect();
        let observations = Observations {
            probes: vec![ProbeHeight {
                commanded: [0.0, 0.0, 0.1],
                sigma: 0.01,
            }],
            ..Observations::default()
        };
        MechanismData::new(Arc::new(delta), configured, observations)
            .with_trigger_height(0.0, Some(0.5))
            .with_prior_correlation(correlation)
    }

    #[test]
    fn the_information_is_the_inverse_of_the_correlated_covariance() {
        let data = matched_rods(0.9);
        data.validate().unwrap();
        let covariance = prior_covariance(&data);
        let n = data.priors.len();
        // Parameters, then the trigger height, independent of them.
        assert_eq!(covariance.shape(), (n + 1, n + 1));
        let sigma = |k: usize| data.priors[k].sigma.unwrap();
        let rods: Vec<usize> = (0..n)
            .filter(|&k| data.mechanism.parameters()[k].group == "diagonal rods")
            .collect();
        let (a, b) = (rods[0], rods[2]);
        assert!((covariance[(a, b)] - 0.9 * sigma(a) * sigma(b)).abs() < 1e-15);
        assert_eq!(covariance[(n, n)], 0.25);
        assert_eq!(covariance[(a, n)], 0.0);
        // Against a dense inverse.
        let information = prior_information(&data).unwrap();
        let identity = &information * &covariance;
        let error = (identity - DMatrix::identity(n + 1, n + 1)).amax();
        assert!(error < 1e-10, "{error:e}");
    }

    #[test]
    fn a_parameter_without_a_prior_has_no_row() {
        let data = matched_rods(0.9)
            .with_group_sigma("diagonal rods", None)
            .unwrap();
        data.validate().unwrap();
        let covariance = prior_covariance(&data);
        let information = prior_information(&data).unwrap();
        for k in 0..data.priors.len() {
            if data.priors[k].sigma.is_none() {
                assert!(covariance.row(k).iter().all(|&v| v == 0.0));
                assert!(information.row(k).iter().all(|&v| v == 0.0));
            }
        }
    }

    #[test]
    fn a_correlation_that_is_no_correlation_is_refused_by_name() {
        let refused = |data: MechanismData| data.validate().unwrap_err().to_string();
        // Three rods all correlated -0.6: not positive definite.
        let error = refused(matched_rods(-0.6));
        assert!(error.contains("prior correlation"), "{error}");
        assert!(error.contains("not positive definite"), "{error}");
        // Not symmetric, named by its two parameters.
        let mut data = matched_rods(0.5);
        let mut correlation = data.prior_correlation.take().unwrap();
        correlation[(0, 1)] = 0.3;
        let names: Vec<String> = data
            .mechanism
            .parameters()
            .iter()
            .map(|p| p.name.clone())
            .collect();
        let error = refused(data.with_prior_correlation(correlation));
        assert!(
            error.contains(&names[0]) && error.contains(&names[1]),
            "{error}"
        );
        assert!(error.contains("transpose"), "{error}");
        // The wrong size.
        let error = refused(matched_rods(0.5).with_prior_correlation(DMatrix::identity(3, 3)));
        assert!(error.contains("3 x 3"), "{error}");
    }
}
