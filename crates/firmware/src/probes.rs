//! Probe heights: `probes.csv`, header `x,y,z`, one probe per row: the
//! commanded nozzle position `x, y` (mm, firmware coordinates) and the
//! height `z` (mm) that `G30 S-1` reports there, the firmware's nozzle
//! height when the probe triggered less the trigger height (`G31 Z`):
//! zero on a perfectly calibrated printer, positive where the bed is
//! higher than the firmware believes. And part distances measured on a
//! printed part ([`read_distances`]), and heights of the nozzle measured
//! by hand ([`read_heights`]).

use std::io::Read;
use std::path::Path;

use crate::FirmwareError;
use crate::files::{bounded_number, read_capped};

/// The most probe points a file may hold (a bed probed every 2 mm over a
/// 200 mm circle holds fewer).
pub const MAX_PROBE_POINTS: usize = 10_000;
/// The largest probe file read (bytes).
pub const MAX_PROBE_BYTES: u64 = 1 << 20;

/// One probe: where the nozzle was sent and the height reported.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ProbePoint {
    /// Commanded nozzle x (mm).
    pub x: f64,
    /// Commanded nozzle y (mm).
    pub y: f64,
    /// Reported height (mm).
    pub z: f64,
}

/// Reads a `probes.csv`.
pub fn read_probes(path: &Path) -> Result<Vec<ProbePoint>, FirmwareError> {
    let text = read_capped(path, MAX_PROBE_BYTES, "probe file")?;
    parse_probes(text.as_bytes(), path)
}

/// [`read_probes`] of any reader (`path` names it in errors): the header
/// must be `x,y,z`, every row three finite numbers, at most
/// [`MAX_PROBE_POINTS`] rows.
pub fn parse_probes<R: Read>(input: R, path: &Path) -> Result<Vec<ProbePoint>, FirmwareError> {
    let rows = parse_rows(input, path, &["x", "y", "z"], "probe points")?;
    Ok(rows
        .into_iter()
        .map(|[x, y, z]| ProbePoint { x, y, z })
        .collect())
}

/// The columns of a part distances file.
pub const DISTANCE_COLUMNS: [&str; 7] = ["x1", "y1", "z1", "x2", "y2", "z2", "distance"];

/// Reads a part distances file: header `x1,y1,z1,x2,y2,z2,distance`, one
/// row per distance measured on a printed part between two commanded
/// positions (mm, firmware coordinates), at most [`MAX_PROBE_POINTS`]
/// rows.
pub fn read_distances(path: &Path) -> Result<Vec<[f64; 7]>, FirmwareError> {
    let text = read_capped(path, MAX_PROBE_BYTES, "distance file")?;
    parse_rows(text.as_bytes(), path, &DISTANCE_COLUMNS, "distances")
}

/// The columns of a file of heights measured by hand.
pub const HEIGHT_COLUMNS: [&str; 4] = ["x", "y", "z", "height"];

/// Reads a file of heights measured by hand: header `x,y,z,height`, one
/// row per measurement, the commanded nozzle position (mm, firmware
/// coordinates) and the nozzle's height above the bed measured there (a
/// gauge block or feeler gauge under the nozzle, mm), at most
/// [`MAX_PROBE_POINTS`] rows.
pub fn read_heights(path: &Path) -> Result<Vec<[f64; 4]>, FirmwareError> {
    let text = read_capped(path, MAX_PROBE_BYTES, "height file")?;
    parse_rows(text.as_bytes(), path, &HEIGHT_COLUMNS, "heights")
}

/// The rows of a CSV file of header `columns`, every field a finite
/// number, at least one and at most [`MAX_PROBE_POINTS`] rows (`what`
/// names them in errors).
fn parse_rows<R: Read, const N: usize>(
    input: R,
    path: &Path,
    columns: &[&str; N],
    what: &str,
) -> Result<Vec<[f64; N]>, FirmwareError> {
    let at = |line: u64, message: String| FirmwareError::Line {
        path: path.to_path_buf(),
        line,
        message,
    };
    let mut reader = csv::ReaderBuilder::new()
        .trim(csv::Trim::All)
        .flexible(true)
        .from_reader(input);
    let header = reader.headers().map_err(|e| at(1, e.to_string()))?.clone();
    if header.iter().collect::<Vec<_>>() != columns {
        let found = header.iter().collect::<Vec<_>>().join(",");
        return Err(at(
            1,
            format!("the header is '{found}', expected '{}'", columns.join(",")),
        ));
    }
    let mut rows = Vec::new();
    for record in reader.records() {
        let record = record.map_err(|e| {
            let line = e.position().map_or(0, |p| p.line());
            at(line, e.to_string())
        })?;
        let line = record.position().map_or(0, |p| p.line());
        if rows.len() == MAX_PROBE_POINTS {
            return Err(at(line, format!("more than {MAX_PROBE_POINTS} {what}")));
        }
        if record.len() != N {
            return Err(at(
                line,
                format!(
                    "{} fields, expected {N} ({})",
                    record.len(),
                    columns.join(",")
                ),
            ));
        }
        let mut values = [0.0; N];
        for (k, name) in columns.iter().enumerate() {
            values[k] =
                bounded_number(&record[k]).map_err(|why| at(line, format!("{name}: {why}")))?;
        }
        rows.push(values);
    }
    if rows.is_empty() {
        return Err(at(1, format!("no {what}")));
    }
    Ok(rows)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reads_points_and_names_the_bad_line() {
        let path = Path::new("probes.csv");
        let points = parse_probes("x,y,z\n0,0,0.05\n-86.6,-50,-0.12\n".as_bytes(), path).unwrap();
        assert_eq!(points.len(), 2);
        assert_eq!(
            points[1],
            ProbePoint {
                x: -86.6,
                y: -50.0,
                z: -0.12
            }
        );
        let err = parse_probes("x,y,z\n0,0,0.05\n1,2,nan\n".as_bytes(), path).unwrap_err();
        assert_eq!(
            err.to_string(),
            "probes.csv: line 3: z: 'nan' is not a finite number"
        );
        let err = parse_probes("x,y,z\n0,0,0.05\n5e6,0,0.1\n".as_bytes(), path).unwrap_err();
        assert_eq!(
            err.to_string(),
            "probes.csv: line 3: x: '5e6' is beyond the 1e6 a firmware's number may be (1 km in mm: a unit error?)"
        );
        let err = parse_probes("x,y,height\n0,0,0\n".as_bytes(), path).unwrap_err();
        assert_eq!(
            err.to_string(),
            "probes.csv: line 1: the header is 'x,y,height', expected 'x,y,z'"
        );
        let err = parse_probes("x,y,z\n0,0\n".as_bytes(), path).unwrap_err();
        assert_eq!(
            err.to_string(),
            "probes.csv: line 2: 2 fields, expected 3 (x,y,z)"
        );
        let err = parse_probes("x,y,z\n".as_bytes(), path).unwrap_err();
        assert_eq!(err.to_string(), "probes.csv: line 1: no probe points");
    }

    #[test]
    fn reads_distances_and_names_the_bad_field() {
        let path = Path::new("distances.csv");
        let header = "x1,y1,z1,x2,y2,z2,distance\n";
        let text = format!("{header}-90,0,0.2,90,0,0.2,180.05\n");
        let rows = parse_rows(text.as_bytes(), path, &DISTANCE_COLUMNS, "distances").unwrap();
        assert_eq!(rows, vec![[-90.0, 0.0, 0.2, 90.0, 0.0, 0.2, 180.05]]);
        let text = format!("{header}-90,0,0.2,90,0,0.2,180.05\n1,2,3,4,5,6,x\n");
        let err = parse_rows(text.as_bytes(), path, &DISTANCE_COLUMNS, "distances").unwrap_err();
        assert_eq!(
            err.to_string(),
            "distances.csv: line 3: distance: 'x' is not a number"
        );
    }

    #[test]
    fn refuses_more_points_than_the_cap() {
        let mut text = String::from("x,y,z\n");
        for _ in 0..=MAX_PROBE_POINTS {
            text.push_str("0,0,0\n");
        }
        let err = parse_probes(text.as_bytes(), Path::new("p.csv")).unwrap_err();
        assert!(
            err.to_string().contains("more than 10000 probe points"),
            "{err}"
        );
    }
}
