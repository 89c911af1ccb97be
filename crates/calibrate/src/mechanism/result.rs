//! A mechanism calibration's result ([`MechanismCalibration`]), assembled
//! from one fit: the estimate in the canonical frame ([`super::frame`]),
//! the w-tests and the global test with the verdict the hexapod's
//! calibrations give ([`crate::verdict`], [`crate::reliability`]'s
//! critical value), and what the data determine
//! ([`super::identifiability`]).

use nalgebra::{DMatrix, DVector, Isometry3, Matrix6};
use parcal_dataset::mechanism::LineElasticity;
use parcal_solver::Status;

use crate::hypothesis::{critical_value, estimated_gross_error};
use crate::options::Observation;
use crate::run_away::RunAway;
use crate::snooping::{Removal, Worst};
use crate::verdict::{GlobalTest, Outcome, Verdict};

use super::checks::ObservationChecks;
use super::data::{MechanismData, ParameterPrior, Repeat};
use super::error::MechanismCalibrationError;
use super::fit::Fit;
use super::frame::{canonical_by, canonical_params};
use super::identifiability::{Identifiability, Inputs, gauge_directions, identifiability};
use super::mirror::MirroredBall;
use super::observation::ObservationRef;
use super::options::MechanismOptions;
use super::prior::prior_covariance;

pub use parcal_dataset::mechanism::TRIGGER_HEIGHT;

/// One estimated unknown: a parameter of the mechanism, or the trigger
/// height.
#[derive(Debug, Clone, PartialEq)]
pub struct EstimatedParameter {
    /// Its name (the mechanism's, or [`TRIGGER_HEIGHT`]).
    pub name: String,
    /// Its unit.
    pub unit: String,
    /// Its group (the mechanism's, or `probe`).
    pub group: String,
    /// Its estimate in the canonical frame.
    pub value: f64,
    /// Its standard deviation there, when the fit gave a covariance.
    pub sigma: Option<f64>,
    /// Its prior, as given.
    pub prior: ParameterPrior,
}

/// A calibrated ball as the calibration located it.
#[derive(Debug, Clone, PartialEq)]
pub struct EstimatedBall {
    /// Its centre (mm, the fit's frame: that of the commanded positions).
    pub centre: [f64; 3],
    /// Its coordinates' standard deviations, when the solver gave them.
    pub centre_sigma: Option<[f64; 3]>,
    /// Its radius: the estimate when it had a calibration sigma, else its
    /// calibrated value.
    pub radius: f64,
    /// The radius's standard deviation (`None`: exact, or the fit gave no
    /// covariance).
    pub radius_sigma: Option<f64>,
}

/// A tracker's frame as the calibration located it.
#[derive(Debug, Clone, PartialEq)]
pub struct EstimatedTracker {
    /// Its label.
    pub label: String,
    /// `F`, from the mechanism's canonical frame to the tracker's (mm).
    pub frame: Isometry3<f64>,
    /// The covariance of its correction `C = (Exp(ω), τ)`, `F = F₀ ∘ C`
    /// ([`parcal_observe::mechanism::TrackerPoint`]): of `ω_x, ω_y, ω_z`
    /// (rad, about the mechanism's axes) and `τ_x, τ_y, τ_z` (mm), when
    /// the fit gave one. To first order, the error `F_true⁻¹ ∘ F` as a
    /// rotation vector and a translation has this covariance.
    pub covariance: Option<Matrix6<f64>>,
    /// The actuators' zero offsets while it measured, with their standard
    /// deviations when the fit gave them (the actuators' unit); empty for
    /// a tracker without offsets.
    pub offsets: Vec<(f64, Option<f64>)>,
    /// The body frame its poses saw, where the body was turned or moved
    /// before it measured (`C_B,k = (Exp(ω_B + φ), τ_B + ρ)`).
    pub body: Option<EstimatedBody>,
}

impl EstimatedTracker {
    /// The standard deviations of its correction's six values (rad, mm).
    pub fn sigma(&self) -> Option<[f64; 6]> {
        correction_sigma(self.covariance.as_ref())
    }
}

/// The body frame the tracker poses saw, as the calibration located it.
#[derive(Debug, Clone, PartialEq)]
pub struct EstimatedBody {
    /// `B`, from the body's frame to the platform's (mm).
    pub frame: Isometry3<f64>,
    /// The covariance of its correction `C = (Exp(ω), τ)`, `B = C ∘ B₀`
    /// ([`parcal_observe::mechanism::BodyFrame`]): of `ω_x, ω_y, ω_z` (rad)
    /// and `τ_x, τ_y, τ_z` (mm), when the fit gave one.
    pub covariance: Option<Matrix6<f64>>,
}

impl EstimatedBody {
    /// The standard deviations of its correction's six values (rad, mm).
    pub fn sigma(&self) -> Option<[f64; 6]> {
        correction_sigma(self.covariance.as_ref())
    }
}

/// The standard deviations of a frame correction's six values from their
/// covariance, if given (a rounding-negative variance as zero).
fn correction_sigma(covariance: Option<&Matrix6<f64>>) -> Option<[f64; 6]> {
    covariance.map(|c| std::array::from_fn(|k| c[(k, k)].max(0.0).sqrt()))
}

/// The calibration of a mechanism.
#[derive(Debug, Clone, PartialEq)]
#[non_exhaustive]
pub struct MechanismCalibration {
    /// The mechanism's name.
    pub mechanism: String,
    /// A printer's printable radius (mm), that of the data
    /// ([`MechanismData::print_radius`](super::MechanismData)).
    pub print_radius: Option<f64>,
    /// A cable robot's elastic lines, those of the data's mechanism
    /// ([`LineElasticity::of`]).
    pub elasticity: Option<LineElasticity>,
    /// The mechanism's parameters, then the trigger height when there were
    /// probe heights: values and sigmas in the canonical frame.
    pub parameters: Vec<EstimatedParameter>,
    /// Their covariance in the canonical frame (rank: unknowns less gauge
    /// freedoms), when the fit gave one.
    pub covariance: Option<DMatrix<f64>>,
    /// The correlation of the mechanism's parameters' priors (`None`:
    /// independent; [`super::prior`]).
    pub prior_correlation: Option<DMatrix<f64>>,
    /// The poses of the point samples (the fit's frame), in the order of
    /// the remaining samples.
    pub poses: Vec<[f64; 3]>,
    /// The calibrated balls, in the data's order.
    pub balls: Vec<EstimatedBall>,
    /// The trackers' frames, in the data's order.
    pub trackers: Vec<EstimatedTracker>,
    /// The body frame, when there were tracker poses.
    pub body: Option<EstimatedBody>,
    /// The observation equation of the ball touches (paper eq. 9 or 10);
    /// `None` without touches.
    pub observation: Option<Observation>,
    /// How the solver ended.
    pub status: Status,
    /// Its linear solves.
    pub iterations: usize,
    /// Every remaining observation's residuals, redundancy numbers and
    /// normalised residuals (named by their place in the data given), at
    /// a least-squares minimum; empty elsewhere.
    pub observations: ObservationChecks,
    /// The global test, at a least-squares minimum with redundancy.
    pub global_test: Option<GlobalTest>,
    /// The critical value of the w-tests (family-wise `α` over
    /// [`Self::tests`], Bonferroni).
    pub critical_value: f64,
    /// The number of data rows.
    pub data_rows: usize,
    /// The w-tests' family: one test per data row, a ball touch's three
    /// coordinate rows one test (their `|w|` are equal but for the angle
    /// prior's share, as the hexapod's own calibration counts them).
    pub tests: usize,
    /// The level `α` of the tests.
    pub alpha: f64,
    /// The verdict.
    pub verdict: Verdict,
    /// Why, in words.
    pub reasons: Vec<String>,
    /// The observations that repeat an earlier one in every number
    /// ([`Observations::repeats`](super::Observations::repeats)), named by
    /// their place in the data given.
    pub repeats: Vec<Repeat>,
    /// What else the data showed, in words: [`Self::repeats`] (not the
    /// verdict's).
    pub warnings: Vec<String>,
    /// The balls found on the wrong side of their touches once the fit had
    /// settled, re-seeded at the mirror image of their centre fit before
    /// it resumed.
    pub mirrored: Vec<MirroredBall>,
    /// When this is the Levenberg-Marquardt fit made after a Gauss-Newton
    /// fit ran away ([`RunAway`]): how that one ended.
    pub gauss_newton: Option<RunAway>,
    /// The observations data snooping removed, in order.
    pub removals: Vec<Removal<ObservationRef>>,
    /// Why snooping stopped before every observation passed, if it did.
    pub snooping_stopped: Option<String>,
    /// What the data determine, when the fit gave a covariance.
    pub identifiability: Option<Identifiability>,
}

impl MechanismCalibration {
    /// The estimated values, in the order of [`Self::parameters`].
    pub fn values(&self) -> DVector<f64> {
        DVector::from_iterator(
            self.parameters.len(),
            self.parameters.iter().map(|p| p.value),
        )
    }

    /// The estimate of the unknown named `name`.
    pub fn parameter(&self, name: &str) -> Option<&EstimatedParameter> {
        self.parameters.iter().find(|p| p.name == name)
    }

    /// Whether the solver converged.
    pub fn converged(&self) -> bool {
        matches!(self.status, Status::Converged)
    }

    /// The verdict's reasons made again with each observation, and the
    /// row of it a test names, named by `place` (a front end's file and
    /// line: `probes.csv line 5 (probe height 3, row 0)`) instead of its
    /// kind and index (`probe height 3 (row 0)`).
    pub fn place_observations(&mut self, place: &dyn Fn(ObservationRef, Option<usize>) -> String) {
        self.reasons = reasons(self, place);
        self.warnings = repeat_warnings(&self.repeats, place);
    }

    /// The observation of largest `|w|`.
    pub fn worst(&self) -> Option<Worst<ObservationRef>> {
        worst(&self.observations)
    }

    /// The a-posteriori variance factor (NaN without a global test).
    pub fn variance_factor(&self) -> f64 {
        self.global_test.map_or(f64::NAN, |t| t.variance_factor)
    }
}

/// The result of `fit` of `data` with `options` (module doc); its
/// observations still named by their place in `data`.
pub(crate) fn assemble(
    data: &MechanismData,
    fit: Fit,
    options: &MechanismOptions,
) -> Result<MechanismCalibration, MechanismCalibrationError> {
    let mechanism = data.mechanism.as_ref();
    let n = data.configured.len();
    let kinematics = |source| MechanismCalibrationError::Kinematics {
        mechanism: mechanism.name().to_string(),
        source,
    };
    // The mechanism's parameters, and the trackers' frames when they
    // follow a gauge's motion, differentiated.
    let map = |global: &[f64]| {
        let mut values = canonical_params(mechanism, global, n)?;
        let moved = values.rows(0, n).into_owned();
        (fit.trackers).follow(data, &global[..n], moved.as_slice(), &mut values)?;
        Ok(values)
    };
    let gauge_moves_frames = !data.observations.trackers.is_empty()
        && !mechanism
            .gauge_freedoms(&fit.global.as_slice()[..n])
            .map_err(kinematics)?
            .is_empty();
    let mut scale: Vec<f64> = data.priors.iter().map(|p| p.sigma.unwrap_or(1.0)).collect();
    if gauge_moves_frames {
        scale.resize(fit.global.len(), 1.0);
    }
    let frame = canonical_by(&map, &fit.global, fit.covariance.as_ref(), &scale)?;
    let mut described: Vec<(String, &str, &str, ParameterPrior)> = mechanism
        .parameters()
        .iter()
        .zip(&data.priors)
        .map(|(p, prior)| (p.name.clone(), &*p.unit, p.group, *prior))
        .collect();
    if data.has_trigger_height() {
        described.push((
            TRIGGER_HEIGHT.to_string(),
            "mm",
            "probe",
            data.trigger_height,
        ));
    }
    let estimated = described.len();
    let sigma = |k: usize| marginal_sigma(frame.covariance.as_ref(), k);
    let trackers = tracker_estimates(data, &fit, &frame.values, frame.covariance.as_ref());
    let body = body_estimate(&fit, None, &frame.values, frame.covariance.as_ref());
    let parameters: Vec<EstimatedParameter> = described
        .into_iter()
        .enumerate()
        .map(|(k, (name, unit, group, prior))| EstimatedParameter {
            name,
            unit: unit.to_string(),
            group: group.to_string(),
            value: frame.values[k],
            sigma: sigma(k),
            prior,
        })
        .collect();
    let g = fit.global.len();
    let gauge = gauge_directions(mechanism, &fit.global.as_slice()[..n], g)?;
    let names: Vec<String> = (parameters.iter().map(|p| p.name.clone()))
        .chain(data.observations.trackers.iter().flat_map(|tracker| {
            let label = &tracker.label;
            FRAME_AXES.map(|axis| format!("tracker {label} {axis}"))
        }))
        .chain(data.observations.trackers.iter().flat_map(|tracker| {
            let offsets = if tracker.rehomed {
                mechanism.actuators().len()
            } else {
                0
            };
            (1..=offsets).map(move |i| format!("tracker {} offset q{i}", tracker.label))
        }))
        .chain(
            (fit.trackers.body_columns().iter())
                .flat_map(|_| FRAME_AXES.map(|axis| format!("body {axis}"))),
        )
        .chain(data.observations.trackers.iter().flat_map(|tracker| {
            let label = &tracker.label;
            let (rotation, origin) = FRAME_AXES.split_at(3);
            let turned = rotation.iter().filter(|_| tracker.body_turned);
            let moved = origin.iter().filter(|_| tracker.body_moved);
            (turned.chain(moved)).map(move |axis| format!("tracker {label} body {axis}"))
        }))
        .collect();
    let estimated_balls = fit
        .centres
        .iter()
        .enumerate()
        .map(|(b, centre)| EstimatedBall {
            centre: *centre,
            centre_sigma: fit.centre_sigmas.as_ref().map(|s| s[b]),
            radius: fit.radii[b],
            radius_sigma: fit.radius_sigmas.as_ref().and_then(|s| s[b]),
        })
        .collect();
    let identifiability = fit.covariance.as_ref().and_then(|covariance| {
        let mut identifiability = identifiability(&Inputs {
            names: &names,
            covariance,
            prior_information: &fit.prior_information,
            prior_covariance: &prior_covariance(data),
            canonical: &frame.transform,
            gauge: &gauge,
        })?;
        // The trackers' frames have no prior, hence no ratio.
        identifiability.sigma_ratio.truncate(estimated);
        Some(identifiability)
    });
    let global_test = fit
        .cost
        .and_then(|cost| GlobalTest::new(cost, fit.redundancy, options.alpha));
    let critical = critical_value(options.alpha, fit.tests);
    let observations = fit.checks.unwrap_or_default();
    let outlier = worst(&observations).is_some_and(|w| w.normalised.abs() > critical);
    let verdict = Verdict::new(&fit.status, global_test, outlier);
    let mut calibration = MechanismCalibration {
        mechanism: mechanism.name().to_string(),
        print_radius: data.print_radius,
        elasticity: LineElasticity::of(mechanism),
        parameters,
        covariance: frame
            .covariance
            .as_ref()
            .map(|c| c.view((0, 0), (estimated, estimated)).into_owned()),
        prior_correlation: data.prior_correlation.clone(),
        poses: fit.poses,
        balls: estimated_balls,
        trackers,
        body,
        observation: (!data.observations.touches.is_empty()).then_some(options.observation),
        global_test: verdict.global_test,
        verdict,
        status: fit.status,
        iterations: fit.iterations,
        observations,
        critical_value: critical,
        data_rows: fit.data_rows,
        tests: fit.tests,
        mirrored: fit.mirrored,
        gauss_newton: fit.gauss_newton,
        alpha: options.alpha,
        reasons: Vec::new(),
        repeats: Vec::new(),
        warnings: Vec::new(),
        removals: Vec::new(),
        snooping_stopped: None,
        identifiability,
    };
    calibration.reasons = reasons(&calibration, &named);
    Ok(calibration)
}

/// The standard deviation of unknown `k` of `covariance`, if given (a
/// rounding-negative variance as zero).
fn marginal_sigma(covariance: Option<&DMatrix<f64>>, k: usize) -> Option<f64> {
    covariance.map(|c| c[(k, k)].max(0.0).sqrt())
}

/// The names of a tracker frame correction's unknowns, in their order.
const FRAME_AXES: [&str; 6] = ["ω_x", "ω_y", "ω_z", "τ_x", "τ_y", "τ_z"];

/// Each tracker's frame `F₀ ∘ C` from the corrections in the canonical
/// global block `values`, with their covariance from the canonical
/// `covariance`, and its offsets with their sigmas.
fn tracker_estimates(
    data: &MechanismData,
    fit: &Fit,
    values: &DVector<f64>,
    covariance: Option<&DMatrix<f64>>,
) -> Vec<EstimatedTracker> {
    (data.observations.trackers.iter().enumerate())
        .map(|(k, tracker)| {
            let start = fit.trackers.columns(k).start;
            let offsets = fit.trackers.offset_columns(k).unwrap_or_default();
            let shift = fit.trackers.body_shift(k);
            let shifted = shift.rotation.is_some() || shift.origin.is_some();
            EstimatedTracker {
                label: tracker.label.clone(),
                frame: fit.trackers.frame(k, values).isometry(),
                covariance: covariance.map(|c| c.fixed_view::<6, 6>(start, start).into_owned()),
                offsets: offsets
                    .map(|j| (values[j], marginal_sigma(covariance, j)))
                    .collect(),
                body: shifted
                    .then(|| body_estimate(fit, Some(k), values, covariance))
                    .flatten(),
            }
        })
        .collect()
}

/// The body frame the poses of tracker `k` saw, `C_B,k ∘ B₀` (`C_B,k = C_B +
/// (φ, ρ)` where its body was turned or moved), or with `k` `None` the body
/// frame `C_B ∘ B₀`, from the canonical global block `values`, with the
/// covariance `A Cov Aᵀ` of its correction, `A` the sum of the body's and
/// the shift's columns; `None` without tracker poses.
fn body_estimate(
    fit: &Fit,
    k: Option<usize>,
    values: &DVector<f64>,
    covariance: Option<&DMatrix<f64>>,
) -> Option<EstimatedBody> {
    let body = fit.trackers.body_columns()?;
    let shift = k.map(|k| fit.trackers.body_shift(k)).unwrap_or_default();
    let frame = match k {
        Some(k) => fit.trackers.body_of(k, values)?,
        None => fit.trackers.body(values)?,
    };
    let mut a = DMatrix::zeros(6, values.len());
    for i in 0..6 {
        a[(i, body.start + i)] = 1.0;
    }
    for (first, start) in [(0, shift.rotation), (3, shift.origin)] {
        if let Some(start) = start {
            for i in 0..3 {
                a[(first + i, start + i)] = 1.0;
            }
        }
    }
    Some(EstimatedBody {
        frame: frame.isometry(),
        covariance: covariance.map(|c| {
            let projected = &a * c * a.transpose();
            Matrix6::from_column_slice(projected.as_slice())
        }),
    })
}

/// The observation of largest `|w|` among `observations`, its estimated
/// gross error over the redundancy of what its test sees
/// ([`estimated_gross_error`]): a touch's rows are tested as one, the
/// others' rows alone.
fn worst(observations: &ObservationChecks) -> Option<Worst<ObservationRef>> {
    let (c, row, normalised) = observations.worst()?;
    let redundancy = if c.observation.kind.rows_tested_as_one() {
        c.rows.iter().map(|r| f64::from(r.redundancy)).sum()
    } else {
        f64::from(c.rows[row].redundancy)
    };
    Some(Worst {
        observation: c.observation,
        row,
        normalised,
        gross_error: estimated_gross_error(normalised, redundancy),
    })
}

/// How a fit ended without converging, in words: a fit that is a result
/// ([`super::fit`]), or a Gauss-Newton fit that ran away.
pub(super) fn not_converged(status: &Status) -> String {
    match status {
        Status::IterationLimit => "it reached its iteration limit".to_string(),
        Status::TimeLimit => "it reached the time limit".to_string(),
        Status::Diverged { iteration, reason } => {
            format!("it diverged at iteration {iteration}: {reason}")
        }
        Status::ProblemFailed {
            iteration, message, ..
        } => format!("its step of iteration {iteration} failed: {message}"),
        other => format!("{other:?}"),
    }
}

/// The w-tests' family in words: `567 rows`, or `189 tests of 567 rows`.
fn family(calibration: &MechanismCalibration) -> String {
    let (tests, rows) = (calibration.tests, calibration.data_rows);
    if tests == rows {
        format!("{rows} rows")
    } else {
        format!("{tests} tests of {rows} rows")
    }
}

/// An observation by its kind and index, and the row of it a test names:
/// `probe height 3 (row 0)`.
pub(crate) fn named(observation: ObservationRef, row: Option<usize>) -> String {
    match row {
        Some(row) => format!("{observation} (row {row})"),
        None => observation.to_string(),
    }
}

/// How many repeats [`repeat_warnings`] names when it does not name them
/// all.
const NAMED_REPEATS: usize = 10;

/// The warnings of `repeats` ([`MechanismCalibration::warnings`]), each
/// observation named by `place` (as [`MechanismCalibration::place_observations`]
/// takes it): one a repeat when there are at most ten (`NAMED_REPEATS`),
/// else one that counts them and names the first ten (a file given twice
/// over would otherwise warn once a row).
pub fn repeat_warnings(
    repeats: &[Repeat],
    place: &dyn Fn(ObservationRef, Option<usize>) -> String,
) -> Vec<String> {
    let pair = |Repeat { copy, of }: &Repeat| {
        format!("{} repeats {}", place(*copy, None), place(*of, None))
    };
    if repeats.len() <= NAMED_REPEATS {
        return (repeats.iter())
            .map(|repeat| {
                format!(
                    "{} in every number, as a row given twice does (a measurement repeated reads otherwise): remove the copy, which counts the measurement twice",
                    pair(repeat)
                )
            })
            .collect();
    }
    let named: Vec<String> = repeats.iter().take(NAMED_REPEATS).map(pair).collect();
    vec![format!(
        "{} observations repeat an earlier one in every number, as rows given twice do (a measurement repeated reads otherwise): remove the copies, which count their measurements twice (the first {NAMED_REPEATS}: {})",
        repeats.len(),
        named.join("; ")
    )]
}

/// The verdict's reasons, in words, each observation (and the row a test
/// names) named by `place` ([`named`], or a front end's file and line).
pub(crate) fn reasons(
    calibration: &MechanismCalibration,
    place: &dyn Fn(ObservationRef, Option<usize>) -> String,
) -> Vec<String> {
    let alpha = calibration.alpha;
    let mut reasons = Vec::new();
    if !calibration.converged() {
        reasons.push(format!(
            "the solver did not converge ({}): the residuals are not those of a least-squares minimum, so nothing is tested",
            not_converged(&calibration.status)
        ));
    }
    if let Some(test) = calibration.global_test {
        let (low, high) = test.interval;
        let statement = match test.outcome {
            Outcome::Consistent => "consistent with the stated noise",
            Outcome::TooLarge => {
                "too large: the data do not fit their stated noise (a blunder, a wrong sigma, a model error)"
            }
            Outcome::TooSmall => {
                "too small: the fit is better than the stated noise allows (the sigmas are overstated)"
            }
        };
        reasons.push(format!(
            "global test: variance factor {:.3} over {} degrees of freedom, interval [{low:.3}, {high:.3}] at level {}: {statement}",
            test.variance_factor, test.redundancy, test.level
        ));
    }
    if let Some(Worst {
        observation,
        row,
        normalised: w,
        ..
    }) = calibration.worst()
    {
        let critical = calibration.critical_value;
        let family = format!("family-wise level {alpha} over {}", family(calibration));
        let observation = place(observation, Some(row));
        reasons.push(if w.abs() > critical {
            format!(
                "{observation} fails its w-test: |w| = {:.2} > {critical:.2} ({family}): a blunder that snooping would remove",
                w.abs()
            )
        } else {
            format!(
                "every w-test passes: the largest, {observation}, |w| = {:.2} <= {critical:.2} ({family})",
                w.abs()
            )
        });
    }
    for removal in &calibration.removals {
        reasons.push(format!(
            "{} removed by snooping (|w| = {:.2}; variance factor {:.3} -> {:.3})",
            place(removal.observation, None),
            removal.normalised.abs(),
            removal.variance_factor_before,
            removal.variance_factor_after
        ));
    }
    if let Some(stopped) = &calibration.snooping_stopped {
        reasons.push(format!("snooping stopped: {stopped}"));
    }
    reasons.push(if calibration.verdict.accepted {
        "accepted".to_string()
    } else {
        "rejected".to_string()
    });
    reasons
}

#[cfg(test)]
mod tests {
    use parcal_dataset::mechanism::RowCheck;

    use super::super::observation::ObservationKind;
    use super::*;

    /// A touch's rows are tested as one: its gross error is `w` over the
    /// root of their summed redundancy; a sample's rows alone, `e / r`.
    #[test]
    fn the_worst_gross_error_is_over_the_redundancy_its_test_sees() {
        let row = |residual: f32, redundancy: f32| RowCheck {
            residual,
            redundancy,
        };
        let rows = vec![row(0.3, 0.25), row(-0.9, 0.36), row(0.02, 0.01)];
        let sum: f64 = rows.iter().map(|r| f64::from(r.redundancy)).sum();
        let w = f64::from(-0.9f32) / f64::from(0.36f32).sqrt();
        for (kind, r) in [
            (ObservationKind::Touch, sum),
            (ObservationKind::Sample, f64::from(0.36f32)),
        ] {
            let observation = ObservationRef { kind, index: 4 };
            let checks = ObservationChecks::new(rows.clone(), [(observation, 3)]);
            let worst = worst(&checks).unwrap();
            assert_eq!((worst.row, worst.normalised), (1, w));
            assert_eq!(worst.gross_error, w / r.sqrt(), "{kind:?}");
        }
    }

    /// Up to [`NAMED_REPEATS`] repeats, a warning each; more, one warning
    /// that counts them all and names the first [`NAMED_REPEATS`].
    #[test]
    fn many_repeats_are_counted_in_one_warning_that_names_the_first() {
        let sample = |index| ObservationRef {
            kind: ObservationKind::Sample,
            index,
        };
        let repeats: Vec<Repeat> = (0..NAMED_REPEATS + 2)
            .map(|k| Repeat {
                copy: sample(100 + k),
                of: sample(k),
            })
            .collect();
        let few = repeat_warnings(&repeats[..NAMED_REPEATS], &named);
        assert_eq!(few.len(), NAMED_REPEATS);
        assert!(
            few[9].starts_with("point sample 109 repeats point sample 9 in every number"),
            "{few:?}"
        );
        let many = repeat_warnings(&repeats, &named);
        assert_eq!(many.len(), 1, "{many:?}");
        assert!(
            many[0].starts_with("12 observations repeat an earlier one in every number"),
            "{many:?}"
        );
        assert!(
            many[0].ends_with("(the first 10: point sample 100 repeats point sample 0; point sample 101 repeats point sample 1; point sample 102 repeats point sample 2; point sample 103 repeats point sample 3; point sample 104 repeats point sample 4; point sample 105 repeats point sample 5; point sample 106 repeats point sample 6; point sample 107 repeats point sample 7; point sample 108 repeats point sample 8; point sample 109 repeats point sample 9)"),
            "{many:?}"
        );
    }
}
