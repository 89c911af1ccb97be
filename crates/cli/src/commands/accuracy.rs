//! `parcal accuracy`: the accuracy maps of docs/paper-scenario.md section 5 as CSV and SVG.

use std::io::Write;
use std::path::{Path, PathBuf};

use anyhow::Context;
use nalgebra::SMatrix;
use parcal_accuracy::MapGrid;
use parcal_calibrate::setup::{design_geometry, kinematic_prior};
use parcal_calibrate::{ParamCovariance, PriorMode};
use parcal_dataset::Dataset;
use parcal_dataset::atomic::write_set;
use parcal_kinematics::params::TOOL_OFFSET;
use parcal_kinematics::{N_PARAMS, PARAM_NAMES, Params, params};
use parcal_report::maps::{map_files, write_maps};
use parcal_report::tables;
use parcal_workflows::evaluate::{BeforeAfter, TrueMachine, accuracy};

#[derive(clap::Args)]
pub struct Args {
    /// Dataset directory, or a binary snapshot file (dataset.bin).
    dataset: PathBuf,
    /// A calibration.json to assess (its parameters and posterior covariance);
    /// without it only the design (before calibration) is assessed.
    #[arg(long)]
    calibration: Option<PathBuf>,
    /// Output directory for accuracy.csv and the SVG maps.
    #[arg(long)]
    out: PathBuf,
    /// Use a calibration whose verdict is "rejected".
    #[arg(long)]
    accept_rejected: bool,
    /// Use a calibration of another dataset (its checksum differs from this one's).
    #[arg(long)]
    other_data: bool,
}

/// The parameters and covariance of a calibration.json of `dataset`: a
/// rejected one, or one of other data, only if the options say so; its
/// parameters must start with the 33, named and ordered as `PARAM_NAMES`
/// (a calibration with poses or points has its instrument parameters
/// after them).
fn calibrated(
    path: &Path,
    dataset: &Dataset,
    args: &Args,
) -> anyhow::Result<(Params, ParamCovariance)> {
    let calibration = super::read_calibration(path, args.accept_rejected)?;
    if let Some(provenance) = &calibration.provenance {
        anyhow::ensure!(
            args.other_data || provenance.dataset_checksum == dataset.checksum(),
            "{}: the calibration is of another dataset ({}, checksum {}; this one's is {}); give --other-data to map it here anyway",
            path.display(),
            provenance.dataset,
            provenance.dataset_checksum,
            dataset.checksum()
        );
    }
    let names = &calibration.parameters.names;
    // A calibration of poses alone holds the joints and legs but no tool.
    let tool_left_out = names
        .get(..TOOL_OFFSET)
        .is_some_and(|leading| leading == &PARAM_NAMES[..TOOL_OFFSET])
        && names.get(TOOL_OFFSET).map(String::as_str) != Some(PARAM_NAMES[TOOL_OFFSET]);
    anyhow::ensure!(
        !tool_left_out,
        "{}: the calibration did not calibrate the tool ({}, {}, {}: its data, poses alone, do not observe it); the accuracy maps are of the tool tip: calibrate with points or ball touches",
        path.display(),
        PARAM_NAMES[N_PARAMS - 3],
        PARAM_NAMES[N_PARAMS - 2],
        PARAM_NAMES[N_PARAMS - 1]
    );
    anyhow::ensure!(
        names.len() >= N_PARAMS && names.iter().zip(PARAM_NAMES).all(|(a, b)| a == b),
        "{}: expected the {N_PARAMS} kinematic parameters {} .. {} first, in that order, found {} parameters ({})",
        path.display(),
        PARAM_NAMES[0],
        PARAM_NAMES[N_PARAMS - 1],
        names.len(),
        names.iter().take(3).cloned().collect::<Vec<_>>().join(", ")
    );
    let values = &calibration.parameters.values;
    anyhow::ensure!(
        calibration.converged && calibration.covariance.len() == names.len(),
        "{}: the calibration has no posterior covariance (status: {})",
        path.display(),
        calibration.status
    );
    let covariance = SMatrix::from_fn(|i, j| calibration.covariance[i][j]);
    Ok((Params::from_column_slice(&values[..N_PARAMS]), covariance))
}

pub fn run(args: &Args) -> anyhow::Result<()> {
    let dataset = super::read_dataset(&args.dataset)?;
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("cannot create {}", args.out.display()))?;
    let mut inputs = crate::outputs::dataset_inputs(&args.dataset);
    inputs.extend(args.calibration.clone());
    crate::outputs::check(&inputs, &map_files(&args.out, ""))?;
    let truth = TrueMachine::of(&dataset)
        .transpose()
        .context("truth.json: the true geometry is degenerate")?;
    let design = design_geometry(&dataset);
    let design_params = params::to_params(&design.canonicalize().context("machine.json")?.geometry);
    let prior = kinematic_prior(&dataset, &design, &design_params, PriorMode::Propagated)?
        .context("machine.json: no prior tolerances")?;
    let grid = MapGrid::paper();
    let before = accuracy(
        &design,
        truth.as_ref(),
        &design_params,
        prior.covariance(),
        &grid,
    )?;
    let after = args
        .calibration
        .as_ref()
        .map(|path| -> anyhow::Result<_> {
            let (p, covariance) = calibrated(path, &dataset, args)?;
            Ok(accuracy(&design, truth.as_ref(), &p, &covariance, &grid)?)
        })
        .transpose()?;
    let maps = BeforeAfter {
        before: Some(before),
        after,
    };
    // The maps as a set that replaces every map of an earlier run: a map
    // this run does not draw (the true ones without truth.json, those
    // after calibration without --calibration) does not stay beside the
    // new ones.
    let files = map_files(&args.out, "");
    let pictures = write_set(&files, || write_maps(&args.out, "", "accuracy", &maps))?;
    let mut stdout = std::io::stdout().lock();
    writeln!(
        stdout,
        "{}",
        tables::accuracy(&[("design (propagated prior) / calibration", &maps)])
    )?;
    writeln!(
        stdout,
        "wrote {} and {} SVG maps to {}",
        args.out.join("accuracy.csv").display(),
        pictures.len(),
        args.out.display()
    )?;
    Ok(())
}
