//! `parcal plan`: which ball touches, or which platform poses for an
//! instrument, to measure (docs/plan.md).

use std::io::Write;
use std::path::{Path, PathBuf};

use anyhow::Context;
use parcal::calibration::RadiusModel;
use parcal::dataset::{ARTEFACTS_FILE, Artefacts, MACHINE_FILE, Machine};
use parcal::hexapod_plan::{self, PosePlanRequest};
use parcal::plan::plan_file::{summary_path, write_plan};
use parcal::plan::tracker::plan_file::write_pose_plan;
use parcal::plan::tracker::plan_poses;
use parcal::plan::{Criterion, CriterionValues, PlanOptions, bounds, plan, plan_next};
use parcal::simulation::mechanism::Spelling;
use parcal::simulation::{TrackerKind, Workspace};

use crate::bounds::Bounded;
use crate::progress::Progress;

#[derive(clap::Args)]
pub struct Args {
    /// Directory holding machine.json (with its "stroke") and artefacts.json;
    /// or machine.json alone: a pose plan for an instrument (--tracker); or
    /// a mechanism's machine.json (a linear delta, a cable robot): its
    /// probe heights or encoder samples to measure next.
    dir: PathBuf,
    /// The budget: number of touches.
    #[arg(long, conflicts_with = "poses", value_parser = Bounded(bounds::CONTACTS))]
    contacts: Option<usize>,
    /// Plan platform poses measured by an instrument instead of ball
    /// touches: body poses (motion capture), tool points (laser tracker) or
    /// both (the default when DIR has no artefacts.json: poses).
    #[arg(long, value_enum)]
    tracker: Option<super::simulate::Kind>,
    /// The budget of a pose plan: number of poses.
    #[arg(long, value_parser = Bounded(bounds::POSES))]
    poses: Option<usize>,
    /// A pose plan over this many measuring sessions (re-homing, a
    /// re-placed instrument), the poses shared evenly: each session's
    /// instrument frame, and its leg offsets and body origin and turn when
    /// machine.json's session_model gives their sigmas, are estimated with
    /// the machine (plan.csv's session column).
    #[arg(long, default_value_t = 1, value_parser = Bounded(bounds::SESSIONS))]
    sessions: usize,
    /// Where a pose plan's platform origin may go: `|x|, |y| <= HALF_WIDTH`,
    /// `Z_MIN <= z <= Z_MAX`, design base frame, mm.
    #[arg(long, value_name = "HALF_WIDTH,Z_MIN,Z_MAX", value_parser = parse_workspace)]
    workspace: Option<Workspace>,
    /// Largest |roll|, |pitch|, |yaw| of the platform, degrees (a
    /// hexapod's plans).
    #[arg(long)]
    tilt: Option<f64>,
    /// plan.csv to write (plan.json is written beside it); for a
    /// mechanism, the probes.csv or points.csv to fill in.
    #[arg(long)]
    out: PathBuf,
    /// What the plan minimises: the mean registered tip variance over the
    /// accuracy map, D- or A-optimality of the 33 parameters, or the worst
    /// map point (G).
    #[arg(long, value_enum, default_value_t = CriterionArg::Registered)]
    criterion: CriterionArg,
    /// Approximate number of candidate touches before the feasibility checks.
    #[arg(long, default_value_t = 20_000, value_parser = Bounded(bounds::POOL))]
    pool: usize,
    /// Seed of the restarts.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// At most this many touches per ball.
    #[arg(long, value_parser = Bounded(bounds::PER_BALL))]
    per_ball: Option<usize>,
    /// A budget below 4 touches of every ball touches at least this many
    /// balls (as many as the budget allows); 0 leaves it to the criterion,
    /// which prefers few balls touched often (default: CONTACTS / 8, so
    /// that a small budget still spreads over the artefact).
    #[arg(long, value_parser = Bounded(bounds::MIN_BALLS))]
    min_balls: Option<usize>,
    /// Runs from different random seeds (the best is kept).
    #[arg(long, default_value_t = 1, value_parser = Bounded(bounds::RESTARTS))]
    restarts: usize,
    /// Sequential mode: the next touches after the data of this
    /// calibration.json (its estimate and posterior replace the design and
    /// the prior).
    #[arg(long, value_name = "CALIBRATION_JSON")]
    after: Option<PathBuf>,
    /// Largest angle between the approach direction and the stylus axis,
    /// degrees: the shaft clears the ball within it.
    #[arg(long, default_value_t = parcal::plan::pool::MAX_APPROACH_DEGREES)]
    max_approach: f64,
    /// How the calibration will treat the balls' calibrated radii, as
    /// `parcal calibrate --radius`: each ball's radius an unknown with its
    /// calibration as prior (the default), or its error independent per
    /// contact.
    #[arg(long, value_enum)]
    radius: Option<RadiusModel>,
    /// The mechanism's plan (its options).
    #[command(flatten)]
    mechanism: super::plan_mechanism::MechanismArgs,
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
    if let Some(mechanism) = super::mechanism::declared(&args.dir)? {
        anyhow::ensure!(
            args.contacts.is_none()
                && args.poses.is_none()
                && args.tracker.is_none()
                && args.workspace.is_none()
                && args.tilt.is_none()
                && args.sessions == 1
                && args.per_ball.is_none()
                && args.min_balls.is_none()
                && args.radius.is_none(),
            "--contacts, --poses, --tracker, --sessions, --workspace, --tilt, --per-ball, --min-balls and --radius apply to a hexapod's plans, not a {mechanism}'s"
        );
        return super::plan_mechanism::run(&super::plan_mechanism::Request {
            dir: &args.dir,
            out: &args.out,
            after: args.after.as_deref(),
            mechanism: &mechanism,
            options: &args.mechanism,
        });
    }
    args.mechanism.refuse_for_hexapod()?;
    let tilt = hexapod_plan::tilt(args.tilt, Spelling::Flags).map_err(anyhow::Error::msg)?;
    // plan.csv and plan.json are checked before the work, against every
    // file the plan reads.
    let mut inputs = crate::outputs::dataset_inputs(&args.dir);
    inputs.extend(args.after.iter().cloned());
    crate::outputs::check(&inputs, &[args.out.clone(), summary_path(&args.out)])?;
    let machine = Machine::read(&args.dir.join(MACHINE_FILE))?;
    let artefacts_file = args.dir.join(ARTEFACTS_FILE);
    let tracker = hexapod_plan::planned_tracker(
        args.tracker.map(super::simulate::Kind::tracker_kind),
        artefacts_file.exists(),
    );
    if let Some(kind) = tracker {
        return run_tracker(args, &machine, kind, tilt);
    }
    let contacts = hexapod_plan::touch_contacts(args.contacts, args.sessions, Spelling::Flags)
        .map_err(anyhow::Error::msg)?;
    let artefacts = Artefacts::read(&artefacts_file)?;
    let defaults = PlanOptions::new(contacts, tilt);
    let options = PlanOptions {
        criterion: criterion(args.criterion),
        pool: args.pool,
        seed: args.seed,
        per_ball: args.per_ball,
        min_balls: args
            .min_balls
            .unwrap_or_else(|| parcal::plan::select::default_min_balls(contacts)),
        restarts: args.restarts,
        max_approach_degrees: args.max_approach,
        radius: args.radius.unwrap_or(defaults.radius),
        ..defaults
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
    let before = if args.after.is_some() {
        "calibration"
    } else {
        "prior"
    };
    print_summary(
        &args.out,
        ("touches", planned.contacts.len()),
        planned.pool_size,
        [(before, &planned.prior), ("predicted", &planned.predicted)],
    )?;
    Ok(())
}

/// A pose plan (`--tracker`, or DIR without artefacts.json).
fn run_tracker(args: &Args, machine: &Machine, kind: TrackerKind, tilt: f64) -> anyhow::Result<()> {
    let request = PosePlanRequest {
        poses: args.poses,
        kind,
        workspace: args.workspace,
        tilt_degrees: tilt,
        criterion: criterion(args.criterion),
        sessions: args.sessions,
        touch_options: args.after.is_some()
            || args.per_ball.is_some()
            || args.min_balls.is_some()
            || args.radius.is_some(),
    };
    let options =
        hexapod_plan::pose_plan_options(&request, Spelling::Flags).map_err(anyhow::Error::msg)?;
    let progress = Progress::spinner();
    let mut report = |line: &str| progress.line(&format!("  {line}"));
    let planned = plan_poses(machine, &options, &mut report).context("planning failed")?;
    progress.finish();
    write_pose_plan(&args.out, &planned, &options)?;
    print_summary(
        &args.out,
        ("poses", planned.poses.len()),
        planned.pool_size,
        [("prior", &planned.prior), ("predicted", &planned.predicted)],
    )?;
    Ok(())
}

/// `--criterion`'s meaning.
fn criterion(arg: CriterionArg) -> Criterion {
    match arg {
        CriterionArg::Registered => Criterion::Registered,
        CriterionArg::D => Criterion::D,
        CriterionArg::A => Criterion::A,
        CriterionArg::G => Criterion::G,
    }
}

/// `--workspace HALF_WIDTH,Z_MIN,Z_MAX`.
fn parse_workspace(value: &str) -> Result<Workspace, String> {
    let numbers: Vec<f64> = value
        .split(',')
        .map(|v| v.trim().parse::<f64>().map_err(|e| format!("{v:?}: {e}")))
        .collect::<Result<_, _>>()?;
    hexapod_plan::workspace(&numbers, value, Spelling::Flags)
}

/// The plan's summary on stdout: where it was written, how many `what`
/// were chosen from how many candidates, and the figures before and after.
fn print_summary(
    out: &Path,
    (what, count): (&str, usize),
    pool_size: usize,
    figures: [(&str, &CriterionValues); 2],
) -> anyhow::Result<()> {
    let mut stdout = std::io::stdout().lock();
    writeln!(
        stdout,
        "plan written to {} and {}",
        out.display(),
        summary_path(out).display()
    )?;
    writeln!(
        stdout,
        "  {what:<19}{count} from {pool_size} feasible candidates"
    )?;
    for (label, values) in figures {
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
