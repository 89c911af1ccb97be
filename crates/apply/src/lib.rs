//! Applying a calibration (docs/apply.md): what a controller needs to make
//! the machine reach its targets with the calibrated geometry.
//!
//! - [`placement`]: the calibrated geometry (canonical frames) placed in the
//!   design frame by the best rigid fit of its joints onto the design's;
//! - [`compensate`](mod@compensate): targets (tool tip and platform orientation, design
//!   frame) to actuator commands by the placed geometry's inverse
//!   kinematics, refusing targets outside the machine's assembly mode, the
//!   stroke or the joint limits, near a singularity, or whose readings do
//!   not lead back to them;
//! - [`corrected`]: the poses to send to a controller that uses the nominal
//!   (design) model, and a correction table over a workspace grid;
//! - exports: [`machine`] (the calibrated machine.json), [`genhexkins`]
//!   (LinuxCNC HAL), [`summary`] (text with the covariance).
//!
//! [`AppliedModel::from_record`] builds everything from calibration.json
//! alone (its `design` field gives the design machine).

pub mod compensate;
pub mod corrected;
mod error;
pub mod genhexkins;
pub mod machine;
mod model;
pub mod placement;
pub mod predicted;
pub mod summary;
pub mod table;
mod target;

pub use compensate::{Command, SINGULARITY_RATIO, command, compensate};
pub use corrected::{corrected_pose, corrected_poses};
pub use error::{ApplyError, Refusal};
pub use model::{AppliedModel, UNSEEN_TOOL};
pub use placement::{Placement, place};
pub use predicted::predicted_registered;
pub use table::{CorrectionTable, InterpolationError, TableGrid};
pub use target::Target;

#[cfg(test)]
mod tests {
    use parcal_kinematics::paper;

    use crate::{AppliedModel, place};

    /// The paper's design, and as calibrated geometry the paper's truth
    /// (what a perfect calibration finds), scales 1 mm per mm, no stroke.
    pub(crate) fn paper_model() -> AppliedModel {
        let design = paper::design();
        let truth = paper::truth().canonicalize().unwrap().geometry;
        let (calibrated, placement) = place(&truth, &design).unwrap();
        AppliedModel {
            design,
            design_scale: [1.0; 6],
            calibrated,
            scale: [1.0; 6],
            unit: "mm".to_string(),
            stroke: None,
            joint_limits: None,
            placement,
            canonical: truth,
            covariance: None,
            tool_calibrated: true,
        }
    }
}
