//! A mechanism dataset's calibrated balls and their touches, both files
//! optional but each needing the other:
//!
//! | file | header | one row per |
//! |---|---|---|
//! | `balls.csv` | `ball,radius,radius_sigma` and optionally `x,y,z,centre_sigma` | ball: its number (0 for the first row, 1 for the next, …), its calibrated radius (mm) and the standard deviation of that calibration (mm; empty: exact); where it was placed and how well (mm, the controller's coordinates; all four empty: not known) |
//! | `touches.csv` | `ball,x,y,z` | touch: the ball's number and the commanded position at which the tool point touched it (mm, the controller's coordinates) |
//!
//! The touch's noise is `machine.json`'s `noise.touch`. Each file holds at
//! most [`BALLS`]`.max` and [`OBSERVATIONS`]`.max` rows, counted as they
//! are read; errors name the line and column.

use std::path::Path;

use crate::bounds::Count;
use crate::error::Result;
use crate::table::{self, Failure, Header, Row};

use super::observations::{OBSERVATIONS, optional_group, too_many, whole_or_empty};

/// The bounds of the rows of balls.csv.
pub const BALLS: Count = Count::new(
    1,
    OBSERVATIONS.max / 4,
    "each ball takes at least 4 of touches.csv's rows",
);

/// The columns of balls.csv.
pub const BALL_COLUMNS: [&str; 3] = ["ball", "radius", "radius_sigma"];
/// The optional columns of balls.csv: where a ball was placed and the
/// standard deviation of each coordinate ([`BallPlacement`]).
pub const PLACEMENT_COLUMNS: [&str; 4] = ["x", "y", "z", "centre_sigma"];
/// The columns of touches.csv.
pub const TOUCH_COLUMNS: [&str; 4] = ["ball", "x", "y", "z"];

/// One row of balls.csv.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct BallRow {
    /// The calibrated radius (mm, positive).
    pub radius: f64,
    /// The standard deviation of its calibration (mm, positive); `None`:
    /// exact.
    pub radius_sigma: Option<f64>,
    /// Where it was placed, if known: a prior on its centre.
    pub placement: Option<BallPlacement>,
}

/// Where a ball was placed: its centre (mm, the controller's coordinates)
/// and the standard deviation of each coordinate (mm, positive).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct BallPlacement {
    /// The centre.
    pub centre: [f64; 3],
    /// Each coordinate's standard deviation.
    pub sigma: f64,
}

/// One row of touches.csv.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct TouchRow {
    /// The ball's number (its row in balls.csv, from 0).
    pub ball: usize,
    /// The commanded position at the touch (mm).
    pub commanded: [f64; 3],
}

/// The ball number in column `column` (named `name`) of `row`: a whole
/// number below `count` (the balls so far, or all of them), else an error
/// saying the value `of`.
pub(super) fn ball_number(
    row: &Row,
    column: usize,
    name: &'static str,
    count: usize,
    of: &str,
) -> Result<usize, Failure> {
    let [value] = row.numbers(&[column], &[name])?;
    if value.fract() != 0.0 || value < 0.0 || value >= count as f64 {
        return Err(row.error(Some(name), format!("{value} {of}")));
    }
    Ok(value as usize)
}

/// The positive number in column `column` (named `name`) of `row`.
pub(super) fn positive(row: &Row, column: usize, name: &'static str) -> Result<f64, Failure> {
    let [value] = row.numbers(&[column], &[name])?;
    if value <= 0.0 {
        return Err(row.error(Some(name), format!("{value} is not positive")));
    }
    Ok(value)
}

/// The message of a ball number in a file that refers to the `balls`
/// balls of balls.csv, after the number.
pub(super) fn not_a_ball(balls: usize) -> String {
    format!("is not the number of a ball of balls.csv, which has {balls}")
}

/// Reads balls.csv at `path`: each row's `ball` its 0-based row number,
/// each radius positive, each sigma empty or positive, each placement
/// given whole (its sigma positive) or left empty, at most [`BALLS`]`.max`
/// rows.
pub(crate) fn read_balls(path: &Path) -> Result<Vec<BallRow>> {
    let expected = BALL_COLUMNS.join(",");
    table::read_file(path, |reader| {
        let header = Header::read(reader, &expected)?;
        let known: Vec<&str> = BALL_COLUMNS
            .iter()
            .chain(&PLACEMENT_COLUMNS)
            .copied()
            .collect();
        header.only(
            &known,
            &format!("{expected}[,{}]", PLACEMENT_COLUMNS.join(",")),
        )?;
        let [ball_at, radius_at, sigma_at] = header.require_all(&BALL_COLUMNS, &expected)?;
        let at_placement = optional_group(&header, "placement", &PLACEMENT_COLUMNS)?;
        let mut rows: Vec<BallRow> = Vec::new();
        table::for_each_row(reader, &header, "ball", |row| {
            if rows.len() == BALLS.max {
                return Err(row.error(None, BALLS.refusal("the number of ball rows", "more")));
            }
            let number = rows.len();
            let [value] = row.numbers(&[ball_at], &["ball"])?;
            if value != number as f64 {
                return Err(row.error(
                    Some("ball"),
                    format!("{value} is not this row's number, {number} (the balls are numbered from 0 in order)"),
                ));
            }
            let radius = positive(row, radius_at, "radius")?;
            let radius_sigma = if row.field(sigma_at).is_empty() {
                None
            } else {
                let [sigma] = row.numbers(&[sigma_at], &["radius_sigma"])?;
                if sigma <= 0.0 {
                    return Err(row.error(
                        Some("radius_sigma"),
                        format!(
                            "{sigma} is not a positive standard deviation (exact: leave it empty)"
                        ),
                    ));
                }
                Some(sigma)
            };
            let placement = match &at_placement {
                Some(at) => placement(row, at)?,
                None => None,
            };
            rows.push(BallRow {
                radius,
                radius_sigma,
                placement,
            });
            Ok(())
        })?;
        Ok(rows)
    })
}

/// Reads touches.csv at `path` for `balls` balls: each `ball` one of
/// them, each position finite, at most [`OBSERVATIONS`]`.max` rows.
pub(crate) fn read_touches(path: &Path, balls: usize) -> Result<Vec<TouchRow>> {
    let expected = TOUCH_COLUMNS.join(",");
    table::read_file(path, |reader| {
        let header = Header::read(reader, &expected)?;
        header.only(&TOUCH_COLUMNS, &expected)?;
        let [ball_at, x_at, y_at, z_at] = header.require_all(&TOUCH_COLUMNS, &expected)?;
        let mut rows = Vec::new();
        let of = not_a_ball(balls);
        table::for_each_row(reader, &header, "touch", |row| {
            if rows.len() == OBSERVATIONS.max {
                return Err(too_many(row, "touch"));
            }
            let ball = ball_number(row, ball_at, "ball", balls, &of)?;
            let commanded = row.numbers(&[x_at, y_at, z_at], &["x", "y", "z"])?;
            rows.push(TouchRow { ball, commanded });
            Ok(())
        })?;
        Ok(rows)
    })
}

/// The placement of a row of balls.csv from its columns `at`
/// ([`PLACEMENT_COLUMNS`]): all empty, `None`; all numbers with a
/// positive sigma, `Some`.
fn placement(row: &Row, at: &[usize]) -> std::result::Result<Option<BallPlacement>, Failure> {
    let Some(values) = whole_or_empty(row, at, &PLACEMENT_COLUMNS, "placement")? else {
        return Ok(None);
    };
    if values[3] <= 0.0 {
        return Err(row.error(
            Some("centre_sigma"),
            format!(
                "{} is not a positive standard deviation (not known: leave x,y,z,centre_sigma empty)",
                values[3]
            ),
        ));
    }
    Ok(Some(BallPlacement {
        centre: [values[0], values[1], values[2]],
        sigma: values[3],
    }))
}

/// Writes balls.csv at `path` atomically, with the placement columns if
/// any ball has a placement.
pub(crate) fn write_balls(path: &Path, rows: &[BallRow]) -> Result<()> {
    let placed = rows.iter().any(|row| row.placement.is_some());
    let columns: Vec<&str> = if placed {
        BALL_COLUMNS
            .iter()
            .chain(&PLACEMENT_COLUMNS)
            .copied()
            .collect()
    } else {
        BALL_COLUMNS.to_vec()
    };
    table::write_file(path, &columns, |w| {
        for (number, row) in rows.iter().enumerate() {
            w.numbers(&[number as f64, row.radius])?;
            match row.radius_sigma {
                Some(sigma) => w.numbers(&[sigma])?,
                None => w.text("")?,
            }
            match (placed, row.placement) {
                (true, Some(p)) => w.numbers(&[p.centre[0], p.centre[1], p.centre[2], p.sigma])?,
                (true, None) => (0..PLACEMENT_COLUMNS.len()).try_for_each(|_| w.text(""))?,
                (false, _) => {}
            }
            w.end_row()?;
        }
        Ok(())
    })
}

/// Writes touches.csv at `path` atomically.
pub(crate) fn write_touches(path: &Path, rows: &[TouchRow]) -> Result<()> {
    table::write_file(path, &TOUCH_COLUMNS, |w| {
        for row in rows {
            w.numbers(&[row.ball as f64])?;
            w.numbers(&row.commanded)?;
            w.end_row()?;
        }
        Ok(())
    })
}
