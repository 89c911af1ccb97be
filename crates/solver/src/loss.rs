//! Robust losses on whole observations, solved by iteratively reweighted
//! least squares (IRLS).
//!
//! An observation `o` of `d` degrees of freedom with whitened rows `e_o` has
//! the scaled residual `u_o = |e_o| / √d` (about 1 at the noise level) and
//! adds `2 d ρ(u_o)` to the cost, with `ρ(u) = u²/2` for least squares, so
//! that its term is `|e_o|²` there. The minimum satisfies
//! `Σ_o w(u_o) J_oᵀ e_o = 0` (plus the priors' terms), `w(u) = ψ(u)/u`,
//! `ψ = ρ'`: at each iterate the solver scales every observation's rows by
//! `√w(u_o)`, `u_o` taken there, and takes the (Gauss–Newton or
//! Levenberg–Marquardt) step of that weighted least-squares problem. The
//! weighted cost's gradient equals the loss's at the iterate, and since
//! `ρ(√s)` is concave in `s` for Huber and Cauchy, the weighted cost
//! majorises the loss: a step that lowers the one lowers the other (IRLS as
//! a majorise-minimise iteration; Holland and Welsch, "Robust regression
//! using iteratively reweighted least-squares", Commun. Statist. A6 (1977)
//! 813).
//!
//! - **Huber** (Huber, "Robust estimation of a location parameter", Ann.
//!   Math. Statist. 35 (1964) 73): `ρ(u) = u²/2` for `|u| ≤ k`, `k|u| −
//!   k²/2` beyond; `ψ(u) = u` and `k sign(u)`; `w(u) = min(1, k/|u|)`.
//! - **Cauchy** (Holland and Welsch 1977): `ρ(u) = (k²/2) ln(1 + (u/k)²)`,
//!   `ψ(u) = u / (1 + (u/k)²)`, `w(u) = 1 / (1 + (u/k)²)`.
//!
//! The default thresholds [`HUBER_K`] and [`CAUCHY_K`] give each estimator
//! 95 % of the efficiency of least squares for Gaussian errors (Holland and
//! Welsch 1977, table 1).

use std::fmt;

/// Huber's threshold for 95 % Gaussian efficiency (Holland and Welsch 1977).
pub const HUBER_K: f64 = 1.345;
/// Cauchy's scale for 95 % Gaussian efficiency (Holland and Welsch 1977).
pub const CAUCHY_K: f64 = 2.385;

/// The loss `ρ` of every observation (module doc); `k` in units of the
/// observation's standard deviation (of its scaled residual `u`).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub enum Loss {
    /// Least squares, `ρ(u) = u²/2`: every weight 1.
    #[default]
    Squared,
    /// Huber's loss with threshold `k`.
    Huber {
        /// The threshold.
        k: f64,
    },
    /// The Cauchy (Lorentzian) loss with scale `k`.
    Cauchy {
        /// The scale.
        k: f64,
    },
}

/// The weight and the cost of one observation ([`Loss::observation`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Weighed {
    /// `w(u)`.
    pub weight: f64,
    /// `2 d ρ(u)`, the observation's term of the loss.
    pub cost: f64,
}

impl Loss {
    /// Whether this is least squares.
    pub fn is_squared(self) -> bool {
        matches!(self, Self::Squared)
    }

    /// `None` if `k` is finite and positive, else why not.
    pub fn invalid(self) -> Option<String> {
        match self {
            Self::Squared => None,
            Self::Huber { k } | Self::Cauchy { k } => {
                (!(k.is_finite() && k > 0.0)).then(|| format!("{self}: k must be positive"))
            }
        }
    }

    /// `ρ(u)`.
    pub fn rho(self, u: f64) -> f64 {
        match self {
            Self::Squared => u * u / 2.0,
            Self::Huber { k } if u.abs() <= k => u * u / 2.0,
            Self::Huber { k } => k * u.abs() - k * k / 2.0,
            Self::Cauchy { k } => k * k / 2.0 * (u / k).powi(2).ln_1p(),
        }
    }

    /// `ψ(u) = ρ'(u)`.
    pub fn psi(self, u: f64) -> f64 {
        u * self.weight(u)
    }

    /// `w(u) = ψ(u)/u` (1 at `u = 0`).
    pub fn weight(self, u: f64) -> f64 {
        match self {
            Self::Squared => 1.0,
            Self::Huber { k } if u.abs() <= k => 1.0,
            Self::Huber { k } => k / u.abs(),
            Self::Cauchy { k } => 1.0 / (1.0 + (u / k).powi(2)),
        }
    }

    /// The weight and cost of an observation of `dof` degrees of freedom
    /// whose whitened rows have squared norm `norm2`: `u = √(norm2 / dof)`.
    pub fn observation(self, norm2: f64, dof: usize) -> Weighed {
        let d = dof as f64;
        let u = (norm2 / d).sqrt();
        Weighed {
            weight: self.weight(u),
            cost: 2.0 * d * self.rho(u),
        }
    }
}

/// `squared`, `huber:K`, `cauchy:K`.
impl fmt::Display for Loss {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Squared => f.write_str("squared"),
            Self::Huber { k } => write!(f, "huber:{k}"),
            Self::Cauchy { k } => write!(f, "cauchy:{k}"),
        }
    }
}

/// Reads `squared`, `huber`, `huber:K`, `cauchy`, `cauchy:K` (without `K`
/// the default thresholds [`HUBER_K`], [`CAUCHY_K`]).
impl std::str::FromStr for Loss {
    type Err = String;

    fn from_str(text: &str) -> Result<Self, String> {
        let (name, k) = match text.split_once(':') {
            Some((name, k)) => {
                let k: f64 = k
                    .parse()
                    .map_err(|e| format!("{text:?}: the threshold {k:?}: {e}"))?;
                (name, Some(k))
            }
            None => (text, None),
        };
        let loss = match name {
            "squared" if k.is_none() => Self::Squared,
            "huber" => Self::Huber {
                k: k.unwrap_or(HUBER_K),
            },
            "cauchy" => Self::Cauchy {
                k: k.unwrap_or(CAUCHY_K),
            },
            _ => {
                return Err(format!(
                    "{text:?}: expected squared, huber[:K] or cauchy[:K]"
                ));
            }
        };
        match loss.invalid() {
            Some(reason) => Err(reason),
            None => Ok(loss),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const HUBER: Loss = Loss::Huber { k: HUBER_K };
    const CAUCHY: Loss = Loss::Cauchy { k: CAUCHY_K };

    /// `ψ = ρ'` by central differences, `w = ψ/u`, and the values at
    /// points where they are known in closed form.
    #[test]
    fn psi_is_the_derivative_of_rho_and_weight_psi_over_u() {
        for loss in [Loss::Squared, HUBER, CAUCHY] {
            for u in [-40.0, -3.0, -1.0, -0.2, 0.3, 1.2, 1.4, 2.0, 7.0, 1e3] {
                let h = 1e-6 * (1.0 + f64::abs(u));
                let numeric = (loss.rho(u + h) - loss.rho(u - h)) / (2.0 * h);
                assert!(
                    (numeric - loss.psi(u)).abs() < 1e-7 * (1.0 + loss.psi(u).abs()),
                    "{loss} at {u}: {numeric} vs {}",
                    loss.psi(u)
                );
                assert!((loss.weight(u) * u - loss.psi(u)).abs() < 1e-15 * (1.0 + u.abs()));
                assert!(loss.weight(u) > 0.0 && loss.weight(u) <= 1.0);
            }
            assert_eq!(loss.weight(0.0), 1.0);
        }
        // Huber: 1 inside the threshold, k/|u| beyond; continuous at k.
        assert_eq!(HUBER.weight(1.3), 1.0);
        assert_eq!(HUBER.weight(-13.45), 0.1);
        assert!((HUBER.rho(HUBER_K) - HUBER_K * HUBER_K / 2.0).abs() < 1e-15);
        // Cauchy: one half at u = k, one tenth at u = 3k.
        assert!((CAUCHY.weight(CAUCHY_K) - 0.5).abs() < 1e-15);
        assert!((CAUCHY.weight(3.0 * CAUCHY_K) - 0.1).abs() < 1e-15);
        assert!((CAUCHY.rho(CAUCHY_K) - CAUCHY_K * CAUCHY_K / 2.0 * 2f64.ln()).abs() < 1e-14);
    }

    /// An observation's cost is `|e|²` for least squares, whatever its
    /// degrees of freedom, and its weight that of `u = |e| / √d`.
    #[test]
    fn an_observation_is_scaled_by_its_degrees_of_freedom() {
        let squared = Loss::Squared.observation(12.0, 3);
        assert_eq!(squared.weight, 1.0);
        assert!((squared.cost - 12.0).abs() < 1e-14);
        // |e|² = 300 over 3 rows: u = 10, Huber's weight k/10, cost
        // 2·3·(10k − k²/2).
        let huber = HUBER.observation(300.0, 3);
        assert!((huber.weight - HUBER_K / 10.0).abs() < 1e-15);
        assert!((huber.cost - 6.0 * (10.0 * HUBER_K - HUBER_K * HUBER_K / 2.0)).abs() < 1e-12);
    }

    #[test]
    fn losses_read_and_write() {
        assert_eq!("squared".parse(), Ok(Loss::Squared));
        assert_eq!("huber".parse(), Ok(HUBER));
        assert_eq!("cauchy".parse(), Ok(CAUCHY));
        assert_eq!("huber:2.5".parse(), Ok(Loss::Huber { k: 2.5 }));
        for loss in [Loss::Squared, HUBER, Loss::Cauchy { k: 4.0 }] {
            assert_eq!(loss.to_string().parse(), Ok(loss));
        }
        for bad in [
            "huber:0",
            "cauchy:-1",
            "huber:inf",
            "huber:x",
            "tukey",
            "squared:1",
        ] {
            assert!(bad.parse::<Loss>().is_err(), "{bad}");
        }
    }
}
