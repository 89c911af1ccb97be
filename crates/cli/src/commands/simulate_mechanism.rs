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
//! With `--truth DATASET`, the true machine of a dataset simulated so is
//! measured again instead of drawn: held-out data for `parcal validate`
//! (new noise with another seed, or another pattern with other flags).

use std::path::{Path, PathBuf};

use anyhow::Context;
use parcal::dataset::bounds::Count;
use parcal::dataset::mechanism::{MACHINE_FILE, MechanismDataset, MechanismTruth};
use parcal::kinematics::mechanisms;
use parcal::simulation::delta::{DeltaScenario, measure_delta, simulate_delta};
use parcal::simulation::{CableScenario, measure_cable_dataset, simulate_cable_dataset};

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
    /// A simulated dataset whose true machine is measured (held-out data)
    /// instead of a drawn one.
    pub truth: Option<PathBuf>,
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

/// The delta's dataset of `request`, of the true printer `truth` if given.
fn delta(request: &Request, truth: Option<&MechanismTruth>) -> anyhow::Result<MechanismDataset> {
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
    Ok(match truth {
        Some(truth) => measure_delta(&scenario, truth, request.seed)?,
        None => simulate_delta(&scenario, request.seed)?,
    })
}

/// The cable robot's dataset of `request`, of the true machine `truth` if
/// given.
fn cable(request: &Request, truth: Option<&MechanismTruth>) -> anyhow::Result<MechanismDataset> {
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
    Ok(match truth {
        Some(truth) => measure_cable_dataset(&scenario, truth, request.seed)?,
        None => simulate_cable_dataset(&scenario, request.seed)?,
    })
}

/// The simulated dataset of `--truth` at `path`: a dataset of the
/// mechanism `name` with its truth.json, not the one written at `out`.
fn read_truth(path: &Path, name: &str, out: &Path) -> anyhow::Result<MechanismDataset> {
    let same = |a: &Path, b: &Path| match (a.canonicalize(), b.canonicalize()) {
        (Ok(a), Ok(b)) => a == b,
        _ => false,
    };
    anyhow::ensure!(
        !same(path, out),
        "--out {} is the dataset of --truth, which this run reads; write the held-out data elsewhere",
        out.display()
    );
    let dataset =
        MechanismDataset::read(path).with_context(|| format!("--truth {}", path.display()))?;
    anyhow::ensure!(
        dataset.machine.mechanism == name,
        "--truth {}: a dataset of a {}, not of a {name}",
        path.display(),
        dataset.machine.mechanism
    );
    anyhow::ensure!(
        dataset.truth.is_some(),
        "--truth {}: the dataset has no truth.json (only a simulated dataset has a true machine to measure)",
        path.display()
    );
    Ok(dataset)
}

/// Refuses held-out data `measured` of the dataset `truth` (at `path`)
/// that the calibration could not be judged on: data of a controller
/// configured otherwise than the simulator's, or the very measurements
/// of `truth` (the same seed and flags).
fn check_held_out(
    measured: &MechanismDataset,
    truth: &MechanismDataset,
    path: &Path,
) -> anyhow::Result<()> {
    anyhow::ensure!(
        measured.machine.configured == truth.machine.configured,
        "--truth {}: {MACHINE_FILE} configures the controller otherwise than parcal simulate does; its true machine cannot be measured with the simulator's configuration",
        path.display()
    );
    let same = measured.probes == truth.probes
        && measured.distances == truth.distances
        && measured.samples == truth.samples;
    anyhow::ensure!(
        !same,
        "--truth {}: these are its own measurements (the same --seed and pattern); give another --seed for held-out data",
        path.display()
    );
    Ok(())
}

/// Simulates the dataset of `request` and writes it.
pub fn run(request: &Request) -> anyhow::Result<()> {
    let name = mechanism_name(&request.mechanism)?;
    let source = request
        .truth
        .as_deref()
        .map(|path| read_truth(path, name, &request.out))
        .transpose()?;
    let truth = source.as_ref().and_then(|dataset| dataset.truth.as_ref());
    let dataset = match name {
        "linear delta" => delta(request, truth)?,
        "cable robot" => cable(request, truth)?,
        other => {
            anyhow::bail!("--mechanism {other}: parcal simulates a linear delta or a cable robot")
        }
    };
    if let (Some(source), Some(path)) = (&source, &request.truth) {
        check_held_out(&dataset, source, path)?;
    }
    dataset
        .write_with(&request.out, request.force)
        .with_context(|| format!("{}", request.out.display()))?;
    let known = dataset
        .samples
        .iter()
        .filter(|s| s.position.is_some())
        .count();
    let machine = match &request.truth {
        Some(path) => format!("the true machine of {}", path.display()),
        None => "the true machine".to_string(),
    };
    println!(
        "{}: a {name}, {} probe heights, {} part distances, {} encoder samples ({known} with a measured position), {} touches of {} balls, seed {} (truth.json: {machine})",
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
