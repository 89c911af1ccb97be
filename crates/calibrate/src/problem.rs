//! The calibration as the solver sees it: one global block (the 33
//! kinematic parameters), one group per ball (its centre, 3), one point per
//! contact (its two angles for the coordinate observation, none for the
//! radius observation), and the priors.
//!
//! Each contact's residual is its observation block (`parcal_observe`) at the
//! tool tip given by forward kinematics of the current parameters at the
//! contact's actuator readings, whitened by the weight computed once at the
//! initial estimate. Forward kinematics starts from the contact's previous
//! pose (the solver keeps it as the point cache).

use std::ops::Range;

use nalgebra::{SVector, Vector2};
use parcal_kinematics::{ForwardOptions, N_PARAMS, Params, Pose, Vec3, forward, params};
use parcal_observe::{
    BlockJacobians, CoordinateBlock, CoordinateWeight, DirectionChart, RadiusBlock, RadiusWeight,
    Tip,
};
use parcal_solver::{GaussianPrior, Linearization, Problem};

use crate::CalibrateError;

/// Paper eq. (9) for every contact.
pub struct RadiusObservations {
    pub weights: Vec<RadiusWeight>,
}

/// Paper eq. (10) for every contact, the angles charted about the initial
/// direction `u0` of each contact.
pub struct CoordinateObservations {
    pub weights: Vec<CoordinateWeight>,
    pub charts: Vec<DirectionChart>,
    /// Angle priors (sigma, rad) per contact; `None`: no angle prior.
    pub angle_sigma: Option<Vec<f64>>,
}

/// The least-squares problem of one calibration, contacts sorted by ball.
pub struct CalibrationProblem<O> {
    /// Actuator readings per contact.
    pub q: Vec<[f64; 6]>,
    /// The measurements.csv row of each contact (0-based, without header).
    pub rows: Vec<usize>,
    /// Contacts of each ball (contiguous).
    pub groups: Vec<Range<usize>>,
    /// Calibrated radius of each ball.
    pub radii: Vec<f64>,
    /// The ball of each contact.
    pub ball_of: Vec<u32>,
    /// Start of every contact's first forward kinematics (design home pose).
    pub home: Vec<Pose>,
    pub observations: O,
    pub global_prior: Option<GaussianPrior<N_PARAMS>>,
    pub centre_priors: Option<Vec<GaussianPrior<3>>>,
    pub forward_options: ForwardOptions,
}

impl<O> CalibrationProblem<O> {
    /// Paper eq. (2): the tool tip of the parameters `p` at contact `i`, by
    /// forward kinematics from the contact's cached pose, with `J_f`, `J_q`.
    fn tip(&self, i: usize, p: &Params, pose: &mut Pose) -> Result<Tip, CalibrateError> {
        let geometry = params::from_params(p);
        let solution =
            forward(&geometry, &self.q[i], pose, &self.forward_options).map_err(|source| {
                CalibrateError::ForwardKinematics {
                    row: self.rows[i],
                    source,
                }
            })?;
        *pose = solution.pose;
        Tip::at(&geometry, &solution).map_err(|source| CalibrateError::Observation {
            row: self.rows[i],
            source,
        })
    }

    fn centre_prior(&self, k: usize) -> Option<GaussianPrior<3>> {
        self.centre_priors.as_ref().map(|priors| priors[k].clone())
    }
}

/// The whitened block as the solver's linearisation.
fn linearization<const R: usize, const P: usize>(
    block: BlockJacobians<R, P>,
) -> Linearization<N_PARAMS, 3, P, R> {
    Linearization {
        residual: block.residual,
        d_global: block.d_params,
        d_group: block.d_centre,
        d_point: block.d_angles,
    }
}

impl Problem<N_PARAMS, 3, 0, 1> for CalibrationProblem<RadiusObservations> {
    type PointCache = Pose;
    type Error = CalibrateError;

    fn n_groups(&self) -> usize {
        self.groups.len()
    }

    fn group_points(&self, k: usize) -> Range<usize> {
        self.groups[k].clone()
    }

    fn initial_cache(&self, i: usize) -> Pose {
        self.home[i]
    }

    fn linearize(
        &self,
        i: usize,
        global: &Params,
        group: &SVector<f64, 3>,
        _point: &SVector<f64, 0>,
        cache: &mut Pose,
    ) -> Result<Linearization<N_PARAMS, 3, 0, 1>, CalibrateError> {
        let tip = self.tip(i, global, cache)?;
        let radius = self.radii[self.ball_of[i] as usize];
        let block = RadiusBlock { radius }
            .evaluate(&tip, &Vec3::from(*group))
            .map_err(|source| CalibrateError::Observation {
                row: self.rows[i],
                source,
            })?;
        Ok(linearization(block.whiten(&self.observations.weights[i])))
    }

    fn global_prior(&self) -> Option<&GaussianPrior<N_PARAMS>> {
        self.global_prior.as_ref()
    }

    fn group_prior(&self, k: usize) -> Option<GaussianPrior<3>> {
        self.centre_prior(k)
    }
}

impl Problem<N_PARAMS, 3, 2, 3> for CalibrationProblem<CoordinateObservations> {
    type PointCache = Pose;
    type Error = CalibrateError;

    fn n_groups(&self) -> usize {
        self.groups.len()
    }

    fn group_points(&self, k: usize) -> Range<usize> {
        self.groups[k].clone()
    }

    fn initial_cache(&self, i: usize) -> Pose {
        self.home[i]
    }

    fn linearize(
        &self,
        i: usize,
        global: &Params,
        group: &SVector<f64, 3>,
        point: &Vector2<f64>,
        cache: &mut Pose,
    ) -> Result<Linearization<N_PARAMS, 3, 2, 3>, CalibrateError> {
        let tip = self.tip(i, global, cache)?;
        let block = CoordinateBlock {
            radius: self.radii[self.ball_of[i] as usize],
            chart: self.observations.charts[i],
        };
        let jacobians = block.evaluate(&tip, &Vec3::from(*group), point);
        Ok(linearization(
            jacobians.whiten(&self.observations.weights[i]),
        ))
    }

    fn global_prior(&self) -> Option<&GaussianPrior<N_PARAMS>> {
        self.global_prior.as_ref()
    }

    fn group_prior(&self, k: usize) -> Option<GaussianPrior<3>> {
        self.centre_prior(k)
    }

    fn point_prior(&self, i: usize) -> Option<GaussianPrior<2>> {
        let sigma = self.observations.angle_sigma.as_ref()?[i];
        Some(GaussianPrior::from_sigmas(
            Vector2::zeros(),
            Vector2::repeat(sigma),
        ))
    }
}
