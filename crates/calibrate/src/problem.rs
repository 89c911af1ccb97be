//! The calibration as the solver sees it: one global block (the 33
//! kinematic parameters), one group per ball (its centre, 3), one point per
//! contact (its two angles for the coordinate observation, none for the
//! radius observation), and the priors.
//!
//! Each contact's residual is its observation block (`parcal_observe`) at the
//! tool tip given by forward kinematics of the current parameters at the
//! contact's actuator readings, whitened by the weight computed once at the
//! initial estimate. Forward kinematics starts from the pose the solver
//! keeps as the contact's point cache: the first time the design's home pose
//! (or a given warm start), then the first-order prediction of the pose at
//! the next iteration's parameters, made during the back-substitution.

use std::ops::Range;

use nalgebra::{SVector, Vector2};
use parcal_kinematics::{
    ForwardOptions, ForwardSolution, Geometry, N_PARAMS, Params, Pose, Vec3, derivative_along,
    forward, forward::step as step_pose, params,
};
use parcal_observe::{
    BlockJacobians, CoordinateBlock, CoordinateWeight, DirectionChart, ObserveError, RadiusBlock,
    RadiusWeight, Tip, Whitening,
};
use parcal_solver::{GaussianPrior, Linearization, Problem};

use crate::CalibrateError;

/// Paper eq. (9) for every contact.
pub struct RadiusObservations {
    pub weights: Vec<RadiusWeight>,
}

/// Paper eq. (10) for every contact, the angles charted about each
/// contact's initial direction `u0`.
pub struct CoordinateObservations {
    /// `u0` of each contact (unit, canonical base frame).
    pub directions: Vec<Vec3>,
    pub weights: Vec<CoordinateWeight>,
    /// Sigma of the angle prior of every contact (rad); `None`: no prior.
    pub angle_sigma: Option<f64>,
}

/// The least-squares problem of one calibration, contacts sorted by ball.
pub struct CalibrationProblem<'a, O> {
    /// The design in canonical frames (its home pose starts the first FK).
    pub design: Geometry,
    /// Actuator readings, measurements.csv order (borrowed from the dataset).
    pub q: &'a [[f64; 6]],
    /// The measurements.csv row of each contact, sorted by ball.
    pub rows: Vec<u32>,
    /// Contacts of each ball (contiguous).
    pub groups: Vec<Range<usize>>,
    /// Calibrated radius of each ball.
    pub radii: Vec<f64>,
    pub observations: O,
    pub global_prior: Option<GaussianPrior<N_PARAMS>>,
    pub centre_priors: Option<Vec<GaussianPrior<3>>>,
    pub forward_options: ForwardOptions,
    /// Warm starts of the first forward kinematics of each contact (sorted
    /// order), e.g. the poses of a previous calibration; `None`: the design's
    /// home pose.
    pub starts: Option<Vec<Pose>>,
}

impl<O> CalibrationProblem<'_, O> {
    fn row(&self, i: usize) -> usize {
        self.rows[i] as usize
    }

    fn actuators(&self, i: usize) -> &[f64; 6] {
        &self.q[self.row(i)]
    }

    /// Forward kinematics of the parameters `p` at contact `i`, from the
    /// contact's cached pose (updated).
    fn forward(
        &self,
        i: usize,
        p: &Params,
        pose: &mut Pose,
    ) -> Result<(Geometry, ForwardSolution), CalibrateError> {
        let geometry = params::from_params(p);
        let solution = forward(&geometry, self.actuators(i), pose, &self.forward_options).map_err(
            |source| CalibrateError::ForwardKinematics {
                row: self.row(i),
                source,
            },
        )?;
        *pose = solution.pose;
        Ok((geometry, solution))
    }

    /// Paper eq. (2): the tool tip of the parameters `p` at contact `i`, with
    /// `J_f` and `J_q`.
    fn tip(&self, i: usize, p: &Params, pose: &mut Pose) -> Result<Tip, CalibrateError> {
        let (geometry, solution) = self.forward(i, p, pose)?;
        Tip::at(&geometry, &solution).map_err(|source| self.observation_error(i, source))
    }

    /// The tool tip of `p` at contact `i` without its Jacobians, and its
    /// derivative `J_f dp` along the step `dp` (one LU solve instead of
    /// `J_f`). The cached pose becomes the first-order prediction of the
    /// pose at `p + dp`, the next iteration's parameters, so that its forward
    /// kinematics starts within `O(|dp|^2)` of the solution.
    fn tip_along(
        &self,
        i: usize,
        p: &Params,
        pose: &mut Pose,
        dp: &Params,
    ) -> Result<(Tip, Vec3), CalibrateError> {
        let (geometry, solution) = self.forward(i, p, pose)?;
        let along = derivative_along(&geometry, &solution.legs, dp).map_err(|source| {
            CalibrateError::ForwardKinematics {
                row: self.row(i),
                source,
            }
        })?;
        *pose = step_pose(&solution.pose, &along.pose, 1.0);
        Ok((
            Tip::position_only(geometry.tool_tip(&solution.pose)),
            along.tip,
        ))
    }

    fn observation_error(&self, i: usize, source: ObserveError) -> CalibrateError {
        CalibrateError::Observation {
            row: self.row(i),
            source,
        }
    }

    fn start(&self, i: usize) -> Pose {
        match &self.starts {
            Some(starts) => starts[i],
            None => self.design.home_pose(self.actuators(i)),
        }
    }

    fn centre_prior(&self, k: usize) -> Option<GaussianPrior<3>> {
        self.centre_priors.as_ref().map(|priors| priors[k].clone())
    }

    /// The radius of contact `i`'s ball: found by the group range it is in.
    fn radius(&self, i: usize) -> f64 {
        let ball = self.groups.partition_point(|g| g.end <= i);
        self.radii[ball]
    }
}

impl CalibrationProblem<'_, CoordinateObservations> {
    /// The coordinate block of contact `i`: its ball's radius, its chart.
    fn coordinate_block(&self, i: usize) -> Result<CoordinateBlock, CalibrateError> {
        let chart = DirectionChart::new(&self.observations.directions[i])
            .map_err(|source| self.observation_error(i, source))?;
        Ok(CoordinateBlock {
            radius: self.radius(i),
            chart,
        })
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

/// The parts of [`Problem`] that do not depend on the observation.
macro_rules! common_problem_items {
    () => {
        type PointCache = Pose;
        type Error = CalibrateError;

        fn n_groups(&self) -> usize {
            self.groups.len()
        }

        fn group_points(&self, k: usize) -> Range<usize> {
            self.groups[k].clone()
        }

        fn initial_cache(&self, i: usize) -> Pose {
            self.start(i)
        }

        fn global_prior(&self) -> Option<&GaussianPrior<N_PARAMS>> {
            self.global_prior.as_ref()
        }

        fn group_prior(&self, k: usize) -> Option<GaussianPrior<3>> {
            self.centre_prior(k)
        }
    };
}

impl Problem<N_PARAMS, 3, 0, 1> for CalibrationProblem<'_, RadiusObservations> {
    common_problem_items!();

    fn linearize(
        &self,
        i: usize,
        global: &Params,
        group: &SVector<f64, 3>,
        _point: &SVector<f64, 0>,
        cache: &mut Pose,
    ) -> Result<Linearization<N_PARAMS, 3, 0, 1>, CalibrateError> {
        let tip = self.tip(i, global, cache)?;
        let block = RadiusBlock {
            radius: self.radius(i),
        };
        let jacobians = block
            .evaluate(&tip, &Vec3::from(*group))
            .map_err(|source| self.observation_error(i, source))?;
        Ok(linearization(
            jacobians.whiten(&self.observations.weights[i]),
        ))
    }

    fn linearize_along(
        &self,
        i: usize,
        global: &Params,
        group: &SVector<f64, 3>,
        _point: &SVector<f64, 0>,
        cache: &mut Pose,
        dg: &Params,
    ) -> Result<(Linearization<N_PARAMS, 3, 0, 1>, SVector<f64, 1>), CalibrateError> {
        let (tip, jf_dg) = self.tip_along(i, global, cache, dg)?;
        let (centre, block) = (
            Vec3::from(*group),
            RadiusBlock {
                radius: self.radius(i),
            },
        );
        let weight = &self.observations.weights[i];
        let jacobians = block
            .evaluate(&tip, &centre)
            .map_err(|source| self.observation_error(i, source))?;
        let along = block
            .along(&tip.position, &centre, &jf_dg)
            .map_err(|source| self.observation_error(i, source))?;
        Ok((
            linearization(jacobians.whiten(weight)),
            weight.whiten(&along),
        ))
    }
}

impl Problem<N_PARAMS, 3, 2, 3> for CalibrationProblem<'_, CoordinateObservations> {
    common_problem_items!();

    fn linearize(
        &self,
        i: usize,
        global: &Params,
        group: &SVector<f64, 3>,
        point: &Vector2<f64>,
        cache: &mut Pose,
    ) -> Result<Linearization<N_PARAMS, 3, 2, 3>, CalibrateError> {
        let tip = self.tip(i, global, cache)?;
        let block = self.coordinate_block(i)?;
        let jacobians = block.evaluate(&tip, &Vec3::from(*group), point);
        Ok(linearization(
            jacobians.whiten(&self.observations.weights[i]),
        ))
    }

    fn linearize_along(
        &self,
        i: usize,
        global: &Params,
        group: &SVector<f64, 3>,
        point: &Vector2<f64>,
        cache: &mut Pose,
        dg: &Params,
    ) -> Result<(Linearization<N_PARAMS, 3, 2, 3>, SVector<f64, 3>), CalibrateError> {
        let (tip, jf_dg) = self.tip_along(i, global, cache, dg)?;
        let block = self.coordinate_block(i)?;
        let weight = &self.observations.weights[i];
        let jacobians = block.evaluate(&tip, &Vec3::from(*group), point);
        Ok((
            linearization(jacobians.whiten(weight)),
            weight.whiten(&block.along(&jf_dg)),
        ))
    }

    fn point_prior(&self, _i: usize) -> Option<GaussianPrior<2>> {
        let sigma = self.observations.angle_sigma?;
        Some(GaussianPrior::from_sigmas(
            Vector2::zeros(),
            Vector2::repeat(sigma),
        ))
    }
}
