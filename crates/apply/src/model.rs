//! The model a calibration gives to apply: the calibrated geometry placed
//! in the design frame, the actuators' scales, the stroke and joint limits.

use parcal_dataset::Calibration;
use parcal_kinematics::{Geometry, ParamCovariance};

use crate::{ApplyError, Placement, place};

/// What applying a calibration uses, from calibration.json alone.
#[derive(Debug, Clone, PartialEq)]
pub struct AppliedModel {
    /// The design geometry (design frame): the nominal model of a closed
    /// controller.
    pub design: Geometry,
    /// The design scales (mm per unit).
    pub design_scale: [f64; 6],
    /// The calibrated geometry placed in the design frame ([`place`]).
    pub calibrated: Geometry,
    /// The calibrated scales (mm per unit): leg `i` is `l_i + s_i q_i` long.
    pub scale: [f64; 6],
    /// The actuators' unit.
    pub unit: String,
    /// The range of every reading (machine.json's `stroke`), if given.
    pub stroke: Option<[f64; 2]>,
    /// The largest joint angles (machine.json's `joint_limits`), if given.
    pub joint_limits: Option<parcal_kinematics::JointLimits>,
    /// How the calibrated geometry was placed.
    pub placement: Placement,
    /// The calibrated geometry in its canonical frames (calibration.json's
    /// `canonical`).
    pub canonical: Geometry,
    /// The posterior covariance of the 33 kinematic parameters (the leading
    /// block of calibration.json's `covariance`), if computed.
    pub covariance: Option<ParamCovariance>,
    /// Whether the data determined the tool
    /// ([`Calibration::calibrates_tool`]).
    pub tool_calibrated: bool,
}

/// What the exports say of a model whose tool the data did not see
/// ([`AppliedModel::tool_calibrated`]).
pub const UNSEEN_TOOL: &str = "the tool tip E_T is not calibrated: the data (poses of the platform) do not see the tool, which keeps the design's coordinates in the platform's canonical frame; points of the tool tip or ball touches calibrate it";

impl AppliedModel {
    /// The model of `record`: its `canonical` geometry placed onto its
    /// `design` geometry, its [`Calibration::calibrated_scales`] (the
    /// design's when not identified), the design's stroke. Leg offsets of
    /// later instrument sessions are not applied: the first session's
    /// homing is the one the initial leg lengths hold.
    ///
    /// Errors: no `design` (a calibration.json written before it was
    /// recorded), a geometry that does not define its frames.
    pub fn from_record(record: &Calibration) -> Result<Self, ApplyError> {
        let design_machine = record.design.as_ref().ok_or_else(|| {
            ApplyError::Missing(
                "calibration.json has no `design` (the machine.json it was computed from); it was written by an older parcal: calibrate again to apply it"
                    .to_string(),
            )
        })?;
        let g = &design_machine.geometry;
        let design =
            Geometry::from_arrays(&g.base_joints, &g.platform_joints, &g.tool, &g.leg_lengths);
        let c = &record.canonical;
        let canonical =
            Geometry::from_arrays(&c.base_joints, &c.platform_joints, &c.tool, &c.leg_lengths);
        for (what, geometry) in [
            ("design geometry", &design),
            ("calibrated geometry", &canonical),
        ] {
            geometry
                .canonicalize()
                .map_err(|source| ApplyError::Geometry { what, source })?;
        }
        let (calibrated, placement) = place(&canonical, &design)?;
        Ok(Self {
            design,
            design_scale: design_machine.actuator.scale,
            calibrated,
            scale: record.calibrated_scales(),
            unit: record.actuator_unit().to_string(),
            stroke: design_machine.stroke,
            joint_limits: design_machine.joint_limits.map(|l| l.limits()),
            placement,
            canonical,
            covariance: kinematic_covariance(record),
            tool_calibrated: record.calibrates_tool(),
        })
    }

    /// The nominal model beside this one: the design geometry and scales as
    /// the calibrated model (what a controller without the calibration
    /// commands), no covariance.
    pub fn nominal(&self) -> Result<Self, ApplyError> {
        let canonical = self
            .design
            .canonicalize()
            .map_err(|source| ApplyError::Geometry {
                what: "design geometry",
                source,
            })?
            .geometry;
        let (calibrated, placement) = place(&canonical, &self.design)?;
        Ok(Self {
            calibrated,
            scale: self.design_scale,
            placement,
            canonical,
            covariance: None,
            ..self.clone()
        })
    }
}

/// The marginal covariance of a calibration's 33 kinematic parameters
/// ([`Calibration::kinematic_estimate`]), or `None`: no covariance, or a
/// calibration that did not identify them all (poses alone leave the tool
/// out).
fn kinematic_covariance(record: &Calibration) -> Option<ParamCovariance> {
    record
        .kinematic_estimate()
        .ok()
        .map(|(_, covariance)| covariance)
}
