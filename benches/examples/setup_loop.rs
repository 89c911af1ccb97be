//! The calibration's set-up (the design's forward kinematics of every
//! contact, the balls' sphere fits, the weights: `Setup::new`) of the
//! iteration benchmark's problem timed in a loop, each time printed, then
//! the mean, median and fastest. Two builds run in turn compare better on a
//! shared machine than two runs minutes apart (docs/performance.md).
//!
//! ```sh
//! cargo run --release -p parcal-benches --example setup_loop -- 1000000 6
//! ```

use std::time::Instant;

use parcal_benches::{campaign, print_times, setup};

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let (contacts, runs) = match args.as_slice() {
        [contacts, runs] => match (contacts.parse::<usize>(), runs.parse::<usize>()) {
            (Ok(contacts), Ok(runs)) if (7..=10_000_000).contains(&contacts) && runs > 0 => {
                (contacts, runs)
            }
            _ => usage(),
        },
        _ => usage(),
    };
    let dataset = campaign(contacts);
    let mut times = Vec::with_capacity(runs);
    for _ in 0..runs {
        let start = Instant::now();
        let made = setup(&dataset);
        times.push(start.elapsed().as_secs_f64() * 1e3);
        // Dropped untimed.
        drop(made);
    }
    print_times("set-up", times);
}

fn usage() -> ! {
    eprintln!("usage: setup_loop CONTACTS RUNS (7 to 10^7 contacts, one run at least)");
    std::process::exit(2);
}
