//! `parcal validate`: apply a calibration of poses or points to
//! measurements it was not fitted on, or cross-validate a dataset; a
//! mechanism's calibration to held-out data of its machine
//! ([`super::mechanism_apply`]); exits with status 3 when the residuals
//! are larger than the calibration predicts (validation.json is written
//! either way).

use std::io::Write;
use std::path::PathBuf;

use anyhow::Context;
use parcal::calibration::cross_validation::cross_validate;
use parcal::calibration::instruments::{Calibrated, validate_calibration};
use parcal::calibration::validate_touches;
use parcal::calibration::{CalibrationOptions, bounds};
use parcal::dataset::VALIDATION_FILE;

use crate::bounds::Bounded;

use super::mechanism_apply::validate_hexapod;
use parcal::command::{Recorded, read_either};

#[derive(clap::Args)]
pub struct Args {
    /// Dataset directory (ball touches, or poses.csv and/or points.csv; or a
    /// mechanism's held-out measurements), or a binary snapshot file.
    dataset: PathBuf,
    /// The calibration to apply (calibration.json of `parcal calibrate`).
    #[arg(long, required_unless_present = "folds", conflicts_with = "folds")]
    calibration: Option<PathBuf>,
    /// Re-fit each session's nuisance (instrument frame; body origin, body
    /// rotation and leg offsets when machine.json's session_model has their
    /// sigmas) on its first N rows, or each ball's centre on its first N
    /// touches, and predict the others. Without it, every session (ball) must
    /// be one of the calibration's (same label, id); for a mechanism's
    /// calibration (or a hexapod's through the common path), each held-out
    /// ball's centre (tracker's frame) is projected out of all its touches
    /// (points and poses); with it, located by its first N of each.
    #[arg(long, value_name = "N", value_parser = Bounded(bounds::REFERENCE))]
    reference: Option<usize>,
    /// Instead of applying a calibration: K-fold cross-validation of the
    /// dataset's own calibration (row j in fold j mod K; a mechanism's
    /// observation j of each kind, without balls or trackers).
    #[arg(long, value_name = "K", value_parser = Bounded(bounds::FOLDS))]
    folds: Option<usize>,
    /// Apply a calibration whose verdict is "rejected".
    #[arg(long)]
    accept_rejected: bool,
    /// Where to write validation.json (default: validation.json in the dataset's directory).
    #[arg(long)]
    out: Option<PathBuf>,
}

pub fn run(args: &Args) -> anyhow::Result<()> {
    let out = args.out.clone().unwrap_or_else(|| {
        let directory = if args.dataset.is_file() {
            args.dataset.parent().map(PathBuf::from).unwrap_or_default()
        } else {
            args.dataset.clone()
        };
        directory.join(VALIDATION_FILE)
    });
    if super::mechanism::declared(&args.dataset)?.is_some() {
        return match (&args.calibration, args.folds) {
            (Some(calibration), None) => super::mechanism_apply::validate(
                &args.dataset,
                calibration,
                args.reference,
                args.accept_rejected,
                &out,
            ),
            (None, Some(folds)) => {
                super::mechanism_apply::cross_validate(&args.dataset, folds, args.reference, &out)
            }
            _ => unreachable!("clap requires one of --calibration and --folds"),
        };
    }
    let dataset = super::read_dataset(&args.dataset)?;
    let mut inputs = crate::outputs::dataset_inputs(&args.dataset);
    inputs.extend(args.calibration.clone());
    crate::outputs::check(&inputs, std::slice::from_ref(&out))?;
    let (validation, calibration) = match (&args.calibration, args.folds) {
        (Some(path), _) => {
            let record = match read_either(path)? {
                Recorded::Own(record) => super::accepted(*record, path, args.accept_rejected)?,
                // A hexapod's calibration through the common path.
                Recorded::Mechanism(record) => {
                    let record = super::accepted(*record, path, args.accept_rejected)?;
                    return validate_hexapod(
                        dataset,
                        &args.dataset,
                        record,
                        path,
                        args.reference,
                        &out,
                    );
                }
            };
            super::note_in_sample(
                record.provenance.as_ref(),
                dataset.checksum(),
                &args.dataset,
                path,
            );
            let validation = if dataset.tracker.is_empty() {
                validate_touches(&dataset, &record, args.reference)
                    .with_context(|| path.display().to_string())?
            } else {
                let calibrated =
                    Calibrated::from_record(&record).with_context(|| path.display().to_string())?;
                validate_calibration(&dataset, &calibrated, args.reference)?
            };
            (validation, path.display().to_string())
        }
        (None, Some(folds)) => {
            let options = CalibrationOptions::default();
            let cross = cross_validate(&dataset, &options, folds)?;
            (cross.pooled(), format!("{folds}-fold cross-validation"))
        }
        (None, None) => unreachable!("clap requires --calibration or --folds"),
    };
    let record = parcal::report::instruments::validation_record(&validation, calibration);
    record.write(&out)?;
    let mut stdout = std::io::stdout().lock();
    writeln!(
        stdout,
        "{}",
        parcal::report::instruments::validation(&record)
    )?;
    writeln!(stdout, "validation written to {}", out.display())?;
    super::validation_outcome(record.is_rejected(), &record.reasons, &out)
}
