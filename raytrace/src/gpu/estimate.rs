//! The thesis's estimator on the GPU as a [`sched::CostEstimator`]: each task's sample traced
//! and counted on a [`GpuDevice`] (`sampling.rs` holds the kernel and its launch), the sums
//! weighed by a [`CostModel`]. Its costs are bit for bit the CPU's
//! [`crate::cost::ReducedTraversal`]'s.

use std::ops::Range;

use super::GpuError;
use super::device::GpuDevice;
use super::sampling::SampledCounts;
use crate::cost::{CostModel, SampleRate, Work};
use crate::ray::RayBatch;
use crate::traverse::walk::Walk;

/// The reduced-traversal estimator of [`crate::cost::ReducedTraversal`], run on a GPU: the
/// same sample, the same sums, the same costs.
///
/// As a [`sched::CostEstimator`] it cannot return an error: when the GPU fails or a task is
/// bad, every cost is NaN, which [`sched::CostEstimator::estimate_timed`] rejects;
/// [`GpuReducedTraversal::try_work`] says why.
#[derive(Clone, Copy, Debug)]
pub struct GpuReducedTraversal<'a> {
    device: &'a GpuDevice,
    rays: &'a RayBatch,
    rate: SampleRate,
    model: CostModel,
    walk: Walk,
}

impl<'a> GpuReducedTraversal<'a> {
    /// An estimator of tasks of `rays` on `device`, sampling at `rate`, with the default
    /// [`CostModel`].
    pub fn new(device: &'a GpuDevice, rays: &'a RayBatch, rate: SampleRate) -> Self {
        Self {
            device,
            rays,
            rate,
            model: CostModel::default(),
            walk: Walk::Reduced,
        }
    }

    /// The same estimator weighing `B` and `T` by a calibrated model.
    pub fn with_model(self, model: CostModel) -> Self {
        Self { model, ..self }
    }

    /// The same estimator tracing its sample with another reduced traversal.
    pub fn with_walk(self, walk: Walk) -> Self {
        Self { walk, ..self }
    }

    /// Estimated `B` and `T` of every task (equal to the CPU's).
    ///
    /// # Errors
    /// As [`GpuDevice::sampled_counts`].
    pub fn try_work(&self, tasks: &[Range<usize>]) -> Result<Vec<Work>, GpuError> {
        Ok(self
            .device
            .sampled_counts(self.rays, tasks, self.rate, self.walk)?
            .iter()
            .map(SampledCounts::work)
            .collect())
    }

    /// Estimated cost of every task.
    ///
    /// # Errors
    /// As [`GpuDevice::sampled_counts`].
    pub fn try_estimate(&self, tasks: &[Range<usize>]) -> Result<Vec<f64>, GpuError> {
        Ok(self.model.costs(&self.try_work(tasks)?))
    }
}

impl sched::CostEstimator<Range<usize>> for GpuReducedTraversal<'_> {
    fn estimate(&self, tasks: &[Range<usize>]) -> Vec<f64> {
        self.try_estimate(tasks)
            .unwrap_or_else(|_| vec![f64::NAN; tasks.len()])
    }
}
