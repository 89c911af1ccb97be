//! `parcal simulate`: write a simulated campaign as a dataset.

use std::io::Write;
use std::path::PathBuf;

use anyhow::Context;
use parcal_simulate::{Plate, PlatePairs, Scenario, simulate};

use super::SNAPSHOT_FILE;

#[derive(clap::Args)]
pub struct Args {
    /// Seed of the random streams: the same seed gives byte-identical files.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Output directory (created if needed).
    #[arg(long)]
    out: PathBuf,
    /// Number of balls on a regular grid filling x, y in [-80, 80], z in [340, 460]
    /// (default: the paper's 27 balls at x, y in {-60, 0, 60}, z in {360, 400, 440}).
    #[arg(long)]
    balls: Option<usize>,
    /// Contacts per ball.
    #[arg(long, default_value_t = 7)]
    points_per_ball: usize,
    /// Largest |yaw|, |pitch|, |roll| of the platform at a contact, degrees.
    #[arg(long, default_value_t = 10.0)]
    tilt: f64,
    /// Also write a calibrated ball plate as the distances of artefacts.json:
    /// `all` pairs of balls (n (n - 1) / 2 distances for n balls), or a number
    /// of distinct pairs drawn at random.
    /// Each distance is the true one plus an error of --plate-sigma; the
    /// contacts are the same as without a plate.
    #[arg(long, value_name = "all|PAIRS", value_parser = parse_pairs)]
    plate: Option<PlatePairs>,
    /// Error of each calibrated distance of the plate (1 sigma), micrometres.
    #[arg(long, value_name = "UM", default_value_t = 1.0, requires = "plate")]
    plate_sigma: f64,
    /// Also write a binary snapshot of the dataset (postcard) to OUT/dataset.bin,
    /// which loads much faster than the text files.
    #[arg(long)]
    binary: bool,
}

pub fn run(args: &Args) -> anyhow::Result<()> {
    anyhow::ensure!(
        args.points_per_ball > 0,
        "--points-per-ball must be at least 1"
    );
    anyhow::ensure!(
        args.tilt.is_finite() && (0.0..90.0).contains(&args.tilt),
        "--tilt must be in [0, 90) degrees, got {}",
        args.tilt
    );
    anyhow::ensure!(
        args.plate_sigma.is_finite() && args.plate_sigma > 0.0,
        "--plate-sigma must be positive, got {}",
        args.plate_sigma
    );
    let mut scenario = match args.balls {
        None => Scenario {
            points_per_ball: args.points_per_ball,
            max_tilt: args.tilt.to_radians(),
            ..Scenario::paper()
        },
        Some(0) => anyhow::bail!("--balls must be at least 1"),
        Some(balls) => Scenario::scaled(balls, args.points_per_ball, args.tilt.to_radians()),
    };
    scenario.plate = args.plate.map(|pairs| Plate {
        pairs,
        sigma: args.plate_sigma * 1e-3,
    });
    let simulation = simulate(&scenario, args.seed).context("simulation failed")?;
    simulation
        .dataset
        .write(&args.out)
        .with_context(|| format!("cannot write the dataset to {}", args.out.display()))?;
    if args.binary {
        let path = args.out.join(SNAPSHOT_FILE);
        simulation
            .dataset
            .write_snapshot(&path)
            .with_context(|| format!("cannot write the snapshot {}", path.display()))?;
    }
    let s = &simulation.summary;
    let mut stdout = std::io::stdout().lock();
    writeln!(
        stdout,
        "simulated dataset written to {}",
        args.out.display()
    )?;
    writeln!(stdout, "  seed               {}", args.seed)?;
    writeln!(stdout, "  balls              {}", s.balls)?;
    writeln!(
        stdout,
        "  contacts           {} ({} per ball)",
        s.contacts, scenario.points_per_ball
    )?;
    if args.plate.is_some() {
        writeln!(
            stdout,
            "  ball distances     {} (sigma {} um)",
            simulation.dataset.artefacts.distances.len(),
            args.plate_sigma
        )?;
    }
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
    writeln!(
        stdout,
        "  FK check           every contact's tip back on its ball, worst {:.2} sigma of the noise",
        s.worst_check
    )?;
    Ok(())
}

/// `--plate`: `all`, or a number of pairs (at least 1).
fn parse_pairs(value: &str) -> Result<PlatePairs, String> {
    if value == "all" {
        return Ok(PlatePairs::All);
    }
    match value.parse::<u64>() {
        Ok(0) => Err("a plate needs at least 1 pair".into()),
        Ok(count) => Ok(PlatePairs::Random(count)),
        Err(_) => Err(format!(
            "expected `all` or a number of pairs, got {value:?}"
        )),
    }
}
