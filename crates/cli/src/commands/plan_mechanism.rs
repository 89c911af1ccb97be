//! `parcal plan` on a mechanism dataset (machine.json naming a linear
//! delta or a cable robot): the probe heights or encoder samples to
//! measure next, and a delta's heights measured by hand and part
//! distances, by [`parcal::plan::mechanism`], written as the dataset's own
//! probes.csv, points.csv, heights.csv or distances.csv to fill in, with
//! the predicted sigmas before and after (docs/delta-measurements.md,
//! docs/cable-robots.md).

use std::io::Write;
use std::path::Path;

use parcal::calibration::mechanism::MechanismData;
use parcal::dataset::mechanism::{
    MACHINE_FILE, MechanismCalibrationRecord, MechanismDataset, MechanismMachine,
};
use parcal::plan::bounds;
use parcal::plan::mechanism::plan_file::{stage_paths, write_mechanism_plan};
use parcal::plan::mechanism::workspace::{DEFAULT_GRID, Grid, checked_gauge, plan_candidates};
use parcal::plan::mechanism::{
    Counts, MechanismPlan, PlanRequest, PlannedParameter, Start, default_group,
    linearisation_point, plan_mechanism, with_sigmas,
};
use parcal::plan::plan_file::summary_path;

use parcal::kinematics::delta::GAUGE_BLOCK;

use crate::bounds::Bounded;

/// The options of a mechanism's plan.
#[derive(clap::Args)]
pub struct MechanismArgs {
    /// A mechanism's plan: how many measurements (probe heights, encoder
    /// samples) to plan.
    #[arg(long, value_parser = Bounded(bounds::MEASUREMENTS))]
    measurements: Option<usize>,
    /// A delta's plan: how many heights measured by hand (the nozzle sent
    /// --gauge above a point of the grid, the height under it measured) to
    /// plan after the measurements; written to OUT itself without
    /// --measurements, else beside it (next.csv -> next-heights.csv).
    #[arg(long, value_parser = Bounded(bounds::MEASUREMENTS))]
    heights: Option<usize>,
    /// A delta's plan: the heights measured by hand, 1 sigma, mm (default:
    /// machine.json's noise.height; needed when the dataset has no such
    /// heights yet).
    #[arg(long, value_name = "MM", requires = "heights")]
    height_sigma: Option<f64>,
    /// A delta's plan: how high the nozzle is sent for a height measured
    /// by hand, mm (the gauge block's height; default 5).
    #[arg(long, value_name = "MM", requires = "heights")]
    gauge: Option<f64>,
    /// A delta's plan: how many part distances (between two points of the
    /// grid on the first layer, measured on a printed part) to plan after
    /// the measurements and heights; written to OUT itself when alone,
    /// else beside it (next.csv -> next-distances.csv).
    #[arg(long, value_parser = Bounded(bounds::MEASUREMENTS))]
    distances: Option<usize>,
    /// A delta's plan: the part distances' noise, 1 sigma, mm (default:
    /// machine.json's noise.distance; needed when the dataset has no part
    /// distances yet).
    #[arg(long, value_name = "MM", requires = "distances")]
    distance_sigma: Option<f64>,
    /// A mechanism's plan: the parameter group whose predicted covariance's
    /// trace is minimised (default: a delta's "diagonal rods", or its
    /// "trigger height" for --heights alone after a calibration; a cable
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
                && self.heights.is_none()
                && self.distances.is_none()
                && self.group.is_none()
                && self.grid.is_none()
                && !self.measured_positions,
            "--measurements, --heights, --distances, --group, --grid and --measured-positions apply to a mechanism's plan (a delta, a cable robot), not a hexapod's"
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
    let counts = Counts {
        measurements: options.measurements.unwrap_or(0),
        heights: options.heights.unwrap_or(0),
        distances: options.distances.unwrap_or(0),
    };
    anyhow::ensure!(
        counts.total() > 0,
        "--measurements is needed for a {}'s plan (or a delta's --heights or --distances)",
        request.mechanism
    );
    let mut inputs = crate::outputs::dataset_inputs(request.dir);
    inputs.extend(request.after.map(Path::to_path_buf));
    let out = request.out.to_path_buf();
    let files: Vec<_> = stage_paths(&out, counts)
        .into_iter()
        .map(|(_, file)| file)
        .collect();
    let mut outputs = files.clone();
    outputs.push(summary_path(&out));
    crate::outputs::check(&inputs, &outputs)?;
    let machine_file = request.dir.join(MACHINE_FILE);
    let machine = MechanismMachine::read(&machine_file)?;
    let noise = with_sigmas(
        machine.noise,
        [options.height_sigma, options.distance_sigma],
        ["--height-sigma", "--distance-sigma"],
    )?;
    let print_radius = machine.print_radius;
    let gauge = checked_gauge(options.gauge.unwrap_or(GAUGE_BLOCK), "--gauge")?;
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
    let params = linearisation_point(&data, start.as_ref());
    anyhow::ensure!(
        !options.measured_positions || mechanism.name() == "cable robot",
        "--measured-positions applies to a cable robot's samples"
    );
    let grid = Grid {
        per_axis: options.grid.unwrap_or(DEFAULT_GRID),
        print_radius,
        gauge,
    };
    let candidates = plan_candidates(mechanism, &params, grid, options.measured_positions, counts)?;
    let group = options
        .group
        .clone()
        .unwrap_or_else(|| default_group(mechanism, counts, start.as_ref()).to_string());
    let plan = plan_mechanism(&PlanRequest {
        data: &data,
        noise,
        start,
        candidates: &candidates,
        group: &group,
        counts,
    })
    .map_err(|error| anyhow::anyhow!("{}: {error}", request.dir.display()))?;
    write_mechanism_plan(&out, &plan, mechanism.actuators().len())?;
    print_summary(&plan, &files, &out, &mut std::io::stdout().lock())?;
    Ok(())
}

/// The plan on stdout: where it went (`files`, then the summary beside
/// `out`), the measurements with the group's RMS sigma after each, each
/// unknown's sigma before and after, and what stays at the prior.
fn print_summary(
    plan: &MechanismPlan,
    files: &[std::path::PathBuf],
    out: &Path,
    to: &mut impl Write,
) -> std::io::Result<()> {
    let files: Vec<String> = files.iter().map(|f| f.display().to_string()).collect();
    writeln!(
        to,
        "plan written to {} and {}",
        files.join(", "),
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
    let group: Vec<&PlannedParameter> = plan
        .parameters
        .iter()
        .filter(|p| p.group == plan.group)
        .collect();
    let unit = group.first().map_or("", |p| p.unit.as_str());
    let rms = |trace: f64| (trace.max(0.0) / group.len().max(1) as f64).sqrt();
    let mut before = plan.trace_before;
    for (k, (candidate, trace)) in plan.picks.iter().enumerate() {
        let at: Vec<String> = candidate
            .positions(plan.trigger_height)
            .iter()
            .map(|[x, y, z]| format!("({x:.1}, {y:.1}, {z:.1})"))
            .collect();
        writeln!(
            to,
            "  {:>3}  {:<13} at {:<30} trace after {trace:.6e}; {} RMS sigma {:.4} -> {:.4} {unit}",
            k + 1,
            candidate.kind(),
            at.join(" to "),
            plan.group,
            rms(before),
            rms(*trace)
        )?;
        before = *trace;
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
