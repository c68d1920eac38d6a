//! What speed costs in accuracy, measured on one scene (`cobalt tradeoff`): each BVH build
//! preset's build time and SAH cost against its trace throughput ([`presets`]), and each AO
//! sample count's image error against a high-sample reference, against render time
//! ([`ao_samples`]).

use std::time::Instant;

use serde::Serialize;

use crate::bvh::{BuildPreset, Bvh};
use crate::camera::Camera;
use crate::scene::Scene;
use crate::shade::{AoSettings, CpuTracer, RenderOptions, Shader, render};
use crate::traverse::{any_hits, closest_hits};
use crate::workload;

/// One BVH preset: what its build cost and what its tree traces.
#[derive(Debug, Serialize)]
pub struct PresetRecord {
    /// The preset's name.
    pub preset: &'static str,
    /// Seconds obvhs took to build the tree.
    pub build_seconds: f64,
    /// The tree's SAH cost.
    pub sah_cost: f64,
    /// Its nodes.
    pub nodes: usize,
    /// Closest hits of the primary rays, in millions of rays per second.
    pub primary_mrays_per_s: f64,
    /// Any hits of the AO probes, in millions of rays per second.
    pub ao_mrays_per_s: f64,
}

/// One AO sample count against the reference.
#[derive(Debug, Serialize)]
pub struct SampleRecord {
    /// AO probes per primary hit.
    pub samples: u32,
    /// Rays the render traced.
    pub rays: usize,
    /// Wall time of the whole AO render.
    pub seconds: f64,
    /// Root mean square difference of the AO value (0..1) from the reference, over pixels.
    pub rmse: f64,
    /// Largest per-pixel difference.
    pub max_error: f64,
    /// Reference render time over this one.
    pub speedup: f64,
}

/// Each of `presets` built for `scene` and timed, best of two, on the same rays: the primary
/// rays of the four orbit cameras at `width × height` (closest hit) and 32 AO probes per
/// primary hit of orbit camera `camera` (any hit).
pub fn presets(
    scene: &Scene,
    (width, height): (u32, u32),
    camera: usize,
    presets: &[BuildPreset],
) -> crate::Result<Vec<PresetRecord>> {
    let mut records = Vec::new();
    let primary = workload::orbit_primary(scene, width, height, 0..4);
    for &preset in presets {
        let bvh = Bvh::build(scene, preset)?;
        let ao = workload::orbit_ao(scene, &bvh, width, height, camera, 32);
        let mrays = |n: usize, f: &dyn Fn()| {
            // Best of two: the first run also warms caches.
            let mut best = f64::MAX;
            for _ in 0..2 {
                let t = Instant::now();
                f();
                best = best.min(t.elapsed().as_secs_f64());
            }
            n as f64 / best / 1e6
        };
        records.push(PresetRecord {
            preset: bvh.report().preset.name(),
            build_seconds: bvh.report().build_seconds,
            sah_cost: bvh.report().sah_cost,
            nodes: bvh.report().nodes,
            primary_mrays_per_s: mrays(primary.len(), &|| {
                closest_hits(&bvh, &primary);
            }),
            ao_mrays_per_s: mrays(ao.rays.len(), &|| {
                any_hits(&bvh, &ao.rays);
            }),
        });
    }
    Ok(records)
}

/// The AO image of orbit camera `camera` at `width × height` with each of `counts` samples,
/// against one of `reference` samples with its own Halton scrambling seed (so that the
/// reference's noise is independent of the estimate's): the reference's render seconds, and
/// one record per count.
pub fn ao_samples(
    scene: &Scene,
    (width, height): (u32, u32),
    camera: usize,
    counts: &[u32],
    reference: u32,
) -> crate::Result<(f64, Vec<SampleRecord>)> {
    let bvh = Bvh::build(scene, BuildPreset::Medium)?;
    let cam = Camera::orbit(&scene.bounds(), camera);
    let ao_render = |samples: u32, seed: u64| {
        let shader = Shader::Ao(AoSettings {
            samples,
            seed,
            ..Default::default()
        });
        render(
            scene,
            &mut CpuTracer::new(&bvh),
            &RenderOptions::new(width, height, cam, shader),
        )
    };
    let reference = ao_render(reference, 0x5EED);
    let mut records = Vec::new();
    for &samples in counts {
        let r = ao_render(samples, 0);
        let (mut sq, mut max) = (0f64, 0f64);
        for (a, b) in r.film.pixels().iter().zip(reference.film.pixels()) {
            let d = f64::from((a.x - b.x).abs());
            sq += d * d;
            max = max.max(d);
        }
        records.push(SampleRecord {
            samples,
            rays: r.total_rays(),
            seconds: r.seconds,
            rmse: (sq / r.film.pixels().len().max(1) as f64).sqrt(),
            max_error: max,
            speedup: reference.seconds / r.seconds.max(1e-12),
        });
    }
    Ok((reference.seconds, records))
}
