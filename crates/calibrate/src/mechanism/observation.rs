//! The observations of a mechanism calibration by kind and index, as
//! errors, tests and snooping name them.

use std::fmt;

#[cfg(doc)]
use parcal_observe::mechanism::{
    BallTouch, CommandedPoint, MeasuredQuantity, PartDistance, PointSample, ProbeHeight,
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
}

impl ObservationKind {
    /// Every kind, in the order of the rows.
    pub const ALL: [Self; 6] = [
        Self::Probe,
        Self::Distance,
        Self::Point,
        Self::Sample,
        Self::Quantity,
        Self::Touch,
    ];

    /// Its place in [`Self::ALL`].
    pub fn index(self) -> usize {
        self as usize
    }

    /// Its name in messages and files: `probe height`, `part distance`,
    /// `measured point`, `point sample`, `measured quantity`, `ball touch`.
    pub fn name(self) -> &'static str {
        match self {
            Self::Probe => "probe height",
            Self::Distance => "part distance",
            Self::Point => "measured point",
            Self::Sample => "point sample",
            Self::Quantity => "measured quantity",
            Self::Touch => "ball touch",
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
