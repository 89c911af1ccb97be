//! A mechanism calibration's observations by kind ([`Observations`]): how
//! many of each, the balls the ball distances tie, each ball's touches
//! counted on the threads, the observations without one.

use nalgebra::Isometry3;
use parcal_observe::mechanism::{
    BallDistance, BallTouch, CommandedPoint, ManualHeight, MeasuredQuantity, PartDistance,
    PointSample, ProbeHeight, TrackerPoint, TrackerPose,
};
use rayon::prelude::*;

use super::super::observation::{ObservationKind, ObservationRef};
use super::super::tied::TiedBalls;
use super::ball::Ball;
use super::tracker::Tracker;

/// The observations, by kind.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Observations {
    /// Probe heights.
    pub probes: Vec<ProbeHeight>,
    /// Heights of the nozzle measured by hand.
    pub manual_heights: Vec<ManualHeight>,
    /// Part distances.
    pub distances: Vec<PartDistance>,
    /// Measured points at commanded positions.
    pub points: Vec<CommandedPoint>,
    /// Readings at unknown or measured poses.
    pub samples: Vec<PointSample>,
    /// Quantities of the machine measured directly.
    pub quantities: Vec<MeasuredQuantity>,
    /// The calibrated balls the touches touch (not observations: their
    /// centres are unknowns).
    pub balls: Vec<Ball>,
    /// Touches of the balls.
    pub touches: Vec<BallTouch>,
    /// Calibrated distances between the balls' centres.
    pub ball_distances: Vec<BallDistance>,
    /// The trackers, one per placement of an instrument (not
    /// observations: each tracker's frame is six unknowns of the global
    /// block).
    pub trackers: Vec<Tracker>,
    /// Points the trackers measured.
    pub tracker_points: Vec<TrackerPoint>,
    /// Poses of a body on the platform the trackers measured.
    pub tracker_poses: Vec<TrackerPose>,
    /// `B₀`, the reference of the body frame the tracker poses see (body →
    /// platform; [`parcal_observe::mechanism::BodyFrame`]): the fit's start,
    /// the body frame's correction six unknowns of the global block when
    /// there are tracker poses. The identity by default.
    pub body_reference: Isometry3<f64>,
}

impl Observations {
    /// The number of observations of `kind`.
    pub fn count(&self, kind: ObservationKind) -> usize {
        match kind {
            ObservationKind::Probe => self.probes.len(),
            ObservationKind::Distance => self.distances.len(),
            ObservationKind::Point => self.points.len(),
            ObservationKind::Sample => self.samples.len(),
            ObservationKind::Quantity => self.quantities.len(),
            ObservationKind::Touch => self.touches.len(),
            ObservationKind::BallDistance => self.ball_distances.len(),
            ObservationKind::TrackerPoint => self.tracker_points.len(),
            ObservationKind::TrackerPose => self.tracker_poses.len(),
            ObservationKind::ManualHeight => self.manual_heights.len(),
        }
    }

    /// The number of observations.
    pub fn len(&self) -> usize {
        ObservationKind::ALL.iter().map(|&k| self.count(k)).sum()
    }

    /// Whether there is none.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The balls the ball distances tie, their unknowns from global column
    /// `first` on ([`super::super::tied`]).
    pub(crate) fn tied_balls(&self, first: usize) -> TiedBalls {
        let radius_unknown: Vec<bool> = self
            .balls
            .iter()
            .map(|ball| ball.radius_sigma.is_some())
            .collect();
        TiedBalls::new(&self.ball_distances, &radius_unknown, first)
    }

    /// Each ball's set and the number of sets: the balls the ball
    /// distances tie together (connected through them) are one set, a ball
    /// tied to none a set of its own, the sets numbered in the order of
    /// their first ball.
    pub(crate) fn ball_sets(&self) -> (Vec<usize>, usize) {
        // Union of each distance's two balls, each set's first ball its
        // representative.
        let mut first: Vec<usize> = (0..self.balls.len()).collect();
        fn root(first: &mut [usize], mut b: usize) -> usize {
            while first[b] != b {
                first[b] = first[first[b]];
                b = first[b];
            }
            b
        }
        for d in &self.ball_distances {
            let (a, b) = (root(&mut first, d.first), root(&mut first, d.second));
            first[a.max(b)] = a.min(b);
        }
        let mut set = vec![0; self.balls.len()];
        let mut sets = 0;
        for b in 0..self.balls.len() {
            let r = root(&mut first, b);
            set[b] = if r == b {
                sets += 1;
                sets - 1
            } else {
                set[r]
            };
        }
        (set, sets)
    }

    /// Each ball's number of touches, and whether the touches come ball by
    /// ball (their balls' indices never decrease); every touch on a ball
    /// that exists. The touches are read a chunk at a time on the threads,
    /// each chunk as its runs of touches of one ball, which are then added
    /// up in order.
    pub(crate) fn touches_per_ball(&self) -> (Vec<usize>, bool) {
        let runs: Vec<Vec<(usize, usize)>> = (self.touches.par_chunks(COUNT_CHUNK))
            .map(|touches| {
                let mut runs: Vec<(usize, usize)> = Vec::new();
                for touch in touches {
                    match runs.last_mut() {
                        Some((ball, count)) if *ball == touch.ball => *count += 1,
                        _ => runs.push((touch.ball, 1)),
                    }
                }
                runs
            })
            .collect();
        let mut counts = vec![0; self.balls.len()];
        let (mut grouped, mut last) = (true, 0);
        for &(ball, count) in runs.iter().flatten() {
            counts[ball] += count;
            grouped &= last <= ball;
            last = ball;
        }
        (counts, grouped)
    }

    /// These observations without `observation`.
    pub fn without(&self, observation: ObservationRef) -> Self {
        let mut rest = self.clone();
        let k = observation.index;
        match observation.kind {
            ObservationKind::Probe => drop(rest.probes.remove(k)),
            ObservationKind::Distance => drop(rest.distances.remove(k)),
            ObservationKind::Point => drop(rest.points.remove(k)),
            ObservationKind::Sample => drop(rest.samples.remove(k)),
            ObservationKind::Quantity => drop(rest.quantities.remove(k)),
            ObservationKind::Touch => drop(rest.touches.remove(k)),
            ObservationKind::BallDistance => drop(rest.ball_distances.remove(k)),
            ObservationKind::TrackerPoint => drop(rest.tracker_points.remove(k)),
            ObservationKind::TrackerPose => drop(rest.tracker_poses.remove(k)),
            ObservationKind::ManualHeight => drop(rest.manual_heights.remove(k)),
        }
        rest
    }
}

/// The number of touches [`Observations::touches_per_ball`] reads at a time
/// on the threads.
const COUNT_CHUNK: usize = 4096;

#[cfg(test)]
mod tests {
    use super::*;
    use parcal_observe::mechanism::Actuation;

    /// Touches of `balls` balls in the order `order`.
    fn observations(balls: usize, order: &[usize]) -> Observations {
        let ball = Ball {
            radius: 5.0,
            radius_sigma: None,
            centre_prior: None,
        };
        Observations {
            balls: vec![ball; balls],
            touches: (order.iter())
                .map(|&b| BallTouch::new(b, Actuation::Commanded([0.0, 0.0, 10.0]), 0.01))
                .collect(),
            ..Observations::default()
        }
    }

    /// Each ball's count, and whether the touches come ball by ball, as
    /// one pass in order finds them, for runs that cross the threads'
    /// chunks and for a ball whose touches come back after another's.
    #[test]
    fn touches_are_counted_per_ball_across_chunks() {
        let n = 3 * COUNT_CHUNK + 17;
        let grouped: Vec<usize> = (0..n).map(|t| t * 5 / n).collect();
        let mut back = grouped.clone();
        back[2 * COUNT_CHUNK] = 0;
        // A decrease exactly at a chunk's first touch.
        let at_boundary: Vec<usize> = (0..n)
            .map(|t| if t < COUNT_CHUNK { 5 } else { t * 5 / n })
            .collect();
        for (order, expected) in [(grouped, true), (back, false), (at_boundary, false)] {
            let mut counts = vec![0; 6];
            let (mut in_order, mut last) = (true, 0);
            for &b in &order {
                counts[b] += 1;
                in_order &= last <= b;
                last = b;
            }
            assert_eq!(in_order, expected);
            assert_eq!(
                observations(6, &order).touches_per_ball(),
                (counts, in_order)
            );
        }
    }
}
