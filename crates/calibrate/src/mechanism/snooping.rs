//! Data snooping of a mechanism calibration, on the path every calibration
//! takes ([`crate::snooping`]): every observation of the result is named
//! by its place in the data given.

use std::time::Instant;

use parcal_solver::IterationRecord;

use crate::snooping::{Place, Removable, Snoopable, Tests, snoop as snoop_data};

use super::data::MechanismData;
use super::error::MechanismCalibrationError;
use super::fit::fit;
use super::observation::{ObservationKind, ObservationRef};
use super::options::MechanismOptions;
use super::result::{MechanismCalibration, assemble, named, reasons};

impl Place for ObservationRef {
    const KINDS: usize = ObservationKind::ALL.len();

    fn kind(self) -> usize {
        self.kind.index()
    }

    fn index(self) -> usize {
        self.index
    }

    fn at(self, index: usize) -> Self {
        Self { index, ..self }
    }
}

impl Removable for MechanismData {
    type Place = ObservationRef;

    fn counts(&self) -> Vec<usize> {
        ObservationKind::ALL
            .iter()
            .map(|&kind| self.observations.count(kind))
            .collect()
    }

    /// Refuses data that would not be valid without it.
    fn without(&self, observation: ObservationRef) -> Result<Self, String> {
        let rest = self.with_observations(self.observations.without(observation));
        rest.validate()
            .map_err(|error| format!("without it, {error}"))?;
        Ok(rest)
    }
}

impl Snoopable for MechanismCalibration {
    type Place = ObservationRef;

    fn tests(&self) -> Option<Tests<ObservationRef>> {
        if !self.converged() {
            return None;
        }
        Some(Tests {
            size: self.tests,
            worst: self.worst(),
        })
    }

    fn variance_factor(&self) -> f64 {
        MechanismCalibration::variance_factor(self)
    }

    fn converged(&self) -> bool {
        MechanismCalibration::converged(self)
    }
}

/// One calibration of `data`, its observations named as in `data`, within
/// what is left of the time budget of the calibration that began at
/// `started`; `observer` sees each iteration.
pub(crate) fn calibrate_once(
    data: &MechanismData,
    options: &MechanismOptions,
    started: Instant,
    observer: &mut dyn FnMut(&IterationRecord),
) -> Result<MechanismCalibration, MechanismCalibrationError> {
    assemble(data, fit(data, options, started, observer)?, options)
}

/// Calibrates `data` with data snooping at the options' level, the
/// result's observations named by their place in `data`; every fit within
/// the time budget of the calibration that began at `started`, `observer`
/// seeing each fit's iterations in turn.
pub(crate) fn snoop(
    data: &MechanismData,
    options: &MechanismOptions,
    started: Instant,
    observer: &mut dyn FnMut(&IterationRecord),
) -> Result<MechanismCalibration, MechanismCalibrationError> {
    let snooped = snoop_data(data, options.alpha, options.max_removals, |data| {
        calibrate_once(data, options, started, &mut *observer)
    })?;
    let mut run = snooped.run;
    (run.observations).rename(|observation| snooped.remaining.original(observation));
    run.removals = snooped.removals;
    run.snooping_stopped = snooped.stopped;
    run.reasons = reasons(&run, &named);
    Ok(run)
}
