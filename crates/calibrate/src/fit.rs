//! Each ball's goodness of fit at the solution: a ball whose contacts fit
//! far worse than the noise allows has a centre in a wrong local minimum
//! (the mirror image of its contact cap, say) or a blunder among its
//! contacts, and the calibration flags it instead of reporting it silently.
//!
//! At the solution a ball's share of the whitened data cost is
//! chi-square distributed with `n − 3` degrees of freedom for `n` contacts:
//! each contact leaves one row beyond its angles (three coordinate rows and
//! two angles, or one radius row), and the centre takes three (a per-ball
//! radius takes a fraction of one more, the share of its information that
//! comes from the touches rather than its prior: testing `n − 3` is then
//! slightly conservative). A ball is
//! flagged beyond the `1 − 0.001 / B` quantile for `B` balls (Bonferroni):
//! a sound calibration flags any ball with probability at most 0.1 %.

use crate::conflict::chi_square_quantile;

/// Family-wise probability that a sound calibration flags any ball.
pub const FAMILY_TAIL: f64 = 1e-3;

/// A ball whose contacts fit worse than the noise allows.
#[derive(Debug, Clone, PartialEq)]
pub struct BallMisfit {
    /// Its index (artefacts.json order).
    pub ball: usize,
    /// artefacts.json's id.
    pub id: String,
    /// Its share of the whitened data cost.
    pub chi_square: f64,
    /// Its contacts less 3.
    pub degrees_of_freedom: usize,
}

/// The balls (their whitened data costs and contact counts, in the same
/// order; `id` names ball `b`) whose cost is beyond the `1 − FAMILY_TAIL /
/// B` quantile of chi-square(`n − 3`); balls with fewer than 4 contacts
/// have no degrees of freedom and are not tested.
pub fn misfit_balls(
    id: impl Fn(usize) -> String,
    costs: &[f64],
    contacts: impl IntoIterator<Item = usize>,
) -> Vec<BallMisfit> {
    let p = 1.0 - FAMILY_TAIL / costs.len().max(1) as f64;
    // The quantile of each number of degrees of freedom, computed once
    // (limits[d]; index 0 is never read).
    let mut limits = vec![f64::NAN];
    costs
        .iter()
        .zip(contacts)
        .enumerate()
        .filter_map(|(ball, (&cost, n))| {
            let degrees_of_freedom = n.checked_sub(3).filter(|&d| d > 0)?;
            while limits.len() <= degrees_of_freedom {
                limits.push(chi_square_quantile(limits.len(), p));
            }
            // A NaN cost is never a pass.
            let passes = cost <= limits[degrees_of_freedom];
            (!passes).then(|| BallMisfit {
                ball,
                id: id(ball),
                chi_square: cost,
                degrees_of_freedom,
            })
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn flags_only_costs_beyond_the_family_quantile() {
        let ids: Vec<String> = (0..1000).map(|k| format!("b{k}")).collect();
        // chi-square(4) has mean 4; the 1 - 1e-6 quantile is about 34.
        let mut costs = vec![4.0; 1000];
        costs[17] = 20.0; // unusual for one ball, not for 1000 of them
        costs[500] = 500.0;
        costs[900] = f64::NAN; // a non-finite cost is never a pass
        let mut contacts = vec![7; 1000];
        contacts[3] = 3; // no degrees of freedom: not tested
        costs[3] = 1e9;
        let misfits = misfit_balls(|b| ids[b].clone(), &costs, contacts);
        let flagged: Vec<&str> = misfits.iter().map(|m| m.id.as_str()).collect();
        assert_eq!(flagged, ["b500", "b900"]);
        assert_eq!(misfits[0].degrees_of_freedom, 4);
    }
}
