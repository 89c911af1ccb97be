//! `calibration.json`: the result of a calibration, and how it is checked
//! when read ([`validate`]).

mod validate;

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

use parcal_kinematics::params::TOOL_OFFSET;
use parcal_kinematics::{N_PARAMS, PARAM_NAMES, ParamCovariance, Params, SCALE_NAMES};

use crate::Point3;
use crate::geometry::GeometryRecord;
use crate::json;
use crate::machine::{Actuator, Machine};
use crate::session::SessionRecord;
use crate::shape;

/// The most parameters a calibration.json may name, and so the most rows
/// and columns of its covariance (the 33 kinematic parameters, 6 scales
/// and 18 per instrument session leave room for 200 sessions).
pub const MAX_PARAMETERS: usize = 4096;
/// The most entries of each diagnostic list a calibration keeps a bounded
/// number of (largest normalised residuals, least controlled
/// observations, weak directions and their dominant parameters, external
/// reliability, systematic tests, variance components, removed
/// observations); parcal writes at most 20.
pub const MAX_LISTED: usize = 100;
/// The most bins of a histogram of calibration.json (parcal writes 48 and
/// 40).
pub const MAX_BINS: usize = 1000;
/// The most sentences of `reasons`, and of `warnings`.
pub const MAX_SENTENCES: usize = 1000;
/// The most iterations calibration.json may record.
pub const MAX_ITERATIONS: usize = 100_000;

/// The identified kinematic parameters, by name (order and names of
/// docs/docs/paper-scenario.md section 2), with their posterior sigmas.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct ParameterTable {
    /// Parameter names, e.g. `y_b2`.
    #[serde(deserialize_with = "shape::bounded::<_, _, MAX_PARAMETERS>")]
    pub names: Vec<String>,
    /// Identified values.
    #[serde(deserialize_with = "shape::bounded::<_, _, MAX_PARAMETERS>")]
    pub values: Vec<f64>,
    /// Posterior standard deviations.
    #[serde(deserialize_with = "shape::bounded::<_, _, MAX_PARAMETERS>")]
    pub sigma: Vec<f64>,
}

/// An identified ball centre (base frame) and the sigma of each coordinate;
/// the identified radius and its sigma when the radius was an unknown.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct CentreEstimate {
    /// Centre.
    #[serde(deserialize_with = "shape::point")]
    pub centre: Point3,
    /// Posterior standard deviation of each coordinate.
    #[serde(deserialize_with = "shape::point")]
    pub sigma: Point3,
    /// Identified radius (mm), when each ball's radius was an unknown.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub radius: Option<f64>,
    /// Its posterior standard deviation (mm).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub radius_sigma: Option<f64>,
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
    #[serde(deserialize_with = "shape::bounded_matrix::<_, MAX_PARAMETERS>")]
    pub covariance: Vec<Vec<f64>>,
    /// Identified ball centres by ball id.
    #[serde(
        deserialize_with = "shape::unique_map",
        serialize_with = "centres_on_threads"
    )]
    pub ball_centres: BTreeMap<String, CentreEstimate>,
    /// The prior used: `"paper"`, `"propagated"` or `"none"`.
    pub prior: String,
    /// One record per iteration.
    #[serde(deserialize_with = "shape::bounded::<_, _, MAX_ITERATIONS>")]
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
    #[serde(
        default,
        skip_serializing_if = "Vec::is_empty",
        deserialize_with = "shape::bounded::<_, _, MAX_PARAMETERS>"
    )]
    pub sessions: Vec<SessionRecord>,
    /// `"accepted"` or `"rejected"` (empty in files written before
    /// verdicts).
    #[serde(default)]
    pub verdict: String,
    /// Why, one sentence each.
    #[serde(default, deserialize_with = "shape::bounded::<_, _, MAX_SENTENCES>")]
    pub reasons: Vec<String>,
    /// Every warning of the run, one sentence each.
    #[serde(default, deserialize_with = "shape::bounded::<_, _, MAX_SENTENCES>")]
    pub warnings: Vec<String>,
    /// The global test of the a-posteriori variance factor.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub global_test: Option<GlobalTestRecord>,
    /// Where the result comes from.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub provenance: Option<Provenance>,
    /// The observations data snooping removed, in the order of removal.
    #[serde(
        default,
        skip_serializing_if = "Vec::is_empty",
        deserialize_with = "shape::bounded::<_, _, MAX_LISTED>"
    )]
    pub removed_observations: Vec<RemovedObservation>,
    /// With a robust loss: the observations it down-weighted (final weight
    /// under 0.1), in the dataset's order.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub down_weighted_observations: Vec<DownWeightedObservation>,
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
    /// The checks behind the verdict, summarised for a report (`None` in
    /// files written before they were recorded).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub diagnostics: Option<Diagnostics>,
}

/// The ball centres, each on one line, formatted on the threads (a
/// calibration has up to 10^5).
fn centres_on_threads<S: serde::Serializer>(
    centres: &BTreeMap<String, CentreEstimate>,
    serializer: S,
) -> std::result::Result<S::Ok, S::Error> {
    let entries: Vec<_> = centres.iter().collect();
    json::serialize_map_on_threads(serializer, entries.len(), json::ELEMENTS_A_WAVE, |k| {
        entries[k]
    })
}

/// What calibration.json keeps of a run's checks: enough for `parcal
/// report` without the dataset, bounded whatever the number of
/// observations.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct Diagnostics {
    /// The variance component of each group of observations.
    #[serde(deserialize_with = "shape::bounded::<_, _, MAX_LISTED>")]
    pub variance_components: Vec<VarianceComponentRecord>,
    /// The observations' tests (absent when the run did not converge).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub observations: Option<ObservationTests>,
    /// Each parameter's prior sigma (`null`: no prior on it), in the order
    /// of `parameters.names`; empty when unknown.
    #[serde(default, deserialize_with = "shape::bounded::<_, _, MAX_PARAMETERS>")]
    pub prior_sigma: Vec<Option<f64>>,
    /// What determined each parameter: `data`, `data and prior`, `prior`,
    /// `prior (not observed)`; empty when unknown.
    #[serde(default, deserialize_with = "shape::bounded::<_, _, MAX_PARAMETERS>")]
    pub determined_by: Vec<String>,
    /// The weakest directions of the parameters, weakest first.
    #[serde(default, deserialize_with = "shape::bounded::<_, _, MAX_LISTED>")]
    pub weak_directions: Vec<WeakDirectionRecord>,
    /// External reliability on the accuracy map: what an undetected error
    /// of one minimal detectable bias in each of the least reliable
    /// observations (largest bias-to-noise ratio first) does to the
    /// parameters and to the registered accuracy map; empty when not
    /// computed.
    #[serde(
        default,
        skip_serializing_if = "Vec::is_empty",
        deserialize_with = "shape::bounded::<_, _, MAX_LISTED>"
    )]
    pub external_reliability: Vec<ExternalReliabilityRecord>,
    /// When the global test rejects a least-squares run, the tests of the
    /// common errors of the entered data that could explain the misfit;
    /// empty otherwise.
    #[serde(
        default,
        skip_serializing_if = "Vec::is_empty",
        deserialize_with = "shape::bounded::<_, _, MAX_LISTED>"
    )]
    pub systematic_tests: Vec<SystematicTestRecord>,
    /// For each common error of the entered data, whatever the global
    /// test said: the smallest its test would detect and what one of that
    /// size that went undetected would do; empty when not computed.
    #[serde(
        default,
        skip_serializing_if = "Vec::is_empty",
        deserialize_with = "shape::bounded::<_, _, MAX_LISTED>"
    )]
    pub systematic_sensitivity: Vec<SystematicSensitivityRecord>,
}

/// How large a common error of the entered data must be for its test to
/// find it (its minimal detectable bias), and what an undetected one of
/// that size does to the parameters and the registered accuracy map.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SystematicSensitivityRecord {
    /// The effect, as in [`SystematicTestRecord`].
    pub effect: String,
    /// The unit of `sigma` and `mdb` (`mm`, `1`).
    pub unit: String,
    /// The standard deviation of the effect's estimate.
    pub sigma: f64,
    /// Its minimal detectable bias: `δ₀ sigma`, the smallest effect its
    /// test finds at `level` with probability `power`.
    pub mdb: f64,
    /// The test's level.
    pub level: f64,
    /// The test's power at `mdb`.
    pub power: f64,
    /// The shift of each kinematic parameter that an undetected effect of
    /// one `mdb` makes (the first of `parameters.names`, their units).
    pub parameter_shift: Vec<f64>,
    /// The registered tool-tip error that shift makes over the accuracy
    /// grid, RMS and max in micrometres (absent without a map).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub map_rms_um: Option<f64>,
    /// See `map_rms_um`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub map_max_um: Option<f64>,
}

/// The test of one common error of the entered data (the w-test of one
/// additional parameter).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SystematicTestRecord {
    /// The effect: `ball radius` (every ball's entered radius off by the
    /// same length), `distance scale` (every calibrated distance off by the
    /// same factor).
    pub effect: String,
    /// The correction of the entered data the residuals ask for: added to
    /// every radius (mm), or `1 + estimate` multiplying every distance.
    pub estimate: f64,
    /// Its standard deviation.
    pub sigma: f64,
    /// The unit of `estimate` and `sigma` (`mm`, `1`).
    pub unit: String,
    /// The test's level.
    pub level: f64,
    /// The critical value of `|estimate / sigma|`.
    pub critical_value: f64,
    /// The a-posteriori variance factor with the effect removed (one more
    /// unknown).
    pub variance_factor_without: f64,
    /// The global test's outcome with the effect removed (`consistent`,
    /// `too large`, `too small`).
    pub outcome_without: String,
}

/// What an undetected error of one minimal detectable bias in one
/// observation's row would do to the calibration.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ExternalReliabilityRecord {
    /// The observation, as in [`ObservationTests`]' lists.
    pub observation: ObservationCheck,
    /// Its row of largest bias-to-noise ratio, 0-based (a pose's leg, a
    /// point's coordinate, a contact's whitened row).
    pub row: usize,
    /// That row's redundancy number.
    pub row_redundancy: f64,
    /// That row's minimal detectable bias, in its standard deviations.
    pub row_mdb_sigmas: f64,
    /// That row's bias-to-noise ratio: the parameters' shift in their own
    /// noise.
    pub bias_to_noise: f64,
    /// The shift of each kinematic parameter (the first of
    /// `parameters.names`, in their order and units: mm, rad).
    #[serde(deserialize_with = "shape::bounded::<_, _, MAX_PARAMETERS>")]
    pub parameter_shift: Vec<f64>,
    /// The registered tool-tip error that shift makes over the accuracy
    /// grid, RMS and max in micrometres (absent without a map).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub map_rms_um: Option<f64>,
    /// See `map_rms_um`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub map_max_um: Option<f64>,
}

/// The variance component `Ω_g / r_g` of one group of observations.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct VarianceComponentRecord {
    /// The group (`ball touches`, `distances`, `poses`, `points`, `priors`).
    pub group: String,
    /// Its weighted sum of squares `Ω_g`.
    pub cost: f64,
    /// Its redundancy `r_g`.
    pub redundancy: f64,
}

/// Every observation's test (Baarda's data snooping), summarised.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ObservationTests {
    /// Observations tested (contacts; rows of poses.csv and points.csv).
    pub tested: usize,
    /// The family-wise level of the test.
    pub level: f64,
    /// The critical value of `|w|` (Bonferroni over `tested`).
    pub critical_value: f64,
    /// The sum of the observations' redundancy numbers.
    pub redundancy: f64,
    /// Redundancy under which an observation counts as uncontrolled.
    pub uncontrolled_below: f64,
    /// How many observations are uncontrolled.
    pub uncontrolled: usize,
    /// The observations of largest `|w|`, largest first (a bounded number).
    #[serde(deserialize_with = "shape::bounded::<_, _, MAX_LISTED>")]
    pub largest: Vec<ObservationCheck>,
    /// The uncontrolled observations of least redundancy, least first (a
    /// bounded number).
    #[serde(deserialize_with = "shape::bounded::<_, _, MAX_LISTED>")]
    pub least_controlled: Vec<ObservationCheck>,
    /// The normalised residuals of every residual row.
    pub normalised_histogram: Histogram,
    /// The redundancy numbers of every observation.
    pub redundancy_histogram: Histogram,
}

/// One observation's test.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ObservationCheck {
    /// Its file (`measurements.csv`, `artefacts.json`, `poses.csv`,
    /// `points.csv`).
    pub file: String,
    /// Its line there, for a CSV file (the header is line 1).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub line: Option<u64>,
    /// Its field, for a JSON file (`distances[3]`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub field: Option<String>,
    /// What it observes: a ball id, a leg, a coordinate.
    pub observes: String,
    /// Its redundancy number.
    pub redundancy: f64,
    /// Its normalised residual `w` (`null`: nothing checks it).
    pub normalised_residual: Option<f64>,
    /// Its estimated gross error `w / √r`, in units of the standard
    /// deviation of what its test sees: a contact's over its redundancy
    /// (tested as one), a pose's or a point's row over that row's, `e / r`
    /// (`null`: nothing checks it).
    pub gross_error_sigmas: Option<f64>,
    /// Its minimal detectable bias at the test's level and 80 % power, in
    /// units of its standard deviation (`null`: nothing checks it).
    pub mdb_sigmas: Option<f64>,
}

/// Counts of values in equal bins `[lower + k width, lower + (k+1) width)`,
/// with those below and above the bins.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct Histogram {
    /// The lower edge of the first bin.
    pub lower: f64,
    /// The width of every bin.
    pub width: f64,
    /// The count of each bin.
    #[serde(deserialize_with = "shape::bounded::<_, _, MAX_BINS>")]
    pub counts: Vec<u64>,
    /// Values below the first bin.
    pub below: u64,
    /// Values at or above the end of the last bin.
    pub above: u64,
}

impl Histogram {
    /// The histogram of `values` in `bins` bins of `width` from `lower`
    /// (values that are not finite count as above).
    pub fn of(values: impl IntoIterator<Item = f64>, lower: f64, width: f64, bins: usize) -> Self {
        let mut histogram = Self {
            lower,
            width,
            counts: vec![0; bins],
            below: 0,
            above: 0,
        };
        values.into_iter().for_each(|v| histogram.add(v));
        histogram
    }

    /// Counts `v` (as above if it is not finite) in bin `⌊x⌋`, `x = (v −
    /// lower) / width`: below when `x < 0`, above unless `x` is less than
    /// the number of bins (an integer, so `⌊x⌋ < n` exactly when `x < n`),
    /// and `x` truncated is `⌊x⌋` in between.
    pub fn add(&mut self, v: f64) {
        let x = (v - self.lower) / self.width;
        if x < 0.0 {
            self.below += 1;
        } else if x < self.counts.len() as f64 {
            self.counts[x as usize] += 1;
        } else {
            self.above += 1;
        }
    }

    /// Every value counted.
    pub fn total(&self) -> u64 {
        self.counts.iter().sum::<u64>() + self.below + self.above
    }
}

/// A weak direction of the parameters: an eigenvalue of the reduced
/// normal matrix and the parameters that dominate its eigenvector.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct WeakDirectionRecord {
    /// The eigenvalue.
    pub eigenvalue: f64,
    /// The sigma it leaves along the direction, `1 / √λ` (`null`: not
    /// identified).
    pub sigma: Option<f64>,
    /// The dominant parameters and their components.
    #[serde(deserialize_with = "shape::bounded::<_, _, MAX_LISTED>")]
    pub dominant: Vec<(String, f64)>,
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
    /// Its estimated gross error when it was removed, as
    /// [`ObservationCheck::gross_error_sigmas`].
    pub gross_error_sigmas: f64,
    /// The a-posteriori variance factor before and after its removal.
    pub variance_factor: [f64; 2],
}

/// An observation a robust loss down-weighted.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct DownWeightedObservation {
    /// Its file (`measurements.csv`, `artefacts.json`, `poses.csv`,
    /// `points.csv`).
    pub file: String,
    /// Its line there, for a CSV file (the header is line 1).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub line: Option<u64>,
    /// Its field, for a JSON file (`distances[3]`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub field: Option<String>,
    /// Its final weight `w(u)`.
    pub weight: f64,
    /// Its scaled residual `u = |e| / √d` at the solution, in units of its
    /// standard deviation.
    pub residual_sigmas: f64,
}

impl Calibration {
    /// Whether the verdict is `"rejected"`.
    pub fn is_rejected(&self) -> bool {
        self.verdict == "rejected"
    }

    /// Whether the data determined the tool: the parameters hold `x_eT,
    /// y_eT, z_eT` (poses of the platform alone do not see it, and it then
    /// keeps the design's coordinates in the platform's canonical frame).
    pub fn calibrates_tool(&self) -> bool {
        let names = &self.parameters.names;
        PARAM_NAMES[TOOL_OFFSET..]
            .iter()
            .all(|tool| names.iter().any(|name| name == tool))
    }

    /// The 33 kinematic parameters and their marginal covariance (the
    /// covariance's leading block), what the tool tip's accuracy maps
    /// take; a calibration with poses or points, or with actuator scales,
    /// has them first and its other unknowns after them. `Err` says why
    /// there are none: a calibration of poses alone, which does not
    /// observe the tool; other parameters; no posterior covariance.
    pub fn kinematic_estimate(&self) -> Result<(Params, ParamCovariance), String> {
        let names = &self.parameters.names;
        // A calibration of poses alone holds the joints and legs but no tool.
        let tool_left_out = names
            .get(..TOOL_OFFSET)
            .is_some_and(|leading| leading == &PARAM_NAMES[..TOOL_OFFSET])
            && !self.calibrates_tool();
        if tool_left_out {
            return Err(format!(
                "the calibration did not calibrate the tool ({}, {}, {}: its data, poses alone, do not observe it); the accuracy maps are of the tool tip: calibrate with points or ball touches",
                PARAM_NAMES[N_PARAMS - 3],
                PARAM_NAMES[N_PARAMS - 2],
                PARAM_NAMES[N_PARAMS - 1]
            ));
        }
        if names.len() < N_PARAMS || !names.iter().zip(PARAM_NAMES).all(|(a, b)| a == b) {
            return Err(format!(
                "expected the {N_PARAMS} kinematic parameters {} .. {} first, in that order, found {} parameters ({})",
                PARAM_NAMES[0],
                PARAM_NAMES[N_PARAMS - 1],
                names.len(),
                names.iter().take(3).cloned().collect::<Vec<_>>().join(", ")
            ));
        }
        if !(self.converged && self.covariance.len() == names.len()) {
            return Err(format!(
                "the calibration has no posterior covariance (status: {})",
                self.status
            ));
        }
        let values = &self.parameters.values;
        let covariance = ParamCovariance::from_fn(|i, j| self.covariance[i][j]);
        Ok((Params::from_column_slice(&values[..N_PARAMS]), covariance))
    }

    /// The actuators as the calibrated machine states them
    /// (`machine.actuator`), else as the design does (`design.actuator`);
    /// `None` when the file has neither. The scales to apply are
    /// [`Self::calibrated_scales`].
    pub fn actuator(&self) -> Option<&Actuator> {
        self.machine
            .as_ref()
            .map(|m| &m.actuator)
            .or(self.design.as_ref().map(|d| &d.actuator))
    }

    /// The actuators' calibrated scales (mm per unit): the parameters
    /// `s_1..s_6` when the calibration identified them (they are the
    /// estimates `machine` copies), else [`Self::actuator`]'s, else 1 (the
    /// millimetres of [`Self::actuator_unit`]).
    pub fn calibrated_scales(&self) -> [f64; 6] {
        let p = &self.parameters;
        let estimated = SCALE_NAMES.map(|name| {
            let k = p.names.iter().position(|known| known == name)?;
            p.values.get(k).copied()
        });
        if estimated.iter().all(Option::is_some) {
            estimated.map(Option::unwrap_or_default)
        } else {
            self.actuator().map_or([1.0; 6], |a| a.scale)
        }
    }

    /// The unit the actuators read in ([`Self::actuator`]'s; millimetres
    /// when the file has none).
    pub fn actuator_unit(&self) -> &str {
        self.actuator().map_or("mm", |a| a.unit.as_str())
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

/// What [`Provenance::dataset`] names a dataset built in memory by.
pub const IN_MEMORY: &str = "(in memory)";

/// Where a calibration comes from.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Provenance {
    /// The parcal version that computed it.
    pub parcal_version: String,
    /// The dataset as it was given (a directory or a snapshot), or
    /// [`IN_MEMORY`].
    pub dataset: String,
    /// The dataset's checksum ([`crate::Dataset::checksum`], a
    /// mechanism's [`crate::mechanism::MechanismDataset::checksum`]).
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_histogram_counts_each_value_once_in_its_bin() {
        // Bins [-1, -0.5), [-0.5, 0), [0, 0.5), [0.5, 1): edges go up.
        let h = Histogram::of(
            [-2.0, -1.0, -0.5, -0.1, 0.0, 0.99, 1.0, f64::NAN],
            -1.0,
            0.5,
            4,
        );
        assert_eq!(h.counts, [1, 2, 1, 1]);
        assert_eq!((h.below, h.above), (1, 2));
        assert_eq!(h.total(), 8);
    }

    /// Each value goes where its bin `⌊(v − lower) / width⌋` says: at and
    /// about every edge, at `±0`, far out and not finite.
    #[test]
    fn a_value_goes_to_the_bin_of_its_floor() {
        let (lower, width, bins) = (-4.0, 0.25, 32);
        let by_floor = |v: f64| {
            let k = ((v - lower) / width).floor();
            match k {
                k if k < 0.0 => None,
                k if k < bins as f64 => Some(k as usize),
                _ => Some(bins),
            }
        };
        let mut values = vec![0.0, -0.0, 1e300, -1e300, f64::INFINITY, f64::NEG_INFINITY];
        for k in -3..=bins as i32 + 3 {
            let edge = lower + f64::from(k) * width;
            values.extend([edge, edge.next_down(), edge.next_up(), edge + 0.1 * width]);
        }
        for v in values {
            let h = Histogram::of([v], lower, width, bins);
            let bin = match (h.below, h.above) {
                (1, 0) => None,
                (0, 1) => Some(bins),
                _ => h.counts.iter().position(|&c| c == 1),
            };
            assert_eq!(bin, by_floor(v), "{v:e}");
            assert_eq!(h.total(), 1, "{v:e}");
        }
    }
}
