//! The held-out balls predicted together ([`BallSet`]): each ball with its
//! touches, or the balls held-out ball distances tie together with theirs
//! and those distances; each set's rows within
//! [`MAX_HELD_OUT_TOUCHES_PER_BALL`].

use super::super::data::Observations;
use super::super::error::MechanismCalibrationError;
use super::super::observation::{HeldOut, ObservationKind, ObservationRef};

/// The most touches of one held-out ball: its rows' noise covariance is
/// dense, `(K − 3)²` numbers factored in `O(K³)`.
pub const MAX_HELD_OUT_TOUCHES_PER_BALL: usize = 1_000;

/// Balls predicted together: one ball and its touches, or the balls
/// held-out ball distances tie together (connected through them), with
/// their touches and those distances.
pub(super) struct BallSet {
    /// The balls, increasing.
    pub(super) balls: Vec<usize>,
    /// Each ball's touches (indices, increasing).
    pub(super) touches: Vec<Vec<usize>>,
    /// The ball distances between them (indices, increasing).
    pub(super) distances: Vec<usize>,
}

impl BallSet {
    /// What its rows are of: a ball, or balls tied by distances.
    pub(super) fn held_out(&self) -> HeldOut {
        match (&self.balls[..], self.distances.is_empty()) {
            (&[ball], true) => HeldOut::Ball {
                ball,
                touches: self.touches[0].clone(),
            },
            _ => {
                let mut touches: Vec<usize> = self.touches.concat();
                touches.sort_unstable();
                HeldOut::TiedBalls {
                    balls: self.balls.clone(),
                    touches,
                    distances: self.distances.clone(),
                }
            }
        }
    }
}

/// The sets of balls predicted together ([`BallSet`]), from each ball's
/// `touches`: every ball touched or tied, the sets in the order of their
/// first ball. An error names a set of more than
/// [`MAX_HELD_OUT_TOUCHES_PER_BALL`] rows.
pub(super) fn tied_sets(
    observations: &Observations,
    touches: Vec<Vec<usize>>,
) -> Result<Vec<BallSet>, MechanismCalibrationError> {
    let (set_of, count) = observations.ball_sets();
    let mut sets: Vec<BallSet> = (0..count)
        .map(|_| BallSet {
            balls: Vec::new(),
            touches: Vec::new(),
            distances: Vec::new(),
        })
        .collect();
    for (b, own) in touches.into_iter().enumerate() {
        let set = &mut sets[set_of[b]];
        set.balls.push(b);
        set.touches.push(own);
    }
    for (k, d) in observations.ball_distances.iter().enumerate() {
        sets[set_of[d.first]].distances.push(k);
    }
    sets.retain(|set| !set.distances.is_empty() || !set.touches[0].is_empty());
    for set in &sets {
        let rows = set.touches.iter().map(Vec::len).sum::<usize>() + set.distances.len();
        if rows > MAX_HELD_OUT_TOUCHES_PER_BALL && set.balls.len() > 1 {
            return Err(MechanismCalibrationError::InvalidData {
                what: set.held_out().to_string(),
                reason: format!(
                    "their {rows} held-out touches and distances are more than the {MAX_HELD_OUT_TOUCHES_PER_BALL} predicted together: validate on fewer"
                ),
            });
        }
    }
    Ok(sets)
}

/// The touches of each ball (indices, increasing); an error names a touch
/// of a ball that does not exist, or a ball of more than
/// [`MAX_HELD_OUT_TOUCHES_PER_BALL`] touches.
pub(super) fn touches_by_ball(
    observations: &Observations,
) -> Result<Vec<Vec<usize>>, MechanismCalibrationError> {
    let count = observations.balls.len();
    let mut balls = vec![Vec::new(); count];
    for (t, touch) in observations.touches.iter().enumerate() {
        let touches =
            balls
                .get_mut(touch.ball)
                .ok_or_else(|| MechanismCalibrationError::Observation {
                    observation: ObservationRef {
                        kind: ObservationKind::Touch,
                        index: t,
                    },
                    reason: format!(
                        "it touches ball {}, and there are {count} balls",
                        touch.ball
                    ),
                })?;
        touches.push(t);
    }
    match balls
        .iter()
        .position(|t| t.len() > MAX_HELD_OUT_TOUCHES_PER_BALL)
    {
        Some(b) => Err(MechanismCalibrationError::InvalidData {
            what: format!("ball {b}"),
            reason: format!(
                "its {} held-out touches are more than the {MAX_HELD_OUT_TOUCHES_PER_BALL} predicted together: validate on fewer",
                balls[b].len()
            ),
        }),
        None => Ok(balls),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mechanism::data::Ball;
    use crate::mechanism::predicted::predict::predict;
    use crate::mechanism::predicted::simulated::delta;
    use parcal_observe::mechanism::{Actuation, BallTouch};

    /// A held-out ball of more touches than its bound is named before any
    /// touch is evaluated.
    #[test]
    fn a_ball_of_too_many_touches_is_named() {
        let (delta, configured, truth) = delta();
        let touch = BallTouch::new(1, Actuation::Commanded([0.0; 3]), 0.01);
        let ball = Ball::new(12.7, None);
        let observations = Observations {
            balls: vec![ball; 2],
            touches: vec![touch; MAX_HELD_OUT_TOUCHES_PER_BALL + 1],
            ..Default::default()
        };
        let error =
            predict(&delta, &truth, configured.as_slice(), &observations, None).unwrap_err();
        let said = error.to_string();
        assert!(
            said.starts_with("ball 1: its 1001 held-out touches"),
            "{said}"
        );
    }
}
