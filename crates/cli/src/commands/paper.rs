//! `parcal paper`: the paper's simulations I-IV on one simulated dataset,
//! with a report.

use std::path::PathBuf;

use crate::progress::Progress;

#[derive(clap::Args)]
pub struct Args {
    /// Seed of the simulated dataset.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Output directory (dataset, calibrations, maps, plots, report.md).
    #[arg(long)]
    out: PathBuf,
}

pub fn run(args: &Args) -> anyhow::Result<()> {
    let progress = Progress::spinner();
    parcal::report::paper::reproduce(args.seed, &args.out, &mut |line| progress.line(line))?;
    Ok(())
}
