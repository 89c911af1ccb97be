//! The dataset of a mechanism other than the hexapod (a linear delta, a
//! cable robot): a directory, separate in its files from the hexapod's.
//!
//! | file | content | type |
//! |---|---|---|
//! | `machine.json` | the mechanism by name, configured and design parameters, tolerances, noise, trigger height | [`MechanismMachine`] |
//! | `probes.csv` | probe heights (`x,y,z`) | [`MechanismDataset::probes`] |
//! | `heights.csv` | heights of the nozzle above the bed measured by hand at commanded positions (`x,y,z,height`) | [`MechanismDataset::heights`] |
//! | `distances.csv` | part distances (`x1,y1,z1,x2,y2,z2,distance`) | [`MechanismDataset::distances`] |
//! | `points.csv` | readings, with the position where known and optionally the loads (`q1..qA,x,y,z[,f1..fA]`) | [`SampleRow`] |
//! | `quantities.csv` | quantities of the machine measured directly (`quantity,value,sigma`) | [`QuantityRow`] |
//! | `balls.csv` | calibrated balls (`ball,radius,radius_sigma`), with `touches.csv` | [`BallRow`] |
//! | `touches.csv` | touches of the balls at commanded positions (`ball,x,y,z`) | [`TouchRow`] |
//! | `ball_distances.csv` | calibrated distances between the balls' centres, a ball plate's or a ball bar's (`first,second,distance,sigma`), with `balls.csv` | [`crate::Distance`] |
//! | `tracker_points.csv` | tool points measured by trackers in their own frames at commanded positions (`tracker,x_c,y_c,z_c,x,y,z`) | [`TrackerPointRow`] |
//! | `truth.json` | simulated datasets only: the true machine | [`MechanismTruth`] |
//!
//! and its calibration writes `calibration.json`
//! ([`MechanismCalibrationRecord`]), its validation on held-out data
//! `validation.json` ([`MechanismValidationRecord`]); `parcal compensate`
//! reads target positions ([`read_targets`]). The observation files are each
//! optional, but one must be there. `machine.json` names its mechanism
//! (`"mechanism"`); a `machine.json` without one is a hexapod's, which
//! [`crate::Dataset::read`] reads, and each reader refuses the other's
//! with a message naming the right one. Reading checks every value and
//! names the file, the field or the line and column; writing is atomic,
//! the directory as a whole ([`crate::atomic::write_dir`]).
//!
//! ```
//! use parcal_dataset::mechanism::{MechanismDataset, MechanismMachine, Noise};
//! use parcal_kinematics::delta::LinearDelta;
//!
//! # fn main() -> Result<(), parcal_dataset::DatasetError> {
//! let mut machine = MechanismMachine::of(&LinearDelta::typical());
//! machine.noise = Noise { probe: Some(0.01), ..Noise::default() };
//! let dataset = MechanismDataset {
//!     machine,
//!     probes: vec![[0.0, 0.0, 0.71], [50.0, 20.0, 0.69]],
//!     ..MechanismDataset::default()
//! };
//! let dir = tempfile::tempdir().unwrap();
//! let path = dir.path().join("delta");
//! dataset.write(&path)?;
//! assert_eq!(MechanismDataset::read(&path)?, dataset);
//! // The hexapod's reader points to this one.
//! let error = parcal_dataset::Dataset::read(&path).unwrap_err().to_string();
//! assert!(error.contains("mechanism reader"), "{error}");
//! # Ok(()) }
//! ```

mod ball_distances;
mod balls;
mod calibration;
mod machine;
mod observation_records;
mod observations;
mod quantities;
mod targets;
mod tracker_points;
mod truth;
mod validation;

use std::path::Path;

pub use ball_distances::{BALL_DISTANCE_COLUMNS, BALL_DISTANCES};
pub use balls::{
    BALL_COLUMNS, BALLS, BallPlacement, BallRow, PLACEMENT_COLUMNS, TOUCH_COLUMNS, TouchRow,
};
pub use calibration::{
    BallRecord, BodyRecord, IdentifiabilityRecord, MechanismCalibrationRecord, MirroredRecord,
    ParameterRecord, RemovalRecord, RunAwayRecord, TRIGGER_HEIGHT, TestsRecord, TrackerRecord,
    UndeterminedRecord,
};
pub use machine::{LineElasticity, MechanismMachine, Noise, ValuePrior};
pub use observation_records::{
    ObservationRecord, ObservationRecords, RowCheck, UNCHECKED_REDUNDANCY, worst_row,
};
pub use observations::{
    DISTANCE_COLUMNS, HEIGHT_COLUMNS, LOAD_COLUMNS, OBSERVATIONS, POSITION_COLUMNS, PROBE_COLUMNS,
    READING_COLUMNS, SampleRow,
};
pub use quantities::{QUANTITY_COLUMNS, QuantityRow};
pub use targets::{TARGETS, Targets, command_header, read_targets};
pub use tracker_points::{TRACKER_POINT_COLUMNS, TRACKERS, TrackerPointRow, tracker_labels};
pub use truth::MechanismTruth;
pub use validation::{KindRecord, MechanismValidationRecord, RowRecord, ShiftRecord};

use crate::Distance;
use crate::atomic;
use crate::check::Check;
use crate::checksum::Crc32;
use crate::dataset::Dataset;
use crate::error::{DatasetError, Result};
use crate::input;

use ball_distances::{read_ball_distances, validate_ball_distances, write_ball_distances};
use balls::{read_balls, read_touches, write_balls, write_touches};
use machine::mechanism_named;
use observations::{read_rows, read_samples, write_rows, write_samples};
use quantities::{read_quantities, write_quantities};
use tracker_points::{read_tracker_points, write_tracker_points};

/// The file of the machine.
pub const MACHINE_FILE: &str = "machine.json";
/// The file of the probe heights.
pub const PROBES_FILE: &str = "probes.csv";
/// The file of the heights measured by hand.
pub const HEIGHTS_FILE: &str = "heights.csv";
/// The file of the part distances.
pub const DISTANCES_FILE: &str = "distances.csv";
/// The file of the readings at unknown or measured positions.
pub const POINTS_FILE: &str = "points.csv";
/// The file of the quantities measured directly.
pub const QUANTITIES_FILE: &str = "quantities.csv";
/// The file of the calibrated balls.
pub const BALLS_FILE: &str = "balls.csv";
/// The file of the touches of the balls.
pub const TOUCHES_FILE: &str = "touches.csv";
/// The file of the trackers' points.
pub const TRACKER_POINTS_FILE: &str = "tracker_points.csv";
/// The file of the calibrated distances between the balls' centres.
pub const BALL_DISTANCES_FILE: &str = "ball_distances.csv";
/// The file of a simulated dataset's truth.
pub const TRUTH_FILE: &str = "truth.json";
/// The file of a calibration.
pub const CALIBRATION_FILE: &str = "calibration.json";

/// A mechanism dataset (module doc).
#[derive(Debug, Clone, PartialEq)]
pub struct MechanismDataset {
    /// The machine.
    pub machine: MechanismMachine,
    /// Probe heights: commanded `x, y` and the height `z` at which the
    /// probe triggered (mm, the controller's coordinates).
    pub probes: Vec<[f64; 3]>,
    /// Heights measured by hand: a commanded position and the nozzle's
    /// height above the bed measured there (a gauge, Klipper's
    /// `MANUAL_HEIGHT`; mm).
    pub heights: Vec<[f64; 4]>,
    /// Part distances: two commanded positions and the distance measured
    /// between them (mm).
    pub distances: Vec<[f64; 7]>,
    /// Readings at unknown or measured positions.
    pub samples: Vec<SampleRow>,
    /// Quantities of the machine measured directly.
    pub quantities: Vec<QuantityRow>,
    /// Calibrated balls, numbered by their place.
    pub balls: Vec<BallRow>,
    /// Touches of the balls.
    pub touches: Vec<TouchRow>,
    /// Calibrated distances between the balls' centres (mm), a ball
    /// plate's or a ball bar's: each joins two distinct balls (their
    /// numbers, [`Self::balls`]' indices), each pair at most once.
    pub ball_distances: Vec<Distance>,
    /// Tool points measured by trackers in their own frames.
    pub tracker_points: Vec<TrackerPointRow>,
    /// The true machine of a simulated dataset.
    pub truth: Option<MechanismTruth>,
}

impl Default for MechanismDataset {
    /// A typical linear delta with no observation.
    fn default() -> Self {
        Self {
            machine: MechanismMachine::of(&parcal_kinematics::delta::LinearDelta::typical()),
            probes: Vec::new(),
            heights: Vec::new(),
            distances: Vec::new(),
            samples: Vec::new(),
            quantities: Vec::new(),
            balls: Vec::new(),
            touches: Vec::new(),
            ball_distances: Vec::new(),
            tracker_points: Vec::new(),
            truth: None,
        }
    }
}

impl MechanismDataset {
    /// A checksum of what was measured, as [`crate::Dataset::checksum`]:
    /// CRC-32 of the machine and every observation in the snapshot's
    /// encoding (a simulation's truth is not part of it), `crc32:` and 8
    /// hex digits. It recognises a dataset; it is not a cryptographic hash.
    pub fn checksum(&self) -> String {
        // The encoding of the machine and the observations in turn, each
        // list in pieces on the threads (`Crc32::of_seq`).
        let mut crc = Crc32::default();
        crc.encode(&self.machine);
        let lists = [
            Crc32::of_seq(&self.probes),
            Crc32::of_seq(&self.heights),
            Crc32::of_seq(&self.distances),
            Crc32::of_seq(&self.samples),
            Crc32::of_seq(&self.quantities),
            Crc32::of_seq(&self.balls),
            Crc32::of_seq(&self.touches),
            Crc32::of_seq(&self.ball_distances),
            Crc32::of_seq(&self.tracker_points),
        ];
        for list in &lists {
            crc.append(list);
        }
        crc.checksum()
    }

    /// Reads the dataset in directory `dir` (module doc).
    pub fn read(dir: &Path) -> Result<Self> {
        let machine = MechanismMachine::read(&dir.join(MACHINE_FILE))?;
        let present = |name: &str| -> Result<Option<std::path::PathBuf>> {
            let path = dir.join(name);
            Ok(input::open(&path)?.map(|_| path))
        };
        let probes = match present(PROBES_FILE)? {
            Some(path) => read_rows(&path, &PROBE_COLUMNS, "probe")?,
            None => Vec::new(),
        };
        let heights = match present(HEIGHTS_FILE)? {
            Some(path) => read_rows(&path, &HEIGHT_COLUMNS, "height")?,
            None => Vec::new(),
        };
        let distances = match present(DISTANCES_FILE)? {
            Some(path) => read_rows(&path, &DISTANCE_COLUMNS, "distance")?,
            None => Vec::new(),
        };
        let samples = match present(POINTS_FILE)? {
            Some(path) => {
                let mechanism = mechanism_named(&path, "mechanism", &machine.mechanism)?;
                read_samples(&path, mechanism.actuators().len())?
            }
            None => Vec::new(),
        };
        let quantities = match present(QUANTITIES_FILE)? {
            Some(path) => {
                let mechanism = mechanism_named(&path, "mechanism", &machine.mechanism)?;
                read_quantities(&path, mechanism.as_ref())?
            }
            None => Vec::new(),
        };
        let balls = match present(BALLS_FILE)? {
            Some(path) => read_balls(&path)?,
            None => Vec::new(),
        };
        let touches = match present(TOUCHES_FILE)? {
            Some(path) if balls.is_empty() => return Err(without_balls(path, "touches of balls")),
            Some(path) => read_touches(&path, balls.len())?,
            None => Vec::new(),
        };
        let ball_distances = match present(BALL_DISTANCES_FILE)? {
            Some(path) if balls.is_empty() => {
                return Err(without_balls(path, "distances between balls"));
            }
            Some(path) => read_ball_distances(&path, balls.len())?,
            None => Vec::new(),
        };
        let tracker_points = match present(TRACKER_POINTS_FILE)? {
            Some(path) => read_tracker_points(&path)?,
            None => Vec::new(),
        };
        let truth = MechanismTruth::read_if_present(&dir.join(TRUTH_FILE), &machine)?;
        let dataset = Self {
            machine,
            probes,
            heights,
            distances,
            samples,
            quantities,
            balls,
            touches,
            ball_distances,
            tracker_points,
            truth,
        };
        dataset.validate(dir)?;
        Ok(dataset)
    }

    /// Writes the dataset as the directory `dir`, as a set (atomically);
    /// an existing non-empty `dir` is an error.
    pub fn write(&self, dir: &Path) -> Result<()> {
        self.write_with(dir, false)
    }

    /// [`Self::write`], replacing an existing dataset directory as a whole
    /// if `replace`.
    pub fn write_with(&self, dir: &Path, replace: bool) -> Result<()> {
        self.validate(dir)?;
        Dataset::check_target(dir, replace)?;
        let name = &self.machine.mechanism;
        atomic::write_dir(dir, replace, |new| {
            self.machine.write(&new.join(MACHINE_FILE))?;
            if !self.probes.is_empty() {
                write_rows(&new.join(PROBES_FILE), &PROBE_COLUMNS, &self.probes)?;
            }
            if !self.heights.is_empty() {
                write_rows(&new.join(HEIGHTS_FILE), &HEIGHT_COLUMNS, &self.heights)?;
            }
            if !self.distances.is_empty() {
                write_rows(
                    &new.join(DISTANCES_FILE),
                    &DISTANCE_COLUMNS,
                    &self.distances,
                )?;
            }
            if !self.samples.is_empty() {
                let path = new.join(POINTS_FILE);
                let mechanism = mechanism_named(&path, "mechanism", name)?;
                write_samples(&path, mechanism.actuators().len(), &self.samples)?;
            }
            if !self.quantities.is_empty() {
                write_quantities(&new.join(QUANTITIES_FILE), &self.quantities)?;
            }
            if !self.balls.is_empty() {
                write_balls(&new.join(BALLS_FILE), &self.balls)?;
                write_touches(&new.join(TOUCHES_FILE), &self.touches)?;
            }
            if !self.ball_distances.is_empty() {
                write_ball_distances(&new.join(BALL_DISTANCES_FILE), &self.ball_distances)?;
            }
            if !self.tracker_points.is_empty() {
                write_tracker_points(&new.join(TRACKER_POINTS_FILE), &self.tracker_points)?;
            }
            if let Some(truth) = &self.truth {
                truth.write(&new.join(TRUTH_FILE), &self.machine)?;
            }
            Ok(())
        })
    }

    /// The checks that tie the files together: at least one observation,
    /// counts within [`OBSERVATIONS`], values finite and within the length
    /// bound, the noise of each kind present given, each measured quantity
    /// one of the mechanism's with a positive sigma, the truth's trigger
    /// height given for a machine with a probe and its trackers among
    /// those measured. Errors name the files in
    /// `dir` and a table's row by its line ([`RowNames::Lines`]).
    pub fn validate(&self, dir: &Path) -> Result<()> {
        self.validate_named(dir, RowNames::Lines)
    }

    /// [`Self::validate`], a table's row named as `names` says (a dataset
    /// built in memory: by its 0-based index, as an array's).
    pub fn validate_named(&self, dir: &Path, names: RowNames) -> Result<()> {
        let machine_path = dir.join(MACHINE_FILE);
        let check = Check::new(&machine_path);
        self.machine.validate(check)?;
        let counts = [
            (PROBES_FILE, self.probes.len()),
            (HEIGHTS_FILE, self.heights.len()),
            (DISTANCES_FILE, self.distances.len()),
            (POINTS_FILE, self.samples.len()),
            (QUANTITIES_FILE, self.quantities.len()),
            (TOUCHES_FILE, self.touches.len()),
            (TRACKER_POINTS_FILE, self.tracker_points.len()),
        ];
        if counts.iter().all(|&(_, n)| n == 0) {
            return Err(DatasetError::Refused {
                path: dir.to_path_buf(),
                message: format!(
                    "the dataset holds no observation: none of {PROBES_FILE}, {HEIGHTS_FILE}, {DISTANCES_FILE}, {POINTS_FILE}, {QUANTITIES_FILE}, {TOUCHES_FILE}, {TRACKER_POINTS_FILE}"
                ),
            });
        }
        self.validate_balls(dir, names)?;
        for (file, count) in counts {
            if count > OBSERVATIONS.max {
                let path = dir.join(file);
                return Err(Check::new(&path).error(
                    "rows",
                    OBSERVATIONS.refusal("the number of rows", &count.to_string()),
                ));
            }
        }
        let noise = &self.machine.noise;
        for (needed, sigma, field) in [
            (!self.probes.is_empty(), noise.probe, "noise.probe"),
            (!self.heights.is_empty(), noise.height, "noise.height"),
            (!self.distances.is_empty(), noise.distance, "noise.distance"),
            (!self.touches.is_empty(), noise.touch, "noise.touch"),
            (
                !self.tracker_points.is_empty(),
                noise.tracker,
                "noise.tracker",
            ),
            (!self.samples.is_empty(), noise.actuator, "noise.actuator"),
            (
                self.samples.iter().any(|s| s.position.is_some()),
                noise.position,
                "noise.position",
            ),
        ] {
            if needed && sigma.is_none() {
                return Err(check.error(
                    field,
                    "required: the dataset holds measurements of this kind",
                ));
            }
        }
        let probed = !self.probes.is_empty() || self.machine.trigger_height.is_some();
        if probed
            && self
                .truth
                .as_ref()
                .is_some_and(|t| t.trigger_height.is_none())
        {
            return Err(Check::new(&dir.join(TRUTH_FILE)).error(
                "trigger_height",
                "required: the machine has a probe (probe heights or machine.json's trigger_height), whose trigger height is an unknown",
            ));
        }
        let labels = tracker_labels(&self.tracker_points);
        let trackers = self.truth.iter().flat_map(|t| t.trackers.keys());
        if let Some(label) = trackers.into_iter().find(|l| !labels.contains(l)) {
            return Err(Check::new(&dir.join(TRUTH_FILE)).error(
                format!("trackers.{label}"),
                format!("no tracker of this label measured in {TRACKER_POINTS_FILE}"),
            ));
        }
        let rows = |file: &str, columns: &[&str], rows: &mut dyn Iterator<Item = &[f64]>| {
            let path = dir.join(file);
            let check = Check::new(&path);
            rows.enumerate()
                .try_for_each(|(k, row)| check.row_lengths(|| names.of(k), columns, row))
        };
        rows(
            PROBES_FILE,
            &PROBE_COLUMNS,
            &mut self.probes.iter().map(|r| r.as_slice()),
        )?;
        rows(
            HEIGHTS_FILE,
            &HEIGHT_COLUMNS,
            &mut self.heights.iter().map(|r| r.as_slice()),
        )?;
        rows(
            DISTANCES_FILE,
            &DISTANCE_COLUMNS,
            &mut self.distances.iter().map(|r| r.as_slice()),
        )?;
        // A measured distance is a length between two points: positive.
        let path = dir.join(DISTANCES_FILE);
        let check = Check::new(&path);
        let distance = DISTANCE_COLUMNS.len() - 1;
        for (k, row) in self.distances.iter().enumerate() {
            let field = format!("{}, column {}", names.of(k), DISTANCE_COLUMNS[distance]);
            check.positive(field, row[distance])?;
        }
        self.validate_tracker_points(dir, names)?;
        let path = dir.join(POINTS_FILE);
        let check = Check::new(&path);
        for (k, sample) in self.samples.iter().enumerate() {
            check.row_values(|| names.of(k), &READING_COLUMNS, &sample.readings)?;
            if let Some(position) = &sample.position {
                check.row_lengths(|| names.of(k), &POSITION_COLUMNS, position)?;
            }
            if let Some(loads) = &sample.loads {
                check.row_values(|| names.of(k), &LOAD_COLUMNS, loads)?;
            }
        }
        if !self.quantities.is_empty() {
            let path = dir.join(QUANTITIES_FILE);
            let check = Check::new(&path);
            let mechanism = mechanism_named(&path, "mechanism", &self.machine.mechanism)?;
            let quantities = mechanism.quantities();
            for (k, row) in self.quantities.iter().enumerate() {
                let field = || names.of(k);
                if !quantities.iter().any(|q| q.name == row.quantity) {
                    return Err(check.error(
                        field(),
                        format!(
                            "{:?} is not a quantity of the {}",
                            row.quantity,
                            mechanism.name()
                        ),
                    ));
                }
                check.row_values(|| names.of(k), &QUANTITY_COLUMNS[1..2], &[row.value])?;
                if !(row.sigma.is_finite() && row.sigma > 0.0) {
                    return Err(check.error(
                        field(),
                        format!("sigma {} is not finite and positive", row.sigma),
                    ));
                }
            }
        }
        Ok(())
    }

    /// The trackers' points: labels not empty, at most [`TRACKERS`]`.max`
    /// of them, positions within the length bound.
    fn validate_tracker_points(&self, dir: &Path, names: RowNames) -> Result<()> {
        let path = dir.join(TRACKER_POINTS_FILE);
        let check = Check::new(&path);
        let labels = tracker_labels(&self.tracker_points);
        if labels.len() > TRACKERS.max {
            let count = labels.len().to_string();
            return Err(check.error(
                "tracker",
                TRACKERS.refusal("the number of trackers", &count),
            ));
        }
        for (k, row) in self.tracker_points.iter().enumerate() {
            let field = || names.of(k);
            if row.tracker.is_empty() {
                return Err(check.error(field(), "empty tracker label"));
            }
            check.row_lengths(|| names.of(k), &TRACKER_POINT_COLUMNS[1..4], &row.commanded)?;
            check.row_lengths(|| names.of(k), &TRACKER_POINT_COLUMNS[4..], &row.measured)?;
        }
        Ok(())
    }

    /// The balls, their touches and the distances between them: balls
    /// and touches both or neither, distances only with balls; balls
    /// within [`BALLS`], radii positive and finite, sigmas positive and
    /// finite where given, every touch on a ball that exists with its
    /// position within the length bound, every distance between two
    /// balls that exist ([`BALL_DISTANCES`]).
    fn validate_balls(&self, dir: &Path, names: RowNames) -> Result<()> {
        let balls_path = dir.join(BALLS_FILE);
        let touches_path = dir.join(TOUCHES_FILE);
        let distances_path = dir.join(BALL_DISTANCES_FILE);
        if self.balls.is_empty() {
            if !self.touches.is_empty() {
                return Err(without_balls(touches_path, "touches of balls"));
            }
            if !self.ball_distances.is_empty() {
                return Err(without_balls(distances_path, "distances between balls"));
            }
        } else if self.touches.is_empty() {
            return Err(DatasetError::Refused {
                path: balls_path,
                message: format!("balls without {TOUCHES_FILE}: nothing touched them"),
            });
        }
        let check = Check::new(&balls_path);
        if self.balls.len() > BALLS.max {
            let count = self.balls.len().to_string();
            return Err(check.error("rows", BALLS.refusal("the number of rows", &count)));
        }
        for (k, ball) in self.balls.iter().enumerate() {
            let field = || names.of(k);
            let positive = |v: f64| v.is_finite() && v > 0.0;
            if !positive(ball.radius) || !ball.radius_sigma.is_none_or(positive) {
                return Err(check.error(
                    field(),
                    format!(
                        "radius {} and its sigma {:?} must be finite and positive",
                        ball.radius, ball.radius_sigma
                    ),
                ));
            }
        }
        let check = Check::new(&touches_path);
        for (k, touch) in self.touches.iter().enumerate() {
            let field = || names.of(k);
            if touch.ball >= self.balls.len() {
                return Err(check.error(
                    field(),
                    format!(
                        "ball {} is not one of the {} of {BALLS_FILE} (numbered from 0)",
                        touch.ball,
                        self.balls.len()
                    ),
                ));
            }
            check.row_lengths(|| names.of(k), &TOUCH_COLUMNS[1..], &touch.commanded)?;
        }
        validate_ball_distances(
            &distances_path,
            &self.ball_distances,
            self.balls.len(),
            names,
        )
    }
}

/// How errors name a row of a dataset's table.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RowNames {
    /// By its line in the file (`line 5` for the fourth row, the header
    /// on line 1): a dataset read or written.
    Lines,
    /// By its 0-based index (`row 3`), as an array's: a dataset built in
    /// memory.
    Indices,
}

impl RowNames {
    /// The name of the row of 0-based index `k`.
    pub fn of(self, k: usize) -> String {
        match self {
            Self::Lines => format!("line {}", k + 2),
            Self::Indices => format!("row {k}"),
        }
    }
}

/// The refusal of the file `path`, which holds `what` (`"touches of
/// balls"`), in a dataset without balls.
fn without_balls(path: std::path::PathBuf, what: &str) -> DatasetError {
    DatasetError::Refused {
        path,
        message: format!("{what} need {BALLS_FILE}, which is not there"),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The checksum made list by list in pieces is that of the whole
    /// encoding of the machine and every list, each list of other rows
    /// than the next, one over several pieces.
    #[test]
    fn the_checksum_is_that_of_the_whole_encoding() {
        let dataset = MechanismDataset {
            probes: (0..40_000).map(|i| [i as f64, -0.5, 1e-3]).collect(),
            heights: vec![[1.0, 2.0, 3.0, 0.25]],
            distances: vec![[0.0, 1.0, 2.0, 3.0, 4.0, 5.0, 6.0]; 2],
            samples: vec![SampleRow {
                readings: vec![1.0, 2.0, 3.0],
                position: Some([4.0, 5.0, 6.0]),
                loads: None,
            }],
            quantities: vec![QuantityRow {
                quantity: "r".to_string(),
                value: 140.0,
                sigma: 0.1,
            }],
            balls: vec![BallRow {
                radius: 12.7,
                radius_sigma: Some(0.001),
                placement: None,
            }],
            touches: vec![
                TouchRow {
                    ball: 0,
                    commanded: [1.0, -1.0, 30.0],
                };
                3
            ],
            ball_distances: vec![Distance {
                a: 0,
                b: 1,
                length: 100.0,
                sigma: 0.002,
            }],
            tracker_points: vec![TrackerPointRow {
                tracker: "t".to_string(),
                commanded: [0.0; 3],
                measured: [1.0; 3],
            }],
            ..MechanismDataset::default()
        };
        let d = &dataset;
        let whole = (
            &d.machine,
            &d.probes,
            &d.heights,
            &d.distances,
            &d.samples,
            &d.quantities,
            &d.balls,
            &d.touches,
            &d.ball_distances,
            &d.tracker_points,
        );
        let bytes = postcard::to_allocvec(&whole).unwrap();
        assert_eq!(dataset.checksum(), crate::checksum::of_bytes(&bytes));
    }
}
