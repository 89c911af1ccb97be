//! The accuracy maps as `parcal accuracy` makes them, for every front end:
//! the design with its propagated prior (before), and a calibration of the
//! dataset with its posterior covariance (after), on the paper's grid;
//! with the true error when the dataset is a simulation's.

use std::fmt;

use parcal_accuracy::MapGrid;
use parcal_calibrate::setup::{design_geometry, kinematic_prior};
use parcal_calibrate::{ParamCovariance, PriorMode};
use parcal_dataset::{Calibration, Dataset};
use parcal_kinematics::{Params, params};
use parcal_workflows::evaluate::{BeforeAfter, TrueMachine, accuracy};

/// Why the maps could not be made: one sentence, naming the file
/// (machine.json, truth.json) when the problem is in one; a front end adds
/// the calibration's name in front of [`MapsError::Calibration`].
#[derive(Debug, Clone, PartialEq)]
pub enum MapsError {
    /// The calibration is of another dataset (its checksum differs), and
    /// another was not allowed: what is said is the front end's way to
    /// allow it.
    OtherData(String),
    /// The calibration cannot be mapped on this dataset.
    Calibration(String),
    /// The dataset's design, prior or truth, or the maps themselves.
    Dataset(String),
}

impl fmt::Display for MapsError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::OtherData(message) | Self::Calibration(message) | Self::Dataset(message) => {
                f.write_str(message)
            }
        }
    }
}

impl std::error::Error for MapsError {}

/// The parameters and covariance of `calibration`, a calibration of
/// `dataset` (or, if `other_data`, of another dataset: its checksum
/// differs): its 33 kinematic parameters and their marginal covariance
/// ([`Calibration::kinematic_estimate`]).
pub fn calibrated_params(
    calibration: &Calibration,
    dataset: &Dataset,
    other_data: bool,
) -> Result<(Params, ParamCovariance), MapsError> {
    if let Some(provenance) = &calibration.provenance
        && !other_data
        && provenance.dataset_checksum != dataset.checksum()
    {
        return Err(MapsError::OtherData(format!(
            "the calibration is of another dataset ({}, checksum {}; this one's is {})",
            provenance.dataset,
            provenance.dataset_checksum,
            dataset.checksum()
        )));
    }
    calibration
        .kinematic_estimate()
        .map_err(MapsError::Calibration)
}

/// The accuracy maps of `dataset` on the paper's grid: before (the design
/// with the propagated prior's covariance) and, with `calibrated`
/// ([`calibrated_params`]), after; each with the true error when the
/// dataset has a truth.
pub fn accuracy_maps(
    dataset: &Dataset,
    calibrated: Option<&(Params, ParamCovariance)>,
) -> Result<BeforeAfter, MapsError> {
    let fail = |message: String| MapsError::Dataset(message);
    let truth = TrueMachine::of(dataset)
        .transpose()
        .map_err(|e| fail(format!("truth.json: the true geometry is degenerate: {e}")))?;
    let design = design_geometry(dataset);
    let canonical = design
        .canonicalize()
        .map_err(|e| fail(format!("machine.json: {e}")))?;
    let design_params = params::to_params(&canonical.geometry);
    let prior = kinematic_prior(dataset, &design, &design_params, PriorMode::Propagated)
        .map_err(|e| fail(e.to_string()))?
        .ok_or_else(|| fail("machine.json: no prior tolerances".to_string()))?;
    let grid = MapGrid::paper();
    let map = |params: &Params, covariance: &ParamCovariance| {
        accuracy(&design, truth.as_ref(), params, covariance, &grid)
            .map_err(|e| fail(e.to_string()))
    };
    Ok(BeforeAfter {
        before: Some(map(&design_params, prior.covariance())?),
        after: calibrated.map(|(p, c)| map(p, c)).transpose()?,
    })
}
