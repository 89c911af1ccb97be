//! The bounds of a plan's counts ([`parcal_dataset::bounds`]), checked by
//! [`crate::plan`] and [`crate::tracker::plan_poses`] before any work and
//! by `parcal plan` as it parses its flags. A selection's time grows with
//! the budget times the pool times the restarts; the measured figures
//! behind the bounds are in docs/plan.md ("Speed").

use parcal_dataset::bounds::Count;

/// A touch plan's budget: 50 times the paper's 189 touches, each
/// addition and exchange evaluating the whole pool.
pub const CONTACTS: Count = Count::new(
    1,
    10_000,
    "50 times the paper's 189 touches: the selection's time grows with the budget times the pool",
);

/// The candidate pool asked for: 50 times the default 20,000. Each
/// candidate holds its touch, its information row and its share of the
/// gain products, about 1 KB: about 1 GB at the bound.
pub const POOL: Count = Count::new(
    1,
    1_000_000,
    "50 times the default 20,000 candidates, about 1 GB of rows and products",
);

/// Runs from different seeds: each is a whole selection.
pub const RESTARTS: Count = Count::new(
    1,
    100,
    "each restart is a whole selection, as long as the first",
);

/// The per-ball capacity and the least number of balls touched: no more
/// than a budget can be.
pub const PER_BALL: Count = Count::new(1, CONTACTS.max, "no more than the largest budget");

/// The least number of balls a small budget touches (0: the criterion's
/// choice): no more than a budget can touch.
pub const MIN_BALLS: Count = Count::new(0, CONTACTS.max, "no more than the largest budget");

/// The most candidate evaluations of a touch plan, budget x pool x
/// restarts: 50 times the paper's plan (189 x 20,000).
pub const MAX_EVALUATIONS: usize = 200_000_000;

/// A pose plan's budget: the selection inverts the information once per
/// pose and evaluates every candidate, so its time grows with the poses.
pub const POSES: Count = Count::new(
    1,
    1000,
    "the selection inverts the information once per pose and evaluates every candidate",
);

/// A pose plan's sessions: each adds its nuisances to every candidate's
/// rows and a copy of the pool to choose from.
pub const SESSIONS: Count = Count::new(
    1,
    100,
    "each session adds a copy of the candidate pool and its nuisances to the problem",
);

/// A mechanism plan's measurements (probe heights, encoder samples):
/// each pick evaluates every candidate once.
pub const MEASUREMENTS: Count = Count::new(
    1,
    1000,
    "each measurement planned evaluates every candidate once; a thousand exceed any calibration of a delta or a cable robot",
);

/// Points per axis of a mechanism plan's candidate grid (a square over a
/// delta's bed, a cube over a cable robot's anchors: 64,000 at the bound).
pub const GRID: Count = Count::new(2, 40, "a cube of 40 per axis is 64,000 candidates");

/// The most candidate evaluations of a mechanism plan, measurements x
/// feasible candidates: each is a rank-`r` update of a covariance of about
/// 20 unknowns, some microseconds.
pub const MAX_MECHANISM_EVALUATIONS: usize = 10_000_000;
