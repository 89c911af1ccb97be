//! The target positions of `parcal compensate` for a mechanism
//! (`x,y,z`, mm) and the header of the commands written for them.

use std::path::Path;

use crate::bounds::Count;
use crate::error::Result;
use crate::numbers::read_numbers_within;

/// The columns of a targets file.
pub const TARGET_COLUMNS: [&str; 3] = ["x", "y", "z"];

/// The bounds of a targets file's rows: each costs an inverse kinematics
/// and its derivatives, and a row of the commands held in memory.
pub const TARGETS: Count = Count::new(
    1,
    1_000_000,
    "each costs an inverse kinematics and a row of commands held in memory",
);

/// Reads the targets file `path` (header `x,y,z`, at most [`TARGETS`]
/// rows); errors name the file, the line and the column.
pub fn read_targets(path: &Path) -> Result<Vec<[f64; 3]>> {
    read_numbers_within(path, &TARGET_COLUMNS, "target", Some(&TARGETS))
}

/// The header of the commands of a mechanism of `actuators` actuators:
/// the target, the calibrated readings `q1..qA`, then the nominal ones
/// `nominal_q1..nominal_qA`.
pub fn command_header(actuators: usize) -> Vec<String> {
    TARGET_COLUMNS
        .iter()
        .map(|c| c.to_string())
        .chain((1..=actuators).map(|k| format!("q{k}")))
        .chain((1..=actuators).map(|k| format!("nominal_q{k}")))
        .collect()
}
