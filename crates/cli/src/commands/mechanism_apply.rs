//! `parcal validate` and `parcal compensate` for a mechanism's calibration
//! (docs/delta.md, docs/cable-robots.md): the files read and written, the
//! summary printed; the work is `parcal::calibration::mechanism`'s and the
//! words `parcal::report::mechanism_validation`'s.

use std::io::Write;
use std::path::{Path, PathBuf};

use crate::progress::Progress;

use parcal::calibration::hypothesis::SNOOPING_LEVEL;
use parcal::calibration::mechanism::{
    CalibratedMechanism, MechanismCalibrationError, MechanismData, MechanismOptions,
    MechanismValidation, compensate_targets, cross_validate_mechanism, validate_mechanism,
};
use parcal::dataset::mechanism::{
    DISTANCES_FILE, LOAD_COLUMNS, MechanismCalibrationRecord, MechanismDataset, PROBES_FILE,
    command_header, read_targets,
};
use parcal::dataset::write_numbers;
use parcal::dataset::{Dataset, HEXAPOD};
use parcal::report::mechanism_validation::{observation_place, summary, validation_record};

/// Reads a mechanism's calibration.json, refusing a rejected one unless
/// `accept_rejected`.
pub fn read_calibration(
    path: &Path,
    accept_rejected: bool,
) -> anyhow::Result<MechanismCalibrationRecord> {
    super::accepted(
        MechanismCalibrationRecord::read(path)?,
        path,
        accept_rejected,
    )
}

/// The numbers of the calibration at `path`.
fn calibrated(path: &Path, accept_rejected: bool) -> anyhow::Result<CalibratedMechanism> {
    let record = read_calibration(path, accept_rejected)?;
    CalibratedMechanism::from_record(&record)
        .map_err(|error| anyhow::anyhow!("{}: {error}", path.display()))
}

/// An error of the data in `dataset` of the mechanism named `mechanism`,
/// an observation named by its file and line.
fn data_error(dataset: &Path, mechanism: &str, error: MechanismCalibrationError) -> anyhow::Error {
    match error {
        MechanismCalibrationError::Observation {
            observation,
            reason,
        } => anyhow::anyhow!(
            "{}: {}: {reason}",
            dataset.display(),
            observation_place(mechanism, observation)
        ),
        other => anyhow::anyhow!("{}: {other}", dataset.display()),
    }
}

/// The files of the mechanism dataset `dataset` a validation reads, which
/// its output must not replace.
fn dataset_inputs(dataset: &Path) -> Vec<PathBuf> {
    let mut inputs = crate::outputs::dataset_inputs(dataset);
    inputs.extend(
        [PROBES_FILE, DISTANCES_FILE]
            .iter()
            .map(|name| dataset.join(name))
            .filter(|file| file.exists()),
    );
    inputs
}

/// Validates the calibration at `calibration` on the mechanism dataset
/// `dataset` (each held-out ball's centre and tracker's frame located by
/// its first `reference` touches, points and poses if given): writes the
/// validation to `out`, prints its summary, and turns a rejection into
/// [`super::Rejected`].
pub fn validate(
    dataset: &Path,
    calibration: &Path,
    reference: Option<usize>,
    accept_rejected: bool,
    out: &Path,
) -> anyhow::Result<()> {
    let mut inputs = dataset_inputs(dataset);
    inputs.push(calibration.to_path_buf());
    crate::outputs::check(&inputs, &[out.to_path_buf()])?;
    let record = read_calibration(calibration, accept_rejected)?;
    let calibrated = CalibratedMechanism::from_record(&record)
        .map_err(|error| anyhow::anyhow!("{}: {error}", calibration.display()))?;
    let held_out = MechanismDataset::read(dataset)?;
    let provenance = record.provenance.as_ref();
    super::note_in_sample(provenance, held_out.checksum(), dataset, calibration);
    let mechanism = held_out.machine.mechanism.as_str();
    let data =
        MechanismData::from_dataset(&held_out).map_err(|e| data_error(dataset, mechanism, e))?;
    let validation = validate_mechanism(&calibrated, &data, SNOOPING_LEVEL, reference)
        .map_err(|e| data_error(dataset, mechanism, e))?;
    judged(&validation, calibration.display().to_string(), out)
}

/// K-fold cross-validation of the calibration of the mechanism dataset
/// `dataset` under the default options ([`cross_validate_mechanism`]),
/// each fold's end shown on stderr: writes the pooled validation to
/// `out`, prints its summary, and turns a rejection into
/// [`super::Rejected`]. Reference observations are refused: folds hold
/// none of the observations they locate.
pub fn cross_validate(
    dataset: &Path,
    folds: usize,
    reference: Option<usize>,
    out: &Path,
) -> anyhow::Result<()> {
    anyhow::ensure!(
        reference.is_none(),
        "--reference: a cross-validation fits each held-out ball's centre and tracker's frame to all its fold's touches, points and poses"
    );
    crate::outputs::check(&dataset_inputs(dataset), &[out.to_path_buf()])?;
    let read = MechanismDataset::read(dataset)?;
    let mechanism = read.machine.mechanism.as_str();
    let data = MechanismData::from_dataset(&read).map_err(|e| data_error(dataset, mechanism, e))?;
    let progress = Progress::bar("fold", folds as u64);
    let options = MechanismOptions::default();
    let validation = cross_validate_mechanism(&data, &options, folds, &mut |r| {
        progress.step(&format!(
            "fold {r} of folds 0-{} predicted by the others' calibration",
            folds - 1
        ))
    })
    .map_err(|e| data_error(dataset, mechanism, e))?;
    progress.finish();
    judged(&validation, format!("{folds}-fold cross-validation"), out)
}

/// Validates `record`, a hexapod's calibration through the common path
/// (read from `calibration`), on the ball touches of the hexapod dataset
/// `dataset` (read from `path`), weighted as
/// [`MechanismData::hexapod_held_out`]
/// says (each ball's centre and tracker's frame located by its first
/// `reference` touches, points and poses if given): writes the validation
/// to `out`, prints its summary, and turns a rejection into
/// [`super::Rejected`]. The files were checked by the caller; their
/// contents are let go once the calibration and the touches are made of
/// them (at 10^6 touches, the record's every row's test and the dataset's
/// readings are a large part of the memory).
pub fn validate_hexapod(
    dataset: Dataset,
    path: &Path,
    record: MechanismCalibrationRecord,
    calibration: &Path,
    reference: Option<usize>,
    out: &Path,
) -> anyhow::Result<()> {
    let calibrated = CalibratedMechanism::from_record(&record)
        .map_err(|error| anyhow::anyhow!("{}: {error}", calibration.display()))?;
    let provenance = record.provenance.as_ref();
    super::note_in_sample(provenance, dataset.checksum(), path, calibration);
    drop(record);
    let data =
        MechanismData::hexapod_held_out(&dataset).map_err(|e| data_error(path, HEXAPOD, e))?;
    drop(dataset);
    let validation = validate_mechanism(&calibrated, &data, SNOOPING_LEVEL, reference)
        .map_err(|e| data_error(path, HEXAPOD, e))?;
    judged(&validation, calibration.display().to_string(), out)
}

/// Writes `validation` of the calibration `calibration` (its file, or
/// the cross-validation) to `out`, prints its summary, and turns a
/// rejection into [`super::Rejected`].
fn judged(validation: &MechanismValidation, calibration: String, out: &Path) -> anyhow::Result<()> {
    let record = validation_record(validation, calibration);
    record.write(out)?;
    let mut stdout = std::io::stdout().lock();
    write!(stdout, "{}", summary(&record))?;
    writeln!(stdout, "validation written to {}", out.display())?;
    super::validation_outcome(record.is_rejected(), &record.reasons, out)
}

/// The commands that reach the target poses of `targets` (a column per
/// pose coordinate of the mechanism; an elastic cable robot's line loads
/// `f1..fA` too, where given) with the calibration at `calibration`,
/// written to `out` beside the nominal ones; nothing is written when a
/// target cannot be reached, and every such target is named by its line.
pub fn compensate(
    calibration: &Path,
    targets: &Path,
    accept_rejected: bool,
    out: &Path,
) -> anyhow::Result<()> {
    crate::outputs::check(
        &[calibration.to_path_buf(), targets.to_path_buf()],
        &[out.to_path_buf()],
    )?;
    let calibrated = calibrated(calibration, accept_rejected)?;
    let pose: Vec<&'static str> = calibrated
        .mechanism
        .pose_coordinates()
        .iter()
        .map(|c| c.name)
        .collect();
    // A mechanism's loads are points.csv's columns f1..fA; a row without
    // them is under the loads of the actuators' zero.
    let actuators = calibrated.mechanism.actuators().len();
    let (load_columns, zero_loads) = match calibrated.mechanism.line_compliances() {
        Some((_, zero_loads)) => (&LOAD_COLUMNS[..actuators], zero_loads),
        None => (&[][..], &[][..]),
    };
    let read = read_targets(targets, &pose, load_columns)?;
    let loads: Vec<Vec<f64>> = (read.loads.into_iter())
        .map(|loads| loads.unwrap_or_else(|| zero_loads.to_vec()))
        .collect();
    let load_columns = if loads.is_empty() { &[] } else { load_columns };
    let compensations =
        compensate_targets(&calibrated, &read.poses, &loads).map_err(|unreachable| {
            anyhow::anyhow!(
                "{}: {} (nothing written)",
                targets.display(),
                unreachable.message(|k| format!("line {}", k + 2))
            )
        })?;
    let rows: Vec<Vec<f64>> = (compensations.iter().enumerate())
        .map(|(k, c)| {
            let loads = loads.get(k).into_iter().flatten();
            (c.target.iter().chain(loads))
                .chain(c.readings.iter())
                .chain(c.nominal.iter())
                .copied()
                .collect()
        })
        .collect();
    let header = command_header(&pose, load_columns, actuators);
    let header: Vec<&str> = header.iter().map(String::as_str).collect();
    write_numbers(out, &header, &rows)?;
    // The position's: the first three pose coordinates (a hexapod's
    // platform origin).
    let sigmas: Vec<f64> = compensations
        .iter()
        .map(|c| c.sigmas()[..3].iter().map(|s| s * s).sum::<f64>().sqrt())
        .collect();
    let correction = compensations
        .iter()
        .map(|c| (&c.readings - &c.nominal).amax())
        .fold(0.0, f64::max);
    let unit = &calibrated.mechanism.actuators()[0].unit;
    println!(
        "{} targets -> {} (readings q1..q{n} in {unit}, the nominal machine's beside them); largest correction {correction:.4} {unit}",
        compensations.len(),
        out.display(),
        n = calibrated.mechanism.actuators().len()
    );
    println!(
        "predicted position error from the calibration's covariance: RMS {:.4} mm, max {:.4} mm",
        (sigmas.iter().map(|s| s * s).sum::<f64>() / sigmas.len() as f64).sqrt(),
        sigmas.iter().copied().fold(0.0, f64::max)
    );
    Ok(())
}
