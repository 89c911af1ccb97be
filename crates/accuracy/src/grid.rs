//! The map grid (docs/paper-scenario.md section 5) and its targets in the canonical frames.
//!
//! The grid lies on a plane `z = const` of the DESIGN frame (the frame of
//! table 2, centred on the base). The targets and the platform's home
//! orientation (`R = I` in the design frame) are carried into the canonical
//! frames by the design geometry's canonical transforms,
//!
//! ```text
//! target_c = T_base * target,      R_c = rot(T_base) * I * rot(T_platform)^-1,
//! ```
//!
//! which is the only mapping a user has: the true machine's canonical frames
//! differ from the design's by a tilt of ~10 mrad (12 mrad for the base of
//! table 2), which is what makes the absolute error large (docs/paper-scenario.md section 4).
//!
//! In simulation the targets can also be mapped with the TRUE geometry's
//! transforms (the truth given in the design frame): the map then shows the
//! machine commanded to where the targets really are in its own canonical
//! frames. That is what the reference implementation of
//! `reference/paper-seed1` did for its true maps; see the crate's
//! `tests/paper_reference.rs` for both.

use nalgebra::UnitQuaternion;
use parcal_kinematics::{Geometry, Vec3};

use crate::AccuracyError;

/// A rectangular grid of targets on the plane `z` of the design frame (mm).
/// Points are ordered row-major, `y` outer and `x` inner: point
/// `iy * xs.len() + ix` is `(xs[ix], ys[iy], z)`.
#[derive(Debug, Clone, PartialEq)]
pub struct MapGrid {
    /// x coordinates of the columns (mm, design frame).
    pub xs: Vec<f64>,
    /// y coordinates of the rows (mm, design frame).
    pub ys: Vec<f64>,
    /// Height of the plane (mm, design frame).
    pub z: f64,
}

impl MapGrid {
    /// The paper's grid (figs. 3, 7, 10): x and y from -100 to 100 mm in
    /// steps of 10 on the plane z = 400 (21 x 21 = 441 points).
    pub fn paper() -> Self {
        Self::square(100.0, 10.0, 400.0)
    }

    /// x and y from `-half_width` to `half_width` in steps of `step` (both
    /// ends included when `half_width` is a multiple of `step`) on the plane
    /// `z`.
    pub fn square(half_width: f64, step: f64, z: f64) -> Self {
        let n = (2.0 * half_width / step + 1e-9).floor().max(0.0) as usize;
        let axis: Vec<f64> = (0..=n).map(|k| -half_width + k as f64 * step).collect();
        Self {
            xs: axis.clone(),
            ys: axis,
            z,
        }
    }

    /// Number of grid points.
    pub fn len(&self) -> usize {
        self.xs.len() * self.ys.len()
    }

    /// Whether the grid has no point.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The points in map order (row-major, y outer), design frame (mm).
    pub fn points(&self) -> impl Iterator<Item = Vec3> + '_ {
        self.ys
            .iter()
            .flat_map(move |&y| self.xs.iter().map(move |&x| Vec3::new(x, y, self.z)))
    }

    /// Checks that the grid can carry a registered map: finite coordinates,
    /// at least two distinct values on each axis (so the points span a
    /// plane and a rigid registration is unique), no repeated value.
    pub fn check(&self) -> Result<(), AccuracyError> {
        let invalid = |reason: String| Err(AccuracyError::Grid { reason });
        if !self.z.is_finite() {
            return invalid(format!("z = {} is not finite", self.z));
        }
        for (name, axis) in [("x", &self.xs), ("y", &self.ys)] {
            if axis.len() < 2 {
                return invalid(format!(
                    "{} value(s) of {name}; at least 2 are needed",
                    axis.len()
                ));
            }
            if let Some(v) = axis.iter().find(|v| !v.is_finite()) {
                return invalid(format!("{name} = {v} is not finite"));
            }
            for (i, a) in axis.iter().enumerate() {
                if axis[..i].contains(a) {
                    return invalid(format!("{name} = {a} appears twice"));
                }
            }
        }
        Ok(())
    }
}

/// The grid's targets and the home orientation in the canonical frames of a
/// design geometry.
#[derive(Debug, Clone, PartialEq)]
pub struct CanonicalTargets {
    /// The grid, in the design frame.
    pub grid: MapGrid,
    /// `target_c = T_base * target` for each grid point, in map order (mm,
    /// canonical base frame).
    pub points: Vec<Vec3>,
    /// The platform orientation of the map in the canonical frames:
    /// `R_c = rot(T_base) * rot(T_platform)^-1` (the design frame's `R = I`).
    pub orientation: UnitQuaternion<f64>,
}

impl CanonicalTargets {
    /// Maps the grid with the canonical transforms of `frames`, a geometry
    /// given in the design frame: the design (docs/paper-scenario.md section 5, what a user
    /// has) or, in simulation, the true geometry. Errors: an invalid grid, a
    /// geometry that does not define the canonical frames.
    pub fn new(frames: &Geometry, grid: &MapGrid) -> Result<Self, AccuracyError> {
        grid.check()?;
        let canonical = frames.canonicalize().map_err(AccuracyError::Design)?;
        let base = canonical.base_from_input;
        let points = grid
            .points()
            .map(|p| base.transform_point(&p.into()).coords)
            .collect();
        let orientation = base.rotation * canonical.platform_from_input.rotation.inverse();
        Ok(Self {
            grid: grid.clone(),
            points,
            orientation,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use parcal_kinematics::paper;

    #[test]
    fn paper_grid_has_441_points_in_row_major_order() {
        let grid = MapGrid::paper();
        assert_eq!((grid.xs.len(), grid.ys.len(), grid.len()), (21, 21, 441));
        assert_eq!(grid.xs[0], -100.0);
        assert!((grid.xs[20] - 100.0).abs() < 1e-12);
        let points: Vec<Vec3> = grid.points().collect();
        assert_eq!(points[1], Vec3::new(grid.xs[1], grid.ys[0], 400.0));
        assert_eq!(points[21], Vec3::new(grid.xs[0], grid.ys[1], 400.0));
        grid.check().unwrap();
    }

    #[test]
    fn refuses_degenerate_grids() {
        let mut grid = MapGrid::paper();
        grid.ys = vec![0.0];
        let message = grid.check().unwrap_err().to_string();
        assert!(message.contains("1 value(s) of y"), "{message}");
        let mut grid = MapGrid::paper();
        grid.xs[3] = f64::NAN;
        assert!(grid.check().unwrap_err().to_string().contains("not finite"));
        let mut grid = MapGrid::paper();
        grid.xs[3] = grid.xs[2];
        assert!(grid.check().unwrap_err().to_string().contains("twice"));
    }

    #[test]
    fn targets_follow_the_design_transforms() {
        let design = paper::design();
        let grid = MapGrid::paper();
        let targets = CanonicalTargets::new(&design, &grid).unwrap();
        let canonical = design.canonicalize().unwrap();
        // The design tool at the design-frame home pose over a grid point
        // lands on the mapped target with the mapped orientation.
        let point = grid.points().nth(37).unwrap();
        let input_pose = parcal_kinematics::Pose::from_parts(
            (point - design.tool).into(),
            UnitQuaternion::identity(),
        );
        let pose_c = canonical.pose_from_input(&input_pose);
        assert!((canonical.geometry.tool_tip(&pose_c) - targets.points[37]).norm() < 1e-12);
        assert!((pose_c.rotation.coords - targets.orientation.coords).norm() < 1e-12);
        // The design frame's base is flat: the mapped plane stays at z = 400
        // above B1's plane, but the canonical origin is at B1.
        assert!((targets.points[0].z - 400.0).abs() < 1e-9);
    }
}
