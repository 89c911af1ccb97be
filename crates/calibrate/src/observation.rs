//! An observation of a dataset by its place there: what the tests judge
//! and data snooping removes as a whole.

/// An observation of a dataset, by its place there (0-based): what data
/// snooping tests and removes as a whole.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum ObservationId {
    /// A ball touch: its measurements.csv row.
    Contact(usize),
    /// A calibrated distance: its index in artefacts.json's `distances`.
    Distance(usize),
    /// A measured pose (six rows): its poses.csv row.
    Pose(usize),
    /// A measured tool point (three rows): its points.csv row.
    Point(usize),
}

impl ObservationId {
    /// Its whitened rows.
    pub fn rows(self) -> usize {
        match self {
            Self::Contact(_) | Self::Distance(_) => 1,
            Self::Pose(_) => 6,
            Self::Point(_) => 3,
        }
    }

    /// The tests it adds to the family of data snooping (module doc): one
    /// for a contact (its rows' `|w|` are equal for the coordinate
    /// observation, and it has one row for the radius observation) and a
    /// distance, one per row for a pose or a point.
    pub fn tests(self) -> usize {
        match self {
            Self::Contact(_) => 1,
            other => other.rows(),
        }
    }

    /// The group of its variance component.
    pub fn group(self) -> &'static str {
        match self {
            Self::Contact(_) => "ball touches",
            Self::Distance(_) => "distances",
            Self::Pose(_) => "poses",
            Self::Point(_) => "points",
        }
    }
}

/// Its kind and index, 0-based: `contact 12`, `distance 3`, `pose 4`,
/// `point 7` (the report names its file and line).
impl std::fmt::Display for ObservationId {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::Contact(k) => write!(f, "contact {k}"),
            Self::Distance(k) => write!(f, "distance {k}"),
            Self::Pose(k) => write!(f, "pose {k}"),
            Self::Point(k) => write!(f, "point {k}"),
        }
    }
}
