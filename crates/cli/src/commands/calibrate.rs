//! `parcal calibrate`: identify the parameters of a dataset, print the
//! table and the accuracy summary, write calibration.json.

use std::io::Write;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use anyhow::Context;
use parcal::accuracy::MapGrid;
use parcal::calibration::mechanism::MechanismOptions;
use parcal::calibration::{
    CalibrateError, CalibrationRun, IterationRecord, Loss, Observation, PriorMode, RadiusModel,
    Simulation, WeightModel, bounds,
};
use parcal::command::{CalibrateFlags, RecordedRun, calibrate_recorded, common_calibration};
use parcal::dataset::{CALIBRATION_FILE, HEXAPOD, MEASUREMENTS_FILE, ReadOptions};
use parcal::report::{instruments, tables};
use parcal::report_pages::{MechanismTrue, hexapod_truth};
use parcal::workflows::evaluate::{TrueMachine, before_after};

use super::{ReportRequest, report};
use crate::bounds::Bounded;
use crate::progress::Progress;

#[derive(clap::Args)]
pub struct Args {
    /// Dataset directory, or a binary snapshot file (dataset.bin).
    dataset: PathBuf,
    /// One of the paper's simulations (observation and paper-mode prior);
    /// --observation and --prior override its parts.
    #[arg(long, value_enum, ignore_case = true)]
    sim: Option<Simulation>,
    /// Observation equation of the ball touches: radius (paper eq. 9) or
    /// transformed coordinates (eq. 10); another mechanism's default is
    /// radius.
    #[arg(long, value_enum)]
    observation: Option<Observation>,
    /// A priori knowledge (paper eq. 7): the paper's diagonal form, the design
    /// tolerances propagated to the canonical parameters (default), or none.
    #[arg(long, value_enum)]
    prior: Option<PriorMode>,
    /// Observation weights: repeatabilities propagated through the kinematics, or a plain diagonal.
    #[arg(long, value_enum, default_value = "propagated")]
    weights: WeightModel,
    /// The calibrated radius's error: one per ball, each ball's radius an
    /// unknown with its calibration as prior (the default), or independent
    /// per contact in the weights (paper eq. 5, the default of --sim).
    #[arg(long, value_enum)]
    radius: Option<RadiusModel>,
    /// Levenberg-Marquardt instead of the paper's Gauss-Newton (eq. 5).
    #[arg(long)]
    lm: bool,
    /// Iteration limit (default 50 for Gauss-Newton, 200 for
    /// Levenberg-Marquardt or a robust --loss); a Gauss-Newton run that
    /// runs away is made again with Levenberg-Marquardt, of four times
    /// this limit, at most 200.
    #[arg(long, value_parser = Bounded(bounds::MAX_ITERATIONS))]
    max_iterations: Option<usize>,
    /// Wall-clock budget of the calibration, seconds: when it has passed the
    /// run stops at its current iterate ("time limit reached", rejected).
    #[arg(long, value_name = "SECONDS", value_parser = seconds)]
    time_limit: Option<Duration>,
    /// Data snooping: remove the observation (contact, distance, pose or
    /// point) of largest normalised residual while it fails the test at 5%
    /// family-wise, at most 10 (calibration.json lists them under
    /// removed_observations).
    #[arg(long)]
    snoop: bool,
    /// The loss of each observation: squared (least squares), huber[:K]
    /// (K default 1.345) or cauchy[:K] (K default 2.385), K in units of the
    /// observation's standard deviation, solved by iteratively reweighted
    /// least squares; a robust loss replaces --snoop (calibration.json
    /// lists the observations it down-weighted under
    /// down_weighted_observations).
    #[arg(long, value_name = "LOSS", default_value = "squared")]
    loss: Loss,
    /// Where to write calibration.json (default: calibration.json in the
    /// dataset's directory). A rejected calibration goes to
    /// NAME.rejected.json beside it instead, leaving this file as it was.
    #[arg(long)]
    out: Option<PathBuf>,
    /// Also write the calibration's report (report.html and report.md, as
    /// `parcal report` does) into the directory of calibration.json; a
    /// rejected calibration's as report.rejected.html and .md, leaving an
    /// accepted one's as it was.
    #[arg(long)]
    report: bool,
    /// Calibrate a hexapod's ball touches by the common calibration of
    /// every mechanism, through its interface (docs/mechanisms.md), rather
    /// than by its own, under the same options, written as a mechanism's
    /// calibration.json.
    #[arg(long)]
    common: bool,
}

impl Args {
    /// The flags that shape the calibration.
    fn flags(&self) -> CalibrateFlags {
        CalibrateFlags {
            sim: self.sim,
            observation: self.observation,
            prior: self.prior,
            weights: self.weights,
            radius: self.radius,
            lm: self.lm,
            max_iterations: self.max_iterations,
            time_limit: self.time_limit,
            snoop: self.snoop,
            loss: self.loss,
        }
    }
}

pub fn run(args: &Args) -> anyhow::Result<()> {
    if let Some(mechanism) = super::mechanism::declared(&args.dataset)? {
        if args.common {
            anyhow::bail!(
                "{}: --common calibrates a hexapod's touches by the {mechanism}'s calibration, which this dataset has already",
                args.dataset.display()
            );
        }
        let (request, options) = args.mechanism_options()?;
        return super::mechanism::calibrate(&mechanism, request, &options);
    }
    if args.common {
        return calibrate_common(args);
    }
    let flags = args.flags();
    let options = flags.options();
    let progress = Progress::bar("iteration", options.max_iterations as u64);
    let read = Instant::now();
    // A simulation's true contact points serve no calibration: skipped.
    let without_true_contacts = ReadOptions {
        true_contacts: false,
        ..ReadOptions::default()
    };
    let mut dataset = super::read_dataset_with(&args.dataset, &without_true_contacts)?;
    let out = args.out_path();
    super::check_calibration_outputs(&args.dataset, &out)?;
    args.report_request(&out, None)
        .map(|request| request.check(&args.dataset, &out))
        .transpose()?;
    let tracker = &dataset.tracker;
    // A simulation's true machine serves the evaluation, not the
    // calibration: keep it, and free the dataset's truth.json with its true
    // contact points (24 bytes per contact).
    let truth = if !dataset.has_touches() {
        progress.line(&format!(
            "calibrating {} poses and {} points in {} sessions, {} prior",
            tracker.poses.len(),
            tracker.points.len(),
            tracker.sessions.len(),
            options.prior
        ));
        None
    } else {
        let truth = TrueMachine::of(&dataset)
            .transpose()
            .context("truth.json: the true geometry is degenerate")?;
        progress.line(&format!(
            "read {} contacts in {:.2} s",
            dataset.measurements.q.len(),
            read.elapsed().as_secs_f64()
        ));
        progress.line(&format!(
            "calibrating {} contacts: {} observation, {} prior, radius error per {}, {} loss",
            dataset.measurements.q.len(),
            options.observation,
            options.prior,
            options.radius,
            options.loss
        ));
        if !tracker.is_empty() {
            progress.line(&format!(
                "  with {} poses and {} points in {} sessions",
                tracker.poses.len(),
                tracker.points.len(),
                tracker.sessions.len()
            ));
        }
        dataset.truth = None;
        truth
    };
    let started = Instant::now();
    let observer = &mut |record: &IterationRecord| progress.iteration(record, started);
    let RecordedRun { run, record, .. } = calibrate_recorded(&dataset, &flags, observer)
        .map_err(|error| in_dataset(error, &args.dataset))?;
    progress.finish();
    // A reader that closed stdout early does not hide a rejected
    // calibration.
    let report = args.report_request(&out, truth.as_ref());
    let destination = super::calibration_destination(&record, &out);
    let printed = if run.has_touches() {
        print_results(truth.as_ref(), &run, &record)
    } else {
        print_instruments(&run, &record)
    };
    let rejected =
        super::write_calibration(record, &dataset, &args.dataset, &out, report.as_ref())?;
    // Said once the files are there, not before.
    let printed =
        printed.and_then(|()| print_written(&destination, rejected.is_some(), report.as_ref()));
    match rejected {
        Some(rejected) => Err(rejected.into()),
        None => printed,
    }
}

/// `parcal calibrate --common`: the hexapod's ball touches by the common
/// calibration ([`MechanismData::from_hexapod_touches`] under the options
/// the flags give), what it does not model refused by name.
fn calibrate_common(args: &Args) -> anyhow::Result<()> {
    let request = args.mechanism_request();
    request.check_outputs()?;
    let started = Instant::now();
    let without_true_contacts = ReadOptions {
        true_contacts: false,
        ..ReadOptions::default()
    };
    let dataset = super::read_dataset_with(&args.dataset, &without_true_contacts)?;
    let read = format!(
        "read the dataset in {:.2} s",
        started.elapsed().as_secs_f64()
    );
    let converting = Instant::now();
    let (data, options) = common_calibration(&dataset, &args.flags())
        .map_err(|error| anyhow::anyhow!("{}: --common: {error}", args.dataset.display()))?;
    let converted = format!(
        "made {} observations of it, with the hexapod calibration's start and weights, in {:.2} s",
        data.observations.len(),
        converting.elapsed().as_secs_f64()
    );
    let trackers: Vec<&str> = (data.observations.trackers.iter())
        .map(|t| t.label.as_str())
        .collect();
    let truth = hexapod_truth(&dataset, data.mechanism.parameters().len(), &trackers)
        .map_err(|error| anyhow::anyhow!("{}: {error}", args.dataset.display()))?;
    let checksum = dataset.checksum();
    // The touches are in `data`: the dataset's memory is the room of the
    // calibration's, given back as it starts.
    let freeing = super::mechanism::free_beside(dataset);
    let from_dataset = MechanismTrue::from_dataset(truth.as_ref(), None);
    let calibrated = super::mechanism::calibrate_with(
        HEXAPOD,
        data,
        &options,
        from_dataset,
        request,
        super::mechanism::DatasetRead {
            said: &[read, converted],
            checksum,
        },
    );
    super::mechanism::freed(freeing, "the dataset")?;
    calibrated
}

/// A number of seconds, finite and not negative.
fn seconds(text: &str) -> Result<Duration, String> {
    let seconds: f64 = text.parse().map_err(|e| format!("{e}"))?;
    Duration::try_from_secs_f64(seconds)
        .map_err(|_| format!("{text} is not a finite, non-negative number of seconds"))
}

/// The summary and parameter table of a calibration of measured poses and
/// points alone on stdout.
fn print_instruments(
    run: &CalibrationRun,
    record: &parcal::dataset::Calibration,
) -> anyhow::Result<()> {
    let mut stdout = std::io::stdout().lock();
    writeln!(
        stdout,
        "{}\n{}",
        instruments::summary(run, record),
        instruments::parameters(run),
    )?;
    Ok(())
}

impl Args {
    /// The options of a mechanism dataset's calibration; an error naming
    /// an option given that only the hexapod's calibration has.
    fn mechanism_options(
        &self,
    ) -> anyhow::Result<(super::mechanism::CalibrateRequest, MechanismOptions)> {
        let hexapod_only = [
            ("--sim", self.sim.is_some()),
            ("--prior", self.prior.is_some()),
            ("--weights", self.weights != WeightModel::default()),
            ("--radius", self.radius.is_some()),
        ];
        if let Some((flag, _)) = hexapod_only.iter().find(|(_, given)| *given) {
            anyhow::bail!(
                "{}: {flag} applies to a hexapod's calibration, not to this mechanism's (its options: --observation, --snoop, --loss, --lm, --max-iterations, --time-limit, --out, --report)",
                self.dataset.display()
            );
        }
        let observation = self.observation.unwrap_or(Observation::Radius);
        let options = self.flags().mechanism_options();
        Ok((
            self.mechanism_request(),
            options.with_observation(observation),
        ))
    }

    /// What a mechanism's calibration (and a hexapod's through the common
    /// one) takes of the flags.
    fn mechanism_request(&self) -> super::mechanism::CalibrateRequest {
        super::mechanism::CalibrateRequest {
            dataset: self.dataset.clone(),
            out: self.out_path(),
            report: self.report,
        }
    }

    /// calibration.json's path: --out, or calibration.json in the
    /// dataset's directory (next to a snapshot file).
    fn out_path(&self) -> PathBuf {
        let directory = if self.dataset.is_file() {
            self.dataset.parent().unwrap_or(Path::new("."))
        } else {
            &self.dataset
        };
        self.out
            .clone()
            .unwrap_or_else(|| directory.join(CALIBRATION_FILE))
    }

    /// With `--report`, the report beside calibration.json `out`, with the
    /// simulation's `truth` if any.
    fn report_request<'a>(
        &self,
        out: &Path,
        truth: Option<&'a TrueMachine>,
    ) -> Option<ReportRequest<'a>> {
        self.report.then(|| ReportRequest {
            directory: report::directory_of(out).to_path_buf(),
            truth,
        })
    }
}

/// Where the calibration (`rejected` or not) and its `report` went, on
/// stdout.
fn print_written(
    calibration: &Path,
    rejected: bool,
    report: Option<&ReportRequest>,
) -> anyhow::Result<()> {
    let mut stdout = std::io::stdout().lock();
    writeln!(stdout, "calibration written to {}", calibration.display())?;
    if let Some(request) = report {
        writeln!(
            stdout,
            "report written to {}",
            report::listed(&request.paths(rejected))
        )?;
    }
    Ok(())
}

/// `error` with the file of its row in front, if it names one: the line of
/// measurements.csv, poses.csv or points.csv (row + 2, the header is line
/// 1), or the snapshot file.
fn in_dataset(error: CalibrateError, dataset: &Path) -> anyhow::Error {
    let (file, row) = match (error.row(), error.instrument_row()) {
        (Some(row), _) => (MEASUREMENTS_FILE, row),
        (None, Some((table, row))) => (table.file_name(), row),
        (None, None) => return error.into(),
    };
    let place = if dataset.is_file() {
        dataset.display().to_string()
    } else {
        let csv = dataset.join(file);
        format!("{} line {}", csv.display(), row + 2)
    };
    anyhow::Error::new(error).context(place)
}

/// The summary, the parameter table, the accuracy and the verdict of `run`
/// on stdout.
fn print_results(
    truth: Option<&TrueMachine>,
    run: &CalibrationRun,
    record: &parcal::dataset::Calibration,
) -> anyhow::Result<()> {
    let maps = before_after(truth, run, &MapGrid::paper()).context("accuracy map")?;
    let mut stdout = std::io::stdout().lock();
    writeln!(stdout, "{}", tables::run_summary(run, truth))?;
    writeln!(stdout, "{}", tables::parameters(run, truth))?;
    if run.instruments.is_some() {
        writeln!(stdout, "{}", instruments::mixed_summary(run))?;
    }
    writeln!(
        stdout,
        "accuracy on the plane z = 400 of the design frame, um:"
    )?;
    writeln!(stdout)?;
    writeln!(
        stdout,
        "{}",
        tables::accuracy(&[("this calibration", &maps)])
    )?;
    writeln!(stdout, "verdict: {}", record.verdict)?;
    for line in record.reasons.iter().chain(&record.warnings) {
        writeln!(stdout, "  {line}")?;
    }
    Ok(())
}
