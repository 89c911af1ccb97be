//! What the data determine, and what only the priors do.
//!
//! - **Per parameter**: the ratio of its posterior sigma to its prior
//!   sigma, both in the canonical frame ([`super::frame`]: the prior
//!   covariance `Σ_prior` (`diag(σ²)` when the priors are independent,
//!   [`super::prior`]) propagated like the posterior's, `J_c Σ_prior
//!   J_cᵀ`). Near 1, the data taught nothing about it: it is determined
//!   by its prior. A value the canonical frame fixes (prior sigma 0 there)
//!   and a value whose canonical form involves a parameter without a prior
//!   have no ratio.
//! - **Directions**: the data-only information of the global block,
//!   `I_d = Cov(g)⁻¹ − Λ_g` (the Schur complement less the prior; the
//!   poses of point samples eliminated), on the unknowns with a prior
//!   (`A`; the others, `B`, which only the data determine, eliminated:
//!   `I_AA − I_AB I_BB⁻¹ I_BA`), scaled by their prior sigmas, `M = D I D`
//!   (`D = diag(σ)`), so that an eigenvalue `λ` compares the data's
//!   information along a direction with the prior's: the data alone
//!   would give it a sigma `1/√λ` prior sigmas. Without a prior there is
//!   nothing to compare, and nothing is reported. The gauge directions
//!   (`D⁻¹ z`, which no data see) are removed first, and every other
//!   direction with `λ < 1`, whose data-only sigma exceeds its prior
//!   sigma, is reported as set by the prior, named by the parameters that
//!   make it up (components in units of their prior sigma). A `λ` within
//!   the difference's rounding error (`g ε λ_max`) is reported as not seen
//!   at all: its `1/√λ` would be a figure of the rounding, not of the data.

use nalgebra::{DMatrix, DVector, SymmetricEigen};
use parcal_kinematics::mechanism::Mechanism;

use super::error::MechanismCalibrationError;

/// A component of a direction at least this large (of a unit vector in
/// prior-sigma units) names its parameter in the statement.
const NAMED_COMPONENT: f64 = 0.25;
/// A parameter whose posterior sigma is at least this fraction of its
/// prior sigma is stated as determined by its prior.
pub const PRIOR_BOUND: f64 = 0.9;

/// A combination of the unknowns that the data alone do not determine.
#[derive(Debug, Clone, PartialEq)]
pub struct Undetermined {
    /// Its components (name, value) in units of each unknown's prior
    /// sigma, a unit vector, largest first, down to 0.25.
    pub components: Vec<(String, f64)>,
    /// The data-only sigma along it over the prior's, `1/√λ` (infinite
    /// where the data do not see it at all).
    pub data_to_prior: f64,
}

/// What the data determine (module doc).
#[derive(Debug, Clone, PartialEq)]
#[non_exhaustive]
pub struct Identifiability {
    /// The gauge freedoms, which the canonical frame removes.
    pub gauge: Vec<String>,
    /// The unknowns' posterior sigma over their prior sigma (canonical
    /// frame), in the order of the result's parameters.
    pub sigma_ratio: Vec<Option<f64>>,
    /// The directions the data alone do not determine, weakest first.
    pub undetermined: Vec<Undetermined>,
    /// The above in words.
    pub statements: Vec<String>,
}

/// The inputs of [`identifiability`]: every matrix over the global block.
pub struct Inputs<'a> {
    /// The unknowns' names.
    pub names: &'a [String],
    /// The fit-frame covariance `Cov(g)`.
    pub covariance: &'a DMatrix<f64>,
    /// The prior information `Λ_g` (zero where no prior).
    pub prior_information: &'a DMatrix<f64>,
    /// The prior covariance `Σ_prior` (zero where no prior), whose
    /// diagonal gives the prior sigmas.
    pub prior_covariance: &'a DMatrix<f64>,
    /// The canonical frame's derivative (`T`, identity beyond the
    /// mechanism's parameters).
    pub canonical: &'a DMatrix<f64>,
    /// The gauge freedoms: names and directions (over the global block).
    pub gauge: &'a [(String, DVector<f64>)],
}

/// The gauge freedoms of `mechanism` at `params`, each direction padded
/// with zeros to the `g` unknowns of the global block (the trigger height
/// does not move with them).
pub fn gauge_directions(
    mechanism: &dyn Mechanism,
    params: &[f64],
    g: usize,
) -> Result<Vec<(String, DVector<f64>)>, MechanismCalibrationError> {
    let freedoms = mechanism.gauge_freedoms(params).map_err(|source| {
        MechanismCalibrationError::Kinematics {
            mechanism: mechanism.name().to_string(),
            source,
        }
    })?;
    Ok(freedoms
        .into_iter()
        .map(|freedom| {
            let mut direction = DVector::zeros(g);
            direction
                .rows_mut(0, params.len())
                .copy_from(&freedom.direction);
            (freedom.name.to_string(), direction)
        })
        .collect())
}

/// The identifiability of a fit (module doc); `None` when `Cov(g)` is not
/// positive definite.
pub fn identifiability(inputs: &Inputs) -> Option<Identifiability> {
    let Inputs {
        names,
        covariance,
        prior_information,
        prior_covariance,
        canonical,
        gauge,
    } = *inputs;
    let g = names.len();
    let prior_sigma: Vec<Option<f64>> = (0..g)
        .map(|k| {
            let variance = prior_covariance[(k, k)];
            (variance > 0.0).then(|| variance.sqrt())
        })
        .collect();
    let sigma_ratio = sigma_ratios(covariance, canonical, prior_covariance, &prior_sigma);
    let information = covariance.clone().cholesky()?.inverse() - prior_information;
    // The unknowns with a prior, and the data-only information about them
    // with the others (which only the data determine) eliminated.
    let with: Vec<usize> = (0..g).filter(|&k| prior_sigma[k].is_some()).collect();
    let without: Vec<usize> = (0..g).filter(|&k| prior_sigma[k].is_none()).collect();
    let block = |rows: &[usize], columns: &[usize]| {
        DMatrix::from_fn(rows.len(), columns.len(), |i, j| {
            0.5 * (information[(rows[i], columns[j])] + information[(columns[j], rows[i])])
        })
    };
    let mut data = block(&with, &with);
    if !without.is_empty() {
        let across = block(&without, &with);
        data -= across.transpose() * block(&without, &without).cholesky()?.solve(&across);
    }
    let scale = DVector::from_iterator(with.len(), prior_sigma.iter().flatten().copied());
    let scaled = DMatrix::from_fn(with.len(), with.len(), |i, j| {
        scale[i] * scale[j] * 0.5 * (data[(i, j)] + data[(j, i)])
    });
    let gauge: Vec<(String, DVector<f64>)> = gauge
        .iter()
        .map(|(name, z)| {
            (
                name.clone(),
                DVector::from_fn(with.len(), |i, _| z[with[i]]),
            )
        })
        .collect();
    let basis = complement(&gauge, &scale);
    let reduced = basis.transpose() * &scaled * &basis;
    // No unknown with a prior (or only gauge directions): nothing to weigh.
    let undetermined = if reduced.is_empty() {
        Vec::new()
    } else {
        undetermined_directions(reduced, &basis, names, &with)
    };
    let statements = statements(names, &sigma_ratio, &undetermined, &gauge);
    Some(Identifiability {
        gauge: gauge.iter().map(|(name, _)| name.clone()).collect(),
        sigma_ratio,
        undetermined,
        statements,
    })
}

/// The directions of the unknowns with a prior (`with`, of `names`) whose
/// data-only information `reduced` (in prior sigmas, on the columns of
/// `basis`) is below the prior's, weakest first (module doc).
fn undetermined_directions(
    reduced: DMatrix<f64>,
    basis: &DMatrix<f64>,
    names: &[String],
    with: &[usize],
) -> Vec<Undetermined> {
    let eigen = SymmetricEigen::new(reduced);
    let floor = rounding_floor(&eigen.eigenvalues);
    let mut order: Vec<usize> = (0..eigen.eigenvalues.len()).collect();
    order.sort_by(|&a, &b| eigen.eigenvalues[a].total_cmp(&eigen.eigenvalues[b]));
    order
        .into_iter()
        .filter(|&a| eigen.eigenvalues[a] < 1.0)
        .map(|a| {
            let lambda = eigen.eigenvalues[a];
            let direction = basis * eigen.eigenvectors.column(a);
            let mut components: Vec<(String, f64)> = direction
                .iter()
                .enumerate()
                .filter(|(_, v)| v.abs() >= NAMED_COMPONENT)
                .map(|(i, &v)| (names[with[i]].clone(), v))
                .collect();
            components.sort_by(|a, b| b.1.abs().total_cmp(&a.1.abs()));
            // One sign convention: the largest component positive.
            if components.first().is_some_and(|c| c.1 < 0.0) {
                components.iter_mut().for_each(|c| c.1 = -c.1);
            }
            Undetermined {
                components,
                data_to_prior: if lambda > floor {
                    1.0 / lambda.sqrt()
                } else {
                    f64::INFINITY
                },
            }
        })
        .collect()
}

/// The eigenvalue below which `M` cannot tell the data's information
/// from none: `I_d` is a difference, `Cov(g)⁻¹ − Λ_g`, whose rounding
/// error is about `g ε` times its largest eigenvalue (`ε` the machine
/// epsilon), so a smaller `λ` is that error, not the data (module doc).
fn rounding_floor(eigenvalues: &DVector<f64>) -> f64 {
    let largest = eigenvalues.iter().fold(0.0_f64, |m, v| m.max(v.abs()));
    eigenvalues.len() as f64 * f64::EPSILON * largest
}

/// Posterior over prior sigma of each canonical value (module doc).
fn sigma_ratios(
    covariance: &DMatrix<f64>,
    canonical: &DMatrix<f64>,
    prior: &DMatrix<f64>,
    prior_sigma: &[Option<f64>],
) -> Vec<Option<f64>> {
    let g = prior_sigma.len();
    let posterior = canonical * covariance * canonical.transpose();
    let prior = canonical * prior * canonical.transpose();
    (0..g)
        .map(|k| {
            let touches_unknown_prior =
                (0..g).any(|j| prior_sigma[j].is_none() && canonical[(k, j)].abs() > 1e-9);
            let prior_variance = prior[(k, k)];
            let scale = posterior[(k, k)].max(prior_variance);
            (!touches_unknown_prior && prior_variance > 1e-12 * scale.max(f64::MIN_POSITIVE))
                .then(|| (posterior[(k, k)].max(0.0) / prior_variance).sqrt())
        })
        .collect()
}

/// An orthonormal basis of the complement of the scaled gauge directions
/// `D⁻¹ z` (as columns).
fn complement(gauge: &[(String, DVector<f64>)], scale: &DVector<f64>) -> DMatrix<f64> {
    let g = scale.len();
    if gauge.is_empty() {
        return DMatrix::identity(g, g);
    }
    let directions = DMatrix::from_columns(
        &gauge
            .iter()
            .map(|(_, z)| z.component_div(scale))
            .collect::<Vec<_>>(),
    );
    let q = directions.qr().q();
    let projector = DMatrix::identity(g, g) - &q * q.transpose();
    let eigen = SymmetricEigen::new(projector);
    let columns: Vec<DVector<f64>> = (0..g)
        .filter(|&a| eigen.eigenvalues[a] > 0.5)
        .map(|a| eigen.eigenvectors.column(a).into_owned())
        .collect();
    DMatrix::from_columns(&columns)
}

fn statements(
    names: &[String],
    sigma_ratio: &[Option<f64>],
    undetermined: &[Undetermined],
    gauge: &[(String, DVector<f64>)],
) -> Vec<String> {
    let mut statements = Vec::new();
    if !gauge.is_empty() {
        let names: Vec<&str> = gauge.iter().map(|(name, _)| name.as_str()).collect();
        statements.push(format!(
            "no measurement sees {}: the canonical frame fixes them",
            names.join("; ")
        ));
    }
    for direction in undetermined {
        let combination: Vec<String> = direction
            .components
            .iter()
            .map(|(name, v)| format!("{v:+.2} {name}"))
            .collect();
        let seen = if direction.data_to_prior.is_finite() {
            format!(
                "the data alone would give it {:.1} times its prior sigma",
                direction.data_to_prior
            )
        } else {
            "the data do not see it at all".to_string()
        };
        statements.push(format!(
            "the data do not determine {} (in prior sigmas): {seen}, so its prior sets it",
            combination.join(" ")
        ));
    }
    let by_prior: Vec<String> = names
        .iter()
        .zip(sigma_ratio)
        .filter_map(|(name, ratio)| {
            ratio
                .filter(|&r| r >= PRIOR_BOUND)
                .map(|r| format!("{name} ({r:.2})"))
        })
        .collect();
    if !by_prior.is_empty() {
        statements.push(format!(
            "determined by their prior, not by the data (posterior over prior sigma): {}",
            by_prior.join(", ")
        ));
    }
    if undetermined.is_empty() && by_prior.is_empty() {
        statements.push(format!(
            "the data determine every parameter: none is left to its prior (every posterior sigma below {PRIOR_BOUND} of the prior's, where there is one)"
        ));
    }
    statements
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The identifiability of two unknowns with unit priors whose data
    /// give them the information `data`.
    fn of(data: [f64; 2]) -> Identifiability {
        let names = ["a".to_string(), "b".to_string()];
        let prior = DMatrix::identity(2, 2);
        let posterior = DMatrix::from_diagonal(&DVector::from_fn(2, |k, _| 1.0 + data[k]));
        let covariance = posterior.try_inverse().unwrap();
        identifiability(&Inputs {
            names: &names,
            covariance: &covariance,
            prior_information: &prior,
            prior_covariance: &prior,
            canonical: &DMatrix::identity(2, 2),
            gauge: &[],
        })
        .unwrap()
    }

    #[test]
    fn a_weak_direction_has_its_ratio_and_an_unseen_one_none() {
        // Data far stronger than the priors: every parameter determined,
        // and said so.
        let strong = of([1e8, 1e8]);
        assert!(strong.undetermined.is_empty());
        assert_eq!(strong.statements.len(), 1, "{:?}", strong.statements);
        assert!(strong.statements[0].starts_with("the data determine every parameter"));
        // Data information 1/4 on b: alone it would give b two prior sigmas.
        let weak = of([1e8, 0.25]);
        assert!(
            !weak
                .statements
                .iter()
                .any(|s| s.contains("every parameter"))
        );
        assert_eq!(weak.undetermined.len(), 1);
        assert_eq!(
            weak.undetermined[0].components,
            vec![("b".to_string(), 1.0)]
        );
        assert!((weak.undetermined[0].data_to_prior - 2.0).abs() < 1e-6);
        // The same without b's prior: b's data are all there is, and a
        // direction of a and b correlated by the data is a's alone.
        let (names, information) = (
            ["a".to_string(), "b".to_string()],
            DMatrix::from_row_slice(2, 2, &[2.0, 1.5, 1.5, 2.0]),
        );
        let prior = DMatrix::from_diagonal(&DVector::from_column_slice(&[1.0, 0.0]));
        let alone = identifiability(&Inputs {
            names: &names,
            covariance: &(&information + &prior).try_inverse().unwrap(),
            prior_information: &prior,
            prior_covariance: &prior,
            canonical: &DMatrix::identity(2, 2),
            gauge: &[],
        })
        .unwrap();
        // a's data-only information, b eliminated: 2 − 1.5²/2 = 7/8.
        assert_eq!(alone.undetermined.len(), 1);
        assert_eq!(
            alone.undetermined[0].components,
            vec![("a".to_string(), 1.0)]
        );
        let expected = 1.0 / (7.0f64 / 8.0).sqrt();
        assert!((alone.undetermined[0].data_to_prior - expected).abs() < 1e-9);
        // No prior at all: nothing is set by one.
        let none = DMatrix::zeros(2, 2);
        let free = identifiability(&Inputs {
            names: &names,
            covariance: &information.clone().try_inverse().unwrap(),
            prior_information: &none,
            prior_covariance: &none,
            canonical: &DMatrix::identity(2, 2),
            gauge: &[],
        })
        .unwrap();
        assert!(free.undetermined.is_empty(), "{:?}", free.statements);
        assert_eq!(free.statements.len(), 1, "{:?}", free.statements);
        assert!(free.statements[0].starts_with("the data determine every parameter"));
        // None on b: 1/(1 + 0) - 1 is exact here, but a rounding of 1e-13
        // (far below 2 ε 1e8) must not be read as data seeing it.
        for data in [0.0, 1e-13] {
            let unseen = of([1e8, data]);
            assert_eq!(unseen.undetermined[0].data_to_prior, f64::INFINITY);
            assert!(
                unseen.statements[0].contains("do not see it at all"),
                "{:?}",
                unseen.statements
            );
        }
    }
}
