//! A measurement a plan may choose, in the observation kinds of the
//! mechanism calibration (`parcal_observe::mechanism`). What the pose of
//! each is matters to its information ([`crate::mechanism::information`]):
//! a probe height and a measured point are taken at a commanded position
//! (the pose is a function of the parameters, with the shared trigger
//! height for a probe; a part distance is between two commanded
//! positions), a sample at an unknown pose has a pose of its
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
}

impl Candidate {
    /// The observation kind's name, as the calibration names it.
    pub fn kind(&self) -> &'static str {
        match self {
            Candidate::Probe(_) => "probe height",
            Candidate::Sample(_) | Candidate::MeasuredSample(_) => "point sample",
            Candidate::Point(_) => "measured point",
            Candidate::Distance(_) => "part distance",
        }
    }

    /// Where the effector goes: the commanded or target position (mm), a
    /// probe at the trigger height `trigger_height` above the bed, a part
    /// distance's two ends.
    pub fn positions(&self, trigger_height: f64) -> Vec<[f64; 3]> {
        match *self {
            Candidate::Probe([x, y]) => vec![[x, y, trigger_height]],
            Candidate::Sample(p) | Candidate::MeasuredSample(p) | Candidate::Point(p) => vec![p],
            Candidate::Distance(ends) => ends.to_vec(),
        }
    }

    /// Whether it is taken at commanded positions (the controller's
    /// parameters put the effector there), rather than at a pose the
    /// machine's true parameters give.
    pub fn is_commanded(&self) -> bool {
        matches!(
            self,
            Candidate::Probe(_) | Candidate::Point(_) | Candidate::Distance(_)
        )
    }
}
