//! What one planned touch tells about the unknowns, linearised at the
//! design: its information row on the 33 canonical parameters `p` and its
//! ball's unknowns, the centre `C` and the radius `r`.
//!
//! The touch is paper eq. (10), `c = C + r u(θ) − f(q, p)`, three rows with
//! covariance `W` (`parcal_observe::coordinate_covariance`, the propagated
//! actuator and tool repeatabilities at the design's `J_q`, and the radius
//! sigma `σ_r` only when the radius error is taken per contact). Whitened
//! by `W = L Lᵀ` its Jacobian is `L⁻¹ [−J_f, I, u, r ∂u/∂θ]`. Without an
//! angle prior (the propagated mode) the two nuisance angles are eliminated
//! by the Schur complement: what is left is the whitened rows projected on
//! the unit normal `n` of the span of `L⁻¹ ∂u/∂θ` (`n ∝ L⁻¹t₁ × L⁻¹t₂`,
//! `t₁, t₂` tangents at `u`), one row
//!
//! ```text
//! h = nᵀ L⁻¹ [−J_f, I, u]   on (p, C, r),       information h hᵀ.
//! ```
//!
//! The radius part follows `parcal calibrate`'s [`RadiusModel`]: with
//! [`RadiusModel::PerBall`] (its default) each ball's radius is an unknown
//! shared by its touches, `σ_r` leaves `W` and the radius gets the prior
//! `1/σ_r²` (`crate::prior_information`); with [`RadiusModel::PerContact`]
//! the calibrated radius is data, `σ_r` is in `W` and the radius part of
//! `h` is zero (the radius then stays at its prior, uncoupled).
//!
//! For an isotropic `W = σ² I` it is the radius row of paper eq. (9),
//! `(−uᵀ J_f, uᵀ, 1) / σ`. Everything in the canonical base frame.

use nalgebra::{Matrix3, SVector, Vector3};
use parcal_calibrate::RadiusModel;
use parcal_kinematics::{Canonical, Geometry, N_PARAMS, Vec3, tip_jacobians_at};
use parcal_observe::{Repeatability, WeightModel, coordinate_covariance};

use crate::DesignError;
use crate::pool::{Candidate, NominalBall, tip_pose};

/// The unknowns of a ball: its centre, then its radius.
pub const BALL_UNKNOWNS: usize = 4;

/// A row on one ball's unknowns (centre, then radius).
pub type BallRow = SVector<f64, BALL_UNKNOWNS>;

/// The information row of one touch (whitened, dimensionless per mm).
#[derive(Debug, Clone, PartialEq)]
pub struct ContactRow {
    /// The ball whose unknowns the row involves.
    pub ball: usize,
    /// `h_p` on the 33 parameters.
    pub params: SVector<f64, N_PARAMS>,
    /// `(h_C, h_r)` on the ball's centre and radius.
    pub on_ball: BallRow,
}

impl ContactRow {
    /// `h_C`, the part on the ball's centre.
    pub fn centre(&self) -> Vector3<f64> {
        self.on_ball.fixed_rows::<3>(0).into_owned()
    }
}

/// The row of `candidate` on ball `ball` (design frame), linearised at the
/// `design` (design frame) and its canonical form `canonical`, with the
/// machine's `repeatability` (its `radius` the ball's calibrated sigma)
/// and the calibration's `radius` model (module doc). Errors: a pose where
/// the design's tip derivatives do not exist (singular), or invalid
/// repeatabilities.
pub fn contact_row(
    design: &Geometry,
    canonical: &Canonical,
    ball: &NominalBall,
    candidate: &Candidate,
    repeatability: &Repeatability,
    radius: RadiusModel,
) -> Result<ContactRow, DesignError> {
    let point = ball.centre + ball.radius * candidate.direction;
    let pose = canonical.pose_from_input(&tip_pose(design, &point, candidate.rotation()));
    let jacobians =
        tip_jacobians_at(&canonical.geometry, &pose).map_err(DesignError::Kinematics)?;
    let u = canonical.base_from_input.rotation * candidate.direction;
    let weighted = Repeatability {
        radius: match radius {
            RadiusModel::PerBall => 0.0,
            RadiusModel::PerContact => repeatability.radius,
        },
        ..*repeatability
    };
    let w = coordinate_covariance(WeightModel::Propagated, &weighted, &jacobians.d_q, &u)
        .map_err(DesignError::Observe)?;
    let row = normal_row(&w, &u)?;
    let on_radius = match radius {
        RadiusModel::PerBall => row.dot(&u),
        RadiusModel::PerContact => 0.0,
    };
    Ok(ContactRow {
        ball: candidate.ball,
        params: -(jacobians.d_params.transpose() * row),
        on_ball: BallRow::new(row.x, row.y, row.z, on_radius),
    })
}

/// `L⁻ᵀ n` (so that `h x = (L⁻ᵀ n)ᵀ x`) for the covariance `w` and the
/// unit direction `u` (module doc).
fn normal_row(w: &Matrix3<f64>, u: &Vec3) -> Result<Vector3<f64>, DesignError> {
    let cholesky = w.cholesky().ok_or(DesignError::TouchCovariance)?;
    let l = cholesky.l();
    let t1 = u
        .cross(&if u.x.abs() < 0.9 {
            Vec3::x()
        } else {
            Vec3::y()
        })
        .normalize();
    let t2 = u.cross(&t1);
    let solve = |t: &Vec3| l.solve_lower_triangular(t).expect("L is invertible");
    let n = solve(&t1).cross(&solve(&t2)).normalize();
    Ok(l.transpose()
        .solve_upper_triangular(&n)
        .expect("Lᵀ is invertible"))
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{DMatrix, SMatrix};
    use parcal_kinematics::{ForwardOptions, actuators, forward_from_home, paper, params};

    fn candidate(direction: Vec3, angles: [f64; 3]) -> Candidate {
        Candidate {
            ball: 0,
            direction: direction.normalize(),
            angles,
            q: [0.0; 6],
        }
    }

    fn ball() -> NominalBall {
        NominalBall {
            centre: Vec3::new(40.0, -30.0, 380.0),
            radius: 5.0,
        }
    }

    #[test]
    fn isotropic_noise_gives_the_radius_row_against_central_differences() {
        // W = σ² I (tool noise only): h = (−uᵀ J_f, uᵀ, 1)/σ, and (−uᵀ J_f, 1)
        // are the derivatives of c = r − |f(q, p) − C| at fixed q in p and
        // r, checked by central differences through the forward kinematics.
        // The ball's radius sigma leaves W when the radius is an unknown.
        let design = paper::design();
        let canonical = design.canonicalize().unwrap();
        let sigma = 1e-3;
        let repeatability = Repeatability {
            actuator: 0.0,
            tool: sigma,
            radius: 2e-3,
        };
        let c = candidate(Vec3::new(0.3, -0.2, -1.0), [0.1, -0.05, 0.2]);
        let row = contact_row(
            &design,
            &canonical,
            &ball(),
            &c,
            &repeatability,
            RadiusModel::PerBall,
        )
        .unwrap();
        let u = canonical.base_from_input.rotation * c.direction;
        assert!((row.centre() - u / sigma).norm() < 1e-9 / sigma);

        let point = ball().centre + ball().radius * c.direction;
        let pose = canonical.pose_from_input(&tip_pose(&design, &point, c.rotation()));
        let q = actuators(&canonical.geometry, &pose);
        let centre = canonical
            .base_from_input
            .transform_point(&ball().centre.into())
            .coords;
        let p0 = params::to_params(&canonical.geometry);
        let residual = |p: &parcal_kinematics::Params, r: f64| {
            let g = params::from_params(p);
            let solution = forward_from_home(&g, &q, &ForwardOptions::default()).unwrap();
            r - (g.tool_tip(&solution.pose) - centre).norm()
        };
        let step = 1e-4;
        for k in 0..N_PARAMS {
            let mut plus = p0;
            let mut minus = p0;
            plus[k] += step;
            minus[k] -= step;
            let numeric =
                (residual(&plus, ball().radius) - residual(&minus, ball().radius)) / (2.0 * step);
            let analytic = row.params[k] * sigma;
            assert!(
                (numeric - analytic).abs() < 1e-6 * (1.0 + analytic.abs()),
                "{}: numeric {numeric}, analytic {analytic}",
                params::PARAM_NAMES[k]
            );
        }
        let r = ball().radius;
        let numeric = (residual(&p0, r + step) - residual(&p0, r - step)) / (2.0 * step);
        let analytic = row.on_ball[3] * sigma;
        assert!(
            (numeric - analytic).abs() < 1e-6,
            "radius: numeric {numeric}, analytic {analytic}"
        );
    }

    #[test]
    fn the_row_is_the_schur_complement_of_the_angles() {
        // Propagated (anisotropic) W: the information of the whitened
        // 3-row block on (p, C, r, θ) with the two angle columns eliminated
        // equals h hᵀ. Per ball the radius column is u and σ_r is out of W;
        // per contact the radius is data (a zero column) and σ_r is in W.
        let design = paper::design();
        let canonical = design.canonicalize().unwrap();
        let repeatability = Repeatability {
            actuator: 1e-3,
            tool: 1e-3,
            radius: 1e-3,
        };
        let c = candidate(Vec3::new(-0.5, 0.4, -0.7), [-0.3, 0.2, 0.1]);
        let point = ball().centre + ball().radius * c.direction;
        let pose = canonical.pose_from_input(&tip_pose(&design, &point, c.rotation()));
        let jacobians = tip_jacobians_at(&canonical.geometry, &pose).unwrap();
        let u = canonical.base_from_input.rotation * c.direction;
        // Any two tangents span the same angle columns as r ∂u/∂θ.
        let t1 = u.cross(&Vec3::z()).normalize();
        let t2 = u.cross(&t1);
        for model in [RadiusModel::PerBall, RadiusModel::PerContact] {
            let row = contact_row(&design, &canonical, &ball(), &c, &repeatability, model).unwrap();
            let (radius_column, radius_sigma) = match model {
                RadiusModel::PerBall => (u, 0.0),
                RadiusModel::PerContact => (Vec3::zeros(), repeatability.radius),
            };
            let weighted = Repeatability {
                radius: radius_sigma,
                ..repeatability
            };
            let w = coordinate_covariance(WeightModel::Propagated, &weighted, &jacobians.d_q, &u)
                .unwrap();
            let l_inv = w.cholesky().unwrap().l().try_inverse().unwrap();
            let n = N_PARAMS + BALL_UNKNOWNS;
            let mut block = SMatrix::<f64, 3, { N_PARAMS + BALL_UNKNOWNS + 2 }>::zeros();
            block
                .fixed_view_mut::<3, N_PARAMS>(0, 0)
                .copy_from(&(-jacobians.d_params));
            block
                .fixed_view_mut::<3, 3>(0, N_PARAMS)
                .fill_with_identity();
            block
                .fixed_view_mut::<3, 1>(0, N_PARAMS + 3)
                .copy_from(&radius_column);
            block.fixed_view_mut::<3, 1>(0, n).copy_from(&(5.0 * t1));
            block
                .fixed_view_mut::<3, 1>(0, n + 1)
                .copy_from(&(5.0 * t2));
            let whitened = DMatrix::from_iterator(3, n + 2, (l_inv * block).iter().copied());
            let full = whitened.transpose() * &whitened;
            let kept = full.view((0, 0), (n, n));
            let cross = full.view((0, n), (n, 2));
            let angles = full
                .view((n, n), (2, 2))
                .clone_owned()
                .try_inverse()
                .unwrap();
            let schur = kept - cross * angles * cross.transpose();
            let mut h = DMatrix::zeros(n, 1);
            h.view_mut((0, 0), (N_PARAMS, 1)).copy_from(&row.params);
            h.view_mut((N_PARAMS, 0), (BALL_UNKNOWNS, 1))
                .copy_from(&row.on_ball);
            let difference = (&schur - &h * h.transpose()).amax();
            assert!(
                difference < 1e-6 * schur.amax(),
                "{model}: {difference:e} of {:e}",
                schur.amax()
            );
        }
    }
}
