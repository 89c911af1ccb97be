//! `parcal simulate`: write a simulated campaign as a dataset: ball
//! touches (the paper scenario and scaled variants) or, with `--tracker`,
//! instrument measurements in sessions (with `--touches`, and the paper's
//! touches of the same machine).

use std::io::Write;
use std::path::PathBuf;
use std::str::FromStr;

use anyhow::Context;
use parcal::dataset::{Dataset, DatasetError, WriteOptions};
use parcal::hexapod_simulation::{
    self, HexapodOptions, HexapodScenario, PlanSource, hexapod_scenario,
};
use parcal::simulation::mechanism::{self, MechanismOptions, Spelling};
use parcal::simulation::{
    COUNT, Plate, PlatePairs, Readings, Scenario, Simulation, TrackerKind, TrackerScenario,
};

use super::{SNAPSHOT_FILE, simulate_mechanism};
use crate::bounds::Bounded;

#[derive(clap::Args)]
pub struct Args {
    /// Seed of the random streams: the same seed gives byte-identical files.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Output directory (created if needed), written as a whole: it must
    /// not exist or be empty, unless --force.
    #[arg(long)]
    out: PathBuf,
    /// Replace an existing dataset at --out, as a whole (its other files,
    /// e.g. a calibration of the old data, go with it).
    #[arg(long)]
    force: bool,
    /// Number of balls on a regular grid filling x, y in [-80, 80], z in [340, 460]
    /// (default: the paper's 27 balls at x, y in {-60, 0, 60}, z in {360, 400, 440}).
    /// With --mechanism delta: calibrated balls (12.7 mm radius, calibrated
    /// to 1 µm) on a ring on the bed, touched by the probe (default none).
    #[arg(long, conflicts_with = "tracker", value_parser = Bounded(COUNT))]
    balls: Option<usize>,
    /// Contacts per ball (default 7; with --mechanism delta: touches per
    /// ball, on its upper cap).
    #[arg(long, conflicts_with = "tracker", value_parser = Bounded(COUNT))]
    points_per_ball: Option<usize>,
    /// What the touches' actuators read: mm (scale 1, known), or motor
    /// revolutions at the scales of --machine jugglebot's instrument
    /// campaign (design about 71 mm/rev, true scales 1 % off, unknown with
    /// a 2 % prior; the same noise and stroke in revolutions).
    #[arg(long, value_enum, default_value_t = ReadingUnit::Mm, conflicts_with = "tracker")]
    readings: ReadingUnit,
    /// Largest |yaw|, |pitch|, |roll| of the platform at a contact or a
    /// tracked pose, degrees.
    #[arg(long, default_value_t = hexapod_simulation::DEFAULT_TILT)]
    tilt: f64,
    /// Simulate instrument measurements instead of ball touches: platform body
    /// poses (poses.csv), tool points (points.csv) or both, in sessions, each
    /// in its own instrument frame; readings with true actuator scales.
    #[arg(long, value_enum)]
    tracker: Option<Kind>,
    /// The tracked machine: the paper's (readings in mm, a laser tracker) or
    /// one in the spirit of Jugglebot (readings in motor revolutions, motion
    /// capture, legs re-homed by 2 mm between sessions).
    #[arg(long, value_enum, default_value_t = TrackedMachine::Paper, requires = "tracker")]
    machine: TrackedMachine,
    /// Also the paper's ball touches (27 balls, 7 contacts each) of the same
    /// true machine, in the same dataset: one calibration takes both
    /// (--machine paper; the actuators read mm, scales 1 and known).
    #[arg(long, requires = "tracker")]
    touches: bool,
    /// Number of measuring sessions (default: 3).
    #[arg(long, requires = "tracker", value_parser = Bounded(parcal::dataset::bounds::SESSIONS))]
    sessions: Option<usize>,
    /// Rows of each file per session (default: 50 for the paper's machine,
    /// 108 for Jugglebot's).
    #[arg(long, requires = "tracker", value_parser = Bounded(COUNT))]
    rows: Option<usize>,
    /// Re-homing between sessions: each leg's zero offset in sessions 2, 3,
    /// ... is drawn with this sigma, mm, and machine.json's
    /// session_model.leg_offset_sigma says so (0: no re-homing).
    #[arg(long, value_name = "MM", requires = "tracker")]
    rehome: Option<f64>,
    /// The instrument's position noise, 1 sigma per axis, mm (default: 0.01
    /// for the paper's machine, 0.3 for Jugglebot's).
    #[arg(long, value_name = "MM", requires = "tracker")]
    position_sigma: Option<f64>,
    /// The instrument's orientation noise, 1 sigma per axis, rad (default:
    /// 1e-4 for the paper's machine, 1e-3 for Jugglebot's).
    #[arg(long, value_name = "RAD", requires = "tracker")]
    orientation_sigma: Option<f64>,
    /// Also write a calibrated ball plate as the distances of artefacts.json
    /// (with --mechanism delta and --balls: as ball_distances.csv):
    /// `all` pairs of balls (n (n - 1) / 2 distances for n balls), or a number
    /// of distinct pairs drawn at random.
    /// Each distance is the true one plus an error of --plate-sigma; the
    /// contacts (the delta's other files) are the same as without a plate.
    #[arg(long, value_name = "all|PAIRS", value_parser = PlatePairs::from_str, conflicts_with = "tracker")]
    plate: Option<PlatePairs>,
    /// Error of each calibrated distance of the plate (1 sigma), micrometres.
    #[arg(long, value_name = "UM", default_value_t = 1.0, requires = "plate")]
    plate_sigma: f64,
    /// Simulate exactly the touches of a plan.csv (`parcal plan`) instead of
    /// random ones: the true contact point is the true centre + r u, the
    /// platform orientation as planned (--points-per-ball and --tilt are
    /// then not used for the touches; balls the plan leaves untouched are
    /// left out of the dataset). With --tracker, a pose plan
    /// (`parcal plan --tracker`): each of its sessions (`session` column)
    /// measures the true machine at its planned readings; a plan of one
    /// session is measured in every session of --sessions (--rows and
    /// --tilt are then not used).
    #[arg(long, value_name = "PLAN_CSV")]
    plan: Option<PathBuf>,
    /// Draw machine.json's design about the true machine by the design
    /// tolerance (each joint coordinate, the tool and each leg length the
    /// truth's plus a normal deviate of the prior sigma, from --seed), so
    /// that the truth is a draw of the prior the design states, as the
    /// calibration's statistical tests assume. Default: the paper's design
    /// and its one truth (table 2).
    #[arg(long, conflicts_with = "tracker")]
    design_drawn: bool,
    /// Also write a binary snapshot of the dataset (postcard) to OUT/dataset.bin,
    /// which loads much faster than the text files.
    #[arg(long)]
    binary: bool,
    /// Run commands instead of simulating a campaign (--out is then a file).
    #[command(flatten)]
    execute: super::execute::RunArgs,
    /// Simulate a mechanism other than the hexapod: `linear delta` (or
    /// `delta`): probe heights and part distances; `cable robot` (or
    /// `cable`): the Hangprinter's encoder samples with a few measured
    /// positions; with its truth (docs/delta.md, docs/cable-robots.md).
    /// With --truth DATASET, the true machine of that simulated dataset is
    /// measured again (held-out data for `parcal validate`).
    #[arg(long, value_name = "NAME", conflicts_with_all = ["tracker", "plan", "design_drawn", "binary"])]
    mechanism: Option<String>,
    /// Delta: probe rings over the printable disc and its centre (default 3).
    #[arg(long, requires = "mechanism", value_parser = Bounded(mechanism::RINGS))]
    probe_rings: Option<usize>,
    /// Delta: probe points on each ring (default 8).
    #[arg(long, requires = "mechanism", value_parser = Bounded(mechanism::PER_RING))]
    probes_per_ring: Option<usize>,
    /// Delta: distances measured across a printed disc on the first layer
    /// (default 0).
    #[arg(long, requires = "mechanism", value_parser = Bounded(mechanism::DISTANCES))]
    part_distances: Option<usize>,
    /// Delta: the probe's noise, 1 sigma, mm (default 0.01).
    #[arg(long, value_name = "MM", requires = "mechanism")]
    probe_sigma: Option<f64>,
    /// Delta: the part distances' noise, 1 sigma, mm (default 0.01).
    #[arg(long, value_name = "MM", requires = "mechanism")]
    distance_sigma: Option<f64>,
    /// Delta: heights of the nozzle measured by hand with a 5 mm gauge
    /// block, at the centre and on a ring (heights.csv; default 0).
    #[arg(long, requires = "mechanism", value_parser = Bounded(mechanism::MANUAL_HEIGHTS))]
    manual_heights: Option<usize>,
    /// Delta: the heights' noise, 1 sigma, mm (default 0.05).
    #[arg(long, value_name = "MM", requires = "mechanism")]
    height_sigma: Option<f64>,
    /// Delta: trackers placed about the printer, each measuring the tool
    /// point in its own frame (tracker_points.csv; default none).
    #[arg(long, requires = "mechanism", value_parser = Bounded(mechanism::TRACKERS))]
    trackers: Option<usize>,
    /// Delta: points each tracker measures (default 12).
    #[arg(long, requires = "mechanism", value_parser = Bounded(mechanism::POINTS_PER_TRACKER))]
    points_per_tracker: Option<usize>,
    /// Delta: a tracker's noise, 1 sigma per coordinate, mm (default 0.01).
    #[arg(long, value_name = "MM", requires = "mechanism")]
    tracker_sigma: Option<f64>,
    /// Cable robot: samples (encoder readings), the encoder zero's included
    /// (default 44, the Hangprinter data's).
    #[arg(long, requires = "mechanism", value_parser = Bounded(mechanism::SAMPLES))]
    samples: Option<usize>,
    /// Cable robot: samples whose position is measured, the encoder zero
    /// and the rest on the bed (default 9).
    #[arg(long, requires = "mechanism", value_parser = Bounded(mechanism::SAMPLES))]
    known_positions: Option<usize>,
    /// Cable robot: the encoders' noise, 1 sigma, degrees (default 1).
    #[arg(long, value_name = "DEG", requires = "mechanism")]
    reading_sigma: Option<f64>,
    /// Cable robot: a measured position's noise, 1 sigma per coordinate,
    /// mm (default 1).
    #[arg(long, value_name = "MM", requires = "mechanism")]
    measured_sigma: Option<f64>,
    /// Cable robot: the lines' loads at the encoder zero, N, one per line
    /// (A,B,C,D): the lines are elastic, machine.json states them, their
    /// true compliances are a draw of their prior (50 +- 50 um/m/N) and
    /// every other sample is measured under loads drawn from
    /// --load-range (default: rigid lines).
    #[arg(
        long,
        value_name = "N,N,N,N",
        value_delimiter = ',',
        requires = "mechanism"
    )]
    zero_loads: Option<Vec<f64>>,
    /// Cable robot, elastic lines: each line's compliance by its index
    /// among the compliances, as machine.json's "compliance_of_line"
    /// (default 0,0,0,0: one shared).
    #[arg(
        long,
        value_name = "K,K,K,K",
        value_delimiter = ',',
        requires = "mechanism"
    )]
    compliance_of_line: Option<Vec<usize>>,
    /// Cable robot, elastic lines: the range each line's load is drawn
    /// from at every sample but the encoder zero, N (default 5,35).
    #[arg(long, value_name = "LOW,HIGH", requires = "mechanism", value_parser = load_range)]
    load_range: Option<[f64; 2]>,
}

/// `--tracker` (also `parcal plan`'s).
#[derive(Clone, Copy, clap::ValueEnum)]
pub(crate) enum Kind {
    Poses,
    Points,
    Both,
}

impl Kind {
    /// What the instrument measures.
    pub(crate) fn tracker_kind(self) -> TrackerKind {
        match self {
            Kind::Poses => TrackerKind::Poses,
            Kind::Points => TrackerKind::Points,
            Kind::Both => TrackerKind::Both,
        }
    }
}

/// `--readings`.
#[derive(Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
enum ReadingUnit {
    Mm,
    Rev,
}

/// `--machine`.
#[derive(Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
enum TrackedMachine {
    Paper,
    Jugglebot,
}

pub fn run(args: &Args) -> anyhow::Result<()> {
    if args.execute.requested() {
        return super::execute::run(&args.execute, &args.out);
    }
    if let Some(mechanism) = &args.mechanism {
        return simulate_mechanism::run(&simulate_mechanism::Request {
            mechanism: mechanism.clone(),
            seed: args.seed,
            out: args.out.clone(),
            force: args.force,
            truth: args.execute.truth().map(PathBuf::from),
            options: MechanismOptions {
                probe_rings: args.probe_rings,
                probes_per_ring: args.probes_per_ring,
                part_distances: args.part_distances,
                probe_sigma: args.probe_sigma,
                distance_sigma: args.distance_sigma,
                manual_heights: args.manual_heights,
                height_sigma: args.height_sigma,
                balls: args.balls,
                points_per_ball: args.points_per_ball,
                plate: plate(args)?,
                trackers: args.trackers,
                points_per_tracker: args.points_per_tracker,
                tracker_sigma: args.tracker_sigma,
                samples: args.samples,
                known_positions: args.known_positions,
                reading_sigma: args.reading_sigma,
                measured_sigma: args.measured_sigma,
                zero_loads: args.zero_loads.clone(),
                compliance_of_line: args.compliance_of_line.clone(),
                load_range: args.load_range,
            },
        });
    }
    anyhow::ensure!(
        args.execute.truth().is_none(),
        "--truth needs --run (commands run on a hexapod's truth) or --mechanism (a mechanism's truth measured again)"
    );
    hexapod_simulation::tilt(args.tilt, Spelling::Flags).map_err(anyhow::Error::msg)?;
    Dataset::check_target(&args.out, args.force).map_err(|error| {
        let exists = matches!(&error, DatasetError::Io { source, .. }
            if source.kind() == std::io::ErrorKind::AlreadyExists);
        let hint = if exists {
            "; give --force to replace it"
        } else {
            ""
        };
        anyhow::anyhow!("{error}{hint}")
    })?;
    let options = HexapodOptions {
        balls: args.balls,
        points_per_ball: args.points_per_ball,
        readings: Some(match args.readings {
            ReadingUnit::Mm => hexapod_simulation::ReadingUnit::Mm,
            ReadingUnit::Rev => hexapod_simulation::ReadingUnit::Rev,
        }),
        tilt: Some(args.tilt),
        tracker: args.tracker.map(Kind::tracker_kind),
        machine: Some(match args.machine {
            TrackedMachine::Paper => hexapod_simulation::TrackedMachine::Paper,
            TrackedMachine::Jugglebot => hexapod_simulation::TrackedMachine::Jugglebot,
        }),
        touches: args.touches,
        sessions: args.sessions,
        rows: args.rows,
        rehome: args.rehome,
        position_sigma: args.position_sigma,
        orientation_sigma: args.orientation_sigma,
        plate: plate(args)?,
        plan: args.plan.clone().map(PlanSource::File),
        design_drawn: args.design_drawn,
    };
    let scenario = hexapod_scenario(&options, args.seed, Spelling::Flags)?;
    let simulation = scenario.simulate(args.seed).context("simulation failed")?;
    write_dataset(args, &simulation)?;
    match &scenario {
        HexapodScenario::Touches(touches) => summarise_touches(args, touches, &simulation),
        HexapodScenario::Tracker { tracker, touches } => {
            summarise_tracker(tracker, touches.is_some(), &simulation)
        }
    }
}

/// The ball plate of `--plate` and `--plate-sigma` (micrometres), if
/// asked for.
fn plate(args: &Args) -> anyhow::Result<Option<Plate>> {
    anyhow::ensure!(
        args.plate_sigma.is_finite() && args.plate_sigma > 0.0,
        "--plate-sigma must be positive, got {}",
        args.plate_sigma
    );
    Ok(args.plate.map(|pairs| Plate {
        pairs,
        sigma: args.plate_sigma * 1e-3,
    }))
}

/// `--load-range`: two numbers, `LOW,HIGH` (N); the simulation checks
/// their values.
fn load_range(text: &str) -> Result<[f64; 2], String> {
    super::numbers(text, "two loads LOW,HIGH (N)")
}

/// The summary of a simulated campaign of ball touches.
fn summarise_touches(
    args: &Args,
    scenario: &Scenario,
    simulation: &Simulation,
) -> anyhow::Result<()> {
    let s = &simulation.summary;
    let mut stdout = std::io::stdout().lock();
    writeln!(stdout, "  balls              {}", s.balls)?;
    match &args.plan {
        Some(path) => writeln!(
            stdout,
            "  contacts           {} (planned: {})",
            s.contacts,
            path.display()
        )?,
        None => writeln!(
            stdout,
            "  contacts           {} ({} per ball)",
            s.contacts, scenario.points_per_ball
        )?,
    }
    if args.plate.is_some() {
        writeln!(
            stdout,
            "  ball distances     {} (sigma {} um)",
            simulation.dataset.artefacts.distances.len(),
            args.plate_sigma
        )?;
    }
    if !scenario.readings.is_default() {
        write_readings(&mut stdout, &scenario.readings)?;
    }
    write_ranges(&mut stdout, simulation)?;
    writeln!(
        stdout,
        "  FK check           every contact's tip back on its ball, worst {:.2} sigma of the noise",
        s.worst_check
    )?;
    Ok(())
}

/// The summary of a simulated campaign of instrument measurements, with
/// the paper's touches of the same machine if `touches`.
fn summarise_tracker(
    scenario: &TrackerScenario,
    touches: bool,
    simulation: &Simulation,
) -> anyhow::Result<()> {
    let s = &simulation.summary;
    let mut stdout = std::io::stdout().lock();
    if touches {
        writeln!(stdout, "  balls              {}", s.balls)?;
        writeln!(stdout, "  contacts           {}", s.contacts)?;
    }
    writeln!(stdout, "  sessions           {}", s.sessions)?;
    for (name, rows) in [("poses", s.poses), ("points", s.points)] {
        if rows > 0 {
            writeln!(
                stdout,
                "  {name:<19}{rows} ({} per session)",
                scenario.rows_per_session
            )?;
        }
    }
    write_readings(&mut stdout, &Readings::of(scenario))?;
    write!(
        stdout,
        "  noise              actuators {} {}, position {} mm",
        scenario.actuator_sigma, scenario.unit, scenario.position_sigma,
    )?;
    if scenario.kind.poses() {
        write!(stdout, ", orientation {} rad", scenario.orientation_sigma)?;
    }
    writeln!(stdout)?;
    if let Some(sigma) = scenario.session_model.leg_offset_sigma {
        writeln!(
            stdout,
            "  re-homing          leg offsets of sigma {sigma} mm"
        )?;
    }
    write_ranges(&mut stdout, simulation)?;
    Ok(())
}

/// Writes the dataset (and the snapshot with `--binary`), then the summary's
/// first lines.
fn write_dataset(args: &Args, simulation: &Simulation) -> anyhow::Result<()> {
    let options = WriteOptions {
        replace: args.force,
        snapshot: args.binary.then(|| SNAPSHOT_FILE.to_string()),
    };
    simulation
        .dataset
        .write_with(&args.out, &options)
        .with_context(|| format!("cannot write the dataset to {}", args.out.display()))?;
    let mut stdout = std::io::stdout().lock();
    writeln!(
        stdout,
        "simulated dataset written to {}",
        args.out.display()
    )?;
    writeln!(stdout, "  seed               {}", args.seed)?;
    Ok(())
}

/// The summary's line on the readings: their unit and how far the true
/// scales are from the design's.
fn write_readings(stdout: &mut impl Write, readings: &Readings) -> anyhow::Result<()> {
    writeln!(
        stdout,
        "  readings           unit {}, true scales within {:.2e} of the design",
        readings.unit,
        (0..6)
            .map(|i| (readings.true_scale[i] / readings.design_scale[i] - 1.0).abs())
            .fold(0.0, f64::max)
    )?;
    Ok(())
}

/// The summary's leg length and tilt ranges.
fn write_ranges(stdout: &mut impl Write, simulation: &Simulation) -> anyhow::Result<()> {
    let s = &simulation.summary;
    writeln!(
        stdout,
        "  leg lengths        {:.3} .. {:.3} mm",
        s.leg_length_range.0, s.leg_length_range.1
    )?;
    writeln!(
        stdout,
        "  platform tilt      {:.2} .. {:.2} deg",
        s.tilt_range.0.to_degrees(),
        s.tilt_range.1.to_degrees()
    )?;
    Ok(())
}
