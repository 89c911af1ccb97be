//! `parcal plan`: which ball touches to measure (docs/design.md).

use std::io::Write;
use std::path::PathBuf;

use anyhow::Context;
use parcal_dataset::{ARTEFACTS_FILE, Artefacts, MACHINE_FILE, Machine};
use parcal_design::plan_file::{summary_path, write_plan};
use parcal_design::{Criterion, CriterionValues, PlanOptions, plan, plan_next};

use crate::progress::Progress;

#[derive(clap::Args)]
pub struct Args {
    /// Directory holding machine.json (with its "stroke") and artefacts.json.
    dir: PathBuf,
    /// The budget: number of touches.
    #[arg(long)]
    contacts: usize,
    /// Largest |roll|, |pitch|, |yaw| of the platform, degrees.
    #[arg(long)]
    tilt: f64,
    /// plan.csv to write (plan.json is written beside it).
    #[arg(long)]
    out: PathBuf,
    /// What the plan minimises: the mean registered tip variance over the
    /// accuracy map, D- or A-optimality of the 33 parameters, or the worst
    /// map point (G).
    #[arg(long, value_enum, default_value_t = CriterionArg::Registered)]
    criterion: CriterionArg,
    /// Approximate number of candidate touches before the feasibility checks.
    #[arg(long, default_value_t = 20_000)]
    pool: usize,
    /// Seed of the restarts.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// At most this many touches per ball.
    #[arg(long)]
    per_ball: Option<usize>,
    /// Runs from different random seeds (the best is kept).
    #[arg(long, default_value_t = 1)]
    restarts: usize,
    /// Sequential mode: the next touches after the data of this
    /// calibration.json (its estimate and posterior replace the design and
    /// the prior).
    #[arg(long, value_name = "CALIBRATION_JSON")]
    after: Option<PathBuf>,
    /// Largest angle between the approach direction and the stylus axis,
    /// degrees: the shaft clears the ball within it.
    #[arg(long, default_value_t = parcal_design::pool::MAX_APPROACH_DEGREES)]
    max_approach: f64,
}

/// `--criterion`.
#[derive(Clone, Copy, clap::ValueEnum)]
enum CriterionArg {
    Registered,
    D,
    A,
    G,
}

pub fn run(args: &Args) -> anyhow::Result<()> {
    anyhow::ensure!(
        args.tilt.is_finite() && (0.0..90.0).contains(&args.tilt),
        "--tilt must be in [0, 90) degrees, got {}",
        args.tilt
    );
    let machine = Machine::read(&args.dir.join(MACHINE_FILE))?;
    let artefacts = Artefacts::read(&args.dir.join(ARTEFACTS_FILE))?;
    let options = PlanOptions {
        criterion: match args.criterion {
            CriterionArg::Registered => Criterion::Registered,
            CriterionArg::D => Criterion::D,
            CriterionArg::A => Criterion::A,
            CriterionArg::G => Criterion::G,
        },
        pool: args.pool,
        seed: args.seed,
        per_ball: args.per_ball,
        restarts: args.restarts,
        max_approach_degrees: args.max_approach,
        ..PlanOptions::new(args.contacts, args.tilt)
    };
    let progress = Progress::spinner();
    let mut report = |line: &str| progress.line(&format!("  {line}"));
    let planned = match &args.after {
        None => plan(&machine, &artefacts, &options, &mut report),
        Some(path) => {
            let calibration = super::read_calibration(path, false)?;
            plan_next(&machine, &artefacts, &calibration, &options, &mut report)
        }
    }
    .context("planning failed")?;
    progress.finish();
    write_plan(&args.out, &planned, &artefacts, &options)?;
    let mut stdout = std::io::stdout().lock();
    writeln!(
        stdout,
        "plan written to {} and {}",
        args.out.display(),
        summary_path(&args.out).display()
    )?;
    writeln!(
        stdout,
        "  touches            {} from {} feasible candidates",
        planned.contacts.len(),
        planned.pool_size
    )?;
    let before = if args.after.is_some() {
        "calibration"
    } else {
        "prior"
    };
    for (label, values) in [(before, &planned.prior), ("predicted", &planned.predicted)] {
        write_values(&mut stdout, label, values)?;
    }
    Ok(())
}

/// One line of figures.
fn write_values(stdout: &mut impl Write, label: &str, v: &CriterionValues) -> anyhow::Result<()> {
    writeln!(
        stdout,
        "  {label:<19}registered RMS {:.2} um, max {:.2} um; ln det {:.2}, trace {:.4e} mm^2",
        v.registered_rms_um, v.registered_max_um, v.d, v.a
    )?;
    Ok(())
}
