//! A ball on the wrong side of its contacts. With its radius fixed, a ball
//! whose contacts lie near one circle (a band of the sphere) has two centre
//! fits, mirror images through the contacts' plane
//! ([`crate::sphere_fit::mirror_fit`]). With the design geometry, off by
//! millimetres, the two can fit its contact points almost equally well, and
//! the best fit the set-up starts from (docs/paper-scenario.md section 4) can be the wrong
//! image: the calibration then keeps that ball on the wrong side, its
//! contacts fitting far worse than the noise allows ([`crate::fit`]). The
//! calibrated geometry tells the sides apart: its contact points fit the
//! right image to the noise level. The check is made at each iterate once
//! Gauss-Newton has settled ([`SETTLED`]), from the ball costs of that
//! iterate's elimination pass: a misfit ball whose contact points at the
//! iterate's parameters fit the mirror image [`MIRROR_GAIN`] times better
//! is re-seeded there and the calibration resumes from that iterate (see
//! [`crate::run::calibrate`]).
//!
//! On the 10^6-contact campaign of docs/performance.md, one ball of 142857
//! is in this case (chi-square 14053 for 4 at the first settled iterate).

use std::time::Instant;

use parcal_kinematics::{ForwardOptions, Geometry, KinematicsError, Pose, Vec3, forward};
use parcal_solver::SolverOptions;

use crate::sphere_fit::{SphereFit, mirror_fit, refine_centre};

/// A misfit ball is re-seeded when its calibrated contact points fit the
/// mirror image at least this many times better (sum of squared distance
/// errors) than the side it is on: a blunder among its contacts spoils
/// both sides alike.
pub const MIRROR_GAIN: f64 = 4.0;

/// The check is made at each iterate of a calibration whose cost is within
/// this fraction of the previous iterate's: Gauss-Newton has then settled,
/// and the geometry is good enough for a ball's misfit to be its own. On
/// the campaigns of docs/performance.md the cost falls by orders of
/// magnitude for two or three iterations, then moves by less than 1e-3.
pub const SETTLED: f64 = 1e-2;

/// A ball found on the wrong side of its contacts.
#[derive(Debug, Clone, PartialEq)]
pub struct WrongSide {
    /// Its index (artefacts.json order).
    pub ball: usize,
    /// Its whitened data cost at the iterate it was found at.
    pub chi_square: f64,
    /// The fit of its contact points at that iterate's parameters on the
    /// side it is on.
    pub side: SphereFit,
    /// Their fit at the mirror image: the re-seeded centre.
    pub mirror: SphereFit,
}

/// Whether ball `ball` (its centre `centre`, of radius `radius`) is on the
/// wrong side of its contacts at the calibrated `geometry`: `actuators`
/// and `poses` are its contacts' actuator values and forward-kinematics
/// warm starts. Returns the two fits and the contact points (at the
/// calibrated geometry) when the mirror side fits [`MIRROR_GAIN`] times
/// better.
pub fn wrong_side(
    geometry: &Geometry,
    actuators: impl Iterator<Item = [f64; 6]>,
    poses: &[Pose],
    radius: f64,
    centre: &Vec3,
) -> Result<Option<(SphereFit, SphereFit, Vec<Vec3>)>, KinematicsError> {
    let fk = ForwardOptions::default();
    let tips = actuators
        .zip(poses)
        .map(|(q, start)| forward(geometry, &q, start, &fk).map(|s| geometry.tool_tip(&s.pose)))
        .collect::<Result<Vec<_>, _>>()?;
    Ok(mirror_side(&tips, radius, centre).map(|(side, mirror)| (side, mirror, tips)))
}

/// The fits of a ball's contact points `tips` (radius `radius`) on the
/// side of `centre` and at its mirror image, when the mirror image fits
/// them [`MIRROR_GAIN`] times better: the ball is then on the wrong side.
pub fn mirror_side(tips: &[Vec3], radius: f64, centre: &Vec3) -> Option<(SphereFit, SphereFit)> {
    let side = refine_centre(tips, radius, centre).ok()?;
    let mirror = mirror_fit(tips, radius, &side).ok()?;
    (mirror.cost * MIRROR_GAIN < side.cost).then_some((side, mirror))
}

/// The centre of a ball located by its `reference` contact points, of
/// which `fit` is the best fit with the ball's `radius`, the ball's
/// other points predicted from it (a validation's reference touches): of
/// `fit` and its mirror image through the points' plane
/// ([`mirror_fit`]), the one the reference points fit
/// [`MIRROR_GAIN`] times better; when they fit both about as well (a few
/// points near one circle), the one `all` the ball's points fit
/// [`MIRROR_GAIN`] times better, else `fit`. Returns the centre, and
/// whether `all` chose the mirror image. The other points only choose
/// between two images `2h` apart, `h` the centre's height above the
/// plane: where `2h` is far above the noise the choice is certain, and
/// where it is not the two images predict those points alike.
pub fn located_side(
    fit: SphereFit,
    reference: &[Vec3],
    all: &[Vec3],
    radius: f64,
) -> (SphereFit, bool) {
    let Ok(mirror) = mirror_fit(reference, radius, &fit) else {
        return (fit, false);
    };
    if mirror.cost * MIRROR_GAIN < fit.cost {
        return (mirror, false);
    }
    if fit.cost * MIRROR_GAIN < mirror.cost {
        return (fit, false);
    }
    let cost = |centre: &Vec3| {
        all.iter()
            .map(|p| ((p - centre).norm() - radius).powi(2))
            .sum::<f64>()
    };
    if cost(&mirror.centre) * MIRROR_GAIN < cost(&fit.centre) {
        (mirror, true)
    } else {
        (fit, false)
    }
}

/// `options` for what is left of the iteration and time limits after
/// `used` iterations since `started`: a solve resumed after re-seeding.
pub(crate) fn remaining(options: &SolverOptions, used: usize, started: Instant) -> SolverOptions {
    SolverOptions {
        max_iterations: options.max_iterations.saturating_sub(used),
        time_limit: options
            .time_limit
            .map(|limit| limit.saturating_sub(started.elapsed())),
        ..options.clone()
    }
}

/// A ball re-seeded at the mirror image of its centre fit.
#[derive(Debug, Clone, PartialEq)]
pub struct Mirrored {
    /// Its index (artefacts.json order).
    pub ball: usize,
    /// artefacts.json's id.
    pub id: String,
    /// Its new initial centre (the mirror fit of its design-FK contact
    /// points).
    pub initial_centre: Vec3,
    /// The Gauss-Newton iterations before it was found (the first settled
    /// iterate that showed it, [`SETTLED`]).
    pub iteration: usize,
    /// What that iterate showed.
    pub side: WrongSide,
}
