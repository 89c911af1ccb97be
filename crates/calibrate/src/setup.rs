//! From a dataset to the least-squares problem: the design in canonical
//! frames, the contacts sorted by ball, the initial estimates
//! (docs/paper-scenario.md section 4), the weights and the priors.
//!
//! Memory: everything per contact that is kept is small (its row, the
//! initial direction `u0` and the whitening of its weight); the design-FK
//! tips and their derivatives are computed [`LANES`] balls at a time (one per
//! SIMD lane of the kinematics) and dropped.

use std::ops::Range;

use nalgebra::{DMatrix, DVector, Dyn, Matrix3x6, SMatrix, SVector, UnitVector3, Vector6};
use parcal_dataset::{ArtefactFrame, Dataset};
use parcal_kinematics::forward_batch::{LANES, forward_derivatives_batch};
use parcal_kinematics::{
    Canonical, ForwardOptions, Geometry, N_PARAMS, Params, Pose, TipDerivatives, Vec3, params,
};
use parcal_observe::{
    CoordinateWhitening, DistanceBlock, KinematicPrior, ObserveError, RadiusWhitening,
    Repeatability, WeightModel, coordinate_covariance, radius_variance, unit_direction,
};
use parcal_solver::{GaussianPrior, State, filled, split_by};
use rayon::prelude::*;

use crate::instruments::observations::{self, group_priors, initial_block};
use crate::layout::ParameterLayout;
use crate::problem::{
    ActuatorScales, BallPrior, CalibrationProblem, CoordinateObservations, DistanceObservation,
    RadiusObservations,
};
use crate::sphere_fit::{SphereFitError, best_fit, mirror_fit};
use crate::{CalibrateError, CalibrationOptions, Observation, PriorMode, RadiusModel};

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
    /// Contacts sorted by ball: `order[k]` is the measurements.csv row (0-based,
    /// header excluded) of the k-th contact.
    pub order: Vec<u32>,
    /// Contact range of each ball in `order`.
    pub groups: Vec<Range<usize>>,
    /// The design's forward kinematics of every contact (sorted order): the
    /// solver's warm starts, to be moved into it (`std::mem::take`).
    pub poses: Vec<Pose>,
    /// The global block: the kinematic parameters, then the unknowns of the
    /// balls that calibrated distances tie together, then the groups of the
    /// poses and points if any ([`crate::mixed`]).
    pub layout: ParameterLayout,
    /// Each ball's radius an unknown, or its error in the contacts' weights.
    pub radius: RadiusModel,
}

/// The observations of every contact (sorted order), for the observation
/// equation of the options.
pub enum Observations {
    /// Paper eq. (9), one row per contact.
    Radius(RadiusObservations),
    /// Paper eq. (10), three rows and two angles per contact.
    Coordinates(CoordinateObservations),
}

/// The design geometry of machine.json.
pub fn design_geometry(dataset: &Dataset) -> Geometry {
    let m = &dataset.machine.geometry;
    Geometry::from_arrays(&m.base_joints, &m.platform_joints, &m.tool, &m.leg_lengths)
}

impl Setup {
    /// Initial estimates of docs/paper-scenario.md section 4 and the observations: `p` = the
    /// design's canonical parameters; each ball centre = the best fit of its
    /// design-FK contact points with the calibrated radius; each contact's
    /// direction `u0` = from that centre to its design-FK point, or the
    /// commanded approach direction when measurements.csv gives one; each
    /// ball's radius (when it is an unknown) = its calibrated radius; the
    /// weights at that estimate (held fixed afterwards), with the radius
    /// repeatability only when its error is taken per contact.
    pub fn new(
        dataset: &Dataset,
        options: &CalibrationOptions,
    ) -> Result<(Self, Observations), CalibrateError> {
        let design = design_geometry(dataset);
        let canonical = design.canonicalize().map_err(CalibrateError::Design)?;
        let initial_params = params::to_params(&canonical.geometry);
        let (order, groups) = sort_by_ball(dataset);

        let starts = DesignStart {
            dataset,
            canonical: &canonical,
            order: &order,
            groups: &groups,
            model: options.weighting,
            radius: options.radius,
        };
        let (initial_centres, poses, observations) = match options.observation {
            Observation::Radius => {
                let ContactStarts {
                    centres,
                    weights,
                    poses,
                    ..
                } = starts.compute::<RadiusWhitening>()?;
                (
                    centres,
                    poses,
                    Observations::Radius(RadiusObservations { weights }),
                )
            }
            Observation::Coordinates => {
                let ContactStarts {
                    centres,
                    directions,
                    weights,
                    poses,
                } = starts.compute::<CoordinateWhitening>()?;
                // Paper mode: every contact's angles about their initial
                // values; propagated mode: only where a commanded direction
                // seeds them.
                let angle_prior = match options.prior {
                    PriorMode::Paper => true,
                    PriorMode::Propagated => dataset.measurements.direction.is_some(),
                    PriorMode::None => false,
                };
                let observations = CoordinateObservations {
                    directions,
                    weights,
                    angle_sigma: angle_prior.then_some(options.angle_sigma),
                };
                (centres, poses, Observations::Coordinates(observations))
            }
        };
        let prior = kinematic_prior(dataset, &design, &initial_params, options.prior)?;
        let layout = ParameterLayout::new(
            dataset.artefacts.balls.len(),
            &tied_balls(dataset),
            options.radius == RadiusModel::PerBall,
        )
        .extended(observations::groups(dataset));
        let setup = Self {
            layout,
            radius: options.radius,
            design,
            canonical,
            initial_params,
            initial_centres,
            prior,
            order,
            groups,
            poses,
        };
        Ok((setup, observations))
    }

    /// The initial state of the solver: the design's parameters and
    /// scales, the fitted centres, with `G` = 4 the calibrated radii of
    /// `dataset`, every instrument correction and offset zero, and zero
    /// angles (`P` = 2 for the coordinate observation, 0 for the radius
    /// observation).
    pub fn initial_state<const G: usize, const P: usize>(&self, dataset: &Dataset) -> State<G, P> {
        let balls: Vec<SVector<f64, G>> = self
            .initial_centres
            .iter()
            .zip(&dataset.artefacts.balls)
            .map(|(centre, ball)| ball_vector(centre, ball.radius))
            .collect();
        let mut global = initial_block(
            &self.layout,
            &self.initial_params,
            &dataset.machine.actuator.scale,
        );
        for (k, values) in balls.iter().enumerate() {
            if let Some(range) = self.layout.ball(k) {
                global.rows_mut(range.start, G).copy_from(values);
            }
        }
        State {
            global,
            groups: balls,
            points: vec![SVector::zeros(); self.order.len()],
        }
    }

    /// Starts ball `ball` at the mirror image of its centre fit instead
    /// ([`mirror_fit`] of its design-FK contact points): returns that
    /// initial centre and writes its contacts' `u0` and weights at it into
    /// `directions` and `weights` (the ball's slots, sorted order), as if
    /// the set-up had chosen that image. For a ball that the solution shows
    /// on the wrong side of its contacts (see `run`).
    pub fn mirror_start<T: StartWhitening>(
        &self,
        dataset: &Dataset,
        weighting: WeightModel,
        ball: usize,
        directions: &mut [UnitVector3<f64>],
        weights: &mut [T],
    ) -> Result<Vec3, CalibrateError> {
        let starts = DesignStart {
            dataset,
            canonical: &self.canonical,
            order: &self.order,
            groups: &self.groups,
            model: weighting,
            radius: self.radius,
        };
        let mut poses = vec![Pose::identity(); weights.len()];
        let contacts = ContactSlots {
            directions,
            weights,
            poses: &mut poses,
        };
        let rows = &self.order[self.groups[ball].clone()];
        starts.ball(ball, rows, contacts, CentreStart::Mirror)
    }

    /// The problem of `observations` (which [`Setup::new`] returned), with
    /// `G` unknowns per ball: 3 for [`RadiusModel::PerContact`], 4 for
    /// [`RadiusModel::PerBall`] ([`RadiusModel::ball_unknowns`]).
    pub fn problem<'a, O, const G: usize>(
        &'a self,
        dataset: &'a Dataset,
        options: &CalibrationOptions,
        observations: O,
    ) -> CalibrationProblem<'a, O, G> {
        assert_eq!(
            G,
            self.radius.ball_unknowns(),
            "the ball unknowns of the radius model"
        );
        let ball_priors = ball_priors::<G>(dataset, self, options.prior);
        CalibrationProblem {
            design: self.canonical.geometry.clone(),
            q: &dataset.measurements.q,
            ball: &dataset.measurements.ball,
            rows: &self.order,
            groups: &self.groups,
            radii: dataset.artefacts.balls.iter().map(|b| b.radius).collect(),
            observations,
            layout: self.layout.clone(),
            fixed_scales: dataset.machine.actuator.scale,
            distances: self.distances(dataset),
            global_prior: self.global_prior(dataset, ball_priors.as_deref()),
            ball_priors,
            forward_options: ForwardOptions::default(),
            instruments: None,
            loss: options.loss,
        }
    }

    /// The calibrated distances of artefacts.json, on the centres in the
    /// global block (the layout holds every ball a distance names:
    /// [`tied_balls`]).
    fn distances(&self, dataset: &Dataset) -> Vec<DistanceObservation> {
        let column = |ball: usize| {
            self.layout
                .centre(ball)
                .expect("the layout holds the centre of every ball a distance names")
                .start
        };
        dataset
            .artefacts
            .distances
            .iter()
            .map(|d| DistanceObservation {
                columns: [column(d.a), column(d.b)],
                block: DistanceBlock {
                    length: d.length,
                    sigma: d.sigma,
                },
            })
            .collect()
    }

    /// The prior on the global block: the kinematic prior on its first 33
    /// values, for each ball whose unknowns are in the block and have a
    /// prior, that prior on its `G`, and the instrument groups' priors
    /// ([`group_priors`]: the scales', the later sessions'); `None` when
    /// neither the kinematic prior nor a centre prior exists.
    fn global_prior<const G: usize>(
        &self,
        dataset: &Dataset,
        ball_priors: Option<&[BallPrior<G>]>,
    ) -> Option<GaussianPrior<Dyn>> {
        let tied = |ball: usize| Some((self.layout.ball(ball)?, ball_priors?.get(ball)?));
        let any_centre = (0..self.initial_centres.len()).any(|ball| tied(ball).is_some());
        if self.prior.is_none() && !any_centre {
            return None;
        }
        let n = self.layout.size();
        let mut mean = DVector::zeros(n);
        let mut information = DMatrix::zeros(n, n);
        mean.rows_mut(0, N_PARAMS).copy_from(&self.initial_params);
        if let Some(prior) = &self.prior {
            mean.rows_mut(0, N_PARAMS).copy_from(prior.mean());
            information
                .view_mut((0, 0), (N_PARAMS, N_PARAMS))
                .copy_from(&prior.information());
        }
        for ball in 0..self.initial_centres.len() {
            if let Some((range, prior)) = tied(ball) {
                let prior = prior.gaussian();
                mean.rows_mut(range.start, G).copy_from(&prior.mean);
                information
                    .view_mut((range.start, range.start), (G, G))
                    .copy_from(&prior.information);
            }
        }
        group_priors(dataset, &self.layout, &mut mean, &mut information);
        Some(GaussianPrior::new(mean, information))
    }
}

/// The balls that calibrated distances tie together, in artefacts.json
/// order: their centres go to the global block.
fn tied_balls(dataset: &Dataset) -> Vec<usize> {
    let mut tied = vec![false; dataset.artefacts.balls.len()];
    for distance in &dataset.artefacts.distances {
        tied[distance.a] = true;
        tied[distance.b] = true;
    }
    (0..tied.len()).filter(|&ball| tied[ball]).collect()
}

/// Rows sorted by ball (stable) and each ball's range: a counting sort,
/// O(contacts), with no buffer beyond its output.
fn sort_by_ball(dataset: &Dataset) -> (Vec<u32>, Vec<Range<usize>>) {
    let balls = &dataset.measurements.ball;
    let mut groups = Vec::with_capacity(dataset.artefacts.balls.len());
    let mut start = 0;
    for count in dataset.contacts_per_ball() {
        groups.push(start..start + count);
        start += count;
    }
    let mut next: Vec<usize> = groups.iter().map(|g| g.start).collect();
    let mut order = vec![0u32; balls.len()];
    for (row, &ball) in balls.iter().enumerate() {
        order[next[ball as usize]] = row as u32;
        next[ball as usize] += 1;
    }
    (order, groups)
}

/// Initial ball centres and, per contact (sorted order), `u0` and weight.
struct ContactStarts<T> {
    centres: Vec<Vec3>,
    directions: Vec<UnitVector3<f64>>,
    weights: Vec<T>,
    poses: Vec<Pose>,
}

/// The design-FK start of every ball and contact.
struct DesignStart<'a> {
    dataset: &'a Dataset,
    canonical: &'a Canonical,
    order: &'a [u32],
    groups: &'a [Range<usize>],
    model: WeightModel,
    radius: RadiusModel,
}

impl DesignStart<'_> {
    /// Initial centres, and per contact (sorted order) its direction `u0`
    /// and its whitening at the design tip ([`StartWhitening::at_start`]).
    /// Parallel over balls.
    fn compute<T: StartWhitening>(&self) -> Result<ContactStarts<T>, CalibrateError> {
        // Each ball writes its contacts' slots of the outputs: nothing per
        // ball is collected and copied again.
        let n = self.order.len();
        let (mut directions, mut weights) = (filled(Vec3::z_axis(), n), filled(T::default(), n));
        let mut poses = filled(Pose::identity(), n);
        let lengths = || self.groups.iter().map(|g| g.len());
        let (mut ball_directions, mut ball_weights, mut ball_poses) = (
            split_by(&mut directions, lengths()),
            split_by(&mut weights, lengths()),
            split_by(&mut poses, lengths()),
        );
        // Balls in chunks of the kinematics' lanes, each ball in a lane; a
        // fixed array per chunk, so that the outcomes take no more memory
        // than one per ball.
        let centres: Vec<[Option<BallOutcome>; LANES]> = self
            .groups
            .par_chunks(LANES)
            .zip(ball_directions.par_chunks_mut(LANES))
            .zip(ball_weights.par_chunks_mut(LANES))
            .zip(ball_poses.par_chunks_mut(LANES))
            .enumerate()
            .map(|(chunk, (((groups, directions), weights), poses))| {
                let rows: Vec<&[u32]> = groups.iter().map(|g| &self.order[g.clone()]).collect();
                let mut slots: Vec<ContactSlots<'_, T>> = directions
                    .iter_mut()
                    .zip(weights.iter_mut())
                    .zip(poses.iter_mut())
                    .map(|((directions, weights), poses)| ContactSlots {
                        directions,
                        weights,
                        poses,
                    })
                    .collect();
                let mut outcomes = [const { None }; LANES];
                let kinematics = self.kinematics(&rows, &mut slots);
                for (b, (kinematics, contacts)) in
                    kinematics.into_iter().zip(&mut slots).enumerate()
                {
                    let start = CentreStart::BestFit;
                    let ball = chunk * LANES + b;
                    // Boxed: a failure is rare, and the outcomes of all
                    // balls are kept until the first failing one is known.
                    outcomes[b] = Some(
                        kinematics
                            .and_then(|k| self.settle(ball, rows[b], contacts, k, start))
                            .map_err(Box::new),
                    );
                }
                outcomes
            })
            .collect();
        drop((ball_directions, ball_weights, ball_poses));
        let centres = centres
            .into_iter()
            .flatten()
            .flatten()
            // The first failing ball in artefacts.json order, whatever the
            // threads' timing (a parallel collect into a `Result` returns
            // whichever error came first).
            .collect::<Result<_, _>>()
            .map_err(|error| *error)?;
        let mut starts = ContactStarts {
            centres,
            directions,
            weights,
            poses,
        };
        self.choose_mirror_images(&mut starts);
        Ok(starts)
    }

    /// At large tilts the design-FK points of a ball (errors of half a mm)
    /// can fit the mirror image of its centre better than the side it is on.
    /// The other balls tell: every fitted centre sits at its nominal position
    /// (artefacts.json, canonical frame) plus a common offset (the canonical
    /// frames' tilt, a few mm), taken as the component-wise median over the
    /// balls. A ball more than half its radius from where that puts it is
    /// started at its mirror image ([`mirror_fit`]) when that lies nearer.
    fn choose_mirror_images<T: StartWhitening>(&self, starts: &mut ContactStarts<T>) {
        let balls = &self.dataset.artefacts.balls;
        let nominal: Vec<Vec3> = balls
            .iter()
            .map(|ball| {
                let centre = Vec3::from(ball.centre);
                match self.dataset.artefacts.frame {
                    ArtefactFrame::Design => {
                        self.canonical
                            .base_from_input
                            .transform_point(&centre.into())
                            .coords
                    }
                    ArtefactFrame::Canonical => centre,
                }
            })
            .collect();
        let offsets: Vec<Vec3> = starts
            .centres
            .iter()
            .zip(&nominal)
            .map(|(c, n)| c - n)
            .collect();
        let shift = Vec3::from_fn(|axis, _| {
            let mut values: Vec<f64> = offsets.iter().map(|o| o[axis]).collect();
            let middle = values.len() / 2;
            // The element a sort would put there, found without sorting.
            if values.is_empty() {
                0.0
            } else {
                *values.select_nth_unstable_by(middle, f64::total_cmp).1
            }
        });
        for (ball, group) in self.groups.iter().enumerate() {
            let miss = |centre: &Vec3| (centre - nominal[ball] - shift).norm();
            if miss(&starts.centres[ball]) <= balls[ball].radius / 2.0 {
                continue;
            }
            let range = group.clone();
            let mut directions = starts.directions[range.clone()].to_vec();
            let mut weights = starts.weights[range.clone()].to_vec();
            let mut poses = starts.poses[range.clone()].to_vec();
            let slots = ContactSlots {
                directions: &mut directions,
                weights: &mut weights,
                poses: &mut poses,
            };
            let rows = &self.order[range.clone()];
            let Ok(mirror) = self.ball(ball, rows, slots, CentreStart::Mirror) else {
                continue;
            };
            if miss(&mirror) < miss(&starts.centres[ball]) {
                starts.centres[ball] = mirror;
                starts.directions[range.clone()].copy_from_slice(&directions);
                starts.weights[range.clone()].clone_from_slice(&weights);
                starts.poses[range].copy_from_slice(&poses);
            }
        }
    }

    /// The initial centre of one ball (the best fit of its design-FK contact
    /// points, or that fit's mirror image, [`mirror_fit`]); writes `u0`, the
    /// weight and the design-FK pose of its contacts (`rows`) into their
    /// slots.
    fn ball<T: StartWhitening>(
        &self,
        ball: usize,
        rows: &[u32],
        mut contacts: ContactSlots<'_, T>,
        start: CentreStart,
    ) -> Result<Vec3, CalibrateError> {
        let kinematics = self
            .kinematics(&[rows], std::slice::from_mut(&mut contacts))
            .pop()
            .expect("one ball, one outcome")?;
        self.settle(ball, rows, &mut contacts, kinematics, start)
    }

    /// The design's forward kinematics of the contacts of up to [`LANES`]
    /// balls (`rows[b]`, ball `b` in lane `b`), contact after contact, the
    /// lanes in lockstep ([`forward_derivatives_batch`]); writes each
    /// contact's pose into its ball's `slots` and gives each ball's tips and
    /// `dT/dq` per unit of the reading, or its first error. A ball's first contact
    /// starts from the home pose, each next one from the pose predicted by
    /// the previous solution (fewer Newton steps than from the home pose),
    /// and from the home pose again if that fails.
    fn kinematics<T>(
        &self,
        rows: &[&[u32]],
        slots: &mut [ContactSlots<'_, T>],
    ) -> Vec<Result<BallKinematics, CalibrateError>> {
        debug_assert!(rows.len() <= LANES, "one ball per lane");
        let (dataset, geometry) = (self.dataset, &self.canonical.geometry);
        let fk = ForwardOptions::default();
        // The design scales: leg `i` extends by `s_i q_i`.
        let scales = ActuatorScales {
            values: dataset.machine.actuator.scale,
            column: None,
        };
        let mut out: Vec<Result<BallKinematics, CalibrateError>> = rows
            .iter()
            .map(|rows| Ok(BallKinematics::with_capacity(rows.len())))
            .collect();
        // Per lane, on the stack: no allocation per contact. Ball `lanes[l]`
        // is in lane `l`, its derivatives `derivatives[l]`.
        let mut derivatives: [TipDerivatives; LANES] = Default::default();
        let mut lanes: [usize; LANES] = std::array::from_fn(|b| b);
        let mut n = rows.len();
        let mut previous: [Option<[f64; 6]>; LANES] = [None; LANES];
        let longest = rows.iter().map(|r| r.len()).max().unwrap_or(0);
        for j in 0..longest {
            // A ball out of contacts, or failed, leaves its lane; the others
            // move down in order, each with its derivatives.
            let mut kept = 0;
            for l in 0..n {
                let b = lanes[l];
                if j < rows[b].len() && out[b].is_ok() {
                    if kept != l {
                        derivatives.swap(kept, l);
                    }
                    lanes[kept] = b;
                    kept += 1;
                }
            }
            n = kept;
            let mut q = [[0.0; 6]; LANES];
            let mut predicted: [Option<Pose>; LANES] = [None; LANES];
            let mut starts = [Pose::identity(); LANES];
            for (l, &b) in lanes[..n].iter().enumerate() {
                let reading = scales.extensions(&dataset.measurements.q[rows[b][j] as usize]);
                predicted[l] = previous[b].map(|before| {
                    derivatives[l].predicted_pose(&Vector6::from_fn(|i, _| reading[i] - before[i]))
                });
                previous[b] = Some(reading);
                starts[l] = predicted[l].unwrap_or_else(|| geometry.home_pose(&reading));
                q[l] = reading;
            }
            let q_refs: [&[f64; 6]; LANES] = std::array::from_fn(|l| &q[l]);
            let solved = forward_derivatives_batch(
                geometry,
                &q_refs[..n],
                &starts[..n],
                &fk,
                &mut derivatives[..n],
            )
            .is_ok();
            for (l, &b) in lanes[..n].iter().enumerate() {
                let row = rows[b][j] as usize;
                let near = |start: Pose| landed(geometry, &derivatives[l].solution().pose, &start);
                let reached = if solved && predicted[l].is_none_or(near) {
                    Ok(())
                } else {
                    // The lanes tried the prediction if they solved.
                    let untried = predicted[l].filter(|_| !solved);
                    one_contact(geometry, &mut derivatives[l], &q[l], untried, row)
                };
                match (reached, &mut out[b]) {
                    (Err(error), slot) => *slot = Err(error),
                    (Ok(()), Ok(kinematics)) => {
                        let pose = derivatives[l].solution().pose;
                        slots[b].poses[j] = pose;
                        kinematics.points.push(geometry.tool_tip(&pose));
                        // dT/dq per unit of the reading: J_q diag(s).
                        let mut d_q = derivatives[l].d_q();
                        for (mut column, scale) in d_q.column_iter_mut().zip(scales.values) {
                            column *= scale;
                        }
                        kinematics.d_q.push(d_q);
                    }
                    // Not a lane: a ball that failed has none.
                    (Ok(()), Err(_)) => {}
                }
            }
        }
        out
    }

    /// The initial centre of ball `ball` from the design-FK `kinematics`
    /// of its contacts (`rows`): the best fit of their tips or its mirror
    /// image (`start`); writes their `u0` and weights into `contacts`.
    fn settle<T: StartWhitening>(
        &self,
        ball: usize,
        rows: &[u32],
        contacts: &mut ContactSlots<'_, T>,
        kinematics: BallKinematics,
        start: CentreStart,
    ) -> Result<Vec3, CalibrateError> {
        let dataset = self.dataset;
        let BallKinematics { points, d_q } = kinematics;
        let artefact = &dataset.artefacts.balls[ball];
        let fit_error = |source| CalibrateError::CentreFit {
            ball: artefact.id.clone(),
            source,
        };
        // A fit that crawls along a valley of its cost (a few close points
        // whose design-FK errors are a tenth of the radius, as at large
        // tilts, or a blunder among them) still ends downhill of its start:
        // the data cannot place the centre along that valley at the design's
        // accuracy, the calibration's iterations do (and its checks name
        // the blunder). So for the fit of the mirror image.
        let settled = |fit| match fit {
            Err(SphereFitError::NotConverged { last }) => Ok(last),
            fit => fit.map_err(fit_error),
        };
        let fit = settled(best_fit(&points, artefact.radius))?;
        let centre = match start {
            CentreStart::BestFit => fit.centre,
            CentreStart::Mirror => settled(mirror_fit(&points, artefact.radius, &fit))?.centre,
        };
        let machine = &dataset.machine.repeatability;
        // A per-ball radius carries its error as an unknown with a prior,
        // not in the weights.
        let repeatability = Repeatability {
            actuator: machine.actuator,
            tool: machine.tool,
            radius: match self.radius {
                RadiusModel::PerContact => artefact.radius_sigma,
                RadiusModel::PerBall => 0.0,
            },
        };
        for (k, ((&row, tip), d_q)) in rows.iter().zip(&points).zip(&d_q).enumerate() {
            let row = row as usize;
            let observation_error = |source| CalibrateError::Observation { row, source };
            let direction = match &dataset.measurements.direction {
                Some(commanded) => {
                    let d = Vec3::from(commanded[row]);
                    match dataset.artefacts.frame {
                        ArtefactFrame::Design => self.canonical.base_from_input.rotation * d,
                        ArtefactFrame::Canonical => d,
                    }
                }
                None => tip - centre,
            };
            let u0 = unit_direction(&direction).map_err(observation_error)?;
            contacts.weights[k] =
                T::at_start(self.model, &repeatability, d_q, &u0).map_err(observation_error)?;
            contacts.directions[k] = u0;
        }
        Ok(centre)
    }
}

/// How far (mm) the tip solved from a predicted start may land from the
/// predicted tip: the prediction's error is second order in the readings'
/// change (contacts of one ball tens of degrees apart); another assembly
/// of the machine lies tens of mm away.
const PREDICTION_TOLERANCE_MM: f64 = 5.0;

/// Whether a solution from a predicted start landed near it: Newton's
/// method from a first-order prediction far off (contacts of one ball at
/// orientations tens of degrees apart) can converge to another assembly of
/// the machine, and its tip must land within [`PREDICTION_TOLERANCE_MM`]
/// of the predicted one.
fn landed(geometry: &Geometry, pose: &Pose, start: &Pose) -> bool {
    (geometry.tool_tip(pose) - geometry.tool_tip(start)).norm() <= PREDICTION_TOLERANCE_MM
}

/// The design's forward kinematics of one contact (measurements.csv row
/// `row`, leg extensions `q`) into `derivatives`, one by one: from the
/// `predicted` pose if one is given and it lands near it, else from the
/// home pose; an error naming the row.
fn one_contact(
    geometry: &Geometry,
    derivatives: &mut TipDerivatives,
    q: &[f64; 6],
    predicted: Option<Pose>,
    row: usize,
) -> Result<(), CalibrateError> {
    let fk = ForwardOptions::default();
    let from_prediction = predicted.is_some_and(|start| {
        derivatives.forward(geometry, q, &start, &fk).is_ok()
            && landed(geometry, &derivatives.solution().pose, &start)
    });
    if from_prediction {
        return Ok(());
    }
    derivatives
        .forward(geometry, q, &geometry.home_pose(q), &fk)
        .map_err(|source| CalibrateError::ForwardKinematics { row, source })
}

/// A ball's initial centre, or why it has none (boxed: a failure is rare).
type BallOutcome = Result<Vec3, Box<CalibrateError>>;

/// The design-FK tips of one ball's contacts and their `dT/dq` per unit of
/// the reading (sorted order).
struct BallKinematics {
    points: Vec<Vec3>,
    d_q: Vec<Matrix3x6<f64>>,
}

impl BallKinematics {
    fn with_capacity(contacts: usize) -> Self {
        Self {
            points: Vec::with_capacity(contacts),
            d_q: Vec::with_capacity(contacts),
        }
    }
}

/// One ball's slots of the per-contact outputs.
struct ContactSlots<'s, T> {
    directions: &'s mut [UnitVector3<f64>],
    weights: &'s mut [T],
    poses: &'s mut [Pose],
}

/// Which local minimum of a ball's centre fit starts the calibration.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum CentreStart {
    /// The best fit (docs/paper-scenario.md section 4).
    BestFit,
    /// Its mirror image through the contacts' plane ([`mirror_fit`]).
    Mirror,
}

/// The whitening of one kind of observation, computed once at the initial
/// estimate: the tip covariance propagated through `J_q = dT/dq` and the
/// repeatabilities, at the contact's initial direction `u0`.
pub trait StartWhitening: Send + Sync + Default + Clone {
    /// The whitening of a contact with tip derivatives `d_q` and initial
    /// direction `u0`, under `model` and the machine's `repeatability`.
    fn at_start(
        model: WeightModel,
        repeatability: &Repeatability,
        d_q: &Matrix3x6<f64>,
        u0: &Vec3,
    ) -> Result<Self, ObserveError>;
}

impl StartWhitening for RadiusWhitening {
    fn at_start(
        model: WeightModel,
        repeatability: &Repeatability,
        d_q: &Matrix3x6<f64>,
        u0: &Vec3,
    ) -> Result<Self, ObserveError> {
        RadiusWhitening::from_variance(radius_variance(model, repeatability, d_q, u0)?)
    }
}

impl StartWhitening for CoordinateWhitening {
    fn at_start(
        model: WeightModel,
        repeatability: &Repeatability,
        d_q: &Matrix3x6<f64>,
        u0: &Vec3,
    ) -> Result<Self, ObserveError> {
        CoordinateWhitening::from_covariance(&coordinate_covariance(model, repeatability, d_q, u0)?)
    }
}

/// The observations of a kind whose balls can be re-seeded at the mirror
/// image of their centre fit ([`Setup::mirror_start`]).
pub trait MirrorStart {
    /// The whitening of one contact of this kind.
    type Weight: StartWhitening;

    /// The `u0` (if the observation keeps one) and the weights of the
    /// contacts `range` (sorted order).
    fn starts(
        &mut self,
        range: Range<usize>,
    ) -> (Option<&mut [UnitVector3<f64>]>, &mut [Self::Weight]);

    /// Re-seeds ball `ball` of `setup` (its contacts' `u0` and weights);
    /// returns its new initial centre.
    fn mirror_start(
        &mut self,
        setup: &Setup,
        dataset: &Dataset,
        weighting: WeightModel,
        ball: usize,
    ) -> Result<Vec3, CalibrateError> {
        let range = setup.groups[ball].clone();
        let mut scratch = Vec::new();
        let (directions, weights) = self.starts(range.clone());
        let directions = directions.unwrap_or_else(|| {
            scratch.resize(range.len(), Vec3::z_axis());
            &mut scratch
        });
        setup.mirror_start(dataset, weighting, ball, directions, weights)
    }
}

impl MirrorStart for RadiusObservations {
    type Weight = RadiusWhitening;

    /// The radius observation keeps no direction.
    fn starts(
        &mut self,
        range: Range<usize>,
    ) -> (Option<&mut [UnitVector3<f64>]>, &mut [RadiusWhitening]) {
        (None, &mut self.weights[range])
    }
}

impl MirrorStart for CoordinateObservations {
    type Weight = CoordinateWhitening;

    fn starts(
        &mut self,
        range: Range<usize>,
    ) -> (Option<&mut [UnitVector3<f64>]>, &mut [CoordinateWhitening]) {
        (
            Some(&mut self.directions[range.clone()]),
            &mut self.weights[range],
        )
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
        PriorMode::Propagated => KinematicPrior::propagated(design, sigma),
    };
    prior.map(Some).map_err(CalibrateError::Prior)
}

/// A ball's unknowns: its centre and, with `G` = 4, its radius.
fn ball_vector<const G: usize>(centre: &Vec3, radius: f64) -> SVector<f64, G> {
    SVector::from_fn(|k, _| if k < 3 { centre[k] } else { radius })
}

/// The priors of the balls' unknowns. The centres': paper mode, every
/// centre about its initial estimate with the ball's `centre_sigma`;
/// propagated mode, only when artefacts.json locates the balls in the
/// canonical base frame. With `G` = 4, every ball's radius about its
/// calibrated value with its `radius_sigma` (the calibration's statement,
/// in every prior mode); a ball without a centre prior then has zero
/// information on its centre. `None` when no ball has a prior.
fn ball_priors<const G: usize>(
    dataset: &Dataset,
    setup: &Setup,
    mode: PriorMode,
) -> Option<Vec<BallPrior<G>>> {
    let balls = &dataset.artefacts.balls;
    let means: Option<Vec<Vec3>> = match (mode, dataset.artefacts.frame) {
        (PriorMode::Paper, _) => Some(setup.initial_centres.clone()),
        (PriorMode::Propagated, ArtefactFrame::Canonical) => {
            Some(balls.iter().map(|b| Vec3::from(b.centre)).collect())
        }
        _ => None,
    };
    if means.is_none() && G == 3 {
        return None;
    }
    Some(
        balls
            .iter()
            .enumerate()
            .map(|(k, ball)| {
                let centre = means.as_ref().map(|m| m[k]);
                let mean = ball_vector(&centre.unwrap_or(setup.initial_centres[k]), ball.radius);
                let centre_sigma = if centre.is_some() {
                    ball.centre_sigma
                } else {
                    f64::INFINITY
                };
                let sigma = ball_vector(&Vec3::repeat(centre_sigma), ball.radius_sigma);
                BallPrior { mean, sigma }
            })
            .collect(),
    )
}
