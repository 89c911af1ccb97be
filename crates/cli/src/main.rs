//! `parcal`: artefact calibration of parallel mechanisms (hexapods, linear
//! deltas, cable robots) with a priori knowledge, after Sato et al., Meas.
//! Sci. Technol. 15 (2004) 1158.
//!
//! A thin binary: it parses arguments and wires the crates together.

mod bounds;
mod commands;
mod outputs;
mod progress;

use std::io::ErrorKind;
use std::process::ExitCode;

use clap::{CommandFactory, FromArgMatches, Parser, Subcommand};

#[derive(Parser)]
#[command(
    name = "parcal",
    version,
    about = "Artefact calibration of parallel mechanisms (hexapods, linear deltas, cable robots) with a priori knowledge"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Simulate a calibration campaign (the paper's hexapod by default; --mechanism delta or cable) and write it as a dataset.
    Simulate(Box<commands::simulate::Args>),
    /// Read and validate a dataset and print a summary.
    Inspect(commands::inspect::Args),
    /// Calibrate a dataset: identified parameters with sigmas, accuracy, calibration.json.
    Calibrate(commands::calibrate::Args),
    /// Judge a calibration on data it was not fitted on (held-out touches, poses, points, probes, samples; or cross-validate).
    Validate(commands::validate::Args),
    /// A hexapod's accuracy maps (absolute and registered, predicted and true) as CSV and SVG.
    Accuracy(commands::accuracy::Args),
    /// Reproduce the paper's simulations I-IV on one simulated dataset, with a report.
    Paper(commands::paper::Args),
    /// Apply a calibration: targets to actuator commands, corrected poses, correction tables.
    Compensate(commands::compensate::Args),
    /// Export a calibration: calibrated machine.json, LinuxCNC genhexkins HAL, summary; a delta's or a Hangprinter's firmware lines.
    Export(commands::export::Args),
    /// A delta printer's firmware configuration and probe log as a dataset (RepRapFirmware, Klipper, Marlin).
    Import(commands::import::Args),
    /// Plan the measurements: the most accurate calibration for a budget.
    Plan(commands::plan::Args),
    /// The report of one calibration: a self-contained HTML page and its Markdown, verdict and tests first.
    Report(commands::report::Args),
}

fn main() -> ExitCode {
    let cli = parse_arguments();
    clean_up_when_interrupted();
    let result = match cli.command {
        Command::Simulate(args) => commands::simulate::run(&args),
        Command::Inspect(args) => commands::inspect::run(&args),
        Command::Calibrate(args) => commands::calibrate::run(&args),
        Command::Validate(args) => commands::validate::run(&args),
        Command::Accuracy(args) => commands::accuracy::run(&args),
        Command::Paper(args) => commands::paper::run(&args),
        Command::Compensate(args) => commands::compensate::run(&args),
        Command::Export(args) => commands::export::run(&args),
        Command::Import(args) => commands::import::run(&args),
        Command::Plan(args) => commands::plan::run(&args),
        Command::Report(args) => commands::report::run(&args),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        // Computed and written, but its tests say not to use it.
        Err(error) if error.downcast_ref::<commands::Rejected>().is_some() => {
            progress::stderr_line(&format!("rejected: {}", one_sentence(&error)));
            ExitCode::from(3)
        }
        // The reader of stdout (`parcal inspect d | head`) has what it
        // wanted: stop quietly, as a program killed by SIGPIPE does.
        Err(error) if closed_pipe(&error) => ExitCode::SUCCESS,
        Err(error) => {
            progress::stderr_line(&format!("error: {}", one_sentence(&error)));
            ExitCode::FAILURE
        }
    }
}

/// The command line, parsed as [`Cli::parse`] does, but for a value that
/// looks like a negative number: an option taking a value takes it
/// (`--gauge -1` is then refused by the option's own bound, not as an
/// unknown flag).
fn parse_arguments() -> Cli {
    let mut command = negative_values_taken(Cli::command());
    let parsed = Cli::from_arg_matches_mut(&mut command.get_matches_mut());
    parsed.unwrap_or_else(|error| error.format(&mut command).exit())
}

/// `command` and its subcommands, every option that takes a value
/// allowed a negative number as its value.
fn negative_values_taken(command: clap::Command) -> clap::Command {
    command
        .mut_args(|arg| match arg.get_action().takes_values() {
            true => arg.allow_negative_numbers(true),
            false => arg,
        })
        .mut_subcommands(negative_values_taken)
}

/// On SIGINT or SIGTERM: removes the temporary files and directories of
/// the writes under way (a rename into place under way finishes first) and
/// exits with 128 + the signal's number (130, 143), as a shell reports a
/// program killed by it.
fn clean_up_when_interrupted() {
    use signal_hook::consts::{SIGINT, SIGTERM};
    let Ok(mut signals) = signal_hook::iterator::Signals::new([SIGINT, SIGTERM]) else {
        // Without the handler the default action stands: stale temporaries
        // are removed by the next write into their directory.
        return;
    };
    std::thread::spawn(move || {
        if let Some(signal) = signals.forever().next() {
            parcal::dataset::atomic::remove_in_flight();
            std::process::exit(128 + signal);
        }
    });
}

/// Whether `error` is a write to a closed pipe.
fn closed_pipe(error: &anyhow::Error) -> bool {
    error.chain().any(|cause| {
        cause
            .downcast_ref::<std::io::Error>()
            .is_some_and(|e| e.kind() == ErrorKind::BrokenPipe)
    })
}

/// The error and its causes joined by ": ", skipping a cause that the
/// message already states: some library errors (dataset I/O, accuracy,
/// report) still print their `source` in their message too.
fn one_sentence(error: &anyhow::Error) -> String {
    let mut message = String::new();
    for cause in error.chain() {
        let text = cause.to_string();
        if !message.contains(&text) {
            if !message.is_empty() {
                message.push_str(": ");
            }
            message.push_str(&text);
        }
    }
    message
}
