//! The report of one calibration as `parcal report` renders it, for every
//! front end: a self-contained HTML page or its Markdown twin, verdict and
//! tests first, with what a dataset adds (a printer's probe and manual
//! height residuals over the bed, the accuracy map placed by the hexapod's
//! machine, a simulation's truth beside the estimates).

use parcal_calibrate::mechanism::MechanismData;
use parcal_dataset::mechanism::{MechanismCalibrationRecord, MechanismDataset};
use parcal_dataset::{Calibration, Dataset, FrameRecord, Provenance};
use parcal_kinematics::N_PARAMS;
use parcal_report::calibration_report::{Subject, predicted_accuracy, render};
use parcal_report::mechanism::FromDataset;
use parcal_workflows::evaluate::TrueMachine;

pub use parcal_report::calibration_report::Format;

/// A simulated machine's truth in the terms of a calibration through the
/// common path.
#[derive(Debug, Clone, PartialEq)]
#[non_exhaustive]
pub struct MechanismTrue {
    /// One value per unknown of the global block the record reports
    /// ([`MechanismData::true_values`]).
    pub values: Vec<f64>,
    /// Each tracker's true frame from the canonical frame, as the record's
    /// ([`MechanismData::true_tracker_frames`]).
    pub frames: Vec<Option<FrameRecord>>,
}

impl MechanismTrue {
    /// What it adds to a mechanism's report, the "true" columns, with what
    /// `dataset` adds: its probes' and manual heights' residuals over the
    /// bed.
    pub fn from_dataset<'a>(
        truth: Option<&'a Self>,
        dataset: Option<&'a MechanismDataset>,
    ) -> FromDataset<'a> {
        FromDataset {
            probes: dataset.map(|d| d.probes.as_slice()),
            heights: dataset.map(|d| d.heights.as_slice()),
            truth: truth.map(|t| t.values.as_slice()),
            true_frames: truth.map(|t| t.frames.as_slice()),
        }
    }
}

/// Why a report cannot be made.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ReportPageError {
    /// The dataset given is not the one calibrated (its checksum
    /// differs), and another was not allowed.
    #[error(
        "the calibration is of another dataset ({dataset}, checksum {recorded}; this one's is {given})"
    )]
    OtherData {
        /// The dataset calibrated, as its provenance names it.
        dataset: String,
        /// Its checksum.
        recorded: String,
        /// The checksum of the one given.
        given: String,
    },
    /// The dataset is of another mechanism than the calibration's.
    #[error("a {calibration} calibration; the dataset is a {dataset}'s")]
    OtherMechanism {
        /// The calibration's mechanism.
        calibration: String,
        /// The dataset's.
        dataset: String,
    },
    /// The dataset's truth.json cannot be put in the calibration's terms.
    #[error("truth.json: {0}")]
    Truth(String),
    /// The report's figure cannot be drawn.
    #[error("cannot draw the report's figure: {0}")]
    Figure(String),
}

/// The truth of a simulated hexapod `dataset` (none for a real one) in the
/// terms of a calibration through the common path of `parameters`
/// parameters and the trackers `trackers` (by label): the true machine's
/// 33 canonical parameters, then its actuators' scales when there are
/// more than 33 (the scales unknown); each tracker's true frame from the
/// true canonical base frame, its session's `tracker_frame` (from
/// machine.json's base frame) composed with the canonical frame's map.
pub fn hexapod_truth(
    dataset: &Dataset,
    parameters: usize,
    trackers: &[&str],
) -> Result<Option<MechanismTrue>, ReportPageError> {
    let (Some(truth), Some(record)) = (TrueMachine::of(dataset), dataset.truth.as_ref()) else {
        return Ok(None);
    };
    let truth = truth.map_err(|error| {
        ReportPageError::Truth(format!("the true geometry is degenerate: {error}"))
    })?;
    let scales = record.actuator_scale.filter(|_| parameters > N_PARAMS);
    let values = truth.params.iter().copied();
    let to_input = truth.base_from_input.inverse();
    let frames = (trackers.iter())
        .map(|label| {
            let session = record.sessions.iter().find(|s| s.label == *label)?;
            Some(FrameRecord::of(
                &(session.tracker_frame.isometry() * to_input),
            ))
        })
        .collect();
    Ok(Some(MechanismTrue {
        values: values.chain(scales.into_iter().flatten()).collect(),
        frames,
    }))
}

/// The truth of the simulated machine of `dataset` (its data `data`) in
/// the terms of its calibration, when it has a truth.json.
pub fn mechanism_truth(
    dataset: &MechanismDataset,
    data: &MechanismData,
) -> Result<Option<MechanismTrue>, ReportPageError> {
    let Some(truth) = &dataset.truth else {
        return Ok(None);
    };
    let failed = |error: parcal_calibrate::mechanism::MechanismCalibrationError| {
        ReportPageError::Truth(error.to_string())
    };
    let values = data.true_values(truth).map_err(failed)?;
    let frames = data.true_tracker_frames(truth).map_err(failed)?;
    Ok(Some(MechanismTrue {
        values,
        frames: (frames.iter())
            .map(|frame| frame.as_ref().map(FrameRecord::of))
            .collect(),
    }))
}

/// The report of the hexapod's own calibration `calibration` (its file
/// `file`, as given) in `format`; with `dataset` (the one calibrated,
/// unless `other_data`), its machine places the accuracy map and a
/// simulation's truth adds the true error; without, calibration.json's
/// design machine.
pub fn hexapod_report(
    calibration: &Calibration,
    file: &str,
    dataset: Option<&Dataset>,
    other_data: bool,
    format: Format,
) -> Result<String, ReportPageError> {
    if let Some(dataset) = dataset {
        same_data(
            calibration.provenance.as_ref(),
            dataset.checksum(),
            other_data,
        )?;
    }
    let subject = Subject {
        calibration,
        file,
        accuracy: predicted_accuracy(calibration, dataset),
    };
    render(&subject, format).map_err(|error| ReportPageError::Figure(error.to_string()))
}

/// A dataset a mechanism's calibration is reported with.
#[derive(Debug, Clone, Copy)]
pub enum ReportDataset<'a> {
    /// A hexapod's, calibrated through the common path: its truth.
    Hexapod(&'a Dataset),
    /// Another mechanism's, with its data: its probes, manual heights and
    /// truth.
    Mechanism(&'a MechanismDataset, &'a MechanismData),
}

/// The report of a mechanism's calibration `record` (its file `file`, as
/// given) in `format`, with what `dataset` (the one calibrated, unless
/// `other_data`) adds: a mechanism's probe and manual height residuals
/// over the bed, a simulated machine's truth.
pub fn mechanism_report(
    record: &MechanismCalibrationRecord,
    file: &str,
    dataset: Option<ReportDataset<'_>>,
    other_data: bool,
    format: Format,
) -> Result<String, ReportPageError> {
    let (truth, bed) = match dataset {
        None => (None, None),
        Some(ReportDataset::Hexapod(dataset)) => {
            same_mechanism(record, parcal_dataset::HEXAPOD)?;
            same_data(record.provenance.as_ref(), dataset.checksum(), other_data)?;
            let trackers: Vec<&str> = record.trackers.iter().map(|t| t.label.as_str()).collect();
            (
                hexapod_truth(dataset, record.parameters.len(), &trackers)?,
                None,
            )
        }
        Some(ReportDataset::Mechanism(dataset, data)) => {
            same_mechanism(record, data.mechanism.name())?;
            // Another dataset's probes are not the residuals' places.
            let same = same_data(record.provenance.as_ref(), dataset.checksum(), other_data)?;
            let truth = mechanism_truth(dataset, data)?;
            (truth, same.then_some(dataset))
        }
    };
    let from_dataset = MechanismTrue::from_dataset(truth.as_ref(), bed);
    mechanism_page(record, file, from_dataset, format)
}

/// The page of `record` with what `from_dataset` adds ([`mechanism_report`]).
pub fn mechanism_page(
    record: &MechanismCalibrationRecord,
    file: &str,
    from_dataset: FromDataset<'_>,
    format: Format,
) -> Result<String, ReportPageError> {
    parcal_report::mechanism::render(record, file, from_dataset, format)
        .map_err(|error| ReportPageError::Figure(error.to_string()))
}

/// Whether the dataset of checksum `given` may be taken as the one a
/// calibration of `provenance` calibrated (a record without provenance
/// names none): `Ok(false)` for another that `other_data` allows, an error
/// for another it does not.
fn same_data(
    provenance: Option<&Provenance>,
    given: String,
    other_data: bool,
) -> Result<bool, ReportPageError> {
    match provenance {
        Some(provenance) if provenance.dataset_checksum != given => match other_data {
            true => Ok(false),
            false => Err(ReportPageError::OtherData {
                dataset: provenance.dataset.clone(),
                recorded: provenance.dataset_checksum.clone(),
                given,
            }),
        },
        _ => Ok(true),
    }
}

/// Whether `record` is a calibration of `mechanism`'s.
fn same_mechanism(
    record: &MechanismCalibrationRecord,
    mechanism: &str,
) -> Result<(), ReportPageError> {
    if record.mechanism == mechanism {
        Ok(())
    } else {
        Err(ReportPageError::OtherMechanism {
            calibration: record.mechanism.clone(),
            dataset: mechanism.to_string(),
        })
    }
}
