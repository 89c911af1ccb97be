//! A mechanism dataset's `machine.json`: the mechanism by name, the
//! parameters its controller runs with and the design, the builder's
//! tolerances per parameter group, the noise of each kind of measurement,
//! the probe's trigger height and a printer's printable radius.
//!
//! ```json
//! {
//!  "format": "parcal-machine/1",
//!  "mechanism": "linear delta",
//!  "configured": { "endstop_a": 0.0, "radius": 135.0, "...": 0.0 },
//!  "design": { "...": 0.0 },
//!  "tolerances": { "diagonal rods": 0.5, "tower radii": null },
//!  "matched": { "diagonal rods": 0.02 },
//!  "noise": { "probe": 0.01, "actuator": 0.005, "position": 0.01, "distance": 0.02 },
//!  "trigger_height": { "value": 0.7, "sigma": 0.05 },
//!  "print_radius": 100.0
//! }
//! ```
//!
//! `configured` names every parameter of the mechanism
//! (`parcal_kinematics::mechanisms`); `design`, the prior means, is
//! optional (the configured values then) and names all of them when
//! given; `tolerances` overrides the mechanism's default prior sigma of a
//! group (`null`: no prior). `matched` names groups whose parts were made
//! as a matched set (a delta's rods cut together): each part within the
//! given sigma of the set's common value, which is as uncertain as the
//! group's tolerance says, so that the parts' priors are correlated; the
//! sigma is positive and at most the group's tolerance. Every noise is
//! optional, but the one of each kind of measurement the dataset holds is
//! required. `print_radius` (mm, optional), a printer's printable radius
//! as its firmware holds it (RepRapFirmware's `M665 B`, Klipper's
//! `print_radius`), is what `parcal export` writes back to the firmware.
//! `elasticity` (optional, a cable robot's) makes its lines elastic
//! (`parcal_kinematics::cable::elasticity`): `{"compliance_of_line": [0,
//! 0, 0, 0], "zero_loads": [13.7, 14.5, 14.1, 12.5]}` gives each line the
//! index of its compliance among the compliance parameters (here one
//! shared, `compliance_abcd`; `[0, 1, 2, 3]`: one per line) and the
//! lines' loads when the encoders were zeroed (N, the unit of the
//! samples' loads); the compliance parameters are then named in
//! `configured` like the others, their group `line compliance`.

use std::collections::BTreeMap;
use std::path::Path;

use parcal_kinematics::cable::CableRobot;
use parcal_kinematics::mechanism::{Mechanism, MechanismError};
use parcal_kinematics::mechanisms;
use serde::ser::SerializeMap;
use serde::{Deserialize, Serialize, Serializer};

use crate::check::Check;
use crate::declared::{HEXAPOD, declared_mechanism};
use crate::error::{DatasetError, Result};
use crate::json;
use crate::quote::quoted;

/// The standard deviations of the measurements, each in its unit.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Noise {
    /// A probe's trigger (mm).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub probe: Option<f64>,
    /// An actuator reading (the actuators' unit).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub actuator: Option<f64>,
    /// A measured position's coordinate (mm).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub position: Option<f64>,
    /// A measured distance (mm).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub distance: Option<f64>,
    /// A height of the nozzle above the bed measured by hand (mm).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub height: Option<f64>,
    /// A touch of a calibrated ball, along its normal (mm).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub touch: Option<f64>,
    /// A tracker's measured coordinate (mm).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub tracker: Option<f64>,
}

/// A value with an optional standard deviation (a prior; without one,
/// a start).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ValuePrior {
    /// The value (the prior's mean).
    pub value: f64,
    /// Its standard deviation; `None`: no prior.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub sigma: Option<f64>,
}

/// A cable robot's elastic lines as machine.json states them (module
/// doc).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LineElasticity {
    /// For each line, the index of its compliance among the compliance
    /// parameters.
    pub compliance_of_line: Vec<usize>,
    /// The lines' loads when the encoders were zeroed (N).
    pub zero_loads: Vec<f64>,
}

impl LineElasticity {
    /// The elastic lines of `mechanism` ([`Mechanism::line_compliances`]);
    /// `None` for readings that do not depend on the load.
    pub fn of(mechanism: &dyn Mechanism) -> Option<Self> {
        (mechanism.line_compliances()).map(|(compliance_of_line, zero_loads)| Self {
            compliance_of_line: compliance_of_line.to_vec(),
            zero_loads: zero_loads.to_vec(),
        })
    }

    /// The typical cable robot with these elastic lines
    /// ([`mechanisms::elastic_cable_robot`]); an error saying what does
    /// not fit its lines.
    pub fn cable_robot(&self) -> std::result::Result<Box<dyn Mechanism>, String> {
        mechanisms::elastic_cable_robot(&self.compliance_of_line, &self.zero_loads)
    }
}

/// A mechanism dataset's machine (module doc).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct MechanismMachine {
    /// The mechanism's name, one of `parcal_kinematics::mechanisms::NAMES`.
    pub mechanism: String,
    /// The parameters the controller ran with, in the mechanism's order.
    pub configured: Vec<f64>,
    /// The design (the priors' means), in the mechanism's order.
    pub design: Vec<f64>,
    /// Prior sigmas overriding the mechanism's, by group (`None`: no
    /// prior), in the order of first appearance of the groups.
    pub tolerances: Vec<(String, Option<f64>)>,
    /// Groups made as matched sets, each with the sigma of a part about
    /// the set's common value (module doc), in the order of the groups.
    pub matched: Vec<(String, f64)>,
    /// The measurements' noise.
    pub noise: Noise,
    /// The probe's trigger height (mm; G31 Z for RepRapFirmware) and its
    /// prior sigma.
    pub trigger_height: Option<ValuePrior>,
    /// A printer's printable radius (mm), as its firmware holds it (module
    /// doc).
    pub print_radius: Option<f64>,
    /// A cable robot's elastic lines (module doc); `None`: rigid lines.
    pub elasticity: Option<LineElasticity>,
}

/// `machine.json` as read.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct MachineFile {
    mechanism: Option<String>,
    configured: BTreeMap<String, f64>,
    #[serde(default)]
    design: Option<BTreeMap<String, f64>>,
    #[serde(default)]
    tolerances: BTreeMap<String, Option<f64>>,
    #[serde(default)]
    matched: BTreeMap<String, f64>,
    #[serde(default)]
    noise: Noise,
    #[serde(default)]
    trigger_height: Option<ValuePrior>,
    #[serde(default)]
    print_radius: Option<f64>,
    #[serde(default)]
    elasticity: Option<LineElasticity>,
}

/// `machine.json` as written: names in the mechanism's order.
#[derive(Serialize)]
struct MachineOut<'a> {
    mechanism: &'a str,
    configured: Named<'a, f64>,
    design: Option<Named<'a, f64>>,
    #[serde(skip_serializing_if = "Named::is_empty")]
    tolerances: Named<'a, Option<f64>>,
    #[serde(skip_serializing_if = "Named::is_empty")]
    matched: Named<'a, f64>,
    noise: Noise,
    #[serde(skip_serializing_if = "Option::is_none")]
    trigger_height: Option<ValuePrior>,
    #[serde(skip_serializing_if = "Option::is_none")]
    print_radius: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    elasticity: Option<&'a LineElasticity>,
}

/// An object of named values, in the order given.
pub(crate) struct Named<'a, T>(pub Vec<(&'a str, T)>);

impl<T> Named<'_, T> {
    fn is_empty(&self) -> bool {
        self.0.is_empty()
    }
}

impl<T: Serialize> Serialize for Named<'_, T> {
    fn serialize<S: Serializer>(&self, serializer: S) -> std::result::Result<S::Ok, S::Error> {
        let mut map = serializer.serialize_map(Some(self.0.len()))?;
        for (name, value) in &self.0 {
            map.serialize_entry(name, value)?;
        }
        map.end()
    }
}

/// The mechanism named `name`, its lines elastic as `elasticity` states
/// (a cable robot's alone); an error naming `mechanism` or `elasticity`
/// of `path`.
pub(crate) fn machine_mechanism(
    path: &Path,
    name: &str,
    elasticity: Option<&LineElasticity>,
) -> Result<Box<dyn Mechanism>> {
    let mechanism = mechanism_named(path, "mechanism", name)?;
    let Some(elasticity) = elasticity else {
        return Ok(mechanism);
    };
    let cable_robot = CableRobot::typical();
    if mechanism.name() != cable_robot.name() {
        return Err(DatasetError::field(
            path,
            "elasticity",
            format!(
                "the {name} has no lines: elastic lines are a {}'s",
                cable_robot.name()
            ),
        ));
    }
    (elasticity.cable_robot()).map_err(|reason| DatasetError::field(path, "elasticity", reason))
}

/// The mechanism named `name`, or an error naming `field` of `path`.
pub(crate) fn mechanism_named(path: &Path, field: &str, name: &str) -> Result<Box<dyn Mechanism>> {
    mechanisms::by_name(name).ok_or_else(|| {
        DatasetError::field(
            path,
            field,
            format!(
                "unknown mechanism {} (known: {})",
                quoted(name),
                mechanisms::NAMES.join(", ")
            ),
        )
    })
}

/// The values of `named` in the order of `mechanism`'s parameters; an
/// unknown or missing name is an error naming `field.NAME`.
pub(crate) fn by_parameter(
    check: Check,
    mechanism: &dyn Mechanism,
    field: &str,
    named: &BTreeMap<String, f64>,
) -> Result<Vec<f64>> {
    let parameters = mechanism.parameters();
    if let Some(unknown) = named
        .keys()
        .find(|name| !parameters.iter().any(|p| &p.name == *name))
    {
        return Err(check.error(
            format!("{field}.{unknown}"),
            format!("the {} has no parameter of this name", mechanism.name()),
        ));
    }
    parameters
        .iter()
        .map(|p| {
            let value = named.get(&p.name).copied().ok_or_else(|| {
                check.error(
                    format!("{field}.{}", p.name),
                    "required parameter is missing",
                )
            })?;
            check.finite(format!("{field}.{}", p.name), value)?;
            Ok(value)
        })
        .collect()
}

/// Refuses parameter values `values` (of `field`) that no machine of
/// `mechanism`'s kind has ([`Mechanism::check_parameters`]), naming
/// `field.NAME`.
pub(crate) fn check_machine(
    check: Check,
    mechanism: &dyn Mechanism,
    field: &str,
    values: &[f64],
) -> Result<()> {
    match mechanism.check_parameters(values) {
        Ok(()) => Ok(()),
        Err(MechanismError::Parameter {
            name,
            value,
            reason,
        }) => Err(check.error(
            format!("{field}.{name}"),
            format!("{reason}, found {value}"),
        )),
        Err(other) => Err(check.error(field, other.to_string())),
    }
}

impl MechanismMachine {
    /// The machine of `mechanism` run with its design values, its lines
    /// elastic as the mechanism's are ([`LineElasticity::of`]), without
    /// tolerance overrides, noise, trigger height or printable radius.
    pub fn of(mechanism: &dyn Mechanism) -> Self {
        let design: Vec<f64> = mechanism.parameters().iter().map(|p| p.design).collect();
        Self {
            mechanism: mechanism.name().to_string(),
            configured: design.clone(),
            design,
            tolerances: Vec::new(),
            matched: Vec::new(),
            noise: Noise::default(),
            trigger_height: None,
            print_radius: None,
            elasticity: LineElasticity::of(mechanism),
        }
    }

    /// [`Self::of`] with every parameter group's tolerance stated (the
    /// mechanism's prior sigma of its first parameter), so that the file
    /// says the priors it was made with.
    pub fn stating_tolerances(mechanism: &dyn Mechanism) -> Self {
        let mut tolerances: Vec<(String, Option<f64>)> = Vec::new();
        for p in mechanism.parameters() {
            if !tolerances.iter().any(|(g, _)| g == p.group) {
                tolerances.push((p.group.to_string(), Some(p.prior_sigma)));
            }
        }
        Self {
            tolerances,
            ..Self::of(mechanism)
        }
    }

    /// The mechanism (its typical design from the one list, within the
    /// printable radius machine.json states, its lines elastic as it
    /// states; the dataset's own values are in [`Self::configured`] and
    /// [`Self::design`]).
    pub fn mechanism(&self) -> Option<Box<dyn Mechanism>> {
        match &self.elasticity {
            None => mechanisms::by_name_within(&self.mechanism, self.print_radius),
            Some(elasticity) => (elasticity.cable_robot().ok())
                .filter(|robot| robot.name() == self.mechanism && self.print_radius.is_none()),
        }
    }

    /// Reads and checks `machine.json` at `path`; a hexapod's (no
    /// `"mechanism"`, or `"hexapod"`) is refused with a pointer to its
    /// reader.
    pub fn read(path: &Path) -> Result<Self> {
        match declared_mechanism(path)? {
            Some(name) if name != HEXAPOD => {}
            _ => {
                return Err(DatasetError::field(
                    path,
                    "mechanism",
                    "this is a hexapod's machine (no mechanism named, or \"hexapod\"): read its dataset with the hexapod reader (Dataset)",
                ));
            }
        }
        let file: MachineFile = json::read(path, json::MACHINE)?;
        let check = Check::new(path);
        let name = file.mechanism.unwrap_or_default();
        let mechanism = machine_mechanism(path, &name, file.elasticity.as_ref())?;
        let configured = by_parameter(check, mechanism.as_ref(), "configured", &file.configured)?;
        let design = match &file.design {
            Some(design) => by_parameter(check, mechanism.as_ref(), "design", design)?,
            None => configured.clone(),
        };
        let mut tolerances: Vec<(String, Option<f64>)> = file.tolerances.into_iter().collect();
        let order = |group: &str| {
            mechanism
                .parameters()
                .iter()
                .position(|p| p.group == group)
                .unwrap_or(usize::MAX)
        };
        tolerances.sort_by_key(|(group, _)| order(group));
        let mut matched: Vec<(String, f64)> = file.matched.into_iter().collect();
        matched.sort_by_key(|(group, _)| order(group));
        let machine = Self {
            mechanism: name,
            configured,
            design,
            tolerances,
            matched,
            noise: file.noise,
            trigger_height: file.trigger_height,
            print_radius: file.print_radius,
            elasticity: file.elasticity,
        };
        machine.validate(check)?;
        Ok(machine)
    }

    /// Checks and writes `machine.json` at `path` atomically.
    pub fn write(&self, path: &Path) -> Result<()> {
        self.with_names(path, |out| json::write(path, json::MACHINE, out))
    }

    /// Checks the machine and returns the text [`Self::write`] writes
    /// (errors name the file `machine.json`).
    pub fn to_json(&self) -> Result<String> {
        let path = Path::new(crate::MACHINE_FILE);
        self.with_names(path, |out| json::text(path, json::MACHINE, out))
    }

    /// `emit` of the machine as written, its values named, once it is
    /// checked (errors naming `path`).
    fn with_names<T>(&self, path: &Path, emit: impl FnOnce(&MachineOut) -> Result<T>) -> Result<T> {
        let check = Check::new(path);
        self.validate(check)?;
        let mechanism = machine_mechanism(path, &self.mechanism, self.elasticity.as_ref())?;
        let names: Vec<&str> = mechanism
            .parameters()
            .iter()
            .map(|p| p.name.as_str())
            .collect();
        let named =
            |values: &[f64]| Named(names.iter().copied().zip(values.iter().copied()).collect());
        let out = MachineOut {
            mechanism: &self.mechanism,
            configured: named(&self.configured),
            design: (self.design != self.configured).then(|| named(&self.design)),
            tolerances: Named(
                self.tolerances
                    .iter()
                    .map(|(group, sigma)| (group.as_str(), *sigma))
                    .collect(),
            ),
            matched: Named(
                self.matched
                    .iter()
                    .map(|(group, sigma)| (group.as_str(), *sigma))
                    .collect(),
            ),
            noise: self.noise,
            trigger_height: self.trigger_height,
            print_radius: self.print_radius,
            elasticity: self.elasticity.as_ref(),
        };
        emit(&out)
    }

    /// The checks of [`Self::read`] and [`Self::write`]: a known mechanism,
    /// one value per parameter, finite and within the length bound; known
    /// groups; sigmas within their bounds; a matched group's sigma at most
    /// its tolerance; a printable radius positive and within the length
    /// bound; elastic lines a cable robot's, fitting its lines.
    pub(crate) fn validate(&self, check: Check) -> Result<()> {
        let mechanism = machine_mechanism(check.path(), &self.mechanism, self.elasticity.as_ref())?;
        let parameters = mechanism.parameters();
        for (field, values) in [("configured", &self.configured), ("design", &self.design)] {
            if values.len() != parameters.len() {
                return Err(check.error(
                    field,
                    format!(
                        "{} values for the {} parameters of the {}",
                        values.len(),
                        parameters.len(),
                        self.mechanism
                    ),
                ));
            }
            for (p, &value) in parameters.iter().zip(values.iter()) {
                check.length(format!("{field}.{}", p.name), value)?;
            }
            check_machine(check, mechanism.as_ref(), field, values)?;
        }
        let known_group = |field: String, group: &str| {
            if parameters.iter().any(|p| p.group == group) {
                return Ok(());
            }
            let mut groups: Vec<&str> = parameters.iter().map(|p| p.group).collect();
            groups.dedup();
            Err(check.error(
                field,
                format!(
                    "the {} has no such group (its groups: {})",
                    self.mechanism,
                    groups.join(", ")
                ),
            ))
        };
        for (group, sigma) in &self.tolerances {
            known_group(format!("tolerances.{group}"), group)?;
            if let Some(sigma) = sigma {
                check.sigma(format!("tolerances.{group}"), *sigma)?;
            }
        }
        for (group, sigma) in &self.matched {
            let field = format!("matched.{group}");
            known_group(field.clone(), group)?;
            check.sigma(field.clone(), *sigma)?;
            let tolerance = match self.tolerances.iter().find(|(g, _)| g == group) {
                Some((_, tolerance)) => *tolerance,
                None => parameters
                    .iter()
                    .find(|p| p.group == group)
                    .map(|p| p.prior_sigma),
            };
            match tolerance {
                None => {
                    return Err(check.error(
                        field,
                        "the group has no prior (tolerances: null): a matched set needs its tolerance",
                    ));
                }
                Some(tolerance) if *sigma > tolerance => {
                    return Err(check.error(
                        field,
                        format!(
                            "{sigma} is more than the group's tolerance {tolerance}: a part of a matched set is closer to the set's value than the tolerance"
                        ),
                    ));
                }
                Some(_) => {}
            }
        }
        let noise = &self.noise;
        for (name, sigma) in [
            ("probe", noise.probe),
            ("actuator", noise.actuator),
            ("position", noise.position),
            ("distance", noise.distance),
            ("height", noise.height),
            ("touch", noise.touch),
            ("tracker", noise.tracker),
        ] {
            if let Some(sigma) = sigma {
                check.sigma(format!("noise.{name}"), sigma)?;
            }
        }
        if let Some(trigger) = &self.trigger_height {
            check.length("trigger_height.value", trigger.value)?;
            if let Some(sigma) = trigger.sigma {
                check.sigma("trigger_height.sigma", sigma)?;
            }
        }
        check_print_radius(check, &self.mechanism, self.print_radius)
    }
}

/// Refuses a printable radius (`print_radius`, mm) that is not a positive
/// length, or that the mechanism named `mechanism` has none of (a linear
/// delta's alone).
pub(crate) fn check_print_radius(check: Check, mechanism: &str, radius: Option<f64>) -> Result<()> {
    let Some(radius) = radius else {
        return Ok(());
    };
    check.positive_length("print_radius", radius)?;
    if mechanisms::by_name_within(mechanism, Some(radius)).is_none() {
        return Err(check.error(
            "print_radius",
            format!("the {mechanism} has no printable radius (a linear delta's)"),
        ));
    }
    Ok(())
}
