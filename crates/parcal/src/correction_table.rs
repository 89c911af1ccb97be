//! A hexapod calibration's correction table as `parcal compensate
//! --table` makes it, for every front end (docs/apply.md): the grid from
//! each axis's range and number of nodes, bounded ([`TABLE_NODES`]), the
//! table ([`CorrectionTable`], header [`CorrectionTable::HEADER`]) and its
//! multilinear interpolation error at the cell midpoints.

use parcal_apply::table::InterpolationError;
use parcal_apply::{AppliedModel, ApplyError, CorrectionTable, TableGrid, Target};
use parcal_dataset::bounds::{Count, check_product};
use parcal_simulate::mechanism::Spelling;

/// The nodes of a correction table, on one axis and in all: each costs an
/// inverse and a forward kinematics, and the table is held in memory (a
/// row of 12 numbers per node, about 1 GB at the bound).
pub const TABLE_NODES: Count = Count::new(
    1,
    10_000_000,
    "each node costs an inverse and a forward kinematics and a row held in memory",
);

/// One axis of a table's grid: `nodes` values evenly from `min` to `max`
/// (one node: `min`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AxisRange {
    /// The first value (mm, rad).
    pub min: f64,
    /// The last value (mm, rad).
    pub max: f64,
    /// The number of values.
    pub nodes: usize,
}

impl AxisRange {
    /// The axis's values.
    fn values(&self) -> Vec<f64> {
        let (min, max, n) = (self.min, self.max, self.nodes);
        match n {
            1 => vec![min],
            _ => (0..n)
                .map(|k| min + (max - min) * k as f64 / (n - 1) as f64)
                .collect(),
        }
    }
}

/// The grid of `ranges`, one per target coordinate
/// ([`Target::COLUMNS`]: x, y, z, roll, pitch, yaw), an axis not given at
/// 0, at least one given (a table of the origin alone is a mistake: an
/// empty `--table`); each axis's nodes and their product within
/// [`TABLE_NODES`], checked before any value is made. A refusal names the
/// axis as the front end spells it (`--table: the nodes N of axis x, 0:
/// ...`, `x: n 0: ...`). Values that cannot be interpolated (not finite,
/// not increasing) are [`CorrectionTable::new`]'s to refuse.
pub fn table_grid(
    ranges: &[Option<AxisRange>; 6],
    spelling: Spelling,
) -> Result<TableGrid, String> {
    if ranges.iter().all(Option::is_none) {
        let axes = Target::COLUMNS.join(", ");
        return Err(match spelling {
            Spelling::Flags => {
                format!("--table: no axis given (AXIS=MIN:MAX:N, AXIS one of {axes})")
            }
            Spelling::Keywords => format!("no axis given: one of {axes} as (min, max, n)"),
        });
    }
    for (name, range) in Target::COLUMNS.iter().zip(ranges) {
        if let Some(range) = range {
            let option = match spelling {
                Spelling::Flags => format!("--table: the nodes N of axis {name},"),
                Spelling::Keywords => format!("{name}: n"),
            };
            TABLE_NODES.check(&option, range.nodes)?;
        }
    }
    let counts: Vec<(&str, usize)> = Target::COLUMNS
        .iter()
        .zip(ranges)
        .map(|(name, range)| (*name, range.map_or(1, |r| r.nodes)))
        .collect();
    check_product(&counts, TABLE_NODES.max, "nodes, the most a table may have").map_err(
        |message| match spelling {
            Spelling::Flags => format!("--table: {message}"),
            Spelling::Keywords => message,
        },
    )?;
    Ok(TableGrid {
        axes: ranges
            .each_ref()
            .map(|range| range.map_or_else(|| vec![0.0], |r| r.values())),
    })
}

/// Why a correction table could not be made.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum TableError {
    /// A node was refused, or the grid cannot be interpolated
    /// ([`ApplyError::Refused`]'s row is the table's, 1-based).
    #[error("the correction table: {0}")]
    Nodes(ApplyError),
    /// A cell midpoint was refused ([`ApplyError::Refused`]'s row counts
    /// the midpoints, 1-based).
    #[error("the correction table's midpoints: {0}")]
    Midpoints(ApplyError),
}

/// The correction table of `model` on `grid` and its interpolation error
/// at the cell midpoints, as `parcal compensate --table` computes them.
pub fn correction_table(
    model: &AppliedModel,
    grid: &TableGrid,
) -> Result<(CorrectionTable, InterpolationError), TableError> {
    let table = CorrectionTable::new(model, grid).map_err(TableError::Nodes)?;
    let error = table.midpoint_error(model).map_err(TableError::Midpoints)?;
    Ok((table, error))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_grid_is_its_ranges_with_absent_axes_at_zero() {
        let mut ranges = [None; 6];
        ranges[0] = Some(AxisRange {
            min: -10.0,
            max: 10.0,
            nodes: 5,
        });
        ranges[3] = Some(AxisRange {
            min: 0.1,
            max: 7.0,
            nodes: 1,
        });
        let grid = table_grid(&ranges, Spelling::Keywords).unwrap();
        assert_eq!(grid.axes[0], [-10.0, -5.0, 0.0, 5.0, 10.0]);
        assert_eq!(grid.axes[3], [0.1]);
        assert_eq!(grid.axes[2], [0.0]);
        assert_eq!(grid.len(), 5);
    }

    #[test]
    fn a_grid_of_no_axis_is_refused() {
        let none = [None; 6];
        assert_eq!(
            table_grid(&none, Spelling::Flags).unwrap_err(),
            "--table: no axis given (AXIS=MIN:MAX:N, AXIS one of x, y, z, roll, pitch, yaw)"
        );
        assert_eq!(
            table_grid(&none, Spelling::Keywords).unwrap_err(),
            "no axis given: one of x, y, z, roll, pitch, yaw as (min, max, n)"
        );
    }

    #[test]
    fn counts_beyond_the_bound_are_refused_by_axis() {
        let mut ranges = [None; 6];
        ranges[1] = Some(AxisRange {
            min: 0.0,
            max: 1.0,
            nodes: 0,
        });
        assert!(
            table_grid(&ranges, Spelling::Keywords)
                .unwrap_err()
                .starts_with("y: n 0: must be a whole number from 1 to 10000000 (")
        );
        assert!(
            table_grid(&ranges, Spelling::Flags)
                .unwrap_err()
                .starts_with("--table: the nodes N of axis y, 0: must be")
        );
        let wide = Some(AxisRange {
            min: 0.0,
            max: 1.0,
            nodes: 10_000,
        });
        let ranges = [wide, wide, None, None, None, None];
        assert_eq!(
            table_grid(&ranges, Spelling::Keywords).unwrap_err(),
            "x 10000 x y 10000 x z 1 x roll 1 x pitch 1 x yaw 1 make more than 10000000 nodes, the most a table may have"
        );
        assert!(
            table_grid(&ranges, Spelling::Flags)
                .unwrap_err()
                .starts_with("--table: x 10000 x y 10000")
        );
    }
}
