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

use nalgebra::{Const, DMatrix, DVector, Dyn, OMatrix, SMatrix, SVector, Vector3};
use parcal_kinematics::batch_workspace::BatchWorkspace;
use parcal_kinematics::mechanism::{Mechanism, MechanismError, Reached, ReachedAlong};
use parcal_observe::mechanism::{
    Actuation, ActuationBatch, BallTouch, RadiusRow, Rows, SampleRows,
};
use parcal_solver::{
    GaussianPrior, GlobalObservations, Linearization, Loss, Problem, State, filled,
};
use rayon::prelude::*;

use crate::sphere_fit::{SphereFitError, best_fit};

use super::data::{MAX_WARM_START, MechanismData};
use super::error::MechanismCalibrationError;
use super::observation::{ObservationKind, ObservationRef};
use super::prior::{global_priors, prior_information};
use super::tied::TiedBalls;
use super::touch_start::TouchStart;
use super::trackers::Trackers;

/// The solver's problem: groups of `C` unknowns (a sample's pose, a
/// ball's centre, and with [`group_size`] 4 a ball's radius), no point
/// unknowns, one row per point.
type Local<const C: usize> = Linearization<C, 0, 1, OMatrix<f64, Const<1>, Dyn>>;

/// Where the touches of a batch are: a worker's, kept from batch to batch
/// (the solver's workspace), so that the mechanism writes into the room
/// the last batch left: the coordinate rows hand each touch's room back,
/// the radius rows (eq. 9, `BallTouch::radius_row`) borrow it. A batch
/// shorter than the one before leaves its extra rooms aside for the next
/// longer one (a ball's 7 touches go in batches of 4 and 3).
#[derive(Debug, Default)]
pub(crate) struct Reaches {
    /// Where they are, with `dT/dp |_q` ([`MechanismProblem::reach`]).
    pub(crate) at: Vec<Result<Reached, MechanismError>>,
    /// Where they are along a step, for a back-substitution
    /// ([`MechanismProblem::reach_along`]).
    pub(crate) along: Vec<Result<ReachedAlong, MechanismError>>,
    /// The rooms of `at` beyond the last batch.
    spare_at: Vec<Result<Reached, MechanismError>>,
    /// The rooms of `along` beyond the last batch.
    spare_along: Vec<Result<ReachedAlong, MechanismError>>,
    /// What the mechanism's batches share (the hexapod's geometry of the
    /// pass's parameters and its lanes' row order).
    kinematics: BatchWorkspace,
}

/// A batch of touch points as a mechanism's batch takes them
/// ([`ActuationBatch`]): each one's touch's actuation and the warm start in
/// its cache, read in place (a pass hands the mechanism some hundred
/// thousand batches).
struct TouchBatch<'b> {
    touches: &'b [BallTouch],
    /// The batch's touches, in the order of its points.
    order: &'b [usize],
    /// Their caches.
    caches: &'b [WarmStart],
    /// The mechanism's [`Mechanism::warm_start_len`].
    warm_start_len: usize,
}

impl ActuationBatch for TouchBatch<'_> {
    fn len(&self) -> usize {
        self.order.len()
    }

    fn actuation(&self, k: usize) -> &Actuation {
        &self.touches[self.order[k]].at
    }

    fn start(&self, k: usize) -> Option<&[f64]> {
        self.caches[k].start(self.warm_start_len)
    }
}

/// `entries` cut or grown to `n` entries from and into `spare` (as far as
/// it holds them), so that what is written into them finds its room.
fn batch_rooms<T>(entries: &mut Vec<T>, spare: &mut Vec<T>, n: usize) {
    if entries.len() > n {
        spare.extend(entries.drain(n..));
    }
    while entries.len() < n {
        match spare.pop() {
            Some(room) => entries.push(room),
            None => break,
        }
    }
}

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

/// A point's cache: the warm start of the pose its touch last reached
/// (none before its first evaluation and for every other point), where
/// its next forward kinematics starts
/// ([`Mechanism::warm_start`](parcal_kinematics::mechanism::Mechanism::warm_start));
/// held inline, so that a million touches' caches make no allocation,
/// its length the mechanism's and none a NaN first value, so that it
/// holds nothing else.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct WarmStart {
    values: [f64; MAX_WARM_START],
}

impl Default for WarmStart {
    /// None.
    fn default() -> Self {
        Self {
            values: [f64::NAN; MAX_WARM_START],
        }
    }
}

impl WarmStart {
    /// The cache of the warm start `start`; none for one of more values
    /// than it holds (which [`MechanismData::validate`] refuses), or that
    /// is not finite, whose next evaluation then starts from the
    /// mechanism's start pose.
    pub(crate) fn of(start: &[f64]) -> Self {
        let mut last = Self::default();
        // `x · 0` is 0 for a finite `x` and NaN otherwise: one sum, without
        // a branch a value (a million touches' caches twice an iteration).
        if let Some(room) = last.values.get_mut(..start.len())
            && start.iter().fold(0.0, |sum, v| sum + v * 0.0) == 0.0
        {
            room.copy_from_slice(start);
        }
        last
    }

    /// The warm start of a mechanism whose warm starts have `len` values,
    /// if any.
    fn start(&self, len: usize) -> Option<&[f64]> {
        (!self.values[0].is_nan())
            .then(|| self.values.get(..len))
            .flatten()
    }
}

/// The number of touches whose start [`MechanismProblem::touches_at_start`]
/// takes at a time: enough that what the mechanism builds of the
/// parameters for them is made seldom, few enough for the threads to share.
const START_CHUNK: usize = 1024;

/// The sigma of the unit prior that holds a block's unused fourth unknown
/// (module doc).
const UNUSED: f64 = 1.0;

/// The problem of [`MechanismData`] (module doc), its local blocks of `C`
/// unknowns ([`group_size`]).
pub(crate) struct MechanismProblem<'a, const C: usize> {
    data: &'a MechanismData,
    prior: Option<GaussianPrior<Dyn>>,
    loss: Loss,
    /// The number of points of the samples' rows, before the touches'
    /// (made once: each touch's lookup needs it).
    sample_points: usize,
    /// The touches in the order of their balls (stable).
    touch_order: Vec<usize>,
    /// The points of each ball, after the samples' rows.
    ball_points: Vec<Range<usize>>,
    /// The tied balls' places in the global block.
    tied: TiedBalls,
    /// The trackers' references and places in the global block.
    trackers: Trackers,
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
        let ball = &self.data.observations.balls[b];
        let uncertain = ball.radius_sigma.is_some();
        let tied = self.tied.column(b);
        // The ball's centre, then its radius when uncertain.
        let unknowns = match tied {
            Some(column) => &global.as_slice()[column..],
            None => block.as_slice(),
        };
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
    fn fill_along(
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
    fn fill(
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

/// Where [`ball_centre`] puts what a ball's touches reached, in the order
/// of its touches.
pub(crate) struct BallFit<'a> {
    /// The warm start of the pose each touch reached.
    pub warm_starts: &'a mut [WarmStart],
    /// The tool point each touch reached.
    pub tips: &'a mut [Vector3<f64>],
}

/// Each ball's [`BallFit`] in `warm_starts` and `tips` (the touches'
/// places, in the order of their points), the balls' points `ball_points`
/// one after the other.
fn ball_rooms<'a>(
    ball_points: &[Range<usize>],
    mut warm_starts: &'a mut [WarmStart],
    mut tips: &'a mut [Vector3<f64>],
) -> Vec<BallFit<'a>> {
    let mut rooms = Vec::with_capacity(ball_points.len());
    for points in ball_points {
        let (ball_warm_starts, rest_warm_starts) = warm_starts.split_at_mut(points.len());
        let (ball_tips, rest_tips) = tips.split_at_mut(points.len());
        rooms.push(BallFit {
            warm_starts: ball_warm_starts,
            tips: ball_tips,
        });
        (warm_starts, tips) = (rest_warm_starts, rest_tips);
    }
    rooms
}

/// A touched ball's unknowns' values and where they are
/// ([`MechanismProblem::touched_ball`]).
pub(crate) struct TouchedBall {
    /// Its centre.
    pub centre: Vector3<f64>,
    /// Its radius.
    pub radius: f64,
    /// Its first column in the global block when it is tied.
    pub tied: Option<usize>,
    /// Whether its radius is an unknown.
    pub uncertain: bool,
}

impl TouchedBall {
    /// The product of a touch's rows' derivatives with respect to the
    /// ball's centre `d_centre` and radius `d_radius` with the global step
    /// `dg`: their share of `d_global · dg` when the ball is tied (its
    /// radius's only when it is an unknown), else none.
    pub(crate) fn tied_step<const R: usize>(
        &self,
        d_centre: &SMatrix<f64, R, 3>,
        d_radius: &SVector<f64, R>,
        dg: &DVector<f64>,
    ) -> SVector<f64, R> {
        let Some(column) = self.tied else {
            return SVector::zeros();
        };
        let mut step = d_centre * dg.fixed_rows::<3>(column);
        if self.uncertain {
            step += d_radius * dg[column + 3];
        }
        step
    }
}

/// A touch's rows' derivatives with respect to its ball's centre
/// `d_centre` and radius `d_radius` written into `out` where the ball's
/// unknowns are ([`TouchedBall`]): the global block's columns when it is
/// tied, else its group's; the radius's only when it is an unknown.
pub(crate) fn put_ball_columns<const C: usize, const P: usize, const R: usize>(
    out: &mut Linearization<C, P, R, OMatrix<f64, Const<R>, Dyn>>,
    ball: &TouchedBall,
    d_centre: &SMatrix<f64, R, 3>,
    d_radius: &SVector<f64, R>,
) {
    match ball.tied {
        Some(column) => {
            out.d_global.columns_mut(column, 3).copy_from(d_centre);
            if ball.uncertain {
                out.d_global.column_mut(column + 3).copy_from(d_radius);
            }
        }
        None => put_group_columns(&mut out.d_group, ball, d_centre, d_radius),
    }
}

/// [`put_ball_columns`] of a ball in its group: `d_centre` and, when its
/// radius is an unknown, `d_radius` into the group's columns `d_group`.
pub(crate) fn put_group_columns<const C: usize, const R: usize>(
    d_group: &mut SMatrix<f64, R, C>,
    ball: &TouchedBall,
    d_centre: &SMatrix<f64, R, 3>,
    d_radius: &SVector<f64, R>,
) {
    d_group.fixed_columns_mut::<3>(0).copy_from(d_centre);
    if ball.uncertain {
        d_group.column_mut(3).copy_from(d_radius);
    }
}

/// A touch's radius row but `d_global` into `out`: its residual and its
/// ball's columns ([`put_ball_columns`]), the group's other columns zero.
fn put_touch_local<const C: usize>(out: &mut Local<C>, row: &RadiusRow, ball: &TouchedBall) {
    out.residual[0] = row.residual;
    out.d_group.fill(0.0);
    let d_radius = SVector::<f64, 1>::new(row.d_radius());
    put_ball_columns(out, ball, &row.d_centre(), &d_radius);
}

/// The error of touch `t` on ball `ball`.
pub(crate) fn touch_failed(
    t: usize,
    ball: usize,
    error: impl std::fmt::Display,
) -> MechanismCalibrationError {
    failed(
        ObservationRef {
            kind: ObservationKind::Touch,
            index: t,
        },
        format!("on ball {ball}: {error}"),
    )
}

/// A local block of `C` unknowns: `xyz`, then (with `C` 4) `fourth`.
fn block<const C: usize>(xyz: &Vector3<f64>, fourth: f64) -> SVector<f64, C> {
    SVector::from_fn(|k, _| if k < 3 { xyz[k] } else { fourth })
}

/// The mechanism's part of the global block's priors' means.
fn prior_means(data: &MechanismData) -> DVector<f64> {
    let priors = global_priors(data);
    DVector::from_iterator(priors.len(), priors.iter().map(|p| p.mean))
}

/// The prior on the global block (module doc): the mechanism's part's
/// ([`prior_information`]), and each tied ball's centre prior and its
/// radius's calibration sigma, independent of it and of each other;
/// `None` when no unknown has one.
fn global_prior(data: &MechanismData, tied: &TiedBalls) -> Option<GaussianPrior<Dyn>> {
    let m = global_priors(data).len();
    let g = m + tied.unknowns();
    let mut mean = prior_means(data).resize_vertically(g, 0.0);
    let mut information = DMatrix::zeros(g, g);
    let mechanism = prior_information(data);
    if let Some(mechanism) = &mechanism {
        information.view_mut((0, 0), (m, m)).copy_from(mechanism);
    }
    let mut any = mechanism.is_some();
    for (b, columns) in tied.iter() {
        let column = columns.start;
        let ball = &data.observations.balls[b];
        if let Some(prior) = ball.centre_prior {
            for k in 0..3 {
                mean[column + k] = prior.centre[k];
                information[(column + k, column + k)] = prior.sigma.powi(-2);
            }
            any = true;
        }
        if let Some(sigma) = ball.radius_sigma {
            mean[column + 3] = ball.radius;
            information[(column + 3, column + 3)] = sigma.powi(-2);
            any = true;
        }
    }
    any.then(|| GaussianPrior::new(mean, information))
}

/// The centre of ball `b` of calibrated radius `radius` from its
/// `touches` (indices into `all`): the best fit, with its radius, of the
/// tool points the touches reach with parameters `params` and the
/// controller's `configured` ([`best_fit`]; the last
/// iterate of a fit that did not converge); the warm start and the tool
/// point each touch reached into `fit`, in the order of `touches`.
/// `reached` is room for the touches' outcomes, kept from ball to ball so
/// that their rooms are allocated once.
#[allow(
    clippy::too_many_arguments,
    reason = "a ball, its touches and where they are put"
)]
pub(crate) fn ball_centre(
    mechanism: &dyn Mechanism,
    params: &[f64],
    configured: &[f64],
    all: &[BallTouch],
    touches: &[usize],
    b: usize,
    radius: f64,
    reached: &mut Vec<Result<ReachedAlong, MechanismError>>,
    fit: BallFit<'_>,
) -> Result<Vector3<f64>, MechanismCalibrationError> {
    // Together: a mechanism may reach several at once (the hexapod's
    // lanes), each from its start pose. Of each only its tool point and
    // warm start are wanted, not `dT/dp |_q`: the touches along a zero
    // step, which a mechanism's batches give without forming `dT/dp |_q`.
    let actuations: Vec<&Actuation> = touches.iter().map(|&t| &all[t].at).collect();
    let (starts, zero_step) = (vec![None; touches.len()], vec![0.0; params.len()]);
    Actuation::tool_points_along(
        mechanism,
        params,
        configured,
        &(&actuations[..], &starts[..]),
        &zero_step,
        &mut BatchWorkspace::default(),
        reached,
    );
    let rooms = fit.tips.iter_mut().zip(fit.warm_starts.iter_mut());
    for ((along, &t), (tip, warm_start)) in reached.iter().zip(touches).zip(rooms) {
        let along = along.as_ref().map_err(|e| failed(touch_ref(t), e))?;
        *tip = along.reached.point;
        *warm_start = WarmStart::of(along.reached.warm_start.as_slice());
    }
    match best_fit(fit.tips, radius) {
        Ok(fit) | Err(SphereFitError::NotConverged { last: fit }) => Ok(fit.centre),
        Err(e) => Err(MechanismCalibrationError::InvalidData {
            what: format!("ball {b}"),
            reason: format!("its touches do not locate its centre: {e}"),
        }),
    }
}

/// Touch `t` as an observation.
fn touch_ref(t: usize) -> ObservationRef {
    ObservationRef {
        kind: ObservationKind::Touch,
        index: t,
    }
}

fn failed(observation: ObservationRef, error: impl std::fmt::Display) -> MechanismCalibrationError {
    MechanismCalibrationError::Observation {
        observation,
        reason: error.to_string(),
    }
}

/// Groups of `C` unknowns, points of one row (module doc).
impl<const C: usize> Problem<C, 0, 1> for MechanismProblem<'_, C> {
    type PointCache = WarmStart;
    type Workspace = Reaches;
    type Error = MechanismCalibrationError;
    type Jacobian = OMatrix<f64, Const<1>, Dyn>;
    type Global = DVector<f64>;

    fn global_size(&self) -> usize {
        self.global_len()
    }

    fn prepare_global(&self, global: &DVector<f64>) -> DVector<f64> {
        global.clone()
    }

    fn n_groups(&self) -> usize {
        self.data.observations.samples.len() + self.ball_points.len()
    }

    /// A tied ball's block: its unknowns are global (module doc).
    fn group_is_fixed(&self, k: usize) -> bool {
        k.checked_sub(self.data.observations.samples.len())
            .is_some_and(|b| self.tied.column(b).is_some())
    }

    fn group_points(&self, k: usize) -> Range<usize> {
        let samples = self.data.observations.samples.len();
        if k < samples {
            let a = self.actuators();
            k * a..(k + 1) * a
        } else {
            self.ball_points[k - samples].clone()
        }
    }

    /// No pose yet: a touch at readings first starts from the
    /// mechanism's [`Mechanism::start_pose`].
    fn initial_cache(&self, _i: usize) -> WarmStart {
        WarmStart::default()
    }

    /// The row of point `i` at its group's block (module doc).
    fn linearize(
        &self,
        i: usize,
        global: &DVector<f64>,
        group: &SVector<f64, C>,
        _point: &SVector<f64, 0>,
        cache: &mut WarmStart,
        out: &mut Local<C>,
    ) -> Result<(), MechanismCalibrationError> {
        let caches = std::slice::from_mut(cache);
        let out = std::slice::from_mut(out);
        self.fill(i, global, group, caches, out, &mut Reaches::default())
            .map_err(|(_, e)| e)
    }

    /// A sample's rows of the batch from one evaluation.
    fn linearize_batch(
        &self,
        first: usize,
        global: &DVector<f64>,
        group: &SVector<f64, C>,
        _points: &[SVector<f64, 0>],
        caches: &mut [WarmStart],
        out: &mut [Local<C>],
        reaches: &mut Reaches,
    ) -> Result<(), (usize, MechanismCalibrationError)> {
        self.fill(first, global, group, caches, out, reaches)
    }

    /// A group's rows along the step ([`MechanismProblem::fill_along`]):
    /// its touches' `d_global` not written, each touch's cache at the pose
    /// predicted after the step.
    fn linearize_along_batch(
        &self,
        first: usize,
        global: &DVector<f64>,
        group: &SVector<f64, C>,
        _points: &[SVector<f64, 0>],
        caches: &mut [WarmStart],
        dg: &DVector<f64>,
        out: &mut [Local<C>],
        steps: &mut [SVector<f64, 1>],
        reaches: &mut Reaches,
    ) -> Result<(), (usize, MechanismCalibrationError)> {
        self.fill_along(first, global, group, caches, dg, out, steps, reaches)
    }

    /// Every probe height's, part distance's, measured point's, measured
    /// quantity's, ball distance's and tracker point's rows (module doc).
    fn global_observations(
        &self,
        global: &DVector<f64>,
        out: &mut GlobalObservations,
    ) -> Result<(), MechanismCalibrationError> {
        let mechanism = self.data.mechanism.as_ref();
        let n = self.n_params();
        let params = &global.as_slice()[..n];
        let configured = self.data.configured.as_slice();
        let m = self
            .global_observation_refs()
            .iter()
            .map(|(_, rows)| rows)
            .sum();
        *out = GlobalObservations::zeros(m, global.len());
        let mut row = 0;
        let mut put = |kind, index, evaluated: Result<Rows, MechanismError>| {
            let rows = evaluated.map_err(|e| failed(ObservationRef { kind, index }, e))?;
            let m = rows.residual.len();
            out.residual.rows_mut(row, m).copy_from(&rows.residual);
            out.jacobian
                .view_mut((row, 0), (m, n))
                .copy_from(&rows.d_params);
            row += m;
            Ok::<usize, MechanismCalibrationError>(row - m)
        };
        let o = &self.data.observations;
        let mut trigger_rows = Vec::with_capacity(o.probes.len());
        for (k, probe) in o.probes.iter().enumerate() {
            let evaluated = probe.evaluate(mechanism, params, configured, global[n]);
            let d_trigger_height = evaluated.as_ref().map_or(0.0, |e| e.d_trigger_height);
            let at = put(ObservationKind::Probe, k, evaluated.map(|e| e.rows))?;
            trigger_rows.push((at, d_trigger_height));
        }
        for (k, manual) in o.manual_heights.iter().enumerate() {
            put(
                ObservationKind::ManualHeight,
                k,
                manual.evaluate(mechanism, params, configured),
            )?;
        }
        for (k, distance) in o.distances.iter().enumerate() {
            put(
                ObservationKind::Distance,
                k,
                distance.evaluate(mechanism, params, configured),
            )?;
        }
        for (k, point) in o.points.iter().enumerate() {
            put(
                ObservationKind::Point,
                k,
                point.evaluate(mechanism, params, configured),
            )?;
        }
        for (k, quantity) in o.quantities.iter().enumerate() {
            put(
                ObservationKind::Quantity,
                k,
                quantity.evaluate(mechanism, params),
            )?;
        }
        for (at, d_trigger_height) in trigger_rows {
            out.jacobian[(at, n)] = d_trigger_height;
        }
        for (k, distance) in o.ball_distances.iter().enumerate() {
            let id = ObservationRef {
                kind: ObservationKind::BallDistance,
                index: k,
            };
            let (Some(a), Some(b)) = (
                self.tied.column(distance.first),
                self.tied.column(distance.second),
            ) else {
                return Err(failed(id, "its balls' centres are not global unknowns"));
            };
            let centre = |c: usize| Vector3::from_column_slice(&global.as_slice()[c..c + 3]);
            let evaluated = distance
                .evaluate(&centre(a), &centre(b))
                .map_err(|e| failed(id, e))?;
            out.residual[row] = evaluated.residual;
            let mut jacobian = out.jacobian.row_mut(row);
            jacobian.columns_mut(a, 3).copy_from(&evaluated.d_first);
            jacobian.columns_mut(b, 3).copy_from(&evaluated.d_second);
            row += 1;
        }
        for (k, point) in o.tracker_points.iter().enumerate() {
            let id = ObservationRef {
                kind: ObservationKind::TrackerPoint,
                index: k,
            };
            let frame = self.trackers.frame(point.tracker, global);
            let offsets = self.trackers.offsets(point.tracker, global);
            let evaluated = point
                .evaluate(mechanism, params, configured, &frame, offsets, None)
                .map_err(|e| failed(id, e))?;
            out.residual
                .rows_mut(row, 3)
                .copy_from(&evaluated.rows.residual);
            out.jacobian
                .view_mut((row, 0), (3, n))
                .copy_from(&evaluated.rows.d_params);
            let columns = self.trackers.columns(point.tracker);
            out.jacobian
                .view_mut((row, columns.start), (3, columns.len()))
                .copy_from(&evaluated.d_frame);
            if let (Some(columns), Some(d_offsets)) = (
                self.trackers.offset_columns(point.tracker),
                &evaluated.d_offsets,
            ) {
                out.jacobian
                    .view_mut((row, columns.start), (3, columns.len()))
                    .copy_from(d_offsets);
            }
            row += 3;
        }
        for (k, pose) in o.tracker_poses.iter().enumerate() {
            let id = ObservationRef {
                kind: ObservationKind::TrackerPose,
                index: k,
            };
            let (Some(body), Some(body_columns)) = (
                self.trackers.body_of(pose.tracker, global),
                self.trackers.body_columns(),
            ) else {
                return Err(failed(id, "the body frame is not an unknown"));
            };
            let frame = self.trackers.frame(pose.tracker, global);
            let offsets = self.trackers.offsets(pose.tracker, global);
            let evaluated = pose
                .evaluate(mechanism, params, &frame, &body, offsets)
                .map_err(|e| failed(id, e))?;
            let m = evaluated.rows.residual.len();
            out.residual
                .rows_mut(row, m)
                .copy_from(&evaluated.rows.residual);
            let mut put = |columns: Range<usize>, d: &DMatrix<f64>| {
                out.jacobian
                    .view_mut((row, columns.start), (m, columns.len()))
                    .copy_from(d);
            };
            put(0..n, &evaluated.rows.d_params);
            put(self.trackers.columns(pose.tracker), &evaluated.d_frame);
            put(body_columns, &evaluated.d_body);
            // A body shift adds to the body's correction: the same columns.
            let shift = self.trackers.body_shift(pose.tracker);
            if let Some(start) = shift.rotation {
                put(
                    start..start + 3,
                    &evaluated.d_body.columns(0, 3).into_owned(),
                );
            }
            if let Some(start) = shift.origin {
                put(
                    start..start + 3,
                    &evaluated.d_body.columns(3, 3).into_owned(),
                );
            }
            if let (Some(columns), Some(d_offsets)) = (
                self.trackers.offset_columns(pose.tracker),
                &evaluated.d_offsets,
            ) {
                put(columns, d_offsets);
            }
            row += m;
        }
        Ok(())
    }

    fn loss(&self) -> Loss {
        self.loss
    }

    fn global_observation_rows(&self) -> Option<Vec<usize>> {
        Some(
            self.global_observation_refs()
                .into_iter()
                .map(|(_, rows)| rows)
                .collect(),
        )
    }

    fn global_prior(&self) -> Option<&GaussianPrior<Dyn>> {
        self.prior.as_ref()
    }

    /// A measured pose's coordinates with their sigmas; a ball's centre
    /// prior; with `C` 4, an uncertain ball's radius with its calibration
    /// sigma, and the unit prior of every unused fourth unknown (module
    /// doc).
    fn group_prior(&self, k: usize) -> Option<GaussianPrior<Const<C>>> {
        let o = &self.data.observations;
        let (mean, sigma) = match o.samples.get(k) {
            Some(sample) => match sample.known_pose {
                Some((pose, sigma)) => (
                    block(&Vector3::from(pose), 0.0),
                    block(&Vector3::from(sigma), UNUSED),
                ),
                None if C == 4 => (
                    SVector::zeros(),
                    block(&Vector3::repeat(f64::INFINITY), UNUSED),
                ),
                None => return None,
            },
            None => {
                let b = k - o.samples.len();
                let ball = &o.balls[b];
                // A tied ball's priors are on its global unknowns.
                if self.tied.column(b).is_some() || (ball.centre_prior.is_none() && C == 3) {
                    return None;
                }
                let (centre, sigma) = ball
                    .centre_prior
                    .map_or((Vector3::zeros(), f64::INFINITY), |prior| {
                        (Vector3::from(prior.centre), prior.sigma)
                    });
                (
                    block(&centre, ball.radius),
                    block(&Vector3::repeat(sigma), ball.radius_sigma.unwrap_or(UNUSED)),
                )
            }
        };
        Some(GaussianPrior::from_sigmas(mean, sigma))
    }
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
    use parcal_solver::{SolverOptions, Status, dense_reference, linear_step, solve};

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

    /// Batches of 4, 3 and 4 keep the rooms: the fourth set aside and
    /// taken back, the vector never shorter than a batch it can fill.
    #[test]
    fn a_warm_start_cache_holds_a_finite_start_that_fits() {
        // A delta's three values and a hexapod's seven come back at their
        // mechanism's length; a start too long, not finite or never set
        // is none.
        let start = [1.0, -2.0, 3.5, 0.1, 0.2, 0.3, 0.9];
        for len in [3, 7] {
            let cache = WarmStart::of(&start[..len]);
            assert_eq!(cache.start(len), Some(&start[..len]));
        }
        assert_eq!(WarmStart::default().start(3), None);
        assert_eq!(WarmStart::of(&[0.0; MAX_WARM_START + 1]).start(3), None);
        assert_eq!(WarmStart::of(&[1.0, f64::NAN, 2.0]).start(3), None);
        assert_eq!(
            WarmStart::of(&[-1.0, 2.0, f64::NEG_INFINITY]).start(3),
            None
        );
        assert_eq!(WarmStart::of(&start).start(MAX_WARM_START + 1), None);
        assert_eq!(size_of::<WarmStart>(), 8 * MAX_WARM_START);
    }

    #[test]
    fn batch_rooms_set_aside_and_take_back() {
        let (mut entries, mut spare) = (vec![10, 11, 12, 13], Vec::new());
        batch_rooms(&mut entries, &mut spare, 3);
        assert_eq!(
            (entries.as_slice(), spare.as_slice()),
            (&[10, 11, 12][..], &[13][..])
        );
        batch_rooms(&mut entries, &mut spare, 4);
        assert_eq!(
            (entries.as_slice(), spare.len()),
            (&[10, 11, 12, 13][..], 0)
        );
        batch_rooms(&mut entries, &mut spare, 6);
        assert_eq!(entries.len(), 4, "only what is set aside is taken back");
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
                    weight: CoordinateWhitening::isotropic(0.01),
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
                weight: CoordinateWhitening::isotropic(0.01),
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
