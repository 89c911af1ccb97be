//! A ball touch observed by its coordinates (paper eq. 10): the touched
//! point is the point of its ball in the contact's direction,
//!
//! ```text
//! c = C + ρ u(θ) − T(p, f(p, q)),                       3 rows,
//! dc/dp = −dT/dp |_q,   dc/dC = I,   dc/dρ = u(θ),   dc/dθ = ρ du/dθ,
//! ```
//!
//! whitened by the touch's weight `L⁻¹` ([`BallTouch::weight`], `σ⁻¹ I`
//! when none is given; `L⁻¹ dc/dp = −L⁻¹ dT/dp |_q` kept as its two
//! factors, [`CoordinateJacobians::d_tip`] beside the mechanism's `dT/dp |_q`), with the contact's two angles `θ` unknowns of its
//! own, charted about its approach's direction when one is known, else
//! about the direction of its tool point from its ball's centre where the
//! fit starts ([`DirectionChart`]). With its approach's `σ_θ`, the angles
//! have the prior `θ ~ N(0, σ_θ² I)`.
//!
//! The angles take up the two tangential rows: without an angle prior and
//! with `W = σ² I`, the fit of a touch's coordinates is that of its
//! radius row (eq. 9, [`BallTouch::row`]).

use nalgebra::{Vector2, Vector3};
use parcal_kinematics::mechanism::MechanismError;

use super::ball_touch::BallTouch;
use super::commanded::check_sigma;
use crate::{
    CoordinateBlock, CoordinateJacobians, CoordinateWhitening, DirectionChart, ObserveError,
};

impl BallTouch {
    /// The chart of its contact angles (module doc): about its approach's
    /// direction, else about `start`, the direction from its ball's centre
    /// to its tool point where the fit starts. An error for a direction
    /// that is zero or not finite.
    pub fn chart(&self, start: &Vector3<f64>) -> Result<DirectionChart, ObserveError> {
        match &self.approach {
            Some(approach) => DirectionChart::new(&Vector3::from(approach.direction)),
            None => DirectionChart::new(start),
        }
    }

    /// The whitening of its coordinate rows: its weight, else `σ⁻¹ I`.
    pub fn coordinate_weight(&self) -> Result<CoordinateWhitening, MechanismError> {
        match self.weight {
            Some(weight) => Ok(weight),
            None => {
                check_sigma("touch sigma", self.sigma)?;
                CoordinateWhitening::isotropic(self.sigma).map_err(|_| MechanismError::NonFinite {
                    what: format!(
                        "touch sigma {} (its whitening 1/sigma, kept in single precision)",
                        self.sigma
                    ),
                })
            }
        }
    }

    /// Its whitened coordinate rows (module doc) where the machine's tool
    /// point is `point` (where it reached,
    /// [`Actuation::tool_points`](super::Actuation::tool_points)), on the
    /// ball of centre `centre` and radius `radius`, at the contact's angles
    /// `angles` in `chart` ([`BallTouch::chart`]): the rows' `L⁻¹ dc/dp` is
    /// their `d_tip` times the mechanism's `dT/dp |_q`
    /// ([`Reached::d_params`](parcal_kinematics::mechanism::Reached::d_params)).
    pub fn coordinate_rows(
        &self,
        point: &Vector3<f64>,
        chart: &DirectionChart,
        centre: &Vector3<f64>,
        radius: f64,
        angles: &Vector2<f64>,
    ) -> Result<CoordinateJacobians, MechanismError> {
        let weight = self.coordinate_weight()?;
        let block = CoordinateBlock {
            radius,
            chart: *chart,
        };
        Ok(block.evaluate_whitened(point, centre, angles, &weight))
    }
}

#[cfg(test)]
mod tests {
    use nalgebra::{DMatrix, DVector, Dyn, Matrix3, OMatrix, U3};
    use parcal_kinematics::mechanism::Reached;

    use super::*;
    use crate::mechanism::test_support::{
        HexapodTouch, assert_matches, delta, differences, hexapod_touch,
    };
    use crate::mechanism::{Actuation, Approach};

    /// Central differences of a touch's rows `at` (its ball's centre,
    /// radius and contact angles) over those, against the analytic columns
    /// (bound 1e-6 of the largest, steps 1e-5).
    fn check_local_columns(
        at: impl Fn(&Vector3<f64>, f64, &Vector2<f64>) -> CoordinateJacobians,
        centre: Vector3<f64>,
        radius: f64,
        angles: Vector2<f64>,
    ) {
        let analytic = at(&centre, radius, &angles);
        let h = 1e-5;
        let mut local = DMatrix::zeros(3, 6);
        for k in 0..6 {
            let (mut c, mut r, mut a) = ([centre; 2], [radius; 2], [angles; 2]);
            match k {
                0..3 => (c[0][k], c[1][k]) = (centre[k] + h, centre[k] - h),
                3 => (r[0], r[1]) = (radius + h, radius - h),
                _ => (a[0][k - 4], a[1][k - 4]) = (angles[k - 4] + h, angles[k - 4] - h),
            }
            let column =
                (at(&c[0], r[0], &a[0]).residual - at(&c[1], r[1], &a[1]).residual) / (2.0 * h);
            local.set_column(k, &column);
        }
        let mut expected = DMatrix::zeros(3, 6);
        expected
            .view_mut((0, 0), (3, 3))
            .copy_from(&analytic.d_centre);
        expected.set_column(3, &analytic.d_radius);
        expected
            .view_mut((0, 4), (3, 2))
            .copy_from(&analytic.d_angles);
        let error = (&local - &expected).amax();
        assert!(
            error < 1e-6 * expected.amax(),
            "{error:e}\n{local}{expected}"
        );
    }

    /// The rows' `L⁻¹ dc/dp` where the machine reached `reached`: their
    /// `d_tip` times its `dT/dp |_q`.
    fn d_params(rows: &CoordinateJacobians, reached: &Reached) -> OMatrix<f64, U3, Dyn> {
        rows.d_tip * reached.d_params.to_dense()
    }

    #[test]
    fn a_deltas_coordinates_match_central_differences() {
        let (delta, configured, truth) = delta();
        let c = configured.as_slice();
        let mut touch = BallTouch::new(0, Actuation::Commanded([40.0, -30.0, 18.0]), 0.005);
        // A full weight, so that a whitening applied to the wrong factor
        // shows.
        let covariance = Matrix3::new(4.0, 1.2, -0.7, 1.2, 2.5, 0.4, -0.7, 0.4, 1.8) * 1e-5;
        touch.weight = Some(CoordinateWhitening::from_covariance(&covariance).unwrap());
        let centre = Vector3::new(35.0, -33.0, 6.0);
        let tip = touch
            .at
            .tool_point(&delta, truth.as_slice(), c, None)
            .unwrap();
        let chart = touch.chart(&(tip.point - centre)).unwrap();
        let angles = Vector2::new(0.03, -0.02);
        let at = |p: &[f64]| {
            let reached = touch.at.tool_point(&delta, p, c, None).unwrap();
            let rows = touch.coordinate_rows(&reached.point, &chart, &centre, 12.7, &angles);
            (rows.unwrap(), reached)
        };
        let (analytic, reached) = at(truth.as_slice());
        let numeric = differences(&delta, &truth, 1e-4, |p| {
            DVector::from_column_slice(at(p).0.residual.as_slice())
        });
        assert_matches(&d_params(&analytic, &reached), &numeric);
        let local = |centre: &Vector3<f64>, radius, angles: &Vector2<f64>| {
            let reached = touch
                .at
                .tool_point(&delta, truth.as_slice(), c, None)
                .unwrap();
            (touch.coordinate_rows(&reached.point, &chart, centre, radius, angles)).unwrap()
        };
        check_local_columns(local, centre, 12.7, angles);
    }

    #[test]
    fn a_hexapods_coordinates_at_its_readings_match_central_differences() {
        let HexapodTouch {
            hexapod,
            params: p,
            touch,
            tip,
            centre,
        } = hexapod_touch();
        let hexapod = hexapod.as_ref();
        let chart = touch.chart(&(tip - centre)).unwrap();
        let angles = Vector2::new(-0.01, 0.04);
        let at = |params: &[f64]| {
            let reached = touch.at.tool_point(hexapod, params, &[], None).unwrap();
            let rows = touch.coordinate_rows(&reached.point, &chart, &centre, 5.0, &angles);
            (rows.unwrap(), reached)
        };
        let (analytic, reached) = at(p.as_slice());
        let numeric = differences(hexapod, &p, 1e-4, |params| {
            DVector::from_column_slice(at(params).0.residual.as_slice())
        });
        assert_matches(&d_params(&analytic, &reached), &numeric);
        let local = |centre: &Vector3<f64>, radius, angles: &Vector2<f64>| {
            let reached = touch
                .at
                .tool_point(hexapod, p.as_slice(), &[], None)
                .unwrap();
            (touch.coordinate_rows(&reached.point, &chart, centre, radius, angles)).unwrap()
        };
        check_local_columns(local, centre, 5.0, angles);
    }

    #[test]
    fn at_the_charts_direction_the_rows_are_the_radial_misfit() {
        // Charted about the direction from the centre to the tip, at zero
        // angles, c = (ρ − |T − C|) u0: the radius row's misfit along u0,
        // whitened by σ⁻¹ I.
        let (delta, configured, truth) = delta();
        let c = configured.as_slice();
        let touch = BallTouch::new(0, Actuation::Commanded([3.0, 4.0, 10.0]), 0.01);
        let reached = touch
            .at
            .tool_point(&delta, truth.as_slice(), c, None)
            .unwrap();
        let centre = reached.point + Vector3::new(1.0, -2.0, 2.0);
        let u0 = (reached.point - centre) / 3.0;
        let chart = touch.chart(&(reached.point - centre)).unwrap();
        let rows = touch
            .coordinate_rows(&reached.point, &chart, &centre, 2.5, &Vector2::zeros())
            .unwrap();
        let expected = (2.5 - 3.0) / 0.01 * u0;
        assert!(
            (rows.residual - expected).amax() < 1e-12,
            "{}",
            rows.residual
        );
        // With an approach, the chart is about it, whatever the start.
        let approach = Approach {
            direction: [0.0, 0.0, 2.0],
            sigma: 0.1,
        };
        let with = BallTouch {
            approach: Some(approach),
            ..touch.clone()
        };
        let chart = with.chart(&(reached.point - centre)).unwrap();
        assert!((chart.reference() - Vector3::z()).amax() < 1e-15);
        // A touch whose sigma is not positive has no weight.
        let bad = BallTouch::new(0, touch.at.clone(), -1.0);
        let error = bad
            .coordinate_rows(&reached.point, &chart, &centre, 2.5, &Vector2::zeros())
            .unwrap_err();
        assert!(error.to_string().contains("touch sigma"), "{error}");
        assert!(touch.chart(&Vector3::zeros()).is_err());
    }
}
