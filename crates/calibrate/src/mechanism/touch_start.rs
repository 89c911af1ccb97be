//! Where a fit starts its balls and touches when another set-up has
//! located them: each ball's centre and each touch's pose, given as the
//! warm start its forward kinematics starts from
//! ([`Mechanism::warm_start`](parcal_kinematics::mechanism::Mechanism::warm_start)).
//! Without one, each ball's touches are reached from the mechanism's start
//! poses
//! ([`Mechanism::start_pose`](parcal_kinematics::mechanism::Mechanism::start_pose))
//! and its centre is the best fit of their tool points. A hexapod's data
//! carry the own set-up's ([`super::MechanismData::from_hexapod_touches`]: the
//! design's forward kinematics of every contact and each ball's centre, or
//! its mirror image), so that the common calibration starts where the
//! hexapod's own does: each touch's tool point at its given warm start
//! ([`Mechanism::tool_points_at_warm_starts`](parcal_kinematics::mechanism::Mechanism::tool_points_at_warm_starts)),
//! without forward kinematics.

use rayon::prelude::*;

use super::error::MechanismCalibrationError;

/// The number of touches whose warm starts [`TouchStart::validate`] checks
/// at a time on the threads: a few hundred shares of a million touches.
const CHECK_CHUNK: usize = 4096;

/// Each ball's centre and each touch's warm start, where a fit starts them
/// (module doc).
#[derive(Debug, Clone, PartialEq)]
pub struct TouchStart {
    /// Each ball's centre (mm, the mechanism's frame), in the order of the
    /// balls.
    pub centres: Vec<[f64; 3]>,
    /// Each touch's warm start (the mechanism's
    /// [`warm_start_len`](parcal_kinematics::mechanism::Mechanism::warm_start_len)
    /// values), in the order of the touches, one touch after another.
    pub warm_starts: Vec<f64>,
}

impl TouchStart {
    /// Touch `t`'s warm start of `len` values.
    pub(crate) fn warm_start(&self, t: usize, len: usize) -> &[f64] {
        &self.warm_starts[t * len..(t + 1) * len]
    }

    /// A centre for each of `balls` balls and a warm start of `len` values
    /// for each of `touches` touches, every value finite.
    pub(crate) fn validate(
        &self,
        balls: usize,
        touches: usize,
        len: usize,
    ) -> Result<(), MechanismCalibrationError> {
        let invalid = |reason: String| MechanismCalibrationError::InvalidData {
            what: "the touches' start".to_string(),
            reason,
        };
        if self.centres.len() != balls {
            return Err(invalid(format!(
                "{} ball centres for {balls} balls",
                self.centres.len()
            )));
        }
        if self.warm_starts.len() != touches * len {
            return Err(invalid(format!(
                "{} warm start values for {touches} touches of {len} each",
                self.warm_starts.len()
            )));
        }
        if let Some(b) = (self.centres.iter()).position(|c| c.iter().any(|v| !v.is_finite())) {
            return Err(invalid(format!("ball {b}'s centre is not finite")));
        }
        // A chunk of touches at a time on the threads, the first that holds
        // a value not finite searched touch by touch.
        let len = len.max(1);
        let chunk = len * CHECK_CHUNK;
        let finite = |values: &[f64]| values.iter().all(|v| v.is_finite());
        let refused = (self.warm_starts.par_chunks(chunk))
            .position_first(|values| !finite(values))
            .and_then(|c| {
                let values = &self.warm_starts[c * chunk..];
                (values.chunks(len).take(CHECK_CHUNK))
                    .position(|start| !finite(start))
                    .map(|t| c * CHECK_CHUNK + t)
            });
        match refused {
            Some(t) => Err(invalid(format!("touch {t}'s warm start is not finite"))),
            None => Ok(()),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A start of the data's sizes, finite, is taken; another is refused,
    /// naming what is wrong.
    #[test]
    fn a_start_must_fit_the_data() {
        let (balls, touches) = (2, 9);
        let start = TouchStart {
            centres: vec![[0.0, 0.0, 10.0]; balls],
            warm_starts: vec![1.0; 3 * touches],
        };
        assert!(start.validate(balls, touches, 3).is_ok());
        let refused = |start: &TouchStart, len| {
            (start.validate(balls, touches, len))
                .unwrap_err()
                .to_string()
        };
        let error = refused(&start, 6);
        assert!(
            error.contains("27 warm start values for 9 touches of 6 each"),
            "{error}"
        );
        let mut short = start.clone();
        short.centres.pop();
        let error = refused(&short, 3);
        assert!(error.contains("1 ball centres for 2 balls"), "{error}");
        let mut infinite = start.clone();
        infinite.warm_starts[3 * 8 + 2] = f64::INFINITY;
        let error = refused(&infinite, 3);
        assert!(error.contains("touch 8's warm start"), "{error}");
        let mut centre = start;
        centre.centres[0][1] = f64::NAN;
        assert!(refused(&centre, 3).contains("ball 0's centre"));
        // The first touch not finite is named, in a later chunk of those the
        // threads check, whichever others follow it.
        let touches = 2 * CHECK_CHUNK + 9;
        let mut long = TouchStart {
            centres: vec![[0.0, 0.0, 10.0]; balls],
            warm_starts: vec![1.0; 7 * touches],
        };
        let first = CHECK_CHUNK + 5;
        long.warm_starts[7 * first + 6] = f64::NAN;
        long.warm_starts[7 * (2 * CHECK_CHUNK + 1)] = f64::INFINITY;
        let error = long.validate(balls, touches, 7).unwrap_err().to_string();
        assert!(
            error.contains(&format!("touch {first}'s warm start")),
            "{error}"
        );
    }
}
