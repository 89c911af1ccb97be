//! Shared test fixtures: one contact of the paper's design machine, central
//! differences and a tolerance check.

use nalgebra::{SMatrix, SVector, Translation3};
use parcal_kinematics::{
    ForwardOptions, ForwardSolution, Geometry, Params, Pose, Vec3, actuators, forward, paper,
    params, rotation_zyx,
};

use crate::Tip;

/// Forward kinematics tight enough for central differences with step 1e-4:
/// closure rounding ~1e-12 mm gives a difference error ~1e-8.
const TIGHT: ForwardOptions = ForwardOptions {
    tolerance: 1e-12,
    max_iterations: 30,
};

/// One contact of the design machine (canonical frames): a tilted pose with
/// the tip near z = 400 of the design frame, touching a ball of radius about
/// 5 from below.
pub struct Contact {
    pub geometry: Geometry,
    pub q: [f64; 6],
    pub solution: ForwardSolution,
}

impl Contact {
    pub fn new() -> Self {
        let canonical = paper::design().canonicalize().unwrap();
        let rotation = rotation_zyx(0.1, -0.05, 0.08);
        let tip = Vec3::new(20.0, -30.0, 400.0);
        let input_pose = Pose::from_parts(
            Translation3::from(tip - rotation * paper::design().tool),
            rotation,
        );
        let pose = canonical.pose_from_input(&input_pose);
        let geometry = canonical.geometry;
        let q = actuators(&geometry, &pose);
        let solution = forward(&geometry, &q, &pose, &TIGHT).unwrap();
        Self {
            geometry,
            q,
            solution,
        }
    }

    pub fn params(&self) -> Params {
        params::to_params(&self.geometry)
    }

    pub fn tip(&self) -> Tip {
        Tip::at(&self.geometry, &self.solution)
    }

    /// The tip at the same actuator values `q` with parameters `p`.
    pub fn tip_with(&self, p: &Params) -> Tip {
        self.tip_with_actuators(p, &self.q)
    }

    /// The tip with parameters `p` at actuator values `q`, by forward
    /// kinematics from this contact's pose.
    pub fn tip_with_actuators(&self, p: &Params, q: &[f64; 6]) -> Tip {
        let geometry = params::from_params(p);
        let solution = forward(&geometry, q, &self.solution.pose, &TIGHT).unwrap();
        Tip::at(&geometry, &solution)
    }

    /// A ball centre 5.004 mm from the tip, the tip on its lower side.
    pub fn centre(&self) -> Vec3 {
        self.tip().position - 5.004 * Vec3::new(0.3, -0.2, -0.9).normalize()
    }
}

/// Central differences of `f` at `x` with step `step`.
pub fn central_difference<const N: usize, const R: usize>(
    x: &SVector<f64, N>,
    step: f64,
    f: impl Fn(&SVector<f64, N>) -> SVector<f64, R>,
) -> SMatrix<f64, R, N> {
    let mut jacobian = SMatrix::<f64, R, N>::zeros();
    for k in 0..N {
        let (mut plus, mut minus) = (*x, *x);
        plus[k] += step;
        minus[k] -= step;
        jacobian.set_column(k, &((f(&plus) - f(&minus)) / (2.0 * step)));
    }
    jacobian
}

/// Asserts `|analytic − reference| <= relative * max(1, |analytic|)`
/// entrywise in the max norm.
pub fn assert_close<const R: usize, const C: usize>(
    analytic: &SMatrix<f64, R, C>,
    reference: &SMatrix<f64, R, C>,
    relative: f64,
    what: &str,
) {
    let error = (analytic - reference).amax();
    let scale = analytic.amax().max(1.0);
    assert!(
        error <= relative * scale,
        "{what}: largest difference {error:e} against scale {scale:e}\nanalytic {analytic}\nreference {reference}"
    );
}
