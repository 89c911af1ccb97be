//! plan.csv and plan.json of a pose plan (docs/outputs-format.md, "plan.csv and plan.json").
//!
//! plan.csv, one pose per row:
//! `session,roll,pitch,yaw,x,y,z,q1,q2,q3,q4,q5,q6`: the session's label
//! (as poses.csv's; optional on reading, every row then in session `1`),
//! the platform orientation `R = Rz(yaw) Ry(pitch) Rx(roll)` (rad, fixed
//! axes of the design frame), the design's tool tip (mm, design frame) and
//! the design's readings there (actuators' unit). plan.json: the predicted
//! figures, the prior's, the options and plan.csv's checksum: a pair
//! written as a set and read only if it matches, as a touch plan's
//! ([`crate::plan_file`]).

use std::path::Path;

use parcal_dataset::{DEFAULT_SESSION, read_optionally_labelled_numbers};
use parcal_kinematics::{Pose, Vec3, rotation_zyx};

use crate::DesignError;
use crate::plan_file::{check_pair, write_pair};
use crate::tracker::{PosePlan, PosePlanOptions};

/// The header of a pose plan.csv.
pub const HEADER: &str = "session,roll,pitch,yaw,x,y,z,q1,q2,q3,q4,q5,q6";
/// The session's column.
const SESSION: &str = "session";
/// Its numeric columns.
const COLUMNS: [&str; 12] = [
    "roll", "pitch", "yaw", "x", "y", "z", "q1", "q2", "q3", "q4", "q5", "q6",
];

/// One row of a pose plan.csv.
#[derive(Debug, Clone, PartialEq)]
pub struct PosePlanRow {
    /// The session's label.
    pub session: String,
    /// `[roll, pitch, yaw]` (rad).
    pub angles: [f64; 3],
    /// The design's tool tip (mm, design frame).
    pub tip: Vec3,
    /// The design's readings (actuators' unit).
    pub q: [f64; 6],
}

impl PosePlanRow {
    /// The platform pose that puts the tool point `tool` (platform frame)
    /// on the row's tip with its orientation.
    pub fn pose(&self, tool: &Vec3) -> Pose {
        let [roll, pitch, yaw] = self.angles;
        crate::pool::tip_pose_of_tool(tool, &self.tip, rotation_zyx(yaw, pitch, roll))
    }
}

/// Writes `plan` to `csv` and its summary to
/// [`crate::plan_file::summary_path`] as a set
/// (`write_pair`).
pub fn write_pose_plan(
    csv: &Path,
    plan: &PosePlan,
    options: &PosePlanOptions,
) -> Result<(), DesignError> {
    let mut text = String::from(HEADER);
    text.push('\n');
    let labels = crate::tracker::information::session_labels(options.sessions);
    for (c, &session) in plan.poses.iter().zip(&plan.sessions) {
        let fields: Vec<String> = std::iter::once(labels[session].clone())
            .chain(
                c.angles
                    .iter()
                    .chain(c.tip.iter())
                    .chain(c.q.iter())
                    .map(f64::to_string),
            )
            .collect();
        text.push_str(&fields.join(","));
        text.push('\n');
    }
    let kind = match (options.kind.poses(), options.kind.points()) {
        (true, true) => "both",
        (true, false) => "poses",
        _ => "points",
    };
    let summary = serde_json::json!({
        "predicted": plan.predicted,
        "prior": plan.prior,
        "criterion": options.criterion,
        "pool_size": plan.pool_size,
        "options": {
            "poses": options.poses,
            "tracker": kind,
            "workspace": {
                "half_width": options.workspace.half_width,
                "height": options.workspace.height,
            },
            "tilt_degrees": options.tilt_degrees,
            "criterion": options.criterion,
            "passes": options.passes,
            "sessions": options.sessions,
        },
    });
    write_pair(csv, &text, summary)
}

/// Reads a pose plan.csv (the dataset's CSV rules: columns by name,
/// bounded lines, errors naming the file, line and column); refused if
/// plan.json beside it is of another plan (`check_pair`).
pub fn read_pose_plan(path: &Path) -> Result<Vec<PosePlanRow>, DesignError> {
    check_pair(path)?;
    Ok(
        read_optionally_labelled_numbers(path, SESSION, &COLUMNS, "pose")?
            .into_iter()
            .map(|(session, v)| PosePlanRow {
                session: session.unwrap_or_else(|| DEFAULT_SESSION.to_owned()),
                angles: [v[0], v[1], v[2]],
                tip: Vec3::new(v[3], v[4], v[5]),
                q: std::array::from_fn(|i| v[6 + i]),
            })
            .collect(),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bad_rows_are_named_and_good_ones_read() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("plan.csv");
        std::fs::write(
            &path,
            format!("{HEADER}\nmon,0,0,0.5,1,2,300,1,2,3,4,5,6\nmon,0,0,x,1,2,3,4,5,6,7,8,9\n"),
        )
        .unwrap();
        let message = read_pose_plan(&path).unwrap_err().to_string();
        assert!(
            message.contains("line 3") && message.contains("yaw"),
            "{message}"
        );
        std::fs::write(&path, format!("{HEADER}\nmon,0,0,0.5,1,2,300,1,2,3,4,5\n")).unwrap();
        let message = read_pose_plan(&path).unwrap_err().to_string();
        assert!(
            message.contains("line 2") && message.contains("found 12"),
            "{message}"
        );
        std::fs::write(&path, "ball,u\n").unwrap();
        let message = read_pose_plan(&path).unwrap_err().to_string();
        assert!(
            message.contains("line 1") && message.contains("header"),
            "{message}"
        );
        std::fs::write(&path, format!("{HEADER}\n,0,0,0.5,1,2,300,1,2,3,4,5,6\n")).unwrap();
        let message = read_pose_plan(&path).unwrap_err().to_string();
        assert!(
            message.contains("line 2") && message.contains("session"),
            "{message}"
        );
        // Without the session column every row is in session 1.
        let old = HEADER.strip_prefix("session,").unwrap();
        std::fs::write(&path, format!("{old}\n0,0,0.5,1,2,300,1,2,3,4,5,6\n")).unwrap();
        assert_eq!(read_pose_plan(&path).unwrap()[0].session, "1");
        std::fs::write(
            &path,
            format!("{HEADER}\nmon,0,0,0.5,1,2,300,1,2,3,4,5,6\n"),
        )
        .unwrap();
        let rows = read_pose_plan(&path).unwrap();
        assert_eq!(rows[0].session, "mon");
        assert_eq!(rows[0].angles, [0.0, 0.0, 0.5]);
        assert_eq!(rows[0].tip, Vec3::new(1.0, 2.0, 300.0));
        assert_eq!(rows[0].q[5], 6.0);
        // The pose puts the tool on the tip.
        let tool = Vec3::new(0.0, 0.0, 50.0);
        let pose = rows[0].pose(&tool);
        assert!((pose.transform_point(&tool.into()).coords - rows[0].tip).norm() < 1e-12);
    }
}
