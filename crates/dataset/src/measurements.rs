//! `measurements.csv`: one row per contact, read in blocks, each parsed in
//! pieces side by side ([`table::read_file_in_pieces`]).
//!
//! Columns are found by header name, in any order; other columns are
//! ignored, fields are trimmed of surrounding (ASCII) whitespace and blank
//! lines are skipped. Each piece goes through one reused `csv::ByteRecord`,
//! trims each field as it is used and parses numbers from the bytes, so
//! reading allocates nothing per row (except to report an error) and scales
//! to millions of rows. Writing uses Rust's shortest round-trip form of each
//! `f64` (`{}`), so values read back bit for bit.

use std::path::Path;

use serde::{Deserialize, Serialize};

use crate::Point3;
use crate::artefacts::{Ball, BallIndex};
use crate::check::{self, Check, not_finite};
use crate::error::{DatasetError, Result};
use crate::quote::quoted_bytes;
use crate::table::{self, Failure, Header, Row};

const BALL: &str = "ball";
const Q: [&str; 6] = ["q1", "q2", "q3", "q4", "q5", "q6"];
const DIR: [&str; 3] = ["dir_x", "dir_y", "dir_z"];

/// The contacts, as a struct of arrays: one entry per row of
/// `measurements.csv`, in file order.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct Measurements {
    /// Index of the touched ball in [`Artefacts::balls`](crate::Artefacts::balls).
    pub ball: Vec<u32>,
    /// The six actuator expansions at the moment of contact.
    pub q: Vec<[f64; 6]>,
    /// The commanded approach directions (outward normal at the intended
    /// contact point, base frame of the artefacts), if the file has them.
    pub direction: Option<Vec<Point3>>,
}

impl Measurements {
    /// Number of contacts (rows).
    pub fn len(&self) -> usize {
        self.ball.len()
    }

    /// Whether there is no contact.
    pub fn is_empty(&self) -> bool {
        self.ball.is_empty()
    }

    /// Reads `measurements.csv`, resolving ball ids by the artefacts' `index`
    /// ([`crate::artefacts::ball_index`]); `scale` is the actuators' (mm per
    /// unit).
    pub(crate) fn read(path: &Path, index: &BallIndex, scale: &[f64; 6]) -> Result<Self> {
        let expected = format!("{BALL},{}", Q.join(","));
        let mut out = Self::default();
        table::read_file_in_pieces(
            path,
            &expected,
            "measurement",
            |header| Columns::locate(header, &expected),
            |columns, row, piece: &mut Piece| piece.push_row(row, columns, index, scale),
            |piece| {
                let piece = &mut piece.touches;
                out.ball.append(&mut piece.ball);
                out.q.append(&mut piece.q);
                // A piece without rows has no directions to add.
                if let Some(more) = &mut piece.direction {
                    out.direction.get_or_insert_with(Vec::new).append(more);
                }
            },
        )?;
        Ok(out)
    }

    /// Writes `measurements.csv` (the caller has validated): floats in Rust's
    /// shortest round-trip form.
    pub(crate) fn write(&self, path: &Path, balls: &[Ball]) -> Result<()> {
        let mut header = vec![BALL];
        header.extend(Q);
        if self.direction.is_some() {
            header.extend(DIR);
        }
        table::write_file(path, &header, |w| {
            for (row, (&ball, q)) in self.ball.iter().zip(&self.q).enumerate() {
                w.text(&balls[ball as usize].id)?;
                w.numbers(q)?;
                if let Some(directions) = &self.direction {
                    w.numbers(&directions[row])?;
                }
                w.end_row()?;
            }
            Ok(())
        })
    }

    /// Arrays of equal length, ball indices in range, rows as
    /// [`row_problem`] wants them (`scale`: the actuators'). Errors name the
    /// line the row has (or would have) in `measurements.csv`.
    pub(crate) fn validate(&self, check: Check, ball_count: usize, scale: &[f64; 6]) -> Result<()> {
        let rows = self.len();
        if rows == 0 {
            return Err(check.error("ball", "no measurement rows"));
        }
        if self.q.len() != rows {
            return Err(check.error("q", format!("has {} rows, ball has {rows}", self.q.len())));
        }
        if let Some(directions) = &self.direction
            && directions.len() != rows
        {
            return Err(check.error(
                "direction",
                format!("has {} rows, ball has {rows}", directions.len()),
            ));
        }
        let line = |row: usize| row as u64 + 2;
        let bad = |row: usize, column: &str, message: String| {
            DatasetError::csv(check.path(), line(row), Some(column), message)
        };
        for (row, (&ball, q)) in self.ball.iter().zip(&self.q).enumerate() {
            if ball as usize >= ball_count {
                return Err(bad(
                    row,
                    BALL,
                    format!("ball index {ball} is out of range ({ball_count} balls)"),
                ));
            }
            let direction = self.direction.as_ref().map(|d| &d[row]);
            if let Some((column, message)) = row_problem(q, direction, scale) {
                return Err(DatasetError::csv(check.path(), line(row), column, message));
            }
        }
        Ok(())
    }

    /// Number of contacts of each of `ball_count` balls.
    pub(crate) fn count_per_ball(&self, ball_count: usize) -> Vec<usize> {
        let mut counts = vec![0; ball_count];
        for &b in &self.ball {
            // Out-of-range indices (an invalid dataset) are not counted.
            if let Some(count) = counts.get_mut(b as usize) {
                *count += 1;
            }
        }
        counts
    }
}

/// The contacts of one piece of measurements.csv, and the ball id its last
/// row resolved: a ball's touches are usually consecutive rows, whose id is
/// then compared with that one instead of looked up again.
#[derive(Default)]
struct Piece<'a> {
    touches: Measurements,
    last: Option<(&'a [u8], u32)>,
}

impl<'a> Piece<'a> {
    /// Appends the contact of `row` (its `columns`; ball ids resolved by
    /// `index`, `scale` the actuators').
    fn push_row(
        &mut self,
        row: &Row,
        columns: &Columns,
        index: &BallIndex<'a>,
        scale: &[f64; 6],
    ) -> Result<(), Failure> {
        let id = row.field(columns.ball);
        let ball = match self.last {
            Some((last, ball)) if last == id => ball,
            _ => {
                let (&key, &ball) = index.get_key_value(id).ok_or_else(|| {
                    row.error(
                        Some(BALL),
                        format!(
                            "unknown ball id {} (not in artefacts.json)",
                            quoted_bytes(id)
                        ),
                    )
                })?;
                let ball = u32::try_from(ball).map_err(|_| {
                    row.error(
                        Some(BALL),
                        format!(
                            "ball index {ball} is beyond the {} a measurement can hold",
                            u32::MAX
                        ),
                    )
                })?;
                self.last = Some((key, ball));
                ball
            }
        };
        let q = row.numbers(&columns.q, &Q)?;
        let direction = match &columns.dir {
            Some(dir) => Some(row.numbers(dir, &DIR)?),
            None => None,
        };
        if let Some((column, message)) = row_problem(&q, direction.as_ref(), scale) {
            return Err(row.error(column, message));
        }
        let out = &mut self.touches;
        out.ball.push(ball);
        out.q.push(q);
        if let Some(d) = direction {
            out.direction.get_or_insert_with(Vec::new).push(d);
        }
        Ok(())
    }
}

/// What is wrong with a row's numbers, if anything, and in which column:
/// the readings as [`check::readings`] wants them, the direction's
/// coordinates finite and its length, as the calibration normalises it
/// (`sqrt(x² + y² + z²)`), finite and non-zero.
fn row_problem(
    q: &[f64; 6],
    direction: Option<&Point3>,
    scale: &[f64; 6],
) -> Option<(Option<&'static str>, String)> {
    if let Some((k, message)) = check::readings(q, scale) {
        return Some((Some(Q[k]), message));
    }
    let d = direction?;
    if let Some(k) = d.iter().position(|v| !v.is_finite()) {
        return Some((Some(DIR[k]), not_finite(d[k])));
    }
    let length = d.iter().map(|v| v * v).sum::<f64>().sqrt();
    if length.is_finite() && length > 0.0 {
        return None;
    }
    let shown = format!(
        "({}, {}, {})",
        check::shown(d[0]),
        check::shown(d[1]),
        check::shown(d[2])
    );
    let why = if length > 0.0 {
        "is too large to normalise (its length overflows); give a unit vector"
    } else if d.iter().all(|&v| v == 0.0) {
        "is zero, not a direction"
    } else {
        "is too small to normalise (its length underflows to 0); give a unit vector"
    };
    Some((None, format!("the approach direction {shown} {why}")))
}

/// Where each column of interest is, by header name.
struct Columns {
    ball: usize,
    q: [usize; 6],
    dir: Option<[usize; 3]>,
}

impl Columns {
    fn locate(header: &Header, expected: &str) -> Result<Self, Failure> {
        let ball = header.require(BALL, expected)?;
        let q = header.require_all(&Q, expected)?;
        let dir = [
            header.find(DIR[0])?,
            header.find(DIR[1])?,
            header.find(DIR[2])?,
        ];
        let dir = match dir {
            [Some(x), Some(y), Some(z)] => Some([x, y, z]),
            [None, None, None] => None,
            _ => {
                let names = |present: bool| {
                    DIR.iter()
                        .zip(dir)
                        .filter(|(_, column)| column.is_some() == present)
                        .map(|(name, _)| *name)
                        .collect::<Vec<_>>()
                };
                let (present, absent) = (names(true), names(false));
                return Err(header.error(format!(
                    "the header has column {} but not {} (give all of {} or none)",
                    present.join(", "),
                    absent.join(", "),
                    DIR.join(",")
                )));
            }
        };
        Ok(Self { ball, q, dir })
    }
}
