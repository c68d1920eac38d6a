use std::ops::Range;

use std::time::Instant;

use sched::CostEstimator;

use crate::{DensityGrid, KnnIndex, KnnQueries};

/// What a query costs beyond the points it examines, in the same unit: descending the tree
/// and scanning the first leaf (kiddo's leaves hold 32 points).
const DESCENT: f64 = 32.0;

/// The tree search examines the leaves that straddle the k-th neighbour's sphere, not only
/// the points inside it: count the points in a cube this much wider.
const SHELL: f32 = 1.5;

pub use sched::SampleRate;

/// Estimates a task's cost from a density grid, never touching the k-d tree: for each
/// sampled query, the grid gives the half-width `r` of the cube expected to hold `k`
/// points, and the points expected in that cube around the query stand for the points the
/// tree search examines. A query inside a dense cluster examines about `k`; one in sparse
/// space beside a cluster has a wide cube that reaches into the cluster and examines many
/// (that is where kd-tree searches are slow). The sum over the sample is scaled to the task.
///
/// This plays the role of the thesis's reduced traversal: the same question (how much work
/// will this query do?) answered on a coarser structure, without the expensive part
/// (distance evaluations).
#[derive(Debug, Clone)]
pub struct DensityEstimator<'a> {
    grid: &'a DensityGrid,
    queries: &'a KnnQueries,
    rate: SampleRate,
}

impl<'a> DensityEstimator<'a> {
    /// An estimator over a grid of the cloud for a query batch.
    pub fn new(grid: &'a DensityGrid, queries: &'a KnnQueries, rate: SampleRate) -> Self {
        DensityEstimator {
            grid,
            queries,
            rate,
        }
    }

    /// The estimated work of one query, in points examined.
    pub fn query_work(&self, q: &[f32; 3]) -> f64 {
        let k = self.queries.k.get();
        let r = self.grid.knn_half_width(q, k);
        DESCENT + self.grid.points_in_cube(q, SHELL * r).max(k as f64)
    }

    /// The estimate of one task (a range of the sorted queries).
    pub fn task_work(&self, task: &Range<usize>) -> f64 {
        let points = &self.queries.points[task.clone()];
        if points.is_empty() {
            return 0.0;
        }
        let sampled: Vec<f64> = points
            .iter()
            .step_by(self.rate.stride())
            .map(|q| self.query_work(q))
            .collect();
        sampled.iter().sum::<f64>() * points.len() as f64 / sampled.len() as f64
    }
}

impl CostEstimator<Range<usize>> for DensityEstimator<'_> {
    fn estimate(&self, tasks: &[Range<usize>]) -> Vec<f64> {
        tasks.iter().map(|t| self.task_work(t)).collect()
    }
}

/// Estimates a task's cost by running the real kiddo search for a sample of its queries and
/// timing them, scaled to the task. Accurate (the rank correlation with measured task time
/// is close to that of one measurement with another) but its overhead is the sample's share
/// of the real work; the [`DensityEstimator`] is far cheaper and far less accurate.
#[derive(Debug, Clone)]
pub struct SampledQueries<'a> {
    index: &'a KnnIndex,
    queries: &'a KnnQueries,
    rate: SampleRate,
}

impl<'a> SampledQueries<'a> {
    /// An estimator that probes `index` with a sample of `queries`.
    pub fn new(index: &'a KnnIndex, queries: &'a KnnQueries, rate: SampleRate) -> Self {
        SampledQueries {
            index,
            queries,
            rate,
        }
    }
}

impl CostEstimator<Range<usize>> for SampledQueries<'_> {
    fn estimate(&self, tasks: &[Range<usize>]) -> Vec<f64> {
        let mut out = Vec::with_capacity(self.queries.k.get());
        tasks
            .iter()
            .map(|t| {
                let points = &self.queries.points[t.clone()];
                let start = Instant::now();
                let mut sampled = 0;
                for q in points.iter().step_by(self.rate.stride()) {
                    self.index.nearest(q, self.queries.k, &mut out);
                    out.clear();
                    sampled += 1;
                }
                // Seconds of one device thread for the whole task.
                let seconds = start.elapsed().as_secs_f64();
                seconds * points.len() as f64 / f64::from(sampled.max(1))
            })
            .collect()
    }
}

/// The thesis's prediction error, `sched`'s: shared by every estimator of the workspace.
pub use sched::prediction_error;
