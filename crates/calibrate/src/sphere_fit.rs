//! Initial ball centres: the best-fit centre of a ball's contact points with
//! its calibrated radius (spec section 4: "the best-fit centre of its
//! contact points computed by forward kinematics with the design parameters,
//! with the ball's calibrated radius").

use nalgebra::{Matrix3, Matrix4, Vector4};
use parcal_kinematics::Vec3;

/// Why a sphere could not be fitted.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SphereFitError {
    #[error("{count} contact points cannot determine a sphere (at least 4 are needed)")]
    TooFewPoints { count: usize },
    #[error("the contact points are (nearly) coplanar and do not determine a sphere")]
    Degenerate,
    #[error("the fit with the calibrated radius did not converge")]
    NotConverged,
}

/// Least-squares centre `C` minimising `sum_j (|x_j - C| - r)^2`.
///
/// Starts from the algebraic fit (`|x|^2 = 2 x.C + k`, linear in `C, k`, the
/// radius free), then Gauss-Newton with the radius fixed at `radius`.
pub fn fit_centre(points: &[Vec3], radius: f64) -> Result<Vec3, SphereFitError> {
    if points.len() < 4 {
        return Err(SphereFitError::TooFewPoints {
            count: points.len(),
        });
    }
    // Centre the points for conditioning.
    let mean = points.iter().sum::<Vec3>() / points.len() as f64;
    let (mut normal, mut rhs) = (Matrix4::<f64>::zeros(), Vector4::<f64>::zeros());
    for p in points {
        let d = p - mean;
        let row = Vector4::new(2.0 * d.x, 2.0 * d.y, 2.0 * d.z, 1.0);
        normal += row * row.transpose();
        rhs += row * d.norm_squared();
    }
    let scale = normal.diagonal().max();
    let eigen = normal.symmetric_eigenvalues();
    let determined = eigen.min() > 1e-12 * scale;
    if !determined {
        return Err(SphereFitError::Degenerate);
    }
    let solution = normal
        .cholesky()
        .ok_or(SphereFitError::Degenerate)?
        .solve(&rhs);
    let mut centre = solution.xyz();
    let cost = |c: &Vec3| {
        points
            .iter()
            .map(|p| ((c - (p - mean)).norm() - radius).powi(2))
            .sum::<f64>()
    };
    let mut current = cost(&centre);
    for _ in 0..MAX_ITERATIONS {
        let (mut jtj, mut jtr) = (Matrix3::<f64>::zeros(), Vec3::zeros());
        for p in points {
            let d = centre - (p - mean);
            let distance = d.norm();
            let n = d / distance;
            // r_j = |d| - radius, dr_j/dC = n^T.
            jtj += n * n.transpose();
            jtr += n * (distance - radius);
        }
        let step = jtj
            .cholesky()
            .ok_or(SphereFitError::Degenerate)?
            .solve(&-jtr);
        // Step halving keeps every accepted step downhill.
        let mut scale = 1.0;
        let (next, next_cost) = loop {
            let candidate = centre + scale * step;
            let candidate_cost = cost(&candidate);
            if candidate_cost <= current || scale < 1e-6 {
                break (candidate, candidate_cost);
            }
            scale *= 0.5;
        };
        let moved = (next - centre).norm();
        let stationary = current - next_cost <= 1e-15 * current;
        (centre, current) = (next, next_cost);
        if moved < STEP_TOLERANCE_MM || stationary {
            return Ok(centre + mean);
        }
    }
    Err(SphereFitError::NotConverged)
}

/// Gauss-Newton steps of the fit before giving up.
const MAX_ITERATIONS: usize = 100;
/// Converged when a step moves the centre less than this (mm): far below
/// anything measurable, and above the rounding of an ill-conditioned fit.
const STEP_TOLERANCE_MM: f64 = 1e-10;

#[cfg(test)]
mod tests {
    use super::*;

    fn hemisphere(centre: Vec3, radius: f64, count: usize) -> Vec<Vec3> {
        (0..count)
            .map(|k| {
                let (azimuth, height) = (2.4 * k as f64, -0.15 - 0.8 * (k as f64 / count as f64));
                let horizontal = (1.0 - height * height).sqrt();
                centre
                    + radius
                        * Vec3::new(
                            horizontal * azimuth.cos(),
                            horizontal * azimuth.sin(),
                            height,
                        )
            })
            .collect()
    }

    #[test]
    fn recovers_the_centre_of_exact_points() {
        let centre = Vec3::new(-100.0, 8.4, 399.7);
        let points = hemisphere(centre, 5.0, 7);
        assert!((fit_centre(&points, 5.0).unwrap() - centre).norm() < 1e-10);
    }

    #[test]
    fn a_wrong_radius_moves_the_centre_not_the_fit() {
        // With radius 5.01 instead of 5 the centre moves along the mean
        // outward direction (up, for the lower hemisphere) by about 0.01.
        let centre = Vec3::new(3.0, -2.0, 360.0);
        let fitted = fit_centre(&hemisphere(centre, 5.0, 9), 5.01).unwrap();
        assert!(fitted.z > centre.z && (fitted - centre).norm() < 0.03);
    }

    #[test]
    fn refuses_degenerate_point_sets() {
        let centre = Vec3::new(0.0, 0.0, 400.0);
        let points = hemisphere(centre, 5.0, 3);
        assert_eq!(
            fit_centre(&points, 5.0),
            Err(SphereFitError::TooFewPoints { count: 3 })
        );
        let flat: Vec<Vec3> = (0..6)
            .map(|k| Vec3::new(k as f64, (k * k) as f64, 1.0))
            .collect();
        assert_eq!(fit_centre(&flat, 5.0), Err(SphereFitError::Degenerate));
    }
}
