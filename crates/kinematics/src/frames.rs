//! Canonical base and platform frames (paper section 2.1).
//!
//! The base frame has its origin at `B1`, its +y axis towards `B2` and `B3`
//! in its z = 0 plane; the platform frame is built the same way from `E1`,
//! `E2`, `E3`. Both are right-handed, with +z along the input frame's +z (the
//! side where the platform is, for the design frame of table 2). In these
//! frames 12 coordinates vanish by definition, which leaves the 33
//! identifiable parameters of [`crate::params`].

use nalgebra::{Isometry3, Matrix3, Rotation3, SMatrix, SVector, Translation3, UnitQuaternion};

use crate::params::{N_PARAMS, Params, to_params};
use crate::{Geometry, KinematicsError, Vec3};

/// Joints closer than this (mm) are the same joint.
const COINCIDENCE_MM: f64 = 1e-9;
/// `|sin|` of the angle at joint 1 below which joints 1, 2, 3 are collinear.
const COLLINEAR_SINE: f64 = 1e-9;

/// A geometry in its canonical frames, with the frames it came from.
#[derive(Debug, Clone, PartialEq)]
pub struct Canonical {
    /// The geometry expressed in the canonical base and platform frames.
    pub geometry: Geometry,
    /// Maps input base-frame coordinates to canonical base-frame coordinates.
    pub base_from_input: Isometry3<f64>,
    /// Maps input platform-frame coordinates to canonical platform coordinates.
    pub platform_from_input: Isometry3<f64>,
}

impl Canonical {
    /// A pose given between the input frames, expressed between the
    /// canonical frames: `T_c = T_base T_input T_platform^-1`.
    pub fn pose_from_input(&self, input_pose: &Isometry3<f64>) -> Isometry3<f64> {
        self.base_from_input * input_pose * self.platform_from_input.inverse()
    }
}

/// The canonical frame of one body: maps input coordinates to coordinates
/// with origin `p[0]`, +y towards `p[1]`, `p[2]` in the z = 0 plane and +z
/// along the input +z.
pub fn canonical_frame(
    body: &'static str,
    p: &[Vec3; 6],
) -> Result<Isometry3<f64>, KinematicsError> {
    for first in 0..6 {
        for second in first + 1..6 {
            if (p[first] - p[second]).norm() < COINCIDENCE_MM {
                let (first, second) = (first + 1, second + 1);
                return Err(KinematicsError::CoincidentJoints {
                    body,
                    first,
                    second,
                });
            }
        }
    }
    let (u, v) = (p[1] - p[0], p[2] - p[0]);
    let normal = u.cross(&v);
    let sine = normal.norm() / (u.norm() * v.norm());
    if sine < COLLINEAR_SINE {
        return Err(KinematicsError::CollinearFrameJoints { body, sine });
    }
    let y = u.normalize();
    let z = if normal.z < 0.0 { -normal } else { normal }.normalize();
    let x = y.cross(&z);
    // Rows of the rotation are the canonical axes in input coordinates.
    let rotation = Rotation3::from_matrix_unchecked(Matrix3::from_columns(&[x, y, z]).transpose());
    let rotation = UnitQuaternion::from_rotation_matrix(&rotation);
    Ok(Isometry3::from_parts(
        Translation3::from(-(rotation * p[0])),
        rotation,
    ))
}

impl Geometry {
    /// Converts a geometry given in any base and platform frames to the
    /// canonical frames. Refuses coincident joints, collinear frame joints
    /// and non-finite values.
    pub fn canonicalize(&self) -> Result<Canonical, KinematicsError> {
        self.check_finite()?;
        let base_from_input = canonical_frame("base", &self.base)?;
        let platform_from_input = canonical_frame("platform", &self.platform)?;
        let to = |frame: &Isometry3<f64>, p: &Vec3| frame.transform_point(&(*p).into()).coords;
        let geometry = Geometry {
            base: self.base.map(|b| to(&base_from_input, &b)),
            platform: self.platform.map(|e| to(&platform_from_input, &e)),
            tool: to(&platform_from_input, &self.tool),
            legs: self.legs,
        };
        Ok(Canonical {
            geometry,
            base_from_input,
            platform_from_input,
        })
    }
}

/// Number of input coordinates of a geometry: 6 base joints, 6 platform
/// joints, the tool (3 each) and 6 leg lengths.
pub const N_INPUT_COORDINATES: usize = 45;

/// Design tolerances (1 sigma, mm) of the input-frame coordinates, one per
/// group (machine.json's `prior_sigma`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PriorSigma {
    /// Each coordinate of each base joint `B_i`.
    pub base: f64,
    /// Each coordinate of each platform joint `E_i`.
    pub platform: f64,
    /// Each coordinate of the tool tip `E_T`.
    pub tool: f64,
    /// Each initial leg length `l_i`.
    pub leg: f64,
}

impl PriorSigma {
    /// The sigma of each of the 45 input coordinates, in the order of
    /// [`input_coordinates`] (mm).
    pub fn per_input_coordinate(&self) -> SVector<f64, N_INPUT_COORDINATES> {
        SVector::from_fn(|k, _| match k {
            0..18 => self.base,
            18..36 => self.platform,
            36..39 => self.tool,
            _ => self.leg,
        })
    }
}

/// The 45 input coordinates in the order `B1..B6 (x, y, z)`, `E1..E6 (x, y, z)`,
/// `E_T (x, y, z)`, `l_1..l_6`.
pub fn input_coordinates(geometry: &Geometry) -> SVector<f64, N_INPUT_COORDINATES> {
    let mut x = SVector::<f64, N_INPUT_COORDINATES>::zeros();
    let points = geometry
        .base
        .iter()
        .chain(&geometry.platform)
        .chain(std::iter::once(&geometry.tool));
    for (k, point) in points.enumerate() {
        x.fixed_rows_mut::<3>(3 * k).copy_from(point);
    }
    x.fixed_rows_mut::<6>(39).copy_from_slice(&geometry.legs);
    x
}

/// The geometry of 45 input coordinates (inverse of [`input_coordinates`]).
pub fn from_input_coordinates(x: &SVector<f64, N_INPUT_COORDINATES>) -> Geometry {
    let point = |k: usize| Vec3::from(x.fixed_rows::<3>(3 * k));
    Geometry {
        base: std::array::from_fn(point),
        platform: std::array::from_fn(|j| point(6 + j)),
        tool: point(12),
        legs: std::array::from_fn(|i| x[39 + i]),
    }
}

/// `d p / d x`: the derivative of the 33 canonical parameters with respect to
/// the 45 input coordinates, linearised at `geometry` by central differences
/// (step 1e-4 mm: rounding ~1e-10 and truncation ~1e-10 relative on a
/// geometry of ~100 mm; the canonicalisation is smooth away from degenerate
/// geometry). Used to propagate input-frame
/// tolerances to a full prior covariance `G Sigma_x G^T` of the parameters
/// (docs/paper-scenario.md section 4, propagated prior).
pub fn parameter_jacobian(
    geometry: &Geometry,
) -> Result<SMatrix<f64, N_PARAMS, N_INPUT_COORDINATES>, KinematicsError> {
    const STEP: f64 = 1e-4;
    let x = input_coordinates(geometry);
    let params_at = |x: SVector<f64, N_INPUT_COORDINATES>| -> Result<Params, KinematicsError> {
        Ok(to_params(
            &from_input_coordinates(&x).canonicalize()?.geometry,
        ))
    };
    let mut jacobian = SMatrix::<f64, N_PARAMS, N_INPUT_COORDINATES>::zeros();
    for k in 0..N_INPUT_COORDINATES {
        let (mut plus, mut minus) = (x, x);
        plus[k] += STEP;
        minus[k] -= STEP;
        let column = (params_at(plus)? - params_at(minus)?) / (2.0 * STEP);
        jacobian.set_column(k, &column);
    }
    Ok(jacobian)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::paper;

    #[test]
    fn true_y_b2_matches_the_spec() {
        let canonical = paper::truth().canonicalize().unwrap().geometry;
        assert_eq!(format!("{:.3}", canonical.base[1].y), "17.253");
        let design = paper::design().canonicalize().unwrap().geometry;
        assert_eq!(format!("{:.3}", design.base[1].y), "17.432");
    }

    #[test]
    fn canonical_coordinates_vanish_by_definition() {
        let c = paper::truth().canonicalize().unwrap().geometry;
        for (body, p) in [("base", &c.base), ("platform", &c.platform)] {
            assert_eq!(p[0], Vec3::zeros(), "{body} joint 1");
            assert!(
                p[1].x.abs() < 1e-13 && p[1].z.abs() < 1e-13,
                "{body} joint 2"
            );
            assert!(p[2].z.abs() < 1e-13, "{body} joint 3");
        }
        // +z towards the platform: the base joints 4-6 and the tool keep the
        // sign of their design-frame heights relative to the joint-1 plane.
        assert!(c.tool.z > 59.0);
    }

    #[test]
    fn refuses_degenerate_geometry() {
        let mut g = paper::design();
        g.base[2] = g.base[0] + 2.0 * (g.base[1] - g.base[0]);
        assert!(matches!(
            g.canonicalize(),
            Err(KinematicsError::CollinearFrameJoints { body: "base", .. })
        ));
        let mut g = paper::design();
        g.platform[4] = g.platform[1];
        let err = g.canonicalize().unwrap_err();
        assert_eq!(
            err,
            KinematicsError::CoincidentJoints {
                body: "platform",
                first: 2,
                second: 5
            }
        );
        assert_eq!(err.to_string(), "platform joints 2 and 5 coincide");
        let mut g = paper::design();
        g.tool.y = f64::NAN;
        assert_eq!(
            g.canonicalize().unwrap_err().to_string(),
            "tool is not a finite number"
        );
    }

    #[test]
    fn parameter_jacobian_moves_parameters_like_the_canonicalisation() {
        let design = paper::design();
        let jacobian = parameter_jacobian(&design).unwrap();
        // Leg lengths pass through unchanged.
        assert!((jacobian[(crate::params::leg_index(2), 41)] - 1.0).abs() < 1e-9);
        // An input change dx moves the parameters by J dx + O(|dx|^2): the
        // remainder shrinks 100-fold when dx shrinks 10-fold.
        let x = input_coordinates(&design);
        let p0 = to_params(&design.canonicalize().unwrap().geometry);
        let remainder = |scale: f64| {
            let dx = SVector::<f64, N_INPUT_COORDINATES>::from_fn(|k, _| {
                scale * ((k * 7 % 11) as f64 - 5.0)
            });
            let exact = to_params(
                &from_input_coordinates(&(x + dx))
                    .canonicalize()
                    .unwrap()
                    .geometry,
            ) - p0;
            (exact - jacobian * dx).amax()
        };
        let ratio = remainder(1e-2) / remainder(1e-3);
        assert!((70.0..130.0).contains(&ratio), "remainder ratio {ratio}");
        assert_eq!(from_input_coordinates(&x), design);
    }

    #[test]
    fn pose_maps_between_frames() {
        let design = paper::design();
        let canonical = design.canonicalize().unwrap();
        let pose = Isometry3::from_parts(
            Translation3::new(3.0, -2.0, 330.0),
            crate::rotation_zyx(0.1, -0.05, 0.08),
        );
        let tip_input = design.tool_tip(&pose);
        let tip_canonical = canonical
            .geometry
            .tool_tip(&canonical.pose_from_input(&pose));
        let mapped = canonical
            .base_from_input
            .transform_point(&tip_input.into())
            .coords;
        assert!((tip_canonical - mapped).norm() < 1e-12);
    }
}
