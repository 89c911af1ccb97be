//! `parcal simulate --mechanism delta`: a simulated linear delta printer
//! as a mechanism dataset with its truth (docs/delta.md), by
//! [`parcal_simulate::delta`]: the typical kit printer's design, its true
//! parameters and trigger height a draw of the prior machine.json states,
//! probes on rings over the printable disc, part distances across it on
//! the first layer.

use std::path::PathBuf;

use anyhow::Context;
use parcal_dataset::bounds::Count;
use parcal_kinematics::mechanisms;
use parcal_simulate::delta::{DeltaScenario, simulate_delta};

/// The bounds of `--probe-rings`.
pub const RINGS: Count = Count::new(1, 20, "a bed probed on more rings than 20 gains nothing");
/// The bounds of `--probes-per-ring`.
pub const PER_RING: Count = Count::new(3, 360, "a point every degree at most");
/// The bounds of `--part-distances`.
pub const DISTANCES: Count = Count::new(0, 180, "one distance per degree at most");

/// The options of a simulated mechanism (`parcal simulate --mechanism`).
pub struct Request {
    /// The mechanism's name as given.
    pub mechanism: String,
    /// The seed.
    pub seed: u64,
    /// The dataset directory.
    pub out: PathBuf,
    /// Replace an existing dataset.
    pub force: bool,
    /// Probe rings.
    pub rings: usize,
    /// Probes per ring.
    pub per_ring: usize,
    /// Part distances.
    pub distances: usize,
    /// Probe noise (mm).
    pub probe_sigma: f64,
    /// Distance noise (mm).
    pub distance_sigma: f64,
}

/// The mechanism named `name`, by its name in the one list or a short
/// name (`delta`).
fn mechanism_name(name: &str) -> anyhow::Result<&'static str> {
    let canonical = match name {
        "delta" => "linear delta",
        other => other,
    };
    match mechanisms::NAMES.iter().find(|n| **n == canonical) {
        Some(&"hexapod") => anyhow::bail!(
            "--mechanism hexapod: the hexapod is simulated without --mechanism (the paper scenario and its options)"
        ),
        Some(found) => Ok(found),
        None => anyhow::bail!(
            "--mechanism {name:?}: unknown (known: {}, or delta)",
            mechanisms::NAMES.join(", ")
        ),
    }
}

/// Simulates the dataset of `request` and writes it.
pub fn run(request: &Request) -> anyhow::Result<()> {
    let name = mechanism_name(&request.mechanism)?;
    anyhow::ensure!(
        name == "linear delta",
        "--mechanism {name}: parcal simulates the linear delta only"
    );
    for (flag, sigma) in [
        ("--probe-sigma", request.probe_sigma),
        ("--distance-sigma", request.distance_sigma),
    ] {
        anyhow::ensure!(
            sigma.is_finite() && sigma > 0.0 && sigma <= 1.0,
            "{flag} must be in (0, 1] mm, got {sigma}"
        );
    }
    let scenario = DeltaScenario {
        rings: request.rings,
        per_ring: request.per_ring,
        distances: request.distances,
        probe_sigma: request.probe_sigma,
        distance_sigma: request.distance_sigma,
        ..DeltaScenario::typical()
    };
    let dataset = simulate_delta(&scenario, request.seed)?;
    dataset
        .write_with(&request.out, request.force)
        .with_context(|| format!("{}", request.out.display()))?;
    println!(
        "{}: a linear delta, {} probe heights, {} part distances, seed {} (truth.json: the true machine)",
        request.out.display(),
        dataset.probes.len(),
        dataset.distances.len(),
        request.seed
    );
    Ok(())
}
