//! The thesis's prediction error of every generation a render traces, measured beside the
//! render without touching its timing: a [`Tracer`] that, before handing a generation to the
//! real tracer, estimates its tasks as the scheduled tracer will (same rays, task size and
//! sampling rate, so the same numbers) and runs the full reduced traversal they are judged
//! against. Both passes are outside the scheduled tracer's clocks.

use std::ops::Range;

use raytrace::cost::{CostModel, ReducedTraversal, full_work};
use raytrace::scheduled::Settings;
use raytrace::shade::Tracer;
use raytrace::{Bvh, Counts, HitBatch, RayBatch, RayKind};

/// `Σ|estimated − full|` and `Σ full` of one generation, in default-model cost units.
#[derive(Clone, Copy, Debug, Default)]
pub struct ErrorSums {
    /// Sum of absolute differences.
    pub diff: f64,
    /// Sum of full costs.
    pub full: f64,
}

impl std::ops::AddAssign for ErrorSums {
    fn add_assign(&mut self, o: Self) {
        self.diff += o.diff;
        self.full += o.full;
    }
}

impl ErrorSums {
    /// The thesis's prediction error, `Σ|estimated − full| / Σ full` (0 for no work).
    pub fn ratio(self) -> f64 {
        if self.full > 0.0 {
            self.diff / self.full
        } else {
            0.0
        }
    }
}

/// Wraps a tracer; when `enabled`, records the prediction error sums of each generation.
pub struct PredictionTracer<'a, T> {
    pub inner: T,
    bvh: &'a Bvh,
    /// The scheduled tracer's: its task size, sampling rate and walk.
    settings: Settings,
    enabled: bool,
    /// One entry per generation traced, in order (empty when disabled).
    pub sums: Vec<(RayKind, ErrorSums)>,
}

impl<'a, T: Tracer> PredictionTracer<'a, T> {
    /// `settings` gives the task size, sampling rate and walk the scheduled tracer uses.
    pub fn new(inner: T, bvh: &'a Bvh, settings: &Settings, enabled: bool) -> Self {
        Self {
            inner,
            bvh,
            settings: *settings,
            enabled,
            sums: Vec::new(),
        }
    }

    fn error_sums(&self, kind: RayKind, rays: &RayBatch) -> ErrorSums {
        let s = &self.settings;
        let tasks: Vec<Range<usize>> = sched::split_ranges(rays.len(), s.task_size.get());
        let model = CostModel::default();
        let walk = s.walk.for_kind(kind);
        let est = ReducedTraversal::new(self.bvh, rays, s.sample_rate)
            .with_walk(walk)
            .try_work(&tasks);
        let full = full_work(self.bvh, rays, &tasks, walk);
        match (est, full) {
            (Ok(est), Ok(full)) => {
                let (est, full) = (model.costs(&est), model.costs(&full));
                ErrorSums {
                    diff: est.iter().zip(&full).map(|(e, f)| (e - f).abs()).sum(),
                    full: full.iter().sum(),
                }
            }
            // Only an empty generation has no tasks to judge; it adds nothing.
            _ => ErrorSums::default(),
        }
    }
}

impl<T: Tracer> Tracer for PredictionTracer<'_, T> {
    fn trace(&mut self, kind: RayKind, rays: &RayBatch) -> HitBatch {
        if self.enabled {
            let sums = self.error_sums(kind, rays);
            self.sums.push((kind, sums));
        }
        self.inner.trace(kind, rays)
    }

    fn counts(&mut self, rays: &RayBatch) -> Option<Vec<Counts>> {
        self.inner.counts(rays)
    }
}
