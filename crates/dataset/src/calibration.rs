//! `calibration.json`: the result of a calibration.

use std::collections::BTreeMap;
use std::path::Path;

use serde::{Deserialize, Serialize};

use crate::Point3;
use crate::check::Check;
use crate::error::Result;
use crate::geometry::GeometryRecord;
use crate::machine::{Actuator, Machine};
use crate::quote::sanitized;
use crate::session::SessionRecord;
use crate::{json, shape};

/// The identified kinematic parameters, by name (order and names of
/// paper-scenario.md section 2), with their posterior sigmas.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct ParameterTable {
    /// Parameter names, e.g. `y_b2`.
    pub names: Vec<String>,
    /// Identified values.
    pub values: Vec<f64>,
    /// Posterior standard deviations.
    pub sigma: Vec<f64>,
}

/// An identified ball centre (base frame) and the sigma of each coordinate.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct CentreEstimate {
    /// Centre.
    #[serde(deserialize_with = "shape::point")]
    pub centre: Point3,
    /// Posterior standard deviation of each coordinate.
    #[serde(deserialize_with = "shape::point")]
    pub sigma: Point3,
}

/// One iteration as calibration.json keeps it: the solver's record of the
/// iteration reduced to its cost, step and residual RMS.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct IterationSummary {
    /// Weighted cost (priors included).
    pub cost: f64,
    /// Norm of the step taken.
    pub step_norm: f64,
    /// RMS of the unweighted observation residuals.
    pub residual_rms: f64,
}

/// The content of `calibration.json`.
///
/// Its serde form is the file's body (without `format`). `status` defaults
/// to the empty string and `options` to an empty map when absent.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Calibration {
    /// Identified geometry in the canonical frames.
    pub canonical: GeometryRecord,
    /// The identified parameters.
    pub parameters: ParameterTable,
    /// Posterior covariance of the parameters (n x n for n parameters), or
    /// empty if it could not be computed.
    pub covariance: Vec<Vec<f64>>,
    /// Identified ball centres by ball id.
    #[serde(deserialize_with = "shape::unique_map")]
    pub ball_centres: BTreeMap<String, CentreEstimate>,
    /// The prior used: `"paper"`, `"propagated"` or `"none"`.
    pub prior: String,
    /// One record per iteration.
    pub iterations: Vec<IterationSummary>,
    /// Whether the run converged.
    pub converged: bool,
    /// Why the run stopped (diverged, iteration limit, ...).
    #[serde(default)]
    pub status: String,
    /// Free-form options of the run (simulation, observation, weights...).
    #[serde(default, deserialize_with = "shape::unique_map")]
    pub options: BTreeMap<String, serde_json::Value>,
    /// Calibrations of poses or points: the calibrated machine as another
    /// tool would load it, in the frames of the first session.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub machine: Option<CalibratedMachine>,
    /// Calibrations of poses or points: every session's nuisance.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub sessions: Vec<SessionRecord>,
    /// `"accepted"` or `"rejected"` (empty in files written before
    /// verdicts).
    #[serde(default)]
    pub verdict: String,
    /// Why, one sentence each.
    #[serde(default)]
    pub reasons: Vec<String>,
    /// Every warning of the run, one sentence each.
    #[serde(default)]
    pub warnings: Vec<String>,
    /// The global test of the a-posteriori variance factor.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub global_test: Option<GlobalTestRecord>,
    /// Where the result comes from.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub provenance: Option<Provenance>,
    /// The observations data snooping removed, in the order of removal.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub removed_observations: Vec<RemovedObservation>,
    /// The design machine the calibration started from (machine.json as
    /// given: the design geometry in the design frame, priors,
    /// repeatability, actuator unit and design scales, stroke): what
    /// applying the calibration needs besides the result (`None` in files
    /// written before it was recorded).
    #[serde(
        default,
        skip_serializing_if = "Option::is_none",
        with = "crate::machine::embedded"
    )]
    pub design: Option<Machine>,
}

/// An observation removed by data snooping.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RemovedObservation {
    /// Its file (`measurements.csv`, `artefacts.json`, `poses.csv`,
    /// `points.csv`).
    pub file: String,
    /// Its line there, for a CSV file (the header is line 1).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub line: Option<u64>,
    /// Its field, for a JSON file (`distances[3]`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub field: Option<String>,
    /// Its normalised residual when it was removed (of its row of largest
    /// magnitude, for an observation of several rows).
    pub normalised_residual: f64,
    /// That row's estimated gross error, in units of its standard
    /// deviation.
    pub gross_error_sigmas: f64,
    /// The a-posteriori variance factor before and after its removal.
    pub variance_factor: [f64; 2],
}

impl Calibration {
    /// Whether the verdict is `"rejected"`.
    pub fn is_rejected(&self) -> bool {
        self.verdict == "rejected"
    }

    /// The actuators' unit and scales to apply: the calibrated ones
    /// (`machine.actuator`) when the calibration identified them, else the
    /// design's (`design.actuator`); `None` when the file has neither.
    pub fn actuator(&self) -> Option<&Actuator> {
        self.machine
            .as_ref()
            .map(|m| &m.actuator)
            .or(self.design.as_ref().map(|d| &d.actuator))
    }
}

/// The global test of a calibration: `Ω ~ χ²(r)` under the model and the
/// stated noise, two-sided at `level`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct GlobalTestRecord {
    /// `Ω`, the weighted sum of squares (priors included).
    pub cost: f64,
    /// The redundancy `r` (rows less unknowns).
    pub redundancy: usize,
    /// `s₀² = Ω / r`.
    pub variance_factor: f64,
    /// The test's level.
    pub level: f64,
    /// The interval of `s₀²` that passes.
    pub interval: [f64; 2],
    /// `"consistent"`, `"too large"` or `"too small"`.
    pub outcome: String,
}

/// Where a calibration comes from.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Provenance {
    /// The parcal version that computed it.
    pub parcal_version: String,
    /// The dataset as it was given (a directory or a snapshot).
    pub dataset: String,
    /// The dataset's checksum ([`crate::Dataset::checksum`]).
    pub dataset_checksum: String,
}

/// The calibrated machine in the frames of the first session: base joints
/// in that session's instrument frame, platform joints (and tool) in the
/// platform body frame (the canonical platform frame for points alone), and
/// leg `i` of length `leg_lengths[i] + actuator.scale[i] q_i`, so that for
/// every row of that session `|R p_i + t − b_i| = l_i + s_i q_i` up to the
/// noise, `(R, t)` the measured pose.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CalibratedMachine {
    /// The geometry.
    pub geometry: GeometryRecord,
    /// The actuators' unit and calibrated scales (`scale_sigma`: their
    /// posterior sigmas).
    pub actuator: Actuator,
}

impl Calibration {
    /// Reads and checks a calibration file (extra fields are ignored).
    pub fn read(path: &Path) -> Result<Self> {
        let calibration: Self = json::read(path, json::CALIBRATION)?;
        calibration.validate(Check::result(path))?;
        Ok(calibration)
    }

    /// Writes a calibration file atomically. Every number must be finite
    /// (JSON has no NaN): a non-finite value is an error naming its field.
    pub fn write(&self, path: &Path) -> Result<()> {
        self.validate(Check::result(path))?;
        json::write(path, json::CALIBRATION, self)
    }

    fn validate(&self, check: Check) -> Result<()> {
        self.canonical.validate(check, "canonical.")?;

        let p = &self.parameters;
        let n = p.names.len();
        for (field, len) in [
            ("parameters.values", p.values.len()),
            ("parameters.sigma", p.sigma.len()),
        ] {
            if len != n {
                return Err(check.error(
                    field,
                    format!("expected {n} values (one per name), found {len}"),
                ));
            }
        }
        check.values("parameters.values", &p.values)?;
        check.values("parameters.sigma", &p.sigma)?;

        if !self.covariance.is_empty() {
            if self.covariance.len() != n {
                return Err(check.error(
                    "covariance",
                    format!(
                        "expected {n} rows (one per parameter), found {}",
                        self.covariance.len()
                    ),
                ));
            }
            for (i, row) in self.covariance.iter().enumerate() {
                let field = format!("covariance[{i}]");
                if row.len() != n {
                    return Err(
                        check.error(field, format!("expected {n} columns, found {}", row.len()))
                    );
                }
                check.values(&field, row)?;
            }
        }

        for (id, estimate) in &self.ball_centres {
            let id = sanitized(id);
            check.point(format_args!("ball_centres.{id}.centre"), &estimate.centre)?;
            check.point(format_args!("ball_centres.{id}.sigma"), &estimate.sigma)?;
        }
        if let Some(machine) = &self.machine {
            machine.geometry.validate(check, "machine.geometry.")?;
            check.values("machine.actuator.scale", &machine.actuator.scale)?;
        }
        if let Some(design) = &self.design {
            design.validate_in(check, "design.")?;
        }
        for (k, session) in self.sessions.iter().enumerate() {
            session.validate(check, &format!("sessions[{k}]"))?;
        }
        for (i, it) in self.iterations.iter().enumerate() {
            check.finite(format_args!("iterations[{i}].cost"), it.cost)?;
            check.finite(format_args!("iterations[{i}].step_norm"), it.step_norm)?;
            check.finite(
                format_args!("iterations[{i}].residual_rms"),
                it.residual_rms,
            )?;
        }
        Ok(())
    }
}
