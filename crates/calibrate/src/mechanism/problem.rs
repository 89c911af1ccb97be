//! A mechanism calibration as the solver's problem.
//!
//! - The **global block**: the mechanism's parameters `p`, then the
//!   trigger height `h` when there are probe heights, then each tracker's
//!   frame correction and each re-homed tracker's actuator offsets, and
//!   with tracker poses the body frame's correction
//!   ([`super::trackers`]), then the centre (and
//!   uncertain radius) of every ball a ball distance ties
//!   ([`super::tied`]).
//! - The **global observations**: every probe height (1 row), part
//!   distance (1 row), measured point (3 rows), measured quantity (1 row),
//!   ball distance (1 row), tracker point (3 rows) and tracker pose (one
//!   row per actuator), in that order
//!   ([`parcal_observe::mechanism`]).
//! - The **local blocks**, the solver's groups, eliminated by the Schur
//!   complement: first the pose of every point sample (with a Gaussian
//!   prior when it was measured), then the centre of every ball (held
//!   fixed for a tied ball, whose unknowns are global). A group's
//!   rows are its points, one row each (the solver's point blocks are
//!   empty): a sample's one row per actuator, a ball's one row per touch
//!   (the touches taken in the order of their balls,
//!   [`MechanismProblem::touch_order`]). A robust loss weighs each row on
//!   its own.
//! - **Uncertain radii**: when some ball's radius has a calibration sigma,
//!   every block has a fourth unknown ([`group_size`] 4), a ball's radius
//!   with that sigma as its prior, so that the radii stay in their balls'
//!   blocks and the reduced system keeps the size of the global block. A
//!   block that has no radius (a sample's, an exact ball's) holds its
//!   fourth unknown, which no row sees, by a unit prior: one row for one
//!   unknown, so the redundancy is that of three.
//! - A ball's **centre prior**, when it has one, is its group's prior on
//!   its centre.
//! - The **prior** on the global block: each parameter's
//!   [`ParameterPrior`](super::data::ParameterPrior) with a sigma, with
//!   their correlation if any, and the trigger height's ([`super::prior`]);
//!   a tied ball's centre prior and its radius's calibration sigma.

use std::ops::Range;

use nalgebra::{Const, DMatrix, DVector, Dyn, OMatrix, SVector, Vector3};
use parcal_kinematics::mechanism::{MechanismError, Reached, ReachedAlong};
use parcal_observe::mechanism::{Actuation, BallTouch, RadiusRow, SampleRows};
use parcal_solver::{GaussianPrior, Linearization, Loss, Problem, State, filled};
use rayon::prelude::*;

use super::data::MechanismData;
use super::error::{MechanismCalibrationError, failed};
use super::observation::{ObservationKind, ObservationRef, touch_ref};
use super::prior::{global_prior, global_priors, prior_means};
use super::reaches::{Reaches, TouchBatch, batch_rooms};
use super::tied::TiedBalls;
use super::touch_start::TouchStart;
use super::touched_ball::{TouchedBall, ball_centre, ball_rooms, put_ball_columns, touch_failed};
use super::trackers::Trackers;
use super::warm_start::WarmStart;

/// The solver's problem: groups of `C` unknowns (a sample's pose, a
/// ball's centre, and with [`group_size`] 4 a ball's radius), no point
/// unknowns, one row per point.
pub(super) type Local<const C: usize> = Linearization<C, 0, 1, OMatrix<f64, Const<1>, Dyn>>;

/// The unknowns of each local block of `data` (module doc): 4 when some
/// ball's radius has a calibration sigma, else 3.
pub(crate) fn group_size(data: &MechanismData) -> usize {
    let balls = &data.observations.balls;
    if balls.iter().any(|ball| ball.radius_sigma.is_some()) {
        4
    } else {
        3
    }
}

/// The number of touches whose start [`MechanismProblem::touches_at_start`]
/// takes at a time: enough that what the mechanism builds of the
/// parameters for them is made seldom, few enough for the threads to share.
const START_CHUNK: usize = 1024;

/// The sigma of the unit prior that holds a block's unused fourth unknown
/// (module doc).
pub(super) const UNUSED: f64 = 1.0;

/// The problem of [`MechanismData`] (module doc), its local blocks of `C`
/// unknowns ([`group_size`]).
pub(crate) struct MechanismProblem<'a, const C: usize> {
    pub(super) data: &'a MechanismData,
    pub(super) prior: Option<GaussianPrior<Dyn>>,
    pub(super) loss: Loss,
    /// The number of points of the samples' rows, before the touches'
    /// (made once: each touch's lookup needs it).
    sample_points: usize,
    /// The touches in the order of their balls (stable).
    touch_order: Vec<usize>,
    /// The points of each ball, after the samples' rows.
    pub(super) ball_points: Vec<Range<usize>>,
    /// The tied balls' places in the global block.
    pub(super) tied: TiedBalls,
    /// The trackers' references and places in the global block.
    pub(super) trackers: Trackers,
}

impl<'a, const C: usize> MechanismProblem<'a, C> {
    /// The problem of `data` (validated) with `loss` on its observations,
    /// its trackers located at the priors' means ([`Trackers::locate`],
    /// whose error it returns).
    pub(crate) fn new(
        data: &'a MechanismData,
        loss: Loss,
    ) -> Result<Self, MechanismCalibrationError> {
        let o = &data.observations;
        let m = global_priors(data).len();
        let n = data.configured.len();
        let frames = n + usize::from(data.has_trigger_height());
        let trackers = Trackers::locate(data, &prior_means(data).as_slice()[..n], frames)?;
        let tied = o.tied_balls(m);
        let prior = global_prior(data, &tied);
        let (counts, grouped) = o.touches_per_ball();
        // Each ball's touches in their order (the identity for data
        // grouped by ball, which needs no sort).
        let mut touch_order: Vec<usize> = (0..o.touches.len()).collect();
        if !grouped {
            touch_order.sort_by_key(|&t| o.touches[t].ball);
        }
        let mut ball_points = Vec::with_capacity(o.balls.len());
        let sample_points = o.samples.len() * data.mechanism.actuators().len();
        let mut first = sample_points;
        for count in counts {
            ball_points.push(first..first + count);
            first += count;
        }
        debug_assert_eq!(C, group_size(data), "the blocks' size is the data's");
        Ok(Self {
            data,
            prior,
            loss,
            sample_points,
            touch_order,
            ball_points,
            tied,
            trackers,
        })
    }

    /// The number of the mechanism's parameters (the first values of the
    /// global block).
    pub(crate) fn n_params(&self) -> usize {
        self.data.configured.len()
    }

    /// The size of the global block (module doc).
    pub(crate) fn global_len(&self) -> usize {
        self.mechanism_len() + self.tied.unknowns()
    }

    /// The size of the global block's first part, the mechanism's: its
    /// parameters, the trigger height when there are probe heights, and
    /// the trackers' frames.
    pub(crate) fn mechanism_len(&self) -> usize {
        global_priors(self.data).len()
    }

    /// The data.
    pub(crate) fn data(&self) -> &MechanismData {
        self.data
    }

    /// The tied balls' places in the global block.
    pub(crate) fn tied(&self) -> &TiedBalls {
        &self.tied
    }

    /// The trackers' references and places in the global block.
    pub(crate) fn trackers(&self) -> &Trackers {
        &self.trackers
    }

    /// The solver's start: the mechanism's part of the global block at its
    /// priors' means, every local block as [`Self::start_blocks`] starts
    /// it, a tied ball's centre and radius at that start in the global
    /// block; and every point's cache there (the pose each touch reached,
    /// the first pass's warm start).
    pub(crate) fn start_state(&self) -> Result<Start<C>, MechanismCalibrationError> {
        let mut global = prior_means(self.data).resize_vertically(self.global_len(), 0.0);
        let n = self.n_params();
        let (groups, caches, tips) = self.start_blocks(&global.as_slice()[..n])?;
        let samples = self.data.observations.samples.len();
        for (b, columns) in self.tied.iter() {
            let unknowns = columns.len();
            global
                .rows_mut(columns.start, unknowns)
                .copy_from(&groups[samples + b].rows(0, unknowns));
        }
        let state = State {
            global,
            groups,
            points: vec![SVector::zeros(); self.n_points()],
        };
        Ok(Start {
            state,
            caches,
            tips,
        })
    }

    /// The prior information on the global block (zero where none).
    pub(crate) fn prior_information(&self) -> DMatrix<f64> {
        let g = self.global_len();
        self.prior
            .as_ref()
            .map_or_else(|| DMatrix::zeros(g, g), |p| p.information.clone())
    }

    /// The number of point samples' rows (the first points).
    fn sample_points(&self) -> usize {
        self.sample_points
    }

    /// The mechanism's number of actuators: a point sample's rows.
    pub(crate) fn actuators(&self) -> usize {
        self.data.mechanism.actuators().len()
    }

    /// The number of points: every sample's rows, then every touch.
    pub(crate) fn n_points(&self) -> usize {
        self.sample_points() + self.touch_order.len()
    }

    /// The touches in the order of their points (sorted by ball).
    pub(crate) fn touch_order(&self) -> &[usize] {
        &self.touch_order
    }

    /// The global observations, each with its number of rows, in the order
    /// of their rows.
    pub(crate) fn global_observation_refs(&self) -> Vec<(ObservationRef, usize)> {
        let o = &self.data.observations;
        let refs =
            |kind, count, rows| (0..count).map(move |index| (ObservationRef { kind, index }, rows));
        refs(ObservationKind::Probe, o.probes.len(), 1)
            .chain(refs(
                ObservationKind::ManualHeight,
                o.manual_heights.len(),
                1,
            ))
            .chain(refs(ObservationKind::Distance, o.distances.len(), 1))
            .chain(refs(ObservationKind::Point, o.points.len(), 3))
            .chain(refs(ObservationKind::Quantity, o.quantities.len(), 1))
            .chain(refs(
                ObservationKind::BallDistance,
                o.ball_distances.len(),
                1,
            ))
            .chain(refs(
                ObservationKind::TrackerPoint,
                o.tracker_points.len(),
                3,
            ))
            .chain(refs(
                ObservationKind::TrackerPose,
                o.tracker_poses.len(),
                self.data.mechanism.actuators().len(),
            ))
            .collect()
    }

    /// The start of every local block: each point sample's pose (its
    /// measured pose, else the forward kinematics of its readings at
    /// `params`), then each ball's centre ([`ball_centre`]; the data's
    /// touch start's if they have one, [`Self::touches_at_start`]) and, with
    /// [`group_size`] 4, its calibrated radius; with every point's cache
    /// (empty for a sample's, the warm start of the pose reached for a
    /// touch's) and every touch's tool point there, in the order of the
    /// points.
    pub(crate) fn start_blocks(&self, params: &[f64]) -> StartBlocks<C> {
        let mechanism = self.data.mechanism.as_ref();
        let o = &self.data.observations;
        let mut blocks = Vec::with_capacity(o.samples.len() + o.balls.len());
        for (index, sample) in o.samples.iter().enumerate() {
            if let Some((pose, _)) = sample.known_pose {
                blocks.push(block(&Vector3::from(pose), 0.0));
                continue;
            }
            let pose = mechanism
                .start_pose(params, &sample.readings)
                .and_then(|start| mechanism.forward(params, &sample.readings, start.as_slice()))
                .map_err(|e| MechanismCalibrationError::Observation {
                    observation: ObservationRef {
                        kind: ObservationKind::Sample,
                        index,
                    },
                    reason: format!("no start pose from its readings: {e}"),
                })?;
            blocks.push(block(&Vector3::new(pose[0], pose[1], pose[2]), 0.0));
        }
        // Each ball on the threads, its touches' warm starts and tool
        // points written in their places; the first failing ball named.
        // With a touch start, the touches where it put them, a chunk of
        // them at a time, and each ball at its centre.
        let configured = self.data.configured.as_slice();
        let samples = self.sample_points();
        let mut caches = filled(WarmStart::default(), samples + self.touch_order.len());
        let mut tips = filled(Vector3::zeros(), self.touch_order.len());
        let centres: Vec<Result<SVector<f64, C>, MechanismCalibrationError>> =
            match &self.data.touch_start {
                Some(start) => {
                    self.touches_at_start(params, start, &mut caches[samples..], &mut tips)?;
                    (o.balls.iter().zip(&start.centres))
                        .map(|(ball, centre)| Ok(block(&Vector3::from(*centre), ball.radius)))
                        .collect()
                }
                None => {
                    let rooms = ball_rooms(&self.ball_points, &mut caches[samples..], &mut tips);
                    (o.balls.par_iter().enumerate().zip(rooms))
                        .map_init(Vec::new, |reached, ((b, ball), fit)| {
                            let points = &self.ball_points[b];
                            let touches =
                                &self.touch_order[points.start - samples..points.end - samples];
                            let centre = ball_centre(
                                mechanism,
                                params,
                                configured,
                                &o.touches,
                                touches,
                                b,
                                ball.radius,
                                reached,
                                fit,
                            )?;
                            Ok(block(&centre, ball.radius))
                        })
                        .collect()
                }
            };
        for centre in centres {
            blocks.push(centre?);
        }
        Ok((blocks, caches, tips))
    }

    /// Each touch where `start` put it (the touch points' `caches` and
    /// `tips`, in their order): its warm start, and its tool point `T(p,
    /// x)` at parameters `params` there
    /// ([`Mechanism::tool_points_at_warm_starts`], which builds what it
    /// needs of `p` once for a chunk of [`START_CHUNK`] touches), on the
    /// threads. No forward kinematics: the pose is where the other set-up
    /// reached the touch's readings, and the first pass starts there. The
    /// first failing touch named.
    fn touches_at_start(
        &self,
        params: &[f64],
        start: &TouchStart,
        caches: &mut [WarmStart],
        tips: &mut [Vector3<f64>],
    ) -> Result<(), MechanismCalibrationError> {
        let mechanism = self.data.mechanism.as_ref();
        let len = mechanism.warm_start_len();
        let chunks = (self.touch_order.par_chunks(START_CHUNK))
            .zip(caches.par_chunks_mut(START_CHUNK))
            .zip(tips.par_chunks_mut(START_CHUNK));
        let outcomes: Vec<Result<(), MechanismCalibrationError>> = chunks
            .map(|((touches, caches), tips)| {
                let starts: Vec<&[f64]> = (touches.iter())
                    .map(|&t| start.warm_start(t, len))
                    .collect();
                let reached = mechanism.tool_points_at_warm_starts(params, &starts);
                let rooms = tips.iter_mut().zip(caches.iter_mut());
                for (((&t, tip), warm_start), (room, cache)) in
                    touches.iter().zip(reached).zip(&starts).zip(rooms)
                {
                    *room = tip.map_err(|e| failed(touch_ref(t), e))?;
                    *cache = WarmStart::of(warm_start);
                }
                Ok(())
            })
            .collect();
        outcomes.into_iter().collect()
    }

    /// The rows of point sample `s` at its pose.
    fn sample_rows(
        &self,
        s: usize,
        global: &DVector<f64>,
        block: &SVector<f64, C>,
    ) -> Result<SampleRows, MechanismCalibrationError> {
        let n = self.n_params();
        self.data.observations.samples[s]
            .evaluate(
                self.data.mechanism.as_ref(),
                &global.as_slice()[..n],
                &block.as_slice()[..3],
            )
            .map_err(|e| {
                failed(
                    ObservationRef {
                        kind: ObservationKind::Sample,
                        index: s,
                    },
                    e,
                )
            })
    }

    /// The row of touch point `i` that reached `reached` on its ball
    /// `ball` into `out`, the warm start of the pose it reached left in
    /// `cache` (the start of its next evaluation).
    fn touch_row(
        &self,
        i: usize,
        ball: &TouchedBall,
        reached: &Result<Reached, MechanismError>,
        cache: &mut WarmStart,
        out: &mut Local<C>,
    ) -> Result<(), MechanismCalibrationError> {
        let (reached, row) = self.radius_row(i, ball, reached, |r| r)?;
        *cache = WarmStart::of(reached.warm_start.as_slice());
        // uᵀ dT/dp |_q over σ, the other columns zero.
        let n = self.n_params();
        let (params, others) = out.d_global.as_mut_slice().split_at_mut(n);
        row.d_params(&reached.d_params, params);
        others.fill(0.0);
        put_touch_local(out, &row, ball);
        Ok(())
    }

    /// [`MechanismProblem::touch_row`] of a touch reached along the global
    /// step `dg` (`along`, [`MechanismProblem::reach_along`]): its row but
    /// `d_global` into `out`, the warm start predicted after the step left
    /// in `cache`, and `d_global · dg` returned (the parameters' share from
    /// `dT/dp |_q · dp`, a tied ball's from its columns).
    fn touch_row_along(
        &self,
        i: usize,
        ball: &TouchedBall,
        along: &Result<ReachedAlong, MechanismError>,
        dg: &DVector<f64>,
        cache: &mut WarmStart,
        out: &mut Local<C>,
    ) -> Result<SVector<f64, 1>, MechanismCalibrationError> {
        let (along, row) = self.radius_row(i, ball, along, |a| &a.reached)?;
        let reached = &along.reached;
        *cache = WarmStart::of(along.predicted.as_slice());
        put_touch_local(out, &row, ball);
        let mut params_step = SVector::<f64, 1>::zeros();
        row.d_params(&reached.d_params, params_step.as_mut_slice());
        let d_radius = SVector::<f64, 1>::new(row.d_radius());
        Ok(params_step + ball.tied_step(&row.d_centre(), &d_radius, dg))
    }

    /// Touch point `i`'s radius row ([`BallTouch::radius_row`]) on its
    /// ball `ball` where `outcome` reached (`reached` of it), with that
    /// outcome; the touch named in an error.
    fn radius_row<'r, T>(
        &self,
        i: usize,
        ball: &TouchedBall,
        outcome: &'r Result<T, MechanismError>,
        reached: impl Fn(&T) -> &Reached,
    ) -> Result<(&'r T, RadiusRow), MechanismCalibrationError> {
        let (t, touch) = self.touch_of(i);
        let failed = |e: &MechanismError| touch_failed(t, touch.ball, e);
        let outcome = outcome.as_ref().map_err(failed)?;
        let point = &reached(outcome).point;
        let row = (touch.radius_row(point, &ball.centre, ball.radius)).map_err(|e| failed(&e))?;
        Ok((outcome, row))
    }

    /// Touch point `i`'s touch: its index and itself.
    pub(crate) fn touch_of(&self, i: usize) -> (usize, &BallTouch) {
        let t = self.touch_at(i);
        (t, &self.data.observations.touches[t])
    }

    /// The ball of the group whose touch point `first` is (every touch
    /// point of a group is its ball's), its unknowns at the global block
    /// `global` and the group's block `block`
    /// ([`MechanismProblem::touched_ball`]).
    pub(crate) fn group_ball(
        &self,
        first: usize,
        global: &DVector<f64>,
        block: &SVector<f64, C>,
    ) -> TouchedBall {
        let (_, touch) = self.touch_of(first);
        self.touched_ball(touch.ball, global, block)
    }

    /// Ball `b`'s centre set to `centre` in the global block `global` when
    /// it is tied, else in its group's block among `groups`.
    pub(crate) fn place_ball(
        &self,
        b: usize,
        centre: &Vector3<f64>,
        global: &mut DVector<f64>,
        groups: &mut [SVector<f64, C>],
    ) {
        match self.tied.column(b) {
            Some(column) => global.rows_mut(column, 3).copy_from(centre),
            None => {
                let k = self.data.observations.samples.len() + b;
                groups[k].fixed_rows_mut::<3>(0).copy_from(centre);
            }
        }
    }

    /// The touch of touch point `i`.
    pub(crate) fn touch_at(&self, i: usize) -> usize {
        self.touch_order[i - self.sample_points()]
    }

    /// Ball `b`'s centre and radius (its calibrated radius when exact):
    /// from the global block `global` for a tied ball, from its group's
    /// block `block` for any other.
    pub(crate) fn touched_ball(
        &self,
        b: usize,
        global: &DVector<f64>,
        block: &SVector<f64, C>,
    ) -> TouchedBall {
        match self.tied.column(b) {
            Some(column) => self.ball_of(b, &global.as_slice()[column..], Some(column)),
            None => self.ball_of(b, block.as_slice(), None),
        }
    }

    /// Ball `b` as its group's block `block` holds it; `None` for a tied
    /// ball, whose unknowns are in the global block.
    pub(crate) fn ball_in_group(&self, b: usize, block: &SVector<f64, C>) -> Option<TouchedBall> {
        match self.tied.column(b) {
            Some(_) => None,
            None => Some(self.ball_of(b, block.as_slice(), None)),
        }
    }

    /// Ball `b` from `unknowns`, which start with its centre, then its
    /// radius when uncertain; tied at the global column `tied`, if any.
    fn ball_of(&self, b: usize, unknowns: &[f64], tied: Option<usize>) -> TouchedBall {
        let ball = &self.data.observations.balls[b];
        let uncertain = ball.radius_sigma.is_some();
        TouchedBall {
            centre: Vector3::new(unknowns[0], unknowns[1], unknowns[2]),
            radius: if uncertain { unknowns[3] } else { ball.radius },
            tied,
            uncertain,
        }
    }

    /// Where the machine is at the touch points `points` (one group's, of
    /// touches), each from the pose in its cache: together, so that a
    /// mechanism may reach them at once ([`Actuation::tool_points`]), into
    /// `reaches.at`.
    pub(crate) fn reach(
        &self,
        points: Range<usize>,
        global: &DVector<f64>,
        caches: &[WarmStart],
        reaches: &mut Reaches,
    ) {
        batch_rooms(&mut reaches.at, &mut reaches.spare_at, points.len());
        Actuation::tool_points(
            self.data.mechanism.as_ref(),
            &global.as_slice()[..self.n_params()],
            self.data.configured.as_slice(),
            &self.touch_batch(points, caches),
            &mut reaches.kinematics,
            &mut reaches.at,
        );
    }

    /// The touch points `points` as a mechanism's batch takes them: each
    /// one's actuation and the warm start in its cache, read in place
    /// ([`TouchBatch`]).
    fn touch_batch<'b>(&'b self, points: Range<usize>, caches: &'b [WarmStart]) -> TouchBatch<'b> {
        let order = &self.touch_order[points.start - self.sample_points()..];
        TouchBatch {
            touches: &self.data.observations.touches,
            order: &order[..points.len()],
            caches,
            warm_start_len: self.data.mechanism.warm_start_len(),
        }
    }

    /// [`MechanismProblem::reach`] along the global step `dg`, into
    /// `reaches.along` ([`Actuation::tool_points_along`]: each touch's
    /// `dT/dp |_q` only as its product with the parameters' step, and the
    /// warm start predicted after the step).
    pub(crate) fn reach_along(
        &self,
        points: Range<usize>,
        global: &DVector<f64>,
        dg: &DVector<f64>,
        caches: &[WarmStart],
        reaches: &mut Reaches,
    ) {
        batch_rooms(&mut reaches.along, &mut reaches.spare_along, points.len());
        let n = self.n_params();
        Actuation::tool_points_along(
            self.data.mechanism.as_ref(),
            &global.as_slice()[..n],
            self.data.configured.as_slice(),
            &self.touch_batch(points, caches),
            &dg.as_slice()[..n],
            &mut reaches.kinematics,
            &mut reaches.along,
        );
    }

    /// [`MechanismProblem::fill`] for a back-substitution along the global
    /// step `dg`, each point's `d_global · dg` into `steps`: a group of
    /// touches along the step ([`MechanismProblem::touch_row_along`]), a
    /// sample's rows in full.
    #[allow(
        clippy::too_many_arguments,
        reason = "Problem::linearize_along_batch's"
    )]
    pub(super) fn fill_along(
        &self,
        first: usize,
        global: &DVector<f64>,
        group: &SVector<f64, C>,
        caches: &mut [WarmStart],
        dg: &DVector<f64>,
        out: &mut [Local<C>],
        steps: &mut [SVector<f64, 1>],
        reaches: &mut Reaches,
    ) -> Result<(), (usize, MechanismCalibrationError)> {
        if first < self.sample_points() {
            self.fill(first, global, group, caches, out, reaches)?;
            for (step, out) in steps.iter_mut().zip(out.iter()) {
                *step = &out.d_global * dg;
            }
            return Ok(());
        }
        self.reach_along(first..first + out.len(), global, dg, caches, reaches);
        let ball = self.group_ball(first, global, group);
        let each = reaches.along.iter().zip(caches).zip(out).zip(steps);
        for (j, (((along, cache), out), step)) in each.enumerate() {
            *step = self
                .touch_row_along(first + j, &ball, along, dg, cache, out)
                .map_err(|e| (first + j, e))?;
        }
        Ok(())
    }

    /// The points `first..first + out.len()` (one group's) at its block
    /// `group`, with their caches: a sample's rows from one evaluation, or
    /// touches.
    pub(super) fn fill(
        &self,
        first: usize,
        global: &DVector<f64>,
        group: &SVector<f64, C>,
        caches: &mut [WarmStart],
        out: &mut [Local<C>],
        reaches: &mut Reaches,
    ) -> Result<(), (usize, MechanismCalibrationError)> {
        if first >= self.sample_points() {
            // The touches together: each from the warm start it last left.
            self.reach(first..first + out.len(), global, caches, reaches);
            let ball = self.group_ball(first, global, group);
            let each = reaches.at.iter().zip(out).zip(caches);
            for (j, ((reached, out), cache)) in each.enumerate() {
                self.touch_row(first + j, &ball, reached, cache, out)
                    .map_err(|e| (first + j, e))?;
            }
            return Ok(());
        }
        let a = self.actuators();
        let rows = self
            .sample_rows(first / a, global, group)
            .map_err(|e| (first, e))?;
        let n = self.n_params();
        for (j, out) in out.iter_mut().enumerate() {
            let row = (first + j) % a;
            out.residual[0] = rows.rows.residual[row];
            out.d_global.as_mut_slice().fill(0.0);
            out.d_global
                .columns_mut(0, n)
                .copy_from(&rows.rows.d_params.row(row));
            out.d_group.fill(0.0);
            out.d_group
                .columns_mut(0, 3)
                .copy_from(&rows.d_pose.row(row));
        }
        Ok(())
    }
}

/// What a fit needs of its problem beyond the solver's
/// (`super::fit`): the radius observation's problem of the same data,
/// whose blocks and global rows it shares, and how a ball found on the
/// wrong side of its touches is moved (`super::mirror`).
pub(crate) trait FitProblem<const C: usize, const P: usize, const R: usize>:
    Problem<C, P, R, PointCache = WarmStart, Error = MechanismCalibrationError>
{
    /// The radius observation's problem of the same data.
    fn base(&self) -> &MechanismProblem<'_, C>;

    /// Ball `b` moved to `centre` in `state` (its block, or its global
    /// unknowns when tied), its touches' own unknowns made to agree with
    /// their tool points `tips` there (in the order of its points).
    fn reseed(
        &mut self,
        state: &mut State<C, P>,
        b: usize,
        centre: &Vector3<f64>,
        tips: &[Vector3<f64>],
    );
}

/// The touches are rows of their own: nothing of theirs moves with a
/// ball.
impl<const C: usize> FitProblem<C, 0, 1> for MechanismProblem<'_, C> {
    fn base(&self) -> &MechanismProblem<'_, C> {
        self
    }

    fn reseed(
        &mut self,
        state: &mut State<C, 0>,
        b: usize,
        centre: &Vector3<f64>,
        _: &[Vector3<f64>],
    ) {
        self.place_ball(b, centre, &mut state.global, &mut state.groups);
    }
}

/// The start of a problem ([`MechanismProblem::start_state`]).
pub(crate) struct Start<const C: usize> {
    /// The solver's start.
    pub state: State<C, 0>,
    /// Every point's cache there.
    pub caches: Vec<WarmStart>,
    /// Every touch's tool point there, in the order of the points.
    pub tips: Vec<Vector3<f64>>,
}

/// The local blocks' start, the points' caches and the touches' tool
/// points ([`MechanismProblem::start_blocks`]).
type StartBlocks<const C: usize> =
    Result<(Vec<SVector<f64, C>>, Vec<WarmStart>, Vec<Vector3<f64>>), MechanismCalibrationError>;

/// A touch's radius row but `d_global` into `out`: its residual and its
/// ball's columns ([`put_ball_columns`]), the group's other columns zero.
fn put_touch_local<const C: usize>(out: &mut Local<C>, row: &RadiusRow, ball: &TouchedBall) {
    out.residual[0] = row.residual;
    out.d_group.fill(0.0);
    let d_radius = SVector::<f64, 1>::new(row.d_radius());
    put_ball_columns(out, ball, &row.d_centre(), &d_radius);
}

/// A local block of `C` unknowns: `xyz`, then (with `C` 4) `fourth`.
pub(super) fn block<const C: usize>(xyz: &Vector3<f64>, fourth: f64) -> SVector<f64, C> {
    SVector::from_fn(|k, _| if k < 3 { xyz[k] } else { fourth })
}

#[cfg(test)]
pub(crate) mod tests {
    use parcal_observe::mechanism::Actuation;
    use std::sync::Arc;

    use nalgebra::DVector;
    use nalgebra::Isometry3;
    use parcal_kinematics::cable::{CableRobot, Elasticity};
    use parcal_kinematics::delta::{DeltaParams, LinearDelta, probe_height};
    use parcal_kinematics::hexapod::Hexapod;
    use parcal_kinematics::mechanism::{Mechanism, design};
    use parcal_kinematics::params::TOOL_OFFSET;
    use parcal_observe::CoordinateWhitening;
    use parcal_observe::mechanism::{
        BallDistance, BallTouch, MeasuredQuantity, PartDistance, PointSample, ProbeHeight,
        TrackerPoint, TrackerPose,
    };
    use parcal_solver::{
        GlobalObservations, SolverOptions, Status, dense_reference, linear_step, solve,
    };

    use super::*;
    use crate::mechanism::data::{Ball, CentrePrior, Observations, Tracker};

    /// The largest difference between the global blocks `a` and `b`, in
    /// the marginal sigmas of `covariance`.
    pub(crate) fn sigmas_apart(
        a: &DVector<f64>,
        b: &DVector<f64>,
        covariance: &DMatrix<f64>,
    ) -> f64 {
        let sigma = covariance.diagonal().map(f64::sqrt);
        (a - b).component_div(&sigma).amax()
    }

    /// A typical delta, its configured (design) parameters, and its true
    /// ones a few tenths off.
    pub(crate) fn delta_off_design() -> (LinearDelta, DVector<f64>, DVector<f64>) {
        let delta = LinearDelta::typical();
        let configured = design(&delta);
        let mut truth = DeltaParams::from_slice(configured.as_slice());
        truth.endstop = [0.3, -0.2, 0.1];
        truth.radius += 0.4;
        truth.angle = [0.2, -0.3, 0.1];
        truth.diagonal = [270.3, 269.8, 270.1];
        truth.tilt = [0.1, -0.15];
        (delta, configured, truth.to_vector())
    }

    /// A delta configured as designed, truly a few tenths off: 7 probe
    /// heights, 2 part distances, 3 point samples (the first at a measured
    /// pose), two balls touched 5 times each (the second's radius with a
    /// calibration sigma), the touches interleaved.
    pub(crate) fn small_delta() -> MechanismData {
        let (delta, configured, truth) = delta_off_design();
        let (p, c) = (truth.as_slice(), configured.as_slice());
        let probes = [
            [0.0, 0.0],
            [80.0, 0.0],
            [-40.0, 69.0],
            [-40.0, -69.0],
            [30.0, 30.0],
            [-50.0, 10.0],
            [10.0, -60.0],
        ]
        .iter()
        .map(|&[x, y]| ProbeHeight {
            commanded: [x, y, probe_height(&delta, p, c, x, y).unwrap() + 0.7],
            sigma: 0.01,
        })
        .collect();
        let distances = [
            ([-60.0, -20.0, 0.2], [60.0, 20.0, 0.2]),
            ([0.0, -70.0, 0.2], [0.0, 70.0, 0.2]),
        ]
        .iter()
        .map(|&(first, second)| PartDistance {
            first,
            second,
            distance: DVector::from_column_slice(&first)
                .metric_distance(&DVector::from_column_slice(&second))
                + 0.05,
            sigma: 0.02,
        })
        .collect();
        let samples = [
            [10.0, 20.0, 50.0],
            [-30.0, 40.0, 120.0],
            [50.0, -10.0, 80.0],
        ]
        .iter()
        .enumerate()
        .map(|(k, pose)| PointSample {
            readings: delta.inverse(p, pose).unwrap().iter().copied().collect(),
            sigma: 0.005,
            known_pose: (k == 0).then_some((*pose, [0.01; 3])),
            loads: None,
        })
        .collect();
        // The first ball placed within 0.05 mm of where it is.
        let placed = CentrePrior {
            centre: [30.02, -20.01, 12.7],
            sigma: 0.05,
        };
        let balls = vec![
            Ball {
                centre_prior: Some(placed),
                ..Ball::new(12.7, None)
            },
            Ball::new(6.35, Some(0.002)),
        ];
        let centres = [[30.0, -20.0, 12.7], [-40.0, 35.0, 6.35]];
        let touches = (0..10)
            .map(|k| {
                let ball = k % 2;
                let (polar, azimuth) = (0.3 + 0.25 * (k / 2) as f64, 1.3 * k as f64);
                let [cx, cy, cz] = centres[ball];
                let radius = balls[ball].radius + 0.01;
                let true_point = [
                    cx + radius * polar.sin() * azimuth.cos(),
                    cy + radius * polar.sin() * azimuth.sin(),
                    cz + radius * polar.cos(),
                ];
                let readings = delta.inverse(p, &true_point).unwrap();
                let commanded = delta.forward(c, readings.as_slice(), &true_point).unwrap();
                BallTouch::new(
                    ball,
                    Actuation::Commanded([commanded[0], commanded[1], commanded[2]]),
                    0.005,
                )
            })
            .collect();
        let observations = Observations {
            probes,
            distances,
            points: Vec::new(),
            samples,
            quantities: Vec::new(),
            balls,
            touches,
            ..Observations::default()
        };
        MechanismData::new(
            Arc::new(delta),
            configured.iter().copied().collect(),
            observations,
        )
        .with_trigger_height(0.6, Some(0.05))
    }

    /// A Hangprinter with elastic lines (one compliance), truly a few mm
    /// off its design: 14 samples under loads (3 at measured poses) and
    /// the four line lengths measured 3 mm long.
    fn small_cable() -> MechanismData {
        let robot = CableRobot::typical()
            .with_elasticity(Elasticity {
                compliance_of_line: vec![0; 4],
                zero_loads: vec![14.0; 4],
                compliance: 50.0,
                compliance_sigma: 50.0,
            })
            .unwrap();
        let configured = design(&robot);
        let truth = DVector::from_fn(configured.len(), |k, _| {
            configured[k] + 4.0 * ((k * 7) as f64).sin()
        });
        let samples = (0..14)
            .map(|k| {
                let t = k as f64;
                let pose = [300.0 * t.cos(), 250.0 * (1.3 * t).sin(), 80.0 * t];
                let loads = [12.0 + t, 15.0 - 0.5 * t, 10.0 + 0.3 * t, 20.0 + t];
                let (readings, _) = robot
                    .loaded_readings(truth.as_slice(), &pose, &loads)
                    .unwrap();
                PointSample {
                    readings: readings.iter().copied().collect(),
                    sigma: 1.0,
                    known_pose: (k % 5 == 0).then_some((pose, [0.1; 3])),
                    loads: Some(loads.to_vec()),
                }
            })
            .collect();
        let quantities = (0..4)
            .map(|quantity| MeasuredQuantity {
                quantity,
                value: robot.quantity(quantity, truth.as_slice()).unwrap().value + 3.0,
                sigma: 10.0,
            })
            .collect();
        let observations = Observations {
            samples,
            quantities,
            ..Observations::default()
        };
        MechanismData::new(
            Arc::new(robot),
            configured.iter().copied().collect(),
            observations,
        )
    }

    /// The Schur complement's step and the solution's covariance against
    /// the dense reference, from the start blocks moved by `offset`.
    fn check_against_dense<const C: usize>(data: &MechanismData, offset: Vector3<f64>) {
        let problem = MechanismProblem::<C>::new(data, Loss::Squared).unwrap();
        let mut state = problem.start_state().unwrap().state;
        for group in &mut state.groups {
            *group += block::<C>(&offset, 0.0);
        }
        for (_, columns) in problem.tied().iter() {
            for k in 0..3 {
                state.global[columns.start + k] += offset[k];
            }
        }
        let dense = dense_reference::solve::<C, 0, 1, _>(&problem, &state, 0.0).unwrap();
        let schur = linear_step::<C, 0, 1, _>(&problem, &state, &mut Vec::new(), 0.0, 64).unwrap();
        let global = (&schur.delta.global - &dense.step.global).amax();
        let points = schur
            .delta
            .groups
            .iter()
            .zip(&dense.step.groups)
            .map(|(a, b)| (a - b).amax())
            .fold(0.0, f64::max);
        // Steps of O(1) from two factorisations of a system of condition
        // ~1e8: agreement to ~1e-8 relative.
        let scale = dense.step.global.amax();
        assert!(
            global < 1e-7 * scale && points < 1e-7 * scale,
            "{global:e} {points:e}"
        );

        let solution = solve::<C, 0, 1, _>(&problem, state, &SolverOptions::default(), &mut |_| {});
        assert_eq!(solution.status, Status::Converged);
        let covariance = solution.covariance.unwrap();
        let dense = dense_reference::solve::<C, 0, 1, _>(&problem, &solution.state, 0.0).unwrap();
        let reference = dense.global_covariance().unwrap();
        let error = (&covariance - &reference).amax();
        assert!(error < 1e-7 * reference.amax(), "{error:e}");
    }

    #[test]
    fn the_schur_step_and_covariance_match_the_dense_reference_with_samples_and_touches() {
        // An uncertain radius: blocks of four, samples and the exact ball
        // holding their fourth unknown by its unit prior; the exact ball's
        // centre with a prior.
        let data = small_delta();
        assert_eq!(group_size(&data), 4);
        check_against_dense::<4>(&data, Vector3::new(0.3, -0.2, 0.1));
        // Both radii exact: blocks of three.
        let mut exact = data.clone();
        exact.observations.balls[1].radius_sigma = None;
        assert_eq!(group_size(&exact), 3);
        check_against_dense::<3>(&exact, Vector3::new(0.3, -0.2, 0.1));
        // The first ball's centre prior is its group's, in both; the
        // second ball has none (and with blocks of three, no prior).
        let samples = data.observations.samples.len();
        let placed = data.observations.balls[0].centre_prior.unwrap();
        let four = MechanismProblem::<4>::new(&data, Loss::Squared).unwrap();
        let three = MechanismProblem::<3>::new(&exact, Loss::Squared).unwrap();
        let prior = four.group_prior(samples).unwrap();
        let mean = three.group_prior(samples).unwrap().mean;
        for k in 0..3 {
            assert_eq!(prior.mean[k], placed.centre[k]);
            assert_eq!(mean[k], placed.centre[k]);
            let information = prior.information[(k, k)] * placed.sigma.powi(2);
            assert!((information - 1.0).abs() < 1e-12, "{information}");
        }
        assert!(three.group_prior(samples + 1).is_none());
    }

    #[test]
    fn loads_and_measured_quantities_match_the_dense_reference() {
        check_against_dense::<3>(&small_cable(), Vector3::new(3.0, -2.0, 1.0));
    }

    /// [`small_delta`] with its two balls tied by a calibrated distance
    /// 0.02 mm longer than the true one: both balls' unknowns global, the
    /// first's centre prior and the second's radius prior with them.
    pub(crate) fn tied_delta() -> MechanismData {
        let mut data = small_delta();
        let true_distance = Vector3::new(70.0, -55.0, 6.35).norm();
        data.observations.ball_distances = vec![BallDistance {
            first: 0,
            second: 1,
            distance: true_distance + 0.02,
            sigma: 0.005,
        }];
        data
    }

    #[test]
    fn tied_balls_match_the_dense_reference() {
        let data = tied_delta();
        let four = MechanismProblem::<4>::new(&data, Loss::Squared).unwrap();
        // Probes add the trigger height; both balls are tied, the second
        // with its uncertain radius.
        let m = four.mechanism_len();
        assert_eq!(m, four.n_params() + 1);
        assert_eq!(four.global_len(), m + 7);
        let samples = data.observations.samples.len();
        assert!(!four.group_is_fixed(samples - 1));
        assert!(four.group_is_fixed(samples) && four.group_is_fixed(samples + 1));
        assert!(four.group_prior(samples).is_none());
        let prior = four.global_prior().unwrap();
        let placed = data.observations.balls[0].centre_prior.unwrap();
        assert_eq!(prior.mean[m], placed.centre[0]);
        assert!((prior.information[(m + 2, m + 2)] * placed.sigma.powi(2) - 1.0).abs() < 1e-12);
        assert!((prior.information[(m + 6, m + 6)] * 0.002_f64.powi(2) - 1.0).abs() < 1e-12);
        check_against_dense::<4>(&data, Vector3::new(0.3, -0.2, 0.1));
        let mut exact = data.clone();
        exact.observations.balls[1].radius_sigma = None;
        check_against_dense::<3>(&exact, Vector3::new(0.3, -0.2, 0.1));
    }

    /// [`small_delta`] measured by two trackers, 5 points each at
    /// commanded positions, in frames turned and shifted from the
    /// delta's, each coordinate off by up to 0.01 mm.
    pub(crate) fn tracked_delta() -> MechanismData {
        let mut data = small_delta();
        let (delta, configured, truth) = delta_off_design();
        let frames = [
            Isometry3::new(
                Vector3::new(-1500.0, 400.0, 90.0),
                Vector3::new(-0.15, 0.05, 0.7),
            ),
            Isometry3::new(
                Vector3::new(600.0, 1800.0, 220.0),
                Vector3::new(0.02, -0.25, -2.2),
            ),
        ];
        let o = &mut data.observations;
        o.trackers = vec![Tracker::new("T1"), Tracker::rehomed("T2", Some(0.3))];
        o.tracker_points = (0..10)
            .map(|j| {
                let t = j as f64;
                let commanded = [
                    60.0 * (1.7 * t).cos(),
                    55.0 * (1.1 * t).sin(),
                    20.0 + 9.0 * t,
                ];
                let at = Actuation::Commanded(commanded);
                let reached = at
                    .tool_point(&delta, truth.as_slice(), configured.as_slice(), None)
                    .unwrap();
                let seen = frames[j % 2].transform_point(&reached.point.into());
                let off = Vector3::new((2.0 * t).sin(), (3.0 * t).cos(), (5.0 * t).sin()) * 0.01;
                TrackerPoint {
                    tracker: j % 2,
                    at,
                    measured: (seen.coords + off).into(),
                    weight: CoordinateWhitening::isotropic(0.01).unwrap(),
                }
            })
            .collect();
        data
    }

    #[test]
    fn trackers_match_the_dense_reference() {
        let data = tracked_delta();
        let four = MechanismProblem::<4>::new(&data, Loss::Squared).unwrap();
        // The trigger height, the two trackers' frames, the second's
        // offsets.
        assert_eq!(four.mechanism_len(), four.n_params() + 1 + 12 + 3);
        check_against_dense::<4>(&data, Vector3::new(0.3, -0.2, 0.1));
    }

    /// Every row of the groups' points after the samples (the touches)
    /// and every global observation of `data`, as the problem linearises
    /// them, against central differences over the whole global block;
    /// the analytic Jacobian.
    fn rows_match_central_differences_over_the_global_block<const C: usize>(
        data: &MechanismData,
    ) -> DMatrix<f64> {
        let problem = MechanismProblem::<C>::new(data, Loss::Squared).unwrap();
        let state = problem.start_state().unwrap().state;
        let samples = data.observations.samples.len();
        let rows = |global: &DVector<f64>| {
            let mut residuals = Vec::new();
            let mut jacobian = Vec::new();
            for k in samples..problem.n_groups() {
                for i in problem.group_points(k) {
                    let mut out = Local::<C>::zeros(global.len());
                    let group = &state.groups[k];
                    let point = SVector::zeros();
                    problem
                        .linearize(
                            i,
                            global,
                            group,
                            &point,
                            &mut WarmStart::default(),
                            &mut out,
                        )
                        .unwrap();
                    residuals.push(out.residual[0]);
                    jacobian.push(out.d_global.clone());
                }
            }
            let mut global_rows = GlobalObservations::zeros(0, global.len());
            problem
                .global_observations(global, &mut global_rows)
                .unwrap();
            residuals.extend(global_rows.residual.iter());
            let mut jacobian = if jacobian.is_empty() {
                DMatrix::zeros(0, global.len())
            } else {
                DMatrix::from_rows(&jacobian)
            };
            let touches = jacobian.nrows();
            jacobian = jacobian.resize_vertically(residuals.len(), 0.0);
            jacobian
                .rows_mut(touches, global_rows.jacobian.nrows())
                .copy_from(&global_rows.jacobian);
            (DVector::from_vec(residuals), jacobian)
        };
        let (_, analytic) = rows(&state.global);
        let h = 1e-6;
        for j in 0..state.global.len() {
            let (mut plus, mut minus) = (state.global.clone(), state.global.clone());
            plus[j] += h;
            minus[j] -= h;
            let column = (rows(&plus).0 - rows(&minus).0) / (2.0 * h);
            let error = (&column - analytic.column(j)).amax();
            // Whitened rows of sigmas down to 2 um: derivatives up to
            // ~1e3 per mm, central differences of step 1e-6 mm exact to
            // ~1e-6 relative.
            assert!(
                error < 1e-6 * column.amax().max(1.0),
                "column {j}: {error:e}"
            );
        }
        analytic
    }

    /// The tracker points' rows see the parameters, their own tracker's
    /// frame and its offsets, and nothing else.
    #[test]
    fn tracker_rows_match_central_differences_over_the_global_block() {
        let data = tracked_delta();
        let analytic = rows_match_central_differences_over_the_global_block::<4>(&data);
        let problem = MechanismProblem::<4>::new(&data, Loss::Squared).unwrap();
        let points = &data.observations.tracker_points;
        let first = analytic.nrows() - 3 * points.len();
        for (j, point) in points.iter().enumerate() {
            let frame = problem.trackers().columns(point.tracker);
            let offsets = problem.trackers().offset_columns(point.tracker);
            for c in 0..analytic.ncols() {
                let seen = (0..3).any(|r| analytic[(first + 3 * j + r, c)] != 0.0);
                let expected = c < problem.n_params()
                    || frame.contains(&c)
                    || offsets.as_ref().is_some_and(|o| o.contains(&c));
                assert_eq!(seen, expected, "tracker point {j}, column {c}");
            }
        }
    }

    /// The `j`-th of a spread of the paper's hexapod's poses: within 30 mm
    /// of its axis, 230 mm high and up, tilted and turned up to 0.08 rad.
    pub(crate) fn hexapod_pose(j: usize) -> [f64; 6] {
        let t = j as f64;
        [
            30.0 * (1.3 * t).cos(),
            25.0 * (0.9 * t).sin(),
            230.0 + 4.0 * t,
            0.06 * (2.1 * t).sin(),
            -0.05 * (1.7 * t).cos(),
            0.08 * (0.7 * t).sin(),
        ]
    }

    /// The paper's hexapod at its design seen by two trackers (the second
    /// after the legs were re-homed and the body re-mounted; it was not
    /// moved), each measuring 4 poses of a body on
    /// the platform and 3 tool points, the readings off by up to 0.01 mm;
    /// the body's reference a little off the true body frame.
    fn tracked_hexapod() -> MechanismData {
        let hexapod = Hexapod::typical();
        let params = design(&hexapod);
        let frames = [
            Isometry3::new(
                Vector3::new(-900.0, 300.0, 60.0),
                Vector3::new(-0.1, 0.05, 0.6),
            ),
            Isometry3::new(
                Vector3::new(500.0, 1200.0, 120.0),
                Vector3::new(0.02, -0.2, -2.0),
            ),
        ];
        let body = Isometry3::new(
            Vector3::new(4.0, -6.0, 35.0),
            Vector3::new(0.03, -0.02, 0.5),
        );
        let at = |j: usize| {
            let x = hexapod_pose(j);
            let q = hexapod.inverse(params.as_slice(), &x).unwrap();
            let off = |i: usize| 0.01 * ((3 * i + j) as f64).sin();
            let readings: Vec<f64> = q.iter().enumerate().map(|(i, q)| q + off(i)).collect();
            (x, readings)
        };
        let mut observations = Observations {
            trackers: vec![
                Tracker::new("T1"),
                Tracker::rehomed("T2", Some(0.3))
                    .with_body_turned(Some(0.02))
                    .with_body_moved(Some(0.5)),
            ],
            body_reference: Isometry3::new(
                Vector3::new(4.5, -6.2, 34.0),
                Vector3::new(0.02, -0.01, 0.52),
            ),
            ..Observations::default()
        };
        for j in 0..8 {
            let (x, readings) = at(j);
            let platform = hexapod.platform_frame(&x).unwrap();
            observations.tracker_poses.push(TrackerPose {
                tracker: j % 2,
                readings,
                measured: frames[j % 2] * platform * body,
                weight: DMatrix::identity(6, 6) * 100.0,
            });
        }
        for j in 8..14 {
            let (x, readings) = at(j);
            let tip = hexapod.tool_point(params.as_slice(), &x).unwrap().point;
            observations.tracker_points.push(TrackerPoint {
                tracker: j % 2,
                at: Actuation::Readings(readings.into()),
                measured: frames[j % 2].transform_point(&tip.into()).coords.into(),
                weight: CoordinateWhitening::isotropic(0.01).unwrap(),
            });
        }
        MechanismData::new(Arc::new(hexapod), params.as_slice().to_vec(), observations)
    }

    /// The tracker poses' rows see the parameters but the tool, their own
    /// tracker's frame, offsets and body shift, and the body frame, and
    /// nothing else; the step
    /// and covariance are the dense reference's.
    #[test]
    fn tracker_pose_rows_match_central_differences_over_the_global_block() {
        let data = tracked_hexapod();
        let problem = MechanismProblem::<3>::new(&data, Loss::Squared).unwrap();
        // The two trackers' frames, the second's offsets, the body frame,
        // the second's body rotation and origin shift.
        assert_eq!(problem.mechanism_len(), problem.n_params() + 12 + 6 + 6 + 6);
        let analytic = rows_match_central_differences_over_the_global_block::<3>(&data);
        let poses = &data.observations.tracker_poses;
        let first = analytic.nrows() - 6 * poses.len();
        let body = problem.trackers().body_columns().unwrap();
        for (j, pose) in poses.iter().enumerate() {
            let frame = problem.trackers().columns(pose.tracker);
            let offsets = problem.trackers().offset_columns(pose.tracker);
            let shift = problem.trackers().body_shift(pose.tracker);
            let shifted = |c: usize| {
                [shift.rotation, shift.origin]
                    .iter()
                    .flatten()
                    .any(|&start| (start..start + 3).contains(&c))
            };
            for c in 0..analytic.ncols() {
                let seen = (0..6).any(|r| analytic[(first + 6 * j + r, c)] != 0.0);
                if c < problem.n_params() {
                    // Every parameter but the tool, which no pose sees.
                    assert_eq!(seen, c < TOOL_OFFSET, "tracker pose {j}, column {c}");
                    continue;
                }
                let expected = frame.contains(&c)
                    || body.contains(&c)
                    || shifted(c)
                    || offsets.as_ref().is_some_and(|o| o.contains(&c));
                assert_eq!(seen, expected, "tracker pose {j}, column {c}");
            }
        }
        check_against_dense::<3>(&data, Vector3::zeros());
    }

    /// The tied balls' touches and the distance among the rows.
    #[test]
    fn tied_balls_rows_match_central_differences_over_the_global_block() {
        let data = tied_delta();
        let problem = MechanismProblem::<4>::new(&data, Loss::Squared).unwrap();
        let analytic = rows_match_central_differences_over_the_global_block::<4>(&data);
        // The distance's row sees the two centres, and nothing else.
        let distance = analytic.row(analytic.nrows() - 1);
        let seen: Vec<usize> = (0..distance.len())
            .filter(|&j| distance[j] != 0.0)
            .collect();
        let expected: Vec<usize> = problem
            .tied()
            .iter()
            .flat_map(|(_, columns)| columns.start..columns.start + 3)
            .collect();
        assert_eq!(seen, expected);
    }
}
