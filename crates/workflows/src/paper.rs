//! The paper study (docs/paper-scenario.md section 4): one dataset of the paper's scenario,
//! calibrated as simulations I and II without a prior, and III and IV with
//! the paper's and with the propagated prior, each with its accuracy maps
//! before and after against the truth.

use parcal_accuracy::MapGrid;
use parcal_calibrate::{CalibrationOptions, CalibrationRun, PriorMode, Simulation, calibrate};
use parcal_dataset::Dataset;
use parcal_simulate::{Scenario, simulate};

use crate::WorkflowError;
use crate::evaluate::{BeforeAfter, TrueMachine, before_after};

/// The six calibrations of the study, in the order the paper reports them.
pub const PAPER_CASES: [(Simulation, PriorMode); 6] = [
    (Simulation::I, PriorMode::None),
    (Simulation::II, PriorMode::None),
    (Simulation::III, PriorMode::Paper),
    (Simulation::IV, PriorMode::Paper),
    (Simulation::III, PriorMode::Propagated),
    (Simulation::IV, PriorMode::Propagated),
];

/// One simulated dataset of the paper's scenario and its truth.
pub struct PaperStudy {
    /// The noise seed.
    pub seed: u64,
    /// The paper's scenario ([`Scenario::paper`]).
    pub scenario: Scenario,
    /// The simulated dataset.
    pub dataset: Dataset,
    /// Its true machine in canonical frames.
    pub truth: TrueMachine,
    /// The grid of the accuracy maps (the paper's plane z = 400).
    pub grid: MapGrid,
}

impl PaperStudy {
    /// Simulates the paper's scenario with `seed`.
    pub fn simulate(seed: u64) -> Result<Self, WorkflowError> {
        let scenario = Scenario::paper();
        let dataset = simulate(&scenario, seed)?.dataset;
        let truth = TrueMachine::of(&dataset).ok_or(WorkflowError::NoTruth)??;
        Ok(Self {
            seed,
            scenario,
            dataset,
            truth,
            grid: MapGrid::paper(),
        })
    }

    /// Calibrates the dataset as `simulation` with `prior`, and maps the
    /// accuracy before and after against the truth.
    pub fn calibrate(
        &self,
        simulation: Simulation,
        prior: PriorMode,
    ) -> Result<PaperCase, WorkflowError> {
        let options = CalibrationOptions {
            prior,
            ..CalibrationOptions::simulation(simulation)
        };
        let run = calibrate(&self.dataset, &options, &mut |_| {})?;
        let maps = before_after(Some(&self.truth), &run, &self.grid)?;
        Ok(PaperCase {
            simulation,
            prior,
            run,
            maps,
        })
    }
}

/// One calibration of the study.
pub struct PaperCase {
    /// Its observation equation and prior use (I-IV).
    pub simulation: Simulation,
    /// Its prior.
    pub prior: PriorMode,
    /// The calibration.
    pub run: CalibrationRun,
    /// Its accuracy maps before and after.
    pub maps: BeforeAfter,
}

impl PaperCase {
    /// "IV (propagated prior)", "I (no prior)".
    pub fn name(&self) -> String {
        match self.prior {
            PriorMode::None => format!("{} (no prior)", self.simulation),
            prior => format!("{} ({prior} prior)", self.simulation),
        }
    }

    /// `sqrt(cost)` per iteration: the weighted residual norm |O| of the
    /// paper's figs. 5 and 8.
    pub fn residual_norms(&self) -> Vec<(f64, f64)> {
        self.run
            .history
            .iter()
            .enumerate()
            .map(|(k, r)| (k as f64, r.cost.sqrt()))
            .collect()
    }
}
