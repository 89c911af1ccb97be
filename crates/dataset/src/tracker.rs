//! `poses.csv` and `points.csv`: what a laser tracker, a motion-capture
//! system or photogrammetry measured of the platform, in the measuring
//! instrument's frame, one row per commanded pose, in sessions.
//!
//! - `poses.csv`: `[session,]q1,…,q6,x,y,z,qx,qy,qz,qw`: the platform body
//!   frame's origin (mm) and orientation (a unit quaternion, x, y, z, w) in
//!   the instrument's frame;
//! - `points.csv`: `[session,]q1,…,q6,x,y,z`: the tool point (a reflector,
//!   a probe tip) in the instrument's frame.
//!
//! Columns are found by header name, in any order. `session` is a free
//! label (a date, a number); sessions are numbered in order of first
//! appearance, poses.csv before points.csv, and a file without the column
//! belongs to the session labelled [`DEFAULT_SESSION`].

use std::collections::HashMap;
use std::path::Path;

use serde::{Deserialize, Serialize};

use crate::Point3;
use crate::check::{self, Check, not_finite};
use crate::error::{DatasetError, Result};
use crate::quote::{has_control, quoted};
use crate::table::{self, Failure, Header, Row};

const SESSION: &str = "session";
const Q: [&str; 6] = ["q1", "q2", "q3", "q4", "q5", "q6"];
const POSITION: [&str; 3] = ["x", "y", "z"];
const ORIENTATION: [&str; 4] = ["qx", "qy", "qz", "qw"];
/// Aliases of the columns: the header of the Jugglebot project's
/// calibration poses (`leg_length_1`, `position_x`, `orientation_x`, …),
/// so that its files read as they are.
const Q_ALIASES: [&str; 6] = [
    "leg_length_1",
    "leg_length_2",
    "leg_length_3",
    "leg_length_4",
    "leg_length_5",
    "leg_length_6",
];
const POSITION_ALIASES: [&str; 3] = ["position_x", "position_y", "position_z"];
const ORIENTATION_ALIASES: [&str; 4] = [
    "orientation_x",
    "orientation_y",
    "orientation_z",
    "orientation_w",
];
/// How far from 1 a quaternion's norm may be (it is normalised on use).
const UNIT_TOLERANCE: f64 = 1e-3;

/// The label of the session of rows read from a file without a `session`
/// column.
pub const DEFAULT_SESSION: &str = "1";

/// Platform poses measured by an instrument (struct of arrays, file order).
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct Poses {
    /// Session of each row: an index into [`Tracker::sessions`].
    pub session: Vec<u32>,
    /// Actuator readings, in the actuators' unit.
    pub q: Vec<[f64; 6]>,
    /// Origin of the platform body frame in the instrument frame (mm).
    pub position: Vec<Point3>,
    /// Orientation of the platform body frame in the instrument frame: a
    /// unit quaternion `[x, y, z, w]`.
    pub orientation: Vec<[f64; 4]>,
}

/// Tool points measured by an instrument (struct of arrays, file order).
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct Points {
    /// Session of each row: an index into [`Tracker::sessions`].
    pub session: Vec<u32>,
    /// Actuator readings, in the actuators' unit.
    pub q: Vec<[f64; 6]>,
    /// The tool point in the instrument frame (mm).
    pub position: Vec<Point3>,
}

/// Everything measured by instruments: the sessions, the poses and the
/// points (each empty when its file is absent).
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct Tracker {
    /// Session labels; a row's session is an index into this list.
    pub sessions: Vec<String>,
    /// `poses.csv`.
    pub poses: Poses,
    /// `points.csv`.
    pub points: Points,
}

impl Poses {
    /// Number of poses.
    pub fn len(&self) -> usize {
        self.q.len()
    }

    /// Whether there is no pose.
    pub fn is_empty(&self) -> bool {
        self.q.is_empty()
    }
}

impl Points {
    /// Number of points.
    pub fn len(&self) -> usize {
        self.q.len()
    }

    /// Whether there is no point.
    pub fn is_empty(&self) -> bool {
        self.q.is_empty()
    }
}

impl Tracker {
    /// Whether nothing was measured by an instrument.
    pub fn is_empty(&self) -> bool {
        self.poses.is_empty() && self.points.is_empty()
    }

    /// Number of poses and points of each session.
    pub fn rows_per_session(&self) -> Vec<(usize, usize)> {
        let mut counts = vec![(0, 0); self.sessions.len()];
        for &s in &self.poses.session {
            if let Some(c) = counts.get_mut(s as usize) {
                c.0 += 1;
            }
        }
        for &s in &self.points.session {
            if let Some(c) = counts.get_mut(s as usize) {
                c.1 += 1;
            }
        }
        counts
    }

    /// Reads `poses.csv` and `points.csv` where they exist; `scale` is the
    /// actuators' (mm per unit).
    pub(crate) fn read(poses: &Path, points: &Path, scale: &[f64; 6]) -> Result<Self> {
        let mut sessions = Sessions::default();
        let poses = if poses.exists() {
            table::read_file(poses, |reader| read_poses(reader, &mut sessions, scale))?
        } else {
            Poses::default()
        };
        let points = if points.exists() {
            table::read_file(points, |reader| read_points(reader, &mut sessions, scale))?
        } else {
            Points::default()
        };
        Ok(Self {
            sessions: sessions.labels,
            poses,
            points,
        })
    }

    /// Writes the non-empty files (the caller has validated), with a
    /// `session` column when there is more than one session or its label is
    /// not [`DEFAULT_SESSION`].
    pub(crate) fn write(&self, poses: &Path, points: &Path) -> Result<()> {
        let sessions =
            self.sessions.len() > 1 || self.sessions.first().is_some_and(|s| s != DEFAULT_SESSION);
        let header = |rest: &[&'static str]| {
            let mut header = Vec::new();
            if sessions {
                header.push(SESSION);
            }
            header.extend(Q);
            header.extend(rest);
            header
        };
        let label = |s: u32| self.sessions[s as usize].as_str();
        if !self.poses.is_empty() {
            let p = &self.poses;
            let columns = header(&[POSITION.as_slice(), &ORIENTATION].concat());
            table::write_file(poses, &columns, |w| {
                for i in 0..p.len() {
                    if sessions {
                        w.text(label(p.session[i]))?;
                    }
                    w.numbers(&p.q[i])?;
                    w.numbers(&p.position[i])?;
                    w.numbers(&p.orientation[i])?;
                    w.end_row()?;
                }
                Ok(())
            })?;
        }
        if !self.points.is_empty() {
            let p = &self.points;
            table::write_file(points, &header(&POSITION), |w| {
                for i in 0..p.len() {
                    if sessions {
                        w.text(label(p.session[i]))?;
                    }
                    w.numbers(&p.q[i])?;
                    w.numbers(&p.position[i])?;
                    w.end_row()?;
                }
                Ok(())
            })?;
        }
        Ok(())
    }

    /// Arrays of equal length, session indices in range, every session
    /// used, values finite, quaternions of unit norm. Errors name the file
    /// (`poses`, `points`) and the line the row has (or would have).
    pub(crate) fn validate(&self, poses: Check, points: Check, scale: &[f64; 6]) -> Result<()> {
        let n = self.sessions.len();
        let p = &self.poses;
        let lengths = [p.session.len(), p.position.len(), p.orientation.len()];
        if lengths.iter().any(|&l| l != p.len()) {
            return Err(poses.error(
                "poses",
                format!(
                    "arrays of different lengths: q {}, session/position/orientation {lengths:?}",
                    p.len()
                ),
            ));
        }
        for i in 0..p.len() {
            let bad = |column: &str, message: String| {
                DatasetError::csv(poses.path(), i as u64 + 2, Some(column), message)
            };
            check_row(p.session[i], n, (&p.q[i], &p.position[i]), scale, bad)?;
            if let Some(k) = p.orientation[i].iter().position(|v| !v.is_finite()) {
                return Err(bad(ORIENTATION[k], not_finite(p.orientation[i][k])));
            }
            let norm = p.orientation[i].iter().map(|v| v * v).sum::<f64>().sqrt();
            if (norm - 1.0).abs() > UNIT_TOLERANCE {
                return Err(bad(
                    "qw",
                    format!("the quaternion qx,qy,qz,qw has norm {norm}, not 1"),
                ));
            }
        }
        let t = &self.points;
        if t.session.len() != t.len() || t.position.len() != t.len() {
            return Err(points.error(
                "points",
                format!(
                    "arrays of different lengths: q {}, session {}, position {}",
                    t.len(),
                    t.session.len(),
                    t.position.len()
                ),
            ));
        }
        for i in 0..t.len() {
            let bad = |column: &str, message: String| {
                DatasetError::csv(points.path(), i as u64 + 2, Some(column), message)
            };
            check_row(t.session[i], n, (&t.q[i], &t.position[i]), scale, bad)?;
        }
        if let Some(label) = self.sessions.iter().find(|l| has_control(l)) {
            return Err(poses.error("sessions", control_label(label)));
        }
        let used = self.rows_per_session();
        if let Some(s) = used.iter().position(|&(a, b)| a + b == 0) {
            return Err(poses.error(
                "sessions",
                format!("session {} has no row", quoted(&self.sessions[s])),
            ));
        }
        Ok(())
    }
}

/// A row's session index in range and its numbers as [`row_problem`]
/// wants them.
fn check_row(
    session: u32,
    sessions: usize,
    (q, position): (&[f64; 6], &Point3),
    scale: &[f64; 6],
    bad: impl Fn(&str, String) -> DatasetError,
) -> Result<()> {
    if session as usize >= sessions {
        return Err(bad(
            SESSION,
            format!("session index {session} is out of range ({sessions} sessions)"),
        ));
    }
    match row_problem(q, position, scale) {
        Some((column, message)) => Err(bad(column, message)),
        None => Ok(()),
    }
}

/// What is wrong with a row's readings (as [`check::readings`] wants them)
/// or position (a point within [`check::MAX_LENGTH_MM`]), and in which
/// column.
fn row_problem(
    q: &[f64; 6],
    position: &Point3,
    scale: &[f64; 6],
) -> Option<(&'static str, String)> {
    if let Some((k, message)) = check::readings(q, scale) {
        return Some((Q[k], message));
    }
    position.iter().enumerate().find_map(|(k, &v)| {
        if !v.is_finite() {
            Some((POSITION[k], not_finite(v)))
        } else if v.abs() > check::MAX_LENGTH_MM {
            Some((POSITION[k], check::too_long(v)))
        } else {
            None
        }
    })
}

/// The message for a session label with a control character.
fn control_label(label: &str) -> String {
    format!(
        "the session label {} has a control character",
        quoted(label)
    )
}

/// Session labels in order of first appearance.
#[derive(Default)]
struct Sessions {
    labels: Vec<String>,
    index: HashMap<String, u32>,
}

impl Sessions {
    /// The index of the session of `row` (column `column`, or the default
    /// session without one).
    fn of(&mut self, row: &Row, column: Option<usize>) -> Result<u32, Failure> {
        let label = match column {
            Some(c) => {
                let bytes = row.field(c);
                let label = std::str::from_utf8(bytes).map_err(|_| {
                    row.error(Some(SESSION), "the session label is not UTF-8".into())
                })?;
                if label.is_empty() {
                    return Err(row.error(Some(SESSION), "empty session label".into()));
                }
                if has_control(label) {
                    return Err(row.error(Some(SESSION), control_label(label)));
                }
                label
            }
            None => DEFAULT_SESSION,
        };
        if let Some(&i) = self.index.get(label) {
            return Ok(i);
        }
        let refused = |message| row.error(Some(SESSION), message);
        crate::bounds::SESSIONS
            .check("sessions", self.labels.len() + 1)
            .map_err(refused)?;
        let i = u32::try_from(self.labels.len())
            .map_err(|_| refused("more than 2^32 sessions".into()))?;
        self.labels.push(label.to_owned());
        self.index.insert(label.to_owned(), i);
        Ok(i)
    }
}

/// The columns `names`, or all of their `aliases` when the header has none
/// of `names`.
fn columns<const N: usize>(
    header: &Header,
    names: &[&str; N],
    aliases: &[&str; N],
    expected: &str,
) -> Result<[usize; N], Failure> {
    if header.find(names[0])?.is_none() && header.find(aliases[0])?.is_some() {
        header.require_all(aliases, expected)
    } else {
        header.require_all(names, expected)
    }
}

fn expected(rest: &[&str]) -> String {
    format!("[{SESSION},]{},{}", Q.join(","), rest.join(","))
}

fn read_poses<R: std::io::Read>(
    reader: &mut csv::Reader<R>,
    sessions: &mut Sessions,
    scale: &[f64; 6],
) -> Result<Poses, Failure> {
    let expected = expected(&[POSITION.as_slice(), &ORIENTATION].concat());
    let header = Header::read(reader, &expected)?;
    let session = header.find(SESSION)?;
    let q = columns(&header, &Q, &Q_ALIASES, &expected)?;
    let position = columns(&header, &POSITION, &POSITION_ALIASES, &expected)?;
    let orientation = columns(&header, &ORIENTATION, &ORIENTATION_ALIASES, &expected)?;
    let mut out = Poses::default();
    table::for_each_row(reader, &header, "pose", |row| {
        out.session.push(sessions.of(row, session)?);
        let (readings, point) = (row.numbers(&q, &Q)?, row.numbers(&position, &POSITION)?);
        if let Some((column, message)) = row_problem(&readings, &point, scale) {
            return Err(row.error(Some(column), message));
        }
        out.q.push(readings);
        out.position.push(point);
        let quaternion = row.numbers(&orientation, &ORIENTATION)?;
        let norm = quaternion.iter().map(|v| v * v).sum::<f64>().sqrt();
        if (norm - 1.0).abs() > UNIT_TOLERANCE {
            return Err(row.error(
                Some("qw"),
                format!("the quaternion qx,qy,qz,qw has norm {norm}, not 1"),
            ));
        }
        out.orientation.push(quaternion);
        Ok(())
    })?;
    Ok(out)
}

fn read_points<R: std::io::Read>(
    reader: &mut csv::Reader<R>,
    sessions: &mut Sessions,
    scale: &[f64; 6],
) -> Result<Points, Failure> {
    let expected = expected(&POSITION);
    let header = Header::read(reader, &expected)?;
    let session = header.find(SESSION)?;
    let q = columns(&header, &Q, &Q_ALIASES, &expected)?;
    let position = columns(&header, &POSITION, &POSITION_ALIASES, &expected)?;
    let mut out = Points::default();
    table::for_each_row(reader, &header, "point", |row| {
        out.session.push(sessions.of(row, session)?);
        let (readings, point) = (row.numbers(&q, &Q)?, row.numbers(&position, &POSITION)?);
        if let Some((column, message)) = row_problem(&readings, &point, scale) {
            return Err(row.error(Some(column), message));
        }
        out.q.push(readings);
        out.position.push(point);
        Ok(())
    })?;
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::fs;

    fn read(poses: &str, points: Option<&str>) -> Result<Tracker> {
        let dir = tempfile::tempdir().unwrap();
        let (a, b) = (dir.path().join("poses.csv"), dir.path().join("points.csv"));
        fs::write(&a, poses).unwrap();
        if let Some(points) = points {
            fs::write(&b, points).unwrap();
        }
        Tracker::read(&a, &b, &[1.0; 6])
    }

    const POSE_HEADER: &str = "q1,q2,q3,q4,q5,q6,x,y,z,qx,qy,qz,qw\n";

    #[test]
    fn sessions_are_numbered_in_order_of_appearance() {
        let poses = "session,q1,q2,q3,q4,q5,q6,x,y,z,qx,qy,qz,qw\n\
                     day2,1,2,3,4,5,6,0,0,700,0,0,0,1\n\
                     day1,1,2,3,4,5,6,0,0,700,0,0,0,1\n\
                     day2,1,2,3,4,5,6,0,0,700,0,0,0,1\n";
        let points = "q1,q2,q3,q4,q5,q6,x,y,z\n1,2,3,4,5,6,1,2,3\n";
        let t = read(poses, Some(points)).unwrap();
        assert_eq!(t.sessions, ["day2", "day1", DEFAULT_SESSION]);
        assert_eq!(t.poses.session, [0, 1, 0]);
        assert_eq!(t.points.session, [2]);
        assert_eq!(t.rows_per_session(), [(2, 0), (1, 0), (0, 1)]);
        t.validate(
            Check::new(Path::new("poses.csv")),
            Check::new(Path::new("points.csv")),
            &[1.0; 6],
        )
        .unwrap();
    }

    /// A 101st session is refused at its first row, by line and column.
    #[test]
    fn sessions_are_bounded() {
        let row = |k: usize| format!("s{k},1,2,3,4,5,6,0,0,700,0,0,0,1\n");
        let header = "session,q1,q2,q3,q4,q5,q6,x,y,z,qx,qy,qz,qw\n";
        let hundred: String = (0..100).map(row).collect();
        let t = read(&format!("{header}{hundred}{}", row(7)), None).unwrap();
        assert_eq!(t.sessions.len(), 100);
        let error = read(&format!("{header}{hundred}{}", row(100)), None)
            .unwrap_err()
            .to_string();
        assert!(
            error.contains("line 102")
                && error.contains("sessions 101: must be a whole number from 1 to 100"),
            "{error}"
        );
    }

    #[test]
    fn written_files_read_back_bit_for_bit() {
        let mut t = read(
            &format!("{POSE_HEADER}0.1,0.2,0.3,0.4,0.5,0.6,1.5,-2.25,700.125,0.6,0,0,0.8\n"),
            Some("session,q1,q2,q3,q4,q5,q6,x,y,z\n2,1,2,3,4,5,6,0.1,0.2,0.3\n"),
        )
        .unwrap();
        t.poses.position[0][0] = 1.0 / 3.0;
        let dir = tempfile::tempdir().unwrap();
        let (a, b) = (dir.path().join("poses.csv"), dir.path().join("points.csv"));
        t.write(&a, &b).unwrap();
        assert_eq!(Tracker::read(&a, &b, &[1.0; 6]).unwrap(), t);
    }

    #[test]
    fn the_jugglebot_header_reads_as_its_aliases() {
        let poses = "leg_length_1,leg_length_2,leg_length_3,leg_length_4,leg_length_5,leg_length_6,\
                     position_x,position_y,position_z,orientation_x,orientation_y,orientation_z,orientation_w\n\
                     1,2,3,4,5,6,7,8,9,0,0,0.6,0.8\n";
        let t = read(poses, None).unwrap();
        assert_eq!(t.poses.q, [[1.0, 2.0, 3.0, 4.0, 5.0, 6.0]]);
        assert_eq!(t.poses.position, [[7.0, 8.0, 9.0]]);
        assert_eq!(t.poses.orientation, [[0.0, 0.0, 0.6, 0.8]]);
    }

    #[test]
    fn errors_name_the_line_and_column() {
        let bad_quaternion =
            format!("{POSE_HEADER}1,2,3,4,5,6,0,0,700,0,0,0,1\n1,2,3,4,5,6,0,0,700,0,0,0,2\n");
        let err = read(&bad_quaternion, None).unwrap_err().to_string();
        assert!(
            err.ends_with(
                "poses.csv: line 3, column qw: the quaternion qx,qy,qz,qw has norm 2, not 1"
            ),
            "{err}"
        );
        let err = read("q1,q2,q3,q4,q5,q6,x,y,z,qx,qy,qz\n", None)
            .unwrap_err()
            .to_string();
        assert!(err.contains("line 1: the header has no column qw"), "{err}");
        let err = read(POSE_HEADER, None).unwrap_err().to_string();
        assert!(
            err.ends_with("the header is followed by no pose row"),
            "{err}"
        );
        let err = read(
            &format!("{POSE_HEADER}1,2,3,4,5,6,0,0,700,0,0,0,1\n"),
            Some("session,q1,q2,q3,q4,q5,q6,x,y,z\n,1,2,3,4,5,6,x,0,0\n"),
        )
        .unwrap_err()
        .to_string();
        assert!(
            err.ends_with("points.csv: line 2, column session: empty session label"),
            "{err}"
        );
    }
}
