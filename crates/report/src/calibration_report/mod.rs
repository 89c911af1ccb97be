//! The report of one calibration (`parcal report`): one self-contained
//! HTML page (inline SVG, no script, no network) or Markdown, from
//! calibration.json alone: the verdict first, then the global test, the
//! variance components, the removed observations, the observations'
//! tests, the parameters, the weakest directions and the predicted
//! accuracy. Every number is read from the file or computed from it.
//!
//! ```no_run
//! # fn main() -> Result<(), Box<dyn std::error::Error>> {
//! use parcal_report::calibration_report::{Format, Subject, predicted_accuracy, render};
//! let calibration = parcal_dataset::Calibration::read("calibration.json".as_ref())?;
//! let subject = Subject {
//!     calibration: &calibration,
//!     file: "calibration.json",
//!     accuracy: predicted_accuracy(&calibration, None),
//! };
//! parcal_report::write_text("report.html".as_ref(), &render(&subject, Format::Html)?)?;
//! # Ok(()) }
//! ```

mod content;
pub(crate) mod document;
pub(crate) mod figures;
pub mod html;
pub(crate) mod markdown;

pub use content::{Subject, global_sentence, tests_sentence, title};

use parcal_accuracy::MapGrid;
use parcal_dataset::{Calibration, Dataset, Machine};
use parcal_kinematics::Geometry;
use parcal_workflows::evaluate::{Accuracy, TrueMachine, accuracy};

use crate::ReportError;

/// The report's form.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Format {
    /// One self-contained HTML page.
    Html,
    /// Markdown (figures by their caption).
    Markdown,
}

/// The report of `subject` as `format`.
pub fn render(subject: &Subject, format: Format) -> Result<String, ReportError> {
    let blocks = content::blocks(subject).map_err(ReportError::Figure)?;
    Ok(match format {
        Format::Html => html::render(&content::title(subject), &blocks),
        Format::Markdown => markdown::render(&blocks),
    })
}

/// The accuracy maps of `calibration` on the paper's grid
/// ([`MapGrid::paper`]): the predicted one from its parameters and
/// posterior covariance, placed with the design machine (the `dataset`'s
/// machine.json if given, else calibration.json's `design`), and with a
/// simulated dataset's truth the true one, of the 33 kinematic parameters
/// ([`Calibration::kinematic_estimate`]). `Err` says why there is none (no
/// tool calibrated, not converged, no design).
pub fn predicted_accuracy(
    calibration: &Calibration,
    dataset: Option<&Dataset>,
) -> Result<Accuracy, String> {
    let truth = dataset
        .and_then(TrueMachine::of)
        .transpose()
        .map_err(|e| format!("the dataset's true geometry is degenerate: {e}"))?;
    accuracy_with(calibration, dataset.map(|d| &d.machine), truth.as_ref())
}

/// [`predicted_accuracy`] placed with `machine` (else calibration.json's
/// `design`), with the true error of `truth` if given: for a caller that
/// has the dataset's parts but no longer the dataset (`calibrate
/// --report`, which frees the truth's contact points).
pub fn accuracy_with(
    calibration: &Calibration,
    machine: Option<&Machine>,
    truth: Option<&TrueMachine>,
) -> Result<Accuracy, String> {
    let (params, covariance) = calibration.kinematic_estimate()?;
    let machine = machine
        .or(calibration.design.as_ref())
        .ok_or("calibration.json does not record its design machine; give --dataset")?;
    let g = &machine.geometry;
    let design = Geometry::from_arrays(&g.base_joints, &g.platform_joints, &g.tool, &g.leg_lengths);
    accuracy(&design, truth, &params, &covariance, &MapGrid::paper())
        .map_err(|e| format!("the accuracy map could not be computed: {e}"))
}
