//! `parcal plan` on a mechanism dataset (machine.json naming a linear
//! delta or a cable robot): the probe heights or encoder samples to
//! measure next, by [`parcal::plan::mechanism`], written as the dataset's
//! own probes.csv or points.csv to fill in, with the predicted sigmas
//! before and after (docs/delta.md, docs/cable-robots.md).

use std::io::Write;
use std::path::Path;

use parcal::calibration::mechanism::MechanismData;
use parcal::dataset::mechanism::{
    MACHINE_FILE, MechanismCalibrationRecord, MechanismDataset, MechanismMachine,
};
use parcal::plan::bounds;
use parcal::plan::mechanism::plan_file::write_mechanism_plan;
use parcal::plan::mechanism::workspace::{DEFAULT_GRID, grid_candidates};
use parcal::plan::mechanism::{MechanismPlan, PlanRequest, Start, default_group, plan_mechanism};
use parcal::plan::plan_file::summary_path;

use crate::bounds::Bounded;

/// The options of a mechanism's plan.
#[derive(clap::Args)]
pub struct MechanismArgs {
    /// A mechanism's plan: how many measurements (probe heights, encoder
    /// samples) to plan.
    #[arg(long, value_parser = Bounded(bounds::MEASUREMENTS))]
    measurements: Option<usize>,
    /// A mechanism's plan: the parameter group whose predicted covariance's
    /// trace is minimised (default: a delta's "diagonal rods", a cable
    /// robot's "anchors").
    #[arg(long, value_name = "GROUP")]
    group: Option<String>,
    /// A mechanism's plan: candidates per axis of the grid over its
    /// workspace (a delta's bed, a cable robot's anchors' box).
    #[arg(long, value_parser = Bounded(bounds::GRID))]
    grid: Option<usize>,
    /// A cable robot's plan: samples whose position is measured too
    /// (noise.position), rather than left unknown.
    #[arg(long)]
    measured_positions: bool,
}

impl MechanismArgs {
    /// Refuses these options in a hexapod's plan.
    pub fn refuse_for_hexapod(&self) -> anyhow::Result<()> {
        anyhow::ensure!(
            self.measurements.is_none()
                && self.group.is_none()
                && self.grid.is_none()
                && !self.measured_positions,
            "--measurements, --group, --grid and --measured-positions apply to a mechanism's plan (a delta, a cable robot), not a hexapod's"
        );
        Ok(())
    }
}

/// What `parcal plan` asks of a mechanism.
pub struct Request<'a> {
    /// The dataset directory (its machine.json).
    pub dir: &'a Path,
    /// The file to fill in.
    pub out: &'a Path,
    /// A calibration to start from.
    pub after: Option<&'a Path>,
    /// The mechanism's name.
    pub mechanism: &'a str,
    /// Its options.
    pub options: &'a MechanismArgs,
}

/// Plans, writes the files and prints the summary.
pub fn run(request: &Request) -> anyhow::Result<()> {
    let options = request.options;
    let Some(count) = options.measurements else {
        anyhow::bail!(
            "--measurements is needed for a {}'s plan",
            request.mechanism
        );
    };
    let mut inputs = crate::outputs::dataset_inputs(request.dir);
    inputs.extend(request.after.map(Path::to_path_buf));
    let out = request.out.to_path_buf();
    crate::outputs::check(&inputs, &[out.clone(), summary_path(&out)])?;
    let machine_file = request.dir.join(MACHINE_FILE);
    let machine = MechanismMachine::read(&machine_file)?;
    let noise = machine.noise;
    let dataset = MechanismDataset {
        machine,
        ..MechanismDataset::default()
    };
    let data = MechanismData::from_dataset(&dataset)
        .map_err(|error| anyhow::anyhow!("{}: {error}", machine_file.display()))?;
    let mechanism = data.mechanism.as_ref();
    let start = match request.after {
        Some(path) => {
            let record = MechanismCalibrationRecord::read(path)?;
            anyhow::ensure!(
                record.accepted,
                "{}: the calibration was rejected ({}); plan after an accepted one",
                path.display(),
                record.reasons.join("; ")
            );
            let start = Start::from_record(&record, mechanism)
                .map_err(|error| anyhow::anyhow!("{}: {error}", path.display()))?;
            Some(start)
        }
        None => None,
    };
    let n = mechanism.parameters().len();
    let params: Vec<f64> = match &start {
        Some(start) => start.values[..n].to_vec(),
        None => data.priors.iter().map(|p| p.mean).collect(),
    };
    anyhow::ensure!(
        !options.measured_positions || mechanism.name() == "cable robot",
        "--measured-positions applies to a cable robot's samples"
    );
    let candidates = grid_candidates(
        mechanism,
        &params,
        options.grid.unwrap_or(DEFAULT_GRID),
        options.measured_positions,
    )?;
    let group = options
        .group
        .clone()
        .unwrap_or_else(|| default_group(mechanism).to_string());
    let plan = plan_mechanism(&PlanRequest {
        data: &data,
        noise,
        start,
        candidates: &candidates,
        group: &group,
        count,
    })
    .map_err(|error| anyhow::anyhow!("{}: {error}", request.dir.display()))?;
    write_mechanism_plan(&out, &plan, mechanism.actuators().len())?;
    print_summary(&plan, &out, &mut std::io::stdout().lock())?;
    Ok(())
}

/// The plan on stdout: where it went, the measurements, each unknown's
/// sigma before and after, and what stays at the prior.
fn print_summary(plan: &MechanismPlan, out: &Path, to: &mut impl Write) -> std::io::Result<()> {
    writeln!(
        to,
        "plan written to {} and {}",
        out.display(),
        summary_path(out).display()
    )?;
    let start = if plan.from_calibration {
        "the calibration"
    } else {
        "the prior alone"
    };
    writeln!(
        to,
        "{} measurements from {} feasible candidates, from {start}: trace of the {} group's covariance {:.6e} -> {:.6e}",
        plan.picks.len(),
        plan.feasible,
        plan.group,
        plan.trace_before,
        plan.trace_after()
    )?;
    for (k, (candidate, trace)) in plan.picks.iter().enumerate() {
        let [x, y, z] = candidate.position(plan.trigger_height);
        writeln!(
            to,
            "  {:>3}  {:<13} at ({x:.1}, {y:.1}, {z:.1})  trace after {trace:.6e}",
            k + 1,
            candidate.kind()
        )?;
    }
    writeln!(
        to,
        "{:<16} {:<5} {:>12} {:>12} {:>12}",
        "parameter", "unit", "prior sigma", "sigma before", "sigma after"
    )?;
    for p in &plan.parameters {
        let prior = p.prior_sigma.map_or("-".to_string(), |s| format!("{s:.4}"));
        writeln!(
            to,
            "{:<16} {:<5} {prior:>12} {:>12.4} {:>12.4}",
            p.name, p.unit, p.before, p.after
        )?;
    }
    for statement in &plan.statements {
        writeln!(to, "{statement}")?;
    }
    Ok(())
}
