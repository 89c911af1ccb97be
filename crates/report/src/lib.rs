//! What a person reads after a calibration: calibration.json's words
//! ([`record`], built from [`sentences`], [`instruments`], [`checks`],
//! [`verdict`], [`places`] and [`diagnostics`]), parameter tables, accuracy
//! maps (CSV and SVG), the HTML/Markdown report of a calibration and the
//! paper-reproduction report of `parcal paper`.
//!
//! ```no_run
//! # fn main() -> Result<(), parcal_report::ReportError> {
//! // Simulate the paper scenario, calibrate it six ways and write report.md.
//! parcal_report::paper::reproduce(1, "out/paper".as_ref(), &mut |line| eprintln!("{line}"))?;
//! # Ok(()) }
//! ```

pub mod calibration_report;
pub mod checks;
pub mod compare;
pub mod diagnostics;
pub mod instruments;
pub mod maps;
pub mod mechanism;
pub mod mechanism_validation;
pub mod paper;
pub mod places;
pub mod plots;
pub mod record;
pub mod sentences;
pub mod tables;
pub mod verdict;

/// Why a report could not be written.
#[derive(Debug, thiserror::Error)]
pub enum ReportError {
    /// Reading or writing a dataset failed.
    #[error(transparent)]
    Dataset(#[from] parcal_dataset::DatasetError),
    /// A workflow (the paper study) stopped.
    #[error(transparent)]
    Workflow(#[from] parcal_workflows::WorkflowError),
    /// A calibration could not be set up.
    #[error(transparent)]
    Calibrate(#[from] parcal_calibrate::CalibrateError),
    /// An accuracy map could not be computed.
    #[error("accuracy map: {0}")]
    Accuracy(#[from] parcal_accuracy::AccuracyError),
    /// A figure of a report could not be drawn.
    #[error("cannot draw a figure of the report: {0}")]
    Figure(String),
    #[error("cannot plot {}: {reason}", path.display())]
    /// A chart could not be drawn.
    Plot {
        /// The chart's file.
        path: std::path::PathBuf,
        /// Why.
        reason: String,
    },
    #[error("cannot write {path}: {source}")]
    /// A file could not be written.
    Io {
        /// The file.
        path: std::path::PathBuf,
        /// Why.
        source: std::io::Error,
    },
}

/// Writes a text file atomically (parcal's one writer,
/// [`parcal_dataset::atomic`]), naming it in the error.
pub fn write_text(path: &std::path::Path, text: &str) -> Result<(), ReportError> {
    Ok(parcal_dataset::atomic::write_file(path, text.as_bytes())?)
}
