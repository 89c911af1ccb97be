//! A mechanism's K-fold cross-validation
//! (`parcal_calibrate::mechanism::cross_validate_mechanism`): each fold's
//! rows are those its own validation gives, named by their index in the
//! whole data; on printers simulated by `parcal_simulate::delta` the
//! pooled statistic has its degrees of freedom as mean, with ball touches
//! (each ball, or the balls a plate ties, held out whole) and tracker
//! points (each tracker in every fold) as with probe heights; too many
//! folds are refused.

use parcal_calibrate::mechanism::{
    CalibratedMechanism, HeldOut, MechanismData, MechanismOptions, Observations,
    calibrate_mechanism, cross_validate_mechanism, validate_mechanism,
};
use parcal_simulate::delta::{DeltaScenario, simulate_delta};
use parcal_simulate::{Plate, PlatePairs};

use crate::mean::mean_and_standard_error;

/// A simulated printer's data: 24 probe heights and 4 part distances.
fn printer(seed: u64) -> MechanismData {
    let scenario = DeltaScenario {
        distances: 4,
        ..DeltaScenario::typical()
    };
    let dataset = simulate_delta(&scenario, seed).unwrap();
    MechanismData::from_dataset(&dataset).unwrap()
}

/// Fold 1 of 3 made by hand (observations 1, 4, 7, ... of each kind held
/// out, the others calibrated): its rows are the cross-validation's rows of
/// that fold, each named by its index in the whole data.
#[test]
fn a_fold_is_the_validation_of_its_observations_by_the_others_calibration() {
    let data = printer(1);
    let options = MechanismOptions::default();
    let mut done = Vec::new();
    let cross = cross_validate_mechanism(&data, &options, 3, &mut |r| done.push(r)).unwrap();
    assert_eq!(done, [0, 1, 2]);
    let o = &data.observations;
    let pick = |keep: &dyn Fn(usize) -> bool| Observations {
        probes: (o.probes.iter().enumerate())
            .filter(|(j, _)| keep(*j))
            .map(|(_, p)| *p)
            .collect(),
        distances: (o.distances.iter().enumerate())
            .filter(|(j, _)| keep(*j))
            .map(|(_, d)| *d)
            .collect(),
        ..o.clone()
    };
    let fit = data.with_observations(pick(&|j| j % 3 != 1));
    let calibration = calibrate_mechanism(&fit, &options, &mut |_| {}).unwrap();
    let calibrated = CalibratedMechanism::of_calibration(&calibration).unwrap();
    let held_out = data.with_observations(pick(&|j| j % 3 == 1));
    let fold = validate_mechanism(&calibrated, &held_out, options.alpha, None).unwrap();
    let of_fold: Vec<_> = (cross.rows.iter())
        .filter(|row| matches!(&row.observation, HeldOut::Observation(o) if o.index % 3 == 1))
        .collect();
    assert_eq!(of_fold.len(), fold.rows.len());
    for (pooled, own) in of_fold.iter().zip(&fold.rows) {
        let (HeldOut::Observation(a), HeldOut::Observation(b)) =
            (&pooled.observation, &own.observation)
        else {
            panic!("{pooled:?} {own:?}");
        };
        assert_eq!((a.kind, a.index), (b.kind, 3 * b.index + 1));
        assert_eq!((pooled.residual, pooled.sigma), (own.residual, own.sigma));
    }
    // Every observation is predicted once.
    assert_eq!(cross.rows.len(), o.probes.len() + o.distances.len());
}

/// Over the 40 printers `printer(0..40)`, `folds` folds each: the pooled
/// `T / n` has mean 1 within 4 standard errors (`T` is `χ²(n)` to first
/// order when the stated noise is the noise); `what` names them in the
/// printed figure.
fn pooled_ratio_has_mean_one(what: &str, printer: impl Fn(u64) -> MechanismData, folds: usize) {
    let ratios: Vec<f64> = (0..40)
        .map(|seed| {
            let data = printer(seed);
            let cross =
                cross_validate_mechanism(&data, &MechanismOptions::default(), folds, &mut |_| {})
                    .unwrap();
            cross.statistic / cross.rows.len() as f64
        })
        .collect();
    let (mean, se) = mean_and_standard_error(&ratios);
    println!("pooled T/n over 40 printers{what}: {mean:.3} ± {se:.3}");
    assert!((mean - 1.0).abs() < 4.0 * se, "{mean} ± {se}");
}

/// Over 40 simulated printers, 4 folds each.
#[test]
fn the_pooled_statistic_has_its_degrees_of_freedom_as_mean() {
    pooled_ratio_has_mean_one("", |seed| printer(100 + seed), 4);
}

/// A simulated printer's data with `balls` balls touched 7 times each
/// besides its probe heights, the balls tied by a plate's distances when
/// `plate` says so.
fn touched(seed: u64, balls: usize, plate: bool) -> MechanismData {
    let scenario = DeltaScenario {
        balls,
        plate: plate.then_some(Plate {
            pairs: PlatePairs::All,
            sigma: 0.002,
        }),
        ..DeltaScenario::typical()
    };
    MechanismData::from_dataset(&simulate_delta(&scenario, seed).unwrap()).unwrap()
}

/// Balls are folded whole: ball `b` and its touches in fold `b mod K`,
/// fitted to its own touches there; its rows name the ball and its touches
/// by their indices in the whole data, and the fold made by hand gives the
/// same rows. Balls a plate ties are one set, held out together.
#[test]
fn a_ball_is_held_out_with_its_touches_and_tied_balls_together() {
    let data = touched(2, 6, false);
    let options = MechanismOptions::default();
    let cross = cross_validate_mechanism(&data, &options, 3, &mut |_| {}).unwrap();
    let o = &data.observations;
    let balls: Vec<usize> = (cross.rows.iter())
        .filter_map(|row| match &row.observation {
            HeldOut::Ball { ball, touches } => {
                let own: Vec<usize> = (0..o.touches.len())
                    .filter(|&j| o.touches[j].ball == *ball)
                    .collect();
                assert_eq!(*touches, own, "ball {ball}");
                Some(*ball)
            }
            _ => None,
        })
        .collect();
    let mut seen = balls.clone();
    seen.dedup();
    assert_eq!(seen, [0, 3, 1, 4, 2, 5]);
    // Fold 1 by hand: balls 1 and 4 (renumbered 0 and 1) with their
    // touches and the probes 1, 4, 7, ... held out.
    let keep = |j: usize, held: bool| (j % 3 == 1) == held;
    let pick = |held: bool| {
        let balls: Vec<usize> = (0..o.balls.len()).filter(|&b| keep(b, held)).collect();
        Observations {
            probes: (o.probes.iter().enumerate())
                .filter(|(j, _)| keep(*j, held))
                .map(|(_, p)| *p)
                .collect(),
            balls: balls.iter().map(|&b| o.balls[b]).collect(),
            touches: (o.touches.iter())
                .filter(|t| keep(t.ball, held))
                .map(|t| {
                    let mut t = t.clone();
                    t.ball = balls.iter().position(|&b| b == t.ball).unwrap();
                    t
                })
                .collect(),
            ..o.clone()
        }
    };
    let fit = data.with_observations(pick(false));
    let calibration = calibrate_mechanism(&fit, &options, &mut |_| {}).unwrap();
    let calibrated = CalibratedMechanism::of_calibration(&calibration).unwrap();
    let held_out = data.with_observations(pick(true));
    let fold = validate_mechanism(&calibrated, &held_out, options.alpha, None).unwrap();
    let of_fold: Vec<_> = (cross.rows.iter())
        .filter(|row| match &row.observation {
            HeldOut::Observation(o) => o.index % 3 == 1,
            HeldOut::Ball { ball, .. } => ball % 3 == 1,
            _ => false,
        })
        .collect();
    assert_eq!(of_fold.len(), fold.rows.len());
    for (pooled, own) in of_fold.iter().zip(&fold.rows) {
        assert_eq!((pooled.residual, pooled.sigma), (own.residual, own.sigma));
    }
    // A plate ties the six balls: one set, in fold 0 of 3.
    let plated = touched(2, 6, true);
    let cross = cross_validate_mechanism(&plated, &options, 3, &mut |_| {}).unwrap();
    let tied: Vec<_> = (cross.rows.iter())
        .filter_map(|row| match &row.observation {
            HeldOut::TiedBalls {
                balls, distances, ..
            } => Some((balls.clone(), distances.len())),
            _ => None,
        })
        .collect();
    assert!(!tied.is_empty());
    assert!(
        tied.iter()
            .all(|(balls, distances)| *balls == [0, 1, 2, 3, 4, 5] && *distances == 15)
    );
}

/// Over 40 simulated printers with 6 balls besides their probe heights, 3
/// folds each.
#[test]
fn the_pooled_statistic_with_balls_has_its_degrees_of_freedom_as_mean() {
    pooled_ratio_has_mean_one(" with balls", |seed| touched(200 + seed, 6, false), 3);
}

/// A simulated printer's data with `trackers` trackers of `points` points
/// each besides its probe heights.
fn tracked(seed: u64, trackers: usize, points: usize) -> MechanismData {
    let scenario = DeltaScenario {
        trackers,
        points_per_tracker: points,
        ..DeltaScenario::typical()
    };
    MechanismData::from_dataset(&simulate_delta(&scenario, seed).unwrap()).unwrap()
}

/// A tracker's `k`-th point is in fold `k mod K`: each tracker's rows in
/// each fold name its points there by their indices in the whole data,
/// every point once.
#[test]
fn a_tracker_is_in_every_fold_with_its_points_interleaved() {
    let data = tracked(3, 2, 12);
    let cross =
        cross_validate_mechanism(&data, &MechanismOptions::default(), 3, &mut |_| {}).unwrap();
    let mut seen: Vec<(usize, Vec<usize>)> = Vec::new();
    for row in &cross.rows {
        if let HeldOut::Tracker {
            tracker, points, ..
        } = &row.observation
            && seen.last() != Some(&(*tracker, points.clone()))
        {
            seen.push((*tracker, points.clone()));
        }
    }
    let o = &data.observations;
    let of = |t: usize| -> Vec<usize> {
        (0..o.tracker_points.len())
            .filter(|&j| o.tracker_points[j].tracker == t)
            .collect()
    };
    let expected: Vec<(usize, Vec<usize>)> = (0..3)
        .flat_map(|r| (0..2).map(move |t| (t, of(t).into_iter().skip(r).step_by(3).collect())))
        .collect();
    assert_eq!(seen, expected);
}

/// Over 40 simulated printers with 2 trackers of 12 points besides their
/// probe heights, 3 folds each.
#[test]
fn the_pooled_statistic_with_trackers_has_its_degrees_of_freedom_as_mean() {
    pooled_ratio_has_mean_one(" with trackers", |seed| tracked(300 + seed, 2, 12), 3);
}

#[test]
fn folds_that_would_hold_too_little_are_refused() {
    let data = printer(1);
    let options = MechanismOptions::default();
    let refused = |folds: usize, data: &MechanismData| {
        cross_validate_mechanism(data, &options, folds, &mut |_| {})
            .unwrap_err()
            .to_string()
    };
    let n = data.observations.probes.len();
    assert!(
        refused(1, &data).contains("give from 2 to"),
        "{}",
        refused(1, &data)
    );
    let error = refused(n + 1, &data);
    assert!(
        error.contains(&format!("whose most numerous kind has {n} observations")),
        "{error}"
    );
    // 3 folds of a tracker's 8 points would leave 2 in a fold.
    let error = refused(3, &tracked(1, 2, 8));
    assert!(
        error.contains("has 8 points and poses: 3 folds need 9 (3 a fold, to locate its frame)"),
        "{error}"
    );
}
