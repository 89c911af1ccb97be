//! The accuracy maps as `parcal accuracy` makes them, for every front end:
//! the design with its propagated prior (before), and a calibration of the
//! dataset with its posterior covariance (after), on the paper's grid;
//! with the true error when the dataset is a simulation's.

use std::fmt;

use parcal_accuracy::MapGrid;
use parcal_calibrate::setup::{design_geometry, kinematic_prior};
use parcal_calibrate::{ParamCovariance, PriorMode};
use parcal_dataset::{Calibration, Dataset};
use parcal_kinematics::params::TOOL_OFFSET;
use parcal_kinematics::{N_PARAMS, PARAM_NAMES, Params, params};
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
/// differs): its parameters must start with the 33, named and ordered as
/// `PARAM_NAMES` (a calibration with poses or points has its instrument
/// parameters after them), and it must have a posterior covariance.
pub fn calibrated_params(
    calibration: &Calibration,
    dataset: &Dataset,
    other_data: bool,
) -> Result<(Params, ParamCovariance), MapsError> {
    let refuse = |message: String| Err(MapsError::Calibration(message));
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
    let names = &calibration.parameters.names;
    // A calibration of poses alone holds the joints and legs but no tool.
    let tool_left_out = names
        .get(..TOOL_OFFSET)
        .is_some_and(|leading| leading == &PARAM_NAMES[..TOOL_OFFSET])
        && names.get(TOOL_OFFSET).map(String::as_str) != Some(PARAM_NAMES[TOOL_OFFSET]);
    if tool_left_out {
        return refuse(format!(
            "the calibration did not calibrate the tool ({}, {}, {}: its data, poses alone, do not observe it); the accuracy maps are of the tool tip: calibrate with points or ball touches",
            PARAM_NAMES[N_PARAMS - 3],
            PARAM_NAMES[N_PARAMS - 2],
            PARAM_NAMES[N_PARAMS - 1]
        ));
    }
    if names.len() < N_PARAMS || !names.iter().zip(PARAM_NAMES).all(|(a, b)| a == b) {
        return refuse(format!(
            "expected the {N_PARAMS} kinematic parameters {} .. {} first, in that order, found {} parameters ({})",
            PARAM_NAMES[0],
            PARAM_NAMES[N_PARAMS - 1],
            names.len(),
            names.iter().take(3).cloned().collect::<Vec<_>>().join(", ")
        ));
    }
    if !(calibration.converged && calibration.covariance.len() == names.len()) {
        return refuse(format!(
            "the calibration has no posterior covariance (status: {})",
            calibration.status
        ));
    }
    let values = &calibration.parameters.values;
    let covariance = ParamCovariance::from_fn(|i, j| calibration.covariance[i][j]);
    Ok((Params::from_column_slice(&values[..N_PARAMS]), covariance))
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
