//! `machine.json`: the design geometry, its tolerances and the machine's
//! repeatability.

use std::path::Path;

use serde::{Deserialize, Serialize};

use crate::Point3;
use crate::check::Check;
use crate::error::Result;
use crate::{json, shape};

/// A priori standard deviation of every parameter of each group (the design
/// tolerance), in mm.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct PriorSigma {
    /// Base joint coordinates.
    pub base: f64,
    /// Platform joint coordinates.
    pub platform: f64,
    /// Tool tip coordinates (platform frame).
    pub tool: f64,
    /// Initial leg lengths.
    pub leg: f64,
}

/// One standard deviation of the machine's repeatability, in mm.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Repeatability {
    /// Actuator encoders, independent per actuator and per contact.
    pub actuator: f64,
    /// Tool positioning, per axis and per contact.
    pub tool: f64,
}

/// The design (nominal) machine, in any base frame and any platform frame.
///
/// Its serde form is the body of `machine.json` (without `format`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Machine {
    /// Base joints B1..B6 in the base frame.
    #[serde(deserialize_with = "shape::joints")]
    pub base_joints: [Point3; 6],
    /// Platform joints E1..E6 in the platform frame.
    #[serde(deserialize_with = "shape::joints")]
    pub platform_joints: [Point3; 6],
    /// Tool tip E_T in the platform frame.
    #[serde(deserialize_with = "shape::point")]
    pub tool: Point3,
    /// Initial leg lengths l1..l6 (leg i is `l_i + q_i` long).
    #[serde(deserialize_with = "shape::legs")]
    pub leg_lengths: [f64; 6],
    /// Design tolerances.
    pub prior_sigma: PriorSigma,
    /// Repeatability, used to weight the observations.
    pub repeatability: Repeatability,
}

impl Machine {
    /// Reads and checks `machine.json`.
    pub(crate) fn read(path: &Path) -> Result<Self> {
        let machine: Self = json::read(path, json::MACHINE)?;
        machine.validate(Check::new(path))?;
        Ok(machine)
    }

    /// Writes `machine.json` (the caller has validated).
    pub(crate) fn write(&self, path: &Path) -> Result<()> {
        json::write(path, json::MACHINE, self)
    }

    /// Every value finite; sigmas and repeatabilities positive.
    pub(crate) fn validate(&self, check: Check) -> Result<()> {
        check.geometry(
            &self.base_joints,
            &self.platform_joints,
            &self.tool,
            &self.leg_lengths,
        )?;
        let PriorSigma {
            base,
            platform,
            tool,
            leg,
        } = self.prior_sigma;
        check.positive("prior_sigma.base", base)?;
        check.positive("prior_sigma.platform", platform)?;
        check.positive("prior_sigma.tool", tool)?;
        check.positive("prior_sigma.leg", leg)?;
        check.positive("repeatability.actuator", self.repeatability.actuator)?;
        check.positive("repeatability.tool", self.repeatability.tool)
    }
}
