//! `machine.json`: the design geometry, its tolerances and the machine's
//! repeatability.

use std::path::Path;

use serde::{Deserialize, Serialize};

use crate::check::Check;
use crate::error::Result;
use crate::geometry::{GeometryRecord, WithGeometry};
use crate::json;

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
/// `machine.json` has the geometry's fields at its top level.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Machine {
    /// Design geometry.
    pub geometry: GeometryRecord,
    /// Design tolerances.
    pub prior_sigma: PriorSigma,
    /// Repeatability, used to weight the observations.
    pub repeatability: Repeatability,
}

/// The fields of `machine.json` after the geometry.
#[derive(Serialize, Deserialize)]
struct Conditions {
    prior_sigma: PriorSigma,
    repeatability: Repeatability,
}

impl Machine {
    /// Reads and checks `machine.json`.
    pub(crate) fn read(path: &Path) -> Result<Self> {
        let file: WithGeometry<GeometryRecord, Conditions> = json::read(path, json::MACHINE)?;
        let machine = Self {
            geometry: file.geometry,
            prior_sigma: file.rest.prior_sigma,
            repeatability: file.rest.repeatability,
        };
        machine.validate(Check::new(path))?;
        Ok(machine)
    }

    /// Writes `machine.json` (the caller has validated).
    pub(crate) fn write(&self, path: &Path) -> Result<()> {
        let file = WithGeometry {
            geometry: &self.geometry,
            rest: Conditions {
                prior_sigma: self.prior_sigma,
                repeatability: self.repeatability,
            },
        };
        json::write(path, json::MACHINE, &file)
    }

    /// Every value finite; sigmas and repeatabilities positive.
    pub(crate) fn validate(&self, check: Check) -> Result<()> {
        self.geometry.validate(check, "")?;
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
