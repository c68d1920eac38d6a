//! A sample that grows only as far as its estimate needs: it starts at a quarter of its rate
//! and doubles while its two interleaved halves disagree by more than a target.
//!
//! Why: on a CPU a sparse sample traces at 1.1–1.5× its share of the full trace (each sampled
//! packet finds the scene's nodes cold), so a fixed 12.5 % costs several percent of the trace
//! beyond the hits it saves. Where counts explain measured time only to 5–15 % anyway, a far
//! smaller sample resolves as much; where they explain it to 2 % (the thin, tangled strands of
//! a hairball seen by camera rays), the sample must be dense. The sample's own halves tell the
//! two apart, before anything is timed.
//!
//! A task's runs at the full rate ([`sample_runs`]) are numbered `j = 0, 1, …`. The sample
//! starts with every fourth (`j % 4 == 0`); a task it grows gets `j % 4 == 2`, then the odd
//! ones: each level is a systematic sample of twice the density of the last, and the last is
//! exactly the fixed rate's sample. At stride `d`, a task's halves are its runs `j % 2d == 0`
//! and `j % 2d == d`; with `A`, `B` each half's cost per ray times the task's rays,
//! `Σ|A − B| / Σ(A + B)` over the tasks is the expected `Σ|X − μ| / Σμ` of their mean `X` (its
//! error has half the spread of `A − B`): the sampling part of what `error_vs_time` measures.
//! While it is above the target, the tasks whose halves disagree most grow first, each
//! expected to keep `1/√2` of its part, until what is left meets the target: the sample grows
//! where the cost varies, as Neyman's allocation would have it. Tasks too small to split
//! take their whole sample at once.

use std::ops::Range;

use super::sample::{Sample, Traced, sample_runs};
use super::{CostModel, SampleRate, SampleRun, Work};
use crate::HitBatch;
use crate::traverse::counts::Counts;

/// Doublings from the first level to the full sample: it starts at `rate / 4`.
const LEVELS: u32 = 2;

/// Runs a task needs at the first level to be refined at all; below, its two halves would be
/// too few to disagree meaningfully, and it takes its whole sample at once.
const MIN_RUNS: usize = 8;

/// Where a run was traced: the pass, its first ray's place in that pass, and its counts' sum.
type Found = Option<(usize, usize, Work)>;

/// The refined sample of `tasks` (checked non-empty and inside the batch): the full sample is
/// `rate`'s in runs of `run`; `trace` walks a list of ray indices, all in one parallel pass;
/// the default [`CostModel`] weighs the halves' counts; refinement stops once the halves
/// disagree by at most `target`. Without a target the full sample is taken at once, in one
/// pass over one contiguous list of every task's sampled rays (the thesis compacts the sample
/// so; the host reads the rays in place through it, a GPU uploads the rays it lists). An
/// error of `trace` ends the refinement.
pub(super) fn refine<E>(
    tasks: &[Range<usize>],
    rate: SampleRate,
    run: SampleRun,
    target: Option<f64>,
    mut trace: impl FnMut(&[usize]) -> Result<(Option<HitBatch>, Vec<Counts>), E>,
) -> Result<Sample, E> {
    // Every task's runs in one list, task `t`'s at `runs[from[t]..from[t + 1]]`: this
    // bookkeeping runs on one thread between parallel passes, and with a list per task and a
    // scan of all of a task's runs for each half, camera-ray estimates took 8–10 % longer.
    let mut runs: Vec<Range<usize>> = Vec::new();
    let mut from = Vec::with_capacity(tasks.len() + 1);
    for r in tasks {
        from.push(runs.len());
        runs.extend(
            sample_runs(rate.samples(r.len()), r.len(), run)
                .map(|s| r.start + s.start..r.start + s.end),
        );
    }
    from.push(runs.len());
    let first = if target.is_some() {
        1usize << LEVELS
    } else {
        1
    };
    let mut stride: Vec<usize> = from
        .windows(2)
        .map(|w| {
            if w[1] - w[0] >= MIN_RUNS * first {
                first
            } else {
                1
            }
        })
        .collect();
    // Per run: the pass that traced it and where in that pass, and its counts' sum.
    let mut found: Vec<Found> = vec![None; runs.len()];
    // Each pass's rays, and their hits where the walk traced for real.
    let mut passes: Vec<(Vec<usize>, Option<HitBatch>)> = Vec::new();
    // Traces, in one pass, every task's runs `j0, j0 + step, …` for its `pick(t) = (j0, step)`.
    let mut take = |pick: &dyn Fn(usize) -> Option<(usize, usize)>, found: &mut [Found]| {
        let mut index = Vec::new();
        let mut starts = Vec::new();
        for t in 0..tasks.len() {
            let Some((j0, step)) = pick(t) else { continue };
            for k in (from[t] + j0..from[t + 1]).step_by(step) {
                starts.push((k, index.len()));
                index.extend(runs[k].clone());
            }
        }
        let (hits, counts) = trace(&index)?;
        for (k, at) in starts {
            let len = runs[k].len();
            found[k] = Some((passes.len(), at, Work::sum(&counts[at..at + len])));
        }
        passes.push((index, hits));
        Ok(())
    };
    take(&|t| Some((0, stride[t])), &mut found)?;
    loop {
        // Each task that can still grow: `|A − B|` and `A + B`. Tasks already whole are left
        // out of both sums, which only makes the target harder to meet.
        let mut by_gap: Vec<(usize, f64, f64)> = (0..tasks.len())
            .filter(|&t| stride[t] > 1)
            .map(|t| {
                let own = &found[from[t]..from[t + 1]];
                let (a, b) = halves(own, stride[t], tasks[t].len());
                (t, (a - b).abs(), a + b)
            })
            .collect();
        let total: f64 = by_gap.iter().map(|h| h.2).sum();
        let mut apart: f64 = by_gap.iter().map(|h| h.1).sum();
        let target = target.unwrap_or(f64::INFINITY);
        if by_gap.is_empty() || apart <= target * total {
            break;
        }
        // The tasks whose halves disagree most grow first (see the module docs).
        by_gap.sort_by(|x, y| y.1.total_cmp(&x.1));
        let mut grow = vec![false; tasks.len()];
        for &(t, gap, _) in &by_gap {
            // Halves that agree exactly (a task of identical rays) gain nothing from more.
            if apart <= target * total || gap <= 0.0 {
                break;
            }
            grow[t] = true;
            apart -= gap * (1.0 - std::f64::consts::FRAC_1_SQRT_2);
        }
        take(&|t| grow[t].then(|| (stride[t] / 2, stride[t])), &mut found)?;
        for (t, g) in grow.into_iter().enumerate() {
            if g {
                stride[t] /= 2;
            }
        }
    }
    Ok(assemble(tasks, &from, &runs, &found, passes))
}

/// A task's two halves at `stride` (see the module docs), from its runs' `found`: each half's
/// cost per ray, times the task's `len` rays.
fn halves(found: &[Found], stride: usize, len: usize) -> (f64, f64) {
    let model = CostModel::default();
    let mut half = [Work::default(); 2];
    for (i, f) in found.iter().step_by(stride).enumerate() {
        if let Some((_, _, w)) = *f {
            half[i % 2] = half[i % 2].plus(w);
        }
    }
    let per_task = |w: Work| model.cost(w) / w.rays.max(1.0) * len as f64;
    (per_task(half[0]), per_task(half[1]))
}

/// Each task's runs in order, gathered from the passes that traced them: the sampled rays'
/// indices task by task, their work scaled to each task's rays, and their hits where the walk
/// traced them for real.
fn assemble(
    tasks: &[Range<usize>],
    from: &[usize],
    runs: &[Range<usize>],
    found: &[Found],
    mut passes: Vec<(Vec<usize>, Option<HitBatch>)>,
) -> Sample {
    let work = tasks
        .iter()
        .enumerate()
        .map(|(t, task)| {
            let own = found[from[t]..from[t + 1]].iter().flatten();
            let sum = own.fold(Work::default(), |sum, &(_, _, w)| sum.plus(w));
            sum.scaled(task.len(), sum.rays as usize)
        })
        .collect();
    // A single pass traced every run it kept task by task, in order: its list is the sample.
    let (index, hits) = if passes.len() == 1 {
        passes.swap_remove(0)
    } else {
        let mut index = Vec::new();
        let mut hits = passes[0].1.as_ref().map(|_| HitBatch::default());
        for (r, &(pass, at, _)) in runs
            .iter()
            .zip(found)
            .filter_map(|(r, f)| Some((r, f.as_ref()?)))
        {
            index.extend(r.clone());
            if let (Some(all), Some(h)) = (&mut hits, &passes[pass].1) {
                all.t.extend_from_slice(&h.t[at..at + r.len()]);
                all.prim.extend_from_slice(&h.prim[at..at + r.len()]);
            }
        }
        (index, hits)
    };
    Sample {
        sampled: index.len(),
        work,
        traced: hits.map(|hits| Traced { index, hits }),
    }
}

#[cfg(test)]
mod tests {
    use glam::Vec3;

    use crate::cost::{ReducedTraversal, SampleRate, Work};
    use crate::{Bvh, Ray, RayBatch, Walk};

    /// Runs of 8 at a quarter: a task of 1024 rays has 32 runs, 8 at the first level.
    const RATE: f64 = 0.25;

    fn forest() -> (Bvh, RayBatch) {
        crate::cost::estimator::tests::forest_of(96)
    }

    fn estimator<'a>(bvh: &'a Bvh, rays: &'a RayBatch, walk: Walk) -> ReducedTraversal<'a> {
        ReducedTraversal::new(bvh, rays, SampleRate::new(RATE).unwrap()).with_walk(walk)
    }

    /// Sampled rays of each task, from the trace walk's index.
    fn per_task(index: &[usize], tasks: &[std::ops::Range<usize>]) -> Vec<usize> {
        tasks
            .iter()
            .map(|r| index.iter().filter(|i| r.contains(i)).count())
            .collect()
    }

    #[test]
    fn a_target_never_met_grows_every_task_that_varies_to_the_fixed_rates_sample() {
        let (bvh, rays) = forest();
        let tasks = sched::split_ranges(rays.len(), 1024);
        for walk in [
            Walk::Reduced,
            Walk::Trace { any: false },
            Walk::Trace { any: true },
        ] {
            let fixed = estimator(&bvh, &rays, walk).try_sample(&tasks).unwrap();
            let grown = estimator(&bvh, &rays, walk)
                .with_sample_error(Some(1e-12))
                .try_sample(&tasks)
                .unwrap();
            // Every task's estimate is the fixed sample's: grown to it, or (a task of sky,
            // every ray entering the root alone) its halves agreed exactly at a quarter.
            assert_eq!(grown.work, fixed.work, "{walk:?}");
            let whole = tasks.len() - 3;
            assert_eq!(grown.sampled, whole * 256 + 3 * 64, "{walk:?}");
            let (Some(g), Some(f)) = (grown.traced, fixed.traced) else {
                assert!(!matches!(walk, Walk::Trace { .. }));
                continue;
            };
            // Each sampled ray's hit, as the fixed sample traced it.
            for (k, i) in g.index.iter().enumerate() {
                let at = f.index.binary_search(i).expect("a ray of the fixed sample");
                assert_eq!(g.hits.get(k), f.hits.get(at), "{walk:?} ray {i}");
            }
        }
    }

    #[test]
    fn a_target_met_at_once_keeps_every_fourth_run_and_small_tasks_whole() {
        let (bvh, rays) = forest();
        // Two tasks of 32 runs, and one of 4 (too few to split: taken whole).
        let tasks = [0..1024, 1024..2048, 2048..2176];
        let e = estimator(&bvh, &rays, Walk::Trace { any: false });
        let s = e.with_sample_error(Some(0.99)).try_sample(&tasks).unwrap();
        assert_eq!(s.sampled, 64 + 64 + 32);
        let traced = s.traced.expect("the trace walk's hits");
        assert_eq!(per_task(&traced.index, &tasks), vec![64, 64, 32]);
        // The fixed rate's sample, in order.
        let fixed = e.try_sample(&tasks).unwrap().traced;
        let full = fixed.expect("the trace walk's hits").index;
        let quarter: Vec<usize> = full[..512]
            .chunks(8)
            .step_by(4)
            .flatten()
            .copied()
            .chain(full[512..].iter().copied())
            .collect();
        assert_eq!(traced.index, quarter);
        for (k, &i) in traced.index.iter().enumerate() {
            let hit = bvh.closest_hit(&rays.get(i)).map(|h| (h.t, h.prim));
            assert_eq!(traced.hits.get(k), hit, "ray {i}");
        }
    }

    #[test]
    fn identical_rays_agree_at_once_and_are_estimated_exactly() {
        let (bvh, _) = forest();
        let ray = Ray::new(Vec3::new(0.0, 50.0, 0.0), Vec3::new(0.1, -1.0, 0.05));
        let rays: RayBatch = std::iter::repeat_n(ray, 3000).collect();
        let tasks = [0..1024, 1024..3000];
        let one = Work::sum(&[bvh.closest_hit_counted(&ray).1]);
        let e = estimator(&bvh, &rays, Walk::Trace { any: false });
        let s = e.with_sample_error(Some(1e-12)).try_sample(&tasks).unwrap();
        // The second task's 62 runs: the last has 6 rays, and every fourth from the first has 8.
        assert_eq!(per_task(&s.traced.unwrap().index, &tasks), vec![64, 128]);
        for (r, w) in tasks.iter().zip(&s.work) {
            assert_eq!(*w, one.scaled(r.len(), 1));
        }
    }

    #[test]
    fn the_sample_grows_where_the_cost_varies() {
        let (bvh, forest) = forest();
        // Four tasks of camera rays over the trees, then four of one ray repeated.
        let ray = forest.get(6000);
        let mut rays: RayBatch = (5120..9216).map(|i| forest.get(i)).collect();
        rays.extend(&std::iter::repeat_n(ray, 4096).collect());
        let tasks = sched::split_ranges(rays.len(), 1024);
        let e = estimator(&bvh, &rays, Walk::Trace { any: false });
        let s = e.with_sample_error(Some(1e-12)).try_sample(&tasks).unwrap();
        let got = per_task(&s.traced.unwrap().index, &tasks);
        assert_eq!(got, [256, 256, 256, 256, 64, 64, 64, 64]);
    }
}
