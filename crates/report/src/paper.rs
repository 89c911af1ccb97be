//! `parcal paper`: the paper's four simulations (Sato et al. 2004, section
//! 3) on one simulated dataset, in paper mode as the paper states them plus
//! III and IV with the propagated prior, and a report that sets our figures
//! beside the paper's and says where and why they differ.

use std::fmt::Write;
use std::path::Path;

use parcal_calibrate::Simulation;
use parcal_dataset::{Dataset, WriteOptions};
use parcal_kinematics::N_PARAMS;
use parcal_workflows::evaluate::BeforeAfter;
use parcal_workflows::paper::{PAPER_CASES, PaperCase, PaperStudy};

use crate::plots::{LineChart, Series, line_chart};
use crate::{ReportError, maps::write_maps, tables, write_text};

mod findings;

use findings::Findings;

/// The paper's predicted accuracy after III and IV (figs. 7 and 10).
const PAPER_PREDICTED_AFTER: [(Simulation, &str); 2] = [
    (Simulation::III, "0.08 mm (fig. 7)"),
    (Simulation::IV, "0.01 mm (fig. 10)"),
];

/// The stem of a calibration's files: `IV-propagated`.
fn file_stem(case: &PaperCase) -> String {
    format!("{}-{}", case.simulation, case.prior)
}

/// Simulates the paper scenario with `seed`, runs the six calibrations and
/// writes the dataset (replacing `out/dataset`, as a whole), the calibrations,
/// maps, plots and report.md to `out`.
pub fn reproduce(seed: u64, out: &Path, progress: &mut dyn FnMut(&str)) -> Result<(), ReportError> {
    std::fs::create_dir_all(out).map_err(|source| ReportError::Io {
        path: out.to_path_buf(),
        source,
    })?;
    // Every place written is checked before the work: the report's files
    // go beside report.md; the dataset of an earlier run is replaced.
    let dataset_dir = out.join("dataset");
    parcal_dataset::atomic::check_file(&out.join("report.md"))?;
    Dataset::check_target(&dataset_dir, true)?;
    let study = PaperStudy::simulate(seed)?;
    let replace = WriteOptions {
        replace: true,
        ..WriteOptions::default()
    };
    // The files are written for the user; the calibrations use the same
    // values in memory (the format round-trips them bit for bit).
    study.dataset.write_with(&dataset_dir, &replace)?;
    progress(&format!(
        "simulated the paper scenario (seed {seed}): {} contacts",
        study.dataset.measurements.len()
    ));
    let mut calibrate_case = |(simulation, prior)| -> Result<PaperCase, ReportError> {
        let case = study.calibrate(simulation, prior)?;
        progress(&format!(
            "simulation {}: {}",
            case.name(),
            crate::sentences::status(&case.run)
        ));
        crate::record::of_run(&case.run, &study.dataset)
            .write(&out.join(format!("calibration-{}.json", file_stem(&case))))?;
        Ok(case)
    };
    let cases = [
        calibrate_case(PAPER_CASES[0])?,
        calibrate_case(PAPER_CASES[1])?,
        calibrate_case(PAPER_CASES[2])?,
        calibrate_case(PAPER_CASES[3])?,
        calibrate_case(PAPER_CASES[4])?,
        calibrate_case(PAPER_CASES[5])?,
    ];

    let mut pictures = Vec::new();
    for case in &cases {
        let title = format!("Simulation {}", case.name());
        pictures.extend(write_maps(
            out,
            &format!("map-{}-", file_stem(case)),
            &title,
            &case.maps,
        )?);
    }
    write_histories(out, &cases)?;
    progress(&format!(
        "wrote {} accuracy maps and the residual histories",
        pictures.len()
    ));

    let report = report(&study, &cases);
    write_text(&out.join("report.md"), &report)?;
    progress(&format!("report: {}", out.join("report.md").display()));
    Ok(())
}

/// residuals.csv and the SVGs of figs. 5 (I, II) and 8 (III, IV).
fn write_histories(out: &Path, cases: &[PaperCase]) -> Result<(), ReportError> {
    let mut csv =
        String::from("simulation,prior,iteration,cost,weighted_residual_norm,step_norm\n");
    for case in cases {
        for (k, r) in case.run.history.iter().enumerate() {
            let _ = writeln!(
                csv,
                "{},{},{k},{},{},{}",
                case.simulation,
                case.prior,
                r.cost,
                r.cost.sqrt(),
                r.step_norm
            );
        }
    }
    write_text(&out.join("residuals.csv"), &csv)?;
    let norms: Vec<(String, Vec<(f64, f64)>)> = cases
        .iter()
        .map(|c| (c.name(), c.residual_norms()))
        .collect();
    for (file, title, selected) in [
        (
            "residuals-fig5.svg",
            "Residual norm per iteration, no prior (paper fig. 5)",
            [0usize, 1].as_slice(),
        ),
        (
            "residuals-fig8.svg",
            "Residual norm per iteration, with prior (paper fig. 8)",
            [2usize, 3, 4, 5].as_slice(),
        ),
    ] {
        let series: Vec<Series> = selected
            .iter()
            .map(|&k| Series {
                name: &norms[k].0,
                points: &norms[k].1,
            })
            .collect();
        line_chart(
            &out.join(file),
            &LineChart {
                title,
                x_label: "iteration",
                y_label: "weighted residual norm |O|",
                series: &series,
                log_x: false,
                log_y: true,
            },
        )?;
    }
    Ok(())
}

fn report(study: &PaperStudy, cases: &[PaperCase; 6]) -> String {
    let (seed, scenario, truth, grid) = (study.seed, &study.scenario, &study.truth, &study.grid);
    let mut md = String::new();
    let _ = writeln!(
        md,
        "# The paper's simulations I-IV, reproduced (seed {seed})\n"
    );
    let _ = writeln!(
        md,
        "Sato, Shimojima, Furutani, Takamasu, Meas. Sci. Technol. 15 (2004) 1158: table 2's machine, {} balls, {} contacts, \
         {} um actuator and {} um tool repeatability, {} um radius error (1 sigma; docs/paper-scenario.md). Dataset: `dataset/`; \
         each calibration: `calibration-<sim>-<prior>.json`; maps: `map-*.svg` and `map-*accuracy.csv`; residual \
         histories: `residuals.csv`, `residuals-fig5.svg`, `residuals-fig8.svg`. Generated by `parcal paper --seed {seed}`.\n",
        scenario.centres.len(),
        scenario.contacts(),
        micrometres(scenario.actuator_sigma),
        micrometres(scenario.tool_sigma),
        micrometres(scenario.radius_sigma),
    );

    md.push_str("## Convergence (paper figs. 5 and 8)\n\n");
    let _ = writeln!(
        md,
        "| simulation | status | iterations | weighted \\|O\\| first -> last | condition number | NEES ({N_PARAMS}) |\n|---|---|---:|---|---:|---:|"
    );
    for case in cases {
        let run = &case.run;
        let (first, last) = (
            run.history.first().map_or(f64::NAN, |r| r.cost.sqrt()),
            run.history.last().map_or(f64::NAN, |r| r.cost.sqrt()),
        );
        let nees = run
            .covariance
            .as_ref()
            .and_then(|c| truth.nees(&run.params, c));
        let _ = writeln!(
            md,
            "| {} | {} | {} | {first:.2} -> {last:.3} | {} | {} |",
            case.name(),
            crate::sentences::status(run),
            run.iterations(),
            run.condition_number()
                .map_or("-".into(), |c| format!("{c:.2e}")),
            nees.map_or("-".into(), |n| format!("{n:.1}"))
        );
    }
    md.push_str("\n![fig. 5](residuals-fig5.svg)\n![fig. 8](residuals-fig8.svg)\n\n");

    let _ = writeln!(
        md,
        "## Accuracy on the plane z = {} (paper figs. 3, 7, 10), um\n",
        grid.z
    );
    let _ = writeln!(
        md,
        "Predicted: sqrt(trace) of `J_f Sigma_p J_f^T` (prior before, posterior after). True: the true machine commanded by the model. Registered: after the best rigid motion of the {} tips (Kabsch), what a user sees after registering the work frame.\n",
        grid.len()
    );
    let rows: Vec<(String, &BeforeAfter)> = cases.iter().map(|c| (c.name(), &c.maps)).collect();
    let rows: Vec<(&str, &BeforeAfter)> = rows.iter().map(|(n, m)| (n.as_str(), *m)).collect();
    md.push_str(&tables::accuracy(&rows));
    for case in cases
        .iter()
        .filter(|c| c.simulation == Simulation::IV || c.simulation == Simulation::III)
    {
        let stem = file_stem(case);
        let _ = writeln!(
            md,
            "\n{}: ![predicted absolute](map-{stem}-after_predicted_absolute.svg) ![true registered](map-{stem}-after_true_registered.svg)",
            case.name()
        );
    }

    for case in cases
        .iter()
        .filter(|c| c.simulation == Simulation::III || c.simulation == Simulation::IV)
    {
        let table = if case.simulation == Simulation::III {
            "3"
        } else {
            "4"
        };
        let _ = writeln!(
            md,
            "\n## Simulation {} (like the paper's table {table})\n",
            case.name()
        );
        md.push_str(&tables::run_summary(&case.run, Some(truth)));
        md.push('\n');
        md.push_str(&tables::parameters(&case.run, Some(truth)));
    }

    md.push_str("\n## The paper's figures beside ours\n\n");
    md.push_str(&comparison(cases));
    md.push_str("\n### Where and why they differ\n\n");
    md.push_str(&Findings::of(cases, truth).differences());
    md
}

/// A length given in mm, in um, without trailing zeros.
fn micrometres(mm: f64) -> String {
    let fixed = format!("{:.3}", mm * 1e3);
    fixed
        .trim_end_matches('0')
        .trim_end_matches('.')
        .to_string()
}

/// The paper's reported figures (docs/paper-scenario.md, section 4) next to ours, and
/// where and why they differ.
fn comparison(cases: &[PaperCase; 6]) -> String {
    let [i, ii, iii, iv, _, iv_propagated] = cases.each_ref();
    let um = |v: f64| format!("{:.1} um", v * 1e3);
    let predicted_after = |c: &PaperCase| {
        c.maps.after.as_ref().map_or("-".into(), |a| {
            format!("{} RMS", um(a.predicted.absolute_summary().rms))
        })
    };
    let true_registered = |c: &PaperCase| {
        c.maps
            .after
            .as_ref()
            .and_then(|a| a.true_error.as_ref())
            .map_or("-".into(), |t| um(t.registered_summary().rms))
    };
    let before = iii.maps.before.as_ref().map_or("-".into(), |a| {
        format!("{} RMS", um(a.predicted.absolute_summary().rms))
    });
    let status = |c: &PaperCase| {
        format!(
            "{} ({} iterations)",
            crate::sentences::status(&c.run),
            c.run.iterations()
        )
    };
    let sigma_range = |c: &PaperCase| {
        c.run
            .sigmas()
            .map_or("-".into(), |s| format!("{:.3}-{:.3} mm", s.min(), s.max()))
    };
    let mut md = String::new();
    md.push_str("| quantity | paper | parcal |\n|---|---|---|\n");
    let _ = writeln!(
        md,
        "| I (radius, no prior) | diverges (fig. 5) | {} |",
        status(i)
    );
    let _ = writeln!(
        md,
        "| II (coordinates, no prior) | diverges (fig. 5) | {} |",
        status(ii)
    );
    let _ = writeln!(
        md,
        "| III, IV (paper prior) | converge in a few steps (fig. 8) | {}; {} |",
        status(iii),
        status(iv)
    );
    let _ = writeln!(
        md,
        "| predicted accuracy before calibration (paper prior) | about 0.1 mm (fig. 3) | {before} |"
    );
    for (case, (sim, theirs)) in [iii, iv].into_iter().zip(PAPER_PREDICTED_AFTER) {
        let _ = writeln!(
            md,
            "| predicted accuracy after {sim} | {theirs} | {} |",
            predicted_after(case)
        );
    }
    for (case, table) in [(iii, 3), (iv, 4)] {
        let _ = writeln!(
            md,
            "| posterior sigmas, {} | 0.06-0.09 mm (table {table}) | {} |",
            case.simulation,
            sigma_range(case)
        );
    }
    let _ = writeln!(
        md,
        "| true registered accuracy after IV | not reported | paper prior {}, propagated prior {} RMS |",
        true_registered(iv),
        true_registered(iv_propagated)
    );
    md
}
