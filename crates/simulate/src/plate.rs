//! A simulated ball plate: calibrated centre-to-centre distances between
//! balls of the campaign, as a plate's certificate (or a set of ball bars)
//! gives them.

use std::collections::BTreeSet;

use parcal_dataset::Distance;
use parcal_kinematics::Vec3;

use crate::{Rng, SimulateError};

/// Which pairs of balls the plate's certificate gives.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PlatePairs {
    /// Every pair: `n (n - 1) / 2` distances for `n` balls.
    All,
    /// This many distinct pairs, drawn uniformly at random.
    Random(u64),
}

impl std::str::FromStr for PlatePairs {
    type Err = String;

    /// `all`, or a number of pairs (at least 1).
    fn from_str(value: &str) -> Result<Self, String> {
        if value == "all" {
            return Ok(Self::All);
        }
        match value.parse::<u64>() {
            Ok(0) => Err("a plate needs at least 1 pair".into()),
            Ok(count) => Ok(Self::Random(count)),
            Err(_) => Err(format!(
                "expected `all` or a number of pairs, got {value:?}"
            )),
        }
    }
}

/// A ball plate calibrated over the campaign's balls.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Plate {
    /// The pairs whose distance is given.
    pub pairs: PlatePairs,
    /// Error of each calibrated distance (1 sigma, mm).
    pub sigma: f64,
}

/// The plate's random stream. The hexapod's balls use streams `0..n`, a
/// delta's kinds of measurement streams `0..5`, so that the rest of a
/// seed's dataset is the same with or without a plate.
const PLATE_STREAM: u64 = u64::MAX;

/// The name of the plate's distances in messages about their number.
pub(crate) const PLATE_DISTANCES: &str = "distances of the ball plate";

/// The number of distances of `plate` over `balls` balls; `usize::MAX`
/// beyond it.
pub(crate) fn size(plate: &Plate, balls: usize) -> usize {
    let pairs = match plate.pairs {
        // n (n - 1) / 2 without overflow: halve the even factor first.
        PlatePairs::All if balls.is_multiple_of(2) => {
            (balls / 2).checked_mul(balls.saturating_sub(1))
        }
        PlatePairs::All => balls.checked_mul(balls.saturating_sub(1) / 2),
        PlatePairs::Random(count) => usize::try_from(count).ok(),
    };
    pairs.unwrap_or(usize::MAX)
}

/// The number of distances of `plate` over `balls` balls, checked against
/// [`MAX_ROWS`](crate::MAX_ROWS) before anything is drawn.
pub(crate) fn check_size(plate: &Plate, balls: usize) -> Result<usize, SimulateError> {
    crate::check_rows(&[(PLATE_DISTANCES, size(plate, balls))])
}

/// The calibrated distances of `plate` over the true centres, pairs
/// `(a, b)` with `a < b` in increasing order: each length is
/// `|C_a - C_b| + N(0, sigma)`. Stream `(seed, PLATE_STREAM)` draws the pairs
/// (for [`PlatePairs::Random`]), then the errors in pair order.
pub(crate) fn distances(
    plate: &Plate,
    centres: &[Vec3],
    seed: u64,
) -> Result<Vec<Distance>, SimulateError> {
    if !(plate.sigma.is_finite() && plate.sigma > 0.0) {
        return Err(SimulateError::Plate(format!(
            "the sigma of a distance must be positive, got {} mm",
            plate.sigma
        )));
    }
    let n = centres.len() as u64;
    let all = n * n.saturating_sub(1) / 2;
    let mut rng = Rng::new(seed, PLATE_STREAM);
    let indices: Vec<u64> = match plate.pairs {
        PlatePairs::All => (0..all).collect(),
        PlatePairs::Random(count) if count <= all => {
            floyd_sample(&mut rng, all, count).into_iter().collect()
        }
        PlatePairs::Random(count) => {
            return Err(SimulateError::Plate(format!(
                "{count} pairs asked for, but {n} balls have {all}"
            )));
        }
    };
    Ok(pairs_of(n as usize, indices.into_iter())
        .map(|(a, b)| Distance {
            a,
            b,
            length: (centres[a] - centres[b]).norm() + rng.normal(plate.sigma),
            sigma: plate.sigma,
        })
        .collect())
}

/// `count` distinct integers of `0..total`, every subset equally likely
/// (Floyd's algorithm: `count` draws, whatever `total`), in increasing order.
fn floyd_sample(rng: &mut Rng, total: u64, count: u64) -> BTreeSet<u64> {
    let mut chosen = BTreeSet::new();
    for j in total - count..total {
        let t = rng.below(j + 1);
        if !chosen.insert(t) {
            chosen.insert(j);
        }
    }
    chosen
}

/// The pairs `(a, b)`, `a < b < n`, of the given indices into the list of
/// all pairs in order `(0, 1), (0, 2), ..., (1, 2), ...`; the indices
/// increase.
fn pairs_of(n: usize, indices: impl Iterator<Item = u64>) -> impl Iterator<Item = (usize, usize)> {
    // `start` is the index of the pair (a, a + 1).
    let (mut a, mut start) = (0usize, 0u64);
    indices.map(move |index| {
        while index >= start + (n - 1 - a) as u64 {
            start += (n - 1 - a) as u64;
            a += 1;
        }
        (a, a + 1 + (index - start) as usize)
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pairs_are_numbered_row_by_row() {
        let pairs: Vec<_> = pairs_of(4, 0..6).collect();
        assert_eq!(pairs, [(0, 1), (0, 2), (0, 3), (1, 2), (1, 3), (2, 3)]);
        let some: Vec<_> = pairs_of(4, [1, 5].into_iter()).collect();
        assert_eq!(some, [(0, 2), (2, 3)]);
    }

    #[test]
    fn floyd_draws_distinct_indices_uniformly() {
        let mut rng = Rng::new(3, 0);
        assert_eq!(floyd_sample(&mut rng, 10, 10), (0..10).collect());
        // 6 of 10, 20000 times: each index is chosen with probability 0.6;
        // the standard error of its frequency is sqrt(0.6 0.4 / 20000) = 0.0035.
        let mut counts = [0u32; 10];
        for _ in 0..20_000 {
            let sample = floyd_sample(&mut rng, 10, 6);
            assert_eq!(sample.len(), 6);
            for i in sample {
                counts[i as usize] += 1;
            }
        }
        for (i, &c) in counts.iter().enumerate() {
            let frequency = f64::from(c) / 20_000.0;
            assert!((frequency - 0.6).abs() < 5.0 * 0.0035, "{i}: {frequency}");
        }
    }
}
