//! plan.csv and plan.json (docs/outputs-format.md, "plan.csv and plan.json").
//!
//! plan.csv, one touch per row:
//! `ball,u_x,u_y,u_z,roll,pitch,yaw,q1,q2,q3,q4,q5,q6`: the ball id, the
//! unit outward normal `u` at the intended contact point (design frame),
//! the orientation `R = Rz(yaw) Ry(pitch) Rx(roll)` (rad, fixed axes of the
//! design frame) and the nominal actuator commands (mm) that put the
//! design's tool tip on `C + r u`. plan.json: the predicted figures, the
//! prior's, the options, and plan.csv's checksum. Written as a set
//! (`write_pair`); read back only as a pair that matches
//! (`check_pair`).

use std::path::{Path, PathBuf};

use parcal_dataset::atomic::{write_file, write_set};
use parcal_dataset::{Artefacts, checksum, read_labelled_numbers};
use parcal_kinematics::Vec3;

use crate::{DesignError, Plan, PlanOptions};

/// The header of plan.csv.
pub const HEADER: &str = "ball,u_x,u_y,u_z,roll,pitch,yaw,q1,q2,q3,q4,q5,q6";
/// The numeric columns of plan.csv, after `ball`.
const COLUMNS: [&str; 12] = [
    "u_x", "u_y", "u_z", "roll", "pitch", "yaw", "q1", "q2", "q3", "q4", "q5", "q6",
];

/// Largest accepted `| |u| - 1 |` of a direction read from plan.csv.
const UNIT_TOLERANCE: f64 = 1e-6;

/// One row of plan.csv.
#[derive(Debug, Clone, PartialEq)]
pub struct PlanRow {
    /// The ball id (artefacts.json).
    pub ball: String,
    /// Unit outward normal at the contact point (design frame).
    pub direction: Vec3,
    /// `[roll, pitch, yaw]` (rad).
    pub angles: [f64; 3],
    /// Nominal actuator commands (mm).
    pub q: [f64; 6],
}

/// plan.json beside plan.csv: `DIR/plan.csv` -> `DIR/plan.json`.
pub fn summary_path(csv: &Path) -> PathBuf {
    csv.with_extension("json")
}

/// Writes `plan` to `csv` and its summary to [`summary_path`], each
/// atomically; `artefacts` names the balls.
pub fn write_plan(
    csv: &Path,
    plan: &Plan,
    artefacts: &Artefacts,
    options: &PlanOptions,
) -> Result<(), DesignError> {
    let mut text = String::from(HEADER);
    text.push('\n');
    for c in &plan.contacts {
        let u = c.direction;
        let [roll, pitch, yaw] = c.angles;
        text.push_str(&format!(
            "{},{},{},{},{},{},{}",
            artefacts.balls[c.ball].id, u.x, u.y, u.z, roll, pitch, yaw
        ));
        for q in c.q {
            text.push_str(&format!(",{q}"));
        }
        text.push('\n');
    }
    let summary = serde_json::json!({
        "predicted": plan.predicted,
        "prior": plan.prior,
        "criterion": options.criterion,
        "pool_size": plan.pool_size,
        "stroke": plan.stroke,
        "options": options,
    });
    write_pair(csv, &text, summary)
}

/// The field of plan.json that records plan.csv's checksum.
const CSV_CHECKSUM: &str = "plan_csv_checksum";

/// Writes the plan `text` to `csv` and `summary`, with the checksum of
/// `text` added as [`CSV_CHECKSUM`], to [`summary_path`], as a set: both
/// whole or neither ([`write_set`]).
pub(crate) fn write_pair(
    csv: &Path,
    text: &str,
    summary: serde_json::Value,
) -> Result<(), DesignError> {
    write_pair_with(csv, text, &[], summary)
}

/// `write_pair` with more files beside: each `(path, text, field)`
/// written in the same set, its checksum recorded in the summary's
/// `field`.
pub(crate) fn write_pair_with(
    csv: &Path,
    text: &str,
    beside: &[(&Path, &str, &str)],
    mut summary: serde_json::Value,
) -> Result<(), DesignError> {
    summary[CSV_CHECKSUM] = checksum::of_bytes(text.as_bytes()).into();
    for (_, text, field) in beside {
        summary[*field] = checksum::of_bytes(text.as_bytes()).into();
    }
    let json = serde_json::to_string_pretty(&summary).expect("plain numbers and strings");
    write_set(&[], || {
        for (path, text, _) in beside {
            write_file(path, text.as_bytes())?;
        }
        write_file(csv, text.as_bytes())?;
        write_file(&summary_path(csv), format!("{json}\n").as_bytes())
    })?;
    Ok(())
}

/// Checks that plan.json beside `csv` ([`summary_path`]), if there is one
/// and it records a checksum (a plan.csv may be written by hand, and
/// alone), is that of `csv`: a pair from two runs (one interrupted between
/// its two renames) is refused, naming both files.
pub(crate) fn check_pair(csv: &Path) -> Result<(), DesignError> {
    let summary = summary_path(csv);
    let Some(recorded) = checksum::recorded(&summary, CSV_CHECKSUM)? else {
        return Ok(());
    };
    let actual = checksum::of_file(csv)?;
    if recorded == actual {
        Ok(())
    } else {
        Err(DesignError::MismatchedPair {
            csv: csv.to_path_buf(),
            summary,
            recorded,
            actual,
        })
    }
}

/// Reads plan.csv (the dataset's CSV rules: columns by name, bounded
/// lines, errors naming the file, line and column): finite numbers with
/// unit directions; refused if plan.json beside it is of another plan
/// (`check_pair`).
pub fn read_plan(path: &Path) -> Result<Vec<PlanRow>, DesignError> {
    check_pair(path)?;
    let rows = read_labelled_numbers(path, "ball", &COLUMNS, "touch", |v| {
        let norm = Vec3::new(v[0], v[1], v[2]).norm();
        if (norm - 1.0).abs() > UNIT_TOLERANCE {
            Err(format!(
                "u = ({}, {}, {}) is not a unit vector",
                v[0], v[1], v[2]
            ))
        } else {
            Ok(())
        }
    })?;
    Ok(rows
        .into_iter()
        .map(|(ball, v)| PlanRow {
            ball,
            direction: Vec3::new(v[0], v[1], v[2]),
            angles: [v[3], v[4], v[5]],
            q: std::array::from_fn(|i| v[6 + i]),
        })
        .collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_plan_csv_of_another_run_than_its_plan_json_is_refused() {
        let dir = tempfile::tempdir().unwrap();
        let csv = dir.path().join("plan.csv");
        let row = |yaw: &str| format!("{HEADER}\nb01,0,0,-1,0,0,{yaw},1,2,3,4,5,6\n");
        write_pair(&csv, &row("0.5"), serde_json::json!({"pool_size": 1})).unwrap();
        assert_eq!(read_plan(&csv).unwrap()[0].angles[2], 0.5);
        // plan.csv of another run beside this plan.json (a kill between
        // the renames): refused, naming both.
        std::fs::write(&csv, row("0.25")).unwrap();
        let message = read_plan(&csv).unwrap_err().to_string();
        assert!(
            message.contains("plan.csv and")
                && message.contains("plan.json are not of the same plan"),
            "{message}"
        );
        // A plan.csv alone is read.
        std::fs::remove_file(summary_path(&csv)).unwrap();
        assert_eq!(read_plan(&csv).unwrap()[0].angles[2], 0.25);
    }

    #[test]
    fn bad_rows_are_named() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("plan.csv");
        std::fs::write(
            &path,
            format!("{HEADER}\nb01,0,0,-1,0,0,0,1,2,3,4,5,6\nb02,0,0,-2,0,0,0,1,2,3,4,5,6\n"),
        )
        .unwrap();
        let message = read_plan(&path).unwrap_err().to_string();
        assert!(
            message.contains("line 3") && message.contains("not a unit vector"),
            "{message}"
        );
        std::fs::write(&path, format!("{HEADER}\nb01,0,0,-1,0,0,x,1,2,3,4,5,6\n")).unwrap();
        let message = read_plan(&path).unwrap_err().to_string();
        assert!(
            message.contains("line 2") && message.contains("yaw"),
            "{message}"
        );
        std::fs::write(&path, "ball,u\n").unwrap();
        let message = read_plan(&path).unwrap_err().to_string();
        assert!(
            message.contains("line 1") && message.contains("header"),
            "{message}"
        );
        std::fs::write(&path, format!("{HEADER}\nb01,0,0,-1,0,0,0.5,1,2,3,4,5,6\n")).unwrap();
        let rows = read_plan(&path).unwrap();
        assert_eq!(rows[0].ball, "b01");
        assert_eq!(rows[0].angles, [0.0, 0.0, 0.5]);
        assert_eq!(rows[0].q[5], 6.0);
    }
}
