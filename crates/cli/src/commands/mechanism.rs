//! The commands on a mechanism dataset (machine.json naming a mechanism
//! other than the hexapod, docs/delta.md), or on a hexapod's ball touches
//! by the same calibration (`parcal calibrate --common`): its
//! calibration, written as calibration.json with its report if asked, and
//! the summary printed.

use std::collections::BTreeSet;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::thread::JoinHandle;
use std::time::Instant;

use parcal::calibration::mechanism::{
    MechanismCalibrationError, MechanismData, MechanismOptions, ObservationKind,
    calibrate_mechanism, check_mechanism_data, repeat_warnings,
};
use parcal::calibration::{IterationRecord, Method};
use parcal::dataset::atomic::write_set;
use parcal::dataset::mechanism::{MACHINE_FILE, MechanismCalibrationRecord, MechanismDataset};
use parcal::dataset::{HEXAPOD, declared_mechanism};
use parcal::report::mechanism::{
    FromDataset, counted, identifiability_statements, mirrored_sentences, observation_counts,
    parameter_header, parameter_rows, prior_correlation_sentence, removal_sentences,
    run_away_sentence, touch_equation, verdict_sentence,
};
use parcal::report::mechanism_validation::{observation_row_place, placed_error};
use parcal::report_pages::{MechanismTrue, mechanism_truth};

use crate::progress::Progress;

/// The mechanism a dataset directory's machine.json names, `None` for a
/// hexapod's dataset (or a snapshot file, always a hexapod's).
pub fn declared(dataset: &Path) -> anyhow::Result<Option<String>> {
    if dataset.is_file() {
        return Ok(None);
    }
    let machine = dataset.join(MACHINE_FILE);
    if !machine.exists() {
        return Ok(None);
    }
    Ok(declared_mechanism(&machine)?.filter(|name| name != HEXAPOD))
}

/// What `parcal calibrate` asks of a mechanism dataset.
pub struct CalibrateRequest {
    /// The dataset directory.
    pub dataset: PathBuf,
    /// Where calibration.json goes (a rejected one beside it).
    pub out: PathBuf,
    /// Also write report.html and report.md beside it.
    pub report: bool,
}

/// Calibrates the mechanism dataset of `request` with `options`: shows
/// the iterations on stderr, prints the summary, writes calibration.json
/// (and its report) atomically, and turns a rejected verdict into
/// [`super::Rejected`].
pub fn calibrate(
    mechanism: &str,
    request: CalibrateRequest,
    options: &MechanismOptions,
) -> anyhow::Result<()> {
    request.check_outputs()?;
    let read = Instant::now();
    let path = &request.dataset;
    let dataset = MechanismDataset::read(path)?;
    let data =
        MechanismData::from_dataset(&dataset).map_err(|error| placed(path, mechanism, &error))?;
    let truth = mechanism_truth(&dataset, &data)
        .map_err(|error| anyhow::anyhow!("{}: {error}", path.display()))?;
    let from_dataset = MechanismTrue::from_dataset(truth.as_ref(), Some(&dataset));
    let read = format!(
        "read {} observations in {:.2} s",
        data.observations.len(),
        read.elapsed().as_secs_f64()
    );
    let read = DatasetRead {
        said: &[read],
        checksum: dataset.checksum(),
    };
    calibrate_with(mechanism, data, options, from_dataset, request, read)
}

/// `parcal inspect` on the mechanism dataset `path`: read, converted and
/// every observation evaluated at the start a calibration takes
/// ([`check_mechanism_data`], the first failure named), then summarised:
/// the mechanism, the observations of each kind, the balls, the trigger
/// height, whether a truth is given.
pub fn inspect(path: &Path, mechanism: &str) -> anyhow::Result<()> {
    let dataset = MechanismDataset::read(path)?;
    let data = MechanismData::from_dataset(&dataset)
        .and_then(|data| check_mechanism_data(&data).map(|()| data))
        .map_err(|error| placed(path, mechanism, &error))?;
    let o = &data.observations;
    let mut stdout = std::io::stdout().lock();
    writeln!(stdout, "dataset {}", path.display())?;
    let held = data.priors.iter().filter(|p| p.sigma.is_some()).count();
    writeln!(
        stdout,
        "  mechanism          {mechanism}: {} actuators, {} parameters ({held} with a prior)",
        data.mechanism.actuators().len(),
        data.priors.len()
    )?;
    let counts: Vec<(&str, usize)> = ObservationKind::ALL
        .iter()
        .map(|&kind| (kind.name(), o.count(kind)))
        .filter(|&(_, n)| n > 0)
        .collect();
    writeln!(
        stdout,
        "  observations       {}",
        counted(&counts).join(", ")
    )?;
    let place = |observation, row| observation_row_place(mechanism, observation, row);
    for warning in repeat_warnings(&o.repeats(), &place) {
        writeln!(stdout, "  warning: {warning}")?;
    }
    if !o.balls.is_empty() {
        let mut per_ball = vec![0usize; o.balls.len()];
        for touch in &o.touches {
            per_ball[touch.ball] += 1;
        }
        let least = per_ball.iter().min().unwrap_or(&0);
        let most = per_ball.iter().max().unwrap_or(&0);
        let tied: BTreeSet<usize> = o
            .ball_distances
            .iter()
            .flat_map(|d| [d.first, d.second])
            .collect();
        let tied = tied.len();
        writeln!(
            stdout,
            "  balls              {} ({least} .. {most} touches a ball; {tied} tied by distances)",
            o.balls.len()
        )?;
    }
    if !o.probes.is_empty() {
        let h = &data.trigger_height;
        let sigma = h.sigma.map_or("none".to_string(), |s| format!("{s} mm"));
        writeln!(
            stdout,
            "  trigger height     {} mm (prior sigma {sigma})",
            h.mean
        )?;
    }
    let truth = if dataset.truth.is_some() { "yes" } else { "no" };
    writeln!(stdout, "  truth              {truth}")?;
    writeln!(
        stdout,
        "  start              every observation evaluates at the design (the priors' means)"
    )?;
    Ok(())
}

/// `error` of a calibration of the `mechanism`'s dataset at `path`, an
/// observation's placed by its file and line ([`placed_error`]).
fn placed(path: &Path, mechanism: &str, error: &MechanismCalibrationError) -> anyhow::Error {
    anyhow::anyhow!(
        "{}: the {mechanism}: {}",
        path.display(),
        placed_error(mechanism, error)
    )
}

impl CalibrateRequest {
    /// Refuses outputs that would overwrite an input (calibration.json,
    /// the report's files).
    pub fn check_outputs(&self) -> anyhow::Result<()> {
        super::check_calibration_outputs(&self.dataset, &self.out)?;
        if self.report {
            let directory = super::report::directory_of(&self.out);
            crate::outputs::check(
                &crate::outputs::dataset_inputs(&self.dataset),
                &super::report::either_verdicts_report_paths(directory),
            )?;
        }
        Ok(())
    }
}

/// `value` dropped beside the work that follows (a million touches'
/// memory given back page by page), on a thread of its own when one can
/// be had, else here (the failed spawn drops it); [`freed`] waits for it.
pub fn free_beside<T: Send + 'static>(value: T) -> Option<JoinHandle<()>> {
    std::thread::Builder::new()
        .name("parcal-free".to_string())
        .spawn(move || drop(value))
        .ok()
}

/// Waits for `what` dropped by [`free_beside`].
pub fn freed(freeing: Option<JoinHandle<()>>, what: &str) -> anyhow::Result<()> {
    match freeing {
        Some(freeing) => (freeing.join()).map_err(|_| anyhow::anyhow!("freeing {what} panicked")),
        None => Ok(()),
    }
}

/// What reading a dataset gave besides its data: the progress lines that
/// say what was read and made (with its time), and the dataset's checksum
/// (the calibration's provenance).
pub struct DatasetRead<'a> {
    /// The progress lines.
    pub said: &'a [String],
    /// The dataset's checksum.
    pub checksum: String,
}

/// The common calibration of `data` under `options`, read from the
/// dataset of `request` (its probes and manual heights, if any, drawn in
/// the report), what reading it gave in `read` (its progress lines shown
/// first): as [`calibrate`], once the outputs are checked
/// ([`CalibrateRequest::check_outputs`]).
pub fn calibrate_with(
    mechanism: &str,
    data: MechanismData,
    options: &MechanismOptions,
    from_dataset: FromDataset<'_>,
    request: CalibrateRequest,
    read: DatasetRead<'_>,
) -> anyhow::Result<()> {
    let CalibrateRequest {
        dataset: path,
        out,
        report,
    } = request;
    let report_directory = report.then(|| super::report::directory_of(&out).to_path_buf());
    let progress = Progress::bar("iteration", options.max_iterations as u64);
    for line in read.said {
        progress.line(line);
    }
    let touches = match data.observations.touches.is_empty() {
        true => String::new(),
        false => format!(
            ", ball touches{}",
            touch_equation(&options.observation.to_string())
        ),
    };
    progress.line(&format!(
        "calibrating the {mechanism}: {}, {} loss{}{touches}",
        match options.method {
            Method::GaussNewton => "Gauss-Newton",
            Method::LevenbergMarquardt { .. } => "Levenberg-Marquardt",
        },
        options.loss,
        if options.snoop { ", data snooping" } else { "" }
    ));
    let started = Instant::now();
    let observer = &mut |record: &IterationRecord| progress.iteration(record, started);
    let mut calibration = calibrate_mechanism(&data, options, observer)
        .map_err(|error| placed(&path, mechanism, &error))?;
    progress.finish();
    let freeing = free_beside(data);
    calibration
        .place_observations(&|observation, row| observation_row_place(mechanism, observation, row));
    let mut record = calibration.into_record();
    record.provenance = Some(parcal::command::provenance(
        read.checksum,
        &path.display().to_string(),
    ));
    let destination = if record.accepted {
        out.clone()
    } else {
        super::rejected_path(&out)
    };
    let file = destination.display().to_string();
    let report_paths = (report_directory.as_deref())
        .map(|directory| super::report::calibration_report_paths(directory, !record.accepted));
    write_set(&[], || -> anyhow::Result<()> {
        record.write(&destination)?;
        match &report_paths {
            Some(paths) => {
                super::report::write_mechanism_report(&record, &file, from_dataset, paths)
            }
            None => Ok(()),
        }
    })?;
    freed(freeing, "the mechanism data")?;
    let mut stdout = std::io::stdout().lock();
    print_summary(&record, from_dataset.truth, &mut stdout)?;
    writeln!(stdout, "calibration written to {file}")?;
    if let Some(paths) = &report_paths {
        writeln!(stdout, "report written to {}", super::report::listed(paths))?;
    }
    if !record.accepted {
        return Err(super::Rejected(format!(
            "{} (written to {file}; export refuses it without --accept-rejected)",
            record.reasons.join("; ")
        ))
        .into());
    }
    Ok(())
}

/// The summary of a mechanism calibration: the verdict with its tests,
/// the observations tested, each parameter with its sigma and prior sigma,
/// and what the data determine.
pub fn print_summary(
    calibration: &MechanismCalibrationRecord,
    truth: Option<&[f64]>,
    out: &mut impl Write,
) -> std::io::Result<()> {
    writeln!(out, "{}", verdict_sentence(calibration))?;
    if let Some(run_away) = run_away_sentence(calibration) {
        writeln!(out, "NOTE: {run_away}")?;
    }
    for mirrored in mirrored_sentences(calibration) {
        writeln!(out, "{mirrored}")?;
    }
    for removal in removal_sentences(calibration) {
        writeln!(out, "removed by data snooping: {removal}")?;
    }
    for warning in &calibration.warnings {
        writeln!(out, "warning: {warning}")?;
    }
    let counts = observation_counts(calibration);
    if !counts.is_empty() {
        writeln!(out, "observations: {}", counts.join(", "))?;
    }
    let rows = parameter_rows(calibration, truth);
    let header = parameter_header(truth.is_some());
    let widths: Vec<usize> = (0..header.len())
        .map(|k| {
            rows.iter()
                .map(|row| row[k].len())
                .chain([header[k].len()])
                .max()
                .unwrap_or(0)
        })
        .collect();
    let line = |cells: &[&str]| {
        cells
            .iter()
            .zip(&widths)
            .enumerate()
            .map(|(k, (cell, width))| {
                if k < 2 {
                    format!("{cell:<width$}")
                } else {
                    format!("{cell:>width$}")
                }
            })
            .collect::<Vec<_>>()
            .join("  ")
    };
    writeln!(out, "{}", line(&header))?;
    for row in &rows {
        let cells: Vec<&str> = row.iter().map(String::as_str).collect();
        writeln!(out, "{}", line(&cells))?;
    }
    if let Some(sentence) = prior_correlation_sentence(calibration) {
        writeln!(out, "{sentence}")?;
    }
    for statement in identifiability_statements(calibration) {
        writeln!(out, "{statement}")?;
    }
    Ok(())
}
