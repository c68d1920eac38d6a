//! Generations: each batch of rays handed to the [`Tracer`] at once, timed and recorded, so a
//! report can give rays and MRays/s per generation (and a scheduler can later cut each one
//! into tasks).

use std::time::Instant;

use super::Tracer;
use crate::RayKind;
use crate::{HitBatch, RayBatch};

/// One traced generation.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Generation {
    /// What the rays were for.
    pub kind: RayKind,
    /// Reflection depth the rays belong to: 0 for primary rays and their shadow rays, `k` for
    /// the `k`-th mirror bounce and its shadow rays (AO probes count as 1).
    pub bounce: u32,
    /// Rays traced.
    pub rays: usize,
    /// Wall time of the trace alone (no ray generation or shading).
    pub seconds: f64,
}

impl Generation {
    /// Millions of rays per second of trace time.
    pub fn mrays_per_s(&self) -> f64 {
        self.rays as f64 / self.seconds.max(1e-12) / 1e6
    }
}

/// Drives a tracer generation by generation and keeps the log. Empty batches are not traced
/// and leave no record: a scene models only what it needs.
pub(crate) struct Generations<'t, T: Tracer + ?Sized> {
    tracer: &'t mut T,
    pub(crate) log: Vec<Generation>,
}

impl<'t, T: Tracer + ?Sized> Generations<'t, T> {
    pub(crate) fn new(tracer: &'t mut T) -> Self {
        Self {
            tracer,
            log: Vec::new(),
        }
    }

    /// Traces `rays`, ray `i` of the path at `path_of(i)` (see [`Tracer::trace_paths`]).
    pub(crate) fn trace(
        &mut self,
        kind: RayKind,
        bounce: u32,
        rays: &RayBatch,
        path_of: &dyn Fn(usize) -> u32,
    ) -> HitBatch {
        if rays.is_empty() {
            return HitBatch::default();
        }
        let start = Instant::now();
        let hits = self.tracer.trace_paths(kind, rays, path_of);
        let seconds = start.elapsed().as_secs_f64();
        debug_assert_eq!(hits.len(), rays.len(), "a tracer broke its contract");
        self.log.push(Generation {
            kind,
            bounce,
            rays: rays.len(),
            seconds,
        });
        hits
    }
}
