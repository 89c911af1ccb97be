//! Where an observation is, as a user finds it: its file and line (CSV,
//! header = line 1) or field (JSON).

use parcal_calibrate::observation::ObservationId;
use parcal_dataset::{ARTEFACTS_FILE, MEASUREMENTS_FILE, POINTS_FILE, POSES_FILE};

/// Where an observation is, as a user finds it: `measurements.csv line
/// 40` (the header is line 1), `artefacts.json distances[3]`.
pub fn place(observation: ObservationId) -> String {
    let (file, line, field) = location(observation);
    match (line, field) {
        (Some(line), _) => format!("{file} line {line}"),
        (None, Some(field)) => format!("{file} {field}"),
        (None, None) => file.to_string(),
    }
}

/// An observation's file and its line (CSV, header = line 1) or field
/// (JSON).
pub(crate) fn location(observation: ObservationId) -> (&'static str, Option<u64>, Option<String>) {
    let line = |row: usize| Some(row as u64 + 2);
    match observation {
        ObservationId::Contact(row) => (MEASUREMENTS_FILE, line(row), None),
        ObservationId::Distance(k) => (ARTEFACTS_FILE, None, Some(format!("distances[{k}]"))),
        ObservationId::Pose(row) => (POSES_FILE, line(row), None),
        ObservationId::Point(row) => (POINTS_FILE, line(row), None),
    }
}

/// An observation's place and, for one of several rows, the row (a pose's
/// leg, a point's coordinate).
pub(crate) fn place_and_row(observation: ObservationId, row: usize) -> String {
    match observation {
        ObservationId::Pose(_) => format!("{}, leg {}", place(observation), row + 1),
        ObservationId::Point(_) => format!("{}, {}", place(observation), ["x", "y", "z"][row]),
        _ => place(observation),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Each kind of observation at its file and line (the header is line 1)
    /// or field, as a user finds it.
    #[test]
    fn an_observation_is_placed_at_its_file_and_line_or_field() {
        assert_eq!(
            location(ObservationId::Contact(38)),
            ("measurements.csv", Some(40), None)
        );
        assert_eq!(
            location(ObservationId::Distance(17)),
            ("artefacts.json", None, Some("distances[17]".to_string()))
        );
        assert_eq!(
            location(ObservationId::Pose(11)),
            ("poses.csv", Some(13), None)
        );
        assert_eq!(
            location(ObservationId::Point(23)),
            ("points.csv", Some(25), None)
        );
        assert_eq!(place(ObservationId::Pose(11)), "poses.csv line 13");
        assert_eq!(
            place_and_row(ObservationId::Point(23), 1),
            "points.csv line 25, y"
        );
    }
}
