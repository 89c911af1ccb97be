//! The simulated campaign against its own definition (spec section 3).

use parcal_kinematics::Vec3;
use parcal_simulate::{Scenario, SimulateError, simulate};

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
        Ok(_) => panic!("80-degree tilts should not all be reachable from the home pose"),
    }
}
