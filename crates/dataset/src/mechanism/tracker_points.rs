//! `tracker_points.csv`: tool points measured by trackers in their own
//! frames, header `tracker,x_c,y_c,z_c,x,y,z`: the tracker's label (its
//! frame is unknown; one label per placement of the instrument), the
//! commanded position (mm, the controller's coordinates) and the point the
//! tracker measured there (mm, the tracker's frame).

use std::collections::HashSet;
use std::path::Path;

use crate::bounds::Count;
use crate::error::Result;
use crate::quote::{has_control, quoted};
use crate::table::{self, Failure, Header, Row};

use super::observations::too_many;
use crate::mechanism::OBSERVATIONS;

/// The columns of tracker_points.csv.
pub const TRACKER_POINT_COLUMNS: [&str; 7] = ["tracker", "x_c", "y_c", "z_c", "x", "y", "z"];

/// The bounds of the trackers: each adds six unknowns, its frame, to the
/// dense global block (a calibration places an instrument a handful of
/// times).
pub const TRACKERS: Count = Count::new(1, 16, "each tracker's frame is six unknowns of the fit");

/// One row of tracker_points.csv.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct TrackerPointRow {
    /// The tracker's label.
    pub tracker: String,
    /// The commanded position (mm, the controller's coordinates).
    pub commanded: [f64; 3],
    /// The point the tracker measured (mm, its frame).
    pub measured: [f64; 3],
}

/// Reads tracker_points.csv at `path`: every label UTF-8, not empty,
/// without a control character, at most [`TRACKERS`]`.max` labels, every
/// value finite, at most [`OBSERVATIONS`]`.max` rows.
pub(crate) fn read_tracker_points(path: &Path) -> Result<Vec<TrackerPointRow>> {
    let expected = TRACKER_POINT_COLUMNS.join(",");
    table::read_file(path, |reader| {
        let header = Header::read(reader, &expected)?;
        header.only(&TRACKER_POINT_COLUMNS, &expected)?;
        let [tracker_at, xc, yc, zc, x, y, z] =
            header.require_all(&TRACKER_POINT_COLUMNS, &expected)?;
        let mut rows = Vec::new();
        let mut labels: HashSet<String> = HashSet::new();
        table::for_each_row(reader, &header, "tracker point", |row| {
            if rows.len() == OBSERVATIONS.max {
                return Err(too_many(row, "tracker point"));
            }
            let tracker = label(row, tracker_at)?;
            if !labels.contains(&tracker) {
                if labels.len() == TRACKERS.max {
                    return Err(row.error(
                        Some("tracker"),
                        TRACKERS.refusal("the number of trackers", "more"),
                    ));
                }
                labels.insert(tracker.clone());
            }
            let commanded = row.numbers(&[xc, yc, zc], &["x_c", "y_c", "z_c"])?;
            let measured = row.numbers(&[x, y, z], &["x", "y", "z"])?;
            rows.push(TrackerPointRow {
                tracker,
                commanded,
                measured,
            });
            Ok(())
        })?;
        Ok(rows)
    })
}

/// The tracker's label in column `column` of `row`.
fn label(row: &Row, column: usize) -> std::result::Result<String, Failure> {
    let label = std::str::from_utf8(row.field(column))
        .map_err(|_| row.error(Some("tracker"), "the label is not UTF-8".into()))?;
    if label.is_empty() {
        return Err(row.error(Some("tracker"), "empty label".into()));
    }
    if has_control(label) {
        return Err(row.error(
            Some("tracker"),
            format!("the label {} has a control character", quoted(label)),
        ));
    }
    Ok(label.to_owned())
}

/// Writes tracker_points.csv at `path`.
pub(crate) fn write_tracker_points(path: &Path, rows: &[TrackerPointRow]) -> Result<()> {
    table::write_file(path, &TRACKER_POINT_COLUMNS, |w| {
        for row in rows {
            w.text(&row.tracker)?;
            w.numbers(&row.commanded)?;
            w.numbers(&row.measured)?;
            w.end_row()?;
        }
        Ok(())
    })
}

/// The trackers' labels in order of first appearance.
pub fn tracker_labels(rows: &[TrackerPointRow]) -> Vec<String> {
    let mut labels: Vec<String> = Vec::new();
    for row in rows {
        if !labels.contains(&row.tracker) {
            labels.push(row.tracker.clone());
        }
    }
    labels
}
