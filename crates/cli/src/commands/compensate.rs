//! `parcal compensate`: targets to actuator commands with a calibration
//! (docs/apply.md), corrected poses for controllers that use the nominal
//! model, and correction tables; target poses to a mechanism's
//! commands with `--targets` ([`super::mechanism_apply`]).

use std::path::{Path, PathBuf};

use anyhow::Context;
use parcal::apply::predicted::rms;
use parcal::apply::{
    AppliedModel, ApplyError, CorrectionTable, TableGrid, Target, compensate, corrected_poses,
    predicted_registered,
};
use parcal::correction_table::{AxisRange, correction_table, table_grid};
use parcal::dataset::atomic::write_set;
use parcal::dataset::mechanism::MechanismCalibrationRecord;
use parcal::dataset::mechanism::TARGETS;
use parcal::dataset::{read_numbers, write_numbers};
use parcal::simulation::mechanism::Spelling;

#[derive(clap::Args)]
pub struct Args {
    /// The calibration to apply (calibration.json; it carries the design).
    #[arg(long)]
    calibration: PathBuf,
    /// Targets: CSV with header x,y,z,roll,pitch,yaw (tool tip in mm and
    /// R = Rz(yaw) Ry(pitch) Rx(roll) in rad, design frame).
    #[arg(
        long,
        required_unless_present_any = ["table", "targets"],
        conflicts_with_all = ["table", "targets"]
    )]
    poses: Option<PathBuf>,
    /// For a mechanism's calibration (a delta, a cable robot, a hexapod
    /// calibrated with --common): target poses, CSV with a column per pose
    /// coordinate (x,y,z, mm, for an effector position; a hexapod's
    /// t_x,t_y,t_z in mm and rotation vector r_x,r_y,r_z in rad); the
    /// commands are written with the target and the nominal machine's
    /// beside them (header: the pose's, q1..qA, nominal_q1..nominal_qA).
    /// An elastic cable robot's targets may give the lines' loads f1..fA
    /// (N): the commands are then those under them, the loads written
    /// after the pose.
    #[arg(long, conflicts_with_all = ["table", "corrected_poses", "nominal"])]
    targets: Option<PathBuf>,
    /// Instead of targets: a correction table over the grid
    /// `x=MIN:MAX:N,y=...,z=...[,roll=...,pitch=...,yaw=...]` (absent axes
    /// at 0), written to --out with its interpolation error printed.
    #[arg(long)]
    table: Option<String>,
    /// Output: the commands (header q1..q6, in the actuators' unit), or the
    /// correction table.
    #[arg(long)]
    out: PathBuf,
    /// Also write the corrected poses (header x,y,z,roll,pitch,yaw): what
    /// to send to a controller that uses the nominal (design) model.
    #[arg(long, conflicts_with = "table")]
    corrected_poses: Option<PathBuf>,
    /// Use a calibration whose verdict is "rejected".
    #[arg(long)]
    accept_rejected: bool,
    /// Command with the nominal (design) model instead of the calibrated
    /// one, for comparison.
    #[arg(long)]
    nominal: bool,
}

pub fn run(args: &Args) -> anyhow::Result<()> {
    if let Some(targets) = &args.targets {
        return super::mechanism_apply::compensate(
            &args.calibration,
            targets,
            args.accept_rejected,
            &args.out,
        );
    }
    let inputs: Vec<PathBuf> = std::iter::once(&args.calibration)
        .chain(&args.poses)
        .cloned()
        .collect();
    let outputs: Vec<PathBuf> = std::iter::once(&args.out)
        .chain(&args.corrected_poses)
        .cloned()
        .collect();
    crate::outputs::check(&inputs, &outputs)?;
    let record = super::read_calibration(&args.calibration, args.accept_rejected).map_err(|error| {
        // A mechanism's calibration read as a hexapod's: say what takes it.
        match MechanismCalibrationRecord::read(&args.calibration) {
            Ok(record) => anyhow::anyhow!(
                "{}: a {}'s calibration: compensate it at positions with --targets (--poses and --table compensate a hexapod's)",
                args.calibration.display(),
                record.mechanism
            ),
            Err(_) => error,
        }
    })?;
    let mut model = AppliedModel::from_record(&record)
        .with_context(|| format!("{}", args.calibration.display()))?;
    let p = &model.placement;
    println!(
        "calibrated geometry placed in the design frame: joints within {:.4} mm (base) and {:.4} mm (platform, tool) RMS of the design's",
        p.base_rms, p.platform_rms
    );
    if args.nominal {
        model = model.nominal()?;
        println!("commanding with the nominal (design) model");
    }
    match (&args.poses, &args.table) {
        (Some(poses), _) => commands(args, &model, poses),
        (None, Some(spec)) => table(args, &model, spec),
        (None, None) => anyhow::bail!("give --poses or --table"),
    }
}

fn commands(args: &Args, model: &AppliedModel, poses: &Path) -> anyhow::Result<()> {
    let targets: Vec<Target> = read_numbers(poses, &Target::COLUMNS, "target", &TARGETS)?
        .iter()
        .map(Target::from_row)
        .collect();
    let commands = compensate(model, &targets).map_err(|error| match error {
        // The file's line: the header is line 1.
        ApplyError::Refused { row, refusal } => {
            anyhow::anyhow!("{}: line {}: {refusal}", poses.display(), row + 1)
        }
        other => anyhow::Error::new(other).context(poses.display().to_string()),
    })?;
    let header = ["q1", "q2", "q3", "q4", "q5", "q6"];
    let rows: Vec<Vec<f64>> = commands.iter().map(|c| c.q.to_vec()).collect();
    // Everything is computed before anything is written.
    let corrected = match &args.corrected_poses {
        Some(path) => {
            let poses = corrected_poses(model, &commands)
                .with_context(|| format!("{}", poses.display()))?;
            let rows: Vec<Vec<f64>> = poses.iter().map(|t| t.row().to_vec()).collect();
            Some((path, rows))
        }
        None => None,
    };
    // The commands and the corrected poses: both new, or both as they were.
    write_set(&[], || -> anyhow::Result<()> {
        write_numbers(&args.out, &header, &rows)?;
        if let Some((path, rows)) = &corrected {
            write_numbers(path, &Target::COLUMNS, rows)?;
        }
        Ok(())
    })?;
    if let Some((path, _)) = corrected {
        println!("corrected poses: {}", path.display());
    }
    let worst = commands
        .iter()
        .map(|c| c.conditioning)
        .fold(f64::INFINITY, f64::min);
    println!(
        "{} targets -> {} (readings in {}); smallest Jacobian singular-value ratio {worst:.3}",
        commands.len(),
        args.out.display(),
        model.unit
    );
    if model.covariance.is_none() && !args.nominal {
        // A run that did not converge records none: its covariance at the
        // last iterate is no accuracy.
        println!(
            "predicted tip error after registration: none (calibration.json gives no posterior covariance of the 33 kinematic parameters: a run that did not converge has none, and poses alone do not calibrate the tool)"
        );
    } else if let Ok(predicted) = predicted_registered(model, &commands) {
        // Three non-collinear targets at least: the registration is
        // defined.
        println!(
            "predicted tip error after registration: RMS {:.1} um, max {:.1} um (posterior covariance of the 33 kinematic parameters)",
            1e3 * rms(&predicted),
            1e3 * predicted.iter().copied().fold(0.0, f64::max)
        );
    }
    Ok(())
}

/// Parses `x=MIN:MAX:N,...` (module doc of `--table`) into the grid
/// ([`parcal::correction_table::table_grid`], which bounds the nodes).
fn grid(spec: &str) -> anyhow::Result<TableGrid> {
    let mut ranges: [Option<AxisRange>; 6] = [None; 6];
    for part in spec.split(',').map(str::trim).filter(|p| !p.is_empty()) {
        let (name, range) = part
            .split_once('=')
            .with_context(|| format!("--table: {part:?} is not AXIS=MIN:MAX:N"))?;
        let axis = Target::COLUMNS
            .iter()
            .position(|c| *c == name.trim())
            .with_context(|| {
                format!("--table: unknown axis {name:?} (one of x, y, z, roll, pitch, yaw)")
            })?;
        let fields: Vec<&str> = range.split(':').collect();
        let parsed = match fields.as_slice() {
            [min, max, n] => min
                .trim()
                .parse::<f64>()
                .ok()
                .zip(max.trim().parse::<f64>().ok())
                .zip(n.trim().parse::<usize>().ok()),
            _ => None,
        };
        let ((min, max), nodes) = parsed
            .filter(|&((min, max), _)| min.is_finite() && max.is_finite())
            .with_context(|| {
                format!("--table: {part:?} is not AXIS=MIN:MAX:N with finite MIN, MAX and N >= 1")
            })?;
        anyhow::ensure!(ranges[axis].is_none(), "--table: axis {name} given twice");
        ranges[axis] = Some(AxisRange { min, max, nodes });
    }
    table_grid(&ranges, Spelling::Flags).map_err(anyhow::Error::msg)
}

fn table(args: &Args, model: &AppliedModel, spec: &str) -> anyhow::Result<()> {
    let grid = grid(spec)?;
    let (table, error) = correction_table(model, &grid)?;
    write_numbers(&args.out, &CorrectionTable::HEADER, &table.rows())?;
    println!(
        "correction table: {} nodes -> {}; multilinear interpolation error at the {} cell midpoints: position RMS {:.2} um, max {:.2} um; angles max {:.2e} rad",
        grid.len(),
        args.out.display(),
        error.points,
        1e3 * error.position_rms,
        1e3 * error.position_max,
        error.angle_max
    );
    Ok(())
}
