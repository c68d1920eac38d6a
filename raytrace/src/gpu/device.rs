//! One GPU adapter tracing batches of rays: the GPU's side of `cobalt trace` and of
//! `cobalt estimate`, beside the host's traversal (`crate::traverse`).

use std::ops::Range;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Mutex, PoisonError};

use crate::Traffic;
use crate::traverse::counts::Counts;
use crate::{Bvh, HitBatch, RayBatch};

use super::buffers::{SceneBuffers, pack_rays};
use super::program::Kernel;
use super::sampling::{SampledCounts, Sampling, estimate_kernel, sampled_counts};
use super::staging::{Staging, staged_hits};
use super::trace::{TraceKernels, TraceMode, launch};
use super::{GpuContext, GpuError};

/// A GPU with a BVH uploaded and its kernels compiled: traces ranges of a batch of rays, all
/// of them in one launch ([`GpuDevice::hits`]), and counts an estimate's samples on the
/// device ([`GpuDevice::sampled_counts`]).
#[derive(Debug)]
pub struct GpuDevice {
    ctx: GpuContext,
    kernels: TraceKernels,
    estimate: Kernel,
    scene: SceneBuffers,
    /// The last launch's GPU seconds as `f64` bits; NaN when unknown (launches take `&self`).
    last_seconds: AtomicU64,
    /// The hit launches' buffers, kept from one launch to the next.
    staging: Mutex<Option<Staging>>,
    /// What crossed since [`GpuDevice::take_traffic`] last took it.
    traffic: Mutex<Traffic>,
}

impl GpuDevice {
    /// Uploads `bvh` to `ctx`'s device and compiles the kernels for it.
    ///
    /// # Errors
    /// [`GpuError::TooLarge`] when the tree exceeds a binding limit, [`GpuError::TooDeep`]
    /// beyond the deepest supported tree.
    pub fn new(ctx: GpuContext, bvh: &Bvh) -> Result<Self, GpuError> {
        let kernels = TraceKernels::new(&ctx.device, bvh.depth())?;
        let scene = SceneBuffers::upload(&ctx, bvh)?;
        let estimate = estimate_kernel(&ctx.device);
        Ok(Self {
            ctx,
            kernels,
            estimate,
            scene,
            last_seconds: AtomicU64::new(f64::NAN.to_bits()),
            staging: Mutex::new(None),
            traffic: Mutex::new(Traffic::default()),
        })
    }

    /// The GPU time of the last hit launch in seconds, from timestamp queries; `None` where
    /// the device has none (or before the first launch).
    pub fn last_gpu_seconds(&self) -> Option<f64> {
        Some(f64::from_bits(self.last_seconds.load(Ordering::Relaxed))).filter(|s| !s.is_nan())
    }

    /// The opened adapter.
    pub fn context(&self) -> &GpuContext {
        &self.ctx
    }

    /// Hits of the rays of `ranges`, one after another, in one launch: any hits for occlusion
    /// kinds, closest hits otherwise.
    ///
    /// # Errors
    /// See [`launch`].
    ///
    /// # Panics
    /// Panics if a range is beyond the batch.
    pub fn hits(
        &self,
        occlusion: bool,
        rays: &RayBatch,
        ranges: &[&Range<usize>],
    ) -> Result<HitBatch, GpuError> {
        let mode = if occlusion {
            TraceMode::Any
        } else {
            TraceMode::Closest
        };
        // A launch that panicked left nothing worth keeping: its buffers are dropped.
        let mut staging = self.staging.lock().unwrap_or_else(|poisoned| {
            let mut s = poisoned.into_inner();
            *s = None;
            s
        });
        let mut traffic = Traffic::default();
        let staged = staged_hits(
            &mut staging,
            &self.ctx,
            &self.kernels,
            &self.scene,
            rays,
            ranges,
            mode,
            &mut traffic,
        );
        self.count(traffic);
        let (hits, seconds) = staged?;
        self.last_seconds
            .store(seconds.unwrap_or(f64::NAN).to_bits(), Ordering::Relaxed);
        Ok(hits)
    }

    /// `walk`'s counts of the rays of `range` (equal to [`crate::traverse::reduced_counts`]'s).
    ///
    /// # Errors
    /// See [`launch`].
    ///
    /// # Panics
    /// Panics if `range` is beyond the batch.
    pub fn reduced_counts(
        &self,
        rays: &RayBatch,
        walk: crate::Walk,
        range: &Range<usize>,
    ) -> Result<Vec<Counts>, GpuError> {
        let packed = pack_rays(rays, &[range]);
        let out = launch(
            &self.ctx,
            &self.kernels,
            &self.scene,
            &packed,
            TraceMode::counts(walk)?,
        )?;
        Ok(out
            .into_iter()
            .map(|[nodes, tris]| Counts { nodes, tris })
            .collect())
    }
}

impl GpuDevice {
    /// The estimator's sums on the device: every task of `rays` sampled at `rate` by
    /// [`crate::cost::Compacted::gather`] on the host, only the samples uploaded and traced by
    /// the reduced traversal, and their `B` and `T` summed per task (see
    /// [`super::GpuReducedTraversal`] for the estimator built on it).
    ///
    /// # Errors
    /// [`GpuError::BadTasks`] for an empty task or one beyond the batch, and the errors of
    /// [`launch`].
    pub fn sampled_counts(
        &self,
        rays: &RayBatch,
        tasks: &[Range<usize>],
        rate: crate::cost::SampleRate,
        walk: crate::Walk,
    ) -> Result<Vec<SampledCounts>, GpuError> {
        let mut traffic = Traffic::default();
        let counts = sampled_counts(
            &self.ctx,
            &self.kernels,
            &self.estimate,
            &self.scene,
            rays,
            tasks,
            Sampling { rate, walk },
            &mut traffic,
        );
        self.count(traffic);
        counts
    }

    /// What crossed between the host and the device since the last call: the rays uploaded
    /// and hits read back, and an estimate's samples and sums.
    pub fn take_traffic(&mut self) -> Traffic {
        std::mem::take(
            self.traffic
                .get_mut()
                .unwrap_or_else(PoisonError::into_inner),
        )
    }

    /// Adds `traffic` to what [`GpuDevice::take_traffic`] will take.
    fn count(&self, traffic: Traffic) {
        // A poisoned lock only means another launch panicked; the counts are still valid.
        *self.traffic.lock().unwrap_or_else(PoisonError::into_inner) += traffic;
    }
}
