//! `parcal simulate --mechanism delta`: a simulated linear delta printer
//! as a mechanism dataset with its truth (docs/delta.md).
//!
//! The printer runs with the typical kit printer's configuration
//! ([`LinearDelta::typical`]); its true parameters and trigger height are
//! a draw of the prior machine.json states (each the configured value
//! plus a normal deviate of its tolerance), so that the calibration's
//! statistical tests hold. Probes on rings over the printable disc
//! ([`probe_rings`]): the commanded height `z_t` at which the probe
//! triggers solves `z(f(p, g(p_c, (x, y, z_t)))) = h` (Newton's method
//! with the slope 1 of a firmware that knows its machine), plus the probe
//! noise. Part distances: across a printed disc on the first layer, at
//! `z = 0.2`, along directions spread over 180 degrees, 90 % of the
//! printable diameter long, each the true distance between the positions
//! reached plus the distance noise. Every stream is `(seed, k)`.

use std::path::PathBuf;

use anyhow::Context;
use parcal_dataset::bounds::Count;
use parcal_dataset::mechanism::{
    MechanismDataset, MechanismMachine, MechanismTruth, Noise, ValuePrior,
};
use parcal_kinematics::delta::{LinearDelta, probe_rings};
use parcal_kinematics::mechanism::{Mechanism, design};
use parcal_kinematics::mechanisms;
use parcal_simulate::Rng;

/// The bounds of `--probe-rings`.
pub const RINGS: Count = Count::new(1, 20, "a bed probed on more rings than 20 gains nothing");
/// The bounds of `--probes-per-ring`.
pub const PER_RING: Count = Count::new(3, 360, "a point every degree at most");
/// The bounds of `--part-distances`.
pub const DISTANCES: Count = Count::new(0, 180, "one distance per degree at most");

/// The configured trigger height (mm) and its prior sigma.
const TRIGGER_HEIGHT: (f64, f64) = (0.7, 0.05);
/// The height of the first layer, where part distances are measured (mm).
const FIRST_LAYER: f64 = 0.2;

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
    let dataset = simulate(request)?;
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

/// The simulated dataset (module documentation).
fn simulate(request: &Request) -> anyhow::Result<MechanismDataset> {
    let delta = LinearDelta::typical();
    let configured = design(&delta);
    let mut rng = Rng::new(request.seed, 0);
    let truth: Vec<f64> = delta
        .parameters()
        .iter()
        .map(|p| p.design + rng.normal(p.prior_sigma))
        .collect();
    let trigger = TRIGGER_HEIGHT.0 + rng.normal(TRIGGER_HEIGHT.1);
    let (c, t) = (configured.as_slice(), truth.as_slice());
    // Where the machine truly is when its firmware commands `target`.
    let reached = |target: &[f64; 3]| -> anyhow::Result<nalgebra::DVector<f64>> {
        let q = delta.inverse(c, target)?;
        Ok(delta.forward(t, q.as_slice(), target)?)
    };
    let print_radius = delta.limits().print_radius;
    let mut probes = Vec::new();
    let mut noise = Rng::new(request.seed, 1);
    for [x, y] in probe_rings(print_radius, request.rings, request.per_ring) {
        let mut z = trigger;
        let mut settled = false;
        for _ in 0..50 {
            let step = reached(&[x, y, z])?[2] - trigger;
            z -= step;
            settled = step.abs() < 1e-12;
            if settled {
                break;
            }
        }
        anyhow::ensure!(
            settled,
            "the probe at ({x:.3}, {y:.3}) does not settle on the bed"
        );
        probes.push([x, y, z + noise.normal(request.probe_sigma)]);
    }
    let mut distances = Vec::new();
    let half = 0.9 * print_radius;
    for k in 0..request.distances {
        let angle = std::f64::consts::PI * k as f64 / request.distances as f64;
        let (sin, cos) = angle.sin_cos();
        let first = [half * cos, half * sin, FIRST_LAYER];
        let second = [-half * cos, -half * sin, FIRST_LAYER];
        let length = (reached(&first)? - reached(&second)?).norm();
        let measured = length + noise.normal(request.distance_sigma);
        distances.push([
            first[0], first[1], first[2], second[0], second[1], second[2], measured,
        ]);
    }
    let mut machine = MechanismMachine::of(&delta);
    machine.noise = Noise {
        probe: Some(request.probe_sigma),
        distance: (request.distances > 0).then_some(request.distance_sigma),
        ..Noise::default()
    };
    machine.trigger_height = Some(ValuePrior {
        value: TRIGGER_HEIGHT.0,
        sigma: Some(TRIGGER_HEIGHT.1),
    });
    Ok(MechanismDataset {
        machine,
        probes,
        distances,
        truth: Some(MechanismTruth {
            parameters: truth,
            trigger_height: trigger,
        }),
        ..MechanismDataset::default()
    })
}
