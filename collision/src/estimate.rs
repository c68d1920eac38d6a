use std::ops::Range;

use sched::CostEstimator;

use crate::{World, broad};

/// A narrow-phase test costs about this many BVH node tests (GJK/EPA or a specialised
/// contact against a box test): the weight of a candidate against a node in the cost.
pub const CANDIDATE_WEIGHT: f64 = 20.0;

pub use sched::SampleRate;

/// The thesis's estimator for collision: the broad phase of a sample of each task's bodies,
/// counting BVH nodes `B` and candidate pairs `N` without any narrow phase, `C = B + w·N`,
/// scaled to the task. Swarms make `N` vary by orders of magnitude between tasks.
#[derive(Debug, Clone, Copy)]
pub struct BroadPhaseCount<'a> {
    world: &'a World,
    rate: SampleRate,
}

impl<'a> BroadPhaseCount<'a> {
    /// An estimator over `world` sampling at `rate`.
    pub fn new(world: &'a World, rate: SampleRate) -> Self {
        BroadPhaseCount { world, rate }
    }

    /// The estimate of one task.
    pub fn task_work(&self, task: &Range<usize>) -> f64 {
        if task.is_empty() {
            return 0.0;
        }
        let (mut sum, mut sampled) = (0.0, 0usize);
        for i in task.clone().step_by(self.rate.stride()) {
            let w = broad::count(self.world, i);
            sum += w.nodes + CANDIDATE_WEIGHT * w.candidates;
            sampled += 1;
        }
        sum * task.len() as f64 / sampled as f64
    }
}

impl CostEstimator<Range<usize>> for BroadPhaseCount<'_> {
    fn estimate(&self, tasks: &[Range<usize>]) -> Vec<f64> {
        tasks.iter().map(|t| self.task_work(t)).collect()
    }
}

/// The thesis's prediction error, `sched`'s: shared by every estimator of the workspace.
pub use sched::prediction_error;
