//! One candidate's information on the unknowns `u` (the mechanism's `n`
//! parameters, then the trigger height when the plan has one), as
//! whitened rows `M` with information `MᵀM`, linearised at the parameters
//! `p` (the controller running `p_c`), by the observation kinds of the
//! calibration (`parcal_observe::mechanism`, whose doc comments give each
//! kind's rows `J = d(e/σ)/du`).
//!
//! A kind with an unknown of its own (the pose `x` of a point sample, rows
//! `K = d(e/σ)/dx`) is reduced by the Schur complement, as the calibration
//! eliminates it: its information is `Jᵀ J − Jᵀ K (KᵀK)⁻¹ Kᵀ J = Mᵀ M` with
//!
//! ```text
//! M = (I − K (KᵀK)⁻¹ Kᵀ) J,
//! ```
//!
//! the part of the rows the pose cannot absorb (rank `A − 3` for `A`
//! actuators: one for a cable robot of four lines). A measured position
//! adds rows `(x − m)/σ_x`, `J` zero and `K = I/σ_x` there, before the
//! reduction. A probe height, a height measured by hand, a measured point
//! or a part distance is taken at commanded positions: no pose of its own,
//! `M = J` (a probe's last column the trigger height's `−1/σ`; a height
//! measured by hand has no trigger height).

use nalgebra::DMatrix;
use parcal_dataset::mechanism::Noise;
use parcal_kinematics::mechanism::{Mechanism, MechanismError};
use parcal_observe::mechanism::{
    CommandedPoint, ManualHeight, PartDistance, PointSample, ProbeHeight,
};

use super::candidate::Candidate;

/// Where the rows are linearised.
#[derive(Debug, Clone, Copy)]
pub struct Linearisation<'a> {
    /// The parameters `p` (the estimate, or the design).
    pub params: &'a [f64],
    /// The parameters the controller runs with, `p_c`.
    pub configured: &'a [f64],
    /// The trigger height (mm).
    pub trigger_height: f64,
    /// The number of unknowns: `n`, or `n + 1` with the trigger height.
    pub unknowns: usize,
}

/// Why a candidate has no rows: a kind whose noise the machine does not
/// state, or a pose the mechanism cannot take.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum RowsError {
    /// machine.json has no noise of this kind.
    #[error("machine.json states no noise.{0}, the standard deviation of the measurements planned")]
    Noise(&'static str),
    /// A probe height in a plan without the trigger height among its
    /// unknowns.
    #[error("a probe height needs the trigger height among the unknowns")]
    NoTriggerHeight,
    /// The pose cannot be taken.
    #[error(transparent)]
    Mechanism(#[from] MechanismError),
}

/// `M` of `candidate` at `at` (module doc): rows × `at.unknowns`.
pub fn whitened_rows(
    mechanism: &dyn Mechanism,
    at: &Linearisation,
    noise: &Noise,
    candidate: &Candidate,
) -> Result<DMatrix<f64>, RowsError> {
    let n = mechanism.parameters().len();
    let sigma = |value: Option<f64>, name| value.ok_or(RowsError::Noise(name));
    let padded = |rows: &DMatrix<f64>| {
        let mut m = DMatrix::zeros(rows.nrows(), at.unknowns);
        m.view_mut((0, 0), (rows.nrows(), n)).copy_from(rows);
        m
    };
    match *candidate {
        Candidate::Probe([x, y]) => {
            if at.unknowns <= n {
                return Err(RowsError::NoTriggerHeight);
            }
            let probe = ProbeHeight {
                commanded: [x, y, at.trigger_height],
                sigma: sigma(noise.probe, "probe")?,
            };
            let row = probe.evaluate(mechanism, at.params, at.configured, at.trigger_height)?;
            let mut m = padded(&row.rows.d_params);
            m[(0, n)] = row.d_trigger_height;
            Ok(m)
        }
        Candidate::Point(commanded) => {
            let sigma = sigma(noise.position, "position")?;
            let point = CommandedPoint {
                commanded,
                measured: commanded,
                sigma: [sigma; 3],
            };
            Ok(padded(
                &point
                    .evaluate(mechanism, at.params, at.configured)?
                    .d_params,
            ))
        }
        Candidate::Height(commanded) => {
            // The measured height enters the residual only, not the rows.
            let height = ManualHeight {
                commanded,
                height: commanded[2],
                sigma: sigma(noise.height, "height")?,
            };
            Ok(padded(
                &height
                    .evaluate(mechanism, at.params, at.configured)?
                    .d_params,
            ))
        }
        Candidate::Distance([first, second]) => {
            // The measured value enters the residual only, not the rows.
            let distance = PartDistance {
                first,
                second,
                distance: 0.0,
                sigma: sigma(noise.distance, "distance")?,
            };
            Ok(padded(
                &distance
                    .evaluate(mechanism, at.params, at.configured)?
                    .d_params,
            ))
        }
        Candidate::Sample(pose) | Candidate::MeasuredSample(pose) => {
            let measured = matches!(candidate, Candidate::MeasuredSample(_));
            let position_sigma = if measured {
                Some(sigma(noise.position, "position")?)
            } else {
                None
            };
            let readings = mechanism.inverse(at.params, &pose)?;
            let sample = PointSample {
                readings: readings.iter().copied().collect(),
                sigma: sigma(noise.actuator, "actuator")?,
                known_pose: None,
                loads: None,
            };
            let rows = sample.evaluate(mechanism, at.params, &pose)?;
            let mut j = padded(&rows.rows.d_params);
            let mut k = rows.d_pose;
            if let Some(sigma) = position_sigma {
                let a = j.nrows();
                j = j.insert_rows(a, 3, 0.0);
                k = k.insert_rows(a, 3, 0.0);
                for c in 0..3 {
                    k[(a + c, c)] = 1.0 / sigma;
                }
            }
            eliminate(&j, &k)
        }
    }
}

/// `(I − K (KᵀK)⁻¹ Kᵀ) J` (module doc); an error if `KᵀK` is singular
/// (the readings do not fix the pose: a singular configuration).
fn eliminate(j: &DMatrix<f64>, k: &DMatrix<f64>) -> Result<DMatrix<f64>, RowsError> {
    let normal = (k.transpose() * k)
        .cholesky()
        .ok_or(RowsError::Mechanism(MechanismError::Singular))?;
    let absorbed = k * normal.solve(&(k.transpose() * j));
    Ok(j - absorbed)
}

#[cfg(test)]
mod tests {
    use super::*;
    use parcal_kinematics::cable::CableRobot;
    use parcal_kinematics::delta::LinearDelta;
    use parcal_kinematics::mechanism::design;

    /// The information of a sample at an unknown pose is the Schur
    /// complement of the dense information of parameters and pose: the
    /// parameter block of the inverse of `[JᵀJ JᵀK; KᵀJ KᵀK]` inverted,
    /// with a prior added to make it invertible.
    #[test]
    fn a_sample_s_rows_are_the_schur_complement_of_its_pose() {
        let robot = CableRobot::typical();
        let p = design(&robot);
        let n = p.len();
        let at = Linearisation {
            params: p.as_slice(),
            configured: p.as_slice(),
            trigger_height: 0.0,
            unknowns: n,
        };
        let noise = Noise {
            actuator: Some(2.0),
            position: Some(0.5),
            ..Noise::default()
        };
        for measured in [false, true] {
            let pose = [120.0, -80.0, 600.0];
            let candidate = if measured {
                Candidate::MeasuredSample(pose)
            } else {
                Candidate::Sample(pose)
            };
            let m = whitened_rows(&robot, &at, &noise, &candidate).unwrap();
            let jacobians = robot.reading_jacobians(p.as_slice(), &pose).unwrap();
            let (a, b) = (jacobians.d_params / 2.0, jacobians.d_pose / 2.0);
            let mut full = DMatrix::zeros(a.nrows(), n + 3);
            full.view_mut((0, 0), (a.nrows(), n)).copy_from(&a);
            full.view_mut((0, n), (a.nrows(), 3)).copy_from(&b);
            let mut information = full.transpose() * &full;
            if measured {
                for c in 0..3 {
                    information[(n + c, n + c)] += 4.0;
                }
            }
            let prior = DMatrix::from_diagonal_element(n, n, 1e-2);
            let mut joint = information.clone();
            for k in 0..n {
                joint[(k, k)] += prior[(k, k)];
            }
            let marginal = joint
                .try_inverse()
                .unwrap()
                .view((0, 0), (n, n))
                .clone_owned();
            let expected = marginal.try_inverse().unwrap() - &prior;
            let reduced = m.transpose() * &m;
            let error = (&reduced - &expected).amax();
            assert!(error < 1e-8 * expected.amax(), "{measured}: {error:e}");
        }
    }

    #[test]
    fn a_probe_needs_its_noise_and_the_trigger_height() {
        let delta = LinearDelta::typical();
        let p = design(&delta);
        let n = p.len();
        let mut at = Linearisation {
            params: p.as_slice(),
            configured: p.as_slice(),
            trigger_height: 0.7,
            unknowns: n + 1,
        };
        let probe = Candidate::Probe([30.0, -20.0]);
        let noise = Noise {
            probe: Some(0.01),
            ..Noise::default()
        };
        let m = whitened_rows(&delta, &at, &noise, &probe).unwrap();
        assert_eq!(m.shape(), (1, n + 1));
        assert_eq!(m[(0, n)], -100.0);
        let error = whitened_rows(&delta, &at, &Noise::default(), &probe).unwrap_err();
        assert!(error.to_string().contains("noise.probe"), "{error}");
        at.unknowns = n;
        let error = whitened_rows(&delta, &at, &noise, &probe).unwrap_err();
        assert_eq!(error, RowsError::NoTriggerHeight);
    }

    /// A height measured by hand is a probe whose trigger height is known:
    /// the probe's rows at the same sigma, without the trigger height's
    /// column.
    #[test]
    fn a_height_by_hand_is_a_probe_with_a_known_trigger_height() {
        let delta = LinearDelta::typical();
        let p = design(&delta);
        let n = p.len();
        let at = Linearisation {
            params: p.as_slice(),
            configured: p.as_slice(),
            trigger_height: 5.0,
            unknowns: n + 1,
        };
        let noise = Noise {
            probe: Some(0.02),
            height: Some(0.02),
            ..Noise::default()
        };
        let probe = whitened_rows(&delta, &at, &noise, &Candidate::Probe([30.0, -20.0])).unwrap();
        let height = Candidate::Height([30.0, -20.0, 5.0]);
        let m = whitened_rows(&delta, &at, &noise, &height).unwrap();
        assert_eq!(m.shape(), (1, n + 1));
        assert_eq!(m.columns(0, n), probe.columns(0, n));
        assert_eq!(m[(0, n)], 0.0);
        let error = whitened_rows(&delta, &at, &Noise::default(), &height).unwrap_err();
        assert_eq!(error, RowsError::Noise("height"));
    }
}
