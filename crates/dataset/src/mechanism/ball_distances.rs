//! A mechanism dataset's calibrated distances between the centres of its
//! balls, as a ball plate's certificate or a ball bar gives them: an
//! optional file that needs balls.csv.
//!
//! | file | header | one row per |
//! |---|---|---|
//! | `ball_distances.csv` | `first,second,distance,sigma` | distance: the two balls' numbers (their rows in balls.csv, from 0; distinct), the calibrated distance between their centres and its standard deviation (mm, positive) |
//!
//! Each pair of balls is given at most once, in either order. The file
//! holds at most [`BALL_DISTANCES`]`.max` rows, counted as they are read;
//! errors name the line and column, a pair given twice both its lines.

use std::collections::HashMap;
use std::collections::hash_map::Entry;
use std::path::Path;

use crate::Distance;
use crate::bounds::Count;
use crate::check::Check;
use crate::error::Result;
use crate::table::{self, Header, RowPlace};

use super::RowNames;
use super::balls::{ball_number, not_a_ball, positive};
use super::observations::OBSERVATIONS;

/// The bounds of the rows of ball_distances.csv: as many as an
/// observation file's.
pub const BALL_DISTANCES: Count = Count::new(
    1,
    OBSERVATIONS.max,
    "each distance is a residual of every iteration",
);

/// The columns of ball_distances.csv.
pub const BALL_DISTANCE_COLUMNS: [&str; 4] = ["first", "second", "distance", "sigma"];

/// The pair of balls `distance` joins, the smaller number first: the same
/// for either order.
fn pair(distance: &Distance) -> (usize, usize) {
    (distance.a.min(distance.b), distance.a.max(distance.b))
}

/// Reads ball_distances.csv at `path` for `balls` balls: each ball one of
/// them, the two distinct, the distance and its sigma positive, no pair
/// twice, at most [`BALL_DISTANCES`]`.max` rows.
pub(crate) fn read_ball_distances(path: &Path, balls: usize) -> Result<Vec<Distance>> {
    let expected = BALL_DISTANCE_COLUMNS.join(",");
    table::read_file(path, |reader| {
        let header = Header::read(reader, &expected)?;
        header.only(&BALL_DISTANCE_COLUMNS, &expected)?;
        let [first_at, second_at, distance_at, sigma_at] =
            header.require_all(&BALL_DISTANCE_COLUMNS, &expected)?;
        let of = not_a_ball(balls);
        let mut rows = Vec::new();
        let mut lines: HashMap<(usize, usize), RowPlace> = HashMap::new();
        table::for_each_row(reader, &header, "ball distance", |row| {
            if rows.len() == BALL_DISTANCES.max {
                let message = BALL_DISTANCES.refusal("the number of ball distance rows", "more");
                return Err(row.error(None, message));
            }
            let a = ball_number(row, first_at, "first", balls, &of)?;
            let b = ball_number(row, second_at, "second", balls, &of)?;
            if a == b {
                return Err(row.error(
                    Some("second"),
                    format!("{b} is the first ball too: a distance joins two balls"),
                ));
            }
            let distance = Distance {
                a,
                b,
                length: positive(row, distance_at, "distance")?,
                sigma: positive(row, sigma_at, "sigma")?,
            };
            match lines.entry(pair(&distance)) {
                Entry::Occupied(first) => {
                    let message = format!("the distance between balls {a} and {b} is given twice");
                    return Err(row.error_after(*first.get(), message));
                }
                Entry::Vacant(slot) => {
                    slot.insert(row.place());
                }
            }
            rows.push(distance);
            Ok(())
        })?;
        Ok(rows)
    })
}

/// Checks `distances` for `balls` balls, naming the rows of the file at
/// `path`: at most [`BALL_DISTANCES`]`.max`, each between two distinct
/// balls that exist, no pair twice, the distance a positive length and
/// its sigma a standard deviation within the bounds of a dataset's.
pub(super) fn validate_ball_distances(
    path: &Path,
    distances: &[Distance],
    balls: usize,
    names: RowNames,
) -> Result<()> {
    let check = Check::new(path);
    if distances.len() > BALL_DISTANCES.max {
        let count = distances.len().to_string();
        return Err(check.error("rows", BALL_DISTANCES.refusal("the number of rows", &count)));
    }
    let mut rows = HashMap::with_capacity(distances.len());
    for (k, distance) in distances.iter().enumerate() {
        let field = names.of(k);
        let (a, b) = (distance.a, distance.b);
        if a.max(b) >= balls || a == b {
            return Err(check.error(
                &field,
                format!("balls {a} and {b} are not two distinct balls of the {balls} of balls.csv"),
            ));
        }
        if let Some(first) = rows.insert(pair(distance), k) {
            return Err(check.error(
                &field,
                format!(
                    "the distance between balls {a} and {b} is given twice, first in {}",
                    names.of(first)
                ),
            ));
        }
        check.positive_length(format_args!("{field} distance"), distance.length)?;
        check.sigma(format_args!("{field} sigma"), distance.sigma)?;
    }
    Ok(())
}

/// Writes ball_distances.csv at `path` atomically.
pub(crate) fn write_ball_distances(path: &Path, rows: &[Distance]) -> Result<()> {
    table::write_file(path, &BALL_DISTANCE_COLUMNS, |w| {
        for row in rows {
            w.numbers(&[row.a as f64, row.b as f64, row.length, row.sigma])?;
            w.end_row()?;
        }
        Ok(())
    })
}
