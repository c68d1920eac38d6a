//! One GPU adapter tracing batches of rays: the GPU's side of `cobalt trace` and of
//! `cobalt estimate`, beside the host's traversal (`crate::traverse`).

use std::ops::Range;
use std::sync::Mutex;
use std::sync::atomic::{AtomicU64, Ordering};

use crate::Traffic;
use crate::cost::CountRays;
use crate::traverse::counts::Counts;
use crate::{Bvh, HitBatch, Layout, RayBatch, Walk};

use super::staging::{Staging, staged};
use super::trace::TraceDevice;
use super::{GpuContext, GpuError};

/// A GPU with a BVH uploaded and its kernels compiled: traces ranges of a batch of rays, all
/// of them in one launch ([`GpuDevice::hits`]), and counts an estimate's samples by the trace
/// kernels' counting modes (as a [`CountRays`], under [`crate::cost::ReducedTraversal`]).
#[derive(Debug)]
pub struct GpuDevice {
    dev: TraceDevice,
    /// The last launch's GPU seconds as `f64` bits; NaN when unknown (launches take `&self`).
    last_seconds: AtomicU64,
    /// The hit launches' buffers, kept from one launch to the next.
    staging: Mutex<Option<Staging>>,
}

impl GpuDevice {
    /// Uploads `bvh` to `ctx`'s device and compiles the kernels for it.
    ///
    /// # Errors
    /// [`GpuError::TooLarge`] when the tree exceeds a binding limit, [`GpuError::TooDeep`]
    /// beyond the deepest supported tree.
    pub fn new(ctx: GpuContext, bvh: &Bvh) -> Result<Self, GpuError> {
        Self::with_layout(ctx, bvh, Layout::Binary)
    }

    /// Uploads `bvh` as `layout` lays it out (the binary tree, or the compressed 8-wide nodes
    /// of [`super::wide`]) and compiles that layout's kernels. Both find the same hits; the
    /// counts of the reduced walk are the nodes of the layout walked, and the wide layout does
    /// not run the first-leaf walk.
    ///
    /// # Errors
    /// Those of [`GpuDevice::new`], and [`GpuError::Compress`] for a wide tree with no
    /// compressed form.
    pub fn with_layout(ctx: GpuContext, bvh: &Bvh, layout: Layout) -> Result<Self, GpuError> {
        Ok(Self {
            dev: TraceDevice::with_layout(ctx, bvh, layout)?,
            last_seconds: AtomicU64::new(f64::NAN.to_bits()),
            staging: Mutex::new(None),
        })
    }

    /// The GPU time of the last hit launch in seconds, from timestamp queries; `None` where
    /// the device has none (or before the first launch).
    pub fn last_gpu_seconds(&self) -> Option<f64> {
        Some(f64::from_bits(self.last_seconds.load(Ordering::Relaxed))).filter(|s| !s.is_nan())
    }

    /// The tree the kernels walk.
    pub fn layout(&self) -> Layout {
        self.dev.layout
    }

    /// Bytes one node visit of the reduced walk reads: an 80-byte compressed wide node, or for
    /// the binary tree the 64-byte pair of siblings that holds the node entered (its parent
    /// read the pair to test both boxes; the node's own 32 bytes come from that line).
    pub fn node_bytes(&self) -> usize {
        match self.dev.layout {
            Layout::Binary => 2 * size_of::<crate::Node>(),
            Layout::Wide => super::wide::CompressedTree::NODE_BYTES,
        }
    }

    /// The opened adapter.
    pub fn context(&self) -> &GpuContext {
        &self.dev.ctx
    }

    /// Hits of the rays of `ranges`, one after another, in one launch: any hits for occlusion
    /// kinds, closest hits otherwise.
    ///
    /// # Errors
    /// [`GpuError::Readback`] when the GPU cannot be waited for or read, [`GpuError::LoopCut`]
    /// when the implementation ended a traversal loop early.
    ///
    /// # Panics
    /// Panics if a range is beyond the batch.
    pub fn hits(
        &self,
        occlusion: bool,
        rays: &RayBatch,
        ranges: &[&Range<usize>],
    ) -> Result<HitBatch, GpuError> {
        let out = self.trace(rays, ranges, Walk::Trace { any: occlusion })?;
        Ok(HitBatch {
            t: out.iter().map(|r| f32::from_bits(r[0])).collect(),
            prim: out.iter().map(|r| r[1]).collect(),
        })
    }

    /// `mode`'s results for the rays of `ranges` (see [`staged`]), through the buffers kept
    /// from the last launch; the kernels' GPU seconds are kept for [`GpuDevice::last_gpu_seconds`].
    ///
    /// # Errors
    /// [`GpuError::Readback`] when the GPU cannot be waited for or read, [`GpuError::LoopCut`]
    /// when the implementation ended a traversal loop early.
    fn trace(
        &self,
        rays: &RayBatch,
        ranges: &[&Range<usize>],
        mode: Walk,
    ) -> Result<Vec<[u32; 2]>, GpuError> {
        // A launch that panicked left nothing worth keeping: its buffers are dropped.
        let mut staging = self.staging.lock().unwrap_or_else(|poisoned| {
            let mut s = poisoned.into_inner();
            *s = None;
            s
        });
        // What crosses is counted for the path devices' reports; a batch's trace has none.
        let traffic = &mut Traffic::default();
        let (out, seconds) = staged(&mut staging, &self.dev, rays, ranges, mode, traffic)?;
        self.last_seconds
            .store(seconds.unwrap_or(f64::NAN).to_bits(), Ordering::Relaxed);
        Ok(out)
    }
}

/// The reduced walks' counts of an estimate's sample: only the sampled rays are uploaded,
/// traced by the trace kernels' counting modes, and their counts `B`, `T` (8 bytes a ray) come
/// back, equal to the host's.
impl CountRays for GpuDevice {
    type Error = GpuError;

    /// # Errors
    /// [`GpuError::WalkUnsupported`] for the trace walk (before anything is uploaded), and
    /// the errors of [`GpuDevice::hits`].
    fn count_at(
        &self,
        rays: &RayBatch,
        walk: Walk,
        index: &[usize],
    ) -> Result<(Option<HitBatch>, Vec<Counts>), GpuError> {
        if let Walk::Trace { .. } = walk {
            return Err(GpuError::WalkUnsupported { walk: walk.name() });
        }
        if walk == Walk::FirstLeaf && self.dev.layout == Layout::Wide {
            return Err(GpuError::LayoutUnsupported {
                layout: self.dev.layout.name(),
                walk: walk.name(),
            });
        }
        // The samples come in runs of neighbours: one range a run.
        let mut runs: Vec<Range<usize>> = Vec::new();
        for &i in index {
            match runs.last_mut() {
                Some(r) if r.end == i => r.end += 1,
                _ => runs.push(i..i + 1),
            }
        }
        let out = self.trace(rays, &runs.iter().collect::<Vec<_>>(), walk)?;
        let counts = out
            .into_iter()
            .map(|[nodes, tris]| Counts { nodes, tris })
            .collect();
        Ok((None, counts))
    }
}
