//! The observations of a mechanism calibration by kind and index, as
//! errors, tests and snooping name them.

use std::fmt;

#[cfg(doc)]
use parcal_observe::mechanism::{
    BallDistance, BallTouch, CommandedPoint, ManualHeight, MeasuredQuantity, PartDistance,
    PointSample, ProbeHeight, TrackerPoint, TrackerPose,
};

/// The kinds of observation of a mechanism calibration.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum ObservationKind {
    /// A probe touching the bed ([`ProbeHeight`]).
    Probe = 0,
    /// A distance measured on a part ([`PartDistance`]).
    Distance = 1,
    /// A position measured at a commanded position ([`CommandedPoint`]).
    Point = 2,
    /// Readings at an unknown or measured pose ([`PointSample`]).
    Sample = 3,
    /// A known function of the parameters measured directly
    /// ([`MeasuredQuantity`]).
    Quantity = 4,
    /// The tool point touching a calibrated ball ([`BallTouch`]).
    Touch = 5,
    /// A calibrated distance between two balls' centres
    /// ([`BallDistance`]).
    BallDistance = 6,
    /// The tool point measured by a tracker in its own frame
    /// ([`TrackerPoint`]).
    TrackerPoint = 7,
    /// A body on the platform measured by a tracker in its own frame
    /// ([`TrackerPose`]).
    TrackerPose = 8,
    /// The nozzle's height above the bed measured by hand
    /// ([`ManualHeight`]).
    ManualHeight = 9,
}

impl ObservationKind {
    /// Every kind, in the order of [`Self::index`].
    pub const ALL: [Self; 10] = [
        Self::Probe,
        Self::Distance,
        Self::Point,
        Self::Sample,
        Self::Quantity,
        Self::Touch,
        Self::BallDistance,
        Self::TrackerPoint,
        Self::TrackerPose,
        Self::ManualHeight,
    ];

    /// Its place in [`Self::ALL`].
    pub fn index(self) -> usize {
        self as usize
    }

    /// The kind whose [`Self::name`] is `name`, if any (as a record
    /// names it).
    pub fn named(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|kind| kind.name() == name)
    }

    /// Whether an observation of the kind is tested as one, over all its
    /// rows (a touch: one point of the solver, its rows together), rather
    /// than row by row (every other kind).
    pub fn rows_tested_as_one(self) -> bool {
        self == Self::Touch
    }

    /// Its name in messages and files: `probe height`, `part distance`,
    /// `measured point`, `point sample`, `measured quantity`, `ball touch`,
    /// `manual height`, ...
    pub fn name(self) -> &'static str {
        match self {
            Self::Probe => "probe height",
            Self::Distance => "part distance",
            Self::Point => "measured point",
            Self::Sample => "point sample",
            Self::Quantity => "measured quantity",
            Self::Touch => "ball touch",
            Self::BallDistance => "ball distance",
            Self::TrackerPoint => "tracker point",
            Self::TrackerPose => "tracker pose",
            Self::ManualHeight => "manual height",
        }
    }
}

/// One observation: its kind and its 0-based index among those of its
/// kind in the data given.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct ObservationRef {
    /// The kind.
    pub kind: ObservationKind,
    /// The 0-based index.
    pub index: usize,
}

impl fmt::Display for ObservationRef {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{} {}", self.kind.name(), self.index)
    }
}

/// What held-out rows are of ([`validate_mechanism`](super::validate_mechanism)):
/// one observation, or every touch of one ball together (they share the
/// ball's unknown centre, fitted to them, so that no touch has rows of its
/// own).
#[derive(Debug, Clone, PartialEq, Eq, Hash)]
pub enum HeldOut {
    /// One observation.
    Observation(ObservationRef),
    /// A ball's touches.
    Ball {
        /// The ball's 0-based index.
        ball: usize,
        /// Its touches' 0-based indices, increasing.
        touches: Vec<usize>,
    },
    /// A tracker's points and poses: its frame is fitted to them (a
    /// tracker placed anew is a frame of its own), and with poses the body
    /// frame they see.
    Tracker {
        /// The tracker's 0-based index.
        tracker: usize,
        /// Its points' 0-based indices, increasing.
        points: Vec<usize>,
        /// Its poses' 0-based indices, increasing.
        poses: Vec<usize>,
    },
    /// Balls that ball distances tie together, their touches and those
    /// distances: the balls' centres are fitted to them together.
    TiedBalls {
        /// The balls' 0-based indices, increasing.
        balls: Vec<usize>,
        /// Their touches' 0-based indices, increasing.
        touches: Vec<usize>,
        /// The ball distances' 0-based indices, increasing.
        distances: Vec<usize>,
    },
}

impl HeldOut {
    /// Its kind's name: the observation's ([`ObservationKind::name`]),
    /// `ball`, `tracker` or `tied balls`.
    pub fn name(&self) -> &'static str {
        match self {
            Self::Observation(observation) => observation.kind.name(),
            Self::Ball { .. } => "ball",
            Self::Tracker { .. } => "tracker",
            Self::TiedBalls { .. } => "tied balls",
        }
    }
}

impl fmt::Display for HeldOut {
    /// `probe height 3`, `ball 1 (ball touches 7-13)`, `tracker 0
    /// (tracker points 0-11, tracker poses 0-5)`, `balls 0-2 (ball touches
    /// 0-20, ball distances 0-1)`.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Observation(observation) => observation.fmt(f),
            Self::Ball { ball, touches } => write!(
                f,
                "ball {ball} (ball touches {})",
                number_ranges(touches.iter().copied())
            ),
            Self::Tracker {
                tracker,
                points,
                poses,
            } => {
                let listed = [("tracker points", points), ("tracker poses", poses)]
                    .into_iter()
                    .filter(|(_, indices)| !indices.is_empty())
                    .map(|(what, indices)| {
                        format!("{what} {}", number_ranges(indices.iter().copied()))
                    })
                    .collect::<Vec<_>>();
                write!(f, "tracker {tracker} ({})", listed.join(", "))
            }
            Self::TiedBalls {
                balls,
                touches,
                distances,
            } => write!(
                f,
                "balls {} (ball touches {}, ball distances {})",
                number_ranges(balls.iter().copied()),
                number_ranges(touches.iter().copied()),
                number_ranges(distances.iter().copied())
            ),
        }
    }
}

/// Increasing numbers as runs: `4-10, 12`.
pub fn number_ranges(numbers: impl IntoIterator<Item = usize>) -> String {
    let mut runs: Vec<(usize, usize)> = Vec::new();
    for n in numbers {
        match runs.last_mut() {
            Some((_, last)) if n == *last + 1 => *last = n,
            _ => runs.push((n, n)),
        }
    }
    let run = |&(first, last): &(usize, usize)| {
        if first == last {
            first.to_string()
        } else {
            format!("{first}-{last}")
        }
    };
    runs.iter().map(run).collect::<Vec<_>>().join(", ")
}

/// Touch `t` as an observation.
pub(crate) fn touch_ref(t: usize) -> ObservationRef {
    ObservationRef {
        kind: ObservationKind::Touch,
        index: t,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_ball_is_named_with_its_touches_as_runs() {
        let ball = HeldOut::Ball {
            ball: 1,
            touches: vec![4, 5, 6, 9, 11, 12],
        };
        assert_eq!(ball.to_string(), "ball 1 (ball touches 4-6, 9, 11-12)");
        assert_eq!(ball.name(), "ball");
        let tied = HeldOut::TiedBalls {
            balls: vec![0, 1, 2, 5],
            touches: (0..20).collect(),
            distances: vec![0, 1, 2],
        };
        assert_eq!(
            tied.to_string(),
            "balls 0-2, 5 (ball touches 0-19, ball distances 0-2)"
        );
        assert_eq!(tied.name(), "tied balls");
        let probe = HeldOut::Observation(ObservationRef {
            kind: ObservationKind::Probe,
            index: 3,
        });
        assert_eq!(probe.to_string(), "probe height 3");
        assert_eq!(number_ranges([]), "");
    }
}
