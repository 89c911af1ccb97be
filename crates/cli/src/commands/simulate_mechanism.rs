//! `parcal simulate --mechanism`: a simulated mechanism as a mechanism
//! dataset with its truth. A linear delta printer (docs/delta.md), by
//! [`parcal::simulation::delta`]: the typical kit printer's design, its true
//! parameters and trigger height a draw of the prior machine.json states,
//! probes on rings over the printable disc, part distances across it on
//! the first layer, calibrated balls on the bed touched by the probe
//! (`--balls`, `--points-per-ball`). A cable robot (docs/cable-robots.md), by
//! [`simulate_cable_dataset`]: the Hangprinter's shape, its true anchors,
//! radii and encoder zero a draw of the prior, encoder samples where every
//! line is taut, the encoder zero's and a few bed positions measured.

use std::path::PathBuf;

use anyhow::Context;
use parcal::dataset::bounds::Count;
use parcal::dataset::mechanism::MechanismDataset;
use parcal::kinematics::mechanisms;
use parcal::simulation::delta::{DeltaScenario, simulate_delta};
use parcal::simulation::{CableScenario, simulate_cable_dataset};

/// The bounds of `--probe-rings`.
pub const RINGS: Count = Count::new(1, 20, "a bed probed on more rings than 20 gains nothing");
/// The bounds of `--probes-per-ring`.
pub const PER_RING: Count = Count::new(3, 360, "a point every degree at most");
/// The bounds of `--part-distances`.
pub const DISTANCES: Count = Count::new(0, 180, "one distance per degree at most");
/// The bounds of `--samples` and `--known-positions`.
pub const SAMPLES: Count = Count::new(
    1,
    10_000,
    "a cable robot's calibration from ten thousand encoder samples is far past what its model error allows",
);

/// The delta's options, each `None` for its default.
pub struct DeltaFlags {
    /// Probe rings.
    pub rings: Option<usize>,
    /// Probes per ring.
    pub per_ring: Option<usize>,
    /// Part distances.
    pub distances: Option<usize>,
    /// Probe noise (mm).
    pub probe_sigma: Option<f64>,
    /// Distance noise (mm).
    pub distance_sigma: Option<f64>,
    /// Calibrated balls on the bed (`--balls`).
    pub balls: Option<usize>,
    /// Touches of each (`--points-per-ball`).
    pub touches_per_ball: usize,
}

/// The cable robot's options, each `None` for its default.
pub struct CableFlags {
    /// Samples, the encoder zero's included.
    pub samples: Option<usize>,
    /// Samples with a measured position.
    pub known: Option<usize>,
    /// The encoders' noise (degrees).
    pub reading_sigma: Option<f64>,
    /// A measured coordinate's noise (mm).
    pub position_sigma: Option<f64>,
}

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
    /// A delta's options.
    pub delta: DeltaFlags,
    /// A cable robot's options.
    pub cable: CableFlags,
}

/// The mechanism named `name`, by its name in the one list or a short
/// name (`delta`, `cable`).
fn mechanism_name(name: &str) -> anyhow::Result<&'static str> {
    let canonical = match name {
        "delta" => "linear delta",
        "cable" => "cable robot",
        other => other,
    };
    match mechanisms::NAMES.iter().find(|n| **n == canonical) {
        Some(&"hexapod") => anyhow::bail!(
            "--mechanism hexapod: the hexapod is simulated without --mechanism (the paper scenario and its options)"
        ),
        Some(found) => Ok(found),
        None => anyhow::bail!(
            "--mechanism {name:?}: unknown (known: {}, or delta, cable)",
            mechanisms::NAMES.join(", ")
        ),
    }
}

/// Refuses the flags of another mechanism than `name`'s.
fn refuse_others(name: &str, given: &[(&str, bool)]) -> anyhow::Result<()> {
    let others: Vec<&str> = given
        .iter()
        .filter(|(_, given)| *given)
        .map(|(flag, _)| *flag)
        .collect();
    anyhow::ensure!(
        others.is_empty(),
        "{} do not apply to a {name}",
        others.join(", ")
    );
    Ok(())
}

/// `sigma` if given (in `(0, max]`), else `default`.
fn sigma(flag: &str, given: Option<f64>, default: f64, max: f64) -> anyhow::Result<f64> {
    let sigma = given.unwrap_or(default);
    anyhow::ensure!(
        sigma.is_finite() && sigma > 0.0 && sigma <= max,
        "{flag} must be in (0, {max}], got {sigma}"
    );
    Ok(sigma)
}

/// The delta's dataset of `request`.
fn delta(request: &Request) -> anyhow::Result<MechanismDataset> {
    let cable = &request.cable;
    refuse_others(
        "linear delta",
        &[
            ("--samples", cable.samples.is_some()),
            ("--known-positions", cable.known.is_some()),
            ("--reading-sigma", cable.reading_sigma.is_some()),
            ("--measured-sigma", cable.position_sigma.is_some()),
        ],
    )?;
    let flags = &request.delta;
    let typical = DeltaScenario::typical();
    let scenario = DeltaScenario {
        rings: flags.rings.unwrap_or(typical.rings),
        per_ring: flags.per_ring.unwrap_or(typical.per_ring),
        distances: flags.distances.unwrap_or(typical.distances),
        probe_sigma: sigma("--probe-sigma", flags.probe_sigma, 0.01, 1.0)?,
        distance_sigma: sigma("--distance-sigma", flags.distance_sigma, 0.01, 1.0)?,
        balls: flags.balls.unwrap_or(typical.balls),
        touches_per_ball: flags.touches_per_ball,
        ..typical
    };
    Ok(simulate_delta(&scenario, request.seed)?)
}

/// The cable robot's dataset of `request`.
fn cable(request: &Request) -> anyhow::Result<MechanismDataset> {
    let delta = &request.delta;
    refuse_others(
        "cable robot",
        &[
            ("--probe-rings", delta.rings.is_some()),
            ("--probes-per-ring", delta.per_ring.is_some()),
            ("--part-distances", delta.distances.is_some()),
            ("--probe-sigma", delta.probe_sigma.is_some()),
            ("--distance-sigma", delta.distance_sigma.is_some()),
            ("--balls", delta.balls.is_some()),
        ],
    )?;
    let flags = &request.cable;
    let hangprinter = CableScenario::hangprinter();
    let samples = flags.samples.unwrap_or(hangprinter.samples);
    let known = flags.known.unwrap_or(hangprinter.known);
    anyhow::ensure!(
        known <= samples,
        "--known-positions {known} is more than the {samples} samples"
    );
    let position = sigma("--measured-sigma", flags.position_sigma, 1.0, 100.0)?;
    let scenario = CableScenario {
        samples,
        known,
        reading_sigma: sigma("--reading-sigma", flags.reading_sigma, 1.0, 90.0)?,
        position_sigma: [position; 3],
        ..hangprinter
    };
    Ok(simulate_cable_dataset(&scenario, request.seed)?)
}

/// Simulates the dataset of `request` and writes it.
pub fn run(request: &Request) -> anyhow::Result<()> {
    let name = mechanism_name(&request.mechanism)?;
    let dataset = match name {
        "linear delta" => delta(request)?,
        "cable robot" => cable(request)?,
        other => {
            anyhow::bail!("--mechanism {other}: parcal simulates a linear delta or a cable robot")
        }
    };
    dataset
        .write_with(&request.out, request.force)
        .with_context(|| format!("{}", request.out.display()))?;
    let known = dataset
        .samples
        .iter()
        .filter(|s| s.position.is_some())
        .count();
    println!(
        "{}: a {name}, {} probe heights, {} part distances, {} encoder samples ({known} with a measured position), {} touches of {} balls, seed {} (truth.json: the true machine)",
        request.out.display(),
        dataset.probes.len(),
        dataset.distances.len(),
        dataset.samples.len(),
        dataset.touches.len(),
        dataset.balls.len(),
        request.seed
    );
    Ok(())
}
