//! docs/plan.md's scaling table and plot: for each budget and tilt, plan
//! the touches of the paper's 27 balls (default options), simulate exactly
//! those with the truth of table 2 over noise seeds 1..=S, calibrate with
//! the default options, and compare the plan's predicted registered RMS
//! with the true one (mean and standard deviation over the seeds).
//!
//! `cargo run --release -p parcal-benches --example plan_scaling -- docs/plan-scaling.svg [S [R]]`
//! (S noise seeds, 5 by default; R the sigma of the balls' calibrated radii
//! in um, the paper scenario's by default).

use std::path::Path;

use parcal_accuracy::MapGrid;
use parcal_calibrate::{CalibrationOptions, calibrate};
use parcal_plan::{PlanOptions, plan};
use parcal_report::plots::{LineChart, Series, line_chart};
use parcal_simulate::{Scenario, simulate};
use parcal_workflows::evaluate::{TrueMachine, before_after};

const BUDGETS: [usize; 4] = [95, 189, 378, 756];
const TILTS: [f64; 4] = [10.0, 20.0, 30.0, 40.0];

/// One budget and tilt: the plan's prediction and the true RMS per seed (um).
struct Case {
    balls: usize,
    predicted: f64,
    true_rms: Vec<f64>,
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let out = args.next().unwrap_or_else(|| "plan-scaling.svg".into());
    let seeds: u64 = args.next().map_or(Ok(5), |s| s.parse())?;
    let paper = match args.next() {
        Some(sigma) => Scenario {
            radius_sigma: sigma.parse::<f64>()? * 1e-3,
            ..Scenario::paper()
        },
        None => Scenario::paper(),
    };
    let template = simulate(&paper, 1)?.dataset;
    let mut cases = Vec::new();
    for tilt in TILTS {
        for contacts in BUDGETS {
            let planned = plan(
                &template.machine,
                &template.artefacts,
                &PlanOptions::new(contacts, tilt),
                &mut |_| {},
            )?;
            let scenario = Scenario {
                plan: Some(planned.touches()),
                ..paper.clone()
            };
            let mut true_rms = Vec::new();
            let mut balls = 0;
            for seed in 1..=seeds {
                let dataset = simulate(&scenario, seed)?.dataset;
                balls = dataset.artefacts.balls.len();
                let run = calibrate(&dataset, &CalibrationOptions::default(), &mut |_| {})?;
                if !run.converged() {
                    return Err(format!(
                        "+-{tilt} deg, {contacts} touches, seed {seed}: not converged"
                    )
                    .into());
                }
                let truth = TrueMachine::of(&dataset).ok_or("no truth")??;
                let after = before_after(Some(&truth), &run, &MapGrid::paper())?
                    .after
                    .ok_or("no calibrated map")?;
                let error = after.true_error.ok_or("no true error")?;
                true_rms.push(error.registered_summary().rms * 1e3);
            }
            let case = Case {
                balls,
                predicted: planned.predicted.registered_rms_um,
                true_rms,
            };
            let (mean, sd) = mean_sd(&case.true_rms);
            eprintln!(
                "+-{tilt} deg, {contacts} touches on {balls} balls: predicted {:.2} um, true {mean:.2} +- {sd:.2} um",
                case.predicted
            );
            cases.push(case);
        }
    }

    println!(
        "| tilt | {} |",
        BUDGETS
            .map(|n| format!("{n}: predicted / true (sd)"))
            .join(" | ")
    );
    println!("|---|{}", "---|".repeat(BUDGETS.len()));
    for (t, tilt) in TILTS.iter().enumerate() {
        let row: Vec<String> = cases[t * BUDGETS.len()..(t + 1) * BUDGETS.len()]
            .iter()
            .map(|case| {
                let (mean, sd) = mean_sd(&case.true_rms);
                format!("{:.2} / {mean:.2} ({sd:.2})", case.predicted)
            })
            .collect();
        println!("| +-{tilt} | {} |", row.join(" | "));
    }
    let balls: Vec<String> = cases[..BUDGETS.len()]
        .iter()
        .zip(BUDGETS)
        .map(|(case, n)| format!("{n}: {}", case.balls))
        .collect();
    println!("\nballs touched at +-{}: {}", TILTS[0], balls.join(", "));

    let lines: Vec<(String, Vec<(f64, f64)>)> = TILTS
        .iter()
        .enumerate()
        .flat_map(|(t, tilt)| {
            let row = &cases[t * BUDGETS.len()..(t + 1) * BUDGETS.len()];
            let points = |f: &dyn Fn(&Case) -> f64| {
                BUDGETS
                    .iter()
                    .zip(row)
                    .map(|(&n, case)| (n as f64, f(case)))
                    .collect()
            };
            [
                (format!("+-{tilt} deg predicted"), points(&|c| c.predicted)),
                (
                    format!("+-{tilt} deg true"),
                    points(&|c| mean_sd(&c.true_rms).0),
                ),
            ]
        })
        .collect();
    let series: Vec<Series> = lines
        .iter()
        .map(|(name, points)| Series { name, points })
        .collect();
    line_chart(
        Path::new(&out),
        &LineChart {
            title: "Planned touches of the paper's 27 balls: registered RMS",
            x_label: "touches",
            y_label: "registered RMS / um",
            series: &series,
            log_x: true,
            log_y: true,
        },
    )?;
    eprintln!("wrote {out}");
    Ok(())
}

/// The mean and the sample standard deviation.
fn mean_sd(values: &[f64]) -> (f64, f64) {
    let n = values.len() as f64;
    let mean = values.iter().sum::<f64>() / n;
    let variance = values.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1.0).max(1.0);
    (mean, variance.sqrt())
}
