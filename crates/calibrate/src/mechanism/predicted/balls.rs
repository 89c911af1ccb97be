//! The rows of a set of held-out balls ([`predict_balls`]): the touches of
//! a ball, and the distances that tie balls together.
//!
//! The touches of a ball: its centre `c` is its own unknown, fitted to
//! its `K` touches, which give `K − 3` rows together, one observation
//! named by the ball ([`HeldOut::Ball`]; a ball touched 4 times gives
//! one row). The tool points the touches reach,
//! `x_k = f(p̂, g(p_c, x_c,k))` ([`BallTouch`]), locate its centre `ĉ`,
//! the best fit of the sphere of its calibrated radius `ρ` through them
//! (as the calibration starts it, [`sphere_through`]; located by reference
//! touches, the side of them all its touches fit,
//! [`located_side`]), and
//!
//! ```text
//! r_k = |x_k − ĉ| − ρ,   dr_k/dc = −u_kᵀ,   dr_k/dp = u_kᵀ dx_k/dp|_q,
//! u_k = (x_k − ĉ) / |x_k − ĉ|.
//! ```
//!
//! To first order `r = J_c δc + G_p δθ + e + δρ 1`, with `δc` the
//! centre's error, `e` the touches' errors along their normals
//! (`Cov(e) = diag(σ_k²)`) and `δρ` the error of the ball's calibrated
//! radius (`σ_ρ` in `balls.csv`, common to all its touches), so that
//!
//! ```text
//! Σ = diag(σ_k²) + σ_ρ² 1 1ᵀ,
//! D = N_⊥ᵀ Σ N_⊥ = σ_t² I + σ_ρ² (N_⊥ᵀ 1)(N_⊥ᵀ 1)ᵀ   (every σ_k = σ_t):
//! ```
//!
//! an uncertain radius adds an error common to the ball's rows, nearly
//! none when a change of radius is nearly a shift of the centre
//! (touches on a small cap: `1` nearly in the span of `J_c`).

use nalgebra::{DMatrix, DVector, Vector3};
use parcal_kinematics::mechanism::{Mechanism, Reached};
use parcal_observe::mechanism::{Actuation, BallTouch};

#[cfg(doc)]
use super::super::observation::HeldOut;

use crate::mirror::located_side;

use super::super::data::Observations;
use super::super::error::{MechanismCalibrationError, failed};
use super::super::observation::{ObservationKind, ObservationRef, touch_ref};
use super::super::touched_ball::sphere_through;
use super::ball_sets::BallSet;
use super::projection::{LocalRows, predict_from_reference, project_out};
use super::rows::PredictedRows;

/// The rows of a set of held-out balls (module doc): each ball's touches,
/// its centre `c` located by them alone, and the distances between the
/// set's balls, `r = |ĉ_a − ĉ_b| − L` (`dr/dc_a = uᵀ`, `dr/dc_b = −uᵀ`,
/// noise `σ_L²`), every centre then projected out together; with
/// `reference` touches `N`, each centre located by its ball's first `N`
/// touches and the set's other rows predicted from them
/// ([`predict_from_reference`]).
pub(super) fn predict_balls(
    mechanism: &dyn Mechanism,
    params: &[f64],
    configured: &[f64],
    observations: &Observations,
    set: BallSet,
    reference: Option<usize>,
    g: usize,
) -> Result<PredictedRows, MechanismCalibrationError> {
    let all = &observations.touches;
    let mut reference_rows = Vec::new();
    let n = params.len();
    let m = set.touches.iter().map(Vec::len).sum::<usize>() + set.distances.len();
    let u = 3 * set.balls.len();
    let (mut residuals, mut d_local) = (DVector::zeros(m), DMatrix::zeros(m, u));
    let mut d_params = DMatrix::zeros(m, n);
    let mut noise = DMatrix::zeros(m, m);
    let mut centres = Vec::with_capacity(set.balls.len());
    let mut sources = Vec::with_capacity(m);
    let mut mirrored_balls = Vec::new();
    let mut row = 0;
    for (s, (&b, touches)) in set.balls.iter().zip(&set.touches).enumerate() {
        let ball = observations.balls[b];
        let k = touches.len();
        let references = match reference {
            None => k,
            Some(n) if n < k => {
                reference_rows.extend(row..row + n);
                n
            }
            Some(n) => {
                return Err(MechanismCalibrationError::InvalidData {
                    what: format!("ball {b}"),
                    reason: format!(
                        "it has {k} held-out touches: none is left to predict after the {n} reference touches"
                    ),
                });
            }
        };
        let reached = reach_ball(mechanism, params, configured, all, touches)?;
        let tips: Vec<Vector3<f64>> = reached.iter().map(|r| r.point).collect();
        let fit = sphere_through(&tips[..references], ball.radius).map_err(|e| {
            MechanismCalibrationError::InvalidData {
                what: format!("ball {b}"),
                reason: format!(
                    "its first {references} touches do not locate its centre: {e} (more reference touches may)"
                ),
            }
        })?;
        let (fit, mirror) = located_side(fit, &tips[..references], &tips, ball.radius);
        if mirror {
            mirrored_balls.push(b);
        }
        let centre = fit.centre;
        let radius_variance = ball.radius_sigma.map_or(0.0, |s| s * s);
        noise.view_mut((row, row), (k, k)).fill(radius_variance);
        for (&t, reached) in touches.iter().zip(reached) {
            let touch = &all[t];
            let observation = touch_ref(t);
            let evaluated = touch.row(reached, &centre, ball.radius).map_err(|e| {
                MechanismCalibrationError::Observation {
                    observation,
                    reason: format!("on ball {b}: {e}"),
                }
            })?;
            sources.push((observation, 0));
            let sigma = touch.sigma;
            residuals[row] = evaluated.rows.residual[0] * sigma;
            d_local
                .view_mut((row, 3 * s), (1, 3))
                .copy_from(&(evaluated.d_centre * sigma));
            d_params
                .row_mut(row)
                .copy_from(&(evaluated.rows.d_params.row(0) * sigma));
            noise[(row, row)] += sigma * sigma;
            row += 1;
        }
        centres.push(centre);
    }
    let slot = |b: usize| set.balls.binary_search(&b).unwrap_or_default();
    for &k in &set.distances {
        let distance = &observations.ball_distances[k];
        let (a, b) = (slot(distance.first), slot(distance.second));
        let observation = ObservationRef {
            kind: ObservationKind::BallDistance,
            index: k,
        };
        let evaluated = distance.evaluate(&centres[a], &centres[b]).map_err(|e| {
            MechanismCalibrationError::Observation {
                observation,
                reason: e.to_string(),
            }
        })?;
        sources.push((observation, 0));
        let sigma = distance.sigma;
        residuals[row] = evaluated.residual * sigma;
        d_local
            .view_mut((row, 3 * a), (1, 3))
            .copy_from(&(evaluated.d_first * sigma));
        d_local
            .view_mut((row, 3 * b), (1, 3))
            .copy_from(&(evaluated.d_second * sigma));
        noise[(row, row)] = sigma * sigma;
        row += 1;
    }
    let held_out = set.held_out();
    let local = LocalRows {
        residuals,
        d_local: &d_local,
        d_params: &d_params,
        noise,
    };
    let (predicted, locating) = match reference {
        None => (project_out(held_out.clone(), &local, g), "held-out"),
        Some(_) => (
            predict_from_reference(held_out.clone(), &local, &reference_rows, &sources, g),
            "reference",
        ),
    };
    let mut predicted = predicted.ok_or_else(|| MechanismCalibrationError::InvalidData {
        what: held_out.to_string(),
        reason: format!("the {locating} touches do not locate the centres"),
    })?;
    predicted.mirrored_balls = mirrored_balls;
    Ok(predicted)
}

/// Where each of a ball's `touches` (indices into `all`) puts the machine
/// of parameters `params`, reached together from the mechanism's start
/// poses ([`Actuation::tool_points_from_scratch`]: the hexapod's SIMD
/// lanes) with `dT/dp |_q`: their tool points locate the ball's centre, and
/// the same `Reached` give their rows ([`BallTouch::row`]). The first touch
/// that cannot be reached named.
fn reach_ball(
    mechanism: &dyn Mechanism,
    params: &[f64],
    configured: &[f64],
    all: &[BallTouch],
    touches: &[usize],
) -> Result<Vec<Reached>, MechanismCalibrationError> {
    let actuations: Vec<&Actuation> = touches.iter().map(|&t| &all[t].at).collect();
    (Actuation::tool_points_from_scratch(mechanism, params, configured, &actuations).into_iter())
        .zip(touches)
        .map(|(outcome, &t)| outcome.map_err(|e| failed(touch_ref(t), e)))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mechanism::data::Ball;
    use crate::mechanism::observation::HeldOut;
    use crate::mechanism::predicted::simulated::{
        assert_derivatives_match_differences, assert_rows_have_their_stated_noise, ball_rows,
        delta, touches,
    };
    use parcal_kinematics::delta::LinearDelta;
    use parcal_observe::mechanism::BallDistance;
    use parcal_simulate::Rng;

    /// Three balls of `radius` (a calibration sigma `radius_sigma`) on a
    /// ring, each touched `k` times with errors from `error`, and the
    /// distances of balls 0-1 and 1-2, `L = true + error()`, of sigma
    /// `distance_sigma`.
    fn tied_balls(
        machine: &(LinearDelta, DVector<f64>, DVector<f64>),
        radius: (f64, f64),
        k: usize,
        distance_sigma: f64,
        mut error: impl FnMut(f64) -> f64,
        turn: f64,
    ) -> Observations {
        let (radius, radius_sigma) = radius;
        let centres: Vec<Vector3<f64>> = (0..3)
            .map(|b| {
                let angle = turn + 2.1 * b as f64;
                Vector3::new(70.0 * angle.cos(), 70.0 * angle.sin(), 6.0)
            })
            .collect();
        let mut observations = Observations {
            balls: vec![Ball::new(radius, Some(radius_sigma)); 3],
            ..Default::default()
        };
        for (b, centre) in centres.iter().enumerate() {
            let true_radius = radius + error(radius_sigma);
            let mut own = touches(machine, *centre, true_radius, k, || error(0.01));
            for touch in &mut own {
                touch.ball = b;
            }
            observations.touches.extend(own);
        }
        observations.ball_distances = [(0, 1), (1, 2)]
            .into_iter()
            .map(|(a, b)| BallDistance {
                first: a,
                second: b,
                distance: (centres[a] - centres[b]).norm() + error(distance_sigma),
                sigma: distance_sigma,
            })
            .collect();
        observations
    }

    /// Three balls tied by two distances are predicted together: `3k + 2`
    /// rows less the 9 coordinates of their centres, their derivative
    /// `G = N_⊥ᵀ G_p` against central differences over the parameters.
    #[test]
    fn tied_balls_are_predicted_together_with_their_derivatives() {
        let machine = delta();
        let k = 6;
        let observations = tied_balls(&machine, (12.7, 0.002), k, 0.002, |_| 0.0, 0.4);
        let at = ball_rows(&machine, &machine.2, &observations, None);
        assert_eq!(at.residuals.len(), 3 * k + 2 - 9);
        assert!(at.residuals.amax() < 1e-9, "{}", at.residuals);
        assert_eq!(
            at.observation,
            HeldOut::TiedBalls {
                balls: vec![0, 1, 2],
                touches: (0..3 * k).collect(),
                distances: vec![0, 1],
            }
        );
        assert_derivatives_match_differences(&machine, &observations, None, &at);
    }

    /// Tied balls' rows of noisy touches and distances of the true machine:
    /// `T = r'ᵀ D⁻¹ r'` over 150 sets of three balls of 6 touches and two
    /// distances (1650 rows), the distances' sigma that of the touches, the
    /// radii's three times, has the mean of its `χ²` within 4 standard
    /// errors (`4 √(2/1650)` of `T/n`).
    #[test]
    fn tied_balls_rows_have_their_stated_noise() {
        let machine = delta();
        let mut noise = Rng::new(37, 0);
        let sets = (0..150).map(|draw| {
            let error = |sigma| noise.normal(sigma);
            tied_balls(&machine, (12.7, 0.03), 6, 0.01, error, draw as f64)
        });
        assert_rows_have_their_stated_noise("tied balls' rows", &machine, None, sets);
    }

    /// `G = N_⊥ᵀ G_p` of a ball's eight exact touches against central
    /// differences of its predicted rows over the parameters, and its
    /// noise's radius term `σ_ρ² (N_⊥ᵀ 1)(N_⊥ᵀ 1)ᵀ` against central
    /// differences over the ball's radius (`dr'/dρ = −N_⊥ᵀ 1`).
    #[test]
    fn ball_derivatives_match_central_differences() {
        let machine = delta();
        let (radius, radius_sigma, k) = (12.7, 0.002, 8);
        let centre = Vector3::new(40.0, -25.0, 6.0);
        let mut observations = Observations {
            balls: vec![Ball::new(radius, Some(radius_sigma))],
            touches: touches(&machine, centre, radius, k, || 0.0),
            ..Default::default()
        };
        let truth = &machine.2;
        let at = ball_rows(&machine, truth, &observations, None);
        assert_eq!(at.residuals.len(), k - 3);
        assert!(at.residuals.amax() < 1e-9, "{}", at.residuals);
        assert_eq!(
            at.observation,
            HeldOut::Ball {
                ball: 0,
                touches: (0..k).collect()
            }
        );
        assert_derivatives_match_differences(&machine, &observations, None, &at);
        let h = 1e-4;
        observations.balls[0].radius = radius + h;
        let plus = ball_rows(&machine, truth, &observations, None).residuals;
        observations.balls[0].radius = radius - h;
        let minus = ball_rows(&machine, truth, &observations, None).residuals;
        let d_radius = (plus - minus) / (2.0 * h);
        let common = &at.noise - DMatrix::identity(k - 3, k - 3) * (0.01 * 0.01);
        let expected = &d_radius * d_radius.transpose() * (radius_sigma * radius_sigma);
        let error = (&common - &expected).amax();
        assert!(
            error < 1e-6 * expected.amax(),
            "{error:e}: {common} {expected}"
        );
    }

    /// A ball's rows of noisy touches of the true machine: `T = r'ᵀ D⁻¹ r'`
    /// over 400 balls of 8 touches (2000 rows), the radius's error three
    /// times the touches' noise (so that a `D` without its radius's term
    /// fails), has the mean of its `χ²(2000)` within 4 standard errors
    /// (`4 √(2/2000)` of `T/n`).
    #[test]
    fn a_ball_s_rows_have_their_stated_noise() {
        let machine = delta();
        let sets = noisy_balls(&machine, 36);
        assert_rows_have_their_stated_noise("a ball's rows", &machine, None, sets);
    }

    /// 400 balls of radius 12.7 mm (a calibration sigma of 0.03 mm, their
    /// true radii drawn so), each touched 8 times with a noise of 0.01 mm
    /// by the true machine, from the random stream `seed`.
    fn noisy_balls(
        machine: &(LinearDelta, DVector<f64>, DVector<f64>),
        seed: u64,
    ) -> impl Iterator<Item = Observations> + '_ {
        let (radius, radius_sigma, sigma) = (12.7, 0.03, 0.01);
        let mut noise = Rng::new(seed, 0);
        (0..400).map(move |draw| {
            let centre = Vector3::new(60.0 * (draw as f64).cos(), 60.0 * (draw as f64).sin(), 6.0);
            let true_radius = radius + noise.normal(radius_sigma);
            Observations {
                balls: vec![Ball::new(radius, Some(radius_sigma))],
                touches: touches(machine, centre, true_radius, 8, || noise.normal(sigma)),
                ..Default::default()
            }
        })
    }

    /// Each ball's centre located by its first 4 touches: a ball of 8
    /// touches gives its other 4 rows, three balls of 6 tied by two
    /// distances their other 2 each and the distances; `G = A G_p`
    /// against central differences over the parameters.
    #[test]
    fn rows_predicted_from_reference_touches_have_their_derivatives() {
        let machine = delta();
        let centre = Vector3::new(40.0, -25.0, 6.0);
        let ball = Observations {
            balls: vec![Ball::new(12.7, Some(0.002))],
            touches: touches(&machine, centre, 12.7, 8, || 0.0),
            ..Default::default()
        };
        let tied = tied_balls(&machine, (12.7, 0.002), 6, 0.002, |_| 0.0, 0.4);
        for (observations, rows) in [(ball, 4), (tied, 3 * 2 + 2)] {
            let at = ball_rows(&machine, &machine.2, &observations, Some(4));
            assert_eq!(at.residuals.len(), rows);
            assert!(at.residuals.amax() < 1e-9, "{}", at.residuals);
            assert_derivatives_match_differences(&machine, &observations, Some(4), &at);
        }
    }

    /// Rows predicted from reference touches (each centre located by its
    /// ball's first 4) of noisy touches of the true machine: `T = r'ᵀ D⁻¹
    /// r'` has the mean of its `χ²` within 4 standard errors, over 400
    /// balls of 8 touches (1600 rows; the radius's error three times the
    /// touches' noise, common to the reference and the predicted touches)
    /// and over 150 sets of three tied balls of 6 touches (1200 rows).
    #[test]
    fn rows_predicted_from_reference_touches_have_their_stated_noise() {
        let machine = delta();
        let balls = noisy_balls(&machine, 38);
        assert_rows_have_their_stated_noise("a ball's rows from 4", &machine, Some(4), balls);
        let mut noise = Rng::new(39, 0);
        let sets = (0..150).map(|draw| {
            let error = |sigma| noise.normal(sigma);
            tied_balls(&machine, (12.7, 0.03), 6, 0.01, error, draw as f64)
        });
        assert_rows_have_their_stated_noise("tied balls' rows from 4", &machine, Some(4), sets);
    }
}
