//! Why a calibration could not be set up or evaluated.
//!
//! Errors name what the calibration was given, not where it came from: a
//! measurement row by its 0-based index in [`Measurements`]'s arrays (`row`
//! 5 is `measurements.q[5]`), a ball by its id, a field of the dataset by
//! its path in [`Dataset`] (`artefacts.balls[3].radius`). A caller that
//! read the dataset from files knows them and adds them: row `r` is line
//! `r + 2` of measurements.csv (the header is line 1), see
//! [`CalibrateError::row`].
//!
//! Each message states its cause and [`Error::source`] is `None`: a chain
//! printed cause by cause (anyhow's `{:#}`) shows every cause once, and so
//! does the message alone (the solver's status keeps only the message).
//!
//! [`Dataset`]: parcal_dataset::Dataset
//! [`Measurements`]: parcal_dataset::Measurements
//! [`Error::source`]: std::error::Error::source

use std::fmt;
use std::path::Path;

use parcal_dataset::DatasetError;
use parcal_kinematics::KinematicsError;
use parcal_observe::ObserveError;

use crate::sphere_fit::SphereFitError;

/// Why [`calibrate`](crate::calibrate) failed before or while it solved.
#[derive(Debug, Clone)]
#[non_exhaustive]
pub enum CalibrateError {
    /// The dataset fails
    /// [`Dataset::validate`](parcal_dataset::Dataset::validate): an array of the wrong
    /// length, a ball index out of range, a value that is not finite or a
    /// sigma that is not positive.
    InvalidDataset {
        /// The measurement row, when the problem is in one.
        row: Option<usize>,
        /// In a row, its field as the columns of measurements.csv name it
        /// (`ball`, `q1`..`q6`, `dir_x`..`dir_z`); otherwise the field's
        /// path in [`Dataset`](parcal_dataset::Dataset)
        /// (`artefacts.balls[3].radius`).
        field: String,
        /// What is wrong with it.
        message: String,
    },
    /// A ball has fewer contacts than its initial centre needs
    /// ([`MIN_CONTACTS_PER_BALL`](crate::MIN_CONTACTS_PER_BALL)).
    TooFewContacts {
        /// Id of the first ball (in artefacts order) that is short.
        ball: String,
        /// Its number of contacts.
        count: usize,
        /// The minimum.
        min: usize,
    },
    /// The design geometry (`machine`) cannot be put in canonical frames.
    Design(KinematicsError),
    /// Forward kinematics failed at the actuator readings of a row.
    /// (`source` is the cause, stated in the message; see the module doc.)
    ForwardKinematics {
        /// The measurement row.
        row: usize,
        /// Why forward kinematics failed.
        source: KinematicsError,
    },
    /// The observation of a row could not be formed (its direction, its
    /// weight).
    Observation {
        /// The measurement row.
        row: usize,
        /// Why the observation could not be formed.
        source: ObserveError,
    },
    /// A ball's contact points do not determine its initial centre.
    CentreFit {
        /// The ball's id.
        ball: String,
        /// Why the sphere fit failed.
        source: SphereFitError,
    },
    /// The a priori covariance built from `machine.prior_sigma` is unusable.
    Prior(ObserveError),
    /// A calibrated distance could not be evaluated (the two centres
    /// coincide).
    Distance {
        /// Its index in `artefacts.distances`.
        index: usize,
        /// Why it could not be evaluated.
        source: ObserveError,
    },
    /// A row of poses.csv or points.csv could not be used (forward
    /// kinematics failed, a leg of zero length, its covariance).
    InstrumentRow {
        /// The file of the row.
        table: InstrumentTable,
        /// The row (0-based, in file order).
        row: usize,
        /// Why.
        reason: String,
    },
    /// A session's instrument frame could not be located from the design's
    /// forward kinematics.
    FrameStart {
        /// The session's label.
        session: String,
        /// Why.
        reason: String,
    },
    /// A calibration cannot be applied to a dataset (validation).
    Calibration {
        /// Why.
        reason: String,
    },
    /// The instrument stage ([`crate::instruments::setup`]) was given a
    /// dataset with ball touches ([`crate::calibrate`] calibrates them
    /// with its poses and points).
    HasTouches,
    /// A robust loss where it does not apply ([`crate::robust`]): with
    /// data snooping, which it replaces, or in a calibration of poses and
    /// points alone.
    RobustLoss {
        /// The loss asked for.
        loss: parcal_solver::Loss,
        /// Where it does not apply.
        reason: &'static str,
    },
}

/// The file of an instrument measurement row.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum InstrumentTable {
    /// poses.csv.
    Poses,
    /// points.csv.
    Points,
}

impl InstrumentTable {
    /// The file's name in a dataset directory.
    pub fn file_name(self) -> &'static str {
        match self {
            Self::Poses => parcal_dataset::POSES_FILE,
            Self::Points => parcal_dataset::POINTS_FILE,
        }
    }

    /// What one row is: `pose`, `point`.
    pub fn row_name(self) -> &'static str {
        match self {
            Self::Poses => "pose",
            Self::Points => "point",
        }
    }
}

impl CalibrateError {
    /// The instrument row the error is about, if it is about one.
    pub fn instrument_row(&self) -> Option<(InstrumentTable, usize)> {
        match self {
            Self::InstrumentRow { table, row, .. } => Some((*table, *row)),
            _ => None,
        }
    }

    /// The measurement row the error is about, if it is about one.
    pub fn row(&self) -> Option<usize> {
        match self {
            Self::InvalidDataset { row, .. } => *row,
            Self::ForwardKinematics { row, .. } | Self::Observation { row, .. } => Some(*row),
            _ => None,
        }
    }

    /// The error of a dataset that fails `Dataset::validate`, in the
    /// dataset's own terms. `validate` names the file each value would be
    /// written to: a row of measurements.csv by its line, any other field
    /// by its path in the file named after the `Dataset` field that holds
    /// it (`artefacts.json`: `artefacts`).
    pub(crate) fn invalid_dataset(error: DatasetError) -> Self {
        let (row, field, message) = match error {
            DatasetError::Csv {
                path,
                line,
                column,
                message,
            } => {
                let row = usize::try_from(line.saturating_sub(2)).unwrap_or(usize::MAX);
                let table = [InstrumentTable::Poses, InstrumentTable::Points]
                    .into_iter()
                    .find(|t| path.file_name().is_some_and(|n| n == t.file_name()));
                if let Some(table) = table {
                    let column = column.map_or_else(String::new, |c| format!("column {c}: "));
                    return Self::InstrumentRow {
                        table,
                        row,
                        reason: format!("invalid: {column}{message}"),
                    };
                }
                (Some(row), column.unwrap_or_default(), message)
            }
            DatasetError::Field {
                path,
                field,
                message,
            } => (None, format!("{}.{field}", part(&path)), message),
            DatasetError::TooFewContacts {
                ball, count, min, ..
            } => return Self::TooFewContacts { ball, count, min },
            other => (None, String::new(), other.to_string()),
        };
        Self::InvalidDataset {
            row,
            field,
            message,
        }
    }
}

/// The `Dataset` field stored in file `path` (`machine.json`: `machine`).
fn part(path: &Path) -> String {
    path.file_stem()
        .map_or_else(String::new, |stem| stem.to_string_lossy().into_owned())
}

impl fmt::Display for CalibrateError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::InvalidDataset {
                row,
                field,
                message,
            } => {
                f.write_str("invalid dataset: ")?;
                if let Some(row) = row {
                    write!(f, "measurement row {row}, ")?;
                }
                if !field.is_empty() {
                    write!(f, "field {field}: ")?;
                }
                f.write_str(message)
            }
            Self::TooFewContacts { ball, count, min } => write!(
                f,
                "ball {ball:?} has {count} contacts, fewer than the {min} its initial centre needs"
            ),
            Self::Design(error) => write!(f, "the design geometry is degenerate: {error}"),
            Self::ForwardKinematics { row, source } => {
                write!(
                    f,
                    "measurement row {row}: forward kinematics failed: {source}"
                )
            }
            Self::Observation { row, source } => write!(f, "measurement row {row}: {source}"),
            Self::CentreFit { ball, source } => {
                write!(f, "ball {ball:?}: no initial centre: {source}")
            }
            Self::Prior(error) => write!(
                f,
                "machine.prior_sigma: the a priori covariance is unusable: {error}"
            ),
            Self::Distance { index, source } => {
                write!(f, "artefacts.distances[{index}]: {source}")
            }
            Self::InstrumentRow { table, row, reason } => {
                write!(f, "{} row {row}: {reason}", table.row_name())
            }
            Self::FrameStart { session, reason } => write!(
                f,
                "session {session:?}: no initial instrument frame: {reason}"
            ),
            Self::Calibration { reason } => {
                write!(f, "the calibration cannot be applied: {reason}")
            }
            Self::HasTouches => f.write_str(
                "the dataset has ball touches: the set-up of poses and points \
                 alone leaves them out; calibrate the touches with them",
            ),
            Self::RobustLoss { loss, reason } => {
                write!(f, "the {loss} loss does not apply {reason}")
            }
        }
    }
}

/// No `source`: each message states its cause (module doc).
impl std::error::Error for CalibrateError {}
