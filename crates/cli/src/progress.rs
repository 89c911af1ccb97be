//! Progress of long runs on stderr.
//!
//! When stderr is a terminal: a bar (a known number of steps) or a spinner,
//! redrawn in place, with plain lines printed above it. Otherwise plain
//! lines only, one per step, as logs and the tests read them:
//!
//! ```text
//!   iteration: cost 1.234567e3, step 4.560e-2 (0.12 s)
//! ```

use std::io::{IsTerminal, Write};
use std::time::{Duration, Instant};

use indicatif::{ProgressBar, ProgressStyle};
use parcal::calibration::IterationRecord;

/// A bar or spinner on a terminal, plain lines elsewhere.
pub struct Progress {
    /// What one step is called ("iteration").
    label: &'static str,
    /// `None` when stderr is not a terminal.
    bar: Option<ProgressBar>,
}

impl Progress {
    /// A bar of `steps` steps called `label`.
    pub fn bar(label: &'static str, steps: u64) -> Self {
        Self::new(
            label,
            || ProgressBar::new(steps),
            "{spinner} {prefix} {pos}/{len} [{wide_bar}] {msg}",
        )
    }

    /// A spinner with the elapsed time, for runs that only print lines.
    pub fn spinner() -> Self {
        Self::new("", ProgressBar::new_spinner, "{spinner} {elapsed}")
    }

    fn new(label: &'static str, bar: impl FnOnce() -> ProgressBar, template: &str) -> Self {
        let bar = std::io::stderr().is_terminal().then(|| {
            let bar = bar();
            let style = ProgressStyle::with_template(template)
                .expect("a valid template")
                .progress_chars("=> ");
            bar.set_style(style);
            bar.set_prefix(label);
            // Ticks between steps too: a step takes seconds at 10^6 contacts.
            bar.enable_steady_tick(Duration::from_millis(100));
            bar
        });
        Self { label, bar }
    }

    /// One more step, described by `message`.
    pub fn step(&self, message: &str) {
        match &self.bar {
            Some(bar) => {
                // The solver records the final iterate after the last step
                // taken.
                if bar.length().is_some_and(|length| bar.position() >= length) {
                    bar.inc_length(1);
                }
                bar.inc(1);
                bar.set_message(message.to_owned());
            }
            None => stderr_line(&format!("  {}: {message}", self.label)),
        }
    }

    /// One iteration of a calibration that began at `started`: its cost,
    /// its step's length and that length in standard deviations, the
    /// time so far.
    pub fn iteration(&self, record: &IterationRecord, started: Instant) {
        self.step(&format!(
            "cost {:.6e}, step {:.3e} ({:.2e} sigma) ({:.2} s)",
            record.cost,
            record.step_norm,
            record.step_sigmas,
            started.elapsed().as_secs_f64()
        ))
    }

    /// A line of text, above the bar on a terminal.
    pub fn line(&self, text: &str) {
        match &self.bar {
            Some(bar) => bar.println(text),
            None => stderr_line(text),
        }
    }

    /// Stops the bar and leaves its last step on screen.
    pub fn finish(self) {
        if let Some(bar) = &self.bar {
            bar.abandon();
        }
    }
}

/// `text` and a newline on stderr. A stderr that cannot be written (a
/// closed pipe) loses the line and the run goes on: the results go to
/// files and stdout, and `eprintln!` would panic instead.
pub fn stderr_line(text: &str) {
    let _ = writeln!(std::io::stderr(), "{text}");
}

/// Clears what was not finished (a spinner, or a run that ended in an
/// error), so that nothing stale is left on screen.
impl Drop for Progress {
    fn drop(&mut self) {
        if let Some(bar) = &self.bar
            && !bar.is_finished()
        {
            bar.finish_and_clear();
        }
    }
}
