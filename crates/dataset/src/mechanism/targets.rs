//! The target poses of `parcal compensate` for a mechanism, a column per
//! pose coordinate (`x,y,z` for a delta's or a cable robot's effector
//! position, mm; `t_x,t_y,t_z,r_x,r_y,r_z` for a hexapod's platform), and
//! the header of the commands written for them.

use std::path::Path;

use crate::bounds::Count;
use crate::error::{DatasetError, Result};
use crate::numbers::{OtherColumns, read_numbers_within};
use crate::table::{self, Header};

use super::observations::{optional_group, whole_or_empty};

/// The bounds of a targets file's rows: each costs an inverse kinematics
/// and its derivatives, and a row of the commands held in memory.
pub const TARGETS: Count = Count::new(
    1,
    1_000_000,
    "each costs an inverse kinematics and a row of commands held in memory",
);

/// The targets of a targets file: each pose, and the loads the actuators
/// hold there where given.
#[derive(Debug, Clone, PartialEq)]
pub struct Targets {
    /// Each target's pose coordinates.
    pub poses: Vec<Vec<f64>>,
    /// Each target's loads, one per actuator (`None`: those held when the
    /// actuators were zeroed); empty when the file has no load columns.
    pub loads: Vec<Option<Vec<f64>>>,
}

/// Reads the targets file `path`, its header the pose coordinates
/// `columns` (3 or 6 of them; others are passed over, as in the commands
/// `compensate` writes), at most [`TARGETS`] rows; errors name the file,
/// the line and the column. The columns `loads` (points.csv's `f1..fA` of
/// a mechanism whose readings depend on its actuators' loads; none for
/// another) are read when the header names them: all or none, each row's
/// whole or empty (empty: the loads held when the actuators were zeroed),
/// as points.csv's.
pub fn read_targets(
    path: &Path,
    columns: &[&'static str],
    loads: &[&'static str],
) -> Result<Targets> {
    let poses = read_poses(path, columns)?;
    let loads = match loads {
        [] => Vec::new(),
        loads => table::read_file(path, |reader| {
            let header = Header::read(reader, &columns.join(","))?;
            let Some(at) = optional_group(&header, "load", loads)? else {
                return Ok(Vec::new());
            };
            let mut rows = Vec::with_capacity(poses.len());
            table::for_each_row(reader, &header, "target", |row| {
                rows.push(whole_or_empty(row, &at, loads, "loads")?);
                Ok(())
            })?;
            Ok(rows)
        })?,
    };
    Ok(Targets { poses, loads })
}

/// The pose coordinates `columns` of each row of the targets file `path`
/// ([`read_targets`]).
fn read_poses(path: &Path, columns: &[&'static str]) -> Result<Vec<Vec<f64>>> {
    let limit = (Some(&TARGETS), OtherColumns::Allowed);
    Ok(match *columns {
        [x, y, z] => rows(read_numbers_within(path, &[x, y, z], "target", limit)?),
        [a, b, c, d, e, f] => rows(read_numbers_within(
            path,
            &[a, b, c, d, e, f],
            "target",
            limit,
        )?),
        _ => {
            return Err(DatasetError::Refused {
                path: path.to_path_buf(),
                message: format!(
                    "targets of {} pose coordinates ({}): a target has 3 or 6",
                    columns.len(),
                    columns.join(",")
                ),
            });
        }
    })
}

/// Fixed-size rows as vectors.
fn rows<const N: usize>(rows: Vec<[f64; N]>) -> Vec<Vec<f64>> {
    rows.into_iter().map(Vec::from).collect()
}

/// The header of the commands of a mechanism of pose coordinates `pose`
/// and `actuators` actuators: the target, then its `loads` columns if
/// any, the calibrated readings `q1..qA`, then the nominal ones
/// `nominal_q1..nominal_qA` (read back as targets, the same targets).
pub fn command_header(pose: &[&str], loads: &[&str], actuators: usize) -> Vec<String> {
    pose.iter()
        .chain(loads)
        .map(|c| c.to_string())
        .chain((1..=actuators).map(|k| format!("q{k}")))
        .chain((1..=actuators).map(|k| format!("nominal_q{k}")))
        .collect()
}
