//! Regression of parcal's calibration on a fixed dataset
//! (fixtures/paper-seed1, written by `parcal simulate --seed 1`): simulation
//! IV with the propagated prior and simulation III with the paper prior,
//! against fixtures/paper-seed1/expected-summary.json.
//!
//! The summary is regenerated (after an intended change of the results) by
//! the ignored test of this file:
//!
//! ```text
//! cargo test -p parcal-workflows --test integration regression:: -- --ignored
//! ```
//!
//! Tolerances (see fixtures/README.md): the computation is deterministic
//! (bit-identical for any number of threads), so they only absorb
//! floating-point differences between platforms and compilers (libm, fused
//! multiply-add): values 1e-6 mm, sigmas 1e-6 relative, final cost 1e-9
//! relative, true registered RMS 1e-6 mm, iterations and convergence exact.

// `!(x <= limit)` fails on NaN too.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use std::io::{self, Write};
use std::path::{Path, PathBuf};

use parcal_accuracy::MapGrid;
use parcal_calibrate::{CalibrationOptions, PriorMode, Simulation, calibrate};
use parcal_dataset::Dataset;
use parcal_kinematics::PARAM_NAMES;
use parcal_workflows::evaluate::{TrueMachine, before_after};
use serde::de::Error as _;
use serde::{Deserialize, Deserializer, Serialize};
use serde_json::Serializer;
use serde_json::ser::{Formatter, PrettyFormatter};
use serde_json::value::RawValue;

const VALUE_TOL: f64 = 1e-6; // mm
const SIGMA_REL_TOL: f64 = 1e-6;
const COST_REL_TOL: f64 = 1e-9;
const RMS_TOL: f64 = 1e-6; // mm

const RUNS: [(Simulation, PriorMode); 2] = [
    (Simulation::IV, PriorMode::Propagated),
    (Simulation::III, PriorMode::Paper),
];

fn fixture() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../fixtures/paper-seed1")
}

fn expected_path() -> PathBuf {
    fixture().join("expected-summary.json")
}

/// The summary file: what it is, its units, and one entry per calibration.
#[derive(Debug, Serialize, Deserialize)]
struct SummaryFile {
    about: String,
    units: String,
    runs: Vec<RunSummary>,
}

/// What the summary records of one calibration.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
struct RunSummary {
    simulation: String,
    prior: String,
    converged: bool,
    /// Gauss-Newton iterations (`CalibrationRun::iterations`).
    iterations: usize,
    /// Cost (data and priors) at the final iterate.
    #[serde(deserialize_with = "exact_f64")]
    final_cost: f64,
    /// True registered error RMS on the paper's map after calibration (mm).
    #[serde(rename = "true_registered_rms_mm", deserialize_with = "exact_f64")]
    true_registered_rms: f64,
    parameters: Vec<Parameter>,
}

/// One identified parameter and its standard deviation (mm).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
struct Parameter {
    name: String,
    #[serde(deserialize_with = "exact_f64")]
    value: f64,
    #[serde(deserialize_with = "exact_f64")]
    sigma: f64,
}

fn summarise(dataset: &Dataset) -> Vec<RunSummary> {
    let truth = TrueMachine::of(dataset)
        .expect("the fixture has its truth")
        .expect("canonical truth");
    RUNS.iter()
        .map(|&(sim, prior)| {
            let options = CalibrationOptions {
                prior,
                ..CalibrationOptions::simulation(sim)
            };
            let run = calibrate(dataset, &options, &mut |_| {}).expect("calibration");
            let maps = before_after(Some(&truth), &run, &MapGrid::paper()).expect("maps");
            let true_registered_rms = maps
                .after
                .and_then(|a| a.true_error)
                .map_or(f64::NAN, |m| m.registered_summary().rms);
            let sigmas = run.sigmas().expect("the calibration has sigmas");
            RunSummary {
                simulation: sim.to_string(),
                prior: prior.to_string(),
                converged: run.converged(),
                iterations: run.iterations(),
                final_cost: run.history.last().map_or(f64::NAN, |r| r.cost),
                true_registered_rms,
                parameters: PARAM_NAMES
                    .iter()
                    .zip(run.params.iter().zip(sigmas.iter()))
                    .map(|(name, (&value, &sigma))| Parameter {
                        name: name.to_string(),
                        value,
                        sigma,
                    })
                    .collect(),
            }
        })
        .collect()
}

// ---- the summary file ----

/// Reads a JSON number with Rust's correctly rounded parser, so that the
/// shortest representation written by [`SummaryFormatter`] reads back to the
/// same f64. serde_json's default parser can miss by an ulp, and its exact
/// one (feature `float_roundtrip`) would also change how parcal-dataset reads
/// the fixture in this test build.
fn exact_f64<'de, D: Deserializer<'de>>(deserializer: D) -> Result<f64, D::Error> {
    let raw = <&RawValue>::deserialize(deserializer)?;
    raw.get().parse().map_err(D::Error::custom)
}

/// serde_json's pretty layout, except that the objects in `parameters` take
/// one line each (`{ "name": "x_b1", "value": …, "sigma": … }`) and numbers
/// are written as Rust's `{:?}`: the shortest representation that reads back
/// to the same f64, as the file has always been written.
struct SummaryFormatter {
    pretty: PrettyFormatter<'static>,
    /// Containers open around the current value.
    depth: usize,
    /// Whether the current object is a parameter, written on one line.
    inline: bool,
}

impl SummaryFormatter {
    /// Root object, `runs`, a run, `parameters`: a parameter opens at depth 4.
    const PARAMETER_DEPTH: usize = 4;
}

impl Formatter for SummaryFormatter {
    fn write_f64<W: ?Sized + Write>(&mut self, writer: &mut W, value: f64) -> io::Result<()> {
        write!(writer, "{value:?}")
    }

    fn begin_array<W: ?Sized + Write>(&mut self, writer: &mut W) -> io::Result<()> {
        self.depth += 1;
        self.pretty.begin_array(writer)
    }

    fn end_array<W: ?Sized + Write>(&mut self, writer: &mut W) -> io::Result<()> {
        self.depth -= 1;
        self.pretty.end_array(writer)
    }

    fn begin_array_value<W: ?Sized + Write>(
        &mut self,
        writer: &mut W,
        first: bool,
    ) -> io::Result<()> {
        self.pretty.begin_array_value(writer, first)
    }

    fn end_array_value<W: ?Sized + Write>(&mut self, writer: &mut W) -> io::Result<()> {
        self.pretty.end_array_value(writer)
    }

    fn begin_object<W: ?Sized + Write>(&mut self, writer: &mut W) -> io::Result<()> {
        self.inline = self.depth == Self::PARAMETER_DEPTH;
        self.depth += 1;
        if self.inline {
            writer.write_all(b"{ ")
        } else {
            self.pretty.begin_object(writer)
        }
    }

    fn end_object<W: ?Sized + Write>(&mut self, writer: &mut W) -> io::Result<()> {
        self.depth -= 1;
        if self.inline {
            self.inline = false;
            writer.write_all(b" }")
        } else {
            self.pretty.end_object(writer)
        }
    }

    fn begin_object_key<W: ?Sized + Write>(
        &mut self,
        writer: &mut W,
        first: bool,
    ) -> io::Result<()> {
        match (self.inline, first) {
            (true, true) => Ok(()),
            (true, false) => writer.write_all(b", "),
            (false, _) => self.pretty.begin_object_key(writer, first),
        }
    }

    fn begin_object_value<W: ?Sized + Write>(&mut self, writer: &mut W) -> io::Result<()> {
        self.pretty.begin_object_value(writer)
    }

    fn end_object_value<W: ?Sized + Write>(&mut self, writer: &mut W) -> io::Result<()> {
        if self.inline {
            Ok(())
        } else {
            self.pretty.end_object_value(writer)
        }
    }
}

fn to_json(runs: &[RunSummary]) -> String {
    for run in runs {
        for x in [run.final_cost, run.true_registered_rms]
            .into_iter()
            .chain(run.parameters.iter().flat_map(|p| [p.value, p.sigma]))
        {
            // serde_json would write null, which does not read back.
            assert!(x.is_finite(), "non-finite value {x} in the summary");
        }
    }
    let file = SummaryFile {
        about: "parcal's calibrations of fixtures/paper-seed1 (parcal simulate --seed 1); \
                regenerate with: cargo test -p parcal-workflows --test integration regression:: -- --ignored"
            .into(),
        units: "values, sigmas, true_registered_rms_mm in mm; final_cost dimensionless (whitened)"
            .into(),
        runs: runs.to_vec(),
    };
    let formatter = SummaryFormatter {
        pretty: PrettyFormatter::new(),
        depth: 0,
        inline: false,
    };
    let mut bytes = Vec::new();
    file.serialize(&mut Serializer::with_formatter(&mut bytes, formatter))
        .expect("the summary serialises");
    bytes.push(b'\n');
    String::from_utf8(bytes).expect("serde_json writes UTF-8")
}

fn from_json(text: &str) -> Vec<RunSummary> {
    serde_json::from_str::<SummaryFile>(text)
        .unwrap_or_else(|e| panic!("expected-summary.json: {e}"))
        .runs
}

// ---- the tests ----

/// The writer gives back the committed summary byte for byte from what the
/// reader takes out of it, so regenerating it changes only the numbers.
#[test]
fn expected_summary_reads_and_writes_back_byte_for_byte() {
    let text = std::fs::read_to_string(expected_path()).expect("expected-summary.json");
    let written = to_json(&from_json(&text));
    assert!(
        written == text,
        "expected-summary.json does not write back as it reads:\n{written}"
    );
}

/// Writes fixtures/paper-seed1/expected-summary.json from the current code.
#[test]
#[ignore = "regenerates the fixture; run after an intended change of the results"]
fn write_expected_summary() {
    let dataset = Dataset::read(&fixture()).expect("fixture dataset");
    let runs = summarise(&dataset);
    for run in &runs {
        assert!(
            run.converged,
            "{} {} did not converge",
            run.simulation, run.prior
        );
    }
    let text = to_json(&runs);
    assert_eq!(
        from_json(&text),
        runs,
        "the summary does not read back exactly"
    );
    std::fs::write(expected_path(), text).expect("write expected-summary.json");
    println!("wrote {}", expected_path().display());
}

#[test]
fn calibrations_of_paper_seed1_match_the_expected_summary() {
    let dataset = Dataset::read(&fixture()).expect("fixture dataset");
    let text = std::fs::read_to_string(expected_path()).expect("expected-summary.json");
    let expected = from_json(&text);
    let actual = summarise(&dataset);
    assert_eq!(expected.len(), actual.len(), "number of runs");
    let mut failures = Vec::new();
    for (e, a) in expected.iter().zip(&actual) {
        let label = format!("{} {}", a.simulation, a.prior);
        assert_eq!(
            (&e.simulation, &e.prior),
            (&a.simulation, &a.prior),
            "run order"
        );
        let names = |run: &RunSummary| -> Vec<String> {
            run.parameters.iter().map(|p| p.name.clone()).collect()
        };
        assert_eq!(names(e), names(a), "{label}: parameter names");
        let pairs = || e.parameters.iter().zip(&a.parameters);
        let worst_value = pairs()
            .map(|(e, a)| (a.value - e.value).abs())
            .fold(0.0, f64::max);
        let worst_sigma = pairs()
            .map(|(e, a)| ((a.sigma - e.sigma) / e.sigma).abs())
            .fold(0.0, f64::max);
        let cost = ((a.final_cost - e.final_cost) / e.final_cost).abs();
        let rms = (a.true_registered_rms - e.true_registered_rms).abs();
        println!(
            "{label}: converged {}, {} iterations (expected {}), final cost {:.12e} (rel diff {cost:.1e}), \
             true registered RMS {:.3} um (diff {:.1e} mm); worst |value diff| {worst_value:.1e} mm, \
             worst sigma rel diff {worst_sigma:.1e}",
            a.converged,
            a.iterations,
            e.iterations,
            a.final_cost,
            1e3 * a.true_registered_rms,
            rms,
        );
        if a.converged != e.converged {
            failures.push(format!(
                "{label}: converged {} (expected {})",
                a.converged, e.converged
            ));
        }
        if a.iterations != e.iterations {
            failures.push(format!(
                "{label}: {} iterations (expected {})",
                a.iterations, e.iterations
            ));
        }
        if !(cost <= COST_REL_TOL) {
            failures.push(format!(
                "{label}: final cost {} (expected {}), rel diff {cost:e}",
                a.final_cost, e.final_cost
            ));
        }
        if !(rms <= RMS_TOL) {
            failures.push(format!(
                "{label}: true registered RMS {} mm (expected {}), diff {rms:e}",
                a.true_registered_rms, e.true_registered_rms
            ));
        }
        for (e, a) in pairs() {
            let dv = (a.value - e.value).abs();
            if !(dv <= VALUE_TOL) {
                failures.push(format!(
                    "{label}: {} = {} (expected {}), diff {dv:e} mm",
                    a.name, a.value, e.value
                ));
            }
            let ds = ((a.sigma - e.sigma) / e.sigma).abs();
            if !(ds <= SIGMA_REL_TOL) {
                failures.push(format!(
                    "{label}: sigma of {} = {} (expected {}), rel diff {ds:e}",
                    a.name, a.sigma, e.sigma
                ));
            }
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

/// The fixture is what its README says: `parcal simulate --seed 1`, i.e.
/// the paper scenario simulated with seed 1.
#[test]
fn fixture_is_the_paper_scenario_seed_1() {
    let fixture = Dataset::read(&fixture()).expect("fixture dataset");
    let simulated = parcal_simulate::simulate(&parcal_simulate::Scenario::paper(), 1)
        .expect("simulation")
        .dataset;
    assert!(
        fixture == simulated,
        "fixtures/paper-seed1 is no longer simulate(Scenario::paper(), 1): regenerate it (fixtures/README.md)"
    );
}
