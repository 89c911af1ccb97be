//! `parcal simulate --run commands.csv --truth DATASET`: actuator commands
//! run on a simulated dataset's true machine (docs/apply.md, the loop
//! closed in simulation), within machine.json's stroke and joint limits.

use std::path::{Path, PathBuf};

use anyhow::Context;
use parcal::apply::Target;
use parcal::apply::predicted::{registered_errors, rms};
use parcal::dataset::mechanism::TARGETS;
use parcal::dataset::{COMMANDS, read_numbers, write_numbers};
use parcal::kinematics::{Geometry, Vec3};
use parcal::simulation::{MachineLimits, SimulateError};

/// The options of `parcal simulate` that run commands.
#[derive(clap::Args)]
pub struct RunArgs {
    /// Run these actuator commands (header q1..q6, as `parcal compensate`
    /// writes them) on the true machine of --truth, and write what it
    /// reaches to --out (a CSV file, header x,y,z,roll,pitch,yaw: the true
    /// tool tip and platform angles in the design frame).
    #[arg(long, value_name = "COMMANDS_CSV", requires = "truth")]
    run: Option<PathBuf>,
    /// The simulated dataset (directory or snapshot) whose truth.json runs
    /// the commands; with --mechanism, the simulated mechanism dataset
    /// whose true machine is measured again (held-out data).
    #[arg(long, value_name = "DATASET")]
    truth: Option<PathBuf>,
    /// The targets the commands were made for: print the tip errors after
    /// the best rigid registration of the reached tips onto them.
    #[arg(long, value_name = "TARGETS_CSV", requires = "run")]
    targets: Option<PathBuf>,
}

impl RunArgs {
    /// Whether commands are to be run.
    pub fn requested(&self) -> bool {
        self.run.is_some()
    }

    /// The simulated dataset of `--truth`.
    pub fn truth(&self) -> Option<&Path> {
        self.truth.as_deref()
    }
}

/// Runs the commands and writes the reached poses to `out`.
pub fn run(args: &RunArgs, out: &Path) -> anyhow::Result<()> {
    let (Some(commands_path), Some(dataset_path)) = (&args.run, &args.truth) else {
        anyhow::bail!("--run needs --truth");
    };
    let mut inputs = crate::outputs::dataset_inputs(dataset_path);
    inputs.push(commands_path.clone());
    inputs.extend(args.targets.iter().cloned());
    crate::outputs::check(&inputs, &[out.to_path_buf()])?;
    let dataset = super::read_dataset(dataset_path)?;
    let truth = dataset.truth.as_ref().with_context(|| {
        format!(
            "{}: the dataset has no truth.json (only simulated datasets can run commands)",
            dataset_path.display()
        )
    })?;
    let g = &truth.geometry;
    let machine =
        Geometry::from_arrays(&g.base_joints, &g.platform_joints, &g.tool, &g.leg_lengths);
    let scale = truth
        .actuator_scale
        .unwrap_or(dataset.machine.actuator.scale);
    let commands = read_numbers(
        commands_path,
        &["q1", "q2", "q3", "q4", "q5", "q6"],
        "command",
        &COMMANDS,
    )?;
    // Every input is read and checked before anything is written.
    let goals = args
        .targets
        .as_ref()
        .map(|path| -> anyhow::Result<Vec<Vec3>> {
            let targets = read_numbers(path, &Target::COLUMNS, "target", &TARGETS)?;
            anyhow::ensure!(
                targets.len() == commands.len(),
                "{}: {} targets for {} commands",
                path.display(),
                targets.len(),
                commands.len()
            );
            Ok(targets
                .iter()
                .map(|t| Target::from_row(t).position)
                .collect())
        })
        .transpose()?;
    let joint_limits = dataset.machine.joint_limits.map(|l| l.limits());
    let limits = MachineLimits {
        stroke: dataset.machine.stroke,
        joint_limits: joint_limits.as_ref(),
    };
    let poses =
        parcal::simulation::execute(&machine, &scale, limits, &commands).map_err(|error| {
            match error {
                // The file's line: the header is line 1.
                SimulateError::Command { row, reason } => {
                    anyhow::anyhow!("{}: line {}: {reason}", commands_path.display(), row + 1)
                }
                other => anyhow::Error::new(other).context(commands_path.display().to_string()),
            }
        })?;
    let reached: Vec<Target> = poses
        .iter()
        .map(|p| Target::of_pose(p, &machine.tool))
        .collect();
    let rows: Vec<Vec<f64>> = reached.iter().map(|t| t.row().to_vec()).collect();
    let tips: Vec<Vec3> = reached.iter().map(|t| t.position).collect();
    let errors = goals
        .map(|goals| registered_errors(&tips, &goals))
        .transpose()?;
    write_numbers(out, &Target::COLUMNS, &rows)?;
    println!(
        "{} commands run on the true machine -> {}",
        rows.len(),
        out.display()
    );
    if let Some(errors) = errors {
        println!(
            "tip error after the best rigid registration onto the targets: RMS {:.1} um, max {:.1} um",
            1e3 * rms(&errors),
            1e3 * errors.iter().copied().fold(0.0, f64::max)
        );
    }
    Ok(())
}
