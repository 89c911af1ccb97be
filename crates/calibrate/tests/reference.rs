//! parcal against the independent implementation's calibrations of the same
//! dataset (fixtures/reference-paper-seed1).

use std::path::{Path, PathBuf};

use parcal_calibrate::{CalibrationOptions, PriorMode, Simulation, calibrate};
use parcal_dataset::{Calibration, Dataset};

fn fixture() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../fixtures/reference-paper-seed1")
}

fn compare(sim: Simulation, prior: PriorMode, reference_file: &str) {
    let dataset = Dataset::read(&fixture()).unwrap();
    let options = CalibrationOptions {
        prior,
        ..CalibrationOptions::simulation(sim)
    };
    let run = calibrate(&dataset, &options, &mut |r| {
        eprintln!("cost {:.6e} step {:.3e}", r.cost, r.step_norm)
    })
    .unwrap();
    let reference = Calibration::read(&fixture().join(reference_file)).unwrap();
    eprintln!("{} {}: {}", sim, prior, run.status_text());
    let sigmas = run.sigmas().unwrap();
    let mut worst: f64 = 0.0;
    for k in 0..33 {
        let (ours, theirs, their_sigma) = (
            run.params[k],
            reference.parameters.values[k],
            reference.parameters.sigma[k],
        );
        let normalised = (ours - theirs) / their_sigma;
        worst = worst.max(normalised.abs());
        eprintln!(
            "{:>5} ours {:>12.6} ± {:.6}  ref {:>12.6} ± {:.6}  diff/sigma {:+.4}",
            reference.parameters.names[k], ours, sigmas[k], theirs, their_sigma, normalised
        );
    }
    eprintln!(
        "worst |difference| / sigma: {worst:.4}; iterations {}",
        run.history.len()
    );
    for c in &run.conflicts {
        eprintln!("{:?}", c.warning());
    }
}

#[test]
fn simulation_iv_propagated_matches_the_reference() {
    compare(
        Simulation::IV,
        PriorMode::Propagated,
        "reference-IV-propagated.json",
    );
}

#[test]
fn simulation_iii_paper_matches_the_reference() {
    compare(
        Simulation::III,
        PriorMode::Paper,
        "reference-III-paper.json",
    );
}

#[test]
fn all_simulations_against_truth() {
    let dataset = Dataset::read(&fixture()).unwrap();
    let truth = dataset.truth.as_ref().unwrap();
    let truth_geometry = parcal_kinematics::Geometry::from_arrays(
        &truth.base_joints,
        &truth.platform_joints,
        &truth.tool,
        &truth.leg_lengths,
    );
    let p_true =
        parcal_kinematics::params::to_params(&truth_geometry.canonicalize().unwrap().geometry);
    for (sim, prior) in [
        (Simulation::I, PriorMode::None),
        (Simulation::II, PriorMode::None),
        (Simulation::III, PriorMode::Paper),
        (Simulation::IV, PriorMode::Paper),
        (Simulation::III, PriorMode::Propagated),
        (Simulation::IV, PriorMode::Propagated),
    ] {
        let options = CalibrationOptions {
            prior,
            ..CalibrationOptions::simulation(sim)
        };
        let run = calibrate(&dataset, &options, &mut |_| {}).unwrap();
        let costs: Vec<String> = run
            .history
            .iter()
            .map(|r| format!("{:.3e}", r.cost))
            .collect();
        eprintln!(
            "{sim} {prior}: {} iterations, status {}, costs {:?}",
            run.history.len(),
            run.status_text(),
            costs
        );
        if let Some(cov) = run.covariance {
            let e = run.params - p_true;
            let nees = e.dot(&(cov.try_inverse().unwrap() * e));
            eprintln!(
                "  NEES {nees:.1}, max |err| {:.4}, cond {:?}",
                e.amax(),
                run.condition_number()
            );
        }
        for w in run.warnings() {
            eprintln!("  WARNING {w}");
        }
    }
}
