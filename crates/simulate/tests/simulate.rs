//! The simulated campaign against its own definition (docs/paper-scenario.md section 3).

use parcal_dataset::Dataset;
use parcal_kinematics::Vec3;
use parcal_simulate::{Plate, PlatePairs, Scenario, SimulateError, simulate};

#[test]
fn contacts_lie_on_their_balls_and_readings_are_deterministic() {
    let scenario = Scenario::paper();
    let simulation = simulate(&scenario, 3).unwrap();
    let dataset = &simulation.dataset;
    let truth = dataset.truth.as_ref().unwrap();
    assert_eq!(dataset.measurements.q.len(), 189);
    for (row, contact) in truth.contacts.iter().enumerate() {
        let ball = dataset.measurements.ball[row] as usize;
        let centre = Vec3::from(truth.ball_centres[ball]);
        let offset = Vec3::from(*contact) - centre;
        assert!((offset.norm() - 5.0).abs() < 1e-12, "row {row}");
        assert!(
            offset.z <= 0.0,
            "row {row}: contacts are on the lower hemisphere"
        );
    }
    // Calibrated radii: 5 + N(0, 1 um), one draw per ball.
    let radii: Vec<f64> = dataset.artefacts.balls.iter().map(|b| b.radius).collect();
    assert!(radii.iter().all(|r| (r - 5.0).abs() < 0.006 && *r != 5.0));
    let again = simulate(&scenario, 3).unwrap().dataset;
    assert_eq!(&again, dataset);
    assert!(simulation.summary.worst_check < 8.0);
    assert!(simulation.summary.tilt_range.1 <= 10f64.to_radians() * 3f64.sqrt());
}

#[test]
fn every_contact_of_a_scaled_campaign_passes_the_forward_kinematics_check() {
    // The check statistic is the Mahalanobis distance of the FK tip from the
    // simulated point: noise is present (the largest of 2000 draws of a 3-D
    // normal's distance is ~4) and nothing is beyond 8 sigma.
    let simulation = simulate(&Scenario::scaled(200, 10, 10f64.to_radians()), 11).unwrap();
    assert_eq!(simulation.summary.contacts, 2000);
    assert!(simulation.summary.worst_check > 2.0, "noise is present");
    assert!(simulation.summary.worst_check < 8.0);
}

#[test]
fn an_unreachable_campaign_is_an_error_naming_the_contact() {
    // Tilts up to 80 degrees: some poses fold the platform over; forward
    // kinematics from the home pose cannot find them back.
    let scenario = Scenario {
        max_tilt: 80f64.to_radians(),
        ..Scenario::paper()
    };
    match simulate(&scenario, 1) {
        Err(SimulateError::Contact {
            ball,
            point,
            reason,
        }) => {
            assert!(ball >= 1 && point >= 1, "{reason}");
            let message = SimulateError::Contact {
                ball,
                point,
                reason,
            }
            .to_string();
            assert!(
                message.starts_with(&format!("ball {ball}, contact {point}: ")),
                "{message}"
            );
        }
        Err(other) => panic!("not a contact error: {other}"),
        Ok(_) => panic!("80-degree tilts should not all be reachable from the home pose"),
    }
}

fn with_plate(scenario: Scenario, pairs: PlatePairs, sigma: f64) -> Scenario {
    Scenario {
        plate: Some(Plate { pairs, sigma }),
        ..scenario
    }
}

#[test]
fn a_plate_leaves_everything_else_as_it_was() {
    let plain = simulate(&Scenario::paper(), 5).unwrap().dataset;
    let scenario = with_plate(Scenario::paper(), PlatePairs::All, 0.002);
    let plated = simulate(&scenario, 5).unwrap().dataset;
    assert_eq!(plated.machine, plain.machine);
    assert_eq!(plated.artefacts.balls, plain.artefacts.balls);
    assert_eq!(plated.measurements, plain.measurements);
    assert_eq!(plated.truth, plain.truth);
    assert!(plain.artefacts.distances.is_empty());

    // Every pair once, in order, with the asked sigma.
    let distances = &plated.artefacts.distances;
    assert_eq!(distances.len(), 27 * 26 / 2);
    let pairs: Vec<(usize, usize)> = distances.iter().map(|d| (d.a, d.b)).collect();
    let all: Vec<(usize, usize)> = (0..27)
        .flat_map(|a| (a + 1..27).map(move |b| (a, b)))
        .collect();
    assert_eq!(pairs, all);
    assert!(distances.iter().all(|d| d.sigma == 0.002));

    // The plate is part of the dataset: it is written and read back.
    let dir = tempfile::tempdir().unwrap();
    plated.write(dir.path()).unwrap();
    assert_eq!(Dataset::read(dir.path()).unwrap(), plated);
    assert_eq!(simulate(&scenario, 5).unwrap().dataset, plated);
}

#[test]
fn plate_distances_are_the_true_ones_with_errors_of_the_asked_sigma() {
    let sigma = 0.003;
    let scenario = with_plate(
        Scenario::scaled(200, 4, 10f64.to_radians()),
        PlatePairs::Random(5000),
        sigma,
    );
    let dataset = simulate(&scenario, 2).unwrap().dataset;
    let truth = dataset.truth.as_ref().unwrap();
    let distances = &dataset.artefacts.distances;
    assert_eq!(distances.len(), 5000);
    assert!(
        distances
            .windows(2)
            .all(|w| (w[0].a, w[0].b) < (w[1].a, w[1].b)),
        "distinct pairs, in order"
    );
    assert!(distances.iter().all(|d| d.a < d.b && d.b < 200));
    let z: Vec<f64> = distances
        .iter()
        .map(|d| {
            let centre = |i: usize| Vec3::from(truth.ball_centres[i]);
            (d.length - (centre(d.a) - centre(d.b)).norm()) / sigma
        })
        .collect();
    // z ~ N(0, 1), n = 5000: the mean has sd 1/sqrt(n) = 0.014, the mean
    // square sd sqrt(2/n) = 0.020; 5 sd each.
    let n = z.len() as f64;
    let mean = z.iter().sum::<f64>() / n;
    let mean_square = z.iter().map(|z| z * z).sum::<f64>() / n;
    assert!(mean.abs() < 5.0 * 0.014, "mean {mean}");
    assert!(
        (mean_square - 1.0).abs() < 5.0 * 0.020,
        "mean square {mean_square}"
    );

    // Another seed draws other pairs.
    let other = simulate(&scenario, 3).unwrap().dataset;
    assert_ne!(
        other
            .artefacts
            .distances
            .iter()
            .map(|d| (d.a, d.b))
            .collect::<Vec<_>>(),
        distances.iter().map(|d| (d.a, d.b)).collect::<Vec<_>>()
    );
}

#[test]
fn an_impossible_plate_is_an_error() {
    let too_many = with_plate(Scenario::paper(), PlatePairs::Random(352), 0.001);
    assert_eq!(
        simulate(&too_many, 1).err().unwrap().to_string(),
        "ball plate: 352 pairs asked for, but 27 balls have 351"
    );
    let every = with_plate(Scenario::paper(), PlatePairs::Random(351), 0.001);
    assert_eq!(
        simulate(&every, 1)
            .unwrap()
            .dataset
            .artefacts
            .distances
            .len(),
        351
    );
    for sigma in [0.0, -1.0, f64::NAN] {
        let bad = with_plate(Scenario::paper(), PlatePairs::All, sigma);
        let message = simulate(&bad, 1).err().unwrap().to_string();
        assert!(
            message.starts_with("ball plate: the sigma of a distance must be positive"),
            "{message}"
        );
    }
}

#[test]
fn a_campaign_beyond_the_row_bound_is_refused_before_anything_is_allocated() {
    use parcal_simulate::{MAX_ROWS, check_rows};
    assert_eq!(check_rows(&[("a", 1000), ("b", 7)]).unwrap(), 7000);
    assert_eq!(check_rows(&[("a", MAX_ROWS)]).unwrap(), MAX_ROWS);
    let error = check_rows(&[("--balls", usize::MAX), ("--points-per-ball", 7)])
        .unwrap_err()
        .to_string();
    assert_eq!(
        error,
        format!(
            "too large: --balls {} x --points-per-ball 7 make more than {MAX_ROWS} rows, the most a simulated campaign may have",
            usize::MAX
        )
    );
    assert!(check_rows(&[("a", MAX_ROWS), ("b", 2)]).is_err());
    // The library checks its scenarios too: a huge points_per_ball is an
    // error at once (it would allocate ~10^18 contacts).
    let huge = Scenario {
        points_per_ball: usize::MAX / 2,
        ..Scenario::paper()
    };
    assert!(matches!(
        simulate(&huge, 1),
        Err(SimulateError::TooLarge(_))
    ));
    // A plate of all pairs of 5000 balls: 12 497 500 distances.
    let plated = Scenario {
        plate: Some(Plate {
            pairs: PlatePairs::All,
            sigma: 1e-3,
        }),
        ..Scenario::scaled(5_000, 1, 0.1)
    };
    let Err(error) = simulate(&plated, 1) else {
        panic!("simulated")
    };
    let error = error.to_string();
    assert!(
        error.contains("distances of the ball plate 12497500"),
        "{error}"
    );
}
