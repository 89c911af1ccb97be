//! calibration.json's `diagnostics`: the checks of a run
//! ([`parcal_calibrate::reliability`]) kept for a report, bounded whatever
//! the number of observations (the [`LISTED`] largest normalised residuals
//! and least controlled observations, histograms of the rest).

use parcal_calibrate::CalibrationRun;
use parcal_calibrate::InstrumentTable;
use parcal_calibrate::instruments::InstrumentRun;
use parcal_calibrate::reliability::{
    UNCONTROLLED, VarianceComponent, critical_value, minimal_detectable_bias,
};
use parcal_calibrate::snooping::SNOOPING_LEVEL;
use parcal_dataset::{
    Dataset, Diagnostics, Histogram, MEASUREMENTS_FILE, ObservationCheck, ObservationTests,
    VarianceComponentRecord, WeakDirectionRecord,
};
use parcal_solver::{SpectrumDiagnostics, normalised_residual};

use crate::instruments::determined_by;

/// How many observations each list of [`ObservationTests`] keeps.
pub const LISTED: usize = 20;
/// How many weak directions are kept.
const WEAK_DIRECTIONS: usize = 5;
/// Bins of the normalised residuals' histogram: `[-6, 6)` by 0.25.
const NORMALISED_BINS: (f64, f64, usize) = (-6.0, 0.25, 48);
/// Bins of the redundancy numbers' histogram over `[0, u)`, `u` the
/// largest redundancy rounded up to a tenth of the rows of an observation.
const REDUNDANCY_BINS: usize = 40;
/// Posterior variance within this share of the prior's: the data did not
/// inform the parameter (as the prior-data conflict test,
/// [`parcal_calibrate::conflict`]).
const NOT_INFORMED: f64 = 1e-9;

/// What an observation observes, named only when it is listed.
#[derive(Clone, Copy)]
enum Observes {
    /// The ball of this index (artefacts.json order).
    Ball(usize),
    /// Leg `i` (0-based) of a pose.
    Leg(usize),
    /// Coordinate `i` (x, y, z) of a point.
    Coordinate(usize),
}

/// One observation's numbers before they are summarised.
struct Tested {
    file: &'static str,
    /// 0-based row of the file.
    row: usize,
    observes: Observes,
    redundancy: f64,
    /// Normalised residual and estimated gross error of its worst row.
    normalised: Option<(f64, f64)>,
}

/// The diagnostics of a ball-touch run: `dataset` the dataset given,
/// `original_row(i)` its row of the run's measurements.csv row `i` (the
/// identity without data snooping).
pub fn of_ball_run(
    run: &CalibrationRun,
    dataset: &Dataset,
    original_row: &dyn Fn(usize) -> usize,
) -> Diagnostics {
    let names = run.layout.names(&run.ball_ids, &[]);
    // calibration.json's parameters are the kinematic ones.
    let (prior_sigma, determined_by) = match (run.sigmas(), &run.prior) {
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
    };
    let observations = run.reliability.as_ref().map(|reliability| {
        let tested = reliability.contacts.iter().map(|c| {
            let row = original_row(c.row);
            Tested {
                file: MEASUREMENTS_FILE,
                row,
                observes: Observes::Ball(dataset.measurements.ball[row] as usize),
                redundancy: c.redundancy,
                normalised: c.normalised.zip(c.gross_error),
            }
        });
        let rows_per_contact = run.residual_rows / reliability.contacts.len().max(1);
        tests(
            tested.collect(),
            reliability.row_normalised.iter().copied(),
            rows_per_contact,
            &|k| dataset.artefacts.balls[k].id.as_str(),
        )
    });
    Diagnostics {
        variance_components: components(
            run.reliability.as_ref().map_or(&[][..], |r| &r.components),
        ),
        observations,
        prior_sigma,
        determined_by,
        weak_directions: weak_directions(run.spectrum.as_ref(), &names),
    }
}

/// The diagnostics of an instrument run (poses, points).
pub fn of_instrument_run(run: &InstrumentRun) -> Diagnostics {
    let names = run.names();
    let prior = run.prior_sigmas();
    let sigmas = run.sigmas();
    let determined_by = sigmas.as_ref().map_or(Vec::new(), |s| {
        (0..names.len())
            .map(|k| determined_by(run.data_information[k], s[k], prior[k]).to_string())
            .collect()
    });
    let observations = run.reliability.as_ref().map(|reliability| {
        let pose_rows = 6 * run.leg_residuals.len();
        let tested = reliability.rows.iter().enumerate().map(|(k, &(r, e))| {
            let (table, row, observes) = if k < pose_rows {
                (InstrumentTable::Poses, k / 6, Observes::Leg(k % 6))
            } else {
                let k = k - pose_rows;
                (InstrumentTable::Points, k / 3, Observes::Coordinate(k % 3))
            };
            Tested {
                file: table.file_name(),
                row,
                observes,
                redundancy: r,
                normalised: normalised_residual(e, r).map(|w| (w, e / r)),
            }
        });
        let rows = reliability
            .rows
            .iter()
            .filter_map(|&(r, e)| normalised_residual(e, r));
        tests(tested.collect(), rows, 1, &|_| "")
    });
    Diagnostics {
        variance_components: components(
            run.reliability.as_ref().map_or(&[][..], |r| &r.components),
        ),
        observations,
        prior_sigma: if determined_by.is_empty() {
            Vec::new()
        } else {
            prior.iter().map(|s| s.is_finite().then_some(*s)).collect()
        },
        determined_by,
        weak_directions: weak_directions(run.spectrum.as_ref(), &names),
    }
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

/// The summary of `tested` (each observation of `rows_per_observation`
/// rows) and of every row's normalised residual `row_normalised`: the
/// data-snooping test at [`SNOOPING_LEVEL`] family-wise (Bonferroni), the
/// minimal detectable biases at its per-test level and 80 % power;
/// `ball_id(k)` is the id of ball `k`.
fn tests<'a>(
    mut tested: Vec<Tested>,
    row_normalised: impl Iterator<Item = f64>,
    rows_per_observation: usize,
    ball_id: &dyn Fn(usize) -> &'a str,
) -> ObservationTests {
    let m = tested.len();
    let per_test_level = SNOOPING_LEVEL / m.max(1) as f64;
    let check = |t: &Tested| ObservationCheck {
        file: t.file.to_string(),
        line: t.row as u64 + 2,
        observes: match t.observes {
            Observes::Ball(k) => format!("ball {}", ball_id(k)),
            Observes::Leg(i) => format!("leg {}", i + 1),
            Observes::Coordinate(i) => ["x", "y", "z"][i].to_string(),
        },
        redundancy: t.redundancy,
        normalised_residual: t.normalised.map(|(w, _)| w),
        gross_error_sigmas: t.normalised.map(|(_, g)| g),
        mdb_sigmas: t
            .normalised
            .map(|_| minimal_detectable_bias(t.redundancy, per_test_level)),
    };
    let (lower, width, bins) = NORMALISED_BINS;
    let normalised_histogram = Histogram::of(row_normalised, lower, width, bins);
    // Over [0, the largest redundancy rounded up to a tenth of the rows).
    let rows = rows_per_observation.max(1) as f64;
    let largest_redundancy = tested.iter().map(|t| t.redundancy).fold(0.0, f64::max);
    let upper = rows * ((largest_redundancy / rows * 10.0).floor() + 1.0).min(10.0) / 10.0;
    let redundancy_histogram = Histogram::of(
        tested.iter().map(|t| t.redundancy),
        0.0,
        upper / REDUNDANCY_BINS as f64,
        REDUNDANCY_BINS,
    );
    let redundancy = tested.iter().map(|t| t.redundancy).sum();
    let uncontrolled = tested
        .iter()
        .filter(|t| t.redundancy < UNCONTROLLED)
        .count();
    let w = |t: &Tested| t.normalised.map_or(-1.0, |(w, _)| w.abs());
    // Largest |w| first, then by file and row: the same for any order of
    // the observations with the same numbers.
    tested.sort_by(|a, b| {
        w(b).total_cmp(&w(a))
            .then(a.file.cmp(b.file))
            .then(a.row.cmp(&b.row))
    });
    let largest = tested
        .iter()
        .filter(|t| t.normalised.is_some())
        .take(LISTED)
        .map(check)
        .collect();
    tested.sort_by(|a, b| {
        a.redundancy
            .total_cmp(&b.redundancy)
            .then(a.file.cmp(b.file))
            .then(a.row.cmp(&b.row))
    });
    let least_controlled = tested
        .iter()
        .take_while(|t| t.redundancy < UNCONTROLLED)
        .take(LISTED)
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
