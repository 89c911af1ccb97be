//! `measurements.csv`: one row per contact, streamed.
//!
//! Columns are found by header name, in any order; other columns are
//! ignored, fields are trimmed of surrounding (ASCII) whitespace and blank
//! lines are skipped. Reading goes through one reused `csv::ByteRecord`,
//! trims each field as it is used and parses numbers from the bytes, so it
//! allocates nothing per row (except to report an error) and scales to
//! millions of rows. Writing uses Rust's shortest round-trip form of each
//! `f64` (`{}`), so values read back bit for bit.

use std::collections::HashMap;
use std::fmt::Write as _;
use std::fs::File;
use std::io::{self, Read, Seek, SeekFrom};
use std::path::Path;

use csv::{ByteRecord, ReaderBuilder};
use serde::{Deserialize, Serialize};

use crate::Point3;
use crate::artefacts::{Ball, ball_index};
use crate::atomic::{write_atomic, write_error};
use crate::check::{Check, not_finite};
use crate::error::{DatasetError, Result};

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

    /// Reads `measurements.csv`, resolving ball ids against `balls` (whose
    /// ids are unique).
    pub(crate) fn read(path: &Path, balls: &[Ball]) -> Result<Self> {
        let file = File::open(path).map_err(|e| match e.kind() {
            io::ErrorKind::NotFound => DatasetError::MissingFile {
                path: path.to_path_buf(),
            },
            _ => DatasetError::io(path, "read", e),
        })?;
        Self::parse(path, file, balls)
    }

    /// Parses CSV from `input`; errors name `path`. `input` is read once,
    /// front to back; it is rewound only to find the line of an error.
    pub(crate) fn parse<R: Read + Seek>(path: &Path, input: R, balls: &[Ball]) -> Result<Self> {
        let mut reader = ReaderBuilder::new().flexible(true).from_reader(input);
        match Self::parse_records(&mut reader, balls) {
            Ok(measurements) => Ok(measurements),
            Err(Failure::Csv(e)) => Err(csv_error(path, e)),
            Err(Failure::At {
                end,
                inner_newlines,
                estimate,
                column,
                message,
            }) => {
                let line = line_of(reader.into_inner(), end, inner_newlines).unwrap_or(estimate);
                Err(DatasetError::csv(path, line, column, message))
            }
        }
    }

    fn parse_records<R: Read>(
        reader: &mut csv::Reader<R>,
        balls: &[Ball],
    ) -> Result<Self, Failure> {
        let index: HashMap<&[u8], u32> = ball_index(balls)
            .expect("ball ids are unique")
            .into_iter()
            .map(|(id, i)| {
                (
                    id.as_bytes(),
                    u32::try_from(i).expect("fewer than 2^32 balls"),
                )
            })
            .collect();
        let header = reader.byte_headers()?.clone();
        let header = Row {
            record: &header,
            end: reader.position().byte(),
        };
        let columns = Columns::locate(&header)?;

        let mut out = Self {
            direction: columns.dir.map(|_| Vec::new()),
            ..Self::default()
        };
        let mut record = ByteRecord::new();
        while reader.read_byte_record(&mut record)? {
            let row = Row {
                record: &record,
                end: reader.position().byte(),
            };
            if record.len() != columns.width {
                return Err(row.error(
                    None,
                    format!("expected {} fields, found {}", columns.width, record.len()),
                ));
            }
            let id = row.field(columns.ball);
            let ball = *index.get(id).ok_or_else(|| {
                row.error(
                    Some(BALL),
                    format!(
                        "unknown ball id {:?} (not in artefacts.json)",
                        String::from_utf8_lossy(id)
                    ),
                )
            })?;
            out.ball.push(ball);
            out.q.push(row.numbers(&columns.q, &Q)?);
            if let (Some(dir), Some(directions)) = (&columns.dir, &mut out.direction) {
                directions.push(row.numbers(dir, &DIR)?);
            }
        }
        if out.is_empty() {
            return Err(header.error(None, "the header is followed by no measurement row".into()));
        }
        Ok(out)
    }

    /// Writes `measurements.csv` (the caller has validated): floats in Rust's
    /// shortest round-trip form.
    pub(crate) fn write(&self, path: &Path, balls: &[Ball]) -> Result<()> {
        write_atomic(path, |w| {
            let mut writer = csv::Writer::from_writer(w);
            let to_error = |e: csv::Error| DatasetError::io(path, "write", e.into());
            let mut header = vec![BALL];
            header.extend(Q);
            if self.direction.is_some() {
                header.extend(DIR);
            }
            writer.write_record(&header).map_err(to_error)?;
            let mut text = String::new();
            let mut number = |writer: &mut csv::Writer<_>, v: f64| {
                text.clear();
                write!(text, "{v}").expect("formatting into a String");
                writer.write_field(&text)
            };
            for (row, (&ball, q)) in self.ball.iter().zip(&self.q).enumerate() {
                writer
                    .write_field(&balls[ball as usize].id)
                    .map_err(to_error)?;
                for &v in q {
                    number(&mut writer, v).map_err(to_error)?;
                }
                if let Some(directions) = &self.direction {
                    for &v in &directions[row] {
                        number(&mut writer, v).map_err(to_error)?;
                    }
                }
                writer.write_record(None::<&[u8]>).map_err(to_error)?;
            }
            writer.flush().map_err(write_error(path))
        })
    }

    /// Arrays of equal length, ball indices in range, values finite. Errors
    /// name the line the row has (or would have) in `measurements.csv`.
    pub(crate) fn validate(&self, check: Check, ball_count: usize) -> Result<()> {
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
            if let Some(k) = q.iter().position(|v| !v.is_finite()) {
                return Err(bad(row, Q[k], not_finite(q[k])));
            }
            if let Some(d) = self.direction.as_ref().map(|d| &d[row])
                && let Some(k) = d.iter().position(|v| !v.is_finite())
            {
                return Err(bad(row, DIR[k], not_finite(d[k])));
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

/// Where each column of interest is, by header name.
struct Columns {
    ball: usize,
    q: [usize; 6],
    dir: Option<[usize; 3]>,
    /// Number of fields every row must have.
    width: usize,
}

impl Columns {
    fn locate(header: &Row) -> Result<Self, Failure> {
        let error = |message: String| header.error(None, message);
        let fields = header.record;
        if fields.is_empty() {
            return Err(error(format!(
                "the file is empty (expected the header {BALL},{})",
                Q.join(",")
            )));
        }
        let find = |name: &str| {
            let mut found = fields
                .iter()
                .enumerate()
                .filter(|(_, f)| f.trim_ascii() == name.as_bytes());
            match (found.next(), found.next()) {
                (Some((i, _)), None) => Ok(Some(i)),
                (None, _) => Ok(None),
                (Some(_), Some(_)) => Err(error(format!("the header names column {name} twice"))),
            }
        };
        let require = |name: &str| {
            find(name)?.ok_or_else(|| {
                error(format!(
                    "the header has no column {name} (it must name {BALL},{})",
                    Q.join(",")
                ))
            })
        };
        let ball = require(BALL)?;
        let mut q = [0; 6];
        for (slot, name) in q.iter_mut().zip(Q) {
            *slot = require(name)?;
        }
        let dir = [find(DIR[0])?, find(DIR[1])?, find(DIR[2])?];
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
                return Err(error(format!(
                    "the header has column {} but not {} (give all of {} or none)",
                    present.join(", "),
                    absent.join(", "),
                    DIR.join(",")
                )));
            }
        };
        Ok(Self {
            ball,
            q,
            dir,
            width: fields.len(),
        })
    }
}

/// An error found while parsing, before its line number is known.
enum Failure {
    /// From the CSV reader itself (I/O).
    Csv(csv::Error),
    /// About the record that ended at byte `end` of the input.
    At {
        end: u64,
        /// Newlines inside the record's (quoted) fields.
        inner_newlines: u64,
        /// The reader's line number, used if the input cannot be rescanned.
        estimate: u64,
        column: Option<&'static str>,
        message: String,
    },
}

impl From<csv::Error> for Failure {
    fn from(e: csv::Error) -> Self {
        Self::Csv(e)
    }
}

/// One record (the header or a data row) being parsed.
struct Row<'a> {
    record: &'a ByteRecord,
    /// Input offset just past the record.
    end: u64,
}

impl Row<'_> {
    /// Field `column` without surrounding ASCII whitespace (trimmed here
    /// rather than by the CSV reader, whose trimming copies every record).
    fn field(&self, column: usize) -> &[u8] {
        self.record[column].trim_ascii()
    }

    fn error(&self, column: Option<&'static str>, message: String) -> Failure {
        Failure::At {
            end: self.end,
            inner_newlines: self
                .record
                .as_slice()
                .iter()
                .filter(|&&b| b == b'\n')
                .count() as u64,
            estimate: self.record.position().map_or(1, csv::Position::line),
            column,
            message,
        }
    }

    /// The finite numbers in `columns` (named `names`).
    fn numbers<const N: usize>(
        &self,
        columns: &[usize; N],
        names: &[&'static str; N],
    ) -> Result<[f64; N], Failure> {
        let mut out = [0.0; N];
        for ((slot, &column), &name) in out.iter_mut().zip(columns).zip(names) {
            let bytes = self.field(column);
            let value = std::str::from_utf8(bytes)
                .ok()
                .and_then(|text| text.parse::<f64>().ok())
                .ok_or_else(|| {
                    let found = String::from_utf8_lossy(bytes);
                    let message = if found.is_empty() {
                        "empty field, expected a number".to_owned()
                    } else {
                        format!("expected a number, found {found:?}")
                    };
                    self.error(Some(name), message)
                })?;
            if !value.is_finite() {
                return Err(self.error(Some(name), not_finite(value)));
            }
            *slot = value;
        }
        Ok(out)
    }
}

/// The 1-based line on which the record that ended at byte `end` begins.
///
/// The CSV reader's own line numbers are off after blank lines (which it
/// skips) and in files with CRLF line ends, so on error the input is rescanned:
/// the last byte of the record (its terminator, or its last byte at the end
/// of the input) is on line 1 + (newlines before it).
fn line_of<R: Read + Seek>(mut input: R, end: u64, inner_newlines: u64) -> Option<u64> {
    input.seek(SeekFrom::Start(0)).ok()?;
    let mut before = input.take(end.saturating_sub(1));
    let mut buffer = [0u8; 1 << 14];
    let mut newlines = 0;
    loop {
        let n = before.read(&mut buffer).ok()?;
        if n == 0 {
            break;
        }
        newlines += buffer[..n].iter().filter(|&&b| b == b'\n').count() as u64;
    }
    Some((1 + newlines).saturating_sub(inner_newlines).max(1))
}

fn csv_error(path: &Path, error: csv::Error) -> DatasetError {
    let line = error.position().map_or(0, csv::Position::line);
    let message = error.to_string();
    match error.into_kind() {
        csv::ErrorKind::Io(e) => DatasetError::io(path, "read", e),
        _ => DatasetError::csv(path, line, None, message),
    }
}
