//! docs/delta.md's side-by-side table: on simulated kit printers, the
//! first-layer flatness and the 3D error over the build volume after
//! RepRapFirmware's 6-, 7- and 9-factor auto-calibration, Klipper's
//! `DELTA_CALIBRATE` and parcal's calibration, on the same probe heights;
//! Klipper's enhanced calibration and parcal with a few part distances
//! added; and Klipper's and parcal's fits with the probe triggering off
//! its configured height, without and with a few heights measured by hand.
//!
//! `cargo run --release -p parcal-benches --example delta_vs_firmware -- [PRINTERS [SEED [DRAW [tilt]]]]`
//! (30 printers, seed 1 and DRAW `uniform` by default; or `prior`; `tilt`:
//! every printer's bed tilt drawn, then set to zero, so that its errors
//! are within Klipper's kinematics but for the towers' own radii).
//!
//! Each printer (its own random stream of the seed): rods 250-300 mm,
//! delta radius 120-150 mm, homed height 300 mm, printable radius 0.75 of
//! the delta radius or less, so that no arm leans more than about 64
//! degrees (the farthest tower at most 0.9 of a rod away). Its errors
//! about that configuration: `uniform`, within +-0.3 mm (endstops, each
//! rod, radius, tower radii, homed height) and +-0.3 degree (tower
//! angles), a bed tilt within +-0.1 %, tighter than the builder's
//! tolerances that parcal's prior states; `prior`, a draw of that prior
//! (normal, the default tolerances as sigmas). Probed at the centre and 3
//! rings of 8 points out to the printable radius, 10 um of probe noise.
//! Part distances: 6 chords of the circle of 0.9 times the printable
//! radius on the first layer (3 diameters and the triangle of the towers'
//! directions), measured to 10 um. parcal's prior: the configuration and
//! the default tolerances, the trigger height to 0.05 mm.
//!
//! The probe off its trigger height: the same printer and probe heights,
//! the probe triggering at a true height drawn from parcal's prior about
//! the configured 0.7 mm (normal, sigma 0.05 mm): each probe height is
//! raised by the difference, and both fits still take 0.7 mm (Klipper's
//! `z_offset`, parcal's prior). Manual heights: 5, at the commanded
//! positions of `parcal simulate --manual-heights`
//! (`parcal_simulate::delta::manual_height_positions`: a 5 mm gauge block
//! at the centre and on a ring at 0.6 of the printable radius), each the
//! true nozzle's height there measured to 20 um; Klipper weighs each as a
//! probe (`klipper::fit`), parcal as its noise says. The trigger height
//! and these heights are drawn from a stream of their own, `(seed,
//! MAX_PRINTERS + printer)`, so that the other rows are unchanged.
//!
//! Errors (`parcal_firmware::accuracy`): the machine's canonical frame,
//! the first layer's height offset removed; flatness at z = 0 over the
//! printable disc, 3D over the cylinder to half the homed height, on a
//! 10 mm grid. The table gives the mean over the printers of each
//! printer's RMS and max, with the standard error of the mean, and for
//! each method against the firmware's 9-factor fit the mean paired
//! difference of the RMS with its standard error. The last column is
//! what manual heights are for, the first layer's height: the mean over
//! the printers of the offset's size, `|mean e_z(z = 0)|` over the
//! printable disc (the nozzle's true height above the bed where the fit
//! sends it to z = 0), with its standard error.

use std::sync::Arc;

use parcal_calibrate::mechanism::{
    MechanismData, MechanismOptions, Observations, calibrate_mechanism,
};
use parcal_firmware::accuracy::{PositionErrors, Workspace, position_errors};
use parcal_firmware::autocal::auto_calibrate;
use parcal_firmware::klipper::{KlipperDelta, ReadDistance, ReadHeight, fit};
use parcal_firmware::probes::ProbePoint;
use parcal_firmware::rrf::RrfDelta;
use parcal_kinematics::delta::{
    DeltaParams, LinearDelta, N_PARAMS, Tolerances, probe_height, probe_rings,
};
use parcal_kinematics::mechanism::Mechanism;
use parcal_observe::mechanism::{ManualHeight, PartDistance, ProbeHeight};
use parcal_simulate::Rng;
use parcal_simulate::delta::manual_height_positions;

/// The largest number of printers a run takes.
const MAX_PRINTERS: usize = 10_000;
/// The probe noise (mm).
const PROBE_SIGMA: f64 = 0.01;
/// The part distances' noise (mm).
const DISTANCE_SIGMA: f64 = 0.01;
/// The part distances: chords of the circle of 0.9 times the printable
/// radius on the first layer, between the angles given (degrees): three
/// diameters and the triangle of the towers' directions.
const CHORDS: [(f64, f64); 6] = [
    (0.0, 180.0),
    (60.0, 240.0),
    (120.0, 300.0),
    (210.0, 330.0),
    (330.0, 90.0),
    (90.0, 210.0),
];
/// The first layer's height, where the part distances are measured (mm).
const FIRST_LAYER: f64 = 0.2;
/// The heights measured by hand: how many, and their noise (mm).
const MANUAL_HEIGHTS: (usize, f64) = (5, 0.02);

/// How a printer's errors are drawn.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Draw {
    /// Uniform within +-0.3 mm or degree (tilt +-0.1 %): tighter than the
    /// builder's tolerances, which the prior states.
    Uniform,
    /// Normal with the builder's tolerances: a draw of the prior.
    Prior,
}

/// The probe's trigger height (mm, `G31 Z`), and the sigma of its prior
/// (a first-layer test's).
const TRIGGER_HEIGHT: (f64, f64) = (0.7, 0.05);

/// One simulated printer and what was measured on it.
struct Printer {
    truth: DeltaParams,
    configured: RrfDelta,
    probes: Vec<ProbePoint>,
    distances: Vec<Distance>,
    /// The probe heights with the probe off its trigger height.
    probes_off_trigger: Vec<ProbePoint>,
    manual_heights: Vec<Height>,
}

/// A distance measured between two commanded positions.
struct Distance {
    first: [f64; 3],
    second: [f64; 3],
    measured: f64,
}

/// A height of the nozzle above the bed measured by hand at a commanded
/// position.
struct Height {
    commanded: [f64; 3],
    measured: f64,
}

/// What one calibration is given.
#[derive(Clone, Copy)]
struct Given<'a> {
    probes: &'a [ProbePoint],
    distances: &'a [Distance],
    manual_heights: &'a [Height],
}

/// Printer `index` of `seed` (module documentation), its bed level if
/// `level`.
fn printer(seed: u64, index: u64, draw: Draw, level: bool) -> Printer {
    let mut rng = Rng::new(seed, index);
    let diagonal = rng.uniform(250.0, 300.0);
    let radius = rng.uniform(120.0, 150.0);
    let configured = RrfDelta {
        diagonals: [diagonal; 3],
        radius,
        homed_height: 300.0,
        print_radius: (0.75 * radius).min(0.9 * diagonal - radius),
        ..RrfDelta::default()
    };
    let mut truth = configured.to_params();
    // Uniform errors within +-0.3 (tilt +-0.1), or a draw of the prior.
    let (d, u) = (draw == Draw::Prior, &mut rng);
    let mut error = |tolerance: f64, bound: f64| {
        if d {
            u.normal(tolerance)
        } else {
            u.uniform(-bound, bound)
        }
    };
    let t = Tolerances::default();
    for i in 0..3 {
        truth.endstop[i] += error(t.endstop, 0.3);
        truth.diagonal[i] += error(t.diagonal, 0.3);
        truth.tower_radius[i] += error(t.tower_radius, 0.3);
        truth.angle[i] += error(t.angle, 0.3);
    }
    truth.radius += error(t.radius, 0.3);
    truth.homed_height += error(t.homed_height, 0.3);
    truth.tilt = [error(t.tilt, 0.1), error(t.tilt, 0.1)];
    if level {
        truth.tilt = [0.0; 2];
    }
    let delta = kinematics(&configured);
    let (t, c) = (truth.to_vector(), configured.to_params().to_vector());
    let probes = probe_rings(configured.print_radius, 3, 8)
        .into_iter()
        .map(|[x, y]| ProbePoint {
            x,
            y,
            z: probe_height(&delta, t.as_slice(), c.as_slice(), x, y).expect("probe")
                + rng.normal(PROBE_SIGMA),
        })
        .collect::<Vec<_>>();
    let ring = 0.9 * configured.print_radius;
    let on_ring = |angle: f64| {
        let (sin, cos) = angle.to_radians().sin_cos();
        [ring * cos, ring * sin, FIRST_LAYER]
    };
    let reached = |target: &[f64; 3]| {
        let q = delta.inverse(c.as_slice(), target).expect("reach");
        delta
            .forward(t.as_slice(), q.as_slice(), target)
            .expect("reach")
    };
    let distances = CHORDS
        .iter()
        .map(|&(from, to)| {
            let (first, second) = (on_ring(from), on_ring(to));
            let measured = (reached(&first) - reached(&second)).norm() + rng.normal(DISTANCE_SIGMA);
            Distance {
                first,
                second,
                measured,
            }
        })
        .collect();
    // The probe off its trigger height and the manual heights: a stream of
    // their own.
    let mut rng = Rng::new(seed, MAX_PRINTERS as u64 + index);
    let trigger_error = rng.normal(TRIGGER_HEIGHT.1);
    let probes_off_trigger = (probes.iter())
        .map(|p| ProbePoint {
            z: p.z + trigger_error,
            ..*p
        })
        .collect();
    let manual_heights = manual_height_positions(configured.print_radius, MANUAL_HEIGHTS.0)
        .into_iter()
        .map(|commanded| Height {
            commanded,
            measured: reached(&commanded)[2] + rng.normal(MANUAL_HEIGHTS.1),
        })
        .collect();
    Printer {
        truth,
        configured,
        probes,
        distances,
        probes_off_trigger,
        manual_heights,
    }
}

/// The kinematics of a configuration, without limits beyond reach.
fn kinematics(configured: &RrfDelta) -> LinearDelta {
    LinearDelta::new(
        &configured.to_params(),
        &Default::default(),
        parcal_kinematics::delta::Limits::reach_only(configured.print_radius),
    )
}

/// parcal's calibration of `printer` from what it is `given`; the default
/// tolerances as the prior about the configuration.
fn parcal(printer: &Printer, given: &Given) -> DeltaParams {
    let configured = printer.configured.to_params().to_vector();
    let probes = (given.probes.iter())
        .map(|p| ProbeHeight {
            commanded: [p.x, p.y, p.z + TRIGGER_HEIGHT.0],
            sigma: PROBE_SIGMA,
        })
        .collect();
    let distances = (given.distances.iter())
        .map(|d| PartDistance {
            first: d.first,
            second: d.second,
            distance: d.measured,
            sigma: DISTANCE_SIGMA,
        })
        .collect();
    let manual_heights = (given.manual_heights.iter())
        .map(|h| ManualHeight {
            commanded: h.commanded,
            height: h.measured,
            sigma: MANUAL_HEIGHTS.1,
        })
        .collect();
    let observations = Observations {
        probes,
        distances,
        manual_heights,
        ..Default::default()
    };
    let data = MechanismData::new(
        Arc::new(kinematics(&printer.configured)),
        configured.iter().copied().collect(),
        observations,
    )
    .with_trigger_height(TRIGGER_HEIGHT.0, Some(TRIGGER_HEIGHT.1));
    let calibration =
        calibrate_mechanism(&data, &MechanismOptions::default(), &mut |_| {}).expect("calibration");
    DeltaParams::from_slice(&calibration.values().as_slice()[..N_PARAMS])
}

/// Klipper's `DELTA_CALIBRATE` of `printer` from what it is `given` (with
/// part distances, the enhanced calibration), each measurement at the
/// carriages' readings of its commanded position; the probe's `z_offset`
/// the configured trigger height.
fn klipper(printer: &Printer, given: &Given) -> DeltaParams {
    let configured = printer.configured.to_params();
    let delta = kinematics(&printer.configured);
    let c = configured.to_vector();
    let readings = |x: &[f64; 3]| {
        let q = delta.inverse(c.as_slice(), x).expect("reach");
        [q[0], q[1], q[2]]
    };
    let probes: Vec<[f64; 3]> = (given.probes.iter())
        .map(|p| readings(&[p.x, p.y, p.z + TRIGGER_HEIGHT.0]))
        .collect();
    let manual_heights: Vec<ReadHeight> = (given.manual_heights.iter())
        .map(|h| ReadHeight {
            readings: readings(&h.commanded),
            height: h.measured,
        })
        .collect();
    let distances: Vec<ReadDistance> = (given.distances.iter())
        .map(|d| ReadDistance {
            first: readings(&d.first),
            second: readings(&d.second),
            distance: d.measured,
        })
        .collect();
    let settings =
        KlipperDelta::from_params(&configured, printer.configured.print_radius).expect("no tilt");
    fit(
        &settings,
        &probes,
        TRIGGER_HEIGHT.0,
        &manual_heights,
        &distances,
    )
    .expect("fit")
    .to_params()
}

/// The errors of each method on one printer.
fn errors(printer: &Printer) -> Vec<PositionErrors> {
    let workspace = Workspace::of_printer(
        printer.configured.print_radius,
        printer.configured.homed_height,
    );
    let on_truth =
        |fitted: &DeltaParams| position_errors(&printer.truth, fitted, &workspace).expect("errors");
    let mut rows = vec![on_truth(&printer.configured.to_params())];
    for factors in [6, 7, 9] {
        let fit = auto_calibrate(&printer.configured, &printer.probes, factors).expect("fit");
        rows.push(on_truth(&fit.delta.to_params()));
    }
    let probes = Given {
        probes: &printer.probes,
        distances: &[],
        manual_heights: &[],
    };
    let off_trigger = Given {
        probes: &printer.probes_off_trigger,
        ..probes
    };
    for given in [
        probes,
        Given {
            distances: &printer.distances,
            ..probes
        },
        off_trigger,
        Given {
            manual_heights: &printer.manual_heights,
            ..off_trigger
        },
    ] {
        rows.push(on_truth(&klipper(printer, &given)));
        rows.push(on_truth(&parcal(printer, &given)));
    }
    rows
}

/// Mean and standard error of the mean.
fn mean_and_error(values: &[f64]) -> (f64, f64) {
    let n = values.len() as f64;
    let mean = values.iter().sum::<f64>() / n;
    let variance = values.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1.0);
    (mean, (variance / n).sqrt())
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let printers: usize = args.next().map_or(Ok(30), |s| s.parse())?;
    let seed: u64 = args.next().map_or(Ok(1), |s| s.parse())?;
    let draw = match args.next().as_deref() {
        None | Some("uniform") => Draw::Uniform,
        Some("prior") => Draw::Prior,
        Some(other) => return Err(format!("DRAW is uniform or prior, got {other}").into()),
    };
    let level = match args.next().as_deref() {
        None => false,
        Some("tilt") => true,
        Some(other) => return Err(format!("the fourth argument is tilt, got {other}").into()),
    };
    if !(2..=MAX_PRINTERS).contains(&printers) {
        return Err(format!("PRINTERS must be from 2 to {MAX_PRINTERS}, got {printers}").into());
    }
    let methods = [
        "as configured",
        "RepRapFirmware 6-factor",
        "RepRapFirmware 7-factor",
        "RepRapFirmware 9-factor",
        "Klipper DELTA_CALIBRATE",
        "parcal, probe heights",
        "Klipper enhanced, 6 part distances",
        "parcal, probe heights and 6 part distances",
        "Klipper DELTA_CALIBRATE, probe off its trigger height",
        "parcal, probe heights, probe off its trigger height",
        "Klipper, probe off its trigger height, 5 manual heights",
        "parcal, probe off its trigger height, 5 manual heights",
    ];
    let results: Vec<Vec<PositionErrors>> = (0..printers as u64)
        .map(|index| errors(&printer(seed, index, draw, level)))
        .collect();
    println!(
        "{printers} printers, seed {seed}, errors {draw:?}{}: mean over the printers (standard error), um; paired difference of the RMS against the 9-factor fit; the first layer's height offset's size",
        if level { ", bed level" } else { "" }
    );
    println!(
        "| method | flatness RMS | flatness max | 3D RMS | 3D max | flatness RMS - 9-factor | 3D RMS - 9-factor | first-layer height |"
    );
    println!("|---|---|---|---|---|---|---|---|");
    let baseline = 3;
    for (m, name) in methods.iter().enumerate() {
        let column = |f: &dyn Fn(&PositionErrors) -> f64| {
            mean_and_error(&results.iter().map(|r| 1e3 * f(&r[m])).collect::<Vec<_>>())
        };
        let paired = |f: &dyn Fn(&PositionErrors) -> f64| {
            mean_and_error(
                &results
                    .iter()
                    .map(|r| 1e3 * (f(&r[m]) - f(&r[baseline])))
                    .collect::<Vec<_>>(),
            )
        };
        let cell = |(mean, error): (f64, f64)| format!("{mean:.1} ({error:.1})");
        println!(
            "| {name} | {} | {} | {} | {} | {} | {} | {} |",
            cell(column(&|e| e.flatness_rms)),
            cell(column(&|e| e.flatness_max)),
            cell(column(&|e| e.volume_rms)),
            cell(column(&|e| e.volume_max)),
            cell(paired(&|e| e.flatness_rms)),
            cell(paired(&|e| e.volume_rms)),
            cell(column(&|e| e.z_offset.abs())),
        );
    }
    Ok(())
}
