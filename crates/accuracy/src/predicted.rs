//! Predicted accuracy maps: the parameter covariance propagated to the tool
//! tip (docs/paper-scenario.md section 5, paper figs. 3, 7, 10).
//!
//! At each target the model's tip Jacobian `J_k = d f(q_k, p) / d p` (3 x 33,
//! at fixed actuator values) gives the tip covariance `J_k Σ_p J_kᵀ`; the
//! absolute map is `sqrt(trace)` of it.
//!
//! The registered map removes what a rigid registration of the whole grid
//! absorbs. Linearised, the best rigid motion of the tips onto the targets
//! removes the component of the stacked tip error `δ = J δp` (3N) in the
//! span of the rigid-motion directions of the target cloud, `B` (3N x 6),
//! with rows `B_k = [I, -[c_k - c̄]x]` (translation, small rotation about
//! the centroid `c̄`). With `P = I - B (BᵀB)⁻¹ Bᵀ`,
//!
//! ```text
//! Σ_reg = (P J) Σ_p (P J)ᵀ,   (P J)_k = J_k - B_k M,   M = (BᵀB)⁻¹ Σ_k B_kᵀ J_k,
//! ```
//!
//! so only the 6 x 6 `BᵀB` and the 6 x 33 `BᵀJ` are formed, never a 3N x 3N
//! matrix, and the map is `sqrt(trace)` of each 3 x 3 diagonal block.
//!
//! `P` never increases the total, `sum_k trace Σ_reg,k <= sum_k trace Σ_k`,
//! but one point's registered value can exceed its absolute one (a rigid fit
//! of the whole grid may move a point whose own error is small); on the
//! paper's maps it does not happen (tested).

use nalgebra::{Matrix3x6, Matrix6, SMatrix};
use parcal_kinematics::{N_PARAMS, PARAM_NAMES, ParamCovariance, Params, Vec3, tip_jacobians_at};

use crate::model::{commands, model_geometry, unreachable};
use crate::{AccuracyError, AccuracyMap, CanonicalTargets, MapGrid};

/// Relative size of a negative tip variance still taken as rounding (and
/// reported as 0); anything more negative means the covariance is not
/// positive semi-definite.
const ROUNDING: f64 = 1e-10;

/// The predicted accuracy map of a model with canonical parameters `model`
/// and covariance `covariance` (mm², the prior before calibration, the
/// posterior after) on `grid`, whose targets and orientation are mapped into
/// the canonical frames by the `design` geometry's transforms
/// ([`CanonicalTargets`]), docs/paper-scenario.md section 5; values in mm.
///
/// Errors: an invalid grid or design, non-finite model or covariance, a
/// target the model cannot reach (infeasible leg or singular pose, naming the
/// grid point), a covariance that is not positive semi-definite.
pub fn predicted(
    design: &parcal_kinematics::Geometry,
    model: &Params,
    covariance: &ParamCovariance,
    grid: &MapGrid,
) -> Result<AccuracyMap, AccuracyError> {
    predicted_at(&CanonicalTargets::new(design, grid)?, model, covariance)
}

/// [`predicted`] at targets already mapped into the canonical frames (by
/// whichever geometry's transforms, see [`CanonicalTargets::new`]).
pub fn predicted_at(
    targets: &CanonicalTargets,
    model: &Params,
    covariance: &ParamCovariance,
) -> Result<AccuracyMap, AccuracyError> {
    let grid = &targets.grid;
    let geometry = model_geometry(model)?;
    if let Some(k) = covariance.iter().position(|v| !v.is_finite()) {
        let (row, column) = (k % N_PARAMS, k / N_PARAMS);
        let what = format!(
            "covariance entry ({}, {})",
            PARAM_NAMES[row], PARAM_NAMES[column]
        );
        return Err(AccuracyError::NonFinite { what });
    }
    let points: Vec<Vec3> = grid.points().collect();
    let mut jacobians = target_jacobians(targets, &geometry)?;
    let absolute = tip_sigmas(&jacobians, covariance, &points)?;
    remove_rigid_motions(&targets.points, &mut jacobians)?;
    let registered = tip_sigmas(&jacobians, covariance, &points)?;
    Ok(AccuracyMap {
        grid: grid.clone(),
        absolute,
        registered,
    })
}

/// The registered tip Jacobians `(P J)_k` (3 x 33 per target, map order)
/// of the model `model` at `targets`: the registered tip covariance of any
/// parameter covariance `Σ_p` is `(P J)_k Σ_p (P J)_kᵀ` (module doc). What a
/// measurement design needs to predict the registered map of a design it
/// has not measured yet.
pub fn registered_jacobians(
    targets: &CanonicalTargets,
    model: &Params,
) -> Result<Vec<SMatrix<f64, 3, N_PARAMS>>, AccuracyError> {
    let mut jacobians = target_jacobians(targets, &model_geometry(model)?)?;
    remove_rigid_motions(&targets.points, &mut jacobians)?;
    Ok(jacobians)
}

/// `J_k = d f(q_k, p) / d p` of `geometry` commanded to each target.
fn target_jacobians(
    targets: &CanonicalTargets,
    geometry: &parcal_kinematics::Geometry,
) -> Result<Vec<SMatrix<f64, 3, N_PARAMS>>, AccuracyError> {
    commands(geometry, targets)?
        .iter()
        .zip(targets.grid.points())
        .map(|(command, point)| {
            tip_jacobians_at(geometry, &command.pose)
                .map(|tip| tip.d_params)
                .map_err(|source| unreachable(&point, source))
        })
        .collect()
}

/// `sqrt(trace(J_k Σ J_kᵀ))` per point (mm). A negative trace is measured
/// against `trace(|J_k| |Σ| |J_k|ᵀ)`, the size of its terms: within
/// [`ROUNDING`] of it, it is rounding.
fn tip_sigmas(
    jacobians: &[SMatrix<f64, 3, N_PARAMS>],
    covariance: &ParamCovariance,
    points: &[Vec3],
) -> Result<Vec<f64>, AccuracyError> {
    // Column `l` of `Σᵀ` is row `l` of `Σ`.
    let rows = covariance.transpose();
    jacobians
        .iter()
        .zip(points)
        .map(|(j, point)| {
            let variance = tip_variance(j, &rows);
            if variance >= 0.0 {
                return Ok(variance.sqrt());
            }
            let scale = (j.abs() * covariance.abs()).component_mul(&j.abs()).sum();
            if variance >= -ROUNDING * scale {
                Ok(0.0)
            } else {
                Err(AccuracyError::NotPositiveSemidefinite {
                    x: point.x,
                    y: point.y,
                    variance,
                })
            }
        })
        .collect()
}

/// `trace(J Σ Jᵀ) = Σ_c Σ_r (J Σ)[r, c] J[r, c]` from `rows = Σᵀ`, with
/// the sums of `(J * Σ).component_mul(J).sum()`: `(J Σ)[r, c] = Σ_l J[r,
/// l] Σ[l, c]` over `l` in order, then the terms column by column from 0.
/// Each row `r` of `J Σ` is built a row of `Σ` at a time, its columns side
/// by side.
fn tip_variance(j: &SMatrix<f64, 3, N_PARAMS>, rows: &ParamCovariance) -> f64 {
    let mut j_sigma = [[0.0; N_PARAMS]; 3];
    for (r, out) in j_sigma.iter_mut().enumerate() {
        let mut sigma_rows = rows.as_slice().chunks_exact(N_PARAMS).enumerate();
        if let Some((_, first)) = sigma_rows.next() {
            for (o, s) in out.iter_mut().zip(first) {
                *o = j[(r, 0)] * s;
            }
        }
        for (l, row) in sigma_rows {
            let a = j[(r, l)];
            for (o, s) in out.iter_mut().zip(row) {
                *o += a * s;
            }
        }
    }
    let mut variance = 0.0;
    for c in 0..N_PARAMS {
        for (r, row) in j_sigma.iter().enumerate() {
            variance += row[c] * j[(r, c)];
        }
    }
    variance
}

/// Replaces each 3 x C block `J_k` of the stacked Jacobian `J` (3N x C) by
/// the block of `P J`, `P` the orthogonal projector that removes the six
/// rigid-motion directions of the cloud `points` (see the module doc), in
/// O(N C) memory. After it, `J δ` has no component that a rigid motion of
/// the cloud can absorb, for any `δ`. Errors: fewer than three points, or
/// collinear points (no unique rigid registration).
pub fn remove_rigid_motions<const C: usize>(
    points: &[Vec3],
    jacobians: &mut [SMatrix<f64, 3, C>],
) -> Result<(), AccuracyError> {
    let refuse = |reason: String| Err(AccuracyError::Registration { reason });
    if points.len() != jacobians.len() {
        return refuse(format!(
            "{} points but {} Jacobian blocks",
            points.len(),
            jacobians.len()
        ));
    }
    if points.len() < 3 {
        return refuse(format!("{} point(s); at least 3 are needed", points.len()));
    }
    let centroid = points.iter().sum::<Vec3>() / points.len() as f64;
    let basis = |point: &Vec3| {
        let mut b = Matrix3x6::zeros();
        b.fixed_view_mut::<3, 3>(0, 0).fill_with_identity();
        b.fixed_view_mut::<3, 3>(0, 3)
            .copy_from(&-(point - centroid).cross_matrix());
        b
    };
    let mut btb = Matrix6::zeros();
    let mut btj = SMatrix::<f64, 6, C>::zeros();
    for (point, j) in points.iter().zip(jacobians.iter()) {
        let b = basis(point);
        btb += b.transpose() * b;
        btj += b.transpose() * j;
    }
    let Some(cholesky) = btb.cholesky() else {
        return refuse("the points are collinear".to_string());
    };
    let m = cholesky.solve(&btj);
    for (point, j) in points.iter().zip(jacobians.iter_mut()) {
        *j -= basis(point) * m;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::DMatrix;
    use parcal_kinematics::{paper, params};

    fn paper_prior() -> ParamCovariance {
        ParamCovariance::identity() * 0.1f64.powi(2)
    }

    fn design_model() -> Params {
        params::to_params(&paper::design().canonicalize().unwrap().geometry)
    }

    #[test]
    fn projection_matches_the_dense_projector() {
        // Small cloud: compare with P = I - B (BᵀB)⁻¹ Bᵀ formed explicitly.
        let points: Vec<Vec3> = (0..7)
            .map(|k| {
                let k = k as f64;
                Vec3::new(10.0 * k.sin(), 7.0 * (1.3 * k).cos(), 400.0 + k)
            })
            .collect();
        let blocks: Vec<SMatrix<f64, 3, 4>> = (0..7)
            .map(|k| {
                SMatrix::<f64, 3, 4>::from_fn(|r, c| ((3 * k + r) as f64 * 0.7 + c as f64).sin())
            })
            .collect();
        let n = points.len();
        let centroid = points.iter().sum::<Vec3>() / n as f64;
        let mut b = DMatrix::zeros(3 * n, 6);
        let mut j = DMatrix::zeros(3 * n, 4);
        for k in 0..n {
            b.view_mut((3 * k, 0), (3, 3)).fill_with_identity();
            b.view_mut((3 * k, 3), (3, 3))
                .copy_from(&-(points[k] - centroid).cross_matrix());
            j.view_mut((3 * k, 0), (3, 4)).copy_from(&blocks[k]);
        }
        let btb_inv = (b.transpose() * &b).try_inverse().unwrap();
        let dense = (DMatrix::identity(3 * n, 3 * n) - &b * btb_inv * b.transpose()) * j;
        let mut projected = blocks.clone();
        remove_rigid_motions(&points, &mut projected).unwrap();
        for (k, block) in projected.iter().enumerate() {
            let difference = (dense.view((3 * k, 0), (3, 4)) - block).amax();
            assert!(difference < 1e-12, "block {k}: {difference:e}");
        }
        // Projecting twice changes nothing (P is idempotent).
        let mut twice = projected.clone();
        remove_rigid_motions(&points, &mut twice).unwrap();
        for (a, b) in twice.iter().zip(&projected) {
            assert!((a - b).amax() < 1e-12);
        }
    }

    #[test]
    fn the_tip_variance_has_the_bits_of_the_matrix_products() {
        // An asymmetric Σ and a J of mixed signs and magnitudes.
        let j = SMatrix::<f64, 3, N_PARAMS>::from_fn(|r, c| {
            ((7 * r + 3 * c) as f64 * 0.37).sin() * 10f64.powi(c as i32 % 5 - 2)
        });
        let sigma = ParamCovariance::from_fn(|r, c| ((r * 31 + c * 17) as f64 * 0.11).cos() * 1e-3);
        let expected = (j * sigma).component_mul(&j).sum();
        assert_eq!(
            tip_variance(&j, &sigma.transpose()).to_bits(),
            expected.to_bits()
        );
    }

    #[test]
    fn jacobians_of_pure_rigid_motions_are_removed() {
        // J_k = B_k A: every parameter change moves the cloud rigidly.
        let grid = MapGrid::paper();
        let points: Vec<Vec3> = grid.points().collect();
        let centroid = points.iter().sum::<Vec3>() / points.len() as f64;
        let a = SMatrix::<f64, 6, 5>::from_fn(|r, c| ((r * 5 + c) as f64).cos());
        let mut jacobians: Vec<SMatrix<f64, 3, 5>> = points
            .iter()
            .map(|p| {
                let mut b = Matrix3x6::zeros();
                b.fixed_view_mut::<3, 3>(0, 0).fill_with_identity();
                b.fixed_view_mut::<3, 3>(0, 3)
                    .copy_from(&-(p - centroid).cross_matrix());
                b * a
            })
            .collect();
        let largest = jacobians.iter().map(|j| j.amax()).fold(0.0, f64::max);
        assert!(largest > 10.0);
        remove_rigid_motions(&points, &mut jacobians).unwrap();
        let left = jacobians.iter().map(|j| j.amax()).fold(0.0, f64::max);
        assert!(left < 1e-10 * largest, "left {left:e}");
    }

    #[test]
    fn collinear_points_are_refused() {
        let points: Vec<Vec3> = (0..5).map(|k| Vec3::new(k as f64, 0.0, 400.0)).collect();
        let mut jacobians = vec![SMatrix::<f64, 3, 2>::zeros(); 5];
        let error = remove_rigid_motions(&points, &mut jacobians).unwrap_err();
        assert!(error.to_string().contains("collinear"), "{error}");
    }

    #[test]
    fn a_tool_offset_covariance_is_a_pure_translation() {
        // At constant orientation a tool-offset error moves every tip by the
        // same R_c δE_T: absolute sqrt(trace) = sigma sqrt(3), registered 0.
        let mut covariance = ParamCovariance::zeros();
        for k in params::TOOL_OFFSET..params::TOOL_OFFSET + 3 {
            covariance[(k, k)] = 0.1f64.powi(2);
        }
        let grid = MapGrid::square(100.0, 20.0, 400.0);
        let map = predicted(&paper::design(), &design_model(), &covariance, &grid).unwrap();
        for (a, r) in map.absolute.iter().zip(&map.registered) {
            assert!((a - 0.1 * 3f64.sqrt()).abs() < 1e-12, "absolute {a}");
            assert!(*r < 1e-7, "registered {r:e}");
        }
    }

    #[test]
    fn a_rigid_rotation_covariance_leaves_no_registered_error() {
        // Σ_p = G Gᵀ, the columns of G the least-squares parameter changes
        // (G = J⁺ B_rot) that turn the whole tip cloud rigidly by 0.1 mrad
        // about each axis through its centroid. The canonical parameters
        // realise such rotations (J G = B_rot), so the absolute map is the
        // rotation's lever arm and registration removes all of it.
        let design = paper::design();
        let grid = MapGrid::square(100.0, 25.0, 400.0);
        let model = design_model();
        let targets = CanonicalTargets::new(&design, &grid).unwrap();
        let geometry = params::from_params(&model);
        let n = targets.points.len();
        let mut j = DMatrix::zeros(3 * n, N_PARAMS);
        let mut rotations = DMatrix::zeros(3 * n, 3);
        let centroid = targets.points.iter().sum::<Vec3>() / n as f64;
        for (k, command) in commands(&geometry, &targets).unwrap().iter().enumerate() {
            let tip = tip_jacobians_at(&geometry, &command.pose).unwrap();
            j.view_mut((3 * k, 0), (3, N_PARAMS))
                .copy_from(&tip.d_params);
            rotations
                .view_mut((3 * k, 0), (3, 3))
                .copy_from(&(-1e-4 * (targets.points[k] - centroid).cross_matrix()));
        }
        let g = j.clone().pseudo_inverse(1e-12).unwrap() * &rotations;
        let realised = (&j * &g - &rotations).amax();
        assert!(realised < 1e-9, "J G - B_rot = {realised:e}");
        let covariance = ParamCovariance::from_iterator((&g * g.transpose()).iter().copied());
        let map = predicted(&design, &model, &covariance, &grid).unwrap();
        // Absolute: the lever arm, sqrt(trace) of the rotation's covariance
        // sum_axes |1e-4 e_a x r|^2 = 2e-8 |r|^2.
        for (k, point) in targets.points.iter().enumerate() {
            let lever = 1e-4 * (2.0f64).sqrt() * (point - centroid).norm();
            assert!((map.absolute[k] - lever).abs() < 1e-9, "point {k}");
        }
        let (absolute, registered) = (map.absolute_summary(), map.registered_summary());
        println!("rigid-rotation covariance: absolute {absolute}; registered {registered}");
        assert!(absolute.max > 0.019);
        assert!(
            registered.max < 1e-6 * absolute.max,
            "registered {registered}"
        );
    }

    #[test]
    fn paper_prior_registered_never_exceeds_absolute() {
        let map = predicted(
            &paper::design(),
            &design_model(),
            &paper_prior(),
            &MapGrid::paper(),
        )
        .unwrap();
        for (a, r) in map.absolute.iter().zip(&map.registered) {
            assert!(r <= a, "registered {r} > absolute {a}");
        }
        // The total (sum of squares) never grows under projection.
        let total = |v: &[f64]| v.iter().map(|x| x * x).sum::<f64>();
        assert!(total(&map.registered) <= total(&map.absolute));
    }

    #[test]
    fn refuses_bad_models_and_covariances() {
        let design = paper::design();
        let grid = MapGrid::square(100.0, 50.0, 400.0);
        let mut model = design_model();
        model[5] = f64::NAN;
        let error = predicted(&design, &model, &paper_prior(), &grid).unwrap_err();
        assert_eq!(
            error.to_string(),
            "model parameter z_b4 is not a finite number"
        );
        let mut covariance = paper_prior();
        covariance[(12, 0)] = f64::INFINITY;
        let error = predicted(&design, &design_model(), &covariance, &grid).unwrap_err();
        assert!(error.to_string().contains("(l_1, y_b2)"), "{error}");
        let covariance = -paper_prior();
        let error = predicted(&design, &design_model(), &covariance, &grid).unwrap_err();
        assert!(
            matches!(error, AccuracyError::NotPositiveSemidefinite { x, y, .. } if x == -100.0 && y == -100.0)
        );
    }

    #[test]
    fn an_unreachable_target_names_the_grid_point() {
        // A geometry given in its own canonical frames (both transforms are
        // the identity) without tool offset, asked to put its tip at the
        // origin: platform joint E1 lands on base joint B1, leg 1 would have
        // length l + q = 0.
        let mut geometry = params::from_params(&design_model());
        geometry.tool = Vec3::zeros();
        let model = params::to_params(&geometry);
        let grid = MapGrid {
            xs: vec![10.0, 0.0],
            ys: vec![-5.0, 0.0],
            z: 0.0,
        };
        let error = predicted(&geometry, &model, &paper_prior(), &grid).unwrap_err();
        assert_eq!(
            error.to_string(),
            "grid point (x = 0 mm, y = 0 mm) is unreachable by the model: leg 1 is infeasible: l + q = 0.000000 mm is not positive"
        );
    }
}
