//! K-fold cross-validation of a mechanism's calibration: observation `j`
//! of each kind in fold `j mod K`, each fold's observations predicted
//! ([`validate_mechanism`]) by the calibration ([`calibrate_mechanism`])
//! of the others, the folds pooled as the hexapod's cross-validation pools
//! them ([`crate::cross_validation`]): the statistics and their degrees of
//! freedom summed, the folds' global tests as one pass over the data, a
//! w-test per row over all the rows.
//!
//! A ball's touches share its unknown centre, and balls tied by ball
//! distances share the distances: each set of balls (a ball alone, or the
//! balls distances tie together), numbered in the order of its first ball,
//! is in fold `s mod K` with its touches and distances, and a held-out
//! set's centres are fitted to its own touches as a held-out campaign's
//! are ([`validate_mechanism`] without reference touches). A tracker's
//! points and poses share its frame: its `k`-th point and its `k`-th pose
//! are in fold `k mod K`, every tracker in every fold, and a held-out
//! fold's frames are fitted to its own points and poses, as a held-out
//! campaign's are; each tracker needs [`MIN_POINTS_PER_TRACKER`] of them
//! in each fold.

use crate::cross_validation::pooled_global_test;
use crate::hypothesis::critical_value;
use crate::prediction::PredictionTest;

use super::calibrate::calibrate_mechanism;
use super::calibrated::CalibratedMechanism;
use super::data::{MIN_POINTS_PER_TRACKER, MechanismData, Observations};
use super::error::MechanismCalibrationError;
use super::observation::{HeldOut, ObservationKind};
use super::options::MechanismOptions;
use super::validation::{MechanismValidation, validate_mechanism};

/// Cross-validates the calibration of `data` under `options` with `folds`
/// folds (module doc); `fold_done` is told of each fold as it ends. Each
/// row is named by its observation's (or ball's, or tracker's) index in
/// `data`. Errors: fewer than two folds, more folds than any kind has
/// observations or there are sets of balls (a fold would hold none), a
/// tracker with fewer than [`MIN_POINTS_PER_TRACKER`] points and poses in
/// a fold, a fold whose calibration does not converge or cannot predict
/// its observations.
pub fn cross_validate_mechanism(
    data: &MechanismData,
    options: &MechanismOptions,
    folds: usize,
    fold_done: &mut dyn FnMut(usize),
) -> Result<MechanismValidation, MechanismCalibrationError> {
    let refuse = |reason: String| MechanismCalibrationError::InvalidData {
        what: "the folds".to_string(),
        reason,
    };
    let o = &data.observations;
    let (ball_set, sets) = o.ball_sets();
    let most = (ObservationKind::ALL.iter())
        .filter(|&&kind| !matches!(kind, ObservationKind::Touch | ObservationKind::BallDistance))
        .map(|&kind| o.count(kind))
        .chain([sets])
        .max()
        .unwrap_or(0);
    if folds < 2 || folds > most {
        return Err(refuse(format!(
            "{folds} folds of data whose most numerous kind has {most} observations (a set of balls counted as one): give from 2 to {most}"
        )));
    }
    let ranks = TrackerRanks::of(o);
    if let Some((t, count)) =
        (ranks.counts.iter().enumerate()).find(|&(_, &n)| n < folds * MIN_POINTS_PER_TRACKER)
    {
        return Err(refuse(format!(
            "tracker {t} ({:?}) has {count} points and poses: {folds} folds need {} ({MIN_POINTS_PER_TRACKER} a fold, to locate its frame)",
            o.trackers[t].label,
            folds * MIN_POINTS_PER_TRACKER
        )));
    }
    let mut pooled = Vec::with_capacity(folds);
    for r in 0..folds {
        let in_fold = |j: usize| j % folds == r;
        let ball_in_fold = |b: usize| in_fold(ball_set[b]);
        let (fit, _) = fold(o, &ranks, |j| !in_fold(j), |b| !ball_in_fold(b));
        let fit = data.with_observations(fit);
        let calibration = calibrate_mechanism(&fit, options, &mut |_| {})?;
        if !calibration.converged() {
            return Err(refuse(format!(
                "the calibration without fold {r} did not converge ({:?})",
                calibration.status
            )));
        }
        let calibrated = CalibratedMechanism::of_calibration(&calibration)?;
        let (held_out, names) = fold(o, &ranks, in_fold, ball_in_fold);
        let held_out = data.with_observations(held_out);
        let mut validation = validate_mechanism(&calibrated, &held_out, options.alpha, None)?;
        for row in &mut validation.rows {
            names.name_in_data(&mut row.observation);
        }
        pooled.push((validation, calibrated.global_test));
        fold_done(r);
    }
    let tests: Option<Vec<(f64, usize)>> = pooled.iter().map(|(_, test)| *test).collect();
    let calibration_test = tests.map(|tests| pooled_global_test(&tests));
    let statistic = pooled.iter().map(|(v, _)| v.statistic).sum();
    let (first, _) = &pooled[0];
    let mechanism = first.mechanism.clone();
    let untested = pooled.iter().map(|(v, _)| v.untested).sum();
    let rows: Vec<_> = pooled.into_iter().flat_map(|(v, _)| v.rows).collect();
    let n = rows.len();
    Ok(MechanismValidation {
        mechanism,
        rows,
        untested,
        reference: None,
        statistic,
        test: PredictionTest::new(statistic, n, calibration_test),
        alpha: options.alpha,
        critical_value: critical_value(options.alpha, n),
        shifts: Vec::new(),
        mirrored_balls: Vec::new(),
    })
}

/// Where each of a fold's observations and balls is in the data.
struct FoldNames {
    /// For each kind ([`ObservationKind::index`]), the index in the data
    /// of each of the fold's observations of that kind.
    index: Vec<Vec<usize>>,
    /// The index in the data of each of the fold's balls.
    balls: Vec<usize>,
}

impl FoldNames {
    /// `held_out`, named by its place in the fold, renamed by its place
    /// in the data.
    fn name_in_data(&self, held_out: &mut HeldOut) {
        let of = |kind: ObservationKind| &self.index[kind.index()];
        let map = |indices: &mut Vec<usize>, to: &[usize]| {
            for k in indices.iter_mut() {
                *k = to[*k];
            }
        };
        match held_out {
            HeldOut::Observation(observation) => {
                observation.index = of(observation.kind)[observation.index];
            }
            HeldOut::Ball { ball, touches } => {
                *ball = self.balls[*ball];
                map(touches, of(ObservationKind::Touch));
            }
            HeldOut::TiedBalls {
                balls,
                touches,
                distances,
            } => {
                map(balls, &self.balls);
                map(touches, of(ObservationKind::Touch));
                map(distances, of(ObservationKind::BallDistance));
            }
            HeldOut::Tracker {
                tracker: _,
                points,
                poses,
            } => {
                map(points, of(ObservationKind::TrackerPoint));
                map(poses, of(ObservationKind::TrackerPose));
            }
        }
    }
}

/// Each tracker point's and pose's rank among its tracker's (module doc),
/// and each tracker's count of them.
struct TrackerRanks {
    points: Vec<usize>,
    poses: Vec<usize>,
    counts: Vec<usize>,
}

impl TrackerRanks {
    fn of(o: &Observations) -> Self {
        let mut counts = vec![0; o.trackers.len()];
        let mut rank = |tracker: usize| {
            counts[tracker] += 1;
            counts[tracker] - 1
        };
        let points = o.tracker_points.iter().map(|p| rank(p.tracker)).collect();
        let poses = o.tracker_poses.iter().map(|p| rank(p.tracker)).collect();
        Self {
            points,
            poses,
            counts,
        }
    }
}

/// The observations of `o` whose index within their kind (a tracker's
/// point's or pose's rank among its tracker's, `ranks`) `keep` takes, and
/// the balls `keep_ball` takes with their touches and the distances
/// between them (a set of balls is kept or left whole, module doc); and
/// where each is in `o`.
fn fold(
    o: &Observations,
    ranks: &TrackerRanks,
    keep: impl Fn(usize) -> bool,
    keep_ball: impl Fn(usize) -> bool,
) -> (Observations, FoldNames) {
    let mut index = vec![Vec::new(); ObservationKind::ALL.len()];
    let mut kept = |kind: ObservationKind, count: usize, keep: &dyn Fn(usize) -> bool| {
        let kept: Vec<usize> = (0..count).filter(|&j| keep(j)).collect();
        index[kind.index()] = kept.clone();
        kept
    };
    fn taken<T: Clone>(all: &[T], kept: &[usize]) -> Vec<T> {
        kept.iter().map(|&j| all[j].clone()).collect()
    }
    let probes = kept(ObservationKind::Probe, o.probes.len(), &keep);
    let manual_heights = kept(ObservationKind::ManualHeight, o.manual_heights.len(), &keep);
    let distances = kept(ObservationKind::Distance, o.distances.len(), &keep);
    let points = kept(ObservationKind::Point, o.points.len(), &keep);
    let samples = kept(ObservationKind::Sample, o.samples.len(), &keep);
    let quantities = kept(ObservationKind::Quantity, o.quantities.len(), &keep);
    let balls: Vec<usize> = (0..o.balls.len()).filter(|&b| keep_ball(b)).collect();
    let mut new_ball = vec![usize::MAX; o.balls.len()];
    for (k, &b) in balls.iter().enumerate() {
        new_ball[b] = k;
    }
    let touches = kept(ObservationKind::Touch, o.touches.len(), &|j| {
        keep_ball(o.touches[j].ball)
    });
    let ball_distances = kept(
        ObservationKind::BallDistance,
        o.ball_distances.len(),
        &|j| keep_ball(o.ball_distances[j].first),
    );
    let tracker_points = kept(
        ObservationKind::TrackerPoint,
        o.tracker_points.len(),
        &|j| keep(ranks.points[j]),
    );
    let tracker_poses = kept(ObservationKind::TrackerPose, o.tracker_poses.len(), &|j| {
        keep(ranks.poses[j])
    });
    let observations = Observations {
        probes: taken(&o.probes, &probes),
        manual_heights: taken(&o.manual_heights, &manual_heights),
        distances: taken(&o.distances, &distances),
        points: taken(&o.points, &points),
        samples: taken(&o.samples, &samples),
        quantities: taken(&o.quantities, &quantities),
        balls: taken(&o.balls, &balls),
        touches: (touches.iter())
            .map(|&j| {
                let mut touch = o.touches[j].clone();
                touch.ball = new_ball[touch.ball];
                touch
            })
            .collect(),
        ball_distances: (ball_distances.iter())
            .map(|&j| {
                let mut distance = o.ball_distances[j];
                distance.first = new_ball[distance.first];
                distance.second = new_ball[distance.second];
                distance
            })
            .collect(),
        trackers: o.trackers.clone(),
        tracker_points: taken(&o.tracker_points, &tracker_points),
        tracker_poses: taken(&o.tracker_poses, &tracker_poses),
        body_reference: o.body_reference,
    };
    (observations, FoldNames { index, balls })
}
