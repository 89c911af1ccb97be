//! What one planned touch tells about the unknowns, linearised at the
//! design: its information row on the 33 canonical parameters `p` and its
//! ball's centre `C`.
//!
//! The touch is paper eq. (10), `c = C + r u(θ) − f(q, p)`, three rows with
//! covariance `W` (`parcal_observe::coordinate_covariance`, the propagated
//! actuator, tool and radius repeatabilities at the design's `J_q`). Whitened
//! by `W = L Lᵀ` its Jacobian is `L⁻¹ [−J_f, I, r ∂u/∂θ]`. Without an angle
//! prior (the propagated mode) the two nuisance angles are eliminated by the
//! Schur complement: what is left is the whitened rows projected on the unit
//! normal `n` of the span of `L⁻¹ ∂u/∂θ` (`n ∝ L⁻¹t₁ × L⁻¹t₂`, `t₁, t₂`
//! tangents at `u`), one row
//!
//! ```text
//! h = nᵀ L⁻¹ [−J_f, I]   on (p, C),       information h hᵀ.
//! ```
//!
//! For an isotropic `W = σ² I` it is the radius row of paper eq. (9),
//! `(−uᵀ J_f, uᵀ) / σ`. Everything in the canonical base frame.

use nalgebra::{Matrix3, SVector, Vector3};
use parcal_kinematics::{Canonical, Geometry, N_PARAMS, Vec3, tip_jacobians_at};
use parcal_observe::{Repeatability, WeightModel, coordinate_covariance};

use crate::DesignError;
use crate::pool::{Candidate, NominalBall, tip_pose};

/// The information row of one touch (whitened, dimensionless per mm).
#[derive(Debug, Clone, PartialEq)]
pub struct ContactRow {
    /// The ball whose centre the row involves.
    pub ball: usize,
    /// `h_p` on the 33 parameters.
    pub params: SVector<f64, N_PARAMS>,
    /// `h_C` on the ball's centre.
    pub centre: Vector3<f64>,
}

/// The row of `candidate` on ball `ball` (design frame), linearised at the
/// `design` (design frame) and its canonical form `canonical`, with the
/// machine's `repeatability` (module doc). Errors: a pose where the design's tip derivatives do not exist
/// (singular), or invalid repeatabilities.
pub fn contact_row(
    design: &Geometry,
    canonical: &Canonical,
    ball: &NominalBall,
    candidate: &Candidate,
    repeatability: &Repeatability,
) -> Result<ContactRow, DesignError> {
    let point = ball.centre + ball.radius * candidate.direction;
    let pose = canonical.pose_from_input(&tip_pose(design, &point, candidate.rotation()));
    let jacobians =
        tip_jacobians_at(&canonical.geometry, &pose).map_err(DesignError::Kinematics)?;
    let u = canonical.base_from_input.rotation * candidate.direction;
    let w = coordinate_covariance(WeightModel::Propagated, repeatability, &jacobians.d_q, &u)
        .map_err(DesignError::Observe)?;
    let row = normal_row(&w, &u)?;
    Ok(ContactRow {
        ball: candidate.ball,
        params: -(jacobians.d_params.transpose() * row),
        centre: row,
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
        // W = σ² I (tool noise only): h = (−uᵀ J_f, uᵀ)/σ, and −uᵀ J_f is
        // the derivative of c = r − |f(q, p) − C| at fixed q, checked by
        // central differences through the forward kinematics.
        let design = paper::design();
        let canonical = design.canonicalize().unwrap();
        let sigma = 1e-3;
        let repeatability = Repeatability {
            actuator: 0.0,
            tool: sigma,
            radius: 0.0,
        };
        let c = candidate(Vec3::new(0.3, -0.2, -1.0), [0.1, -0.05, 0.2]);
        let row = contact_row(&design, &canonical, &ball(), &c, &repeatability).unwrap();
        let u = canonical.base_from_input.rotation * c.direction;
        assert!((row.centre - u / sigma).norm() < 1e-9 / sigma);

        let point = ball().centre + ball().radius * c.direction;
        let pose = canonical.pose_from_input(&tip_pose(&design, &point, c.rotation()));
        let q = actuators(&canonical.geometry, &pose);
        let centre = canonical
            .base_from_input
            .transform_point(&ball().centre.into())
            .coords;
        let p0 = params::to_params(&canonical.geometry);
        let residual = |p: &parcal_kinematics::Params| {
            let g = params::from_params(p);
            let solution = forward_from_home(&g, &q, &ForwardOptions::default()).unwrap();
            ball().radius - (g.tool_tip(&solution.pose) - centre).norm()
        };
        let step = 1e-4;
        for k in 0..N_PARAMS {
            let mut plus = p0;
            let mut minus = p0;
            plus[k] += step;
            minus[k] -= step;
            let numeric = (residual(&plus) - residual(&minus)) / (2.0 * step);
            let analytic = row.params[k] * sigma;
            assert!(
                (numeric - analytic).abs() < 1e-6 * (1.0 + analytic.abs()),
                "{}: numeric {numeric}, analytic {analytic}",
                params::PARAM_NAMES[k]
            );
        }
    }

    #[test]
    fn the_row_is_the_schur_complement_of_the_angles() {
        // Propagated (anisotropic) W: the information of the whitened
        // 3-row block with the two angle columns eliminated equals h hᵀ.
        let design = paper::design();
        let canonical = design.canonicalize().unwrap();
        let repeatability = Repeatability {
            actuator: 1e-3,
            tool: 1e-3,
            radius: 1e-3,
        };
        let c = candidate(Vec3::new(-0.5, 0.4, -0.7), [-0.3, 0.2, 0.1]);
        let row = contact_row(&design, &canonical, &ball(), &c, &repeatability).unwrap();

        let point = ball().centre + ball().radius * c.direction;
        let pose = canonical.pose_from_input(&tip_pose(&design, &point, c.rotation()));
        let jacobians = tip_jacobians_at(&canonical.geometry, &pose).unwrap();
        let u = canonical.base_from_input.rotation * c.direction;
        let w = coordinate_covariance(WeightModel::Propagated, &repeatability, &jacobians.d_q, &u)
            .unwrap();
        let l_inv = w.cholesky().unwrap().l().try_inverse().unwrap();
        // Any two tangents span the same angle columns as r ∂u/∂θ.
        let t1 = u.cross(&Vec3::z()).normalize();
        let t2 = u.cross(&t1);
        let mut block = SMatrix::<f64, 3, { N_PARAMS + 5 }>::zeros();
        block
            .fixed_view_mut::<3, N_PARAMS>(0, 0)
            .copy_from(&(-jacobians.d_params));
        block
            .fixed_view_mut::<3, 3>(0, N_PARAMS)
            .fill_with_identity();
        block
            .fixed_view_mut::<3, 1>(0, N_PARAMS + 3)
            .copy_from(&(5.0 * t1));
        block
            .fixed_view_mut::<3, 1>(0, N_PARAMS + 4)
            .copy_from(&(5.0 * t2));
        let whitened = DMatrix::from_iterator(3, N_PARAMS + 5, (l_inv * block).iter().copied());
        let full = whitened.transpose() * &whitened;
        let n = N_PARAMS + 3;
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
        h.view_mut((N_PARAMS, 0), (3, 1)).copy_from(&row.centre);
        let difference = (&schur - &h * h.transpose()).amax();
        assert!(
            difference < 1e-6 * schur.amax(),
            "{difference:e} of {:e}",
            schur.amax()
        );
    }
}
