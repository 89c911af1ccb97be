//! One Gauss-Newton step of the iteration benchmark's problem (simulation
//! IV, propagated prior, mid-run state) timed in a loop: each step from the
//! same state and warm starts, its time printed, then the mean, median and
//! fastest. On a shared machine, whose speed moves within minutes, two
//! builds run in turn compare better than two criterion runs minutes
//! apart (docs/performance.md).
//!
//! ```sh
//! cargo run --release -p parcal-benches --example step_loop -- 1000000 6
//! RAYON_NUM_THREADS=1 cargo run --release -p parcal-benches --example step_loop -- 100000 30
//! ```

use std::time::Instant;

use parcal_benches::{campaign, print_times, setup, warm_problem};
use parcal_solver::{SolverOptions, linear_step};

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let (contacts, steps) = match args.as_slice() {
        [contacts, steps] => match (contacts.parse::<usize>(), steps.parse::<usize>()) {
            (Ok(contacts), Ok(steps)) if contacts >= 7 && steps > 0 => (contacts, steps),
            _ => usage(),
        },
        _ => usage(),
    };
    let dataset = campaign(contacts);
    let (setup, observations) = setup(&dataset);
    let (problem, state) = warm_problem(&dataset, &setup, observations);
    let chunk = SolverOptions::default().groups_per_chunk;
    let mut times = Vec::with_capacity(steps);
    for _ in 0..steps {
        let mut warm_starts = setup.poses.clone();
        let start = Instant::now();
        let step = linear_step(&problem, &state, &mut warm_starts, 0.0, chunk).expect("step");
        times.push(start.elapsed().as_secs_f64() * 1e3);
        // Dropped untimed, as in the benchmark.
        drop((step, warm_starts));
    }
    print_times("step", times);
}

fn usage() -> ! {
    eprintln!("usage: step_loop CONTACTS STEPS (at least 7 contacts, one step)");
    std::process::exit(2);
}
