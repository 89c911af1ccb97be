//! Measurement planning (`parcal plan`): for a hexapod's artefact
//! calibration, which ball touches to measure, at which platform
//! orientations, so that the calibrated machine is most accurate for a
//! given number of touches; for another mechanism, [`mechanism`]. The paper
//! (Sato et al., Meas. Sci. Technol. 15 (2004) 1158) measures at random and
//! names the choice as future work; docs/plan.md gives the method and
//! the figures.
//!
//! - [`bounds`]: the bounds of every count a plan is asked for;
//! - [`pool`]: the feasible candidate touches (stroke, singularity, stylus
//!   approach);
//! - [`information`]: one touch's information row on the 33 parameters and
//!   its ball's centre and radius, linearised at the design;
//! - [`criterion`]: the registered map criterion and D, A, G;
//! - [`select`]: greedy selection, Fedorov exchange, seeded restarts;
//! - [`plan_file`]: plan.csv and plan.json;
//! - [`tracker`]: the same for the poses of an instrument calibration
//!   (laser tracker, motion capture);
//! - [`mechanism`]: which measurements to make next on a mechanism
//!   calibrated through the generic engine (a linear delta's probe
//!   heights, a cable robot's encoder samples).
//!
//! [`plan`] puts them together for a machine and its artefacts.

pub mod bounds;
pub mod criterion;
mod error;
pub mod information;
pub mod mechanism;
pub mod plan_file;
pub mod pool;
pub mod select;
pub mod tracker;

use nalgebra::{DMatrix, Vector3};
use parcal_accuracy::{CanonicalTargets, MapGrid, registered_jacobians};
use parcal_calibrate::RadiusModel;
use parcal_dataset::bounds::check_product;
use parcal_dataset::{ArtefactFrame, Artefacts, Calibration, Machine};
use parcal_kinematics::{Geometry, N_PARAMS, PARAM_NAMES, Params, Vec3, params};
use parcal_observe::{KinematicPrior, Repeatability};
use rayon::prelude::*;

pub use criterion::{Criterion, CriterionValues};
pub use error::DesignError;
pub use pool::{Candidate, NominalBall};

use criterion::MapWeights;
use information::contact_row;
use pool::{PoolOptions, candidate_pool};
use select::{Problem, SelectOptions, WEAK_CENTRE_SIGMA, ball_offset};

/// Everything a plan is asked for.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct PlanOptions {
    /// The budget: number of touches.
    pub contacts: usize,
    /// Largest |roll|, |pitch|, |yaw| (degrees).
    pub tilt_degrees: f64,
    /// What is minimised.
    pub criterion: Criterion,
    /// Approximate size of the candidate pool before the feasibility checks.
    pub pool: usize,
    /// Seed of the restarts.
    pub seed: u64,
    /// At most this many touches per ball.
    pub per_ball: Option<usize>,
    /// When the budget is below every ball's anchor touches: touch at
    /// least this many balls ([`select::SelectOptions::min_balls`]).
    pub min_balls: usize,
    /// Runs from different random seeds.
    pub restarts: usize,
    /// Largest number of exchange passes per run.
    pub passes: usize,
    /// Largest angle between the approach direction and the stylus axis
    /// (degrees).
    pub max_approach_degrees: f64,
    /// Smallest `sigma_min / sigma_max` of the scaled closure Jacobian.
    pub min_conditioning: f64,
    /// How the calibration will treat each ball's calibrated radius
    /// (`parcal calibrate --radius`; [`information`]).
    #[serde(serialize_with = "display")]
    pub radius: RadiusModel,
}

/// Serialises `value` as its `Display` text (`"ball"`, `"contact"`).
fn display<S: serde::Serializer>(
    value: &impl std::fmt::Display,
    serializer: S,
) -> Result<S::Ok, S::Error> {
    serializer.collect_str(value)
}

impl PlanOptions {
    /// `contacts` touches within `tilt_degrees`, everything else by default:
    /// the registered criterion, a pool of about 20,000, seed 1, no
    /// per-ball capacity, at least [`select::default_min_balls`] balls, one
    /// run of at most 3 exchange passes, each ball's radius an unknown (the
    /// calibration's default).
    pub fn new(contacts: usize, tilt_degrees: f64) -> Self {
        Self {
            contacts,
            tilt_degrees,
            criterion: Criterion::Registered,
            pool: 20_000,
            seed: 1,
            per_ball: None,
            min_balls: select::default_min_balls(contacts),
            restarts: 1,
            passes: 3,
            max_approach_degrees: pool::MAX_APPROACH_DEGREES,
            min_conditioning: pool::MIN_CONDITIONING,
            radius: parcal_calibrate::CalibrationOptions::default().radius,
        }
    }
}

impl PlanOptions {
    /// Checks every count against its [`bounds`], and the candidate
    /// evaluations they make against [`bounds::MAX_EVALUATIONS`], before
    /// any work.
    pub fn check(&self) -> Result<(), DesignError> {
        let refuse = DesignError::Options;
        bounds::CONTACTS
            .check("contacts", self.contacts)
            .map_err(refuse)?;
        bounds::POOL.check("pool", self.pool).map_err(refuse)?;
        bounds::RESTARTS
            .check("restarts", self.restarts)
            .map_err(refuse)?;
        bounds::MIN_BALLS
            .check("min_balls", self.min_balls)
            .map_err(refuse)?;
        if let Some(per_ball) = self.per_ball {
            bounds::PER_BALL
                .check("per_ball", per_ball)
                .map_err(refuse)?;
        }
        check_product(
            &[
                ("contacts", self.contacts),
                ("pool", self.pool),
                ("restarts", self.restarts),
            ],
            bounds::MAX_EVALUATIONS,
            "candidate evaluations, the most a plan may take (a few minutes)",
        )
        .map_err(refuse)?;
        Ok(())
    }
}

/// A plan: the touches and what they are predicted to give.
#[derive(Debug, Clone)]
pub struct Plan {
    /// The chosen touches, by ball.
    pub contacts: Vec<Candidate>,
    /// Predicted figures after calibrating the plan's touches.
    pub predicted: CriterionValues,
    /// The figures before the plan's touches: the prior's, or in sequential
    /// mode ([`plan_next`]) the calibration's.
    pub prior: CriterionValues,
    /// Number of feasible candidates the plan was chosen from.
    pub pool_size: usize,
    /// The stroke the plan respects.
    pub stroke: [f64; 2],
}

impl Plan {
    /// The plan's touches as the simulator takes them
    /// (`Scenario::plan`).
    pub fn touches(&self) -> Vec<parcal_simulate::PlannedTouch> {
        self.contacts
            .iter()
            .map(|c| parcal_simulate::PlannedTouch {
                ball: c.ball,
                direction: c.direction,
                rotation: c.rotation(),
            })
            .collect()
    }
}

/// The nominal balls of `artefacts` in the design frame of `design`.
pub fn nominal_balls(
    design: &Geometry,
    artefacts: &Artefacts,
) -> Result<Vec<NominalBall>, DesignError> {
    let canonical = design.canonicalize().map_err(DesignError::Design)?;
    let to_design = canonical.base_from_input.inverse();
    Ok(artefacts
        .balls
        .iter()
        .map(|ball| {
            let centre = Vec3::from(ball.centre);
            NominalBall {
                centre: match artefacts.frame {
                    ArtefactFrame::Design => centre,
                    ArtefactFrame::Canonical => to_design.transform_point(&centre.into()).coords,
                },
                radius: ball.radius,
            }
        })
        .collect())
}

/// Plans `options.contacts` touches of the balls of `artefacts` on the
/// machine of `machine` (module doc, docs/plan.md); `progress` hears one
/// line per stage, run and exchange pass.
pub fn plan(
    machine: &Machine,
    artefacts: &Artefacts,
    options: &PlanOptions,
    progress: &mut dyn FnMut(&str),
) -> Result<Plan, DesignError> {
    plan_with(machine, artefacts, options, None, progress)
}

/// Sequential mode: the next `options.contacts` touches after the data of
/// `calibration` (a converged calibration.json of this machine and these
/// balls). Its estimate replaces the design as the model (the rows and the
/// map are linearised there, the commands stay the design's), its
/// posterior covariance of the 33 replaces the prior, and its centre and
/// radius sigmas locate the balls it measured (their correlations with the 33 are
/// not in the record and are left out). No anchor touches: the balls are
/// located already; calibrated distances are in the posterior already.
pub fn plan_next(
    machine: &Machine,
    artefacts: &Artefacts,
    calibration: &Calibration,
    options: &PlanOptions,
    progress: &mut dyn FnMut(&str),
) -> Result<Plan, DesignError> {
    plan_with(machine, artefacts, options, Some(calibration), progress)
}

fn plan_with(
    machine: &Machine,
    artefacts: &Artefacts,
    options: &PlanOptions,
    known: Option<&Calibration>,
    progress: &mut dyn FnMut(&str),
) -> Result<Plan, DesignError> {
    options.check()?;
    let m = &machine.geometry;
    let design = Geometry::from_arrays(&m.base_joints, &m.platform_joints, &m.tool, &m.leg_lengths);
    let mut canonical = design.canonicalize().map_err(DesignError::Design)?;
    let known = known.map(Posterior::of).transpose()?;
    if let Some(posterior) = &known {
        canonical.geometry = params::from_params(&posterior.params);
    }
    let stroke = machine.stroke.ok_or(DesignError::NoStroke)?;
    let balls = nominal_balls(&design, artefacts)?;
    let pool = candidate_pool(
        &design,
        &balls,
        &PoolOptions {
            tilt: options.tilt_degrees.to_radians(),
            size: options.pool,
            max_approach: options.max_approach_degrees.to_radians(),
            min_conditioning: options.min_conditioning,
            stroke,
            scale: machine.actuator.scale,
            joint_limits: machine.joint_limits.map(|l| l.limits()),
        },
    )?;
    progress(&format!("{} feasible candidate touches", pool.len()));
    let rows = pool
        .par_iter()
        .map(|candidate| {
            let ball = &artefacts.balls[candidate.ball];
            let repeatability = Repeatability {
                actuator: machine.repeatability.actuator,
                tool: machine.repeatability.tool,
                radius: ball.radius_sigma,
            };
            contact_row(
                &design,
                &canonical,
                &balls[candidate.ball],
                candidate,
                &repeatability,
                options.radius,
            )
        })
        .collect::<Result<Vec<_>, _>>()?;
    let targets =
        CanonicalTargets::new(&design, &MapGrid::paper()).map_err(DesignError::Accuracy)?;
    let map = MapWeights::new(
        registered_jacobians(&targets, &params::to_params(&canonical.geometry))
            .map_err(DesignError::Accuracy)?,
    );
    let prior = match &known {
        None => prior_information(machine, artefacts, &design, &balls)?,
        Some(posterior) => posterior.information(artefacts)?,
    };
    let problem = Problem::new(&rows, balls.len(), prior, &map);
    let selection = problem.select(
        &SelectOptions {
            contacts: options.contacts,
            criterion: options.criterion,
            per_ball: options.per_ball,
            restarts: options.restarts,
            seed: options.seed,
            passes: options.passes,
            anchors: known.is_none(),
            min_balls: options.min_balls,
        },
        progress,
    )?;
    Ok(Plan {
        contacts: selection.chosen.iter().map(|&k| pool[k].clone()).collect(),
        predicted: selection.values,
        prior: problem.prior_values()?,
        pool_size: pool.len(),
        stroke,
    })
}

/// The prior information of the 33 parameters and the `B` balls' centres
/// and radii (`33 + 4 B` square): the propagated kinematic prior
/// (docs/paper-scenario.md section 4); per centre `I / centre_sigma²` when artefacts.json locates
/// the balls in the canonical frame, else `I /` [`WEAK_CENTRE_SIGMA`]²; per
/// radius `1 / radius_sigma²` (its calibration); and one row
/// `(e, −e) / sigma` per calibrated distance, `e` the unit vector between
/// the nominal centres (canonical frame).
fn prior_information(
    machine: &Machine,
    artefacts: &Artefacts,
    design: &Geometry,
    balls: &[NominalBall],
) -> Result<DMatrix<f64>, DesignError> {
    let kinematic =
        KinematicPrior::propagated(design, &machine.prior_sigma).map_err(DesignError::Observe)?;
    let mut information = DMatrix::zeros(ball_offset(balls.len()), ball_offset(balls.len()));
    information
        .view_mut((0, 0), (N_PARAMS, N_PARAMS))
        .copy_from(&kinematic.information());
    for (b, ball) in artefacts.balls.iter().enumerate() {
        let centre_sigma = match artefacts.frame {
            ArtefactFrame::Canonical => ball.centre_sigma,
            ArtefactFrame::Design => WEAK_CENTRE_SIGMA,
        };
        let sigmas = [centre_sigma, centre_sigma, centre_sigma, ball.radius_sigma];
        for (k, sigma) in sigmas.iter().enumerate() {
            information[(ball_offset(b) + k, ball_offset(b) + k)] += sigma.powi(-2);
        }
    }
    let rotation = design
        .canonicalize()
        .map_err(DesignError::Design)?
        .base_from_input
        .rotation;
    for distance in &artefacts.distances {
        let e: Vector3<f64> =
            rotation * (balls[distance.a].centre - balls[distance.b].centre).normalize();
        let (a, b) = (ball_offset(distance.a), ball_offset(distance.b));
        let outer = e * e.transpose() / distance.sigma.powi(2);
        for (r, c, sign) in [(a, a, 1.0), (b, b, 1.0), (a, b, -1.0), (b, a, -1.0)] {
            let mut block = information.view_mut((r, c), (3, 3));
            block += sign * outer;
        }
    }
    Ok(information)
}

/// What a calibration knows: its estimate, the information of its
/// posterior covariance, and its centres' sigmas by ball id.
struct Posterior<'a> {
    params: Params,
    information: DMatrix<f64>,
    calibration: &'a Calibration,
}

impl<'a> Posterior<'a> {
    /// Refuses a calibration that did not converge, has no covariance, or
    /// whose parameters are not the 33 of paper eq. (3) in order.
    fn of(calibration: &'a Calibration) -> Result<Self, DesignError> {
        let refuse = |why: &str| Err(DesignError::Options(format!("the calibration {why}")));
        let names = &calibration.parameters.names;
        if names.len() != N_PARAMS || names.iter().zip(PARAM_NAMES).any(|(a, b)| a != b) {
            return refuse("does not hold the 33 kinematic parameters in order");
        }
        if !calibration.converged || calibration.covariance.len() != N_PARAMS {
            return refuse("did not converge or has no posterior covariance");
        }
        let covariance = DMatrix::from_fn(N_PARAMS, N_PARAMS, |i, j| {
            calibration.covariance[i]
                .get(j)
                .copied()
                .unwrap_or(f64::NAN)
        });
        let Some(cholesky) = covariance.cholesky() else {
            return refuse("covariance is not positive definite");
        };
        Ok(Self {
            params: Params::from_column_slice(&calibration.parameters.values),
            information: cholesky.inverse(),
            calibration,
        })
    }

    /// The prior information of the 33 and the balls' centres and radii
    /// (`33 + 4 B`): the posterior's on the 33, `1/sigma²` per coordinate of
    /// the centres it estimated ([`WEAK_CENTRE_SIGMA`] for the others) and
    /// per radius it estimated (artefacts.json's `radius_sigma` for the
    /// others).
    fn information(&self, artefacts: &Artefacts) -> Result<DMatrix<f64>, DesignError> {
        let n = ball_offset(artefacts.balls.len());
        let mut information = DMatrix::zeros(n, n);
        information
            .view_mut((0, 0), (N_PARAMS, N_PARAMS))
            .copy_from(&self.information);
        for (b, ball) in artefacts.balls.iter().enumerate() {
            let estimate = self.calibration.ball_centres.get(&ball.id);
            let [x, y, z] = estimate.map_or([WEAK_CENTRE_SIGMA; 3], |e| e.sigma);
            let radius = estimate
                .and_then(|e| e.radius_sigma)
                .unwrap_or(ball.radius_sigma);
            for (k, (what, s)) in [
                ("centre", x),
                ("centre", y),
                ("centre", z),
                ("radius", radius),
            ]
            .into_iter()
            .enumerate()
            {
                if !(s.is_finite() && s > 0.0) {
                    return Err(DesignError::Options(format!(
                        "the calibration's {what} sigma of ball {} is {s}",
                        ball.id
                    )));
                }
                information[(ball_offset(b) + k, ball_offset(b) + k)] = s.powi(-2);
            }
        }
        Ok(information)
    }
}
