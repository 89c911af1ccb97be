//! The one error type of the crate.

use std::path::PathBuf;

use parcal_kinematics::KinematicsError;

/// Why an accuracy map could not be computed or written. `Display` is one
/// sentence meant for the user; errors at a grid point name its design-frame
/// coordinates `(x, y)` in mm.
#[derive(Debug, thiserror::Error)]
pub enum AccuracyError {
    /// The map grid cannot carry a map (too few points, repeated or
    /// non-finite coordinates).
    #[error("invalid map grid: {reason}")]
    Grid {
        /// What is wrong with the grid.
        reason: String,
    },

    /// The geometry the targets are mapped with (the design) does not define
    /// the canonical frames.
    #[error("the design geometry cannot map the targets into the canonical frames: {0}")]
    Design(KinematicsError),

    /// A model parameter, a covariance entry or a true coordinate is NaN or
    /// infinite.
    #[error("{what} is not a finite number")]
    NonFinite {
        /// Which value.
        what: String,
    },

    /// The model cannot put its tool tip on a grid point: its inverse
    /// kinematics gives an infeasible leg, or the pose is singular.
    #[error("grid point (x = {x} mm, y = {y} mm) is unreachable by the model: {source}")]
    Unreachable {
        /// Design-frame x of the grid point (mm).
        x: f64,
        /// Design-frame y of the grid point (mm).
        y: f64,
        /// The kinematic failure.
        source: KinematicsError,
    },

    /// Forward kinematics of the true geometry failed at the actuator values
    /// the model commands for a grid point.
    #[error(
        "grid point (x = {x} mm, y = {y} mm): forward kinematics of the true geometry failed: {source}"
    )]
    TrueForward {
        /// Design-frame x of the grid point (mm).
        x: f64,
        /// Design-frame y of the grid point (mm).
        y: f64,
        /// The kinematic failure.
        source: KinematicsError,
    },

    /// The covariance gives a clearly negative tip variance: it is not
    /// positive semi-definite.
    #[error(
        "grid point (x = {x} mm, y = {y} mm): the covariance gives a negative tip variance ({variance:.3e} mm^2); it is not positive semi-definite"
    )]
    NotPositiveSemidefinite {
        /// Design-frame x of the grid point (mm).
        x: f64,
        /// Design-frame y of the grid point (mm).
        y: f64,
        /// The trace of the 3 x 3 tip covariance (mm^2).
        variance: f64,
    },

    /// A rigid registration (Kabsch) was asked of unusable point sets.
    #[error("cannot register the point sets: {reason}")]
    Registration {
        /// What is wrong.
        reason: String,
    },

    /// No map was given to write.
    #[error("{}: no map to write", path.display())]
    NoMaps {
        /// The file that was to be written.
        path: PathBuf,
    },

    /// Maps written side by side must share one grid, and each must have
    /// one value per grid point.
    #[error("{}: map {name:?} does not fit the grid of the first map", path.display())]
    MismatchedGrids {
        /// The file that was to be written.
        path: PathBuf,
        /// The map whose grid differs.
        name: String,
    },

    /// The map file could not be written.
    #[error("{}: cannot write: {source}", path.display())]
    Write {
        /// The file concerned.
        path: PathBuf,
        /// The underlying error.
        source: csv::Error,
    },
}
