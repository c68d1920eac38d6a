//! The seam between shading and tracing: the host's shaders hand whole generations of rays to
//! a [`Tracer`] and get hits back. [`CpuTracer`] traces them on the host's threads; a counting
//! tracer wraps it where an estimate renders a sample of paths (`crate::paths::sample_paths`).

use crate::traverse::batch::{any_hits, closest_hits};
use crate::{Bvh, HitBatch, RayBatch, RayKind, Result};

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

/// The CPU tracer: rayon over the batch functions of [`crate::traverse`], in its own pool of
/// threads or in the caller's.
pub struct CpuTracer<'a> {
    bvh: &'a Bvh,
    pool: Option<rayon::ThreadPool>,
}

impl<'a> CpuTracer<'a> {
    /// Traces in whatever rayon pool the caller runs in (the global one by default).
    pub fn new(bvh: &'a Bvh) -> Self {
        Self { bvh, pool: None }
    }

    /// Traces in a pool of its own with `threads` threads (the `--devices cpu:N` device).
    pub fn with_threads(bvh: &'a Bvh, threads: usize) -> Result<Self> {
        let pool = crate::pool::thread_pool(String::from("cobalt-cpu"), threads)?;
        Ok(Self {
            bvh,
            pool: Some(pool),
        })
    }

    /// Threads that trace.
    pub fn threads(&self) -> usize {
        self.pool
            .as_ref()
            .map_or_else(rayon::current_num_threads, |p| p.current_num_threads())
    }

    fn run<R: Send>(&self, f: impl FnOnce() -> R + Send) -> R {
        match &self.pool {
            Some(pool) => pool.install(f),
            None => f(),
        }
    }
}

impl Tracer for CpuTracer<'_> {
    fn trace(&mut self, kind: RayKind, rays: &RayBatch) -> HitBatch {
        let bvh = self.bvh;
        if kind.is_occlusion() {
            self.run(|| any_hits(bvh, rays))
        } else {
            self.run(|| closest_hits(bvh, rays))
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
