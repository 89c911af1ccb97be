//! A simulated mechanism dataset's truth (`truth.json`): the true
//! parameters by name; for a dataset whose probe heights make it an
//! unknown, the true trigger height (a cable robot has none); and each
//! tracker's true frame by its label, from the true machine's frame to
//! the tracker's (`x_tracker = R x + t`, `R` a unit quaternion `[x, y, z,
//! w]`).
//!
//! ```json
//! { "format": "parcal-mechanism-truth/1",
//!   "parameters": { "endstop_a": 0.12, "...": 0.0 },
//!   "trigger_height": 0.71,
//!   "trackers": { "T1": { "translation": [1500.0, -20.0, 80.0],
//!                         "rotation": [0.0, 0.0, 0.6, 0.8] } } }
//! ```

use std::collections::BTreeMap;
use std::path::Path;

use serde::{Deserialize, Serialize};

use crate::FrameRecord;
use crate::check::Check;
use crate::error::Result;
use crate::json;

use super::machine::{MechanismMachine, Named, by_parameter, check_machine, machine_mechanism};

/// The true machine of a simulated dataset.
#[derive(Debug, Clone, PartialEq)]
pub struct MechanismTruth {
    /// The true parameters, in the mechanism's order.
    pub parameters: Vec<f64>,
    /// The true trigger height (mm), if the machine has a probe.
    pub trigger_height: Option<f64>,
    /// Each tracker's true frame by its label (tracker_points.csv's), from
    /// the true machine's frame to the tracker's; none for a dataset
    /// without trackers.
    pub trackers: BTreeMap<String, FrameRecord>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct TruthFile {
    parameters: BTreeMap<String, f64>,
    #[serde(default)]
    trigger_height: Option<f64>,
    #[serde(default)]
    trackers: BTreeMap<String, FrameRecord>,
}

#[derive(Serialize)]
struct TruthOut<'a> {
    parameters: Named<'a, f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    trigger_height: Option<f64>,
    #[serde(skip_serializing_if = "BTreeMap::is_empty")]
    trackers: &'a BTreeMap<String, FrameRecord>,
}

impl MechanismTruth {
    /// Reads `truth.json` at `path` if present, for the mechanism of
    /// `machine` (its lines elastic as it states).
    pub fn read_if_present(path: &Path, machine: &MechanismMachine) -> Result<Option<Self>> {
        let Some(file) = json::read_if_present::<TruthFile>(path, json::MECHANISM_TRUTH)? else {
            return Ok(None);
        };
        let check = Check::new(path);
        let mechanism = machine_mechanism(path, &machine.mechanism, machine.elasticity.as_ref())?;
        let parameters = by_parameter(check, mechanism.as_ref(), "parameters", &file.parameters)?;
        check_machine(check, mechanism.as_ref(), "parameters", &parameters)?;
        let truth = Self {
            parameters,
            trigger_height: file.trigger_height,
            trackers: file.trackers,
        };
        truth.check_values(check)?;
        Ok(Some(truth))
    }

    /// Refuses a trigger height or a tracker's frame that is not finite
    /// or out of bounds (a rotation that is not a unit quaternion), naming
    /// it.
    fn check_values(&self, check: Check) -> Result<()> {
        if let Some(height) = self.trigger_height {
            check.length("trigger_height", height)?;
        }
        for (label, frame) in &self.trackers {
            frame.validate(check, &format!("trackers.{label}"))?;
        }
        Ok(())
    }

    /// Writes `truth.json` at `path` atomically, for the mechanism of
    /// `machine` (its lines elastic as it states).
    pub fn write(&self, path: &Path, machine: &MechanismMachine) -> Result<()> {
        let check = Check::new(path);
        let name = &machine.mechanism;
        let mechanism = machine_mechanism(path, name, machine.elasticity.as_ref())?;
        let parameters = mechanism.parameters();
        if self.parameters.len() != parameters.len() {
            return Err(check.error(
                "parameters",
                format!(
                    "{} values for the {} parameters of the {name}",
                    self.parameters.len(),
                    parameters.len()
                ),
            ));
        }
        for (p, &value) in parameters.iter().zip(&self.parameters) {
            check.length(format!("parameters.{}", p.name), value)?;
        }
        check_machine(check, mechanism.as_ref(), "parameters", &self.parameters)?;
        self.check_values(check)?;
        let out = TruthOut {
            parameters: Named(
                parameters
                    .iter()
                    .map(|p| p.name.as_str())
                    .zip(self.parameters.iter().copied())
                    .collect(),
            ),
            trigger_height: self.trigger_height,
            trackers: &self.trackers,
        };
        json::write(path, json::MECHANISM_TRUTH, &out)
    }
}
