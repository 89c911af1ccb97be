//! A measurement a plan may choose, in the observation kinds of the
//! mechanism calibration (`parcal_observe::mechanism`). What the pose of
//! each is matters to its information ([`crate::mechanism::information`]):
//! a probe height and a measured point are taken at a commanded position
//! (the pose is a function of the parameters, with the shared trigger
//! height for a probe; a part distance is between two commanded
//! positions; a height measured by hand too, with no trigger height), a
//! sample at an unknown pose has a pose of its
//! own that absorbs part of its readings, and a sample whose position is
//! measured has that pose held by the measurement.

/// One candidate measurement.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Candidate {
    /// A probe height at commanded `(x, y)` (mm): probes.csv's `x, y`.
    Probe([f64; 2]),
    /// Readings with the effector moved near `position` (mm), the
    /// position not measured: a points.csv row with `x, y, z` empty.
    Sample([f64; 3]),
    /// Readings with the effector at `position`, the position measured
    /// too: a points.csv row with `x, y, z`.
    MeasuredSample([f64; 3]),
    /// The effector's position measured at the commanded `position`.
    Point([f64; 3]),
    /// The distance between two commanded positions measured on a
    /// printed part: a distances.csv row's `x1,y1,z1` and `x2,y2,z2`.
    Distance([[f64; 3]; 2]),
    /// The nozzle's height above the bed measured by hand at the
    /// commanded `position` (mm): a heights.csv row's `x, y, z`.
    Height([f64; 3]),
}

/// The sets a plan picks from in turn, each with its own count: the
/// measurements a machine makes itself (probe heights, encoder samples,
/// measured points), then heights measured by hand, then part distances,
/// each set from the covariance the sets before leave.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Stage {
    /// Probe heights, samples and measured points.
    Measurements,
    /// Heights measured by hand.
    Heights,
    /// Part distances.
    Distances,
}

impl Stage {
    /// Every stage, in the order a plan picks them.
    pub const ALL: [Stage; 3] = [Stage::Measurements, Stage::Heights, Stage::Distances];

    /// What the stage's picks are called.
    pub fn name(self) -> &'static str {
        match self {
            Stage::Measurements => "measurements",
            Stage::Heights => "manual heights",
            Stage::Distances => "part distances",
        }
    }
}

/// How many picks a plan makes of each stage's candidates
/// ([`Candidate::stage`]).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Counts {
    /// Probe heights, samples or measured points.
    pub measurements: usize,
    /// Heights measured by hand ([`Candidate::Height`]).
    pub heights: usize,
    /// Part distances ([`Candidate::Distance`]).
    pub distances: usize,
}

impl Counts {
    /// The count of `stage`.
    pub fn of(&self, stage: Stage) -> usize {
        match stage {
            Stage::Measurements => self.measurements,
            Stage::Heights => self.heights,
            Stage::Distances => self.distances,
        }
    }

    /// Every stage's together.
    pub fn total(&self) -> usize {
        self.measurements + self.heights + self.distances
    }
}

impl Candidate {
    /// The observation kind's name, as the calibration names it.
    pub fn kind(&self) -> &'static str {
        match self {
            Candidate::Probe(_) => "probe height",
            Candidate::Sample(_) | Candidate::MeasuredSample(_) => "point sample",
            Candidate::Point(_) => "measured point",
            Candidate::Distance(_) => "part distance",
            Candidate::Height(_) => "manual height",
        }
    }

    /// The stage of the plan that picks it.
    pub fn stage(&self) -> Stage {
        match self {
            Candidate::Height(_) => Stage::Heights,
            Candidate::Distance(_) => Stage::Distances,
            _ => Stage::Measurements,
        }
    }

    /// Where the effector goes: the commanded or target position (mm), a
    /// probe at the trigger height `trigger_height` above the bed, a part
    /// distance's two ends.
    pub fn positions(&self, trigger_height: f64) -> Vec<[f64; 3]> {
        match *self {
            Candidate::Probe([x, y]) => vec![[x, y, trigger_height]],
            Candidate::Sample(p)
            | Candidate::MeasuredSample(p)
            | Candidate::Point(p)
            | Candidate::Height(p) => vec![p],
            Candidate::Distance(ends) => ends.to_vec(),
        }
    }

    /// Whether it is taken at commanded positions (the controller's
    /// parameters put the effector there), rather than at a pose the
    /// machine's true parameters give.
    pub fn is_commanded(&self) -> bool {
        matches!(
            self,
            Candidate::Probe(_)
                | Candidate::Point(_)
                | Candidate::Distance(_)
                | Candidate::Height(_)
        )
    }
}
