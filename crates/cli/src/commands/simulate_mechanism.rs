//! `parcal simulate --mechanism`: a simulated mechanism as a mechanism
//! dataset with its truth, by [`parcal::simulation::mechanism`] (a linear
//! delta printer, docs/delta.md, its balls with a ball plate's distances
//! given `--plate`; a cable robot, docs/cable-robots.md), written to
//! `--out`. With `--truth DATASET`, the true machine of a
//! dataset simulated so is measured again instead of drawn: held-out data
//! for `parcal validate` (new noise with another seed, or another pattern
//! with other flags).

use std::path::{Path, PathBuf};

use anyhow::Context;
use parcal::dataset::mechanism::{MechanismDataset, tracker_labels};
use parcal::simulation::mechanism::{
    MechanismOptions, MechanismRequest, Spelling, TrueMachine, mechanism_name, simulate_mechanism,
};

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
    /// The mechanism's options.
    pub options: MechanismOptions,
}

/// The dataset of `--truth` at `path`, not the one written at `out`.
fn read_truth(path: &Path, out: &Path) -> anyhow::Result<MechanismDataset> {
    let same = |a: &Path, b: &Path| match (a.canonicalize(), b.canonicalize()) {
        (Ok(a), Ok(b)) => a == b,
        _ => false,
    };
    anyhow::ensure!(
        !same(path, out),
        "--out {} is the dataset of --truth, which this run reads; write the held-out data elsewhere",
        out.display()
    );
    MechanismDataset::read(path).with_context(|| format!("--truth {}", path.display()))
}

/// Simulates the dataset of `request` and writes it.
pub fn run(request: &Request) -> anyhow::Result<()> {
    let name = mechanism_name(&request.mechanism, Spelling::Flags)?;
    let source = request
        .truth
        .as_deref()
        .map(|path| read_truth(path, &request.out))
        .transpose()?;
    let source_name = request
        .truth
        .as_ref()
        .map(|path| format!("--truth {}", path.display()));
    let dataset = simulate_mechanism(&MechanismRequest {
        mechanism: name,
        seed: request.seed,
        options: &request.options,
        truth: source
            .as_ref()
            .zip(source_name.as_deref())
            .map(|(dataset, name)| TrueMachine { dataset, name }),
        spelling: Spelling::Flags,
    })?;
    dataset
        .write_with(&request.out, request.force)
        .with_context(|| format!("{}", request.out.display()))?;
    let known = dataset
        .samples
        .iter()
        .filter(|s| s.position.is_some())
        .count();
    let mut machine = match &request.truth {
        Some(path) => format!("the true machine of {}", path.display()),
        None => "the true machine".to_string(),
    };
    let plate = match dataset.ball_distances.len() {
        0 => String::new(),
        n => format!(" ({n} distances between them)"),
    };
    let trackers = match tracker_labels(&dataset.tracker_points).len() {
        0 => String::new(),
        k => {
            machine.push_str(" and the trackers' frames");
            format!(", {} points of {k} trackers", dataset.tracker_points.len())
        }
    };
    let heights = match dataset.heights.len() {
        0 => String::new(),
        n => format!(", {n} heights measured by hand"),
    };
    let loads = match &dataset.machine.elasticity {
        None => String::new(),
        Some(lines) => {
            let drawn: Vec<f64> = (dataset.samples.iter().skip(1))
                .flat_map(|sample| sample.loads.iter().flatten().copied())
                .collect();
            let others = match drawn.iter().copied().reduce(f64::min) {
                Some(low) => {
                    let high = drawn.iter().copied().fold(low, f64::max);
                    format!("; the others' from {low:.1} to {high:.1} N")
                }
                None => String::new(),
            };
            format!(
                " under loads (elastic lines zeroed under {:?} N{others})",
                lines.zero_loads
            )
        }
    };
    println!(
        "{}: a {name}, {} probe heights{heights}, {} part distances, {} encoder samples ({known} with a measured position){loads}, {} touches of {} balls{plate}{trackers}, seed {} (truth.json: {machine})",
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
