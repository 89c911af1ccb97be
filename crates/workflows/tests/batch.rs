//! The calibration linearises a ball's contacts in batches
//! (`Problem::linearize_batch`: their forward kinematics together, in SIMD
//! lanes on a machine with AVX2). A batch gives what one contact at a time
//! gives, to rounding, and names the same failing contact.

use crate::common;

use common::options;
use nalgebra::{DVector, SVector, Vector2};
use parcal_calibrate::problem::{
    CalibrationProblem, ContactJacobian, CoordinateObservations, GlobalValues,
};
use parcal_calibrate::setup::{Observations, Setup};
use parcal_dataset::Dataset;
use parcal_kinematics::forward_batch::PivotOrder;
use parcal_kinematics::{N_PARAMS, Params, Pose, Vec3};
use parcal_simulate::{Scenario, simulate};
use parcal_solver::{BATCH, GlobalJacobian, Linearization, LocalRows, Problem};

type Lin = Linearization<3, 2, 3, ContactJacobian<3, 3>>;

fn dataset() -> Dataset {
    simulate(&Scenario::scaled(12, 7, 10f64.to_radians()), 3)
        .unwrap()
        .dataset
}

/// The solver's global block of the parameters `params`.
fn global_block(params: &Params) -> DVector<f64> {
    DVector::from_column_slice(params.as_slice())
}

fn setup(dataset: &Dataset) -> (Setup, CoordinateObservations) {
    let (setup, observations) = Setup::new(dataset, &options()).unwrap();
    let Observations::Coordinates(observations) = observations else {
        unreachable!("simulation IV observes coordinates")
    };
    (setup, observations)
}

/// `|a - b| <= tolerance max(|b|, 1)`, entry by entry.
fn assert_close(a: &[f64], b: &[f64], tolerance: f64, what: &str) {
    let scale = b.iter().fold(1.0_f64, |m, x| m.max(x.abs()));
    for (x, y) in a.iter().zip(b) {
        assert!(
            (x - y).abs() <= tolerance * scale,
            "{what}: {a:?} against {b:?}"
        );
    }
}

/// What rounding leaves of a whitened coordinate: a few ulps of a tip
/// coordinate (under 500 mm here) over the smallest sigma of the weights
/// (the machine's 1 µm repeatability), `16 ε · 500 / 1e-3`, about 1.8e-9.
/// The lanes' LU pivots as the scalar code does only to rounding, and
/// the two forward kinematics may end an ulp apart.
const WHITENED_ROUNDING: f64 = 16.0 * f64::EPSILON * 500.0 / 1e-3;

type Calibration<'a> = CalibrationProblem<'a, CoordinateObservations, 3>;

/// `linearize_along_batch` of the contacts `first..first + angles.len()`
/// of the ball at `centre` along `dg`, from `poses` (left predicted after
/// the step): their linearisations, `d_global dg` and anchors.
#[allow(clippy::too_many_arguments)]
fn along_batch(
    problem: &Calibration<'_>,
    first: usize,
    global: &GlobalValues<3>,
    centre: &SVector<f64, 3>,
    angles: &[Vector2<f64>],
    poses: &mut [Pose],
    dg: &DVector<f64>,
    workspace: &mut PivotOrder,
) -> (Vec<Lin>, Vec<SVector<f64, 3>>, Vec<Vec3>) {
    let n = angles.len();
    let mut batch: Vec<Lin> = (0..n).map(|_| Lin::zeros(N_PARAMS)).collect();
    let mut steps = vec![SVector::<f64, 3>::zeros(); n];
    let mut anchors = vec![Vec3::zeros(); n];
    problem
        .linearize_along_batch(
            first,
            global,
            centre,
            angles,
            poses,
            dg,
            &mut batch,
            &mut steps,
            &mut anchors,
            workspace,
        )
        .unwrap();
    (batch, steps, anchors)
}

/// The linearisations agree: the blocks to rounding, and (`global`) the
/// global Jacobian row by row.
fn assert_same(batch: &Lin, single: &Lin, global: bool) {
    assert_close(
        batch.residual.as_slice(),
        single.residual.as_slice(),
        WHITENED_ROUNDING,
        "residual",
    );
    assert_close(
        batch.d_group.as_slice(),
        single.d_group.as_slice(),
        1e-12,
        "d_group",
    );
    assert_close(
        batch.d_point.as_slice(),
        single.d_point.as_slice(),
        1e-12,
        "d_point",
    );
    if global {
        for r in 0..3 {
            let (mut a, mut b) = ([0.0; N_PARAMS], [0.0; N_PARAMS]);
            batch.d_global.row(r, &mut a);
            single.d_global.row(r, &mut b);
            assert_close(&a, &b, 1e-9, "d_global");
        }
        let iterations = batch.d_global.tip.iterations;
        assert_eq!(iterations, single.d_global.tip.iterations);
    }
}

fn assert_same_pose(a: &Pose, b: &Pose) {
    assert!((a.translation.vector - b.translation.vector).amax() < 1e-9);
    assert!(a.rotation.angle_to(&b.rotation) < 1e-12);
}

#[test]
fn a_batch_is_its_contacts_one_at_a_time() {
    let dataset = dataset();
    let (setup, observations) = setup(&dataset);
    let problem = setup.problem(&dataset, &options(), observations);
    // Mid-run: parameters away from the design, angles away from zero, the
    // poses the design's (two Newton steps per contact).
    let global = problem.prepare_global(&global_block(
        &(setup.initial_params + Params::repeat(1e-3)),
    ));
    let dg = DVector::from_fn(N_PARAMS, |k, _| 1e-4 * (k as f64 - 16.0));
    let mut lanes_used = 0;
    for k in 0..problem.n_groups() {
        let centre = setup.initial_centres[k];
        let contacts = problem.group_points(k);
        for first in contacts.clone().step_by(BATCH) {
            let n = (contacts.end - first).min(BATCH);
            let range = first..first + n;
            let angles: Vec<_> = range
                .clone()
                .map(|i| Vector2::new(1e-3 * i as f64, -2e-3))
                .collect();
            // The back-substitution's lanes carry their row order from
            // batch to batch, as the solver's chunks do.
            let mut workspace = PivotOrder::default();
            for along in [false, true] {
                let mut poses = setup.poses[range.clone()].to_vec();
                let (batch, steps, _) = if along {
                    along_batch(
                        &problem,
                        first,
                        &global,
                        &centre,
                        &angles,
                        &mut poses,
                        &dg,
                        &mut workspace,
                    )
                } else {
                    let mut batch: Vec<Lin> = (0..n).map(|_| Lin::zeros(N_PARAMS)).collect();
                    problem
                        .linearize_batch(
                            first,
                            &global,
                            &centre,
                            &angles,
                            &mut poses,
                            &mut batch,
                            &mut workspace,
                        )
                        .unwrap();
                    (batch, Vec::new(), Vec::new())
                };
                for (j, i) in range.clone().enumerate() {
                    let mut pose = setup.poses[i];
                    let mut single = Lin::zeros(N_PARAMS);
                    if along {
                        let step = problem
                            .linearize_along(
                                i,
                                &global,
                                &centre,
                                &angles[j],
                                &mut pose,
                                &dg,
                                &mut single,
                            )
                            .unwrap();
                        assert_close(step.as_slice(), steps[j].as_slice(), 1e-9, "d_global dg");
                    } else {
                        problem
                            .linearize(i, &global, &centre, &angles[j], &mut pose, &mut single)
                            .unwrap();
                    }
                    // The back-substitution needs only `d_global dg` (the
                    // steps, above) and keeps the predicted poses.
                    assert_same(&batch[j], &single, !along);
                    assert_same_pose(&poses[j], &pose);
                }
                lanes_used += usize::from(n > 1);
            }
        }
    }
    assert!(lanes_used > 20, "batches of several contacts: {lanes_used}");
}

#[test]
fn a_batch_names_its_first_failing_contact() {
    let mut dataset = dataset();
    let (setup, observations) = setup(&dataset);
    // The sixth contact of ball 0 (sorted order) cannot be reached, and
    // neither can the seventh: both in the batch's second group of lanes.
    let contacts = setup.groups[0].clone();
    assert!(contacts.len() > 6 && contacts.len() <= BATCH, "one batch");
    for j in [5, 6] {
        let row = setup.order[contacts.start + j] as usize;
        dataset.measurements.q[row] = [-1e4; 6];
    }
    let problem = setup.problem(&dataset, &options(), observations);
    let global = problem.prepare_global(&global_block(&setup.initial_params));
    let centre = setup.initial_centres[0];
    let range = contacts;
    let angles = vec![Vector2::zeros(); range.len()];
    let mut poses = setup.poses[range.clone()].to_vec();
    let mut batch: Vec<Lin> = range.clone().map(|_| Lin::zeros(N_PARAMS)).collect();
    let workspace = &mut PivotOrder::default();
    let (failed, error) = problem
        .linearize_batch(
            range.start,
            &global,
            &centre,
            &angles,
            &mut poses,
            &mut batch,
            workspace,
        )
        .expect_err("an unreachable contact");
    assert_eq!(failed, range.start + 5);
    let mut steps = vec![SVector::<f64, 3>::zeros(); range.len()];
    let along = problem
        .linearize_along_batch(
            range.start,
            &global,
            &centre,
            &angles,
            &mut setup.poses[range.clone()].to_vec(),
            &DVector::from_element(N_PARAMS, 1e-3),
            &mut batch,
            &mut steps,
            &mut vec![Vec3::zeros(); range.len()],
            workspace,
        )
        .expect_err("an unreachable contact");
    assert_eq!((along.0, along.1.to_string()), (failed, error.to_string()));
    let mut pose = setup.poses[failed];
    let single = problem
        .linearize(
            failed,
            &global,
            &centre,
            &angles[0],
            &mut pose,
            &mut Lin::zeros(N_PARAMS),
        )
        .expect_err("the same contact alone");
    assert_eq!(error.to_string(), single.to_string());
    assert!(error.to_string().contains("measurement row"), "{error}");
}

/// The back-substitution's anchors: each contact's tool tip at the new
/// parameters to first order, `T + J_f dg`, at which its local rows are
/// its rows along the step. The observation block is affine in the tip
/// with a `d_group` and `d_point` that do not depend on it, so the local
/// rows' residual is `r + d_global dg` to rounding and their Jacobians
/// are the linearisation's; and the anchor's distance from the tip that
/// forward kinematics gives at `p + dg` is of second order in `dg`.
#[test]
fn a_contact_s_local_rows_at_its_anchor_are_its_rows_along_the_step() {
    let dataset = dataset();
    let (setup, observations) = setup(&dataset);
    let problem = setup.problem(&dataset, &options(), observations);
    let params = setup.initial_params + Params::repeat(1e-3);
    let global = problem.prepare_global(&global_block(&params));
    let direction = DVector::from_fn(N_PARAMS, |k, _| 1e-3 * (k as f64 - 16.0));
    let k = 0;
    let centre = setup.initial_centres[k];
    let range = problem.group_points(k);
    let n = range.len().min(BATCH);
    let angles: Vec<_> = (0..n)
        .map(|j| Vector2::new(2e-3 * j as f64, -1e-3))
        .collect();
    let workspace = &mut PivotOrder::default();
    // The anchor's error from the tip after the step, for `dg` and `dg / 2`.
    let mut errors = Vec::new();
    for scale in [1.0, 0.5] {
        let dg = &direction * scale;
        let mut poses = setup.poses[range.start..range.start + n].to_vec();
        let (batch, steps, anchors) = along_batch(
            &problem,
            range.start,
            &global,
            &centre,
            &angles,
            &mut poses,
            &dg,
            workspace,
        );
        let stepped = problem.prepare_global(&global_block(
            &(params + Params::from_column_slice(dg.as_slice())),
        ));
        let mut worst = 0.0_f64;
        for j in 0..n {
            let i = range.start + j;
            let mut rows = LocalRows::default();
            let has = problem.local_rows(i, &anchors[j], &centre, &angles[j], &mut rows);
            assert!(has.unwrap(), "the calibration's contacts have local rows");
            let along = batch[j].residual + steps[j];
            assert_close(
                rows.residual.as_slice(),
                along.as_slice(),
                WHITENED_ROUNDING,
                "residual",
            );
            assert_close(
                rows.d_group.as_slice(),
                batch[j].d_group.as_slice(),
                1e-12,
                "d_group",
            );
            assert_close(
                rows.d_point.as_slice(),
                batch[j].d_point.as_slice(),
                1e-12,
                "d_point",
            );
            let mut pose = setup.poses[i];
            let mut after = Lin::zeros(N_PARAMS);
            problem
                .linearize(i, &stepped, &centre, &angles[j], &mut pose, &mut after)
                .unwrap();
            worst = worst.max((anchors[j] - after.d_global.tip.tool_tip).norm());
        }
        errors.push(worst);
    }
    // Second order: halving the step quarters the error (within 10 %),
    // an error far above the kinematics' tolerance.
    let ratio = errors[0] / errors[1];
    assert!(errors[1] > 1e-9, "errors {errors:?}");
    assert!(
        (ratio - 4.0).abs() < 0.4,
        "errors {errors:?}, ratio {ratio}"
    );
}
