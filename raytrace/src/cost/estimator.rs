//! The reduced-traversal estimator (thesis, section 3.1): trace a compacted uniform sample of
//! each task's rays through the boxes only, count nodes `B` and reached triangles `T`, scale
//! to the task's length and weigh by `C = kB·B + kT·T`. It is written once over what counts
//! the sample ([`CountRays`]): the host's tree, or a GPU's trace kernels.

use std::ops::Range;

use super::refine::refine;
use super::sample::{Sample, check_tasks};
use super::{CostError, CostModel, SampleRate, SampleRun, Work};
use crate::traverse::batch::{reduced_counts_at, traced_at};
use crate::traverse::counts::Counts;
use crate::traverse::walk::Walk;
use crate::{Bvh, HitBatch, RayBatch};

/// What counts an estimate's sample: a list of rays of a batch, walked in one pass. The
/// host's tree counts on all cores (the 8-wide tree for the trace walk, the binary one for
/// the reduced walks); a GPU (`gpu::GpuDevice`) counts the reduced walks with its trace
/// kernels, exactly as the host does.
pub trait CountRays {
    /// Why a sample could not be counted; a bad task is one.
    type Error: From<CostError>;

    /// `walk`'s counts of the rays `index` of `rays`, in order, and with [`Walk::Trace`]
    /// their hits.
    ///
    /// # Errors
    /// A walk the counter cannot take, and the counter's own failures.
    fn count_at(
        &self,
        rays: &RayBatch,
        walk: Walk,
        index: &[usize],
    ) -> Result<(Option<HitBatch>, Vec<Counts>), Self::Error>;
}

impl CountRays for Bvh {
    type Error = CostError;

    fn count_at(
        &self,
        rays: &RayBatch,
        walk: Walk,
        index: &[usize],
    ) -> Result<(Option<HitBatch>, Vec<Counts>), CostError> {
        Ok(match walk {
            Walk::Trace { any } => {
                let (hits, counts) = traced_at(self, rays, any, index);
                (Some(hits), counts)
            }
            walk => (None, reduced_counts_at(self, rays, walk, index)),
        })
    }
}

/// Estimates ray tasks (ranges of one [`RayBatch`]) by the reduced traversal of a sample,
/// counted by `C` (the host's [`Bvh`], or a GPU).
///
/// As a [`sched::CostEstimator`] it cannot return an error: a task that is empty or outside
/// the batch gets a NaN cost, which [`sched::CostEstimator::estimate_timed`] rejects naming
/// that task, and a counter that fails gives every task a NaN cost.
/// [`ReducedTraversal::try_work`] says why.
#[derive(Debug)]
pub struct ReducedTraversal<'a, C = Bvh> {
    counter: &'a C,
    rays: &'a RayBatch,
    rate: SampleRate,
    run: SampleRun,
    walk: Walk,
    sample_error: Option<f64>,
}

// Derived, they would ask `C` to be `Clone` and `Copy`: only the reference is copied.
impl<C> Clone for ReducedTraversal<'_, C> {
    fn clone(&self) -> Self {
        *self
    }
}

impl<C> Copy for ReducedTraversal<'_, C> {}

impl ReducedTraversal<'_> {
    /// The halves' disagreement `cobalt estimate` refines its sample to unless told otherwise
    /// (see [`ReducedTraversal::with_sample_error`]; `docs/results.md`, "Sample-error
    /// targets compared", has the figures that chose it).
    pub const DEFAULT_SAMPLE_ERROR: f64 = 0.08;
}

impl<'a, C: CountRays> ReducedTraversal<'a, C> {
    /// An estimator of tasks of `rays` counted by `counter`, sampling at `rate`; its costs are
    /// the default [`CostModel`]'s.
    pub fn new(counter: &'a C, rays: &'a RayBatch, rate: SampleRate) -> Self {
        Self {
            counter,
            rays,
            rate,
            run: SampleRun::DEFAULT,
            walk: Walk::Reduced,
            sample_error: None,
        }
    }

    /// The same estimator with a sample that grows only as far as it needs (see
    /// `cost/refine.rs`): it starts at a quarter of the rate and doubles, up to the rate,
    /// while its two interleaved halves disagree by more than `target` (`Σ|A − B| / Σ(A + B)`
    /// over the tasks, the sample's expected share of `error_vs_time`). `None` takes the
    /// whole sample at the rate, as the thesis does.
    pub fn with_sample_error(self, target: Option<f64>) -> Self {
        Self {
            sample_error: target,
            ..self
        }
    }

    /// The same estimator keeping its samples in runs of `run` adjacent rays.
    pub fn with_run(self, run: SampleRun) -> Self {
        Self { run, ..self }
    }

    /// The same estimator tracing its sample with another reduced traversal.
    pub fn with_walk(self, walk: Walk) -> Self {
        Self { walk, ..self }
    }

    /// Estimated `B` and `T` of every task: the sample's sums scaled by `len / sampled`.
    pub fn try_work(&self, tasks: &[Range<usize>]) -> Result<Vec<Work>, C::Error> {
        Ok(self.try_sample(tasks)?.work)
    }

    /// Every task's estimated work, the rays sampled, and with [`Walk::Trace`] their hits.
    pub fn try_sample(&self, tasks: &[Range<usize>]) -> Result<Sample, C::Error> {
        check_tasks(self.rays, tasks)?;
        // Each pass over one list of every task's sampled rays (rayon chunks of it, or one
        // launch), not one per task: tasks of 512 rays sampled at 1/8 are 64 rays, too few to
        // split.
        let trace = |index: &[usize]| self.counter.count_at(self.rays, self.walk, index);
        // A sample of every ray is asked for exactly; nothing is left to refine towards.
        let target = self.sample_error.filter(|_| self.rate < SampleRate::FULL);
        refine(tasks, self.rate, self.run, target, trace)
    }
}

impl<C: CountRays> sched::CostEstimator<Range<usize>> for ReducedTraversal<'_, C> {
    fn estimate(&self, tasks: &[Range<usize>]) -> Vec<f64> {
        let checked = check_tasks(self.rays, tasks).map_err(Some);
        match checked.and_then(|()| self.try_work(tasks).map_err(|_| None)) {
            Ok(work) => CostModel::default().costs(&work),
            Err(e) => {
                // Mark the task at fault (or all, for a broken batch or a failed counter) so
                // the caller's validation names it instead of scheduling on a made-up cost.
                let bad = match e {
                    Some(
                        CostError::EmptyTask { task } | CostError::TaskOutOfRange { task, .. },
                    ) => Some(task),
                    _ => None,
                };
                (0..tasks.len())
                    .map(|t| {
                        if bad.is_none_or(|b| b == t) {
                            f64::NAN
                        } else {
                            0.0
                        }
                    })
                    .collect()
            }
        }
    }
}

/// `walk`'s reduced traversal of *every* ray of every task: the "full" of the thesis's
/// prediction error, the estimator's count at a sample rate of 1 (which takes every ray and
/// never refines). It is a reference, not timed.
pub fn full_work(
    bvh: &Bvh,
    rays: &RayBatch,
    tasks: &[Range<usize>],
    walk: Walk,
) -> Result<Vec<Work>, CostError> {
    ReducedTraversal::new(bvh, rays, SampleRate::FULL)
        .with_walk(walk)
        .try_work(tasks)
}

#[cfg(test)]
pub(super) mod tests {
    use glam::Vec3;
    use sched::CostEstimator;

    use super::*;
    use crate::{BuildPreset, Camera, Ray, SceneNeeds, SceneSource};
    use sched::prediction_error;

    /// A small forest and its camera rays, `size`² of them, for the estimator's tests.
    pub(in crate::cost) fn forest_of(size: u32) -> (Bvh, RayBatch) {
        let scene = SceneSource::parse("builtin:forest:0.02")
            .and_then(|s| s.load(SceneNeeds::AO))
            .expect("builtin scene");
        let bvh = Bvh::build(&scene, BuildPreset::Fast).expect("bvh");
        let rays = Camera::orbit(&scene.bounds(), 1)
            .primary_rays(size, size)
            .rays;
        (bvh, rays)
    }

    fn forest() -> (Bvh, RayBatch) {
        forest_of(48)
    }

    #[test]
    fn rate_one_gives_exactly_the_full_counts() {
        let (bvh, rays) = forest();
        let tasks = sched::split_ranges(rays.len(), 100);
        let est = ReducedTraversal::new(&bvh, &rays, SampleRate::FULL);
        let full = full_work(&bvh, &rays, &tasks, Walk::Reduced).unwrap();
        assert_eq!(est.try_work(&tasks).unwrap(), full);
        // The full count is every ray's own walk, one ray at a time.
        for walk in Walk::ALL {
            let single: Vec<Work> = tasks
                .iter()
                .map(|r| {
                    let counts: Vec<_> = r.clone().map(|i| bvh.walk(&rays.get(i), walk)).collect();
                    Work::sum(&counts)
                })
                .collect();
            assert_eq!(full_work(&bvh, &rays, &tasks, walk).unwrap(), single);
        }
        let m = CostModel::default();
        assert_eq!(
            prediction_error(&est.estimate(&tasks), &m.costs(&full)),
            Some(0.0)
        );
        assert!(
            full.iter().all(|w| w.nodes > 0.0),
            "every task sees the scene"
        );
    }

    #[test]
    fn sampling_converges_on_coherent_rays() {
        let (bvh, rays) = forest();
        let tasks = sched::split_ranges(rays.len(), 256);
        let m = CostModel::default();
        let full = m.costs(&full_work(&bvh, &rays, &tasks, Walk::Reduced).unwrap());
        let err = |r| {
            let e = ReducedTraversal::new(&bvh, &rays, SampleRate::new(r).unwrap());
            prediction_error(&m.costs(&e.try_work(&tasks).unwrap()), &full).unwrap()
        };
        let (e8, e2) = (err(0.125), err(0.5));
        assert!(e8 < 0.15 && e2 < 0.08 && e2 <= e8 + 0.01, "{e8} {e2}");
    }

    #[test]
    fn scaling_is_exact_for_uniform_tasks() {
        // Identical rays: any sample's mean is the task's mean, so the scaled estimate is exact
        // whatever the rate and the task length.
        let (bvh, _) = forest();
        let ray = Ray::new(Vec3::new(0.0, 50.0, 0.0), Vec3::new(0.1, -1.0, 0.05));
        let rays: RayBatch = std::iter::repeat_n(ray, 1000).collect();
        let tasks = vec![0..1000, 1000..1000, 0..333];
        assert_eq!(
            ReducedTraversal::new(&bvh, &rays, SampleRate::FULL).try_work(&tasks),
            Err(CostError::EmptyTask { task: 1 })
        );
        let tasks = vec![0..1000, 100..433, 999..1000];
        let one = Work::sum(&[bvh.reduced_traversal(&ray)]);
        for rate in [1e-6, 0.1, 0.125, 0.3, 1.0] {
            let e = ReducedTraversal::new(&bvh, &rays, SampleRate::new(rate).unwrap());
            let w = e.try_work(&tasks).unwrap();
            for (r, w) in tasks.iter().zip(&w) {
                assert_eq!(*w, one.scaled(r.len(), 1), "rate {rate}");
            }
        }
    }

    /// The trace walk counts what the real trace does and keeps the sample's hits, which
    /// are the trace's own; the reduced walks keep none.
    #[test]
    fn the_trace_walk_counts_the_real_trace_and_keeps_its_hits() {
        let (bvh, rays) = forest();
        let tasks = sched::split_ranges(rays.len(), 200);
        for any in [false, true] {
            let walk = Walk::Trace { any };
            let e = ReducedTraversal::new(&bvh, &rays, SampleRate::THESIS).with_walk(walk);
            let Sample { work, traced, .. } = e.try_sample(&tasks).unwrap();
            let traced = traced.expect("the sample's hits");
            // Every task's runs, task after task: one list for one pass.
            let sample: Vec<usize> = (tasks.iter())
                .flat_map(|r| {
                    let k = SampleRate::THESIS.samples(r.len());
                    let runs = crate::cost::sample::sample_runs(k, r.len(), SampleRun::DEFAULT);
                    runs.flatten().map(|i| r.start + i)
                })
                .collect();
            assert_eq!(traced.index, sample);
            assert!(traced.index.windows(2).all(|w| w[0] < w[1]), "sorted");
            for (k, &i) in traced.index.iter().enumerate() {
                let ray = rays.get(i);
                let (hit, _) = if any {
                    bvh.any_hit_counted(&ray)
                } else {
                    bvh.closest_hit_counted(&ray)
                };
                assert_eq!(traced.hits.get(k), hit.map(|h| (h.t, h.prim)), "ray {i}");
            }
            assert_eq!(work, e.try_work(&tasks).unwrap());
            // At a rate of 1 the estimate is the real trace's own counts.
            let full = ReducedTraversal::new(&bvh, &rays, SampleRate::FULL).with_walk(walk);
            let counted = if any {
                crate::traverse::any_hits_counted(&bvh, &rays).1
            } else {
                crate::traverse::closest_hits_counted(&bvh, &rays).1
            };
            let want: Vec<Work> = tasks
                .iter()
                .map(|r| Work::sum(&counted[r.clone()]))
                .collect();
            assert_eq!(full.try_work(&tasks).unwrap(), want);
            assert_eq!(full_work(&bvh, &rays, &tasks, walk).unwrap(), want);
        }
        let reduced = ReducedTraversal::new(&bvh, &rays, SampleRate::THESIS);
        assert_eq!(reduced.try_sample(&tasks).unwrap().traced, None);
    }

    #[test]
    fn bad_tasks_become_errors_or_named_nan_costs_never_panics() {
        let (bvh, rays) = forest();
        let n = rays.len();
        let e = ReducedTraversal::new(&bvh, &rays, SampleRate::THESIS);
        let err = e.try_work(&[0..10, n..n + 1]).unwrap_err();
        assert!(err.to_string().contains("task 1"), "{err}");
        let timed = e.estimate_timed(&[0..10, 10..10]).unwrap_err();
        assert!(
            matches!(timed, sched::SchedError::BadCost { task: 1, .. }),
            "{timed}"
        );
        #[allow(clippy::reversed_empty_ranges)] // the point of the test
        let backwards = vec![0..1, 5..3];
        assert!(full_work(&bvh, &rays, &backwards, Walk::Reduced).is_err());
        assert_eq!(e.try_work(&[]), Ok(vec![]));
    }
}
