//! Initial ball centres: the best-fit centre of a ball's contact points with
//! its calibrated radius (docs/paper-scenario.md section 4: "the best-fit centre of its
//! contact points computed by forward kinematics with the design parameters,
//! with the ball's calibrated radius").

use nalgebra::{Matrix3, Matrix4, Vector4};
use parcal_kinematics::Vec3;

/// Why a sphere could not be fitted.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SphereFitError {
    #[error("{count} contact points cannot determine a sphere (at least 4 are needed)")]
    /// Fewer than four points.
    TooFewPoints {
        /// The number of points given.
        count: usize,
    },
    #[error("the contact points are (nearly) coplanar and do not determine a sphere")]
    /// Coplanar points.
    Degenerate,
    #[error("the fit with the calibrated radius did not converge (cost {:.3e} mm^2 after {MAX_ITERATIONS} steps)", last.cost)]
    /// Gauss-Newton with the radius fixed did not converge: the points
    /// leave the centre nearly free along a valley of the cost (a few close
    /// points with errors of a tenth of the radius). `last` is the last
    /// iterate, every step of which went downhill.
    NotConverged {
        /// The last iterate.
        last: SphereFit,
    },
}

/// A centre fitted with a fixed radius.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SphereFit {
    /// The centre (mm).
    pub centre: Vec3,
    /// Its cost `sum_j (|x_j - C| - r)^2` (mm^2).
    pub cost: f64,
}

/// Least-squares centre `C` minimising `sum_j (|x_j - C| - r)^2`, and its
/// cost.
///
/// Starts from the algebraic fit (`|x|^2 = 2 x.C + k`, linear in `C, k`, the
/// radius free), then Gauss-Newton with the radius fixed at `radius`
/// ([`refine_centre`]).
pub fn best_fit(points: &[Vec3], radius: f64) -> Result<SphereFit, SphereFitError> {
    if points.len() < 4 {
        return Err(SphereFitError::TooFewPoints {
            count: points.len(),
        });
    }
    // Centre the points for conditioning.
    let mean = mean(points);
    let (normal, rhs) = algebraic_normal(points, &mean);
    // Determined when the smallest eigenvalue of the normal matrix exceeds
    // `DETERMINED * max diag`: exactly when the matrix less that multiple of
    // `I` is positive definite, which its Cholesky factorisation tells.
    let floor = Matrix4::from_diagonal_element(DETERMINED * normal.diagonal().max());
    if (normal - floor).cholesky().is_none() {
        return Err(SphereFitError::Degenerate);
    }
    let solution = normal
        .cholesky()
        .ok_or(SphereFitError::Degenerate)?
        .solve(&rhs);
    refine_centre(points, radius, &(solution.xyz() + mean))
}

/// The normal equations of the algebraic fit of `points` about `mean`:
/// the rows `(2 d, 1)` and right-hand sides `|d|²`, `d = x - mean`.
fn algebraic_normal(points: &[Vec3], mean: &Vec3) -> (Matrix4<f64>, Vector4<f64>) {
    let (mut normal, mut rhs) = (Matrix4::<f64>::zeros(), Vector4::<f64>::zeros());
    for p in points {
        let d = p - mean;
        let row = Vector4::new(2.0 * d.x, 2.0 * d.y, 2.0 * d.z, 1.0);
        normal += row * row.transpose();
        rhs += row * d.norm_squared();
    }
    (normal, rhs)
}

/// The other local minimum of a fit whose points lie near a circle (a band
/// of a sphere, say): with the radius fixed, the centre is determined only
/// up to its mirror image through the points' plane, and which image fits
/// better can turn on errors of a tenth of the radius. Gauss-Newton
/// ([`refine_centre`]) from the mirror image of `fit.centre` through the
/// least-squares plane of `points`; for points spread over a sphere it falls
/// back to (or near) `fit` itself.
pub fn mirror_fit(
    points: &[Vec3],
    radius: f64,
    fit: &SphereFit,
) -> Result<SphereFit, SphereFitError> {
    let mean = mean(points);
    let scatter = points
        .iter()
        .map(|p| (p - mean) * (p - mean).transpose())
        .sum::<Matrix3<f64>>();
    let eigen = scatter.symmetric_eigen();
    let normal = eigen
        .eigenvectors
        .column(eigen.eigenvalues.imin())
        .into_owned();
    let image = fit.centre - 2.0 * normal * normal.dot(&(fit.centre - mean));
    refine_centre(points, radius, &image)
}

/// `min_C sum_j (|x_j - C| - r)^2` from `start`, every accepted step
/// downhill (step halving): by Gauss-Newton, and a fit Gauss-Newton leaves
/// unconverged by Newton's method from its last iterate.
///
/// Gauss-Newton's matrix `Σ n_j n_jᵀ` (`n_j` the unit vector from the point
/// to the centre) leaves out the residuals' curvature `Σ (r_j / d_j) (I −
/// n_j n_jᵀ)`, `r_j = d_j − r`, `d_j = |x_j − C|`. Where the points leave
/// the centre nearly free along a valley (four nearly coplanar touches, say)
/// that term is as large as the matrix's smallest eigenvalue and
/// Gauss-Newton crawls, each step shorter by a few percent; Newton's
/// method, with the exact Hessian (Gauss-Newton's matrix where the Hessian
/// is not positive definite), ends such a fit.
pub fn refine_centre(
    points: &[Vec3],
    radius: f64,
    start: &Vec3,
) -> Result<SphereFit, SphereFitError> {
    match descend(points, radius, start, Curvature::Left) {
        Err(SphereFitError::NotConverged { last }) => {
            descend(points, radius, &last.centre, Curvature::Exact)
        }
        fit => fit,
    }
}

/// Which matrix the steps of [`descend`] solve with.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Curvature {
    /// Gauss-Newton's, `Σ n_j n_jᵀ`.
    Left,
    /// The exact Hessian (Newton), Gauss-Newton's where it is not positive
    /// definite.
    Exact,
}

/// The descent of [`refine_centre`] from `start`, its steps solved with the
/// matrix `curvature` names.
fn descend(
    points: &[Vec3],
    radius: f64,
    start: &Vec3,
    curvature: Curvature,
) -> Result<SphereFit, SphereFitError> {
    if points.len() < 4 {
        return Err(SphereFitError::TooFewPoints {
            count: points.len(),
        });
    }
    let mean = mean(points);
    let mut centre = start - mean;
    let cost = |c: &Vec3| {
        points
            .iter()
            .map(|p| ((c - (p - mean)).norm() - radius).powi(2))
            .sum::<f64>()
    };
    let mut current = cost(&centre);
    for _ in 0..MAX_ITERATIONS {
        let (mut jtj, mut jtr) = (Matrix3::<f64>::zeros(), Vec3::zeros());
        let mut bend = Matrix3::<f64>::zeros();
        for p in points {
            let d = centre - (p - mean);
            let distance = d.norm();
            let n = d / distance;
            // r_j = |d| - radius, dr_j/dC = n^T, d²r_j/dC² = (I - n nᵀ) / |d|.
            jtj += n * n.transpose();
            jtr += n * (distance - radius);
            if curvature == Curvature::Exact {
                bend +=
                    (Matrix3::identity() - n * n.transpose()) * ((distance - radius) / distance);
            }
        }
        let newton = (curvature == Curvature::Exact)
            .then(|| (jtj + bend).cholesky())
            .flatten();
        let step = match newton {
            Some(hessian) => hessian.solve(&-jtr),
            None => jtj
                .cholesky()
                .ok_or(SphereFitError::Degenerate)?
                .solve(&-jtr),
        };
        // Step halving keeps every accepted step downhill, except a step
        // this short, which ends the fit below: taken as it is, since the
        // change of the cost it makes is below the cost's rounding, which
        // halving would chase for nothing.
        let short = step.norm() < STEP_TOLERANCE_MM;
        let mut scale = 1.0;
        let (next, next_cost) = loop {
            let candidate = centre + scale * step;
            let candidate_cost = cost(&candidate);
            if short || candidate_cost <= current || scale < 1e-6 {
                break (candidate, candidate_cost);
            }
            scale *= 0.5;
        };
        let moved = (next - centre).norm();
        let stationary = current - next_cost <= 1e-15 * current;
        (centre, current) = (next, next_cost);
        if moved < STEP_TOLERANCE_MM || stationary {
            return Ok(SphereFit {
                centre: centre + mean,
                cost: current,
            });
        }
    }
    Err(SphereFitError::NotConverged {
        last: SphereFit {
            centre: centre + mean,
            cost: current,
        },
    })
}

fn mean(points: &[Vec3]) -> Vec3 {
    points.iter().sum::<Vec3>() / points.len() as f64
}

/// The smallest eigenvalue of the algebraic fit's normal matrix, relative
/// to its largest diagonal entry, below which the points do not determine
/// a sphere ([`best_fit`]).
const DETERMINED: f64 = 1e-12;
/// Gauss-Newton steps of the fit before giving up.
const MAX_ITERATIONS: usize = 100;
/// Converged when a step moves the centre less than this (mm): far below
/// anything measurable, and above the rounding of an ill-conditioned fit.
const STEP_TOLERANCE_MM: f64 = 1e-10;

#[cfg(test)]
mod tests {
    use super::*;

    /// `count` points at heights from `low` to `high` (in radii, evenly),
    /// azimuths 2.4 rad apart.
    fn band(centre: Vec3, radius: f64, count: usize, low: f64, high: f64) -> Vec<Vec3> {
        (0..count)
            .map(|k| {
                let (azimuth, t) = (2.4 * k as f64, k as f64 / (count - 1) as f64);
                let height = low + (high - low) * t;
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

    /// `count` points of the lower hemisphere spread from 0.15 radii below
    /// the equator down to near the pole.
    fn hemisphere(centre: Vec3, radius: f64, count: usize) -> Vec<Vec3> {
        let lowest = -0.15 - 0.8 * (count - 1) as f64 / count as f64;
        band(centre, radius, count, -0.15, lowest)
    }

    #[test]
    fn recovers_the_centre_of_exact_points() {
        let centre = Vec3::new(-100.0, 8.4, 399.7);
        let points = hemisphere(centre, 5.0, 7);
        assert!((best_fit(&points, 5.0).unwrap().centre - centre).norm() < 1e-10);
    }

    #[test]
    fn a_wrong_radius_moves_the_centre_not_the_fit() {
        // With radius 5.01 instead of 5 the centre moves along the mean
        // outward direction (up, for the lower hemisphere) by about 0.01.
        let centre = Vec3::new(3.0, -2.0, 360.0);
        let fitted = best_fit(&hemisphere(centre, 5.0, 9), 5.01).unwrap().centre;
        assert!(fitted.z > centre.z && (fitted - centre).norm() < 0.03);
    }

    #[test]
    fn the_mirror_fit_of_a_band_is_its_other_minimum() {
        // A band below the equator: exact points fit the true centre with
        // cost 0; the mirror minimum lies below the band, with a cost that
        // grows with the band's width.
        let centre = Vec3::new(-4.2, -57.5, 442.9);
        let points = band(centre, 5.0, 7, -0.3, -0.1);
        let truth = refine_centre(&points, 5.0, &centre).unwrap();
        assert!(truth.cost < 1e-20 && (truth.centre - centre).norm() < 1e-9);
        let mirror = mirror_fit(&points, 5.0, &truth).unwrap();
        assert!(mirror.centre.z < centre.z - 1.5, "{mirror:?}");
        assert!(mirror.cost > 1e-6, "{mirror:?}");
        // And back: the mirror of the mirror is the truth.
        let back = mirror_fit(&points, 5.0, &mirror).unwrap();
        assert!((back.centre - centre).norm() < 1e-8, "{back:?}");
    }

    #[test]
    fn points_spread_over_a_sphere_have_no_mirror_minimum() {
        let centre = Vec3::new(3.0, -2.0, 360.0);
        let points = hemisphere(centre, 5.0, 9);
        let fit = best_fit(&points, 5.0).unwrap();
        let mirror = mirror_fit(&points, 5.0, &fit).unwrap();
        assert!((mirror.centre - centre).norm() < 1e-8, "{mirror:?}");
    }

    /// Four nearly coplanar touches (within 0.11 mm of a plane, a ball of
    /// radius 5: a held-out ball's first four in a simulated campaign, as
    /// the calibrated machine reaches them): Gauss-Newton crawls along the
    /// valley, each step about 1.4 % shorter, and is not done after
    /// `MAX_ITERATIONS`; Newton's method from there ends at the minimum,
    /// where the cost's gradient vanishes.
    #[test]
    fn a_fit_gauss_newton_leaves_crawling_is_ended_by_newtons_method() {
        let points: Vec<Vec3> = [
            [-45.85108354533189, 9.569813846570174, 338.07137725735265],
            [-36.24129431678285, 10.052983097241643, 338.9867238394597],
            [-40.92024004887761, 9.590703793138843, 334.82111237186353],
            [-40.22435367818155, 9.469269738488087, 334.917758849961],
        ]
        .iter()
        .map(|p| Vec3::new(p[0], p[1], p[2]))
        .collect();
        let radius = 4.998914488424929;
        let start = Vec3::new(-41.176, 9.9926, 339.80);
        let crawled = descend(&points, radius, &start, Curvature::Left);
        let Err(SphereFitError::NotConverged { last }) = crawled else {
            panic!("Gauss-Newton converged: {crawled:?}");
        };
        let fit = refine_centre(&points, radius, &start).unwrap();
        assert!(fit.cost < last.cost, "{fit:?} against {last:?}");
        let gradient: Vec3 = points
            .iter()
            .map(|p| {
                let d = fit.centre - p;
                d / d.norm() * (d.norm() - radius)
            })
            .sum();
        assert!(gradient.norm() < 1e-12, "{gradient:?}");
        // Gauss-Newton stopped 0.3 µm along the valley from the minimum,
        // thousands of its step tolerances.
        let left = (fit.centre - last.centre).norm();
        assert!(left > 1e-4 && left < 1e-3, "{left}");
    }

    #[test]
    fn refuses_degenerate_point_sets() {
        let centre = Vec3::new(0.0, 0.0, 400.0);
        let points = hemisphere(centre, 5.0, 3);
        assert_eq!(
            best_fit(&points, 5.0),
            Err(SphereFitError::TooFewPoints { count: 3 })
        );
        let flat: Vec<Vec3> = (0..6)
            .map(|k| Vec3::new(k as f64, (k * k) as f64, 1.0))
            .collect();
        assert_eq!(best_fit(&flat, 5.0), Err(SphereFitError::Degenerate));
    }

    /// Points of a circle lifted off its plane by `±lift` in turn: from
    /// flat (no sphere) to well spread, through the threshold.
    #[test]
    fn a_fit_is_refused_exactly_when_the_smallest_eigenvalue_is_below_the_threshold() {
        let mut refused = 0;
        for step in 0..400 {
            let lift = 10f64.powf(-9.0 + 0.02 * f64::from(step));
            let points: Vec<Vec3> = (0..7)
                .map(|k| {
                    let angle = 0.9 * f64::from(k);
                    let sign = if k % 2 == 0 { 1.0 } else { -1.0 };
                    Vec3::new(5.0 * angle.cos(), 5.0 * angle.sin(), 400.0 + sign * lift)
                })
                .collect();
            let (normal, _) = algebraic_normal(&points, &mean(&points));
            let smallest = normal.symmetric_eigenvalues().min();
            let threshold = DETERMINED * normal.diagonal().max();
            let fit = best_fit(&points, 5.0);
            refused += usize::from(fit.is_err());
            // Rounding decides within a hair of the threshold.
            if (smallest / threshold - 1.0).abs() > 1e-6 {
                let degenerate = fit == Err(SphereFitError::Degenerate);
                assert_eq!(degenerate, smallest <= threshold, "lift {lift:e}");
            }
        }
        // The sweep crosses the threshold.
        assert!(refused > 0 && refused < 400, "{refused} refused");
    }
}
