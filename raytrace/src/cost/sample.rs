//! Uniform task sampling (thesis, figure 3.1 b and section 3.3): every task keeps rays at a
//! fixed stride (runs of neighbours, see [`SampleRun`]), and the kept rays of all tasks are
//! gathered into one contiguous list (`refine.rs`), so the reduced trace streams through
//! memory and its parallel loop sees one flat array instead of many short strided ones. What
//! a sample found is a [`Sample`], with the hits of a sample traced for real ([`Traced`]).

use std::ops::Range;

use super::{CostError, Work};
use crate::{HitBatch, RayBatch};

/// The fraction of each task's rays that is traced, in `(0, 1]`: `sched`'s, shared by
/// every estimator of the workspace.
pub use sched::SampleRate;

/// How many adjacent rays a task's sample keeps together: its samples are runs of this many
/// neighbours (the last run of a sample count that does not divide has fewer), each at the
/// middle of one of equal strata of the task.
///
/// Longer runs trace faster, since neighbouring rays in Morton order (a tile of pixels, or a
/// pixel's Halton probes) share most of their nodes and the trace left after the sample has
/// fewer, wider gaps; shorter runs spread the same number of samples over more of the task.
/// `cobalt estimate --sample-run` measures the trade (error against measured time, net
/// overhead).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct SampleRun(std::num::NonZeroUsize);

impl SampleRun {
    /// The run every estimator uses unless told otherwise.
    pub const DEFAULT: Self = Self(std::num::NonZeroUsize::new(8).unwrap());

    /// A run of `n` adjacent rays; `None` for zero.
    pub fn new(n: usize) -> Option<Self> {
        std::num::NonZeroUsize::new(n).map(Self)
    }

    /// Rays a run holds.
    pub fn get(self) -> usize {
        self.0.get()
    }
}

impl Default for SampleRun {
    fn default() -> Self {
        Self::DEFAULT
    }
}

impl std::fmt::Display for SampleRun {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        self.0.fmt(f)
    }
}

impl std::str::FromStr for SampleRun {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        s.trim()
            .parse::<usize>()
            .ok()
            .and_then(Self::new)
            .ok_or_else(|| format!("sample run `{s}` is not a whole number of rays of at least 1"))
    }
}

/// The runs (ranges within a task of `len` rays) that hold its `k` samples, `0 < k <= len`,
/// in order: the whole task as one run when `k == len`, else runs of up to `run` adjacent rays near the
/// middle of each of `ceil(k / run)` equal strata, starting on a multiple of `run` where the
/// stratum has one before its middle. Where the strata would be narrower than the run (a
/// sample of nearly the whole task), the run is shortened until each fits its stratum, so runs
/// never overlap. The GPU estimator uploads exactly these samples.
pub(super) fn sample_runs(
    k: usize,
    len: usize,
    run: SampleRun,
) -> impl Iterator<Item = Range<usize>> {
    // A run of 1 always fits: `len / k >= 1`.
    let run = (1..=run.get().min(k))
        .rev()
        .find(|&r| len / k.div_ceil(r) >= r)
        .unwrap_or(1);
    let runs = if k == len { 1 } else { k.div_ceil(run) };
    (0..runs).map(move |j| {
        let width = if k == len { len } else { run.min(k - run * j) };
        // Integer strata bounds, never past the task: `(j + 1)·len <= len²` does not overflow
        // for tasks below 2^32 rays.
        let (lo, hi) = (j * len / runs, (j + 1) * len / runs);
        let middle = lo + (hi - lo - width) / 2;
        // On a multiple of the run where the stratum allows: a tracer that walks eight
        // neighbours at a time then finds whole groups in the sample and in the rays it
        // leaves, instead of groups cut across a gap.
        let aligned = middle / run * run;
        let start = if aligned >= lo { aligned } else { middle };
        start..start + width
    })
}

/// What an estimate's sample found.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Sample {
    /// Each task's estimated work.
    pub work: Vec<Work>,
    /// Rays traced by the estimate, over all tasks.
    pub sampled: usize,
    /// The sampled rays' hits, with [`Walk::Trace`](crate::Walk::Trace).
    pub traced: Option<Traced>,
}

/// The hits of a sample traced for real ([`Walk::Trace`](crate::Walk::Trace)): ray `index[k]` of the batch hit
/// `hits.get(k)`. Sorted by index when the tasks were.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Traced {
    /// Indices in the batch of the traced rays.
    pub index: Vec<usize>,
    /// Their hits, in the same order.
    pub hits: HitBatch,
}

/// Every task non-empty and inside a consistent batch: checked before any ray is read.
pub(crate) fn check_tasks(rays: &RayBatch, tasks: &[Range<usize>]) -> Result<(), CostError> {
    if !rays.is_consistent() {
        return Err(CostError::InconsistentBatch);
    }
    for (task, r) in tasks.iter().enumerate() {
        if r.end > rays.len() || r.start > r.end {
            return Err(CostError::TaskOutOfRange {
                task,
                start: r.start,
                end: r.end,
                rays: rays.len(),
            });
        }
        if r.is_empty() {
            return Err(CostError::EmptyTask { task });
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Ray;
    use glam::Vec3;

    /// Every task's sampled rays, task after task, as the estimator lists them for its one pass
    /// (`refine.rs`, without a target), with each task's first entry in the list: for the tests
    /// that compare a sample's rays.
    fn gather(
        rays: &RayBatch,
        tasks: &[Range<usize>],
        rate: SampleRate,
        run: SampleRun,
    ) -> Result<(Vec<usize>, Vec<usize>), CostError> {
        check_tasks(rays, tasks)?;
        let (mut index, mut offsets) = (Vec::new(), vec![0]);
        for r in tasks {
            let runs = sample_runs(rate.samples(r.len()), r.len(), run);
            index.extend(runs.flatten().map(|i| r.start + i));
            offsets.push(index.len());
        }
        Ok((index, offsets))
    }

    fn batch(n: usize) -> RayBatch {
        (0..n)
            .map(|i| Ray::new(Vec3::new(i as f32, 0.0, 0.0), Vec3::X))
            .collect()
    }

    #[test]
    fn every_task_keeps_at_least_one_ray_even_at_tiny_rates() {
        let rate = SampleRate::new(1e-9).unwrap();
        let tasks = sched::split_ranges(1000, 7);
        let (index, offsets) = gather(&batch(1000), &tasks, rate, SampleRun::DEFAULT).unwrap();
        assert_eq!(tasks.len(), 143);
        assert!(offsets.windows(2).all(|w| w[1] - w[0] == 1));
        assert_eq!(index.len(), 143);
        // The single sample of a 7-ray task is its middle ray, standing for all seven.
        assert_eq!(index[0], 3);
        assert_eq!(index[142], 142 * 7 + 2); // the last task has 1000 - 142·7 = 6 rays
    }

    #[test]
    fn samples_are_runs_at_a_uniform_stride_and_rate_one_keeps_everything() {
        let rays = batch(64);
        let pairs = SampleRun::new(2).unwrap();
        let (index, offsets) = gather(&rays, &[0..32, 32..64], SampleRate::THESIS, pairs).unwrap();
        // Each pair starts on the even ray just before its stratum's middle.
        assert_eq!(index, vec![6, 7, 22, 23, 38, 39, 54, 55]);
        assert_eq!(offsets, vec![0, 4, 8]);
        let tasks = [0..40, 40..64];
        let (all, offsets) = gather(&rays, &tasks, SampleRate::FULL, SampleRun::DEFAULT).unwrap();
        assert!(all.iter().copied().eq(0..64));
        assert_eq!(offsets, vec![0, 40, 64]);
        // A task sampled whole is one run.
        let whole: Vec<Range<usize>> = sample_runs(40, 40, SampleRun::DEFAULT).collect();
        assert_eq!(whole, vec![0..40]);
        assert_eq!(SampleRate::THESIS.samples(4096), 512);
        assert_eq!(SampleRate::THESIS.samples(513), 65);
    }

    #[test]
    fn samples_are_distinct_in_order_inside_the_task_and_as_many_as_asked() {
        for run in [1, 2, 3, 8, 16, 64, usize::MAX] {
            let run = SampleRun::new(run).unwrap();
            for len in 1..200 {
                for k in 1..=len {
                    let got: Vec<usize> = sample_runs(k, len, run).flatten().collect();
                    let case = format!("run {run:?} k {k} len {len}: {got:?}");
                    assert_eq!(got.len(), k, "{case}");
                    assert!(got.windows(2).all(|w| w[0] < w[1]), "{case}");
                    assert!(got.last().is_some_and(|&i| i < len), "{case}");
                    if k == len {
                        assert!(got.iter().copied().eq(0..len));
                    }
                }
            }
        }
    }

    #[test]
    fn a_long_run_keeps_neighbours_together_in_the_middle_of_each_stratum() {
        let rays = batch(256);
        let run = SampleRun::new(8).unwrap();
        let (index, _) = gather(&rays, &[0..128, 128..256], SampleRate::THESIS, run).unwrap();
        // 16 samples a task: two runs of 8, each in the middle of a stratum of 64, on the
        // multiple of 8 before it.
        let first: Vec<usize> = (24..32).chain(88..96).collect();
        let second: Vec<usize> = first.iter().map(|x| x + 128).collect();
        assert_eq!(index, [first, second].concat());
        assert!("0".parse::<SampleRun>().is_err() && "x".parse::<SampleRun>().is_err());
        assert_eq!("16".parse::<SampleRun>(), Ok(SampleRun::new(16).unwrap()));
    }

    #[test]
    fn default_runs_fill_whole_groups_of_eight_in_tasks_of_a_multiple_of_eight() {
        let rays = batch(3 * 4096);
        let tasks = sched::split_ranges(rays.len(), 4096);
        let (index, _) = gather(&rays, &tasks, SampleRate::THESIS, SampleRun::DEFAULT).unwrap();
        assert_eq!(SampleRun::DEFAULT.get(), 8);
        assert_eq!(index.len(), 3 * 512);
        for run in index.chunks(8) {
            assert_eq!(run[0] % 8, 0, "{run:?}");
            assert!(run.windows(2).all(|w| w[1] == w[0] + 1), "{run:?}");
        }
    }

    #[test]
    fn empty_and_out_of_range_tasks_are_errors_naming_the_task() {
        let rays = batch(10);
        let empty = gather(&rays, &[0..5, 5..5], SampleRate::FULL, SampleRun::DEFAULT).unwrap_err();
        assert_eq!(empty, CostError::EmptyTask { task: 1 });
        let out = gather(&rays, &[0..5, 5..11], SampleRate::FULL, SampleRun::DEFAULT).unwrap_err();
        assert!(matches!(
            out,
            CostError::TaskOutOfRange {
                task: 1,
                end: 11,
                rays: 10,
                ..
            }
        ));
        let mut broken = rays.clone();
        broken.tmax.pop();
        let err = gather(&broken, &[0..5, 5..9], SampleRate::FULL, SampleRun::DEFAULT).unwrap_err();
        assert_eq!(err, CostError::InconsistentBatch);
    }
}
