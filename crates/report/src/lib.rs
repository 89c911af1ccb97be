//! What a person reads after a calibration: parameter tables, accuracy maps
//! (CSV and SVG) and the paper-reproduction report of `parcal paper`.
//!
//! ```no_run
//! # fn main() -> Result<(), parcal_report::ReportError> {
//! // Simulate the paper scenario, calibrate it six ways and write report.md.
//! parcal_report::paper::reproduce(1, "out/paper".as_ref(), &mut |line| eprintln!("{line}"))?;
//! # Ok(()) }
//! ```

pub mod compare;
pub mod maps;
pub mod paper;
pub mod plots;
pub mod sentences;
pub mod tables;

/// Why a report could not be written.
#[derive(Debug, thiserror::Error)]
pub enum ReportError {
    #[error(transparent)]
    Dataset(#[from] parcal_dataset::DatasetError),
    #[error(transparent)]
    Simulate(#[from] parcal_simulate::SimulateError),
    #[error(transparent)]
    Calibrate(#[from] parcal_calibrate::CalibrateError),
    #[error("accuracy map: {0}")]
    Accuracy(#[from] parcal_accuracy::AccuracyError),
    #[error("cannot plot {}: {reason}", path.display())]
    Plot {
        path: std::path::PathBuf,
        reason: String,
    },
    #[error("the simulated dataset has no truth")]
    NoTruth,
    #[error("the true geometry is degenerate: {0}")]
    Truth(#[from] parcal_kinematics::KinematicsError),
    #[error("cannot write {path}: {source}")]
    Io {
        path: std::path::PathBuf,
        source: std::io::Error,
    },
}

/// Writes a text file, naming it in the error.
pub fn write_text(path: &std::path::Path, text: &str) -> Result<(), ReportError> {
    std::fs::write(path, text).map_err(|source| ReportError::Io {
        path: path.to_path_buf(),
        source,
    })
}
