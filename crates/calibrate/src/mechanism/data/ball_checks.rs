//! The balls, their touches and the ball distances checked
//! ([`check_balls`], [`check_ball_distances`]): radii, centre priors,
//! touches of balls that exist and enough of them, distances between
//! distinct balls, each pair once, within the tied balls accepted.

use parcal_observe::mechanism::Actuation;
use rayon::prelude::*;

use super::super::error::MechanismCalibrationError;
use super::super::observation::{ObservationKind, ObservationRef};
use super::limits::{MAX_TIED_BALLS, MIN_TOUCHES_PER_BALL};
use super::observations::Observations;
use super::value_checks::{check_sigma, observation_error};

/// Every ball's radius finite and positive and its sigma, if any, finite
/// and positive; every touch on a ball that exists, where the machine was
/// put as `check_at` accepts, with a positive sigma; every ball touched at
/// least [`MIN_TOUCHES_PER_BALL`] times.
pub(super) fn check_balls(
    observations: &Observations,
    check_at: impl Fn(ObservationRef, &Actuation) -> Result<(), MechanismCalibrationError> + Sync,
) -> Result<(), MechanismCalibrationError> {
    let balls = &observations.balls;
    let ball_error = |b: usize, reason: String| MechanismCalibrationError::InvalidData {
        what: format!("ball {b}"),
        reason,
    };
    for (b, ball) in balls.iter().enumerate() {
        if !(ball.radius.is_finite() && ball.radius > 0.0) {
            return Err(ball_error(
                b,
                format!("its radius {} is not finite and positive", ball.radius),
            ));
        }
        if let Some(sigma) = ball.radius_sigma
            && !(sigma.is_finite() && sigma > 0.0)
        {
            return Err(ball_error(
                b,
                format!("its radius sigma {sigma} is not finite and positive (exact: none)"),
            ));
        }
        if let Some(prior) = ball.centre_prior {
            if prior.centre.iter().any(|c| !c.is_finite()) {
                return Err(ball_error(
                    b,
                    format!("its centre prior {:?} is not finite", prior.centre),
                ));
            }
            if !(prior.sigma.is_finite() && prior.sigma > 0.0) {
                return Err(ball_error(
                    b,
                    format!(
                        "its centre prior's sigma {} is not finite and positive (no prior: none)",
                        prior.sigma
                    ),
                ));
            }
        }
    }
    // The touches on the threads, the first refused named.
    let refused = (observations.touches.par_iter().enumerate()).find_map_first(|(k, touch)| {
        let id = ObservationRef {
            kind: ObservationKind::Touch,
            index: k,
        };
        let checked = if touch.ball >= balls.len() {
            Err(observation_error(
                id,
                format!(
                    "it touches ball {}, and there are {} balls",
                    touch.ball,
                    balls.len()
                ),
            ))
        } else {
            check_at(id, &touch.at).and_then(|()| check_sigma(id, touch.sigma))
        };
        checked.err()
    });
    if let Some(error) = refused {
        return Err(error);
    }
    let (touches_of, _) = observations.touches_per_ball();
    match touches_of
        .iter()
        .position(|&count| count < MIN_TOUCHES_PER_BALL)
    {
        Some(b) => Err(ball_error(
            b,
            format!(
                "it has {} touches; its centre needs at least {MIN_TOUCHES_PER_BALL} (give it more, or remove it)",
                touches_of[b]
            ),
        )),
        None => Ok(()),
    }
}

/// Every ball distance between two distinct balls that exist, of a finite
/// and positive distance and sigma, each pair of balls at most once, the
/// balls they tie at most [`MAX_TIED_BALLS`].
pub(super) fn check_ball_distances(
    observations: &Observations,
) -> Result<(), MechanismCalibrationError> {
    let balls = observations.balls.len();
    let mut pairs = std::collections::HashMap::new();
    for (k, d) in observations.ball_distances.iter().enumerate() {
        let id = ObservationRef {
            kind: ObservationKind::BallDistance,
            index: k,
        };
        if let Some(b) = [d.first, d.second].into_iter().find(|&b| b >= balls) {
            return Err(observation_error(
                id,
                format!("it ties ball {b}, and there are {balls} balls"),
            ));
        }
        if d.first == d.second {
            return Err(observation_error(
                id,
                format!("it ties ball {} to itself", d.first),
            ));
        }
        if !(d.distance.is_finite() && d.distance > 0.0) {
            return Err(observation_error(
                id,
                format!("its distance {} is not finite and positive", d.distance),
            ));
        }
        check_sigma(id, d.sigma)?;
        let pair = (d.first.min(d.second), d.first.max(d.second));
        if let Some(earlier) = pairs.insert(pair, k) {
            return Err(observation_error(
                id,
                format!(
                    "balls {} and {} already have ball distance {earlier}",
                    pair.0, pair.1
                ),
            ));
        }
    }
    let tied = observations.tied_balls(0).len();
    if tied > MAX_TIED_BALLS {
        return Err(MechanismCalibrationError::InvalidData {
            what: "ball distances".to_string(),
            reason: format!(
                "they tie {tied} balls together, more than the {MAX_TIED_BALLS} accepted (each tied ball's centre is an unknown of the dense global block)"
            ),
        });
    }
    Ok(())
}
