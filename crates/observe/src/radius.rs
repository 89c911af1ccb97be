//! The radius observation (paper eq. 9, simulations I and III): a touched
//! point lies on its ball,
//!
//! ```text
//! c_ij = r_i − |f(q_ij, p) − C_i|,                           1 row,
//! dc/dp = −nᵀ J_f,   dc/dC = nᵀ,   dc/dr = 1,   n = (T − C) / |T − C|,
//! ```
//!
//! with `T = f(q_ij, p)` the tool tip and `J_f = dT/dp`. Unknowns: the 33
//! parameters, the ball centre `C_i` and, when the radius is modelled per
//! ball, the ball's radius `r_i` (otherwise the calibrated radius is data).

use nalgebra::{SMatrix, SVector};
use parcal_kinematics::Vec3;

use crate::{ObserveError, RadiusJacobians};

/// The radius observation of one contact on a ball of calibrated radius
/// `radius` (mm).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RadiusBlock {
    /// The ball's radius `r_i` (mm): the calibrated one, or the current
    /// estimate when the radius is an unknown.
    pub radius: f64,
}

impl RadiusBlock {
    /// Paper eq. (9): `c = r − |T − C|` (mm) at the tool tip `tip`
    /// (`T = f(q, p)`) and the ball centre `centre` (mm, canonical base
    /// frame), with `dc/dT = −nᵀ` (so `dc/dp = −nᵀ J_f`), `dc/dC = nᵀ` and
    /// `dc/dr = 1`.
    /// Refuses a tip at the centre, where the normal `n` is undefined.
    pub fn evaluate(&self, tip: &Vec3, centre: &Vec3) -> Result<RadiusJacobians, ObserveError> {
        let (normal, distance) =
            unit_offset(tip, centre, "contact normal (tool tip minus ball centre)")?;
        let normal = normal.transpose();
        Ok(RadiusJacobians {
            residual: SVector::<f64, 1>::new(self.radius - distance),
            d_tip: -normal,
            d_centre: normal,
            d_radius: SVector::<f64, 1>::new(1.0),
            d_angles: SMatrix::zeros(),
        })
    }
}

/// The unit vector `n = (a - b) / |a - b|` and the distance `|a - b|`,
/// refusing coincident points (`what` names the direction), where `n` is
/// undefined.
pub(crate) fn unit_offset(
    a: &Vec3,
    b: &Vec3,
    what: &'static str,
) -> Result<(Vec3, f64), ObserveError> {
    let offset = a - b;
    let distance = offset.norm();
    if !(distance.is_finite() && distance > 0.0) {
        return Err(ObserveError::DegenerateDirection {
            what,
            length: distance,
        });
    }
    Ok((offset / distance, distance))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_support::{Contact, assert_close, central_difference};

    #[test]
    fn derivatives_match_central_differences_through_forward_kinematics() {
        let contact = Contact::new();
        let block = RadiusBlock { radius: 5.0 };
        let tip = contact.tip();
        let centre = contact.centre();
        let blocks = block.evaluate(&tip.position, &centre).unwrap();
        assert!((blocks.residual[0] - (5.0 - (tip.position - centre).norm())).abs() < 1e-15);
        assert!(blocks.residual[0].abs() > 1e-3, "a non-trivial residual");

        let by_params = central_difference(&contact.params(), 1e-4, |p| {
            let tip = contact.tip_with(p);
            block.evaluate(&tip.position, &centre).unwrap().residual
        });
        assert_close(&blocks.d_params(&tip), &by_params, 1e-6, "dc/dp");

        let by_centre = central_difference(&centre, 1e-5, |c| {
            block.evaluate(&tip.position, c).unwrap().residual
        });
        assert_close(&blocks.d_centre, &by_centre, 1e-6, "dc/dC");

        // The residual is linear in r: a large step is exact up to rounding.
        let by_radius = central_difference(&SVector::<f64, 1>::new(5.0), 1e-2, |r| {
            RadiusBlock { radius: r[0] }
                .evaluate(&tip.position, &centre)
                .unwrap()
                .residual
        });
        assert_close(&blocks.d_radius, &by_radius, 1e-9, "dc/dr");
    }

    #[test]
    fn refuses_a_tip_at_the_centre() {
        let tip = Contact::new().tip();
        let error = RadiusBlock { radius: 5.0 }
            .evaluate(&tip.position, &tip.position)
            .unwrap_err();
        assert!(matches!(error, ObserveError::DegenerateDirection { .. }));
    }
}
