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

use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::Point3;
use crate::artefacts::{Ball, BallIndex};
use crate::check::{self, Check, not_finite};
use crate::checksum::Crc32;
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

    /// The CRC-32 of its snapshot encoding (postcard, as its `Serialize`
    /// writes it: `ball`, `q`, then `direction` as an option), each column
    /// in pieces on the threads ([`Crc32::of_seq`]).
    pub(crate) fn encoded_crc(&self) -> Crc32 {
        let mut crc = Crc32::of_seq(&self.ball);
        crc.append(&Crc32::of_seq(&self.q));
        match &self.direction {
            None => crc.encode(&None::<()>),
            Some(direction) => {
                crc.encode(&Some(()));
                crc.append(&Crc32::of_seq(direction));
            }
        }
        crc
    }

    /// Reads `measurements.csv`, resolving ball ids by the artefacts' `index`
    /// ([`crate::artefacts::ball_index`]) row by row; `scale` is the
    /// actuators' (mm per unit). Of several errors, the one earliest in the
    /// file, an unknown ball id among them.
    pub(crate) fn read(path: &Path, index: &BallIndex, scale: &[f64; 6]) -> Result<Self> {
        let mut out = Self::default();
        read_rows(
            path,
            |columns, row, piece: &mut Piece| piece.push_row(row, columns, index, scale),
            |piece| out.append(&mut piece.touches),
        )?;
        Ok(out)
    }

    /// Reads `measurements.csv` before the artefacts are known: each row's
    /// ball id kept as it is written, to be resolved by
    /// [`Unresolved::resolve`]. An error here, or an id that does not
    /// resolve, is named by [`Measurements::read`].
    pub(crate) fn read_unresolved(path: &Path, scale: &[f64; 6]) -> Result<Unresolved> {
        let mut out = Unresolved::default();
        read_rows(
            path,
            |columns, row, piece: &mut Unresolved| piece.push_row(row, columns, scale),
            |piece| out.append(piece),
        )?;
        Ok(out)
    }

    /// Moves the contacts of `more` to the end of these.
    fn append(&mut self, more: &mut Self) {
        self.ball.append(&mut more.ball);
        self.q.append(&mut more.q);
        // A piece without rows has no directions to add.
        if let Some(more) = &mut more.direction {
            self.direction.get_or_insert_with(Vec::new).append(more);
        }
    }

    /// Appends a row's readings `q` and approach `direction` (its ball's
    /// index is the caller's).
    fn push_readings(&mut self, (q, direction): ([f64; 6], Option<Point3>)) {
        self.q.push(q);
        if let Some(d) = direction {
            self.direction.get_or_insert_with(Vec::new).push(d);
        }
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
        // The rows on the threads, the first bad one named.
        let first_bad =
            (self.ball.par_iter().zip(&self.q).enumerate()).find_map_first(|(row, (&ball, q))| {
                if ball as usize >= ball_count {
                    return Some(bad(
                        row,
                        BALL,
                        format!("ball index {ball} is out of range ({ball_count} balls)"),
                    ));
                }
                let direction = self.direction.as_ref().map(|d| &d[row]);
                let (column, message) = row_problem(q, direction, scale)?;
                Some(DatasetError::csv(check.path(), line(row), column, message))
            });
        first_bad.map_or(Ok(()), Err)
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
        let readings = readings(row, columns, scale)?;
        self.touches.ball.push(ball);
        self.touches.push_readings(readings);
        Ok(())
    }
}

/// The contacts of measurements.csv read before the artefacts (their balls'
/// indices not yet known) and their rows' ball ids.
#[derive(Default)]
pub(crate) struct Unresolved {
    touches: Measurements,
    ids: IdRuns,
}

impl Unresolved {
    /// Appends the contact of `row` (its `columns`, `scale` the actuators'),
    /// its ball id kept.
    fn push_row(&mut self, row: &Row, columns: &Columns, scale: &[f64; 6]) -> Result<(), Failure> {
        let readings = readings(row, columns, scale)?;
        self.ids.push(row.field(columns.ball));
        self.touches.push_readings(readings);
        Ok(())
    }

    /// Moves the contacts of `more` (the rows after these) to the end.
    fn append(&mut self, more: &mut Self) {
        self.touches.append(&mut more.touches);
        self.ids.append(&mut more.ids);
    }

    /// The contacts, their balls' indices by the artefacts' `index`;
    /// `None` if an id is not in it (or its index does not fit a
    /// measurement's `u32`), for [`Measurements::read`] to name.
    pub(crate) fn resolve(self, index: &BallIndex) -> Option<Measurements> {
        let Self { mut touches, ids } = self;
        touches.ball.reserve_exact(touches.q.len());
        let mut start = 0;
        for &(end, rows) in &ids.runs {
            let ball = u32::try_from(*index.get(&ids.bytes[start..end])?).ok()?;
            touches.ball.extend(std::iter::repeat_n(ball, rows));
            start = end;
        }
        Some(touches)
    }
}

/// Ball ids of rows in file order, as runs of consecutive rows of one id
/// (a ball's touches are usually consecutive): each run's id once, the
/// ids' bytes side by side.
#[derive(Default)]
struct IdRuns {
    bytes: Vec<u8>,
    /// Each run's end in `bytes` (its start the run before's end) and its
    /// number of rows.
    runs: Vec<(usize, usize)>,
}

impl IdRuns {
    /// The id of the next row.
    fn push(&mut self, id: &[u8]) {
        let start = self.runs.len().checked_sub(2).map_or(0, |k| self.runs[k].0);
        match self.runs.last_mut() {
            Some((end, rows)) if &self.bytes[start..*end] == id => *rows += 1,
            _ => {
                self.bytes.extend_from_slice(id);
                self.runs.push((self.bytes.len(), 1));
            }
        }
    }

    /// Moves the runs of `more` (the rows after these) to the end.
    fn append(&mut self, more: &mut Self) {
        let offset = self.bytes.len();
        self.bytes.append(&mut more.bytes);
        let runs = more.runs.drain(..).map(|(end, rows)| (end + offset, rows));
        self.runs.extend(runs);
    }
}

/// The rows of `measurements.csv` at `path`, each passed to `each` with
/// its piece's accumulator, the pieces emptied by `gather` in file order
/// ([`table::read_file_in_pieces`]).
fn read_rows<A: Default + Send>(
    path: &Path,
    each: impl Fn(&Columns, &Row, &mut A) -> Result<(), Failure> + Sync,
    gather: impl FnMut(&mut A),
) -> Result<()> {
    let expected = format!("{BALL},{}", Q.join(","));
    table::read_file_in_pieces(
        path,
        &expected,
        "measurement",
        |header| Columns::locate(header, &expected),
        each,
        gather,
    )
}

/// A row's readings and approach direction (its `columns`), checked
/// ([`row_problem`], `scale` the actuators').
fn readings(
    row: &Row,
    columns: &Columns,
    scale: &[f64; 6],
) -> Result<([f64; 6], Option<Point3>), Failure> {
    let q = row.numbers(&columns.q, &Q)?;
    let direction = match &columns.dir {
        Some(dir) => Some(row.numbers(dir, &DIR)?),
        None => None,
    };
    match row_problem(&q, direction.as_ref(), scale) {
        Some((column, message)) => Err(row.error(column, message)),
        None => Ok((q, direction)),
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

#[cfg(test)]
mod tests {
    use super::*;

    /// The columns' CRC in pieces is the CRC of the whole encoding, with
    /// and without approach directions, over several pieces and none.
    #[test]
    fn encoded_crc_is_that_of_the_whole_encoding() {
        let whole =
            |m: &Measurements| crate::checksum::of_bytes(&postcard::to_allocvec(m).unwrap());
        for n in [0, 1, 40_000] {
            let mut m = Measurements {
                ball: (0..n).map(|i| (i * 7919 % 300) as u32).collect(),
                q: (0..n)
                    .map(|i| [i as f64 * 0.25, -1.5, 3.0, 1e-9, f64::MAX, -0.0])
                    .collect(),
                direction: None,
            };
            assert_eq!(m.encoded_crc().checksum(), whole(&m), "{n} rows");
            m.direction = Some((0..n).map(|i| [i as f64, 0.5, -2.0]).collect());
            assert_eq!(
                m.encoded_crc().checksum(),
                whole(&m),
                "{n} rows with directions"
            );
        }
    }

    /// Ids in runs, a ball's touches apart and runs split between pieces,
    /// resolve to the indices row by row resolution gives.
    #[test]
    fn id_runs_resolve_row_by_row() {
        let rows: [&[u8]; 7] = [b"b2", b"b2", b"b10", b"b2", b"b1", b"b1", b"b10"];
        let index: BallIndex = [(&b"b1"[..], 0), (b"b2", 1), (b"b10", 2)]
            .into_iter()
            .collect();
        let piece = |rows: &[&[u8]]| {
            let mut piece = Unresolved::default();
            for id in rows {
                piece.ids.push(id);
                piece.touches.push_readings(([0.0; 6], None));
            }
            piece
        };
        let (mut all, mut second) = (piece(&rows[..4]), piece(&rows[4..]));
        all.append(&mut second);
        assert_eq!(all.ids.runs.len(), 5);
        let resolved = all.resolve(&index).expect("every id is in the index");
        let by_row: Vec<u32> = rows.iter().map(|id| index[id] as u32).collect();
        assert_eq!(resolved.ball, by_row);
        assert_eq!(piece(&[b"b3"]).resolve(&index), None);
    }
}
