//! The thesis's ray workloads, built the same way for benches, `cobalt` reports and tests:
//! primary rays of the four orbit cameras ([`Camera::orbit`], Morton order), and
//! ambient-occlusion rays from the hits of one of them (Halton order).

use crate::traverse::batch::closest_hits;
use crate::{Bvh, Camera, RayBatch, Scene, ao};

/// The default AO ray length: 5 % of the scene's bounding-box diagonal.
pub fn ao_radius(scene: &Scene) -> f32 {
    0.05 * scene.bounds().extent().length()
}

/// Primary rays of `width x height` pixels for each camera in `cameras` (indices of
/// [`Camera::orbit`]), one camera after another, each in Morton order.
pub fn orbit_primary(
    scene: &Scene,
    width: u32,
    height: u32,
    cameras: impl IntoIterator<Item = usize>,
) -> RayBatch {
    let bounds = scene.bounds();
    let mut out = RayBatch::default();
    for cam in cameras {
        let p = Camera::orbit(&bounds, cam).primary_rays(width, height);
        out.extend(&p.rays);
    }
    out
}

/// `samples` AO rays per primary hit of orbit camera `camera` at `width x height`, with the
/// default length ([`ao_radius`]).
pub fn orbit_ao(
    scene: &Scene,
    bvh: &Bvh,
    width: u32,
    height: u32,
    camera: usize,
    samples: u32,
) -> ao::AoRays {
    let primary = Camera::orbit(&scene.bounds(), camera).primary_rays(width, height);
    let hits = closest_hits(bvh, &primary.rays);
    ao::ao_rays(scene, &primary.rays, &hits, samples, ao_radius(scene), 1)
}
