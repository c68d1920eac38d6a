//! One GPU adapter as a device of the scheduler.

use std::ops::Range;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Mutex, PoisonError};

use sched::{DeviceError, Sink};

use crate::Traffic;
use crate::ray_device::{BadRange, RayDevice};
use crate::traverse::counts::Counts;
use crate::{Bvh, HitBatch, RayBatch, RayKind};

use super::buffers::{SceneBuffers, pack_rays};
use super::program::Kernel;
use super::sampling::{SampledCounts, Sampling, estimate_kernel, sampled_counts};
use super::staging::{Staging, staged_hits};
use super::trace::{Threads, TraceKernels, TraceMode, launch};
use super::{GpuContext, GpuError};

/// A GPU with a BVH uploaded and its kernels compiled: traces ranges of a generation's rays,
/// all ranges of a static plan in one launch ([`RayDevice::trace_ranges`]); a queue policy
/// launches once per task.
#[derive(Debug)]
pub struct GpuDevice {
    ctx: GpuContext,
    kernels: TraceKernels,
    estimate: Kernel,
    scene: SceneBuffers,
    threads: Threads,
    /// The last launch's GPU seconds as `f64` bits; NaN when unknown.
    last_seconds: AtomicU64,
    /// GPU seconds of the hit launches since [`RayDevice::take_device_seconds`] last took
    /// them, as `f64` bits (launches take `&self`).
    kernel_seconds: AtomicU64,
    /// The hit launches' buffers, kept from one launch to the next.
    staging: Mutex<Option<Staging>>,
    /// What crossed since [`RayDevice::take_traffic`] last took it.
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
            threads: Threads::default(),
            last_seconds: AtomicU64::new(f64::NAN.to_bits()),
            kernel_seconds: AtomicU64::new(0f64.to_bits()),
            staging: Mutex::new(None),
            traffic: Mutex::new(Traffic::default()),
        })
    }

    /// The same device handing rays to invocations as `threads` says (persistent threads by
    /// default).
    pub fn with_threads(self, threads: Threads) -> Self {
        Self { threads, ..self }
    }

    /// How rays are handed to invocations.
    pub fn threads(&self) -> Threads {
        self.threads
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

    fn check(&self, rays: &RayBatch, range: &Range<usize>) -> Result<(), BadRange> {
        BadRange::check(|| self.ctx.name(), rays, range)
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
            self.threads,
            &mut traffic,
        );
        self.count(traffic);
        let (hits, seconds) = staged?;
        self.last_seconds
            .store(seconds.unwrap_or(f64::NAN).to_bits(), Ordering::Relaxed);
        if let Some(s) = seconds {
            // One thread launches at a time (the runtime's device thread), but the update is
            // a loop anyway so that `hits` stays safe to call from several.
            let _ = self
                .kernel_seconds
                .fetch_update(Ordering::Relaxed, Ordering::Relaxed, |b| {
                    Some((f64::from_bits(b) + s).to_bits())
                });
        }
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

    /// Adds `traffic` to what [`RayDevice::take_traffic`] will take.
    fn count(&self, traffic: Traffic) {
        // A poisoned lock only means another launch panicked; the counts are still valid.
        *self.traffic.lock().unwrap_or_else(PoisonError::into_inner) += traffic;
    }
}

impl RayDevice for GpuDevice {
    fn trace_range(
        &mut self,
        kind: RayKind,
        rays: &RayBatch,
        range: &Range<usize>,
    ) -> Result<HitBatch, DeviceError> {
        self.check(rays, range)?;
        Ok(self.hits(kind.is_occlusion(), rays, &[range])?)
    }

    /// One launch for all `ranges`; each range's hits are cut out of its results in order.
    /// Every ray is traced, `known` ones too (the device does not skip them).
    fn trace_ranges(
        &mut self,
        kind: RayKind,
        rays: &RayBatch,
        ranges: &[&Range<usize>],
        known: &[usize],
        sink: &mut Sink<HitBatch>,
    ) -> Result<(), DeviceError> {
        let _ = known;
        for r in ranges {
            self.check(rays, r)?;
        }
        let all = self.hits(kind.is_occlusion(), rays, ranges)?;
        // A launch of one task (every launch of a queue policy) times that task on the GPU;
        // a launch of several has one time for all of them, so none per task.
        if let ([_], Some(seconds)) = (ranges, self.last_gpu_seconds()) {
            sink.push_timed(all, seconds);
            return Ok(());
        }
        let mut start = 0;
        for r in ranges {
            let end = start + r.len();
            sink.push(HitBatch {
                t: all.t[start..end].to_vec(),
                prim: all.prim[start..end].to_vec(),
            });
            start = end;
        }
        Ok(())
    }

    fn name(&self) -> String {
        self.ctx.name()
    }

    /// The thesis's estimate on the GPU: sample, compact, reduced traversal and per-task sums
    /// on the device ([`super::GpuReducedTraversal`]), equal to the CPU's.
    fn estimate_work(
        &mut self,
        rays: &RayBatch,
        tasks: &[Range<usize>],
        rate: crate::cost::SampleRate,
        walk: crate::Walk,
    ) -> Option<Result<Vec<crate::cost::Work>, DeviceError>> {
        let estimator = super::GpuReducedTraversal::new(self, rays, rate).with_walk(walk);
        Some(estimator.try_work(tasks).map_err(DeviceError::from))
    }

    /// The rays uploaded and hits read back (and an estimate's samples and sums).
    fn take_traffic(&mut self) -> Traffic {
        std::mem::take(
            self.traffic
                .get_mut()
                .unwrap_or_else(PoisonError::into_inner),
        )
    }

    /// The kernels' time from timestamp queries, where the adapter has them.
    fn take_device_seconds(&mut self) -> Option<f64> {
        let taken = f64::from_bits(self.kernel_seconds.swap(0f64.to_bits(), Ordering::Relaxed));
        self.ctx.timestamps.then_some(taken)
    }
}
