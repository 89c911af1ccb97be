//! The target poses of `parcal compensate` for a mechanism, a column per
//! pose coordinate (`x,y,z` for a delta's or a cable robot's effector
//! position, mm; `t_x,t_y,t_z,r_x,r_y,r_z` for a hexapod's platform), and
//! the header of the commands written for them.

use std::path::Path;

use crate::bounds::Count;
use crate::error::{DatasetError, Result};
use crate::numbers::{OtherColumns, read_numbers_within};
use crate::table::{self, Header};

/// The bounds of a targets file's rows: each costs an inverse kinematics
/// and its derivatives, and a row of the commands held in memory.
pub const TARGETS: Count = Count::new(
    1,
    1_000_000,
    "each costs an inverse kinematics and a row of commands held in memory",
);

/// Reads the targets file `path`, its header the pose coordinates
/// `columns` (3 or 6 of them; others are passed over, as in the commands
/// `compensate` writes), at most [`TARGETS`] rows; errors name the file,
/// the line and the column. A column of `loads` (points.csv's `f1..fA` of
/// a mechanism whose readings depend on its actuators' loads) is refused:
/// the commands are those under the loads held when the actuators were
/// zeroed, and a load given would be passed over.
pub fn read_targets(
    path: &Path,
    columns: &[&'static str],
    loads: &[&'static str],
) -> Result<Vec<Vec<f64>>> {
    let named = table::read_file(path, |reader| {
        let header = Header::read(reader, &columns.join(","))?;
        for load in loads {
            if header.find(load)?.is_some() {
                return Err(header.error(format!(
                    "column {load}: the commands are those under the loads the lines held when they were zeroed (machine.json's zero_loads); commands under other loads are not computed"
                )));
            }
        }
        Ok(())
    });
    named?;
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
/// and `actuators` actuators: the target, the calibrated readings
/// `q1..qA`, then the nominal ones `nominal_q1..nominal_qA`.
pub fn command_header(pose: &[&str], actuators: usize) -> Vec<String> {
    pose.iter()
        .map(|c| c.to_string())
        .chain((1..=actuators).map(|k| format!("q{k}")))
        .chain((1..=actuators).map(|k| format!("nominal_q{k}")))
        .collect()
}
