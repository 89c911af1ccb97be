//! From a dataset to the least-squares problem: the design in canonical
//! frames, the contacts sorted by ball, the initial estimates (spec section
//! 4), the weights and the priors.

use nalgebra::{SMatrix, Vector3};
use parcal_dataset::{ArtefactFrame, Dataset};
use parcal_kinematics::{
    Canonical, ForwardOptions, Geometry, N_PARAMS, Params, Pose, Vec3, forward_from_home, params,
};
use parcal_observe::{
    CoordinateWeight, DirectionChart, InputSigmas, KinematicPrior, RadiusWeight, Repeatability,
    Tip, WeightModel, coordinate_covariance, radius_variance,
};
use parcal_solver::GaussianPrior;
use rayon::prelude::*;

use crate::problem::{CalibrationProblem, CoordinateObservations, RadiusObservations};
use crate::sphere_fit::fit_centre;
use crate::{CalibrateError, CalibrationOptions, PriorMode, Weighting};

/// The initial estimate and everything derived from the dataset once.
pub struct Setup {
    /// The design geometry as given (machine.json's frames).
    pub design: Geometry,
    /// The design in its canonical frames, with the frame transforms.
    pub canonical: Canonical,
    /// The design's canonical parameters: the initial estimate of `p`.
    pub initial_params: Params,
    /// Initial ball centres (canonical base frame), artefacts.json order.
    pub initial_centres: Vec<Vec3>,
    /// The a priori knowledge on `p`, if any.
    pub prior: Option<KinematicPrior>,
    /// Contacts sorted by ball: `order[k]` is the measurements.csv row of
    /// the k-th contact.
    pub order: Vec<usize>,
    /// Contact range of each ball in `order`.
    pub groups: Vec<std::ops::Range<usize>>,
    /// Design-FK tip and its derivatives at each contact (sorted order).
    pub tips: Vec<Tip>,
    /// Initial direction `u0` of each contact (sorted order).
    pub directions: Vec<Vec3>,
    /// Home pose of each contact (sorted order): the first FK start.
    pub home: Vec<Pose>,
}

/// The design geometry of machine.json.
pub fn design_geometry(dataset: &Dataset) -> Geometry {
    let m = &dataset.machine;
    Geometry::from_arrays(&m.base_joints, &m.platform_joints, &m.tool, &m.leg_lengths)
}

impl Setup {
    /// Initial estimates of spec section 4: `p` = the design's canonical
    /// parameters; each ball centre = the best fit of its design-FK contact
    /// points with the calibrated radius; each contact's direction = from
    /// that centre to its design-FK point, or the commanded approach
    /// direction when measurements.csv gives one.
    pub fn new(dataset: &Dataset, options: &CalibrationOptions) -> Result<Self, CalibrateError> {
        let design = design_geometry(dataset);
        let canonical = design.canonicalize().map_err(CalibrateError::Design)?;
        let geometry = &canonical.geometry;
        let initial_params = params::to_params(geometry);

        let balls = dataset.artefacts.balls.len();
        let mut order: Vec<usize> = (0..dataset.measurements.q.len()).collect();
        order.sort_by_key(|&row| dataset.measurements.ball[row]);
        let mut groups = vec![0..0; balls];
        let mut start = 0;
        for (ball, group) in groups.iter_mut().enumerate() {
            let count = order[start..]
                .iter()
                .take_while(|&&row| dataset.measurements.ball[row] as usize == ball)
                .count();
            *group = start..start + count;
            start += count;
        }

        let fk = ForwardOptions::default();
        let solved: Vec<(Pose, Tip)> = order
            .par_iter()
            .map(|&row| {
                let q = &dataset.measurements.q[row];
                let solution = forward_from_home(geometry, q, &fk)
                    .map_err(|source| CalibrateError::ForwardKinematics { row, source })?;
                let tip = Tip::at(geometry, &solution)
                    .map_err(|source| CalibrateError::Observation { row, source })?;
                Ok((geometry.home_pose(q), tip))
            })
            .collect::<Result<_, CalibrateError>>()?;
        let (home, tips): (Vec<Pose>, Vec<Tip>) = solved.into_iter().unzip();

        let initial_centres = groups
            .iter()
            .zip(&dataset.artefacts.balls)
            .map(|(group, ball)| {
                let points: Vec<Vec3> = tips[group.clone()].iter().map(|t| t.position).collect();
                fit_centre(&points, ball.radius).map_err(|source| CalibrateError::CentreFit {
                    ball: ball.id.clone(),
                    source,
                })
            })
            .collect::<Result<Vec<_>, _>>()?;

        let base_rotation = canonical.base_from_input.rotation;
        let directions = order
            .iter()
            .zip(&tips)
            .enumerate()
            .map(|(k, (&row, tip))| match &dataset.measurements.direction {
                Some(commanded) => {
                    let d = Vec3::from(commanded[row]);
                    match dataset.artefacts.frame {
                        ArtefactFrame::Design => base_rotation * d,
                        ArtefactFrame::Canonical => d,
                    }
                    .normalize()
                }
                None => {
                    let ball = dataset.measurements.ball[order[k]] as usize;
                    (tip.position - initial_centres[ball]).normalize()
                }
            })
            .collect();

        let prior = kinematic_prior(dataset, &design, &initial_params, options.prior)?;
        Ok(Self {
            design,
            canonical,
            initial_params,
            initial_centres,
            prior,
            order,
            groups,
            tips,
            directions,
            home,
        })
    }

    /// The problem with the radius observation (paper eq. 9).
    pub fn radius_problem(
        &self,
        dataset: &Dataset,
        options: &CalibrationOptions,
    ) -> Result<CalibrationProblem<RadiusObservations>, CalibrateError> {
        let model = weight_model(options.weighting);
        let weights = self.each_contact(dataset, |row, tip, u0, repeatability| {
            let variance = radius_variance(model, repeatability, &tip.d_q, u0)
                .map_err(|source| CalibrateError::Observation { row, source })?;
            RadiusWeight::from_variance(variance)
                .map_err(|source| CalibrateError::Observation { row, source })
        })?;
        Ok(self.problem(dataset, options, RadiusObservations { weights }))
    }

    /// The problem with the transformed-coordinate observation (paper eq. 10).
    pub fn coordinate_problem(
        &self,
        dataset: &Dataset,
        options: &CalibrationOptions,
    ) -> Result<CalibrationProblem<CoordinateObservations>, CalibrateError> {
        let model = weight_model(options.weighting);
        let weights = self.each_contact(dataset, |row, tip, u0, repeatability| {
            let covariance = coordinate_covariance(model, repeatability, &tip.d_q, u0)
                .map_err(|source| CalibrateError::Observation { row, source })?;
            CoordinateWeight::from_covariance(&covariance)
                .map_err(|source| CalibrateError::Observation { row, source })
        })?;
        let charts = self.each_contact(dataset, |row, _, u0, _| {
            DirectionChart::new(u0).map_err(|source| CalibrateError::Observation { row, source })
        })?;
        // Paper mode: every contact's angles about their initial values;
        // propagated mode: only where a commanded direction seeds them.
        let angle_prior = match options.prior {
            PriorMode::Paper => true,
            PriorMode::Propagated => dataset.measurements.direction.is_some(),
            PriorMode::None => false,
        };
        let angle_sigma = angle_prior.then(|| vec![options.angle_sigma; self.order.len()]);
        let observations = CoordinateObservations {
            weights,
            charts,
            angle_sigma,
        };
        Ok(self.problem(dataset, options, observations))
    }

    /// `f(row, design tip, u0, repeatability)` for every contact, in sorted
    /// order.
    fn each_contact<T: Send>(
        &self,
        dataset: &Dataset,
        f: impl Fn(usize, &Tip, &Vec3, &Repeatability) -> Result<T, CalibrateError> + Sync,
    ) -> Result<Vec<T>, CalibrateError> {
        let balls = &dataset.artefacts.balls;
        let machine = &dataset.machine.repeatability;
        self.order
            .par_iter()
            .zip(&self.tips)
            .zip(&self.directions)
            .map(|((&row, tip), u0)| {
                let ball = &balls[dataset.measurements.ball[row] as usize];
                let repeatability = Repeatability {
                    actuator: machine.actuator,
                    tool: machine.tool,
                    radius: ball.radius_sigma,
                };
                f(row, tip, u0, &repeatability)
            })
            .collect()
    }

    fn problem<O>(
        &self,
        dataset: &Dataset,
        options: &CalibrationOptions,
        observations: O,
    ) -> CalibrationProblem<O> {
        let m = &dataset.measurements;
        let balls = &dataset.artefacts.balls;
        CalibrationProblem {
            q: self.order.iter().map(|&row| m.q[row]).collect(),
            rows: self.order.clone(),
            groups: self.groups.clone(),
            radii: balls.iter().map(|b| b.radius).collect(),
            ball_of: self.order.iter().map(|&row| m.ball[row]).collect(),
            home: self.home.clone(),
            observations,
            global_prior: self
                .prior
                .as_ref()
                .map(|prior| GaussianPrior::new(*prior.mean(), prior.information())),
            centre_priors: centre_priors(dataset, self, options.prior),
            forward_options: ForwardOptions::default(),
        }
    }
}

fn weight_model(weighting: Weighting) -> WeightModel {
    match weighting {
        Weighting::Propagated => WeightModel::Propagated,
        Weighting::Diagonal => WeightModel::Diagonal,
    }
}

/// Paper eq. (7), the prior on the 33: the paper's diagonal form (each
/// parameter about its design value with its group's tolerance) or the
/// tolerances of the input-frame coordinates propagated through the
/// canonicalisation.
pub fn kinematic_prior(
    dataset: &Dataset,
    design: &Geometry,
    design_params: &Params,
    mode: PriorMode,
) -> Result<Option<KinematicPrior>, CalibrateError> {
    let sigma = &dataset.machine.prior_sigma;
    let prior = match mode {
        PriorMode::None => return Ok(None),
        PriorMode::Paper => {
            let group_sigma = |k: usize| match k {
                _ if k < params::LEG_OFFSET => sigma.base,
                _ if k < params::LEG_OFFSET + 6 => sigma.leg,
                _ if k < params::TOOL_OFFSET => sigma.platform,
                _ => sigma.tool,
            };
            let variances = Params::from_fn(|k, _| group_sigma(k).powi(2));
            KinematicPrior::new(
                *design_params,
                SMatrix::<f64, N_PARAMS, N_PARAMS>::from_diagonal(&variances),
            )
        }
        PriorMode::Propagated => {
            let sigmas = InputSigmas {
                base: sigma.base,
                platform: sigma.platform,
                tool: sigma.tool,
                leg: sigma.leg,
            };
            KinematicPrior::propagated(design, &sigmas)
        }
    };
    prior.map(Some).map_err(CalibrateError::Prior)
}

/// Ball-centre priors: paper mode, every centre about its initial estimate
/// with the ball's `centre_sigma`; propagated mode, only when artefacts.json
/// locates the balls in the canonical base frame.
fn centre_priors(
    dataset: &Dataset,
    setup: &Setup,
    mode: PriorMode,
) -> Option<Vec<GaussianPrior<3>>> {
    let balls = &dataset.artefacts.balls;
    let means: Vec<Vec3> = match (mode, dataset.artefacts.frame) {
        (PriorMode::Paper, _) => setup.initial_centres.clone(),
        (PriorMode::Propagated, ArtefactFrame::Canonical) => {
            balls.iter().map(|b| Vec3::from(b.centre)).collect()
        }
        _ => return None,
    };
    Some(
        means
            .iter()
            .zip(balls)
            .map(|(mean, ball)| {
                GaussianPrior::from_sigmas(*mean, Vector3::repeat(ball.centre_sigma))
            })
            .collect(),
    )
}
