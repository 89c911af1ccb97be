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
//!
//! The summary (JSON): the mechanism, the group, the start, the
//! measurements with their targets and the group's trace after each, the
//! sigma of every unknown before and after, and the statements.

use std::path::Path;

use parcal_dataset::mechanism::{POSITION_COLUMNS, PROBE_COLUMNS, READING_COLUMNS};

use super::candidate::Candidate;
use super::predict::MechanismPlan;
use crate::DesignError;
use crate::plan_file::write_pair;

/// The fill-in file of `plan`'s measurements, for a mechanism of
/// `actuators` actuators; an error for a plan mixing kinds or of measured
/// points, which have no dataset file.
fn fill_in(plan: &MechanismPlan, actuators: usize) -> Result<String, DesignError> {
    let probes = plan
        .picks
        .iter()
        .all(|(c, _)| matches!(c, Candidate::Probe(_)));
    let samples = plan
        .picks
        .iter()
        .all(|(c, _)| matches!(c, Candidate::Sample(_) | Candidate::MeasuredSample(_)));
    let mut text = String::new();
    if probes {
        text.push_str(&PROBE_COLUMNS.join(","));
        text.push('\n');
        for (candidate, _) in &plan.picks {
            let [x, y, _] = candidate.position(plan.trigger_height);
            text.push_str(&format!("{x},{y},\n"));
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
        for (candidate, _) in &plan.picks {
            match candidate {
                Candidate::MeasuredSample([x, y, z]) => {
                    text.push_str(&format!("{empty}{x},{y},{z}\n"));
                }
                _ => text.push_str(&format!("{empty},,\n")),
            }
        }
    } else {
        return Err(DesignError::Options(
            "a plan's file holds one kind of measurement of the dataset: probe heights or encoder samples".into(),
        ));
    }
    Ok(text)
}

/// Writes `plan` to `path` (the fill-in file) and its summary beside it,
/// as a pair.
pub fn write_mechanism_plan(
    path: &Path,
    plan: &MechanismPlan,
    actuators: usize,
) -> Result<(), DesignError> {
    let text = fill_in(plan, actuators)?;
    let measurements: Vec<serde_json::Value> = plan
        .picks
        .iter()
        .map(|(candidate, trace)| {
            serde_json::json!({
                "kind": candidate.kind(),
                "target": candidate.position(plan.trigger_height),
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
    write_pair(path, &text, summary)
}
