//! `parcal import`: a printer's firmware configuration and probe log (or
//! the probes its firmware saved with its configuration, Klipper's) as a
//! mechanism dataset (docs/delta.md): the configured parameters the
//! firmware ran with, also the prior's means, the builder's tolerances as
//! the prior's sigmas, and each probe as a probe height at the commanded
//! position where it triggered, `(x, y, z + trigger height)`, the trigger
//! height an unknown with its own prior.

use std::path::PathBuf;

use parcal::dataset::mechanism::{MechanismDataset, MechanismMachine, Noise, ValuePrior};
use parcal::firmware::klipper::{DeltaCalibrateResults, read_printer};
use parcal::firmware::probes::{ProbePoint, read_distances, read_probes};
use parcal::firmware::rrf::read_config;
use parcal::kinematics::delta::{DeltaParams, Limits, LinearDelta, RODS, Tolerances};
use parcal::kinematics::mechanism::Mechanism;

/// The largest tolerance or standard deviation accepted (mm, degrees or
/// percent): beyond it a prior says nothing.
const MAX_SIGMA: f64 = 100.0;

#[derive(clap::Args)]
pub struct Args {
    #[command(subcommand)]
    firmware: Firmware,
}

#[derive(clap::Subcommand)]
enum Firmware {
    /// RepRapFirmware: config.g's M665, M666 and G31 lines, and the
    /// heights G30 S-1 reported.
    Reprapfirmware(FirmwareArgs),
    /// Klipper: printer.cfg's delta settings (the SAVE_CONFIG block
    /// included) and the probes and part distances its DELTA_CALIBRATE
    /// saved, or the probe heights of --probes less the probe's z_offset.
    Klipper(FirmwareArgs),
}

#[derive(clap::Args)]
struct FirmwareArgs {
    /// The firmware's configuration (config.g or printer.cfg).
    #[arg(long)]
    config: PathBuf,
    /// The probe log: header x,y,z, the commanded XY of each probe and the
    /// height reported there (mm). Klipper's without it: the probes its
    /// DELTA_CALIBRATE saved in printer.cfg.
    #[arg(long)]
    probes: Option<PathBuf>,
    /// Part distances measured on a printed part: header
    /// x1,y1,z1,x2,y2,z2,distance, two commanded positions and the distance
    /// measured between them (mm). Klipper's without it: those its
    /// DELTA_ANALYZE saved in printer.cfg, if any.
    #[arg(long)]
    distances: Option<PathBuf>,
    /// The dataset directory to write (it must not exist or be empty,
    /// unless --force).
    #[arg(long)]
    out: PathBuf,
    /// Replace an existing dataset at --out, as a whole.
    #[arg(long)]
    force: bool,
    #[command(flatten)]
    tolerances: ToleranceArgs,
}

/// The builder's tolerances (one standard deviation each) and the probe's
/// noise; the defaults are a kit printer's ([`Tolerances::default`]).
#[derive(clap::Args)]
pub struct ToleranceArgs {
    /// Diagonal rods, mm.
    #[arg(long, value_name = "MM", default_value_t = Tolerances::default().diagonal, value_parser = sigma)]
    diagonal_tolerance: f64,
    /// The rods were cut as a matched set: each within MM of the set's
    /// length (at most the rods' tolerance), so that their differences
    /// are known far better than their length.
    #[arg(long, value_name = "MM", value_parser = sigma)]
    matched_rods: Option<f64>,
    /// Delta radius, mm.
    #[arg(long, value_name = "MM", default_value_t = Tolerances::default().radius, value_parser = sigma)]
    radius_tolerance: f64,
    /// Each tower's own radius, mm.
    #[arg(long, value_name = "MM", default_value_t = Tolerances::default().tower_radius, value_parser = sigma)]
    tower_radius_tolerance: f64,
    /// Tower angles, degrees.
    #[arg(long, value_name = "DEG", default_value_t = Tolerances::default().angle, value_parser = sigma)]
    angle_tolerance: f64,
    /// Endstops, mm.
    #[arg(long, value_name = "MM", default_value_t = Tolerances::default().endstop, value_parser = sigma)]
    endstop_tolerance: f64,
    /// Homed height, mm.
    #[arg(long, value_name = "MM", default_value_t = Tolerances::default().homed_height, value_parser = sigma)]
    homed_height_tolerance: f64,
    /// Bed tilt, percent.
    #[arg(long, value_name = "PERCENT", default_value_t = Tolerances::default().tilt, value_parser = sigma)]
    tilt_tolerance: f64,
    /// The probe's repeatability, mm.
    #[arg(long, value_name = "MM", default_value_t = 0.01, value_parser = sigma)]
    probe_sigma: f64,
    /// The part distances' standard deviation (a calliper's), mm.
    #[arg(long, value_name = "MM", default_value_t = 0.02, value_parser = sigma)]
    distance_sigma: f64,
    /// The trigger height's standard deviation about the configured one
    /// (G31 Z; Klipper's z_offset with the probes it saved, else 0), mm: a
    /// first-layer test's.
    #[arg(long, value_name = "MM", default_value_t = 0.05, value_parser = sigma)]
    trigger_sigma: f64,
}

impl ToleranceArgs {
    fn tolerances(&self) -> Tolerances {
        Tolerances {
            endstop: self.endstop_tolerance,
            homed_height: self.homed_height_tolerance,
            radius: self.radius_tolerance,
            tower_radius: self.tower_radius_tolerance,
            angle: self.angle_tolerance,
            diagonal: self.diagonal_tolerance,
            tilt: self.tilt_tolerance,
        }
    }
}

/// A standard deviation: finite, positive and at most [`MAX_SIGMA`].
fn sigma(text: &str) -> Result<f64, String> {
    let value: f64 = text.trim().parse().map_err(|e| format!("{e}"))?;
    if value.is_finite() && value > 0.0 && value <= MAX_SIGMA {
        Ok(value)
    } else {
        Err(format!(
            "{text} is not a standard deviation in (0, {MAX_SIGMA}]"
        ))
    }
}

/// What a firmware's files say: the configured parameters, the printable
/// radius and the trigger height.
struct Configured {
    params: DeltaParams,
    print_radius: f64,
    trigger_height: f64,
}

/// The mechanism dataset of a firmware's configuration, its probes (the
/// commanded position at each trigger) and part distances.
fn dataset(
    configured: &Configured,
    probes: Vec<[f64; 3]>,
    distances: Vec<[f64; 7]>,
    tolerances: &ToleranceArgs,
) -> MechanismDataset {
    // The kinematics only: the files state no joint or travel limits.
    let limits = Limits::reach_only(configured.print_radius);
    let delta = LinearDelta::new(&configured.params, &tolerances.tolerances(), limits);
    let mut machine = MechanismMachine::of(&delta);
    for parameter in delta.parameters() {
        if !machine
            .tolerances
            .iter()
            .any(|(group, _)| group == parameter.group)
        {
            machine
                .tolerances
                .push((parameter.group.to_string(), Some(parameter.prior_sigma)));
        }
    }
    if let Some(sigma) = tolerances.matched_rods {
        machine.matched.push((RODS.to_string(), sigma));
    }
    machine.noise = Noise {
        probe: Some(tolerances.probe_sigma),
        distance: (!distances.is_empty()).then_some(tolerances.distance_sigma),
        ..Noise::default()
    };
    machine.trigger_height = Some(ValuePrior {
        value: configured.trigger_height,
        sigma: Some(tolerances.trigger_sigma),
    });
    machine.print_radius = Some(configured.print_radius);
    MechanismDataset {
        machine,
        probes,
        distances,
        ..MechanismDataset::default()
    }
}

pub fn run(args: &Args) -> anyhow::Result<()> {
    let (firmware, files) = match &args.firmware {
        Firmware::Reprapfirmware(files) => ("RepRapFirmware", files),
        Firmware::Klipper(files) => ("Klipper", files),
    };
    // The configuration, and what its firmware saved of its last
    // calibration (Klipper's DELTA_CALIBRATE): probes and part distances.
    let (mut configured, saved) = match &args.firmware {
        Firmware::Reprapfirmware(files) => {
            let config = read_config(&files.config)?;
            let configured = Configured {
                params: config.delta.to_params(),
                print_radius: config.delta.print_radius,
                trigger_height: config.probe.trigger_height,
            };
            (configured, DeltaCalibrateResults::default())
        }
        Firmware::Klipper(files) => {
            let printer = read_printer(&files.config)?;
            let configured = Configured {
                params: printer.delta.to_params(),
                print_radius: printer.delta.print_radius,
                trigger_height: 0.0,
            };
            (configured, printer.saved)
        }
    };
    let (probes, probes_from) = match &files.probes {
        Some(path) => {
            let commanded = (read_probes(path)?.iter())
                .map(|p: &ProbePoint| [p.x, p.y, p.z + configured.trigger_height])
                .collect();
            (commanded, path.display().to_string())
        }
        None if !saved.probes.is_empty() => {
            configured.trigger_height = saved.z_offset.unwrap_or_default();
            let from = format!("saved in {}", files.config.display());
            (saved.probes, from)
        }
        None => anyhow::bail!(
            "{}: no probes: give --probes (header x,y,z){}",
            files.config.display(),
            match args.firmware {
                Firmware::Klipper(_) => ", or run DELTA_CALIBRATE and SAVE_CONFIG first",
                Firmware::Reprapfirmware(_) => "",
            }
        ),
    };
    // A file given replaces what the firmware saved, each kind its own.
    let (distances, distances_from) = match &files.distances {
        Some(path) => (read_distances(path)?, format!(" ({})", path.display())),
        None if !saved.distances.is_empty() => (
            saved.distances,
            format!(" (saved in {})", files.config.display()),
        ),
        None => (Vec::new(), String::new()),
    };
    let n_distances = distances.len();
    let n_probes = probes.len();
    dataset(&configured, probes, distances, &files.tolerances)
        .write_with(&files.out, files.force)?;
    println!(
        "{}: {firmware}'s configuration ({}), {n_probes} probe heights ({probes_from}) and {n_distances} part distances{distances_from}",
        files.out.display(),
        files.config.display(),
    );
    Ok(())
}
