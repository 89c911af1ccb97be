//! `parcal inspect`: read and validate a dataset and summarise it, with a
//! warning naming the first reading outside machine.json's stroke (another
//! mechanism's dataset: [`super::mechanism::inspect`]).

use std::collections::BTreeSet;
use std::io::Write;
use std::path::PathBuf;

use anyhow::Context;
use parcal::calibration::setup::design_geometry;
use parcal::dataset::Dataset;
use parcal::kinematics::{ForwardOptions, forward_from_home};
use rayon::prelude::*;

#[derive(clap::Args)]
pub struct Args {
    /// Dataset directory (machine.json, artefacts.json, measurements.csv[, truth.json]),
    /// or a binary snapshot file (dataset.bin).
    dataset: PathBuf,
}

/// How many failing rows to name.
const LISTED_FAILURES: usize = 5;

pub fn run(args: &Args) -> anyhow::Result<()> {
    if let Some(mechanism) = super::mechanism::declared(&args.dataset)? {
        return super::mechanism::inspect(&args.dataset, &mechanism);
    }
    let dataset = super::read_dataset(&args.dataset)?;
    let design = design_geometry(&dataset);
    design
        .canonicalize()
        .context("machine.json: the design geometry is degenerate")?;

    let mut stdout = std::io::stdout().lock();
    writeln!(stdout, "dataset {}", args.dataset.display())?;
    if let Some(outside) = dataset.reading_outside_stroke() {
        writeln!(stdout, "  warning: {outside}")?;
    }
    if !dataset.tracker.is_empty() {
        instruments(&mut stdout, &dataset)?;
    }
    if !dataset.has_touches() {
        return Ok(());
    }
    let counts = dataset.contacts_per_ball();
    let m = &dataset.measurements;
    writeln!(
        stdout,
        "  balls              {} ({:?} frame)",
        counts.len(),
        dataset.artefacts.frame
    )?;
    writeln!(
        stdout,
        "  contacts           {} ({} .. {} per ball)",
        m.q.len(),
        counts.iter().min().unwrap_or(&0),
        counts.iter().max().unwrap_or(&0)
    )?;
    let distances = &dataset.artefacts.distances;
    if distances.is_empty() {
        writeln!(stdout, "  ball distances     0")?;
    } else {
        let tied: BTreeSet<usize> = distances.iter().flat_map(|d| [d.a, d.b]).collect();
        writeln!(
            stdout,
            "  ball distances     {} (tying {} balls)",
            distances.len(),
            tied.len()
        )?;
    }
    writeln!(
        stdout,
        "  approach dirs      {}",
        if m.direction.is_some() { "yes" } else { "no" }
    )?;
    truth_line(&mut stdout, &dataset)?;
    for i in 0..6 {
        let (lo, hi) =
            m.q.iter()
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), q| {
                    (lo.min(q[i]), hi.max(q[i]))
                });
        writeln!(stdout, "  q{}                 {lo:.4} .. {hi:.4} mm", i + 1)?;
    }

    let options = ForwardOptions::default();
    let failures: Vec<(usize, String)> =
        m.q.par_iter()
            .enumerate()
            .filter_map(|(row, q)| {
                forward_from_home(&design, q, &options)
                    .err()
                    .map(|error| (row, error.to_string()))
            })
            .collect();
    if failures.is_empty() {
        writeln!(
            stdout,
            "  forward kinematics with the design geometry succeeds on every row"
        )?;
        return Ok(());
    }
    for (row, error) in failures.iter().take(LISTED_FAILURES) {
        // Line numbers of measurements.csv: the header is line 1.
        crate::progress::stderr_line(&format!("  measurements.csv line {}: {error}", row + 2));
    }
    anyhow::bail!(
        "forward kinematics with the design geometry fails on {} of {} rows of measurements.csv",
        failures.len(),
        m.q.len()
    )
}

fn truth_line(out: &mut impl Write, dataset: &Dataset) -> std::io::Result<()> {
    writeln!(
        out,
        "  truth              {}",
        if dataset.truth.is_some() { "yes" } else { "no" }
    )
}

/// The instrument measurements: sessions, rows, the readings' ranges in
/// the actuators' unit, the instrument's repeatability.
fn instruments(out: &mut impl Write, dataset: &Dataset) -> anyhow::Result<()> {
    let tracker = &dataset.tracker;
    let machine = &dataset.machine;
    writeln!(
        out,
        "  poses              {} (poses.csv)",
        tracker.poses.len()
    )?;
    writeln!(
        out,
        "  points             {} (points.csv)",
        tracker.points.len()
    )?;
    for (label, (poses, points)) in tracker.sessions.iter().zip(tracker.rows_per_session()) {
        writeln!(out, "  session {label:<10} {poses} poses, {points} points")?;
    }
    let unit = &machine.actuator.unit;
    let scales = if machine.actuator.scale_sigma.is_some() {
        "estimated"
    } else {
        "known"
    };
    writeln!(out, "  actuator unit      {unit} (scales {scales})")?;
    for i in 0..6 {
        let (lo, hi) = tracker
            .poses
            .q
            .iter()
            .chain(&tracker.points.q)
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), q| {
                (lo.min(q[i]), hi.max(q[i]))
            });
        writeln!(
            out,
            "  q{}                 {lo:.4} .. {hi:.4} {unit}",
            i + 1
        )?;
    }
    let r = &machine.repeatability;
    let sigma = |v: Option<f64>| v.map_or("-".to_string(), |v| format!("{v}"));
    writeln!(
        out,
        "  instrument sigma   position {} mm, orientation {} rad",
        sigma(r.position),
        sigma(r.orientation)
    )?;
    truth_line(out, dataset)?;
    Ok(())
}
