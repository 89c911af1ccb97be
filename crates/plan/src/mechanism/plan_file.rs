//! A mechanism plan's files: the measurements to fill in, in the dataset's
//! own format, and its summary beside it (`FILE.json`,
//! [`crate::plan_file::summary_path`]), written as a pair.
//!
//! - Probe heights: probes.csv, `x,y,z`, each row the commanded `x, y`
//!   with `z` empty: the height `G30 S-1` reports there goes in.
//! - Encoder samples: points.csv, `q1..qA,x,y,z`, the readings empty; the
//!   position `x, y, z` given where it is to be measured (the target, to be
//!   replaced by the measured position), empty where it is not (the
//!   effector is moved near the target the summary lists and left there
//!   unmeasured).
//! - Part distances: distances.csv, `x1,y1,z1,x2,y2,z2,distance`, each row
//!   the two commanded positions with `distance` empty: the distance
//!   measured between them on the printed part goes in. In the file
//!   itself when the plan has only part distances, else beside it
//!   ([`distances_path`]).
//!
//! The summary (JSON): the mechanism, the group, the start, the
//! measurements with their targets and the group's trace after each, the
//! sigma of every unknown before and after, and the statements.

use std::path::{Path, PathBuf};

use parcal_dataset::mechanism::{
    DISTANCE_COLUMNS, POSITION_COLUMNS, PROBE_COLUMNS, READING_COLUMNS,
};

use super::candidate::Candidate;
use super::predict::MechanismPlan;
use crate::DesignError;
use crate::plan_file::{write_pair, write_pair_with};

/// The field of the summary that records the distances file's checksum.
const DISTANCES_CHECKSUM: &str = "distances_csv_checksum";

/// Where a plan with part distances and other measurements writes the
/// distances: `DIR/next.csv` -> `DIR/next-distances.csv`.
pub fn distances_path(path: &Path) -> PathBuf {
    let stem = path.file_stem().unwrap_or_default().to_string_lossy();
    path.with_file_name(format!("{stem}-distances.csv"))
}

/// The fill-in file of `picks` (one kind of measurement), for a mechanism
/// of `actuators` actuators; an error for picks mixing kinds or of
/// measured points, which have no dataset file.
fn fill_in(
    picks: &[Candidate],
    trigger_height: f64,
    actuators: usize,
) -> Result<String, DesignError> {
    let probes = picks.iter().all(|c| matches!(c, Candidate::Probe(_)));
    let samples = picks
        .iter()
        .all(|c| matches!(c, Candidate::Sample(_) | Candidate::MeasuredSample(_)));
    let distances = picks.iter().all(|c| matches!(c, Candidate::Distance(_)));
    let mut text = String::new();
    if probes {
        text.push_str(&PROBE_COLUMNS.join(","));
        text.push('\n');
        for candidate in picks {
            let [x, y, _] = candidate.positions(trigger_height)[0];
            text.push_str(&format!("{x},{y},\n"));
        }
    } else if distances {
        text.push_str(&DISTANCE_COLUMNS.join(","));
        text.push('\n');
        for candidate in picks {
            for [x, y, z] in candidate.positions(trigger_height) {
                text.push_str(&format!("{x},{y},{z},"));
            }
            text.push('\n');
        }
    } else if samples {
        let columns: Vec<&str> = READING_COLUMNS[..actuators]
            .iter()
            .chain(&POSITION_COLUMNS)
            .copied()
            .collect();
        text.push_str(&columns.join(","));
        text.push('\n');
        let empty = ",".repeat(actuators);
        for candidate in picks {
            match candidate {
                Candidate::MeasuredSample([x, y, z]) => {
                    text.push_str(&format!("{empty}{x},{y},{z}\n"));
                }
                _ => text.push_str(&format!("{empty},,\n")),
            }
        }
    } else {
        return Err(DesignError::Options(
            "a plan's file holds one kind of measurement of the dataset: probe heights, part distances or encoder samples".into(),
        ));
    }
    Ok(text)
}

/// Writes `plan` to `path` (the fill-in file), its part distances to
/// [`distances_path`] if it has other measurements too, and its summary
/// beside `path`, as a set.
pub fn write_mechanism_plan(
    path: &Path,
    plan: &MechanismPlan,
    actuators: usize,
) -> Result<(), DesignError> {
    let (distances, others): (Vec<Candidate>, Vec<Candidate>) = plan
        .picks
        .iter()
        .map(|(c, _)| *c)
        .partition(|c| matches!(c, Candidate::Distance(_)));
    let fill = |picks: &[Candidate]| fill_in(picks, plan.trigger_height, actuators);
    let (text, beside) = if others.is_empty() {
        (fill(&distances)?, None)
    } else if distances.is_empty() {
        (fill(&others)?, None)
    } else {
        (fill(&others)?, Some(fill(&distances)?))
    };
    let measurements: Vec<serde_json::Value> = plan
        .picks
        .iter()
        .map(|(candidate, trace)| {
            let positions = candidate.positions(plan.trigger_height);
            let (field, at) = match positions.as_slice() {
                [target] => ("target", serde_json::json!(target)),
                ends => ("ends", serde_json::json!(ends)),
            };
            serde_json::json!({
                "kind": candidate.kind(),
                field: at,
                "position_measured": !matches!(candidate, Candidate::Sample(_)),
                "trace_after": trace,
            })
        })
        .collect();
    let summary = serde_json::json!({
        "mechanism": plan.mechanism,
        "group": plan.group,
        "start": if plan.from_calibration { "calibration" } else { "prior" },
        "feasible_candidates": plan.feasible,
        "trace_before": plan.trace_before,
        "trace_after": plan.trace_after(),
        "measurements": measurements,
        "parameters": plan.parameters,
        "statements": plan.statements,
    });
    match beside {
        None => write_pair(path, &text, summary),
        Some(distances) => write_pair_with(
            path,
            &text,
            &[(&distances_path(path), &distances, DISTANCES_CHECKSUM)],
            summary,
        ),
    }
}
