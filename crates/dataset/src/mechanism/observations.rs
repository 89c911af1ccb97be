//! A mechanism dataset's observation files, each optional:
//!
//! | file | header | one row per |
//! |---|---|---|
//! | `probes.csv` | `x,y,z` | probe: the commanded XY and the height at which it triggered (mm) |
//! | `distances.csv` | `x1,y1,z1,x2,y2,z2,distance` | distance measured between two commanded positions (mm, positive) |
//! | `points.csv` | `q1..qA,x,y,z[,f1..fA]` | readings of the `A` actuators, the position where known (`x,y,z` empty where not), and optionally the actuators' loads (`f1..fA`, a cable robot's line forces; empty where not recorded) |
//!
//! Every file holds at most [`OBSERVATIONS`]`.max` rows, counted as they are
//! read, so that a huge file is refused before it fills memory.

use std::path::Path;

use crate::bounds::Count;
use crate::error::{DatasetError, Result};
use crate::numbers::{OtherColumns, read_numbers_within};
use crate::table::{self, Failure, Header, Row};

use super::RowNames;

/// The bounds of the rows of each observation file: at least one (an
/// empty file is an error), at most a million (far beyond a calibration's
/// needs; each row costs a forward kinematics per iteration).
pub const OBSERVATIONS: Count = Count::new(
    1,
    1_000_000,
    "each row costs a forward kinematics per iteration",
);

/// The columns of probes.csv.
pub const PROBE_COLUMNS: [&str; 3] = ["x", "y", "z"];
/// The columns of heights.csv.
pub const HEIGHT_COLUMNS: [&str; 4] = ["x", "y", "z", "height"];
/// The columns of distances.csv.
pub const DISTANCE_COLUMNS: [&str; 7] = ["x1", "y1", "z1", "x2", "y2", "z2", "distance"];
/// The reading columns of points.csv, of which a mechanism of `A`
/// actuators uses the first `A`.
pub const READING_COLUMNS: [&str; 8] = ["q1", "q2", "q3", "q4", "q5", "q6", "q7", "q8"];
/// The position columns of points.csv.
pub const POSITION_COLUMNS: [&str; 3] = ["x", "y", "z"];
/// The optional load columns of points.csv, of which a mechanism of `A`
/// actuators uses the first `A`.
pub const LOAD_COLUMNS: [&str; 8] = ["f1", "f2", "f3", "f4", "f5", "f6", "f7", "f8"];

/// One row of points.csv: the readings, and the position if it was
/// measured.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct SampleRow {
    /// The readings, one per actuator.
    pub readings: Vec<f64>,
    /// The measured position (mm), if any.
    pub position: Option<[f64; 3]>,
    /// The loads the actuators held (a cable robot's line forces, N), if
    /// recorded.
    pub loads: Option<Vec<f64>>,
}

/// The error of a file with more rows than [`OBSERVATIONS`] allows.
pub(crate) fn too_many(row: &Row, what: &str) -> Failure {
    row.error(
        None,
        OBSERVATIONS.refusal(&format!("the number of {what} rows"), "more"),
    )
}

/// Reads the table `path` of `columns` (in any order, no other), every
/// field a finite number, at most [`OBSERVATIONS`] rows.
pub(crate) fn read_rows<const N: usize>(
    path: &Path,
    columns: &[&'static str; N],
    what: &str,
) -> Result<Vec<[f64; N]>> {
    let within = (Some(&OBSERVATIONS), OtherColumns::Refused);
    read_numbers_within(path, columns, what, within)
}

/// Writes `rows` under `columns` to `path` atomically.
pub(crate) fn write_rows<const N: usize>(
    path: &Path,
    columns: &[&'static str; N],
    rows: &[[f64; N]],
) -> Result<()> {
    table::write_file(path, columns, |w| {
        for row in rows {
            w.numbers(row)?;
            w.end_row()?;
        }
        Ok(())
    })
}

/// Reads points.csv at `path` for a mechanism of `actuators` actuators:
/// `q1..qA` and `x,y,z`, the position's three fields all empty or all
/// numbers, and `f1..fA` if the header names them, likewise; no other
/// column.
pub(crate) fn read_samples(path: &Path, actuators: usize) -> Result<Vec<SampleRow>> {
    let readings = &READING_COLUMNS[..actuators];
    let loads = &LOAD_COLUMNS[..actuators];
    let expected = readings
        .iter()
        .chain(&POSITION_COLUMNS)
        .copied()
        .collect::<Vec<_>>()
        .join(",");
    table::read_file(path, |reader| {
        let header = Header::read(reader, &expected)?;
        let known: Vec<&str> = readings
            .iter()
            .chain(&POSITION_COLUMNS)
            .chain(loads)
            .copied()
            .collect();
        header.only(&known, &format!("{expected}[,{}]", loads.join(",")))?;
        let at_readings = readings
            .iter()
            .map(|name| header.require(name, &expected))
            .collect::<std::result::Result<Vec<usize>, Failure>>()?;
        let at_position = header.require_all(&POSITION_COLUMNS, &expected)?;
        let at_loads = optional_group(&header, "load", loads)?;
        let mut rows = Vec::new();
        table::for_each_row(reader, &header, "point", |row| {
            if rows.len() == OBSERVATIONS.max {
                return Err(too_many(row, "point"));
            }
            let mut values = Vec::with_capacity(actuators);
            for (&column, &name) in at_readings.iter().zip(readings) {
                values.push(row.numbers(&[column], &[name])?[0]);
            }
            let position = whole_or_empty(row, &at_position, &POSITION_COLUMNS, "position")?
                .map(|xyz| [xyz[0], xyz[1], xyz[2]]);
            let loads = match &at_loads {
                Some(at_loads) => whole_or_empty(row, at_loads, loads, "loads")?,
                None => None,
            };
            rows.push(SampleRow {
                readings: values,
                position,
                loads,
            });
            Ok(())
        })?;
        Ok(rows)
    })
}

/// The places of the optional `what` columns `names`, which a header
/// names all or none of: `None` when none; an error naming them when only
/// some.
pub(super) fn optional_group(
    header: &Header,
    what: &str,
    names: &[&str],
) -> std::result::Result<Option<Vec<usize>>, Failure> {
    let at = names
        .iter()
        .map(|name| header.find(name))
        .collect::<std::result::Result<Option<Vec<usize>>, Failure>>()?;
    if at.is_none()
        && names
            .iter()
            .any(|name| matches!(header.find(name), Ok(Some(_))))
    {
        return Err(header.error(format!(
            "the header names some of the {what} columns {} but not all",
            names.join(",")
        )));
    }
    Ok(at)
}

/// The numbers of `columns` (named `names`) of `row`: all empty, `None`;
/// all numbers, `Some`; else an error naming `what`.
pub(super) fn whole_or_empty(
    row: &Row,
    columns: &[usize],
    names: &[&'static str],
    what: &str,
) -> std::result::Result<Option<Vec<f64>>, Failure> {
    let empty: Vec<bool> = columns.iter().map(|&c| row.field(c).is_empty()).collect();
    if empty.iter().all(|&e| e) {
        return Ok(None);
    }
    if empty.iter().any(|&e| e) {
        return Err(row.error(
            None,
            format!(
                "the {what} {} must be given whole or left empty whole",
                names.join(",")
            ),
        ));
    }
    let mut values = Vec::with_capacity(columns.len());
    for (&column, &name) in columns.iter().zip(names) {
        values.push(row.numbers(&[column], &[name])?[0]);
    }
    Ok(Some(values))
}

/// Writes points.csv at `path` for a mechanism of `actuators` actuators,
/// with the load columns if any row has loads. Refuses a row of another
/// number of readings or loads, naming the line it would have.
pub(crate) fn write_samples(path: &Path, actuators: usize, rows: &[SampleRow]) -> Result<()> {
    let miscounted = |r: &SampleRow| {
        r.readings.len() != actuators || r.loads.as_ref().is_some_and(|f| f.len() != actuators)
    };
    if let Some(k) = rows.iter().position(miscounted) {
        return Err(DatasetError::Field {
            path: path.to_path_buf(),
            field: RowNames::Lines.of(k),
            message: format!(
                "{} readings and {} loads for {actuators} actuators",
                rows[k].readings.len(),
                rows[k].loads.as_ref().map_or(0, Vec::len)
            ),
        });
    }
    let with_loads = rows.iter().any(|r| r.loads.is_some());
    let load_columns = if with_loads {
        &LOAD_COLUMNS[..actuators]
    } else {
        &[]
    };
    let header: Vec<&str> = READING_COLUMNS[..actuators]
        .iter()
        .chain(&POSITION_COLUMNS)
        .chain(load_columns)
        .copied()
        .collect();
    table::write_file(path, &header, |w| {
        for row in rows {
            w.numbers(&row.readings)?;
            match &row.position {
                Some(position) => w.numbers(position)?,
                None => {
                    for _ in 0..3 {
                        w.text("")?;
                    }
                }
            }
            match &row.loads {
                Some(loads) => w.numbers(loads)?,
                None => {
                    for _ in load_columns {
                        w.text("")?;
                    }
                }
            }
            w.end_row()?;
        }
        Ok(())
    })
}
