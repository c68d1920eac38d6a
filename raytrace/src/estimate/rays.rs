//! The rays an estimate is judged on ([`Generations`]): one generation of camera or AO rays,
//! every generation of a Whitted render, or rays given.

use crate::bvh::Bvh;
use crate::camera::Camera;
use crate::ray::{RayBatch, RayKind};
use crate::scene::Scene;
use crate::shade::{CpuTracer, Recorder, RenderOptions, Shader, WhittedSettings, render};
use crate::traverse;

/// Seed of the AO rays' per-pixel scrambling: fixed, so runs are comparable.
const AO_SEED: u64 = 1;

/// The rays of one run, one segment per generation: tasks never straddle two generations, and
/// each is traced with its own query (closest or any hit).
pub struct Generations {
    /// Each generation's rays and their kind.
    pub segments: Vec<(RayBatch, RayKind)>,
    /// The rays' kind as the report names it (`whitted` for a Whitted render's generations).
    pub kind_name: &'static str,
    /// Whether the rays are coherent.
    pub coherent: bool,
}

impl Generations {
    /// `samples` AO rays per camera ray's hit, each `distance` × the scene's bounding-box
    /// diagonal long.
    pub fn ao(
        (scene, bvh): (&Scene, &Bvh),
        camera: &Camera,
        (width, height): (u32, u32),
        samples: u32,
        distance: f32,
    ) -> Self {
        let primary = camera.primary_rays(width, height).rays;
        let hits = traverse::closest_hits(bvh, &primary);
        let length = distance * scene.bounds().extent().length();
        let ao = crate::ao::ao_rays(scene, &primary, &hits, samples, length, AO_SEED);
        Self::of(ao.rays, RayKind::Ao)
    }

    /// Every generation of a Whitted render: primary, shadow and reflection rays.
    pub fn whitted((scene, bvh): (&Scene, &Bvh), camera: Camera, width: u32, height: u32) -> Self {
        let mut rec = Recorder::new(CpuTracer::new(bvh));
        let shader = Shader::Whitted(WhittedSettings::default());
        render(
            scene,
            &mut rec,
            &RenderOptions::new(width, height, camera, shader),
        );
        Self {
            segments: rec.generations.into_iter().map(|(k, r)| (r, k)).collect(),
            kind_name: "whitted",
            coherent: true,
        }
    }

    /// Rays given (a ray file), all of `kind`.
    pub fn of(rays: RayBatch, kind: RayKind) -> Self {
        Self {
            segments: vec![(rays, kind)],
            kind_name: kind.name(),
            coherent: kind.is_coherent(),
        }
    }
}
