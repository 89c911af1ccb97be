//! Regression of parcal's calibration on a fixed dataset
//! (fixtures/paper-seed1, written by `parcal simulate --seed 1`): simulation
//! IV with the propagated prior and simulation III with the paper prior,
//! against fixtures/paper-seed1/expected-summary.json.
//!
//! The summary is regenerated (after an intended change of the results) by
//! the ignored test of this file:
//!
//! ```text
//! cargo test -p parcal-calibrate --test regression -- --ignored
//! ```
//!
//! Tolerances (see fixtures/README.md): the computation is deterministic
//! (bit-identical for any number of threads), so they only absorb
//! floating-point differences between platforms and compilers (libm, fused
//! multiply-add): values 1e-6 mm, sigmas 1e-6 relative, final cost 1e-9
//! relative, true registered RMS 1e-6 mm, iterations and convergence exact.

// `!(x <= limit)` fails on NaN too; index loops over several arrays read best.
#![allow(clippy::neg_cmp_op_on_partial_ord, clippy::needless_range_loop)]

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use parcal_accuracy::MapGrid;
use parcal_calibrate::evaluate::{Truth, before_after};
use parcal_calibrate::{CalibrationOptions, PriorMode, Simulation, calibrate};
use parcal_dataset::Dataset;
use parcal_kinematics::PARAM_NAMES;

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

/// What the summary records of one calibration.
#[derive(Debug, Clone, PartialEq)]
struct RunSummary {
    simulation: String,
    prior: String,
    converged: bool,
    /// Gauss-Newton iterations (`CalibrationRun::iterations`).
    iterations: usize,
    /// Cost (data and priors) at the final iterate.
    final_cost: f64,
    /// True registered error RMS on the paper's map after calibration (mm).
    true_registered_rms: f64,
    names: Vec<String>,
    values: Vec<f64>,
    sigmas: Vec<f64>,
}

fn summarise(dataset: &Dataset) -> Vec<RunSummary> {
    let truth = Truth::of(dataset)
        .expect("the fixture has its truth")
        .expect("canonical truth");
    RUNS.iter()
        .map(|&(sim, prior)| {
            let options = CalibrationOptions {
                prior,
                ..CalibrationOptions::simulation(sim)
            };
            let run = calibrate(dataset, &options, &mut |_| {}).expect("calibration");
            let maps = before_after(dataset, Some(&truth), &run, &MapGrid::paper()).expect("maps");
            let true_registered_rms = maps
                .after
                .and_then(|a| a.true_error)
                .map_or(f64::NAN, |m| m.registered_summary().rms);
            RunSummary {
                simulation: sim.to_string(),
                prior: prior.to_string(),
                converged: run.converged(),
                iterations: run.iterations(),
                final_cost: run.history.last().map_or(f64::NAN, |r| r.cost),
                true_registered_rms,
                names: PARAM_NAMES.iter().map(|s| s.to_string()).collect(),
                values: run.params.iter().copied().collect(),
                sigmas: run
                    .sigmas()
                    .map_or_else(Vec::new, |s| s.iter().copied().collect()),
            }
        })
        .collect()
}

// ---- the summary file (a small JSON writer and reader: the crate has no
// JSON dependency) ----

/// Shortest representation that reads back to the same f64 (Rust's `{:?}`),
/// which is also valid JSON for finite values.
fn number(x: f64) -> String {
    assert!(x.is_finite(), "non-finite value {x} in the summary");
    format!("{x:?}")
}

fn to_json(runs: &[RunSummary]) -> String {
    let mut s = String::from("{\n");
    s.push_str("  \"about\": \"parcal's calibrations of fixtures/paper-seed1 (parcal simulate --seed 1); regenerate with: cargo test -p parcal-calibrate --test regression -- --ignored\",\n");
    s.push_str("  \"units\": \"values, sigmas, true_registered_rms_mm in mm; final_cost dimensionless (whitened)\",\n");
    s.push_str("  \"runs\": [\n");
    for (r, run) in runs.iter().enumerate() {
        s.push_str("    {\n");
        let _ = writeln!(s, "      \"simulation\": \"{}\",", run.simulation);
        let _ = writeln!(s, "      \"prior\": \"{}\",", run.prior);
        let _ = writeln!(s, "      \"converged\": {},", run.converged);
        let _ = writeln!(s, "      \"iterations\": {},", run.iterations);
        let _ = writeln!(s, "      \"final_cost\": {},", number(run.final_cost));
        let _ = writeln!(
            s,
            "      \"true_registered_rms_mm\": {},",
            number(run.true_registered_rms)
        );
        s.push_str("      \"parameters\": [\n");
        for k in 0..run.names.len() {
            let _ = writeln!(
                s,
                "        {{ \"name\": \"{}\", \"value\": {}, \"sigma\": {} }}{}",
                run.names[k],
                number(run.values[k]),
                number(run.sigmas[k]),
                if k + 1 < run.names.len() { "," } else { "" }
            );
        }
        s.push_str("      ]\n");
        let _ = writeln!(s, "    }}{}", if r + 1 < runs.len() { "," } else { "" });
    }
    s.push_str("  ]\n}\n");
    s
}

#[derive(Debug, Clone, PartialEq)]
enum Json {
    Null,
    Bool(bool),
    Number(f64),
    String(String),
    Array(Vec<Json>),
    Object(BTreeMap<String, Json>),
}

struct Parser<'a> {
    s: &'a [u8],
    at: usize,
}

impl Parser<'_> {
    fn parse(text: &str) -> Result<Json, String> {
        let mut p = Parser {
            s: text.as_bytes(),
            at: 0,
        };
        let value = p.value()?;
        p.space();
        if p.at != p.s.len() {
            return Err(format!("trailing characters at byte {}", p.at));
        }
        Ok(value)
    }

    fn space(&mut self) {
        while self.at < self.s.len() && self.s[self.at].is_ascii_whitespace() {
            self.at += 1;
        }
    }

    fn eat(&mut self, c: u8) -> Result<(), String> {
        self.space();
        if self.s.get(self.at) == Some(&c) {
            self.at += 1;
            Ok(())
        } else {
            Err(format!("expected '{}' at byte {}", c as char, self.at))
        }
    }

    fn value(&mut self) -> Result<Json, String> {
        self.space();
        match self.s.get(self.at) {
            Some(b'{') => {
                self.at += 1;
                let mut map = BTreeMap::new();
                self.space();
                if self.s.get(self.at) == Some(&b'}') {
                    self.at += 1;
                    return Ok(Json::Object(map));
                }
                loop {
                    self.space();
                    let key = self.string()?;
                    self.eat(b':')?;
                    map.insert(key, self.value()?);
                    self.space();
                    match self.s.get(self.at) {
                        Some(b',') => self.at += 1,
                        Some(b'}') => {
                            self.at += 1;
                            return Ok(Json::Object(map));
                        }
                        _ => return Err(format!("expected ',' or '}}' at byte {}", self.at)),
                    }
                }
            }
            Some(b'[') => {
                self.at += 1;
                let mut items = Vec::new();
                self.space();
                if self.s.get(self.at) == Some(&b']') {
                    self.at += 1;
                    return Ok(Json::Array(items));
                }
                loop {
                    items.push(self.value()?);
                    self.space();
                    match self.s.get(self.at) {
                        Some(b',') => self.at += 1,
                        Some(b']') => {
                            self.at += 1;
                            return Ok(Json::Array(items));
                        }
                        _ => return Err(format!("expected ',' or ']' at byte {}", self.at)),
                    }
                }
            }
            Some(b'"') => self.string().map(Json::String),
            Some(_) => {
                let start = self.at;
                while self.at < self.s.len() && !b",]} \t\r\n".contains(&self.s[self.at]) {
                    self.at += 1;
                }
                let word =
                    std::str::from_utf8(&self.s[start..self.at]).map_err(|e| e.to_string())?;
                match word {
                    "null" => Ok(Json::Null),
                    "true" => Ok(Json::Bool(true)),
                    "false" => Ok(Json::Bool(false)),
                    _ => word
                        .parse::<f64>()
                        .map(Json::Number)
                        .map_err(|e| format!("bad number '{word}' at byte {start}: {e}")),
                }
            }
            None => Err("unexpected end of the file".into()),
        }
    }

    /// A string without escapes other than \" and \\ (all the writer makes).
    fn string(&mut self) -> Result<String, String> {
        self.eat(b'"')?;
        let mut out = Vec::new();
        loop {
            match self.s.get(self.at) {
                None => return Err("unterminated string".into()),
                Some(b'"') => {
                    self.at += 1;
                    return String::from_utf8(out).map_err(|e| e.to_string());
                }
                Some(b'\\') => {
                    out.push(*self.s.get(self.at + 1).ok_or("unterminated escape")?);
                    self.at += 2;
                }
                Some(&c) => {
                    out.push(c);
                    self.at += 1;
                }
            }
        }
    }
}

impl Json {
    fn get(&self, key: &str) -> &Json {
        match self {
            Json::Object(map) => map
                .get(key)
                .unwrap_or_else(|| panic!("expected-summary.json: missing field {key}")),
            _ => panic!("expected-summary.json: {key} looked up in a non-object"),
        }
    }

    fn f64(&self) -> f64 {
        match self {
            Json::Number(x) => *x,
            other => panic!("expected-summary.json: expected a number, found {other:?}"),
        }
    }

    fn str(&self) -> &str {
        match self {
            Json::String(s) => s,
            other => panic!("expected-summary.json: expected a string, found {other:?}"),
        }
    }

    fn bool(&self) -> bool {
        match self {
            Json::Bool(b) => *b,
            other => panic!("expected-summary.json: expected a boolean, found {other:?}"),
        }
    }

    fn array(&self) -> &[Json] {
        match self {
            Json::Array(items) => items,
            other => panic!("expected-summary.json: expected an array, found {other:?}"),
        }
    }
}

fn from_json(text: &str) -> Vec<RunSummary> {
    let root = Parser::parse(text).unwrap_or_else(|e| panic!("expected-summary.json: {e}"));
    root.get("runs")
        .array()
        .iter()
        .map(|run| {
            let parameters = run.get("parameters").array();
            RunSummary {
                simulation: run.get("simulation").str().to_string(),
                prior: run.get("prior").str().to_string(),
                converged: run.get("converged").bool(),
                iterations: run.get("iterations").f64() as usize,
                final_cost: run.get("final_cost").f64(),
                true_registered_rms: run.get("true_registered_rms_mm").f64(),
                names: parameters
                    .iter()
                    .map(|p| p.get("name").str().to_string())
                    .collect(),
                values: parameters.iter().map(|p| p.get("value").f64()).collect(),
                sigmas: parameters.iter().map(|p| p.get("sigma").f64()).collect(),
            }
        })
        .collect()
}

// ---- the tests ----

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
        assert_eq!(e.names, a.names, "{label}: parameter names");
        assert_eq!(a.sigmas.len(), a.names.len(), "{label}: no sigmas");
        let worst_value = (0..a.values.len())
            .map(|k| (a.values[k] - e.values[k]).abs())
            .fold(0.0, f64::max);
        let worst_sigma = (0..a.sigmas.len())
            .map(|k| ((a.sigmas[k] - e.sigmas[k]) / e.sigmas[k]).abs())
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
        for k in 0..a.values.len() {
            let dv = (a.values[k] - e.values[k]).abs();
            if !(dv <= VALUE_TOL) {
                failures.push(format!(
                    "{label}: {} = {} (expected {}), diff {dv:e} mm",
                    a.names[k], a.values[k], e.values[k]
                ));
            }
            let ds = ((a.sigmas[k] - e.sigmas[k]) / e.sigmas[k]).abs();
            if !(ds <= SIGMA_REL_TOL) {
                failures.push(format!(
                    "{label}: sigma of {} = {} (expected {}), rel diff {ds:e}",
                    a.names[k], a.sigmas[k], e.sigmas[k]
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
