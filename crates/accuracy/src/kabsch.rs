//! Best rigid motion between two point sets (Kabsch 1976), proper rotation,
//! no scale.
//!
//! Given points `p_k` and their targets `q_k`, find the rotation `R`
//! (`det R = +1`) and translation `t` minimising `sum |R p_k + t - q_k|^2`.
//! With the centroids `p̄`, `q̄` and the cross-covariance
//! `H = sum (p_k - p̄)(q_k - q̄)^T = U S V^T` (SVD),
//!
//! ```text
//! R = V diag(1, 1, d) U^T,   d = sign det(V U^T),   t = q̄ - R p̄.
//! ```
//!
//! `d = -1` is the reflection case: the unconstrained optimum is a
//! reflection (always a risk for planar clouds such as the map grid, whose
//! `H` has a zero singular value), and the best proper rotation flips the
//! singular direction of the smallest singular value.

use nalgebra::{Matrix3, Rotation3};
use parcal_kinematics::Vec3;

use crate::AccuracyError;

/// A rigid motion `x -> R x + t` (mm).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RigidMotion {
    /// The proper rotation `R`.
    pub rotation: Rotation3<f64>,
    /// The translation `t` (mm).
    pub translation: Vec3,
}

impl RigidMotion {
    /// `R x + t`.
    pub fn apply(&self, x: &Vec3) -> Vec3 {
        self.rotation * x + self.translation
    }
}

/// The rigid motion that best maps `points` onto `targets` in the least-
/// squares sense (see the module doc). Errors: sets of different lengths,
/// fewer than three points, non-finite coordinates.
pub fn kabsch(points: &[Vec3], targets: &[Vec3]) -> Result<RigidMotion, AccuracyError> {
    let refuse = |reason: String| Err(AccuracyError::Registration { reason });
    if points.len() != targets.len() {
        return refuse(format!(
            "{} points but {} targets",
            points.len(),
            targets.len()
        ));
    }
    if points.len() < 3 {
        return refuse(format!("{} point(s); at least 3 are needed", points.len()));
    }
    let finite = |set: &[Vec3]| set.iter().all(|p| p.iter().all(|v| v.is_finite()));
    if !finite(points) || !finite(targets) {
        return refuse("a coordinate is not finite".to_string());
    }
    let centroid = |set: &[Vec3]| set.iter().sum::<Vec3>() / set.len() as f64;
    let (p_bar, q_bar) = (centroid(points), centroid(targets));
    let h: Matrix3<f64> = points
        .iter()
        .zip(targets)
        .map(|(p, q)| (p - p_bar) * (q - q_bar).transpose())
        .sum();
    let svd = h.svd(true, true);
    let (Some(u), Some(v_t)) = (svd.u, svd.v_t) else {
        return refuse("the singular value decomposition failed".to_string());
    };
    let mut v = v_t.transpose();
    if (v * u.transpose()).determinant() < 0.0 {
        // Reflection: flip the direction of the smallest singular value.
        let smallest = svd.singular_values.imin();
        v.column_mut(smallest).neg_mut();
    }
    let rotation = Rotation3::from_matrix_unchecked(v * u.transpose());
    let translation = q_bar - rotation * p_bar;
    Ok(RigidMotion {
        rotation,
        translation,
    })
}

/// The residuals `R p_k + t - q_k` after the best rigid motion of `points`
/// onto `targets` ([`kabsch`]), with that motion.
pub fn registered_residuals(
    points: &[Vec3],
    targets: &[Vec3],
) -> Result<(Vec<Vec3>, RigidMotion), AccuracyError> {
    let motion = kabsch(points, targets)?;
    let residuals = points
        .iter()
        .zip(targets)
        .map(|(p, q)| motion.apply(p) - q)
        .collect();
    Ok((residuals, motion))
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{Unit, UnitQuaternion};
    use rand::rngs::StdRng;
    use rand::{RngExt, SeedableRng};

    /// Entries uniform in [-scale, scale).
    fn random_vector(rng: &mut StdRng, scale: f64) -> Vec3 {
        Vec3::from_fn(|_, _| rng.random_range(-scale..scale))
    }

    /// A rotation by an angle uniform in [0, π) about a random axis.
    fn random_rotation(rng: &mut StdRng) -> Rotation3<f64> {
        let axis = Unit::new_normalize(random_vector(rng, 1.0));
        let angle = rng.random_range(0.0..std::f64::consts::PI);
        UnitQuaternion::from_axis_angle(&axis, angle).to_rotation_matrix()
    }

    fn max_residual(points: &[Vec3], targets: &[Vec3]) -> f64 {
        let (residuals, _) = registered_residuals(points, targets).unwrap();
        residuals.iter().map(|r| r.norm()).fold(0.0, f64::max)
    }

    #[test]
    fn recovers_a_known_rigid_motion() {
        let mut rng = StdRng::seed_from_u64(7);
        for trial in 0..20 {
            let points: Vec<Vec3> = (0..30).map(|_| random_vector(&mut rng, 100.0)).collect();
            let truth = RigidMotion {
                rotation: random_rotation(&mut rng),
                translation: random_vector(&mut rng, 500.0),
            };
            let targets: Vec<Vec3> = points.iter().map(|p| truth.apply(p)).collect();
            let found = kabsch(&points, &targets).unwrap();
            let off = (found.rotation.matrix() - truth.rotation.matrix()).norm();
            assert!(off < 1e-12, "trial {trial}: rotation off by {off:e}");
            assert!((found.translation - truth.translation).norm() < 1e-10);
            assert!(max_residual(&points, &targets) < 1e-10);
        }
    }

    #[test]
    fn planar_clouds_get_a_proper_rotation() {
        // A planar cloud (the map grid's case): H has a zero singular value
        // and its third singular direction has an arbitrary sign.
        let mut rng = StdRng::seed_from_u64(11);
        for trial in 0..20 {
            let points: Vec<Vec3> = (0..25)
                .map(|_| {
                    let p = random_vector(&mut rng, 100.0);
                    Vec3::new(p.x, p.y, 400.0)
                })
                .collect();
            let truth = RigidMotion {
                rotation: random_rotation(&mut rng),
                translation: random_vector(&mut rng, 50.0),
            };
            let targets: Vec<Vec3> = points.iter().map(|p| truth.apply(p)).collect();
            let found = kabsch(&points, &targets).unwrap();
            assert!((found.rotation.matrix().determinant() - 1.0).abs() < 1e-12);
            let off = (found.rotation.matrix() - truth.rotation.matrix()).norm();
            assert!(off < 1e-12, "trial {trial}: rotation off by {off:e}");
            assert!(max_residual(&points, &targets) < 1e-10);
        }
    }

    #[test]
    fn a_mirrored_cloud_gets_the_best_proper_rotation_not_a_reflection() {
        // Box corners with spreads 40 > 20 > 5 along x, y, z, mirrored in
        // z, then moved rigidly. The unconstrained optimum is the reflection;
        // the best proper rotation keeps x and y and is the rigid part.
        let corners: Vec<Vec3> = (0..8)
            .map(|k| {
                let s = |bit: usize| if k >> bit & 1 == 1 { 1.0 } else { -1.0 };
                Vec3::new(40.0 * s(0), 20.0 * s(1), 5.0 * s(2))
            })
            .collect();
        let mut rng = StdRng::seed_from_u64(3);
        let rigid = RigidMotion {
            rotation: random_rotation(&mut rng),
            translation: random_vector(&mut rng, 100.0),
        };
        let targets: Vec<Vec3> = corners
            .iter()
            .map(|p| rigid.apply(&Vec3::new(p.x, p.y, -p.z)))
            .collect();
        let found = kabsch(&corners, &targets).unwrap();
        assert!((found.rotation.matrix().determinant() - 1.0).abs() < 1e-12);
        assert!((found.rotation.matrix() - rigid.rotation.matrix()).norm() < 1e-12);
        assert!((found.translation - rigid.translation).norm() < 1e-10);
        // The residual of each corner is its z mirrored: 2 * 5 mm.
        let (residuals, _) = registered_residuals(&corners, &targets).unwrap();
        for r in residuals {
            assert!((r.norm() - 10.0).abs() < 1e-9);
        }
    }

    #[test]
    fn refuses_unusable_sets() {
        let p = vec![Vec3::zeros(); 3];
        let message = kabsch(&p, &p[..2]).unwrap_err().to_string();
        assert!(message.contains("3 points but 2 targets"), "{message}");
        assert!(kabsch(&p[..2], &p[..2]).is_err());
        let mut q = p.clone();
        q[1].x = f64::NAN;
        assert!(kabsch(&p, &q).is_err());
    }
}
