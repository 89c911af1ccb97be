//! A dataset's calibration as `parcal calibrate` makes it, for every front
//! end (the binary, the Python package): the options from the command's
//! flags ([`CalibrateFlags`]), the calibration of any hexapod dataset
//! (ball touches, poses, points), with or without data snooping, and
//! calibration.json's record of it ([`calibrate_recorded`]); a hexapod's
//! ball touches as the common calibration's data ([`common_calibration`]);
//! a dataset read from a directory or a snapshot ([`read_dataset`]).

use std::path::Path;
use std::time::Duration;

use parcal_calibrate::hypothesis::{MAX_REMOVALS, SNOOPING_LEVEL};
use parcal_calibrate::mechanism::{MechanismCalibrationError, MechanismData, MechanismOptions};
use parcal_calibrate::observation::ObservationId;
use parcal_calibrate::snooping::{Remaining, calibrate_with_snooping};
use parcal_calibrate::{
    CalibrateError, CalibrationOptions, CalibrationRun, IterationRecord, Loss, Observation,
    PriorMode, RadiusModel, Simulation, WeightModel, calibrate,
};
use parcal_dataset::mechanism::MechanismCalibrationRecord;
use parcal_dataset::{Calibration, Dataset, DatasetError, Provenance, ReadOptions};
use parcal_report::record;

/// Reads a dataset as the commands do: a directory of text files, or a
/// binary snapshot file (`dataset.bin`). A directory holding a snapshot is
/// read from the text files.
pub fn read_dataset(path: &Path) -> Result<Dataset, DatasetError> {
    read_dataset_with(path, &ReadOptions::default())
}

/// [`read_dataset`] with `options` for a directory of text files (a
/// snapshot is read whole).
pub fn read_dataset_with(path: &Path, options: &ReadOptions) -> Result<Dataset, DatasetError> {
    if path.is_file() {
        Dataset::read_snapshot(path)
    } else {
        Dataset::read_with(path, options)
    }
}

/// The flags of `parcal calibrate` that shape a calibration (the
/// command's `--sim`, `--observation`, `--prior`, `--weights`, `--radius`,
/// `--lm`, `--max-iterations`, `--time-limit`, `--snoop`, `--loss`); the
/// default is the command without flags.
#[derive(Debug, Clone, PartialEq)]
pub struct CalibrateFlags {
    /// One of the paper's simulations; `observation` and `prior` override
    /// its parts.
    pub sim: Option<Simulation>,
    /// The observation equation.
    pub observation: Option<Observation>,
    /// The a priori knowledge.
    pub prior: Option<PriorMode>,
    /// The observation weights.
    pub weights: WeightModel,
    /// The calibrated radius's error.
    pub radius: Option<RadiusModel>,
    /// Levenberg-Marquardt instead of Gauss-Newton.
    pub lm: bool,
    /// The iteration limit, if not the method's default.
    pub max_iterations: Option<usize>,
    /// The wall-clock budget of the calibration.
    pub time_limit: Option<Duration>,
    /// Data snooping ([`SNOOPING_LEVEL`], at most [`MAX_REMOVALS`]).
    pub snoop: bool,
    /// The loss of each observation.
    pub loss: Loss,
}

impl Default for CalibrateFlags {
    fn default() -> Self {
        Self {
            sim: None,
            observation: None,
            prior: None,
            weights: WeightModel::Propagated,
            radius: None,
            lm: false,
            max_iterations: None,
            time_limit: None,
            snoop: false,
            loss: Loss::Squared,
        }
    }
}

impl CalibrateFlags {
    /// The calibration options these flags ask for: the simulation's (or
    /// the defaults), its parts overridden, then the method, the loss and
    /// the limits.
    pub fn options(&self) -> CalibrationOptions {
        let mut options = self
            .sim
            .map_or_else(CalibrationOptions::default, CalibrationOptions::simulation);
        if let Some(observation) = self.observation {
            options.observation = observation;
        }
        if let Some(prior) = self.prior {
            options.prior = prior;
        }
        options.weighting = self.weights;
        if let Some(radius) = self.radius {
            options.radius = radius;
        }
        if self.lm {
            options = options.levenberg_marquardt();
        }
        options = options.with_loss(self.loss);
        if let Some(limit) = self.max_iterations {
            options.max_iterations = limit;
        }
        options.time_limit = self.time_limit;
        options
    }

    /// The options of the common calibration of every mechanism these
    /// flags ask for: the method, the loss, data snooping and the limits
    /// (the other flags shape a hexapod's data,
    /// [`MechanismData::from_hexapod_touches`]).
    pub fn mechanism_options(&self) -> MechanismOptions {
        let options = if self.lm {
            MechanismOptions::default().levenberg_marquardt()
        } else {
            MechanismOptions::default()
        };
        options
            .with_snooping(self.snoop)
            .with_loss(self.loss)
            .with_max_iterations(self.max_iterations)
            .with_time_limit(self.time_limit)
    }
}

/// What `parcal calibrate --common` calibrates: a hexapod's ball touches
/// as the common calibration's data under the options `flags` give
/// ([`MechanismData::from_hexapod_touches`]: what it does not model is
/// refused by name), and that calibration's options
/// ([`CalibrateFlags::mechanism_options`], with the touches' observation
/// equation of the hexapod's options).
pub fn common_calibration(
    dataset: &Dataset,
    flags: &CalibrateFlags,
) -> Result<(MechanismData, MechanismOptions), MechanismCalibrationError> {
    let options = flags.options();
    let data = MechanismData::from_hexapod_touches(dataset, &options)?;
    Ok((
        data,
        flags
            .mechanism_options()
            .with_observation(options.observation),
    ))
}

/// A calibration and its record.
pub struct RecordedRun {
    /// The run (of the observations data snooping left, if it removed
    /// any).
    pub run: Box<CalibrationRun>,
    /// Where the run's observations are in the dataset given.
    pub remaining: Remaining<ObservationId>,
    /// calibration.json's content, without its provenance ([`provenance`]).
    pub record: Calibration,
}

impl RecordedRun {
    /// Where the run's `observation` is in the dataset given.
    pub fn original(&self, observation: ObservationId) -> ObservationId {
        self.remaining.original(observation)
    }
}

/// Calibrates `dataset` as `parcal calibrate` with `flags` does, calling
/// `observer` at each iteration, and makes calibration.json's record of it
/// (with a warning naming the first reading outside machine.json's stroke,
/// if any).
pub fn calibrate_recorded(
    dataset: &Dataset,
    flags: &CalibrateFlags,
    observer: &mut dyn FnMut(&IterationRecord),
) -> Result<RecordedRun, CalibrateError> {
    let options = flags.options();
    let (run, remaining, mut record) = if flags.snoop {
        let snooped =
            calibrate_with_snooping(dataset, &options, SNOOPING_LEVEL, MAX_REMOVALS, observer)?;
        let record = record::of_snooped_run(&snooped, dataset);
        (snooped.run, snooped.remaining, record)
    } else {
        let run = calibrate(dataset, &options, observer)?;
        let record = record::of_run(&run, dataset);
        (run, Remaining::all(dataset), record)
    };
    record
        .warnings
        .extend(dataset.reading_outside_stroke().map(|o| o.to_string()));
    Ok(RecordedRun {
        run: Box::new(run),
        remaining,
        record,
    })
}

/// calibration.json's provenance of a calibration of the dataset of
/// checksum `checksum` ([`Dataset::checksum`], a mechanism's
/// [`MechanismDataset::checksum`](parcal_dataset::mechanism::MechanismDataset::checksum)),
/// given as `given` (a directory or a snapshot's path): this parcal's
/// version, that name, the checksum.
pub fn provenance(checksum: String, given: &str) -> Provenance {
    Provenance {
        parcal_version: env!("CARGO_PKG_VERSION").to_string(),
        dataset: given.to_string(),
        dataset_checksum: checksum,
    }
}

/// A calibration.json of either kind.
#[derive(Debug, Clone)]
pub enum Recorded {
    /// The hexapod's own calibration.
    Own(Box<Calibration>),
    /// A mechanism's (a hexapod's too, through the common path).
    Mechanism(Box<MechanismCalibrationRecord>),
}

/// Reads the calibration.json at `path` as the hexapod's own, else as a
/// mechanism's; the own reader's error when it is neither.
pub fn read_either(path: &Path) -> Result<Recorded, DatasetError> {
    match Calibration::read(path) {
        Ok(own) => Ok(Recorded::Own(Box::new(own))),
        Err(own) => match MechanismCalibrationRecord::read(path) {
            Ok(record) => Ok(Recorded::Mechanism(Box::new(record))),
            Err(_) => Err(own),
        },
    }
}
