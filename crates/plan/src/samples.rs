//! Which poses to sample next, for a mechanism calibrated from readings at
//! unknown poses (a cable robot's encoder samples): greedily, the candidate
//! pose whose sample most reduces the trace of the covariance of a group of
//! parameters (the anchors), given the covariance of a calibration made.
//!
//! A sample at an unknown pose `x` adds, with `A = G_p / σ_q` and
//! `B = G_x / σ_q` (the readings' derivatives, whitened), the information
//! of the readings with the pose eliminated by the Schur complement,
//! `Mᵀ M` with `M = P A` and `P = I − B (BᵀB)⁻¹ Bᵀ` (the readings' part
//! the pose cannot absorb: rank `A − 3`, one for four cables). The
//! covariance after it follows by the Woodbury identity,
//!
//! ```text
//! C' = C − C Mᵀ (I + M C Mᵀ)⁻¹ M C,
//! ```
//!
//! linearised at the calibration's parameters.

use nalgebra::{DMatrix, DVector};
use parcal_kinematics::mechanism::{Mechanism, MechanismError};

use crate::DesignError;

/// The most candidate poses (each costs a few small matrix products per
/// pick).
pub const MAX_CANDIDATES: usize = 100_000;

/// One pick of [`next_samples`].
#[derive(Debug, Clone, PartialEq)]
pub struct Pick {
    /// The candidate's index.
    pub candidate: usize,
    /// The trace of the group's covariance after this and the earlier
    /// picks (the parameters' unit squared).
    pub trace_after: f64,
}

/// `M = P A` of a sample at `pose` (module doc).
fn whitened_rows(
    mechanism: &dyn Mechanism,
    params: &[f64],
    pose: &[f64],
    sigma: f64,
) -> Result<DMatrix<f64>, MechanismError> {
    let jacobians = mechanism.reading_jacobians(params, pose)?;
    let a = jacobians.d_params / sigma;
    let b = jacobians.d_pose / sigma;
    let normal = (b.transpose() * &b)
        .try_inverse()
        .ok_or(MechanismError::Singular)?;
    let n = b.nrows();
    let projector = DMatrix::identity(n, n) - &b * normal * b.transpose();
    Ok(projector * a)
}

/// The trace of the rows and columns `group` of `covariance`.
fn group_trace(covariance: &DMatrix<f64>, group: &[usize]) -> f64 {
    group.iter().map(|&k| covariance[(k, k)]).sum()
}

/// Picks `count` of `candidates` (poses), one at a time, each the one
/// that most reduces the trace of the covariance of the parameters of
/// `group` (a [`Parameter::group`](parcal_kinematics::mechanism::Parameter)),
/// starting from `covariance` (a calibration's, over the mechanism's
/// parameters) at `params`, each sample's readings of standard deviation
/// `reading_sigma`. A candidate the mechanism cannot reach
/// ([`Mechanism::check_feasible`]) is never picked; a pose may be picked
/// more than once (a repeated sample adds its information again).
pub fn next_samples(
    mechanism: &dyn Mechanism,
    params: &[f64],
    covariance: &DMatrix<f64>,
    candidates: &[[f64; 3]],
    reading_sigma: f64,
    group: &str,
    count: usize,
) -> Result<Vec<Pick>, DesignError> {
    let n = mechanism.parameters().len();
    let options = |reason: String| DesignError::Options(reason);
    if covariance.shape() != (n, n) {
        return Err(options(format!(
            "the covariance is {}x{}; the {} has {n} parameters",
            covariance.nrows(),
            covariance.ncols(),
            mechanism.name()
        )));
    }
    if !(reading_sigma.is_finite() && reading_sigma > 0.0) {
        return Err(options(format!(
            "the reading sigma {reading_sigma} must be positive"
        )));
    }
    if candidates.is_empty() || candidates.len() > MAX_CANDIDATES {
        return Err(options(format!(
            "{} candidate poses: 1 to {MAX_CANDIDATES}",
            candidates.len()
        )));
    }
    if count > candidates.len() * 10 {
        return Err(options(format!(
            "{count} picks from {} candidates: at most ten per candidate",
            candidates.len()
        )));
    }
    let indices: Vec<usize> = (0..n)
        .filter(|&k| mechanism.parameters()[k].group == group)
        .collect();
    if indices.is_empty() {
        return Err(options(format!(
            "the {} has no parameter group {group:?}",
            mechanism.name()
        )));
    }
    let rows: Vec<Option<DMatrix<f64>>> = candidates
        .iter()
        .map(|pose| {
            mechanism
                .check_feasible(params, pose)
                .and_then(|()| whitened_rows(mechanism, params, pose, reading_sigma))
                .ok()
        })
        .collect();
    let mut covariance = covariance.clone();
    let mut picks = Vec::with_capacity(count);
    for _ in 0..count {
        let best = rows
            .iter()
            .enumerate()
            .filter_map(|(k, m)| m.as_ref().map(|m| (k, updated(&covariance, m))))
            .filter_map(|(k, c)| c.map(|c| (k, group_trace(&c, &indices), c)))
            .min_by(|a, b| a.1.total_cmp(&b.1));
        let Some((candidate, trace_after, after)) = best else {
            return Err(options(
                "no candidate pose is reachable (every one outside the mechanism's limits or singular)"
                    .into(),
            ));
        };
        covariance = after;
        picks.push(Pick {
            candidate,
            trace_after,
        });
    }
    Ok(picks)
}

/// `C − C Mᵀ (I + M C Mᵀ)⁻¹ M C` (module doc); `None` if the middle
/// matrix is not positive definite (a covariance that is not).
fn updated(covariance: &DMatrix<f64>, m: &DMatrix<f64>) -> Option<DMatrix<f64>> {
    let cm = covariance * m.transpose();
    let middle = DMatrix::identity(m.nrows(), m.nrows()) + m * &cm;
    let solved = middle.cholesky()?.solve(&cm.transpose());
    Some(covariance - &cm * solved)
}

/// The covariance after samples at `poses` (each once), for checking
/// [`next_samples`] against the dense form `(C⁻¹ + Σ Mᵀ M)⁻¹`.
pub fn covariance_after(
    mechanism: &dyn Mechanism,
    params: &[f64],
    covariance: &DMatrix<f64>,
    poses: &[[f64; 3]],
    reading_sigma: f64,
) -> Result<DMatrix<f64>, DesignError> {
    let mut information = covariance
        .clone()
        .try_inverse()
        .ok_or_else(|| DesignError::Options("the covariance is singular".into()))?;
    for pose in poses {
        let m = whitened_rows(mechanism, params, pose, reading_sigma)
            .map_err(|e| DesignError::Options(format!("pose {pose:?}: {e}")))?;
        information += m.transpose() * m;
    }
    information
        .try_inverse()
        .ok_or_else(|| DesignError::Options("the information is singular".into()))
}

/// Candidate poses on a grid over a box: `per_axis` values along each of
/// x, y (within `±half_width`) and z (from `0` to `height`).
pub fn grid(half_width: f64, height: f64, per_axis: usize) -> Vec<[f64; 3]> {
    let along = |low: f64, high: f64| -> DVector<f64> {
        DVector::from_fn(per_axis, |i, _| {
            if per_axis == 1 {
                0.5 * (low + high)
            } else {
                low + (high - low) * i as f64 / (per_axis - 1) as f64
            }
        })
    };
    let (xs, zs) = (along(-half_width, half_width), along(0.0, height));
    let mut poses = Vec::with_capacity(per_axis.pow(3));
    for &x in xs.iter() {
        for &y in xs.iter() {
            for &z in zs.iter() {
                poses.push([x, y, z]);
            }
        }
    }
    poses
}

#[cfg(test)]
mod tests {
    use super::*;
    use parcal_kinematics::cable::CableRobot;
    use parcal_kinematics::mechanism::{design, prior_sigma};

    #[test]
    fn greedy_picks_follow_the_dense_update_and_beat_the_rest() {
        let robot = CableRobot::typical();
        let p = design(&robot);
        let prior = DMatrix::from_diagonal(&prior_sigma(&robot).map(|s| s * s));
        let candidates = grid(500.0, 1400.0, 4);
        let picks = next_samples(
            &robot,
            p.as_slice(),
            &prior,
            &candidates,
            18.0,
            "anchors",
            5,
        )
        .unwrap();
        assert_eq!(picks.len(), 5);
        // The traces fall with every pick.
        assert!(
            picks
                .windows(2)
                .all(|w| w[1].trace_after < w[0].trace_after)
        );
        // The Woodbury updates equal the dense inverse.
        let chosen: Vec<[f64; 3]> = picks.iter().map(|k| candidates[k.candidate]).collect();
        let dense = covariance_after(&robot, p.as_slice(), &prior, &chosen, 18.0).unwrap();
        let anchors: Vec<usize> = (0..12).collect();
        let trace = group_trace(&dense, &anchors);
        let last = picks[4].trace_after;
        assert!((trace - last).abs() < 1e-9 * trace, "{trace} vs {last}");
        // The first pick is the best single sample: no other candidate
        // alone does better.
        for pose in &candidates {
            if robot.check_feasible(p.as_slice(), pose).is_err() {
                continue;
            }
            let alone = covariance_after(&robot, p.as_slice(), &prior, &[*pose], 18.0).unwrap();
            assert!(group_trace(&alone, &anchors) >= picks[0].trace_after * (1.0 - 1e-9));
        }
    }

    #[test]
    fn bad_requests_are_named() {
        let robot = CableRobot::typical();
        let p = design(&robot);
        let prior = DMatrix::from_diagonal(&prior_sigma(&robot).map(|s| s * s));
        let err = next_samples(
            &robot,
            p.as_slice(),
            &prior,
            &[[0.0, 0.0, 500.0]],
            1.0,
            "legs",
            1,
        )
        .unwrap_err();
        assert!(
            err.to_string().contains("no parameter group \"legs\""),
            "{err}"
        );
        let err = next_samples(
            &robot,
            p.as_slice(),
            &prior,
            &[[0.0, 0.0, 9000.0]],
            1.0,
            "anchors",
            1,
        )
        .unwrap_err();
        assert!(
            err.to_string().contains("no candidate pose is reachable"),
            "{err}"
        );
        let err = next_samples(&robot, p.as_slice(), &prior, &[], 1.0, "anchors", 1).unwrap_err();
        assert!(err.to_string().contains("0 candidate poses"), "{err}");
    }
}
