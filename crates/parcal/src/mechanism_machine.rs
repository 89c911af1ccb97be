//! A mechanism's calibration as the machine.json of its next calibration,
//! as `parcal export --format machine-json` writes it for every front end
//! ([`calibrated_machine`]: the machine it was made from, its design the
//! calibrated parameters). A mechanism's record does not carry the noise
//! and tolerances: they come from that machine.json, given, or found in
//! the dataset the record names.

use std::path::{Path, PathBuf};

use parcal_calibrate::mechanism::calibrated_machine;
use parcal_dataset::mechanism::{MechanismCalibrationRecord, MechanismMachine};
use parcal_dataset::{DatasetError, HEXAPOD, IN_MEMORY, MACHINE_FILE, declared_mechanism};

/// Why a mechanism's calibrated machine.json cannot be written.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum MachineExportError {
    /// No machine.json was given and the record names no dataset that has
    /// one.
    #[error(
        "a {mechanism}'s calibration does not carry its machine's noise and tolerances, and {where_}: give the machine.json it was calibrated from"
    )]
    NoMachine {
        /// The calibration's mechanism.
        mechanism: String,
        /// Where it was looked for, in words.
        where_: String,
    },
    /// The machine.json could not be read.
    #[error(transparent)]
    Read(#[from] DatasetError),
    /// The calibration is not one of that machine (another mechanism, a
    /// prior mean that is not its design).
    #[error("{path}: {reason}")]
    Other {
        /// The machine.json.
        path: PathBuf,
        /// Why, naming the field or parameter.
        reason: String,
    },
}

/// The machine.json `record` (read from the file `read_from`, if any) was
/// calibrated from: `given`, else the one in the dataset directory its
/// provenance names (as it was given, from the directory it was
/// calibrated in), else the one beside the record (where `parcal
/// calibrate` writes it by default), the first that is there.
pub fn machine_path(
    record: &MechanismCalibrationRecord,
    given: Option<&Path>,
    read_from: Option<&Path>,
) -> Result<PathBuf, MachineExportError> {
    if let Some(path) = given {
        return Ok(path.to_path_buf());
    }
    let provenance = (record.provenance.as_ref())
        .filter(|provenance| provenance.dataset != IN_MEMORY)
        .map(|provenance| Path::new(&provenance.dataset).join(MACHINE_FILE));
    let beside = read_from.map(|path| path.with_file_name(MACHINE_FILE));
    let candidates: Vec<PathBuf> = provenance.into_iter().chain(beside).collect();
    if let Some(found) = candidates.iter().find(|path| path.is_file()) {
        return Ok(found.clone());
    }
    let where_ = match candidates.as_slice() {
        [] => "it names no dataset (one built in memory)".to_string(),
        paths => {
            let paths: Vec<String> = paths.iter().map(|p| p.display().to_string()).collect();
            format!("none is at {}", paths.join(" or "))
        }
    };
    Err(MachineExportError::NoMachine {
        mechanism: record.mechanism.clone(),
        where_,
    })
}

/// The text of `record`'s calibrated machine.json ([`calibrated_machine`]),
/// from the machine.json at `machine` (a hexapod's refused as another
/// mechanism's is).
pub fn mechanism_machine_json(
    record: &MechanismCalibrationRecord,
    machine: &Path,
) -> Result<String, MachineExportError> {
    if declared_mechanism(machine)?.is_none_or(|name| name == HEXAPOD) {
        return Err(MachineExportError::Other {
            path: machine.to_path_buf(),
            reason: format!(
                "mechanism: the calibration is a {}'s, machine.json a {HEXAPOD}'s: the calibration was not made from this machine.json",
                record.mechanism
            ),
        });
    }
    calibrated_machine_json(record, &MechanismMachine::read(machine)?, machine)
}

/// The text of `record`'s calibrated machine.json ([`calibrated_machine`]),
/// from `machine`, read from `path` (what an error names).
pub fn calibrated_machine_json(
    record: &MechanismCalibrationRecord,
    machine: &MechanismMachine,
    path: &Path,
) -> Result<String, MachineExportError> {
    let calibrated =
        calibrated_machine(record, machine).map_err(|error| MachineExportError::Other {
            path: path.to_path_buf(),
            reason: error.to_string(),
        })?;
    Ok(calibrated.to_json()?)
}
