//! A mechanism plan: from the starting covariance of the unknowns (a
//! calibration's, or the design's prior alone), the candidates' rows
//! ([`super::information`]) and the greedy selection ([`super::greedy`]),
//! the measurements to make and the predicted sigma of every parameter
//! before and after them. The picks come in stages
//! ([`super::candidate::Stage`]): the machine's own measurements, then
//! heights measured by hand, then part distances, each stage from the
//! covariance the stages before leave: each then gains what the probe
//! heights could not give.
//!
//! Everything is linearised at one point: the calibration's estimate, or
//! the design (the priors' means), with the controller running its
//! configured parameters. The sigmas are those the calibration would
//! report, in the mechanism's canonical frame: `√diag(T C Tᵀ)` with `T`
//! the canonical frame's derivative (`parcal_calibrate::mechanism::frame`,
//! which removes the gauge freedoms), and the criterion is the trace of
//! the chosen group's block of `T C Tᵀ`. From the prior alone, what the
//! planned measurements leave to the prior is stated as a calibration
//! states it (`parcal_calibrate::mechanism::identifiability`): the
//! combinations the measurements alone would determine worse than the
//! prior does, and the parameters whose sigma stays within 0.9 of the
//! prior's.

use nalgebra::{DMatrix, DVector};
use parcal_calibrate::mechanism::frame::canonical;
use parcal_calibrate::mechanism::identifiability::{Inputs, gauge_directions, identifiability};
use parcal_calibrate::mechanism::prior::prior_covariance;
use parcal_calibrate::mechanism::{MechanismData, TRIGGER_HEIGHT};
use parcal_dataset::bounds::check_product;
use parcal_dataset::mechanism::{MechanismCalibrationRecord, Noise};
use parcal_kinematics::mechanism::Mechanism;

use super::candidate::{Candidate, Counts, Stage};
use super::greedy::{group_trace, select};
use super::information::{Linearisation, RowsError, whitened_rows};
use crate::DesignError;
use crate::bounds::{MAX_MECHANISM_EVALUATIONS, MEASUREMENTS};

/// The most candidates of a plan.
pub const MAX_CANDIDATES: usize = 100_000;

/// A sigma after at least this fraction of the sigma before: the plan
/// leaves the parameter as it was (the calibration's bound for "set by
/// its prior").
const UNCHANGED: f64 = 0.9;

/// Where a plan starts from instead of the prior: a calibration's
/// estimate and covariance (canonical frame), over the mechanism's
/// parameters and, if it had probe heights, the trigger height.
#[derive(Debug, Clone, PartialEq)]
pub struct Start {
    /// The estimate.
    pub values: Vec<f64>,
    /// Its covariance.
    pub covariance: DMatrix<f64>,
}

/// The parameters a plan is linearised at: a calibration's estimate
/// (`start`) if it starts from one, the priors' means of `data` otherwise.
pub fn linearisation_point(data: &MechanismData, start: Option<&Start>) -> Vec<f64> {
    match start {
        Some(start) => start.values[..data.mechanism.parameters().len()].to_vec(),
        None => data.priors.iter().map(|p| p.mean).collect(),
    }
}

impl Start {
    /// The start of a calibration record of `mechanism`: its parameters in
    /// the mechanism's order, then optionally the trigger height, with
    /// their covariance.
    pub fn from_record(
        record: &MechanismCalibrationRecord,
        mechanism: &dyn Mechanism,
    ) -> Result<Self, DesignError> {
        let refused = |reason: String| {
            Err(DesignError::Options(format!(
                "the calibration of a {}: {reason}",
                record.mechanism
            )))
        };
        if record.mechanism != mechanism.name() {
            return refused(format!("the dataset's mechanism is a {}", mechanism.name()));
        }
        let names: Vec<&str> = mechanism
            .parameters()
            .iter()
            .map(|p| p.name.as_str())
            .collect();
        let recorded: Vec<&str> = record.parameters.iter().map(|p| p.name.as_str()).collect();
        let with_trigger: Vec<&str> = names.iter().copied().chain([TRIGGER_HEIGHT]).collect();
        if recorded != names && recorded != with_trigger {
            return refused(format!(
                "its parameters {recorded:?} are not the mechanism's {names:?} (then {TRIGGER_HEIGHT})"
            ));
        }
        let Some(rows) = &record.covariance else {
            return refused("it has no covariance (the fit did not give one)".into());
        };
        let g = recorded.len();
        Ok(Self {
            values: record.parameters.iter().map(|p| p.value).collect(),
            covariance: DMatrix::from_fn(g, g, |i, j| rows[i][j]),
        })
    }
}

/// What a plan is asked.
#[derive(Debug, Clone)]
pub struct PlanRequest<'a> {
    /// The mechanism, the controller's parameters, the priors (means and
    /// sigmas) and the trigger height's.
    pub data: &'a MechanismData,
    /// The noise of each kind of measurement planned.
    pub noise: Noise,
    /// A calibration to start from; `None`: the prior alone.
    pub start: Option<Start>,
    /// The candidates.
    pub candidates: &'a [Candidate],
    /// The parameter group whose covariance's trace is minimised (or
    /// [`TRIGGER_GROUP`]).
    pub group: &'a str,
    /// How many of each stage's candidates to plan.
    pub counts: Counts,
}

/// The group of the trigger height, an unknown of a plan with probe
/// heights: a plan may minimise its variance.
pub const TRIGGER_GROUP: &str = "trigger height";

/// The largest sigma a plan takes for a measurement by hand (mm).
const MAX_SIGMA: f64 = 1.0;

/// machine.json's `noise` with the sigmas of the heights measured by hand
/// and of the part distances a plan is given instead (mm; a dataset
/// without such measurements yet states none); an error names a sigma
/// outside `(0, 1]` by `names` (the front end's words for the two).
pub fn with_sigmas(
    mut noise: Noise,
    [heights, distances]: [Option<f64>; 2],
    names: [&str; 2],
) -> Result<Noise, DesignError> {
    for ((sigma, name), slot) in [heights, distances]
        .into_iter()
        .zip(names)
        .zip([&mut noise.height, &mut noise.distance])
    {
        if let Some(sigma) = sigma {
            if !(sigma > 0.0 && sigma <= MAX_SIGMA) {
                return Err(DesignError::Options(format!(
                    "{name} must be in (0, {MAX_SIGMA}] mm, got {sigma}"
                )));
            }
            *slot = Some(sigma);
        }
    }
    Ok(noise)
}

/// The parameter group a plan of `counts` minimises unless asked another:
/// the trigger height's ([`TRIGGER_GROUP`]) for heights measured by hand
/// alone after a calibration that has it among its unknowns (`start`),
/// what such heights determine; else a linear delta's diagonal rods (what
/// probe heights see least), a cable robot's anchors, another mechanism's
/// first parameter's group.
pub fn default_group(
    mechanism: &dyn Mechanism,
    counts: Counts,
    start: Option<&Start>,
) -> &'static str {
    let heights_alone = counts.heights == counts.total();
    let n = mechanism.parameters().len();
    if heights_alone && start.is_some_and(|s| s.values.len() > n) {
        return TRIGGER_GROUP;
    }
    match mechanism.name() {
        "linear delta" => "diagonal rods",
        "cable robot" => "anchors",
        _ => mechanism.parameters()[0].group,
    }
}

/// One parameter's predicted sigma.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct PlannedParameter {
    /// Its name (the mechanism's, or `trigger_height`).
    pub name: String,
    /// Its unit.
    pub unit: String,
    /// Its group.
    pub group: String,
    /// Its prior sigma, if it has a prior.
    pub prior_sigma: Option<f64>,
    /// Its sigma before the planned measurements (canonical frame).
    pub before: f64,
    /// And after them.
    pub after: f64,
}

/// A plan (module doc).
#[derive(Debug, Clone, PartialEq)]
pub struct MechanismPlan {
    /// The mechanism's name.
    pub mechanism: String,
    /// The group minimised.
    pub group: String,
    /// Whether it starts from a calibration (else the prior).
    pub from_calibration: bool,
    /// The number of feasible candidates.
    pub feasible: usize,
    /// The trigger height the probes are planned at (mm).
    pub trigger_height: f64,
    /// The measurements chosen, in the order picked, each with the
    /// group's trace after it.
    pub picks: Vec<(Candidate, f64)>,
    /// The group's trace before.
    pub trace_before: f64,
    /// Every unknown's sigma before and after.
    pub parameters: Vec<PlannedParameter>,
    /// What the plan leaves to the prior, in words.
    pub statements: Vec<String>,
}

impl MechanismPlan {
    /// The group's trace after the whole plan.
    pub fn trace_after(&self) -> f64 {
        self.picks.last().map_or(self.trace_before, |p| p.1)
    }
}

/// The starting point: the unknowns' values (parameters, then the
/// trigger height if `trigger`) and covariance.
fn starting_point(
    request: &PlanRequest,
    trigger: bool,
) -> Result<(DVector<f64>, DMatrix<f64>), DesignError> {
    let data = request.data;
    let mechanism = data.mechanism.as_ref();
    let n = mechanism.parameters().len();
    let trigger_variance = || {
        data.trigger_height.sigma.map(|s| s * s).ok_or_else(|| {
            DesignError::Options(
                "the trigger height has no prior sigma (machine.json's trigger_height.sigma): probe heights cannot be planned without it"
                    .into(),
            )
        })
    };
    match &request.start {
        Some(start) => {
            let recorded = start.values.len();
            let g = if trigger { n + 1 } else { recorded };
            let mut values = DVector::from_element(g, data.trigger_height.mean);
            values.rows_mut(0, recorded).copy_from_slice(&start.values);
            let mut covariance = DMatrix::zeros(g, g);
            covariance
                .view_mut((0, 0), (recorded, recorded))
                .copy_from(&start.covariance);
            if g > recorded {
                covariance[(n, n)] = trigger_variance()?;
            }
            Ok((values, covariance))
        }
        None => {
            let g = n + usize::from(trigger);
            let mut values = DVector::from_element(g, data.trigger_height.mean);
            for (k, (prior, parameter)) in
                data.priors.iter().zip(mechanism.parameters()).enumerate()
            {
                if prior.sigma.is_none() {
                    return Err(DesignError::Options(format!(
                        "parameter {} has no prior (machine.json's tolerances): plan after a calibration (--after)",
                        parameter.name
                    )));
                }
                values[k] = prior.mean;
            }
            // The parameters' prior, correlated if the data say so.
            let mut covariance = DMatrix::zeros(g, g);
            covariance
                .view_mut((0, 0), (n, n))
                .copy_from(&prior_covariance(data).view((0, 0), (n, n)));
            if trigger {
                covariance[(n, n)] = trigger_variance()?;
            }
            Ok((values, covariance))
        }
    }
}

/// Checks the request's counts and group before any work.
fn check(request: &PlanRequest) -> Result<(), DesignError> {
    let options = |reason: String| Err(DesignError::Options(reason));
    MEASUREMENTS
        .check(
            "measurements, manual heights and part distances",
            request.counts.total(),
        )
        .map_err(DesignError::Options)?;
    let candidates = request.candidates.len();
    if candidates == 0 || candidates > MAX_CANDIDATES {
        return options(format!("{candidates} candidates: 1 to {MAX_CANDIDATES}"));
    }
    for stage in Stage::ALL {
        let count = request.counts.of(stage);
        let offered = request.candidates.iter().any(|c| c.stage() == stage);
        if count > 0 && !offered {
            return options(format!(
                "{count} {} asked, and no candidate of them",
                stage.name()
            ));
        }
    }
    let mechanism = request.data.mechanism.as_ref();
    let mut groups: Vec<&str> = mechanism.parameters().iter().map(|p| p.group).collect();
    groups.dedup();
    if has_trigger_height(request) {
        groups.push(TRIGGER_GROUP);
    }
    if !groups.contains(&request.group) {
        return options(format!(
            "the {} has no parameter group {:?} (its groups: {})",
            mechanism.name(),
            request.group,
            groups.join(", ")
        ));
    }
    Ok(())
}

/// Whether the trigger height is among a plan's unknowns: probe heights
/// are offered, or the calibration it starts from had them.
fn has_trigger_height(request: &PlanRequest) -> bool {
    let n = request.data.mechanism.parameters().len();
    request
        .candidates
        .iter()
        .any(|c| matches!(c, Candidate::Probe(_)))
        || request.start.as_ref().is_some_and(|s| s.values.len() > n)
}

/// Plans `request` (module doc).
pub fn plan_mechanism(request: &PlanRequest) -> Result<MechanismPlan, DesignError> {
    check(request)?;
    let data = request.data;
    let mechanism = data.mechanism.as_ref();
    let parameters = mechanism.parameters();
    let n = parameters.len();
    let probes = request
        .candidates
        .iter()
        .any(|c| matches!(c, Candidate::Probe(_)));
    let (values, covariance) = starting_point(request, probes)?;
    let g = values.len();
    let params = &values.as_slice()[..n];
    let trigger_height = if g > n {
        values[n]
    } else {
        data.trigger_height.mean
    };
    let failed =
        |e: &dyn std::fmt::Display| DesignError::Options(format!("{}: {e}", mechanism.name()));
    let scale: Vec<f64> = data.priors.iter().map(|p| p.sigma.unwrap_or(1.0)).collect();
    let transform = canonical(mechanism, &values, None, &scale)
        .map_err(|e| failed(&e))?
        .transform;
    let group_of = |k: usize| parameters.get(k).map_or(TRIGGER_GROUP, |p| p.group);
    let group: Vec<usize> = (0..g).filter(|&k| group_of(k) == request.group).collect();
    let objective = transform.select_rows(&group);
    let at = Linearisation {
        params,
        configured: &data.configured,
        trigger_height,
        unknowns: g,
    };
    let rows = request
        .candidates
        .iter()
        .map(|candidate| {
            let reach = if candidate.is_commanded() {
                &data.configured[..]
            } else {
                params
            };
            let feasible = candidate
                .positions(trigger_height)
                .iter()
                .all(|position| mechanism.check_feasible(reach, position).is_ok());
            if !feasible {
                return Ok(None);
            }
            match whitened_rows(mechanism, &at, &request.noise, candidate) {
                Ok(m) => Ok(Some(m)),
                Err(RowsError::Mechanism(_)) => Ok(None),
                Err(other) => Err(DesignError::Options(other.to_string())),
            }
        })
        .collect::<Result<Vec<_>, DesignError>>()?;
    let feasible = rows.iter().flatten().count();
    check_product(
        &[
            ("measurements", request.counts.total()),
            ("feasible candidates", feasible),
        ],
        MAX_MECHANISM_EVALUATIONS,
        "candidate evaluations",
    )
    .map_err(DesignError::Options)?;
    // Stage by stage, each from what the stages before leave.
    let mut after = covariance.clone();
    let mut picks = Vec::with_capacity(request.counts.total());
    for stage in Stage::ALL {
        let count = request.counts.of(stage);
        if count == 0 {
            continue;
        }
        let of_stage: Vec<Option<DMatrix<f64>>> = rows
            .iter()
            .zip(request.candidates)
            .map(|(m, c)| m.clone().filter(|_| c.stage() == stage))
            .collect();
        let offered = request
            .candidates
            .iter()
            .filter(|c| c.stage() == stage)
            .count();
        let (chosen, left) = select(&after, &of_stage, &objective, count).ok_or_else(|| {
            DesignError::Options(format!(
                "none of the {offered} candidate {} is feasible for the {} (outside its limits, or singular)",
                stage.name(),
                mechanism.name()
            ))
        })?;
        picks.extend(chosen);
        after = left;
    }
    let sigmas = |c: &DMatrix<f64>| -> Vec<f64> {
        let canonical = &transform * c * transform.transpose();
        (0..g).map(|k| canonical[(k, k)].max(0.0).sqrt()).collect()
    };
    let (before, after_sigmas) = (sigmas(&covariance), sigmas(&after));
    let planned: Vec<PlannedParameter> = (0..g)
        .map(|k| {
            let (name, unit, group, prior_sigma) = match parameters.get(k) {
                Some(p) => (p.name.clone(), &*p.unit, p.group, data.priors[k].sigma),
                None => (
                    TRIGGER_HEIGHT.to_string(),
                    "mm",
                    TRIGGER_GROUP,
                    data.trigger_height.sigma,
                ),
            };
            PlannedParameter {
                name,
                unit: unit.to_string(),
                group: group.to_string(),
                prior_sigma,
                before: before[k],
                after: after_sigmas[k],
            }
        })
        .collect();
    let statements = if request.start.is_none() {
        let names: Vec<String> = planned.iter().map(|p| p.name.clone()).collect();
        // Every unknown has a prior here (`starting_point`), validated
        // positive definite.
        let prior_information = covariance
            .clone()
            .cholesky()
            .ok_or_else(|| failed(&"the prior covariance is not positive definite"))?
            .inverse();
        let gauge = gauge_directions(mechanism, params, g).map_err(|e| failed(&e))?;
        identifiability(&Inputs {
            names: &names,
            covariance: &after,
            prior_information: &prior_information,
            prior_covariance: &covariance,
            canonical: &transform,
            gauge: &gauge,
        })
        .map(|found| found.statements)
        .unwrap_or_default()
    } else {
        unchanged(&planned)
    };
    Ok(MechanismPlan {
        mechanism: mechanism.name().to_string(),
        group: request.group.to_string(),
        from_calibration: request.start.is_some(),
        feasible,
        trigger_height,
        trace_before: group_trace(&covariance, &objective),
        picks: picks
            .iter()
            .map(|p| (request.candidates[p.candidate], p.trace_after))
            .collect(),
        parameters: planned,
        statements,
    })
}

/// The parameters a plan after a calibration leaves as they were.
fn unchanged(planned: &[PlannedParameter]) -> Vec<String> {
    let named: Vec<String> = planned
        .iter()
        .filter(|p| p.before > 0.0 && p.after >= UNCHANGED * p.before)
        .map(|p| format!("{} ({:.2})", p.name, p.after / p.before))
        .collect();
    if named.is_empty() {
        Vec::new()
    } else {
        vec![format!(
            "the planned measurements leave these as the calibration has them (sigma after over before): {}",
            named.join(", ")
        )]
    }
}
