//! Where the memory of `parcal calibrate` goes: the resident set (and its
//! peak so far) after reading the dataset, at every iteration, after the
//! calibration and after its record, read from `/proc/self/status` (Linux).
//!
//! ```sh
//! cargo run --release -p parcal-benches --example memory -- /tmp/s1e6/dataset.bin
//! ```

use parcal_calibrate::calibrate;
use parcal_dataset::Dataset;

/// `VmRSS` and `VmHWM` (peak) of this process, bytes.
fn resident() -> (f64, f64) {
    let status = std::fs::read_to_string("/proc/self/status").unwrap_or_default();
    let field = |name: &str| {
        status
            .lines()
            .find_map(|line| line.strip_prefix(name))
            .and_then(|rest| {
                rest.trim()
                    .trim_end_matches("kB")
                    .trim()
                    .parse::<f64>()
                    .ok()
            })
            .map_or(f64::NAN, |kb| kb * 1024.0)
    };
    (field("VmRSS:"), field("VmHWM:"))
}

fn report(what: &str, contacts: usize) {
    let (now, peak) = resident();
    let per = |bytes: f64| bytes / contacts as f64;
    println!(
        "{what:<20} resident {:>7.1} MB ({:>5.0} B/contact), peak {:>7.1} MB ({:>5.0} B/contact)",
        now / 1e6,
        per(now),
        peak / 1e6,
        per(peak)
    );
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let path = std::env::args()
        .nth(1)
        .ok_or("usage: memory DATASET.bin | DATASET_DIRECTORY")?;
    let path = std::path::Path::new(&path);
    let mut dataset = if path.is_file() {
        Dataset::read_snapshot(path)?
    } else {
        Dataset::read(path)?
    };
    // As `parcal calibrate` does: a simulation's truth (24 bytes a
    // contact of true contact points) serves the evaluation only.
    dataset.truth = None;
    let contacts = dataset.measurements.q.len();
    report("read", contacts);
    let mut iteration = 0;
    let run = calibrate(&dataset, &parcal_benches::options(), &mut |_| {
        iteration += 1;
        report(&format!("iteration {iteration}"), contacts);
    })?;
    report("calibrated", contacts);
    drop(parcal_report::record::of_run(&run, &dataset));
    report("recorded", contacts);
    Ok(())
}
