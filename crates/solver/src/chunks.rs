//! The fixed partition of the groups into chunks, per-thread work buffers,
//! and the parallel pass over chunks whose results are combined in chunk
//! order (so that they do not depend on the number of threads).

use std::ops::Range;
use std::sync::Mutex;

use rayon::prelude::*;

/// Chunks processed in parallel between two in-order reductions; bounds the
/// memory held by per-chunk results (a chunk's part of the reduced system,
/// about 10 KB: 2.6 MB a wave). Each wave ends with the threads waiting for
/// its last chunk: fewer, larger waves wait less (docs/performance.md).
const CHUNKS_PER_WAVE: usize = 256;

/// Rows of the per-thread group buffer (the group QR runs on at most this many
/// rows at once; more rows are folded in batches).
const GROUP_BUFFER_ROWS: usize = 256;
/// Rows of the per-thread buffer of reduced rows, multiplied into the chunk's
/// reduced matrix by one Gram update `AᵀA` when full.
const CHUNK_BUFFER_ROWS: usize = 2048;

/// A run of whole groups and their points.
#[derive(Clone, Debug)]
pub(crate) struct Chunk {
    pub(crate) groups: Range<usize>,
    pub(crate) points: Range<usize>,
}

impl Chunk {
    /// Where the chunk's `points` (a range of the problem's points) sit in
    /// the chunk's own per-point slices.
    pub(crate) fn local(&self, points: &Range<usize>) -> Range<usize> {
        points.start - self.points.start..points.end - self.points.start
    }
}

/// The block sizes of a problem.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Dims {
    pub(crate) g: usize,
    pub(crate) c: usize,
    pub(crate) p: usize,
    pub(crate) r: usize,
    /// The effects carried as extra right-hand sides ([`crate::effects`];
    /// the checks' pass only, 0 otherwise).
    pub(crate) effects: usize,
}

impl Dims {
    /// Most rows of one point block: data, prior and damping rows.
    pub(crate) fn point_rows(self) -> usize {
        self.r + 2 * self.p
    }
    /// Width of a group row: group and global columns, the residual, the
    /// effects.
    pub(crate) fn group_width(self) -> usize {
        self.c + self.g + 1 + self.effects
    }
    /// Width of a reduced row (global columns and the residual).
    pub(crate) fn reduced_width(self) -> usize {
        self.g + 1
    }
    /// Capacity of the group buffer: room for the running triangle, a full
    /// point and the group's prior and damping rows, with plenty to spare.
    pub(crate) fn group_capacity(self) -> usize {
        GROUP_BUFFER_ROWS.max(4 * (self.c + self.point_rows()))
    }
}

/// Reusable buffers of one thread: nothing is allocated per point.
pub(crate) struct Workspace {
    /// One point's panel (`m × P`) and its orthogonal factor (`m × m`).
    pub(crate) point: Vec<f64>,
    /// The group rows being eliminated, row-major.
    pub(crate) group: Vec<f64>,
    /// Reduced rows waiting for the Gram update, row-major.
    pub(crate) reduced: Vec<f64>,
    /// One group row (`C + G + 1` values).
    pub(crate) row: Vec<f64>,
    /// Back-substitution data of the points of the current group.
    pub(crate) point_data: Vec<f64>,
}

impl Workspace {
    pub(crate) fn new(d: Dims) -> Self {
        Self {
            point: vec![0.0; d.point_rows() * (d.p + d.point_rows())],
            group: vec![0.0; d.group_capacity() * d.group_width()],
            reduced: vec![0.0; CHUNK_BUFFER_ROWS * d.reduced_width()],
            row: vec![0.0; d.group_width()],
            point_data: Vec::new(),
        }
    }

    /// The buffers of the elimination, the reduced-row buffer and the
    /// back-substitution data, borrowed separately.
    pub(crate) fn split(&mut self) -> (ElimBuffers<'_>, &mut [f64], &mut Vec<f64>) {
        (
            ElimBuffers {
                point: &mut self.point,
                group: &mut self.group,
                row: &mut self.row,
            },
            &mut self.reduced,
            &mut self.point_data,
        )
    }
}

/// The buffers the elimination of points and groups works in.
pub(crate) struct ElimBuffers<'w> {
    pub(crate) point: &'w mut [f64],
    pub(crate) group: &'w mut [f64],
    /// One group row: scratch for a row that skips the group buffer, or
    /// for a global Jacobian's rows (its first `G` values).
    pub(crate) row: &'w mut [f64],
}

/// A pool of workspaces: a task takes one, uses it, gives it back. At most
/// one per concurrently running task (so per thread) is ever created.
pub(crate) struct WorkspacePool {
    dims: Dims,
    free: Mutex<Vec<Workspace>>,
}

impl WorkspacePool {
    pub(crate) fn new(dims: Dims) -> Self {
        Self {
            dims,
            free: Mutex::new(Vec::new()),
        }
    }

    pub(crate) fn with<T>(&self, f: impl FnOnce(&mut Workspace) -> T) -> T {
        let taken = self.free.lock().unwrap_or_else(|e| e.into_inner()).pop();
        let mut ws = taken.unwrap_or_else(|| Workspace::new(self.dims));
        let out = f(&mut ws);
        self.free.lock().unwrap_or_else(|e| e.into_inner()).push(ws);
        out
    }
}

/// Splits the groups `0..n_groups` into chunks of `groups_per_chunk` groups,
/// checking that the group ranges partition `0..n_points`.
pub(crate) fn make_chunks(
    group_points: impl Fn(usize) -> Range<usize>,
    n_groups: usize,
    n_points: usize,
    groups_per_chunk: usize,
) -> Result<Vec<Chunk>, String> {
    if groups_per_chunk == 0 {
        return Err("groups_per_chunk must be positive".into());
    }
    let mut chunks = Vec::with_capacity(n_groups.div_ceil(groups_per_chunk));
    let mut next = 0;
    let mut k0 = 0;
    let mut start = 0;
    for k in 0..n_groups {
        let range = group_points(k);
        if range.start != next || range.end < range.start {
            return Err(format!(
                "group {k} has points {range:?}, expected a range starting at {next}"
            ));
        }
        next = range.end;
        if k + 1 - k0 == groups_per_chunk || k + 1 == n_groups {
            chunks.push(Chunk {
                groups: k0..k + 1,
                points: start..next,
            });
            k0 = k + 1;
            start = next;
        }
    }
    if next != n_points {
        return Err(format!(
            "the groups cover points 0..{next} but the state has {n_points} points"
        ));
    }
    Ok(chunks)
}

/// `len` copies of `value`, written on the threads: a million contacts'
/// room is first touched by all of them, not by one before they start.
pub fn filled<T: Clone + Send + Sync>(value: T, len: usize) -> Vec<T> {
    let mut filled = Vec::new();
    filled.par_extend(rayon::iter::repeat_n(value, len));
    filled
}

/// Splits `items` into consecutive mutable slices of the given lengths
/// (e.g. per-point arrays into the points of each group, to be filled in
/// parallel).
pub fn split_by<T>(mut items: &mut [T], lengths: impl Iterator<Item = usize>) -> Vec<&mut [T]> {
    let mut out = Vec::new();
    for len in lengths {
        let (head, tail) = items.split_at_mut(len);
        out.push(head);
        items = tail;
    }
    out
}

/// When a pass's results are folded.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Absorb {
    /// After each wave, the threads waiting: for a light fold (a chunk's
    /// part of the reduced system added in).
    AfterWave,
    /// On the calling thread while the next wave runs, two waves' results
    /// held at once: for a fold as heavy as a share of the work (every
    /// contact's checks).
    BesideNextWave,
}

/// One pass over the chunks: runs `work` on every job (a chunk and what it
/// reads or writes) with a workspace of `pool`, in parallel waves of
/// `CHUNKS_PER_WAVE`, and feeds the results to `absorb` in job order after
/// each wave. The first error in job order ends the pass, after its wave.
/// What `absorb` folds does not depend on the number of threads.
pub(crate) fn run_chunks<J, O, E, W, A>(
    pool: &WorkspacePool,
    jobs: Vec<J>,
    work: W,
    absorb: A,
) -> Result<(), E>
where
    J: Send,
    O: Send,
    E: Send,
    W: Fn(&mut Workspace, J) -> Result<O, E> + Sync,
    A: FnMut(O),
{
    run_chunks_in_waves(pool, jobs, CHUNKS_PER_WAVE, Absorb::AfterWave, work, absorb)
}

/// [`run_chunks`] in waves of `chunks_per_wave` chunks (at least one), for
/// a pass whose per-chunk results are large (fewer at a time), their fold
/// as `when` says. No wave after the first error's is started.
pub(crate) fn run_chunks_in_waves<J, O, E, W, A>(
    pool: &WorkspacePool,
    jobs: Vec<J>,
    chunks_per_wave: usize,
    when: Absorb,
    work: W,
    mut absorb: A,
) -> Result<(), E>
where
    J: Send,
    O: Send,
    E: Send,
    W: Fn(&mut Workspace, J) -> Result<O, E> + Sync,
    A: FnMut(O),
{
    let mut jobs = jobs.into_iter();
    let mut next_wave = || -> Vec<J> { jobs.by_ref().take(chunks_per_wave.max(1)).collect() };
    let compute = |wave: Vec<J>| -> Vec<Result<O, E>> {
        wave.into_par_iter()
            .map(|job| pool.with(|ws| work(ws, job)))
            .collect()
    };
    let mut fold = |results: Vec<Result<O, E>>| {
        results
            .into_iter()
            .try_for_each(|result| result.map(&mut absorb))
    };
    let mut results = compute(next_wave());
    while !results.is_empty() {
        if results.iter().any(Result::is_err) {
            return fold(results);
        }
        let wave = next_wave();
        results = match when {
            Absorb::AfterWave => {
                fold(results)?;
                compute(wave)
            }
            Absorb::BesideNextWave => {
                let mut next = Vec::new();
                rayon::in_place_scope(|scope| {
                    if !wave.is_empty() {
                        scope.spawn(|_| next = compute(wave));
                    }
                    fold(results)
                })?;
                next
            }
        };
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use std::sync::atomic::{AtomicUsize, Ordering};

    use super::*;

    #[test]
    fn chunks_partition_groups() {
        let sizes = [3usize, 0, 2, 5, 1];
        let starts: Vec<usize> = sizes
            .iter()
            .scan(0, |s, &n| {
                let a = *s;
                *s += n;
                Some(a)
            })
            .collect();
        let chunks = make_chunks(|k| starts[k]..starts[k] + sizes[k], 5, 11, 2).unwrap();
        let got: Vec<_> = chunks
            .iter()
            .map(|c| (c.groups.clone(), c.points.clone()))
            .collect();
        assert_eq!(got, vec![(0..2, 0..3), (2..4, 3..10), (4..5, 10..11)]);
        assert!(make_chunks(|k| starts[k]..starts[k] + sizes[k], 5, 12, 2).is_err());
        assert!(make_chunks(|k| k..k + 2, 3, 6, 2).is_err());
        assert!(make_chunks(|k| k..k + 1, 3, 3, 0).is_err());
    }

    #[test]
    fn a_pass_keeps_job_order_and_stops_at_the_first_error() {
        let dims = Dims {
            g: 1,
            c: 1,
            p: 0,
            r: 1,
            effects: 0,
        };
        let pool = WorkspacePool::new(dims);
        let mut seen = Vec::new();
        let double = |_: &mut Workspace, j: usize| Ok::<_, usize>(j * 2);
        run_chunks(&pool, (0..600).collect(), double, |o| seen.push(o)).unwrap();
        assert_eq!(seen, (0..600).map(|j| j * 2).collect::<Vec<_>>());
        let mut seen = Vec::new();
        let fail = |_: &mut Workspace, j: usize| if j % 100 == 7 { Err(j) } else { Ok(j) };
        let first = run_chunks(&pool, (0..600).collect(), fail, |o| seen.push(o));
        assert_eq!(first, Err(7));
        assert_eq!(seen, (0..7).collect::<Vec<_>>());
        for when in [Absorb::AfterWave, Absorb::BesideNextWave] {
            let mut seen = Vec::new();
            run_chunks_in_waves(&pool, (0..600).collect(), 7, when, double, |o| seen.push(o))
                .unwrap();
            assert_eq!(seen, (0..600).map(|j| j * 2).collect::<Vec<_>>());
            // The first error is in the second wave, which started (beside
            // the first's fold, or after it); none after it did.
            let started = AtomicUsize::new(0);
            let counted = |ws: &mut Workspace, j: usize| {
                started.fetch_add(1, Ordering::Relaxed);
                fail(ws, j)
            };
            let mut seen = Vec::new();
            let first = run_chunks_in_waves(&pool, (0..600).collect(), 7, when, counted, |o| {
                seen.push(o)
            });
            assert_eq!(first, Err(7));
            assert_eq!(seen, (0..7).collect::<Vec<_>>());
            assert_eq!(started.into_inner(), 14);
        }
    }
}
