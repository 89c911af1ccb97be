//! A mechanism plan's files: the measurements to fill in, in the dataset's
//! own format, and its summary beside it (`FILE.json`,
//! [`crate::plan_file::summary_path`]), written as a set.
//!
//! - Probe heights: probes.csv, `x,y,z`, each row the commanded `x, y`
//!   with `z` empty: the height `G30 S-1` reports there goes in.
//! - Encoder samples: points.csv, `q1..qA,x,y,z`, the readings empty; the
//!   position `x, y, z` given where it is to be measured (the target, to be
//!   replaced by the measured position), empty where it is not (the
//!   effector is moved near the target the summary lists and left there
//!   unmeasured).
//! - Heights measured by hand: heights.csv, `x,y,z,height`, each row the
//!   commanded position with `height` empty: the nozzle's height above
//!   the bed measured there goes in.
//! - Part distances: distances.csv, `x1,y1,z1,x2,y2,z2,distance`, each row
//!   the two commanded positions with `distance` empty: the distance
//!   measured between them on the printed part goes in.
//!
//! The first stage planned ([`Stage`]) goes in the file itself, each later
//! one beside it ([`stage_paths`]). The summary (JSON): the mechanism, the
//! group, the start, the measurements with their targets and the group's
//! trace after each, the sigma of every unknown before and after, and the
//! statements.

use std::path::{Path, PathBuf};

use parcal_dataset::mechanism::{
    DISTANCE_COLUMNS, HEIGHT_COLUMNS, POSITION_COLUMNS, PROBE_COLUMNS, READING_COLUMNS,
};

use super::candidate::{Candidate, Counts, Stage};
use super::predict::MechanismPlan;
use crate::DesignError;
use crate::plan_file::write_pair_with;

/// The word a stage's file beside the plan's is named by.
fn suffix(stage: Stage) -> &'static str {
    match stage {
        Stage::Measurements => "measurements",
        Stage::Heights => "heights",
        Stage::Distances => "distances",
    }
}

/// The files a plan of `counts` writes its picks to, stage by stage: the
/// first stage with picks in `path` itself, each later one beside it
/// (`DIR/next.csv` -> `DIR/next-heights.csv`, `DIR/next-distances.csv`).
pub fn stage_paths(path: &Path, counts: Counts) -> Vec<(Stage, PathBuf)> {
    let stem = path.file_stem().unwrap_or_default().to_string_lossy();
    Stage::ALL
        .into_iter()
        .filter(|&stage| counts.of(stage) > 0)
        .enumerate()
        .map(|(k, stage)| {
            let file = if k == 0 {
                path.to_path_buf()
            } else {
                path.with_file_name(format!("{stem}-{}.csv", suffix(stage)))
            };
            (stage, file)
        })
        .collect()
}

/// A CSV's header line.
fn header(columns: &[&str]) -> String {
    format!("{}\n", columns.join(","))
}

/// The fill-in file of `picks` (one stage's), for a mechanism of
/// `actuators` actuators; an error for measurements mixing kinds or of
/// measured points, which have no dataset file.
fn fill_in(
    picks: &[Candidate],
    trigger_height: f64,
    actuators: usize,
) -> Result<String, DesignError> {
    let all = |kind: fn(&Candidate) -> bool| picks.iter().all(kind);
    let mut text;
    if all(|c| matches!(c, Candidate::Probe(_))) {
        text = header(&PROBE_COLUMNS);
        for candidate in picks {
            let [x, y, _] = candidate.positions(trigger_height)[0];
            text.push_str(&format!("{x},{y},\n"));
        }
    } else if all(|c| matches!(c, Candidate::Height(_))) {
        text = header(&HEIGHT_COLUMNS);
        for candidate in picks {
            let [x, y, z] = candidate.positions(trigger_height)[0];
            text.push_str(&format!("{x},{y},{z},\n"));
        }
    } else if all(|c| matches!(c, Candidate::Distance(_))) {
        text = header(&DISTANCE_COLUMNS);
        for candidate in picks {
            for [x, y, z] in candidate.positions(trigger_height) {
                text.push_str(&format!("{x},{y},{z},"));
            }
            text.push('\n');
        }
    } else if all(|c| matches!(c, Candidate::Sample(_) | Candidate::MeasuredSample(_))) {
        let columns: Vec<&str> = READING_COLUMNS[..actuators]
            .iter()
            .chain(&POSITION_COLUMNS)
            .copied()
            .collect();
        text = header(&columns);
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
            "a plan's file holds one kind of measurement of the dataset: probe heights, encoder samples, manual heights or part distances".into(),
        ));
    }
    Ok(text)
}

/// Writes `plan` to `path` and, when it has picks of more than one
/// stage, the later stages' beside it ([`stage_paths`]), with its summary
/// beside `path`, as a set.
pub fn write_mechanism_plan(
    path: &Path,
    plan: &MechanismPlan,
    actuators: usize,
) -> Result<(), DesignError> {
    let of_stage = |stage: Stage| -> Vec<Candidate> {
        plan.picks
            .iter()
            .map(|(c, _)| *c)
            .filter(|c| c.stage() == stage)
            .collect()
    };
    let counts = Counts {
        measurements: of_stage(Stage::Measurements).len(),
        heights: of_stage(Stage::Heights).len(),
        distances: of_stage(Stage::Distances).len(),
    };
    let files = stage_paths(path, counts)
        .into_iter()
        .map(|(stage, file)| {
            let text = fill_in(&of_stage(stage), plan.trigger_height, actuators)?;
            Ok((stage, file, text))
        })
        .collect::<Result<Vec<_>, DesignError>>()?;
    let Some(((_, _, text), beside)) = files.split_first() else {
        return Err(DesignError::Options("a plan with no measurements".into()));
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
    let fields: Vec<String> = beside
        .iter()
        .map(|(stage, _, _)| format!("{}_csv_checksum", suffix(*stage)))
        .collect();
    let beside: Vec<(&Path, &str, &str)> = beside
        .iter()
        .zip(&fields)
        .map(|((_, file, text), field)| (file.as_path(), text.as_str(), field.as_str()))
        .collect();
    write_pair_with(path, text, &beside, summary)
}
