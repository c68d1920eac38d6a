//! The seam between shading and tracing: the host's shaders hand whole generations of rays to
//! a [`Tracer`] and get hits back. [`CpuTracer`] traces them on the host's threads; a counting
//! tracer wraps it where an estimate renders a sample of paths (`crate::paths::sample_paths`).

use crate::traverse::batch::{any_hits, closest_hits};
use crate::{Bvh, HitBatch, RayBatch, RayKind};

/// Traces generations of rays. There is one required method.
///
/// ## Contract
/// `trace` returns one entry per ray, in order: for [`RayKind::is_occlusion`] kinds any hit within
/// the ray's range (`t` of the hit found), otherwise the closest; misses as in [`HitBatch`].
/// Results must not depend on how the work was split, so renders are deterministic.
pub trait Tracer {
    /// Traces one generation.
    fn trace(&mut self, kind: RayKind, rays: &RayBatch) -> HitBatch;

    /// Traces one generation whose ray `i` belongs to the path at `path_of(i)` (its place in
    /// the film the shaders write): what a tracer that keeps something per path overrides.
    fn trace_paths(
        &mut self,
        kind: RayKind,
        rays: &RayBatch,
        path_of: &dyn Fn(usize) -> u32,
    ) -> HitBatch {
        let _ = path_of;
        self.trace(kind, rays)
    }
}

/// The CPU tracer: rayon over the batch functions of [`crate::traverse`], in whatever rayon
/// pool the caller runs in (the global one by default; a `--devices cpu:N` device installs
/// its own).
pub struct CpuTracer<'a> {
    bvh: &'a Bvh,
}

impl<'a> CpuTracer<'a> {
    /// Traces `bvh`.
    pub fn new(bvh: &'a Bvh) -> Self {
        Self { bvh }
    }
}

impl Tracer for CpuTracer<'_> {
    fn trace(&mut self, kind: RayKind, rays: &RayBatch) -> HitBatch {
        if kind.is_occlusion() {
            any_hits(self.bvh, rays)
        } else {
            closest_hits(self.bvh, rays)
        }
    }
}

/// A tracer that keeps a copy of every generation it is handed (kind and rays) and traces
/// it with `inner`: the rays a shader produces, for estimating or replaying them elsewhere.
pub struct Recorder<T> {
    /// The tracer that does the work.
    pub inner: T,
    /// Every generation traced, in order.
    pub generations: Vec<(RayKind, RayBatch)>,
}

impl<T: Tracer> Recorder<T> {
    /// Records what `inner` traces.
    pub fn new(inner: T) -> Self {
        Self {
            inner,
            generations: Vec::new(),
        }
    }
}

impl<T: Tracer> Tracer for Recorder<T> {
    fn trace(&mut self, kind: RayKind, rays: &RayBatch) -> HitBatch {
        self.generations.push((kind, rays.clone()));
        self.inner.trace(kind, rays)
    }
}
