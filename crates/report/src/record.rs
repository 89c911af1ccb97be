//! calibration.json, built in one place: the record of a run, with or
//! without data snooping. Each record holds the run's numbers
//! ([`CalibrationRun::record`]), its status, verdict, reasons and warnings
//! in words, and its diagnostics.

use parcal_calibrate::CalibrationRun;
use parcal_calibrate::observation::ObservationId;
use parcal_calibrate::snooping::Snooped;
use parcal_calibrate::verdict::Outcome;
use parcal_dataset::{Calibration, Dataset};

use crate::checks::{checks, down_weighted_records};
use crate::diagnostics;
use crate::sentences::{self, sensitivity_sentence, systematic_sentence};
use crate::verdict::{with_removals, with_verdict};

/// The calibration.json record of the `run` of `dataset`.
pub fn of_run(run: &CalibrationRun, dataset: &Dataset) -> Calibration {
    recorded(run, dataset, &|observation| observation)
}

/// The calibration.json record of a calibration with data snooping: the
/// remaining observations' run, and every removal with its place and what
/// it did to the variance factor; `dataset` is the dataset given.
pub fn of_snooped_run(
    snooped: &Snooped<CalibrationRun, ObservationId>,
    dataset: &Dataset,
) -> Calibration {
    let mut record = recorded(&snooped.run, dataset, &|o| snooped.remaining.original(o));
    with_removals(&mut record, &snooped.removals, snooped.stopped.as_deref());
    record
}

/// [`of_run`] of a run whose observation `o` is `original(o)` in the
/// dataset given.
fn recorded(
    run: &CalibrationRun,
    dataset: &Dataset,
    original: &(dyn Fn(ObservationId) -> ObservationId + Sync),
) -> Calibration {
    let status = sentences::status(run);
    // The run's numbers and its diagnostics each pass over every ball or
    // observation (a million contacts' at 10^6): made side by side.
    let (mut record, diagnostics) = rayon::join(
        || run.record(status.clone()),
        || diagnostics::of_run(run, dataset, original),
    );
    let mut warnings = sentences::warnings(run);
    let mut reasons = Vec::new();
    if let Some(reliability) = &run.reliability {
        checks(reliability, original, &mut reasons, &mut warnings);
        record.down_weighted_observations = down_weighted_records(reliability, original);
        if let Some(global) = run.global_test.filter(|t| t.outcome == Outcome::TooLarge) {
            reasons.extend(
                reliability
                    .systematic
                    .iter()
                    .filter_map(|t| systematic_sentence(t, &global)),
            );
        }
    }
    reasons.extend(
        diagnostics
            .systematic_sensitivity
            .iter()
            .map(sensitivity_sentence),
    );
    with_verdict(&mut record, &run.verdict(), &status, warnings);
    record.reasons.extend(reasons);
    record.diagnostics = Some(diagnostics);
    record
}
