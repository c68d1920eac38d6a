//! The yardstick: obvhs's own 8-wide compressed BVH (`CwBvh`) and its traversal, over the
//! same triangles, with obvhs's (Möller–Trumbore, not watertight) triangle test. The
//! `raytrace` bench traces the same rays through it and through [`Bvh`](crate::Bvh), so the
//! throughput ratio is measured in one run.

use glam::Vec3A;
use obvhs::cwbvh::{CwBvh, builder::build_cwbvh_from_tris};
use obvhs::ray::RayHit;
use obvhs::triangle::Triangle;
use rayon::prelude::*;

use crate::bvh::preset::BuildPreset;
use crate::{HitBatch, RayBatch, Scene};

/// Rays per rayon work item, as in [`crate::traverse`].
const CHUNK: usize = 256;

/// obvhs's CwBvh over a scene (degenerate triangles included: they never hit).
pub struct CwBvhBaseline {
    cw: CwBvh,
    tris: Vec<Triangle>,
    /// Seconds the CwBvh build took.
    pub build_seconds: f64,
}

impl CwBvhBaseline {
    /// Builds with the obvhs parameters of `preset`, the same ones [`crate::Bvh::build`] uses.
    pub fn build(scene: &Scene, preset: BuildPreset) -> Self {
        let tris: Vec<Triangle> = (0..scene.len())
            .map(|i| {
                let [a, b, c] = scene.vertices(i).map(Vec3A::from);
                Triangle {
                    v0: a,
                    v1: b,
                    v2: c,
                }
            })
            .collect();
        let start = std::time::Instant::now();
        let mut core = std::time::Duration::ZERO;
        let cw = build_cwbvh_from_tris(&tris, preset.params(), &mut core);
        Self {
            cw,
            tris,
            build_seconds: start.elapsed().as_secs_f64(),
        }
    }

    fn ray(rays: &RayBatch, i: usize) -> obvhs::ray::Ray {
        let r = rays.get(i);
        obvhs::ray::Ray::new(r.origin.into(), r.dir.into(), r.tmin, r.tmax)
    }

    /// Closest hits of all rays, in parallel; `prim` is the scene's primitive id.
    pub fn closest_hits(&self, rays: &RayBatch) -> HitBatch {
        let mut out = HitBatch::misses(rays.len());
        out.t
            .par_chunks_mut(CHUNK)
            .zip(out.prim.par_chunks_mut(CHUNK))
            .enumerate()
            .for_each(|(c, (ts, ps))| {
                for (k, (t, p)) in ts.iter_mut().zip(ps.iter_mut()).enumerate() {
                    let mut hit = RayHit::none();
                    let cw = &self.cw;
                    if cw.ray_traverse(Self::ray(rays, c * CHUNK + k), &mut hit, |ray, id| {
                        self.tris[cw.primitive_indices[id] as usize].intersect(ray)
                    }) {
                        *t = hit.t;
                        *p = cw.primitive_indices[hit.primitive_id as usize];
                    }
                }
            });
        out
    }

    /// Whether each ray hits anything (early exit), in parallel.
    pub fn occluded(&self, rays: &RayBatch) -> Vec<bool> {
        (0..rays.len())
            .into_par_iter()
            .with_min_len(CHUNK)
            .map(|i| {
                let cw = &self.cw;
                !cw.ray_traverse_miss(Self::ray(rays, i), |ray, id| {
                    self.tris[cw.primitive_indices[id] as usize].intersect(ray)
                })
            })
            .collect()
    }
}
