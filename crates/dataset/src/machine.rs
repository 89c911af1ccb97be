//! `machine.json`: the design geometry, its tolerances and the machine's
//! repeatability.

use std::path::Path;

use parcal_kinematics::PriorSigma;
use serde::{Deserialize, Serialize};

use crate::check::Check;
use crate::declared::{HEXAPOD, declared_mechanism};
use crate::error::{DatasetError, Result};
use crate::geometry::{GeometryRecord, WithGeometry};
use crate::json;
use crate::quote::{has_control, quoted};

/// machine.json's `prior_sigma`: the design tolerance (1 sigma, mm) of every
/// coordinate of each group, as [`PriorSigma`] in the same fields.
#[derive(Serialize, Deserialize)]
#[serde(remote = "PriorSigma")]
struct PriorSigmaRecord {
    base: f64,
    platform: f64,
    tool: f64,
    leg: f64,
}

/// One standard deviation of the machine's and the instruments'
/// repeatability.
///
/// In JSON an absent instrument sigma is left out; binary snapshots (not
/// self-describing) hold every field.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
pub struct Repeatability {
    /// Actuator readings, independent per actuator and per reading, in the
    /// actuators' unit ([`Actuator::unit`]; mm without `actuator`).
    pub actuator: f64,
    /// Tool positioning, per axis and per contact (mm).
    pub tool: f64,
    /// An instrument's position coordinates (poses.csv, points.csv), per
    /// axis (mm). Required when the dataset has poses or points.
    #[serde(default)]
    pub position: Option<f64>,
    /// An instrument's orientation (poses.csv), per axis of a small
    /// rotation (rad). Required when the dataset has poses.
    #[serde(default)]
    pub orientation: Option<f64>,
}

impl Serialize for Repeatability {
    fn serialize<S: serde::Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        use serde::ser::SerializeStruct;
        let text = serializer.is_human_readable();
        let optional = [
            ("position", self.position),
            ("orientation", self.orientation),
        ];
        let fields = 2 + optional
            .iter()
            .filter(|(_, v)| !text || v.is_some())
            .count();
        let mut out = serializer.serialize_struct("Repeatability", fields)?;
        out.serialize_field("actuator", &self.actuator)?;
        out.serialize_field("tool", &self.tool)?;
        for (name, value) in optional {
            optional_field(&mut out, text, name, &value)?;
        }
        out.end()
    }
}

/// The actuators' reading unit and scale: leg `i` is `l_i + s_i q_i` long
/// for a reading `q_i` (`machine.json`'s optional `actuator`; absent: unit
/// mm, scale 1, known).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Actuator {
    /// The readings' unit, free text (e.g. `rev`, `count`, `mm`).
    pub unit: String,
    /// Design scale of each actuator, mm per unit.
    pub scale: [f64; 6],
    /// A priori standard deviation of each scale (mm per unit); absent: the
    /// scales are known and not estimated.
    #[serde(default)]
    pub scale_sigma: Option<[f64; 6]>,
}

impl Default for Actuator {
    fn default() -> Self {
        Self {
            unit: "mm".to_owned(),
            scale: [1.0; 6],
            scale_sigma: None,
        }
    }
}

/// What changes from one measuring session to the next besides the
/// instrument's frame (which is always a session's own): `machine.json`'s
/// optional `session_model`. Each present sigma makes that group a
/// per-session unknown with a zero-mean prior of that sigma relative to the
/// first session; absent, the group is shared by all sessions.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct SessionModel {
    /// Re-homing: a per-session zero offset of each leg (mm).
    #[serde(default)]
    pub leg_offset_sigma: Option<f64>,
    /// A re-mounted marker body: a per-session origin of the platform body
    /// frame (mm).
    #[serde(default)]
    pub body_origin_sigma: Option<f64>,
    /// A re-mounted marker body: a per-session turn of the platform body
    /// frame (rad).
    #[serde(default)]
    pub body_rotation_sigma: Option<f64>,
}

/// The largest angle between each leg and its joints' axes
/// (`machine.json`'s optional `joint_limits`): what the joints allow.
/// `parcal_kinematics::joints` gives the angles.
///
/// In JSON an absent field is left out; binary snapshots (not
/// self-describing) hold every field.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
pub struct JointLimitsRecord {
    /// Largest angle between a leg and its base joint's axis (degrees);
    /// absent: unlimited.
    #[serde(default)]
    pub base_deg: Option<f64>,
    /// Largest angle between a leg and its platform joint's axis
    /// (degrees); absent: unlimited.
    #[serde(default)]
    pub platform_deg: Option<f64>,
    /// Each base joint's axis (base frame, any length), in joint order;
    /// absent: the base frame's `+z`.
    #[serde(default)]
    pub base_axes: Option<[[f64; 3]; 6]>,
    /// Each platform joint's axis (platform frame, any length, along the
    /// leg from base to platform), in joint order; absent: the platform
    /// frame's `+z`.
    #[serde(default)]
    pub platform_axes: Option<[[f64; 3]; 6]>,
}

impl Serialize for JointLimitsRecord {
    fn serialize<S: serde::Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        use serde::ser::SerializeStruct;
        let text = serializer.is_human_readable();
        let present = [
            self.base_deg.is_some(),
            self.platform_deg.is_some(),
            self.base_axes.is_some(),
            self.platform_axes.is_some(),
        ];
        let fields = present.iter().filter(|p| !text || **p).count();
        let mut out = serializer.serialize_struct("JointLimitsRecord", fields)?;
        optional_field(&mut out, text, "base_deg", &self.base_deg)?;
        optional_field(&mut out, text, "platform_deg", &self.platform_deg)?;
        optional_field(&mut out, text, "base_axes", &self.base_axes)?;
        optional_field(&mut out, text, "platform_axes", &self.platform_axes)?;
        out.end()
    }
}

/// Serialises `value` as field `name`, skipped in text when absent.
fn optional_field<S: serde::ser::SerializeStruct, T: Serialize>(
    out: &mut S,
    text: bool,
    name: &'static str,
    value: &Option<T>,
) -> Result<(), S::Error> {
    if text && value.is_none() {
        out.skip_field(name)
    } else {
        out.serialize_field(name, value)
    }
}

impl JointLimitsRecord {
    /// The limits in radians with unit axes (absent axes `+z`).
    pub fn limits(&self) -> parcal_kinematics::JointLimits {
        let axes = |given: &Option<[[f64; 3]; 6]>| match given {
            Some(axes) => axes.map(|a| parcal_kinematics::Vec3::from(a).normalize()),
            None => [parcal_kinematics::Vec3::z(); 6],
        };
        parcal_kinematics::JointLimits {
            base: self.base_deg.map(f64::to_radians),
            platform: self.platform_deg.map(f64::to_radians),
            base_axes: axes(&self.base_axes),
            platform_axes: axes(&self.platform_axes),
        }
    }

    /// Each given limit in `(0, 180]` degrees and at least one given; each
    /// given axis finite and not zero, and only for an end with a limit.
    fn validate(&self, check: Check, parent: &str) -> Result<()> {
        let field = |name: &str| format!("{parent}joint_limits.{name}");
        if self.base_deg.is_none() && self.platform_deg.is_none() {
            return Err(check.error(
                field("base_deg"),
                "joint_limits needs base_deg, platform_deg or both",
            ));
        }
        for (end, limit, axes) in [
            ("base", self.base_deg, &self.base_axes),
            ("platform", self.platform_deg, &self.platform_axes),
        ] {
            if let Some(limit) = limit {
                let name = field(&format!("{end}_deg"));
                check.finite(&name, limit)?;
                if !(limit > 0.0 && limit <= 180.0) {
                    return Err(check.error(
                        name,
                        format!("must be an angle in (0, 180] degrees, found {limit}"),
                    ));
                }
            }
            let Some(axes) = axes else { continue };
            if limit.is_none() {
                return Err(check.error(
                    field(&format!("{end}_axes")),
                    format!("given without {end}_deg"),
                ));
            }
            for (i, axis) in axes.iter().enumerate() {
                for (c, value) in axis.iter().enumerate() {
                    check.finite(
                        format_args!("{}[{i}][{c}]", field(&format!("{end}_axes"))),
                        *value,
                    )?;
                }
                if axis.iter().all(|v| v.abs() < 1e-12) {
                    return Err(check.error(
                        format!("{}[{i}]", field(&format!("{end}_axes"))),
                        "an axis must not be zero",
                    ));
                }
            }
        }
        Ok(())
    }
}

/// The design (nominal) machine, in any base frame and any platform frame.
///
/// `machine.json` has the geometry's fields at its top level.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Machine {
    /// Design geometry.
    pub geometry: GeometryRecord,
    /// Design tolerances.
    #[serde(with = "PriorSigmaRecord")]
    pub prior_sigma: PriorSigma,
    /// Repeatability, used to weight the observations.
    pub repeatability: Repeatability,
    /// The actuators' unit and scales.
    pub actuator: Actuator,
    /// What changes between measuring sessions.
    pub session_model: SessionModel,
    /// The range `[min, max]` of every actuator reading, in the actuators'
    /// unit (`machine.json`'s optional `stroke`): what the machine can reach.
    pub stroke: Option<[f64; 2]>,
    /// The largest joint angles (`machine.json`'s optional `joint_limits`).
    pub joint_limits: Option<JointLimitsRecord>,
}

/// `machine.json`'s object (without `format`) as read.
type MachineFile = WithGeometry<GeometryRecord, Conditions>;

impl From<MachineFile> for Machine {
    fn from(file: MachineFile) -> Self {
        Self {
            geometry: file.geometry,
            prior_sigma: file.rest.prior_sigma,
            repeatability: file.rest.repeatability,
            actuator: file.rest.actuator,
            session_model: file.rest.session_model,
            stroke: file.rest.stroke,
            joint_limits: file.rest.joint_limits,
        }
    }
}

/// Serde of a machine held in another JSON file (calibration.json's
/// `design`) as `machine.json`'s object without `format`; absent is `None`.
/// Binary formats (not self-describing) take [`Machine`]'s own fields.
pub(crate) mod embedded {
    use serde::{Deserialize, Deserializer, Serialize, Serializer};

    use super::{Machine, MachineFile};

    pub(crate) fn serialize<S: Serializer>(
        machine: &Option<Machine>,
        serializer: S,
    ) -> Result<S::Ok, S::Error> {
        if serializer.is_human_readable() {
            machine.as_ref().map(Machine::file).serialize(serializer)
        } else {
            machine.serialize(serializer)
        }
    }

    pub(crate) fn deserialize<'de, D: Deserializer<'de>>(
        deserializer: D,
    ) -> Result<Option<Machine>, D::Error> {
        if deserializer.is_human_readable() {
            Ok(Option::<MachineFile>::deserialize(deserializer)?.map(Machine::from))
        } else {
            Option::<Machine>::deserialize(deserializer)
        }
    }
}

/// The fields of `machine.json` after the geometry.
#[derive(Serialize, Deserialize)]
struct Conditions {
    #[serde(with = "PriorSigmaRecord")]
    prior_sigma: PriorSigma,
    repeatability: Repeatability,
    #[serde(default, skip_serializing_if = "is_default")]
    actuator: Actuator,
    #[serde(default, skip_serializing_if = "is_default")]
    session_model: SessionModel,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    stroke: Option<[f64; 2]>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    joint_limits: Option<JointLimitsRecord>,
}

fn is_default<T: Default + PartialEq>(value: &T) -> bool {
    *value == T::default()
}

impl Machine {
    /// Reads and checks a `machine.json` file.
    pub fn read(path: &Path) -> Result<Self> {
        if let Some(name) = declared_mechanism(path)?
            && name != HEXAPOD
        {
            return Err(DatasetError::field(
                path,
                "mechanism",
                format!(
                    "{} is not the hexapod this reader reads: read its dataset with the mechanism reader (MechanismDataset)",
                    quoted(&name)
                ),
            ));
        }
        let file: MachineFile = json::read(path, json::MACHINE)?;
        let machine = Self::from(file);
        machine.validate(Check::new(path))?;
        Ok(machine)
    }

    /// Checks and writes a `machine.json` file atomically.
    pub fn write(&self, path: &Path) -> Result<()> {
        self.validate(Check::new(path))?;
        json::write(path, json::MACHINE, &self.file())
    }

    /// Checks the machine and returns the text [`Self::write`] writes
    /// (errors name the file `machine.json`).
    pub fn to_json(&self) -> Result<String> {
        let path = Path::new(crate::MACHINE_FILE);
        self.validate(Check::new(path))?;
        json::text(path, json::MACHINE, &self.file())
    }

    /// The object `machine.json` holds (without `format`).
    fn file(&self) -> WithGeometry<&GeometryRecord, Conditions> {
        WithGeometry {
            geometry: &self.geometry,
            rest: Conditions {
                prior_sigma: self.prior_sigma,
                repeatability: self.repeatability,
                actuator: self.actuator.clone(),
                session_model: self.session_model,
                stroke: self.stroke,
                joint_limits: self.joint_limits,
            },
        }
    }

    /// The geometry a machine's ([`GeometryRecord::validate_machine`]),
    /// sigmas and repeatabilities within [`Check::sigma`]'s bounds, scales
    /// within [`Check::scale`]'s, the unit a label.
    pub(crate) fn validate(&self, check: Check) -> Result<()> {
        self.validate_in(check, "")
    }

    /// [`Machine::validate`] of a machine held in field `parent` of another
    /// file (`"design."`): errors name `parent` before the field.
    pub(crate) fn validate_in(&self, check: Check, parent: &str) -> Result<()> {
        let field = |name: &str| format!("{parent}{name}");
        self.geometry.validate_machine(check, parent)?;
        let PriorSigma {
            base,
            platform,
            tool,
            leg,
        } = self.prior_sigma;
        check.sigma(field("prior_sigma.base"), base)?;
        check.sigma(field("prior_sigma.platform"), platform)?;
        check.sigma(field("prior_sigma.tool"), tool)?;
        check.sigma(field("prior_sigma.leg"), leg)?;
        let r = &self.repeatability;
        check.sigma(field("repeatability.actuator"), r.actuator)?;
        check.sigma(field("repeatability.tool"), r.tool)?;
        for (name, value) in [
            ("repeatability.position", r.position),
            ("repeatability.orientation", r.orientation),
            (
                "session_model.leg_offset_sigma",
                self.session_model.leg_offset_sigma,
            ),
            (
                "session_model.body_origin_sigma",
                self.session_model.body_origin_sigma,
            ),
            (
                "session_model.body_rotation_sigma",
                self.session_model.body_rotation_sigma,
            ),
        ] {
            if let Some(value) = value {
                check.sigma(format_args!("{parent}{name}"), value)?;
            }
        }
        if self.actuator.unit.trim().is_empty() {
            return Err(check.error(field("actuator.unit"), "must not be empty"));
        }
        if has_control(&self.actuator.unit) {
            return Err(check.error(
                field("actuator.unit"),
                format!("{} has a control character", quoted(&self.actuator.unit)),
            ));
        }
        for (i, &s) in self.actuator.scale.iter().enumerate() {
            check.scale(format_args!("{parent}actuator.scale[{i}]"), s)?;
        }
        if let Some(sigmas) = &self.actuator.scale_sigma {
            for (i, &s) in sigmas.iter().enumerate() {
                check.sigma(format_args!("{parent}actuator.scale_sigma[{i}]"), s)?;
            }
        }
        if let Some([min, max]) = self.stroke {
            check.finite(field("stroke[0]"), min)?;
            check.finite(field("stroke[1]"), max)?;
            if min >= max {
                return Err(check.error(
                    field("stroke"),
                    format!("must be [min, max] with min < max, found [{min}, {max}]"),
                ));
            }
        }
        if let Some(limits) = &self.joint_limits {
            limits.validate(check, parent)?;
        }
        Ok(())
    }

    /// Whether the actuators read in mm with scale 1 (no `actuator` block,
    /// or one equal to it).
    pub fn reads_millimetres(&self) -> bool {
        self.actuator.scale == [1.0; 6] && self.actuator.scale_sigma.is_none()
    }
}
