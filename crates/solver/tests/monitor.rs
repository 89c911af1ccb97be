//! A monitor sees every new iterate once, with its groups' costs, and can
//! stop the run there; a run resumed from the stopped iterate ends where
//! the uninterrupted run does.

use crate::common;

use common::{Spec, flatten, perturb, touches};
use parcal_solver::{
    Decision, Iterate, IterationRecord, Method, Monitor, SolverOptions, State, Status, solve,
    solve_with_caches,
};

/// What a monitor saw of one iterate.
#[derive(Debug)]
struct Seen {
    solves: usize,
    cost: f64,
    previous_cost: Option<f64>,
    group_cost_sum: f64,
    groups: usize,
    caches: usize,
    state: State<3, 2>,
}

/// Records everything and stops at the iterate after `stop_at` solves.
struct Recorder {
    records: Vec<IterationRecord>,
    seen: Vec<Seen>,
    stop_at: Option<usize>,
}

impl Recorder {
    fn new(stop_at: Option<usize>) -> Self {
        Self {
            records: Vec::new(),
            seen: Vec::new(),
            stop_at,
        }
    }
}

impl Monitor<3, 2, u32> for Recorder {
    fn record(&mut self, record: &IterationRecord) {
        self.records.push(record.clone());
    }

    fn inspect(&mut self, iterate: &Iterate<'_, 3, 2, u32>) -> Decision {
        self.seen.push(Seen {
            solves: iterate.solves,
            cost: iterate.cost,
            previous_cost: iterate.previous_cost,
            group_cost_sum: iterate.group_costs.iter().sum(),
            groups: iterate.group_costs.len(),
            caches: iterate.caches.len(),
            state: iterate.state.clone(),
        });
        if Some(iterate.solves) == self.stop_at {
            Decision::Stop
        } else {
            Decision::Continue
        }
    }
}

fn options(method: Method) -> SolverOptions {
    SolverOptions {
        method,
        groups_per_chunk: 3,
        ..SolverOptions::default()
    }
}

fn spec() -> Spec {
    Spec {
        n_groups: 10,
        points_per_group: 12,
        ..Spec::default()
    }
}

#[test]
fn a_monitor_sees_each_iterate_once_with_its_group_costs() {
    let (problem, truth) = touches(spec());
    let lm = Method::LevenbergMarquardt {
        initial_lambda: 1e-3,
    };
    // LM from a start far enough for some of its steps to be rejected.
    for (method, start) in [
        (Method::GaussNewton, perturb(&truth, 1, 0.01, 0.02, 0.1)),
        (lm, perturb(&truth, 1, 0.1, 0.1, 1.0)),
    ] {
        let plain = solve(&problem, start.clone(), &options(method), &mut |_| {});
        let mut recorder = Recorder::new(None);
        let watched = solve_with_caches(
            &problem,
            start.clone(),
            &mut Vec::new(),
            &options(method),
            &mut recorder,
        );
        assert_eq!(watched.status, Status::Converged);
        // Watching changes nothing.
        assert_eq!(flatten(&watched.state), flatten(&plain.state));
        assert_eq!(watched.history, plain.history);
        assert_eq!(recorder.records, watched.history);
        // One inspection per iterate: the start and each accepted step's
        // result (an LM rejection keeps the iterate); the last is the
        // solution.
        let history = &watched.history;
        let accepted = history[..history.len() - 1]
            .iter()
            .filter(|r| r.accepted)
            .count();
        assert_eq!(recorder.seen.len(), accepted + 1, "{method:?}");
        let rejected = history.iter().filter(|r| !r.accepted).count();
        assert_eq!(
            rejected > 0,
            method == lm,
            "{method:?}: {rejected} rejected"
        );
        assert_eq!(
            flatten(&recorder.seen.last().unwrap().state),
            flatten(&watched.state)
        );
        let mut previous = None;
        for seen in &recorder.seen {
            // The iterate's record is the first made after `solves` solves.
            let record = &history[seen.solves];
            assert_eq!(seen.cost, record.cost);
            assert_eq!(seen.previous_cost, previous);
            assert!(
                (seen.group_cost_sum - record.data_cost).abs() <= 1e-12 * record.data_cost,
                "{} vs {}",
                seen.group_cost_sum,
                record.data_cost
            );
            assert_eq!((seen.groups, seen.caches), (10, 120));
            previous = Some(seen.cost);
        }
        let final_costs = watched.group_costs.as_ref().expect("group costs");
        let sum: f64 = final_costs.iter().sum();
        let data_cost = history.last().unwrap().data_cost;
        assert!((sum - data_cost).abs() <= 1e-12 * data_cost);
    }
}

#[test]
fn a_stopped_run_resumes_to_the_uninterrupted_solution() {
    let (problem, truth) = touches(spec());
    let start = perturb(&truth, 1, 0.01, 0.02, 0.1);
    let options = options(Method::GaussNewton);
    let mut all = Recorder::new(None);
    let whole = solve_with_caches(&problem, start.clone(), &mut Vec::new(), &options, &mut all);
    assert_eq!(whole.status, Status::Converged);
    assert!(whole.history.len() > 3, "{}", whole.history.len());

    let mut caches = Vec::new();
    let mut first = Recorder::new(Some(2));
    let stopped = solve_with_caches(&problem, start, &mut caches, &options, &mut first);
    assert_eq!(stopped.status, Status::Stopped { iteration: 2 });
    // No record, covariance or group results for the stopped iterate.
    assert_eq!(stopped.history, whole.history[..2]);
    assert!(stopped.covariance.is_none() && stopped.group_costs.is_none());
    assert_eq!(flatten(&stopped.state), flatten(&all.seen[2].state));
    assert_eq!(caches.len(), 120);

    let resumed = solve_with_caches(
        &problem,
        stopped.state,
        &mut caches,
        &options,
        &mut |_: &IterationRecord| {},
    );
    assert_eq!(resumed.status, Status::Converged);
    assert_eq!(resumed.history, whole.history[2..]);
    assert_eq!(flatten(&resumed.state), flatten(&whole.state));
}
