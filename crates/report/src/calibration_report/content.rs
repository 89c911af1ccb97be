//! What the report of one calibration says, section by section, every
//! number taken from calibration.json (or the accuracy map computed from
//! it): the verdict first, then the tests, the observations, the
//! parameters and the predicted accuracy.

use parcal_calibrate::robust::DOWN_WEIGHTED;
use parcal_dataset::{
    Calibration, GlobalTestRecord, ObservationCheck, ObservationTests, SystematicTestRecord,
};
use parcal_workflows::evaluate::Accuracy;

use super::document::{Block, Cell, Tone};
use super::figures;
use crate::sentences::sensitivity_sentence;

/// The calibration a report is about.
pub struct Subject<'a> {
    /// calibration.json's content.
    pub calibration: &'a Calibration,
    /// Its file, as given.
    pub file: &'a str,
    /// Its accuracy maps, or why there are none.
    pub accuracy: Result<Accuracy, String>,
}

/// The report's title.
pub fn title(subject: &Subject) -> String {
    match &subject.calibration.provenance {
        Some(p) => format!("Calibration report: {}", p.dataset),
        None => format!("Calibration report: {}", subject.file),
    }
}

/// Every block of the report, in order.
pub fn blocks(subject: &Subject) -> Result<Vec<Block>, String> {
    let c = subject.calibration;
    let mut out = vec![Block::Heading(1, title(subject))];
    out.extend(verdict(c));
    out.extend(provenance(subject));
    out.extend(global_test(c));
    out.extend(variance_components(c));
    out.extend(systematic_tests(c));
    out.extend(systematic_sensitivity(c));
    out.extend(removed(c));
    out.extend(down_weighted(c));
    out.extend(observations(c)?);
    out.extend(parameters(c)?);
    out.extend(weak_directions(c));
    out.extend(accuracy(&subject.accuracy)?);
    out.extend(external_reliability(c, &subject.accuracy));
    out.extend(iterations(c));
    Ok(out)
}

/// `n` and the noun in the singular or plural.
fn counted(n: usize, one: &str, many: &str) -> String {
    format!("{n} {}", if n == 1 { one } else { many })
}

fn number(value: f64, decimals: usize) -> Cell {
    Cell::number(format!("{value:.decimals$}"))
}

fn optional(value: Option<f64>, decimals: usize) -> Cell {
    value.map_or(Cell::number("-"), |v| number(v, decimals))
}

/// The verdict in one line, its reasons and the warnings.
fn verdict(c: &Calibration) -> Vec<Block> {
    let (tone, word) = match c.verdict.as_str() {
        "accepted" => (Tone::Accepted, "ACCEPTED"),
        "rejected" => (Tone::Rejected, "REJECTED"),
        _ => (Tone::Rejected, "NO VERDICT"),
    };
    let first = c.reasons.iter().find(|r| {
        // The reason that decided: a failed test when rejected.
        c.verdict != "rejected" || r.contains("failed") || r.starts_with("the solver stopped")
    });
    let line = match (c.verdict.as_str(), first) {
        ("accepted", _) => format!(
            "{word}: the calibration passed its tests ({}, {} below).",
            counted(c.reasons.len(), "reason", "reasons"),
            counted(c.warnings.len(), "warning", "warnings")
        ),
        ("rejected", Some(reason)) => {
            let explained = explaining_effects(c);
            let explained = if explained.is_empty() {
                String::new()
            } else {
                format!(
                    "; explained by a common {} error (Systematic errors, below)",
                    explained.join(" and a common ")
                )
            };
            format!("{word}: do not use this calibration: {reason}{explained}.")
        }
        ("rejected", None) => format!("{word}: do not use this calibration."),
        _ => format!(
            "{word}: this calibration.json was written before verdicts were recorded; its status: {}.",
            c.status
        ),
    };
    let mut out = vec![Block::Paragraph(tone, line)];
    if !c.reasons.is_empty() {
        out.push(Block::Heading(2, "Reasons".into()));
        out.push(Block::List(Tone::Plain, c.reasons.clone()));
    }
    if !c.warnings.is_empty() {
        out.push(Block::Heading(2, "Warnings".into()));
        out.push(Block::List(Tone::Warning, c.warnings.clone()));
    }
    out
}

/// Where the calibration comes from: the dataset, its checksum, the parcal
/// version, the options.
fn provenance(subject: &Subject) -> Vec<Block> {
    let c = subject.calibration;
    let mut rows = vec![vec![
        Cell::text("calibration file"),
        Cell::text(subject.file),
    ]];
    match &c.provenance {
        Some(p) => rows.extend([
            vec![Cell::text("dataset"), Cell::text(&p.dataset)],
            vec![
                Cell::text("dataset checksum"),
                Cell::text(&p.dataset_checksum),
            ],
            vec![Cell::text("parcal version"), Cell::text(&p.parcal_version)],
        ]),
        None => rows.push(vec![
            Cell::text("provenance"),
            Cell::text("not recorded (a file written before provenance was)"),
        ]),
    }
    rows.push(vec![Cell::text("prior"), Cell::text(&c.prior)]);
    rows.extend(c.options.iter().map(|(key, value)| {
        // A string option without its JSON quotes.
        let value = value
            .as_str()
            .map_or_else(|| value.to_string(), str::to_string);
        vec![Cell::text(format!("option {key}")), Cell::text(value)]
    }));
    rows.push(vec![Cell::text("status"), Cell::text(&c.status)]);
    vec![
        Block::Heading(2, "Provenance".into()),
        Block::Table {
            header: vec!["item".into(), "value".into()],
            rows,
        },
    ]
}

/// The global test: variance factor, its interval, the redundancy.
fn global_test(c: &Calibration) -> Vec<Block> {
    let mut out = vec![Block::Heading(2, "Global test".into())];
    let Some(t) = &c.global_test else {
        out.push(Block::Paragraph(
            Tone::Warning,
            "No global test: the run did not converge, or the file predates the test.".into(),
        ));
        return out;
    };
    out.push(Block::Paragraph(Tone::Plain, global_sentence(t)));
    out.push(Block::Table {
        header: vec![
            "weighted sum of squares Ω".into(),
            "redundancy r".into(),
            "variance factor s₀² = Ω/r".into(),
            "interval".into(),
            "level".into(),
            "outcome".into(),
        ],
        rows: vec![vec![
            number(t.cost, 3),
            Cell::number(t.redundancy.to_string()),
            number(t.variance_factor, 3).flagged(t.outcome != "consistent"),
            Cell::number(format!("[{:.3}, {:.3}]", t.interval[0], t.interval[1])),
            Cell::number(format!("{}%", t.level * 100.0)),
            Cell::text(&t.outcome).flagged(t.outcome != "consistent"),
        ]],
    });
    out
}

/// The global test in one sentence.
pub fn global_sentence(t: &GlobalTestRecord) -> String {
    let meaning = match t.outcome.as_str() {
        "consistent" => "the residuals are as large as the stated noise makes them",
        "too large" => {
            "the residuals are larger than the stated noise allows: a blunder, a wrong radius or repeatability, or a model error"
        }
        "too small" => {
            "the residuals are smaller than the stated noise allows: the repeatabilities are pessimistic and the sigmas overstated"
        }
        _ => "the test's outcome is not one parcal writes",
    };
    format!(
        "The a-posteriori variance factor s₀² = {:.3} (Ω = {:.3} over a redundancy of {}) against the two-sided {}% interval [{:.3}, {:.3}] of χ²(r)/r: {} ({meaning}).",
        t.variance_factor,
        t.cost,
        t.redundancy,
        (1.0 - t.level) * 100.0,
        t.interval[0],
        t.interval[1],
        t.outcome
    )
}

/// The variance component of each group, with the group of the largest
/// factor named.
fn variance_components(c: &Calibration) -> Vec<Block> {
    let Some(d) = &c.diagnostics else {
        return vec![];
    };
    if d.variance_components.is_empty() {
        return vec![];
    }
    let rows = d
        .variance_components
        .iter()
        .map(|v| {
            let estimable = v.redundancy >= 1.0;
            let factor = v.cost / v.redundancy;
            vec![
                Cell::text(&v.group),
                number(v.cost, 3),
                number(v.redundancy, 2),
                if estimable {
                    number(factor, 3)
                } else {
                    Cell::number("not estimable")
                },
            ]
        })
        .collect();
    let largest = d
        .variance_components
        .iter()
        .filter(|v| v.redundancy >= 1.0)
        .max_by(|a, b| (a.cost / a.redundancy).total_cmp(&(b.cost / b.redundancy)));
    let mut out = vec![
        Block::Heading(2, "Variance components".into()),
        Block::Table {
            header: vec![
                "group".into(),
                "Ω_g".into(),
                "redundancy r_g".into(),
                "factor Ω_g / r_g".into(),
            ],
            rows,
        },
    ];
    if let Some(v) = largest {
        out.push(Block::Paragraph(
            Tone::Plain,
            format!(
                "About 1 for a group whose stated noise is right. Largest: {} ({:.3}); a factor is not estimable below one redundant observation.",
                v.group,
                v.cost / v.redundancy
            ),
        ));
    }
    out
}

/// The tests of common errors of the entered data, when the global test
/// rejected the run.
fn systematic_tests(c: &Calibration) -> Vec<Block> {
    let tests = systematic_records(c);
    if tests.is_empty() {
        return vec![];
    }
    let explaining = explaining_effects(c);
    let summary = if explaining.is_empty() {
        "No common error of the entered data tested here explains the misfit alone.".to_string()
    } else {
        format!(
            "The misfit is explained by a common error of the entered data: {}. Correct the data and calibrate again.",
            explaining.join(", ")
        )
    };
    vec![
        Block::Heading(2, "Systematic errors".into()),
        Block::Paragraph(
            Tone::Plain,
            format!(
                "The global test rejected the run: each common error below is estimated from the residuals as one more unknown (the correction the data ask for, with its σ), tested at {}% (|w| = |estimate / σ| against its critical value), and removed to see whether the rest fits. {summary}",
                tests[0].level * 100.0
            ),
        ),
        Block::Table {
            header: vec![
                "effect".into(),
                "correction".into(),
                "σ".into(),
                "unit".into(),
                "w".into(),
                "critical value".into(),
                "variance factor without it".into(),
                "outcome without it".into(),
            ],
            rows: tests
                .iter()
                .map(|t| {
                    let w = t.estimate / t.sigma;
                    vec![
                        Cell::text(&t.effect),
                        Cell::number(format!("{:+.3e}", t.estimate)),
                        Cell::number(format!("{:.1e}", t.sigma)),
                        Cell::text(&t.unit),
                        Cell::number(format!("{w:+.2}")).flagged(w.abs() > t.critical_value),
                        number(t.critical_value, 2),
                        number(t.variance_factor_without, 3),
                        Cell::text(&t.outcome_without).flagged(t.outcome_without != "consistent"),
                    ]
                })
                .collect(),
        },
    ]
}

/// How large a common error of the entered data must be to show, and
/// what one that does not show does to the registered error.
fn systematic_sensitivity(c: &Calibration) -> Vec<Block> {
    let records = c
        .diagnostics
        .as_ref()
        .map_or(&[][..], |d| &d.systematic_sensitivity[..]);
    if records.is_empty() {
        return vec![];
    }
    let um = |v: Option<f64>| optional(v, 1);
    vec![
        Block::Heading(2, "Sensitivity to systematic errors".into()),
        Block::Paragraph(
            Tone::Plain,
            format!(
                "A common error of the entered data smaller than its minimal detectable bias passes every test, yet goes into the parameters. For each: that bias (the smallest error its test finds at {}% with {:.0}% power) and the registered error an undetected one of that size adds over the accuracy grid.",
                records[0].level * 100.0,
                records[0].power * 100.0
            ),
        ),
        Block::Table {
            header: vec![
                "effect".into(),
                "minimal detectable bias".into(),
                "unit".into(),
                "σ".into(),
                "registered RMS (um)".into(),
                "registered max (um)".into(),
            ],
            rows: records
                .iter()
                .map(|r| {
                    vec![
                        Cell::text(&r.effect),
                        Cell::number(format!("{:.2e}", r.mdb)),
                        Cell::text(&r.unit),
                        Cell::number(format!("{:.1e}", r.sigma)),
                        um(r.map_rms_um),
                        um(r.map_max_um),
                    ]
                })
                .collect(),
        },
        Block::List(
            Tone::Plain,
            records.iter().map(sensitivity_sentence).collect(),
        ),
    ]
}

/// calibration.json's tests of common errors (none when not recorded).
fn systematic_records(c: &Calibration) -> &[SystematicTestRecord] {
    c.diagnostics
        .as_ref()
        .map_or(&[][..], |d| &d.systematic_tests[..])
}

/// The common errors of the entered data that explain the misfit alone:
/// significant, and the global test passes without them.
fn explaining_effects(c: &Calibration) -> Vec<&str> {
    systematic_records(c)
        .iter()
        .filter(|t| {
            (t.estimate / t.sigma).abs() > t.critical_value && t.outcome_without == "consistent"
        })
        .map(|t| t.effect.as_str())
        .collect()
}

/// The observations a robust loss down-weighted, when it did.
fn down_weighted(c: &Calibration) -> Vec<Block> {
    let listed = &c.down_weighted_observations;
    if listed.is_empty() {
        return vec![];
    }
    let mut sorted: Vec<_> = listed.iter().collect();
    sorted.sort_by(|a, b| a.weight.total_cmp(&b.weight));
    vec![
        Block::Heading(2, "Down-weighted observations".into()),
        Block::Paragraph(
            Tone::Plain,
            format!(
                "The robust loss gave {} a weight under {DOWN_WEIGHTED}, least weight first: likely blunders, kept in the fit with little influence.",
                counted(listed.len(), "observation", "observations")
            ),
        ),
        Block::Table {
            header: vec![
                "file".into(),
                "line".into(),
                "weight".into(),
                "residual / σ".into(),
            ],
            rows: sorted
                .iter()
                .map(|d| {
                    vec![
                        Cell::text(&d.file),
                        line_or_field(d.line, d.field.as_deref()),
                        Cell::number(format!("{:.2e}", d.weight)),
                        number(d.residual_sigmas, 1),
                    ]
                })
                .collect(),
        },
    ]
}

/// The observations data snooping removed.
fn removed(c: &Calibration) -> Vec<Block> {
    let mut out = vec![Block::Heading(2, "Removed observations".into())];
    if c.removed_observations.is_empty() {
        out.push(Block::Paragraph(
            Tone::Plain,
            "No observation was removed (data snooping removes observations only when asked, calibrate --snoop).".into(),
        ));
        return out;
    }
    out.push(Block::Paragraph(
        Tone::Plain,
        format!(
            "Data snooping removed {} observation{}, in this order; the variance factor went from {:.3} to {:.3}.",
            c.removed_observations.len(),
            if c.removed_observations.len() == 1 { "" } else { "s" },
            c.removed_observations[0].variance_factor[0],
            c.removed_observations[c.removed_observations.len() - 1].variance_factor[1]
        ),
    ));
    out.push(Block::Table {
        header: vec![
            "file".into(),
            "line".into(),
            "w".into(),
            "estimated gross error / σ".into(),
            "variance factor before".into(),
            "after".into(),
        ],
        rows: c
            .removed_observations
            .iter()
            .map(|r| {
                vec![
                    Cell::text(&r.file),
                    line_or_field(r.line, r.field.as_deref()),
                    Cell::number(format!("{:+.2}", r.normalised_residual)),
                    Cell::number(format!("{:+.2}", r.gross_error_sigmas)),
                    number(r.variance_factor[0], 3),
                    number(r.variance_factor[1], 3),
                ]
            })
            .collect(),
    });
    out
}

/// A table of observation checks, `critical` the critical value of `|w|`.
fn checks_table(checks: &[ObservationCheck], critical: f64) -> Block {
    Block::Table {
        header: vec![
            "file".into(),
            "line".into(),
            "observes".into(),
            "redundancy r".into(),
            "normalised residual w".into(),
            "estimated gross error / σ".into(),
            "MDB / σ".into(),
        ],
        rows: checks
            .iter()
            .map(|o| {
                let failed = o.normalised_residual.is_some_and(|w| w.abs() > critical);
                vec![
                    Cell::text(&o.file),
                    line_or_field(o.line, o.field.as_deref()),
                    Cell::text(&o.observes),
                    number(o.redundancy, 3),
                    o.normalised_residual
                        .map_or(Cell::number("-"), |w| Cell::number(format!("{w:+.2}")))
                        .flagged(failed),
                    o.gross_error_sigmas
                        .map_or(Cell::number("-"), |g| Cell::number(format!("{g:+.2}"))),
                    optional(o.mdb_sigmas, 1),
                ]
            })
            .collect(),
    }
}

/// The observations' tests: the largest normalised residuals, the
/// uncontrolled observations, the histograms.
fn observations(c: &Calibration) -> Result<Vec<Block>, String> {
    let mut out = vec![Block::Heading(2, "Observations".into())];
    // Only a least-squares minimum is judged (what an older file kept of
    // a run that did not converge is not shown).
    if !c.converged {
        out.push(Block::Paragraph(
            Tone::Warning,
            "The observations were not tested: the run did not converge, and only a least-squares minimum is judged (elsewhere the residuals carry the error the iteration had not yet removed, and would blame good observations).".into(),
        ));
        return Ok(out);
    }
    let Some(t) = c.diagnostics.as_ref().and_then(|d| d.observations.as_ref()) else {
        out.push(Block::Paragraph(
            Tone::Warning,
            "The observations were not tested: calibration.json predates the recorded diagnostics (calibrate again to have them).".into(),
        ));
        return Ok(out);
    };
    out.push(Block::Paragraph(Tone::Plain, tests_sentence(t)));
    out.push(Block::Heading(3, "Largest normalised residuals".into()));
    out.push(checks_table(&t.largest, t.critical_value));
    if t.largest
        .iter()
        .any(|o| o.file == parcal_dataset::MEASUREMENTS_FILE)
    {
        out.push(Block::Paragraph(
            Tone::Note,
            "A contact is tested as one observation: its w is that of its row of largest |w| (its rows' |w| are equal under the coordinate observation), its redundancy the sum over its rows, and its estimated gross error (w / √r) and MDB (minimal detectable bias, at the test's per-observation level and 80% power) follow from that sum, in sigmas of its error along the direction the test sees.".into(),
        ));
    }
    out.push(Block::Heading(3, "Uncontrolled observations".into()));
    out.push(Block::Paragraph(
        Tone::Plain,
        match t.uncontrolled {
            0 => format!(
                "None: every observation has a redundancy number of at least {}.",
                t.uncontrolled_below
            ),
            n => format!(
                "{n} observation{} with a redundancy number under {}: an error in {} goes into the parameters unseen. The {} least controlled:",
                if n == 1 { "" } else { "s" },
                t.uncontrolled_below,
                if n == 1 { "it" } else { "them" },
                t.least_controlled.len()
            ),
        },
    ));
    if !t.least_controlled.is_empty() {
        out.push(checks_table(&t.least_controlled, t.critical_value));
    }
    out.push(figures::normalised_histogram(
        &t.normalised_histogram,
        t.critical_value,
    )?);
    out.push(figures::redundancy_histogram(t)?);
    Ok(out)
}

/// The data-snooping test in one sentence.
pub fn tests_sentence(t: &ObservationTests) -> String {
    let worst = t.largest.first().and_then(|o| {
        o.normalised_residual.map(|w| {
            format!(
                "; the largest |w| is {:.2} at {} {} ({}), {} the critical value",
                w.abs(),
                o.file,
                match (o.line, &o.field) {
                    (Some(line), _) => format!("line {line}"),
                    (None, Some(field)) => field.clone(),
                    (None, None) => String::new(),
                },
                o.observes,
                if w.abs() > t.critical_value {
                    "above"
                } else {
                    "within"
                }
            )
        })
    });
    let mean = if t.tested > 0 {
        t.redundancy / t.tested as f64
    } else {
        f64::NAN
    };
    format!(
        "{} observations tested: normalised residuals w against the critical value {:.2} ({}% family-wise, Bonferroni); redundancy numbers sum to {:.2} (mean {:.3}){}.",
        t.tested,
        t.critical_value,
        t.level * 100.0,
        t.redundancy,
        mean,
        worst.unwrap_or_default()
    )
}

/// The parameter table: value, sigma, prior sigma, what determined it;
/// the correlation matrix.
fn parameters(c: &Calibration) -> Result<Vec<Block>, String> {
    let p = &c.parameters;
    let d = c.diagnostics.as_ref();
    let prior = |k: usize| d.and_then(|d| d.prior_sigma.get(k).copied().flatten());
    let by = |k: usize| {
        d.and_then(|d| d.determined_by.get(k).cloned())
            .unwrap_or_else(|| "-".into())
    };
    let rows = (0..p.names.len())
        .map(|k| {
            let ratio = prior(k).map(|s0| p.sigma[k] / s0);
            vec![
                Cell::text(&p.names[k]),
                number(p.values[k], 4),
                number(p.sigma[k], 4),
                optional(prior(k), 4),
                optional(ratio, 3),
                Cell::text(by(k)),
            ]
        })
        .collect();
    let mut out = vec![
        Block::Heading(2, "Parameters".into()),
        Block::Paragraph(
            Tone::Plain,
            format!(
                "{} parameters ({}), posterior sigma against the prior's: the data determine a parameter whose ratio is under 0.5, the prior one whose ratio is over 0.9.",
                p.names.len(),
                if p.names.len() == parcal_kinematics::N_PARAMS {
                    "mm, canonical frames"
                } else {
                    "mm; actuator scales in mm per unit; frame corrections in rad and mm"
                }
            ),
        ),
        Block::Table {
            header: vec![
                "parameter".into(),
                "value".into(),
                "sigma".into(),
                "prior sigma".into(),
                "sigma / prior sigma".into(),
                "determined by".into(),
            ],
            rows,
        },
    ];
    if c.covariance.is_empty() {
        out.push(Block::Paragraph(
            Tone::Warning,
            "No posterior covariance: the sigmas are not meaningful.".into(),
        ));
    }
    out.extend(figures::correlation(&p.names, &c.covariance)?);
    Ok(out)
}

/// The weakest directions, named by their dominant parameters.
fn weak_directions(c: &Calibration) -> Vec<Block> {
    let Some(d) = c
        .diagnostics
        .as_ref()
        .filter(|d| !d.weak_directions.is_empty())
    else {
        return vec![];
    };
    let rows = d
        .weak_directions
        .iter()
        .map(|w| {
            let along: Vec<String> = w
                .dominant
                .iter()
                .map(|(name, v)| format!("{name} {v:+.2}"))
                .collect();
            vec![
                Cell::number(format!("{:.3e}", w.eigenvalue)),
                w.sigma
                    .map_or(Cell::text("not identified").flagged(true), |s| number(s, 4)),
                Cell::text(along.join(", ")),
            ]
        })
        .collect();
    vec![
        Block::Heading(2, "Weakest directions".into()),
        Block::Paragraph(
            Tone::Plain,
            "The least determined combinations of the parameters (eigenvectors of the reduced normal matrix, smallest eigenvalue first) and the sigma along each, 1/√λ.".into(),
        ),
        Block::Table {
            header: vec![
                "eigenvalue".into(),
                "sigma along it".into(),
                "dominant parameters (components)".into(),
            ],
            rows,
        },
    ]
}

/// The predicted (and, for a simulation, true) accuracy and its map.
fn accuracy(accuracy: &Result<Accuracy, String>) -> Result<Vec<Block>, String> {
    let mut out = vec![Block::Heading(2, "Predicted accuracy".into())];
    let a = match accuracy {
        Ok(a) => a,
        Err(why) => {
            out.push(Block::Paragraph(
                Tone::Note,
                format!("No accuracy map: {why}."),
            ));
            return Ok(out);
        }
    };
    let grid = &a.predicted.grid;
    let summary = |name: &str, map: &parcal_accuracy::AccuracyMap| {
        let (abs, reg) = (map.absolute_summary(), map.registered_summary());
        vec![
            Cell::text(name),
            number(reg.rms * 1e3, 2),
            number(reg.max * 1e3, 2),
            number(abs.rms * 1e3, 2),
            number(abs.max * 1e3, 2),
        ]
    };
    let mut rows = vec![summary("predicted", &a.predicted)];
    if let Some(t) = &a.true_error {
        rows.push(summary("true (simulation)", t));
    }
    let registered = a.predicted.registered_summary();
    out.push(Block::Paragraph(
        Tone::Plain,
        format!(
            "Tool-tip error over {} × {} points of the plane z = {} mm of the design frame, propagated from the posterior covariance: registered RMS {:.2} µm, max {:.2} µm.",
            grid.xs.len(),
            grid.ys.len(),
            grid.z,
            registered.rms * 1e3,
            registered.max * 1e3
        ),
    ));
    out.push(Block::Table {
        header: vec![
            "map".into(),
            "registered RMS / µm".into(),
            "registered max / µm".into(),
            "absolute RMS / µm".into(),
            "absolute max / µm".into(),
        ],
        rows,
    });
    out.push(figures::accuracy_map(&a.predicted)?);
    Ok(out)
}

/// What an undetected blunder of one minimal detectable bias in each of
/// the least reliable observations does to the parameters and to the
/// registered map: a sentence and a table. Nothing for a calibration.json
/// without them.
fn external_reliability(c: &Calibration, accuracy: &Result<Accuracy, String>) -> Vec<Block> {
    let Some(records) = c
        .diagnostics
        .as_ref()
        .map(|d| &d.external_reliability)
        .filter(|r| !r.is_empty())
    else {
        return vec![];
    };
    let p = &c.parameters;
    // The parameter shifted most in its own sigmas.
    let largest = |shift: &[f64]| {
        shift
            .iter()
            .enumerate()
            .filter(|(k, _)| p.sigma.get(*k).is_some_and(|s| *s > 0.0))
            .map(|(k, v)| (k, v / p.sigma[k]))
            .max_by(|a, b| a.1.abs().total_cmp(&b.1.abs()))
    };
    let rows = records
        .iter()
        .map(|e| {
            let o = &e.observation;
            let most = largest(&e.parameter_shift);
            vec![
                Cell::text(&o.file),
                line_or_field(o.line, o.field.as_deref()),
                Cell::text(&o.observes),
                Cell::number(e.row.to_string()),
                number(e.row_redundancy, 3),
                number(e.row_mdb_sigmas, 2),
                number(e.bias_to_noise, 2),
                most.map_or(Cell::text("-"), |(k, v)| {
                    Cell::text(format!("{} {v:+.2}σ", p.names[k]))
                }),
                optional(e.map_rms_um, 2),
                optional(e.map_max_um, 2),
            ]
        })
        .collect();
    let first = &records[0];
    let o = &first.observation;
    let place = match (o.line, &o.field) {
        (Some(line), _) => format!("{} line {line}", o.file),
        (None, Some(field)) => format!("{} {field}", o.file),
        (None, None) => o.file.clone(),
    };
    let mut sentence = format!(
        "An undetected blunder of one minimal detectable bias ({:.2} sigmas) in the least reliable observation, {place} ({}), would shift the parameters by {:.2} of their sigmas (λ)",
        first.row_mdb_sigmas, o.observes, first.bias_to_noise
    );
    match (first.map_rms_um, first.map_max_um) {
        (Some(rms), Some(max)) => {
            sentence += &format!(
                " and the registered tool tip by {rms:.2} µm RMS (max {max:.2} µm) over the accuracy grid"
            );
            if let Ok(a) = accuracy {
                let predicted = a.predicted.registered_summary().rms * 1e3;
                sentence += &format!(
                    ", {:.2} times the predicted registered RMS of {predicted:.2} µm",
                    rms / predicted
                );
            }
        }
        _ => sentence += "; no map: the run did not converge or did not calibrate the tool",
    }
    sentence.push('.');
    let worst_map = records
        .iter()
        .filter_map(|e| e.map_rms_um.map(|rms| (rms, e)))
        .max_by(|a, b| a.0.total_cmp(&b.0));
    if let Some((rms, e)) = worst_map.filter(|(_, e)| !std::ptr::eq(*e, first)) {
        let o = &e.observation;
        sentence += &format!(
            " Of these {}, the largest effect on the map is that of {} {} ({}), {rms:.2} µm RMS.",
            records.len(),
            o.file,
            o.line.map_or_else(
                || o.field.clone().unwrap_or_default(),
                |l| format!("line {l}")
            ),
            o.observes
        );
    }
    vec![
        Block::Heading(2, "External reliability on the accuracy map".into()),
        Block::Paragraph(Tone::Plain, sentence),
        Block::Table {
            header: vec![
                "file".into(),
                "line".into(),
                "observes".into(),
                "row".into(),
                "r (row)".into(),
                "MDB / σ".into(),
                "λ".into(),
                "largest parameter shift".into(),
                "map RMS / µm".into(),
                "map max / µm".into(),
            ],
            rows,
        },
        Block::Paragraph(
            Tone::Note,
            format!(
                "The {} observations of largest bias-to-noise ratio λ; for each, its row of largest λ (a contact's whitened coordinate row, a pose's leg, a point's coordinate, 0-based) with an error of one minimal detectable bias (at the test's per-observation level and 80% power) that increases its whitened residual. That error shifts the parameters by Δp = −Cov u ∇₀ (u the row's reduced row); the map is the registered tool-tip error of a model whose parameters are off by Δp, on the grid of the predicted accuracy. The largest parameter shift is in that parameter's posterior sigmas.",
                records.len()
            ),
        ),
    ]
}

/// The iterations in one sentence.
fn iterations(c: &Calibration) -> Vec<Block> {
    let (Some(first), Some(last)) = (c.iterations.first(), c.iterations.last()) else {
        return vec![];
    };
    vec![
        Block::Heading(2, "Iterations".into()),
        Block::Paragraph(
            Tone::Plain,
            format!(
                "{} iterates recorded, {}: weighted cost {:.6e} -> {:.6e}, residual RMS {:.4} -> {:.4}.",
                c.iterations.len(),
                if c.converged {
                    "converged"
                } else {
                    "not converged"
                },
                first.cost,
                last.cost,
                first.residual_rms,
                last.residual_rms
            ),
        ),
    ]
}

/// The "line" column of an observation: its CSV line, or its JSON field.
fn line_or_field(line: Option<u64>, field: Option<&str>) -> Cell {
    match (line, field) {
        (Some(line), _) => Cell::number(line.to_string()),
        (None, field) => Cell::text(field.unwrap_or("-")),
    }
}
