//! A touch of a calibrated sphere: the machine's probe (its tool point)
//! touches a ball of known radius placed at an unknown centre.
//!
//! The controller commands `x_c` in its own coordinates, readings `q =
//! g(p_c, x_c)` from the configured parameters `p_c`, or the actuators'
//! readings `q` are recorded at the touch ([`Actuation`]); the tool point
//! truly is at `x = T(p, f(p, q))` and lies on the sphere of centre `c`
//! (3 unknowns of the ball, eliminated like a point sample's pose) and
//! radius `ρ` (the ball's calibrated radius: known, or an unknown with its
//! calibration's prior). With `σ` the touch's noise along the normal:
//!
//! ```text
//! e = |x − c| − ρ,     r = e / σ,     u = (x − c) / |x − c|,
//! dr/dp = uᵀ (dx/dp|_q) / σ,     dr/dc = −uᵀ / σ,     dr/dρ = −1 / σ.
//! ```
//!
//! A sphere of known radius fixes lengths: the touches of one ball
//! measure the machine's scale, which probe heights on a plane leave to
//! the prior. This is the paper's radius observation (eq. 9), which the
//! hexapod's own calibration also offers. A touch may instead be observed
//! by its three coordinates (eq. 10, [`super::touch_coordinates`]), whose
//! weight and contact direction's prior it then carries too.

use nalgebra::{DVector, Dyn, RowVector3, Vector3};
use parcal_kinematics::mechanism::{Mechanism, MechanismError, Reached};
use parcal_kinematics::params_jacobian::ParamsJacobian;

use super::commanded::{Actuation, Rows, check_sigma};
use crate::CoordinateWhitening;

/// One touch of a ball (module doc).
#[derive(Debug, Clone, PartialEq)]
pub struct BallTouch {
    /// The index of the ball touched.
    pub ball: usize,
    /// Where the machine was put at the touch.
    pub at: Actuation,
    /// The touch's standard deviation `σ` along the sphere's normal (mm).
    pub sigma: f64,
    /// The whitening of its three coordinate rows (eq. 10): `L⁻¹` of
    /// their covariance `W = L Lᵀ` (mm²); `None`: `W = σ² I`.
    pub weight: Option<CoordinateWhitening>,
    /// What is known of its contact direction before the fit (eq. 10's
    /// angles); `None`: nothing.
    pub approach: Option<Approach>,
}

/// A touch's contact direction as known before the fit: the coordinate
/// observation's two contact angles `θ` are charted about `direction`
/// ([`DirectionChart`](crate::DirectionChart)) and have the prior
/// `θ ~ N(0, σ_θ² I)` (paper eq. 7's angle terms).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Approach {
    /// The direction `u0` from the ball's centre to the touched point (any
    /// non-zero length): the commanded approach, or the direction at the
    /// design.
    pub direction: [f64; 3],
    /// `σ_θ`, each angle's standard deviation (rad).
    pub sigma: f64,
}

impl BallTouch {
    /// A touch of ball `ball`, the machine put there by `at`, of standard
    /// deviation `sigma` along the normal (mm); its coordinates' weight
    /// `σ⁻¹ I`, nothing known of its contact direction.
    pub fn new(ball: usize, at: Actuation, sigma: f64) -> Self {
        Self {
            ball,
            at,
            sigma,
            weight: None,
            approach: None,
        }
    }
}

/// A touch's whitened rows (one: along the sphere's normal), as a point
/// sample's are [`SampleRows`](super::SampleRows).
#[derive(Debug, Clone, PartialEq)]
pub struct TouchRows {
    /// The row `r` and `dr/dp`.
    pub rows: Rows,
    /// The warm start of the pose the machine reached at the touch: a
    /// start for the next evaluation's forward kinematics.
    pub warm_start: DVector<f64>,
    /// `dr/dc`, the derivative with respect to the ball's centre.
    pub d_centre: RowVector3<f64>,
    /// `dr/dρ`, the derivative with respect to the ball's radius.
    pub d_radius: f64,
}

impl BallTouch {
    /// The whitened row at true parameters `params`, configured parameters
    /// `configured`, the ball's centre `centre` and radius `radius`
    /// (module doc), the forward kinematics of a touch at readings started
    /// from the warm start `start` if given ([`Actuation::tool_point`]).
    /// An error if the tool point is at the centre (no normal).
    pub fn evaluate(
        &self,
        mechanism: &dyn Mechanism,
        params: &[f64],
        configured: &[f64],
        centre: &Vector3<f64>,
        radius: f64,
        start: Option<&[f64]>,
    ) -> Result<TouchRows, MechanismError> {
        let reached = self.at.tool_point(mechanism, params, configured, start)?;
        self.row(reached, centre, radius)
    }

    /// The whitened row of the touch that reached `reached`
    /// ([`Actuation::tool_point`], [`Actuation::tool_points`]) on the ball
    /// of centre `centre` and radius `radius` (module doc); an error if
    /// the tool point is at the centre (no normal).
    pub fn row(
        &self,
        reached: Reached,
        centre: &Vector3<f64>,
        radius: f64,
    ) -> Result<TouchRows, MechanismError> {
        let row = self.radius_row(&reached.point, centre, radius)?;
        let mut d_params = DVector::zeros(reached.d_params.ncols());
        row.d_params(&reached.d_params, d_params.as_mut_slice());
        let n = d_params.len();
        Ok(TouchRows {
            rows: Rows {
                residual: DVector::from_element(1, row.residual),
                d_params: d_params.reshape_generic(Dyn(1), Dyn(n)),
            },
            warm_start: reached.warm_start,
            d_centre: row.d_centre(),
            d_radius: row.d_radius(),
        })
    }

    /// [`BallTouch::row`] at the tool point `point`, without `dr/dp`: what
    /// forms it from `dT/dp |_q` ([`RadiusRow::d_params`]) into room of the
    /// caller's.
    pub fn radius_row(
        &self,
        point: &Vector3<f64>,
        centre: &Vector3<f64>,
        radius: f64,
    ) -> Result<RadiusRow, MechanismError> {
        check_sigma("touch sigma", self.sigma)?;
        let offset = point - centre;
        let distance = offset.norm();
        if distance == 0.0 || !distance.is_finite() {
            return Err(MechanismError::Unreachable {
                reason: "a touch's tool point is at its ball's centre".to_string(),
            });
        }
        Ok(RadiusRow {
            residual: (distance - radius) / self.sigma,
            normal: offset / distance,
            sigma: self.sigma,
        })
    }
}

/// A touch's radius row (eq. 9) but `dr/dp` ([`BallTouch::radius_row`]):
/// `r = (|T − c| − ρ) / σ` and the sphere's normal `u = (T − c) / |T − c|`,
/// so that `dr/dp = uᵀ dT/dp |_q / σ`, `dr/dc = −uᵀ / σ`, `dr/dρ = −1 / σ`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RadiusRow {
    /// `r`.
    pub residual: f64,
    /// `u`.
    pub normal: Vector3<f64>,
    /// `σ`.
    pub sigma: f64,
}

impl RadiusRow {
    /// `dr/dT = uᵀ / σ`.
    pub fn d_tip(&self) -> Vector3<f64> {
        self.normal / self.sigma
    }

    /// `dr/dp = (dr/dT) dT/dp |_q` into `out`, one value per column of
    /// `d_tip_params` (a combination of its rows).
    pub fn d_params(&self, d_tip_params: &ParamsJacobian, out: &mut [f64]) {
        d_tip_params.combine(&self.d_tip(), out);
    }

    /// `dr/dc`.
    pub fn d_centre(&self) -> RowVector3<f64> {
        -self.normal.transpose() / self.sigma
    }

    /// `dr/dρ`.
    pub fn d_radius(&self) -> f64 {
        -1.0 / self.sigma
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mechanism::test_support::{
        HexapodTouch, assert_matches, delta, differences, hexapod_touch,
    };

    #[test]
    fn derivatives_match_central_differences() {
        let (delta, configured, truth) = delta();
        let touch = BallTouch::new(0, Actuation::Commanded([40.0, -30.0, 18.0]), 0.005);
        let centre = Vector3::new(35.0, -33.0, 6.0);
        let c = configured.as_slice();
        let at = |p: &[f64], centre: &Vector3<f64>, radius: f64| {
            touch.evaluate(&delta, p, c, centre, radius, None).unwrap()
        };
        let analytic = at(truth.as_slice(), &centre, 12.7);
        let numeric = differences(&delta, &truth, 1e-4, |p| at(p, &centre, 12.7).rows.residual);
        assert_matches(&analytic.rows.d_params, &numeric);
        let h = 1e-4;
        for k in 0..3 {
            let step = Vector3::from_fn(|i, _| if i == k { h } else { 0.0 });
            let column = (at(truth.as_slice(), &(centre + step), 12.7).rows.residual[0]
                - at(truth.as_slice(), &(centre - step), 12.7).rows.residual[0])
                / (2.0 * h);
            assert!((column - analytic.d_centre[k]).abs() < 1e-6, "{column}");
        }
        let d_radius = (at(truth.as_slice(), &centre, 12.7 + h).rows.residual[0]
            - at(truth.as_slice(), &centre, 12.7 - h).rows.residual[0])
            / (2.0 * h);
        assert!((d_radius - analytic.d_radius).abs() < 1e-6, "{d_radius}");
    }

    #[test]
    fn a_hexapods_touch_at_its_readings_matches_central_differences() {
        // The tool tip of a hexapod whose legs read q, from its home pose.
        let HexapodTouch {
            hexapod,
            params: p,
            touch,
            centre,
            ..
        } = hexapod_touch();
        let hexapod = hexapod.as_ref();
        let at = |params: &[f64]| {
            touch
                .evaluate(hexapod, params, &[], &centre, 5.0, None)
                .unwrap()
        };
        let analytic = at(p.as_slice());
        // |tip - c| = √29: the residual is (√29 - 5) / σ.
        let expected = (29f64.sqrt() - 5.0) / 0.002;
        assert!(
            (analytic.rows.residual[0] - expected).abs() < 1e-5,
            "{:?}",
            analytic.rows
        );
        // Steps of 1e-4 mm through forward kinematics converged far below
        // its 1e-9 mm tolerance (Newton's quadratic convergence).
        let numeric = differences(hexapod, &p, 1e-4, |params| at(params).rows.residual);
        assert_matches(&analytic.rows.d_params, &numeric);
        // Started from the pose it reached, the same row to the forward
        // kinematics' tolerance (1e-9 mm, over σ).
        let warm = touch
            .evaluate(
                hexapod,
                p.as_slice(),
                &[],
                &centre,
                5.0,
                Some(analytic.warm_start.as_slice()),
            )
            .unwrap();
        let moved = (warm.rows.residual[0] - analytic.rows.residual[0]).abs();
        assert!(moved < 1e-9 / 0.002, "{moved:e}");
        assert!((&warm.rows.d_params - &analytic.rows.d_params).amax() < 1e-9 * numeric.amax());
    }

    #[test]
    fn a_correct_controller_touches_at_the_radius() {
        // Configured = true: the tool point is where it was commanded.
        let (delta, configured, _) = delta();
        let c = configured.as_slice();
        let touch = BallTouch::new(0, Actuation::Commanded([3.0, 4.0, 10.0]), 0.01);
        let row = touch
            .evaluate(&delta, c, c, &Vector3::new(0.0, 0.0, 10.0), 4.9, None)
            .unwrap();
        assert!((row.rows.residual[0] - 10.0).abs() < 1e-8, "{:?}", row.rows);
        let bad = BallTouch {
            sigma: 0.0,
            ..touch.clone()
        };
        let error = bad
            .evaluate(&delta, c, c, &Vector3::zeros(), 4.9, None)
            .unwrap_err();
        assert!(error.to_string().contains("touch sigma"), "{error}");
    }
}
