//! A campaign of ball touches and instrument measurements of one true
//! machine, in one dataset: the touches of a [`Scenario`] and the sessions
//! of a [`TrackerScenario`] with the same design and truth.
//!
//! The touches and the instrument read the same actuators (leg
//! `l_i + s_i q_i`): both scenarios need the same readings (unit, design
//! and true scales, the scales' prior) and the same actuator noise. The
//! touches draw from the streams `(seed, ball)` ([`simulate`]); the
//! instrument from the seed drawn by stream `(seed, TRACKER_STREAM)`
//! ([`simulate_tracker`]), so that the two never share a stream.

use crate::{
    Readings, Rng, Scenario, SimulateError, Simulation, TrackerScenario, simulate, simulate_tracker,
};

/// The stream that draws the instrument part's seed (the plate's is
/// `u64::MAX`, the balls' are their indices).
const TRACKER_STREAM: u64 = u64::MAX - 1;

/// Simulates `touches` and `tracker` (module doc) with random stream
/// `seed`: machine.json is the touches' with the instrument's
/// repeatability and session model; truth.json has the balls, the contacts
/// and the sessions.
pub fn simulate_mixed(
    touches: &Scenario,
    tracker: &TrackerScenario,
    seed: u64,
) -> Result<Simulation, SimulateError> {
    if touches.design != tracker.design || touches.truth != tracker.truth {
        return Err(SimulateError::Scenario(
            "touches and instrument measurements of one dataset need one design and one truth"
                .into(),
        ));
    }
    if touches.readings != Readings::of(tracker) || touches.actuator_sigma != tracker.actuator_sigma
    {
        return Err(SimulateError::Scenario(
            "touches and instrument measurements of one dataset read the same actuators: one \
             unit, design and true scales, scale sigmas and actuator noise"
                .into(),
        ));
    }
    let Simulation {
        dataset: mut mixed,
        mut summary,
    } = simulate(touches, seed)?;
    let instruments = simulate_tracker(tracker, Rng::new(seed, TRACKER_STREAM).next_u64())?;
    let (from, s) = (instruments.dataset, instruments.summary);
    let r = &from.machine.repeatability;
    mixed.machine.repeatability.position = r.position;
    mixed.machine.repeatability.orientation = r.orientation;
    mixed.machine.session_model = from.machine.session_model;
    mixed.tracker = from.tracker;
    if let (Some(truth), Some(instrument_truth)) = (&mut mixed.truth, from.truth) {
        truth.sessions = instrument_truth.sessions;
    }
    summary.sessions = s.sessions;
    summary.poses = s.poses;
    summary.points = s.points;
    let range = |a: (f64, f64), b: (f64, f64)| (a.0.min(b.0), a.1.max(b.1));
    summary.leg_length_range = range(summary.leg_length_range, s.leg_length_range);
    summary.tilt_range = range(summary.tilt_range, s.tilt_range);
    Ok(Simulation {
        dataset: mixed,
        summary,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The paper's touches with a laser tracker's poses and points of the
    /// same machine, scales 1 and known.
    fn scenarios() -> (Scenario, TrackerScenario) {
        let tracker = TrackerScenario {
            true_scale: [1.0; 6],
            scale_sigma: None,
            sessions: 2,
            rows_per_session: 10,
            ..TrackerScenario::paper_like()
        };
        (Scenario::paper(), tracker)
    }

    #[test]
    fn one_dataset_holds_both_kinds_of_one_truth() {
        let (touches, tracker) = scenarios();
        let mixed = simulate_mixed(&touches, &tracker, 4).unwrap();
        let alone = simulate(&touches, 4).unwrap();
        let d = &mixed.dataset;
        // The touches are those of the touch campaign alone.
        assert_eq!(d.measurements.q, alone.dataset.measurements.q);
        assert_eq!(d.tracker.poses.len(), 20);
        assert_eq!(d.tracker.points.len(), 20);
        assert_eq!(d.truth.as_ref().unwrap().sessions.len(), 2);
        assert!(d.machine.repeatability.position.is_some());
        d.validate().unwrap();
        // The instrument part does not reuse a touch stream: its readings
        // differ from the instrument campaign with the same seed.
        let same_seed = simulate_tracker(&tracker, 4).unwrap();
        assert_ne!(d.tracker.poses.q, same_seed.dataset.tracker.poses.q);
    }

    #[test]
    fn other_readings_or_machines_are_refused() {
        let (touches, tracker) = scenarios();
        let scaled = TrackerScenario {
            true_scale: [1.001; 6],
            ..tracker.clone()
        };
        assert!(simulate_mixed(&touches, &scaled, 1).is_err());
        let same = touches.clone().reading(Readings::of(&scaled));
        let same = Scenario {
            actuator_sigma: scaled.actuator_sigma,
            ..same
        };
        let d = simulate_mixed(&same, &scaled, 1).unwrap().dataset;
        assert_eq!(d.truth.unwrap().actuator_scale, Some([1.001; 6]));
        let other = TrackerScenario {
            truth: touches.design.clone(),
            ..tracker
        };
        assert!(simulate_mixed(&touches, &other, 1).is_err());
    }
}
