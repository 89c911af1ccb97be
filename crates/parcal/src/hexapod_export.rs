//! A hexapod's own calibration in the forms other tools load, as `parcal
//! export --format machine-json | genhexkins | summary` writes them, for
//! every front end (docs/apply.md).

use parcal_apply::genhexkins::hal_snippet;
use parcal_apply::machine::calibrated_machine;
use parcal_apply::summary::summary;
use parcal_apply::{AppliedModel, ApplyError};
use parcal_dataset::{Calibration, DatasetError};

/// A form a hexapod's calibration is written in.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum HexapodFormat {
    /// The calibrated machine.json in the design frame (the design of the
    /// next calibration).
    MachineJson,
    /// A LinuxCNC genhexkins HAL snippet (`setp` of the 36 joint
    /// coordinates).
    Genhexkins,
    /// A human-readable summary with the covariance.
    Summary,
}

impl HexapodFormat {
    /// The formats by their names (`parcal export --format`'s).
    pub const NAMES: [(&'static str, Self); 3] = [
        ("machine-json", Self::MachineJson),
        ("genhexkins", Self::Genhexkins),
        ("summary", Self::Summary),
    ];

    /// The format named `name` ([`Self::NAMES`]), if any.
    pub fn by_name(name: &str) -> Option<Self> {
        crate::named::by_name(&Self::NAMES, name)
    }
}

/// Why a hexapod's calibration cannot be exported.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum HexapodExportError {
    /// The calibration cannot be applied (no design, a degenerate one).
    #[error(transparent)]
    Apply(#[from] ApplyError),
    /// The calibrated machine.json is not a valid one.
    #[error(transparent)]
    Dataset(#[from] DatasetError),
}

/// The text of `record` written as `format`. Whether a rejected
/// calibration may be used is the caller's decision.
pub fn hexapod_export(
    record: &Calibration,
    format: HexapodFormat,
) -> Result<String, HexapodExportError> {
    let model = AppliedModel::from_record(record)?;
    Ok(match format {
        HexapodFormat::MachineJson => calibrated_machine(record, &model)?.to_json()?,
        HexapodFormat::Genhexkins => hal_snippet(&model),
        HexapodFormat::Summary => summary(record, &model),
    })
}
