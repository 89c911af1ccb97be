//! calibration.json's `diagnostics`: the checks of a run
//! ([`parcal_calibrate::reliability`]) kept for a report, bounded whatever
//! the number of observations (the [`LISTED`] largest normalised residuals
//! and least controlled observations, histograms of the rest).

use parcal_accuracy::{MapGrid, parameter_error};
use parcal_calibrate::CalibrationRun;
use parcal_calibrate::hypothesis::SNOOPING_LEVEL;
use parcal_calibrate::hypothesis::{POWER, critical_value, minimal_detectable_bias};
use parcal_calibrate::observation::ObservationId;
use parcal_calibrate::reliability::{
    ObservationCheck as Check, Reliability, UNCONTROLLED, VarianceComponent,
};
use parcal_calibrate::systematic::{SYSTEMATIC_LEVEL, SystematicTest};
use parcal_calibrate::verdict::{GlobalTest, Outcome};
use parcal_dataset::{
    Dataset, Diagnostics, ExternalReliabilityRecord, Histogram, ObservationCheck, ObservationTests,
    SystematicSensitivityRecord, SystematicTestRecord, VarianceComponentRecord,
    WeakDirectionRecord,
};
use parcal_kinematics::Params;
use parcal_solver::SpectrumDiagnostics;

use crate::places::location;

/// How many observations each list of [`ObservationTests`] keeps.
pub const LISTED: usize = 20;
/// How many weak directions are kept.
const WEAK_DIRECTIONS: usize = 5;
/// Bins of the redundancy numbers' histogram over `[0, u)`, `u` the
/// largest redundancy rounded up to a tenth of the rows of an observation.
const REDUNDANCY_BINS: usize = 40;
// What this module keeps is within what calibration.json's reader accepts
// (parcal_dataset's bounds), so that a calibration parcal writes reads back.
const _: () = assert!(
    LISTED <= parcal_dataset::MAX_LISTED
        && WEAK_DIRECTIONS <= parcal_dataset::MAX_LISTED
        && parcal_calibrate::external::SHIFTED <= parcal_dataset::MAX_LISTED
        && parcal_calibrate::hypothesis::MAX_REMOVALS <= parcal_dataset::MAX_LISTED
        && REDUNDANCY_BINS <= parcal_dataset::MAX_BINS
        && parcal_calibrate::reliability::NORMALISED_BINS.2 <= parcal_dataset::MAX_BINS
);
/// Posterior variance within this share of the prior's: the data did not
/// inform the parameter (as the prior-data conflict test,
/// [`parcal_calibrate::conflict`]).
const NOT_INFORMED: f64 = 1e-9;

/// Posterior over prior sigma below which the data determine a parameter.
const DATA_DETERMINED: f64 = 0.5;
/// Posterior over prior sigma above which the prior alone does.
const PRIOR_DETERMINED: f64 = 0.9;

/// What determined a parameter, from the data's information on it and its
/// posterior and prior sigmas: `prior (not observed)` when the data carry
/// no information on it (it moves only through the prior's correlations),
/// else `data` (the posterior sigma under half the prior's), `prior` (over
/// 0.9 of it) or `data and prior`.
pub fn determined_by(data_information: f64, posterior: f64, prior: f64) -> &'static str {
    if data_information <= 0.0 {
        return "prior (not observed)";
    }
    let ratio = posterior / prior;
    if ratio < DATA_DETERMINED {
        "data"
    } else if ratio > PRIOR_DETERMINED {
        "prior"
    } else {
        "data and prior"
    }
}

/// One observation's numbers before they are summarised.
struct Tested {
    /// The observation, at its place in the dataset given.
    observation: ObservationId,
    /// What it observes: its ball, its distance's balls, the pose's leg or
    /// the point's coordinate of its worst row.
    observes: Observes,
    redundancy: f64,
    /// Normalised residual and estimated gross error of its worst row.
    normalised: Option<(f64, f64)>,
}

/// What an observation observes, named only when it is listed.
#[derive(Clone, Copy)]
enum Observes {
    /// The ball of this index (artefacts.json order).
    Ball(usize),
    /// The balls of distance `k` of artefacts.json.
    Distance(usize),
    /// Leg `i` (0-based) of a pose.
    Leg(usize),
    /// Coordinate `i` (x, y, z) of a point.
    Coordinate(usize),
}

/// `check` as [`Tested`]: `original(o)` is the place in the dataset given
/// of the run's observation `o`.
fn tested(
    check: &Check,
    dataset: &Dataset,
    original: &dyn Fn(ObservationId) -> ObservationId,
) -> Tested {
    let observation = original(check.observation());
    let observes = match observation {
        ObservationId::Contact(row) => Observes::Ball(dataset.measurements.ball[row] as usize),
        ObservationId::Distance(k) => Observes::Distance(k),
        ObservationId::Pose(_) => Observes::Leg(check.row()),
        ObservationId::Point(_) => Observes::Coordinate(check.row()),
    };
    Tested {
        observation,
        observes,
        redundancy: check.redundancy(),
        normalised: check.normalised().zip(check.gross_error()),
    }
}

/// The diagnostics of a run: `dataset` the dataset given, `original(o)`
/// the place in it of the run's observation `o` (the identity without
/// data snooping).
pub fn of_run(
    run: &CalibrationRun,
    dataset: &Dataset,
    original: &(dyn Fn(ObservationId) -> ObservationId + Sync),
) -> Diagnostics {
    let (prior_sigma, determined_by) = attribution(run);
    let reliability = run.reliability.as_ref();
    let mut diagnostics = Diagnostics {
        variance_components: components(reliability.map_or(&[][..], |r| &r.components)),
        observations: reliability.map(|reliability| tests(reliability, dataset, original)),
        prior_sigma,
        determined_by,
        weak_directions: weak_directions(run.spectrum.as_ref(), &run.names()),
        external_reliability: Vec::new(),
        systematic_tests: Vec::new(),
        systematic_sensitivity: Vec::new(),
    };
    // The shifts and common errors of the touches' kinematic parameters,
    // mapped on the accuracy grid; poses and points alone name their
    // least reliable observations in the warnings.
    if let (Some(reliability), true) = (&run.reliability, run.has_touches()) {
        diagnostics.external_reliability =
            external_reliability(run, reliability, dataset, original);
        if let Some(global) = &run.global_test {
            diagnostics.systematic_tests = systematic_tests(&reliability.systematic, global);
        }
        diagnostics.systematic_sensitivity = systematic_sensitivity(run, &reliability.systematic);
    }
    diagnostics
}

/// calibration.json's `prior_sigma` and `determined_by` of a converged
/// run's recorded parameters: with poses and points alone, every global
/// parameter's from its prior sigma and the data's information on it
/// ([`parcal_calibrate::instruments::ParameterInformation`]); with touches,
/// the kinematic parameters' from their prior (the data inform a
/// parameter whose posterior variance is below its prior's), none when
/// calibration.json's parameters go beyond them (the instrument groups'
/// and the scales' priors are attributed only without touches).
fn attribution(run: &CalibrationRun) -> (Vec<Option<f64>>, Vec<String>) {
    let information = run
        .instruments
        .as_ref()
        .and_then(|i| i.information.as_ref());
    if let Some(information) = information {
        let Some(sigmas) = run.global_sigmas() else {
            return (Vec::new(), Vec::new());
        };
        let prior = &information.prior_sigmas;
        let determined_by = (0..sigmas.len())
            .map(|k| determined_by(information.data[k], sigmas[k], prior[k]).to_string())
            .collect();
        let prior_sigma = prior.iter().map(|s| s.is_finite().then_some(*s)).collect();
        return (prior_sigma, determined_by);
    }
    match (run.sigmas(), &run.prior) {
        _ if run.layout.recorded().len() > run.params.len() => (Vec::new(), Vec::new()),
        (Some(sigmas), Some(prior)) => sigmas
            .iter()
            .zip(prior.sigma().iter())
            .map(|(&posterior, &prior)| {
                let informed = prior * prior - posterior * posterior > NOT_INFORMED * prior * prior;
                let by = determined_by(if informed { 1.0 } else { 0.0 }, posterior, prior);
                (Some(prior), by.to_string())
            })
            .unzip(),
        (Some(sigmas), None) => (
            vec![None; sigmas.len()],
            vec!["data".to_string(); sigmas.len()],
        ),
        _ => (Vec::new(), Vec::new()),
    }
}

/// calibration.json's `systematic_tests` of a run whose global test is
/// `global`: when it rejects the run, the tests of the common errors that
/// could explain the misfit; none otherwise.
fn systematic_tests(tests: &[SystematicTest], global: &GlobalTest) -> Vec<SystematicTestRecord> {
    if global.outcome != Outcome::TooLarge {
        return Vec::new();
    }
    tests
        .iter()
        .filter_map(|t| {
            let without = t.without(global)?;
            Some(SystematicTestRecord {
                effect: t.effect.name().to_string(),
                estimate: t.estimate,
                sigma: t.sigma,
                unit: t.effect.unit().to_string(),
                level: SYSTEMATIC_LEVEL,
                critical_value: t.critical_value(),
                variance_factor_without: without.variance_factor,
                outcome_without: without.outcome.name().to_string(),
            })
        })
        .collect()
}

/// calibration.json's `systematic_sensitivity` of a converged ball-touch
/// run: each common error's minimal detectable bias, the kinematic
/// parameters' shift of an undetected one of that size and the registered
/// map of that shift as the parameter error
/// ([`parcal_accuracy::parameter_error`]) on the paper's grid, as
/// [`external_reliability`] maps one observation's.
fn systematic_sensitivity(
    run: &CalibrationRun,
    tests: &[SystematicTest],
) -> Vec<SystematicSensitivityRecord> {
    tests
        .iter()
        .map(|test| {
            let shift = test.undetected_shift();
            let error = Params::from_fn(|k, _| shift[k]);
            let map = parameter_error(&run.design, &run.params, &error, &MapGrid::paper())
                .ok()
                .map(|map| map.registered_summary());
            SystematicSensitivityRecord {
                effect: test.effect.name().to_string(),
                unit: test.effect.unit().to_string(),
                sigma: test.sigma,
                mdb: test.minimal_detectable_bias(),
                level: SYSTEMATIC_LEVEL,
                power: POWER,
                parameter_shift: error.iter().copied().collect(),
                map_rms_um: map.map(|m| 1e3 * m.rms),
                map_max_um: map.map(|m| 1e3 * m.max),
            }
        })
        .collect()
}

/// calibration.json's `external_reliability` of a ball-touch run: each of
/// the least reliable observations' kinematic parameter shift and, when
/// the run converged, the registered map of that shift as the parameter
/// error ([`parcal_accuracy::parameter_error`]) on the paper's grid, the
/// targets placed by the run's design.
fn external_reliability(
    run: &CalibrationRun,
    reliability: &Reliability,
    dataset: &Dataset,
    original: &dyn Fn(ObservationId) -> ObservationId,
) -> Vec<ExternalReliabilityRecord> {
    let level = per_test_level(reliability);
    reliability
        .external
        .iter()
        .filter_map(|shift| {
            let check = reliability.check(shift.observation)?;
            let error = Params::from_fn(|k, _| shift.global_shift[k]);
            let map = run
                .converged()
                .then(|| parameter_error(&run.design, &run.params, &error, &MapGrid::paper()).ok())
                .flatten()
                .map(|map| map.registered_summary());
            Some(ExternalReliabilityRecord {
                observation: observation_record(&check, dataset, original, level),
                row: shift.row,
                row_redundancy: shift.redundancy,
                row_mdb_sigmas: shift.minimal_detectable_bias,
                bias_to_noise: shift.bias_to_noise,
                parameter_shift: error.iter().copied().collect(),
                map_rms_um: map.map(|m| 1e3 * m.rms),
                map_max_um: map.map(|m| 1e3 * m.max),
            })
        })
        .collect()
}

fn components(components: &[VarianceComponent]) -> Vec<VarianceComponentRecord> {
    components
        .iter()
        .map(|c| VarianceComponentRecord {
            group: c.group.to_string(),
            cost: c.cost,
            redundancy: c.redundancy,
        })
        .collect()
}

/// The weakest directions of `spectrum`, parameters named by `names`.
fn weak_directions(
    spectrum: Option<&SpectrumDiagnostics>,
    names: &[String],
) -> Vec<WeakDirectionRecord> {
    spectrum.map_or(Vec::new(), |spectrum| {
        spectrum
            .weakest
            .iter()
            .take(WEAK_DIRECTIONS)
            .map(|weak| WeakDirectionRecord {
                eigenvalue: weak.eigenvalue,
                sigma: weak.identified.then(|| weak.eigenvalue.sqrt().recip()),
                dominant: weak
                    .dominant
                    .iter()
                    .map(|(k, c)| (names[*k].clone(), *c))
                    .collect(),
            })
            .collect()
    })
}

/// The summary of `reliability`'s checks and of every row's normalised
/// residual: the data-snooping test at [`SNOOPING_LEVEL`] family-wise
/// (Bonferroni over [`ObservationId::tests`]), the minimal detectable
/// biases at its per-test level and 80 % power; observations placed by
/// `original` in `dataset`, balls and distances named by its artefacts.
/// Only the listed observations are gathered, so that the summary of a
/// million contacts costs one index per observation.
fn tests(
    reliability: &Reliability,
    dataset: &Dataset,
    original: &dyn Fn(ObservationId) -> ObservationId,
) -> ObservationTests {
    let m = reliability.tests();
    let level = per_test_level(reliability);
    let check =
        |k: &usize| observation_record(&reliability.observation(*k), dataset, original, level);
    let normalised_histogram = reliability.row_normalised.clone();
    // Over [0, the largest redundancy rounded up to a tenth of the rows
    // of an observation, as many as that redundancy rounded up).
    let checks = || reliability.observations();
    let largest_redundancy = checks().map(|c| c.redundancy()).fold(0.0, f64::max);
    let rows = largest_redundancy.ceil().max(1.0);
    let upper = rows * ((largest_redundancy / rows * 10.0).floor() + 1.0).min(10.0) / 10.0;
    let redundancy_histogram = Histogram::of(
        checks().map(|c| c.redundancy()),
        0.0,
        upper / REDUNDANCY_BINS as f64,
        REDUNDANCY_BINS,
    );
    let redundancy = reliability.redundancy();
    let uncontrolled = checks().filter(|c| c.redundancy() < UNCONTROLLED).count();
    // Ties broken by the place in the dataset given: the same lists for
    // any order of the observations with the same numbers.
    let at = |k: &usize| reliability.observation(*k);
    let place = |k: &usize| order(original(at(k).observation()));
    let w = |k: &usize| at(k).normalised().map_or(-1.0, f64::abs);
    let largest = first_listed(
        (0..reliability.len()).filter(|&k| at(&k).normalised().is_some()),
        |a, b| w(b).total_cmp(&w(a)).then(place(a).cmp(&place(b))),
    )
    .iter()
    .map(check)
    .collect();
    let least_controlled = first_listed(
        (0..reliability.len()).filter(|&k| at(&k).redundancy() < UNCONTROLLED),
        |a, b| {
            at(a)
                .redundancy()
                .total_cmp(&at(b).redundancy())
                .then(place(a).cmp(&place(b)))
        },
    )
    .iter()
    .map(check)
    .collect();
    ObservationTests {
        tested: m,
        level: SNOOPING_LEVEL,
        critical_value: critical_value(SNOOPING_LEVEL, m),
        redundancy,
        uncontrolled_below: UNCONTROLLED,
        uncontrolled,
        largest,
        least_controlled,
        normalised_histogram,
        redundancy_histogram,
    }
}

/// The level of each test of data snooping: [`SNOOPING_LEVEL`] over the
/// family (Bonferroni).
fn per_test_level(reliability: &Reliability) -> f64 {
    SNOOPING_LEVEL / reliability.tests().max(1) as f64
}

/// calibration.json's record of `check`, placed by `original` in
/// `dataset` (balls and distances named by its artefacts), its minimal
/// detectable bias for tests at `level`.
fn observation_record(
    check: &Check,
    dataset: &Dataset,
    original: &dyn Fn(ObservationId) -> ObservationId,
    level: f64,
) -> ObservationCheck {
    let t = tested(check, dataset, original);
    let (file, line, field) = location(t.observation);
    ObservationCheck {
        file: file.to_string(),
        line,
        field,
        observes: match t.observes {
            Observes::Ball(k) => format!("ball {}", dataset.artefacts.balls[k].id),
            Observes::Distance(k) => {
                let d = &dataset.artefacts.distances[k];
                format!("balls {} and {}", d.a, d.b)
            }
            Observes::Leg(i) => format!("leg {}", i + 1),
            Observes::Coordinate(i) => ["x", "y", "z"][i].to_string(),
        },
        redundancy: t.redundancy,
        normalised_residual: t.normalised.map(|(w, _)| w),
        gross_error_sigmas: t.normalised.map(|(_, g)| g),
        mdb_sigmas: t
            .normalised
            .map(|_| minimal_detectable_bias(t.redundancy, level)),
    }
}

/// A fixed order of observations: by file, then by place.
fn order(observation: ObservationId) -> (u8, usize) {
    match observation {
        ObservationId::Contact(k) => (0, k),
        ObservationId::Distance(k) => (1, k),
        ObservationId::Pose(k) => (2, k),
        ObservationId::Point(k) => (3, k),
    }
}

/// The first [`LISTED`] of `indices` in the order `by`, in that order.
fn first_listed(
    indices: impl Iterator<Item = usize>,
    by: impl Fn(&usize, &usize) -> std::cmp::Ordering,
) -> Vec<usize> {
    // The first LISTED in order so far, kept sorted: one comparison with
    // the last of them for most indices.
    let mut listed: Vec<usize> = Vec::with_capacity(LISTED + 1);
    for k in indices {
        if listed.len() == LISTED && by(&k, &listed[LISTED - 1]).is_ge() {
            continue;
        }
        let at = listed.partition_point(|kept| by(kept, &k).is_le());
        listed.insert(at, k);
        listed.truncate(LISTED);
    }
    listed
}
