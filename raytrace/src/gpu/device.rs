//! One GPU adapter as a device of the scheduler.

use std::ops::Range;
use std::sync::atomic::{AtomicU64, Ordering};

use sched::{DeviceError, Sink};

use crate::scheduled::{BadRange, RayDevice};
use crate::{Bvh, Counts, HitBatch, RayBatch, RayKind};

use super::buffers::{SceneBuffers, pack_rays};
use super::pipeline::{GpuMode, Kernels, launch, launch_timed};
use super::{GpuContext, GpuError};

/// A GPU with a BVH uploaded and its kernels compiled: traces ranges of a generation's rays,
/// all ranges of a static plan in one launch ([`RayDevice::trace_ranges`]); a queue policy
/// launches once per task.
#[derive(Debug)]
pub struct GpuDevice {
    ctx: GpuContext,
    kernels: Kernels,
    scene: SceneBuffers,
    /// The last launch's GPU seconds as `f64` bits; NaN when unknown.
    last_seconds: AtomicU64,
}

impl GpuDevice {
    /// Uploads `bvh` to `ctx`'s device and compiles the kernels for it.
    ///
    /// # Errors
    /// [`GpuError::TooLarge`] when the tree exceeds a binding limit, [`GpuError::TooDeep`]
    /// beyond the deepest supported tree.
    pub fn new(ctx: GpuContext, bvh: &Bvh) -> Result<Self, GpuError> {
        let kernels = Kernels::new(&ctx.device, bvh.depth())?;
        let scene = SceneBuffers::upload(&ctx, bvh)?;
        Ok(Self {
            ctx,
            kernels,
            scene,
            last_seconds: AtomicU64::new(f64::NAN.to_bits()),
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
            GpuMode::Any
        } else {
            GpuMode::Closest
        };
        let packed = pack_rays(rays, ranges);
        let (out, seconds) = launch_timed(&self.ctx, &self.kernels, &self.scene, &packed, mode)?;
        self.last_seconds
            .store(seconds.unwrap_or(f64::NAN).to_bits(), Ordering::Relaxed);
        Ok(HitBatch {
            t: out.iter().map(|r| f32::from_bits(r[0])).collect(),
            prim: out.iter().map(|r| r[1]).collect(),
        })
    }

    /// Reduced-traversal counts of the rays of `range` (equal to
    /// [`crate::traverse::reduced_counts`]'s).
    ///
    /// # Errors
    /// See [`launch`].
    ///
    /// # Panics
    /// Panics if `range` is beyond the batch.
    pub fn reduced_counts(
        &self,
        rays: &RayBatch,
        range: &Range<usize>,
    ) -> Result<Vec<Counts>, GpuError> {
        let packed = pack_rays(rays, &[range]);
        let out = launch(
            &self.ctx,
            &self.kernels,
            &self.scene,
            &packed,
            GpuMode::Reduced,
        )?;
        Ok(out
            .into_iter()
            .map(|[nodes, tris]| Counts { nodes, tris })
            .collect())
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
    fn trace_ranges(
        &mut self,
        kind: RayKind,
        rays: &RayBatch,
        ranges: &[&Range<usize>],
        sink: &mut Sink<HitBatch>,
    ) -> Result<(), DeviceError> {
        for r in ranges {
            self.check(rays, r)?;
        }
        let all = self.hits(kind.is_occlusion(), rays, ranges)?;
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
}
