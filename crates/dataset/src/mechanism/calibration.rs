//! The record of a mechanism calibration (`calibration.json`, format
//! `parcal-mechanism-calibration/1.6`): the mechanism (and a printer's
//! printable radius, since 1.2; a cable robot's elastic lines, since
//! 1.3), the estimated
//! parameters in its canonical frame with their sigmas, priors and
//! covariance, the verdict and its reasons, the tests (global test,
//! w-tests, snooping), the identifiability and a Gauss-Newton fit that ran
//! away before (since 1.4), the dataset's provenance (since 1.5), warnings
//! that are not the verdict's (since 1.6: observations given twice), so that
//! `export` and
//! `report` read one without the calibration's code.

use std::collections::BTreeSet;
use std::path::Path;

use serde::{Deserialize, Serialize};

use crate::check::Check;
use crate::error::Result;
use crate::json;
use crate::{FrameRecord, GlobalTestRecord, Provenance};

use super::machine::{LineElasticity, check_print_radius, machine_mechanism};
use super::observation_records::ObservationRecords;

/// The name of the probe's trigger height among the estimated unknowns,
/// after the mechanism's parameters.
pub const TRIGGER_HEIGHT: &str = "trigger_height";

/// One estimated unknown.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ParameterRecord {
    /// Its name (the mechanism's, or [`TRIGGER_HEIGHT`]).
    pub name: String,
    /// Its unit.
    pub unit: String,
    /// Its group.
    pub group: String,
    /// Its estimate (canonical frame).
    pub value: f64,
    /// Its standard deviation.
    pub sigma: Option<f64>,
    /// Its prior mean.
    pub prior_mean: f64,
    /// Its prior sigma (`None`: no prior).
    pub prior_sigma: Option<f64>,
    /// Its posterior over its prior sigma (canonical frame).
    pub sigma_ratio: Option<f64>,
}

/// An observation removed by snooping.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RemovalRecord {
    /// Its kind.
    pub kind: String,
    /// Its 0-based index in the dataset.
    pub index: usize,
    /// Its row of largest `|w|`.
    pub row: usize,
    /// That `w`.
    pub normalised: f64,
    /// The variance factor before its removal.
    pub variance_factor_before: Option<f64>,
    /// And after.
    pub variance_factor_after: Option<f64>,
}

/// The w-tests and data snooping.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TestsRecord {
    /// The level `α`.
    pub alpha: f64,
    /// The data rows.
    pub data_rows: usize,
    /// The w-tests' family when it is not one test per data row (a ball
    /// touch's three coordinate rows are one test); absent: one per row.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub tests: Option<usize>,
    /// The critical value of `|w|`.
    pub critical_value: f64,
    /// Every observation's numbers.
    pub observations: ObservationRecords,
    /// The observations snooping removed.
    pub removed: Vec<RemovalRecord>,
    /// Why snooping stopped early, if it did.
    pub snooping_stopped: Option<String>,
}

/// A combination of the unknowns the data alone do not determine.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct UndeterminedRecord {
    /// Components in units of the prior sigmas, largest first.
    pub components: Vec<(String, f64)>,
    /// The data-only sigma over the prior's (`None`: unseen).
    pub data_to_prior: Option<f64>,
}

/// What the data determine.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct IdentifiabilityRecord {
    /// The gauge freedoms the canonical frame fixes.
    pub gauge: Vec<String>,
    /// The directions set by the priors.
    pub undetermined: Vec<UndeterminedRecord>,
    /// In words.
    pub statements: Vec<String>,
}

/// A calibrated ball's estimated centre and radius.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BallRecord {
    /// Its centre (mm, the fit's frame: the frame of the commanded
    /// positions).
    pub centre: [f64; 3],
    /// Its coordinates' standard deviations (mm).
    pub centre_sigma: Option<[f64; 3]>,
    /// Its radius: the estimate, or its calibrated value when exact (mm).
    pub radius: f64,
    /// The radius's standard deviation (`None`: exact).
    pub radius_sigma: Option<f64>,
}

/// A Gauss-Newton fit that ran away, made again with Levenberg-Marquardt
/// (since 1.4).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RunAwayRecord {
    /// How it ended, in words.
    pub status: String,
    /// Its iterations.
    pub iterations: usize,
    /// Its cost at its start and at its end (`null` where not finite).
    pub cost: [Option<f64>; 2],
}

/// A ball found on the wrong side of its touches and re-seeded at the
/// mirror image of its centre fit.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MirroredRecord {
    /// Its 0-based index.
    pub ball: usize,
    /// The linear solves before the iterate that showed it.
    pub iteration: usize,
    /// Its whitened data cost there.
    pub chi_square: f64,
    /// How many times better its touches' tool points there fit the
    /// mirror image.
    pub gain: f64,
    /// Its re-seeded centre (mm, the fit's frame).
    pub centre: [f64; 3],
}

/// The body frame the tracker poses saw, as the calibration located it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BodyRecord {
    /// `B`, from the body's frame to the platform's (`x_platform = R x +
    /// t`).
    pub frame: FrameRecord,
    /// The standard deviations of its correction: rotations about the
    /// platform's axes `x, y, z` (rad), then translations (mm).
    pub sigma: Option<[f64; 6]>,
}

/// A tracker's frame as the calibration located it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TrackerRecord {
    /// Its label.
    pub label: String,
    /// `F`, from the mechanism's canonical frame to the tracker's
    /// (`x_tracker = R x + t`).
    pub frame: FrameRecord,
    /// The standard deviations of its correction: rotations about the
    /// mechanism's axes `x, y, z` (rad), then translations (mm).
    pub sigma: Option<[f64; 6]>,
    /// The actuators' zero offsets while it measured, when the machine was
    /// re-homed before (their extension, mm, where their scales are the
    /// mechanism's parameters, else the readings' unit; absent: none).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub offsets: Vec<f64>,
    /// Their standard deviations.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub offset_sigmas: Option<Vec<f64>>,
    /// The body frame its poses saw, when the body was turned or moved
    /// before it measured (absent: the record's `body`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub body: Option<BodyRecord>,
}

/// A mechanism calibration's record (module doc).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MechanismCalibrationRecord {
    /// The mechanism's name.
    pub mechanism: String,
    /// The dataset calibrated, as given, and its checksum (absent: data
    /// built in memory, or a record written before 1.5).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub provenance: Option<Provenance>,
    /// A printer's printable radius (mm), its dataset's (machine.json's
    /// `print_radius`): what applying the calibration keeps the nozzle
    /// within and writes back to the firmware (absent: none stated).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub print_radius: Option<f64>,
    /// A cable robot's elastic lines, its dataset's (machine.json's
    /// `elasticity`): what evaluating the calibrated robot under loads
    /// needs besides its parameters (absent: rigid lines).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub elasticity: Option<LineElasticity>,
    /// How the solver ended.
    pub status: String,
    /// Its linear solves.
    pub iterations: usize,
    /// Whether the result may be used.
    pub accepted: bool,
    /// Why, in words.
    pub reasons: Vec<String>,
    /// What else the data showed, in words (observations given twice);
    /// none: absent.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub warnings: Vec<String>,
    /// The mechanism's parameters, then the trigger height if estimated.
    pub parameters: Vec<ParameterRecord>,
    /// Their covariance (canonical frame), row by row.
    pub covariance: Option<Vec<Vec<f64>>>,
    /// The correlation of the mechanism's parameters' priors, row by row
    /// (absent: independent priors), in the mechanism's parameter order.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub prior_correlation: Option<Vec<Vec<f64>>>,
    /// The global test.
    pub global_test: Option<GlobalTestRecord>,
    /// The w-tests and snooping.
    pub tests: TestsRecord,
    /// What the data determine.
    pub identifiability: Option<IdentifiabilityRecord>,
    /// The calibrated balls' centres and radii, numbered as in the
    /// dataset (none without touches).
    #[serde(
        default,
        skip_serializing_if = "Vec::is_empty",
        serialize_with = "balls_on_threads"
    )]
    pub balls: Vec<BallRecord>,
    /// The balls found on the wrong side of their touches and re-seeded
    /// (none: absent).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub mirrored: Vec<MirroredRecord>,
    /// When the fit is the Levenberg-Marquardt one made after a
    /// Gauss-Newton fit ran away: how that one ended (absent otherwise).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub gauss_newton: Option<RunAwayRecord>,
    /// The trackers' frames, in the dataset's order (none: absent).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub trackers: Vec<TrackerRecord>,
    /// The body frame the tracker poses saw (none: absent).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub body: Option<BodyRecord>,
    /// The ball touches' observation equation: `radius` (paper eq. 9, a
    /// row a touch) or `coordinates` (eq. 10, three rows and two contact
    /// angles a touch); absent without touches.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub observation: Option<String>,
}

/// The balls, each on one line, formatted on the threads (a hexapod's
/// calibration has 10^5).
fn balls_on_threads<S: serde::Serializer>(
    balls: &[BallRecord],
    serializer: S,
) -> std::result::Result<S::Ok, S::Error> {
    json::serialize_seq_on_threads(serializer, balls.len(), json::ELEMENTS_A_WAVE, |b| {
        &balls[b]
    })
}

impl MechanismCalibrationRecord {
    /// The parameter named `name`.
    pub fn parameter(&self, name: &str) -> Option<&ParameterRecord> {
        self.parameters.iter().find(|p| p.name == name)
    }

    /// Reads and checks `calibration.json` at `path`.
    pub fn read(path: &Path) -> Result<Self> {
        let record: Self = json::read(path, json::MECHANISM_CALIBRATION)?;
        record.validate(Check::result(path))?;
        Ok(record)
    }

    /// Checks and writes `calibration.json` at `path` atomically.
    pub fn write(&self, path: &Path) -> Result<()> {
        // A 10^6-contact calibration's observation rows are written while
        // the rest is checked.
        json::write_checked(path, json::MECHANISM_CALIBRATION, self, || {
            self.validate(Check::result(path))
        })
    }

    /// A known mechanism (elastic lines a cable robot's, fitting its
    /// lines); unique parameter names; finite values, sigmas
    /// and covariance of the parameters' size; a prior correlation of the
    /// size of the parameters but the trigger height, unit diagonal, entries within ±1;
    /// finite ball centres and radii; a run-away fit's status a text and
    /// its costs finite; every observation row held by an observation.
    fn validate(&self, check: Check) -> Result<()> {
        machine_mechanism(check.path(), &self.mechanism, self.elasticity.as_ref())?;
        check_print_radius(check, &self.mechanism, self.print_radius)?;
        let mut names = BTreeSet::new();
        for (k, p) in self.parameters.iter().enumerate() {
            let field = |name: &str| format!("parameters[{k}].{name}");
            if !names.insert(p.name.as_str()) {
                return Err(check.error(field("name"), format!("{:?} is given twice", p.name)));
            }
            check.finite(field("value"), p.value)?;
            check.finite(field("prior_mean"), p.prior_mean)?;
            for (name, value) in [
                ("sigma", p.sigma),
                ("prior_sigma", p.prior_sigma),
                ("sigma_ratio", p.sigma_ratio),
            ] {
                if let Some(value) = value {
                    check.non_negative(field(name), value)?;
                }
            }
        }
        if let Some(covariance) = &self.covariance {
            let n = self.parameters.len();
            if covariance.len() != n || covariance.iter().any(|row| row.len() != n) {
                return Err(check.error(
                    "covariance",
                    format!("must be {n} x {n}, one row and column per parameter"),
                ));
            }
            for (i, row) in covariance.iter().enumerate() {
                check.values(format!("covariance[{i}]"), row)?;
            }
        }
        if let Some(correlation) = &self.prior_correlation {
            let n = self
                .parameters
                .iter()
                .filter(|p| p.name != TRIGGER_HEIGHT)
                .count();
            if correlation.len() != n || correlation.iter().any(|row| row.len() != n) {
                return Err(check.error(
                    "prior_correlation",
                    format!(
                        "must be {n} x {n}, one row and column per parameter of the {}",
                        self.mechanism
                    ),
                ));
            }
            for (i, row) in correlation.iter().enumerate() {
                let field = format!("prior_correlation[{i}]");
                check.values(field.clone(), row)?;
                if row[i] != 1.0 || row.iter().any(|c| c.abs() > 1.0) {
                    return Err(check.error(
                        field,
                        "a correlation is 1 on the diagonal and within ±1 elsewhere",
                    ));
                }
            }
        }
        for (b, ball) in self.balls.iter().enumerate() {
            check.values(format_args!("balls[{b}].centre"), &ball.centre)?;
            if let Some(sigma) = &ball.centre_sigma {
                check.values(format_args!("balls[{b}].centre_sigma"), sigma)?;
            }
            check.finite(format_args!("balls[{b}].radius"), ball.radius)?;
            if let Some(sigma) = ball.radius_sigma {
                check.non_negative(format_args!("balls[{b}].radius_sigma"), sigma)?;
            }
        }
        if let Some(run) = &self.gauss_newton {
            check.text("gauss_newton.status", &run.status)?;
            check.values(
                "gauss_newton.cost",
                &run.cost.iter().flatten().copied().collect::<Vec<_>>(),
            )?;
        }
        let unclaimed = self.tests.observations.unclaimed_rows();
        if unclaimed > 0 {
            return Err(check.error(
                "tests.observations",
                format!("{unclaimed} rows belong to no observation"),
            ));
        }
        Ok(())
    }
}
