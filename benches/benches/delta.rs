//! The linear delta: one inverse and forward kinematics, the readings'
//! analytic derivatives, the probe heights' Jacobian at 25 points, and
//! on those 25 probes RepRapFirmware's 9-factor auto-calibration, Klipper's
//! `DELTA_CALIBRATE` and parcal's calibration (all 16 parameters, the
//! trigger height, the default tolerances as the prior).

use std::sync::Arc;

use criterion::{Criterion, criterion_group, criterion_main};
use parcal_calibrate::mechanism::{
    MechanismData, MechanismOptions, Observations, calibrate_mechanism,
};
use parcal_firmware::autocal::auto_calibrate;
use parcal_firmware::klipper::{KlipperDelta, fit};
use parcal_firmware::probes::ProbePoint;
use parcal_firmware::rrf::RrfDelta;
use parcal_kinematics::delta::{LinearDelta, probe_height, probe_height_jacobian, probe_rings};
use parcal_kinematics::mechanism::{Mechanism, design};
use parcal_observe::mechanism::ProbeHeight;
use std::hint::black_box;

fn delta(c: &mut Criterion) {
    let delta = LinearDelta::typical();
    let p = design(&delta);
    let pose = [30.0, -40.0, 80.0];
    let q = delta.inverse(p.as_slice(), &pose).unwrap();
    c.bench_function("delta inverse", |b| {
        b.iter(|| {
            delta
                .inverse(black_box(p.as_slice()), black_box(&pose))
                .unwrap()
        })
    });
    c.bench_function("delta forward", |b| {
        b.iter(|| {
            delta
                .forward(black_box(p.as_slice()), black_box(q.as_slice()), &[0.0; 3])
                .unwrap()
        })
    });
    c.bench_function("delta reading jacobians", |b| {
        b.iter(|| {
            delta
                .reading_jacobians(black_box(p.as_slice()), black_box(&pose))
                .unwrap()
        })
    });
    let points = probe_rings(100.0, 3, 8);
    c.bench_function("delta probe height jacobian, 25 points", |b| {
        b.iter(|| probe_height_jacobian(&delta, black_box(p.as_slice()), &points).unwrap())
    });
    // A printer off its firmware's parameters by a few tenths.
    let firmware = RrfDelta {
        diagonals: [270.0; 3],
        radius: 135.0,
        homed_height: 300.0,
        print_radius: 110.0,
        ..RrfDelta::default()
    };
    let truth = RrfDelta {
        diagonals: [270.3; 3],
        radius: 134.6,
        angle_corrections: [0.2, -0.15, 0.0],
        endstop_adjustments: [0.3, -0.1, -0.2],
        tilt: [0.05, -0.03],
        ..firmware
    };
    let (t, f) = (
        truth.to_params().to_vector(),
        firmware.to_params().to_vector(),
    );
    let probes: Vec<ProbePoint> = points
        .iter()
        .map(|&[x, y]| ProbePoint {
            x,
            y,
            z: probe_height(&delta, t.as_slice(), f.as_slice(), x, y).unwrap(),
        })
        .collect();
    c.bench_function("RepRapFirmware 9-factor auto-calibration, 25 points", |b| {
        b.iter(|| auto_calibrate(black_box(&firmware), black_box(&probes), 9).unwrap())
    });
    // Klipper: the same probes at their carriages' readings, z_offset 0.
    let readings: Vec<[f64; 3]> = (probes.iter())
        .map(|p| {
            let q = delta.inverse(f.as_slice(), &[p.x, p.y, p.z]).unwrap();
            [q[0], q[1], q[2]]
        })
        .collect();
    let settings = KlipperDelta::from_params(&firmware.to_params(), 110.0).unwrap();
    c.bench_function("Klipper DELTA_CALIBRATE, 25 points", |b| {
        b.iter(|| fit(black_box(&settings), black_box(&readings), 0.0, &[], &[]).unwrap())
    });
    // The same probes, the trigger height 0 mm known to 0.05 mm.
    let observations = Observations {
        probes: probes
            .iter()
            .map(|p| ProbeHeight {
                commanded: [p.x, p.y, p.z],
                sigma: 0.01,
            })
            .collect(),
        ..Default::default()
    };
    let data = MechanismData::new(
        Arc::new(LinearDelta::typical()),
        f.iter().copied().collect(),
        observations,
    )
    .with_trigger_height(0.0, Some(0.05));
    c.bench_function("parcal delta calibration, 25 probes", |b| {
        b.iter(|| {
            calibrate_mechanism(black_box(&data), &MechanismOptions::default(), &mut |_| {})
                .unwrap()
        })
    });
}

criterion_group!(benches, delta);
criterion_main!(benches);
