//! The estimate in the mechanism's canonical frame.
//!
//! The fit runs in the frame the priors are stated in: the gauge freedoms
//! ([`Mechanism::gauge_freedoms`]: combinations of the parameters that
//! change no measurement) are then determined by the priors alone, and
//! their values mean nothing about the machine. The result is reported
//! in the canonical frame ([`Mechanism::canonicalize`]), `c(p)`, where
//! they are fixed: its values are functions of what the data and priors
//! determine, the same whatever the gauge directions held.
//!
//! The covariance follows by linear propagation, `Cov(c) = J_c Cov(p)
//! J_cᵀ`, with `J_c = dc/dp` by central differences (the trait has no
//! analytic derivative of its canonical frame); `J_c` maps every gauge
//! direction to zero, so this projects the gauge out of the covariance,
//! which is of rank `n − (number of gauge freedoms)`. The trigger height
//! passes unchanged; a tracker's frame follows the mechanism's frame (the
//! rigid motion of its tool points, `C ∘ A⁻¹`, docs/trackers.md), and its
//! correction is then among the differentiated unknowns.

use nalgebra::{DMatrix, DVector};
use parcal_kinematics::mechanism::Mechanism;

use super::error::MechanismCalibrationError;

/// Relative step of the central differences of the canonical frame, in
/// units of each unknown's scale (its prior sigma, else 1): the
/// truncation error is of order its square, the rounding error of order
/// `ε |c| / step`, both far below the sigmas.
const STEP: f64 = 1e-4;

/// The estimate and its covariance in the canonical frame.
pub struct Canonical {
    /// The global block in the canonical frame.
    pub values: DVector<f64>,
    /// `T = diag(J_c, I)`, the derivative of the canonical global block.
    pub transform: DMatrix<f64>,
    /// `T Cov Tᵀ`.
    pub covariance: Option<DMatrix<f64>>,
}

/// `c(p)` of the first `n` values of `global`, the rest unchanged; the
/// covariance propagated (module doc). `scale` holds each parameter's
/// step scale.
pub fn canonical(
    mechanism: &dyn Mechanism,
    global: &DVector<f64>,
    covariance: Option<&DMatrix<f64>>,
    scale: &[f64],
) -> Result<Canonical, MechanismCalibrationError> {
    let n = scale.len();
    let map = |global: &[f64]| canonical_params(mechanism, global, n);
    canonical_by(&map, global, covariance, scale)
}

/// `global` with its first `n` values, the mechanism's parameters, in the
/// canonical frame.
pub(crate) fn canonical_params(
    mechanism: &dyn Mechanism,
    global: &[f64],
    n: usize,
) -> Result<DVector<f64>, MechanismCalibrationError> {
    let mut values = DVector::from_column_slice(global);
    let params = mechanism.canonicalize(&global[..n]).map_err(|source| {
        MechanismCalibrationError::Kinematics {
            mechanism: mechanism.name().to_string(),
            source,
        }
    })?;
    values.rows_mut(0, n).copy_from(&params);
    Ok(values)
}

/// The global block `global` in the canonical frame, `map(global)`, and
/// its covariance propagated (module doc): `map` changes the first
/// `scale.len()` unknowns at most, `scale` holding each one's step scale.
pub(crate) fn canonical_by(
    map: &impl Fn(&[f64]) -> Result<DVector<f64>, MechanismCalibrationError>,
    global: &DVector<f64>,
    covariance: Option<&DMatrix<f64>>,
    scale: &[f64],
) -> Result<Canonical, MechanismCalibrationError> {
    let n = scale.len();
    let values = map(global.as_slice())?;
    let leading = |p: &[f64]| {
        let mut moved = global.clone();
        moved.rows_mut(0, n).copy_from_slice(p);
        map(moved.as_slice()).map(|values| values.rows(0, n).into_owned())
    };
    let jacobian = canonical_jacobian(&leading, &global.as_slice()[..n], scale)?;
    let g = global.len();
    let mut transform = DMatrix::identity(g, g);
    transform.view_mut((0, 0), (n, n)).copy_from(&jacobian);
    let covariance = covariance.map(|covariance| &transform * covariance * transform.transpose());
    Ok(Canonical {
        values,
        transform,
        covariance,
    })
}

/// `J_c = dc/dp` at `params` by central differences.
pub(crate) fn canonical_jacobian(
    canonicalize: &impl Fn(&[f64]) -> Result<DVector<f64>, MechanismCalibrationError>,
    params: &[f64],
    scale: &[f64],
) -> Result<DMatrix<f64>, MechanismCalibrationError> {
    let n = params.len();
    let mut jacobian = DMatrix::zeros(n, n);
    for k in 0..n {
        let h = STEP * scale[k];
        let (mut plus, mut minus) = (params.to_vec(), params.to_vec());
        plus[k] += h;
        minus[k] -= h;
        let column = (canonicalize(&plus)? - canonicalize(&minus)?) / (2.0 * h);
        jacobian.set_column(k, &column);
    }
    Ok(jacobian)
}

#[cfg(test)]
mod tests {
    use super::*;
    use parcal_kinematics::delta::LinearDelta;
    use parcal_kinematics::mechanism::{design, prior_sigma};

    #[test]
    fn the_canonical_derivative_removes_every_gauge_direction() {
        // J_c z = 0 for each gauge freedom z, and J_c is a projector
        // (canonical twice is canonical): J_c J_c = J_c, to the
        // differences' accuracy.
        let delta = LinearDelta::typical();
        let mut p = design(&delta);
        p[0] = 0.3;
        p[9] = -0.2;
        p[14] = 0.1;
        let scale: Vec<f64> = prior_sigma(&delta).iter().copied().collect();
        let canonicalize = |p: &[f64]| {
            delta
                .canonicalize(p)
                .map_err(|source| MechanismCalibrationError::Kinematics {
                    mechanism: "linear delta".into(),
                    source,
                })
        };
        let canonical = canonicalize(p.as_slice()).unwrap();
        let jacobian = canonical_jacobian(&canonicalize, canonical.as_slice(), &scale).unwrap();
        for freedom in delta.gauge_freedoms(canonical.as_slice()).unwrap() {
            let moved = (&jacobian * &freedom.direction).amax();
            assert!(moved < 1e-7, "{}: {moved:e}", freedom.name);
        }
        let square = &jacobian * &jacobian;
        assert!((&square - &jacobian).amax() < 1e-7);
        let rank = jacobian
            .singular_values()
            .iter()
            .filter(|&&s| s > 1e-6)
            .count();
        assert_eq!(rank, 16 - 5);
    }
}
